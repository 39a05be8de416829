/*
 * libFuzzer harness 3: the settings decoder on its own - CTRL_PARAM payloads through
 * caekf_proto_decode_param and caekf_proto_param_value into caekf_settings_set, then
 * caekf_settings_validate. No estimator steps: thousands of inputs a second.
 *
 * Input layout (every byte optional; missing bytes read as 0):
 *   [start]  bit 0: start from caekf_settings_default instead of the reference scenario's settings,
 *            bits 1-2: with no preset (0) or the schema's preset 0..2 (1..3)
 *   records until the end: 8 bytes, one CTRL_PARAM payload (E2E bytes included, not checked here:
 *   the app does that before decoding).
 *
 * Invariants (any violation aborts, i.e. is a finding):
 *   decode_param: OK or ERR_VALUE only; an OK decode re-encodes (OK) to a payload that decodes to the
 *         same fields (PARAM_ID, EXP10, MANTISSA).
 *   param_value: OK exactly when |exp10| <= 22, and then finite and equal to mantissa * 10^exp10 as a
 *         correctly rounded double (checked against strtod of the decimal text).
 *   settings_set: a refusal (unknown id, an element beyond what this build stores, a fraction for an
 *         integer setting) names that id and leaves the settings byte for byte unchanged; an accepted value
 *         reads back (caekf_settings_get) as the value in the storage type (caekf_scalar_t for reals).
 *   settings_validate: accepted only when every element in use (the row's in-use count, or all it stores)
 *         satisfies its range rule (caekf_setting_rule via caekf_setting_rule_ok); a range refusal names an
 *         element that breaks its rule.
 */
#include "fuzz_common.h"

#include "caekf/caekf_proto.h"

static void check_param_value(const caekf_msg_param_t *m)
{
    double v = 0.0;
    const caekf_proto_status_t st = caekf_proto_param_value(m, &v);
    const int usable = m->param_exp10 >= -22 && m->param_exp10 <= 22;
    FZ_CHECK((st == CAEKF_PROTO_OK) == usable, "param_value: OK exactly for |exp10| <= 22");
    if (st == CAEKF_PROTO_OK) {
        char text[64];
        snprintf(text, sizeof text, "%lde%d", (long)m->param_mantissa, (int)m->param_exp10);
        FZ_CHECK(isfinite(v), "param_value: finite");
        FZ_CHECK(v == strtod(text, NULL), "param_value: the correctly rounded decimal");
    }
}

/* The rule row of parameter id `id` (NULL when unknown; valid until the next call). */
static const caekf_setting_rule_t *rule_of(unsigned id)
{
    static caekf_setting_rule_t row;
    unsigned i;
    for (i = 0; i < CAEKF_SETTING_COUNT; ++i) {
        FZ_CHECK(caekf_setting_rule(i, &row) == CAEKF_OK, "every row of the table decodes");
        if (id >= row.id && id < (unsigned)row.id + row.count) {
            return &row;
        }
    }
    return NULL;
}

