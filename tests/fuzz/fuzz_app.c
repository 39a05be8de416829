/*
 * libFuzzer harness 1: CAN frames into the firmware application (caekf_app_poll over an in-memory HAL),
 * checked against a reference model of the protocol written from caekf.dbc / firmware/protocol/README.md
 * and caekf_app.h, not from the app's code.
 *
 * The model keeps its own E2E receivers (own CRC-8/SAE-J1850 and bit extraction), its own step assembly,
 * its own configuration staging and commit, and a shadow estimator stepped with the inputs the model
 * decoded. After every poll it checks, exactly:
 *   - every counter the app keeps (all but TX_SATURATED): so every frame is accounted once, and every
 *     rejected frame (unknown ID, DLC, CRC, duplicate, jump, bad value, unconfigured, late, repeated)
 *     raised its counter;
 *   - the transmitted frames, in order: DLC 8, valid CRC, consecutive alive counters per message, the
 *     12 estimate frames of a step with EST_STEP last (STEP, status, flags, Newton iterations), EST_ACK
 *     fields (token, status, bad parameter: exactly the element caekf_settings_validate names,
 *     N_PARAMS_RX, state; its unused bits 40..47 zero), EST_HEALTH bursts;
 *   - the running configuration (settings compared field by field, bit for bit), the staging state,
 *     and the estimator (z, P, step count) against the shadow: a refused configuration or a rejected
 *     frame changes none of them. The wire carries no experiment: the schema's presets (the paper's
 *     experiments) arrive as ordinary CTRL_PARAMs, and CTRL_RESET's unused bits 16..23 (once the
 *     EXPERIMENT field) are filled with fuzz bytes the app must ignore;
 *   - after every accepted step: z and P finite, P exactly symmetric.
 *
 * Input: [cfg] [resync] [init] [time] then operations until the end (see the OP_* list below). [init] bit 7:
 * configured locally with the paper's settings and preset bits 0-1; with bit 6 also, the estimator starts from
 * snapshot bits 2-3 of that preset (fz_snapshot). At most MAX_FRAMES frames per input.
 */
#include "caekf/caekf_app.h"
#include "fuzz_common.h"

#define NMSG ((unsigned)CAEKF_MSG_COUNT)
#define QLEN 256u
#define TXCAP 4096u
/* Per input: short sequences keep the harness at about a thousand executions a second with the sanitizers
 * (3000 frames gave about 50); a sequence reaches deep states through OP_PAPER_CONFIG and OP_REPEAT_STEPS. */
#define MAX_OPS 32u
#define MAX_FRAMES 32u
#define PRESET_NONE (-1)

enum {
    OP_RAW = 0,      /* [id sel] ([id u32]) [dlc] [8 bytes]: a frame as it comes */
    OP_SEALED,       /* [msg] [counter mode] [7 payload bytes]: valid CRC over arbitrary payload */
    OP_STEP,         /* [flags] [step u16] [u u32] [y1 5 bytes] [y4 5 bytes]: a bench step */
    OP_PARAM,        /* [id] [exp10] [mantissa 5 bytes] */
    OP_RESET,        /* [unused bits 16..23] [n mode] [token] */
    OP_STATUS_REQ,   /* [token] */
    OP_TIME,         /* [u16]: advance the clock, poll */
    OP_HAL_FAULT,    /* [b]: receive errors pending, transmit failure toggle; poll */
    OP_LOCAL_CONFIG, /* [preset] [n] n x ([param id] [value]): caekf_app_configure */
    OP_BURST,        /* toggles burst mode: frames queue up, then polls drain the queue */
    OP_PAPER_CONFIG, /* [preset] [token]: the paper settings and a preset's as CTRL_PARAMs + CTRL_RESET */
    OP_REPEAT_STEPS, /* [n]: n more steps with the last inputs and consecutive STEP numbers */
    OP_COUNT
};

/* The DBC's CAN IDs and senders, written here independently of the generated table (by message, whatever
 * the enumeration's order). */
static const struct {
    uint16_t can_id;
    uint8_t from_bench;
} k_msg[CAEKF_MSG_COUNT] = {
    [CAEKF_MSG_CTRL_RESET] = {0x0C0, 1},      [CAEKF_MSG_CTRL_PARAM] = {0x0C1, 1},
    [CAEKF_MSG_CTRL_STATUS_REQ] = {0x0C2, 1}, [CAEKF_MSG_BENCH_U] = {0x100, 1},
    [CAEKF_MSG_BENCH_Y1] = {0x101, 1},        [CAEKF_MSG_BENCH_Y4] = {0x102, 1},
    [CAEKF_MSG_EST_ACK] = {0x0C8, 0},         [CAEKF_MSG_EST_HEALTH] = {0x0C9, 0},
    [CAEKF_MSG_EST_GAMMA] = {0x180, 0},       [CAEKF_MSG_EST_Q1] = {0x181, 0},
    [CAEKF_MSG_EST_Q2] = {0x182, 0},          [CAEKF_MSG_EST_Q3] = {0x183, 0},
    [CAEKF_MSG_EST_Q4] = {0x184, 0},          [CAEKF_MSG_EST_V1] = {0x185, 0},
    [CAEKF_MSG_EST_V2] = {0x186, 0},          [CAEKF_MSG_EST_V3] = {0x187, 0},
    [CAEKF_MSG_EST_V4] = {0x188, 0},          [CAEKF_MSG_EST_P_NORM] = {0x189, 0},
    [CAEKF_MSG_EST_P_GG] = {0x18A, 0},        [CAEKF_MSG_EST_STEP] = {0x18B, 0},
    [CAEKF_MSG_BENCH_YP] = {0x103, 1},        [CAEKF_MSG_EST_PROD] = {0x190, 0},
    [CAEKF_MSG_EST_PAGE] = {0x191, 0},        [CAEKF_MSG_BENCH_FD] = {0x104, 1},
    [CAEKF_MSG_EST_FD] = {0x192, 0},          [CAEKF_MSG_BENCH_U2] = {0x105, 1},
    [CAEKF_MSG_BENCH_S3_POS] = {0x106, 1},    [CAEKF_MSG_BENCH_S4_POS] = {0x107, 1},
    [CAEKF_MSG_BENCH_S1_VEL] = {0x108, 1},    [CAEKF_MSG_BENCH_S2_VEL] = {0x109, 1},
    [CAEKF_MSG_BENCH_S3_VEL] = {0x10A, 1},    [CAEKF_MSG_BENCH_S4_VEL] = {0x10B, 1},
    [CAEKF_MSG_EST_Q5] = {0x193, 0},          [CAEKF_MSG_EST_Q6] = {0x194, 0},
    [CAEKF_MSG_EST_Q7] = {0x195, 0},          [CAEKF_MSG_EST_Q8] = {0x196, 0},
    [CAEKF_MSG_EST_V5] = {0x197, 0},          [CAEKF_MSG_EST_V6] = {0x198, 0},
    [CAEKF_MSG_EST_V7] = {0x199, 0},          [CAEKF_MSG_EST_V8] = {0x19A, 0},
    [CAEKF_MSG_EST_GAMMA2] = {0x19B, 0},      [CAEKF_MSG_EST_P_GG2] = {0x19C, 0},
};
static uint16_t can_id_of(unsigned m) { return k_msg[m].can_id; }
static int is_bench_msg(unsigned m) { return k_msg[m].from_bench; }
static uint16_t data_id_of(unsigned m) { return (uint16_t)(0xCA00u | (can_id_of(m) & 0xFFu)); }

/* ---- bits and CRC (own implementation) -------------------------------------------------------- */

static uint64_t le64(const uint8_t d[8])
{
    uint64_t v = 0;
    int i;
    for (i = 7; i >= 0; --i) {
        v = (v << 8) | d[i];
    }
    return v;
}

static uint64_t mask_of(unsigned len) { return (len >= 64u) ? ~(uint64_t)0 : (((uint64_t)1 << len) - 1u); }

static uint64_t get_bits(const uint8_t d[8], unsigned start, unsigned len) { return (le64(d) >> start) & mask_of(len); }

static int64_t get_sbits(const uint8_t d[8], unsigned start, unsigned len)
{
    const uint64_t v = get_bits(d, start, len);
    if ((v >> (len - 1u)) & 1u) {
        return -(int64_t)((~v) & mask_of(len)) - 1;
    }
    return (int64_t)v;
}

static void put_bits(uint8_t d[8], unsigned start, unsigned len, uint64_t raw)
{
    uint64_t v = le64(d);
    int i;
    v &= ~(mask_of(len) << start);
    v |= (raw & mask_of(len)) << start;
    for (i = 0; i < 8; ++i) {
        d[i] = (uint8_t)(v >> (8 * i));
    }
}

