/* Step assembly: collects the input frames of one STEP, then runs the estimator once. A step needs every
 * input and sensor of the configured mechanism (caekf_model_params_t inputs, sensors, sensor_kind):
 * input 1 BENCH_U, input 2 BENCH_U2; sensor s by its kind, position BENCH_Y1 (s = 1), BENCH_Y4 (s = 2),
 * BENCH_S3_POS, BENCH_S4_POS, velocity BENCH_S1_VEL..BENCH_S4_VEL (the paper: BENCH_U, BENCH_Y1, BENCH_Y4).
 * BENCH_YP carries sensors 1 and 2 as positions, BENCH_FD input 1 and sensors 1 and 2 as positions: they
 * complete the paper's step alone, and a larger mechanism's with the diagnostics frames of the rest. A frame
 * for a value the mechanism does not have (another kind, a sensor or input it lacks) is counted RX_OK and
 * ignored.
 * One slot is enough: the bench sends a step's frames together, so a frame of a newer step means the
 * open step will never complete. STEP is 16 bits on the wire (8 in BENCH_YP, unwrapped), compared modulo
 * 2^16. */
#include <stddef.h>

#include "app_internal.h"

#define HAVE_INPUT(i) (1u << (unsigned)(i))
#define HAVE_SENSOR(s) (1u << ((unsigned)CAEKF_MAX_INPUTS + (unsigned)(s)))
#define NO_SENSOR (-1)

CAEKF_STATIC_ASSERT(CAEKF_MAX_INPUTS + CAEKF_MAX_SENSORS <= 8, slot_bits_fit_in_have);

/* Every value the configured mechanism needs for a step. */
static unsigned need_mask(const caekf_app_t *app)
{
    const caekf_model_params_t *mp = &app->est.cfg.model;
    unsigned m = 0u;
    int i;
    for (i = 0; i < mp->inputs && i < CAEKF_MAX_INPUTS; i++) {
        m |= HAVE_INPUT(i);
    }
    for (i = 0; i < mp->sensors && i < CAEKF_MAX_SENSORS; i++) {
        m |= HAVE_SENSOR(i);
    }
    return m;
}

/* The slot bit of sensor s (0-based) carried as kind, 0 when the mechanism has no such sensor. */
static unsigned sensor_bit(const caekf_app_t *app, int s, int kind)
{
    const caekf_model_params_t *mp = &app->est.cfg.model;
    if (s < 0 || s >= mp->sensors || s >= CAEKF_MAX_SENSORS || mp->sensor_kind[s] != kind) {
        return 0u;
    }
    return HAVE_SENSOR(s);
}

/* The slot bit of input i (0-based), 0 when the mechanism has no such input. */
static unsigned input_bit(const caekf_app_t *app, int i)
{
    return (i < app->est.cfg.model.inputs && i < CAEKF_MAX_INPUTS) ? HAVE_INPUT(i) : 0u;
}

/* Which input (*input, or -1) or sensor (*sensor and *kind, or NO_SENSOR) a diagnostics value frame
 * carries. */
static void value_target(caekf_msg_t msg, int *input, int *sensor, int *kind)
{
    *input = -1;
    *sensor = NO_SENSOR;
    *kind = CAEKF_SENSOR_POSITION;
    switch (msg) {
    case CAEKF_MSG_BENCH_U: *input = 0; break;
    case CAEKF_MSG_BENCH_U2: *input = 1; break;
    case CAEKF_MSG_BENCH_Y1: *sensor = 0; break;
    case CAEKF_MSG_BENCH_Y4: *sensor = 1; break;
    case CAEKF_MSG_BENCH_S3_POS: *sensor = 2; break;
    case CAEKF_MSG_BENCH_S4_POS: *sensor = 3; break;
    case CAEKF_MSG_BENCH_S1_VEL:
        *sensor = 0;
        *kind = CAEKF_SENSOR_VELOCITY;
        break;
    case CAEKF_MSG_BENCH_S2_VEL:
        *sensor = 1;
        *kind = CAEKF_SENSOR_VELOCITY;
        break;
    case CAEKF_MSG_BENCH_S3_VEL:
        *sensor = 2;
        *kind = CAEKF_SENSOR_VELOCITY;
        break;
    case CAEKF_MSG_BENCH_S4_VEL:
        *sensor = 3;
        *kind = CAEKF_SENSOR_VELOCITY;
        break;
    default: break;
    }
}

