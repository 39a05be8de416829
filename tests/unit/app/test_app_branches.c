/* The app's corners the scenario suites do not reach (issue 31's branch coverage): the public API's refusals,
 * the status names, staging corners, pages only on request, a gap longer than the bridge, late and ignored
 * frames, a failed step, float32 saturation and an unavailable P norm (double builds: they need values beyond
 * float's range), and mechanisms other than the paper's (unsized builds: a sized build has only the paper's). */
#include <float.h>
#include <math.h>
#include <string.h>

#include "app_fixture.h"
#include "unity.h"

void setUp(void) { fixture_start(); }
void tearDown(void) {}

/* The payload of the nth transmitted frame of msg (0-based); fails the test if there is none. */
static const uint8_t *tx_data(caekf_msg_t msg, unsigned nth)
{
    const int i = fake_tx_find(&fake, msg, nth);
    TEST_ASSERT_TRUE(i >= 0);
    return fake.tx[i].data;
}

static caekf_msg_step_t tx_step(unsigned nth)
{
    caekf_msg_step_t m;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_step(tx_data(CAEKF_MSG_EST_STEP, nth), &m));
    return m;
}

static caekf_msg_ack_t last_ack(void)
{
    caekf_msg_ack_t a;
    const unsigned n = fake_tx_count(&fake, CAEKF_MSG_EST_ACK);
    int i;
    TEST_ASSERT_TRUE_MESSAGE(n > 0u, "no EST_ACK sent");
    i = fake_tx_find(&fake, CAEKF_MSG_EST_ACK, n - 1u);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_ack(fake.tx[i].data, &a));
    return a;
}

/* What the wire does to a value: encode then decode. */
static double wire(caekf_msg_t msg, double v)
{
    uint8_t d[8];
    uint16_t s;
    double out = 0.0;
    TEST_ASSERT_TRUE(caekf_proto_encode_value(msg, 0, v, d) >= 0);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_value(msg, d, &s, &out));
    return out;
}

static void bench_yp(uint16_t step, double y1, double y4)
{
    caekf_can_frame_t f;
    caekf_msg_yp_t yp;
    yp.step = (uint8_t)(step & 0xFFu); /* BENCH_YP carries STEP modulo 2^8 */
    yp.y1 = y1;
    yp.y4 = y4;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_yp(&yp, f.data));
    bench_send(&fake, CAEKF_MSG_BENCH_YP, &f);
}

/* A fresh app of `profile` (periodic status off) and page period. */
static void start_profile(caekf_profile_t profile, uint16_t page_period_steps)
{
    caekf_app_hal_t hal;
    caekf_app_config_t cfg;
    fake_hal_init(&fake, &hal);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_config_default(&cfg));
    cfg.status_period_us = 0;
    cfg.profile = (uint8_t)profile;
    cfg.page_period_steps = page_period_steps;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_init(&app, &hal, &cfg));
}

static caekf_msg_page_t tx_page(unsigned nth)
{
    caekf_msg_page_t pg;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_page(tx_data(CAEKF_MSG_EST_PAGE, nth), &pg));
    return pg;
}

