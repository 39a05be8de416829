/* Branches of the core that the scenario suites do not take: refusals of the public accessors and of the
 * settings API, each rule of validation that a finite setting can still break once scaled, the settings
 * refusal texts, and the argument and singular cases of the dense linear algebra. Every refused call is
 * checked for its status and for leaving its outputs (or the instance) as they were. */
#include <math.h>
#include <string.h>

#include "caekf_filter.h"
#include "caekf_linalg.h"
#include "caekf_model_internal.h"
#include "test_support.h"
#include "unity.h"

static caekf_t est, copy;
static caekf_settings_t good;

/* Values that overflow (BIG over a sigma, HUGE_SQ over a sigma then squared) in the build's scalar. */
#if CAEKF_USE_FLOAT
#define BIG ((caekf_scalar_t)1e37f)
#define HUGE_SQ ((caekf_scalar_t)1e20f)
#else
#define BIG ((caekf_scalar_t)1e307)
#define HUGE_SQ ((caekf_scalar_t)1e200)
#endif

void setUp(void) { paper_settings(&good, EXP_SWITCHED_HIGHQ_CONSTRAINED); }
void tearDown(void) {}

/* Refused by validation with this id and reason, and by caekf_init leaving a running instance unchanged. */
static void expect_refused(const caekf_settings_t *bad, unsigned param_id, unsigned reason, const char *what)
{
    caekf_setting_error_t err;
    TEST_ASSERT_EQUAL_INT_MESSAGE(CAEKF_OK, caekf_init(&est, &good), what);
    memcpy(&copy, &est, sizeof est);
    TEST_ASSERT_EQUAL_INT_MESSAGE(CAEKF_ERR_SETTINGS, caekf_init(&est, bad), what);
    TEST_ASSERT_TRUE_MESSAGE(memcmp(&copy, &est, sizeof est) == 0, what);
    memset(&err, 0xEE, sizeof err);
    TEST_ASSERT_EQUAL_INT_MESSAGE(CAEKF_ERR_SETTINGS, caekf_settings_validate(bad, &err), what);
    TEST_ASSERT_EQUAL_UINT_MESSAGE(param_id, err.param_id, what);
    TEST_ASSERT_EQUAL_UINT_MESSAGE(reason, err.reason, what);
}

/* Guards the accessors' refusals: NULL instance or output, an instance never initialised, a contact out of
 * range; a refused call writes nothing. */
static void test_accessors_refuse_null_uninitialised_and_bad_contact(void)
{
    static caekf_t blank;
    static caekf_scalar_t P[CAEKF_N][CAEKF_N];
    caekf_scalar_t x[CAEKF_N], var[CAEKF_N], g = 42, nn = 42, lam = 42, gap = 42, norm = 42, nis = 42, qs = 42;
    int n = -7, ny = -7, nu = -7;
    memset(&blank, 0, sizeof blank);
    x[0] = var[0] = P[0][0] = 42;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_get_state(&blank, x));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_get_variances(&blank, var));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_get_covariance(&blank, P));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_get_cov_norm2(&blank, &norm));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_get_mismatch(&blank, &nis, &qs));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_get_contact_law(&blank, 0, &g, &nn, &lam, &gap));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_state(NULL, x));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_mismatch(NULL, &nis, &qs));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_sizes(NULL, &n, &ny, &nu));
    TEST_ASSERT_TRUE(x[0] == 42 && var[0] == 42 && P[0][0] == 42 && g == 42 && nn == 42 && lam == 42 && gap == 42);
    TEST_ASSERT_TRUE(norm == 42 && nis == 42 && qs == 42 && n == -7 && ny == -7 && nu == -7);

    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &good));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_state(&est, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_variances(&est, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_covariance(&est, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_cov_norm2(&est, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_gamma(&est, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_sizes(&est, NULL, &ny, &nu));
    TEST_ASSERT_TRUE(n == -7 && ny == -7 && nu == -7);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_get_contact_law(&est, -1, &g, &nn, &lam, &gap));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_get_contact_law(&est, good.model.contacts, &g, &nn, &lam, &gap));
    TEST_ASSERT_TRUE(g == 42 && nn == 42 && lam == 42 && gap == 42);
}

/* Guards the accessors' optional outputs: the law without gamma, the monitor one value at a time. */
static void test_accessors_fill_only_the_outputs_given(void)
{
    caekf_scalar_t g = 42, g0 = 0, nn = 42, lam = 42, gap = 42, nis = 42, qs = 42;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &good));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_contact_law(&est, 0, NULL, &nn, &lam, &gap));
    TEST_ASSERT_TRUE(nn == good.model.contact_n[0] && lam == good.model.contact_lambda[0] &&
                     gap == good.model.contact_gap[0]);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_contact_law(&est, 0, &g, NULL, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_gamma(&est, &g0));
    TEST_ASSERT_TRUE(g == g0);
    TEST_ASSERT_FLOAT_WITHIN(1e-5f * (float)good.gamma0[0], (float)good.gamma0[0], (float)g);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_mismatch(&est, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_mismatch(&est, &nis, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_mismatch(&est, NULL, &qs));
    TEST_ASSERT_TRUE(nis != 42 && qs != 42 && isfinite((double)nis) && qs > 0);
}

/* Guards the settings API's NULL refusals and an unknown id's report (clamped to 8 bits). */
static void test_settings_api_refuses_null_and_unknown_ids(void)
{
    caekf_settings_t b = good;
    caekf_setting_error_t err;
    double v = 42;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_settings_default(NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_settings_validate(NULL, &err));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_settings_set(NULL, CAEKF_PARAM_DT, 1.0, &err));
    memset(&err, 0, sizeof err);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_set(&b, 1000u, 1.0, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_UNKNOWN_ID, err.reason);
    TEST_ASSERT_EQUAL_UINT(255u, err.param_id);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_set(&b, CAEKF_PARAM_COUNT, 1.0, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_get(&b, CAEKF_PARAM_COUNT, &v));
    TEST_ASSERT_TRUE(v == 42);
    TEST_ASSERT_TRUE(memcmp(&b, &good, sizeof b) == 0);
}

/* Guards first_unscalable's per-state rules: each finite setting whose scaled value overflows is refused,
 * blaming that setting. */
static void test_each_scaled_state_value_must_be_finite(void)
{
    caekf_settings_t b = good;
    b.q0[0] = BIG; /* over sigma_q0 */
    expect_refused(&b, CAEKF_PARAM_Q0, CAEKF_SETTING_NOT_SCALABLE, "q0 / sigma_q0 overflows");
    b = good;
    b.v0[0] = BIG; /* over sigma_v0 */
    expect_refused(&b, CAEKF_PARAM_V0, CAEKF_SETTING_NOT_SCALABLE, "v0 / sigma_v0 overflows");
    b = good;
    b.model.m[1] = BIG; /* over dt */
    expect_refused(&b, CAEKF_PARAM_M + 1, CAEKF_SETTING_NOT_SCALABLE, "m / dt overflows");
    b = good;
    b.constraint_enabled = 0;
    b.sigma_gamma0[0] = (caekf_scalar_t)1e-3;
    b.gamma_min[0] = BIG;
    expect_refused(&b, CAEKF_PARAM_GAMMA_MIN, CAEKF_SETTING_NOT_SCALABLE, "gamma_min / sigma_gamma0 overflows");
    b = good;
    b.constraint_enabled = 0;
    b.sigma_gamma0[0] = (caekf_scalar_t)1e-3;
    b.gamma_max[0] = BIG;
    expect_refused(&b, CAEKF_PARAM_GAMMA_MAX, CAEKF_SETTING_NOT_SCALABLE, "gamma_max / sigma_gamma0 overflows");
    b = good;
    b.sigma_gamma0[0] = BIG; /* over sigma_v0 in the scaled transition */
    expect_refused(&b, CAEKF_PARAM_SIGMA_V0, CAEKF_SETTING_NOT_SCALABLE, "sigma_gamma0 / sigma_v0 overflows");
    b = good;
    b.sigma_qx_v = HUGE_SQ;
    expect_refused(&b, CAEKF_PARAM_SIGMA_QX_V, CAEKF_SETTING_NOT_SCALABLE, "(sigma_qx_v / sigma_v0)^2 overflows");
}

