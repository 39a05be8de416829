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
    s->q_gamma_scale = 1;
    s->mode = CAEKF_MODE_SWITCHED;
    s->switchoff = CAEKF_SWITCHOFF_CONSISTENT;
    s->cov_update = CAEKF_COV_STANDARD;
    s->constraint_enabled = 0;
    s->cov_repair_enabled = 1;
    s->psd_check_period = 16; /* the per-step screen catches |corr| > 1 at once */
    /* chi-square(2) exceeds 25 with probability e^-12.5 = 3.7e-6 in a consistent filter; on the paper's
     * scenario the switched filter's NIS stays below 18, while the first measurement after 0.1 s without
     * measurements in contact gives ~1e4. */
    s->gamma_gate_nis = 25;
    s->newton_max_iter = CAEKF_NEWTON_MAX_ITER;
    /* Residual rounding scales with eps times the row's terms; 256 leaves room for the sums. */
    s->newton_rtol = CAEKF_EPS * 256;
    return CAEKF_OK;
}

/* Names validation reports, each stored once; NAME_x is the index of "x". The table checks below
 * hold a name in 4 bits, so theirs come first. */
#define CHECK_NAMES(X)                                                                                                 \
    X(q0) X(v0) X(m) X(dt) X(gamma0) X(gamma_min) X(sigma_q0) X(sigma_v0) X(sigma_gamma0) X(sigma_qx_q) X(sigma_qx_v) \
        X(sigma_q_gamma) X(q_gamma_scale) X(sigma_r) X(gamma_gate_nis)
#define OTHER_NAMES(X)                                                                                                 \
    X(mode) X(switchoff) X(cov_update) X(constraint_enabled) X(cov_repair_enabled) X(psd_check_period)                \
        X(newton_max_iter) X(newton_rtol)
#define NAME_INDEX(n) NAME_##n,
#define NAME_TEXT(n) #n "\0"
enum { CHECK_NAMES(NAME_INDEX) OTHER_NAMES(NAME_INDEX) NAME_gamma0_lt_min };
CAEKF_STATIC_ASSERT(NAME_mode <= 16, check_name_index_fits_4_bits);
static const char check_names[] = CHECK_NAMES(NAME_TEXT) OTHER_NAMES(NAME_TEXT) "gamma0 < gamma_min";

/* Out of line: called from two places, and each inlined copy costs flash. */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
static const char *name_of(unsigned k)
{
    const char *p = check_names;
    for (; k > 0; --k) {
        while (*p++ != 0) {
        }
    }
    return p;
}

/* A check forms r = num / den (num + the next slot if SUM), squares it if SQ, multiplies it by fac
 * and needs r finite, and > 0 if POS or >= 0 if NONNEG. Operands are slots, indices of scalar fields
 * in the settings read as an array of scalars, or the constants ONE and RQ: four bytes a check keep
 * the tables small on the MCU. Plain field checks divide and multiply by one, which is exact. */
