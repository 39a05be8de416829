/* The estimator: init, one step (Table 1 with the switch-off of Sec. 3.2 and the constraint of
 * Sec. 3.3), and the accessors that translate the scaled internal state into physical units. */
#include "caekf/caekf.h"

#include "caekf_filter.h"
#include "caekf_model_internal.h"
#include "caekf_linalg.h"
#include "caekf_math.h"

#define NQ CAEKF_NQ
#define N CAEKF_N
#define IG CAEKF_IG
#define INIT_MAGIC 0xCAEF0001u

CAEKF_STATIC_ASSERT(IG == N - 1, gamma_is_last);
CAEKF_STATIC_ASSERT(NQ == 4, scale_fv_is_written_for_4_q_columns);
CAEKF_STATIC_ASSERT(CAEKF_NEWTON_MAX_ITER >= 1 && CAEKF_NEWTON_MAX_ITER <= 100, newton_bound_sane);

static caekf_scalar_t sq(caekf_scalar_t x) { return x * x; }

/* F in scaled coordinates, S^-1 F S: column j of the v-rows times s_j / s_v, which is exactly 1 for
 * the v-columns (so those are left alone) and one ratio for all q-columns. */
static void scale_fv(caekf_scalar_t fv[NQ][N], const caekf_scalar_t s[N])
{
    const caekf_scalar_t rq = s[0] / s[NQ], rg = s[IG] / s[NQ];
    int i;
    for (i = 0; i < NQ; ++i) {
        caekf_scalar_t *f = fv[i];
        f[0] *= rq;
        f[1] *= rq;
        f[2] *= rq;
        f[3] *= rq;
        f[IG] *= rg;
    }
}

/* The contact-free F is a constant: scaled once and kept in fv until a contact step overwrites it. */
static void load_fv0(caekf_t *est)
{
    int i, j;
    for (i = 0; i < NQ; ++i) {
        for (j = 0; j < N; ++j) {
            est->fv[i][j] = est->model.fv0[i][j];
        }
    }
    scale_fv(est->fv, est->scale);
    est->fv_const = 1;
}

caekf_status_t caekf_init(caekf_t *est, const caekf_settings_t *s)
{
    int i, j;
    if (est == 0 || s == 0) {
        return CAEKF_ERR_NULL;
    }
    /* Validation covers everything caekf_model_init checks, so nothing below can fail half-way. */
    if (caekf_settings_validate(s, 0) != CAEKF_OK) {
        return CAEKF_ERR_SETTINGS;
    }
    est->cfg = *s;
    (void)caekf_model_init(&est->model, &s->model);
    for (i = 0; i < NQ; ++i) {
        est->scale[i] = s->sigma_q0;
        est->scale[NQ + i] = s->sigma_v0;
        est->z[i] = s->q0[i] / s->sigma_q0;
        est->z[NQ + i] = s->v0[i] / s->sigma_v0;
        /* Ratios before squaring: float would underflow on (1e-9)^2 / (1e-6)^2 done the other way. */
        est->q_diag[i] = sq(s->sigma_qx_q / s->sigma_q0);
        est->q_diag[NQ + i] = sq(s->sigma_qx_v / s->sigma_v0);
    }
    est->scale[IG] = s->sigma_gamma0[0];
    est->z[IG] = s->gamma0[0] / s->sigma_gamma0[0];
    est->q_diag[IG] = s->q_gamma_scale * sq(s->sigma_q_gamma[0] / s->sigma_gamma0[0]);
    est->r_scaled = sq(s->sigma_r / s->sigma_q0);
    est->gamma_min_scaled = s->gamma_min[0] / s->sigma_gamma0[0];
    for (i = 0; i < N; ++i) { /* P0 = diag(sigma0^2) is the identity in scaled coordinates */
        for (j = 0; j < N; ++j) {
            est->P[i][j] = (i == j) ? 1 : 0;
            est->P_work[i][j] = 0;
            est->scratch[i][j] = 0;
        }
        est->x_prev[i] = 0;
        est->x_pred[i] = 0;
    }
    load_fv0(est);
    est->step_count = 0;
    est->last_flags = 0;
    est->init_magic = INIT_MAGIC;
    return CAEKF_OK;
}

static int is_init(const caekf_t *est) { return est != 0 && est->init_magic == INIT_MAGIC; }

static caekf_gamma_policy_t gamma_policy(const caekf_settings_t *cfg, int contact_active)
{
    if (cfg->mode == CAEKF_MODE_CANONICAL || contact_active) {
        return CAEKF_GAMMA_LIVE;
    }
    return cfg->switchoff == CAEKF_SWITCHOFF_PAPER ? CAEKF_GAMMA_FROZEN_PAPER : CAEKF_GAMMA_FROZEN_SCHMIDT;
}

