/* Settings: defaults and validation. Init refuses anything this rejects, leaving the estimator as it was. */
#include "caekf/caekf.h"

#include "caekf_math.h"

caekf_status_t caekf_settings_default(caekf_settings_t *s)
{
    static const caekf_settings_t zero_settings; /* const: no mutable global */
    if (s == 0) {
        return CAEKF_ERR_NULL;
    }
    *s = zero_settings;
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

static int finite_nonneg(caekf_scalar_t x) { return CAEKF_ISFINITE(x) && x >= 0; }
static int finite_pos(caekf_scalar_t x) { return CAEKF_ISFINITE(x) && x > 0; }

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
        if (!CAEKF_ISFINITE(s->gamma0)) bad = "gamma0";
        else if (!finite_pos(s->sigma_q0)) bad = "sigma_q0";
        else if (!finite_pos(s->sigma_v0)) bad = "sigma_v0";
        else if (!finite_pos(s->sigma_gamma0)) bad = "sigma_gamma0";
        else if (!finite_nonneg(s->sigma_qx_q)) bad = "sigma_qx_q";
        else if (!finite_nonneg(s->sigma_qx_v)) bad = "sigma_qx_v";
        else if (!finite_nonneg(s->sigma_q_gamma)) bad = "sigma_q_gamma";
        else if (!finite_nonneg(s->q_gamma_scale)) bad = "q_gamma_scale";
        else if (!finite_pos(s->sigma_r)) bad = "sigma_r";
        else if (s->mode != CAEKF_MODE_CANONICAL && s->mode != CAEKF_MODE_SWITCHED) bad = "mode";
        else if (s->switchoff != CAEKF_SWITCHOFF_CONSISTENT && s->switchoff != CAEKF_SWITCHOFF_PAPER) bad = "switchoff";
        else if (s->cov_update != CAEKF_COV_STANDARD && s->cov_update != CAEKF_COV_JOSEPH) bad = "cov_update";
        else if (s->constraint_enabled != 0 && s->constraint_enabled != 1) bad = "constraint_enabled";
        else if (s->cov_repair_enabled != 0 && s->cov_repair_enabled != 1) bad = "cov_repair_enabled";
        else if (s->psd_check_period < 1 || s->psd_check_period > 1000) bad = "psd_check_period";
        else if (!CAEKF_ISFINITE(s->gamma_min)) bad = "gamma_min";
        else if (s->constraint_enabled && s->gamma0 < s->gamma_min) bad = "gamma0 < gamma_min";
        else if (s->newton_max_iter < 1 || s->newton_max_iter > CAEKF_NEWTON_MAX_ITER) bad = "newton_max_iter";
        else if (!finite_pos(s->newton_rtol) || s->newton_rtol >= 1) bad = "newton_rtol";
    }
    if (first_bad != 0) {
        *first_bad = bad;
    }
    return bad == 0 ? CAEKF_OK : CAEKF_ERR_SETTINGS;
}
