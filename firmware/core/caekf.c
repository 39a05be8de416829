/* The estimator: init, one step (Table 1 with the switch-off of Sec. 3.2 and the constraint of
 * Sec. 3.3), and the accessors that translate the scaled internal state into physical units. */
#include "caekf/caekf.h"

#include <stddef.h>

#include "caekf_filter.h"
#include "caekf_model_internal.h"
#include "caekf_linalg.h"
#include "caekf_math.h"

#define INIT_MAGIC 0xCAEF0001u

CAEKF_STATIC_ASSERT(CAEKF_NEWTON_MAX_ITER >= 1 && CAEKF_NEWTON_MAX_ITER <= 100, newton_bound_sane);
CAEKF_STATIC_ASSERT(CAEKF_N <= 255, state_indices_fit_a_byte);
CAEKF_STATIC_ASSERT(CAEKF_N *CAEKF_N >= 2 * CAEKF_NQ * CAEKF_N && CAEKF_N * CAEKF_N >= 4 * CAEKF_NQ,
                    scratch_holds_the_newton_and_substep_work);
CAEKF_STATIC_ASSERT(CAEKF_N *CAEKF_N >= CAEKF_N + 2 * CAEKF_MAX_INPUTS, p_work_holds_a_substep_start);
CAEKF_STATIC_ASSERT(CAEKF_GAMMA_LIVE == 0, init_zeroes_the_policies_to_live);
CAEKF_STATIC_ASSERT(offsetof(caekf_t, cfg) == 0, init_zeroes_what_follows_the_settings);

/* The instance's members a build may lack (caekf.h's layout), as caekf_model_internal.h's: the member, or where
 * the layout lacks it a null pointer of its type, named only under if (the switch), which compiles out there. */

/* x_{k-1}, step work: in P_work, which is free until the covariance prediction, when the step has no
 * substeps (they keep their start there); else in the instance. */
#if CAEKF_ONE_STEP_BE
#define X_PREV(est) ((est)->P_work)
#else
#define X_PREV(est) ((est)->x_prev)
#endif /* CAEKF_ONE_STEP_BE */

/* The inputs at the estimate's time (the step's start): the last step's, or u itself until a step or
 * caekf_correct has seen them (the first step holds u over its interval). Only the trapezoidal rule, the
 * substeps and base inputs read them. */
#if CAEKF_KEEPS_U_PREV
#define U_PREV(est, u) ((est)->u_prev_known ? (const caekf_scalar_t *)(est)->u_prev : (u))
#define U_PREV_STORE(est) ((est)->u_prev)
#define U_PREV_KNOWN_STORE(est) (&(est)->u_prev_known)
#else
#define U_PREV(est, u) ((void)(est), (u))
#define U_PREV_STORE(est) ((void)(est), (caekf_scalar_t *)0)
#define U_PREV_KNOWN_STORE(est) ((void)(est), (uint32_t *)0)
#endif /* CAEKF_KEEPS_U_PREV */

/* The substeps' model (at dt / contact_substeps), the q-rows of their F, the contacts at a substep's start and
 * end, and the LU of the Newton matrix at its start (CAEKF_HAS_SUBSTEPS). */
#if CAEKF_HAS_SUBSTEPS
#define SUB_MODEL(est) (&(est)->sub_model)
#define SUB_FQ(est) ((est)->fq)
#define SUB_CT(est, k) ((est)->sub_ct[k])
#define SUB_LU(est) (&(est)->sub_lu)
#else
#define SUB_MODEL(est) ((void)(est), (caekf_model_t *)0)
#define SUB_FQ(est) ((void)(est), (caekf_scalar_t(*)[CAEKF_N])0)
#define SUB_CT(est, k) ((void)(est), (void)(k), (caekf_contact_t *)0)
#define SUB_LU(est) ((void)(est), (caekf_newton_lu_t *)0)
#endif /* CAEKF_HAS_SUBSTEPS */

static caekf_scalar_t sq(caekf_scalar_t x) { return x * x; }

/* F in scaled coordinates, S^-1 F S: column j of the v-rows times s_j / s_v, which is exactly 1 for
 * the v-columns (so those are left alone), one ratio for all q-columns and one per gamma. */
static void scale_fv(caekf_scalar_t fv[CAEKF_NQ][CAEKF_N], const caekf_scalar_t *s, int nq, int n)
{
    const caekf_scalar_t rq = s[0] / s[nq];
    caekf_scalar_t rp[CAEKF_NP_STORE]; /* the parameters' ratios, once for all rows */
    int i, j;
    CAEKF_UNROLL_SIZED
    for (j = 2 * nq; j < n; ++j) {
        rp[j - 2 * nq] = s[j] / s[nq];
    }
    for (i = 0; i < nq; ++i) {
        caekf_scalar_t *f = fv[i];
        CAEKF_UNROLL_SIZED
        for (j = 0; j < nq; ++j) {
            f[j] *= rq;
        }
        CAEKF_UNROLL_SIZED
        for (j = 2 * nq; j < n; ++j) {
            /* cppcheck-suppress uninitvar ; rp is written above for every j of this loop */
            f[j] *= rp[j - 2 * nq];
        }
    }
}

/* The contact-free F is a constant: scaled once and kept in fv until a contact step overwrites it. */
static void load_fv0(caekf_t *est)
{
    const int nq = CAEKF_DIM_NQ(&est->model), n = CAEKF_DIM_N(&est->model);
    caekf_model_free_transition_v(&est->model, est->fv);
    scale_fv(est->fv, est->scale, nq, n);
    caekf_fv_compact(est->fv, nq, n, &est->fv_pattern);
    est->fv_const = 1;
}

/* Parameter k (state 2 nq + k, its initial value already in z) gets the lower bound lo (if has_lo) and
 * the upper bound hi (if has_hi), both in the state's own units (ln gamma for a log gamma). A scaled
 * bound is moved inwards by what its rounding lost, so that a state on it reads back within the bound
 * (found by fuzzing, in float: lo / s underflows to 0, or lo / s * s < lo, and a constrained gamma
 * reported below gamma_min); the initial value, validated within the bounds, is held to them alike. */
static void set_bounds(caekf_t *est, int k, int has_lo, caekf_scalar_t lo, int has_hi, caekf_scalar_t hi)
{
    const int g = 2 * est->model.nq + k;
    const caekf_scalar_t s = est->scale[g];
    int i;
    if (has_lo) {
        caekf_scalar_t b = lo / s;
        for (i = 0; i < 4 && b * s < lo; ++i) { /* one step, rarely two: the division rounds once */
            b += CAEKF_FABS(b) * CAEKF_EPS + CAEKF_TINY;
        }
        est->bound_lo |= 1u << k;
        est->lo_scaled[k] = b;
        est->z[g] = caekf_max(est->z[g], b);
    }
    if (has_hi) {
        caekf_scalar_t b = hi / s;
        for (i = 0; i < 4 && b * s > hi; ++i) {
            b -= CAEKF_FABS(b) * CAEKF_EPS + CAEKF_TINY;
        }
        est->bound_hi |= 1u << k;
        est->hi_scaled[k] = b;
        est->z[g] = est->z[g] > b ? b : est->z[g];
    }
}

/* gamma's bound (gamma_min, or gamma_max with is_max) of contact c in the state's units. */
static caekf_scalar_t gamma_bound(const caekf_settings_t *s, int c, int is_max)
{
    const caekf_scalar_t b = is_max ? s->gamma_max[c] : s->gamma_min[c];
    return CAEKF_PARAMS_GAMMA_LOG(&s->model) ? CAEKF_LOG(b) : b;
}

/* An estimated law parameter at state g: its scale sigma0, initial value, Q and bounds. */
static void init_param(caekf_t *est, int g, caekf_scalar_t x0, caekf_scalar_t sigma0, caekf_scalar_t sigma_q,
                       caekf_scalar_t lo, caekf_scalar_t hi)
{
    est->scale[g] = sigma0;
    est->z[g] = x0 / sigma0;
    est->q_diag[g] = sq(sigma_q / sigma0);
    set_bounds(est, g - 2 * est->model.nq, 1, lo, hi > 0, hi);
}

/* The physical bound (the minimum, or with is_max the maximum) of parameter k, from the settings. */
static caekf_scalar_t bound_of(const caekf_t *est, int k, int is_max)
{
    const caekf_settings_t *s = &est->cfg;
    const int c = est->model.param_contact[k];
    const unsigned char *law = est->model.law_state[c];
    const int g = 2 * est->model.nq + k;
    if (CAEKF_HAS_LAW_PARAMS && k >= est->model.nc) { /* an estimated law parameter's */
        if (law[CAEKF_LAW_N] == g) {
            return is_max ? s->n_max[c] : s->n_min[c];
        }
        if (law[CAEKF_LAW_LAMBDA] == g) {
            return is_max ? s->lambda_max[c] : s->lambda_min[c];
        }
        return is_max ? s->gap_max[c] : s->gap_min[c];
    }
    return gamma_bound(s, c, is_max);
}

