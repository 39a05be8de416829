/*
 * caekf: contact-parameter estimation with a switched, constrained augmented EKF.
 *
 * The public API speaks physical SI units. All state lives in one caller-owned `caekf_t`; nothing is
 * allocated and there are no mutable globals, so several estimators can run side by side.
 *
 *   caekf_settings_t s;
 *   caekf_settings_default(&s);            // then fill in the model and noise from your scenario
 *   caekf_t est;
 *   if (caekf_init(&est, &s) != CAEKF_OK) { ...settings refused... }
 *   for each sample k: caekf_step(&est, u_k, y_k, &report);
 */
#ifndef CAEKF_H
#define CAEKF_H

#include <stdint.h>

#include "caekf/caekf_config.h"
#include "caekf/caekf_model.h"
#include "caekf/caekf_settings_schema.h" /* generated from the settings schema at build time */
#include "caekf/caekf_status.h"          /* generated too */

#ifdef __cplusplus
extern "C" {
#endif

/* The status of every call (caekf_status_t: errno-like, 0 success, negative an error) and the health flags of
 * one step (CAEKF_FLAG_*, a bit mask, PX4-style) are generated from the schema into caekf/caekf_status.h;
 * caekf_settings_t (the model first, then the estimator's settings) and the enums of its settings
 * (caekf_mode_t, caekf_switchoff_t, caekf_cov_update_t) are generated from the settings schema into
 * caekf/caekf_settings_types.h (docs/settings.md lists them). */

/* What one step did. */
typedef struct {
    uint32_t flags;       /* CAEKF_FLAG_* */
    int newton_iters;     /* Newton iterations of the prediction */
    caekf_scalar_t delta; /* deepest predicted penetration over the contacts, max_c delta_c(x_k-) [m] */
    caekf_scalar_t nis;   /* normalised innovation squared of the correction (0 without one) */
} caekf_report_t;

/* The model-mismatch monitor's state (docs/mismatch.md). */
typedef struct {
    caekf_scalar_t nis_mean; /* exponentially weighted mean of NIS per sensor (clipped): 1 while consistent */
    caekf_scalar_t q_scale;  /* the factor on the bodies' Q_x (mismatch_adapt): 1 unless adapted to a mismatch */
} caekf_mismatch_t;

/* The estimator instance (CMSIS-DSP style: caller-owned, no hidden state). Treat as opaque and read it
 * through the accessors below. Internally the state is scaled, z = S^-1 x with
 * S = diag(sigma_q0 .., sigma_v0 .., sigma_gamma0 of each contact), and P is kept in the same scaled
 * coordinates (P0 = I), which keeps float32 well conditioned. Matrices are n x n with leading dimension
 * n (n = 2 bodies + contacts) in buffers of the build's capacity. P_work and scratch are the step's
 * work buffers: they live here rather than on the stack so the step fits a small MCU stack, and so that
 * a failed step can be dropped without touching P. */
typedef struct {
    caekf_settings_t cfg;
    caekf_model_t model; /* derived model matrices */
#if CAEKF_HAS_SUBSTEPS
    caekf_model_t sub_model; /* the same at dt / contact_substeps (when > 1) */
#endif
    caekf_scalar_t scale[CAEKF_N];       /* S */
    caekf_scalar_t z[CAEKF_N];           /* scaled state */
    caekf_scalar_t P[CAEKF_N * CAEKF_N]; /* scaled covariance */
    caekf_scalar_t P_work[CAEKF_N * CAEKF_N];
    /* scratch: the PSD check's and the P norm's n x n workspace, earlier in a step the correction's, and
     * before it the contacts' laws at x_k- (eq. 21, then F) */
    union {
        caekf_scalar_t m[CAEKF_N * CAEKF_N];
        caekf_correct_work_t correct;
        caekf_contact_t contacts[CAEKF_MAX_CONTACTS + 1];
    } scratch;
#if !CAEKF_ONE_STEP_BE
    caekf_scalar_t x_prev[CAEKF_N]; /* step work: x_{k-1} (CAEKF_ONE_STEP_BE: kept in P_work) */
#endif
    caekf_scalar_t x_pred[CAEKF_N];       /* step work: x_k-, then the scaled z */
    caekf_scalar_t fv[CAEKF_NQ][CAEKF_N]; /* step work: v-rows of the scaled F */
#if CAEKF_HAS_SUBSTEPS
    caekf_scalar_t fq[CAEKF_NQ][CAEKF_N]; /* step work: q-rows of F after substeps (else implied by fv) */
    /* step work: the contacts at a substep's start and at its end (the next one's start), off the stack */
    caekf_contact_t sub_ct[2][CAEKF_MAX_CONTACTS];
    caekf_newton_lu_t sub_lu; /* step work: the Newton matrix's LU at a substep's start */
#endif
    caekf_fv_pattern_t fv_pattern;  /* fv's rows, compacted to their nonzeros: their columns */
    uint8_t fv_const;               /* fv holds the constant contact-free F (kept across steps) */
    caekf_scalar_t q_diag[CAEKF_N]; /* scaled Q diagonal (Q_gamma included) */
    caekf_filter_dims_t dims;       /* sizes, sensed states, scaled R; the parameters' policies */
    /* Bounds of parameter k (state 2 nq + k), scaled; bit k of bound_lo / bound_hi says it has one. */
    caekf_scalar_t lo_scaled[CAEKF_NP_STORE], hi_scaled[CAEKF_NP_STORE];
    uint32_t bound_lo, bound_hi;
#if CAEKF_KEEPS_U_PREV
    caekf_scalar_t u_prev[CAEKF_MAX_INPUTS]; /* inputs at the estimate's time (the trapezoidal rule's start) */
    uint32_t u_prev_known;                   /* 0 until a step or caekf_correct has seen the inputs */
#endif
    caekf_mismatch_t mismatch; /* the model-mismatch monitor (mismatch_window > 0) */
    /* The measured inputs' trend (input_trend_window; docs/mechanism.md): a Holt tracker's level at the last
     * step's input and its slope per step, input by input; known once a step has seen the inputs. */
    caekf_scalar_t input_trend[CAEKF_MAX_INPUTS][2];
    uint32_t input_trend_known;
    uint32_t step_count;
    uint32_t last_flags;
    uint32_t init_magic;
} caekf_t;

/* Why a setting was refused (caekf_setting_error_t.reason). */
typedef enum {
    CAEKF_SETTING_OK = 0,
    CAEKF_SETTING_OUT_OF_RANGE = 1,    /* breaks the schema's range rule of the setting */
    CAEKF_SETTING_BELOW_GAMMA_MIN = 2, /* gamma0 < gamma_min while constraint_enabled */
    CAEKF_SETTING_NOT_SCALABLE = 3,    /* finite, but a value init derives from it is not (this scalar type) */
    CAEKF_SETTING_OVER_CAPACITY = 4,   /* above a compile-time bound (newton_max_iter > CAEKF_NEWTON_MAX_ITER) */
    CAEKF_SETTING_UNKNOWN_ID = 5,      /* caekf_settings_set: no such parameter id */
    CAEKF_SETTING_NOT_INTEGER = 6,     /* caekf_settings_set: an int, enum or bool setting got a fraction */
    CAEKF_SETTING_BAD_BODY = 7,        /* names a body beyond `bodies` (or the ground where a body is needed,
                                         * or both ends the same) */
    CAEKF_SETTING_UNSUPPORTED = 8,     /* a count or step method other than a sized build's (CAEKF_SIZED) */
    CAEKF_SETTING_NEEDED = 9,          /* 0 (its default), but the mechanism uses it: must be > 0 */
    CAEKF_SETTING_OUTSIDE_BOUNDS = 10, /* an estimated parameter's initial value outside its bounds, or a
                                        * maximum below its minimum */
    CAEKF_SETTING_NOT_POSITIVE = 11,   /* gamma0 <= 0 with gamma_log (ln gamma needs gamma > 0) */
    CAEKF_SETTING_BAD_LINK = 12        /* a base input's link (input{i}_link): not a link in use with one end on
                                        * the ground, or one an earlier base input moves */
} caekf_setting_reason_t;

/* The first refused setting: its CTRL_PARAM id (element included), the setting (index into the schema's
 * table) and the element of an array setting. No strings to parse. */
typedef struct {
    uint8_t reason;   /* caekf_setting_reason_t */
    uint8_t param_id; /* CAEKF_PARAM_<NAME> + index */
    uint8_t setting;  /* 0 .. CAEKF_SETTING_COUNT-1 */
    uint8_t index;    /* element of an array setting, else 0 */
} caekf_setting_error_t;

/* One setting of the generated settings table, decoded (caekf_setting_rule): where it lives in
 * caekf_settings_t and the range rule validation applies to each of its elements. */
typedef struct {
    uint16_t offset; /* byte offset of element 0 in caekf_settings_t */
    uint16_t in_use; /* byte offset of the int giving how many elements are in use, or CAEKF_ALL_IN_USE */
    uint8_t id;      /* CTRL_PARAM id of element 0 */
    uint8_t count;   /* elements on the wire: ids id .. id+count-1 */
    uint8_t stored;  /* elements this build stores (its capacity; <= count) */
    uint8_t limit;   /* for a count of elements: the build's capacity it must not exceed, else 0 */
    uint8_t storage; /* CAEKF_SETTING_REAL or CAEKF_SETTING_INT */
    uint8_t rule;    /* CAEKF_RULE_* */
    uint16_t lo, hi; /* integer range of CAEKF_RULE_INT */
} caekf_setting_rule_t;
#define CAEKF_ALL_IN_USE 0xFFFFu

/* Row `setting` (0 .. CAEKF_SETTING_COUNT-1) of the table; CAEKF_ERR_SETTINGS for no such row. */
caekf_status_t caekf_setting_rule(unsigned setting, caekf_setting_rule_t *rule);

/* The table as generated, compact (what settings share is stored once): read it through
 * caekf_setting_rule. A row: the setting's offset, its element kind (low nibble: an index into
 * caekf_setting_kinds; high nibble: 1 + the capacity a count setting counts, else 0) and its rule (low
 * nibble: CAEKF_RULE_*; high nibble: for CAEKF_RULE_INT an index into caekf_setting_ranges). */
typedef struct {
    uint16_t offset;
    uint8_t kind;
    uint8_t rule;
} caekf_setting_row_t;
/* An element kind: one element, or an array over one of the mechanism's capacities. */
typedef struct {
    uint16_t in_use; /* offset of the int giving how many elements are in use, or CAEKF_ALL_IN_USE */
    uint8_t count;   /* elements on the wire */
    uint8_t stored;  /* elements this build stores */
} caekf_setting_kind_t;
extern const caekf_setting_row_t caekf_setting_rows[CAEKF_SETTING_COUNT];
extern const caekf_setting_kind_t caekf_setting_kinds[CAEKF_SETTING_KIND_COUNT];
extern const uint16_t caekf_setting_ranges[][2];

/* Fills the schema's defaults (switched, consistent, standard update, constraint off, repair on, gate
 * 25) and zero for the settings without a default (the model, gamma0, sigma0s and noise): the caller
 * must fill those. */
caekf_status_t caekf_settings_default(caekf_settings_t *s);
/* The generated part of it, on settings caekf_settings_default has zeroed: writes every default the
 * schema gives that differs from all bits zero (0, 0.0, the first enumerator), touches nothing else. */
caekf_status_t caekf_settings_schema_defaults(caekf_settings_t *s);

/* Sets one element by its CTRL_PARAM id (the scenario keys and the wire use the same ids). Integer,
 * enum and bool settings need an integral value. Ranges are checked by caekf_settings_validate, so a
 * configuration can be assembled in any order. On refusal (CAEKF_ERR_SETTINGS, `err` says why; may be
 * NULL) nothing is written. */
caekf_status_t caekf_settings_set(caekf_settings_t *s, unsigned param_id, double value, caekf_setting_error_t *err);

/* Reads one element by its CTRL_PARAM id. */
caekf_status_t caekf_settings_get(const caekf_settings_t *s, unsigned param_id, double *value);

/* Validates every setting against the schema's range (finite values, positive masses, springs, dt and
 * sigma0, sigma_r > 0, known enums, Newton bounds), then gamma0 >= gamma_min when constrained, then
 * the values init derives in this scalar type. Returns CAEKF_OK or CAEKF_ERR_SETTINGS with the first
 * refused element in `err` (may be NULL; reason CAEKF_SETTING_OK when valid). */
caekf_status_t caekf_settings_validate(const caekf_settings_t *s, caekf_setting_error_t *err);

/* The meaning of a range rule (CAEKF_RULE_*; lo and hi bound CAEKF_RULE_INT): 1 if v satisfies it. The
 * one implementation in C: validation and the host's scenario reader both call it. */
int caekf_setting_rule_ok(unsigned rule, double lo, double hi, double v);

/* Host-side text of a refusal, e.g. "m[2] = -1: must be finite and > 0". Writes at most len bytes
 * (always terminated); `s` gives the value (may be NULL). Built where CAEKF_HAS_SETTING_TEXT is 1 (host
 * builds): it formats with snprintf, which would bring an allocator into an MCU image. */
caekf_status_t caekf_setting_error_text(const caekf_setting_error_t *err, const caekf_settings_t *s, char *buf,
                                        unsigned len);

/* Names from the schema (NULL when out of range): a setting's name, its range rule as a message states
 * it, and the scenario/wire key of a parameter id ("m3", "sigma_r"). */
const char *caekf_setting_name(unsigned setting);
const char *caekf_setting_rule_text(unsigned setting);
const char *caekf_param_key(unsigned param_id);

/* Validates and initialises. On refusal `est` is left unchanged. */
caekf_status_t caekf_init(caekf_t *est, const caekf_settings_t *s);
/* caekf_init for a linear structure given as its matrices (docs/structure.md): M, K, C, B_u, the contacts' w and
 * the sensors' rows come from st (read once; the settings' bodies, links and ends are not read), the rest from
 * the settings. The structure starts at rest at q = 0. CAEKF_ERR_SETTINGS when the settings or the structure
 * are refused (caekf_model_structure_check), CAEKF_ERR_NULL for a NULL argument. */
caekf_status_t caekf_init_structure(caekf_t *est, const caekf_settings_t *s, const caekf_structure_t *st);

/* One estimator step with the inputs u_k (one force per input of the mechanism [N]; may be NULL when it
 * has none) and the measurements y_k (one per sensor [m or m/s]).
 * Non-finite u or y: CAEKF_ERR_INPUT, flags INPUT_REJECTED, state bit-for-bit untouched.
 * A non-finite intermediate result rolls the step back (CAEKF_ERR_NUMERIC). `report` may be NULL. */
caekf_status_t caekf_step(caekf_t *est, const caekf_scalar_t *u, const caekf_scalar_t *y, caekf_report_t *report);

/* The measurements y at the estimate's own time, without a time update: the first sample of a recording
 * that starts at t0, where the initial estimate (q0, v0) is given. Correction and constraints as in
 * caekf_step; u is remembered as the inputs at t0 (the trapezoidal rule's first step starts from them).
 * Afterwards call caekf_step for each later sample. Without it the first caekf_step advances from t0 to
 * its own sample with its inputs held over the interval. (docs/discretisation.md: the time convention.) */
caekf_status_t caekf_correct(caekf_t *est, const caekf_scalar_t *u, const caekf_scalar_t *y, caekf_report_t *report);

/* Time update only, for a step whose measurement is missing (e.g. frames lost on the bus): the model
 * still advances one dt with the inputs u (the caller may hold the last known u), P grows by Q, the
 * gammas are unchanged. Keeping the estimator on the clock this way avoids blaming a time shift on gamma.
 * Non-finite u is rejected with the state untouched. Flags include CAEKF_FLAG_NO_MEASUREMENT. */
caekf_status_t caekf_predict(caekf_t *est, const caekf_scalar_t *u, caekf_report_t *report);

/* The model-mismatch monitor: the mean NIS per sensor over mismatch_window steps (about 1 while the
 * innovations are consistent with P and R) and the factor now on the bodies' Q_x (1 unless
 * mismatch_adapt has raised it). Either pointer may be NULL. */
caekf_status_t caekf_get_mismatch(const caekf_t *est, caekf_scalar_t *nis_mean, caekf_scalar_t *q_scale);

/* Sizes of the mechanism the estimator runs: states n = 2 bodies + contacts, sensors, inputs. */
caekf_status_t caekf_get_sizes(const caekf_t *est, int *n, int *sensors, int *inputs);

/* Accessors in physical units. The state is x = [q_1..q_bodies, v_1..v_bodies, gamma_1..gamma_contacts,
 * then the estimated law parameters contact by contact: n, lambda, gap of those model.contact_estimate_*
 * selects]; entries beyond n are 0. */
caekf_status_t caekf_get_state(const caekf_t *est, caekf_scalar_t x[CAEKF_N]);
/* gamma of contact 1 (CAEKF_ERR_SETTINGS for a mechanism without contacts). */
caekf_status_t caekf_get_gamma(const caekf_t *est, caekf_scalar_t *gamma);
/* Contact c's law as the estimator now has it (0-based c): gamma, n, lambda and gap, the estimates of
 * those it estimates and the settings' values of the others. Any output pointer may be NULL. */
caekf_status_t caekf_get_contact_law(const caekf_t *est, int c, caekf_scalar_t *gamma, caekf_scalar_t *n,
                                     caekf_scalar_t *lambda, caekf_scalar_t *gap);
/* P in physical units (P_phys = S P S; with gamma_log, gamma's rows and columns also times gamma, the
 * first-order map from ln gamma), n x n in the top left corner, 0 elsewhere. */
caekf_status_t caekf_get_covariance(const caekf_t *est, caekf_scalar_t P[CAEKF_N][CAEKF_N]);
/* The diagonal of caekf_get_covariance (the same values): each state's variance; 0 beyond n. */
caekf_status_t caekf_get_variances(const caekf_t *est, caekf_scalar_t var[CAEKF_N]);
/* 2-norm of P in physical units (largest eigenvalue, by bounded Jacobi sweeps). Uses the instance's
 * scratch buffers, hence the non-const instance; the estimate is not changed. */
caekf_status_t caekf_get_cov_norm2(caekf_t *est, caekf_scalar_t *norm2);

/* Names of a status and of a flag bit: in the names library (<core>_names: the generated
 * caekf_settings_names.c, with the settings' names), so the estimator carries no strings. */
const char *caekf_status_str(caekf_status_t st);
const char *caekf_flag_name(unsigned bit_index);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_H */
