/* Estimator settings by parameter id (CTRL_PARAM and scenario keys) and the four experiments. */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "app_internal.h"

#define DEFAULT_HIGHQ_SCALE 1000.0 /* Sec. 4.2 of the paper multiplies Q_gamma by 1000 */
#define INT_PARAM_LIMIT 1000000.0  /* integer parameters are small: this keeps the cast defined */

caekf_app_status_t caekf_app_settings_default(caekf_app_settings_t *s)
{
    if (s == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    (void)caekf_settings_default(&s->est);
    s->highq_scale = DEFAULT_HIGHQ_SCALE;
    return CAEKF_APP_OK;
}

caekf_app_status_t caekf_app_param_id(const char *name, unsigned *param_id)
{
    unsigned i;
    if (name == NULL || param_id == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    for (i = 0; i < (unsigned)CAEKF_PARAM_COUNT; i++) {
        const char *candidate;
        if (caekf_proto_param_name(i, &candidate) == CAEKF_PROTO_OK && strcmp(candidate, name) == 0) {
            *param_id = i;
            return CAEKF_APP_OK;
        }
    }
    return CAEKF_APP_ERR_PARAM;
}

/* The field a real-valued parameter writes, or NULL for the integer ones and highq_scale. */
static caekf_scalar_t *real_field(caekf_settings_t *s, unsigned id)
{
    caekf_model_params_t *m = &s->model;
    caekf_scalar_t *const fields[CAEKF_PARAM_COUNT] = {
        &m->m[0], &m->m[1], &m->m[2], &m->m[3], &m->k1, &m->k12, &m->k34, &m->k4,
        &m->c1, &m->c12, &m->c34, &m->c4, &m->gap, &m->dt,
        &s->q0[0], &s->q0[1], &s->q0[2], &s->q0[3], &s->v0[0], &s->v0[1], &s->v0[2], &s->v0[3],
        &s->gamma0, &s->sigma_q0, &s->sigma_v0, &s->sigma_gamma0, &s->sigma_qx_q, &s->sigma_qx_v,
        &s->sigma_q_gamma, &s->sigma_r, &s->gamma_min,
        NULL, NULL, NULL, NULL, NULL, /* highq_scale, switchoff, cov_update, cov_repair, newton_max_iter */
        &s->newton_rtol, &s->gamma_gate_nis,
    };
    return fields[id];
}

caekf_app_status_t caekf_app_settings_set(caekf_app_settings_t *s, unsigned param_id, double value)
{
    caekf_scalar_t *field;
    int iv;
    if (s == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    if (param_id >= (unsigned)CAEKF_PARAM_COUNT) {
        return CAEKF_APP_ERR_PARAM;
    }
    field = real_field(&s->est, param_id);
    if (field != NULL) {
        *field = (caekf_scalar_t)value; /* range and finiteness: caekf_settings_validate at commit */
        return CAEKF_APP_OK;
    }
    if (param_id == (unsigned)CAEKF_PARAM_HIGHQ_SCALE) {
        s->highq_scale = value;
        return CAEKF_APP_OK;
    }
    if (!(fabs(value) <= INT_PARAM_LIMIT) || value != floor(value)) {
        return CAEKF_APP_ERR_PARAM;
    }
    iv = (int)value;
    switch (param_id) {
    case CAEKF_PARAM_SWITCHOFF:
        s->est.switchoff = (caekf_switchoff_t)iv;
        break;
    case CAEKF_PARAM_COV_UPDATE:
        s->est.cov_update = (caekf_cov_update_t)iv;
        break;
    case CAEKF_PARAM_COV_REPAIR:
        s->est.cov_repair_enabled = iv;
        break;
    default: /* CAEKF_PARAM_NEWTON_MAX_ITER */
        s->est.newton_max_iter = iv;
        break;
    }
    return CAEKF_APP_OK;
}

caekf_app_status_t caekf_app_experiment_settings(const caekf_app_settings_t *base, unsigned experiment,
                                                 caekf_settings_t *out)
{
    caekf_settings_t s;
    if (base == NULL || out == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    if (experiment >= (unsigned)CAEKF_EXPERIMENT_COUNT) {
        return CAEKF_APP_ERR_EXPERIMENT;
    }
    if (!(base->highq_scale > 0.0) || isinf(base->highq_scale)) {
        return CAEKF_APP_ERR_PARAM;
    }
    s = base->est;
    s.mode = (experiment == CAEKF_EXPERIMENT_CANONICAL) ? CAEKF_MODE_CANONICAL : CAEKF_MODE_SWITCHED;
    s.q_gamma_scale = (experiment >= CAEKF_EXPERIMENT_SWITCHED_HIGHQ) ? (caekf_scalar_t)base->highq_scale
                                                                       : (caekf_scalar_t)1;
    s.constraint_enabled = (experiment == CAEKF_EXPERIMENT_SWITCHED_HIGHQ_CONSTRAINED) ? 1 : 0;
    if (experiment == CAEKF_EXPERIMENT_CANONICAL) {
        s.gamma_gate_nis = 0; /* Table 1 as the paper has it */
    }
    *out = s;
    return CAEKF_APP_OK;
}

/* First non-finite or non-positive entry of an array of 4, as a parameter id. */
static uint8_t first_bad_of4(const caekf_scalar_t *v, unsigned first_id, int must_be_positive)
{
    unsigned i;
    for (i = 0; i < 4u; i++) {
        if (isnan(v[i]) || isinf(v[i]) || (must_be_positive && !(v[i] > 0))) {
            return (uint8_t)(first_id + i);
        }
    }
    return (uint8_t)first_id;
}

uint8_t caekf_app_bad_param(const char *first_bad, const caekf_settings_t *s)
{
    unsigned id;
    if (first_bad == NULL) {
        return (uint8_t)CAEKF_ACK_BAD_PARAM_NONE;
    }
    /* caekf_settings_validate names fields, mostly as the scenario keys; the rest are mapped here. */
    if (strcmp(first_bad, "m") == 0) {
        return first_bad_of4(s->model.m, CAEKF_PARAM_M1, 1);
    }
    if (strcmp(first_bad, "q0") == 0) {
        return first_bad_of4(s->q0, CAEKF_PARAM_Q0_1, 0);
    }
    if (strcmp(first_bad, "v0") == 0) {
        return first_bad_of4(s->v0, CAEKF_PARAM_V0_1, 0);
    }
    if (strcmp(first_bad, "cov_repair_enabled") == 0) {
        return (uint8_t)CAEKF_PARAM_COV_REPAIR;
    }
    if (strcmp(first_bad, "q_gamma_scale") == 0) {
        return (uint8_t)CAEKF_PARAM_HIGHQ_SCALE;
    }
    if (strncmp(first_bad, "gamma0 <", 8) == 0) {
        return (uint8_t)CAEKF_PARAM_GAMMA0;
    }
    if (caekf_app_param_id(first_bad, &id) == CAEKF_APP_OK) {
        return (uint8_t)id;
    }
    return (uint8_t)CAEKF_ACK_BAD_PARAM_NONE;
}