static void test_api_calls_refuse_null_and_out_of_range_arguments(void)
{
    caekf_app_hal_t hal, h;
    caekf_app_config_t cfg, c;
    caekf_app_settings_t s;
    static caekf_app_t other;
    unsigned id = 7u;
    uint32_t v = 5u;
    uint8_t bad = 0;
    fake_hal_init(&fake, &hal);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_config_default(NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_config_default(&cfg));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_init(&other, NULL, &cfg));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_init(&other, &hal, NULL));
    /* each incomplete HAL and each out-of-range setting alone */
    h = hal;
    h.receive = NULL;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_init(&other, &h, &cfg));
    h = hal;
    h.transmit = NULL;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_init(&other, &h, &cfg));
    c = cfg;
    c.e2e_max_delta = 0u;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_init(&other, &hal, &c));
    c = cfg;
    c.max_frames_per_poll = 0u;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_init(&other, &hal, &c));
    c = cfg;
    c.step_timeout_us = 0u;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_init(&other, &hal, &c));
    c = cfg;
    c.e2e_max_delta = 15u; /* the bounds themselves are valid */
    c.max_frames_per_poll = 1u;
    c.step_timeout_us = 1u;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_init(&other, &hal, &c));

    /* configure: NULLs, an app never initialised, a refusal without the bad_param out-pointer */
    fixture_paper_settings(&s, CAEKF_FIXTURE_PRESET_SWITCHED);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_configure(NULL, &s, &bad));
    TEST_ASSERT_EQUAL_UINT8(CAEKF_ACK_BAD_PARAM_NONE, bad); /* written even then */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_configure(&app, NULL, NULL));
    memset(&other, 0, sizeof other);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_configure(&other, &s, NULL));
    TEST_ASSERT_EQUAL_UINT8(0, other.configured);
    s.est.mode = 4; /* no such mode */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_SETTINGS, caekf_app_configure(&app, &s, NULL));
    TEST_ASSERT_EQUAL_UINT8(0, app.configured);

    /* counters: NULLs and an id past the last */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_counter(NULL, CAEKF_CNT_RX_OK, &v));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_counter(&app, CAEKF_CNT_RX_OK, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_PARAM, caekf_app_counter(&app, CAEKF_CNT_COUNT, &v));
    TEST_ASSERT_EQUAL_UINT32(5u, v); /* untouched by the refusals */

    /* settings helpers */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_settings_default(NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_settings_set(NULL, CAEKF_PARAM_DT, 1e-3));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_param_id(NULL, &id));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_param_id("dt", NULL));
    TEST_ASSERT_EQUAL_UINT(7u, id);
}

static void test_status_names_every_status_and_an_unknown_one(void)
{
    TEST_ASSERT_EQUAL_STRING("ok", caekf_app_status_str(CAEKF_APP_OK));
    TEST_ASSERT_EQUAL_STRING("null pointer", caekf_app_status_str(CAEKF_APP_ERR_NULL));
    TEST_ASSERT_EQUAL_STRING("app configuration or HAL incomplete", caekf_app_status_str(CAEKF_APP_ERR_CONFIG));
    TEST_ASSERT_EQUAL_STRING("estimator settings refused", caekf_app_status_str(CAEKF_APP_ERR_SETTINGS));
    TEST_ASSERT_EQUAL_STRING("bad parameter", caekf_app_status_str(CAEKF_APP_ERR_PARAM));
    TEST_ASSERT_EQUAL_STRING("estimator initialisation failed", caekf_app_status_str(CAEKF_APP_ERR_INIT));
    TEST_ASSERT_EQUAL_STRING("unknown status", caekf_app_status_str((caekf_app_status_t)-4)); /* retired */
}

/* The first bad CTRL_PARAM is the one named: later ones are often its echo. */
static void test_a_second_bad_param_keeps_the_first_one_named(void)
{
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_param(&fake, CAEKF_PARAM_MODE, -1, 5);      /* 0.5: not an integer */
    bench_param(&fake, CAEKF_PARAM_SWITCHOFF, -1, 5); /* as bad, a second time */
    bench_param(&fake, CAEKF_PARAM_SIGMA_R, -7, 2);   /* and a good one */
    bench_reset(&fake, 3, 21);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_REFUSED_PARAM, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_MODE, last_ack().bad_param);
    TEST_ASSERT_EQUAL_UINT8(3, last_ack().n_params_rx);
    TEST_ASSERT_TRUE(app.active.est.sigma_r == (caekf_scalar_t)1e-7); /* running configuration unchanged */
}

/* More than 255 CTRL_PARAM frames: the count stays at 255 (it does not wrap), so a CTRL_RESET saying 255
 * commits them. */
static void test_staged_param_count_saturates_at_255(void)
{
    unsigned k;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    for (k = 0; k < 260u; k++) {
        bench_param(&fake, CAEKF_PARAM_SIGMA_R, -7, (k == 259u) ? 3 : 2);
        if (fake.rx_count >= 64u) {
            fixture_poll_all();
        }
    }
    bench_reset(&fake, 255, 4);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT8(CAEKF_ACK_ACCEPTED, last_ack().ack_status);
    TEST_ASSERT_EQUAL_UINT8(255, last_ack().n_params_rx);
    TEST_ASSERT_EQUAL_UINT32(260u, counter(CAEKF_CNT_PARAMS_RX));
    TEST_ASSERT_TRUE(app.active.est.sigma_r == (caekf_scalar_t)3e-7); /* the last value staged */
}

