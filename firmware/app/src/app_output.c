/* The estimate frames of one step, by profile. DIAGNOSTICS: EST_GAMMA, EST_Q and EST_V of every body of the
 * mechanism (up to 8), EST_P_NORM, EST_P_GG, EST_GAMMA2 and EST_P_GG2 (two contacts), EST_STEP last (it tells
 * the bench the step is complete); the paper's mechanism: 12 frames. PRODUCTION: EST_PROD (closes the step),
 * then at most one EST_PAGE. FD: EST_FD. PRODUCTION and FD carry bodies 1..4 and contact 1 only (the paper's
 * chain; values a smaller mechanism lacks are NaN): a mechanism's other bodies and its contact 2 are sent in
 * the diagnostics profile only. */
#include <math.h>
#include <stddef.h>

#include "app_internal.h"

/* The estimator's flags (the schema's) share EST_STEP.FLAGS with the app's named bits (the DBC's) above them,
 * and EST_PROD.FLAGS carries every one of the estimator's but MODEL_MISMATCH, a condition over hundreds of
 * steps that EST_PAGE's page 10 carries (EST_PROD keeps its 8-bit step). */
CAEKF_STATIC_ASSERT((CAEKF_STEP_FLAGS_NAMED & CAEKF_FLAG_MASK) == 0u, core_flags_fit_below_app_flags);
CAEKF_STATIC_ASSERT((CAEKF_FLAG_MASK & ~CAEKF_PROD_FLAGS_MASK & ~(uint32_t)CAEKF_FLAG_MODEL_MISMATCH) == 0u,
                    production_carries_every_per_step_core_flag);

static void send_value(caekf_app_t *app, caekf_msg_t msg, uint16_t step, double value, uint16_t *app_flags)
{
    caekf_can_frame_t f;
    if (caekf_proto_encode_value(msg, step, value, f.data) == CAEKF_PROTO_SATURATED) {
        *app_flags |= (uint16_t)CAEKF_STEP_FLAGS_SATURATED;
        caekf_app_count(app, CAEKF_CNT_TX_SATURATED, 1u);
    }
    caekf_app_send(app, msg, &f);
}

/* The production and FD frames carry bodies 1..4 and contact 1 (the paper's chain); a larger mechanism's
 * other bodies and contact 2 are not sent there (the diagnostics profile sends them). */
#define WIRE_BODIES 4u
#define DIAG_BODIES 8u

/* State index of wire value k: q1..q4 (k < 4), v1..v4, gamma (k = 8), for a mechanism of nq bodies;
 * -1 when it has no such state. */
static int wire_state(const caekf_app_t *app, unsigned k)
{
    const unsigned nq = (unsigned)app->est.model.nq;
    if (k < WIRE_BODIES) {
        return k < nq ? (int)k : -1;
    }
    if (k < 2u * WIRE_BODIES) {
        return k - WIRE_BODIES < nq ? (int)(nq + k - WIRE_BODIES) : -1;
    }
    return app->est.model.nc > 0 ? (int)(2u * nq) : -1;
}

static double wire_value(const caekf_app_t *app, const caekf_scalar_t *x, unsigned k)
{
    const int i = wire_state(app, k);
    return i >= 0 ? (double)x[i] : (double)NAN;
}

static double wire_p_gg(const caekf_app_t *app)
{
    const int g = wire_state(app, 2u * WIRE_BODIES);
    return g >= 0 ? (double)app->cov_scratch[g][g] : (double)NAN;
}

static uint8_t clamp_iters(int it) { return (uint8_t)((it < 0) ? 0 : (it > 255) ? 255 : it); }

/* What a step did, as EST_STEP, production page 10 and EST_FD carry it. */
static caekf_msg_step_t step_info(uint16_t step, caekf_status_t status, const caekf_report_t *report,
                                  uint16_t app_flags)
{
    caekf_msg_step_t s;
    s.step = step;
    s.flags = (uint16_t)((report->flags & CAEKF_FLAG_MASK) | app_flags);
    s.newton_iters = clamp_iters(report->newton_iters);
    s.step_status = (int8_t)status;
    return s;
}

