/* CRC-8/SAE-J1850, bitwise: 8 shifts per byte is cheap at CAN rates and needs no 256-byte table. */
#include "caekf/caekf_crc8.h"

#define CRC8_POLY 0x1Du

uint8_t caekf_crc8_update(uint8_t crc, const uint8_t *data, size_t len)
{
    size_t i;
    unsigned bit;
    if (data == NULL) {
        return crc;
    }
    for (i = 0; i < len; i++) {
        crc = (uint8_t)(crc ^ data[i]);
        for (bit = 0; bit < 8u; bit++) {
            crc = (crc & 0x80u) ? (uint8_t)((crc << 1) ^ CRC8_POLY) : (uint8_t)(crc << 1);
        }
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