static uint8_t crc8_j1850(uint16_t data_id, const uint8_t d[8])
{
    uint8_t buf[9];
    uint8_t crc = 0xFFu;
    unsigned i, b;
    buf[0] = (uint8_t)(data_id & 0xFFu);
    buf[1] = (uint8_t)(data_id >> 8);
    memcpy(&buf[2], &d[1], 7);
    for (i = 0; i < sizeof buf; ++i) {
        crc ^= buf[i];
        for (b = 0; b < 8u; ++b) {
            crc = (uint8_t)((crc & 0x80u) ? (((unsigned)crc << 1) ^ 0x1Du) : ((unsigned)crc << 1));
        }
    }
    return (uint8_t)(crc ^ 0xFFu);
}

/* ---- settings helpers --------------------------------------------------------------------------- */

#define SAME(a, b) (memcmp(&(a), &(b), sizeof(a)) == 0)

static int settings_equal(const caekf_settings_t *a, const caekf_settings_t *b)
{
    return SAME(a->model, b->model) && SAME(a->q0, b->q0) && SAME(a->v0, b->v0) && SAME(a->gamma0, b->gamma0) &&
           SAME(a->sigma_q0, b->sigma_q0) && SAME(a->sigma_v0, b->sigma_v0) && SAME(a->sigma_gamma0, b->sigma_gamma0) &&
           SAME(a->sigma_qx_q, b->sigma_qx_q) && SAME(a->sigma_qx_v, b->sigma_qx_v) &&
           SAME(a->sigma_q_gamma, b->sigma_q_gamma) && SAME(a->q_gamma_scale, b->q_gamma_scale) &&
           SAME(a->sigma_r, b->sigma_r) && SAME(a->sigma_rv, b->sigma_rv) && a->mode == b->mode &&
           a->switchoff == b->switchoff && a->cov_update == b->cov_update &&
           a->constraint_enabled == b->constraint_enabled && SAME(a->gamma_min, b->gamma_min) &&
           a->cov_repair_enabled == b->cov_repair_enabled && a->psd_check_period == b->psd_check_period &&
           a->newton_max_iter == b->newton_max_iter && SAME(a->newton_rtol, b->newton_rtol) &&
           SAME(a->gamma_gate_nis, b->gamma_gate_nis) && SAME(a->contact_slr_p, b->contact_slr_p);
}

static int app_settings_equal(const caekf_app_settings_t *a, const caekf_app_settings_t *b)
{
    return settings_equal(&a->est, &b->est);
}

/* The real-valued parameters by id (caekf.dbc's PARAM_ID table: arrays take consecutive ids); NULL for
 * the others. */
/* id within the n elements an array setting stores from `first`. */
#define IN(first, n) (id >= (unsigned)(first) && id < (unsigned)(first) + (unsigned)(n))

static caekf_scalar_t *model_real_field(caekf_settings_t *s, unsigned id)
{
    caekf_model_params_t *m = &s->model;
    if (IN(CAEKF_PARAM_M, CAEKF_MAX_BODIES)) return &m->m[id - CAEKF_PARAM_M];
    if (IN(CAEKF_PARAM_SPRING_K, CAEKF_MAX_SPRINGS)) return &m->spring_k[id - CAEKF_PARAM_SPRING_K];
    if (IN(CAEKF_PARAM_SPRING_C, CAEKF_MAX_SPRINGS)) return &m->spring_c[id - CAEKF_PARAM_SPRING_C];
    if (IN(CAEKF_PARAM_CONTACT_GAP, CAEKF_MAX_CONTACTS)) return &m->contact_gap[id - CAEKF_PARAM_CONTACT_GAP];
    if (IN(CAEKF_PARAM_CONTACT_N, CAEKF_MAX_CONTACTS)) return &m->contact_n[id - CAEKF_PARAM_CONTACT_N];
    if (IN(CAEKF_PARAM_CONTACT_LAMBDA, CAEKF_MAX_CONTACTS)) return &m->contact_lambda[id - CAEKF_PARAM_CONTACT_LAMBDA];
    if (IN(CAEKF_PARAM_Q0, CAEKF_MAX_BODIES)) return &s->q0[id - CAEKF_PARAM_Q0];
    if (IN(CAEKF_PARAM_V0, CAEKF_MAX_BODIES)) return &s->v0[id - CAEKF_PARAM_V0];
    if (IN(CAEKF_PARAM_GAMMA0, CAEKF_MAX_CONTACTS)) return &s->gamma0[id - CAEKF_PARAM_GAMMA0];
    if (IN(CAEKF_PARAM_SIGMA_GAMMA0, CAEKF_MAX_CONTACTS)) return &s->sigma_gamma0[id - CAEKF_PARAM_SIGMA_GAMMA0];
    if (IN(CAEKF_PARAM_SIGMA_Q_GAMMA, CAEKF_MAX_CONTACTS)) return &s->sigma_q_gamma[id - CAEKF_PARAM_SIGMA_Q_GAMMA];
    if (IN(CAEKF_PARAM_GAMMA_MIN, CAEKF_MAX_CONTACTS)) return &s->gamma_min[id - CAEKF_PARAM_GAMMA_MIN];
    if (IN(CAEKF_PARAM_GAMMA_MAX, CAEKF_MAX_CONTACTS)) return &s->gamma_max[id - CAEKF_PARAM_GAMMA_MAX];
    if (IN(CAEKF_PARAM_N0, CAEKF_MAX_CONTACTS)) return &s->n0[id - CAEKF_PARAM_N0];
    if (IN(CAEKF_PARAM_LAMBDA0, CAEKF_MAX_CONTACTS)) return &s->lambda0[id - CAEKF_PARAM_LAMBDA0];
    if (IN(CAEKF_PARAM_GAP0, CAEKF_MAX_CONTACTS)) return &s->gap0[id - CAEKF_PARAM_GAP0];
    if (IN(CAEKF_PARAM_SIGMA_N0, CAEKF_MAX_CONTACTS)) return &s->sigma_n0[id - CAEKF_PARAM_SIGMA_N0];
    if (IN(CAEKF_PARAM_SIGMA_LAMBDA0, CAEKF_MAX_CONTACTS)) return &s->sigma_lambda0[id - CAEKF_PARAM_SIGMA_LAMBDA0];
    if (IN(CAEKF_PARAM_SIGMA_GAP0, CAEKF_MAX_CONTACTS)) return &s->sigma_gap0[id - CAEKF_PARAM_SIGMA_GAP0];
    if (IN(CAEKF_PARAM_SIGMA_Q_N, CAEKF_MAX_CONTACTS)) return &s->sigma_q_n[id - CAEKF_PARAM_SIGMA_Q_N];
    if (IN(CAEKF_PARAM_SIGMA_Q_LAMBDA, CAEKF_MAX_CONTACTS)) return &s->sigma_q_lambda[id - CAEKF_PARAM_SIGMA_Q_LAMBDA];
    if (IN(CAEKF_PARAM_SIGMA_Q_GAP, CAEKF_MAX_CONTACTS)) return &s->sigma_q_gap[id - CAEKF_PARAM_SIGMA_Q_GAP];
    if (IN(CAEKF_PARAM_N_MIN, CAEKF_MAX_CONTACTS)) return &s->n_min[id - CAEKF_PARAM_N_MIN];
    if (IN(CAEKF_PARAM_N_MAX, CAEKF_MAX_CONTACTS)) return &s->n_max[id - CAEKF_PARAM_N_MAX];
    if (IN(CAEKF_PARAM_LAMBDA_MIN, CAEKF_MAX_CONTACTS)) return &s->lambda_min[id - CAEKF_PARAM_LAMBDA_MIN];
    if (IN(CAEKF_PARAM_LAMBDA_MAX, CAEKF_MAX_CONTACTS)) return &s->lambda_max[id - CAEKF_PARAM_LAMBDA_MAX];
    if (IN(CAEKF_PARAM_GAP_MIN, CAEKF_MAX_CONTACTS)) return &s->gap_min[id - CAEKF_PARAM_GAP_MIN];
    if (IN(CAEKF_PARAM_GAP_MAX, CAEKF_MAX_CONTACTS)) return &s->gap_max[id - CAEKF_PARAM_GAP_MAX];
    if (IN(CAEKF_PARAM_M_SIGMA, CAEKF_MAX_BODIES)) return &m->m_sigma[id - CAEKF_PARAM_M_SIGMA];
    if (IN(CAEKF_PARAM_SPRING_K_SIGMA, CAEKF_MAX_SPRINGS)) return &m->spring_k_sigma[id - CAEKF_PARAM_SPRING_K_SIGMA];
    if (IN(CAEKF_PARAM_SPRING_C_SIGMA, CAEKF_MAX_SPRINGS)) return &m->spring_c_sigma[id - CAEKF_PARAM_SPRING_C_SIGMA];
    if (IN(CAEKF_PARAM_INPUT_SIGMA, CAEKF_MAX_INPUTS)) return &s->input_sigma[id - CAEKF_PARAM_INPUT_SIGMA];
    if (IN(CAEKF_PARAM_SENSOR_SIGMA, CAEKF_MAX_SENSORS)) return &s->sensor_sigma[id - CAEKF_PARAM_SENSOR_SIGMA];
    if (IN(CAEKF_PARAM_SENSOR_BIAS_SIGMA, CAEKF_MAX_SENSORS))
        return &m->sensor_bias_sigma[id - CAEKF_PARAM_SENSOR_BIAS_SIGMA];
    switch (id) {
    case CAEKF_PARAM_DT: return &m->dt;
    case CAEKF_PARAM_SIGMA_Q0: return &s->sigma_q0;
    case CAEKF_PARAM_SIGMA_V0: return &s->sigma_v0;
    case CAEKF_PARAM_SIGMA_QX_Q: return &s->sigma_qx_q;
    case CAEKF_PARAM_SIGMA_QX_V: return &s->sigma_qx_v;
    case CAEKF_PARAM_SIGMA_R: return &s->sigma_r;
    case CAEKF_PARAM_SIGMA_RV: return &s->sigma_rv;
    case CAEKF_PARAM_Q_GAMMA_SCALE: return &s->q_gamma_scale;
    case CAEKF_PARAM_NEWTON_RTOL: return &s->newton_rtol;
    case CAEKF_PARAM_GAMMA_GATE_NIS: return &s->gamma_gate_nis;
    case CAEKF_PARAM_CONTACT_SLR_P: return &s->contact_slr_p;
    case CAEKF_PARAM_MISMATCH_RATIO: return &s->mismatch_ratio;
    case CAEKF_PARAM_SIGMA_Q_MECH: return &s->sigma_q_mech;
    default: return NULL;
    }
}

