/* Codec round trips at the resolution limits, saturation, non-finite values, control frames. The
 * byte-level agreement with the DBC is tests/protocol's job; this suite checks the C semantics. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "caekf/caekf_e2e.h"
#include "caekf/caekf_proto.h"
#include "unity.h"

#define POS_LSB 1e-12
#define VEL_LSB 1e-10
#define RAW36_MAX 34359738367.0 /* 2^35 - 1 */

void setUp(void) {}
void tearDown(void) {}

static double roundtrip(caekf_msg_t msg, uint16_t step, double value, int expect_status)
{
    uint8_t d[8];
    uint16_t got_step = 0;
    double got = -12345.0;
    TEST_ASSERT_EQUAL_INT(expect_status, caekf_proto_encode_value(msg, step, value, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_value(msg, d, &got_step, &got));
    TEST_ASSERT_EQUAL_UINT16(step, got_step);
    return got;
}

static void assert_same_double(double expected, double actual)
{
    TEST_ASSERT_TRUE_MESSAGE(memcmp(&expected, &actual, sizeof expected) == 0, "not the same double");
}

static void test_positions_exact_on_the_lsb_grid_up_to_the_range_ends(void)
{
    const double ks[] = {0.0, 1.0, -1.0, 2.0, 1e6, -1e6, RAW36_MAX, -RAW36_MAX - 1.0};
    unsigned i;
    for (i = 0; i < sizeof ks / sizeof ks[0]; i++) {
        assert_same_double(ks[i] * POS_LSB, roundtrip(CAEKF_MSG_BENCH_Y1, 65535, ks[i] * POS_LSB, CAEKF_PROTO_OK));
        assert_same_double(ks[i] * VEL_LSB, roundtrip(CAEKF_MSG_EST_V2, 0, ks[i] * VEL_LSB, CAEKF_PROTO_OK));
    }
}

static void test_quantisation_error_is_at_most_half_an_lsb(void)
{
    /* 2.4 um penetration scale and the +/-34 mm range: quantisation stays at 0.5 pm */
    unsigned i;
    for (i = 0; i < 2000u; i++) {
        const double v = -0.034 + 0.068 * (double)i / 1999.0 + 1.234567e-13 * (double)(i % 7u);
        const double q = roundtrip(CAEKF_MSG_EST_Q2, (uint16_t)i, v, CAEKF_PROTO_OK);
        TEST_ASSERT_TRUE(fabs(q - v) <= 0.5 * POS_LSB * (1.0 + 1e-6));
        TEST_ASSERT_TRUE(fabs(roundtrip(CAEKF_MSG_EST_V3, 1, v * 100.0, CAEKF_PROTO_OK) - v * 100.0) <=
                         0.5 * VEL_LSB * (1.0 + 1e-6));
    }
}

static void test_ties_round_to_even_like_cantools(void)
{
    /* 2.5 and 3.5 LSB are exact ties after the division: ties go to the even raw value */
    TEST_ASSERT_TRUE(2.5 * VEL_LSB / VEL_LSB == 2.5);
    assert_same_double(2.0 * VEL_LSB, roundtrip(CAEKF_MSG_EST_V1, 1, 2.5 * VEL_LSB, CAEKF_PROTO_OK));
    TEST_ASSERT_TRUE(-3.5 * VEL_LSB / VEL_LSB == -3.5);
    assert_same_double(-4.0 * VEL_LSB, roundtrip(CAEKF_MSG_EST_V1, 1, -3.5 * VEL_LSB, CAEKF_PROTO_OK));
}

static void test_beyond_the_range_saturates_and_says_so(void)
{
    assert_same_double(RAW36_MAX * POS_LSB, roundtrip(CAEKF_MSG_EST_Q1, 2, 0.05, CAEKF_PROTO_SATURATED));
    assert_same_double((-RAW36_MAX - 1.0) * POS_LSB, roundtrip(CAEKF_MSG_EST_Q1, 2, -1e300, CAEKF_PROTO_SATURATED));
    assert_same_double(0.0, roundtrip(CAEKF_MSG_EST_Q4, 2, (double)NAN, CAEKF_PROTO_SATURATED));
    assert_same_double(RAW36_MAX * VEL_LSB, roundtrip(CAEKF_MSG_EST_V4, 2, (double)INFINITY, CAEKF_PROTO_SATURATED));
    assert_same_double((double)FLT_MAX, roundtrip(CAEKF_MSG_EST_P_NORM, 3, 1e39, CAEKF_PROTO_SATURATED));
    assert_same_double(-(double)FLT_MAX, roundtrip(CAEKF_MSG_EST_GAMMA, 3, -1e300, CAEKF_PROTO_SATURATED));
}

static void test_float32_signals_keep_24_bits_over_their_wide_range(void)
{
    const double vals[] = {1e8, 7.5e7, -1e12, -6e11, 1e17, 1.6e16, 1e-20, 2.6, -2.6};
    unsigned i;
    for (i = 0; i < sizeof vals / sizeof vals[0]; i++) {
        const double got = roundtrip(CAEKF_MSG_EST_GAMMA, 9, vals[i], CAEKF_PROTO_OK);
        TEST_ASSERT_TRUE(fabs(got - vals[i]) <= fabs(vals[i]) * 0x1p-24);
        assert_same_double((double)(float)vals[i], got);
        assert_same_double(got, roundtrip(CAEKF_MSG_BENCH_U, 9, got, CAEKF_PROTO_OK));
    }
}

static void test_non_finite_float_is_sent_but_never_decoded(void)
{
    const double bad[] = {(double)NAN, (double)INFINITY, -(double)INFINITY};
    unsigned i;
    for (i = 0; i < 3u; i++) {
        uint8_t d[8];
        uint16_t step = 77;
        double value = 42.0;
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_value(CAEKF_MSG_BENCH_U, 5, bad[i], d));
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_VALUE, caekf_proto_decode_value(CAEKF_MSG_BENCH_U, d, &step, &value));
        TEST_ASSERT_EQUAL_UINT16(77, step);
        assert_same_double(42.0, value);
    }
}

