#include "experiment.h"

#include <string.h>

static const char *const names[CAEKF_EXP_COUNT] = {"canonical", "switched", "switched-highq",
                                                    "switched-highq-constrained"};

int caekf_experiment_from_name(const char *name)
{
    int i;
    for (i = 0; i < CAEKF_EXP_COUNT; ++i) {
        if (strcmp(name, names[i]) == 0) {
            return i;
        }
    }
    return -1;
}

const char *caekf_experiment_name(caekf_experiment_t e)
{
    return (e >= 0 && e < CAEKF_EXP_COUNT) ? names[e] : "unknown";
}

void caekf_experiment_model(const caekf_scenario_t *sc, double dt, caekf_model_params_t *p)
{
    p->m[0] = (caekf_scalar_t)sc->m1;
    p->m[1] = (caekf_scalar_t)sc->m2;
    p->m[2] = (caekf_scalar_t)sc->m3;
    p->m[3] = (caekf_scalar_t)sc->m4;
    p->k1 = (caekf_scalar_t)sc->k1;
    p->k12 = (caekf_scalar_t)sc->k12;
    p->k34 = (caekf_scalar_t)sc->k34;
    p->k4 = (caekf_scalar_t)sc->k4;
    p->c1 = (caekf_scalar_t)sc->c1;
    p->c12 = (caekf_scalar_t)sc->c12;
    p->c34 = (caekf_scalar_t)sc->c34;
    p->c4 = (caekf_scalar_t)sc->c4;
    p->gap = (caekf_scalar_t)sc->gap;
    p->dt = (caekf_scalar_t)dt;
}

caekf_status_t caekf_experiment_settings(const caekf_scenario_t *sc, caekf_experiment_t e, caekf_settings_t *s)
{
    if (e < 0 || e >= CAEKF_EXP_COUNT) {
        return CAEKF_ERR_SETTINGS;
    }
    (void)caekf_settings_default(s);
    caekf_experiment_model(sc, sc->dt, &s->model);
    s->gamma0 = (caekf_scalar_t)sc->gamma0;
    s->sigma_q0 = (caekf_scalar_t)sc->sigma_q0;
    s->sigma_v0 = (caekf_scalar_t)sc->sigma_v0;
    s->sigma_gamma0 = (caekf_scalar_t)sc->sigma_gamma0;
    s->sigma_qx_q = (caekf_scalar_t)sc->sigma_qx_q;
    s->sigma_qx_v = (caekf_scalar_t)sc->sigma_qx_v;
    s->sigma_q_gamma = (caekf_scalar_t)sc->sigma_q_gamma;
    s->sigma_r = (caekf_scalar_t)sc->sigma_r;
    s->gamma_min = (caekf_scalar_t)sc->gamma_min;
    s->mode = (e == CAEKF_EXP_CANONICAL) ? CAEKF_MODE_CANONICAL : CAEKF_MODE_SWITCHED;
    s->q_gamma_scale = (e == CAEKF_EXP_SWITCHED_HIGHQ || e == CAEKF_EXP_SWITCHED_HIGHQ_CONSTRAINED) ? 1000 : 1;
    s->constraint_enabled = (e == CAEKF_EXP_SWITCHED_HIGHQ_CONSTRAINED);
    if (e == CAEKF_EXP_CANONICAL) {
        s->gamma_gate_nis = 0; /* Table 1 as the paper has it */
    }
    return caekf_settings_validate(s, 0);
}