/* The integer, enum and bool parameters: the field of `id`, or NULL if `id` is not one. */
static int *model_int_field(caekf_settings_t *s, unsigned id)
{
    caekf_model_params_t *m = &s->model;
    if (IN(CAEKF_PARAM_SPRING_A, CAEKF_MAX_SPRINGS)) return &m->spring_a[id - CAEKF_PARAM_SPRING_A];
    if (IN(CAEKF_PARAM_SPRING_B, CAEKF_MAX_SPRINGS)) return &m->spring_b[id - CAEKF_PARAM_SPRING_B];
    if (IN(CAEKF_PARAM_INPUT_BODY, CAEKF_MAX_INPUTS)) return &m->input_body[id - CAEKF_PARAM_INPUT_BODY];
    if (IN(CAEKF_PARAM_INPUT_KIND, CAEKF_MAX_INPUTS)) return &m->input_kind[id - CAEKF_PARAM_INPUT_KIND];
    if (IN(CAEKF_PARAM_INPUT_LINK, CAEKF_MAX_INPUTS)) return &m->input_link[id - CAEKF_PARAM_INPUT_LINK];
    if (IN(CAEKF_PARAM_SENSOR_BODY, CAEKF_MAX_SENSORS)) return &m->sensor_body[id - CAEKF_PARAM_SENSOR_BODY];
    if (IN(CAEKF_PARAM_SENSOR_KIND, CAEKF_MAX_SENSORS)) return &m->sensor_kind[id - CAEKF_PARAM_SENSOR_KIND];
    if (IN(CAEKF_PARAM_SENSOR_REF, CAEKF_MAX_SENSORS)) return &m->sensor_ref[id - CAEKF_PARAM_SENSOR_REF];
    if (IN(CAEKF_PARAM_SENSOR_LINK, CAEKF_MAX_SENSORS)) return &m->sensor_link[id - CAEKF_PARAM_SENSOR_LINK];
    if (IN(CAEKF_PARAM_CONTACT_A, CAEKF_MAX_CONTACTS)) return &m->contact_a[id - CAEKF_PARAM_CONTACT_A];
    if (IN(CAEKF_PARAM_CONTACT_B, CAEKF_MAX_CONTACTS)) return &m->contact_b[id - CAEKF_PARAM_CONTACT_B];
    if (IN(CAEKF_PARAM_ESTIMATE_N, CAEKF_MAX_CONTACTS)) return &m->contact_estimate_n[id - CAEKF_PARAM_ESTIMATE_N];
    if (IN(CAEKF_PARAM_ESTIMATE_LAMBDA, CAEKF_MAX_CONTACTS))
        return &m->contact_estimate_lambda[id - CAEKF_PARAM_ESTIMATE_LAMBDA];
    if (IN(CAEKF_PARAM_ESTIMATE_GAP, CAEKF_MAX_CONTACTS))
        return &m->contact_estimate_gap[id - CAEKF_PARAM_ESTIMATE_GAP];
    switch (id) {
    case CAEKF_PARAM_BODIES: return &m->bodies;
    case CAEKF_PARAM_SPRINGS: return &m->springs;
    case CAEKF_PARAM_INPUTS: return &m->inputs;
    case CAEKF_PARAM_SENSORS: return &m->sensors;
    case CAEKF_PARAM_CONTACTS: return &m->contacts;
    case CAEKF_PARAM_SWITCHOFF: return &s->switchoff;
    case CAEKF_PARAM_COV_UPDATE: return &s->cov_update;
    case CAEKF_PARAM_COV_REPAIR_ENABLED: return &s->cov_repair_enabled;
    case CAEKF_PARAM_NEWTON_MAX_ITER: return &s->newton_max_iter;
    case CAEKF_PARAM_MODE: return &s->mode;
    case CAEKF_PARAM_CONSTRAINT_ENABLED: return &s->constraint_enabled;
    case CAEKF_PARAM_PSD_CHECK_PERIOD: return &s->psd_check_period;
    case CAEKF_PARAM_DISCRETISATION: return &m->discretisation;
    case CAEKF_PARAM_CONTACT_SUBSTEPS: return &s->contact_substeps;
    case CAEKF_PARAM_GAMMA_LOG: return &m->gamma_log;
    case CAEKF_PARAM_LAW_SECOND_ORDER: return &s->law_second_order;
    case CAEKF_PARAM_MISMATCH_WINDOW: return &s->mismatch_window;
    case CAEKF_PARAM_INPUT_TREND_WINDOW: return &s->input_trend_window;
    case CAEKF_PARAM_MISMATCH_ADAPT: return &s->mismatch_adapt;
    default: return NULL;
    }
}

static int model_int_set(caekf_settings_t *s, unsigned id, int v)
{
    int *f = model_int_field(s, id);
    if (f == NULL) {
        return -1;
    }
    *f = v;
    return 0;
}

/* Sets a parameter as the model understands it, and checks caekf_app_settings_set agrees. 0 if set.
 * Real parameters take any value (validation is the commit's business); integer, enum and bool ones
 * need an integral value: the model accepts every integral value up to 1000 (psd_check_period's upper
 * bound) and leaves the limit beyond that to the setter. */
static int model_set(caekf_app_settings_t *s, unsigned id, double value)
{
    caekf_app_settings_t other = *s;
    const caekf_app_status_t ast = caekf_app_settings_set(&other, id, value);
    caekf_scalar_t *f = model_real_field(&s->est, id);
    int ok;
    double stored;
    if (id >= (unsigned)CAEKF_PARAM_COUNT || caekf_settings_get(&s->est, id, &stored) != CAEKF_OK) {
        ok = 0; /* no such id, or an element beyond this build's capacity */
    } else if (f != NULL) {
        *f = (caekf_scalar_t)value;
        ok = 1;
    } else {
        caekf_settings_t probe = s->est;
        FZ_CHECK(model_int_set(&probe, id, 0) == 0, "every parameter id is a real or an integer setting");
        if (!isfinite(value) || value != floor(value)) {
            ok = 0;
        } else if (fabs(value) <= 1000.0) {
            ok = 1;
        } else {
            ok = (ast == CAEKF_APP_OK);
            FZ_CHECK(!ok || fabs(value) < 2147483647.0, "an accepted integer fits an int");
        }
        if (ok) {
            (void)model_int_set(&s->est, id, (int)value);
        }
    }
    FZ_CHECK((ast == CAEKF_APP_OK) == ok, "caekf_app_settings_set agrees on acceptance");
    if (ok) {
        FZ_CHECK(app_settings_equal(s, &other), "caekf_app_settings_set writes the documented field");
    }
    return ok ? 0 : -1;
}