/* PRODUCTION with page_period_steps 0: no EST_PAGE until a CTRL_STATUS_REQ, then pages 0..10 over the next
 * eleven steps, then none again. */
static void test_pages_go_out_only_on_request_when_the_period_is_zero(void)
{
    unsigned k;
    start_profile(CAEKF_PROFILE_PRODUCTION, 0u);
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    for (k = 1; k <= 30u; k++) {
        bench_value(&fake, CAEKF_MSG_BENCH_U, (uint16_t)k, 0.1);
        bench_yp((uint16_t)k, 1e-6, 0.0);
        fixture_poll_all();
    }
    TEST_ASSERT_EQUAL_UINT32(30u, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT(30u, fake_tx_count(&fake, CAEKF_MSG_EST_PROD));
    TEST_ASSERT_EQUAL_UINT(0u, fake_tx_count(&fake, CAEKF_MSG_EST_PAGE));
    fake_tx_clear(&fake);
    bench_status_req(&fake, 3);
    for (k = 31; k <= 31u + 2u * CAEKF_PAGE_COUNT; k++) {
        bench_value(&fake, CAEKF_MSG_BENCH_U, (uint16_t)k, 0.1);
        bench_yp((uint16_t)k, 1e-6, 0.0);
        fixture_poll_all();
    }
    TEST_ASSERT_EQUAL_UINT(CAEKF_PAGE_COUNT, fake_tx_count(&fake, CAEKF_MSG_EST_PAGE));
    for (k = 0; k < CAEKF_PAGE_COUNT; k++) {
        TEST_ASSERT_EQUAL_UINT8(k, tx_page(k).page);
        TEST_ASSERT_EQUAL_UINT16(31u + k, tx_page(k).step);
    }
    /* a reconfiguration forgets a request not yet served: no page until the next one */
    bench_status_req(&fake, 4);
    fixture_poll_all();
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    fake_tx_clear(&fake);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 100, 0.1);
    bench_yp(100, 1e-6, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT(0u, fake_tx_count(&fake, CAEKF_MSG_EST_PAGE));
}

/* A gap longer than CAEKF_APP_MAX_GAP_PREDICT is bridged by that many prediction-only steps, no more (it bounds
 * one poll's work), and every missing step is still counted. */
static void test_a_gap_longer_than_the_bridge_predicts_only_its_bound(void)
{
    caekf_app_settings_t base;
    static caekf_t ref;
    static caekf_scalar_t x[CAEKF_N], xr[CAEKF_N], P[CAEKF_N][CAEKF_N], Pr[CAEKF_N][CAEKF_N];
    const uint16_t gap = (uint16_t)(2 * CAEKF_APP_MAX_GAP_PREDICT);
    caekf_scalar_t u[1], y[2];
    int k;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    fixture_paper_settings(&base, CAEKF_FIXTURE_PRESET_SWITCHED);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&ref, &base.est));
    bench_step(&fake, 10, 0.5, 2e-7, 0.0);
    bench_step(&fake, (uint16_t)(11u + gap), 0.5, 2e-7, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(2, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT32(gap, counter(CAEKF_CNT_STEPS_SKIPPED));
    u[0] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_U, 0.5);
    y[0] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_Y1, 2e-7);
    y[1] = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&ref, u, y, NULL));
    for (k = 0; k < CAEKF_APP_MAX_GAP_PREDICT; k++) {
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&ref, u, NULL));
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&ref, u, y, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&app.est, x));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&ref, xr));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(&app.est, P));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(&ref, Pr));
    TEST_ASSERT_EQUAL_MEMORY(xr, x, sizeof x);
    TEST_ASSERT_EQUAL_MEMORY(Pr, P, sizeof P);
}

/* BENCH_YP as the very first frame after a configuration (no step open, none closed yet): its 8-bit STEP is
 * taken as it is, and BENCH_U of that step completes it. 200 is more than 128 ahead of step 0 (and of the
 * step after the last one closed before the configuration): unwrapped against either, it would be a step
 * behind them. */
static void test_a_first_yp_frame_is_taken_at_its_8_bit_step(void)
{
    start_profile(CAEKF_PROFILE_PRODUCTION, 20u);
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 5, 0.1);
    bench_yp(5, 1e-6, 0.0);
    fixture_poll_all();
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED); /* forgets step 5 */
    fake_tx_clear(&fake);
    bench_yp(200, 1e-6, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 200, 0.1);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(2, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_SUPERSEDED));
    TEST_ASSERT_EQUAL_UINT16(200, tx_page(0).step);
}

