/* Configuration over CAN: staging, commit, refusal (running configuration untouched), the schema's
 * presets sent as ordinary CTRL_PARAMs, status requests and the health pages. */
#include <string.h>

#include "app_fixture.h"
#include "unity.h"

void setUp(void) { fixture_start(); }
void tearDown(void) {}

static caekf_msg_ack_t last_ack(void)
{
    caekf_msg_ack_t a;
    const unsigned n = fake_tx_count(&fake, CAEKF_MSG_EST_ACK);
    int i;
    TEST_ASSERT_TRUE_MESSAGE(n > 0u, "no EST_ACK sent");
    i = fake_tx_find(&fake, CAEKF_MSG_EST_ACK, n - 1u);
    TEST_ASSERT_TRUE(fake_tx_crc_ok(&fake, (unsigned)i));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_ack(fake.tx[i].data, &a));
    return a;
}

static void assert_same_estimate(const caekf_t *a, const caekf_t *b)
{
    static caekf_scalar_t xa[CAEKF_N], xb[CAEKF_N], Pa[CAEKF_N][CAEKF_N], Pb[CAEKF_N][CAEKF_N];
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(a, xa));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(b, xb));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(a, Pa));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(b, Pb));
    TEST_ASSERT_EQUAL_MEMORY(xa, xb, sizeof xa);
    TEST_ASSERT_EQUAL_MEMORY(Pa, Pb, sizeof Pa);
}

/* Every parameter id of `got` reads back as in `want` (the settings as the schema names them). */
static void assert_same_settings(const caekf_settings_t *want, const caekf_settings_t *got)
{
    unsigned id;
    for (id = 0; id < (unsigned)CAEKF_PARAM_COUNT; id++) {
        double w = -1.0, g = -2.0;
        const caekf_status_t sw = caekf_settings_get(want, id, &w);
        TEST_ASSERT_EQUAL_INT(sw, caekf_settings_get(got, id, &g)); /* refused alike beyond the capacity */
        if (sw != CAEKF_OK) {
            continue;
        }
        TEST_ASSERT_TRUE_MESSAGE(w == g, caekf_param_key(id));
    }
}

static void run_steps(uint16_t first, unsigned n)
{
    unsigned k;
    for (k = 0; k < n; k++) {
        bench_step(&fake, (uint16_t)(first + k), 0.3, 2e-7 * (double)(k + 1u), -1e-8);
    }
    fixture_poll_all();
}

static void test_params_and_reset_configure_the_estimator_exactly(void)
{
    caekf_app_settings_t paper;
    caekf_settings_t s;
    static caekf_t ref;
    caekf_msg_ack_t a;
    const unsigned n = fixture_send_paper_params(&fake, CAEKF_FIXTURE_PRESET_SWITCHED_HIGHQ);
    bench_reset(&fake, n, 42);
    fixture_poll_all();
    a = last_ack();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_ACCEPTED, a.ack_status);
    TEST_ASSERT_EQUAL_UINT8(42, a.token);
    TEST_ASSERT_EQUAL_UINT8(n, a.n_params_rx);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_ACK_BAD_PARAM_NONE, a.bad_param);
    TEST_ASSERT_EQUAL_HEX8(CAEKF_ACK_STATE_CONFIGURED, a.state);
    TEST_ASSERT_EQUAL_UINT32(n, counter(CAEKF_CNT_PARAMS_RX));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_CFG_ACCEPTED));

    /* the decimal parameters arrive as the very doubles of the scenario: same estimator, bit for bit */
    fixture_paper_settings(&paper, CAEKF_FIXTURE_PRESET_SWITCHED_HIGHQ);
    s = paper.est;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&ref, &s));
    TEST_ASSERT_EQUAL_MEMORY(&s.model, &app.est.cfg.model, sizeof s.model);
    assert_same_settings(&s, &app.est.cfg);
    TEST_ASSERT_TRUE(app.est.cfg.q_gamma_scale > (caekf_scalar_t)1); /* the preset's Q_gamma made it */
    assert_same_estimate(&ref, &app.est);
}

/* The bench selects an experiment by sending a preset's values as ordinary CTRL_PARAMs on top of the
 * running settings: the app ends with exactly the settings the preset names, nothing else changed. */
