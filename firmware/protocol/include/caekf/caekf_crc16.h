/*
 * CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, xorout 0, no reflection): the CRC of AUTOSAR E2E
 * profile 5, used for the long payloads of the CAN FD profile (a CRC-8 keeps Hamming distance 4 only up
 * to 119 bits; this one up to 32,751). Check value: CRC of the ASCII bytes "123456789" is 0x29B1.
 */
#ifndef CAEKF_CRC16_H
#define CAEKF_CRC16_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define CAEKF_CRC16_INIT 0xFFFFu

/* Chainable: pass CAEKF_CRC16_INIT for the first block, the previous return value for the next. NULL
 * data leaves the register unchanged. */
uint16_t caekf_crc16_update(uint16_t crc, const uint8_t *data, size_t len);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_CRC16_H */
