/* The app's step path over the fake HAL: assembly, estimate frames, timeouts, and every reject class. */
#include <string.h>

#include "app_fixture.h"
#include "unity.h"

#define STEP_TIMEOUT_US 20000u

void setUp(void) { fixture_start(); }
void tearDown(void) {}

static double tx_value(caekf_msg_t msg, unsigned nth, uint16_t *step)
{
    uint16_t s = 0;
    double v = 0.0;
    const int i = fake_tx_find(&fake, msg, nth);
    TEST_ASSERT_TRUE(i >= 0);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_value(msg, fake.tx[i].data, &s, &v));
    if (step != NULL) {
        *step = s;
    }
    return v;
}

static caekf_msg_step_t tx_step(unsigned nth)
{
    caekf_msg_step_t m;
    const int i = fake_tx_find(&fake, CAEKF_MSG_EST_STEP, nth);
    TEST_ASSERT_TRUE(i >= 0);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_step(fake.tx[i].data, &m));
    return m;
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

static void test_unconfigured_app_counts_bench_frames_and_sends_nothing(void)
{
    bench_step(&fake, 1, 0.5, 1e-6, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(3, counter(CAEKF_CNT_RX_UNCONFIGURED));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT(0, fake.tx_count);
}

static void test_complete_step_sends_twelve_protected_frames_status_last(void)
{
    static const caekf_msg_t order[12] = {CAEKF_MSG_EST_GAMMA,  CAEKF_MSG_EST_Q1,   CAEKF_MSG_EST_Q2,
                                          CAEKF_MSG_EST_Q3,     CAEKF_MSG_EST_Q4,   CAEKF_MSG_EST_V1,
                                          CAEKF_MSG_EST_V2,     CAEKF_MSG_EST_V3,   CAEKF_MSG_EST_V4,
                                          CAEKF_MSG_EST_P_NORM, CAEKF_MSG_EST_P_GG, CAEKF_MSG_EST_STEP};
    unsigned i;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 7, 0.25);
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 7, 1e-7);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT(0, fake.tx_count); /* not complete yet */
    bench_value(&fake, CAEKF_MSG_BENCH_Y4, 7, -2e-8);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT(12, fake.tx_count);
    for (i = 0; i < 12u; i++) {
        const caekf_msg_info_t *info;
        uint16_t step = 0;
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_msg_info(order[i], &info));
        TEST_ASSERT_EQUAL_HEX32(info->can_id, fake.tx[i].id);
        TEST_ASSERT_TRUE(fake_tx_e2e_ok(&fake, i));
        if (order[i] != CAEKF_MSG_EST_STEP) {
            (void)tx_value(order[i], 0, &step);
            TEST_ASSERT_EQUAL_UINT16(7, step);
        }
    }
    TEST_ASSERT_EQUAL_UINT16(7, tx_step(0).step);
    TEST_ASSERT_EQUAL_INT8(CAEKF_OK, tx_step(0).step_status);
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT32(12, counter(CAEKF_CNT_TX_FRAMES));
    TEST_ASSERT_EQUAL_UINT32(3, counter(CAEKF_CNT_RX_OK));
}

