/* The scalar conversions cantools uses, shared by the codec (see scaling.h). */
#include "scaling.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* The float32 signals are copied bit for bit: float must be IEEE single precision. */
typedef char caekf_proto_float_is_32_bit[(sizeof(float) == 4) ? 1 : -1];

/* Ties to even, like Python's round(). Exact for |x| < 2^62: x - trunc(x) is representable. */
static int64_t round_half_even(double x)
{
    int64_t t = (int64_t)x;
    double frac = x - (double)t;
    if (frac > 0.5 || (frac == 0.5 && (t & 1))) {
        t += 1;
    } else if (frac < -0.5 || (frac == -0.5 && (t & 1))) {
        t -= 1;
    } else {
        /* frac within (-0.5, 0.5), or a tie towards an even t: t stands */
    }
    return t;
}

int caekf_scaled_to_raw(double value, double lsb, unsigned len, int64_t *raw)
{
    const unsigned sign_bit = len - 1u;
    const int64_t max_raw = (int64_t)(((uint64_t)1u << sign_bit) - (uint64_t)1u);
    const int64_t min_raw = -max_raw - 1;
    double x = value / lsb; /* division, not multiplication by 1/lsb: the same double as cantools */
    int64_t r;
    if (isnan(x) != 0) {
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
    (void)memcpy(bits, &f, sizeof f);
    return clipped;
}

int caekf_float32_value(uint32_t bits, double *value)
{
    float f;
    (void)memcpy(&f, &bits, sizeof f);
    *value = (double)f;
    return (isnan(f) || isinf(f)) ? -1 : 0;
}
