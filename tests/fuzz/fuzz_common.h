/*
 * Shared helpers of the libFuzzer harnesses: a byte reader that never fails (missing bytes read as 0),
 * scalar decoders that reach non-finite and extreme values, and the invariant check.
 *
 * The harnesses are plain C99 with one entry point, LLVMFuzzerTestOneInput. They build two ways:
 * with clang -fsanitize=fuzzer,address,undefined (tools/fuzz.sh, build/fuzz) and, in the host
 * presets, with the project's compiler and warnings against replay_main.c, which runs the committed
 * corpus as a ctest (regression inputs included).
 */
#ifndef CAEKF_FUZZ_COMMON_H
#define CAEKF_FUZZ_COMMON_H

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "caekf/caekf.h"
#include "caekf_fixture_settings.h" /* generated: the reference scenario's values and the presets */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* A violated invariant is a finding: report where and abort, which libFuzzer records as a crash. */
#define FZ_CHECK(cond, what)                                                                                \
    do {                                                                                                    \
        if (!(cond)) {                                                                                      \
            fprintf(stderr, "FUZZ INVARIANT VIOLATED %s:%d: %s [%s]\n", __FILE__, __LINE__, (what), #cond); \
            abort();                                                                                        \
        }                                                                                                   \
    } while (0)

typedef struct {
    const uint8_t *p;
    size_t n;
} fz_reader_t;

static inline int fz_more(const fz_reader_t *r) { return r->n > 0u; }

static inline uint8_t fz_u8(fz_reader_t *r)
{
    if (r->n == 0u) {
        return 0u;
    }
    r->n--;
    return *r->p++;
}

static inline uint16_t fz_u16(fz_reader_t *r)
{
    uint16_t lo = fz_u8(r);
    return (uint16_t)(lo | ((uint16_t)fz_u8(r) << 8));
}

static inline uint32_t fz_u32(fz_reader_t *r)
{
    uint32_t lo = fz_u16(r);
    return lo | ((uint32_t)fz_u16(r) << 16);
}

static inline uint64_t fz_u64(fz_reader_t *r)
{
    uint64_t lo = fz_u32(r);
    return lo | ((uint64_t)fz_u32(r) << 32);
}

static inline double fz_bits_to_double(uint64_t bits)
{
    double d;
    memcpy(&d, &bits, sizeof d);
    return d;
}

static inline double fz_bits_to_float(uint32_t bits)
{
    float f;
    memcpy(&f, &bits, sizeof f);
    return (double)f;
}

/* Values that break things: signed zeros, infinities, NaN, the ends of both formats, subnormals. */
static inline double fz_special(uint8_t i)
{
    // clang-format off
    static const double table[] = {0.0,     -0.0,     1.0,      -1.0,    HUGE_VAL, -HUGE_VAL, 0.0 /* NaN */,
                                   DBL_MAX, -DBL_MAX, DBL_MIN,  4.9e-324, (double)FLT_MAX, -(double)FLT_MAX, (double)FLT_MIN,
                                   1.4e-45, 1e-300,   1e300,    1e-30,   1e30,     3.4e39,   1e-39,
                                   0.5,     2.0,      1e-12,    1e12,    -1e-12,   1e-7,     1e7};
    // clang-format on
    const unsigned n = (unsigned)(sizeof table / sizeof table[0]);
    if (i % n == 6u) {
        return NAN;
    }
    return table[i % n];
}

/* A scalar around `nominal`: mostly near it (so that the estimator runs), sometimes scaled by powers of
 * ten, negated, or replaced by a special value or raw IEEE bits. */
static inline double fz_scalar(fz_reader_t *r, double nominal)
{
    const uint8_t c = fz_u8(r);
    switch (c & 7u) {
    case 0: return fz_special(fz_u8(r));
    case 1: return fz_bits_to_double(fz_u64(r));
    case 2: return fz_bits_to_float(fz_u32(r));
    case 3: { /* nominal * 10^(e/4), e in -128..127: 1e-32 .. 1e32 times nominal */
        const int e = (int)(int8_t)fz_u8(r);
        const double v = nominal * pow(10.0, (double)e / 4.0);
        return (c & 0x80u) ? -v : v;
    }
    default: { /* nominal * (1 + d), |d| < 1/2 */
        const int d = (int)(int16_t)fz_u16(r);
        return nominal * (1.0 + (double)d / 65536.0);
    }
    }
}

static inline int fz_is_finite_scalar(caekf_scalar_t x) { return isfinite(x) != 0; }

/* The reference scenario's settings (sim/scenarios/paper.toml) with one of the schema's presets applied
 * (index into caekf_fixture_presets: 0 canonical, 1 switched, 2 switched-highq, 3 switched-highq-
 * constrained; any other value: none, the recommended defaults). Both come from the fixture the build
 * generates from the schema and the scenario (caekf_fixture_settings.h), like the unit tests'. */
static inline void fz_paper_settings(caekf_settings_t *s, int preset)
{
    unsigned i;
    (void)caekf_settings_default(s);
    for (i = 0; i < CAEKF_N_PAPER_PARAMS; ++i) {
        (void)caekf_settings_set(s, caekf_paper_params[i].id, caekf_paper_params[i].value, NULL);
    }
    for (i = 0; preset >= 0 && preset < (int)CAEKF_N_FIXTURE_PRESETS && i < caekf_fixture_presets[preset].n; ++i) {
        (void)caekf_settings_set(s, caekf_fixture_presets[preset].id[i], caekf_fixture_presets[preset].value[i], NULL);
    }
}

/* ---- snapshot states ------------------------------------------------------------------------------ */

#define FZ_SNAPSHOTS 4

/* Snapshot k (any value: taken modulo FZ_SNAPSHOTS) of preset p's estimator, made on first use: each
 * preset's estimator driven by the reference input u(t) and, as measurements, its own positions one step
 * ahead (x + dt v), so it follows its model into and out of contact. Kept at 5 s (free motion), 12.9 s and
 * 14 s (the first contact's onset and middle; the reference truth closes the gap near 12.8 s) and 17.4 s
 * (just after it opens). */
static inline const caekf_t *fz_snapshot(unsigned p, unsigned k)
{
    static const double at[FZ_SNAPSHOTS] = {5.0, 12.9, 14.0, 17.4};
    static caekf_t snaps[CAEKF_N_FIXTURE_PRESETS][FZ_SNAPSHOTS];
    static int made;
    unsigned i, j;
    for (i = 0; !made && i < CAEKF_N_FIXTURE_PRESETS; ++i) {
        caekf_settings_t st;
        caekf_t e;
        long step = 0;
        fz_paper_settings(&st, (int)i);
        FZ_CHECK(caekf_init(&e, &st) == CAEKF_OK, "snapshot: paper settings accepted");
        for (j = 0; j < FZ_SNAPSHOTS; ++j) {
            const long until = (long)(at[j] / CAEKF_PAPER_DT + 0.5);
            for (; step < until; ++step) {
                const double t = (double)(step + 1) * CAEKF_PAPER_DT;
                caekf_scalar_t x[CAEKF_N], y[CAEKF_MAX_SENSORS];
                caekf_report_t rep;
                const caekf_scalar_t u =
                    (caekf_scalar_t)(CAEKF_PAPER_U_AMP *
                                     sin(2.0 * 3.14159265358979323846 * CAEKF_PAPER_U_FREQ * t + CAEKF_PAPER_U_PHASE));
                (void)caekf_get_state(&e, x);
                y[0] = x[0] + (caekf_scalar_t)CAEKF_PAPER_DT * x[e.model.nq];
                y[1] = x[3] + (caekf_scalar_t)CAEKF_PAPER_DT * x[e.model.nq + 3];
                (void)caekf_step(&e, &u, y, &rep);
            }
            snaps[i][j] = e;
        }
    }
    made = 1;
    return &snaps[p % CAEKF_N_FIXTURE_PRESETS][k % FZ_SNAPSHOTS];
}

#endif /* CAEKF_FUZZ_COMMON_H */
