/* Settings: defaults and validation. Init refuses anything this rejects, leaving the estimator as it was. */
#include "caekf/caekf.h"

#include <stddef.h>

#include "caekf_math.h"

caekf_status_t caekf_settings_default(caekf_settings_t *s)
{
    unsigned char *bytes = (unsigned char *)s;
    size_t i;
    if (s == 0) {
        return CAEKF_ERR_NULL;
    }
    for (i = 0; i < sizeof *s; ++i) { /* all-bits zero: 0, 0.0 and the first enumerators */
        bytes[i] = 0;
    }
    s->q_gamma_scale = 1;
    s->mode = CAEKF_MODE_SWITCHED;
    s->switchoff = CAEKF_SWITCHOFF_CONSISTENT;
    s->cov_update = CAEKF_COV_STANDARD;
    s->constraint_enabled = 0;
    s->cov_repair_enabled = 1;
    s->psd_check_period = 16; /* the per-step screen catches |corr| > 1 at once */
    s->newton_max_iter = CAEKF_NEWTON_MAX_ITER;
    /* Residual rounding scales with eps times the row's terms; 256 leaves room for the sums. */
    s->newton_rtol = CAEKF_EPS * 256;
    return CAEKF_OK;
}

/* Scalar checks in order, the first failing one is reported: kind 0 finite, 1 finite and >= 0,
 * 2 finite and > 0. A table keeps this small on the MCU. */
static const struct {
    unsigned short off;
    unsigned char kind;
    const char *name;
} scalar_fields[] = {
    {offsetof(caekf_settings_t, gamma0), 0, "gamma0"},
    {offsetof(caekf_settings_t, sigma_q0), 2, "sigma_q0"},
    {offsetof(caekf_settings_t, sigma_v0), 2, "sigma_v0"},
    {offsetof(caekf_settings_t, sigma_gamma0), 2, "sigma_gamma0"},
    {offsetof(caekf_settings_t, sigma_qx_q), 1, "sigma_qx_q"},
    {offsetof(caekf_settings_t, sigma_qx_v), 1, "sigma_qx_v"},
    {offsetof(caekf_settings_t, sigma_q_gamma), 1, "sigma_q_gamma"},
    {offsetof(caekf_settings_t, q_gamma_scale), 1, "q_gamma_scale"},
    {offsetof(caekf_settings_t, sigma_r), 2, "sigma_r"},
};

static const char *scalar_bad(const caekf_settings_t *s)
{
    unsigned i;
    for (i = 0; i < sizeof scalar_fields / sizeof scalar_fields[0]; ++i) {
        caekf_scalar_t x = *(const caekf_scalar_t *)(const void *)((const char *)s + scalar_fields[i].off);
        if (!CAEKF_ISFINITE(x) || !(scalar_fields[i].kind == 0 || x > 0 || (scalar_fields[i].kind == 1 && x == 0))) {
            return scalar_fields[i].name;
        }
    }
    return 0;
}

/* 1 when num/den (squared if `square`, times `factor`) is finite, and > 0 if `positive`. One
 * out-of-line helper keeps the many checks below small in flash. */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
static int ratio_ok(caekf_scalar_t num, caekf_scalar_t den, caekf_scalar_t factor, int square, int positive)
{
    caekf_scalar_t r = num / den;
    if (square) {
        r *= r;
    }
    r *= factor;
    return CAEKF_ISFINITE(r) && (!positive || r > 0);
}

/* Values caekf_init derives must be usable in this scalar type too: finite settings can still
 * overflow or underflow once scaled (found by fuzzing: sigma_q0 = 1e-22 with sigma_qx_q = 1e22 in
 * float, subnormal sigmas in double). */