/* a is after b in modulo-2^16 order (within half the circle). */
static int step_after(uint16_t a, uint16_t b)
{
    uint16_t d = (uint16_t)(a - b);
    return d != 0u && d < 0x8000u;
}

static void close_slot(caekf_app_t *app)
{
    app->slot.open = 0;
    app->slot.have = 0;
    app->last_closed_step = app->slot.step;
    app->have_closed = 1;
}

void caekf_app_assembly_reset(caekf_app_t *app)
{
    app->slot.open = 0;
    app->slot.have = 0;
    app->have_closed = 0;
    app->have_run = 0;
    app->page_phase = (app->cfg.page_period_steps == 0u) ? (uint16_t)CAEKF_PAGE_COUNT : 0u;
}

void caekf_app_assembly_timeout(caekf_app_t *app, uint32_t now_us)
{
    if (app->slot.open && (uint32_t)(now_us - app->slot.opened_us) > app->cfg.step_timeout_us) {
        caekf_app_count(app, CAEKF_CNT_STEPS_TIMED_OUT, 1u);
        close_slot(app);
    }
}

static void run_step(caekf_app_t *app)
{
    caekf_scalar_t y[CAEKF_MAX_SENSORS], u[CAEKF_MAX_INPUTS];
    caekf_report_t report;
    caekf_status_t st;
    uint16_t app_flags = 0;
    const uint16_t step = app->slot.step;
    unsigned i;

    if (app->have_run && step != (uint16_t)(app->last_run_step + 1u)) {
        /* The estimator advances one dt per call: bridge the missing steps with prediction-only steps
         * (input held), or the time shift against the truth would be blamed on gamma in contact. */
        uint16_t missing = (uint16_t)(step - app->last_run_step - 1u);
        uint16_t k;
        app_flags |= (uint16_t)CAEKF_STEP_FLAGS_STEP_GAP;
        caekf_app_count(app, CAEKF_CNT_STEPS_SKIPPED, missing);
        for (i = 0; i < (unsigned)CAEKF_MAX_INPUTS; i++) {
            u[i] = (caekf_scalar_t)app->last_u[i];
        }
        for (k = 0; k < missing && k < (uint16_t)CAEKF_APP_MAX_GAP_PREDICT; ++k) {
            (void)caekf_predict(&app->est, u, NULL);
        }
    }
    for (i = 0; i < (unsigned)CAEKF_MAX_SENSORS; i++) {
        y[i] = (caekf_scalar_t)app->slot.y[i];
    }
    for (i = 0; i < (unsigned)CAEKF_MAX_INPUTS; i++) {
        u[i] = (caekf_scalar_t)app->slot.u[i];
    }
    st = caekf_step(&app->est, u, y, &report);
    caekf_app_count(app, CAEKF_CNT_STEPS_DONE, 1u);
    if (st != CAEKF_OK) {
        caekf_app_count(app, CAEKF_CNT_STEPS_FAILED, 1u);
    }
    close_slot(app);
    app->last_run_step = step;
    for (i = 0; i < (unsigned)CAEKF_MAX_INPUTS; i++) {
        app->last_u[i] = app->slot.u[i];
    }
    app->have_run = 1;
    caekf_app_send_estimate(app, step, st, &report, app_flags);
}

/* BENCH_YP carries STEP modulo 2^8: the 16-bit step nearest to the step being assembled (or the one after
 * the last closed step) with those low 8 bits. The bench keeps fewer than 128 steps in flight. */
static uint16_t unwrap_step8(const caekf_app_t *app, uint8_t step8)
{
    uint16_t ref;
    uint8_t d;
    if (app->slot.open != 0u) {
        ref = app->slot.step;
    } else if (app->have_closed != 0u) {
        ref = (uint16_t)(app->last_closed_step + 1u);
    } else {
        return step8;
    }
    d = (uint8_t)(step8 - (uint8_t)ref); /* forward distance modulo 2^8; >= 128 means behind */
    return (d < 128u) ? (uint16_t)(ref + d) : (uint16_t)(ref + d - 256u);
}

