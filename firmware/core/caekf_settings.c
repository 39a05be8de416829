/* Settings: defaults and validation. Init refuses anything this rejects, leaving the estimator as it was. */
#include "caekf/caekf.h"

#include <stddef.h>

#include "caekf_math.h"
#include "caekf_model_internal.h"

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
CAEKF_STATIC_ASSERT(CAEKF_MAX_BODIES <= CAEKF_WIRE_MAX_BODIES && CAEKF_MAX_SPRINGS <= CAEKF_WIRE_MAX_SPRINGS &&
                        CAEKF_MAX_INPUTS <= CAEKF_WIRE_MAX_INPUTS && CAEKF_MAX_SENSORS <= CAEKF_WIRE_MAX_SENSORS &&
                        CAEKF_MAX_CONTACTS <= CAEKF_WIRE_MAX_CONTACTS,
                    capacities_fit_the_wire);

/* Row k of the table, whose first id is id (ids are dense: the counts of the rows before it). */
static void decode(unsigned k, unsigned id, caekf_setting_rule_t *r)
{
    const caekf_setting_row_t *row = &caekf_setting_rows[k];
    const caekf_setting_kind_t *kind = &caekf_setting_kinds[row->kind & 15u];
    const unsigned rule = row->rule & 15u;
    r->offset = row->offset;
    r->in_use = kind->in_use;
    r->id = (uint8_t)id;
    r->count = kind->count;
    r->stored = kind->stored;
    r->limit = (uint8_t)(row->kind >> 4 ? caekf_setting_kinds[row->kind >> 4].stored : 0u);
    r->storage = rule == CAEKF_RULE_INT ? CAEKF_SETTING_INT : CAEKF_SETTING_REAL;
    r->rule = (uint8_t)rule;
    r->lo = rule == CAEKF_RULE_INT ? caekf_setting_ranges[row->rule >> 4][0] : 0u;
    r->hi = rule == CAEKF_RULE_INT ? caekf_setting_ranges[row->rule >> 4][1] : 0u;
}

/* The row (decoded into r) and element of a parameter id, or with row < CAEKF_SETTING_COUNT that
 * row; 0 when there is none. */
static int locate(unsigned param_id, unsigned row, unsigned *setting, unsigned *index, caekf_setting_rule_t *r)
{
    unsigned k, id = 0;
    for (k = 0; k < CAEKF_SETTING_COUNT; ++k) {
        decode(k, id, r);
        if (row < CAEKF_SETTING_COUNT ? k == row : param_id - id < r->count) {
            *setting = k;
            *index = param_id - id;
            return 1;
        }
        id += r->count;
    }
    return 0;
}

caekf_status_t caekf_setting_rule(unsigned setting, caekf_setting_rule_t *rule)
{
    unsigned k, index;
    if (rule == 0) {
        return CAEKF_ERR_NULL;
    }
    return setting < CAEKF_SETTING_COUNT && locate(0, setting, &k, &index, rule) ? CAEKF_OK : CAEKF_ERR_SETTINGS;
}

/* Byte offset of one element in caekf_settings_t. */
static size_t element_offset(const caekf_setting_rule_t *r, unsigned index)
{
    return r->offset + index * (r->storage == CAEKF_SETTING_REAL ? sizeof(caekf_scalar_t) : sizeof(int));
}
#define ELEMENT(type, s, r, index) ((type *)(void *)((char *)(s) + element_offset((r), (index))))
#define CELEMENT(type, s, r, index) ((const type *)(const void *)((const char *)(s) + element_offset((r), (index))))

/* One element's value as a double (either storage). */
static double element_value(const void *s, const caekf_setting_rule_t *r, unsigned index)
{
    return r->storage == CAEKF_SETTING_REAL ? (double)*CELEMENT(caekf_scalar_t, s, r, index)
                                            : (double)*CELEMENT(int, s, r, index);
}

