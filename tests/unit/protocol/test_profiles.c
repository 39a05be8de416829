/* The production and CAN FD profiles' codecs (BENCH_YP, EST_PROD, EST_PAGE, BENCH_FD, EST_FD) and the control
 * codecs' tables (EST_HEALTH's counters, CTRL_PARAM's powers of ten), in the protocol suites themselves: before,
 * only the app suites reached them, and tools/mutation.py showed most of codec_step.c unchecked by the protocol
 * suites (docs/mutation.md). Round trips with each field distinct, the E2E bytes left zero for the sealer, the
 * statuses of clipping and of refused fields. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "caekf/caekf_proto.h"
#include "unity.h"

#define POS_LSB 1e-12
#define VEL_LSB 1e-10

void setUp(void) {}
void tearDown(void) {}

static void assert_same_double(double expected, double actual)
{
    TEST_ASSERT_TRUE_MESSAGE(memcmp(&expected, &actual, sizeof expected) == 0, "not the same double");
}

/* Before an encode: the output buffer filled with 0xEE and the stack below the caller with 0xA5, so that the
 * encoder's uninitialised locals hold a pattern rather than whatever an earlier call left (often zeros): a
 * field it forgets to clear, or a pointer it reads before setting, then shows deterministically. Called
 * through a volatile pointer so that it is never inlined into the caller's own frame. */
static void fresh_impl(uint8_t *d, size_t n)
{
    volatile uint8_t area[2048];
    unsigned i;
    for (i = 0; i < sizeof area; i++) {
        area[i] = 0xA5u;
    }
    if (d != NULL) {
        memset(d, 0xEE, n);
    }
}
static void (*volatile fresh)(uint8_t *d, size_t n) = fresh_impl;

/* The E2E fields of a fresh encode: CRC and counter are the sealer's, the encoder leaves them zero. */
static void assert_e2e_fields_zero(const uint8_t *d, int fd)
{
    TEST_ASSERT_EQUAL_HEX8(0u, d[0]);
    if (fd) {
        TEST_ASSERT_EQUAL_HEX8(0u, d[1]);
        TEST_ASSERT_EQUAL_HEX8(0u, d[2] & 0x0Fu);
    } else {
        TEST_ASSERT_EQUAL_HEX8(0u, d[1] & 0x0Fu);
    }
}

static void test_yp_roundtrip_on_its_grid_and_clipping(void)
{
    const double max_y = (ldexp(1.0, (int)CAEKF_YP_BITS - 1) - 1.0) * CAEKF_YP_LSB;
    caekf_msg_yp_t in = {201u, 123.0 * CAEKF_YP_LSB, -4567.0 * CAEKF_YP_LSB}, out;
    uint8_t d[8];
    fresh(d, sizeof d);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_yp(&in, d));
    assert_e2e_fields_zero(d, 0);
    memset(&out, 0, sizeof out);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_yp(d, &out));
    TEST_ASSERT_EQUAL_UINT8(201u, out.step);
    assert_same_double(in.y1, out.y1);
    assert_same_double(in.y4, out.y4);
    /* either position beyond the range: clipped, and said */
    in.y1 = 1.0;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_SATURATED, caekf_proto_encode_yp(&in, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_yp(d, &out));
    assert_same_double(max_y, out.y1);
    assert_same_double(in.y4, out.y4);
    in.y1 = 0.0;
    in.y4 = -1.0;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_SATURATED, caekf_proto_encode_yp(&in, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_yp(d, &out));
    assert_same_double(-max_y - CAEKF_YP_LSB, out.y4);
}

static void test_prod_keeps_step_and_flags_within_their_masks(void)
{
    caekf_msg_prod_t in = {0xA5u, 0x0ABCu, 2.5e7}, out;
    uint8_t d[8];
    fresh(d, sizeof d);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_prod(&in, d));
    assert_e2e_fields_zero(d, 0);
    memset(&out, 0, sizeof out);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_prod(d, &out));
    TEST_ASSERT_EQUAL_UINT8(0xA5u & CAEKF_PROD_STEP_MASK, out.step);
    TEST_ASSERT_EQUAL_HEX16(0x0ABCu & CAEKF_PROD_FLAGS_MASK, out.flags);
    assert_same_double(2.5e7, out.gamma);
    /* flag bits beyond the mask are not sent */
    in.flags = 0xFFFFu;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_prod(&in, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_prod(d, &out));
    TEST_ASSERT_EQUAL_HEX16(CAEKF_PROD_FLAGS_MASK, out.flags);
    in.gamma = 1e300;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_SATURATED, caekf_proto_encode_prod(&in, d));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_prod(d, &out));
    assert_same_double((double)FLT_MAX, out.gamma);
}