static const char *derived_bad(const caekf_settings_t *s)
{
    const caekf_model_params_t *m = &s->model;
    int i;
    for (i = 0; i < CAEKF_NQ; ++i) {
        if (!ratio_ok(s->q0[i], s->sigma_q0, 1, 0, 0)) return "q0";
        if (!ratio_ok(s->v0[i], s->sigma_v0, 1, 0, 0)) return "v0";
        if (!ratio_ok(m->m[i], m->dt, 1, 0, 1)) return "m";
    }
    if (!ratio_ok(m->k1 + m->k12 + m->k34 + m->k4, 1, m->dt, 0, 1)) return "dt";
    if (!ratio_ok(s->gamma0, s->sigma_gamma0, 1, 0, 0)) return "gamma0";
    if (!ratio_ok(s->gamma_min, s->sigma_gamma0, 1, 0, 0)) return "gamma_min";
    if (!ratio_ok(s->sigma_qx_q, s->sigma_q0, 1, 1, 0)) return "sigma_qx_q";
    if (!ratio_ok(s->sigma_qx_v, s->sigma_v0, 1, 1, 0)) return "sigma_qx_v";
    if (!ratio_ok(s->sigma_q_gamma, s->sigma_gamma0, s->q_gamma_scale, 1, 0)) return "sigma_q_gamma";
    if (!ratio_ok(s->sigma_r, s->sigma_q0, 1, 1, 1)) return "sigma_r";
    /* The scaled transition S^-1 F S multiplies by these ratios. */
    if (!ratio_ok(s->sigma_q0, s->sigma_v0, 1, 0, 1) || !ratio_ok(s->sigma_v0, s->sigma_q0, m->dt, 0, 1) ||
        !ratio_ok(s->sigma_gamma0, s->sigma_v0, 1, 0, 1)) {
        return "sigma_v0";
    }
    return 0;
}

caekf_status_t caekf_settings_validate(const caekf_settings_t *s, const char **first_bad)
{
    const char *bad = 0;
    int i;
    if (s == 0) {
        return CAEKF_ERR_NULL;
    }
    (void)caekf_model_params_check(&s->model, &bad);
    for (i = 0; i < CAEKF_NQ && bad == 0; ++i) {
        if (!CAEKF_ISFINITE(s->q0[i])) bad = "q0";
        if (!CAEKF_ISFINITE(s->v0[i])) bad = "v0";
    }
    if (bad == 0) {
        bad = scalar_bad(s);
    }
    if (bad == 0) {
        if (s->mode != CAEKF_MODE_CANONICAL && s->mode != CAEKF_MODE_SWITCHED) bad = "mode";
        else if (s->switchoff != CAEKF_SWITCHOFF_CONSISTENT && s->switchoff != CAEKF_SWITCHOFF_PAPER) bad = "switchoff";
        else if (s->cov_update != CAEKF_COV_STANDARD && s->cov_update != CAEKF_COV_JOSEPH) bad = "cov_update";
        else if (s->constraint_enabled != 0 && s->constraint_enabled != 1) bad = "constraint_enabled";
        else if (s->cov_repair_enabled != 0 && s->cov_repair_enabled != 1) bad = "cov_repair_enabled";
        else if (s->psd_check_period < 1 || s->psd_check_period > 1000) bad = "psd_check_period";
        else if (!CAEKF_ISFINITE(s->gamma_min)) bad = "gamma_min";
        else if (s->constraint_enabled && s->gamma0 < s->gamma_min) bad = "gamma0 < gamma_min";
        else if (s->newton_max_iter < 1 || s->newton_max_iter > CAEKF_NEWTON_MAX_ITER) bad = "newton_max_iter";
        else if (!CAEKF_ISFINITE(s->newton_rtol) || !(s->newton_rtol > 0) || s->newton_rtol >= 1) bad = "newton_rtol";
    }
    if (bad == 0) {
        bad = derived_bad(s);
    }
    if (first_bad != 0) {
        *first_bad = bad;
    }
    return bad == 0 ? CAEKF_OK : CAEKF_ERR_SETTINGS;
}
