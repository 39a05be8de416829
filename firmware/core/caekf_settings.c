/* Settings: defaults and validation. Init refuses anything this rejects, leaving the estimator as it was. */
#include "caekf/caekf.h"

#include <stddef.h>

#include "caekf_math.h"

caekf_status_t caekf_settings_default(caekf_settings_t *s)
{
    unsigned char *bytes = (unsigned char *)s;
    size_t i;
    if (s == 0) {
        return CAEKF_ERR_NULL;
    }
    for (i = 0; i < sizeof *s; ++i) { /* all-bits zero: 0, 0.0 and the first enumerators */
        bytes[i] = 0;
    }
    return caekf_settings_schema_defaults(s); /* generated from the schema */
}

CAEKF_STATIC_ASSERT(CAEKF_PARAM_COUNT <= 255u && CAEKF_SETTING_COUNT <= 255u, ids_fit_a_byte);

/* The table row and element of a parameter id; 0 when there is none. Rows are in id order. */
static const caekf_setting_rule_t *locate(unsigned param_id, unsigned *setting, unsigned *index)
{
    unsigned k;
    for (k = 0; k < CAEKF_SETTING_COUNT; ++k) {
        const caekf_setting_rule_t *r = &caekf_setting_rules[k];
        if (param_id >= r->id && param_id < (unsigned)r->id + r->count) {
            *setting = k;
            *index = param_id - r->id;
            return r;
        }
    }
    return 0;
}

/* Byte offset of one element in caekf_settings_t. */
static size_t element_offset(const caekf_setting_rule_t *r, unsigned index)
{
    return r->offset + index * (r->storage == CAEKF_SETTING_REAL ? sizeof(caekf_scalar_t) : sizeof(int));
}
#define ELEMENT(type, s, r, index) ((type *)(void *)((char *)(s) + element_offset((r), (index))))
#define CELEMENT(type, s, r, index) ((const type *)(const void *)((const char *)(s) + element_offset((r), (index))))

static caekf_status_t refuse(caekf_setting_error_t *err, unsigned reason, unsigned param_id)
{
    if (err != 0) {
        unsigned setting = 0, index = 0;
        (void)locate(param_id, &setting, &index);
        err->reason = (uint8_t)reason;
        err->param_id = (uint8_t)param_id;
        err->setting = (uint8_t)setting;
        err->index = (uint8_t)index;
    }
    return CAEKF_ERR_SETTINGS;
}

/* Integer settings are small: this bound keeps the conversion to int defined. */
#define INT_SETTING_LIMIT 1000000.0

caekf_status_t caekf_settings_set(caekf_settings_t *s, unsigned param_id, double value, caekf_setting_error_t *err)
{
    unsigned setting, index;
    const caekf_setting_rule_t *r;
    if (s == 0) {
        return CAEKF_ERR_NULL;
    }
    r = locate(param_id, &setting, &index);
    if (r == 0) {
        if (err != 0) {
            err->reason = CAEKF_SETTING_UNKNOWN_ID;
            err->param_id = (uint8_t)(param_id > 255u ? 255u : param_id);
            err->setting = 0;
            err->index = 0;
        }
        return CAEKF_ERR_SETTINGS;
    }
    if (r->storage == CAEKF_SETTING_REAL) {
        *ELEMENT(caekf_scalar_t, s, r, index) = (caekf_scalar_t)value; /* range: at validation */
        return CAEKF_OK;
    }
    if (!(value >= -INT_SETTING_LIMIT && value <= INT_SETTING_LIMIT) || value != (double)(long)value) {
        return refuse(err, CAEKF_SETTING_NOT_INTEGER, param_id);
    }
    *ELEMENT(int, s, r, index) = (int)value;
    return CAEKF_OK;
}

caekf_status_t caekf_settings_get(const caekf_settings_t *s, unsigned param_id, double *value)
{
    unsigned setting, index;
    const caekf_setting_rule_t *r;
    if (s == 0 || value == 0) {
        return CAEKF_ERR_NULL;
    }
    r = locate(param_id, &setting, &index);
    if (r == 0) {
        return CAEKF_ERR_SETTINGS;
    }
    *value = r->storage == CAEKF_SETTING_REAL ? (double)*CELEMENT(caekf_scalar_t, s, r, index)
                                              : (double)*CELEMENT(int, s, r, index);
    return CAEKF_OK;
}

