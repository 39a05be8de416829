/* Bad inputs never corrupt the estimator: non-finite u or y is rejected with the whole instance
 * unchanged byte for byte; bad settings are refused and leave the instance as it was. */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "test_support.h"
#include "unity.h"

static caekf_t est, copy;
static caekf_settings_t good;

void setUp(void) { paper_settings(&good, EXP_SWITCHED_HIGHQ_CONSTRAINED); }
void tearDown(void) {}

/* Runs the scenario to t = 13 s (inside the first contact episode) so the state is non-trivial. */
static void run_into_contact(void)
{
    truth_rec_t r;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &good));
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (truth_next(&r) == 1 && r.t < 13.0) {
        caekf_scalar_t y[2];
        y[0] = (caekf_scalar_t)r.y1;
        y[1] = (caekf_scalar_t)r.y4;
        (void)caekf_step(&est, (const caekf_scalar_t[]){(caekf_scalar_t)r.u}, y, NULL);
    }
    truth_close();
    TEST_ASSERT_TRUE(EST_P(&est, PAPER_IG, PAPER_IG) != 1); /* moved away from P0 */
}

static void expect_rejected(caekf_scalar_t u, caekf_scalar_t y1, caekf_scalar_t y4)
{
    caekf_scalar_t y[2];
    caekf_report_t rep;
    y[0] = y1;
    y[1] = y4;
    memcpy(&copy, &est, sizeof est);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_INPUT, caekf_step(&est, (const caekf_scalar_t[]){u}, y, &rep));
    TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_INPUT_REJECTED, rep.flags);
    TEST_ASSERT_TRUE_MESSAGE(memcmp(&copy, &est, sizeof est) == 0, "state changed by a rejected input");
}

static void test_non_finite_inputs_are_rejected_and_change_nothing(void)
{
    const caekf_scalar_t nan = (caekf_scalar_t)NAN, inf = (caekf_scalar_t)INFINITY;
    caekf_scalar_t y[2] = {0, 0};
    run_into_contact();
    expect_rejected(nan, 0, 0);
    expect_rejected(inf, 0, 0);
    expect_rejected(-inf, 0, 0);
    expect_rejected(0, nan, 0);
    expect_rejected(0, 0, inf);
    expect_rejected(0, -inf, nan);
    /* ... and the estimator carries on normally afterwards. */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, (const caekf_scalar_t[]){0}, y, NULL));
}

static void test_null_and_uninitialised(void)
{
    caekf_t blank;
    caekf_scalar_t y[2] = {0, 0}, g;
    memset(&blank, 0, sizeof blank);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_step(&blank, (const caekf_scalar_t[]){0}, y, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_get_gamma(&blank, &g));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_step(NULL, (const caekf_scalar_t[]){0}, y, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_step(&blank, (const caekf_scalar_t[]){0}, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_init(NULL, &good));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_init(&blank, NULL));
}

/* Each mutation must be refused, naming the right element, and leave a running estimator byte-for-byte
 * as it was. */
static void expect_refused(caekf_settings_t *bad, unsigned param_id, unsigned reason, const char *what)
{
    caekf_setting_error_t err;
    memcpy(&copy, &est, sizeof est);
    TEST_ASSERT_EQUAL_INT_MESSAGE(CAEKF_ERR_SETTINGS, caekf_init(&est, bad), what);
    TEST_ASSERT_TRUE_MESSAGE(memcmp(&copy, &est, sizeof est) == 0, what);
    TEST_ASSERT_EQUAL_INT_MESSAGE(CAEKF_ERR_SETTINGS, caekf_settings_validate(bad, &err), what);
    TEST_ASSERT_EQUAL_UINT_MESSAGE(param_id, err.param_id, what);
    TEST_ASSERT_EQUAL_UINT_MESSAGE(reason, err.reason, what);
}

/* A refused element of the model is refused by the model itself too (caekf_model_init's own defence). */
static void expect_model_refuses(const caekf_settings_t *bad, size_t offset, const char *what)
{
    caekf_model_t m;
    if (offset < sizeof bad->model) {
        TEST_ASSERT_EQUAL_INT_MESSAGE(-1, caekf_model_init(&m, &bad->model), what);
    }
}