/* A value as the bench sends it: mantissa * 10^exp10, shortest decimal form (fixture values are short
 * decimals). */
static void wire_decimal(double value, int *exp10, int64_t *mantissa)
{
    double m = value;
    int e = 0;
    while (m != 0.0 && m != (double)(int64_t)m && e > -22) {
        m *= 10.0;
        e--;
    }
    *exp10 = e;
    *mantissa = (int64_t)m;
}

/* ---- the model ---------------------------------------------------------------------------------- */

typedef struct {
    uint8_t msg;
    uint16_t step;  /* value frames and EST_STEP */
    int8_t status;  /* EST_STEP: step status; EST_ACK: ack status */
    uint16_t flags; /* EST_STEP: flags without bits 12 and 14 (saturation, P norm) */
    uint8_t iters;
    uint8_t token, n_rx, state;
    uint16_t bad_param; /* EST_ACK: expected BAD_PARAM */
    uint8_t page;
} expect_t;

typedef struct {
    /* app configuration */
    caekf_app_config_t cfg;
    /* E2E receivers */
    uint8_t synced[CAEKF_MSG_COUNT], last_ctr[CAEKF_MSG_COUNT];
    uint32_t last_us[CAEKF_MSG_COUNT];
    uint32_t cnt[CAEKF_CNT_COUNT];
    /* configuration */
    int configured;
    caekf_app_settings_t active;
    int staging;
    unsigned staged_count;
    int staged_error;
    unsigned staged_bad;
    caekf_app_settings_t staged;
    /* step assembly */
    int open;
    unsigned have;
    uint16_t step;
    uint32_t opened_us;
    double u[CAEKF_MAX_INPUTS], y[CAEKF_MAX_SENSORS]; /* the mechanism's inputs and sensors */
    int have_closed, have_run;
    uint16_t last_closed, last_run;
    double last_u[CAEKF_MAX_INPUTS]; /* held over a gap's prediction-only steps */
    caekf_t est;                     /* shadow estimator */
    uint32_t last_status_us;
    /* transmit expectations of the current poll */
    expect_t exp[TXCAP];
    unsigned n_exp;
    /* bench-side view of what the app sends */
    uint8_t tx_seen[CAEKF_MSG_COUNT], tx_next[CAEKF_MSG_COUNT];
} model_t;

typedef struct {
    caekf_can_frame_t q[QLEN];
    unsigned head, count;
    uint32_t now;
    int rx_errors_pending;
    int tx_fail;
    caekf_can_frame_t tx[TXCAP];
    unsigned n_tx;
    uint8_t bench_ctr[CAEKF_MSG_COUNT];
} hal_t;

static model_t M;
static hal_t H;
static caekf_app_t app;

static void expect_push(const expect_t *e)
{
    FZ_CHECK(M.n_exp < TXCAP, "harness: expectation list full");
    M.exp[M.n_exp++] = *e;
}

static void model_close_slot(void)
{
    M.open = 0;
    M.have = 0;
    M.last_closed = M.step;
    M.have_closed = 1;
}

static void model_timeout(uint32_t now)
{
    if (M.open && (uint32_t)(now - M.opened_us) > M.cfg.step_timeout_us) {
        M.cnt[CAEKF_CNT_STEPS_TIMED_OUT]++;
        model_close_slot();
    }
}

static int step_after(uint16_t a, uint16_t b)
{
    const uint16_t d = (uint16_t)(a - b);
    return d != 0u && d < 0x8000u;
}

static void check_estimate_sane(const caekf_t *e)
{
    const int n = e->model.n; /* the fuzzed frames may change the mechanism's counts */
    int i, j;
    for (i = 0; i < n; ++i) {
        FZ_CHECK(fz_is_finite_scalar(e->z[i]), "accepted step: z finite");
        for (j = 0; j < n; ++j) {
            FZ_CHECK(fz_is_finite_scalar(e->P[i * n + j]), "accepted step: P finite");
            FZ_CHECK(e->P[i * n + j] == e->P[j * n + i], "accepted step: P exactly symmetric");
        }
    }
}

static void model_run_step(void)
{
    static const uint8_t q_msgs[8] = {CAEKF_MSG_EST_Q1, CAEKF_MSG_EST_Q2, CAEKF_MSG_EST_Q3, CAEKF_MSG_EST_Q4,
                                      CAEKF_MSG_EST_Q5, CAEKF_MSG_EST_Q6, CAEKF_MSG_EST_Q7, CAEKF_MSG_EST_Q8};
    static const uint8_t v_msgs[8] = {CAEKF_MSG_EST_V1, CAEKF_MSG_EST_V2, CAEKF_MSG_EST_V3, CAEKF_MSG_EST_V4,
                                      CAEKF_MSG_EST_V5, CAEKF_MSG_EST_V6, CAEKF_MSG_EST_V7, CAEKF_MSG_EST_V8};
    caekf_scalar_t y[CAEKF_MAX_SENSORS], u[CAEKF_MAX_INPUTS];
    caekf_report_t rep;
    caekf_status_t st;
    expect_t e;
    uint16_t gap = 0;
    unsigned i;
    uint8_t zb[sizeof M.est.z], Pb[sizeof M.est.P];
    if (M.have_run && M.step != (uint16_t)(M.last_run + 1u)) {
        uint16_t missing = (uint16_t)(M.step - M.last_run - 1u);
        uint16_t k;
        gap = (uint16_t)CAEKF_STEP_FLAGS_STEP_GAP;
        M.cnt[CAEKF_CNT_STEPS_SKIPPED] += missing;
        for (i = 0; i < (unsigned)CAEKF_MAX_INPUTS; ++i) {
            u[i] = (caekf_scalar_t)M.last_u[i];
        }
        for (k = 0; k < missing && k < (uint16_t)CAEKF_APP_MAX_GAP_PREDICT; ++k) {
            (void)caekf_predict(&M.est, u, NULL); /* the app bridges gaps */
        }
    }
    for (i = 0; i < (unsigned)CAEKF_MAX_SENSORS; ++i) {
        y[i] = (caekf_scalar_t)M.y[i];
    }
    for (i = 0; i < (unsigned)CAEKF_MAX_INPUTS; ++i) {
        u[i] = (caekf_scalar_t)M.u[i];
    }
    memcpy(zb, M.est.z, sizeof zb);
    memcpy(Pb, M.est.P, sizeof Pb);
    st = caekf_step(&M.est, u, y, &rep);
    M.cnt[CAEKF_CNT_STEPS_DONE]++;
    if (st != CAEKF_OK) {
        M.cnt[CAEKF_CNT_STEPS_FAILED]++;
        FZ_CHECK(st == CAEKF_ERR_NUMERIC || st == CAEKF_ERR_SINGULAR, "decoded inputs are finite: no ERR_INPUT");
        FZ_CHECK(memcmp(zb, M.est.z, sizeof zb) == 0 && memcmp(Pb, M.est.P, sizeof Pb) == 0,
                 "failed step: estimate untouched");
    } else {
        check_estimate_sane(&M.est);
    }
    model_close_slot();
    M.last_run = M.step;
    memcpy(M.last_u, M.u, sizeof M.last_u);
    M.have_run = 1;
    memset(&e, 0, sizeof e);
    e.step = M.step;
    /* diagnostics: gamma, every body's q and v, P norm, P_gg, contact 2's gamma and P_gg, EST_STEP */
    e.msg = (uint8_t)CAEKF_MSG_EST_GAMMA;
    expect_push(&e);
    for (i = 0; i < (unsigned)M.est.model.nq && i < 8u; ++i) {
        e.msg = q_msgs[i];
        expect_push(&e);
    }
    for (i = 0; i < (unsigned)M.est.model.nq && i < 8u; ++i) {
        e.msg = v_msgs[i];
        expect_push(&e);
    }
    e.msg = (uint8_t)CAEKF_MSG_EST_P_NORM;
    expect_push(&e);
    e.msg = (uint8_t)CAEKF_MSG_EST_P_GG;
    expect_push(&e);
    if (M.est.model.nc > 1) {
        e.msg = (uint8_t)CAEKF_MSG_EST_GAMMA2;
        expect_push(&e);
        e.msg = (uint8_t)CAEKF_MSG_EST_P_GG2;
        expect_push(&e);
    }
    e.msg = (uint8_t)CAEKF_MSG_EST_STEP;
    e.status = (int8_t)st;
    e.flags = (uint16_t)((rep.flags & CAEKF_FLAG_MASK) | gap);
    e.iters = (uint8_t)(rep.newton_iters < 0 ? 0 : rep.newton_iters > 255 ? 255 : rep.newton_iters);
    expect_push(&e);
}

