/* The protocol library's argument contract and the edges of its scaling, which neither the codec suites nor the
 * fuzz harnesses reach (tools/coverage.sh showed them untaken; docs/coverage.md): every public function refuses
 * NULL arguments and unknown messages with its error status and writes nothing; the CRC-16 and FD E2E functions
 * refuse lengths outside 3..64; caekf_scaled_to_raw clips a value that only rounding takes past the signal's
 * range. Each test fails (or crashes) when the check it covers is removed. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "caekf/caekf_crc16.h"
#include "caekf/caekf_crc8.h"
#include "caekf/caekf_e2e.h"
#include "caekf/caekf_proto.h"
#include "scaling.h"
#include "unity.h"

void setUp(void) {}
void tearDown(void) {}

static const uint8_t zeros[CAEKF_CAN_FD_MAX_LEN];

static void test_message_table_refuses_null_and_unknown_messages(void)
{
    caekf_can_frame_t f;
    uint32_t id = 0x55u;
    caekf_msg_t msg = CAEKF_MSG_EST_HEALTH;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_msg_info(CAEKF_MSG_EST_HEALTH, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_bus_id(CAEKF_MSG_EST_HEALTH, 0, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_MSG, caekf_proto_bus_id(CAEKF_MSG_COUNT, 0, &id));
    TEST_ASSERT_EQUAL_UINT32(0x55u, id);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_msg_from_bus_id(0x100u, 0, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_seal(CAEKF_MSG_EST_HEALTH, 0u, NULL));
    memset(&f, 0xA5, sizeof f);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_MSG, caekf_proto_seal(CAEKF_MSG_COUNT, 0u, &f));
    TEST_ASSERT_EQUAL_HEX8(0xA5u, f.dlc);
    TEST_ASSERT_EQUAL_INT(CAEKF_MSG_EST_HEALTH, msg);
}

static void test_codecs_refuse_null_arguments(void)
{
    uint8_t data[CAEKF_CAN_FD_MAX_LEN];
    caekf_msg_health_t h;
    caekf_msg_yp_t yp;
    caekf_msg_prod_t prod;
    caekf_msg_page_t page;
    caekf_msg_fd_in_t fin;
    caekf_msg_fd_out_t fout;
    caekf_msg_param_t param;
    uint16_t step;
    double v;
    memset(&h, 0, sizeof h);
    memset(&yp, 0, sizeof yp);
    memset(&prod, 0, sizeof prod);
    memset(&page, 0, sizeof page);
    memset(&fin, 0, sizeof fin);
    memset(&fout, 0, sizeof fout);
    memset(&param, 0, sizeof param);
    memset(data, 0, sizeof data);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_health(NULL, data));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_health(&h, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_health(NULL, &h));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_health(data, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_yp(NULL, data));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_yp(&yp, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_yp(NULL, &yp));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_yp(data, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_prod(NULL, data));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_prod(&prod, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_prod(NULL, &prod));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_prod(data, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_page(NULL, data));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_page(&page, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_page(NULL, &page));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_page(data, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_fd_in(NULL, data));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_fd_in(&fin, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_fd_in(NULL, &fin));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_fd_in(data, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_fd_out(NULL, data));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_encode_fd_out(&fout, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_fd_out(NULL, &fout));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_fd_out(data, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_value(CAEKF_MSG_BENCH_Y1, NULL, &step, &v));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_value(CAEKF_MSG_BENCH_Y1, data, NULL, &v));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_decode_value(CAEKF_MSG_BENCH_Y1, data, &step, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_param_value(NULL, &v));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_NULL, caekf_proto_param_value(&param, NULL));
}

static void test_crc16_and_fd_e2e_refuse_null_and_bad_lengths(void)
{
    uint8_t p[CAEKF_CAN_FD_MAX_LEN + 1];
    uint16_t crc = 0x1234u;
    caekf_e2e_rx_t rx;
    uint8_t lost = 7u;
    memset(p, 0x3C, sizeof p);
    TEST_ASSERT_EQUAL_HEX16(0xBEEFu, caekf_crc16_update(0xBEEFu, NULL, 5u));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_NULL, caekf_e2e_crc16(1u, NULL, 8u, &crc));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_NULL, caekf_e2e_crc16(1u, p, 8u, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_DLC, caekf_e2e_crc16(1u, p, 2u, &crc));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_DLC, caekf_e2e_crc16(1u, p, 65u, &crc));
    TEST_ASSERT_EQUAL_HEX16(0x1234u, crc);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_crc16(1u, p, 3u, &crc));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_DLC, caekf_e2e_protect_fd(1u, 0u, p, 65u));
    TEST_ASSERT_EQUAL_HEX8(0x3Cu, p[0]);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_rx_init(&rx));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_NULL, caekf_e2e_check_fd(NULL, 1u, 1u, p, 8u, 8u, &lost));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_NULL, caekf_e2e_check_fd(&rx, 1u, 1u, NULL, 8u, 8u, &lost));
    /* a length the CRC-16 refuses is a DLC error even when the frame has that length */
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_DLC, caekf_e2e_check_fd(&rx, 1u, 1u, zeros, 2u, 2u, &lost));
    TEST_ASSERT_EQUAL_UINT8(7u, lost);
}