#define REFUSE(field, value, param_id)                                                    \
    do {                                                                                  \
        caekf_settings_t b = good;                                                        \
        b.field = value;                                                                  \
        expect_refused(&b, (param_id), CAEKF_SETTING_OUT_OF_RANGE, #field " = " #value);  \
        expect_model_refuses(&b, offsetof(caekf_settings_t, field), #field " = " #value); \
    } while (0)

static void test_bad_settings_are_refused(void)
{
    const caekf_scalar_t nan = (caekf_scalar_t)NAN, inf = (caekf_scalar_t)INFINITY;
    run_into_contact();
    REFUSE(model.dt, 0, CAEKF_PARAM_DT);
    REFUSE(model.dt, -1e-3f, CAEKF_PARAM_DT);
    REFUSE(model.dt, nan, CAEKF_PARAM_DT);
    REFUSE(model.m[2], -1, CAEKF_PARAM_M + 2);
    REFUSE(model.m[0], 0, CAEKF_PARAM_M);
    REFUSE(model.spring_k[1], -1, CAEKF_PARAM_SPRING_K + 1);
    REFUSE(model.spring_k[3], inf, CAEKF_PARAM_SPRING_K + 3);
    REFUSE(model.spring_c[2], -5, CAEKF_PARAM_SPRING_C + 2);
    REFUSE(model.contact_gap[0], nan, CAEKF_PARAM_CONTACT_GAP);
    REFUSE(model.contact_n[0], (caekf_scalar_t)0.5, CAEKF_PARAM_CONTACT_N);
    REFUSE(model.spring_b[1], 9, CAEKF_PARAM_SPRING_B + 1);
    REFUSE(model.bodies, 0, CAEKF_PARAM_BODIES);
    REFUSE(q0[1], inf, CAEKF_PARAM_Q0 + 1);
    REFUSE(v0[3], nan, CAEKF_PARAM_V0 + 3);
    REFUSE(gamma0[0], nan, CAEKF_PARAM_GAMMA0);
    REFUSE(sigma_q0, 0, CAEKF_PARAM_SIGMA_Q0);
    REFUSE(sigma_gamma0[0], -1, CAEKF_PARAM_SIGMA_GAMMA0);
    REFUSE(sigma_r, 0, CAEKF_PARAM_SIGMA_R);
    REFUSE(sigma_q_gamma[0], -1, CAEKF_PARAM_SIGMA_Q_GAMMA);
    REFUSE(q_gamma_scale, nan, CAEKF_PARAM_Q_GAMMA_SCALE);
    REFUSE(mode, 7, CAEKF_PARAM_MODE);
    REFUSE(switchoff, -1, CAEKF_PARAM_SWITCHOFF);
    REFUSE(cov_update, 2, CAEKF_PARAM_COV_UPDATE);
    REFUSE(constraint_enabled, 2, CAEKF_PARAM_CONSTRAINT_ENABLED);
    REFUSE(cov_repair_enabled, -1, CAEKF_PARAM_COV_REPAIR_ENABLED);
    REFUSE(psd_check_period, 0, CAEKF_PARAM_PSD_CHECK_PERIOD);
    REFUSE(newton_max_iter, 0, CAEKF_PARAM_NEWTON_MAX_ITER);
    REFUSE(newton_rtol, 1, CAEKF_PARAM_NEWTON_RTOL);
    REFUSE(newton_rtol, 0, CAEKF_PARAM_NEWTON_RTOL);
    REFUSE(gamma_gate_nis, -1, CAEKF_PARAM_GAMMA_GATE_NIS);
    REFUSE(gamma_gate_nis, nan, CAEKF_PARAM_GAMMA_GATE_NIS);
    {
        caekf_settings_t b = good;
        b.gamma_min[0] = (caekf_scalar_t)1e9; /* above gamma0 with the constraint on */
        expect_refused(&b, CAEKF_PARAM_GAMMA0, CAEKF_SETTING_BELOW_GAMMA_MIN, "gamma0 < gamma_min");
    }
    /* Finite settings whose scaled values overflow or underflow in this scalar type (fuzz findings). */
    {
        caekf_settings_t b = good;
#if CAEKF_USE_FLOAT
        b.sigma_q0 = 1e-22f;
        b.sigma_qx_q = 1e22f;
#else
        b.sigma_q0 = 1e-300;
        b.sigma_qx_q = 1e10;
#endif
        expect_refused(&b, CAEKF_PARAM_SIGMA_QX_Q, CAEKF_SETTING_NOT_SCALABLE, "Q ratio overflows");
        b = good;
#if CAEKF_USE_FLOAT
        b.sigma_r = 1e-22f;
        b.sigma_q0 = 1e3f; /* (sigma_r / sigma_q0)^2 underflows to 0: R would vanish */
#else
        b.sigma_r = 1e-200;
        b.sigma_q0 = 1e3;
#endif
        expect_refused(&b, CAEKF_PARAM_SIGMA_R, CAEKF_SETTING_NOT_SCALABLE, "R underflows");
        b = good;
#if CAEKF_USE_FLOAT
        b.sigma_v0 = 1e-22f;
        b.v0[0] = 1e20f;
        expect_refused(&b, CAEKF_PARAM_V0, CAEKF_SETTING_NOT_SCALABLE, "scaled state overflows");
#else
        b.sigma_gamma0[0] = 1.9e-318; /* subnormal: gamma0 / sigma_gamma0 overflows */
        expect_refused(&b, CAEKF_PARAM_GAMMA0, CAEKF_SETTING_NOT_SCALABLE, "scaled state overflows");
#endif
    }
    /* gamma_min above gamma0 is fine when the constraint is off. */
    {
        caekf_settings_t b = good;
        b.constraint_enabled = 0;
        b.gamma_min[0] = (caekf_scalar_t)1e9;
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, NULL));
    }
}