int caekf_setting_rule_ok(unsigned rule, double lo, double hi, double v)
{
    if (!(v == v) || !(v - v == 0)) { /* NaN or infinite */
        return 0;
    }
    switch (rule) {
    case CAEKF_RULE_POS:
        return v > 0;
    case CAEKF_RULE_NONNEG:
        return v >= 0;
    case CAEKF_RULE_OPEN01:
        return v > 0 && v < 1;
    case CAEKF_RULE_INT:
        return v >= lo && v <= hi && v == (double)(long)v;
    default:
        return 1;
    }
}

/* The schema's range rule of one element (an int setting holds an integer by construction). */
static int in_range(const caekf_settings_t *s, const caekf_setting_rule_t *r, unsigned index)
{
    double v;
    (void)caekf_settings_get(s, (unsigned)r->id + index, &v);
    return caekf_setting_rule_ok(r->rule, r->lo, r->hi, v);
}

/* A derived check forms r = num / den (num + the next slot if SUM), squares it if SQ, multiplies it by
 * fac and needs r finite, and > 0 if POS. Operands are slots, indices of scalar fields in the settings
 * read as an array of scalars, or the constants ONE and RQ: a few bytes a check keep the table small on
 * the MCU. */
enum { SUM = 1, SQ = 2, POS = 4 };
#define SLOT(field) (offsetof(caekf_settings_t, field) / sizeof(caekf_scalar_t))
#define ONE 0xFE /* operand 1 */
#define RQ 0xFF  /* operand sigma_q0 / sigma_v0 */
#define CHECK(param, num, den, fac, flags)                                                                             \
    {(unsigned char)(num), (unsigned char)(den), (unsigned char)(fac), (unsigned char)(flags), (unsigned char)(param)}
CAEKF_STATIC_ASSERT(offsetof(caekf_settings_t, gamma_min) % sizeof(caekf_scalar_t) == 0 &&
                        offsetof(caekf_settings_t, sigma_q_gamma) % sizeof(caekf_scalar_t) == 0 &&
                        SLOT(sigma_q_gamma) < ONE,
                    settings_slots_fit_a_byte);
CAEKF_STATIC_ASSERT(CAEKF_NQ == 4, checks_list_four_bodies);

typedef struct {
    unsigned char num, den, fac, flags, param;
} check_t;

/* Values caekf_init derives must be usable in this scalar type too: finite settings can still
 * overflow or underflow once scaled (found by fuzzing: sigma_q0 = 1e-22 with sigma_qx_q = 1e22 in
 * float, subnormal sigmas in double). Each check repeats the operations of the value it guards and
 * blames the setting it divides. */
#define SCALED_BODY(i)                                                                                                 \
    CHECK(CAEKF_PARAM_Q0 + (i), SLOT(q0[i]), SLOT(sigma_q0), ONE, 0),                                                 \
        CHECK(CAEKF_PARAM_V0 + (i), SLOT(v0[i]), SLOT(sigma_v0), ONE, 0),                                             \
        CHECK(CAEKF_PARAM_M + (i), SLOT(model.m[i]), SLOT(model.dt), ONE, POS)
