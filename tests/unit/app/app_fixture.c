#include "app_fixture.h"

#include "unity.h"

fake_hal_t fake;
caekf_app_t app;

/* (param, mantissa, exp10): the scenario's estimator values in their shortest decimal form. */
static const struct {
    unsigned id;
    int64_t mantissa;
    int exp10;
} paper_params[] = {
    {CAEKF_PARAM_M1, 1, 0},         {CAEKF_PARAM_M2, 1, 0},          {CAEKF_PARAM_M3, 1, 0},
    {CAEKF_PARAM_M4, 1, 0},         {CAEKF_PARAM_K1, 2, 3},          {CAEKF_PARAM_K12, 1, 4},
    {CAEKF_PARAM_K34, 1, 4},        {CAEKF_PARAM_K4, 1, 4},          {CAEKF_PARAM_C1, 5, 0},
    {CAEKF_PARAM_C12, 5, 0},        {CAEKF_PARAM_C34, 5, 0},         {CAEKF_PARAM_C4, 5, 0},
    {CAEKF_PARAM_GAP, 1, -3},       {CAEKF_PARAM_DT, 1, -3},         {CAEKF_PARAM_GAMMA0, 75, 6},
    {CAEKF_PARAM_SIGMA_Q0, 1, -6},  {CAEKF_PARAM_SIGMA_V0, 1, -5},   {CAEKF_PARAM_SIGMA_GAMMA0, 25, 6},
    {CAEKF_PARAM_SIGMA_QX_Q, 1, -9}, {CAEKF_PARAM_SIGMA_QX_V, 1, -7}, {CAEKF_PARAM_SIGMA_Q_GAMMA, 1, 6},
    {CAEKF_PARAM_SIGMA_R, 1, -7},   {CAEKF_PARAM_GAMMA_MIN, 1, 6},
};
#define N_PAPER_PARAMS (sizeof paper_params / sizeof paper_params[0])

void fixture_start(void)
{
    caekf_app_hal_t hal;
    caekf_app_config_t cfg;
    fake_hal_init(&fake, &hal);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_config_default(&cfg));
    cfg.status_period_us = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_init(&app, &hal, &cfg));
}

void fixture_paper_settings(caekf_app_settings_t *s)
{
    unsigned i;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_default(s));
    for (i = 0; i < N_PAPER_PARAMS; i++) {
        caekf_msg_param_t p;
        double v;
        p.param_id = (uint8_t)paper_params[i].id;
        p.exp10 = (int8_t)paper_params[i].exp10;
        p.mantissa = paper_params[i].mantissa;
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_param_value(&p, &v));
        TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(s, paper_params[i].id, v));
    }
    /* spot checks against the literal scenario values */
    TEST_ASSERT_TRUE(s->est.model.dt == (caekf_scalar_t)1.0e-3);
    TEST_ASSERT_TRUE(s->est.gamma0 == (caekf_scalar_t)7.5e7);
    TEST_ASSERT_TRUE(s->est.sigma_r == (caekf_scalar_t)1.0e-7);
}

unsigned fixture_send_paper_params(fake_hal_t *f)
{
    unsigned i;
    for (i = 0; i < N_PAPER_PARAMS; i++) {
        bench_param(f, paper_params[i].id, paper_params[i].exp10, paper_params[i].mantissa);
    }
    return (unsigned)N_PAPER_PARAMS;
}

void fixture_configure(unsigned experiment)
{
    caekf_app_settings_t s;
    uint8_t bad = 0;
    fixture_paper_settings(&s);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_configure(&app, &s, experiment, &bad));
    TEST_ASSERT_EQUAL_UINT8(CAEKF_ACK_BAD_PARAM_NONE, bad);
}

void fixture_poll_all(void)
{
    unsigned i;
    for (i = 0; i < 64u && fake.rx_count > 0u; i++) {
        TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_poll(&app));
    }
    TEST_ASSERT_EQUAL_UINT(0, fake.rx_count);
}

uint32_t counter(unsigned id)
{
    uint32_t v = 0xDEADBEEFu;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_counter(&app, id, &v));
    return v;
}