/* The mechanism's references name bodies it has (a body past the last is refused, naming the element), and
 * the derived values that multiply two settings are checked as products (k dt, (sigma_q_gamma / sigma_gamma0)^2
 * q_gamma_scale): finite each, refused once the product overflows. */
static void test_bodies_referenced_and_products_of_settings(void)
{
    caekf_settings_t b = good;
    const int past = good.model.bodies + 1;
    b.model.contact_a[0] = past;
    expect_refused(&b, CAEKF_PARAM_CONTACT_A, CAEKF_SETTING_BAD_BODY, "contact a past the last body");
    b = good;
    b.model.contact_b[0] = b.model.contact_a[0];
    expect_refused(&b, CAEKF_PARAM_CONTACT_B, CAEKF_SETTING_BAD_BODY, "contact b = a");
    b = good;
    b.model.sensor_body[1] = past;
    expect_refused(&b, CAEKF_PARAM_SENSOR_BODY + 1, CAEKF_SETTING_BAD_BODY, "sensor past the last body");
    b = good;
    b.model.input_body[0] = past;
    expect_refused(&b, CAEKF_PARAM_INPUT_BODY, CAEKF_SETTING_BAD_BODY, "input past the last body");
    b = good;
    b.model.spring_a[2] = past;
    expect_refused(&b, CAEKF_PARAM_SPRING_A + 2, CAEKF_SETTING_BAD_BODY, "spring past the last body");
    b = good;
#if CAEKF_USE_FLOAT
    b.model.spring_k[0] = 1e36f;
    b.model.dt = 1e3f; /* k dt overflows, k / dt would not */
#else
    b.model.spring_k[0] = 1e306;
    b.model.dt = 1e3;
#endif
    expect_refused(&b, CAEKF_PARAM_DT, CAEKF_SETTING_NOT_SCALABLE, "k dt overflows");
    b = good;
#if CAEKF_USE_FLOAT
    b.sigma_q_gamma[0] = b.sigma_gamma0[0] * 1e15f;
    b.q_gamma_scale = 1e10f; /* the ratio squared is finite, times the scale not */
#else
    b.sigma_q_gamma[0] = b.sigma_gamma0[0] * 1e150;
    b.q_gamma_scale = 1e10;
#endif
    expect_refused(&b, CAEKF_PARAM_SIGMA_Q_GAMMA, CAEKF_SETTING_NOT_SCALABLE, "Q_gamma times its scale overflows");
}

/* More rules of validation, each at its edge: a spring's ends must differ; a stiffness whose square would
 * overflow is still a stiffness (k dt is what the step takes); every velocity sensor needs sigma_rv, not only
 * the first; the defaults write the settings and nothing after them. */
static void test_more_rules_at_their_edges(void)
{
    struct {
        caekf_settings_t s;
        unsigned char guard[16];
    } d;
    caekf_settings_t b = good;
    caekf_setting_error_t err;
    b.model.spring_b[1] = b.model.spring_a[1];
    expect_refused(&b, CAEKF_PARAM_SPRING_B + 1, CAEKF_SETTING_BAD_BODY, "spring b = a");
    b = good;
#if CAEKF_USE_FLOAT
    b.model.spring_k[0] = 1e30f; /* k^2 overflows float, k dt does not */
#else
    b.model.spring_k[0] = 1e200;
#endif
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, &err));
    b = good;
    b.model.sensor_kind[1] = CAEKF_SENSOR_VELOCITY;
    b.sigma_rv = 0;
    expect_refused(&b, CAEKF_PARAM_SIGMA_RV, CAEKF_SETTING_NEEDED, "the second sensor a velocity without sigma_rv");
    memset(d.guard, 0xA5, sizeof d.guard);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_default(&d.s));
    TEST_ASSERT_EQUAL_HEX8(0xA5, d.guard[0]);
    {
        double v = 0;
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_settings_get(NULL, CAEKF_PARAM_DT, &v));
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_settings_get(&good, CAEKF_PARAM_DT, NULL));
    }
}

#if !CAEKF_SIZED
/* Settings beyond the counts in use are not read: an uncertain mass of a body the mechanism does not have and
 * a stiffness sigma of a spring past the last add no state. */
static void test_settings_beyond_the_counts_are_not_read(void)
{
    caekf_settings_t b = good;
    int n, ny, nu;
    b.model.m_sigma[b.model.bodies] = (caekf_scalar_t)0.03;
    b.model.spring_k_sigma[b.model.springs] = (caekf_scalar_t)0.03;
    b.model.spring_c_sigma[b.model.springs] = (caekf_scalar_t)0.03;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &b));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_sizes(&est, &n, &ny, &nu));
    TEST_ASSERT_EQUAL_INT(PAPER_N, n);
}

/* A sensor's estimated offset (sensor{i}_bias_sigma), the first sensor's too: a state after the mechanism's,
 * starting at 0, read back as it is. */
