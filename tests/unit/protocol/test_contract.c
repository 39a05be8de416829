/* The protocol library's argument contract and the edges of its scaling, which neither the codec suites nor the
 * fuzz harnesses reach (tools/coverage.sh showed them untaken; docs/coverage.md): every public function refuses
 * NULL arguments and unknown messages with its error status and writes nothing; the CRC-16 and FD E2E functions
 * refuse lengths outside 3..64; caekf_scaled_to_raw clips a value that only rounding takes past the signal's
 * range. Each test fails (or crashes) when the check it covers is removed. */
#include <string.h>

#include "caekf/caekf_crc16.h"
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

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_message_table_refuses_null_and_unknown_messages);
    RUN_TEST(test_codecs_refuse_null_arguments);
    RUN_TEST(test_crc16_and_fd_e2e_refuse_null_and_bad_lengths);
    RUN_TEST(test_scaled_to_raw_clips_what_rounding_takes_past_the_range);
    return UNITY_END();
}