/* Inequality constraints, eqs. (28)-(30) over the active set: every parameter outside a bound gets the
 * perfect measurement that puts it on the bound, in order, pass after pass until none is outside. A
 * parameter put on a bound has zero variance and covariance, so later ones cannot move it: each pass
 * that applies one fixes one more, and np passes bound the loop. */
static void apply_bounds(caekf_t *est, caekf_scalar_t *z, uint32_t *flags)
{
    /* the contacts' parameters (the mechanism's have no bounds: their logs keep them positive) */
    const int nx = 2 * CAEKF_DIM_NQ(&est->model), n = CAEKF_DIM_N(&est->model), np = CAEKF_DIM_MECH0(&est->model) - nx;
    const caekf_scalar_t *s = est->scale;
    int pass, k;
    if ((est->bound_lo | est->bound_hi) == 0) {
        return;
    }
    for (pass = 0; pass < np; ++pass) {
        int applied = 0;
        for (k = 0; k < np; ++k) { /* the physical bound (a log for ln gamma) only for a violated one */
            if (((est->bound_lo >> k) & 1u) && z[nx + k] < est->lo_scaled[k]) {
                applied |= caekf_constrain_upper(z, est->P_work, n, nx + k, est->lo_scaled[k], 0, s[nx + k],
                                                 bound_of(est, k, 0), flags);
            }
            if (((est->bound_hi >> k) & 1u) && z[nx + k] > est->hi_scaled[k]) {
                applied |= caekf_constrain_upper(z, est->P_work, n, nx + k, est->hi_scaled[k], 1, s[nx + k],
                                                 bound_of(est, k, 1), flags);
            }
        }
        if (!applied) {
            break;
        }
    }
}

/* The bodies' Q_x (scaled), times the mismatch monitor's factor (1 unless adapted: x * 1 is x). */
static void set_body_q(caekf_t *est)
{
    const caekf_settings_t *s = &est->cfg;
    const caekf_scalar_t f = est->mismatch.q_scale;
    const int nq = CAEKF_DIM_NQ(&est->model);
    int i;
    for (i = 0; i < nq; ++i) {
        /* Ratios before squaring: float would underflow on (1e-9)^2 / (1e-6)^2 done the other way. */
        est->q_diag[i] = sq(s->sigma_qx_q / s->sigma_q0) * f;
        est->q_diag[nq + i] = sq(s->sigma_qx_v / s->sigma_v0) * f;
    }
}

/* The model-mismatch monitor (docs/mismatch.md). A consistent filter's NIS per sensor has mean 1; its
 * exponentially weighted mean over mismatch_window steps stays near 1 (within about 2 / sqrt(window ny)
 * by chance). Each step's NIS is clipped at CAEKF_MISMATCH_NIS_CLIP per sensor so that a few outliers
 * (a contact's first steps) cannot raise the mean alone; innovations that stay large do. Above
 * mismatch_ratio the model does not fit the data. With mismatch_adapt the bodies' Q_x is then scaled
 * by q_scale <- q_scale (1 + (mean - 1) / window) each step, which grows while the innovations are too
 * large and shrinks back to 1 once they are consistent: P then admits the model's error, and the gate
 * lets the contact parameters go. `next` gets the monitor after this step's NIS (corrected: a
 * correction computed one). Returns CAEKF_FLAG_MODEL_MISMATCH or 0. */
#define CAEKF_MISMATCH_NIS_CLIP ((caekf_scalar_t)100)
#define CAEKF_MISMATCH_Q_SCALE_MAX ((caekf_scalar_t)1e12)
static uint32_t mismatch_update(const caekf_t *est, int corrected, caekf_scalar_t nis, caekf_mismatch_t *next)
{
    const caekf_settings_t *cfg = &est->cfg;
    const int ny = cfg->model.sensors;
    *next = est->mismatch;
    if (cfg->mismatch_window <= 0 || ny <= 0) {
        return 0;
    }
    if (corrected) {
        const caekf_scalar_t w = (caekf_scalar_t)cfg->mismatch_window;
        const caekf_scalar_t per_sensor = caekf_min(nis / (caekf_scalar_t)ny, CAEKF_MISMATCH_NIS_CLIP);
        next->nis_mean += (per_sensor - next->nis_mean) / w;
        if (cfg->mismatch_adapt && (next->q_scale > 1 || next->nis_mean > cfg->mismatch_ratio)) {
            next->q_scale *= 1 + (next->nis_mean - 1) / w;
            next->q_scale = caekf_min(caekf_max(next->q_scale, 1), CAEKF_MISMATCH_Q_SCALE_MAX);
        }
    }
    return next->nis_mean > cfg->mismatch_ratio || next->q_scale > 1 ? CAEKF_FLAG_MODEL_MISMATCH : 0u;
}

/* Sensor k's noise std in its own unit (docs/sensors.md): its own, or the position or velocity sensors'. */
static caekf_scalar_t sensor_sigma(const caekf_settings_t *s, int k)
{
    if (s->sensor_sigma[k] > 0) {
        return s->sensor_sigma[k];
    }
    return s->model.sensor_kind[k] == CAEKF_SENSOR_VELOCITY ? s->sigma_rv : s->sigma_r;
}

/* What input k's white noise adds to acceleration sensor i's variance, over the sensor's own (a measured force
 * read through the model's M^-1: on its body for bodies on a line, along h^T M^-1 B_u's column for a structure;
 * a base displacement's white noise e_k through k u_k + c (u_k - u_{k-1}) / dt on its link's body, the std of
 * ((k + c/dt) e_k - c/dt e_{k-1}) / m). */
static caekf_scalar_t input_noise_ratio(const caekf_t *est, const caekf_settings_t *s, int i, int k)
{
    const caekf_model_params_t *mp = &s->model;
    const caekf_model_t *m = &est->model;
    caekf_scalar_t gain = 1;
    int body = mp->input_body[k];
    if (CAEKF_IS_STRUCTURE(m)) {
        int j;
        gain = 0;
        for (j = 0; j < CAEKF_DIM_NQ(m); ++j) {
            gain += CAEKF_STRUCTURE_H(m, i)[j] / CAEKF_STRUCTURE_MASS(m)[j] * CAEKF_STRUCTURE_BU(m, k)[j];
        }
        return sq(gain * s->input_sigma[k] / sensor_sigma(s, i));
    }
    if (CAEKF_BASE_LINK(m, k) != 0) {
        const caekf_scalar_t c_dt = CAEKF_BASE_C(m, k) / mp->dt;
        gain = CAEKF_SQRT(sq(CAEKF_BASE_K(m, k) + c_dt) + sq(c_dt));
        body = m->p.input_body[k];
    }
    if (body != mp->sensor_body[i]) {
        return 0;
    }
    return sq(gain * s->input_sigma[k] / (mp->m[mp->sensor_body[i] - 1] * sensor_sigma(s, i)));
}

/* The parameters' scales, initial values, Q and bounds (init): the contacts' gammas (ln gamma with gamma_log), their
 * estimated law parameters, the mechanism's parameters (ln(value / setting), 0 at first) and the sensors'
 * offsets (0 at first); each a random walk. */
static void init_params(caekf_t *est, const caekf_settings_t *s)
{
    const caekf_model_params_t *mp = &s->model;
    const int nq = est->model.nq, nc = est->model.nc;
    int i;
    for (i = 0; i < nc; ++i) {
        const int g = 2 * nq + i;
        if (CAEKF_PARAMS_GAMMA_LOG(mp)) { /* ln gamma, scaled by sigma_gamma0 / gamma0 (its P0 std to first order) */
            est->scale[g] = s->sigma_gamma0[i] / s->gamma0[i];
            est->z[g] = CAEKF_LOG(s->gamma0[i]) / est->scale[g];
        } else {
            est->scale[g] = s->sigma_gamma0[i];
            est->z[g] = s->gamma0[i] / s->sigma_gamma0[i];
        }
        /* the same ratio either way: sigma_q_gamma / gamma0 over sigma_gamma0 / gamma0 for ln gamma */
        est->q_diag[g] = s->q_gamma_scale * sq(s->sigma_q_gamma[i] / s->sigma_gamma0[i]);
        if (s->constraint_enabled) { /* gamma's bounds: the paper's eqs. (28)-(30); ln 0 is no bound */
            set_bounds(est, i, !CAEKF_PARAMS_GAMMA_LOG(mp) || s->gamma_min[i] > 0, gamma_bound(s, i, 0),
                       s->gamma_max[i] > 0, gamma_bound(s, i, 1));
        }
    }
    for (i = 0; CAEKF_HAS_LAW_PARAMS && i < nc; ++i) { /* the estimated law parameters: after the gammas, bounded */
        const unsigned char *law = est->model.law_state[i];
        if (law[CAEKF_LAW_N] != 0) {
            init_param(est, law[CAEKF_LAW_N], s->n0[i], s->sigma_n0[i], s->sigma_q_n[i], s->n_min[i], s->n_max[i]);
        }
        if (law[CAEKF_LAW_LAMBDA] != 0) {
            init_param(est, law[CAEKF_LAW_LAMBDA], s->lambda0[i], s->sigma_lambda0[i], s->sigma_q_lambda[i],
                       s->lambda_min[i], s->lambda_max[i]);
        }
        if (law[CAEKF_LAW_GAP] != 0) {
            init_param(est, law[CAEKF_LAW_GAP], s->gap0[i], s->sigma_gap0[i], s->sigma_q_gap[i], s->gap_min[i],
                       s->gap_max[i]);
        }
    }
    for (i = 0; i < CAEKF_DIM_NM(&est->model); ++i) { /* the mechanism's parameters: ln(value / setting), 0 at first */
        const int k = CAEKF_DIM_MECH0(&est->model) + i;
        (void)caekf_model_mech_setting(&est->model, mp, i, &est->scale[k]);
        est->q_diag[k] = sq(s->sigma_q_mech); /* relative to sigma: already scaled */
    }
    for (i = 0; i < mp->sensors; ++i) { /* the sensors' offsets: 0 at first, a random walk */
        const int k = est->model.sensor_bias[i];
        if (k != 0) {
            est->scale[k] = mp->sensor_bias_sigma[i];
            est->q_diag[k] = sq(s->sigma_q_mech);
        }
    }
}