#if !CAEKF_SIZED
/* Guards the ln gamma scale's rule: with gamma_log, sigma_gamma0 / gamma0 must be finite. */
static void test_log_gamma_scale_must_be_finite(void)
{
    caekf_settings_t b = good;
    caekf_setting_error_t err;
    b.constraint_enabled = 0;
    b.model.gamma_log = 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, &err));
#if CAEKF_USE_FLOAT
    b.gamma0[0] = 1e-32f;
#else
    b.gamma0[0] = 1e-305;
#endif
    expect_refused(&b, CAEKF_PARAM_SIGMA_GAMMA0, CAEKF_SETTING_NOT_SCALABLE, "sigma_gamma0 / gamma0 overflows");
}
#endif

/* Guards the scaled transition's factors rq = sigma_q0 / sigma_v0, 1 / rq and dt / rq: each one refused. */
static void test_scaled_transition_factors_must_be_finite(void)
{
    caekf_settings_t b = good;
#if CAEKF_USE_FLOAT
    b.sigma_q0 = 1e-20f;
    b.sigma_v0 = 1e37f; /* rq underflows to 0 */
#else
    b.sigma_q0 = 1e-20;
    b.sigma_v0 = 1e307;
#endif
    expect_refused(&b, CAEKF_PARAM_SIGMA_V0, CAEKF_SETTING_NOT_SCALABLE, "rq underflows");
    b = good;
#if CAEKF_USE_FLOAT
    b.sigma_v0 = 1e34f; /* rq subnormal: 1 / rq overflows */
#else
    b.sigma_v0 = 1e303;
#endif
    expect_refused(&b, CAEKF_PARAM_SIGMA_V0, CAEKF_SETTING_NOT_SCALABLE, "1 / rq overflows");
    b = good;
    b.model.dt = 1000; /* 1 / rq finite, dt / rq not */
#if CAEKF_USE_FLOAT
    b.sigma_v0 = 1e30f;
#else
    b.sigma_v0 = 1e300;
#endif
    expect_refused(&b, CAEKF_PARAM_SIGMA_V0, CAEKF_SETTING_NOT_SCALABLE, "dt / rq overflows");
}

/* Guards the references between elements: an end past the last body, a relative sensor on itself. */
static void test_references_past_the_bodies_are_refused(void)
{
    caekf_settings_t b = good;
    b.model.spring_b[0] = good.model.bodies + 1;
    expect_refused(&b, CAEKF_PARAM_SPRING_B, CAEKF_SETTING_BAD_BODY, "spring b past the last body");
    b = good;
    b.model.contact_b[0] = good.model.bodies + 1;
    expect_refused(&b, CAEKF_PARAM_CONTACT_B, CAEKF_SETTING_BAD_BODY, "contact b past the last body");
    b = good;
    b.model.sensor_kind[1] = CAEKF_SENSOR_RELATIVE;
    b.model.sensor_ref[1] = b.model.sensor_body[1];
    expect_refused(&b, CAEKF_PARAM_SENSOR_REF + 1, CAEKF_SETTING_BAD_BODY, "relative sensor against itself");
    b.model.sensor_ref[1] = good.model.bodies + 1;
    expect_refused(&b, CAEKF_PARAM_SENSOR_REF + 1, CAEKF_SETTING_BAD_BODY, "relative sensor past the last body");
}

#if !CAEKF_SIZED
/* Guards the sensor and bound rules: a velocity sensor with its own sigma needs no sigma_rv; gamma0 above
 * gamma_max is refused while constrained. */
static void test_velocity_sigma_and_gamma_max(void)
{
    caekf_settings_t b = good;
    caekf_setting_error_t err;
    b.model.sensor_kind[1] = CAEKF_SENSOR_VELOCITY;
    b.sigma_rv = 0;
    b.sensor_sigma[1] = (caekf_scalar_t)1e-6;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_OK, err.reason);
    b = good;
    b.gamma_max[0] = good.gamma0[0] / 2;
    expect_refused(&b, CAEKF_PARAM_GAMMA0, CAEKF_SETTING_BELOW_GAMMA_MIN, "gamma0 above gamma_max");
    b.constraint_enabled = 0; /* bounds are the constraint's: without it gamma0 may lie outside */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, &err));
}
#endif

#if !CAEKF_SIZED /* the helpers of the runs below, which take settings a sized build does not have */
/* Runs `s` over the truth until time t_end, every step required to succeed; returns the flags' union and
 * counts the steps in contact. */
static uint32_t run_until(const caekf_settings_t *s, double t_end, long *in_contact)
{
    truth_rec_t r;
    uint32_t all = 0;
    *in_contact = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, s));
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (truth_next(&r) == 1 && r.t < t_end) {
        caekf_report_t rep;
        const caekf_scalar_t y[2] = {(caekf_scalar_t)r.y1, (caekf_scalar_t)r.y4};
        const caekf_scalar_t u[2] = {(caekf_scalar_t)r.u, 0}; /* a second input, where there is one, at rest */
        const caekf_status_t st = caekf_step(&est, u, y, &rep);
        if (st != CAEKF_OK) {
            truth_close();
            TEST_ASSERT_EQUAL_INT_MESSAGE(CAEKF_OK, st, "a step failed");
        }
        all |= rep.flags;
        *in_contact += (rep.flags & CAEKF_FLAG_CONTACT_ACTIVE) != 0;
    }
    truth_close();
    return all;
}

/* Every state and variance of the estimator finite, every variance > 0. */
static void expect_sound_covariance(void)
{
    caekf_scalar_t var[CAEKF_N], x[CAEKF_N];
    int n, ny, nu, i;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_sizes(&est, &n, &ny, &nu));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_variances(&est, var));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, x));
    for (i = 0; i < n; ++i) {
        TEST_ASSERT_TRUE(isfinite((double)x[i]) && isfinite((double)var[i]) && var[i] > 0);
    }
}
#endif

#if !CAEKF_SIZED && CAEKF_MAX_MECH_PARAMS > 0 && CAEKF_MAX_BIASES > 0 && CAEKF_HAS_SUBSTEPS && CAEKF_HAS_SENSOR_ROWS
/* Guards the estimator's paths for a sensor offset (rows of H), an uncertain mass with substeps (its columns
 * over the substeps' product) and a measured input (its noise as Q, the mass's columns at the input's trend):
 * through contact every step succeeds, the offset stays near 0 (the truth has none) and its variance and the
 * mass's fall from their initial values. */