static void test_a_sensor_offset_is_a_state_from_zero(void)
{
    caekf_settings_t b = good;
    caekf_scalar_t x[CAEKF_N];
    int n, ny, nu;
    b.model.sensor_bias_sigma[0] = (caekf_scalar_t)1e-6;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &b));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_sizes(&est, &n, &ny, &nu));
    TEST_ASSERT_EQUAL_INT(PAPER_N + 1, n);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, x));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, (double)x[PAPER_N]);
}
#endif

#if !CAEKF_SIZED && CAEKF_MAX_CONTACTS >= 2 && CAEKF_MAX_LAW_PARAMS >= 6
/* A second contact (bodies 3 and 4): its gamma0 is checked against its own gamma_min, and every law parameter
 * of both contacts (the state's whole room for them) is a valid mechanism. */
static void test_a_second_contact_is_checked_and_fills_the_law_room(void)
{
    caekf_settings_t b = good;
    caekf_setting_error_t err;
    caekf_model_t m;
    int c;
    b.model.contacts = 2;
    b.model.contact_a[1] = 3;
    b.model.contact_b[1] = 4;
    b.model.contact_gap[1] = b.model.contact_gap[0];
    b.model.contact_n[1] = b.model.contact_n[0];
    b.gamma0[1] = b.gamma0[0];
    b.sigma_gamma0[1] = b.sigma_gamma0[0];
    b.sigma_q_gamma[1] = b.sigma_q_gamma[0];
    b.gamma_min[1] = b.gamma_min[0];
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, &err));
    b.gamma_min[1] = b.gamma0[1] * 2; /* contact 2's gamma0 below its minimum, the constraint on */
    expect_refused(&b, CAEKF_PARAM_GAMMA0 + 1, CAEKF_SETTING_BELOW_GAMMA_MIN, "contact 2 below gamma_min");
    b.gamma_min[1] = b.gamma_min[0];
#if CAEKF_USE_FLOAT
    b.sigma_q_gamma[1] = b.sigma_gamma0[1] * 1e20f; /* contact 2's Q_gamma not scalable: blamed on contact 2 */
#else
    b.sigma_q_gamma[1] = b.sigma_gamma0[1] * 1e160;
#endif
    expect_refused(&b, CAEKF_PARAM_SIGMA_Q_GAMMA + 1, CAEKF_SETTING_NOT_SCALABLE, "contact 2's Q_gamma overflows");
    b.sigma_q_gamma[1] = b.sigma_q_gamma[0];
    for (c = 0; c < 2; ++c) {
        b.model.contact_estimate_n[c] = b.model.contact_estimate_lambda[c] = b.model.contact_estimate_gap[c] = 1;
    }
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&m, &b.model));
    TEST_ASSERT_EQUAL_INT(2 * PAPER_NQ + 2 + 6, m.n);
    for (c = 0; c < 2; ++c) { /* each law state belongs to its own contact (its switch-off follows that gamma) */
        int k;
        for (k = 0; k < CAEKF_LAW_COUNT; ++k) {
            TEST_ASSERT_EQUAL_INT(c, m.param_contact[m.law_state[c][k] - 2 * PAPER_NQ]);
        }
        TEST_ASSERT_EQUAL_INT(c, m.param_contact[c]);
    }
}
#endif

#if !CAEKF_SIZED && CAEKF_MAX_MECH_PARAMS > 0 && CAEKF_MAX_MECH_PARAMS <= CAEKF_MAX_BODIES + 2 * CAEKF_MAX_SPRINGS
/* As many uncertain mechanism parameters as the build has room for are accepted; one more is refused. */
static void test_mechanism_parameters_up_to_the_capacity(void)
{
    static caekf_settings_t b;
    caekf_setting_error_t err;
    int i, count = 0;
    b = good;
    b.model.bodies = CAEKF_MAX_BODIES;
    b.model.springs = CAEKF_MAX_SPRINGS;
    for (i = 0; i < CAEKF_MAX_BODIES; ++i) {
        b.model.m[i] = 1;
    }
    for (i = 0; i < CAEKF_MAX_SPRINGS; ++i) { /* a ring of the bodies, then links two bodies apart */
        b.model.spring_a[i] = i % CAEKF_MAX_BODIES + 1;
        b.model.spring_b[i] =
            i < CAEKF_MAX_BODIES ? (i + 1) % CAEKF_MAX_BODIES + 1 : (b.model.spring_a[i] + 1) % CAEKF_MAX_BODIES + 2;
        b.model.spring_k[i] = 1000;
        b.model.spring_c[i] = 1;
    }
    for (i = 0; i < CAEKF_MAX_BODIES && count < CAEKF_MAX_MECH_PARAMS; ++i, ++count) {
        b.model.m_sigma[i] = (caekf_scalar_t)0.03;
    }
    for (i = 0; i < CAEKF_MAX_SPRINGS && count < CAEKF_MAX_MECH_PARAMS; ++i, ++count) {
        b.model.spring_k_sigma[i] = (caekf_scalar_t)0.03;
    }
    for (i = 0; i < CAEKF_MAX_SPRINGS && count < CAEKF_MAX_MECH_PARAMS; ++i, ++count) {
        b.model.spring_c_sigma[i] = (caekf_scalar_t)0.03;
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, &err));
    for (i = 0; i < CAEKF_MAX_SPRINGS && b.model.spring_c_sigma[i] > 0; ++i) {
    }
    if (i < CAEKF_MAX_SPRINGS) { /* room for one more sigma in the table: over the capacity */
        b.model.spring_c_sigma[i] = (caekf_scalar_t)0.03;
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
        TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_OVER_CAPACITY, err.reason);
    }
}
#endif