/* The filter's sizes, sensed states and scaled R (init). rows: the sensors read rows of H (a structure's). */
static void init_dims(caekf_t *est, const caekf_settings_t *s, int rows)
{
    const caekf_model_params_t *mp = &s->model;
    const int nq = est->model.nq, n = est->model.n;
    int i;
    est->dims.nq = nq;
    est->dims.n = n;
    est->dims.ny = mp->sensors;
    for (i = 0; i < CAEKF_MAX_SENSORS; ++i) {
        est->dims.r[i] = 1;
    }
    est->dims.rows = rows;
    for (i = 0; i < mp->sensors; ++i) {
        const int velocity = mp->sensor_kind[i] == CAEKF_SENSOR_VELOCITY;
        est->dims.rows |= mp->sensor_kind[i] > CAEKF_SENSOR_VELOCITY || est->model.sensor_bias[i] != 0;
        est->dims.h[i] = (velocity ? nq : 0) + mp->sensor_body[i] - 1;
        est->dims.r[i] = sq(sensor_sigma(s, i) / (velocity ? s->sigma_v0 : s->sigma_q0));
    }
    for (i = 0; i < mp->sensors && est->dims.rows; ++i) { /* rows of H: each sensor in units of its noise */
        int k;
        est->dims.r[i] = 1;
        for (k = 0; k < mp->inputs && mp->sensor_kind[i] == CAEKF_SENSOR_ACCELERATION; ++k) {
            est->dims.r[i] += input_noise_ratio(est, s, i, k);
        }
    }
}

/* caekf_init with the mechanism given as a structure (st) or by the settings' bodies and links (st NULL). */
static caekf_status_t init_instance(caekf_t *est, const caekf_settings_t *s, const caekf_structure_t *st)
{
    const caekf_model_params_t *mp;
    int i, nq, n;
    if (!CAEKF_HAS_STRUCTURES) { /* a sized build's mechanism is bodies on a line: no structure code linked */
        st = 0;
    }
    if (est == 0 || s == 0) {
        return CAEKF_ERR_NULL;
    }
    mp = &s->model;
    /* Validation covers everything caekf_model_init checks, so nothing below can fail half-way. */
    if (caekf_settings_validate(s, 0) != CAEKF_OK || (st != 0 && caekf_model_structure_check(mp, st) != 0)) {
        return CAEKF_ERR_SETTINGS;
    }
    est->cfg = *s; /* first: s may be the instance's own settings */
    /* The rest of the instance zero (every buffer and flag), then what is not: one loop, less flash. */
    {
        unsigned char *bytes = (unsigned char *)est;
        size_t k;
        for (k = offsetof(caekf_t, model); k < sizeof *est; ++k) {
            bytes[k] = 0;
        }
    }
    if (st != 0) { /* checked above; a structure without a nonsingular Newton matrix is refused here */
        if (caekf_model_init_structure(&est->model, mp, st) != 0) {
            return CAEKF_ERR_SETTINGS;
        }
    } else {
        (void)caekf_model_init(&est->model, mp);
    }
    if (CAEKF_HAS_SUBSTEPS && s->contact_substeps > 1) { /* validation checked dt / contact_substeps is usable */
        caekf_model_params_t sub = *mp;
        sub.dt = mp->dt / (caekf_scalar_t)s->contact_substeps;
        if (st != 0) {
            if (caekf_model_init_structure(SUB_MODEL(est), &sub, st) != 0) {
                return CAEKF_ERR_SETTINGS;
            }
        } else {
            (void)caekf_model_init(SUB_MODEL(est), &sub);
        }
    } else if (CAEKF_HAS_SUBSTEPS) {
        *SUB_MODEL(est) = est->model;
    }
    nq = est->model.nq;
    n = est->model.n;
    for (i = 0; i < CAEKF_N; ++i) {
        est->scale[i] = 1;
    }
    for (i = 0; i < nq; ++i) { /* a structure starts at rest at q = 0 (q0 and v0 are a line's bodies') */
        est->scale[i] = s->sigma_q0;
        est->scale[nq + i] = s->sigma_v0;
        est->z[i] = st == 0 ? s->q0[i] / s->sigma_q0 : 0;
        est->z[nq + i] = st == 0 ? s->v0[i] / s->sigma_v0 : 0;
    }
    est->mismatch.nis_mean = 1;
    est->mismatch.q_scale = 1;
    set_body_q(est);
    init_params(est, s);
    init_dims(est, s, st != 0);
    for (i = 0; i < n; ++i) { /* P0 = diag(sigma0^2) is the identity in scaled coordinates */
        est->P[i * n + i] = 1;
    }
    load_fv0(est);
    est->init_magic = INIT_MAGIC;
    return CAEKF_OK;
}

caekf_status_t caekf_init(caekf_t *est, const caekf_settings_t *s) { return init_instance(est, s, 0); }

caekf_status_t caekf_init_structure(caekf_t *est, const caekf_settings_t *s, const caekf_structure_t *st)
{
    if (st == 0) {
        return CAEKF_ERR_NULL;
    }
    if (!CAEKF_HAS_STRUCTURES) {
        return CAEKF_ERR_SETTINGS;
    }
    return init_instance(est, s, st);
}

static int is_init(const caekf_t *est) { return est != 0 && est->init_magic == INIT_MAGIC; }

static caekf_gamma_policy_t gamma_policy(const caekf_settings_t *cfg, int contact_active)
{
    if (cfg->mode == CAEKF_MODE_CANONICAL || contact_active) {
        return CAEKF_GAMMA_LIVE;
    }
    return CAEKF_METHOD_SWITCHOFF(cfg) == CAEKF_SWITCHOFF_PAPER ? CAEKF_GAMMA_FROZEN_PAPER : CAEKF_GAMMA_FROZEN_SCHMIDT;
}

/* Every value finite: v * 0 is 0 for finite v, NaN otherwise. */
static int all_finite(const caekf_scalar_t *v, int n)
{
    caekf_scalar_t nf = 0;
    int i;
    CAEKF_UNROLL_SIZED
    for (i = 0; i < n; ++i) {
        nf += v[i] * 0;
    }
    return nf == 0;
}

/* The caller errors a step refuses before it writes anything: CAEKF_ERR_NULL (no instance, no inputs where the
 * mechanism has some, or no measurements where `measured`), CAEKF_ERR_NOT_INIT, CAEKF_ERR_INPUT (a value of u or
 * y not finite); else CAEKF_OK. */
static caekf_status_t refused(const caekf_t *est, const caekf_scalar_t *u, const caekf_scalar_t *y, int measured)
{
    if (est == 0 || (measured && y == 0)) {
        return CAEKF_ERR_NULL;
    }
    if (!is_init(est)) {
        return CAEKF_ERR_NOT_INIT;
    }
    if (CAEKF_DIM_NU(&est->model) > 0 && u == 0) {
        return CAEKF_ERR_NULL;
    }
    if (!all_finite(u, CAEKF_DIM_NU(&est->model)) || (y != 0 && !all_finite(y, est->cfg.model.sensors))) {
        return CAEKF_ERR_INPUT;
    }
    return CAEKF_OK;
}

/* x_{k-1} (x_prev) -> x_k- (x_pred) in contact_substeps substeps of the sub-model, inputs linear from u0 to
 * u, with F = F_S .. F_1 accumulated in physical units into fq (q-rows) and fv (v-rows), each map applied
 * without forming it (caekf_model_substep_map); F's gamma rows
 * stay identity rows. The contacts at x_{k-1} are in sub_ct[1] (advance evaluated them; the sub-model's
 * contacts are the model's), those at x_k- are left in sub_ct[(substeps + 1) & 1]. Returns 0, 1 when a
 * Newton solve did not converge, -1 on a singular matrix. */