static void test_offset_mass_and_measured_input_through_contact(void)
{
    caekf_settings_t b = good;
    caekf_scalar_t x[CAEKF_N], var[CAEKF_N];
    long contact;
    int n, ny, nu;
    const int mass = PAPER_N; /* the mechanism's parameters follow gamma */
    b.model.sensor_bias_sigma[0] = (caekf_scalar_t)1e-5;
    b.model.m_sigma[0] = (caekf_scalar_t)0.05;
    b.input_sigma[0] = (caekf_scalar_t)1e-3;
    b.contact_substeps = 3;
    b.sensor_sigma[1] = good.sigma_r; /* its own sigma, the same value */
    (void)run_until(&b, 13.0, &contact);
    TEST_ASSERT_TRUE(contact > 0);
    expect_sound_covariance();
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_sizes(&est, &n, &ny, &nu));
    TEST_ASSERT_EQUAL_INT(PAPER_N + 2, n); /* the mass's state, then the offset's */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, x));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_variances(&est, var));
    TEST_ASSERT_TRUE(var[mass + 1] < (caekf_scalar_t)1e-10); /* offset: from (1e-5)^2 */
    TEST_ASSERT_TRUE(fabs((double)x[mass + 1]) < 3 * sqrt((double)var[mass + 1]) + 1e-7);
    TEST_ASSERT_TRUE(var[mass] < good.model.m[0] * good.model.m[0] * (caekf_scalar_t)0.0025); /* (0.05 m)^2 */
    TEST_ASSERT_FLOAT_WITHIN(0.2f * (float)good.model.m[0], (float)good.model.m[0], (float)x[mass]);
}
#endif

#if !CAEKF_SIZED && CAEKF_HAS_LAW_PARAMS
/* Guards first_unscalable_law: each scaled value of an estimated damping or gap (initial value, bounds, Q,
 * sigma0 over sigma_v0) must be finite, blamed on its sigma0. */
static void test_each_scaled_law_value_must_be_finite(void)
{
    caekf_settings_t base = good, b;
    caekf_setting_error_t err;
    base.model.contact_estimate_lambda[0] = 1;
    base.lambda0[0] = (caekf_scalar_t)0.1;
    base.sigma_lambda0[0] = (caekf_scalar_t)0.05;
    base.lambda_min[0] = 0;
    base.lambda_max[0] = 0;
    base.sigma_q_lambda[0] = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&base, &err));
    b = base;
    b.lambda0[0] = BIG;
    b.sigma_lambda0[0] = (caekf_scalar_t)1e-3;
    expect_refused(&b, CAEKF_PARAM_SIGMA_LAMBDA0, CAEKF_SETTING_NOT_SCALABLE, "lambda0 / sigma overflows");
    b = base;
    b.lambda_max[0] = BIG;
    b.sigma_lambda0[0] = (caekf_scalar_t)1e-3;
    expect_refused(&b, CAEKF_PARAM_SIGMA_LAMBDA0, CAEKF_SETTING_NOT_SCALABLE, "lambda_max / sigma overflows");
    b = base;
    b.sigma_q_lambda[0] = HUGE_SQ;
    expect_refused(&b, CAEKF_PARAM_SIGMA_LAMBDA0, CAEKF_SETTING_NOT_SCALABLE, "(sigma_q / sigma)^2 overflows");
    b = base;
    b.sigma_lambda0[0] = BIG; /* over sigma_v0 */
    expect_refused(&b, CAEKF_PARAM_SIGMA_LAMBDA0, CAEKF_SETTING_NOT_SCALABLE, "sigma_lambda0 / sigma_v0 overflows");
    b = good;
    b.model.contact_estimate_gap[0] = 1;
    b.gap0[0] = good.model.contact_gap[0];
    b.sigma_gap0[0] = (caekf_scalar_t)1e-4;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, &err));
    b.sigma_gap0[0] = BIG;
    b.gap_min[0] = 0;
    expect_refused(&b, CAEKF_PARAM_SIGMA_GAP0, CAEKF_SETTING_NOT_SCALABLE, "sigma_gap0 / sigma_v0 overflows");
}

/* Guards the bounds of estimated law parameters (bound_of for an exponent, a damping and a gap): with bounds tight around
 * their initial values, the run through contact keeps each estimate within them. */
static void test_law_parameters_stay_within_their_bounds(void)
{
    caekf_settings_t b = good;
    caekf_scalar_t g, nn, lam, gap;
    long contact;
    const caekf_scalar_t gap0 = good.model.contact_gap[0];
    b.model.contact_estimate_lambda[0] = 1;
    b.lambda0[0] = (caekf_scalar_t)0.01;
    b.sigma_lambda0[0] = (caekf_scalar_t)0.5;
    b.sigma_q_lambda[0] = (caekf_scalar_t)0.05;
    b.lambda_min[0] = (caekf_scalar_t)0.0099;
    b.lambda_max[0] = (caekf_scalar_t)0.0101;
    b.model.contact_estimate_n[0] = 1;
    b.n0[0] = good.model.contact_n[0];
    b.sigma_n0[0] = (caekf_scalar_t)0.1;
    b.sigma_q_n[0] = (caekf_scalar_t)0.01;
    b.n_min[0] = good.model.contact_n[0] * (caekf_scalar_t)0.999;
    b.n_max[0] = good.model.contact_n[0] * (caekf_scalar_t)1.001;
    b.law_second_order = 1;
    b.model.contact_estimate_gap[0] = 1;
    b.gap0[0] = gap0;
    b.sigma_gap0[0] = gap0 * (caekf_scalar_t)0.1;
    b.sigma_q_gap[0] = gap0 * (caekf_scalar_t)0.01;
    b.gap_min[0] = gap0 * (caekf_scalar_t)0.999;
    b.gap_max[0] = gap0 * (caekf_scalar_t)1.001;
    (void)run_until(&b, 20.0, &contact);
    TEST_ASSERT_TRUE(contact > 0);
    expect_sound_covariance();
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_contact_law(&est, 0, &g, &nn, &lam, &gap));
    TEST_ASSERT_TRUE(nn >= b.n_min[0] && nn <= b.n_max[0]);
    TEST_ASSERT_TRUE(lam >= b.lambda_min[0] && lam <= b.lambda_max[0]);
    TEST_ASSERT_TRUE(gap >= b.gap_min[0] && gap <= b.gap_max[0]);
    TEST_ASSERT_TRUE(g >= good.gamma_min[0]);
}
#endif

#if !CAEKF_SIZED
/* Guards ln gamma's bounds (gamma_min and gamma_max as logs) and a run without the mismatch monitor: gamma
 * stays within its bounds, the monitor never moves nor flags. */
static void test_log_gamma_within_bounds_without_monitor(void)
{
    caekf_settings_t b = good;
    caekf_scalar_t g, nis0, qs0, nis, qs;
    long contact;
    uint32_t flags;
    b.model.gamma_log = 1;
    b.gamma_max[0] = good.gamma0[0] * 4;
    b.law_second_order = 1;
    b.mismatch_window = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&copy, &b));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_mismatch(&copy, &nis0, &qs0));
    flags = run_until(&b, 20.0, &contact);
    TEST_ASSERT_TRUE(contact > 0);
    TEST_ASSERT_EQUAL_UINT32(0, flags & CAEKF_FLAG_MODEL_MISMATCH);
    expect_sound_covariance();
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_mismatch(&est, &nis, &qs));
    TEST_ASSERT_TRUE(nis == nis0 && qs == qs0);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_gamma(&est, &g));
    TEST_ASSERT_TRUE((double)g >= (double)b.gamma_min[0] * (1 - 1e-5) &&
                     (double)g <= (double)b.gamma_max[0] * (1 + 1e-5));
}
#endif

/* Guards the step's refusal of a missing input vector: CAEKF_ERR_NULL, the instance unchanged. */
static void test_a_step_without_inputs_is_refused(void)
{
    const caekf_scalar_t y[2] = {0, 0};
    caekf_report_t rep;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &good));
    memcpy(&copy, &est, sizeof est);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_step(&est, NULL, y, &rep));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_predict(&est, NULL, NULL));
    TEST_ASSERT_TRUE(memcmp(&copy, &est, sizeof est) == 0);
}

