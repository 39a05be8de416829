/*
 * Frama-C EVA driver of the settings by parameter id and their validation (tools/eva.py, target `settings`;
 * docs/eva.md): caekf_settings_set, caekf_settings_get and caekf_settings_validate (firmware/core/caekf_settings.c,
 * with the schema's generated table), what CTRL_PARAM frames and CTRL_RESET's commit reach.
 *
 * All inputs unknown: the settings any bytes (every int any value, every double any bit pattern: NaN and
 * infinities included), every parameter id (each of the schema's ids on its own, then every other unsigned
 * value at once), every value (in four parts, below), and each pointer NULL or valid. Validation: every settings
 * value, as a union of parts (validate_all).
 */
#include <float.h>
#include <limits.h>
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

/* --- caekf_settings_validate ------------------------------------------------------------------------------ */

static caekf_setting_error_t error;

static void validate(void)
{
    (void)caekf_settings_validate((const caekf_settings_t *)Frama_C_nondet_ptr(NULL, &settings),
                                  (caekf_setting_error_t *)Frama_C_nondet_ptr(NULL, &error));
}

/* The table's row of the setting at `offset` in caekf_settings_t (the driver names settings of the table: an
 * offset without a row would return r uninitialised, an alarm). */
static caekf_setting_rule_t rule_at(size_t offset)
{
    caekf_setting_rule_t r;
    unsigned k;
    for (k = 0u; k < (unsigned)CAEKF_SETTING_COUNT; k++) {
        if (caekf_setting_rule(k, &r) == CAEKF_OK && r.offset == offset) {
            return r;
        }
    }
    return r;
}

static int *element(const caekf_setting_rule_t *r, unsigned i)
{
    return (int *)(void *)((char *)&settings + r->offset + i * sizeof(int));
}

/* The largest valid value of an integer setting: its rule's, and a count's capacity. */
static int top(const caekf_setting_rule_t *r)
{
    return r->limit != 0u && r->limit < r->hi ? (int)r->limit : (int)r->hi;
}

static int valid(const caekf_setting_rule_t *r) { return Frama_C_interval((int)r->lo, top(r)); }

/* Every value outside the rule: below it (side 0) or above it (side 1). */
static int invalid(const caekf_setting_rule_t *r, unsigned side)
{
    return side == 0u ? Frama_C_interval(INT_MIN, (int)r->lo - 1) : Frama_C_interval(top(r) + 1, INT_MAX);
}

/* The count settings (bodies, springs, inputs, sensors, contacts): the rows with a capacity. */
static void counts_valid(void)
{
    caekf_setting_rule_t r;
    unsigned k;
    for (k = 0u; k < (unsigned)CAEKF_SETTING_COUNT; k++) {
        if (caekf_setting_rule(k, &r) == CAEKF_OK && r.limit != 0u) {
            *element(&r, 0u) = valid(&r);
        }
    }
}

/* caekf_settings_validate on every settings value, as the union of parts EVA follows apart (docs/eva.md):
 *  (1) a count outside its rule (each count, each side), everything else any bytes: refused first;
 *  with every count valid and everything else any bytes except:
 *  (2) the inputs and contacts counts each of their values, the input links and the contacts' estimate flags
 *      in use within their rules (the ones not in use any);
 *  (3) one input link in use outside its rule (each count, element, side): refused;
 *  (4) one estimate flag in use outside its rule (each count, flag, element, side): refused.
 * Every settings value is in one part: a count is invalid (1), or an element of (3) or (4) in use is, or none
 * is (2). Only the input links (an index after - 1) and the flags (summed) need their rule past the range
 * check; the other elements are any bytes in every part. */
static void validate_all(void)
{
    const caekf_setting_rule_t inputs = rule_at(offsetof(caekf_settings_t, model.inputs));
    const caekf_setting_rule_t contacts = rule_at(offsetof(caekf_settings_t, model.contacts));
    const caekf_setting_rule_t link = rule_at(offsetof(caekf_settings_t, model.input_link));
    caekf_setting_rule_t flags[3];
    caekf_setting_rule_t r;
    unsigned k, side, n, m, a, j;
    flags[0] = rule_at(offsetof(caekf_settings_t, model.contact_estimate_n));
    flags[1] = rule_at(offsetof(caekf_settings_t, model.contact_estimate_lambda));
    flags[2] = rule_at(offsetof(caekf_settings_t, model.contact_estimate_gap));

    /*@ loop unroll 128; */
    for (k = 0u; k < (unsigned)CAEKF_SETTING_COUNT; k++) { /* (1) */
        if (caekf_setting_rule(k, &r) == CAEKF_OK && r.limit != 0u) {
            /*@ loop unroll 2; */
            for (side = 0u; side < 2u; side++) {
                any_bytes(&settings, sizeof settings);
                *element(&r, 0u) = invalid(&r, side);
                validate();
            }
        }
    }
    /*@ loop unroll 8; */
    for (n = inputs.lo; n <= (unsigned)top(&inputs); n++) {
        /*@ loop unroll 8; */
        for (m = contacts.lo; m <= (unsigned)top(&contacts); m++) { /* (2) */
            any_bytes(&settings, sizeof settings);
            counts_valid();
            *element(&inputs, 0u) = (int)n;
            *element(&contacts, 0u) = (int)m;
            /*@ loop unroll 8; */
            for (j = 0u; j < n; j++) {
                *element(&link, j) = valid(&link);
            }
            /*@ loop unroll 3; */
            for (a = 0u; a < 3u; a++) {
                /*@ loop unroll 8; */
                for (j = 0u; j < m; j++) {
                    *element(&flags[a], j) = valid(&flags[a]);
                }
            }
            validate();
        }
        /*@ loop unroll 8; */
        for (j = 0u; j < n; j++) { /* (3) */
            /*@ loop unroll 2; */
            for (side = 0u; side < 2u; side++) {
                any_bytes(&settings, sizeof settings);
                counts_valid();
                *element(&inputs, 0u) = (int)n;
                *element(&link, j) = invalid(&link, side);
                validate();
            }
        }
    }
    /*@ loop unroll 8; */
    for (m = contacts.lo; m <= (unsigned)top(&contacts); m++) { /* (4) */
        /*@ loop unroll 3; */
        for (a = 0u; a < 3u; a++) {
            /*@ loop unroll 8; */
            for (j = 0u; j < m; j++) {
                /*@ loop unroll 2; */
                for (side = 0u; side < 2u; side++) {
                    any_bytes(&settings, sizeof settings);
                    counts_valid();
                    *element(&contacts, 0u) = (int)m;
                    *element(&flags[a], j) = invalid(&flags[a], side);
                    validate();
                }
            }
        }
    }
}

int main(void)
{
    unsigned id;
    /*@ loop unroll 1024; */
    for (id = 0u; id < (unsigned)CAEKF_PARAM_COUNT; id++) {
        set_and_get(id);
    }
    set_and_get(Frama_C_unsigned_int_interval((unsigned)CAEKF_PARAM_COUNT, 0xFFFFFFFFu));
    validate_all();

    return 0;
}