static void test_scaled_to_raw_clips_what_rounding_takes_past_the_range(void)
{
    /* 36-bit signed field, lsb 1: max 2^35 - 1 (odd), min -2^35. max + 0.5 is below max + 1, so only the
     * rounding (half to even: max + 1) leaves the range; min - 0.75 rounds to min - 1. */
    const double max_raw = 34359738367.0;
    const double min_raw = -34359738368.0;
    int64_t raw = 0;
    TEST_ASSERT_EQUAL_INT(1, caekf_scaled_to_raw(max_raw + 0.5, 1.0, 36u, &raw));
    TEST_ASSERT_EQUAL_INT64(INT64_C(34359738367), raw);
    TEST_ASSERT_EQUAL_INT(1, caekf_scaled_to_raw(min_raw - 0.75, 1.0, 36u, &raw));
    TEST_ASSERT_EQUAL_INT64(-INT64_C(34359738368), raw);
    /* in range: not clipped (the ties go to the even neighbour) */
    TEST_ASSERT_EQUAL_INT(0, caekf_scaled_to_raw(max_raw - 0.5, 1.0, 36u, &raw));
    TEST_ASSERT_EQUAL_INT64(INT64_C(34359738366), raw);
    TEST_ASSERT_EQUAL_INT(0, caekf_scaled_to_raw(min_raw + 0.25, 1.0, 36u, &raw));
    TEST_ASSERT_EQUAL_INT64(-INT64_C(34359738368), raw);
}

/* scaling.h's contract: 1 when clipped (not merely non-zero), a NaN gives raw 0, ties to even on both sides of
 * zero; float32: FLT_MAX itself is not clipped, the value of a non-finite pattern is -1. (tools/mutation.py:
 * the codec only reads these results as booleans, so no codec test tells 1 from 2.) */
static void test_scaling_results_are_exactly_as_documented(void)
{
    int64_t raw = 5;
    uint32_t bits = 0u;
    double v = 0.0;
    float f;
    TEST_ASSERT_EQUAL_INT(1, caekf_scaled_to_raw((double)NAN, 1.0, 36u, &raw));
    TEST_ASSERT_EQUAL_INT64(0, raw);
    TEST_ASSERT_EQUAL_INT(1, caekf_scaled_to_raw(1e300, 1.0, 36u, &raw));
    TEST_ASSERT_EQUAL_INT(1, caekf_scaled_to_raw(-1e300, 1.0, 36u, &raw));
    TEST_ASSERT_EQUAL_INT(0, caekf_scaled_to_raw(-2.5, 1.0, 36u, &raw)); /* t = -2 even: stands */
    TEST_ASSERT_EQUAL_INT64(-2, raw);
    TEST_ASSERT_EQUAL_INT(0, caekf_scaled_to_raw(-0.5, 1.0, 36u, &raw));
    TEST_ASSERT_EQUAL_INT64(0, raw);
    TEST_ASSERT_EQUAL_INT(0, caekf_scaled_to_raw(-1.5, 1.0, 36u, &raw)); /* t = -1 odd: away, to -2 */
    TEST_ASSERT_EQUAL_INT64(-2, raw);
    TEST_ASSERT_EQUAL_INT(0, caekf_scaled_to_raw(-2.75, 1.0, 36u, &raw));
    TEST_ASSERT_EQUAL_INT64(-3, raw);
    TEST_ASSERT_EQUAL_INT(0, caekf_float32_bits((double)FLT_MAX, &bits));
    memcpy(&f, &bits, sizeof f);
    TEST_ASSERT_TRUE(f == FLT_MAX);
    TEST_ASSERT_EQUAL_INT(0, caekf_float32_bits(-(double)FLT_MAX, &bits));
    memcpy(&f, &bits, sizeof f);
    TEST_ASSERT_TRUE(f == -FLT_MAX);
    TEST_ASSERT_EQUAL_INT(1, caekf_float32_bits(2.0 * (double)FLT_MAX, &bits));
    TEST_ASSERT_EQUAL_INT(1, caekf_float32_bits(-2.0 * (double)FLT_MAX, &bits));
    TEST_ASSERT_EQUAL_INT(0, caekf_float32_value(0x3F800000u, &v));
    TEST_ASSERT_TRUE(v == 1.0);
    TEST_ASSERT_EQUAL_INT(-1, caekf_float32_value(0x7FC00000u, &v)); /* NaN */
    TEST_ASSERT_EQUAL_INT(-1, caekf_float32_value(0xFF800000u, &v)); /* -infinity */
    TEST_ASSERT_TRUE(isinf(v) && v < 0.0);
}