/* A frame of an older step while a newer one is open is late: it neither closes nor enters the open step. */
static void test_an_older_frame_while_a_newer_step_is_open_is_late(void)
{
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 20, 0.25);
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 19, 3e-7);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_LATE));
    TEST_ASSERT_EQUAL_UINT(0, fake.tx_count);
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 20, 1e-7);
    bench_value(&fake, CAEKF_MSG_BENCH_Y4, 20, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_SUPERSEDED));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_RX_REPEATED));
    TEST_ASSERT_EQUAL_UINT16(20, tx_step(0).step);
}

/* Every bench value frame the paper's mechanism has no value for (a second input, sensors 3 and 4, velocity
 * sensors) is counted RX_OK and ignored: it opens no step, so the older step after it is not late. */
static void test_frames_for_values_the_mechanism_lacks_are_ignored(void)
{
    static const caekf_msg_t others[] = {CAEKF_MSG_BENCH_U2,     CAEKF_MSG_BENCH_S3_POS, CAEKF_MSG_BENCH_S4_POS,
                                         CAEKF_MSG_BENCH_S1_VEL, CAEKF_MSG_BENCH_S2_VEL, CAEKF_MSG_BENCH_S3_VEL,
                                         CAEKF_MSG_BENCH_S4_VEL};
    unsigned i;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    for (i = 0; i < sizeof others / sizeof others[0]; i++) {
        bench_value(&fake, others[i], 9, 1e-6);
    }
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(sizeof others / sizeof others[0], counter(CAEKF_CNT_RX_OK));
    TEST_ASSERT_EQUAL_UINT(0, fake.tx_count);
    bench_step(&fake, 8, 0.1, 1e-7, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_RX_LATE));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_SUPERSEDED));
    TEST_ASSERT_EQUAL_UINT16(8, tx_step(0).step);
}

#if !CAEKF_USE_FLOAT /* settings and estimates beyond float's range */

/* A step the estimator refuses (here a state that overflows its internal scale) is counted STEPS_FAILED and
 * its status travels in EST_STEP, as a directly stepped estimator returns it. */
static void test_a_failed_step_is_counted_and_its_status_sent(void)
{
    caekf_app_settings_t s;
    static caekf_t ref;
    caekf_scalar_t u[1], y[2];
    caekf_status_t want;
    fixture_paper_settings(&s, CAEKF_FIXTURE_PRESET_SWITCHED);
    s.est.sigma_q0 = (caekf_scalar_t)1e-280; /* positions scaled by 1e280 */
    s.est.sigma_v0 = (caekf_scalar_t)1e-279;
    s.est.sigma_qx_q = (caekf_scalar_t)1e-283;
    s.est.sigma_qx_v = (caekf_scalar_t)1e-281;
    s.est.sigma_r = (caekf_scalar_t)1e-281;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_configure(&app, &s, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&ref, &s.est));
    bench_step(&fake, 1, 3.0e38, 0.0, 0.0); /* a force near float32's largest: q ~ 1e32 m after one step */
    fixture_poll_all();
    u[0] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_U, 3.0e38);
    y[0] = 0;
    y[1] = 0;
    want = caekf_step(&ref, u, y, NULL);
    TEST_ASSERT_TRUE(want != CAEKF_OK);
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_FAILED));
    TEST_ASSERT_EQUAL_INT8(want, tx_step(0).step_status);
}

/* Settings whose gamma estimate (1e39) and its P entry (1e40) lie beyond float32's range. */
static void configure_beyond_float32(void)
{
    caekf_app_settings_t s;
    fixture_paper_settings(&s, CAEKF_FIXTURE_PRESET_SWITCHED);
    s.est.gamma0[0] = (caekf_scalar_t)1e39;
    s.est.sigma_gamma0[0] = (caekf_scalar_t)1e20;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_configure(&app, &s, NULL));
}

/* PRODUCTION and FD: a float32 value beyond its range is clipped to FLT_MAX, counted TX_SATURATED, and flagged
 * SATURATED (in EST_PAGE's page 10 for EST_PROD's gamma, in EST_FD itself). */
