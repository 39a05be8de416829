#include "test_support.h"

#include <math.h>
#include <string.h>

#include "caekf_fixture_settings.h" /* generated from the schema and sim/scenarios/paper.toml */

#ifndef CAEKF_TRUTH_BIN
#error "CAEKF_TRUTH_BIN (path of the truth record) must be defined by the build"
#endif

void paper_settings(caekf_settings_t *s, int preset)
{
    unsigned i;
    (void)caekf_settings_default(s);
    for (i = 0; i < CAEKF_N_PAPER_PARAMS; ++i) {
        (void)caekf_settings_set(s, caekf_paper_params[i].id, caekf_paper_params[i].value, 0);
    }
    for (i = 0; preset >= 0 && i < caekf_fixture_presets[preset].n; ++i) {
        (void)caekf_settings_set(s, caekf_fixture_presets[preset].id[i], caekf_fixture_presets[preset].value[i], 0);
    }
}

double paper_gamma_true(void) { return CAEKF_PAPER_GAMMA; }
double paper_gamma_min(void) { return CAEKF_PAPER_GAMMA_MIN; }
long paper_steps(void) { return (long)(CAEKF_PAPER_T_END / CAEKF_PAPER_DT + 0.5); }

int truth_open(void) { return test_file_open(CAEKF_TRUTH_BIN); }

int truth_next(truth_rec_t *r)
{
    double rec[13];
    long n = test_file_read(rec, sizeof rec);
    int i;
    if (n == 0) {
        return 0;
    }
    if (n != (long)sizeof rec) {
        return -1;
    }
    r->t = rec[0];
    r->u = rec[1];
    r->y1 = rec[2];
    r->y4 = rec[3];
    for (i = 0; i < 4; ++i) {
        r->q[i] = rec[4 + i];
        r->v[i] = rec[8 + i];
    }
    r->delta = rec[12];
    return 1;
}

void truth_close(void) { test_file_close(); }

long run_paper(caekf_t *est, const caekf_settings_t *s, step_hook_t each, void *ctx)
{
    truth_rec_t r;
    long n = 0;
    int rc;
    if (caekf_init(est, s) != CAEKF_OK || truth_open() != 0) {
        return -1;
    }
    while ((rc = truth_next(&r)) == 1) {
        caekf_scalar_t y[2];
        caekf_report_t rep;
        caekf_status_t st;
        y[0] = (caekf_scalar_t)r.y1;
        y[1] = (caekf_scalar_t)r.y4;
        st = caekf_step(est, (const caekf_scalar_t[]){(caekf_scalar_t)r.u}, y, &rep);
        if (each != 0) {
            each(est, &rep, st, &r, ctx);
        }
        n++;
    }
    truth_close();
    return rc < 0 ? -1 : n;
}

void test_spd_matrix(paper_mat_t P)
{
    double L[PAPER_N][PAPER_N];
    int i, j, k;
    for (i = 0; i < PAPER_N; ++i)
        for (j = 0; j < PAPER_N; ++j) L[i][j] = j <= i ? 0.3 + 0.1 * ((i * 7 + j * 3) % 5) - (i == j ? 0 : 0.2) : 0;
    for (i = 0; i < PAPER_N; ++i)
        for (j = 0; j < PAPER_N; ++j) {
            double s = (i == j) ? 0.05 : 0;
            for (k = 0; k < PAPER_N; ++k) s += L[i][k] * L[j][k];
            P[i][j] = (caekf_scalar_t)s;
        }
}

double test_fd_column_error(const caekf_scalar_t *a, const caekf_scalar_t *b, int nq, double span,
                            const caekf_scalar_t *col, int ld, double scale)
{
    double big = 0, worst = 0;
    int i;
    for (i = 0; i < nq; ++i) {
        const double fd = ((double)a[nq + i] - (double)b[nq + i]) / span;
        big = fmax(big, fabs(fd));
        worst = fmax(worst, fabs(fd - scale * (double)col[i * ld]));
    }
    return big > 0 ? worst / big : -1;
}

double test_eq10_error(caekf_scalar_t Jk[CAEKF_N][CAEKF_N], caekf_scalar_t Jp[CAEKF_N][CAEKF_N],
                       caekf_scalar_t F[CAEKF_N][CAEKF_N], int n)
{
    static double A[CAEKF_N * CAEKF_N], Ai[CAEKF_N * CAEKF_N]; /* off the small MCU stacks */
    double worst = 0;
    int i, j, k;
    for (i = 0; i < n; ++i) {
        for (j = 0; j < n; ++j) {
            A[i * n + j] = (double)Jk[i][j];
        }
    }
    if (test_invert(A, Ai, n) != 0) {
        return -1;
    }
    for (i = 0; i < n; ++i) {
        double ref[CAEKF_N], rowmax = 0;
        for (j = 0; j < n; ++j) {
            double s = 0;
            for (k = 0; k < n; ++k) {
                s += Ai[i * n + k] * (double)Jp[k][j];
            }
            ref[j] = -s; /* eq. (10) */
            rowmax = fmax(rowmax, fabs(ref[j]));
        }
        for (j = 0; j < n; ++j) {
            worst = fmax(worst, fabs((double)F[i][j] - ref[j]) / (rowmax + 1e-300));
        }
    }
    return worst;
}

int test_invert(double *a, double *inv, int n)
{
    int i, j, k;
    for (i = 0; i < n; ++i) {
        for (j = 0; j < n; ++j) {
            inv[i * n + j] = (i == j);
        }
    }
    for (k = 0; k < n; ++k) {
        int p = k;
        double piv;
        for (i = k + 1; i < n; ++i) {
            if (fabs(a[i * n + k]) > fabs(a[p * n + k])) p = i;
        }
        for (j = 0; j < n; ++j) {
            double t = a[k * n + j];
            a[k * n + j] = a[p * n + j];
            a[p * n + j] = t;
            t = inv[k * n + j];
            inv[k * n + j] = inv[p * n + j];
            inv[p * n + j] = t;
        }
        piv = a[k * n + k];
        if (!(fabs(piv) > 0)) {
            return -1;
        }
        for (j = 0; j < n; ++j) {
            a[k * n + j] /= piv;
            inv[k * n + j] /= piv;
        }
        for (i = 0; i < n; ++i) {
            double f = a[i * n + k];
            if (i == k) continue;
            for (j = 0; j < n; ++j) {
                a[i * n + j] -= f * a[k * n + j];
                inv[i * n + j] -= f * inv[k * n + j];
            }
        }
    }
    return 0;
}

void paper_moving_state(caekf_scalar_t x[CAEKF_N], double gap, double delta, double gamma)
{
    const double q3 = 1.5e-5;
    int i;
    for (i = 0; i < CAEKF_N; ++i) {
        x[i] = 0;
    }
    x[0] = (caekf_scalar_t)1.2e-3;
    x[1] = (caekf_scalar_t)(q3 + gap + delta);
    x[2] = (caekf_scalar_t)q3;
    x[3] = (caekf_scalar_t)-4e-6;
    x[4] = (caekf_scalar_t)3e-3;
    x[5] = (caekf_scalar_t)-2e-3;
    x[6] = (caekf_scalar_t)1e-3;
    x[7] = (caekf_scalar_t)-5e-4;
    x[8] = (caekf_scalar_t)gamma;
}

void test_fill_stack(unsigned char byte)
{
    volatile unsigned char area[8192];
    unsigned i;
    for (i = 0; i < sizeof area; i++) {
        area[i] = byte;
    }
}