/* The slot bit of sensor s carried as `kind` (own reading of the app's rule: 0 when the configured mechanism has
 * no such sensor); inputs take bits 0..CAEKF_MAX_INPUTS-1, sensors the bits above. */
static unsigned model_sensor_bit(int s, int kind)
{
    const caekf_model_params_t *mp = &M.est.cfg.model;
    return (s < mp->sensors && mp->sensor_kind[s] == kind) ? 1u << (CAEKF_MAX_INPUTS + s) : 0u;
}

static void model_assembly(unsigned msg, const uint8_t d[8], uint32_t now)
{
    uint16_t step = (uint16_t)get_bits(d, 12, 16);
    unsigned bit = 0u, bit2 = 0u, need = 0u, i;
    int input = -1, sensor = -1, kind = CAEKF_SENSOR_POSITION;
    double v = 0.0;
    double yp1 = 0.0, yp4 = 0.0;
    switch (msg) {
    case CAEKF_MSG_BENCH_U: input = 0; break;
    case CAEKF_MSG_BENCH_U2: input = 1; break;
    case CAEKF_MSG_BENCH_Y1: sensor = 0; break;
    case CAEKF_MSG_BENCH_Y4: sensor = 1; break;
    case CAEKF_MSG_BENCH_S3_POS: sensor = 2; break;
    case CAEKF_MSG_BENCH_S4_POS: sensor = 3; break;
    case CAEKF_MSG_BENCH_S1_VEL:
        sensor = 0;
        kind = CAEKF_SENSOR_VELOCITY;
        break;
    case CAEKF_MSG_BENCH_S2_VEL:
        sensor = 1;
        kind = CAEKF_SENSOR_VELOCITY;
        break;
    case CAEKF_MSG_BENCH_S3_VEL:
        sensor = 2;
        kind = CAEKF_SENSOR_VELOCITY;
        break;
    case CAEKF_MSG_BENCH_S4_VEL:
        sensor = 3;
        kind = CAEKF_SENSOR_VELOCITY;
        break;
    default: break;
    }
    if (msg == CAEKF_MSG_BENCH_YP) {
        /* STEP mod 2^8: the 16-bit step within -128..+127 of the open step (or the one after the last
         * closed step) with these low bits */
        const unsigned s8 = (unsigned)get_bits(d, 12, 8);
        const unsigned ref = M.open ? M.step : M.have_closed ? (unsigned)(uint16_t)(M.last_closed + 1u) : s8;
        step = (uint16_t)(ref + (unsigned)((int)(((s8 - ref) & 0xFFu) ^ 0x80u) - 0x80));
        yp1 = (double)get_sbits(d, 20, 22) * 1e-9; /* LSB 1e-9 m, as cantools: raw * scale */
        yp4 = (double)get_sbits(d, 42, 22) * 1e-9;
    } else if (input >= 0) {
        const uint32_t fb = (uint32_t)get_bits(d, 32, 32);
        if (((fb >> 23) & 0xFFu) == 0xFFu) { /* NaN or infinity: refused */
            M.cnt[CAEKF_CNT_RX_BAD_VALUE]++;
            return;
        }
        v = fz_bits_to_float(fb);
    } else {
        /* LSB 1e-12 m or 1e-10 m/s, as cantools: raw * scale */
        v = (double)get_sbits(d, 28, 36) * (kind == CAEKF_SENSOR_VELOCITY ? 1e-10 : 1e-12);
    }
    M.cnt[CAEKF_CNT_RX_OK]++;
    if (!M.configured) {
        M.cnt[CAEKF_CNT_RX_UNCONFIGURED]++;
        return;
    }
    if (msg == CAEKF_MSG_BENCH_YP) {
        bit = model_sensor_bit(0, CAEKF_SENSOR_POSITION);
        bit2 = model_sensor_bit(1, CAEKF_SENSOR_POSITION);
    } else if (input >= 0) {
        bit = (input < M.est.cfg.model.inputs) ? 1u << input : 0u;
    } else if (sensor >= 0) {
        bit = model_sensor_bit(sensor, kind);
    }
    if ((bit | bit2) == 0u) {
        return; /* a value this mechanism does not have: ignored */
    }
    /* A frame of the open step joins it; an older one is late; a newer one drops the open step. */
    if (!(M.open && step == M.step)) {
        if (M.open && !step_after(step, M.step)) {
            M.cnt[CAEKF_CNT_RX_LATE]++;
            return;
        }
        if (M.open) {
            M.cnt[CAEKF_CNT_STEPS_SUPERSEDED]++;
            model_close_slot();
        } else if (M.have_closed && !step_after(step, M.last_closed)) {
            M.cnt[CAEKF_CNT_RX_LATE]++;
            return;
        }
        M.open = 1;
        M.have = 0;
        M.step = step;
        M.opened_us = now;
    }
    if (M.have & (bit | bit2)) {
        M.cnt[CAEKF_CNT_RX_REPEATED]++; /* the first value stays */
        return;
    }
    M.have |= bit | bit2;
    if (msg == CAEKF_MSG_BENCH_YP) {
        if (bit != 0u) {
            M.y[0] = yp1;
        }
        if (bit2 != 0u) {
            M.y[1] = yp4;
        }
    } else if (input >= 0) {
        M.u[input] = v;
    } else {
        M.y[sensor] = v;
    }
    for (i = 0; i < (unsigned)M.est.cfg.model.inputs; ++i) {
        need |= 1u << i;
    }
    for (i = 0; i < (unsigned)M.est.cfg.model.sensors; ++i) {
        need |= 1u << (CAEKF_MAX_INPUTS + i);
    }
    if ((M.have & need) == need) {
        model_run_step();
    }
}

static void model_stage_error(unsigned id)
{
    if (M.staged_error == 0) {
        M.staged_error = (int)CAEKF_ACK_REFUSED_PARAM;
        M.staged_bad = id;
    }
}

static void model_param(const uint8_t d[8])
{
    const unsigned id = (unsigned)get_bits(d, 12, 8);
    const int exp10 = (int)get_sbits(d, 20, 6);
    const int64_t mant = get_sbits(d, 26, 38);
    static const double p10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                   1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    if (!M.staging) {
        if (M.configured) {
            M.staged = M.active;
        } else {
            (void)caekf_app_settings_default(&M.staged);
        }
        M.staging = 1;
        M.staged_count = 0;
        M.staged_error = 0;
        M.staged_bad = CAEKF_ACK_BAD_PARAM_NONE;
    }
    if (M.staged_count < 255u) {
        M.staged_count++;
    }
    if (exp10 > 22 || exp10 < -22 || id >= (unsigned)CAEKF_PARAM_COUNT) {
        M.cnt[CAEKF_CNT_RX_BAD_VALUE]++;
        model_stage_error(id);
        return;
    }
    M.cnt[CAEKF_CNT_RX_OK]++;
    M.cnt[CAEKF_CNT_PARAMS_RX]++;
    if (model_set(&M.staged, id, exp10 >= 0 ? (double)mant * p10[exp10] : (double)mant / p10[-exp10]) != 0) {
        model_stage_error(id);
    }
}

/* Accepts `s` into the model (the estimator is re-initialised, the step history forgotten). */
static void model_commit_accepted(const caekf_app_settings_t *s)
{
    FZ_CHECK(caekf_init(&M.est, &s->est) == CAEKF_OK, "validated settings initialise");
    M.active = *s;
    M.configured = 1;
    M.open = 0;
    M.have = 0;
    M.have_closed = 0;
    M.have_run = 0;
}