static void test_float32_values_beyond_range_are_clipped_counted_and_flagged(void)
{
    caekf_msg_prod_t pm;
    caekf_msg_fd_in_t in;
    caekf_msg_fd_out_t out;
    caekf_can_frame_t f;
    unsigned k;
    start_profile(CAEKF_PROFILE_PRODUCTION, 20u);
    configure_beyond_float32();
    for (k = 1; k <= CAEKF_PAGE_COUNT; k++) {
        bench_value(&fake, CAEKF_MSG_BENCH_U, (uint16_t)k, 0.1);
        bench_yp((uint16_t)k, 0.0, 0.0);
        fixture_poll_all();
    }
    TEST_ASSERT_EQUAL_UINT32(CAEKF_PAGE_COUNT, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_prod(tx_data(CAEKF_MSG_EST_PROD, 0), &pm));
    TEST_ASSERT_TRUE(pm.gamma == (double)FLT_MAX);
    TEST_ASSERT_TRUE(tx_page(8).value == (double)FLT_MAX); /* the P norm, about 1e40 */
    TEST_ASSERT_TRUE(tx_page(9).value == (double)FLT_MAX); /* P_gamma_gamma */
    TEST_ASSERT_EQUAL_HEX16(CAEKF_STEP_FLAGS_SATURATED, tx_page(10).info.flags & CAEKF_STEP_FLAGS_SATURATED);
    TEST_ASSERT_EQUAL_UINT32(CAEKF_PAGE_COUNT + 2u, counter(CAEKF_CNT_TX_SATURATED)); /* EST_PRODs, pages 8, 9 */

    start_profile(CAEKF_PROFILE_FD, 20u);
    configure_beyond_float32();
    memset(&in, 0, sizeof in);
    in.step = 1;
    in.u = 0.1;
    memset(f.data, 0, sizeof f.data);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_fd_in(&in, f.data));
    bench_send(&fake, CAEKF_MSG_BENCH_FD, &f);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT(1u, fake.tx_count);
    TEST_ASSERT_TRUE(fake_tx_e2e_ok(&fake, 0)); /* sealed after the re-encoding */
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_fd_out(fake.tx[0].data, &out));
    TEST_ASSERT_TRUE(out.x[8] == (double)FLT_MAX);
    TEST_ASSERT_EQUAL_HEX16(CAEKF_STEP_FLAGS_SATURATED, out.info.flags & CAEKF_STEP_FLAGS_SATURATED);
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_TX_SATURATED));
}

/* A P whose physical value overflows (sigma_gamma0 1e155: P_gamma_gamma 1e310) has no norm: EST_P_NORM and
 * page 8 are NaN and EST_STEP and page 10 carry PNORM_UNAVAILABLE; the step itself is fine. */
static void test_a_p_norm_the_estimator_cannot_compute_is_nan_and_flagged(void)
{
    caekf_app_settings_t s;
    caekf_scalar_t pn = 0;
    uint16_t step = 0;
    double v = 0.0;
    unsigned k;
    fixture_paper_settings(&s, CAEKF_FIXTURE_PRESET_SWITCHED);
    s.est.sigma_gamma0[0] = (caekf_scalar_t)1e155;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_configure(&app, &s, NULL));
    bench_step(&fake, 1, 0.1, 1e-7, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NUMERIC, caekf_get_cov_norm2(&app.est, &pn)); /* the cause */
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_FAILED));
    TEST_ASSERT_EQUAL_HEX16(CAEKF_STEP_FLAGS_PNORM_UNAVAILABLE, tx_step(0).flags & CAEKF_STEP_FLAGS_PNORM_UNAVAILABLE);
    /* non-finite: the decoder refuses it */
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_VALUE,
                          caekf_proto_decode_value(CAEKF_MSG_EST_P_NORM, tx_data(CAEKF_MSG_EST_P_NORM, 0), &step, &v));

    start_profile(CAEKF_PROFILE_PRODUCTION, 20u);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_configure(&app, &s, NULL));
    for (k = 1; k <= CAEKF_PAGE_COUNT; k++) {
        bench_value(&fake, CAEKF_MSG_BENCH_U, (uint16_t)k, 0.1);
        bench_yp((uint16_t)k, 1e-7, 0.0);
        fixture_poll_all();
    }
    TEST_ASSERT_TRUE(isnan(tx_page(8).value));
    TEST_ASSERT_EQUAL_HEX16(CAEKF_STEP_FLAGS_PNORM_UNAVAILABLE,
                            tx_page(10).info.flags & CAEKF_STEP_FLAGS_PNORM_UNAVAILABLE);
    TEST_ASSERT_EQUAL_INT8(CAEKF_OK, tx_page(10).info.step_status);
}

