#include "app_fixture.h"

#include "unity.h"

fake_hal_t fake;
caekf_app_t app;

void fixture_start(void)
{
    caekf_app_hal_t hal;
    caekf_app_config_t cfg;
    fake_hal_init(&fake, &hal);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_config_default(&cfg));
    cfg.status_period_us = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_init(&app, &hal, &cfg));
}

/* A value in its shortest decimal form, as the bench sends it. */
static void send_value(fake_hal_t *f, unsigned id, double value)
{
    int exp10 = 0;
    double m = value;
    while (m != 0.0 && m != (double)(int64_t)m && exp10 > -22) { /* fixture values are short decimals */
        m *= 10.0;
        exp10--;
    }
    bench_param(f, id, exp10, (int64_t)m);
}

void fixture_paper_settings(caekf_app_settings_t *s, int preset)
{
    unsigned i;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_default(s));
    for (i = 0; i < CAEKF_N_PAPER_PARAMS; i++) {
        caekf_msg_param_t p;
        double v;
        p.param_id = caekf_paper_params[i].id;
        p.param_exp10 = caekf_paper_params[i].exp10;
        p.param_mantissa = caekf_paper_params[i].mantissa;
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_param_value(&p, &v));
        TEST_ASSERT_TRUE(v == caekf_paper_params[i].value); /* the wire form is exact */
        TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(s, caekf_paper_params[i].id, v));
    }
    for (i = 0; preset >= 0 && i < caekf_fixture_presets[preset].n; i++) {
        TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(s, caekf_fixture_presets[preset].id[i],
                                                                   caekf_fixture_presets[preset].value[i]));
    }
    /* spot checks against the literal scenario values */
    TEST_ASSERT_TRUE(s->est.model.dt == (caekf_scalar_t)1.0e-3);
    TEST_ASSERT_TRUE(s->est.gamma0[0] == (caekf_scalar_t)7.5e7);
    TEST_ASSERT_TRUE(s->est.sigma_r == (caekf_scalar_t)1.0e-7);
}

unsigned fixture_send_preset(fake_hal_t *f, int preset)
{
    unsigned i;
    for (i = 0; preset >= 0 && i < caekf_fixture_presets[preset].n; i++) {
        send_value(f, caekf_fixture_presets[preset].id[i], caekf_fixture_presets[preset].value[i]);
    }
    return preset >= 0 ? caekf_fixture_presets[preset].n : 0u;
}

unsigned fixture_send_paper_params(fake_hal_t *f, int preset)
{
    unsigned i;
    for (i = 0; i < CAEKF_N_PAPER_PARAMS; i++) {
        bench_param(f, caekf_paper_params[i].id, caekf_paper_params[i].exp10, caekf_paper_params[i].mantissa);
    }
    return (unsigned)CAEKF_N_PAPER_PARAMS + fixture_send_preset(f, preset);
}

void fixture_configure(int preset)
{
    caekf_app_settings_t s;
    uint8_t bad = 0;
    fixture_paper_settings(&s, preset);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_configure(&app, &s, &bad));
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