static void model_reset(const uint8_t d[8])
{
    const unsigned n_params = (unsigned)get_bits(d, 24, 8);
    const unsigned token = (unsigned)get_bits(d, 32, 8);
    const unsigned received = M.staging ? M.staged_count : 0u;
    int status;
    unsigned bad = CAEKF_ACK_BAD_PARAM_NONE;
    expect_t e;
    M.cnt[CAEKF_CNT_RX_OK]++; /* bits 16..23 are unused: whatever they hold, the frame is the same */
    if (M.staging && M.staged_error != 0) {
        status = M.staged_error;
        bad = M.staged_bad;
    } else if (n_params != received) {
        status = CAEKF_ACK_REFUSED_INCOMPLETE;
    } else if (received == 0u && !M.configured) {
        status = CAEKF_ACK_REFUSED_NO_SETTINGS;
    } else {
        const caekf_app_settings_t base = received ? M.staged : M.active;
        caekf_setting_error_t err;
        if (caekf_settings_validate(&base.est, &err) != CAEKF_OK) {
            status = CAEKF_ACK_REFUSED_SETTINGS;
            bad = err.param_id; /* BAD_PARAM names the element validation refused */
        } else {
            status = CAEKF_ACK_ACCEPTED;
            model_commit_accepted(&base);
        }
    }
    M.staging = 0; /* accepted or not, the staged values are spent */
    M.cnt[status == CAEKF_ACK_ACCEPTED ? CAEKF_CNT_CFG_ACCEPTED : CAEKF_CNT_CFG_REFUSED]++;
    memset(&e, 0, sizeof e);
    e.msg = (uint8_t)CAEKF_MSG_EST_ACK;
    e.token = (uint8_t)token;
    e.status = (int8_t)status;
    e.bad_param = (uint16_t)bad;
    e.n_rx = (uint8_t)received;
    e.state = (uint8_t)(M.configured ? CAEKF_ACK_STATE_CONFIGURED : 0u);
    expect_push(&e);
}

static void model_health(void)
{
    expect_t e;
    unsigned p;
    memset(&e, 0, sizeof e);
    e.msg = (uint8_t)CAEKF_MSG_EST_HEALTH;
    for (p = 0; p < (unsigned)CAEKF_HEALTH_PAGES; ++p) {
        e.page = (uint8_t)p;
        expect_push(&e);
    }
}

static void model_status_req(const uint8_t d[8])
{
    expect_t e;
    M.cnt[CAEKF_CNT_RX_OK]++;
    M.cnt[CAEKF_CNT_STATUS_REQUESTS]++;
    memset(&e, 0, sizeof e);
    e.msg = (uint8_t)CAEKF_MSG_EST_ACK;
    e.token = (uint8_t)get_bits(d, 16, 8);
    e.status = (int8_t)CAEKF_ACK_STATUS;
    e.bad_param = CAEKF_ACK_BAD_PARAM_NONE;
    e.n_rx = (uint8_t)(M.staging ? M.staged_count : 0u);
    e.state = (uint8_t)((M.configured ? CAEKF_ACK_STATE_CONFIGURED : 0u) | (M.staging ? CAEKF_ACK_STATE_STAGED : 0u));
    expect_push(&e);
    model_health();
}

/* One frame as the app receives it at time `now`. */
static void model_rx(const caekf_can_frame_t *f, uint32_t now)
{
    unsigned m;
    uint8_t ctr;
    for (m = 0; m < NMSG; ++m) {
        if ((uint32_t)can_id_of(m) == f->id) {
            break;
        }
    }
    if (m == NMSG || !is_bench_msg(m)) {
        M.cnt[CAEKF_CNT_RX_UNKNOWN_ID]++;
        return;
    }
    if (M.synced[m] && (uint32_t)(now - M.last_us[m]) > M.cfg.e2e_resync_us) {
        M.synced[m] = 0; /* silence: a new sender, any counter goes */
    }
    if (f->dlc != (m == (unsigned)CAEKF_MSG_BENCH_FD ? 20u : 8u)) { /* the harness's frames have <= 15 bytes */
        M.cnt[CAEKF_CNT_RX_BAD_DLC]++;
        return;
    }
    if (crc8_j1850(data_id_of(m), f->data) != f->data[0]) {
        M.cnt[CAEKF_CNT_RX_BAD_CRC]++;
        return;
    }
    M.last_us[m] = now;
    ctr = (uint8_t)(f->data[1] & 0x0Fu);
    if (M.synced[m]) {
        const uint8_t delta = (uint8_t)((ctr - M.last_ctr[m]) & 0x0Fu);
        if (delta == 0u) {
            M.cnt[CAEKF_CNT_RX_DUPLICATE]++;
            return;
        }
        M.last_ctr[m] = ctr;
        if (delta > M.cfg.e2e_max_delta) {
            M.cnt[CAEKF_CNT_RX_COUNTER_JUMP]++; /* re-synced to the new counter */
            return;
        }
        M.cnt[CAEKF_CNT_RX_LOST] += (uint32_t)(delta - 1u);
    } else {
        M.synced[m] = 1;
        M.last_ctr[m] = ctr;
    }
    switch (m) {
    case CAEKF_MSG_CTRL_PARAM: model_param(f->data); break;
    case CAEKF_MSG_CTRL_RESET: model_reset(f->data); break;
    case CAEKF_MSG_CTRL_STATUS_REQ: model_status_req(f->data); break;
    default: model_assembly(m, f->data, now); break;
    }
}

/* ---- the HAL ------------------------------------------------------------------------------------ */

static int hal_receive(void *ctx, caekf_can_frame_t *frame)
{
    FZ_CHECK(ctx == &H, "HAL context handed back");
    if (H.rx_errors_pending > 0) {
        H.rx_errors_pending--;
        M.cnt[CAEKF_CNT_RX_HAL_ERROR]++;
        return -5;
    }
    if (H.count == 0u) {
        return 0;
    }
    *frame = H.q[H.head];
    H.head = (H.head + 1u) % QLEN;
    H.count--;
    model_rx(frame, H.now);
    return 1;
}

static int hal_transmit(void *ctx, const caekf_can_frame_t *frame)
{
    FZ_CHECK(ctx == &H, "HAL context handed back");
    FZ_CHECK(H.n_tx < TXCAP, "harness: transmit log full");
    H.tx[H.n_tx++] = *frame;
    if (H.tx_fail) {
        M.cnt[CAEKF_CNT_TX_ERRORS]++;
        return -105;
    }
    M.cnt[CAEKF_CNT_TX_FRAMES]++;
    return 0;
}

static uint32_t hal_now(void *ctx)
{
    FZ_CHECK(ctx == &H, "HAL context handed back");
    return H.now;
}

static void queue_frame(const caekf_can_frame_t *f)
{
    if (H.count < QLEN) { /* a full bus queue drops: the model only sees delivered frames */
        H.q[(H.head + H.count) % QLEN] = *f;
        H.count++;
    }
}

/* ---- checks after each poll ---------------------------------------------------------------------- */

static void check_tx(void)
{
    unsigned i;
    FZ_CHECK(H.n_tx == M.n_exp, "number of frames sent");
    for (i = 0; i < H.n_tx; ++i) {
        const caekf_can_frame_t *f = &H.tx[i];
        const expect_t *e = &M.exp[i];
        const unsigned m = e->msg;
        const uint8_t ctr = (uint8_t)(f->data[1] & 0x0Fu);
        FZ_CHECK(f->id == can_id_of(m), "frame sent in the expected order");
        FZ_CHECK(f->dlc == 8u, "DLC 8");
        FZ_CHECK(crc8_j1850(data_id_of(m), f->data) == f->data[0], "CRC of a sent frame");
        FZ_CHECK(!M.tx_seen[m] || ctr == M.tx_next[m], "alive counter +1 per frame of a message");
        M.tx_seen[m] = 1;
        M.tx_next[m] = (uint8_t)((ctr + 1u) & 0x0Fu);
        if (m == CAEKF_MSG_EST_ACK) {
            FZ_CHECK(f->data[2] == e->token, "ACK token");
            FZ_CHECK((int8_t)f->data[3] == e->status, "ACK status");
            FZ_CHECK(f->data[4] == e->bad_param, "ACK bad param");
            FZ_CHECK(f->data[5] == 0u, "ACK bits 40..47 unused (zero)");
            FZ_CHECK(f->data[6] == e->n_rx, "ACK N_PARAMS_RX");
            FZ_CHECK(f->data[7] == e->state, "ACK state");
        } else if (m == CAEKF_MSG_EST_HEALTH) {
            FZ_CHECK(get_bits(f->data, 12, 4) == e->page, "HEALTH pages in order");
        } else if (m == CAEKF_MSG_EST_STEP) {
            FZ_CHECK(get_bits(f->data, 12, 16) == e->step, "EST_STEP step");
            FZ_CHECK((get_bits(f->data, 32, 16) &
                      ~(uint64_t)(CAEKF_STEP_FLAGS_SATURATED | CAEKF_STEP_FLAGS_PNORM_UNAVAILABLE)) == e->flags,
                     "EST_STEP flags");
            FZ_CHECK(f->data[6] == e->iters, "EST_STEP Newton iterations");
            FZ_CHECK((int8_t)f->data[7] == e->status, "EST_STEP status");
        } else {
            FZ_CHECK(get_bits(f->data, 12, 16) == e->step, "estimate frame step");
        }
    }
    H.n_tx = 0;
    M.n_exp = 0;
}