static void test_estimates_equal_a_directly_stepped_estimator(void)
{
    caekf_app_settings_t base;
    caekf_settings_t s;
    static caekf_t ref;
    uint16_t k;
    fixture_configure(CAEKF_FIXTURE_PRESET_CANONICAL);
    fixture_paper_settings(&base, CAEKF_FIXTURE_PRESET_CANONICAL);
    s = base.est;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&ref, &s));
    for (k = 0; k < 40u; k++) {
        const double u = -0.01 * (double)k, y1 = -3.3e-9 * (double)k * (double)k, y4 = 1.1e-12 * (double)k;
        caekf_scalar_t y[2], x[CAEKF_N], P[CAEKF_N][CAEKF_N], pn;
        caekf_report_t rep;
        unsigned i;
        fake_tx_clear(&fake);
        bench_step(&fake, (uint16_t)(100u + k), u, y1, y4);
        fixture_poll_all();
        y[0] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_Y1, y1);
        y[1] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_Y4, y4);
        TEST_ASSERT_EQUAL_INT(
            CAEKF_OK, caekf_step(&ref, (const caekf_scalar_t[]){(caekf_scalar_t)wire(CAEKF_MSG_BENCH_U, u)}, y, &rep));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&ref, x));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(&ref, P));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_cov_norm2(&ref, &pn));
        TEST_ASSERT_TRUE(wire(CAEKF_MSG_EST_GAMMA, (double)x[2 * ref.model.nq]) ==
                         tx_value(CAEKF_MSG_EST_GAMMA, 0, NULL));
        for (i = 0; i < 4u; i++) {
            TEST_ASSERT_TRUE(wire(CAEKF_MSG_EST_Q1, (double)x[i]) ==
                             tx_value((caekf_msg_t)(CAEKF_MSG_EST_Q1 + i), 0, NULL));
            TEST_ASSERT_TRUE(wire(CAEKF_MSG_EST_V1, (double)x[4u + i]) ==
                             tx_value((caekf_msg_t)(CAEKF_MSG_EST_V1 + i), 0, NULL));
        }
        TEST_ASSERT_TRUE(wire(CAEKF_MSG_EST_P_NORM, (double)pn) == tx_value(CAEKF_MSG_EST_P_NORM, 0, NULL));
        TEST_ASSERT_TRUE(wire(CAEKF_MSG_EST_P_GG, (double)P[2 * ref.model.nq][2 * ref.model.nq]) ==
                         tx_value(CAEKF_MSG_EST_P_GG, 0, NULL));
        TEST_ASSERT_EQUAL_HEX16((uint16_t)rep.flags, tx_step(0).flags);
        TEST_ASSERT_EQUAL_UINT8((uint8_t)rep.newton_iters, tx_step(0).newton_iters);
    }
    TEST_ASSERT_EQUAL_UINT32(40, counter(CAEKF_CNT_STEPS_DONE));
}

static void test_frames_of_a_step_may_arrive_in_any_order(void)
{
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_value(&fake, CAEKF_MSG_BENCH_Y4, 3, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 3, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 3, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT(1, fake_tx_count(&fake, CAEKF_MSG_EST_STEP));
}

static void test_partial_step_times_out_never_hangs_and_its_straggler_is_late(void)
{
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 10, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 10, 0.0);
    fixture_poll_all();
    fake.now_us += STEP_TIMEOUT_US; /* exactly the timeout: still waiting */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_poll(&app));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_TIMED_OUT));
    fake.now_us += 1u; /* crosses the 32-bit wrap of the fake clock on the way */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_poll(&app));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_TIMED_OUT));
    bench_value(&fake, CAEKF_MSG_BENCH_Y4, 10, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_LATE));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT(0, fake.tx_count);
    bench_step(&fake, 11, 0.0, 0.0, 0.0); /* the next step runs, flagged: step 10 was never estimated */
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_DONE));
}

static void test_newer_step_supersedes_a_partial_one(void)
{
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 20, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 20, 0.0);
    bench_step(&fake, 21, 0.0, 0.0, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_Y4, 20, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_SUPERSEDED));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_LATE));
    TEST_ASSERT_EQUAL_UINT16(21, tx_step(0).step);
}

static void test_repeated_signal_keeps_the_first_value(void)
{
    uint16_t step;
    static caekf_t before;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    memcpy(&before, &app.est, sizeof before);
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 30, 1e-6);
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 30, -1e-6);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 30, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_Y4, 30, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_REPEATED));
    {
        caekf_scalar_t y[2] = {(caekf_scalar_t)1e-6, 0};
        caekf_scalar_t x[CAEKF_N];
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&before, (const caekf_scalar_t[]){0}, y, NULL));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&before, x));
        TEST_ASSERT_TRUE(wire(CAEKF_MSG_EST_Q1, (double)x[0]) == tx_value(CAEKF_MSG_EST_Q1, 0, &step));
    }
}

