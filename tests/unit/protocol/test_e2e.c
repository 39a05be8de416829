/* E2E protect/check: CRC over data ID and payload, alive counter logic (wrap, duplicate, jump). */
#include <string.h>

#include "caekf/caekf_crc8.h"
#include "caekf/caekf_crc16.h"
#include "caekf/caekf_e2e.h"
#include "unity.h"

#define DATA_ID 0xCA01u

static caekf_e2e_rx_t rx;

void setUp(void) { TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_rx_init(&rx)); }
void tearDown(void) {}

static void frame(uint8_t counter, uint8_t out[8])
{
    const uint8_t body[8] = {0, 0xB0, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66};
    memcpy(out, body, 8);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_protect(DATA_ID, counter, out));
}

static caekf_e2e_status_t check(uint8_t counter, uint8_t max_delta, uint8_t *lost)
{
    uint8_t f[8];
    frame(counter, f);
    return caekf_e2e_check(&rx, DATA_ID, max_delta, f, 8, lost);
}

static void test_crc_covers_data_id_both_bytes_then_bytes_1_to_7(void)
{
    uint8_t f[8];
    const uint8_t seq[9] = {0x01, 0xCA, 0xB5, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66};
    uint8_t expected;
    frame(5, f);
    TEST_ASSERT_EQUAL_INT(0, caekf_crc8(seq, sizeof seq, &expected));
    TEST_ASSERT_EQUAL_HEX8(expected, f[0]);
    TEST_ASSERT_EQUAL_HEX8(0xB5, f[1]); /* counter in the low nibble, the high nibble kept */
}

static void test_consecutive_counters_pass_through_the_wrap(void)
{
    unsigned i;
    uint8_t lost = 99;
    for (i = 0; i < 40u; i++) {
        TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, check((uint8_t)((i + 13u) & 15u), 1, &lost));
        TEST_ASSERT_EQUAL_UINT8(0, lost);
    }
}

static void test_first_frame_is_accepted_with_any_counter(void)
{
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, check(9, 1, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_JUMP, check(3, 1, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_rx_init(&rx));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, check(3, 1, NULL)); /* after init: accepted again */
}

static void test_duplicate_is_rejected_and_keeps_the_state(void)
{
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, check(4, 1, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_DUPLICATE, check(4, 1, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_DUPLICATE, check(4, 15, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, check(5, 1, NULL));
}

static void test_jump_is_rejected_then_resyncs(void)
{
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, check(14, 1, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_JUMP, check(0, 1, NULL)); /* 14 -> 0 is +2 across the wrap */
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, check(1, 1, NULL));
}

static void test_gap_within_max_delta_passes_and_reports_lost_frames(void)
{
    uint8_t lost = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, check(15, 3, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, check(2, 3, &lost)); /* 15 -> 2: delta 3 */
    TEST_ASSERT_EQUAL_UINT8(2, lost);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_JUMP, check(6, 3, NULL));
}

static void test_max_delta_zero_means_one(void)
{
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, check(0, 0, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, check(1, 0, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_JUMP, check(3, 0, NULL));
}

static void test_wrong_dlc_is_rejected_before_anything_else(void)
{
    uint8_t f[8];
    frame(0, f);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_DLC, caekf_e2e_check(&rx, DATA_ID, 1, f, 7, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_DLC, caekf_e2e_check(&rx, DATA_ID, 1, f, 0, NULL));
    TEST_ASSERT_EQUAL_UINT8(0, rx.synced);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_check(&rx, DATA_ID, 1, f, 8, NULL));
}

static void test_any_bit_flip_or_wrong_data_id_is_a_crc_error(void)
{
    uint8_t f[8];
    unsigned bit;
    frame(7, f);
    for (bit = 0; bit < 64u; bit++) {
        f[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
        TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_CRC, caekf_e2e_check(&rx, DATA_ID, 1, f, 8, NULL));
        f[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_CRC, caekf_e2e_check(&rx, DATA_ID ^ 0x0100u, 1, f, 8, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_CRC, caekf_e2e_check(&rx, DATA_ID ^ 0x0001u, 1, f, 8, NULL));
    TEST_ASSERT_EQUAL_UINT8(0, rx.synced); /* CRC errors never touch the counter state */
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_check(&rx, DATA_ID, 1, f, 8, NULL));
}

static void test_null_pointers_are_refused(void)
{
    uint8_t f[8] = {0};
    uint8_t crc;
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_NULL, caekf_e2e_check(NULL, DATA_ID, 1, f, 8, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_NULL, caekf_e2e_check(&rx, DATA_ID, 1, NULL, 8, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_NULL, caekf_e2e_protect(DATA_ID, 0, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_NULL, caekf_e2e_crc(DATA_ID, f, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_NULL, caekf_e2e_crc(DATA_ID, NULL, &crc));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_NULL, caekf_e2e_rx_init(NULL));
}

/* CAN FD frames: CRC-16/CCITT-FALSE in bytes 0..1 over the data ID and bytes 2..len-1, counter in bits
 * 16..19; the same counter rules as the classic frames. */
static void test_fd_crc16_check_value_and_seal_check(void)
{
    static const uint8_t check[9] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
    uint8_t p[64];
    caekf_e2e_rx_t frx;
    unsigned i, bit;
    uint8_t lost = 9;
    TEST_ASSERT_EQUAL_HEX16(0x29B1u, caekf_crc16_update(CAEKF_CRC16_INIT, check, sizeof check));
    for (i = 0; i < sizeof p; i++) {
        p[i] = (uint8_t)(i * 37u + 5u);
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_protect_fd(0xCA92u, 3u, p, 64u));
    TEST_ASSERT_EQUAL_HEX8(3u, p[2] & 0x0Fu);
    TEST_ASSERT_EQUAL_HEX8((uint8_t)((2u * 37u + 5u) & 0xF0u), p[2] & 0xF0u); /* upper nibble kept */
    (void)caekf_e2e_rx_init(&frx);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_DLC, caekf_e2e_check_fd(&frx, 0xCA92u, 1u, p, 8u, 64u, &lost));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_CRC, caekf_e2e_check_fd(&frx, 0xCA04u, 1u, p, 64u, 64u, &lost));
    for (bit = 0; bit < 64u * 8u; bit += 13u) { /* a flipped bit anywhere, CRC bytes included */
        p[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
        TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_CRC, caekf_e2e_check_fd(&frx, 0xCA92u, 1u, p, 64u, 64u, &lost));
        p[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_check_fd(&frx, 0xCA92u, 1u, p, 64u, 64u, &lost));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_DUPLICATE, caekf_e2e_check_fd(&frx, 0xCA92u, 1u, p, 64u, 64u, &lost));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_protect_fd(0xCA92u, 5u, p, 64u));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_JUMP, caekf_e2e_check_fd(&frx, 0xCA92u, 1u, p, 64u, 64u, &lost));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_protect_fd(0xCA92u, 6u, p, 64u));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_check_fd(&frx, 0xCA92u, 1u, p, 64u, 64u, &lost));
    TEST_ASSERT_EQUAL_UINT8(0u, lost);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_DLC, caekf_e2e_protect_fd(0xCA92u, 0u, p, 65u));
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_ERR_NULL, caekf_e2e_protect_fd(0xCA92u, 0u, NULL, 64u));
}