static void test_value_codec_refuses_other_layouts_and_nulls(void)
{
    uint8_t d[8];
    uint16_t s;
    double v;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_MSG, caekf_proto_encode_value(CAEKF_MSG_EST_STEP, 1, 1.0, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_MSG, caekf_proto_encode_value(CAEKF_MSG_COUNT, 1, 1.0, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_MSG, caekf_proto_decode_value(CAEKF_MSG_CTRL_RESET, d, &s, &v));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_value(CAEKF_MSG_BENCH_U, 1, 1.0, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_value(CAEKF_MSG_BENCH_U, d, NULL, &v));
}

static void test_e2e_fields_are_left_to_the_sealer(void)
{
    uint8_t d[8];
    memset(d, 0xFF, sizeof d);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_value(CAEKF_MSG_BENCH_Y4, 0xFFFF, -1.0 * POS_LSB, d));
    TEST_ASSERT_EQUAL_HEX8(0x00, d[0]);
    TEST_ASSERT_EQUAL_HEX8(0xF0, d[1]); /* counter nibble zero, STEP's low nibble above it */
}

static void test_step_frame_roundtrip(void)
{
    caekf_msg_step_t in = {0xBEEF, 0x7123, 20, -6}, out;
    uint8_t d[8];
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_step(&in, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_step(d, &out));
    TEST_ASSERT_EQUAL_UINT16(in.step, out.step);
    TEST_ASSERT_EQUAL_HEX16(in.flags, out.flags);
    TEST_ASSERT_EQUAL_UINT8(in.newton_iters, out.newton_iters);
    TEST_ASSERT_EQUAL_INT8(in.step_status, out.step_status);
}

static void test_control_frames_roundtrip(void)
{
    caekf_msg_reset_t r = {37, 200}, r2;
    caekf_msg_param_t p = {36, -22, -137438953472LL}, p2;
    caekf_msg_status_req_t q = {99}, q2;
    caekf_msg_ack_t a = {7, -4, 31, 12, 3}, a2;
    uint8_t d[8];
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_reset(&r, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_reset(d, &r2));
    TEST_ASSERT_EQUAL_MEMORY(&r, &r2, sizeof r);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_param(&p, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_param(d, &p2));
    TEST_ASSERT_EQUAL_UINT8(p.param_id, p2.param_id);
    TEST_ASSERT_EQUAL_INT8(p.param_exp10, p2.param_exp10);
    TEST_ASSERT_EQUAL_INT64(p.param_mantissa, p2.param_mantissa);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_status_req(&q, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_status_req(d, &q2));
    TEST_ASSERT_EQUAL_UINT8(q.token, q2.token);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_ack(&a, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_ack(d, &a2));
    TEST_ASSERT_EQUAL_MEMORY(&a, &a2, sizeof a);
}

static void test_param_fields_out_of_range_are_refused(void)
{
    caekf_msg_param_t p = {0, 0, 137438953472LL}; /* 2^37: one past the 38-bit field */
    uint8_t d[8];
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_RANGE, caekf_proto_encode_param(&p, d));
    p.param_mantissa = 1;
    p.param_exp10 = 32;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_RANGE, caekf_proto_encode_param(&p, d));
    p.param_exp10 = -33;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_RANGE, caekf_proto_encode_param(&p, d));
}