static void test_newton_bound_is_a_capacity(void)
{
    caekf_settings_t b = good;
    caekf_setting_error_t err;
    b.newton_max_iter = CAEKF_NEWTON_MAX_ITER + 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_NEWTON_MAX_ITER, err.param_id);
}

#if CAEKF_SIZED_METHOD
/* A build sized for one configuration runs its step method only: any other is refused as unsupported
 * (its defaults are that method), and the model refuses it too. */
static void test_a_method_sized_build_refuses_other_methods(void)
{
    caekf_settings_t b;
    caekf_setting_error_t err;
    caekf_model_t m;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_default(&b));
    TEST_ASSERT_EQUAL_INT(CAEKF_SIZED_DISCRETISATION, b.model.discretisation);
    TEST_ASSERT_EQUAL_INT(CAEKF_SIZED_CONTACT_SUBSTEPS, b.contact_substeps);
    TEST_ASSERT_EQUAL_INT(CAEKF_SIZED_GAMMA_LOG, b.model.gamma_log);
    TEST_ASSERT_EQUAL_INT(CAEKF_SIZED_COV_UPDATE, b.cov_update);
    TEST_ASSERT_EQUAL_INT(CAEKF_SIZED_SWITCHOFF, b.switchoff);
    b = good;
    /* statistically linearised contacts: required where sized with them, refused where compiled out */
    b.contact_slr_p = CAEKF_SIZED_SLR ? 0 : (caekf_scalar_t)0.01;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_UNSUPPORTED, err.reason);
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_CONTACT_SLR_P, err.param_id);
    b = good;
    b.model.discretisation = 1 - CAEKF_SIZED_DISCRETISATION;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_UNSUPPORTED, err.reason);
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_DISCRETISATION, err.param_id);
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_init(&m, &b.model));
    b = good;
    b.contact_substeps = CAEKF_SIZED_CONTACT_SUBSTEPS == 1 ? 2 : 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_UNSUPPORTED, err.reason);
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_CONTACT_SUBSTEPS, err.param_id);
    b = good;
    b.model.gamma_log = 1 - CAEKF_SIZED_GAMMA_LOG;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_UNSUPPORTED, err.reason);
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_GAMMA_LOG, err.param_id);
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_init(&m, &b.model));
    /* the covariance form and the switch-off: the sized configuration's (its defaults) only */
    b = good;
    b.cov_update = 1 - CAEKF_SIZED_COV_UPDATE;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_UNSUPPORTED, err.reason);
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_COV_UPDATE, err.param_id);
    b = good;
    b.switchoff = 1 - CAEKF_SIZED_SWITCHOFF;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_UNSUPPORTED, err.reason);
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_SWITCHOFF, err.param_id);
#if !CAEKF_HAS_DAMPING
    /* an undamped scenario's build has the elastic law only: a damped contact is refused, by the model too */
    b = good;
    b.model.contact_lambda[CAEKF_SIZED_CONTACTS - 1] = 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_UNSUPPORTED, err.reason);
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_CONTACT_LAMBDA + CAEKF_SIZED_CONTACTS - 1, err.param_id);
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_init(&m, &b.model));
#endif
#ifdef CAEKF_SIZED_CONTACT_N
    b = good;
    b.model.contact_n[0] = (caekf_scalar_t)CAEKF_SIZED_CONTACT_N + 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_UNSUPPORTED, err.reason);
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_CONTACT_N, err.param_id);
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_init(&m, &b.model));
#endif
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&good, &err));
}
#endif

#if CAEKF_SIZED
/* A sized build's model keeps no input count (the sized one is a constant): any other count is refused,
 * by the settings and by the model itself, never read as the sized one. */
static void test_a_sized_build_refuses_another_input_count(void)
{
    caekf_settings_t b = good;
    caekf_setting_error_t err;
    caekf_model_t m;
    b.model.inputs = CAEKF_SIZED_INPUTS > 0 ? CAEKF_SIZED_INPUTS - 1 : 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_TRUE(err.reason == CAEKF_SETTING_UNSUPPORTED || err.reason == CAEKF_SETTING_OVER_CAPACITY);
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_INPUTS, err.param_id);
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_init(&m, &b.model));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&m, &good.model));
}
#endif

