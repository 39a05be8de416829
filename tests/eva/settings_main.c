/*
 * Frama-C EVA driver of the settings by parameter id (tools/eva.py, target `settings`; docs/eva.md):
 * caekf_settings_set and caekf_settings_get (firmware/core/caekf_settings.c, with the schema's generated table),
 * what a CTRL_PARAM frame's id and value reach. caekf_settings_validate is not in it yet (docs/eva.md).
 *
 * All inputs unknown: the settings any bytes (every int any value, every double any bit pattern: NaN and
 * infinities included), every parameter id (each of the schema's ids on its own, then every other unsigned
 * value at once), every value (in four parts, below), and each pointer NULL or valid.
 */
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "__fc_builtin.h"
#include "caekf/caekf.h"

static caekf_settings_t settings;

static void any_bytes(void *obj, size_t size) { Frama_C_make_unknown((char *)obj, size); }

/* Every double, in four parts that EVA follows apart: NaN; [-1e6, 1e6] (the integer settings' bound,
 * INT_SETTING_LIMIT); above it, +infinity included; below it, -infinity included. */
#define VALUE_PARTS 4u
#define INT_LIMIT 1e6
#define ABOVE_INT_LIMIT 0x1.e848000000001p+19 /* the double after 1e6 = 0x1.e848p+19 */
static double any_double(unsigned part)
{
    switch (part) {
    case 0u: return (double)NAN;
    case 1u: return Frama_C_double_interval(-INT_LIMIT, INT_LIMIT);
    case 2u: return Frama_C_nondet(0, 1) != 0 ? (double)INFINITY : Frama_C_double_interval(ABOVE_INT_LIMIT, DBL_MAX);
    default: return Frama_C_nondet(0, 1) != 0 ? -(double)INFINITY : Frama_C_double_interval(-DBL_MAX, -ABOVE_INT_LIMIT);
    }
}

static caekf_settings_t *any_settings(void)
{
    any_bytes(&settings, sizeof settings);
    return (caekf_settings_t *)Frama_C_nondet_ptr(NULL, &settings);
}

static void set_and_get(unsigned id)
{
    caekf_setting_error_t err;
    double value = 0.0;
    caekf_setting_error_t *perr = (caekf_setting_error_t *)Frama_C_nondet_ptr(NULL, &err);
    unsigned part;
    /*@ loop unroll 4; */
    for (part = 0u; part < VALUE_PARTS; part++) {
        (void)caekf_settings_set(any_settings(), id, any_double(part), perr);
    }
    (void)caekf_settings_get(any_settings(), id, (double *)Frama_C_nondet_ptr(NULL, &value));
}

int main(void)
{
    unsigned id;
    /*@ loop unroll 1024; */
    for (id = 0u; id < (unsigned)CAEKF_PARAM_COUNT; id++) {
        set_and_get(id);
    }
    set_and_get(Frama_C_unsigned_int_interval((unsigned)CAEKF_PARAM_COUNT, 0xFFFFFFFFu));

    return 0;
}