static void check_state(void)
{
    unsigned i;
    for (i = 0; i < (unsigned)CAEKF_CNT_COUNT; ++i) {
        uint32_t v = 0;
        if (i == (unsigned)CAEKF_CNT_TX_SATURATED) {
            continue;
        }
        FZ_CHECK(caekf_app_counter(&app, i, &v) == CAEKF_APP_OK, "counter readable");
        if (v != M.cnt[i]) {
            const char *name = "?";
            (void)caekf_proto_counter_name(i, &name);
            fprintf(stderr, "counter %s: app %lu, model %lu\n", name, (unsigned long)v, (unsigned long)M.cnt[i]);
        }
        FZ_CHECK(v == M.cnt[i], "counter as the protocol says");
    }
    FZ_CHECK(!!app.configured == !!M.configured, "configured");
    FZ_CHECK(!!app.staging == !!M.staging, "staging");
    if (M.staging) {
        FZ_CHECK(app.staged_count == M.staged_count, "staged count");
        FZ_CHECK(app.staged_error == M.staged_error, "staged error");
        FZ_CHECK(app_settings_equal(&app.staged, &M.staged), "staged settings");
    }
    if (M.configured) {
        FZ_CHECK(app_settings_equal(&app.active, &M.active), "running settings unchanged unless accepted");
        FZ_CHECK(settings_equal(&app.est.cfg, &M.est.cfg), "estimator settings");
        FZ_CHECK(memcmp(app.est.z, M.est.z, sizeof app.est.z) == 0, "estimator state == shadow");
        FZ_CHECK(memcmp(app.est.P, M.est.P, sizeof app.est.P) == 0, "estimator covariance == shadow");
        FZ_CHECK(app.est.step_count == M.est.step_count, "estimator step count == shadow");
    }
}

static void poll_once(void)
{
    model_timeout(H.now);
    FZ_CHECK(caekf_app_poll(&app) == CAEKF_APP_OK, "poll");
    model_timeout(H.now);
    if (M.cfg.status_period_us != 0u && (uint32_t)(H.now - M.last_status_us) >= M.cfg.status_period_us) {
        M.last_status_us = H.now;
        model_health();
    }
    check_tx();
    check_state();
}

static int burst; /* frames queue up without polling while set */

static unsigned frames_sent;

static void send_frame(const caekf_can_frame_t *f)
{
    frames_sent++;
    queue_frame(f);
    if (!burst) {
        poll_once();
    }
}

static void drain(void)
{
    unsigned guard = 0;
    do {
        poll_once();
    } while (H.count > 0u && ++guard < 2u * QLEN + 16u);
}

/* Seals with the bench's next alive counter (or a given one) and sends. */
static void send_sealed(unsigned msg, uint8_t data[8], int counter)
{
    caekf_can_frame_t f;
    f.id = can_id_of(msg);
    f.dlc = 8;
    if (counter < 0) {
        counter = H.bench_ctr[msg];
        H.bench_ctr[msg] = (uint8_t)((H.bench_ctr[msg] + 1u) & 0x0Fu);
    }
    data[1] = (uint8_t)((data[1] & 0xF0u) | ((unsigned)counter & 0x0Fu));
    data[0] = crc8_j1850(data_id_of(msg), data);
    memcpy(f.data, data, 8);
    send_frame(&f);
}

static void send_param(unsigned id, int exp10, int64_t mantissa)
{
    uint8_t d[8] = {0};
    put_bits(d, 12, 8, id);
    put_bits(d, 20, 6, (uint64_t)(int64_t)exp10);
    put_bits(d, 26, 38, (uint64_t)mantissa);
    send_sealed(CAEKF_MSG_CTRL_PARAM, d, -1);
}

static void send_reset(unsigned unused, unsigned n, unsigned token)
{
    uint8_t d[8] = {0};
    put_bits(d, 16, 8, unused); /* unused bits: the app must ignore them */
    put_bits(d, 24, 8, n);
    put_bits(d, 32, 8, token);
    send_sealed(CAEKF_MSG_CTRL_RESET, d, -1);
}

/* ---- operations --------------------------------------------------------------------------------- */

static uint16_t bench_step;
static uint32_t last_u_bits;
static int64_t last_y1, last_y4;

static void send_step_frames(uint16_t step, uint32_t ubits, int64_t y1, int64_t y4, unsigned order, int omit,
                             int dup_first)
{
    static const uint8_t perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    unsigned k;
    for (k = 0; k < 3u; ++k) {
        const unsigned which = perms[order % 6u][k];
        uint8_t d[8] = {0};
        unsigned msg;
        if (omit && k == 2u) {
            break;
        }
        put_bits(d, 12, 16, step);
        if (which == 0u) {
            msg = CAEKF_MSG_BENCH_U;
            put_bits(d, 32, 32, ubits);
        } else {
            msg = (which == 1u) ? CAEKF_MSG_BENCH_Y1 : CAEKF_MSG_BENCH_Y4;
            put_bits(d, 28, 36, (uint64_t)((which == 1u) ? y1 : y4));
        }
        send_sealed(msg, d, -1);
        if (dup_first && k == 0u) {
            send_sealed(msg, d, -1);
        }
    }
}

static int64_t sign_extend36(uint64_t v)
{
    v &= mask_of(36);
    return (v >> 35) ? -(int64_t)((~v) & mask_of(36)) - 1 : (int64_t)v;
}

static void op_step(fz_reader_t *r)
{
    const uint8_t fl = fz_u8(r);
    const uint16_t sv = fz_u16(r);
    const uint32_t uraw = fz_u32(r);
    const uint64_t y1raw = (uint64_t)fz_u32(r) | ((uint64_t)fz_u8(r) << 32);
    const uint64_t y4raw = (uint64_t)fz_u32(r) | ((uint64_t)fz_u8(r) << 32);
    switch (fl & 3u) {
    case 0: bench_step = (uint16_t)(bench_step + 1u); break;
    case 1: break;
    case 2: bench_step = (uint16_t)(bench_step + (uint16_t)(int16_t)(int8_t)(sv & 0xFFu)); break;
    default: bench_step = sv; break;
    }
    if (fl & 0x40u) {
        last_u_bits = uraw; /* any float32, NaN and infinities included */
    } else {
        const float u = (float)((double)(int32_t)uraw * 1e-9); /* +-2.1 N */
        memcpy(&last_u_bits, &u, sizeof u);
    }
    if (fl & 0x08u) { /* full 36-bit range: +-34 mm */
        last_y1 = sign_extend36(y1raw);
        last_y4 = sign_extend36(y4raw);
    } else { /* +-2.1 mm in pm */
        last_y1 = (int64_t)(int32_t)(uint32_t)y1raw;
        last_y4 = (int64_t)(int32_t)(uint32_t)y4raw;
    }
    send_step_frames(bench_step, last_u_bits, last_y1, last_y4, (unsigned)(fl >> 2) & 7u, (fl & 0x20u) != 0u,
                     (fl & 0x80u) != 0u);
    H.now += 1000u; /* 1 kHz bench */
}

static void op_local_config(fz_reader_t *r)
{
    const unsigned preset = fz_u8(r) % 6u; /* 4 and 5: no preset, the recommended defaults */
    unsigned n = fz_u8(r) % 8u;
    caekf_app_settings_t s;
    caekf_setting_error_t err;
    uint8_t bad = 0;
    caekf_app_status_t st, want;
    (void)caekf_app_settings_default(&s);
    fz_paper_settings(&s.est, preset < CAEKF_N_FIXTURE_PRESETS ? (int)preset : PRESET_NONE);
    while (n-- > 0u) {
        const unsigned id = fz_u8(r) % ((unsigned)CAEKF_PARAM_COUNT);
        caekf_scalar_t *f = model_real_field(&s.est, id);
        const double typical = (f != NULL && *f != (caekf_scalar_t)0) ? (double)*f : 1.0;
        (void)model_set(&s, id, fz_scalar(r, typical));
    }
    st = caekf_app_configure(&app, &s, &bad);
    if (caekf_settings_validate(&s.est, &err) != CAEKF_OK) {
        want = CAEKF_APP_ERR_SETTINGS;
        FZ_CHECK(bad == err.param_id, "configure: names the element validation refused");
    } else {
        want = CAEKF_APP_OK;
        FZ_CHECK(bad == CAEKF_ACK_BAD_PARAM_NONE, "configure: no bad param when accepted");
        model_commit_accepted(&s);
    }
    FZ_CHECK(st == want, "caekf_app_configure status");
    check_state();
}

/* The paper's settings and then a preset's (what the bench does to select one of the paper's
 * experiments) as CTRL_PARAM frames, and CTRL_RESET with their number. */