static void send_production(caekf_app_t *app, uint16_t step, caekf_status_t status, const caekf_report_t *report,
                            uint16_t app_flags)
{
    caekf_scalar_t x[CAEKF_N];
    caekf_scalar_t p_norm;
    caekf_msg_prod_t pm;
    caekf_msg_page_t pg;
    caekf_can_frame_t f;
    const uint16_t page = app->page_phase;

    (void)caekf_get_state(&app->est, x);
    pm.step = (uint8_t)(step & CAEKF_PROD_STEP_MASK);
    pm.flags = (uint16_t)(report->flags & CAEKF_PROD_FLAGS_MASK);
    pm.gamma = wire_value(app, x, 2u * WIRE_BODIES);
    if (caekf_proto_encode_prod(&pm, f.data) == CAEKF_PROTO_SATURATED) {
        caekf_app_count(app, CAEKF_CNT_TX_SATURATED, 1u);
        app_flags |= (uint16_t)CAEKF_STEP_FLAGS_SATURATED;
    }
    caekf_app_send(app, CAEKF_MSG_EST_PROD, &f);

    if (app->cfg.page_period_steps != 0u) {
        app->page_phase = (uint16_t)((app->page_phase + 1u) % app->cfg.page_period_steps);
    } else if (app->page_phase < CAEKF_PAGE_COUNT) {
        app->page_phase++;
    } else {
        /* pages only on request: the phase stays past the last page */
    }
    if (page >= CAEKF_PAGE_COUNT) {
        return;
    }
    pg.page = (uint8_t)page;
    pg.step = step;
    pg.value = 0.0;
    if (page < 2u * WIRE_BODIES) {
        pg.value = wire_value(app, x, page);
    } else if (page == 8u) {
        pg.value = (double)NAN; /* sent when the norm cannot be computed */
        if (caekf_get_cov_norm2(&app->est, &p_norm) == CAEKF_OK) {
            pg.value = (double)p_norm;
        }
    } else if (page == 9u) {
        (void)caekf_get_covariance(&app->est, app->cov_scratch);
        pg.value = wire_p_gg(app);
    } else {
        if (caekf_get_cov_norm2(&app->est, &p_norm) != CAEKF_OK) {
            app_flags |= (uint16_t)CAEKF_STEP_FLAGS_PNORM_UNAVAILABLE;
        }
        pg.info = step_info(step, status, report, app_flags);
    }
    if (caekf_proto_encode_page(&pg, f.data) == CAEKF_PROTO_SATURATED) {
        caekf_app_count(app, CAEKF_CNT_TX_SATURATED, 1u);
    }
    caekf_app_send(app, CAEKF_MSG_EST_PAGE, &f);
}

/* State, P (into app->cov_scratch) and the P norm of the step's estimate, for the profiles that send them all;
 * a norm that cannot be computed is NaN and flagged. */
static double full_estimate(caekf_app_t *app, caekf_scalar_t x[CAEKF_N], uint16_t *app_flags)
{
    caekf_scalar_t p_norm;
    (void)caekf_get_state(&app->est, x);
    (void)caekf_get_covariance(&app->est, app->cov_scratch);
    if (caekf_get_cov_norm2(&app->est, &p_norm) == CAEKF_OK) {
        return (double)p_norm;
    }
    *app_flags |= (uint16_t)CAEKF_STEP_FLAGS_PNORM_UNAVAILABLE;
    return (double)NAN;
}

