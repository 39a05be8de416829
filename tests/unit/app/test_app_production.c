/* The PRODUCTION profile over the fake HAL: BENCH_U + BENCH_YP in, EST_PROD every step, one EST_PAGE per
 * step at the first 11 steps of every page period, every page after a status request; each value equal
 * to a directly stepped estimator's as the frame encodes it. */
#include <math.h>
#include <string.h>

#include "app_fixture.h"
#include "unity.h"

#define PERIOD 20u

void setUp(void)
{
    caekf_app_hal_t hal;
    caekf_app_config_t cfg;
    fake_hal_init(&fake, &hal);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_config_default(&cfg));
    cfg.status_period_us = 0;
    cfg.profile = (uint8_t)CAEKF_PROFILE_PRODUCTION;
    cfg.page_period_steps = PERIOD;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_init(&app, &hal, &cfg));
}
void tearDown(void) {}

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

static void bench_prod_step(uint16_t step, double u, double y1, double y4)
{
    bench_value(&fake, CAEKF_MSG_BENCH_U, step, u);
    bench_yp(step, y1, y4);
}

/* float32 of a value, as EST_PROD/EST_PAGE carry it */
static double f32(double v) { return (double)(float)v; }

static double yp_wire(double y)
{
    caekf_msg_yp_t m, out;
    uint8_t d[8];
    m.step = 0;
    m.y1 = y;
    m.y4 = 0.0;
    TEST_ASSERT_TRUE(caekf_proto_encode_yp(&m, d) >= 0);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_yp(d, &out));
    return out.y1;
}

static void test_init_refuses_a_page_period_shorter_than_the_pages_and_unknown_profiles(void)
{
    caekf_app_hal_t hal;
    caekf_app_config_t cfg;
    static caekf_app_t other;
    fake_hal_init(&fake, &hal);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_config_default(&cfg));
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PROFILE_DIAGNOSTICS, cfg.profile);
    cfg.page_period_steps = (uint16_t)(CAEKF_PAGE_COUNT - 1u);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_init(&other, &hal, &cfg));
    cfg.page_period_steps = 0u;
    cfg.profile = (uint8_t)CAEKF_PROFILE_COUNT;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_init(&other, &hal, &cfg));
}

static void test_two_input_frames_make_a_step_and_each_value_equals_the_estimator(void)
{
    caekf_app_settings_t base;
    caekf_settings_t s;
    static caekf_t ref;
    uint16_t k;
    unsigned pages_seen = 0;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    fixture_paper_settings(&base, CAEKF_FIXTURE_PRESET_SWITCHED);
    s = base.est;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&ref, &s));
    for (k = 0; k < 2u * PERIOD + 5u; k++) {
        const uint16_t step = (uint16_t)(250u + k); /* EST_PROD.STEP wraps (CAEKF_PROD_STEP_MASK) on the way */
        const double u = 0.02 * (double)k, y1 = -3.3e-7 * (double)k, y4 = 1.1e-8 * (double)k;
        caekf_scalar_t y[2], x[CAEKF_N], P[CAEKF_N][CAEKF_N], pn;
        caekf_report_t rep;
        caekf_msg_prod_t pm;
        int i;
        fake_tx_clear(&fake);
        bench_prod_step(step, u, y1, y4);
        fixture_poll_all();
        y[0] = (caekf_scalar_t)yp_wire(y1);
        y[1] = (caekf_scalar_t)yp_wire(y4);
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&ref, (const caekf_scalar_t[]){(caekf_scalar_t)(float)u}, y, &rep));
        (void)caekf_get_state(&ref, x);
        (void)caekf_get_covariance(&ref, P);
        (void)caekf_get_cov_norm2(&ref, &pn);
        /* EST_PROD first, then at most one page */
        TEST_ASSERT_TRUE(fake.tx_count == 1u || fake.tx_count == 2u);
        i = fake_tx_find(&fake, CAEKF_MSG_EST_PROD, 0);
        TEST_ASSERT_EQUAL_INT(0, i);
        TEST_ASSERT_TRUE(fake_tx_e2e_ok(&fake, 0));
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_prod(fake.tx[0].data, &pm));
        TEST_ASSERT_EQUAL_UINT8((uint8_t)(step & CAEKF_PROD_STEP_MASK), pm.step);
        TEST_ASSERT_EQUAL_HEX16((uint16_t)(rep.flags & CAEKF_PROD_FLAGS_MASK), pm.flags);
        TEST_ASSERT_TRUE(f32((double)x[2 * ref.model.nq]) == pm.gamma);
        i = fake_tx_find(&fake, CAEKF_MSG_EST_PAGE, 0);
        if ((k % PERIOD) < CAEKF_PAGE_COUNT) {
            caekf_msg_page_t pg;
            TEST_ASSERT_EQUAL_INT(1, i);
            TEST_ASSERT_TRUE(fake_tx_e2e_ok(&fake, 1));
            TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_page(fake.tx[1].data, &pg));
            TEST_ASSERT_EQUAL_UINT8(k % PERIOD, pg.page);
            TEST_ASSERT_EQUAL_UINT16(step, pg.step);
            if (pg.page < 8u) {
                TEST_ASSERT_TRUE(f32((double)x[pg.page]) == pg.value);
            } else if (pg.page == 8u) {
                TEST_ASSERT_TRUE(f32((double)pn) == pg.value);
            } else if (pg.page == 9u) {
                TEST_ASSERT_TRUE(f32((double)P[2 * ref.model.nq][2 * ref.model.nq]) == pg.value);
            } else {
                TEST_ASSERT_EQUAL_HEX16((uint16_t)rep.flags, pg.info.flags);
                TEST_ASSERT_EQUAL_UINT8((uint8_t)rep.newton_iters, pg.info.newton_iters);
                TEST_ASSERT_EQUAL_INT8(CAEKF_OK, pg.info.step_status);
            }
            pages_seen++;
        } else {
            TEST_ASSERT_EQUAL_INT(-1, i);
        }
    }
    TEST_ASSERT_EQUAL_UINT(2u * CAEKF_PAGE_COUNT + 5u, pages_seen);
    TEST_ASSERT_EQUAL_UINT32(2u * PERIOD + 5u, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_RX_REPEATED));
}