static void op_paper_config(fz_reader_t *r)
{
    const caekf_fixture_param_t *const p = caekf_paper_params;
    const unsigned preset = fz_u8(r) % (CAEKF_N_FIXTURE_PRESETS + 1u); /* the last: none */
    const unsigned token = fz_u8(r);
    unsigned i, n = CAEKF_N_PAPER_PARAMS;
    for (i = 0; i < n; ++i) {
        send_param(p[i].id, p[i].exp10, p[i].mantissa);
    }
    if (preset < CAEKF_N_FIXTURE_PRESETS) {
        const caekf_fixture_preset_t *pr = &caekf_fixture_presets[preset];
        for (i = 0; i < pr->n; ++i) {
            int exp10;
            int64_t mant;
            wire_decimal(pr->value[i], &exp10, &mant);
            send_param(pr->id[i], exp10, mant);
        }
        n += pr->n;
    }
    send_reset(0, n, token);
}

static void run_ops(fz_reader_t *r)
{
    unsigned ops = 0;
    while (fz_more(r) && ops++ < MAX_OPS && frames_sent < MAX_FRAMES) {
        const unsigned op = fz_u8(r) % (unsigned)OP_COUNT;
        switch (op) {
        case OP_RAW: {
            caekf_can_frame_t f;
            const uint8_t sel = fz_u8(r);
            uint8_t dl;
            if (sel < 200u) {
                // clang-format off
                static const uint32_t extra[] = {0x000, 0x7FF, 0x0C3, 0x104, 0x0BF, 0x1C0,
                                                 0x0C0u | CAEKF_CAN_ID_EXT_FLAG, 0x100u | CAEKF_CAN_ID_EXT_FLAG};
                // clang-format on
                const unsigned k = sel % (NMSG + (unsigned)(sizeof extra / sizeof extra[0]));
                f.id = (k < NMSG) ? can_id_of(k) : extra[k - NMSG];
            } else {
                f.id = fz_u32(r);
            }
            dl = fz_u8(r);
            f.dlc = (dl < 0xE0u) ? 8u : (uint8_t)(dl & 0x0Fu);
            for (dl = 0; dl < 8u; ++dl) {
                f.data[dl] = fz_u8(r);
            }
            send_frame(&f);
            break;
        }
        case OP_SEALED: {
            const unsigned msg = fz_u8(r) % NMSG;
            const uint8_t mode = fz_u8(r);
            uint8_t d[8];
            unsigned k;
            d[0] = 0;
            for (k = 1; k < 8u; ++k) {
                d[k] = fz_u8(r);
            }
            send_sealed(msg, d, (mode < 0xC0u) ? -1 : (int)(mode & 0x0Fu));
            break;
        }
        case OP_STEP: op_step(r); break;
        case OP_PARAM: {
            const unsigned id = fz_u8(r);
            const int exp10 = (int)(int8_t)fz_u8(r);
            const uint64_t mant = (uint64_t)fz_u32(r) | ((uint64_t)fz_u8(r) << 32);
            send_param(id, exp10, (int64_t)mant);
            break;
        }
        case OP_RESET: {
            const unsigned unused = fz_u8(r);
            const uint8_t nmode = fz_u8(r);
            const unsigned token = fz_u8(r);
            send_reset(unused, (nmode < 0xC0u) ? (M.staging ? M.staged_count : 0u) : nmode, token);
            break;
        }
        case OP_STATUS_REQ: {
            uint8_t d[8] = {0};
            d[2] = fz_u8(r);
            send_sealed(CAEKF_MSG_CTRL_STATUS_REQ, d, -1);
            break;
        }
        case OP_TIME: {
            const uint16_t v = fz_u16(r);
            H.now += (v & 0x8000u) ? ((uint32_t)(v & 0x7FFFu) << 12) : (uint32_t)v;
            poll_once();
            break;
        }
        case OP_HAL_FAULT: {
            const uint8_t b = fz_u8(r);
            H.rx_errors_pending = (int)(b & 7u);
            if (b & 8u) {
                H.tx_fail = !H.tx_fail;
            }
            poll_once();
            break;
        }
        case OP_LOCAL_CONFIG: op_local_config(r); break;
        case OP_BURST:
            burst = !burst;
            if (!burst) {
                drain();
            }
            break;
        case OP_PAPER_CONFIG: op_paper_config(r); break;
        default: { /* OP_REPEAT_STEPS */
            unsigned n = 1u + fz_u8(r) % 64u;
            while (n-- > 0u && frames_sent < MAX_FRAMES) {
                bench_step = (uint16_t)(bench_step + 1u);
                send_step_frames(bench_step, last_u_bits, last_y1, last_y4, 0, 0, 0);
                H.now += 1000u;
            }
            break;
        }
        }
    }
    burst = 0;
    drain();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const uint8_t deltas[4] = {1, 2, 3, 15};
    static const uint32_t timeouts[4] = {20000u, 1000u, 100000u, 1u};
    static const uint8_t per_poll[4] = {64, 1, 2, 5};
    static const uint32_t resyncs[4] = {500000u, 10000u, 0u, 0xFFFFFFFFu};
    caekf_app_hal_t hal;
    fz_reader_t r;
    uint8_t c, init;
    unsigned i;
    r.p = data;
    r.n = size;

    for (i = 0; i < NMSG; ++i) {
        const caekf_msg_info_t *info;
        FZ_CHECK(caekf_proto_msg_info((caekf_msg_t)i, &info) == CAEKF_PROTO_OK && info->can_id == can_id_of(i) &&
                     info->data_id == data_id_of(i) && (info->dir == CAEKF_DIR_TO_ESTIMATOR) == is_bench_msg(i),
                 "message table as in caekf.dbc");
    }
    memset(&M, 0, sizeof M);
    memset(&H, 0, sizeof H);
    memset(&app, 0, sizeof app);
    burst = 0;
    frames_sent = 0;
    bench_step = 0;
    last_u_bits = 0;
    last_y1 = 0;
    last_y4 = 0;

    c = fz_u8(&r);
    (void)caekf_app_config_default(&M.cfg);
    M.cfg.e2e_max_delta = deltas[c & 3u];
    M.cfg.status_period_us = (c & 4u) ? ((c & 8u) ? 50000u : 1000000u) : 0u;
    M.cfg.step_timeout_us = timeouts[(c >> 4) & 3u];
    M.cfg.max_frames_per_poll = per_poll[(c >> 6) & 3u];
    M.cfg.e2e_resync_us = resyncs[fz_u8(&r) & 3u];
    init = fz_u8(&r);
    H.now = (fz_u8(&r) & 1u) ? 0xFFFF0000u : 0x1000u; /* near the 32-bit wrap, or not */

    hal.ctx = &H;
    hal.receive = hal_receive;
    hal.transmit = hal_transmit;
    hal.now_us = hal_now;
    FZ_CHECK(caekf_app_init(&app, &hal, &M.cfg) == CAEKF_APP_OK, "app init");
    M.last_status_us = H.now;
    (void)caekf_app_settings_default(&M.active);
    check_state();
    if (init & 0x80u) { /* configured locally from the start: the paper's settings and preset init & 3 */
        caekf_app_settings_t s;
        (void)caekf_app_settings_default(&s);
        fz_paper_settings(&s.est, (int)(init & 3u));
        FZ_CHECK(caekf_settings_validate(&s.est, NULL) == CAEKF_OK, "paper settings with a preset are valid");
        FZ_CHECK(caekf_app_configure(&app, &s, NULL) == CAEKF_APP_OK, "paper settings configure");
        model_commit_accepted(&s);
        if (init & 0x40u) { /* and the estimator (app and shadow) moved to a snapshot state: short inputs reach
                             * contact (fz_snapshot, bits 2-3 pick it) */
            app.est = *fz_snapshot(init & 3u, (init >> 2) & 3u);
            M.est = app.est;
        }
        check_state();
    }
    run_ops(&r);
    if (getenv("CAEKF_FUZZ_TRACE") != NULL) { /* what an input reached, for writing seeds */
        for (i = 0; i < (unsigned)CAEKF_CNT_COUNT; ++i) {
            const char *name = "?";
            (void)caekf_proto_counter_name(i, &name);
            if (M.cnt[i] != 0u) {
                fprintf(stderr, "%s=%lu ", name, (unsigned long)M.cnt[i]);
            }
        }
        fprintf(stderr, "| configured=%d mode=%d q_gamma_scale=%g constraint=%d\n", M.configured,
                (int)M.active.est.mode, (double)M.active.est.q_gamma_scale, M.active.est.constraint_enabled);
    }
    return 0;
}