#if CAEKF_HAS_SETTING_TEXT
/* The refusal reads as the schema states the rule, with the element and its value. */
static void test_refusal_text_names_element_value_and_rule(void)
{
    caekf_settings_t b = good;
    caekf_setting_error_t err;
    char text[120];
    b.model.m[2] = -1;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_UINT(2, err.index);
    TEST_ASSERT_EQUAL_STRING("m", caekf_setting_name(err.setting));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_error_text(&err, &b, text, sizeof text));
    TEST_ASSERT_EQUAL_STRING("m[2] = -1: must be finite and > 0", text);
    b = good;
    b.sigma_r = 0;
    (void)caekf_settings_validate(&b, &err);
    (void)caekf_setting_error_text(&err, &b, text, sizeof text);
    TEST_ASSERT_EQUAL_STRING("sigma_r = 0: must be finite and > 0", text);
    b = good; /* an element of a two-element setting is named with its index too */
    b.model.contact_gap[0] = -1;
    (void)caekf_settings_validate(&b, &err);
    (void)caekf_setting_error_text(&err, &b, text, sizeof text);
    TEST_ASSERT_EQUAL_STRING("contact_gap[0] = -1: must be finite and >= 0", text);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&good, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_OK, err.reason);
}
#endif

/* Set and get by parameter id: the id table, element addressing, integer checks. */
static void test_set_by_id_reaches_every_element(void)
{
    caekf_settings_t b;
    caekf_setting_error_t err;
    double v = 0;
    unsigned id;
    (void)caekf_settings_default(&b);
    for (id = 0; id < CAEKF_PARAM_COUNT; ++id) { /* every id reads back what was written */
        double want = (id == CAEKF_PARAM_MODE || id == CAEKF_PARAM_SWITCHOFF || id == CAEKF_PARAM_COV_UPDATE ||
                       id == CAEKF_PARAM_COV_REPAIR_ENABLED || id == CAEKF_PARAM_CONSTRAINT_ENABLED)
                          ? 1.0
                          : (double)(id + 2);
        if (caekf_settings_get(&b, id, &v) != CAEKF_OK) { /* beyond this build's capacity: refused */
            TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_set(&b, id, want, &err));
            TEST_ASSERT_EQUAL_INT(CAEKF_SETTING_OVER_CAPACITY, err.reason);
            TEST_ASSERT_EQUAL_UINT(id, err.param_id);
            continue;
        }
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_set(&b, id, want, &err));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_get(&b, id, &v));
        TEST_ASSERT_TRUE(v == want);
    }
    TEST_ASSERT_TRUE(b.model.m[3] == CAEKF_PARAM_M + 3 + 2 && b.q0[2] == CAEKF_PARAM_Q0 + 4 &&
                     b.v0[0] == CAEKF_PARAM_V0 + 2);
    TEST_ASSERT_TRUE(b.gamma_gate_nis == CAEKF_PARAM_GAMMA_GATE_NIS + 2 && b.mode == CAEKF_MODE_SWITCHED);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_set(&b, CAEKF_PARAM_COUNT, 1.0, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_UNKNOWN_ID, err.reason);
    b.newton_max_iter = 7;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_set(&b, CAEKF_PARAM_NEWTON_MAX_ITER, 2.5, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_SETTING_NOT_INTEGER, err.reason);
    TEST_ASSERT_EQUAL_INT(7, b.newton_max_iter); /* refused: nothing written */
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_set(&b, CAEKF_PARAM_MODE, (double)NAN, &err));
    TEST_ASSERT_EQUAL_STRING("contact1_sigma_q_gamma", caekf_param_key(CAEKF_PARAM_SIGMA_Q_GAMMA));
    TEST_ASSERT_EQUAL_STRING("spring2_k", caekf_param_key(CAEKF_PARAM_SPRING_K + 1));
    TEST_ASSERT_EQUAL_STRING("m3", caekf_param_key(CAEKF_PARAM_M + 2));
    TEST_ASSERT_NULL(caekf_param_key(CAEKF_PARAM_COUNT));
}

/* The compact generated table decodes to every setting's row: ids dense and in order, each element
 * addressed in caekf_settings_t, an array's counts and in-use count from its capacity, the integer
 * ranges and a count's capacity limit as the schema gives them. */