static void test_yp_after_y1_repeats_and_a_status_request_restarts_the_pages(void)
{
    unsigned k;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    /* BENCH_Y1 then BENCH_YP of the same step: y1 twice, the first value stays, counted */
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 3, 1e-6);
    bench_prod_step(3, 0.1, 2e-6, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_REPEATED));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_DONE));
    /* steps 4..15: pages 0..10 then none; a status request starts them over at the next step */
    for (k = 4; k < 16u; k++) {
        bench_prod_step((uint16_t)k, 0.1, 1e-6, 0.0);
    }
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT(CAEKF_PAGE_COUNT, fake_tx_count(&fake, CAEKF_MSG_EST_PAGE));
    fake_tx_clear(&fake);
    bench_status_req(&fake, 9);
    for (k = 16; k < 16u + CAEKF_PAGE_COUNT; k++) {
        bench_prod_step((uint16_t)k, 0.1, 1e-6, 0.0);
    }
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT(CAEKF_PAGE_COUNT, fake_tx_count(&fake, CAEKF_MSG_EST_PAGE));
    TEST_ASSERT_EQUAL_UINT(CAEKF_PAGE_COUNT, fake_tx_count(&fake, CAEKF_MSG_EST_PROD));
    TEST_ASSERT_EQUAL_UINT(0, fake_tx_count(&fake, CAEKF_MSG_EST_STEP));
}

static void test_yp_step_modulo_256_is_unwrapped_against_the_open_or_next_step(void)
{
    uint16_t k;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    /* across 2^8 and 2^16: BENCH_YP first (unwrapped against the step after the last closed one),
     * then BENCH_U (unwrapped against the open step) - every step completes, none late or superseded */
    bench_prod_step(65530u, 0.1, 1e-6, 0.0);
    fixture_poll_all();
    for (k = 65531u; k != 262u; k++) {
        if (k & 1u) {
            bench_yp(k, 1e-6, 0.0);
            bench_value(&fake, CAEKF_MSG_BENCH_U, k, 0.1);
        } else {
            bench_prod_step(k, 0.1, 1e-6, 0.0);
        }
        fixture_poll_all();
        fake_tx_clear(&fake);
    }
    TEST_ASSERT_EQUAL_UINT32(268u, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_SKIPPED));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_SUPERSEDED));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_RX_LATE));
    /* a BENCH_YP of an already closed step (5 behind: low byte 0x00 after 0x05) is late, not step 256 */
    bench_yp(256u, 1e-6, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_LATE));
    TEST_ASSERT_EQUAL_UINT32(268u, counter(CAEKF_CNT_STEPS_DONE));
}

/* The CAN FD profile: BENCH_FD (u, y1, y4 in one 20-byte frame) makes a step, EST_FD (64 bytes, CRC-16) carries
 * every value of it, equal to a directly stepped estimator's as the frame encodes it. */