static void test_step_gap_is_flagged_and_counted_but_the_16_bit_wrap_is_not_a_gap(void)
{
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_step(&fake, 65534, 0.0, 0.0, 0.0);
    bench_step(&fake, 65535, 0.0, 0.0, 0.0);
    bench_step(&fake, 0, 0.0, 0.0, 0.0);
    bench_step(&fake, 3, 0.0, 0.0, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(4, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_HEX16(0, tx_step(1).flags & CAEKF_STEP_FLAGS_STEP_GAP);
    TEST_ASSERT_EQUAL_HEX16(0, tx_step(2).flags & CAEKF_STEP_FLAGS_STEP_GAP);
    TEST_ASSERT_EQUAL_HEX16(CAEKF_STEP_FLAGS_STEP_GAP, tx_step(3).flags & CAEKF_STEP_FLAGS_STEP_GAP);
    TEST_ASSERT_EQUAL_UINT32(2, counter(CAEKF_CNT_STEPS_SKIPPED));
}

/* Missing steps are bridged by prediction-only steps with the last input held: the app's estimate
 * after a gap equals a reference estimator doing exactly that (and differs from simply stepping on). */
static void test_step_gap_is_bridged_by_prediction_only_steps(void)
{
    caekf_app_settings_t base;
    caekf_settings_t s;
    static caekf_t ref, naive;
    caekf_scalar_t y[2], x[CAEKF_N], xn[CAEKF_N];
    const double u1 = 0.4, u2 = -0.2, y1 = 2e-7, y4 = -1e-9;
    int k;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    fixture_paper_settings(&base, CAEKF_FIXTURE_PRESET_SWITCHED);
    s = base.est;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&ref, &s));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&naive, &s));
    bench_step(&fake, 10, u1, y1, y4);
    bench_step(&fake, 16, u2, y1, y4); /* steps 11..15 never arrive */
    fixture_poll_all();
    y[0] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_Y1, y1);
    y[1] = (caekf_scalar_t)wire(CAEKF_MSG_BENCH_Y4, y4);
    TEST_ASSERT_EQUAL_INT(
        CAEKF_OK, caekf_step(&ref, (const caekf_scalar_t[]){(caekf_scalar_t)wire(CAEKF_MSG_BENCH_U, u1)}, y, NULL));
    TEST_ASSERT_EQUAL_INT(
        CAEKF_OK, caekf_step(&naive, (const caekf_scalar_t[]){(caekf_scalar_t)wire(CAEKF_MSG_BENCH_U, u1)}, y, NULL));
    for (k = 0; k < 5; k++) {
        caekf_report_t rep;
        TEST_ASSERT_EQUAL_INT(
            CAEKF_OK, caekf_predict(&ref, (const caekf_scalar_t[]){(caekf_scalar_t)wire(CAEKF_MSG_BENCH_U, u1)}, &rep));
        TEST_ASSERT_TRUE(rep.flags & CAEKF_FLAG_NO_MEASUREMENT);
    }
    TEST_ASSERT_EQUAL_INT(
        CAEKF_OK, caekf_step(&ref, (const caekf_scalar_t[]){(caekf_scalar_t)wire(CAEKF_MSG_BENCH_U, u2)}, y, NULL));
    TEST_ASSERT_EQUAL_INT(
        CAEKF_OK, caekf_step(&naive, (const caekf_scalar_t[]){(caekf_scalar_t)wire(CAEKF_MSG_BENCH_U, u2)}, y, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&ref, x));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&naive, xn));
    TEST_ASSERT_EQUAL_UINT32(5, counter(CAEKF_CNT_STEPS_SKIPPED));
    TEST_ASSERT_EQUAL_HEX16(CAEKF_STEP_FLAGS_STEP_GAP, tx_step(1).flags & CAEKF_STEP_FLAGS_STEP_GAP);
    for (k = 0; k < 4; k++) {
        TEST_ASSERT_TRUE(wire(CAEKF_MSG_EST_Q1, (double)x[k]) ==
                         tx_value((caekf_msg_t)(CAEKF_MSG_EST_Q1 + k), 1, NULL));
    }
    /* The bridge matters: without it the velocities would differ. */
    TEST_ASSERT_FALSE(wire(CAEKF_MSG_EST_V1, (double)xn[4]) == tx_value(CAEKF_MSG_EST_V1, 1, NULL));
}

static void test_frame_for_an_estimated_step_is_late(void)
{
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_step(&fake, 40, 0.0, 0.0, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 40, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 39, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(2, counter(CAEKF_CNT_RX_LATE));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_DONE));
}

static void test_nan_input_is_rejected_counted_and_the_estimator_untouched(void)
{
    static caekf_t before;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    memcpy(&before, &app.est, sizeof before);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 50, (double)NAN);
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 50, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_Y4, 50, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_U, 51, (double)INFINITY);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(2, counter(CAEKF_CNT_RX_BAD_VALUE));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT(0, fake.tx_count);
    TEST_ASSERT_EQUAL_MEMORY(&before, &app.est, sizeof before);
}

