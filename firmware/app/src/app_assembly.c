/* Step assembly: collects BENCH_U, BENCH_Y1, BENCH_Y4 (or BENCH_U, BENCH_YP; or BENCH_FD alone) of one STEP, then runs the
 * estimator once.
 * One slot is enough: the bench sends a step's frames together, so a frame of a newer step means the
 * open step will never complete. STEP is 16 bits on the wire (8 in BENCH_YP, unwrapped), compared modulo
 * 2^16. */
#include <stddef.h>

#include "app_internal.h"

#define HAVE_U 1u
#define HAVE_Y1 2u
#define HAVE_Y4 4u
#define HAVE_ALL (HAVE_U | HAVE_Y1 | HAVE_Y4)

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
    caekf_scalar_t y[2], u;     /* the frames carry one input and two sensors (the paper's chain) */
    caekf_report_t report;
    caekf_status_t st;
    uint16_t app_flags = 0;
    const uint16_t step = app->slot.step;

    if (app->have_run && step != (uint16_t)(app->last_run_step + 1u)) {
        /* The estimator advances one dt per call: bridge the missing steps with prediction-only steps
         * (input held), or the time shift against the truth would be blamed on gamma in contact. */
        uint16_t missing = (uint16_t)(step - app->last_run_step - 1u);
        uint16_t k;
        app_flags |= (uint16_t)CAEKF_STEP_FLAG_STEP_GAP;
        caekf_app_count(app, CAEKF_CNT_STEPS_SKIPPED, missing);
        u = (caekf_scalar_t)app->last_u;
        for (k = 0; k < missing && k < (uint16_t)CAEKF_APP_MAX_GAP_PREDICT; ++k) {
            (void)caekf_predict(&app->est, &u, NULL);
        }
    }
    y[0] = (caekf_scalar_t)app->slot.y1;
    y[1] = (caekf_scalar_t)app->slot.y4;
    u = (caekf_scalar_t)app->slot.u;
    st = caekf_step(&app->est, &u, y, &report);
    caekf_app_count(app, CAEKF_CNT_STEPS_DONE, 1u);
    if (st != CAEKF_OK) {
        caekf_app_count(app, CAEKF_CNT_STEPS_FAILED, 1u);
    }
    close_slot(app);
    app->last_run_step = step;
    app->last_u = app->slot.u;
    app->have_run = 1;
    caekf_app_send_estimate(app, step, st, &report, app_flags);
}

/* BENCH_YP carries STEP modulo 2^8: the 16-bit step nearest to the step being assembled (or the one after
 * the last closed step) with those low 8 bits. The bench keeps fewer than 128 steps in flight. */
static uint16_t unwrap_step8(const caekf_app_t *app, uint8_t step8)
{
    uint16_t ref;
    uint8_t d;
    if (app->slot.open) {
        ref = app->slot.step;
    } else if (app->have_closed) {
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
    if (app->slot.open) {
        caekf_app_count(app, CAEKF_CNT_STEPS_SUPERSEDED, 1u);
        close_slot(app);
    } else if (app->have_closed && !step_after(step, app->last_closed_step)) {
        caekf_app_count(app, CAEKF_CNT_RX_LATE, 1u);
        return 0;
    }
    app->slot.open = 1;
    app->slot.have = 0;
    app->slot.step = step;
    app->slot.opened_us = now_us;
    return 1;
}

void caekf_app_assembly_input(caekf_app_t *app, caekf_msg_t msg, const uint8_t data[CAEKF_CAN_FD_MAX_LEN], uint32_t now_us)
{
    uint16_t step = 0u;
    double value = 0.0;
    caekf_msg_yp_t yp;
    caekf_msg_fd_in_t fd;
    uint8_t bits;
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
    bits = (msg == CAEKF_MSG_BENCH_U)    ? HAVE_U
           : (msg == CAEKF_MSG_BENCH_Y1) ? HAVE_Y1
           : (msg == CAEKF_MSG_BENCH_Y4) ? HAVE_Y4
           : (msg == CAEKF_MSG_BENCH_FD) ? HAVE_ALL
                                         : (uint8_t)(HAVE_Y1 | HAVE_Y4);
    if (!route(app, step, now_us)) {
        return;
    }
    if (app->slot.have & bits) {
        caekf_app_count(app, CAEKF_CNT_RX_REPEATED, 1u); /* keep the first value */
        return;
    }
    app->slot.have = (uint8_t)(app->slot.have | bits);
    if (bits == HAVE_ALL) {
        app->slot.u = fd.u;
        app->slot.y1 = fd.y1;
        app->slot.y4 = fd.y4;
    } else if (bits == HAVE_U) {
        app->slot.u = value;
    } else if (bits == HAVE_Y1) {
        app->slot.y1 = value;
    } else if (bits == HAVE_Y4) {
        app->slot.y4 = value;
    } else {
        app->slot.y1 = yp.y1;
        app->slot.y4 = yp.y4;
    }
    if (app->slot.have == HAVE_ALL) {
        run_step(app);
    }
}
