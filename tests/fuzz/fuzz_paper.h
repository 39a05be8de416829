/* The reference scenario's settings (sim/scenarios/paper.toml), for the harnesses' starting points.
 * A copy on purpose: the fuzz build has no scenario parser, and the seeds stay meaningful if the
 * scenario is retuned. */
#ifndef CAEKF_FUZZ_PAPER_H
#define CAEKF_FUZZ_PAPER_H

#include "caekf/caekf.h"

static inline void fz_paper_settings(caekf_settings_t *s, int experiment)
{
    int i;
    (void)caekf_settings_default(s);
    for (i = 0; i < CAEKF_NQ; ++i) {
        s->model.m[i] = (caekf_scalar_t)1.0;
    }
    s->model.k1 = (caekf_scalar_t)2.0e3;
    s->model.k12 = (caekf_scalar_t)1.0e4;
    s->model.k34 = (caekf_scalar_t)1.0e4;
    s->model.k4 = (caekf_scalar_t)1.0e4;
    s->model.c1 = (caekf_scalar_t)5.0;
    s->model.c12 = (caekf_scalar_t)5.0;
    s->model.c34 = (caekf_scalar_t)5.0;
    s->model.c4 = (caekf_scalar_t)5.0;
    s->model.gap = (caekf_scalar_t)1.0e-3;
    s->model.dt = (caekf_scalar_t)1.0e-3;
    s->gamma0 = (caekf_scalar_t)7.5e7;
    s->sigma_q0 = (caekf_scalar_t)1.0e-6;
    s->sigma_v0 = (caekf_scalar_t)1.0e-5;
    s->sigma_gamma0 = (caekf_scalar_t)2.5e7;
    s->sigma_qx_q = (caekf_scalar_t)1.0e-9;
    s->sigma_qx_v = (caekf_scalar_t)1.0e-7;
    s->sigma_q_gamma = (caekf_scalar_t)1.0e6;
    s->sigma_r = (caekf_scalar_t)1.0e-7;
    s->gamma_min = (caekf_scalar_t)1.0e6;
    s->mode = (experiment == 0) ? CAEKF_MODE_CANONICAL : CAEKF_MODE_SWITCHED;
    s->q_gamma_scale = (caekf_scalar_t)((experiment >= 2) ? 1000 : 1);
    s->constraint_enabled = (experiment == 3) ? 1 : 0;
    if (experiment == 0) {
        s->gamma_gate_nis = 0; /* Table 1 as published; the others keep the default gate */
    }
}

#endif /* CAEKF_FUZZ_PAPER_H */