static void test_each_reject_class_is_counted(void)
{
    caekf_can_frame_t f;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    memset(&f, 0, sizeof f);

    f.id = 0x123; /* not in the DBC */
    f.dlc = 8;
    fake_push(&fake, &f);
    f.id = 0x100u | CAEKF_CAN_ID_EXT_FLAG; /* an extended ID that looks like BENCH_U */
    fake_push(&fake, &f);
    (void)caekf_proto_encode_value(CAEKF_MSG_EST_Q1, 1, 0.0, f.data);
    (void)caekf_proto_seal(CAEKF_MSG_EST_Q1, 0, &f); /* our own output: never an input */
    fake_push(&fake, &f);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(3, counter(CAEKF_CNT_RX_UNKNOWN_ID));

    (void)caekf_proto_encode_value(CAEKF_MSG_BENCH_U, 60, 0.0, f.data);
    bench_send(&fake, CAEKF_MSG_BENCH_U, &f); /* counter 0: accepted */
    f.dlc = 7;
    fake_push(&fake, &f);
    f.dlc = 8;
    f.data[5] ^= 0x10u;
    fake_push(&fake, &f);
    f.data[5] ^= 0x10u;
    fake_push(&fake, &f);                             /* the same frame again: duplicate counter */
    (void)caekf_proto_seal(CAEKF_MSG_BENCH_U, 5, &f); /* 0 -> 5: jump */
    fake_push(&fake, &f);
    fake.bench_counter[CAEKF_MSG_BENCH_U] = 6; /* the bench carries on from the re-synced counter */
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_BAD_DLC));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_BAD_CRC));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_DUPLICATE));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_COUNTER_JUMP));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_OK));

    fake.rx_errors_pending = 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_poll(&app));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_HAL_ERROR));

    fake.tx_fail = 1;
    bench_value(&fake, CAEKF_MSG_BENCH_U, 61, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_Y1, 61, 0.0);
    bench_value(&fake, CAEKF_MSG_BENCH_Y4, 61, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(12, counter(CAEKF_CNT_TX_ERRORS));
    TEST_ASSERT_EQUAL_UINT32(0, counter(CAEKF_CNT_TX_FRAMES));
}

static void test_counter_resyncs_only_after_the_bench_went_quiet(void)
{
    caekf_can_frame_t f;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    (void)caekf_proto_encode_value(CAEKF_MSG_BENCH_U, 70, 0.0, f.data);
    bench_send(&fake, CAEKF_MSG_BENCH_U, &f);
    fixture_poll_all();
    (void)caekf_proto_seal(CAEKF_MSG_BENCH_U, 9, &f);
    fake_push(&fake, &f);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_COUNTER_JUMP));
    fake.now_us += 500001u; /* default e2e_resync_us is 500 ms: a new bench run may start anywhere */
    (void)caekf_proto_seal(CAEKF_MSG_BENCH_U, 3, &f);
    fake_push(&fake, &f);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_RX_COUNTER_JUMP));
    TEST_ASSERT_EQUAL_UINT32(2, counter(CAEKF_CNT_RX_OK));
}

static void test_poll_takes_a_bounded_number_of_frames(void)
{
    unsigned i;
    for (i = 0; i < 100u; i++) {
        bench_value(&fake, CAEKF_MSG_BENCH_U, (uint16_t)i, 0.0);
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_poll(&app));
    TEST_ASSERT_EQUAL_UINT(100u - 64u, fake.rx_count);
    TEST_ASSERT_EQUAL_UINT32(64, counter(CAEKF_CNT_RX_UNCONFIGURED));
}

static void test_out_of_range_estimate_is_saturated_and_flagged(void)
{
    caekf_app_settings_t s;
    fixture_paper_settings(&s, CAEKF_FIXTURE_PRESET_SWITCHED);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_settings_set(&s, CAEKF_PARAM_Q0 + 1, 0.5)); /* beyond +/-34 mm */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_configure(&app, &s, NULL));
    bench_step(&fake, 1, 0.0, 0.0, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_HEX16(CAEKF_STEP_FLAGS_SATURATED, tx_step(0).flags & CAEKF_STEP_FLAGS_SATURATED);
    TEST_ASSERT_TRUE(counter(CAEKF_CNT_TX_SATURATED) >= 1u);
    TEST_ASSERT_TRUE(tx_value(CAEKF_MSG_EST_Q2, 0, NULL) > 0.0343);
}