enum { SUM = 1, SQ = 2, POS = 4, NONNEG = 8 };
#define SLOT(field) (offsetof(caekf_settings_t, field) / sizeof(caekf_scalar_t))
#define ONE 0xFE /* operand 1 */
#define RQ 0xFF  /* operand sigma_q0 / sigma_v0 */
#define CHECK(name, num, den, fac, flags)                                                                              \
    {(unsigned char)(num), (unsigned char)(den), (unsigned char)(fac), (unsigned char)((flags) | (NAME_##name << 4))}
#define FIELD(name, field, flags) CHECK(name, SLOT(field), ONE, ONE, flags)
CAEKF_STATIC_ASSERT(offsetof(caekf_settings_t, gamma_min) % sizeof(caekf_scalar_t) == 0 &&
                        offsetof(caekf_settings_t, gamma_gate_nis) % sizeof(caekf_scalar_t) == 0 &&
                        SLOT(gamma_gate_nis) < ONE,
                    settings_slots_fit_a_byte);
CAEKF_STATIC_ASSERT(CAEKF_NQ == 4, checks_list_four_bodies);

typedef struct {
    unsigned char num, den, fac, flags_name;
} check_t;

/* Plain field checks, in order; q0 and v0 go body by body, v0 first. */
#define FINITE_BODY(i) FIELD(v0, v0[i], 0), FIELD(q0, q0[i], 0)
static const check_t field_checks[] = {
    FINITE_BODY(0),
    FINITE_BODY(1),
    FINITE_BODY(2),
    FINITE_BODY(3),
    FIELD(gamma0, gamma0, 0),
    FIELD(sigma_q0, sigma_q0, POS),
    FIELD(sigma_v0, sigma_v0, POS),
    FIELD(sigma_gamma0, sigma_gamma0, POS),
    FIELD(sigma_qx_q, sigma_qx_q, NONNEG),
    FIELD(sigma_qx_v, sigma_qx_v, NONNEG),
    FIELD(sigma_q_gamma, sigma_q_gamma, NONNEG),
    FIELD(q_gamma_scale, q_gamma_scale, NONNEG),
    FIELD(sigma_r, sigma_r, POS),
    FIELD(gamma_gate_nis, gamma_gate_nis, NONNEG),
};

/* Values caekf_init derives must be usable in this scalar type too: finite settings can still
 * overflow or underflow once scaled (found by fuzzing: sigma_q0 = 1e-22 with sigma_qx_q = 1e22 in
 * float, subnormal sigmas in double). Each check repeats the operations of the value it guards. */
#define SCALED_BODY(i)                                                                                                 \
    CHECK(q0, SLOT(q0[i]), SLOT(sigma_q0), ONE, 0), CHECK(v0, SLOT(v0[i]), SLOT(sigma_v0), ONE, 0),                  \
        CHECK(m, SLOT(model.m[i]), SLOT(model.dt), ONE, POS)
static const check_t derived_checks[] = {
    SCALED_BODY(0),
    SCALED_BODY(1),
    SCALED_BODY(2),
    SCALED_BODY(3),
    /* The diagonal of A0 = M/dt + C + dt K: dt (k1 + k12) and dt (k34 + k4). */
    CHECK(dt, SLOT(model.k1), ONE, SLOT(model.dt), SUM),
    CHECK(dt, SLOT(model.k34), ONE, SLOT(model.dt), SUM),
    CHECK(gamma0, SLOT(gamma0), SLOT(sigma_gamma0), ONE, 0),
    CHECK(gamma_min, SLOT(gamma_min), SLOT(sigma_gamma0), ONE, 0),
    CHECK(sigma_qx_q, SLOT(sigma_qx_q), SLOT(sigma_q0), ONE, SQ),
    CHECK(sigma_qx_v, SLOT(sigma_qx_v), SLOT(sigma_v0), ONE, SQ),
    CHECK(sigma_q_gamma, SLOT(sigma_q_gamma), SLOT(sigma_gamma0), SLOT(q_gamma_scale), SQ),
    CHECK(sigma_r, SLOT(sigma_r), SLOT(sigma_q0), ONE, SQ | POS),
    /* The scaled transition S^-1 F S multiplies by rq, 1 / rq, dt / rq and sigma_gamma0 / sigma_v0. */
    CHECK(sigma_v0, SLOT(sigma_q0), SLOT(sigma_v0), ONE, POS),
    CHECK(sigma_v0, ONE, RQ, ONE, POS),
    CHECK(sigma_v0, SLOT(model.dt), RQ, ONE, POS),
    CHECK(sigma_v0, SLOT(sigma_gamma0), SLOT(sigma_v0), ONE, POS),
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

/* The name of the first failing check of c[0..n), or 0. */
static const char *first_failing(const caekf_settings_t *s, const check_t *c, unsigned n)
{
    for (; n > 0; --n, ++c) {
        unsigned flags = c->flags_name & 15;
        caekf_scalar_t r = operand(s, c->num);
        if (flags & SUM) {
            r += operand(s, c->num + 1u);
        }
        r /= operand(s, c->den);
        if (flags & SQ) {
            r *= r;
        }
        r *= operand(s, c->fac);
        if (!CAEKF_ISFINITE(r) || ((flags & POS) && !(r > 0)) || ((flags & NONNEG) && r < 0)) {
            return name_of(c->flags_name >> 4);
        }
    }
    return 0;
}

/* The name of the first failing check, or 0. */
static const char *first_bad_field(const caekf_settings_t *s)
{
    const char *bad;
    unsigned name;
    if (caekf_model_params_check(&s->model, &bad) != 0) {
        return bad;
    }
    bad = first_failing(s, field_checks, sizeof field_checks / sizeof field_checks[0]);
    if (bad != 0) {
        return bad;
    }
    if (s->mode != CAEKF_MODE_CANONICAL && s->mode != CAEKF_MODE_SWITCHED) name = NAME_mode;
    else if (s->switchoff != CAEKF_SWITCHOFF_CONSISTENT && s->switchoff != CAEKF_SWITCHOFF_PAPER) name = NAME_switchoff;
    else if (s->cov_update != CAEKF_COV_STANDARD && s->cov_update != CAEKF_COV_JOSEPH) name = NAME_cov_update;
    else if (s->constraint_enabled != 0 && s->constraint_enabled != 1) name = NAME_constraint_enabled;
    else if (s->cov_repair_enabled != 0 && s->cov_repair_enabled != 1) name = NAME_cov_repair_enabled;
    else if (s->psd_check_period < 1 || s->psd_check_period > 1000) name = NAME_psd_check_period;
    else if (!CAEKF_ISFINITE(s->gamma_min)) name = NAME_gamma_min;
    else if (s->constraint_enabled && s->gamma0 < s->gamma_min) name = NAME_gamma0_lt_min;
    else if (s->newton_max_iter < 1 || s->newton_max_iter > CAEKF_NEWTON_MAX_ITER) name = NAME_newton_max_iter;
    else if (!CAEKF_ISFINITE(s->newton_rtol) || !(s->newton_rtol > 0) || s->newton_rtol >= 1) name = NAME_newton_rtol;
    else return first_failing(s, derived_checks, sizeof derived_checks / sizeof derived_checks[0]);
    return name_of(name);
}

caekf_status_t caekf_settings_validate(const caekf_settings_t *s, const char **first_bad)
{
    const char *bad;
    if (s == 0) {
        return CAEKF_ERR_NULL;
    }
    bad = first_bad_field(s);
    if (first_bad != 0) {
        *first_bad = bad;
    }
    return bad == 0 ? CAEKF_OK : CAEKF_ERR_SETTINGS;
}
