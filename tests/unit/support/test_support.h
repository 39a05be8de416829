/* Shared test fixtures: the reference scenario's settings and its truth record. */
#ifndef CAEKF_TEST_SUPPORT_H
#define CAEKF_TEST_SUPPORT_H

#include "caekf/caekf.h"

#include "caekf_fixture_settings.h"

/* The schema's presets (the paper's experiments), by their index in caekf_fixture_presets. */
enum {
    EXP_CANONICAL = CAEKF_FIXTURE_PRESET_CANONICAL,
    EXP_SWITCHED = CAEKF_FIXTURE_PRESET_SWITCHED,
    EXP_SWITCHED_HIGHQ = CAEKF_FIXTURE_PRESET_SWITCHED_HIGHQ,
    EXP_SWITCHED_HIGHQ_CONSTRAINED = CAEKF_FIXTURE_PRESET_SWITCHED_HIGHQ_CONSTRAINED
};

typedef struct {
    double t, u, y1, y4;
    double q[4], v[4];
    double delta;
} truth_rec_t;

/* The reference scenario's settings with a preset applied (-1: none, the recommended defaults). */
void paper_settings(caekf_settings_t *s, int preset);
double paper_gamma_true(void);
double paper_gamma_min(void);
long paper_steps(void);

/* The truth record produced by caekf-truth (little-endian float64, 13 per sample). */
int truth_open(void);                /* 0 on success */
int truth_next(truth_rec_t *r);      /* 1 sample, 0 end, -1 error */
void truth_close(void);

/* Platform file access used by truth_*: stdio on the host, semihosting on the MCU targets. */
int test_file_open(const char *path);
long test_file_read(void *buf, unsigned long n);
void test_file_close(void);

/* A deterministic SPD matrix L L^T + small diagonal, with every entry correlated (filter-level tests). */
void test_spd_matrix(caekf_scalar_t P[CAEKF_N][CAEKF_N]);

/* Runs `experiment` over the whole truth, calling `each` after every step (may be NULL). Returns the
 * number of steps, or -1 when the truth cannot be read. */
typedef void (*step_hook_t)(const caekf_t *est, const caekf_report_t *rep, caekf_status_t st,
                            const truth_rec_t *truth, void *ctx);
long run_paper(caekf_t *est, const caekf_settings_t *s, step_hook_t each, void *ctx);

#endif
