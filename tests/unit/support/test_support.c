#include "test_support.h"

#include <string.h>

#include "paper_scenario.h" /* generated from sim/scenarios/paper.toml: PAPER_<key> */

#ifndef CAEKF_TRUTH_BIN
#error "CAEKF_TRUTH_BIN (path of the truth record) must be defined by the build"
#endif

void paper_settings(caekf_settings_t *s, int experiment)
{
    (void)caekf_settings_default(s);
    s->model.m[0] = (caekf_scalar_t)PAPER_m1;
    s->model.m[1] = (caekf_scalar_t)PAPER_m2;
    s->model.m[2] = (caekf_scalar_t)PAPER_m3;
    s->model.m[3] = (caekf_scalar_t)PAPER_m4;
    s->model.k1 = (caekf_scalar_t)PAPER_k1;
    s->model.k12 = (caekf_scalar_t)PAPER_k12;
    s->model.k34 = (caekf_scalar_t)PAPER_k34;
    s->model.k4 = (caekf_scalar_t)PAPER_k4;
    s->model.c1 = (caekf_scalar_t)PAPER_c1;
    s->model.c12 = (caekf_scalar_t)PAPER_c12;
    s->model.c34 = (caekf_scalar_t)PAPER_c34;
    s->model.c4 = (caekf_scalar_t)PAPER_c4;
    s->model.gap = (caekf_scalar_t)PAPER_gap;
    s->model.dt = (caekf_scalar_t)PAPER_dt;
    s->gamma0 = (caekf_scalar_t)PAPER_gamma0;
    s->sigma_q0 = (caekf_scalar_t)PAPER_sigma_q0;
    s->sigma_v0 = (caekf_scalar_t)PAPER_sigma_v0;
    s->sigma_gamma0 = (caekf_scalar_t)PAPER_sigma_gamma0;
    s->sigma_qx_q = (caekf_scalar_t)PAPER_sigma_qx_q;
    s->sigma_qx_v = (caekf_scalar_t)PAPER_sigma_qx_v;
    s->sigma_q_gamma = (caekf_scalar_t)PAPER_sigma_q_gamma;
    s->sigma_r = (caekf_scalar_t)PAPER_sigma_r;
    s->gamma_min = (caekf_scalar_t)PAPER_gamma_min;
    s->mode = experiment == EXP_CANONICAL ? CAEKF_MODE_CANONICAL : CAEKF_MODE_SWITCHED;
    s->q_gamma_scale = (experiment >= EXP_SWITCHED_HIGHQ) ? 1000 : 1;
    s->constraint_enabled = experiment == EXP_SWITCHED_HIGHQ_CONSTRAINED;
    if (experiment == EXP_CANONICAL) {
        s->gamma_gate_nis = 0; /* Table 1 as published */
    }
}

double paper_gamma_true(void) { return PAPER_gamma; }
double paper_gamma_min(void) { return PAPER_gamma_min; }
long paper_steps(void) { return (long)(PAPER_t_end / PAPER_dt + 0.5); }

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
        st = caekf_step(est, (caekf_scalar_t)r.u, y, &rep);
        if (each != 0) {
            each(est, &rep, st, &r, ctx);
        }
        n++;
    }
    truth_close();
    return rc < 0 ? -1 : n;
}

void test_spd_matrix(caekf_scalar_t P[CAEKF_N][CAEKF_N])
{
    double L[CAEKF_N][CAEKF_N];
    int i, j, k;
    for (i = 0; i < CAEKF_N; ++i)
        for (j = 0; j < CAEKF_N; ++j) L[i][j] = j <= i ? 0.3 + 0.1 * ((i * 7 + j * 3) % 5) - (i == j ? 0 : 0.2) : 0;
    for (i = 0; i < CAEKF_N; ++i)
        for (j = 0; j < CAEKF_N; ++j) {
            double s = (i == j) ? 0.05 : 0;
            for (k = 0; k < CAEKF_N; ++k) s += L[i][k] * L[j][k];
            P[i][j] = (caekf_scalar_t)s;
        }
}