#if !CAEKF_SIZED && CAEKF_HAS_LAW_PARAMS
/* Guards bad_law_param's upper bound: an initial damping above its maximum is outside its bounds. */
static void test_law_initial_value_above_its_maximum(void)
{
    caekf_settings_t b = good;
    b.model.contact_estimate_lambda[0] = 1;
    b.lambda0[0] = (caekf_scalar_t)0.2;
    b.sigma_lambda0[0] = (caekf_scalar_t)0.05;
    b.lambda_max[0] = (caekf_scalar_t)0.1;
    expect_refused(&b, CAEKF_PARAM_LAMBDA0, CAEKF_SETTING_OUTSIDE_BOUNDS, "lambda0 above lambda_max");
}
#endif

#if !CAEKF_SIZED && CAEKF_HAS_BASE_INPUTS && CAEKF_MAX_INPUTS >= 2
/* Guards first_bad_base_input: two base inputs on the ground links are valid, on the same link refused. */
static void test_two_base_inputs_on_one_link_are_refused(void)
{
    caekf_settings_t b = good;
    caekf_setting_error_t err;
    int l, ground[2], k = 0;
    for (l = 0; l < good.model.springs && k < 2; ++l) { /* the paper's chain: k1 and k4 end on the ground */
        if (good.model.spring_a[l] == 0 || good.model.spring_b[l] == 0) {
            ground[k++] = l + 1;
        }
    }
    TEST_ASSERT_EQUAL_INT(2, k);
    b.model.inputs = 2;
    b.model.input_kind[0] = b.model.input_kind[1] = CAEKF_INPUT_BASE_DISPLACEMENT;
    b.model.input_link[0] = ground[0];
    b.model.input_link[1] = ground[1];
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, &err));
    b.model.input_link[1] = ground[0];
    expect_refused(&b, CAEKF_PARAM_INPUT_LINK + 1, CAEKF_SETTING_BAD_LINK, "two base inputs on one link");
}
#endif

#if !CAEKF_SIZED && CAEKF_HAS_SENSOR_ROWS
/* Guards caekf_model_sensor's velocity case and an acceleration in contact without estimated law parameters:
 * the velocity reads its state, the acceleration is the momentum balance over the mass (written out here). */
static void test_velocity_and_acceleration_sensor_values(void)
{
    static caekf_model_t m;
    caekf_settings_t b = good;
    caekf_scalar_t x[CAEKF_N], row[CAEKF_N], v;
    const caekf_scalar_t u[1] = {(caekf_scalar_t)0.3};
    caekf_contact_t ct;
    const int body = 1, nq = PAPER_NQ; /* body 2, in the contact */
    double force = 0, side, a;
    int i;
    b.model.sensor_kind[0] = CAEKF_SENSOR_VELOCITY;
    b.model.sensor_body[0] = 3;
    b.model.sensor_kind[1] = CAEKF_SENSOR_ACCELERATION;
    b.model.sensor_body[1] = body + 1;
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&m, &b.model));
    paper_moving_state(x, (double)good.model.contact_gap[0], 2e-6, 1.1e8);
    caekf_model_sensor(&m, &b.model, 0, x, u, u, &v, row);
    TEST_ASSERT_TRUE(v == x[nq + 2]);
    for (i = 0; i < m.n; ++i) {
        TEST_ASSERT_TRUE(row[i] == (i == nq + 2 ? 1 : 0));
    }
    for (i = 0; i < b.model.inputs; ++i) {
        force += b.model.input_body[i] - 1 == body ? (double)u[i] : 0;
    }
    for (i = 0; i < b.model.springs; ++i) {
        const int ea = b.model.spring_a[i] - 1, eb = b.model.spring_b[i] - 1;
        const double dq = (ea >= 0 ? (double)x[ea] : 0) - (eb >= 0 ? (double)x[eb] : 0);
        const double dv = (ea >= 0 ? (double)x[nq + ea] : 0) - (eb >= 0 ? (double)x[nq + eb] : 0);
        const double f = (double)b.model.spring_k[i] * dq + (double)b.model.spring_c[i] * dv;
        force += ea == body ? -f : eb == body ? f : 0;
    }
    caekf_model_contact(&m, 0, x, &ct);
    TEST_ASSERT_TRUE(ct.fc > 0);
    side = (b.model.contact_a[0] - 1 == body ? -1 : 0) + (b.model.contact_b[0] - 1 == body ? 1 : 0);
    TEST_ASSERT_TRUE(side != 0);
    force += side * (double)ct.fc;
    a = force / (double)b.model.m[body];
    caekf_model_sensor(&m, &b.model, 1, x, u, u, &v, row);
    TEST_ASSERT_DOUBLE_WITHIN(fabs(a) * (CAEKF_USE_FLOAT ? 1e-4 : 1e-10), a, (double)v);
    TEST_ASSERT_DOUBLE_WITHIN(fabs((double)ct.dfc_dgamma) * 1e-5,
                              side * (double)ct.dfc_dgamma / (double)b.model.m[body], (double)row[2 * nq]);
}
#endif

#if !CAEKF_SIZED /* a 3 x 3 P: a sized build's kernels take its own n */
/* Guards caekf_covariance_health's screen of a negative or NaN variance: flagged indefinite; without repair
 * a finite P passes on as it is and a NaN fails; with repair the bad variance's row is dropped. */
static void test_covariance_health_negative_and_nan_variances(void)
{
    caekf_scalar_t P[9], scratch[CAEKF_N * CAEKF_N];
    const caekf_scalar_t z[3] = {0, 0, 0};
    uint32_t flags = 0;
    const caekf_scalar_t id[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    memcpy(P, id, sizeof P);
    TEST_ASSERT_EQUAL_INT(1, caekf_covariance_health(P, z, 3, 1, 0, scratch, &flags));
    TEST_ASSERT_EQUAL_UINT32(0, flags);
    P[4] = -1;
    TEST_ASSERT_EQUAL_INT(1, caekf_covariance_health(P, z, 3, 0, 0, scratch, &flags));
    TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_COV_INDEFINITE, flags);
    TEST_ASSERT_TRUE(P[4] == -1); /* no repair: left as it was */
    flags = 0;
    P[4] = (caekf_scalar_t)NAN;
    TEST_ASSERT_EQUAL_INT(0, caekf_covariance_health(P, z, 3, 0, 0, scratch, &flags));
    TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_COV_INDEFINITE, flags);
    flags = 0;
    TEST_ASSERT_EQUAL_INT(1, caekf_covariance_health(P, z, 3, 0, 1, scratch, &flags));
    TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_COV_INDEFINITE | CAEKF_FLAG_COV_REPAIRED, flags);
    TEST_ASSERT_TRUE(P[4] == 0 && P[1] == 0 && P[5] == 0);
    TEST_ASSERT_FLOAT_WITHIN(1e-6f, 1.0f, (float)P[0]);
    TEST_ASSERT_FLOAT_WITHIN(1e-6f, 1.0f, (float)P[8]);
}
#endif

#if !CAEKF_SIZED
/* Guards the power law's linear case and its general (pow) case: gamma delta^n and n gamma delta^(n-1) for
 * n = 1 and n = 2, against the law written out. */
