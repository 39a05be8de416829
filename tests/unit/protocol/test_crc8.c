/* CRC-8/SAE-J1850 known answers: the catalogue check value and the AUTOSAR CRC library's table. */
#include <string.h>

#include "caekf/caekf_crc8.h"
#include "unity.h"

void setUp(void) {}
void tearDown(void) {}

static uint8_t crc_of(const uint8_t *data, size_t len)
{
    uint8_t crc = 0xA5; /* not a possible answer of the cases below: a skipped write shows */
    TEST_ASSERT_EQUAL_INT(0, caekf_crc8(data, len, &crc));
    return crc;
}

static void test_check_value_of_123456789_is_0x4b(void)
{
    const uint8_t ascii[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
    TEST_ASSERT_EQUAL_HEX8(0x4B, crc_of(ascii, sizeof ascii));
}

static void test_autosar_crc_library_vectors(void)
{
    static const uint8_t v1[] = {0x00, 0x00, 0x00, 0x00};
    static const uint8_t v2[] = {0xF2, 0x01, 0x83};
    static const uint8_t v3[] = {0x0F, 0xAA, 0x00, 0x55};
    static const uint8_t v4[] = {0x00, 0xFF, 0x55, 0x11};
    static const uint8_t v5[] = {0x33, 0x22, 0x55, 0xAA, 0xBB, 0xCC, 0xDD, 0xEE, 0xFF};
    static const uint8_t v6[] = {0x92, 0x6B, 0x55};
    static const uint8_t v7[] = {0xFF, 0xFF, 0xFF, 0xFF};
    TEST_ASSERT_EQUAL_HEX8(0x59, crc_of(v1, sizeof v1));
    TEST_ASSERT_EQUAL_HEX8(0x37, crc_of(v2, sizeof v2));
    TEST_ASSERT_EQUAL_HEX8(0x79, crc_of(v3, sizeof v3));
    TEST_ASSERT_EQUAL_HEX8(0xB8, crc_of(v4, sizeof v4));
    TEST_ASSERT_EQUAL_HEX8(0xCB, crc_of(v5, sizeof v5));
    TEST_ASSERT_EQUAL_HEX8(0x8C, crc_of(v6, sizeof v6));
    TEST_ASSERT_EQUAL_HEX8(0x74, crc_of(v7, sizeof v7));
}

static void test_empty_input_is_init_xor_xorout(void) { TEST_ASSERT_EQUAL_HEX8(0x00, crc_of(NULL, 0)); }

static void test_chained_update_equals_one_shot(void)
{
    const uint8_t data[] = {0x33, 0x22, 0x55, 0xAA, 0xBB, 0xCC, 0xDD, 0xEE, 0xFF};
    size_t split;
    for (split = 0; split <= sizeof data; split++) {
        uint8_t reg = caekf_crc8_update(CAEKF_CRC8_INIT, data, split);
        reg = caekf_crc8_update(reg, data + split, sizeof data - split);
        TEST_ASSERT_EQUAL_HEX8(0xCB, (uint8_t)(reg ^ CAEKF_CRC8_XOROUT));
    }
}

static void test_every_single_bit_flip_changes_the_crc(void)
{
    uint8_t data[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    const uint8_t good = crc_of(data, sizeof data);
    unsigned bit;
    for (bit = 0; bit < 64u; bit++) {
        data[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
        TEST_ASSERT_NOT_EQUAL(good, crc_of(data, sizeof data));
        data[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
    }
}

static void test_null_pointers_are_refused(void)
{
    uint8_t crc;
    const uint8_t one = 1;
    TEST_ASSERT_EQUAL_INT(-1, caekf_crc8(NULL, 3, &crc));
    TEST_ASSERT_EQUAL_INT(-1, caekf_crc8(&one, 1, NULL));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_check_value_of_123456789_is_0x4b);
    RUN_TEST(test_autosar_crc_library_vectors);
    RUN_TEST(test_empty_input_is_init_xor_xorout);
    RUN_TEST(test_chained_update_equals_one_shot);
    RUN_TEST(test_every_single_bit_flip_changes_the_crc);
    RUN_TEST(test_null_pointers_are_refused);
    return UNITY_END();
}
