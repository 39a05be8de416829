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
    return UNITY_END();
}