static int substep_predict(caekf_t *est, const caekf_scalar_t *u0, const caekf_scalar_t *u, int *iters)
{
    const caekf_model_t *m = SUB_MODEL(est);
    const int nq = CAEKF_DIM_NQ(m), n = CAEKF_DIM_N(m), nu = CAEKF_DIM_NU(m), steps = CAEKF_METHOD_SUBSTEPS(&est->cfg);
    /* P_work is free until the covariance prediction: it holds each substep's start and inputs, off the
     * stack (the substeps' Newton solve is the deepest call of a step) */
    caekf_scalar_t *xa = est->P_work, *ua = est->P_work + CAEKF_N, *ub = ua + CAEKF_MAX_INPUTS;
    /* scratch: the Newton work, then the map's right-hand sides */
    caekf_scalar_t(*w)[CAEKF_N] = (caekf_scalar_t(*)[CAEKF_N])est->scratch.m;
    int i, j, step, result = 0;
    for (i = 0; i < n; ++i) {
        xa[i] = X_PREV(est)[i];
    }
    for (i = 0; i < nq; ++i) { /* F = I, accumulated map by map */
        for (j = 0; j < n; ++j) {
            SUB_FQ(est)[i][j] = j == i ? 1 : 0;
            est->fv[i][j] = j == nq + i ? 1 : 0;
        }
    }
    for (i = 0; i < nu; ++i) {
        ub[i] = u0[i];
    }
    for (step = 1; step <= steps; ++step) {
        int it = 0;
        for (i = 0; i < nu; ++i) {
            ua[i] = ub[i];
            ub[i] = step == steps ? u[i] : u0[i] + (u[i] - u0[i]) * (caekf_scalar_t)step / (caekf_scalar_t)steps;
        }
        /* the contacts at the substep's start and end (the next one's start): their roles swap every
         * substep */
        caekf_contact_t *ct0 = SUB_CT(est, step & 1), *ct = SUB_CT(est, (step + 1) & 1);
        /* Each substep's first Newton update takes the Jacobian at its start: the previous substep's map
         * has factorised it; the first substep's is factorised here (refused: its own Jacobian). */
        const int first_ok = step > 1 || caekf_model_newton_lu(m, ct0, SUB_LU(est)) == 0;
        if (caekf_model_newton_ct(m, xa, ua, ub, est->cfg.newton_max_iter, est->cfg.newton_rtol, est->x_pred, &it,
                                  est->scratch.m, ct, CAEKF_METHOD_TRAP(m) ? ct0 : 0,
                                  first_ok ? SUB_LU(est) : 0) != 0) {
            result = 1;
        }
        *iters += it;
        if (caekf_model_substep_map(m, ct, ct0, SUB_FQ(est), est->fv, SUB_LU(est), w) != 0) {
            return -1;
        }
        for (i = 0; i < n; ++i) {
            xa[i] = est->x_pred[i];
        }
    }
    return result;
}

/* Any input given a noise (input{i}_sigma > 0). */
static int measured_inputs(const caekf_t *est)
{
    int k, any = 0;
    for (k = 0; k < CAEKF_DIM_NU(&est->model); ++k) {
        any |= est->cfg.input_sigma[k] > 0;
    }
    return any;
}

/* The mechanism parameters' columns of F (v-rows, unscaled, into fv) for the step x_{k-1} -> x_k-.
 * With measured inputs they are taken at the inputs' trend, not at the samples: a column that carries the
 * force's noise correlates with the innovation the same noise makes, and biases the parameters (errors in
 * variables: the driven body's mass grew to several times its value). The step's end moves to where the
 * trend would have taken it, to first order x_k- - G (u - trend) (G = dx_k/du, each end of the trapezoidal
 * rule), and a base input's ground end is at its trend. An exact input (sigma 0) keeps its samples. */
CAEKF_NOINLINE static int mech_columns(caekf_t *est, const caekf_contact_t *ct, const caekf_scalar_t *u0,
                                       const caekf_scalar_t *u)
{
    caekf_scalar_t t0[CAEKF_MAX_INPUTS], t1[CAEKF_MAX_INPUTS], dev[CAEKF_MAX_INPUTS];
    const caekf_model_t *m = &est->model;
    int k;
    if (!est->input_trend_known || est->cfg.input_trend_window == 0 || !measured_inputs(est)) {
        return caekf_model_mech_columns(m, ct, X_PREV(est), est->x_pred, u0, u, 0, est->fv);
    }
    for (k = 0; k < CAEKF_DIM_NU(m); ++k) {
        const int noisy = est->cfg.input_sigma[k] > 0;
        t0[k] = noisy ? est->input_trend[k][0] : u0[k];
        t1[k] = noisy ? est->input_trend[k][0] + est->input_trend[k][1] : u[k];
        dev[k] = (u[k] - t1[k]) + (CAEKF_METHOD_TRAP(m) ? u0[k] - t0[k] : 0);
    }
    return caekf_model_mech_columns(m, ct, X_PREV(est), est->x_pred, t0, t1, dev, est->fv);
}

/* The measured inputs' trend after a step with inputs u: Holt's linear tracker, critically damped for
 * window W (lambda = 1 - 1/W: level gain 1 - lambda^2, slope gain (1 - lambda) / (1 + lambda)), so that a
 * ramp is followed without lag and white noise is averaged over about W steps. */
static void track_inputs(caekf_t *est, const caekf_scalar_t *u)
{
    const caekf_scalar_t lambda = 1 - 1 / (caekf_scalar_t)est->cfg.input_trend_window;
    const caekf_scalar_t a = 1 - lambda * lambda, b = (1 - lambda) / (1 + lambda);
    int k;
    for (k = 0; k < CAEKF_DIM_NU(&est->model); ++k) {
        caekf_scalar_t *t = est->input_trend[k];
        if (est->input_trend_known) {
            const caekf_scalar_t p = t[0] + t[1], level = p + a * (u[k] - p);
            t[1] += b * (level - t[0] - t[1]);
            t[0] = level;
        } else {
            t[0] = u[k];
            t[1] = 0;
        }
    }
    est->input_trend_known = 1;
}

/* F at x_k- (the constant contact-free F unless a contact is closed at either end of the step; after
 * substeps their product, in fq and fv) and P- = F P F^T + Q into P_work (upper triangle);
 * z = S^-1 x_k-. Returns 0, or -1 on a singular matrix. */
static int predict_covariance(caekf_t *est, int closed, int substepped, const caekf_contact_t *ct,
                              const caekf_scalar_t *u0, const caekf_scalar_t *u)
{
    const int nq = CAEKF_DIM_NQ(&est->model), n = CAEKF_DIM_N(&est->model);
    const caekf_scalar_t *s = est->scale, s_q = s[0], s_v = s[nq];
    caekf_scalar_t *z = est->x_pred;
    int i;
    if (CAEKF_HAS_SUBSTEPS && substepped) { /* scaled: S^-1 F S, column j times s_j / s_q (q-rows) or s_j / s_v
                                               * (v-rows) */
        const caekf_scalar_t rvq = s_v / s_q, rqv = s_q / s_v;
        est->fv_const = 0;
        if (CAEKF_DIM_NM(&est->model) > 0) { /* the mechanism's columns over the whole step (docs) */
            const int first = CAEKF_DIM_MECH0(&est->model), end = first + CAEKF_DIM_NM(&est->model);
            if (mech_columns(est, ct, u0, u) != 0) {
                return -1;
            }
            for (i = 0; i < nq; ++i) {
                int j;
                for (j = first; j < end; ++j) {
                    SUB_FQ(est)[i][j] = est->model.hs * est->fv[i][j];
                }
            }
        }
        for (i = 0; i < nq; ++i) {
            caekf_scalar_t *fq = SUB_FQ(est)[i], *fv = est->fv[i];
            int j;
            /* the ratio is exactly 1 for the rows' own kind (one scale for all q, one for all v) */
            CAEKF_UNROLL_SIZED
            for (j = 0; j < nq; ++j) {
                fq[nq + j] *= rvq;
                fv[j] *= rqv;
            }
            for (j = 2 * nq; j < n; ++j) {
                fq[j] *= s[j] / s_q;
                fv[j] *= s[j] / s_v;
            }
        }
        caekf_fv_dense(nq, n, &est->fv_pattern); /* dense in contact: no scan for zeros */
    } else if (closed || CAEKF_DIM_NM(&est->model) > 0) {
        est->fv_const = 0;
        /* with substeps the trapezoidal rule's contacts at x_{k-1} are advance's, in sub_ct[1] */
        if (CAEKF_HAS_SUBSTEPS ? caekf_model_transition_ct(&est->model, ct, SUB_CT(est, 1), est->fv) != 0
                               : caekf_model_transition_v_at(&est->model, ct, X_PREV(est), est->fv) != 0) {
            return -1;
        }
        if (CAEKF_DIM_NM(&est->model) > 0 && mech_columns(est, ct, u0, u) != 0) {
            return -1;
        }
        scale_fv(est->fv, s, nq, n);
        caekf_fv_dense(nq, n, &est->fv_pattern); /* dense in contact: no scan for zeros */
    } else if (!est->fv_const) {
        load_fv0(est);
    }
    for (i = 0; i < 2 * nq; ++i) {
        z[i] = est->x_pred[i] / s[i];
    }
    for (i = 2 * nq; i < n; ++i) {
        z[i] = est->z[i]; /* exact: the random walk carries gamma over bit for bit */
    }
    /* From here on P_work holds the upper triangle only; the commit mirrors it. */
    caekf_predict_covariance(est->P, est->P_work, est->fv, &est->fv_pattern, est->model.hs * s_v / s_q,
                             (est->model.p.dt - est->model.hs) * s_v / s_q,
                             CAEKF_HAS_SUBSTEPS && substepped ? SUB_FQ(est) : 0, est->q_diag, &est->dims);
    return 0;
}