/* One step: prediction, then (with y) the correction and the constraint. y == NULL: no measurement
 * (caekf_predict), which caekf_step (measured == 1) refuses as a caller error. */
static caekf_status_t advance(caekf_t *est, caekf_scalar_t u, const caekf_scalar_t *y, int measured,
                              caekf_report_t *report)
{
    caekf_scalar_t *xprev, *z; /* z reuses x_pred once F is formed */
    caekf_scalar_t y_s[CAEKF_NY];
    caekf_contact_t contact;
    caekf_gamma_policy_t policy;
    caekf_status_t st = CAEKF_OK;
    uint32_t flags = 0;
    int iters = 0;
    int i, finite;
    const caekf_scalar_t *s;
    caekf_scalar_t s_q, s_v, nf, nis = 0;

    if (report != 0) {
        report->flags = 0;
        report->newton_iters = 0;
        report->delta = 0;
        report->nis = 0;
    }
    if (est == 0 || (measured && y == 0)) {
        return CAEKF_ERR_NULL;
    }
    if (!is_init(est)) {
        return CAEKF_ERR_NOT_INIT;
    }
    if (!CAEKF_ISFINITE(u) || (y != 0 && (!CAEKF_ISFINITE(y[0]) || !CAEKF_ISFINITE(y[1])))) {
        if (report != 0) {
            report->flags = CAEKF_FLAG_INPUT_REJECTED;
        }
        return CAEKF_ERR_INPUT; /* nothing in *est has been written */
    }
    s = est->scale;
    s_q = s[0];
    s_v = s[NQ];
    xprev = est->x_prev;
    z = est->x_pred;

    /* Prediction (Table 1): Newton solve of eq. (19), then F by eq. (10) at x_k-. */
    for (i = 0; i < N; ++i) {
        xprev[i] = est->z[i] * s[i];
    }
    if (caekf_model_newton(&est->model, xprev, u, est->cfg.newton_max_iter, est->cfg.newton_rtol, est->x_pred,
                           &iters) != 0) {
        flags |= CAEKF_FLAG_NEWTON_NOT_CONVERGED;
    }
    caekf_model_contact(&est->model, est->x_pred, est->x_pred[IG], &contact);
    if (contact.delta > 0) { /* eq. (21) */
        flags |= CAEKF_FLAG_CONTACT_ACTIVE;
    }
    policy = gamma_policy(&est->cfg, contact.delta > 0);
    if (policy != CAEKF_GAMMA_LIVE) {
        flags |= CAEKF_FLAG_GAMMA_FROZEN;
    }
    if (contact.delta > 0) {
        est->fv_const = 0;
        if (caekf_model_transition_v(&est->model, est->x_pred, est->fv) != 0) {
            flags |= CAEKF_FLAG_NEWTON_NOT_CONVERGED | CAEKF_FLAG_NUMERIC_ROLLBACK;
            st = CAEKF_ERR_SINGULAR;
            goto done;
        }
        scale_fv(est->fv, s);
    } else if (!est->fv_const) {
        load_fv0(est);
    }
    for (i = 0; i < IG; ++i) {
        z[i] = est->x_pred[i] / s[i];
    }
    z[IG] = est->z[IG]; /* exact: the random walk carries gamma over bit for bit */
    /* From here on P_work holds the upper triangle only; the commit mirrors it. */
    caekf_predict_covariance(est->P, est->P_work, est->fv, est->model.p.dt * s_v / s_q, est->q_diag, policy,
                             contact.delta > 0);

    if (y != 0) {
        /* Correction, eqs. (13)-(15) / (25)-(27). */
        y_s[0] = y[0] / s_q;
        y_s[1] = y[1] / s_q;
        (void)caekf_correct_upper(z, est->P_work, y_s, est->r_scaled, est->cfg.cov_update == CAEKF_COV_JOSEPH,
                                  policy, est->cfg.gamma_gate_nis, &nis, &flags);
        /* Inequality constraint, eqs. (28)-(30). */
        if (est->cfg.constraint_enabled) {
            caekf_constrain_upper(z, est->P_work, est->gamma_min_scaled, s[IG], est->cfg.gamma_min[0], &flags);
        }
    } else {
        flags |= CAEKF_FLAG_NO_MEASUREMENT; /* prediction only: gamma cannot move */
    }
    finite = caekf_covariance_health(est->P_work, (est->step_count % (uint32_t)est->cfg.psd_check_period) == 0,
                                     est->cfg.cov_repair_enabled, est->scratch, &flags);
    nf = 0; /* v * 0 is 0 for finite v, NaN otherwise */
    for (i = 0; i < N; ++i) {
        nf += z[i] * 0;
    }
    if (!finite || !(nf == 0)) {
        flags |= CAEKF_FLAG_NUMERIC_ROLLBACK;
        st = CAEKF_ERR_NUMERIC;
        goto done;
    }
    for (i = 0; i < N; ++i) { /* commit, filling the lower triangle */
        const caekf_scalar_t *w = &est->P_work[i][i];
        caekf_scalar_t *row = &est->P[i][i], *col = row, *const end = est->P[i] + N;
        est->z[i] = z[i];
        *row = *w;
        while (++row != end) {
            col += N;
            *row = *++w;
            *col = *w;
        }
    }
    est->step_count++;
    est->last_flags = flags;
done:
    if (report != 0) {
        report->flags = flags;
        report->newton_iters = iters;
        report->delta = contact.delta;
        report->nis = nis;
    }
    return st;
}