static const check_t derived_checks[] = {
    SCALED_BODY(0),
    SCALED_BODY(1),
    SCALED_BODY(2),
    SCALED_BODY(3),
    /* The diagonal of A0 = M/dt + C + dt K: dt (k1 + k12) and dt (k34 + k4). */
    CHECK(CAEKF_PARAM_DT, SLOT(model.k1), ONE, SLOT(model.dt), SUM),
    CHECK(CAEKF_PARAM_DT, SLOT(model.k34), ONE, SLOT(model.dt), SUM),
    CHECK(CAEKF_PARAM_GAMMA0, SLOT(gamma0), SLOT(sigma_gamma0), ONE, 0),
    CHECK(CAEKF_PARAM_GAMMA_MIN, SLOT(gamma_min), SLOT(sigma_gamma0), ONE, 0),
    CHECK(CAEKF_PARAM_SIGMA_QX_Q, SLOT(sigma_qx_q), SLOT(sigma_q0), ONE, SQ),
    CHECK(CAEKF_PARAM_SIGMA_QX_V, SLOT(sigma_qx_v), SLOT(sigma_v0), ONE, SQ),
    CHECK(CAEKF_PARAM_SIGMA_Q_GAMMA, SLOT(sigma_q_gamma), SLOT(sigma_gamma0), SLOT(q_gamma_scale), SQ),
    CHECK(CAEKF_PARAM_SIGMA_R, SLOT(sigma_r), SLOT(sigma_q0), ONE, SQ | POS),
    /* The scaled transition S^-1 F S multiplies by rq, 1 / rq, dt / rq and sigma_gamma0 / sigma_v0. */
    CHECK(CAEKF_PARAM_SIGMA_V0, SLOT(sigma_q0), SLOT(sigma_v0), ONE, POS),
    CHECK(CAEKF_PARAM_SIGMA_V0, ONE, RQ, ONE, POS),
    CHECK(CAEKF_PARAM_SIGMA_V0, SLOT(model.dt), RQ, ONE, POS),
    CHECK(CAEKF_PARAM_SIGMA_V0, SLOT(sigma_gamma0), SLOT(sigma_v0), ONE, POS),
};
CAEKF_STATIC_ASSERT(SLOT(model.k12) == SLOT(model.k1) + 1 && SLOT(model.k4) == SLOT(model.k34) + 1, sum_slots_adjacent);

static caekf_scalar_t operand(const caekf_settings_t *s, unsigned op)
{
    if (op == ONE) {
        return 1;
    }
    if (op == RQ) {
        return s->sigma_q0 / s->sigma_v0;
    }
    return *(const caekf_scalar_t *)(const void *)((const char *)s + op * sizeof(caekf_scalar_t));
}

/* The blamed parameter id of the first failing derived check, or -1. */
static int first_unscalable(const caekf_settings_t *s)
{
    unsigned n;
    const check_t *c = derived_checks;
    for (n = sizeof derived_checks / sizeof derived_checks[0]; n > 0; --n, ++c) {
        caekf_scalar_t r = operand(s, c->num);
        if (c->flags & SUM) {
            r += operand(s, c->num + 1u);
        }
        r /= operand(s, c->den);
        if (c->flags & SQ) {
            r *= r;
        }
        r *= operand(s, c->fac);
        if (!CAEKF_ISFINITE(r) || ((c->flags & POS) && !(r > 0))) {
            return c->param;
        }
    }
    return -1;
}

caekf_status_t caekf_settings_validate(const caekf_settings_t *s, caekf_setting_error_t *err)
{
    unsigned k, i;
    int bad;
    if (s == 0) {
        return CAEKF_ERR_NULL;
    }
    for (k = 0; k < CAEKF_SETTING_COUNT; ++k) {
        const caekf_setting_rule_t *r = &caekf_setting_rules[k];
        for (i = 0; i < r->count; ++i) {
            if (!in_range(s, r, i)) {
                return refuse(err, CAEKF_SETTING_OUT_OF_RANGE, r->id + i);
            }
        }
    }
    if (s->newton_max_iter > CAEKF_NEWTON_MAX_ITER) {
        return refuse(err, CAEKF_SETTING_OVER_CAPACITY, CAEKF_PARAM_NEWTON_MAX_ITER);
    }
    if (s->constraint_enabled && s->gamma0 < s->gamma_min) {
        return refuse(err, CAEKF_SETTING_BELOW_GAMMA_MIN, CAEKF_PARAM_GAMMA0);
    }
    bad = first_unscalable(s);
    if (bad >= 0) {
        return refuse(err, CAEKF_SETTING_NOT_SCALABLE, (unsigned)bad);
    }
    if (err != 0) {
        err->reason = CAEKF_SETTING_OK;
        err->param_id = err->setting = err->index = 0;
    }
    return CAEKF_OK;
}