static void test_the_compact_table_decodes_every_row(void)
{
    caekf_setting_rule_t r;
    caekf_settings_t b;
    unsigned k, id = 0;
    (void)caekf_settings_default(&b);
    for (k = 0; k < CAEKF_SETTING_COUNT; ++k) {
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_rule(k, &r));
        TEST_ASSERT_EQUAL_UINT(id, r.id);
        TEST_ASSERT_TRUE(r.count >= 1 && r.stored >= 1 && r.stored <= r.count);
        TEST_ASSERT_EQUAL_UINT(r.rule == CAEKF_RULE_INT ? CAEKF_SETTING_INT : CAEKF_SETTING_REAL, r.storage);
        TEST_ASSERT_TRUE(r.rule == CAEKF_RULE_INT ? r.lo <= r.hi : r.lo == 0 && r.hi == 0);
        TEST_ASSERT_TRUE(
            r.offset + r.stored * (r.storage == CAEKF_SETTING_REAL ? sizeof(caekf_scalar_t) : sizeof(int)) <= sizeof b);
        id += r.count;
    }
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_COUNT, id);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_setting_rule(CAEKF_SETTING_COUNT, &r));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_setting_rule(0, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_rule(2, &r)); /* m: an array over the bodies */
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_M, r.id);
    TEST_ASSERT_EQUAL_UINT(offsetof(caekf_settings_t, model.m), r.offset);
    TEST_ASSERT_EQUAL_UINT(offsetof(caekf_settings_t, model.bodies), r.in_use);
    TEST_ASSERT_EQUAL_UINT(CAEKF_WIRE_MAX_BODIES, r.count);
    TEST_ASSERT_EQUAL_UINT(CAEKF_MAX_BODIES, r.stored);
    TEST_ASSERT_EQUAL_UINT(CAEKF_RULE_POS, r.rule);
    TEST_ASSERT_EQUAL_UINT(0, r.limit);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_rule(1, &r)); /* bodies: counts them, up to the capacity */
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_BODIES, r.id);
    TEST_ASSERT_EQUAL_UINT(CAEKF_ALL_IN_USE, r.in_use);
    TEST_ASSERT_EQUAL_UINT(CAEKF_MAX_BODIES, r.limit);
    TEST_ASSERT_TRUE(r.rule == CAEKF_RULE_INT && r.lo == 1 && r.hi == CAEKF_WIRE_MAX_BODIES);
    for (k = 0; k < CAEKF_SETTING_COUNT; ++k) { /* the rows of newton_max_iter and psd_check_period */
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_rule(k, &r));
        if (r.id == CAEKF_PARAM_NEWTON_MAX_ITER) {
            TEST_ASSERT_TRUE(r.lo == 1 && r.hi == 20 && r.offset == offsetof(caekf_settings_t, newton_max_iter));
        }
        if (r.id == CAEKF_PARAM_PSD_CHECK_PERIOD) {
            TEST_ASSERT_TRUE(r.lo == 1 && r.hi == 1000 && r.offset == offsetof(caekf_settings_t, psd_check_period));
        }
        if (r.id == CAEKF_PARAM_CONTACT_GAP) {
            TEST_ASSERT_TRUE(r.rule == CAEKF_RULE_NONNEG && r.stored == CAEKF_MAX_CONTACTS &&
                             r.in_use == offsetof(caekf_settings_t, model.contacts));
        }
    }
}

static void test_predict_only_moves_the_model_not_gamma(void)
{
    caekf_report_t rep;
    caekf_scalar_t g0, g1, x0[CAEKF_N], x1[CAEKF_N];
    run_into_contact();
    memcpy(&copy, &est, sizeof est);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_INPUT, caekf_predict(&est, (const caekf_scalar_t[]){(caekf_scalar_t)NAN}, &rep));
    TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_INPUT_REJECTED, rep.flags);
    TEST_ASSERT_TRUE(memcmp(&copy, &est, sizeof est) == 0);
    (void)caekf_get_gamma(&est, &g0);
    (void)caekf_get_state(&est, x0);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&est, (const caekf_scalar_t[]){(caekf_scalar_t)0.3}, &rep));
    TEST_ASSERT_TRUE(rep.flags & CAEKF_FLAG_NO_MEASUREMENT);
    TEST_ASSERT_TRUE(rep.flags & CAEKF_FLAG_CONTACT_ACTIVE); /* in contact, yet gamma cannot move */
    (void)caekf_get_gamma(&est, &g1);
    (void)caekf_get_state(&est, x1);
    TEST_ASSERT_TRUE(memcmp(&g0, &g1, sizeof g0) == 0);
    TEST_ASSERT_TRUE(x1[0] != x0[0]);                         /* the model advanced one dt */
    TEST_ASSERT_TRUE(EST_P(&est, 0, 0) > EST_P(&copy, 0, 0)); /* and its uncertainty grew by Q */
}

/* The accessors write all CAEKF_N entries: the state's n, zeros after them (over whatever the caller's
 * arrays held, and whatever the stack held). */
static void test_accessors_give_zeros_beyond_the_state(void)
{
    static caekf_scalar_t P[CAEKF_N][CAEKF_N];
    caekf_scalar_t x[CAEKF_N], var[CAEKF_N];
    int n, ny, nu, i, j;
    run_into_contact();
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_sizes(&est, &n, &ny, &nu));
    for (i = 0; i < CAEKF_N; ++i) {
        x[i] = var[i] = 7;
        for (j = 0; j < CAEKF_N; ++j) {
            P[i][j] = 7;
        }
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, x));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_variances(&est, var));
    test_fill_stack(0xFF); /* a local read before it is written: a NaN */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(&est, P));
    for (i = 0; i < CAEKF_N; ++i) {
        TEST_ASSERT_TRUE(i < n ? x[i] != 0 && var[i] > 0 : x[i] == 0 && var[i] == 0);
        for (j = 0; j < CAEKF_N; ++j) {
            if (i >= n || j >= n) {
                TEST_ASSERT_TRUE(P[i][j] == 0);
            } else {
                TEST_ASSERT_TRUE(isfinite((double)P[i][j]));
            }
        }
        TEST_ASSERT_TRUE(i >= n || P[i][i] == var[i]);
    }
}