static void test_each_preset_sent_as_params_yields_exactly_its_settings(void)
{
    unsigned p;
    for (p = 0; p < CAEKF_N_FIXTURE_PRESETS; p++) {
        caekf_app_settings_t want;
        caekf_msg_ack_t a;
        unsigned i, n;
        fixture_start();
        fixture_configure(PRESET_NONE); /* the paper's values with the recommended defaults */
        n = fixture_send_preset(&fake, (int)p);
        TEST_ASSERT_EQUAL_UINT(caekf_fixture_presets[p].n, n);
        TEST_ASSERT_TRUE(n > 0u);
        bench_reset(&fake, n, p);
        fixture_poll_all();
        a = last_ack();
        TEST_ASSERT_EQUAL_INT8_MESSAGE(CAEKF_ACK_ACCEPTED, a.ack_status, caekf_fixture_presets[p].name);
        TEST_ASSERT_EQUAL_UINT8(p, a.token);
        TEST_ASSERT_EQUAL_UINT8(n, a.n_params_rx);
        fixture_paper_settings(&want, (int)p);
        assert_same_settings(&want.est, &app.est.cfg);
        assert_same_settings(&want.est, &app.active.est);
        for (i = 0; i < n; i++) { /* and the preset's own values, read back by id */
            double got = -1.0;
            TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_get(&app.est.cfg, caekf_fixture_presets[p].id[i], &got));
            TEST_ASSERT_TRUE_MESSAGE(got == (double)(caekf_scalar_t)caekf_fixture_presets[p].value[i],
                                     caekf_param_key(caekf_fixture_presets[p].id[i]));
        }
    }
}

static void test_innovation_gate_is_configured_and_validated_over_can(void)
{
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_param(&fake, CAEKF_PARAM_GAMMA_GATE_NIS, 0, -1); /* a gate must be >= 0 */
    bench_reset(&fake, 1, 5);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_SETTINGS, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_GAMMA_GATE_NIS, last_ack().bad_param);
    bench_param(&fake, CAEKF_PARAM_GAMMA_GATE_NIS, 2, 1);
    bench_reset(&fake, 1, 6);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_ACCEPTED, last_ack().ack_status);
    TEST_ASSERT_TRUE(app.est.cfg.gamma_gate_nis == (caekf_scalar_t)100);
}

static void test_reset_reinitialises_and_forgets_the_step_history(void)
{
    caekf_app_settings_t paper;
    caekf_settings_t s;
    static caekf_t fresh;
    caekf_scalar_t x[CAEKF_N];
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    run_steps(500, 5);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&app.est, x));
    TEST_ASSERT_TRUE(x[0] != 0); /* the estimate moved */
    bench_reset(&fake, 0, 1);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_ACCEPTED, last_ack().ack_status);
    fixture_paper_settings(&paper, CAEKF_FIXTURE_PRESET_SWITCHED);
    s = paper.est;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&fresh, &s));
    assert_same_estimate(&fresh, &app.est);
    fake_tx_clear(&fake);
    run_steps(0, 1); /* an earlier STEP is a new run, not a late frame */
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_RX_LATE));
    TEST_ASSERT_EQUAL_UINT(1, fake_tx_count(&fake, CAEKF_MSG_EST_STEP));
}

static void test_refused_settings_leave_the_running_configuration_unchanged(void)
{
    static caekf_t before;
    static caekf_app_settings_t active_before;
    caekf_msg_ack_t a;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED_HIGHQ);
    run_steps(1, 3);
    memcpy(&before, &app.est, sizeof before);
    memcpy(&active_before, &app.active, sizeof active_before);
    bench_param(&fake, CAEKF_PARAM_SPRING_K + 1, 4, 1);
    bench_param(&fake, CAEKF_PARAM_MODE, 0, CAEKF_MODE_CANONICAL); /* valid on its own */
    bench_param(&fake, CAEKF_PARAM_SIGMA_R, -7, -1);               /* sigma_r must be > 0 */
    bench_reset(&fake, 3, 9);
    fixture_poll_all();
    a = last_ack();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_SETTINGS, a.ack_status);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_SIGMA_R, a.bad_param);
    TEST_ASSERT_EQUAL_UINT8(9, a.token);
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_CFG_REFUSED));
    TEST_ASSERT_EQUAL_MEMORY(&before, &app.est, sizeof before);
    TEST_ASSERT_EQUAL_MEMORY(&active_before, &app.active, sizeof active_before);
    TEST_ASSERT_EQUAL_INT(CAEKF_MODE_SWITCHED, app.est.cfg.mode); /* the refused MODE did not leak */
    run_steps(4, 1); /* and it keeps running: step 4 follows step 3 without a gap */
    TEST_ASSERT_EQUAL_UINT32(4, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_SKIPPED));
}