static void test_linear_and_quadratic_contact_laws(void)
{
    static caekf_model_t m;
    caekf_settings_t b = good;
    caekf_scalar_t x[CAEKF_N];
    caekf_contact_t ct;
    const double delta = 2e-6, gamma = 1.1e8;
    const double tol = CAEKF_USE_FLOAT ? 1e-4 : 1e-9;
    b.model.contact_lambda[0] = 0;
    b.model.contact_n[0] = 1;
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&m, &b.model));
    paper_moving_state(x, (double)good.model.contact_gap[0], delta, gamma);
    caekf_model_contact(&m, 0, x, &ct);
    TEST_ASSERT_DOUBLE_WITHIN(delta * tol, delta, (double)ct.delta);
    TEST_ASSERT_DOUBLE_WITHIN(gamma * delta * tol, gamma * delta, (double)ct.fc);
    TEST_ASSERT_DOUBLE_WITHIN(gamma * tol, gamma, (double)ct.dfc_ddelta);
    b.model.contact_n[0] = 2;
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&m, &b.model));
    caekf_model_contact(&m, 0, x, &ct);
    TEST_ASSERT_DOUBLE_WITHIN(gamma * delta * delta * tol, gamma * delta * delta, (double)ct.fc);
    TEST_ASSERT_DOUBLE_WITHIN(2 * gamma * delta * tol, 2 * gamma * delta, (double)ct.dfc_ddelta);
}
#endif

#if !CAEKF_SIZED && CAEKF_HAS_SLR && CAEKF_HAS_LAW_PARAMS
/* Guards the statistically linearised contact with ln gamma and an estimated gap (the penetration's std and
 * the averaged law with law states): through contact every step succeeds and gamma stays within its bounds. */
static void test_slr_contact_with_log_gamma_and_estimated_gap(void)
{
    caekf_settings_t b = good;
    caekf_scalar_t g, gap;
    long contact;
    b.contact_slr_p = (caekf_scalar_t)0.01;
    b.model.gamma_log = 1;
    b.model.contact_estimate_gap[0] = 1;
    b.gap0[0] = good.model.contact_gap[0];
    b.sigma_gap0[0] = good.model.contact_gap[0] * (caekf_scalar_t)0.01;
    b.sigma_q_gap[0] = 0;
    (void)run_until(&b, 20.0, &contact);
    TEST_ASSERT_TRUE(contact > 0);
    expect_sound_covariance();
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_contact_law(&est, 0, &g, NULL, NULL, &gap));
    TEST_ASSERT_TRUE((double)g >= (double)good.gamma_min[0] * (1 - 1e-5));
    TEST_ASSERT_TRUE(fabs((double)gap - (double)good.model.contact_gap[0]) < 0.1 * (double)good.model.contact_gap[0]);
}
#endif

#if !CAEKF_SIZED && CAEKF_MAX_MECH_PARAMS > 0 && CAEKF_MAX_INPUTS >= 2
/* Guards the measured inputs' paths with a second, exact input (no noise of its own, its samples taken as
 * they are) and with the trend off (input_trend_window 0: the mass's columns at the samples, nothing
 * tracked): every step succeeds and the uncertain mass is learnt within 20 %. */
static void test_an_exact_second_input_and_no_trend(void)
{
    caekf_settings_t b = good;
    caekf_scalar_t x[CAEKF_N];
    long contact;
    int w;
    b.model.m_sigma[0] = (caekf_scalar_t)0.05;
    b.model.inputs = 2;
    b.model.input_kind[1] = CAEKF_INPUT_FORCE;
    b.model.input_body[1] = 4;
    b.input_sigma[0] = (caekf_scalar_t)1e-3;
    b.input_sigma[1] = 0;
    for (w = 0; w < 2; ++w) {
        b.input_trend_window = w == 0 ? good.input_trend_window : 0;
        (void)run_until(&b, 13.0, &contact);
        TEST_ASSERT_TRUE(contact > 0);
        expect_sound_covariance();
        TEST_ASSERT_EQUAL_UINT32(w == 0 ? 1u : 0u, est.input_trend_known);
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, x));
        TEST_ASSERT_FLOAT_WITHIN(0.2f * (float)good.model.m[0], (float)good.model.m[0], (float)x[PAPER_N]);
    }
}
#endif

#if !CAEKF_SIZED && CAEKF_HAS_SENSOR_ROWS && CAEKF_HAS_BASE_INPUTS && CAEKF_MAX_INPUTS >= 2
/* Guards an acceleration sensor's R (docs/sensors.md): 1 plus each input's noise on its body read through
 * 1 / m, a measured force's sigma as it is and a base displacement's through (k + c/dt, -c/dt) of its link;
 * inputs on other bodies add nothing. */
static void test_acceleration_sensor_noise_takes_the_inputs_on_its_body(void)
{
    caekf_settings_t b = good;
    const double sa = 0.1, su = 0.01, sb = 1e-6;
    double k = 0, c = 0, gain, want;
    int l, link = 0;
    for (l = 0; l < good.model.springs; ++l) { /* the link from the ground to body 1 */
        if ((good.model.spring_a[l] == 0 && good.model.spring_b[l] == 1) ||
            (good.model.spring_b[l] == 0 && good.model.spring_a[l] == 1)) {
            link = l + 1;
            k = (double)good.model.spring_k[l];
            c = (double)good.model.spring_c[l];
        }
    }
    TEST_ASSERT_TRUE(link > 0);
    TEST_ASSERT_EQUAL_INT(1, good.model.input_body[0]); /* the paper's force drives body 1 */
    b.model.sensor_kind[0] = CAEKF_SENSOR_ACCELERATION; /* body 1 */
    b.model.sensor_body[0] = 1;
    b.sensor_sigma[0] = (caekf_scalar_t)sa;
    b.model.sensor_kind[1] = CAEKF_SENSOR_ACCELERATION; /* body 4: no input there */
    b.model.sensor_body[1] = 4;
    b.sensor_sigma[1] = (caekf_scalar_t)sa;
    b.input_sigma[0] = (caekf_scalar_t)su;
    b.model.inputs = 2;
    b.model.input_kind[1] = CAEKF_INPUT_BASE_DISPLACEMENT;
    b.model.input_link[1] = link;
    b.input_sigma[1] = (caekf_scalar_t)sb;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &b));
    TEST_ASSERT_EQUAL_INT(1, est.dims.rows);
    gain = sqrt((k + c / (double)good.model.dt) * (k + c / (double)good.model.dt) +
                (c / (double)good.model.dt) * (c / (double)good.model.dt));
    want = 1 + (su / (double)good.model.m[0] / sa) * (su / (double)good.model.m[0] / sa) +
           (gain * sb / (double)good.model.m[0] / sa) * (gain * sb / (double)good.model.m[0] / sa);
    TEST_ASSERT_DOUBLE_WITHIN(want * (CAEKF_USE_FLOAT ? 1e-5 : 1e-12), want, (double)est.dims.r[0]);
    TEST_ASSERT_TRUE(est.dims.r[1] == 1);
}
#endif

/* Guards the model's own defence (caekf_model_init): a spring past the last body and two base inputs on one
 * link are refused by the model too, not only by validation. */
static void test_the_model_refuses_bad_references_itself(void)
{
    static caekf_model_t m;
    caekf_settings_t b = good;
    b.model.spring_b[0] = good.model.bodies + 1;
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_init(&m, &b.model));
#if !CAEKF_SIZED && CAEKF_HAS_BASE_INPUTS && CAEKF_MAX_INPUTS >= 2
    b = good;
    b.model.inputs = 2;
    b.model.input_kind[0] = b.model.input_kind[1] = CAEKF_INPUT_BASE_DISPLACEMENT;
    b.model.input_link[0] = b.model.input_link[1] = 1;
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_init(&m, &b.model));
#endif
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&m, &good.model));
}

/* A value near `from` whose quotient by s, times s again, rounds below it (below < 0) or above it. */
static caekf_scalar_t rounding_off(caekf_scalar_t from, caekf_scalar_t s, int below)
{
    volatile caekf_scalar_t v = from, q; /* volatile: each operation rounded to the scalar type */
    int i;
    for (i = 0; i < 100000; ++i, v = v + from * (caekf_scalar_t)1.2345678e-7) {
        q = v / s;
        q = q * s;
        if (below ? q < v : q > v) {
            return v;
        }
    }
    TEST_FAIL_MESSAGE("no value whose scaling rounds that way");
    return 0;
}