/* protect writes the whole counter nibble: a stale counter in the payload does not leak into the new one */
static void test_protect_overwrites_the_old_counter_nibble(void)
{
    uint8_t f[8] = {0, 0xAF, 1, 2, 3, 4, 5, 6};
    uint8_t fd[20];
    memset(fd, 0x5F, sizeof fd);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_protect(DATA_ID, 0x30u, f)); /* only the low 4 bits count */
    TEST_ASSERT_EQUAL_HEX8(0xA0u, f[1]);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_protect(DATA_ID, 3u, f));
    TEST_ASSERT_EQUAL_HEX8(0xA3u, f[1]);
    TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_protect_fd(DATA_ID, 0x12u, fd, sizeof fd));
    TEST_ASSERT_EQUAL_HEX8(0x52u, fd[2]);
}

/* The CRC-16 is over [data ID low, data ID high, bytes 2..len-1], from the shortest frame (3 bytes) to the
 * longest, with data IDs whose low and high bytes both matter. */
static void test_fd_crc16_covers_both_data_id_bytes_then_bytes_2_to_len(void)
{
    static const uint16_t ids[] = {0xCA92u, 0x0001u, 0x0100u, 0xFFFFu};
    static const uint8_t lens[] = {3u, 4u, 20u, 63u, 64u};
    uint8_t p[64];
    uint8_t seq[2 + 62];
    unsigned i, k, j;
    for (i = 0; i < sizeof p; i++) {
        p[i] = (uint8_t)(i * 29u + 3u);
    }
    for (k = 0; k < sizeof ids / sizeof ids[0]; k++) {
        for (j = 0; j < sizeof lens; j++) {
            const unsigned len = lens[j];
            uint16_t crc = 0u;
            seq[0] = (uint8_t)(ids[k] & 0xFFu);
            seq[1] = (uint8_t)(ids[k] >> 8);
            memcpy(&seq[2], &p[2], len - 2u);
            TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_crc16(ids[k], p, (uint8_t)len, &crc));
            TEST_ASSERT_EQUAL_HEX16(caekf_crc16_update(CAEKF_CRC16_INIT, seq, len), crc);
        }
    }
    /* the shortest frame seals and checks */
    {
        caekf_e2e_rx_t frx;
        uint8_t s3[3] = {0, 0, 0x70};
        TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_protect_fd(0xCA04u, 9u, s3, 3u));
        TEST_ASSERT_EQUAL_HEX8(0x79u, s3[2]);
        (void)caekf_e2e_rx_init(&frx);
        TEST_ASSERT_EQUAL_INT(CAEKF_E2E_OK, caekf_e2e_check_fd(&frx, 0xCA04u, 1u, s3, 3u, 3u, NULL));
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_crc_covers_data_id_both_bytes_then_bytes_1_to_7);
    RUN_TEST(test_consecutive_counters_pass_through_the_wrap);
    RUN_TEST(test_first_frame_is_accepted_with_any_counter);
    RUN_TEST(test_duplicate_is_rejected_and_keeps_the_state);
    RUN_TEST(test_jump_is_rejected_then_resyncs);
    RUN_TEST(test_gap_within_max_delta_passes_and_reports_lost_frames);
    RUN_TEST(test_max_delta_zero_means_one);
    RUN_TEST(test_wrong_dlc_is_rejected_before_anything_else);
    RUN_TEST(test_any_bit_flip_or_wrong_data_id_is_a_crc_error);
    RUN_TEST(test_null_pointers_are_refused);
    RUN_TEST(test_fd_crc16_check_value_and_seal_check);
    RUN_TEST(test_protect_overwrites_the_old_counter_nibble);
    RUN_TEST(test_fd_crc16_covers_both_data_id_bytes_then_bytes_2_to_len);
    return UNITY_END();
}