static void test_missing_param_frame_refuses_as_incomplete(void)
{
    static caekf_t before;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    memcpy(&before, &app.est, sizeof before);
    bench_param(&fake, CAEKF_PARAM_SIGMA_R, -7, 2);
    bench_param(&fake, CAEKF_PARAM_GAMMA0, 6, 80);
    bench_param(&fake, CAEKF_PARAM_GAMMA_MIN, 5, 1);
    bench_reset(&fake, 4, 3);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_INCOMPLETE, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(3, last_ack().n_params_rx);
    TEST_ASSERT_EQUAL_MEMORY(&before, &app.est, sizeof before);
    bench_reset(&fake, 3, 4); /* the staged values were spent by the refusal */
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_INCOMPLETE, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(0, last_ack().n_params_rx);
}

/* What used to be an unknown experiment: a parameter id beyond the schema, a fractional mode or a mode
 * the estimator does not know is refused, naming the parameter, and the running mode stays. */
static void test_unknown_param_id_or_bad_mode_is_refused_naming_it(void)
{
    static caekf_t before;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    memcpy(&before, &app.est, sizeof before);
    bench_param(&fake, CAEKF_PARAM_COUNT, 0, 1); /* the first id past the schema */
    bench_reset(&fake, 1, 5);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_PARAM, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_COUNT, last_ack().bad_param);

    bench_param(&fake, CAEKF_PARAM_MODE, -1, 5); /* mode 0.5 */
    bench_reset(&fake, 1, 6);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_PARAM, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_MODE, last_ack().bad_param);

    bench_param(&fake, CAEKF_PARAM_MODE, 0, 4); /* an integer, but no such mode */
    bench_reset(&fake, 1, 7);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_SETTINGS, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_MODE, last_ack().bad_param);

    TEST_ASSERT_EQUAL_UINT32(3, counter(CAEKF_CNT_CFG_REFUSED));
    TEST_ASSERT_EQUAL_INT(CAEKF_MODE_SWITCHED, app.est.cfg.mode);
    TEST_ASSERT_EQUAL_MEMORY(&before, &app.est, sizeof before);
}

static void test_bad_param_frames_are_refused_with_their_id(void)
{
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_param(&fake, CAEKF_PARAM_COUNT, 0, 1); /* the first id no setting has */
    bench_param(&fake, CAEKF_PARAM_SPRING_K, 3, 2);
    bench_reset(&fake, 2, 6);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_PARAM, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_COUNT, last_ack().bad_param);
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_BAD_VALUE));

    bench_param(&fake, CAEKF_PARAM_NEWTON_MAX_ITER, -1, 25); /* 2.5 iterations */
    bench_reset(&fake, 1, 7);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_PARAM, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_NEWTON_MAX_ITER, last_ack().bad_param);

    bench_param(&fake, CAEKF_PARAM_DT, 23, 1); /* 10^23 is beyond the exact decimal range */
    bench_reset(&fake, 1, 8);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_PARAM, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_DT, last_ack().bad_param);
    TEST_ASSERT_EQUAL_UINT32(2, counter(CAEKF_CNT_RX_BAD_VALUE));
    TEST_ASSERT_EQUAL_UINT32(3, counter(CAEKF_CNT_CFG_REFUSED));
}

static void test_reset_without_any_settings_is_refused(void)
{
    bench_reset(&fake, 0, 10);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_NO_SETTINGS, last_ack().ack_status);
    TEST_ASSERT_EQUAL_HEX8(0, last_ack().state);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_ACK_BAD_PARAM_NONE, last_ack().bad_param);
    TEST_ASSERT_EQUAL_UINT8(0, app.configured);
}

static void test_params_stage_on_top_of_the_running_settings(void)
{
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_param(&fake, CAEKF_PARAM_SIGMA_R, -7, 2);
    fixture_poll_all();
    bench_status_req(&fake, 1);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_HEX8(CAEKF_ACK_STATE_CONFIGURED | CAEKF_ACK_STATE_STAGED, last_ack().state);
    TEST_ASSERT_TRUE(app.est.cfg.sigma_r == (caekf_scalar_t)1e-7); /* staged, not yet in effect */
    bench_reset(&fake, 1, 11);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_ACCEPTED, last_ack().ack_status);
    TEST_ASSERT_TRUE(app.est.cfg.sigma_r == (caekf_scalar_t)2e-7);
    TEST_ASSERT_TRUE(app.est.cfg.gamma0[0] == (caekf_scalar_t)7.5e7);
    TEST_ASSERT_TRUE(app.est.cfg.model.spring_k[0] == (caekf_scalar_t)2e3);
}