caekf_status_t caekf_step(caekf_t *est, caekf_scalar_t u, const caekf_scalar_t y[CAEKF_NY], caekf_report_t *report)
{
    return advance(est, u, y, 1, report);
}

caekf_status_t caekf_predict(caekf_t *est, caekf_scalar_t u, caekf_report_t *report)
{
    return advance(est, u, 0, 0, report);
}

caekf_status_t caekf_get_state(const caekf_t *est, caekf_scalar_t x[CAEKF_N])
{
    int i;
    if (est == 0 || x == 0) {
        return CAEKF_ERR_NULL;
    }
    if (!is_init(est)) {
        return CAEKF_ERR_NOT_INIT;
    }
    for (i = 0; i < N; ++i) {
        x[i] = est->z[i] * est->scale[i];
    }
    return CAEKF_OK;
}

caekf_status_t caekf_get_gamma(const caekf_t *est, caekf_scalar_t *gamma)
{
    if (est == 0 || gamma == 0) {
        return CAEKF_ERR_NULL;
    }
    if (!is_init(est)) {
        return CAEKF_ERR_NOT_INIT;
    }
    *gamma = est->z[IG] * est->scale[IG];
    return CAEKF_OK;
}

caekf_status_t caekf_get_covariance(const caekf_t *est, caekf_scalar_t P[CAEKF_N][CAEKF_N])
{
    int i, j;
    if (est == 0 || P == 0) {
        return CAEKF_ERR_NULL;
    }
    if (!is_init(est)) {
        return CAEKF_ERR_NOT_INIT;
    }
    for (i = 0; i < N; ++i) {
        for (j = 0; j < N; ++j) {
            P[i][j] = est->P[i][j] * est->scale[i] * est->scale[j];
        }
    }
    return CAEKF_OK;
}

caekf_status_t caekf_get_cov_norm2(caekf_t *est, caekf_scalar_t *norm2)
{
    caekf_status_t st;
    if (est == 0 || norm2 == 0) {
        return CAEKF_ERR_NULL;
    }
    /* P_work is free between steps: it takes the physical P while scratch is the eigen workspace. */
    st = caekf_get_covariance(est, est->P_work);
    if (st != CAEKF_OK) {
        return st;
    }
    return caekf_sym_norm2(&est->P_work[0][0], N, &est->scratch[0][0], norm2) == CAEKF_LA_OK ? CAEKF_OK
                                                                                       : CAEKF_ERR_NUMERIC;
}

const char *caekf_status_str(caekf_status_t st)
{
    switch (st) {
    case CAEKF_OK: return "ok";
    case CAEKF_ERR_NULL: return "null pointer";
    case CAEKF_ERR_SETTINGS: return "settings refused";
    case CAEKF_ERR_NOT_INIT: return "not initialised";
    case CAEKF_ERR_INPUT: return "non-finite input rejected";
    case CAEKF_ERR_NUMERIC: return "non-finite result, rolled back";
    case CAEKF_ERR_SINGULAR: return "singular matrix, rolled back";
    default: return "unknown status";
    }
}

const char *caekf_flag_name(unsigned bit_index)
{
    static const char *const names[CAEKF_FLAG_COUNT] = {
        "newton_not_converged", "input_rejected",       "constraint_applied", "contact_active",
        "cov_repaired",         "singular_innovation",  "constraint_clamped", "numeric_rollback",
        "gamma_frozen",         "cov_indefinite",       "no_measurement",     "gamma_gated"};
    return bit_index < CAEKF_FLAG_COUNT ? names[bit_index] : "unknown";
}