static void test_param_value_is_the_correctly_rounded_double(void)
{
    caekf_msg_param_t p = {0, -3, 1};
    double v = 0.0;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_param_value(&p, &v));
    assert_same_double(1.0e-3, v);
    p.param_mantissa = 75;
    p.param_exp10 = 6;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_param_value(&p, &v));
    assert_same_double(7.5e7, v);
    p.param_mantissa = 1;
    p.param_exp10 = -7;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_param_value(&p, &v));
    assert_same_double(1.0e-7, v);
    p.param_mantissa = -314159265359LL / 10;
    p.param_exp10 = -10;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_param_value(&p, &v));
    assert_same_double(-3.1415926535, v);
    p.param_exp10 = 23;
    v = 5.0;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_VALUE, caekf_proto_param_value(&p, &v));
    assert_same_double(5.0, v);
}

static void test_health_pages_are_bounded_and_counters_wrap_at_24_bits(void)
{
    caekf_msg_health_t h = {CAEKF_HEALTH_PAGES - 1u, 0x01234567u, 0x00FFFFFFu}, h2;
    uint8_t d[8];
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_health(&h, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_health(d, &h2));
    TEST_ASSERT_EQUAL_UINT8(h.page, h2.page);
    TEST_ASSERT_EQUAL_HEX32(0x00234567u, h2.counter_a);
    TEST_ASSERT_EQUAL_HEX32(0x00FFFFFFu, h2.counter_b);
    h.page = CAEKF_HEALTH_PAGES;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_RANGE, caekf_proto_encode_health(&h, d));
    d[1] = (uint8_t)((d[1] & 0x0Fu) | 0xF0u); /* page 15 on the wire */
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_VALUE, caekf_proto_decode_health(d, &h2));
}

static void test_ids_map_both_ways_and_foreign_ids_are_unknown(void)
{
    unsigned i;
    caekf_msg_t msg;
    for (i = 0; i < (unsigned)CAEKF_MSG_COUNT; i++) {
        const caekf_msg_info_t *info;
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_msg_info((caekf_msg_t)i, &info));
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_msg_from_id(info->can_id, &msg));
        TEST_ASSERT_EQUAL_INT((int)i, (int)msg);
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_MSG, caekf_proto_msg_from_id(info->can_id | CAEKF_CAN_ID_EXT_FLAG, &msg));
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_MSG, caekf_proto_msg_from_id(0x10C, &msg));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_MSG, caekf_proto_msg_from_id(0x7FF, &msg));
}

static void test_seal_makes_a_frame_the_receiver_accepts(void)
{
    caekf_can_frame_t f;
    const caekf_msg_info_t *info;
    caekf_e2e_rx_t rx;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_value(CAEKF_MSG_EST_Q3, 12, 1e-6, f.data));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_seal(CAEKF_MSG_EST_Q3, 11, &f));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_msg_info(CAEKF_MSG_EST_Q3, &info));
    TEST_ASSERT_EQUAL_HEX32(0x183u, f.id);
    TEST_ASSERT_EQUAL_UINT8(8, f.dlc);
    TEST_ASSERT_EQUAL_UINT8(11, f.data[1] & 0x0Fu);
    (void)caekf_e2e_rx_init(&rx);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_check(&rx, info->data_id, 1, f.data, f.dlc, NULL));
}

static void test_names_cover_each_table_and_stop_at_its_end(void)
{
    const char *name = NULL;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_counter_name(CAEKF_CNT_STATUS_REQUESTS, &name));
    TEST_ASSERT_EQUAL_STRING("STATUS_REQUESTS", name);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_RANGE, caekf_proto_counter_name(CAEKF_CNT_COUNT, &name));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_counter_name(0, NULL));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_positions_exact_on_the_lsb_grid_up_to_the_range_ends);
    RUN_TEST(test_quantisation_error_is_at_most_half_an_lsb);
    RUN_TEST(test_ties_round_to_even_like_cantools);
    RUN_TEST(test_beyond_the_range_saturates_and_says_so);
    RUN_TEST(test_float32_signals_keep_24_bits_over_their_wide_range);
    RUN_TEST(test_non_finite_float_is_sent_but_never_decoded);
    RUN_TEST(test_value_codec_refuses_other_layouts_and_nulls);
    RUN_TEST(test_e2e_fields_are_left_to_the_sealer);
    RUN_TEST(test_step_frame_roundtrip);
    RUN_TEST(test_control_frames_roundtrip);
    RUN_TEST(test_param_fields_out_of_range_are_refused);
    RUN_TEST(test_param_value_is_the_correctly_rounded_double);
    RUN_TEST(test_health_pages_are_bounded_and_counters_wrap_at_24_bits);
    RUN_TEST(test_ids_map_both_ways_and_foreign_ids_are_unknown);
    RUN_TEST(test_seal_makes_a_frame_the_receiver_accepts);
    RUN_TEST(test_names_cover_each_table_and_stop_at_its_end);
    return UNITY_END();
}