/* The measured inputs' noise (settings input{i}_sigma) as process noise: Q_u = G diag(sigma_u^2) G^T over
 * the bodies' states, G = dx_k/du_k through the implicit step (A^-1 B_u at x_k-, the positions hs times
 * the velocities), added to P_work's upper triangle. Returns -1 on a singular Newton matrix. */
static int add_input_noise(caekf_t *est, const caekf_contact_t *ct)
{
    caekf_scalar_t g[CAEKF_NQ][CAEKF_MAX_INPUTS], col[2 * CAEKF_NQ];
    const int nq = CAEKF_DIM_NQ(&est->model), n = CAEKF_DIM_N(&est->model), nu = CAEKF_DIM_NU(&est->model);
    int i, j, k;
    if (caekf_model_input_columns(&est->model, ct, g) != 0) {
        return -1;
    }
    for (k = 0; k < nu; ++k) {
        const caekf_scalar_t var = sq(est->cfg.input_sigma[k]);
        if (!(var > 0)) {
            continue;
        }
        for (i = 0; i < nq; ++i) { /* scaled: S^-1 G */
            /* the trapezoidal rule takes each sample in two steps (u_{k-1} + u_k): as white noise of the
             * same low-frequency power, twice the one-end gain */
            const caekf_scalar_t gi = CAEKF_METHOD_TRAP(&est->model) ? 2 * g[i][k] : g[i][k];
            col[i] = est->model.hs * gi / est->scale[i];
            col[nq + i] = gi / est->scale[nq + i];
        }
        for (i = 0; i < 2 * nq; ++i) {
            for (j = i; j < 2 * nq; ++j) {
                est->P_work[i * n + j] += var * col[i] * col[j];
            }
        }
    }
    return 0;
}

/* The Gaussian second-order filter's term for contact c's force, for laws that are nonlinear in their
 * parameter states (ln gamma, n, lambda, gap): the force's second-order part in the parameters' error,
 * 1/2 dtheta^T H dtheta with H its Hessian, has the variance 1/2 tr(H P H P) over the parameters'
 * covariance P. The EKF's first-order F ignores it, which makes the first impacts, while the law is still
 * uncertain, move the parameters far too confidently. It enters the step as process noise on the
 * velocities the force acts on (dv = -hs/m df). Nothing while the contact is open or the law is linear
 * in its states (gamma alone). */
CAEKF_NOINLINE static void add_second_order_noise(caekf_t *est, int c)
{
    const caekf_model_t *m = &est->model;
    const int nq = CAEKF_DIM_NQ(m), n = CAEKF_DIM_N(m), a = CAEKF_CONTACT_I(m, c), b = CAEKF_CONTACT_J(m, c);
    const caekf_scalar_t *s = est->scale, s_v = s[nq];
    /* x_k- in the states' units (x_pred holds it scaled by now), in scratch: free between the
     * prediction's Newton solve and the correction */
    caekf_scalar_t *const x = est->scratch.m;
    caekf_scalar_t H[4][4], P[4][4], d, r, gamma, nn, lambda, f, fl, L, kg, var = 0;
    int idx[4], kind[4], k = 0, i, j, l;
    caekf_contact_t ct;
    if (CAEKF_HAS_LAW_PARAMS && !CAEKF_METHOD_GAMMA_LOG(m) &&
        (m->law_state[c][CAEKF_LAW_N] | m->law_state[c][CAEKF_LAW_LAMBDA] | m->law_state[c][CAEKF_LAW_GAP]) == 0) {
        return; /* gamma alone: the law is linear in it */
    }
    for (i = 0; i < n; ++i) {
        x[i] = est->x_pred[i] * s[i];
    }
    caekf_model_contact(m, c, x, &ct);
    if (!(ct.delta > 0) || !(ct.fc > 0)) {
        return;
    }
    d = ct.delta;
    f = ct.fc;
    gamma = CAEKF_METHOD_GAMMA_LOG(m) ? CAEKF_EXP(x[2 * nq + c]) : x[2 * nq + c];
    nn = CAEKF_METHOD_CONTACT_N(m, c);
    lambda = CAEKF_METHOD_LAMBDA(m, c);
    idx[k] = 2 * nq + c;
    kind[k++] = -1;
    for (i = 0; CAEKF_HAS_LAW_PARAMS && i < CAEKF_LAW_COUNT; ++i) { /* the estimated law parameters */
        const int g = m->law_state[c][i];
        if (g != 0) {
            idx[k] = g;
            kind[k++] = i;
            if (i == CAEKF_LAW_N) {
                nn = x[g];
            } else if (i == CAEKF_LAW_LAMBDA) {
                lambda = x[g];
            }
        }
    }
    if (k == 1 && !CAEKF_METHOD_GAMMA_LOG(m)) {
        return; /* gamma alone: the law is linear in it */
    }
    r = caekf_model_contact_dot(m, c, x + nq);
    L = CAEKF_LOG(d);
    fl = f / (1 + lambda * r) * r;                  /* df/dlambda = gamma delta^n r */
    kg = CAEKF_METHOD_GAMMA_LOG(m) ? 1 : 1 / gamma; /* df/dtheta = kg f for theta = ln gamma or gamma */
    for (i = 0; i < k; ++i) {
        for (j = i; j < k; ++j) {
            /* second derivatives of f = gamma delta^n (1 + lambda r), delta = q_a - q_b - gap */
            const int p = kind[i] < kind[j] ? kind[i] : kind[j], q = kind[i] < kind[j] ? kind[j] : kind[i];
            caekf_scalar_t h = 0;
            if (p == -1 && q == -1) {
                h = CAEKF_METHOD_GAMMA_LOG(m) ? f : 0;
            } else if (p == -1) {
                h = kg * (q == CAEKF_LAW_N ? f * L : q == CAEKF_LAW_LAMBDA ? fl : -nn * f / d);
            } else if (p == CAEKF_LAW_N) {
                h = q == CAEKF_LAW_N ? f * L * L : q == CAEKF_LAW_LAMBDA ? fl * L : -(nn * f * L + f) / d;
            } else if (p == CAEKF_LAW_LAMBDA) {
                h = q == CAEKF_LAW_LAMBDA ? 0 : -nn * fl / d;
            } else {
                h = nn * (nn - 1) * f / (d * d);
            }
            H[i][j] = H[j][i] = h;
            /* the parameters' predicted covariance (P_work's upper triangle), physical units */
            P[i][j] = P[j][i] =
                est->P_work[(idx[i] < idx[j] ? idx[i] * n + idx[j] : idx[j] * n + idx[i])] * s[idx[i]] * s[idx[j]];
        }
    }
    /* tr((H P)^2): each entry of H P formed where it is used, by the same sums (no third matrix on the
     * deepest stack path of the joint step) */
    for (i = 0; i < k; ++i) {
        for (j = 0; j < k; ++j) {
            caekf_scalar_t hp_ij = 0, hp_ji = 0;
            for (l = 0; l < k; ++l) {
                hp_ij += H[i][l] * P[l][j];
            }
            for (l = 0; l < k; ++l) {
                hp_ji += H[j][l] * P[l][i];
            }
            var += hp_ij * hp_ji;
        }
    }
    var = var / 2 / (s_v * s_v); /* scaled velocity units */
    if (CAEKF_IS_STRUCTURE(m)) { /* dv = -hs M^-1 w df */
        const caekf_scalar_t *w = CAEKF_STRUCTURE_W(m, c);
        for (i = 0; i < nq; ++i) {
            for (j = i; j < nq; ++j) {
                est->P_work[(nq + i) * n + nq + j] += var * (w[i] / m->m_dt[i]) * (w[j] / m->m_dt[j]);
            }
        }
    } else {
        const int e[2] = {a, b};
        const caekf_scalar_t w[2] = {a >= 0 ? -1 / m->m_dt[a] : 0, b >= 0 ? 1 / m->m_dt[b] : 0};
        for (i = 0; i < 2; ++i) {
            for (j = 0; j < 2; ++j) {
                if (e[i] >= 0 && e[j] >= 0 && e[i] <= e[j]) {
                    est->P_work[(nq + e[i]) * n + nq + e[j]] += var * w[i] * w[j];
                }
            }
        }
    }
}

/* The commit of a step in a sized build with substeps or the trapezoidal rule: z, and P from P_work's upper
 * triangle, filling the lower one; the sizes are constants, and the copy is written out (no loop overhead
 * per entry). The one-step build's loop below costs 127 instructions more and 652 B less. */