/* CAN FD: every value in one EST_FD; a clipped value sets the SATURATED flag in that same frame. */
static void send_fd(caekf_app_t *app, uint16_t step, caekf_status_t status, const caekf_report_t *report,
                    uint16_t app_flags)
{
    caekf_scalar_t x[CAEKF_N];
    caekf_msg_fd_out_t m;
    caekf_can_frame_t f;
    unsigned i;
    m.p_norm = full_estimate(app, x, &app_flags);
    /* q1..q4, v1..v4, gamma: 0 for what the mechanism lacks (the frame's fields are integers, which carry no
     * NaN; sending NaN would flag every step of a smaller mechanism SATURATED) */
    for (i = 0; i <= 2u * WIRE_BODIES; i++) {
        m.x[i] = wire_state(app, i) >= 0 ? wire_value(app, x, i) : 0.0;
    }
    m.p_gg = wire_state(app, 2u * WIRE_BODIES) >= 0 ? wire_p_gg(app) : 0.0;
    m.step = step;
    m.info = step_info(step, status, report, app_flags);
    if (caekf_proto_encode_fd_out(&m, f.data) == CAEKF_PROTO_SATURATED) {
        caekf_app_count(app, CAEKF_CNT_TX_SATURATED, 1u);
        m.info.flags |= (uint16_t)CAEKF_STEP_FLAGS_SATURATED;
        (void)caekf_proto_encode_fd_out(&m, f.data);
    }
    caekf_app_send(app, CAEKF_MSG_EST_FD, &f);
}

void caekf_app_send_estimate(caekf_app_t *app, uint16_t step, caekf_status_t status, const caekf_report_t *report,
                             uint16_t app_flags)
{
    static const caekf_msg_t q_msgs[DIAG_BODIES] = {CAEKF_MSG_EST_Q1, CAEKF_MSG_EST_Q2, CAEKF_MSG_EST_Q3,
                                                    CAEKF_MSG_EST_Q4, CAEKF_MSG_EST_Q5, CAEKF_MSG_EST_Q6,
                                                    CAEKF_MSG_EST_Q7, CAEKF_MSG_EST_Q8};
    static const caekf_msg_t v_msgs[DIAG_BODIES] = {CAEKF_MSG_EST_V1, CAEKF_MSG_EST_V2, CAEKF_MSG_EST_V3,
                                                    CAEKF_MSG_EST_V4, CAEKF_MSG_EST_V5, CAEKF_MSG_EST_V6,
                                                    CAEKF_MSG_EST_V7, CAEKF_MSG_EST_V8};
    caekf_scalar_t x[CAEKF_N];
    double p_norm_out;
    caekf_msg_step_t sm;
    caekf_can_frame_t f;
    unsigned i;
    const unsigned nq = (unsigned)app->est.model.nq;
    const unsigned nc = (unsigned)app->est.model.nc;

    if (app->cfg.profile == (uint8_t)CAEKF_PROFILE_PRODUCTION) {
        send_production(app, step, status, report, app_flags);
        return;
    }
    if (app->cfg.profile == (uint8_t)CAEKF_PROFILE_FD) {
        send_fd(app, step, status, report, app_flags);
        return;
    }
    /* DIAGNOSTICS: every body and contact of the mechanism, nothing it lacks (EST_GAMMA and EST_P_GG aside:
     * NaN without a contact) */
    p_norm_out = full_estimate(app, x, &app_flags);
    send_value(app, CAEKF_MSG_EST_GAMMA, step, wire_value(app, x, 2u * WIRE_BODIES), &app_flags);
    for (i = 0; i < DIAG_BODIES && i < nq; i++) {
        send_value(app, q_msgs[i], step, (double)x[i], &app_flags);
    }
    for (i = 0; i < DIAG_BODIES && i < nq; i++) {
        send_value(app, v_msgs[i], step, (double)x[nq + i], &app_flags);
    }
    send_value(app, CAEKF_MSG_EST_P_NORM, step, p_norm_out, &app_flags);
    send_value(app, CAEKF_MSG_EST_P_GG, step, wire_p_gg(app), &app_flags);
    if (nc > 1u) {
        send_value(app, CAEKF_MSG_EST_GAMMA2, step, (double)x[2u * nq + 1u], &app_flags);
        send_value(app, CAEKF_MSG_EST_P_GG2, step, (double)app->cov_scratch[2u * nq + 1u][2u * nq + 1u], &app_flags);
    }

    sm = step_info(step, status, report, app_flags);
    (void)caekf_proto_encode_step(&sm, f.data);
    caekf_app_send(app, CAEKF_MSG_EST_STEP, &f);
}
