/*
 * Private helpers of the codec: little-endian (Intel, DBC "@1") bit fields in an 8-byte payload and
 * the scalar conversions cantools uses, so both encoders produce the same bytes.
 */
#ifndef CAEKF_PROTO_BITFIELD_H
#define CAEKF_PROTO_BITFIELD_H

#include <stdint.h>

/* Bit i of the payload is bit (i % 8) of byte i / 8. start + len <= 64, 1 <= len <= 64. */
void caekf_bits_put(uint8_t data[8], unsigned start, unsigned len, uint64_t raw);
uint64_t caekf_bits_get(const uint8_t data[8], unsigned start, unsigned len);
int64_t caekf_bits_get_signed(const uint8_t data[8], unsigned start, unsigned len);
void caekf_bits_put_signed(uint8_t data[8], unsigned start, unsigned len, int64_t value);

/* round(value / lsb) with ties to even (Python's round), clipped to a signed `len`-bit field.
 * Returns 1 when clipped (NaN gives 0 and counts as clipped), else 0. */
int caekf_scaled_to_raw(double value, double lsb, unsigned len, int64_t *raw);

/* IEEE-754 float32 bit pattern of `value`; finite values beyond FLT_MAX are clipped (returns 1). */
int caekf_float32_bits(double value, uint32_t *bits);
/* Value of a float32 bit pattern. Returns 0 if finite, -1 for NaN or infinity (*value still set). */
int caekf_float32_value(uint32_t bits, double *value);

#endif /* CAEKF_PROTO_BITFIELD_H */