static void commit_sized(caekf_t *est, const caekf_scalar_t *z)
{
    const int n = CAEKF_DIM_N(&est->model);
    int i, j;
    CAEKF_UNROLL_SIZED
    for (i = 0; i < n; ++i) {
        const caekf_scalar_t *const w = &est->P_work[i * n];
        est->z[i] = z[i];
        est->P[i * n + i] = w[i];
        CAEKF_UNROLL_SIZED
        for (j = i + 1; j < n; ++j) {
            est->P[i * n + j] = w[j];
            est->P[j * n + i] = w[j];
        }
    }
}

/* Statistically linearised contacts (contact_slr_p > 0): each contact's penetration std,
 * sqrt(b^T P_qq b) from P_{k-1} (physical units; every q shares one scale), into both models; 0 for a
 * law that is not linearised statistically (caekf_model_slr_law), which keeps eq. (21)'s sign switch. */
static void set_penetration_std(caekf_t *est)
{
    const int nc = CAEKF_DIM_NC(&est->model), n = CAEKF_DIM_N(&est->model);
    int c;
    for (c = 0; c < nc; ++c) {
        const int a = CAEKF_CONTACT_I(&est->model, c), b = CAEKF_CONTACT_J(&est->model, c);
        caekf_scalar_t v = 0;
        if (CAEKF_IS_STRUCTURE(&est->model)) { /* w^T P_qq w */
            const caekf_scalar_t *w = CAEKF_STRUCTURE_W(&est->model, c);
            int i, j;
            for (i = 0; i < CAEKF_DIM_NQ(&est->model); ++i) {
                for (j = 0; j < CAEKF_DIM_NQ(&est->model); ++j) {
                    v += w[i] * w[j] * est->P[i * n + j];
                }
            }
        } else {
            if (a >= 0) {
                v += est->P[a * n + a];
            }
            if (b >= 0) {
                v += est->P[b * n + b];
            }
            if (a >= 0 && b >= 0) {
                v -= 2 * est->P[a * n + b];
            }
        }
        v = v > 0 && caekf_model_slr_law(&est->model, c) ? CAEKF_SQRT(v) * est->scale[0] : 0;
        CAEKF_SLR_S(&est->model)[c] = v;
        if (CAEKF_HAS_SUBSTEPS) {
            CAEKF_SLR_S(SUB_MODEL(est))[c] = v;
        }
    }
}

/* The correction's rows of H for sensors that read more than one state: at the scaled prediction z (the
 * physical state is z times the scales), each sensor's h(x), row and measurement scaled by its noise std
 * (its R is then 1). */
static void sensor_rows(caekf_t *est, const caekf_scalar_t *z, const caekf_scalar_t *u, const caekf_scalar_t *u0,
                        const caekf_scalar_t *y, caekf_scalar_t *y_s)
{
    caekf_correct_work_t *w = &est->scratch.correct;
    const int n = CAEKF_DIM_N(&est->model);
    caekf_scalar_t x[CAEKF_N];
    int i, k;
    for (i = 0; i < n; ++i) {
        x[i] = z[i] * est->scale[i];
    }
    for (k = 0; k < est->cfg.model.sensors; ++k) {
        const caekf_scalar_t sigma = sensor_sigma(&est->cfg, k);
        caekf_scalar_t h;
        caekf_model_sensor(&est->model, &est->cfg.model, k, x, u, u0, &h, w->row[k]);
        for (i = 0; i < n; ++i) {
            w->row[k][i] *= est->scale[i] / sigma;
        }
        w->hx[k] = h / sigma;
        y_s[k] = y[k] / sigma;
    }
}

/* The model at the mechanism parameters' estimates (x: the physical state, ln(value / setting) in its
 * last nm entries): its matrices, and the substeps' model's. Returns -1 on a singular Newton matrix (the
 * step is then rolled back: the next one derives them again). */
static int set_mechanism(caekf_t *est, const caekf_scalar_t *x)
{
    caekf_scalar_t mult[CAEKF_MECH_STORE];
    const int nm = CAEKF_DIM_NM(&est->model), first = CAEKF_DIM_MECH0(&est->model);
    int j, r;
    for (j = 0; j < nm; ++j) {
        mult[j] = CAEKF_EXP(x[first + j]);
    }
    r = caekf_model_set_mech(&est->model, &est->cfg.model, mult);
    if (CAEKF_HAS_SUBSTEPS && est->cfg.contact_substeps > 1) {
        r |= caekf_model_set_mech(SUB_MODEL(est), &est->cfg.model, mult);
    }
    return r; /* fv_const stays unused: with mechanism parameters every step forms F (predict_covariance) */
}

/* Table 1's prediction of the state, x_{k-1} -> x_k- (eq. 19), into x_pred (physical units), from the scaled z: the
 * model at the mechanism's estimates and the contacts' penetration std first, then (unless `predict` is 0:
 * caekf_correct, x_k- = x_{k-1}) the Newton solve of one step from the inputs u0 to u or, where a contact is
 * closed at either end of it, of the substeps. The first step after init holds u over its interval unless
 * caekf_correct gave the input at t0. *closed_prev: a contact closed at x_{k-1} (substeps and the trapezoidal F
 * both ask); *substepped: the substeps ran; *ct_pred: the contacts at x_k- the prediction evaluated (NULL: none).
 * Returns CAEKF_OK, else the error with its flags. */
CAEKF_HOT_INLINE caekf_status_t predict_state(caekf_t *est, const caekf_scalar_t *u0, const caekf_scalar_t *u,
                                              int predict, int *iters, int *closed_prev, int *substepped,
                                              const caekf_contact_t **ct_pred, uint32_t *flags)
{
    const int n = CAEKF_DIM_N(&est->model), substeps = CAEKF_METHOD_SUBSTEPS(&est->cfg);
    caekf_scalar_t *const xprev = X_PREV(est);
    int i, closed_before, r = 0;
    for (i = 0; i < n; ++i) {
        xprev[i] = est->z[i] * est->scale[i];
    }
    if (CAEKF_MAX_MECH_PARAMS > 0 && CAEKF_DIM_NM(&est->model) > 0 && set_mechanism(est, xprev) != 0) {
        *flags |= CAEKF_FLAG_NUMERIC_ROLLBACK;
        return CAEKF_ERR_SINGULAR;
    }
    if (CAEKF_HAS_SLR && est->cfg.contact_slr_p > 0) {
        set_penetration_std(est);
    }
    if (!predict) {
        for (i = 0; i < n; ++i) {
            est->x_pred[i] = xprev[i];
        }
        return CAEKF_OK;
    }
    /* With substeps the contacts at x_{k-1} (sub_ct[1]: the first substep's start, and the one step's) and at the
     * one step's x_k- (sub_ct[0]) are kept: evaluated once each. */
    *closed_prev = (substeps > 1 || CAEKF_METHOD_TRAP(&est->model)) &&
                   (CAEKF_HAS_SUBSTEPS ? caekf_model_contacts_any(&est->model, xprev, SUB_CT(est, 1))
                                       : caekf_model_any_contact(&est->model, xprev));
    closed_before = substeps > 1 && *closed_prev;
    if (!closed_before && CAEKF_HAS_SUBSTEPS) { /* a step from an open contact: one step unless it closes one */
        r = caekf_model_newton_ct(&est->model, xprev, u0, u, est->cfg.newton_max_iter, est->cfg.newton_rtol,
                                  est->x_pred, iters, est->scratch.m, SUB_CT(est, 0),
                                  CAEKF_METHOD_TRAP(&est->model) ? SUB_CT(est, 1) : 0, 0);
        *ct_pred = SUB_CT(est, 0);
    } else if (!closed_before) {
        r = caekf_model_newton(&est->model, xprev, u0, u, est->cfg.newton_max_iter, est->cfg.newton_rtol, est->x_pred,
                               iters, est->scratch.m);
    }
    if (CAEKF_HAS_SUBSTEPS &&
        (closed_before || (substeps > 1 && caekf_model_contacts_any(&est->model, 0, SUB_CT(est, 0))))) {
        *substepped = 1; /* the one-step solution only decided that substeps are needed */
        r = substep_predict(est, u0, u, iters);
        *ct_pred = SUB_CT(est, (substeps + 1) & 1);
        if (r < 0) {
            *flags |= CAEKF_FLAG_NEWTON_NOT_CONVERGED | CAEKF_FLAG_NUMERIC_ROLLBACK;
            return CAEKF_ERR_SINGULAR;
        }
    }
    if (r != 0) {
        *flags |= CAEKF_FLAG_NEWTON_NOT_CONVERGED;
    }
    return CAEKF_OK;
}

/* Table 1's switch-off (eq. 21, Sec. 3.2): each contact's law at x_k- into ct (the prediction's own, ct_pred, when
 * it evaluated them), whether it is active (closed; statistically linearised: while P(delta > 0) > contact_slr_p)
 * and so each parameter's policy this step; *deepest: the deepest penetration. Returns whether any contact is
 * active. */