/* The message count itself is an unknown message; a NULL buffer with a length is refused by the CRC-8. */
static void test_the_first_index_past_the_table_and_a_null_buffer_with_bytes_are_refused(void)
{
    const caekf_msg_info_t *info = NULL;
    uint8_t crc = 0x5Au;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_MSG, caekf_proto_msg_info(CAEKF_MSG_COUNT, &info));
    TEST_ASSERT_NULL(info);
    TEST_ASSERT_EQUAL_INT(-1, caekf_crc8(NULL, 1u, &crc));
    TEST_ASSERT_EQUAL_HEX8(0x5Au, crc);
    TEST_ASSERT_EQUAL_INT(0, caekf_crc8(NULL, 0u, &crc));
}

/* The runtime ID base: every message moves by the offset, both ways; the offsets that keep every ID within
 * 0..0x7FF are exactly the accepted ones. */
static void test_id_offsets_move_every_message_and_stop_at_the_11_bit_range(void)
{
    unsigned i;
    uint32_t lo = 0xFFFFu, hi = 0u;
    const int32_t offsets[] = {0, 5, -3};
    unsigned k;
    for (i = 0; i < (unsigned)CAEKF_MSG_COUNT; i++) {
        const caekf_msg_info_t *info;
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_msg_info((caekf_msg_t)i, &info));
        lo = info->can_id < lo ? info->can_id : lo;
        hi = info->can_id > hi ? info->can_id : hi;
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_id_offset_check(-(int32_t)lo));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_RANGE, caekf_proto_id_offset_check(-(int32_t)lo - 1));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_id_offset_check((int32_t)(CAEKF_CAN_SFF_MAX - hi)));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_RANGE, caekf_proto_id_offset_check((int32_t)(CAEKF_CAN_SFF_MAX - hi) + 1));
    for (k = 0; k < sizeof offsets / sizeof offsets[0]; k++) {
        for (i = 0; i < (unsigned)CAEKF_MSG_COUNT; i++) {
            const caekf_msg_info_t *info;
            uint32_t id = 0u;
            caekf_msg_t msg = CAEKF_MSG_COUNT;
            TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_msg_info((caekf_msg_t)i, &info));
            TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_bus_id((caekf_msg_t)i, offsets[k], &id));
            TEST_ASSERT_EQUAL_UINT32((uint32_t)((int32_t)info->can_id + offsets[k]), id);
            TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_msg_from_bus_id(id, offsets[k], &msg));
            TEST_ASSERT_EQUAL_INT((int)i, (int)msg);
        }
    }
    {
        uint32_t id = 0x55u;
        TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_ERR_RANGE,
                              caekf_proto_bus_id(CAEKF_MSG_EST_HEALTH, (int32_t)(CAEKF_CAN_SFF_MAX - hi) + 1, &id));
        TEST_ASSERT_EQUAL_UINT32(0x55u, id);
    }
}

/* A CAN FD message is sealed at its own length with the CRC-16 the FD check accepts. */
static void test_seal_of_a_can_fd_message_uses_its_length_and_the_crc16(void)
{
    caekf_can_frame_t f;
    const caekf_msg_info_t *info;
    caekf_e2e_rx_t rx;
    memset(&f, 0, sizeof f);
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_msg_info(CAEKF_MSG_EST_FD, &info));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_seal(CAEKF_MSG_EST_FD, 6u, &f));
    TEST_ASSERT_EQUAL_UINT32(info->can_id, f.id);
    TEST_ASSERT_EQUAL_UINT8(CAEKF_FD_OUT_LEN, f.dlc);
    (void)caekf_e2e_rx_init(&rx);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK,
                          caekf_e2e_check_fd(&rx, info->data_id, 1u, f.data, f.dlc, (uint8_t)CAEKF_FD_OUT_LEN, NULL));
    TEST_ASSERT_EQUAL_HEX8(6u, f.data[2] & 0x0Fu);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_message_table_refuses_null_and_unknown_messages);
    RUN_TEST(test_codecs_refuse_null_arguments);
    RUN_TEST(test_crc16_and_fd_e2e_refuse_null_and_bad_lengths);
    RUN_TEST(test_scaled_to_raw_clips_what_rounding_takes_past_the_range);
    RUN_TEST(test_scaling_results_are_exactly_as_documented);
    RUN_TEST(test_the_first_index_past_the_table_and_a_null_buffer_with_bytes_are_refused);
    RUN_TEST(test_id_offsets_move_every_message_and_stop_at_the_11_bit_range);
    RUN_TEST(test_seal_of_a_can_fd_message_uses_its_length_and_the_crc16);
    return UNITY_END();
}
