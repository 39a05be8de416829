/*
 * Private helpers of the codec: the scalar conversions cantools uses (its Python encoder's rounding and
 * float32), so both encoders produce the same bytes; the bit layout is cantools' generated C.
 */
#ifndef CAEKF_PROTO_SCALING_H
#define CAEKF_PROTO_SCALING_H

#include <stdint.h>

/* round(value / lsb) with ties to even (Python's round), clipped to a signed `len`-bit field.
 * Returns 1 when clipped (NaN gives 0 and counts as clipped), else 0. */
int caekf_scaled_to_raw(double value, double lsb, unsigned len, int64_t *raw);

/* IEEE-754 float32 bit pattern of `value`; finite values beyond FLT_MAX are clipped (returns 1). */
int caekf_float32_bits(double value, uint32_t *bits);
/* Value of a float32 bit pattern. Returns 0 if finite, -1 for NaN or infinity (*value still set). */
int caekf_float32_value(uint32_t bits, double *value);

#endif /* CAEKF_PROTO_SCALING_H */