static caekf_status_t refuse(caekf_setting_error_t *err, unsigned reason, unsigned param_id)
{
    if (err != 0) {
        unsigned setting = 0, index = 0;
        caekf_setting_rule_t r;
        (void)locate(param_id, CAEKF_SETTING_COUNT, &setting, &index, &r);
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
    caekf_setting_rule_t row;
    const caekf_setting_rule_t *r = &row;
    if (s == 0) {
        return CAEKF_ERR_NULL;
    }
    if (!locate(param_id, CAEKF_SETTING_COUNT, &setting, &index, &row)) {
        if (err != 0) {
            err->reason = CAEKF_SETTING_UNKNOWN_ID;
            err->param_id = (uint8_t)(param_id > 255u ? 255u : param_id);
            err->setting = 0;
            err->index = 0;
        }
        return CAEKF_ERR_SETTINGS;
    }
    if (index >= r->stored) { /* the wire carries more elements than this build stores */
        return refuse(err, CAEKF_SETTING_OVER_CAPACITY, param_id);
    }
    if (r->storage == CAEKF_SETTING_REAL) {
        *ELEMENT(caekf_scalar_t, s, r, index) = (caekf_scalar_t)value; /* range: at validation */
        return CAEKF_OK;
    }
    if (!caekf_setting_rule_ok(CAEKF_RULE_INT, -INT_SETTING_LIMIT, INT_SETTING_LIMIT, value)) {
        return refuse(err, CAEKF_SETTING_NOT_INTEGER, param_id);
    }
    *ELEMENT(int, s, r, index) = (int)value;
    return CAEKF_OK;
}

caekf_status_t caekf_settings_get(const caekf_settings_t *s, unsigned param_id, double *value)
{
    unsigned setting, index;
    caekf_setting_rule_t r;
    if (s == 0 || value == 0) {
        return CAEKF_ERR_NULL;
    }
    if (!locate(param_id, CAEKF_SETTING_COUNT, &setting, &index, &r) || index >= r.stored) {
        return CAEKF_ERR_SETTINGS;
    }
    *value = element_value(s, &r, index);
    return CAEKF_OK;
}

int caekf_setting_rule_ok(unsigned rule, double lo, double hi, double v)
{
    if (!(v - v == 0)) { /* NaN or infinite: v - v is NaN */
        return 0;
    }
    switch (rule) {
    case CAEKF_RULE_POS: return v > 0;
    case CAEKF_RULE_NONNEG: return v >= 0;
    case CAEKF_RULE_OPEN01: return v > 0 && v < 1;
    case CAEKF_RULE_GE1: return v >= 1;
    case CAEKF_RULE_INT: return v >= lo && v <= hi && v == (double)(long)v;
    default: return 1;
    }
}

/* The schema's range rule of one element (an int setting holds an integer by construction). */
static int in_range(const void *s, const caekf_setting_rule_t *r, unsigned index)
{
    return caekf_setting_rule_ok(r->rule, r->lo, r->hi, element_value(s, r, index));
}

/* How many elements of a row are in use: its count setting's value (range-checked before, so within
 * the stored capacity), or all it stores. */
static unsigned elements_in_use(const void *s, const caekf_setting_rule_t *r)
{
    int n;
    if (r->in_use == CAEKF_ALL_IN_USE) {
        return r->stored;
    }
    n = *(const int *)(const void *)((const char *)s + r->in_use);
    return n < 0 ? 0u : ((unsigned)n < r->stored ? (unsigned)n : r->stored);
}

/* The range and capacity rules of the table's rows that lie in the first `size` bytes of caekf_settings_t
 * (all, or its model: caekf_model_params_check), read from s: the first offending id with *reason, or -1.
 * Rows are in id order and every count precedes the arrays it counts: an array's in-use count has passed
 * its range and capacity checks when the array is checked. */
static int first_out_of_range(const void *s, size_t size, unsigned *reason)
{
    caekf_setting_rule_t r;
    unsigned k, i, id = 0;
    for (k = 0; k < CAEKF_SETTING_COUNT; ++k, id += r.count) {
        unsigned n;
        decode(k, id, &r);
        if (r.offset >= size) {
            continue;
        }
        n = elements_in_use(s, &r);
        *reason = CAEKF_SETTING_OUT_OF_RANGE;
        for (i = 0; i < n; ++i) {
            if (!in_range(s, &r, i)) {
                return (int)(id + i);
            }
        }
        *reason = CAEKF_SETTING_OVER_CAPACITY;
        if (r.limit != 0 && *CELEMENT(int, s, &r, 0) > (int)r.limit) {
            return (int)id;
        }
    }
    return -1;
}

/* Values caekf_init derives must be usable in this scalar type too: finite settings can still overflow
 * or underflow once scaled (found by fuzzing: sigma_q0 = 1e-22 with sigma_qx_q = 1e22 in float,
 * subnormal sigmas in double). Each check repeats the operation of the value it guards: the quotient
 * num / den (squared with USABLE_SQ, times fac) must be finite, and > 0 with USABLE_POS. Returns 1 if it passes. */
#define USABLE_SQ 1u  /* the quotient squared */
#define USABLE_POS 2u /* and > 0 */
CAEKF_NOINLINE static int usable_times(caekf_scalar_t num, caekf_scalar_t den, caekf_scalar_t fac, unsigned how)
{
    caekf_scalar_t r = num / den;
    if (how & USABLE_SQ) {
        r *= r;
    }
    r *= fac;
    return CAEKF_ISFINITE(r) && (!(how & USABLE_POS) || r > 0);
}

/* usable_times with fac = 1 (the same value: r * 1 is r): the common case, one argument less a call. */
CAEKF_NOINLINE static int usable(caekf_scalar_t num, caekf_scalar_t den, unsigned how)
{
    return usable_times(num, den, 1, how);
}

/* One estimated law parameter's scaled values (x0, bounds and Q over sigma0, and sigma0 / sigma_v0 in
 * the scaled transition): 1 with *bad set when one is not usable. */
static int law_unscalable(caekf_scalar_t x0, caekf_scalar_t sigma0, caekf_scalar_t sigma_q, caekf_scalar_t lo,
                          caekf_scalar_t hi, caekf_scalar_t sigma_v0, int id0, int *bad)
{
    if (!usable(x0, sigma0, 0) || !usable(lo, sigma0, 0) || !usable(hi, sigma0, 0) ||
        !usable(sigma_q, sigma0, USABLE_SQ) || !usable(sigma0, sigma_v0, USABLE_POS)) {
        *bad = id0;
        return 1;
    }
    return 0;
}

static int first_unscalable_law(const caekf_settings_t *s, unsigned c, int *bad)
{
    const caekf_model_params_t *m = &s->model;
    return (m->contact_estimate_n[c] && law_unscalable(s->n0[c], s->sigma_n0[c], s->sigma_q_n[c], s->n_min[c],
                                                       s->n_max[c], s->sigma_v0, CAEKF_PARAM_SIGMA_N0 + (int)c, bad)) ||
           (m->contact_estimate_lambda[c] &&
            law_unscalable(s->lambda0[c], s->sigma_lambda0[c], s->sigma_q_lambda[c], s->lambda_min[c], s->lambda_max[c],
                           s->sigma_v0, CAEKF_PARAM_SIGMA_LAMBDA0 + (int)c, bad)) ||
           (m->contact_estimate_gap[c] &&
            law_unscalable(s->gap0[c], s->sigma_gap0[c], s->sigma_q_gap[c], s->gap_min[c], s->gap_max[c], s->sigma_v0,
                           CAEKF_PARAM_SIGMA_GAP0 + (int)c, bad));
}

/* The blamed parameter id of the first failing derived check, or -1. */
static int first_unscalable(const caekf_settings_t *s)
{
    const caekf_model_params_t *m = &s->model;
    const caekf_scalar_t rq = s->sigma_q0 / s->sigma_v0;
    int i, bad = -1;
    for (i = 0; i < m->bodies; ++i) {
        if (!usable(s->q0[i], s->sigma_q0, 0)) {
            return (int)CAEKF_PARAM_Q0 + i;
        }
        if (!usable(s->v0[i], s->sigma_v0, 0)) {
            return (int)CAEKF_PARAM_V0 + i;
        }
        if (!usable(m->m[i], m->dt, USABLE_POS)) {
            return (int)CAEKF_PARAM_M + i;
        }
    }
    for (i = 0; i < m->springs; ++i) { /* A0 = M/dt + C + dt K takes dt k of each link */
        if (!usable_times(m->spring_k[i], 1, m->dt, 0)) {
            return (int)CAEKF_PARAM_DT;
        }
    }
    for (i = 0; i < m->contacts; ++i) {
        if (!usable(s->gamma0[i], s->sigma_gamma0[i], 0)) {
            return (int)CAEKF_PARAM_GAMMA0 + i;
        }
        if (!usable(s->gamma_min[i], s->sigma_gamma0[i], 0)) {
            return (int)CAEKF_PARAM_GAMMA_MIN + i;
        }
        if (!usable_times(s->sigma_q_gamma[i], s->sigma_gamma0[i], s->q_gamma_scale, USABLE_SQ)) {
            return (int)CAEKF_PARAM_SIGMA_Q_GAMMA + i;
        }
        if (m->gamma_log && !usable(s->sigma_gamma0[i], s->gamma0[i], USABLE_POS)) { /* ln gamma's scale */
            return (int)CAEKF_PARAM_SIGMA_GAMMA0 + i;
        }
        if (!usable(s->gamma_max[i], s->sigma_gamma0[i], 0)) {
            return (int)CAEKF_PARAM_GAMMA_MAX + i;
        }
        if (CAEKF_HAS_LAW_PARAMS && first_unscalable_law(s, (unsigned)i, &bad)) {
            return bad;
        }
        /* The scaled transition multiplies by sigma_gamma0 / sigma_v0. */
        if (!usable(s->sigma_gamma0[i], s->sigma_v0, USABLE_POS)) {
            return (int)CAEKF_PARAM_SIGMA_V0;
        }
    }
    if (!usable(s->sigma_qx_q, s->sigma_q0, USABLE_SQ)) {
        return (int)CAEKF_PARAM_SIGMA_QX_Q;
    }
    if (!usable(s->sigma_qx_v, s->sigma_v0, USABLE_SQ)) {
        return (int)CAEKF_PARAM_SIGMA_QX_V;
    }
    if (!usable(s->sigma_r, s->sigma_q0, USABLE_SQ | USABLE_POS)) {
        return (int)CAEKF_PARAM_SIGMA_R;
    }
    /* The scaled transition S^-1 F S multiplies by rq, 1 / rq and dt / rq. */
    if (!usable(s->sigma_q0, s->sigma_v0, USABLE_POS) || !usable(1, rq, USABLE_POS) || !usable(m->dt, rq, USABLE_POS)) {
        return (int)CAEKF_PARAM_SIGMA_V0;
    }
    return -1;
}

/* A body number within the mechanism. Its lower bound (0, the ground, or 1 where the ground is not
 * allowed) is the setting's range rule, which every caller has checked before. */
static int body_ok(const caekf_model_params_t *m, int body) { return body <= m->bodies; }

/* The mechanism's references between its elements; returns the first offending parameter id or -1. */
static int first_bad_body(const caekf_model_params_t *m)
{
    int i;
    for (i = 0; i < m->springs; ++i) {
        if (!body_ok(m, m->spring_a[i])) {
            return (int)CAEKF_PARAM_SPRING_A + i;
        }
        if (!body_ok(m, m->spring_b[i]) || m->spring_b[i] == m->spring_a[i]) {
            return (int)CAEKF_PARAM_SPRING_B + i;
        }
    }
    for (i = 0; i < m->inputs; ++i) { /* a base input's body is its link's (first_bad_base_input) */
        if ((!CAEKF_HAS_BASE_INPUTS || m->input_kind[i] == CAEKF_INPUT_FORCE) && !body_ok(m, m->input_body[i])) {
            return (int)CAEKF_PARAM_INPUT_BODY + i;
        }
    }
    for (i = 0; i < m->sensors; ++i) {
        if (!body_ok(m, m->sensor_body[i])) {
            return (int)CAEKF_PARAM_SENSOR_BODY + i;
        }
        if (m->sensor_kind[i] == CAEKF_SENSOR_RELATIVE &&
            (!body_ok(m, m->sensor_ref[i]) || m->sensor_ref[i] == m->sensor_body[i])) {
            return (int)CAEKF_PARAM_SENSOR_REF + i;
        }
        if (m->sensor_kind[i] == CAEKF_SENSOR_LINK_FORCE && m->sensor_link[i] > m->springs) {
            return (int)CAEKF_PARAM_SENSOR_LINK + i;
        }
    }
    for (i = 0; i < m->contacts; ++i) {
        if (!body_ok(m, m->contact_a[i])) {
            return (int)CAEKF_PARAM_CONTACT_A + i;
        }
        if (!body_ok(m, m->contact_b[i]) || m->contact_b[i] == m->contact_a[i]) {
            return (int)CAEKF_PARAM_CONTACT_B + i;
        }
    }
    return -1;
}

/* The base-displacement inputs' links (input{i}_link): a link in use with one end on the ground, which no
 * earlier base input moves; returns the first offending parameter id or -1. A build whose inputs are all
 * forces (CAEKF_HAS_BASE_INPUTS 0) refuses the kind itself (first_unsized). */
static int first_bad_base_input(const caekf_model_params_t *m)
{
    int i, j;
    for (i = 0; i < m->inputs; ++i) {
        const int l = m->input_link[i] - 1;
        if (m->input_kind[i] != CAEKF_INPUT_BASE_DISPLACEMENT) {
            continue;
        }
        if (l >= m->springs || (m->spring_a[l] != 0 && m->spring_b[l] != 0)) {
            return (int)CAEKF_PARAM_INPUT_LINK + i;
        }
        for (j = 0; j < i; ++j) {
            if (m->input_kind[j] == CAEKF_INPUT_BASE_DISPLACEMENT && m->input_link[j] == m->input_link[i]) {
                return (int)CAEKF_PARAM_INPUT_LINK + i;
            }
        }
    }
    return -1;
}

/* One estimated law parameter's settings (the settings' ids of its flag, initial value, sigma0, minimum
 * and maximum): the blamed id and reason of the first problem, or -1. */
static int bad_law_param(int estimated, unsigned c, caekf_scalar_t x0, int x0_id, caekf_scalar_t sigma0, int sigma0_id,
                         caekf_scalar_t lo, caekf_scalar_t hi, int hi_id, unsigned *reason)
{
    if (!estimated) {
        return -1;
    }
    if (!(sigma0 > 0)) {
        *reason = CAEKF_SETTING_NEEDED;
        return sigma0_id + (int)c;
    }
    *reason = CAEKF_SETTING_OUTSIDE_BOUNDS;
    if (hi > 0 && hi < lo) {
        return hi_id + (int)c;
    }
    return x0 < lo || (hi > 0 && x0 > hi) ? x0_id + (int)c : -1;
}

/* The estimated law parameters of every contact: sigma0 given, initial value within its bounds. */
static int first_bad_law_param(const caekf_settings_t *s, unsigned *reason)
{
    unsigned c;
    int bad = -1;
    for (c = 0; c < (unsigned)s->model.contacts && bad < 0; ++c) {
        bad = bad_law_param(s->model.contact_estimate_n[c], c, s->n0[c], CAEKF_PARAM_N0, s->sigma_n0[c],
                            CAEKF_PARAM_SIGMA_N0, s->n_min[c], s->n_max[c], CAEKF_PARAM_N_MAX, reason);
        if (bad < 0) {
            bad = bad_law_param(s->model.contact_estimate_lambda[c], c, s->lambda0[c], CAEKF_PARAM_LAMBDA0,
                                s->sigma_lambda0[c], CAEKF_PARAM_SIGMA_LAMBDA0, s->lambda_min[c], s->lambda_max[c],
                                CAEKF_PARAM_LAMBDA_MAX, reason);
        }
        if (bad < 0) {
            bad = bad_law_param(s->model.contact_estimate_gap[c], c, s->gap0[c], CAEKF_PARAM_GAP0, s->sigma_gap0[c],
                                CAEKF_PARAM_SIGMA_GAP0, s->gap_min[c], s->gap_max[c], CAEKF_PARAM_GAP_MAX, reason);
        }
    }
    return bad;
}

/* A build sized for one mechanism (CAEKF_SIZED) runs exactly its counts: the first count that differs. */
static int first_unsized(const caekf_model_params_t *m)
{
#if CAEKF_SIZED
    if (m->bodies != CAEKF_SIZED_BODIES) {
        return (int)CAEKF_PARAM_BODIES;
    }
    if (m->springs != CAEKF_SIZED_SPRINGS) {
        return (int)CAEKF_PARAM_SPRINGS;
    }
    if (m->inputs != CAEKF_SIZED_INPUTS) {
        return (int)CAEKF_PARAM_INPUTS;
    }
    if (m->sensors != CAEKF_SIZED_SENSORS) {
        return (int)CAEKF_PARAM_SENSORS;
    }
    if (m->contacts != CAEKF_SIZED_CONTACTS) {
        return (int)CAEKF_PARAM_CONTACTS;
    }
    {
        int i;
        for (i = 0; i < CAEKF_SIZED_INPUTS && !CAEKF_HAS_BASE_INPUTS; ++i) { /* the build's inputs are forces */
            if (m->input_kind[i] != CAEKF_INPUT_FORCE) {
                return (int)CAEKF_PARAM_INPUT_KIND + i;
            }
        }
    }
    return -1;
#else
    (void)m;
    return -1;
#endif /* CAEKF_SIZED: its counts are generated only there */
}

/* A build sized for one configuration (CAEKF_SIZED_METHOD) runs exactly its step method: the first
 * setting that differs, in the model m and, unless s is NULL (the model's own check), the settings s. */
static int first_unsized_method(const caekf_model_params_t *m, const caekf_settings_t *s)
{
#if CAEKF_SIZED_METHOD
    unsigned i;
    if (m->discretisation != CAEKF_SIZED_DISCRETISATION) {
        return (int)CAEKF_PARAM_DISCRETISATION;
    }
    if (s != 0 && s->contact_substeps != CAEKF_SIZED_CONTACT_SUBSTEPS) {
        return (int)CAEKF_PARAM_CONTACT_SUBSTEPS;
    }
    if (m->gamma_log != CAEKF_SIZED_GAMMA_LOG) {
        return (int)CAEKF_PARAM_GAMMA_LOG;
    }
    /* statistically linearised contacts: the sized method, or compiled out (CAEKF_HAS_SLR) */
    if (s != 0 && (CAEKF_HAS_SLR ? !(s->contact_slr_p > 0) : s->contact_slr_p != 0)) {
        return (int)CAEKF_PARAM_CONTACT_SLR_P;
    }
    if (s != 0 && s->cov_update != CAEKF_SIZED_COV_UPDATE) {
        return (int)CAEKF_PARAM_COV_UPDATE;
    }
    if (s != 0 && s->switchoff != CAEKF_SIZED_SWITCHOFF) {
        return (int)CAEKF_PARAM_SWITCHOFF;
    }
    for (i = 0; i < (unsigned)m->contacts; ++i) {
        if (!CAEKF_HAS_CONTACT_N && m->contact_n[i] != CAEKF_SIZED_CONTACT_N_VALUE) { /* the build's exponent */
            return (int)(CAEKF_PARAM_CONTACT_N + i);
        }
        if (!CAEKF_HAS_DAMPING && m->contact_lambda[i] != 0) { /* the build's laws are elastic */
            return (int)(CAEKF_PARAM_CONTACT_LAMBDA + i);
        }
    }
    { /* CAEKF_FIXED_LINKS: the build's links */
        static const int sized_a[] = CAEKF_SIZED_SPRING_A, sized_b[] = CAEKF_SIZED_SPRING_B;
        static const int sized_ca[] = CAEKF_SIZED_CONTACT_A, sized_cb[] = CAEKF_SIZED_CONTACT_B;
        for (i = 0; i < (unsigned)CAEKF_SIZED_SPRINGS; ++i) { /* the links' ends: the build's step is theirs */
            if (m->spring_a[i] != sized_a[i]) {
                return (int)(CAEKF_PARAM_SPRING_A + i);
            }
            if (m->spring_b[i] != sized_b[i]) {
                return (int)(CAEKF_PARAM_SPRING_B + i);
            }
        }
        for (i = 0; i < (unsigned)CAEKF_SIZED_CONTACTS; ++i) { /* and the contacts' */
            if (m->contact_a[i] != sized_ca[i]) {
                return (int)(CAEKF_PARAM_CONTACT_A + i);
            }
            if (m->contact_b[i] != sized_cb[i]) {
                return (int)(CAEKF_PARAM_CONTACT_B + i);
            }
        }
    }
    (void)i;
#else
    (void)m;
    (void)s;
#endif /* CAEKF_SIZED_METHOD: its method and links are generated only there */
    return -1;
}

/* The estimated law parameters of the model's contacts. */
static unsigned law_params(const caekf_model_params_t *m)
{
    unsigned i, law = 0;
    for (i = 0; i < (unsigned)m->contacts; ++i) {
        law += (unsigned)(m->contact_estimate_n[i] + m->contact_estimate_lambda[i] + m->contact_estimate_gap[i]);
    }
    return law;
}

CAEKF_STATIC_ASSERT(offsetof(caekf_settings_t, model) == 0, the_model_leads_the_settings);

/* The first mechanism parameter declared uncertain (m{i}_sigma, spring{i}_k_sigma, spring{i}_c_sigma > 0)
 * the build has no room for: its parameter id, or -1 when they fit. A sized build estimates exactly its
 * scenario's count: fewer is refused at the first sigma (as unsupported). */
static int first_mech_over(const caekf_model_params_t *p)
{
    int i, count = 0, over = -1;
    for (i = 0; i < p->bodies && i < CAEKF_MAX_BODIES; ++i) {
        count += p->m_sigma[i] > 0;
        over = over < 0 && count > CAEKF_MAX_MECH_PARAMS ? (int)CAEKF_PARAM_M_SIGMA + i : over;
    }
    for (i = 0; i < p->springs && i < CAEKF_MAX_SPRINGS; ++i) {
        count += p->spring_k_sigma[i] > 0;
        over = over < 0 && count > CAEKF_MAX_MECH_PARAMS ? (int)CAEKF_PARAM_SPRING_K_SIGMA + i : over;
    }
    for (i = 0; i < p->springs && i < CAEKF_MAX_SPRINGS; ++i) {
        count += p->spring_c_sigma[i] > 0;
        over = over < 0 && count > CAEKF_MAX_MECH_PARAMS ? (int)CAEKF_PARAM_SPRING_C_SIGMA + i : over;
    }
    return over >= 0 || !CAEKF_SIZED || count == CAEKF_MAX_MECH_PARAMS ? over : (int)CAEKF_PARAM_M_SIGMA;
}

/* The first sensor the build cannot take: an offset (sensor{i}_bias_sigma > 0) beyond its room, or in a
 * build sized for one scenario any other count of offsets (refused at the first) or a sensor reading more
 * than one state where the build has no rows of H (CAEKF_HAS_SENSOR_ROWS). Its parameter id, or -1. */
static int first_sensor_over(const caekf_model_params_t *p)
{
    int i, count = 0, over = -1;
    for (i = 0; i < p->sensors && i < CAEKF_MAX_SENSORS; ++i) {
        count += p->sensor_bias_sigma[i] > 0;
        over = over < 0 && count > CAEKF_MAX_BIASES ? (int)CAEKF_PARAM_SENSOR_BIAS_SIGMA + i : over;
        over = over < 0 && !CAEKF_HAS_SENSOR_ROWS && p->sensor_kind[i] > CAEKF_SENSOR_VELOCITY
                   ? (int)CAEKF_PARAM_SENSOR_KIND + i
                   : over;
    }
    return over >= 0 || !CAEKF_SIZED || count == CAEKF_MAX_BIASES ? over : (int)CAEKF_PARAM_SENSOR_BIAS_SIGMA;
}

/* The model's own defence: the checks of caekf_settings_validate that concern the model alone (the same
 * code: its rows of the table, the bodies, a sized build's counts and method, the law parameters' room),
 * so that an invalid mechanism can never be derived (validation says which parameter is wrong). Returns
 * 0 if valid. */
int caekf_model_params_check(const caekf_model_params_t *p)
{
    unsigned reason, law;
    if (first_out_of_range(p, sizeof *p, &reason) >= 0 || first_bad_body(p) >= 0 ||
        (CAEKF_HAS_BASE_INPUTS && first_bad_base_input(p) >= 0) || first_unsized(p) >= 0 ||
        first_unsized_method(p, 0) >= 0) {
        return 1;
    }
    law = law_params(p);
    return law > (unsigned)CAEKF_MAX_LAW_PARAMS || (CAEKF_SIZED && law != (unsigned)CAEKF_MAX_LAW_PARAMS) ||
           first_mech_over(p) >= 0 || first_sensor_over(p) >= 0;
}

caekf_status_t caekf_settings_validate(const caekf_settings_t *s, caekf_setting_error_t *err)
{
    unsigned k, i;
    unsigned law_count = 0;
    int bad;
    if (s == 0) {
        return CAEKF_ERR_NULL;
    }
    bad = first_out_of_range(s, sizeof *s, &k);
    if (bad >= 0) {
        return refuse(err, k, (unsigned)bad);
    }
    if (s->newton_max_iter > CAEKF_NEWTON_MAX_ITER) {
        return refuse(err, CAEKF_SETTING_OVER_CAPACITY, CAEKF_PARAM_NEWTON_MAX_ITER);
    }
    bad = first_bad_body(&s->model);
    if (bad >= 0) {
        return refuse(err, CAEKF_SETTING_BAD_BODY, (unsigned)bad);
    }
    bad = CAEKF_HAS_BASE_INPUTS ? first_bad_base_input(&s->model) : -1; /* else refused as unsupported */
    if (bad >= 0) {
        return refuse(err, CAEKF_SETTING_BAD_LINK, (unsigned)bad);
    }
    for (i = 0; i < (unsigned)s->model.sensors; ++i) {
        const int kind = s->model.sensor_kind[i];
        if (kind == CAEKF_SENSOR_VELOCITY && !(s->sigma_rv > 0) && !(s->sensor_sigma[i] > 0)) {
            return refuse(err, CAEKF_SETTING_NEEDED, CAEKF_PARAM_SIGMA_RV);
        }
        if ((kind == CAEKF_SENSOR_ACCELERATION || kind == CAEKF_SENSOR_LINK_FORCE) && !(s->sensor_sigma[i] > 0)) {
            return refuse(err, CAEKF_SETTING_NEEDED, CAEKF_PARAM_SENSOR_SIGMA + i);
        }
    }
    bad = first_unsized(&s->model);
    if (bad < 0) {
        bad = first_unsized_method(&s->model, s);
    }
    if (bad >= 0) {
        return refuse(err, CAEKF_SETTING_UNSUPPORTED, (unsigned)bad);
    }
    for (i = 0; i < (unsigned)s->model.contacts; ++i) {
        law_count += (unsigned)(s->model.contact_estimate_n[i] + s->model.contact_estimate_lambda[i] +
                                s->model.contact_estimate_gap[i]);
        if (law_count > (unsigned)CAEKF_MAX_LAW_PARAMS) { /* the state has no room for it */
            return refuse(err, CAEKF_SIZED ? CAEKF_SETTING_UNSUPPORTED : CAEKF_SETTING_OVER_CAPACITY,
                          CAEKF_PARAM_ESTIMATE_N + i);
        }
    }
    if (CAEKF_SIZED && law_count != (unsigned)CAEKF_MAX_LAW_PARAMS) {
        return refuse(err, CAEKF_SETTING_UNSUPPORTED, CAEKF_PARAM_ESTIMATE_N);
    }
    bad = first_mech_over(&s->model);
    if (bad < 0) {
        bad = first_sensor_over(&s->model);
    }
    if (bad >= 0) {
        return refuse(err, CAEKF_SIZED ? CAEKF_SETTING_UNSUPPORTED : CAEKF_SETTING_OVER_CAPACITY, (unsigned)bad);
    }
    for (i = 0; i < (unsigned)s->model.contacts; ++i) {
        if (s->model.gamma_log && !(s->gamma0[i] > 0)) {
            return refuse(err, CAEKF_SETTING_NOT_POSITIVE, CAEKF_PARAM_GAMMA0 + i);
        }
        if (s->constraint_enabled &&
            (s->gamma0[i] < s->gamma_min[i] || (s->gamma_max[i] > 0 && s->gamma0[i] > s->gamma_max[i]))) {
            return refuse(err, CAEKF_SETTING_BELOW_GAMMA_MIN, CAEKF_PARAM_GAMMA0 + i);
        }
    }
    bad = CAEKF_HAS_LAW_PARAMS ? first_bad_law_param(s, &k) : -1;
    if (bad >= 0) {
        return refuse(err, k, (unsigned)bad);
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
