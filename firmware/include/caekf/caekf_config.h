/*
 * caekf compile-time options. Every option a build may set is documented here, in one place.
 *
 *   CAEKF_USE_FLOAT          0 (default): caekf_scalar_t is double. 1: float (Cortex-M4F class).
 *   CAEKF_NEWTON_MAX_ITER    hard upper bound on Newton iterations per step (default 20). The run-time
 *                            setting `newton_max_iter` may only lower it.
 *   CAEKF_JACOBI_MAX_SWEEPS  bound on cyclic Jacobi sweeps used by the eigen routines (P norm and
 *                            covariance repair; default 12, 9x9 converges in about 6).
 *
 * Dimensions are fixed by the model (4 bodies on a line, one contact parameter, two position sensors)
 * and checked with static asserts; they are not options.
 */
#ifndef CAEKF_CONFIG_H
#define CAEKF_CONFIG_H

#include <float.h>

#ifndef CAEKF_USE_FLOAT
#define CAEKF_USE_FLOAT 0
#endif

#ifndef CAEKF_NEWTON_MAX_ITER
#define CAEKF_NEWTON_MAX_ITER 20
#endif

#ifndef CAEKF_JACOBI_MAX_SWEEPS
#define CAEKF_JACOBI_MAX_SWEEPS 12
#endif

#if CAEKF_USE_FLOAT
typedef float caekf_scalar_t;
#define CAEKF_EPS FLT_EPSILON
#define CAEKF_TINY 1e-30f /* off-diagonal covariances below this are flushed to 0 (no subnormals) */
#define CAEKF_SCALAR_NAME "float"
#else
typedef double caekf_scalar_t;
#define CAEKF_EPS DBL_EPSILON
#define CAEKF_TINY 1e-290
#define CAEKF_SCALAR_NAME "double"
#endif

/* Model dimensions. */
#define CAEKF_NQ 4                        /* bodies (positions) */
#define CAEKF_NX (2 * CAEKF_NQ)           /* mechanical state [q; v] */
#define CAEKF_N (CAEKF_NX + 1)            /* augmented state [q; v; gamma] */
#define CAEKF_NY 2                        /* measurements y = [q1, q4] */
#define CAEKF_IG (CAEKF_N - 1)            /* index of gamma in the augmented state */

/* C99 static assert (no _Static_assert before C11). */
#define CAEKF_STATIC_ASSERT(cond, name) typedef char caekf_static_assert_##name[(cond) ? 1 : -1]

#endif /* CAEKF_CONFIG_H */
