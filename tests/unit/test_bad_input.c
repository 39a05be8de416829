/* Bad inputs never corrupt the estimator: non-finite u or y is rejected with the whole instance
 * unchanged byte for byte; bad settings are refused and leave the instance as it was. */
#include <math.h>
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
        (void)caekf_step(&est, (caekf_scalar_t)r.u, y, NULL);
    }
    truth_close();
    TEST_ASSERT_TRUE(est.P[CAEKF_IG][CAEKF_IG] != 1); /* moved away from P0 */
}

static void expect_rejected(caekf_scalar_t u, caekf_scalar_t y1, caekf_scalar_t y4)
{
    caekf_scalar_t y[2];
    caekf_report_t rep;
    y[0] = y1;
    y[1] = y4;
    memcpy(&copy, &est, sizeof est);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_INPUT, caekf_step(&est, u, y, &rep));
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
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, 0, y, NULL));
}

static void test_null_and_uninitialised(void)
{
    caekf_t blank;
    caekf_scalar_t y[2] = {0, 0}, g;
    memset(&blank, 0, sizeof blank);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_step(&blank, 0, y, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_get_gamma(&blank, &g));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_step(NULL, 0, y, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_step(&blank, 0, NULL, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_init(NULL, &good));
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_init(&blank, NULL));
}

/* Each mutation must be refused, leaving a running estimator byte-for-byte as it was. */
static void expect_refused(caekf_settings_t *bad, const char *what)
{
    memcpy(&copy, &est, sizeof est);
    TEST_ASSERT_EQUAL_INT_MESSAGE(CAEKF_ERR_SETTINGS, caekf_init(&est, bad), what);
    TEST_ASSERT_TRUE_MESSAGE(memcmp(&copy, &est, sizeof est) == 0, what);
}

#define REFUSE(field, value)                                                                                      \
    do {                                                                                                          \
        caekf_settings_t b = good;                                                                                \
        b.field = value;                                                                                          \
        expect_refused(&b, #field " = " #value);                                                                  \
    } while (0)

static void test_bad_settings_are_refused(void)
{
    const caekf_scalar_t nan = (caekf_scalar_t)NAN, inf = (caekf_scalar_t)INFINITY;
    run_into_contact();
    REFUSE(model.dt, 0);
    REFUSE(model.dt, -1e-3f);
    REFUSE(model.dt, nan);
    REFUSE(model.m[2], -1);
    REFUSE(model.m[0], 0);
    REFUSE(model.k12, 0);
    REFUSE(model.k4, inf);
    REFUSE(model.c34, -5);
    REFUSE(model.gap, nan);
    REFUSE(q0[1], inf);
    REFUSE(gamma0, nan);
    REFUSE(sigma_q0, 0);
    REFUSE(sigma_gamma0, -1);
    REFUSE(sigma_r, 0);
    REFUSE(sigma_q_gamma, -1);
    REFUSE(q_gamma_scale, nan);
    REFUSE(gamma_min, 1e9f); /* above gamma0 with the constraint on */
    REFUSE(mode, (caekf_mode_t)7);
    REFUSE(switchoff, (caekf_switchoff_t)-1);
    REFUSE(cov_update, (caekf_cov_update_t)2);
    REFUSE(constraint_enabled, 2);
    REFUSE(newton_max_iter, 0);
    REFUSE(newton_max_iter, CAEKF_NEWTON_MAX_ITER + 1);
    REFUSE(newton_rtol, 1);
    REFUSE(newton_rtol, 0);
    REFUSE(gamma_gate_nis, -1);
    REFUSE(gamma_gate_nis, nan);
    {
        const char *bad = NULL;
        caekf_settings_t b = good;
        b.model.k34 = -1;
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &bad));
        TEST_ASSERT_EQUAL_STRING("k34", bad);
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
        expect_refused(&b, "Q ratio overflows");
        b = good;
#if CAEKF_USE_FLOAT
        b.sigma_r = 1e-22f;
        b.sigma_q0 = 1e3f; /* (sigma_r / sigma_q0)^2 underflows to 0: R would vanish */
#else
        b.sigma_r = 1e-200;
        b.sigma_q0 = 1e3;
#endif
        expect_refused(&b, "R underflows");
        b = good;
#if CAEKF_USE_FLOAT
        b.sigma_v0 = 1e-22f;
        b.v0[0] = 1e20f;
#else
        b.sigma_gamma0 = 1.9e-318; /* subnormal: gamma0 / sigma_gamma0 overflows */
#endif
        expect_refused(&b, "scaled state overflows");
    }
    /* gamma_min above gamma0 is fine when the constraint is off. */
    {
        caekf_settings_t b = good;
        b.constraint_enabled = 0;
        b.gamma_min = (caekf_scalar_t)1e9;
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, NULL));
    }
}

static void test_predict_only_moves_the_model_not_gamma(void)
{
    caekf_report_t rep;
    caekf_scalar_t g0, g1, x0[CAEKF_N], x1[CAEKF_N];
    run_into_contact();
    memcpy(&copy, &est, sizeof est);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_INPUT, caekf_predict(&est, (caekf_scalar_t)NAN, &rep));
    TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_INPUT_REJECTED, rep.flags);
    TEST_ASSERT_TRUE(memcmp(&copy, &est, sizeof est) == 0);
    (void)caekf_get_gamma(&est, &g0);
    (void)caekf_get_state(&est, x0);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&est, (caekf_scalar_t)0.3, &rep));
    TEST_ASSERT_TRUE(rep.flags & CAEKF_FLAG_NO_MEASUREMENT);
    TEST_ASSERT_TRUE(rep.flags & CAEKF_FLAG_CONTACT_ACTIVE); /* in contact, yet gamma cannot move */
    (void)caekf_get_gamma(&est, &g1);
    (void)caekf_get_state(&est, x1);
    TEST_ASSERT_TRUE(memcmp(&g0, &g1, sizeof g0) == 0);
    TEST_ASSERT_TRUE(x1[0] != x0[0]); /* the model advanced one dt */
    TEST_ASSERT_TRUE(est.P[0][0] > copy.P[0][0]); /* and its uncertainty grew by Q */
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_non_finite_inputs_are_rejected_and_change_nothing);
    RUN_TEST(test_null_and_uninitialised);
    RUN_TEST(test_bad_settings_are_refused);
    RUN_TEST(test_predict_only_moves_the_model_not_gamma);
    return UNITY_END();
}