static void set_one(caekf_settings_t *s, const uint8_t payload[CAEKF_CAN_DLC])
{
    caekf_msg_param_t m, m2;
    uint8_t again[CAEKF_CAN_DLC];
    caekf_settings_t before;
    caekf_setting_error_t e;
    double v = 0.0, got = 0.0;
    caekf_proto_status_t st = caekf_proto_decode_param(payload, &m);
    caekf_status_t set;
    FZ_CHECK(st == CAEKF_PROTO_OK || st == CAEKF_PROTO_ERR_VALUE, "decode_param: OK or ERR_VALUE");
    if (st != CAEKF_PROTO_OK) {
        return;
    }
    memcpy(again, payload, sizeof again);
    FZ_CHECK(caekf_proto_encode_param(&m, again) == CAEKF_PROTO_OK, "encode_param of a decoded param");
    FZ_CHECK(caekf_proto_decode_param(again, &m2) == CAEKF_PROTO_OK, "decode_param of a re-encoded param");
    FZ_CHECK(m2.param_id == m.param_id && m2.param_exp10 == m.param_exp10 && m2.param_mantissa == m.param_mantissa,
             "decode(encode(decode(p))) == decode(p)");
    check_param_value(&m);
    if (caekf_proto_param_value(&m, &v) != CAEKF_PROTO_OK) {
        return;
    }
    before = *s;
    memset(&e, 0xA5, sizeof e);
    set = caekf_settings_set(s, m.param_id, v, &e);
    if (set != CAEKF_OK) {
        const caekf_setting_rule_t *r = rule_of(m.param_id);
        FZ_CHECK(set == CAEKF_ERR_SETTINGS, "settings_set: OK or ERR_SETTINGS");
        FZ_CHECK(memcmp(&before, s, sizeof before) == 0, "a refused set leaves the settings untouched");
        FZ_CHECK(e.param_id == m.param_id, "the refusal names the id");
        FZ_CHECK((r == NULL) == (e.reason == CAEKF_SETTING_UNKNOWN_ID), "unknown id exactly when not in the table");
        FZ_CHECK(r == NULL || (e.reason == CAEKF_SETTING_OVER_CAPACITY) == (m.param_id - r->id >= r->stored),
                 "over capacity exactly for an element beyond what the build stores");
        FZ_CHECK(r == NULL || m.param_id - r->id >= r->stored ||
                     (e.reason == CAEKF_SETTING_NOT_INTEGER && r->storage != CAEKF_SETTING_REAL),
                 "a stored element is refused only for a fraction in an integer setting");
        return;
    }
    FZ_CHECK(rule_of(m.param_id) != NULL, "an accepted id is in the table");
    FZ_CHECK(caekf_settings_get(s, m.param_id, &got) == CAEKF_OK, "settings_get of an accepted id");
    if (rule_of(m.param_id)->storage == CAEKF_SETTING_REAL) {
        const caekf_scalar_t stored = (caekf_scalar_t)v;
        FZ_CHECK(got == (double)stored || (isnan(got) && isnan(v)), "a real reads back in the scalar type");
    } else {
        FZ_CHECK(got == v, "an integer reads back exactly");
    }
}

/* Elements of row r in use: its in-use count (clamped to what the build stores), or all it stores. */
static unsigned in_use(const caekf_settings_t *s, const caekf_setting_rule_t *r)
{
    int n;
    if (r->in_use == CAEKF_ALL_IN_USE) {
        return r->stored;
    }
    memcpy(&n, (const char *)s + r->in_use, sizeof n);
    return n < 0 ? 0u : ((unsigned)n < r->stored ? (unsigned)n : r->stored);
}

static int element_ok(const caekf_settings_t *s, unsigned id)
{
    const caekf_setting_rule_t *r = rule_of(id);
    double v = 0.0;
    FZ_CHECK(r != NULL && caekf_settings_get(s, id, &v) == CAEKF_OK, "settings_get of a stored table id");
    return caekf_setting_rule_ok(r->rule, (double)r->lo, (double)r->hi, v);
}

static void check_validate(const caekf_settings_t *s)
{
    caekf_setting_error_t e;
    unsigned i, k;
    const caekf_status_t st = caekf_settings_validate(s, &e);
    if (st == CAEKF_OK) {
        FZ_CHECK(e.reason == CAEKF_SETTING_OK, "validate OK: reason OK");
        for (i = 0; i < CAEKF_SETTING_COUNT; ++i) {
            caekf_setting_rule_t row;
            const caekf_setting_rule_t *r = &row;
            FZ_CHECK(caekf_setting_rule(i, &row) == CAEKF_OK, "every row of the table decodes");
            for (k = 0; k < in_use(s, r); ++k) {
                FZ_CHECK(element_ok(s, (unsigned)r->id + k), "validate accepted an element that breaks its rule");
            }
        }
        return;
    }
    FZ_CHECK(st == CAEKF_ERR_SETTINGS, "validate: OK or ERR_SETTINGS");
    FZ_CHECK(e.reason != CAEKF_SETTING_OK && e.reason != CAEKF_SETTING_UNKNOWN_ID &&
                 e.reason != CAEKF_SETTING_NOT_INTEGER,
             "validate: a reason of validation (not one of caekf_settings_set's)");
    if (e.reason == CAEKF_SETTING_OUT_OF_RANGE) {
        FZ_CHECK(!element_ok(s, e.param_id), "a range refusal names an element that breaks its rule");
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader_t r = {data, size};
    caekf_settings_t s;
    const uint8_t start = fz_u8(&r);
    if (start & 1u) {
        (void)caekf_settings_default(&s);
    } else {
        fz_paper_settings(&s, (int)((start >> 1) & 3u) - 1); /* -1: no preset */
    }
    check_validate(&s);
    while (fz_more(&r)) {
        uint8_t payload[CAEKF_CAN_DLC];
        unsigned b;
        for (b = 0; b < CAEKF_CAN_DLC; ++b) {
            payload[b] = fz_u8(&r);
        }
        set_one(&s, payload);
    }
    check_validate(&s);
    return 0;
}