/* Guards set_bounds' correction of a scaled bound that rounding moved outside: with gamma_min and gamma_max
 * whose quotient by sigma_gamma0 rounds outwards, and gamma0 on either bound, gamma reads back within both. */
static void test_scaled_gamma_bounds_read_back_within_the_bounds(void)
{
    caekf_settings_t b = good;
    caekf_scalar_t g;
    const caekf_scalar_t s = good.sigma_gamma0[0];
    int side;
    b.gamma_min[0] = rounding_off(good.gamma_min[0], s, 1);
    b.gamma_max[0] = rounding_off(good.gamma0[0] * (caekf_scalar_t)1.73, s, 0);
    TEST_ASSERT_TRUE(b.gamma_min[0] / s * s < b.gamma_min[0] && b.gamma_max[0] / s * s > b.gamma_max[0]);
    for (side = 0; side < 2; ++side) {
        b.gamma0[0] = side == 0 ? b.gamma_min[0] : b.gamma_max[0];
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &b));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_gamma(&est, &g));
        TEST_ASSERT_TRUE(g >= b.gamma_min[0] && g <= b.gamma_max[0]);
        TEST_ASSERT_TRUE(est.lo_scaled[0] * s >= b.gamma_min[0] && est.hi_scaled[0] * s <= b.gamma_max[0]);
    }
}

#if !CAEKF_SIZED /* a 3 x 3 P: a sized build's kernels take its own n */
/* Guards caekf_constrain_upper: the perfect measurement onto a bound whose scaled value rounds outside it
 * (z_g times its scale lands within the physical bound after the ulp steps, row and column g zeroed, the
 * correlated state moved), either bound; a bound not violated changes nothing; a zero variance clamps only. */
static void test_constrain_onto_a_bound_that_rounds_outwards(void)
{
    const caekf_scalar_t s = good.sigma_gamma0[0];
    int is_max;
    for (is_max = 0; is_max < 2; ++is_max) {
        const caekf_scalar_t bound =
            is_max ? rounding_off(good.gamma0[0] * (caekf_scalar_t)1.73, s, 0) : rounding_off(good.gamma_min[0], s, 1);
        const caekf_scalar_t zb = bound / s; /* rounds outwards: zb * s is outside the bound */
        caekf_scalar_t P[9] = {1, 0, (caekf_scalar_t)0.5, 0, 1, 0, 0, 0, 1}; /* upper triangle, g = 2 */
        caekf_scalar_t z[3] = {0, 0, 0}, before[3];
        uint32_t flags = 0;
        z[2] = is_max ? zb + 1 : zb - 1;
        memcpy(before, z, sizeof z);
        TEST_ASSERT_TRUE(is_max ? zb * s > bound : zb * s < bound);
        TEST_ASSERT_EQUAL_INT(1, caekf_constrain_upper(z, P, 3, 2, zb, is_max, s, bound, &flags));
        TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_CONSTRAINT_APPLIED, flags);
        TEST_ASSERT_TRUE(is_max ? z[2] * s <= bound : z[2] * s >= bound);
        TEST_ASSERT_TRUE(P[2] == 0 && P[5] == 0 && P[8] == 0);
        TEST_ASSERT_FLOAT_WITHIN(1e-6f, 0.75f, (float)P[0]);                                             /* 1 - 0.5^2 */
        TEST_ASSERT_FLOAT_WITHIN(1e-6f, (float)before[0] + 0.5f * (is_max ? -1.0f : 1.0f), (float)z[0]); /* 0.5 dz */
        TEST_ASSERT_TRUE(z[1] == 0);
        flags = 0; /* already on the bound: nothing to do */
        TEST_ASSERT_EQUAL_INT(0, caekf_constrain_upper(z, P, 3, 2, z[2], is_max, s, bound, &flags));
        TEST_ASSERT_EQUAL_UINT32(0, flags);
        z[2] = is_max ? zb + 1 : zb - 1; /* P_gg now 0: clamped, the rest left alone */
        memcpy(before, z, sizeof z);
        TEST_ASSERT_EQUAL_INT(1, caekf_constrain_upper(z, P, 3, 2, zb, is_max, s, bound, &flags));
        TEST_ASSERT_EQUAL_UINT32(
            CAEKF_FLAG_CONSTRAINT_APPLIED | CAEKF_FLAG_CONSTRAINT_CLAMPED | CAEKF_FLAG_SINGULAR_INNOVATION, flags);
        TEST_ASSERT_TRUE(z[0] == before[0] && (is_max ? z[2] * s <= bound : z[2] * s >= bound));
    }
}
#endif

#if !CAEKF_SIZED && CAEKF_LA_GENERAL_LU && CAEKF_MAX_SENSORS >= 3
/* Guards the innovation covariance's refusals with three sensors (the LU path): two exact sensors of one state
 * (S singular) and an exact sensor of a state with no variance (S_kk = 0): SINGULAR_INNOVATION, -1, and the
 * state and P left as they were. */
static void test_three_sensor_innovation_refusals(void)
{
    static paper_mat_t P, P0;
    static caekf_correct_work_t work;
    caekf_filter_dims_t d;
    caekf_scalar_t z[PAPER_N], z0[PAPER_N], nis = 42;
    const caekf_scalar_t y[3] = {(caekf_scalar_t)0.1, (caekf_scalar_t)0.2, (caekf_scalar_t)0.3};
    int i, j, c;
    for (c = 0; c < 2; ++c) {
        uint32_t flags = 0;
        test_spd_matrix(P);
        paper_filter_dims(&d, 0, CAEKF_GAMMA_LIVE);
        d.ny = 3;
        d.r[2] = 0;
        if (c == 0) {
            d.h[2] = PAPER_IY1; /* a second exact reading of q1 */
        } else {
            d.h[2] = 5; /* v2, its variance zeroed */
            for (i = 0; i < PAPER_N; ++i) {
                P[5][i] = P[i][5] = 0;
            }
        }
        for (i = 0; i < PAPER_N; ++i) {
            z[i] = z0[i] = (caekf_scalar_t)i;
            for (j = 0; j < PAPER_N; ++j) {
                P0[i][j] = P[i][j];
            }
        }
        TEST_ASSERT_EQUAL_INT(-1, caekf_correct_upper(z, &P[0][0], y, 0, &d, 0, &nis, &flags, &work));
        TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_SINGULAR_INNOVATION, flags);
        TEST_ASSERT_TRUE(memcmp(z, z0, sizeof z) == 0 && memcmp(P, P0, sizeof P) == 0);
    }
    /* the same three sensors with noise: accepted, a finite NIS */
    {
        uint32_t flags = 0;
        test_spd_matrix(P);
        paper_filter_dims(&d, 1, CAEKF_GAMMA_LIVE);
        d.ny = 3;
        d.h[2] = 5;
        d.r[2] = 1;
        TEST_ASSERT_EQUAL_INT(0, caekf_correct_upper(z, &P[0][0], y, 0, &d, 0, &nis, &flags, &work));
        TEST_ASSERT_TRUE(nis > 0 && isfinite((double)nis));
    }
}
#endif

#if !CAEKF_SIZED && CAEKF_MAX_CONTACTS >= 2 && CAEKF_MAX_MECH_PARAMS > 0 && CAEKF_HAS_SLR
/* Guards a contact with the ground (body 4 against a stop at the ground, the ground's end -1 in every sum):
 * with ln gamma, its second-order term, the statistically linearised law, substeps and an uncertain mass
 * of body 4, the run over the whole record succeeds step by step, and as the truth has no such stop its
 * gamma is driven onto its minimum (there with zero variance, a constrained parameter's). */