CAEKF_HOT_INLINE int switch_off(caekf_t *est, caekf_contact_t *ct, const caekf_contact_t *ct_pred,
                                caekf_scalar_t *deepest, uint32_t *flags)
{
    const int nq = CAEKF_DIM_NQ(&est->model), nc = CAEKF_DIM_NC(&est->model), n = CAEKF_DIM_N(&est->model);
    const int mech0 = CAEKF_DIM_MECH0(&est->model) - 2 * nq;
    caekf_filter_dims_t *const dims = &est->dims;
    int i, any_contact = 0;
    for (i = 0; i < nc; ++i) { /* contact by contact (F at x_k- takes the same laws) */
        int on;
        if (CAEKF_HAS_SUBSTEPS && ct_pred != 0) { /* the prediction's own, at x_k- */
            ct[i] = ct_pred[i];
        } else {
            caekf_model_contact(&est->model, i, est->x_pred, &ct[i]);
        }
        on = ct[i].delta > 0;
        if (CAEKF_HAS_SLR && est->cfg.contact_slr_p > 0 && CAEKF_SLR_S(&est->model)[i] > 0) {
            /* at or past the gap P(delta > 0) = erfc(-x) / 2 >= 1/2 (x >= 0): no erfc for a closed contact */
            on = (ct[i].delta >= 0 && est->cfg.contact_slr_p < CAEKF_C(0.5)) ||
                 CAEKF_C(0.5) * CAEKF_ERFC(-ct[i].delta / (CAEKF_SLR_S(&est->model)[i] * CAEKF_SQRT(CAEKF_C(2.0)))) >
                     est->cfg.contact_slr_p;
        }
        *deepest = i == 0 ? ct[i].delta : caekf_max(*deepest, ct[i].delta);
        any_contact |= on;
        dims->policy[i] = (uint8_t)gamma_policy(&est->cfg, on);
        if (dims->policy[i] != CAEKF_GAMMA_LIVE) {
            *flags |= CAEKF_FLAG_GAMMA_FROZEN;
        }
    }
    for (i = nc; i < mech0; ++i) { /* a law parameter follows its contact's gamma */
        dims->policy[i] = dims->policy[est->model.param_contact[i]];
    }
    for (i = mech0; i < n - 2 * nq; ++i) { /* the mechanism's and the sensors' offsets: observable without contact */
        dims->policy[i] = CAEKF_GAMMA_LIVE;
    }
    if (any_contact) {
        *flags |= CAEKF_FLAG_CONTACT_ACTIVE;
    }
    return any_contact;
}

/* Table 1's prediction of the covariance into P_work and z (unless `predict` is 0: P- is P): F at x_k- (eq. 10)
 * and P- = F P F^T + Q (eq. 12), with the measured inputs' noise and the law's second-order term. closed: a
 * contact active at x_k-, or (trapezoidal) closed at x_{k-1}. Returns CAEKF_OK, else the error with its
 * flags. */
CAEKF_HOT_INLINE caekf_status_t predict_cov(caekf_t *est, int predict, int closed, int any_contact, int substepped,
                                            const caekf_contact_t *ct, const caekf_scalar_t *u0,
                                            const caekf_scalar_t *u, uint32_t *flags)
{
    const int nc = CAEKF_DIM_NC(&est->model), n = CAEKF_DIM_N(&est->model);
    int i;
    if (!predict) { /* a correction at the estimate's own time */
        for (i = 0; i < n; ++i) {
            est->x_pred[i] = est->z[i];
        }
        for (i = 0; i < n * n; ++i) {
            est->P_work[i] = est->P[i];
        }
        return CAEKF_OK;
    }
    if (predict_covariance(est, closed, substepped, ct, u0, u) != 0) {
        *flags |= CAEKF_FLAG_NEWTON_NOT_CONVERGED | CAEKF_FLAG_NUMERIC_ROLLBACK;
        return CAEKF_ERR_SINGULAR;
    }
    if (measured_inputs(est) && add_input_noise(est, ct) != 0) {
        *flags |= CAEKF_FLAG_NUMERIC_ROLLBACK;
        return CAEKF_ERR_SINGULAR;
    }
    if (any_contact && est->cfg.law_second_order && (CAEKF_HAS_LAW_PARAMS || CAEKF_METHOD_GAMMA_LOG(&est->model))) {
        for (i = 0; i < nc; ++i) {
            add_second_order_noise(est, i);
        }
    }
    return CAEKF_OK;
}

/* Table 1's correction (eqs. 13-15, with a parameter switched off eqs. 25-27) of z and P_work by the measurements
 * y (sensors that read more than one state through their rows of H), then the constraint (eqs. 28-30). u, u0:
 * the inputs at the step's end and start (an acceleration sensor reads them). Returns whether it corrected. */
CAEKF_HOT_INLINE int correct(caekf_t *est, caekf_scalar_t *z, const caekf_scalar_t *u, const caekf_scalar_t *u0,
                             const caekf_scalar_t *y, caekf_scalar_t *nis, uint32_t *flags)
{
    const caekf_filter_dims_t *const dims = &est->dims;
    caekf_scalar_t y_s[CAEKF_MAX_SENSORS];
    int corrected;
    if (CAEKF_HAS_SENSOR_ROWS && dims->rows) {
        sensor_rows(est, z, u, u0, y, y_s);
    } else {
        int i;
        for (i = 0; i < est->cfg.model.sensors; ++i) {
            y_s[i] = y[i] / est->scale[dims->h[i]];
        }
    }
    corrected = caekf_correct_upper(z, est->P_work, y_s, est->cfg.cov_update == CAEKF_COV_JOSEPH, dims,
                                    est->cfg.gamma_gate_nis, nis, flags, &est->scratch.correct) == 0;
    apply_bounds(est, z, flags);
    return corrected;
}

/* The step's result into the instance: z and P from P_work's upper triangle (filling the lower one), the inputs
 * (the next step's start) and their trend, the mismatch monitor, the step count. */
CAEKF_HOT_INLINE void commit(caekf_t *est, const caekf_scalar_t *z, const caekf_scalar_t *u, int predict,
                             const caekf_mismatch_t *monitor, uint32_t flags)
{
    const int n = CAEKF_DIM_N(&est->model);
    int i, rescale;
    if (CAEKF_SIZED && !CAEKF_ONE_STEP_BE) {
        commit_sized(est, z);
    } else {
        for (i = 0; i < n; ++i) {
            const caekf_scalar_t *w = &est->P_work[i * n + i];
            caekf_scalar_t *row = &est->P[i * n + i], *col = row, *const end = est->P + i * n + n;
            est->z[i] = z[i];
            *row = *w;
            while (++row != end) {
                col += n;
                *row = *++w;
                *col = *w;
            }
        }
    }
    if (CAEKF_KEEPS_U_PREV) {
        for (i = 0; i < CAEKF_DIM_NU(&est->model); ++i) {
            U_PREV_STORE(est)[i] = u[i];
        }
        *U_PREV_KNOWN_STORE(est) = 1;
    }
    if (predict && CAEKF_DIM_NM(&est->model) > 0 && est->cfg.input_trend_window > 0 && measured_inputs(est)) {
        track_inputs(est, u);
    }
    rescale = monitor->q_scale != est->mismatch.q_scale;
    est->mismatch = *monitor;
    if (rescale) {
        set_body_q(est);
    }
    est->step_count++;
    est->last_flags = flags;
}

/* One step (Table 1): prediction (unless `predict` is 0: caekf_correct), the switch-off, then (with y) the
 * correction and the constraint, and P's health. y == NULL: no measurement (caekf_predict), which caekf_step
 * (measured == 1) refuses as a caller error. A step that fails leaves the instance as it was. */
static caekf_status_t advance(caekf_t *est, const caekf_scalar_t *u, const caekf_scalar_t *y, int measured, int predict,
                              caekf_report_t *report)
{
    caekf_scalar_t *z;                  /* x_k-, then the scaled z once F is formed */
    const caekf_scalar_t *u0;           /* the inputs at the step's start */
    caekf_contact_t *ct;                /* the contacts' laws at x_k- (in scratch) */
    const caekf_contact_t *ct_pred = 0; /* the prediction's, when it evaluated them */
    caekf_status_t st;
    caekf_scalar_t deepest = 0, nis = 0;
    caekf_mismatch_t monitor;
    uint32_t flags = 0;
    int iters = 0, closed_prev = 0, substepped = 0;

    if (report != 0) {
        report->flags = 0;
        report->newton_iters = 0;
        report->delta = 0;
        report->nis = 0;
    }
    st = refused(est, u, y, measured);
    if (st != CAEKF_OK) {
        if (report != 0 && st == CAEKF_ERR_INPUT) {
            report->flags = CAEKF_FLAG_INPUT_REJECTED;
        }
        return st; /* nothing in *est has been written */
    }
    z = est->x_pred;
    ct = est->scratch.contacts;
    u0 = predict ? U_PREV(est, u) : u; /* a correction at the estimate's own time: no step, no rate */

    st = predict_state(est, u0, u, predict, &iters, &closed_prev, &substepped, &ct_pred, &flags);
    if (st == CAEKF_OK) {
        const int any_contact = switch_off(est, ct, ct_pred, &deepest, &flags);
        st = predict_cov(est, predict, any_contact || (CAEKF_METHOD_TRAP(&est->model) && closed_prev), any_contact,
                         substepped, ct, u0, u, &flags);
    }
    if (st == CAEKF_OK) {
        int corrected = 0;
        if (y != 0) {
            corrected = correct(est, z, u, u0, y, &nis, &flags);
        } else {
            flags |= CAEKF_FLAG_NO_MEASUREMENT; /* prediction only: gamma cannot move */
        }
        flags |= mismatch_update(est, corrected, nis, &monitor);
        if (!caekf_covariance_health(est->P_work, z, CAEKF_DIM_N(&est->model),
                                     (est->step_count % (uint32_t)est->cfg.psd_check_period) == 0,
                                     est->cfg.cov_repair_enabled, est->scratch.m, &flags)) {
            flags |= CAEKF_FLAG_NUMERIC_ROLLBACK;
            st = CAEKF_ERR_NUMERIC;
        }
    }
    if (st == CAEKF_OK) {
        commit(est, z, u, predict, &monitor, flags);
    } else { /* a rolled-back step leaves the monitor as it was, and says what it says */
        flags |= mismatch_update(est, 0, 0, &monitor);
    }
    if (report != 0) {
        report->flags = flags;
        report->newton_iters = iters;
        report->delta = deepest;
        report->nis = nis;
    }
    return st;
}

