/* CRC-8/SAE-J1850 (poly 0x1D, MSB first), a nibble at a time from a 16-entry table: two lookups per
 * byte instead of eight shifts (the E2E seal and check run ~15 times per step on the MCU), 16 bytes of
 * flash instead of 256. nibble_table[n] = the register after shifting the nibble n (in the top four
 * bits) through the polynomial four times. */
#include "caekf/caekf_crc8.h"

static const uint8_t nibble_table[16] = {0x00u, 0x1Du, 0x3Au, 0x27u, 0x74u, 0x69u, 0x4Eu, 0x53u,
                                         0xE8u, 0xF5u, 0xD2u, 0xCFu, 0x9Cu, 0x81u, 0xA6u, 0xBBu};

uint8_t caekf_crc8_update(uint8_t crc, const uint8_t *data, size_t len)
{
    size_t i;
    if (data == NULL) {
        return crc;
    }
    for (i = 0; i < len; i++) {
        crc = (uint8_t)(crc ^ data[i]);
        crc = (uint8_t)((uint8_t)(crc << 4) ^ nibble_table[crc >> 4]);
        crc = (uint8_t)((uint8_t)(crc << 4) ^ nibble_table[crc >> 4]);
    }
    return crc;
}

int caekf_crc8(const uint8_t *data, size_t len, uint8_t *crc_out)
{
    if (crc_out == NULL || (data == NULL && len > 0u)) {
        return -1;
    }
    *crc_out = (uint8_t)(caekf_crc8_update(CAEKF_CRC8_INIT, data, len) ^ CAEKF_CRC8_XOROUT);
    return 0;
}