static void test_init_and_poll_refuse_incomplete_set_ups(void)
{
    caekf_app_hal_t hal;
    caekf_app_config_t cfg;
    static caekf_app_t other;
    fake_hal_init(&fake, &hal);
    (void)caekf_app_config_default(&cfg);
    memset(&other, 0, sizeof other);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_poll(&other));
    hal.now_us = NULL;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_init(&other, &hal, &cfg));
    fake_hal_init(&fake, &hal);
    cfg.e2e_max_delta = 16;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_init(&other, &hal, &cfg));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_init(NULL, &hal, &cfg));
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_NULL, caekf_app_poll(NULL));
}

static void test_id_offset_moves_every_frame_and_the_dbc_ids_become_foreign(void)
{
    caekf_app_hal_t hal;
    caekf_app_config_t cfg;
    uint32_t id = 0;
    unsigned i;
    fake_hal_init(&fake, &hal);
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_config_default(&cfg));
    TEST_ASSERT_EQUAL_INT(0, cfg.id_offset);
    cfg.status_period_us = 0;
    cfg.id_offset = (int16_t)(0x7FF - 0x19C + 1); /* EST_P_GG2 (0x19C, the highest ID) would leave the 11-bit range */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_init(&app, &hal, &cfg));
    cfg.id_offset = -0x0C1; /* CTRL_RESET (0x0C0) would go below 0 */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_ERR_CONFIG, caekf_app_init(&app, &hal, &cfg));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_RANGE, caekf_proto_bus_id(CAEKF_MSG_EST_FD, cfg.id_offset, &id));
    cfg.id_offset = 0x7FF - 0x19C; /* the last valid offset: EST_P_GG2 at 0x7FF */
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_init(&app, &hal, &cfg));
    cfg.id_offset = 0x500;
    TEST_ASSERT_EQUAL_INT(CAEKF_APP_OK, caekf_app_init(&app, &hal, &cfg));
    fake.id_offset = 0x500;
    fixture_configure(CAEKF_FIXTURE_PRESET_SWITCHED);
    bench_step(&fake, 1, 0.25, 1e-7, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_DONE));
    TEST_ASSERT_EQUAL_UINT(12, fake.tx_count);
    for (i = 0; i < 12u; i++) {
        TEST_ASSERT_TRUE(fake.tx[i].id >= 0x5C0u && fake.tx[i].id <= 0x691u);
        TEST_ASSERT_TRUE(fake_tx_e2e_ok(&fake, i)); /* data IDs unchanged: the bench checks them as before */
    }
    TEST_ASSERT_EQUAL_HEX32(0x18Bu + 0x500u, fake.tx[11].id); /* EST_STEP, last */
    /* a bench still on the DBC's IDs is a foreign node now */
    fake.id_offset = 0;
    bench_step(&fake, 2, 0.25, 1e-7, 0.0);
    fixture_poll_all();
    TEST_ASSERT_EQUAL_UINT32(3, counter(CAEKF_CNT_RX_UNKNOWN_ID));
    TEST_ASSERT_EQUAL_UINT32(1, counter(CAEKF_CNT_STEPS_DONE));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_unconfigured_app_counts_bench_frames_and_sends_nothing);
    RUN_TEST(test_complete_step_sends_twelve_protected_frames_status_last);
    RUN_TEST(test_estimates_equal_a_directly_stepped_estimator);
    RUN_TEST(test_frames_of_a_step_may_arrive_in_any_order);
    RUN_TEST(test_partial_step_times_out_never_hangs_and_its_straggler_is_late);
    RUN_TEST(test_newer_step_supersedes_a_partial_one);
    RUN_TEST(test_repeated_signal_keeps_the_first_value);
    RUN_TEST(test_step_gap_is_flagged_and_counted_but_the_16_bit_wrap_is_not_a_gap);
    RUN_TEST(test_step_gap_is_bridged_by_prediction_only_steps);
    RUN_TEST(test_frame_for_an_estimated_step_is_late);
    RUN_TEST(test_nan_input_is_rejected_counted_and_the_estimator_untouched);
    RUN_TEST(test_each_reject_class_is_counted);
    RUN_TEST(test_counter_resyncs_only_after_the_bench_went_quiet);
    RUN_TEST(test_poll_takes_a_bounded_number_of_frames);
    RUN_TEST(test_out_of_range_estimate_is_saturated_and_flagged);
    RUN_TEST(test_init_and_poll_refuse_incomplete_set_ups);
    RUN_TEST(test_id_offset_moves_every_frame_and_the_dbc_ids_become_foreign);
    return UNITY_END();
}
