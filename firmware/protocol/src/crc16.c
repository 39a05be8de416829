/* CRC-16/CCITT-FALSE (poly 0x1021, MSB first), a nibble at a time from a 16-entry table: four lookups per
 * byte, 32 bytes of flash. nibble_table[n] = the register after shifting the nibble n (in the top four bits)
 * through the polynomial four times. */
#include "caekf/caekf_crc16.h"

static const uint16_t nibble_table[16] = {0x0000u, 0x1021u, 0x2042u, 0x3063u, 0x4084u, 0x50A5u, 0x60C6u, 0x70E7u,
                                          0x8108u, 0x9129u, 0xA14Au, 0xB16Bu, 0xC18Cu, 0xD1ADu, 0xE1CEu, 0xF1EFu};

uint16_t caekf_crc16_update(uint16_t crc, const uint8_t *data, size_t len)
{
    size_t i;
    unsigned k;
    if (data == NULL) {
        return crc;
    }
    for (i = 0; i < len; i++) {
        crc = (uint16_t)(crc ^ ((uint16_t)data[i] << 8));
        for (k = 0; k < 2u; k++) {
            crc = (uint16_t)((uint16_t)(crc << 4) ^ nibble_table[crc >> 12]);
        }
    }
    return crc;
}