static void test_fd_profile_one_frame_in_one_frame_out(void)
{
    caekf_app_hal_t hal;
    caekf_app_config_t cfg;
    caekf_app_settings_t base;
    caekf_settings_t s;
    static caekf_t ref;
    caekf_can_frame_t f;
    caekf_msg_fd_in_t in;
    caekf_msg_fd_out_t out, want;
    uint16_t k;
    fake_hal_init(&fake, &hal);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_config_default(&cfg));
    cfg.status_period_us = 0;
    cfg.profile = (uint8_t)CAEKF_PROFILE_FD;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_init(&app, &hal, &cfg));
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    fixture_paper_settings(&base, CAEKF_FIXTURE_PRESET_SWITCHED);
    s = base.est;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&ref, &s));
    for (k = 1; k <= 30u; k++) {
        caekf_scalar_t y[2], x[CAEKF_N], P[CAEKF_N][CAEKF_N], pn;
        caekf_report_t rep;
        uint8_t d[CAEKF_CAN_FD_MAX_LEN];
        unsigned i;
        in.step = k;
        in.u = 0.02 * (double)k;
        in.y1 = -3.3e-7 * (double)k;
        in.y4 = 1.1e-8 * (double)k;
        memset(f.data, 0, sizeof f.data);
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_fd_in(&in, f.data));
        fake_tx_clear(&fake);
        bench_send(&fake, CAEKF_MSG_BENCH_FD, &f);
        TEST_ASSERT_EQUAL_UINT8(CAEKF_FD_IN_LEN, f.dlc);
        fixture_poll_all();
        TEST_ASSERT_EQUAL_UINT(1u, fake.tx_count);
        TEST_ASSERT_EQUAL_INT(0, fake_tx_find(&fake, CAEKF_MSG_EST_FD, 0));
        TEST_ASSERT_EQUAL_UINT8(CAEKF_FD_OUT_LEN, fake.tx[0].dlc);
        TEST_ASSERT_TRUE(fake_tx_e2e_ok(&fake, 0));
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_fd_out(fake.tx[0].data, &out));
        /* the reference estimator on the values as the frame carries them */
        y[0] = (caekf_scalar_t)in.y1;
        y[1] = (caekf_scalar_t)in.y4;
        TEST_ASSERT_EQUAL_INT(CAEKF_OK,
                              caekf_step(&ref, (const caekf_scalar_t[]){(caekf_scalar_t)(float)in.u}, y, &rep));
        (void)caekf_get_state(&ref, x);
        (void)caekf_get_covariance(&ref, P);
        (void)caekf_get_cov_norm2(&ref, &pn);
        for (i = 0; i < 9; i++) { /* the paper's q1..q4, v1..v4, gamma */
            want.x[i] = (double)x[i];
        }
        want.p_norm = (double)pn;
        want.p_gg = (double)P[2 * ref.model.nq][2 * ref.model.nq];
        want.step = k;
        want.info.flags = (uint16_t)(rep.flags & CAEKF_FLAG_MASK);
        want.info.newton_iters = (uint8_t)rep.newton_iters;
        want.info.step_status = CAEKF_OK;
        memset(d, 0, sizeof d);
        (void)caekf_proto_encode_fd_out(&want, d);
        (void)caekf_proto_decode_fd_out(d, &want);
        TEST_ASSERT_EQUAL_MEMORY(want.x, out.x, sizeof out.x);
        TEST_ASSERT_TRUE(want.p_norm == out.p_norm && want.p_gg == out.p_gg);
        TEST_ASSERT_EQUAL_UINT16(k, out.step);
        TEST_ASSERT_EQUAL_HEX16(want.info.flags, out.info.flags);
        TEST_ASSERT_EQUAL_UINT8(want.info.newton_iters, out.info.newton_iters);
    }
    TEST_ASSERT_EQUAL_UINT32(30u, counter(CAEKF_CNT_STEPS_DONE));
    /* a classic 8-byte frame with BENCH_FD's ID is a wrong DLC */
    f.dlc = 8u;
    fake_push(&fake, &f);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1u, counter(CAEKF_CNT_RX_BAD_DLC));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_init_refuses_a_page_period_shorter_than_the_pages_and_unknown_profiles);
    RUN_TEST(test_two_input_frames_make_a_step_and_each_value_equals_the_estimator);
    RUN_TEST(test_yp_after_y1_repeats_and_a_status_request_restarts_the_pages);
    RUN_TEST(test_yp_step_modulo_256_is_unwrapped_against_the_open_or_next_step);
    RUN_TEST(test_fd_profile_one_frame_in_one_frame_out);
    return UNITY_END();
}
