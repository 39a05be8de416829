/* Scalar helpers matching caekf_scalar_t (float or double), so core code never names sqrt/sqrtf. */
#ifndef CAEKF_MATH_H
#define CAEKF_MATH_H

#include <math.h>

#include "caekf/caekf_config.h"

#if CAEKF_USE_FLOAT
#define CAEKF_SQRT(x) sqrtf(x)
#define CAEKF_FABS(x) fabsf(x)
#define CAEKF_HYPOT(x, y) hypotf((x), (y))
#define CAEKF_POW(x, y) powf((x), (y))
#define CAEKF_LOG(x) logf(x)
#define CAEKF_EXP(x) expf(x)
#define CAEKF_ERFC(x) erfcf(x)
#define CAEKF_C(x) ((caekf_scalar_t)(x##f))
#else
#define CAEKF_SQRT(x) sqrt(x)
#define CAEKF_FABS(x) fabs(x)
#define CAEKF_HYPOT(x, y) hypot((x), (y))
#define CAEKF_POW(x, y) pow((x), (y))
#define CAEKF_LOG(x) log(x)
#define CAEKF_EXP(x) exp(x)
#define CAEKF_ERFC(x) erfc(x)
#define CAEKF_C(x) ((caekf_scalar_t)(x))
#endif /* CAEKF_USE_FLOAT */

/* CAEKF_HOT_INLINE: a small helper on the step's hot path, inlined even at -Os (a call costs more than its
 * body). CAEKF_NOINLINE keeps a function out of line: its frame then adds to the stack only while it runs. */
#if defined(__GNUC__)
#define CAEKF_HOT_INLINE static inline __attribute__((always_inline))
#define CAEKF_NOINLINE __attribute__((noinline))
#else
#define CAEKF_HOT_INLINE static inline
#define CAEKF_NOINLINE
#endif /* __GNUC__ */

/* Before a loop whose bound is a size: a sized build knows it, and the loop is then written out even at
 * -Os (no library call for a fill, operands held in registers). CAEKF_UNROLL_DOT, before a dot product's
 * loop: written out where the build knows n, else four terms a turn (the same order). */
#if CAEKF_SIZED && defined(__GNUC__) && !defined(__clang__)
#define CAEKF_UNROLL_SIZED _Pragma("GCC unroll 32")
#define CAEKF_UNROLL_DOT _Pragma("GCC unroll 32")
#elif defined(__GNUC__) && !defined(__clang__)
#define CAEKF_UNROLL_SIZED
#define CAEKF_UNROLL_DOT _Pragma("GCC unroll 4")
#else
#define CAEKF_UNROLL_SIZED
#define CAEKF_UNROLL_DOT
#endif /* CAEKF_SIZED && defined(__GNUC__) && !defined(__clang__) */

/* isfinite() is type-generic in C99. */
#define CAEKF_ISFINITE(x) (isfinite(x) != 0)

static inline caekf_scalar_t caekf_max(caekf_scalar_t a, caekf_scalar_t b) { return a > b ? a : b; }
static inline caekf_scalar_t caekf_min(caekf_scalar_t a, caekf_scalar_t b) { return a < b ? a : b; }

#endif /* CAEKF_MATH_H */