static void test_every_page_carries_its_own_value_and_the_info_page_its_fields(void)
{
    unsigned p;
    uint8_t d[8];
    caekf_msg_page_t in, out;
    for (p = 0; p < CAEKF_PAGE_STEP_INFO; p++) {
        memset(&in, 0, sizeof in);
        in.page = (uint8_t)p;
        in.step = (uint16_t)(1000u + p);
        in.value = 1.5 + (double)p; /* distinct and exact in float32 */
        fresh(d, sizeof d);
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_page(&in, d));
        assert_e2e_fields_zero(d, 0);
        memset(&out, 0xEE, sizeof out);
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_page(d, &out));
        TEST_ASSERT_EQUAL_UINT8(p, out.page);
        TEST_ASSERT_EQUAL_UINT16(1000u + p, out.step);
        assert_same_double(1.5 + (double)p, out.value);
        /* a value page's info is cleared, its step the frame's */
        TEST_ASSERT_EQUAL_UINT16(1000u + p, out.info.step);
        TEST_ASSERT_EQUAL_HEX16(0u, out.info.flags);
        TEST_ASSERT_EQUAL_UINT8(0u, out.info.newton_iters);
        TEST_ASSERT_EQUAL_INT8(0, out.info.step_status);
    }
    memset(&in, 0, sizeof in);
    in.page = CAEKF_PAGE_STEP_INFO;
    in.step = 4242u;
    in.value = 99.0; /* not sent on the info page */
    in.info.flags = 0x1234u;
    in.info.newton_iters = 7u;
    in.info.step_status = -3;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_page(&in, d));
    memset(&out, 0xEE, sizeof out);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_page(d, &out));
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PAGE_STEP_INFO, out.page);
    TEST_ASSERT_EQUAL_UINT16(4242u, out.step);
    TEST_ASSERT_EQUAL_UINT16(4242u, out.info.step);
    TEST_ASSERT_EQUAL_HEX16(0x1234u, out.info.flags);
    TEST_ASSERT_EQUAL_UINT8(7u, out.info.newton_iters);
    TEST_ASSERT_EQUAL_INT8(-3, out.info.step_status);
    assert_same_double(0.0, out.value);
}

static void test_pages_past_the_last_are_refused_both_ways(void)
{
    caekf_msg_page_t in, out;
    uint8_t d[8];
    memset(&in, 0, sizeof in);
    in.page = CAEKF_PAGE_COUNT;
    memset(d, 0xEE, sizeof d);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_RANGE, caekf_proto_encode_page(&in, d));
    TEST_ASSERT_EQUAL_HEX8(0xEEu, d[2]);
    in.page = 0u;
    in.value = 1e300;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_SATURATED, caekf_proto_encode_page(&in, d));
    d[1] = (uint8_t)((d[1] & 0x0Fu) | (CAEKF_PAGE_COUNT << 4)); /* the first page past the last, on the wire */
    out.page = 0xEEu;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_VALUE, caekf_proto_decode_page(d, &out));
    TEST_ASSERT_EQUAL_HEX8(0xEEu, out.page);
}

static void test_fd_in_roundtrip_clipping_and_refused_input(void)
{
    caekf_msg_fd_in_t in = {65000u, -12.25, 3.0e-3 + 7.0 * POS_LSB, -1.0e-3 - 3.0 * POS_LSB}, out;
    uint8_t d[CAEKF_CAN_FD_MAX_LEN];
    fresh(d, sizeof d);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_fd_in(&in, d));
    assert_e2e_fields_zero(d, 1);
    memset(&out, 0, sizeof out);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_fd_in(d, &out));
    TEST_ASSERT_EQUAL_UINT16(65000u, out.step);
    assert_same_double(-12.25, out.u);
    TEST_ASSERT_DOUBLE_WITHIN(0.5 * POS_LSB, in.y1, out.y1);
    TEST_ASSERT_DOUBLE_WITHIN(0.5 * POS_LSB, in.y4, out.y4);
    in.y4 = 1.0; /* beyond the 36-bit range of 1e-12 m */
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_SATURATED, caekf_proto_encode_fd_in(&in, d));
    in.y4 = 0.0;
    in.y1 = -1.0;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_SATURATED, caekf_proto_encode_fd_in(&in, d));
    in.y1 = 0.0;
    in.u = 1e300;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_SATURATED, caekf_proto_encode_fd_in(&in, d));
    /* a NaN force is sent, and refused on receipt with nothing written */
    in.u = (double)NAN;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_fd_in(&in, d));
    out.step = 7u;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_VALUE, caekf_proto_decode_fd_in(d, &out));
    TEST_ASSERT_EQUAL_UINT16(7u, out.step);
}