/* Decides where a frame of `step` goes; returns 1 if it belongs to the (possibly new) open slot. */
static int route(caekf_app_t *app, uint16_t step, uint32_t now_us)
{
    if (app->slot.open && step == app->slot.step) {
        return 1;
    }
    if (app->slot.open && !step_after(step, app->slot.step)) {
        caekf_app_count(app, CAEKF_CNT_RX_LATE, 1u);
        return 0;
    }
    if (app->slot.open != 0u) {
        caekf_app_count(app, CAEKF_CNT_STEPS_SUPERSEDED, 1u);
        close_slot(app);
    } else if (app->have_closed != 0u && !step_after(step, app->last_closed_step)) {
        caekf_app_count(app, CAEKF_CNT_RX_LATE, 1u);
        return 0;
    } else {
        /* no slot open and the step is new: it opens one below */
    }
    app->slot.open = 1;
    app->slot.have = 0;
    app->slot.step = step;
    app->slot.opened_us = now_us;
    return 1;
}

/* Puts value into slot bit `bit` (one input or sensor). */
static void put(caekf_app_t *app, unsigned bit, double value)
{
    unsigned i;
    app->slot.have = (uint8_t)(app->slot.have | bit);
    for (i = 0; i < (unsigned)CAEKF_MAX_INPUTS; i++) {
        if (bit == HAVE_INPUT(i)) {
            app->slot.u[i] = value;
        }
    }
    for (i = 0; i < (unsigned)CAEKF_MAX_SENSORS; i++) {
        if (bit == HAVE_SENSOR(i)) {
            app->slot.y[i] = value;
        }
    }
}

void caekf_app_assembly_input(caekf_app_t *app, caekf_msg_t msg, const uint8_t data[CAEKF_CAN_FD_MAX_LEN],
                              uint32_t now_us)
{
    uint16_t step = 0u;
    double value = 0.0;
    caekf_msg_yp_t yp;
    caekf_msg_fd_in_t fd;
    unsigned bits[3]; /* slot bits of the frame's values, 0 for a value the mechanism does not have */
    double vals[3];
    unsigned all = 0u;
    unsigned j;
    int input, sensor, kind;
    caekf_proto_status_t st;
    yp.y1 = 0.0;
    yp.y4 = 0.0;
    fd.u = 0.0;
    fd.y1 = 0.0;
    fd.y4 = 0.0;
    if (msg == CAEKF_MSG_BENCH_YP) {
        st = caekf_proto_decode_yp(data, &yp);
        step = unwrap_step8(app, yp.step);
    } else if (msg == CAEKF_MSG_BENCH_FD) {
        st = caekf_proto_decode_fd_in(data, &fd);
        step = fd.step;
    } else {
        st = caekf_proto_decode_value(msg, data, &step, &value);
    }
    if (st != CAEKF_PROTO_OK) {
        caekf_app_count(app, CAEKF_CNT_RX_BAD_VALUE, 1u); /* NaN/inf never reaches the estimator */
        return;
    }
    caekf_app_count(app, CAEKF_CNT_RX_OK, 1u);
    if (!app->configured) {
        caekf_app_count(app, CAEKF_CNT_RX_UNCONFIGURED, 1u);
        return;
    }
    bits[0] = bits[1] = bits[2] = 0u;
    vals[0] = vals[1] = vals[2] = 0.0;
    if (msg == CAEKF_MSG_BENCH_YP) {
        bits[0] = sensor_bit(app, 0, CAEKF_SENSOR_POSITION);
        bits[1] = sensor_bit(app, 1, CAEKF_SENSOR_POSITION);
        vals[0] = yp.y1;
        vals[1] = yp.y4;
    } else if (msg == CAEKF_MSG_BENCH_FD) {
        bits[0] = input_bit(app, 0);
        bits[1] = sensor_bit(app, 0, CAEKF_SENSOR_POSITION);
        bits[2] = sensor_bit(app, 1, CAEKF_SENSOR_POSITION);
        vals[0] = fd.u;
        vals[1] = fd.y1;
        vals[2] = fd.y4;
    } else {
        value_target(msg, &input, &sensor, &kind);
        bits[0] = (input >= 0) ? input_bit(app, input) : sensor_bit(app, sensor, kind);
        vals[0] = value;
    }
    all = bits[0] | bits[1] | bits[2];
    if (all == 0u) {
        return; /* nothing this mechanism measures: ignored */
    }
    if (!route(app, step, now_us)) {
        return;
    }
    if ((app->slot.have & all) != 0u) {
        caekf_app_count(app, CAEKF_CNT_RX_REPEATED, 1u); /* keep the first values */
        return;
    }
    for (j = 0; j < 3u; j++) {
        if (bits[j] != 0u) {
            put(app, bits[j], vals[j]);
        }
    }
    if ((app->slot.have & need_mask(app)) == need_mask(app)) {
        run_step(app);
    }
}