static void test_constrained_preset_refuses_gamma0_below_gamma_min(void)
{
    unsigned n;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_param(&fake, CAEKF_PARAM_GAMMA0, 5, 1);
    n = 1u + fixture_send_preset(&fake, CAEKF_FIXTURE_PRESET_SWITCHED_HIGHQ_CONSTRAINED);
    bench_reset(&fake, n, 12);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_SETTINGS, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_GAMMA0, last_ack().bad_param);
    TEST_ASSERT_EQUAL_INT(0, app.est.cfg.constraint_enabled);
    bench_param(&fake, CAEKF_PARAM_GAMMA0, 5, 1);
    n = 1u + fixture_send_preset(&fake, CAEKF_FIXTURE_PRESET_SWITCHED_HIGHQ); /* unconstrained: fine */
    bench_reset(&fake, n, 13);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_ACCEPTED, last_ack().ack_status);
    TEST_ASSERT_TRUE(app.est.cfg.gamma0[0] < app.est.cfg.gamma_min[0]);
}

static void test_status_request_answers_with_ack_and_every_health_page(void)
{
    unsigned page;
    uint32_t tx_before;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    run_steps(1, 2);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 1, 0.0); /* one late frame */
    fixture_poll_all();
    tx_before = counter(CAEKF_CNT_TX_FRAMES);
    fake_tx_clear(&fake);
    bench_status_req(&fake, 77);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_STATUS, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(77, last_ack().token);
    TEST_ASSERT_EQUAL_UINT(1u + CAEKF_HEALTH_PAGES, fake.tx_count);
    TEST_ASSERT_EQUAL_UINT(CAEKF_HEALTH_PAGES, fake_tx_count(&fake, CAEKF_MSG_EST_HEALTH));
    for (page = 0; page < CAEKF_HEALTH_PAGES; page++) {
        caekf_msg_health_t h;
        const int i = fake_tx_find(&fake, CAEKF_MSG_EST_HEALTH, page);
        unsigned c;
        TEST_ASSERT_TRUE(fake_tx_e2e_ok(&fake, (unsigned)i));
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_health(fake.tx[i].data, &h));
        TEST_ASSERT_EQUAL_UINT8(page, h.page);
        for (c = 2u * page; c < 2u * page + 2u; c++) {
            const uint32_t got = (c % 2u == 0u) ? h.counter_a : h.counter_b;
            /* TX_FRAMES grows during the burst: the ACK and the pages before this one */
            const uint32_t want = (c == CAEKF_CNT_TX_FRAMES) ? tx_before + 1u + page : counter(c);
            TEST_ASSERT_EQUAL_UINT32(want, got);
        }
    }
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_LATE));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STATUS_REQUESTS));
}

static void test_health_burst_is_periodic_when_enabled(void)
{
    caekf_app_hal_t hal;
    caekf_app_config_t cfg;
    fake_hal_init(&fake, &hal);
    (void)caekf_app_config_default(&cfg);
    TEST_ASSERT_EQUAL_UINT32(1000000u, cfg.status_period_us);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_init(&app, &hal, &cfg));
    fake.now_us += 999999u;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_poll(&app));
    TEST_ASSERT_EQUAL_UINT(0, fake.tx_count);
    fake.now_us += 1u;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_poll(&app));
    TEST_ASSERT_EQUAL_UINT(CAEKF_HEALTH_PAGES, fake_tx_count(&fake, CAEKF_MSG_EST_HEALTH));
    fake.now_us += 500000u;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_poll(&app));
    TEST_ASSERT_EQUAL_UINT(CAEKF_HEALTH_PAGES, fake.tx_count);
}