static void test_fd_out_positions_and_velocities_on_their_own_grids(void)
{
    caekf_msg_fd_out_t in, out;
    uint8_t d[CAEKF_CAN_FD_MAX_LEN];
    unsigned i;
    memset(&in, 0, sizeof in);
    in.step = 513u;
    /* positions of a few pm (velocities' LSB would lose them), velocities of 1 m/s (beyond the positions' range) */
    for (i = 0; i < 4u; i++) {
        in.x[i] = (double)(i + 1u) * 3.0 * POS_LSB;
        in.x[4u + i] = 1.0 + (double)i * 0.25;
    }
    in.x[8] = 3.0e7;
    in.p_norm = 0.125;
    in.p_gg = 1.5e9; /* exact in float32 */
    in.info.flags = 0x0F0Fu;
    in.info.newton_iters = 3u;
    in.info.step_status = -1;
    fresh(d, sizeof d);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_fd_out(&in, d));
    assert_e2e_fields_zero(d, 1);
    memset(&out, 0, sizeof out);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_fd_out(d, &out));
    for (i = 0; i < 4u; i++) {
        TEST_ASSERT_DOUBLE_WITHIN(0.5 * POS_LSB, in.x[i], out.x[i]);
        TEST_ASSERT_DOUBLE_WITHIN(0.5 * VEL_LSB, in.x[4u + i], out.x[4u + i]);
    }
    assert_same_double(3.0e7, out.x[8]);
    assert_same_double(0.125, out.p_norm);
    assert_same_double(1.5e9, out.p_gg);
    TEST_ASSERT_EQUAL_UINT16(513u, out.step);
    TEST_ASSERT_EQUAL_UINT16(513u, out.info.step);
    TEST_ASSERT_EQUAL_HEX16(0x0F0Fu, out.info.flags);
    TEST_ASSERT_EQUAL_UINT8(3u, out.info.newton_iters);
    TEST_ASSERT_EQUAL_INT8(-1, out.info.step_status);
    /* each value beyond its range is clipped and said: a position, a velocity, the three float32 values */
    {
        caekf_msg_fd_out_t big;
        const unsigned slots[] = {0u, 5u, 8u, 9u, 10u};
        for (i = 0; i < sizeof slots / sizeof slots[0]; i++) {
            big = in;
            *(slots[i] < 9u ? &big.x[slots[i]] : (slots[i] == 9u ? &big.p_norm : &big.p_gg)) = 1e300;
            TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_SATURATED, caekf_proto_encode_fd_out(&big, d));
        }
    }
}

static void test_health_pages_carry_both_their_counters(void)
{
    unsigned page;
    for (page = 0; page < CAEKF_HEALTH_PAGES; page++) {
        caekf_msg_health_t h = {(uint8_t)page, 0x00100000u + page, 0x00012345u + 0x100u * page}, h2;
        uint8_t d[8];
        fresh(d, sizeof d);
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_health(&h, d));
        assert_e2e_fields_zero(d, 0);
        memset(&h2, 0, sizeof h2);
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_decode_health(d, &h2));
        TEST_ASSERT_EQUAL_UINT8(page, h2.page);
        TEST_ASSERT_EQUAL_HEX32(h.counter_a, h2.counter_a);
        TEST_ASSERT_EQUAL_HEX32(h.counter_b, h2.counter_b);
    }
}

static void test_health_page_just_past_the_last_is_refused_on_receipt(void)
{
    caekf_msg_health_t h = {0u, 1u, 2u}, h2 = {0xEEu, 0u, 0u};
    uint8_t d[8];
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_health(&h, d));
    d[1] = (uint8_t)((d[1] & 0x0Fu) | (CAEKF_HEALTH_PAGES << 4));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_VALUE, caekf_proto_decode_health(d, &h2));
    TEST_ASSERT_EQUAL_HEX8(0xEEu, h2.page);
}

/* An unknown message is refused before its table row is read: with the stack painted, a codec that read the
 * row it was not given would follow a wild pointer. */
static void test_value_codec_refuses_an_unknown_message_before_reading_its_row(void)
{
    uint8_t d[8];
    uint16_t step = 3u;
    double v = 4.0;
    memset(d, 0, sizeof d);
    fresh(NULL, 0u);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_MSG, caekf_proto_encode_value(CAEKF_MSG_COUNT, 1u, 1.0, d));
    fresh(NULL, 0u);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_MSG, caekf_proto_decode_value(CAEKF_MSG_COUNT, d, &step, &v));
    TEST_ASSERT_EQUAL_UINT16(3u, step);
}

/* Every power of ten of the table, both signs of the exponent, against 10^k made by exact multiplications
 * (10^k is exact in a double up to k = 22). */
static void test_param_value_uses_every_power_of_ten(void)
{
    double p = 1.0;
    int k;
    for (k = 0; k <= 22; k++) {
        caekf_msg_param_t m = {0u, (int8_t)k, 7};
        double v = 0.0;
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_param_value(&m, &v));
        assert_same_double(7.0 * p, v);
        m.param_exp10 = (int8_t)-k;
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_param_value(&m, &v));
        assert_same_double(7.0 / p, v);
        p *= 10.0;
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_yp_roundtrip_on_its_grid_and_clipping);
    RUN_TEST(test_prod_keeps_step_and_flags_within_their_masks);
    RUN_TEST(test_every_page_carries_its_own_value_and_the_info_page_its_fields);
    RUN_TEST(test_pages_past_the_last_are_refused_both_ways);
    RUN_TEST(test_fd_in_roundtrip_clipping_and_refused_input);
    RUN_TEST(test_fd_out_positions_and_velocities_on_their_own_grids);
    RUN_TEST(test_health_pages_carry_both_their_counters);
    RUN_TEST(test_health_page_just_past_the_last_is_refused_on_receipt);
    RUN_TEST(test_value_codec_refuses_an_unknown_message_before_reading_its_row);
    RUN_TEST(test_param_value_uses_every_power_of_ten);
    return UNITY_END();
}