caekf_status_t caekf_step(caekf_t *est, const caekf_scalar_t *u, const caekf_scalar_t *y, caekf_report_t *report)
{
    return advance(est, u, y, 1, 1, report);
}

caekf_status_t caekf_predict(caekf_t *est, const caekf_scalar_t *u, caekf_report_t *report)
{
    return advance(est, u, 0, 0, 1, report);
}

caekf_status_t caekf_correct(caekf_t *est, const caekf_scalar_t *u, const caekf_scalar_t *y, caekf_report_t *report)
{
    return advance(est, u, y, 1, 0, report);
}

/* The accessors' common refusals: a NULL instance or output, then an instance never initialised. */
CAEKF_NOINLINE static caekf_status_t readable(const caekf_t *est, const void *out)
{
    if (est == 0 || out == 0) {
        return CAEKF_ERR_NULL;
    }
    return is_init(est) ? CAEKF_OK : CAEKF_ERR_NOT_INIT;
}

caekf_status_t caekf_get_mismatch(const caekf_t *est, caekf_scalar_t *nis_mean, caekf_scalar_t *q_scale)
{
    const caekf_status_t st = readable(est, est);
    if (st == CAEKF_OK && nis_mean != 0) {
        *nis_mean = est->mismatch.nis_mean;
    }
    if (st == CAEKF_OK && q_scale != 0) {
        *q_scale = est->mismatch.q_scale;
    }
    return st;
}

caekf_status_t caekf_get_sizes(const caekf_t *est, int *n, int *sensors, int *inputs)
{
    const caekf_status_t ok = readable(est, (n && sensors && inputs) ? (const void *)n : 0);
    if (ok != CAEKF_OK) {
        return ok;
    }
    *n = est->model.n;
    *sensors = est->cfg.model.sensors;
    *inputs = est->cfg.model.inputs;
    return CAEKF_OK;
}

/* State i in physical units, and the factor from its scaled value's perturbation to the physical one's
 * (the covariance's scale): s_i, and gamma s_i for a log gamma (d gamma = gamma d ln gamma). */
static caekf_scalar_t state_value(const caekf_t *est, int i, caekf_scalar_t *factor)
{
    const caekf_scalar_t v = est->z[i] * est->scale[i];
    const int nx = 2 * est->model.nq;
    if (CAEKF_METHOD_GAMMA_LOG(&est->model) && i >= nx && i < nx + est->model.nc) {
        const caekf_scalar_t gamma = CAEKF_EXP(v);
        *factor = est->scale[i] * gamma;
        return gamma;
    }
    if (i >= CAEKF_DIM_MECH0(&est->model) && i < CAEKF_DIM_MECH0(&est->model) + CAEKF_DIM_NM(&est->model)) {
        /* a mechanism parameter: the setting times exp(ln(value / setting)) */
        const caekf_scalar_t value =
            caekf_model_mech_setting(&est->model, &est->cfg.model, i - CAEKF_DIM_MECH0(&est->model), 0) * CAEKF_EXP(v);
        *factor = est->scale[i] * value;
        return value;
    }
    *factor = est->scale[i];
    return v;
}

caekf_status_t caekf_get_state(const caekf_t *est, caekf_scalar_t x[CAEKF_N])
{
    int i;
    const caekf_status_t ok = readable(est, x);
    if (ok != CAEKF_OK) {
        return ok;
    }
    for (i = 0; i < CAEKF_N; ++i) {
        caekf_scalar_t f;
        x[i] = i < est->model.n ? state_value(est, i, &f) : 0;
    }
    return CAEKF_OK;
}

caekf_status_t caekf_get_gamma(const caekf_t *est, caekf_scalar_t *gamma)
{
    /* the first contact's gamma: the same refusals in the same order, but gamma must be given */
    return gamma == 0 ? CAEKF_ERR_NULL : caekf_get_contact_law(est, 0, gamma, 0, 0, 0);
}

caekf_status_t caekf_get_contact_law(const caekf_t *est, int c, caekf_scalar_t *gamma, caekf_scalar_t *n,
                                     caekf_scalar_t *lambda, caekf_scalar_t *gap)
{
    const caekf_model_run_params_t *p;
    caekf_scalar_t law[CAEKF_LAW_COUNT], f;
    int k, g;
    const caekf_status_t ok = readable(est, est);
    if (ok != CAEKF_OK) {
        return ok;
    }
    if (c < 0 || c >= est->model.nc) {
        return CAEKF_ERR_SETTINGS;
    }
    p = &est->model.p;
    law[CAEKF_LAW_N] = CAEKF_METHOD_CONTACT_N(&est->model, c);
    law[CAEKF_LAW_LAMBDA] = CAEKF_METHOD_LAMBDA(&est->model, c);
    law[CAEKF_LAW_GAP] = p->contact_gap[c];
    for (k = 0; CAEKF_HAS_LAW_PARAMS && k < CAEKF_LAW_COUNT; ++k) { /* the estimated ones: states */
        const int s = est->model.law_state[c][k];
        if (s != 0) {
            law[k] = state_value(est, s, &f);
        }
    }
    g = 2 * est->model.nq + c;
    if (gamma != 0) {
        *gamma = state_value(est, g, &f);
    }
    if (n != 0) {
        *n = law[CAEKF_LAW_N];
    }
    if (lambda != 0) {
        *lambda = law[CAEKF_LAW_LAMBDA];
    }
    if (gap != 0) {
        *gap = law[CAEKF_LAW_GAP];
    }
    return CAEKF_OK;
}

/* P in physical units into out (leading dimension ld). */
static void physical_covariance(const caekf_t *est, caekf_scalar_t *out, int ld)
{
    const int n = est->model.n;
    caekf_scalar_t f[CAEKF_N];
    int i, j;
    for (i = 0; i < n; ++i) {
        (void)state_value(est, i, &f[i]);
    }
    for (i = 0; i < n; ++i) {
        for (j = 0; j < n; ++j) {
            out[i * ld + j] = est->P[i * n + j] * f[i] * f[j];
        }
    }
}

caekf_status_t caekf_get_variances(const caekf_t *est, caekf_scalar_t var[CAEKF_N])
{
    int i;
    const caekf_status_t ok = readable(est, var);
    if (ok != CAEKF_OK) {
        return ok;
    }
    for (i = 0; i < CAEKF_N; ++i) {
        var[i] = 0;
    }
    for (i = 0; i < est->model.n; ++i) {
        caekf_scalar_t f;
        (void)state_value(est, i, &f);
        var[i] = est->P[i * est->model.n + i] * f * f;
    }
    return CAEKF_OK;
}

caekf_status_t caekf_get_covariance(const caekf_t *est, caekf_scalar_t P[CAEKF_N][CAEKF_N])
{
    int i, j;
    const caekf_status_t ok = readable(est, P);
    if (ok != CAEKF_OK) {
        return ok;
    }
    for (i = 0; i < CAEKF_N; ++i) {
        for (j = 0; j < CAEKF_N; ++j) {
            P[i][j] = 0;
        }
    }
    physical_covariance(est, &P[0][0], CAEKF_N);
    return CAEKF_OK;
}

caekf_status_t caekf_get_cov_norm2(caekf_t *est, caekf_scalar_t *norm2)
{
    const caekf_status_t ok = readable(est, norm2);
    if (ok != CAEKF_OK) {
        return ok;
    }
    /* P_work is free between steps: it takes the physical P while scratch is the eigen workspace. */
    physical_covariance(est, est->P_work, est->model.n);
    return caekf_sym_norm2(est->P_work, est->model.n, est->scratch.m, norm2) == CAEKF_LA_OK ? CAEKF_OK
                                                                                            : CAEKF_ERR_NUMERIC;
}