static void test_a_contact_with_the_ground(void)
{
    caekf_settings_t b = good;
    caekf_scalar_t var[CAEKF_N], x[CAEKF_N], g;
    long contact;
    int n, ny, nu, i;
    b.model.contacts = 2;
    b.model.contact_a[1] = 4;
    b.model.contact_b[1] = 0;
    b.model.contact_gap[1] = (caekf_scalar_t)3.0e-5;
    b.model.contact_n[1] = good.model.contact_n[0];
    b.gamma0[1] = (caekf_scalar_t)1e7;
    b.sigma_gamma0[1] = (caekf_scalar_t)1e7;
    b.sigma_q_gamma[1] = (caekf_scalar_t)1e5;
    b.gamma_min[1] = (caekf_scalar_t)1e5;
    b.model.gamma_log = 1;
    b.law_second_order = 1;
    b.contact_slr_p = (caekf_scalar_t)0.01;
    b.model.m_sigma[3] = (caekf_scalar_t)0.05;
    (void)run_until(&b, 60.0, &contact);
    TEST_ASSERT_TRUE(contact > 0);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_sizes(&est, &n, &ny, &nu));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_variances(&est, var));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, x));
    for (i = 0; i < n; ++i) {
        TEST_ASSERT_TRUE(isfinite((double)x[i]) && isfinite((double)var[i]) && var[i] >= 0);
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_contact_law(&est, 1, &g, NULL, NULL, NULL));
    TEST_ASSERT_DOUBLE_WITHIN(1e5 * 1e-3, 1e5, (double)g);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_gamma(&est, &g)); /* the paper's contact: still stiff */
    TEST_ASSERT_TRUE((double)g > (double)good.gamma_min[0]);
}
#endif

#if CAEKF_HAS_SETTING_TEXT
/* Guards caekf_setting_error_text: NULL refusals, an unknown id, every reason's sentence, an unnamed
 * setting, no value without the settings. */
static void test_every_refusal_reason_has_its_text(void)
{
    static const struct {
        unsigned reason;
        const char *words;
    } reasons[] = {
        {CAEKF_SETTING_BELOW_GAMMA_MIN, "gamma_min .. gamma_max"},
        {CAEKF_SETTING_NOT_SCALABLE, "not finite in"},
        {CAEKF_SETTING_OVER_CAPACITY, "capacity"},
        {CAEKF_SETTING_NOT_INTEGER, "must be an integer"},
        {CAEKF_SETTING_NEEDED, "the settings use it"},
        {CAEKF_SETTING_NOT_POSITIVE, "with gamma_log"},
        {CAEKF_SETTING_OUTSIDE_BOUNDS, "bounds"},
        {CAEKF_SETTING_BAD_BODY, "must name a body"},
        {CAEKF_SETTING_BAD_LINK, "base_displacement"},
        {CAEKF_SETTING_UNSUPPORTED, "sized for another"},
    };
    caekf_setting_error_t err;
    char text[300];
    unsigned k;
    memset(&err, 0, sizeof err);
    memset(text, 'x', sizeof text);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_setting_error_text(NULL, &good, text, sizeof text));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_setting_error_text(&err, &good, NULL, sizeof text));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_setting_error_text(&err, &good, text, 0));
    TEST_ASSERT_TRUE(text[0] == 'x');
    err.reason = CAEKF_SETTING_UNKNOWN_ID;
    err.param_id = 250;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_error_text(&err, &good, text, sizeof text));
    TEST_ASSERT_EQUAL_STRING("parameter id 250: no such setting", text);
    err.reason = CAEKF_SETTING_OK;
    err.param_id = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_error_text(&err, &good, text, sizeof text));
    TEST_ASSERT_EQUAL_STRING("settings valid", text);
    for (k = 0; k < sizeof reasons / sizeof reasons[0]; ++k) {
        err.reason = (uint8_t)reasons[k].reason;
        err.param_id = CAEKF_PARAM_DT;
        err.setting = 0; /* dt */
        err.index = 0;
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_error_text(&err, NULL, text, sizeof text));
        TEST_ASSERT_NOT_NULL_MESSAGE(strstr(text, reasons[k].words), text);
        TEST_ASSERT_EQUAL_INT_MESSAGE(0, strncmp(text, "dt: ", 4), text); /* no settings: no value */
    }
    /* A setting the table does not have: named "?", its rule unknown. */
    err.reason = CAEKF_SETTING_OUT_OF_RANGE;
    err.setting = CAEKF_SETTING_COUNT;
    err.param_id = CAEKF_PARAM_COUNT;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_error_text(&err, &good, text, sizeof text));
    TEST_ASSERT_EQUAL_STRING("?: refused", text);
    /* A short buffer is still terminated. */
    err.reason = CAEKF_SETTING_BAD_BODY;
    err.setting = 0;
    err.param_id = CAEKF_PARAM_DT;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_error_text(&err, &good, text, 5));
    TEST_ASSERT_EQUAL_STRING("dt =", text);
}
#endif

/* Guards caekf_sym2_inverse's refusals (non-positive diagonal, NaN, near-singular) and its result. */
static void test_sym2_inverse_refuses_singular_and_non_finite(void)
{
    const caekf_scalar_t nan = (caekf_scalar_t)NAN, tol = (caekf_scalar_t)1e-6;
    caekf_scalar_t inv[3] = {7, 7, 7};
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse(0, 0, 1, tol, inv));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse(1, 0, 0, tol, inv));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse(1, 0, -1, tol, inv));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse(nan, 0, 1, tol, inv));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse(1, 0, nan, tol, inv));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse(1, 1, 1, tol, inv)); /* det 0 */
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse(1, nan, 1, tol, inv));
    TEST_ASSERT_TRUE(inv[0] == 7 && inv[1] == 7 && inv[2] == 7);
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_sym2_inverse(2, 1, 3, tol, inv)); /* det 5 */
    TEST_ASSERT_FLOAT_WITHIN(1e-6f, 0.6f, (float)inv[0]);
    TEST_ASSERT_FLOAT_WITHIN(1e-6f, -0.2f, (float)inv[1]);
    TEST_ASSERT_FLOAT_WITHIN(1e-6f, 0.4f, (float)inv[2]);
}

/* Guards the size checks of every linear-algebra entry point: n = 0 and n past CAEKF_LA_MAX_N refused. */
static void test_linalg_refuses_bad_sizes(void)
{
    static caekf_scalar_t a[(CAEKF_LA_MAX_N + 1) * (CAEKF_LA_MAX_N + 1)],
        w[(CAEKF_LA_MAX_N + 1) * (CAEKF_LA_MAX_N + 1)];
    int piv[CAEKF_LA_MAX_N + 1];
    caekf_scalar_t norm = 42;
    const int sizes[2] = {0, CAEKF_LA_MAX_N + 1};
    int k;
    for (k = 0; k < 2; ++k) {
        const int n = sizes[k];
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_psd_check(a, n, (caekf_scalar_t)1e-9, w));
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_sym_eigen(a, n, w));
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_sym_norm2(a, n, w, &norm));
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_psd_repair(a, n, w));
#if CAEKF_LA_GENERAL_LU
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_lu_factor_tol(a, n, piv, (caekf_scalar_t)1e-12));
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_lu_solve(a, n, piv, w, 1, 1));
#endif
    }
#if CAEKF_LA_GENERAL_LU
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_lu_solve(a, 2, piv, w, 0, 1)); /* no right-hand side */
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_lu_solve(a, 2, piv, w, 2, 1)); /* ldb < nrhs */
#endif
    (void)piv;
    TEST_ASSERT_TRUE(norm == 42);
}