#endif /* !CAEKF_USE_FLOAT */

#if !CAEKF_SIZED /* other mechanisms than the paper's: a sized build has the paper's only */

/* One setting by its scenario key (the schema's names: the reader of a scenario file does the same). */
static void set_key(caekf_app_settings_t *s, const char *key, double value)
{
    unsigned id = 0;
    TEST_ASSERT_EQUAL_INT_MESSAGE(CAEKF_APP_OK, caekf_app_param_id(key, &id), key);
    TEST_ASSERT_EQUAL_INT_MESSAGE(CAEKF_APP_OK, caekf_app_settings_set(s, id, value), key);
}

/* The paper's values on two bodies without a contact: ground -k1- 1 -k12- 2, the force on body 1, position
 * sensors on bodies 1 and 2. */
static void two_bodies_no_contact(caekf_app_settings_t *s)
{
    fixture_paper_settings(s, CAEKF_FIXTURE_PRESET_SWITCHED);
    set_key(s, "bodies", 2);
    set_key(s, "springs", 2);
    set_key(s, "sensors", 2);
    set_key(s, "sensor2_body", 2);
    set_key(s, "contacts", 0);
}

/* A mechanism with two inputs and four sensors of both kinds: a step needs exactly its own values, each from
 * the frame of its kind and number (BENCH_U2, BENCH_S3_POS, BENCH_S2_VEL, BENCH_S4_VEL besides BENCH_U and
 * BENCH_Y1); the frames for sensors it has with another kind are ignored. The estimate equals a directly
 * stepped estimator's on those values, so each value went to its own input or sensor; the diagnostics
 * profile sends the bodies it has and NaN for the gamma it lacks. */
static void test_a_general_mechanism_takes_each_value_from_its_own_frame(void)
{
    caekf_app_settings_t s;
    static caekf_t ref;
    caekf_scalar_t u[2], y[4], x[CAEKF_N];
    uint16_t step = 0;
    double v = 0.0;
    unsigned i;
    two_bodies_no_contact(&s);
    set_key(&s, "inputs", 2);
    set_key(&s, "input2_body", 2);
    set_key(&s, "sensors", 4);
    set_key(&s, "sensor2_kind", CAEKF_SENSOR_VELOCITY); /* body 2 */
    set_key(&s, "sensor3_body", 2);                     /* position */
    set_key(&s, "sensor4_body", 1);
    set_key(&s, "sensor4_kind", CAEKF_SENSOR_VELOCITY);
    set_key(&s, "sigma_rv", 1e-4);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_configure(&app, &s, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&ref, &s.est));
    /* values for sensors of another kind: ignored */
    bench_value(&fake, CAEKF_MSG_BENCH_Y4, 5, 1e-3);
    bench_value(&fake, CAEKF_MSG_BENCH_S1_VEL, 5, 1e-3);
    bench_value(&fake, CAEKF_MSG_BENCH_S3_VEL, 5, 1e-3);
    bench_value(&fake, CAEKF_MSG_BENCH_S4_POS, 5, 1e-3);
    /* its own values, all but the last */
    bench_value(&fake, CAEKF_MSG_BENCH_U, 5, 0.3);
    bench_value(&fake, CAEKF_MSG_BENCH_U2, 5, -0.7);
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 5, 2e-7);
    bench_value(&fake, CAEKF_MSG_BENCH_S2_VEL, 5, 3e-5);
    bench_value(&fake, CAEKF_MSG_BENCH_S3_POS, 5, -4e-7);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_RX_REPEATED));
    bench_value(&fake, CAEKF_MSG_BENCH_S4_VEL, 5, -6e-5);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_DONE));
    u[0] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_U, 0.3);
    u[1] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_U2, -0.7);
    y[0] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_Y1, 2e-7);
    y[1] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_S2_VEL, 3e-5);
    y[2] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_S3_POS, -4e-7);
    y[3] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_S4_VEL, -6e-5);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&ref, u, y, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&ref, x));
    /* EST_GAMMA, EST_Q1, Q2, EST_V1, V2, EST_P_NORM, EST_P_GG, EST_STEP */
    TEST_ASSERT_EQUAL_UINT(8u, fake.tx_count);
    TEST_ASSERT_EQUAL_UINT(0u, fake_tx_count(&fake, CAEKF_MSG_EST_Q3));
    for (i = 0; i < 2u; i++) {
        const caekf_msg_t q = (caekf_msg_t)(CAEKF_MSG_EST_Q1 + i), vm = (caekf_msg_t)(CAEKF_MSG_EST_V1 + i);
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_value(q, tx_data(q, 0), &step, &v));
        TEST_ASSERT_TRUE(wire(q, (double)x[i]) == v);
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_value(vm, tx_data(vm, 0), &step, &v));
        TEST_ASSERT_TRUE(wire(vm, (double)x[2u + i]) == v);
    }
    /* no contact: gamma and its variance are NaN, which the decoder refuses */
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_VALUE,
                          caekf_proto_decode_value(CAEKF_MSG_EST_GAMMA, tx_data(CAEKF_MSG_EST_GAMMA, 0), &step, &v));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_VALUE,
                          caekf_proto_decode_value(CAEKF_MSG_EST_P_GG, tx_data(CAEKF_MSG_EST_P_GG, 0), &step, &v));
}

