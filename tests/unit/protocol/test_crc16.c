/* CRC-16/CCITT-FALSE (the CAN FD profile's E2E CRC) against known answers and a bit-at-a-time reference:
 * every entry of the nibble table is reached (each byte value in both nibbles), so a wrong entry, shift or
 * xor shows (tools/mutation.py found entries 3, 5 and 13 of the table unchecked by the E2E suite). */
#include <string.h>

#include "caekf/caekf_crc16.h"
#include "unity.h"

void setUp(void) {}
void tearDown(void) {}

/* The textbook definition, one bit at a time: poly 0x1021, MSB first, no reflection. */
static uint16_t crc16_bitwise(uint16_t crc, const uint8_t *data, size_t len)
{
    size_t i;
    unsigned bit;
    for (i = 0; i < len; i++) {
        crc = (uint16_t)(crc ^ (uint16_t)((unsigned)data[i] << 8));
        for (bit = 0; bit < 8u; bit++) {
            crc = (crc & 0x8000u) != 0u ? (uint16_t)((unsigned)(crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
        }
    }
    return crc;
}

static void test_check_value_of_123456789_is_0x29b1(void)
{
    static const uint8_t ascii[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
    TEST_ASSERT_EQUAL_HEX16(0x29B1u, caekf_crc16_update(CAEKF_CRC16_INIT, ascii, sizeof ascii));
}

static void test_every_byte_value_from_several_registers_matches_the_bitwise_crc(void)
{
    static const uint16_t registers[] = {0x0000u, 0xFFFFu, 0x1234u, 0x8001u, 0x7FFEu};
    unsigned r, b;
    for (r = 0; r < sizeof registers / sizeof registers[0]; r++) {
        for (b = 0; b < 256u; b++) {
            const uint8_t byte = (uint8_t)b;
            TEST_ASSERT_EQUAL_HEX16(crc16_bitwise(registers[r], &byte, 1u),
                                    caekf_crc16_update(registers[r], &byte, 1u));
        }
    }
}

static void test_long_buffers_and_chaining_match_the_bitwise_crc(void)
{
    uint8_t buf[64];
    unsigned i;
    uint16_t chained;
    for (i = 0; i < sizeof buf; i++) {
        buf[i] = (uint8_t)(i * 73u + 11u);
    }
    for (i = 0; i <= sizeof buf; i++) {
        TEST_ASSERT_EQUAL_HEX16(crc16_bitwise(CAEKF_CRC16_INIT, buf, i), caekf_crc16_update(CAEKF_CRC16_INIT, buf, i));
    }
    chained = caekf_crc16_update(CAEKF_CRC16_INIT, buf, 20u);
    chained = caekf_crc16_update(chained, &buf[20], sizeof buf - 20u);
    TEST_ASSERT_EQUAL_HEX16(caekf_crc16_update(CAEKF_CRC16_INIT, buf, sizeof buf), chained);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_check_value_of_123456789_is_0x29b1);
    RUN_TEST(test_every_byte_value_from_several_registers_matches_the_bitwise_crc);
    RUN_TEST(test_long_buffers_and_chaining_match_the_bitwise_crc);
    return UNITY_END();
}
