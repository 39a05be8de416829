/*
 * CRC-8/SAE-J1850 (poly 0x1D, init 0xFF, xorout 0xFF, no reflection): the CRC of AUTOSAR E2E
 * profile 1. Check value: CRC of the ASCII bytes "123456789" is 0x4B.
 */
#ifndef CAEKF_CRC8_H
#define CAEKF_CRC8_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define CAEKF_CRC8_INIT 0xFFu
#define CAEKF_CRC8_XOROUT 0xFFu

/* Chainable form: pass CAEKF_CRC8_INIT as `crc` for the first block, the previous return value for
 * the next block, and xor the final value with CAEKF_CRC8_XOROUT. Returns the running register. */
uint8_t caekf_crc8_update(uint8_t crc, const uint8_t *data, size_t len);

/* One-shot CRC-8/SAE-J1850 of `len` bytes into *crc_out. Returns 0, or -1 if a pointer is NULL
 * (NULL data is allowed when len is 0). */
int caekf_crc8(const uint8_t *data, size_t len, uint8_t *crc_out);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_CRC8_H */