/* PRODUCTION on two bodies without a contact: the pages of bodies 3 and 4, P_gamma_gamma and EST_PROD's gamma
 * are NaN; bodies 1 and 2 are the estimate's q1, q2, v1, v2 (v1 is state 2 here, not 4). */
static void test_production_pages_of_a_smaller_mechanism_are_nan_where_it_has_no_state(void)
{
    caekf_app_settings_t s;
    static caekf_t ref;
    caekf_msg_prod_t pm;
    caekf_scalar_t u[1], y[2], x[CAEKF_N];
    caekf_msg_yp_t yp;
    uint8_t d[8];
    unsigned k;
    start_profile(CAEKF_PROFILE_PRODUCTION, 20u);
    two_bodies_no_contact(&s);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_configure(&app, &s, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&ref, &s.est));
    yp.step = 0;
    yp.y1 = 3e-7;
    yp.y4 = -1e-7;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_yp(&yp, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_yp(d, &yp));
    u[0] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_U, 0.2);
    y[0] = (caekf_scalar_t)yp.y1;
    y[1] = (caekf_scalar_t)yp.y4;
    for (k = 0; k < CAEKF_PAGE_COUNT; k++) {
        caekf_msg_page_t pg;
        fake_tx_clear(&fake);
        bench_value(&fake, CAEKF_MSG_BENCH_U, (uint16_t)(k + 1u), 0.2);
        bench_yp((uint16_t)(k + 1u), 3e-7, -1e-7);
        fixture_poll_all();
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&ref, u, y, NULL));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&ref, x));
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_prod(fake.tx[0].data, &pm));
        TEST_ASSERT_TRUE(isnan(pm.gamma));
        pg = tx_page(0);
        TEST_ASSERT_EQUAL_UINT8(k, pg.page);
        if (k == 0u || k == 1u) {
            TEST_ASSERT_TRUE((double)(float)x[k] == pg.value);
        } else if (k == 4u || k == 5u) {
            TEST_ASSERT_TRUE((double)(float)x[k - 2u] == pg.value);
        } else if (k < 8u || k == 9u) { /* q3, q4, v3, v4, P_gamma_gamma */
            TEST_ASSERT_TRUE(isnan(pg.value));
        } else if (k == 8u) {
            TEST_ASSERT_TRUE(pg.value > 0.0);
        } else {
            TEST_ASSERT_EQUAL_INT8(CAEKF_OK, pg.info.step_status);
        }
    }
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_TX_SATURATED));
}

/* The diagnostics profile sends the second contact's gamma and its variance (EST_GAMMA2, EST_P_GG2), before
 * EST_STEP: 14 frames for the paper's chain with a second stop (body 4 on the ground). */