/* Guards caekf_psd_check's refusals of a NaN or infinite variance and the pivots of a 3x3 case. */
static void test_psd_check_refuses_non_finite_and_indefinite(void)
{
    caekf_scalar_t w[9];
    const caekf_scalar_t tol = (caekf_scalar_t)1e-9;
    caekf_scalar_t a[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_check(a, 3, tol, w));
    a[4] = (caekf_scalar_t)NAN;
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(a, 3, tol, w));
    a[4] = (caekf_scalar_t)INFINITY;
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(a, 3, tol, w));
    a[4] = -1;
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(a, 3, tol, w));
    /* a zero variance with a coupling left: not PSD; without: PSD */
    {
        caekf_scalar_t z[9] = {0, 0, 0, 0, 1, 0, 0, 0, 1};
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_check(z, 3, tol, w));
        z[1] = z[3] = (caekf_scalar_t)0.5;
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(z, 3, tol, w));
    }
    /* correlation above one: a negative pivot */
    {
        caekf_scalar_t c[9] = {1, 2, 0, 2, 1, 0, 0, 0, 1};
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(c, 3, tol, w));
    }
}

/* Guards caekf_psd_repair's dropping of an infinite or NaN variance: that row and column become zero, the
 * others keep their variances. */
static void test_psd_repair_drops_non_finite_variances(void)
{
    caekf_scalar_t v[9];
    caekf_scalar_t a[9] = {4, 0, 0, 0, (caekf_scalar_t)INFINITY, 0, 0, 0, 9};
    int k;
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_repair(a, 3, v));
    for (k = 0; k < 3; ++k) {
        TEST_ASSERT_TRUE(a[1 * 3 + k] == 0 && a[k * 3 + 1] == 0);
    }
    TEST_ASSERT_FLOAT_WITHIN(1e-5f, 4.0f, (float)a[0]);
    TEST_ASSERT_FLOAT_WITHIN(1e-5f, 9.0f, (float)a[8]);
    a[4] = (caekf_scalar_t)NAN;
    a[0] = 4;
    a[8] = 9;
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_repair(a, 3, v));
    TEST_ASSERT_TRUE(a[4] == 0 && a[1] == 0 && a[7] == 0);
    TEST_ASSERT_FLOAT_WITHIN(1e-5f, 9.0f, (float)a[8]);
}

#if CAEKF_LA_LU4
/* Guards the 4x4 LU's exchange of the first pivot when a lower row of column 0 is larger (a[8], a[12]):
 * the factors solve the system. */
static void test_lu4_pivots_from_rows_three_and_four(void)
{
    int r;
    for (r = 2; r < 4; ++r) {
        caekf_scalar_t a[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
        caekf_scalar_t b[4] = {1, 2, 3, 4};
        int piv[4];
        a[r * 4 + 0] = 5; /* column 0 largest in row r */
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_lu4_factor_tol(a, piv, (caekf_scalar_t)1e-12));
        TEST_ASSERT_EQUAL_INT(r, piv[0]);
        caekf_lu4_solve(a, piv, b, 1, 1);
        /* x0 = 1, x_r = b_r - 5 x0 */
        TEST_ASSERT_FLOAT_WITHIN(1e-6f, 1.0f, (float)b[0]);
        TEST_ASSERT_FLOAT_WITHIN(1e-6f, (float)(r + 1 - 5), (float)b[r]);
    }
}
#endif

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_accessors_refuse_null_uninitialised_and_bad_contact);
    RUN_TEST(test_accessors_fill_only_the_outputs_given);
    RUN_TEST(test_settings_api_refuses_null_and_unknown_ids);
    RUN_TEST(test_each_scaled_state_value_must_be_finite);
#if !CAEKF_SIZED
    RUN_TEST(test_log_gamma_scale_must_be_finite);
#endif
    RUN_TEST(test_scaled_transition_factors_must_be_finite);
    RUN_TEST(test_references_past_the_bodies_are_refused);
#if !CAEKF_SIZED
    RUN_TEST(test_velocity_sigma_and_gamma_max);
#endif
#if !CAEKF_SIZED && CAEKF_MAX_MECH_PARAMS > 0 && CAEKF_MAX_BIASES > 0 && CAEKF_HAS_SUBSTEPS && CAEKF_HAS_SENSOR_ROWS
    RUN_TEST(test_offset_mass_and_measured_input_through_contact);
#endif
#if !CAEKF_SIZED && CAEKF_HAS_LAW_PARAMS
    RUN_TEST(test_each_scaled_law_value_must_be_finite);
    RUN_TEST(test_law_parameters_stay_within_their_bounds);
#endif
#if !CAEKF_SIZED
    RUN_TEST(test_log_gamma_within_bounds_without_monitor);
#endif
    RUN_TEST(test_a_step_without_inputs_is_refused);
#if !CAEKF_SIZED && CAEKF_HAS_LAW_PARAMS
    RUN_TEST(test_law_initial_value_above_its_maximum);
#endif
#if !CAEKF_SIZED && CAEKF_HAS_BASE_INPUTS && CAEKF_MAX_INPUTS >= 2
    RUN_TEST(test_two_base_inputs_on_one_link_are_refused);
#endif
#if !CAEKF_SIZED && CAEKF_HAS_SENSOR_ROWS
    RUN_TEST(test_velocity_and_acceleration_sensor_values);
#endif
#if !CAEKF_SIZED
    RUN_TEST(test_covariance_health_negative_and_nan_variances);
#endif
#if !CAEKF_SIZED && CAEKF_HAS_SENSOR_ROWS && CAEKF_HAS_BASE_INPUTS && CAEKF_MAX_INPUTS >= 2
    RUN_TEST(test_acceleration_sensor_noise_takes_the_inputs_on_its_body);
#endif
    RUN_TEST(test_the_model_refuses_bad_references_itself);
    RUN_TEST(test_scaled_gamma_bounds_read_back_within_the_bounds);
#if !CAEKF_SIZED
    RUN_TEST(test_constrain_onto_a_bound_that_rounds_outwards);
#endif
#if !CAEKF_SIZED && CAEKF_MAX_CONTACTS >= 2 && CAEKF_MAX_MECH_PARAMS > 0 && CAEKF_HAS_SLR
    RUN_TEST(test_a_contact_with_the_ground);
#endif
#if !CAEKF_SIZED && CAEKF_LA_GENERAL_LU && CAEKF_MAX_SENSORS >= 3
    RUN_TEST(test_three_sensor_innovation_refusals);
#endif
#if !CAEKF_SIZED && CAEKF_MAX_MECH_PARAMS > 0 && CAEKF_MAX_INPUTS >= 2
    RUN_TEST(test_an_exact_second_input_and_no_trend);
#endif
#if !CAEKF_SIZED
    RUN_TEST(test_linear_and_quadratic_contact_laws);
#endif
#if !CAEKF_SIZED && CAEKF_HAS_SLR && CAEKF_HAS_LAW_PARAMS
    RUN_TEST(test_slr_contact_with_log_gamma_and_estimated_gap);
#endif
#if CAEKF_HAS_SETTING_TEXT
    RUN_TEST(test_every_refusal_reason_has_its_text);
#endif
    RUN_TEST(test_sym2_inverse_refuses_singular_and_non_finite);
    RUN_TEST(test_linalg_refuses_bad_sizes);
    RUN_TEST(test_psd_check_refuses_non_finite_and_indefinite);
    RUN_TEST(test_psd_repair_drops_non_finite_variances);
#if CAEKF_LA_LU4
    RUN_TEST(test_lu4_pivots_from_rows_three_and_four);
#endif
    return UNITY_END();
}
