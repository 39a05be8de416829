/* Bit fields and scalar conversions shared by the codec (see bitfield.h). */
#include "bitfield.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* The float32 signals are copied bit for bit: float must be IEEE single precision. */
typedef char caekf_proto_float_is_32_bit[(sizeof(float) == 4) ? 1 : -1];

/* The payload as one little-endian 64-bit word: bit i of the payload is bit i of the word. A field is
 * a mask and a shift (a few word operations instead of one loop pass per bit: the codec packs ~12
 * frames per step on the MCU). */
static uint64_t load_le64(const uint8_t data[8])
{
    uint64_t w = 0;
    unsigned i;
    for (i = 8u; i > 0u; i--) {
        w = (w << 8) | data[i - 1u];
    }
    return w;
}

static uint64_t field_mask(unsigned start, unsigned len)
{
    uint64_t m;
    if (start >= 64u || len == 0u) {
        return 0u;
    }
    if (len > 64u - start) {
        len = 64u - start; /* bits beyond the payload are dropped */
    }
    m = (len >= 64u) ? ~(uint64_t)0u : (((uint64_t)1u << len) - 1u);
    return m << start;
}

void caekf_bits_put(uint8_t data[8], unsigned start, unsigned len, uint64_t raw)
{
    const uint64_t m = field_mask(start, len);
    uint64_t w;
    unsigned i;
    if (m == 0u) {
        return;
    }
    w = (load_le64(data) & ~m) | ((raw << start) & m);
    for (i = 0; i < 8u; i++) {
        data[i] = (uint8_t)(w >> (8u * i));
    }
}

uint64_t caekf_bits_get(const uint8_t data[8], unsigned start, unsigned len)
{
    const uint64_t m = field_mask(start, len);
    if (m == 0u) {
        return 0u;
    }
    return (load_le64(data) & m) >> start;
}

int64_t caekf_bits_get_signed(const uint8_t data[8], unsigned start, unsigned len)
{
    uint64_t raw = caekf_bits_get(data, start, len);
    if (len < 64u && ((raw >> (len - 1u)) & 1u)) {
        /* Two's complement of a len-bit field; written without implementation-defined casts. */
        return (int64_t)raw - (int64_t)((uint64_t)1u << (len - 1u)) - (int64_t)((uint64_t)1u << (len - 1u));
    }
    return (int64_t)raw;
}

void caekf_bits_put_signed(uint8_t data[8], unsigned start, unsigned len, int64_t value)
{
    caekf_bits_put(data, start, len, (uint64_t)value); /* modulo 2^64, the low len bits are the field */
}

/* Ties to even, like Python's round(). Exact for |x| < 2^62: x - trunc(x) is representable. */
static int64_t round_half_even(double x)
{
    int64_t t = (int64_t)x;
    double frac = x - (double)t;
    if (frac > 0.5 || (frac == 0.5 && (t & 1))) {
        t += 1;
    } else if (frac < -0.5 || (frac == -0.5 && (t & 1))) {
        t -= 1;
    }
    return t;
}

int caekf_scaled_to_raw(double value, double lsb, unsigned len, int64_t *raw)
{
    const int64_t max_raw = (int64_t)(((uint64_t)1u << (len - 1u)) - 1u);
    const int64_t min_raw = -max_raw - 1;
    double x = value / lsb; /* division, not multiplication by 1/lsb: the same double as cantools */
    int64_t r;
    if (isnan(x)) {
        *raw = 0;
        return 1;
    }
    if (x >= (double)max_raw + 1.0) {
        *raw = max_raw;
        return 1;
    }
    if (x <= (double)min_raw - 1.0) {
        *raw = min_raw;
        return 1;
    }
    r = round_half_even(x);
    if (r > max_raw) {
        *raw = max_raw;
        return 1;
    }
    if (r < min_raw) {
        *raw = min_raw;
        return 1;
    }
    *raw = r;
    return 0;
}

int caekf_float32_bits(double value, uint32_t *bits)
{
    float f;
    int clipped = 0;
    if (!isnan(value) && !isinf(value) && value > (double)FLT_MAX) {
        f = FLT_MAX; /* converting an out-of-range double to float is undefined behaviour */
        clipped = 1;
    } else if (!isnan(value) && !isinf(value) && value < -(double)FLT_MAX) {
        f = -FLT_MAX;
        clipped = 1;
    } else {
        f = (float)value;
    }
    memcpy(bits, &f, sizeof f);
    return clipped;
}

int caekf_float32_value(uint32_t bits, double *value)
{
    float f;
    memcpy(&f, &bits, sizeof f);
    *value = (double)f;
    return (isnan(f) || isinf(f)) ? -1 : 0;
}