/* A call refused before it starts (no instance, not initialised) reports an empty step, whatever the caller's
 * report held: no flags, no iterations, no penetration, no NIS; a prediction has no NIS either. */
static void test_a_refused_call_and_a_prediction_report_no_correction(void)
{
    caekf_t blank;
    caekf_report_t rep;
    const caekf_scalar_t y[2] = {0, 0}, u[1] = {0};
    memset(&blank, 0, sizeof blank);
    memset(&rep, 0xFF, sizeof rep);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_step(NULL, u, y, &rep));
    TEST_ASSERT_TRUE(rep.flags == 0 && rep.newton_iters == 0 && rep.delta == 0 && rep.nis == 0);
    memset(&rep, 0xFF, sizeof rep);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_step(&blank, u, y, &rep));
    TEST_ASSERT_TRUE(rep.flags == 0 && rep.newton_iters == 0 && rep.delta == 0 && rep.nis == 0);
    run_into_contact();
    {
        const caekf_scalar_t bad_y[2] = {(caekf_scalar_t)NAN, 0};
        int n, ny, nu;
        memcpy(&copy, &est, sizeof est);
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_INPUT, caekf_step(&est, u, bad_y, NULL));  /* no report to fill */
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_correct(&est, u, NULL, &rep)); /* a correction needs y */
        TEST_ASSERT_TRUE(memcmp(&copy, &est, sizeof est) == 0);
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_sizes(&est, &n, NULL, &nu));
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_sizes(&est, &n, &ny, NULL));
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_get_sizes(&blank, &n, &ny, &nu));
    }
    memset(&rep, 0xFF, sizeof rep);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&est, u, &rep));
    TEST_ASSERT_TRUE(rep.nis == 0);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, u, y, &rep));
    TEST_ASSERT_TRUE(rep.nis > 0);
}

/* caekf_init determines every byte of the instance after the settings: an instance that has run into
 * contact (every work buffer dirty) and one of other garbage come out of init identical to a fresh one, so
 * no stale value can leak into the next run. */
static void test_init_leaves_nothing_of_what_was_there(void)
{
    static caekf_t fresh;
    run_into_contact();
    memset(&fresh, 0xA5, sizeof fresh);
    memset(&copy, 0x5A, sizeof copy);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &good)); /* over the run's state */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&fresh, &good));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&copy, &good));
    TEST_ASSERT_TRUE_MESSAGE(memcmp(&fresh, &copy, sizeof fresh) == 0, "init left bytes of the garbage");
    TEST_ASSERT_TRUE_MESSAGE(memcmp(&fresh, &est, sizeof fresh) == 0, "init left bytes of the last run");
    /* the instance's own settings as the argument: the same instance again */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&copy, &copy.cfg));
    TEST_ASSERT_TRUE(memcmp(&fresh, &copy, sizeof fresh) == 0);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_non_finite_inputs_are_rejected_and_change_nothing);
    RUN_TEST(test_null_and_uninitialised);
    RUN_TEST(test_bad_settings_are_refused);
    RUN_TEST(test_newton_bound_is_a_capacity);
    RUN_TEST(test_bodies_referenced_and_products_of_settings);
    RUN_TEST(test_more_rules_at_their_edges);
#if !CAEKF_SIZED
    RUN_TEST(test_a_sensor_offset_is_a_state_from_zero);
    RUN_TEST(test_settings_beyond_the_counts_are_not_read);
#endif
#if !CAEKF_SIZED && CAEKF_MAX_CONTACTS >= 2 && CAEKF_MAX_LAW_PARAMS >= 6
    RUN_TEST(test_a_second_contact_is_checked_and_fills_the_law_room);
#endif
#if !CAEKF_SIZED && CAEKF_MAX_MECH_PARAMS > 0 && CAEKF_MAX_MECH_PARAMS <= CAEKF_MAX_BODIES + 2 * CAEKF_MAX_SPRINGS
    RUN_TEST(test_mechanism_parameters_up_to_the_capacity);
#endif
#if CAEKF_SIZED_METHOD
    RUN_TEST(test_a_method_sized_build_refuses_other_methods);
#endif
#if CAEKF_SIZED
    RUN_TEST(test_a_sized_build_refuses_another_input_count);
#endif
#if CAEKF_HAS_SETTING_TEXT
    RUN_TEST(test_refusal_text_names_element_value_and_rule);
#endif
    RUN_TEST(test_set_by_id_reaches_every_element);
    RUN_TEST(test_the_compact_table_decodes_every_row);
    RUN_TEST(test_predict_only_moves_the_model_not_gamma);
    RUN_TEST(test_init_leaves_nothing_of_what_was_there);
    RUN_TEST(test_accessors_give_zeros_beyond_the_state);
    RUN_TEST(test_a_refused_call_and_a_prediction_report_no_correction);
    return UNITY_END();
}