static void test_diagnostics_send_the_second_contact(void)
{
    caekf_app_settings_t s;
    static caekf_t ref;
    static caekf_scalar_t x[CAEKF_N], P[CAEKF_N][CAEKF_N];
    caekf_scalar_t u[1], y[2];
    uint16_t step = 0;
    double v = 0.0;
    int g2;
    fixture_paper_settings(&s, CAEKF_FIXTURE_PRESET_SWITCHED);
    set_key(&s, "contacts", 2);
    set_key(&s, "contact2_a", 4);
    set_key(&s, "contact2_b", 0);
    set_key(&s, "contact2_gap", 2e-3);
    set_key(&s, "contact2_gamma0", 3e7);
    set_key(&s, "contact2_sigma_gamma0", 1e7);
    set_key(&s, "contact2_sigma_q_gamma", 1e5);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_configure(&app, &s, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&ref, &s.est));
    bench_step(&fake, 1, 0.25, 1e-7, -2e-8);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT(14u, fake.tx_count);
    TEST_ASSERT_EQUAL_INT(13, fake_tx_find(&fake, CAEKF_MSG_EST_STEP, 0));
    u[0] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_U, 0.25);
    y[0] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_Y1, 1e-7);
    y[1] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_Y4, -2e-8);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&ref, u, y, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&ref, x));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(&ref, P));
    g2 = 2 * ref.model.nq + 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK,
                          caekf_proto_decode_value(CAEKF_MSG_EST_GAMMA2, tx_data(CAEKF_MSG_EST_GAMMA2, 0), &step, &v));
    TEST_ASSERT_TRUE((double)(float)x[g2] == v);
    TEST_ASSERT_EQUAL_UINT16(1, step);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK,
                          caekf_proto_decode_value(CAEKF_MSG_EST_P_GG2, tx_data(CAEKF_MSG_EST_P_GG2, 0), &step, &v));
    TEST_ASSERT_TRUE((double)(float)P[g2][g2] == v);
}

/* EST_FD of a mechanism smaller than the paper's chain: its integer fields carry 0 for the bodies it lacks, so
 * the step is not flagged SATURATED nor counted (it was on every step, for values that do not exist). */
static void test_fd_frame_of_a_two_body_mechanism_is_not_saturated(void)
{
    caekf_app_settings_t s;
    caekf_msg_fd_in_t in;
    caekf_msg_fd_out_t out;
    caekf_can_frame_t f;
    start_profile(CAEKF_PROFILE_FD, 20u);
    two_bodies_no_contact(&s);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_configure(&app, &s, NULL));
    memset(&in, 0, sizeof in);
    in.step = 1;
    in.u = 0.1;
    in.y1 = 1e-7;
    memset(f.data, 0, sizeof f.data);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_fd_in(&in, f.data));
    bench_send(&fake, CAEKF_MSG_BENCH_FD, &f);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_fd_out(fake.tx[0].data, &out));
    TEST_ASSERT_EQUAL_HEX16(0, out.info.flags & CAEKF_STEP_FLAGS_SATURATED);
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_TX_SATURATED));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, out.x[3]); /* q4: the mechanism has two bodies */
}

#endif /* !CAEKF_SIZED */

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_api_calls_refuse_null_and_out_of_range_arguments);
    RUN_TEST(test_status_names_every_status_and_an_unknown_one);
    RUN_TEST(test_a_second_bad_param_keeps_the_first_one_named);
    RUN_TEST(test_staged_param_count_saturates_at_255);
    RUN_TEST(test_pages_go_out_only_on_request_when_the_period_is_zero);
    RUN_TEST(test_a_gap_longer_than_the_bridge_predicts_only_its_bound);
    RUN_TEST(test_a_first_yp_frame_is_taken_at_its_8_bit_step);
    RUN_TEST(test_an_older_frame_while_a_newer_step_is_open_is_late);
    RUN_TEST(test_frames_for_values_the_mechanism_lacks_are_ignored);
#if !CAEKF_USE_FLOAT
    RUN_TEST(test_a_failed_step_is_counted_and_its_status_sent);
    RUN_TEST(test_float32_values_beyond_range_are_clipped_counted_and_flagged);
    RUN_TEST(test_a_p_norm_the_estimator_cannot_compute_is_nan_and_flagged);
#endif
#if !CAEKF_SIZED
    RUN_TEST(test_a_general_mechanism_takes_each_value_from_its_own_frame);
    RUN_TEST(test_production_pages_of_a_smaller_mechanism_are_nan_where_it_has_no_state);
    RUN_TEST(test_diagnostics_send_the_second_contact);
    RUN_TEST(test_fd_frame_of_a_two_body_mechanism_is_not_saturated);
#endif
    return UNITY_END();
}