static void test_settings_set_writes_every_parameter_to_its_field(void)
{
    caekf_app_settings_t s;
    unsigned id;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_default(&s));
    for (id = 0; id < (unsigned)CAEKF_PARAM_COUNT; id++) {
        unsigned back = 999;
        const char *name = caekf_param_key(id);
        double probe;
        if (caekf_settings_get(&s.est, id, &probe) != CAEKF_OK) { /* an element beyond this build's capacity */
            TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_PARAM, caekf_app_settings_set(&s, id, 1.0));
            continue;
        }
        TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(&s, id, (double)(id % 2u)));
        TEST_ASSERT_NOT_NULL(name);
        TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_param_id(name, &back));
        TEST_ASSERT_EQUAL_UINT(id, back);
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(&s, CAEKF_PARAM_M + 2, 3.5));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(&s, CAEKF_PARAM_SPRING_K + 2, 34.0));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(&s, CAEKF_PARAM_V0 + 3, -4.0));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(&s, CAEKF_PARAM_SIGMA_QX_V, 0.25));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(&s, CAEKF_PARAM_Q_GAMMA_SCALE, 123.0));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(&s, CAEKF_PARAM_NEWTON_MAX_ITER, 7.0));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(&s, CAEKF_PARAM_NEWTON_RTOL, 1e-9));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(&s, CAEKF_PARAM_PSD_CHECK_PERIOD, 9.0));
    TEST_ASSERT_TRUE(s.est.model.m[2] == (caekf_scalar_t)3.5 && s.est.model.spring_k[2] == (caekf_scalar_t)34.0);
    TEST_ASSERT_TRUE(s.est.v0[3] == (caekf_scalar_t)-4.0 && s.est.sigma_qx_v == (caekf_scalar_t)0.25);
    TEST_ASSERT_TRUE(s.est.q_gamma_scale == (caekf_scalar_t)123.0 && s.est.newton_max_iter == 7);
    TEST_ASSERT_TRUE(s.est.newton_rtol == (caekf_scalar_t)1e-9);
    TEST_ASSERT_EQUAL_INT(9, s.est.psd_check_period);
    TEST_ASSERT_TRUE(s.est.model.dt == (caekf_scalar_t)(CAEKF_PARAM_DT % 2u) &&
                     s.est.gamma_min[0] == (caekf_scalar_t)(CAEKF_PARAM_GAMMA_MIN % 2u));
    TEST_ASSERT_EQUAL_INT(CAEKF_PARAM_COV_REPAIR_ENABLED % 2u, s.est.cov_repair_enabled);
    TEST_ASSERT_EQUAL_INT(CAEKF_PARAM_MODE % 2u, s.est.mode);
    TEST_ASSERT_EQUAL_INT(CAEKF_PARAM_CONSTRAINT_ENABLED % 2u, s.est.constraint_enabled);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_PARAM, caekf_app_settings_set(&s, CAEKF_PARAM_COUNT, 1.0));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_PARAM, caekf_app_settings_set(&s, CAEKF_PARAM_SWITCHOFF, 0.5));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_PARAM, caekf_app_settings_set(&s, CAEKF_PARAM_MODE, 0.5));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_PARAM, caekf_app_settings_set(&s, CAEKF_PARAM_COV_UPDATE, 1e300));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_PARAM, caekf_app_param_id("gamma", &id));      /* a truth key */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_PARAM, caekf_app_param_id("experiment", &id)); /* not a setting */
}

static void test_local_configure_refuses_without_touching_anything(void)
{
    caekf_app_settings_t s;
    uint8_t bad = 0;
    fixture_paper_settings(&s, CAEKF_FIXTURE_PRESET_SWITCHED);
    s.est.mode = 4; /* no such mode */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_SETTINGS, caekf_app_configure(&app, &s, &bad));
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_MODE, bad);
    fixture_paper_settings(&s, CAEKF_FIXTURE_PRESET_SWITCHED);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(&s, CAEKF_PARAM_M + 1, 0.0));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_SETTINGS, caekf_app_configure(&app, &s, &bad));
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_M + 1, bad);
    fixture_paper_settings(&s, CAEKF_FIXTURE_PRESET_SWITCHED_HIGHQ);
    s.est.q_gamma_scale = (caekf_scalar_t)-1.0;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_SETTINGS, caekf_app_configure(&app, &s, &bad));
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_Q_GAMMA_SCALE, bad);
    TEST_ASSERT_EQUAL_UINT8(0, app.configured);
    bench_step(&fake, 1, 0.0, 0.0, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(3, counter(CAEKF_CNT_RX_UNCONFIGURED));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_params_and_reset_configure_the_estimator_exactly);
    RUN_TEST(test_each_preset_sent_as_params_yields_exactly_its_settings);
    RUN_TEST(test_reset_reinitialises_and_forgets_the_step_history);
    RUN_TEST(test_refused_settings_leave_the_running_configuration_unchanged);
    RUN_TEST(test_missing_param_frame_refuses_as_incomplete);
    RUN_TEST(test_unknown_param_id_or_bad_mode_is_refused_naming_it);
    RUN_TEST(test_bad_param_frames_are_refused_with_their_id);
    RUN_TEST(test_innovation_gate_is_configured_and_validated_over_can);
    RUN_TEST(test_reset_without_any_settings_is_refused);
    RUN_TEST(test_params_stage_on_top_of_the_running_settings);
    RUN_TEST(test_constrained_preset_refuses_gamma0_below_gamma_min);
    RUN_TEST(test_status_request_answers_with_ack_and_every_health_page);
    RUN_TEST(test_health_burst_is_periodic_when_enabled);
    RUN_TEST(test_settings_set_writes_every_parameter_to_its_field);
    RUN_TEST(test_local_configure_refuses_without_touching_anything);
    return UNITY_END();
}
