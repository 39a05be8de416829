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
int truth_open(void);           /* 0 on success */
int truth_next(truth_rec_t *r); /* 1 sample, 0 end, -1 error */
void truth_close(void);

/* Platform file access used by truth_*: stdio on the host, semihosting on the MCU targets. */
int test_file_open(const char *path);
long test_file_read(void *buf, unsigned long n);
void test_file_close(void);

/* The paper's mechanism in the estimator's state, whatever the build's capacity: 4 bodies, one contact
 * (n = 9 states, gamma last), sensors on q1 and q4. */
#define PAPER_NQ 4
#define PAPER_N 9
#define PAPER_IG 8
#define PAPER_IY1 0
#define PAPER_IY4 3
typedef caekf_scalar_t paper_mat_t[PAPER_N][PAPER_N];
/* Entry (i, j) of an estimator's scaled covariance (n x n, leading dimension n). */
#define EST_P(est, i, j) ((est)->P[(i) * (est)->model.n + (j)])

#ifdef CAEKF_FILTER_H
/* Filter dimensions of the paper's mechanism, for the tests of caekf_filter.h's steps (only they
 * include that internal header). */
static inline void paper_filter_dims(caekf_filter_dims_t *d, caekf_scalar_t r, caekf_gamma_policy_t policy)
{
    d->nq = PAPER_NQ;
    d->n = PAPER_N;
    d->ny = 2;
    d->rows = 0;
    d->h[0] = PAPER_IY1;
    d->h[1] = PAPER_IY4;
    d->r[0] = r;
    d->r[1] = r;
    d->policy[0] = (uint8_t)policy;
}
#endif

/* A deterministic SPD matrix L L^T + small diagonal, with every entry correlated (filter-level tests). */
void test_spd_matrix(paper_mat_t P);

/* A state of the paper's chain in motion: bodies 2 and 3 at penetration `delta` beyond `gap` (<= 0: open),
 * gamma `gamma` in state 8, every other entry up to CAEKF_N zero. The model and contact-law suites' point. */
void paper_moving_state(caekf_scalar_t x[CAEKF_N], double gap, double delta, double gamma);

/* Fills the stack below the caller with `byte` (0xFF: a NaN in either scalar type), so that the next call's
 * locals that are read before they are written hold it rather than what an earlier call left (often zeros):
 * such a read then shows. A call into this separate object: never inlined into the caller's frame. */
void test_fill_stack(unsigned char byte);

/* Gauss-Jordan inverse with partial pivoting in double, written independently of the library's LU, for
 * reference computations: a (n x n, row-major, destroyed) -> inv. Returns 0, or -1 on a zero pivot. */
int test_invert(double *a, double *inv, int n);

/* Eq. (10) as the reference for a structured F: the largest |F_ij - ref_ij| / max_j |ref_ij| over the rows,
 * ref = -(Jk)^-1 Jp computed in double by test_invert (n x n in arrays of the capacity); -1 when Jk is
 * singular. */
double test_eq10_error(caekf_scalar_t Jk[CAEKF_N][CAEKF_N], caekf_scalar_t Jp[CAEKF_N][CAEKF_N],
                       caekf_scalar_t F[CAEKF_N][CAEKF_N], int n);

/* A column of the step's map against central differences of the step: the largest |fd_i - scale col[i ld]| over
 * the nq velocities, fd = (a - b) / span taken from states a and b (their v at nq..), relative to the largest
 * |fd_i|; -1 when every fd_i is 0 (the difference says nothing). */
double test_fd_column_error(const caekf_scalar_t *a, const caekf_scalar_t *b, int nq, double span,
                            const caekf_scalar_t *col, int ld, double scale);

/* Runs `experiment` over the whole truth, calling `each` after every step (may be NULL). Returns the
 * number of steps, or -1 when the truth cannot be read. */
typedef void (*step_hook_t)(const caekf_t *est, const caekf_report_t *rep, caekf_status_t st, const truth_rec_t *truth,
                            void *ctx);
long run_paper(caekf_t *est, const caekf_settings_t *s, step_hook_t each, void *ctx);

#endif
