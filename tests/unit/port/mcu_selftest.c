/* The firmware end to end over the simulated bxCAN: see mcu_selftest.h. */
#include "mcu_selftest.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "caekf_fixture_settings.h" /* the reference scenario and the presets, generated from the schema */

#define PUMP_LIMIT 400u /* main-loop passes allowed for the firmware to go idle */
#define SELFTEST_TOKEN 0x5Au
#define SELFTEST_PRESET CAEKF_FIXTURE_PRESET_SWITCHED_HIGHQ_CONSTRAINED
#define APB1_HZ 42000000u /* STM32F4 at 168 MHz; only the BTR value depends on it */
#define BITRATE 1000000u  /* the firmware's bit rate (app_main.c) */

#define CHECK(t, cond, what, value)           \
    do {                                      \
        if (!(cond)) {                        \
            fail((t), (what), (long)(value)); \
            return 1;                         \
        }                                     \
    } while (0)

/* The estimate frames of one step, in the order the app sends them. */
static const caekf_msg_t step_msgs[] = {
    CAEKF_MSG_EST_GAMMA, CAEKF_MSG_EST_Q1,     CAEKF_MSG_EST_Q2,   CAEKF_MSG_EST_Q3,
    CAEKF_MSG_EST_Q4,    CAEKF_MSG_EST_V1,     CAEKF_MSG_EST_V2,   CAEKF_MSG_EST_V3,
    CAEKF_MSG_EST_V4,    CAEKF_MSG_EST_P_NORM, CAEKF_MSG_EST_P_GG, CAEKF_MSG_EST_STEP,
};
#define N_STEP_MSGS ((unsigned)(sizeof step_msgs / sizeof step_msgs[0]))

static void fail(caekf_mcu_selftest_t *t, const char *what, long value)
{
    if (t->failure == NULL) {
        t->failure = what;
        t->failure_value = value;
    }
}

void caekf_mcu_selftest_prepare(caekf_mcu_selftest_t *t)
{
    unsigned i;
    if (t == NULL) {
        return;
    }
    caekf_bxcan_fake_reset(&t->fake);
    memset(t->bench_counter, 0, sizeof t->bench_counter);
    for (i = 0u; i < (unsigned)CAEKF_MSG_COUNT; i++) {
        (void)caekf_e2e_rx_init(&t->est_rx[i]);
    }
    t->failure = NULL;
    t->failure_value = 0;
    t->frames_in = 0u;
    t->frames_out = 0u;
    t->steps_ok = 0u;
    t->est_step_status_sum = 0u;
    t->profile = (uint8_t)CAEKF_PROFILE_DIAGNOSTICS;
}

/* One main-loop pass of the firmware, with the hardware reacting before and after. */
static void pump(caekf_mcu_selftest_t *t)
{
    caekf_bxcan_fake_step(&t->fake);
    (void)caekf_mcu_fw_poll(&t->fw);
    caekf_bxcan_fake_step(&t->fake);
}

static int tx_pending(const caekf_mcu_selftest_t *t)
{
    unsigned m;
    for (m = 0u; m < CAEKF_BXCAN_TX_MAILBOXES; m++) {
        if (t->fake.regs.tx[m].TIR & CAEKF_BXCAN_IR_TXRQ) {
            return 1;
        }
    }
    return 0;
}

/* Polls until a pass finds the RX FIFO, the HAL's TX queue and the mailboxes empty and sends nothing
 * (so that pass's service has also collected every completion). */
static int settle(caekf_mcu_selftest_t *t)
{
    unsigned i;
    for (i = 0u; i < PUMP_LIMIT; i++) {
        uint32_t sent = t->fake.tx_total;
        pump(t);
        if (t->fake.tx_total == sent && t->fake.fifo_count == 0u && t->fw.hal.txq_count == 0u && !tx_pending(t)) {
            return 1;
        }
    }
    return 0;
}

/* Bench side: seal with the next alive counter and put the frame on the bus (waiting for FIFO room). */
static int bench_send(caekf_mcu_selftest_t *t, caekf_msg_t msg, const uint8_t data[CAEKF_CAN_DLC])
{
    caekf_can_frame_t f;
    caekf_bxcan_frame_t bx;
    unsigned i;
    memcpy(f.data, data, CAEKF_CAN_DLC);
    CHECK(t, caekf_proto_seal(msg, t->bench_counter[msg], &f) == CAEKF_PROTO_OK, "bench: seal", msg);
    t->bench_counter[msg] = (uint8_t)((t->bench_counter[msg] + 1u) & CAEKF_E2E_COUNTER_MASK);
    for (i = 0u; i < PUMP_LIMIT && t->fake.fifo_count >= CAEKF_BXCAN_RX_FIFO_DEPTH; i++) {
        pump(t);
    }
    memset(&bx, 0, sizeof bx);
    bx.id = f.id;
    bx.dlc = f.dlc;
    memcpy(bx.data, f.data, sizeof bx.data);
    CHECK(t, caekf_bxcan_fake_deliver(&t->fake, &bx) == 1, "bench: frame not stored in RX FIFO 0", f.id);
    t->frames_in++;
    return 0;
}

/* Takes the frames the firmware transmitted since the last call; every one must pass the E2E check. */
static int take_tx(caekf_mcu_selftest_t *t, unsigned *n)
{
    unsigned i, count = t->fake.tx_count;
    t->frames_out += count;
    CHECK(t, t->fake.tx_total == t->frames_out, "bench: fake TX log overflowed", t->fake.tx_total);
    for (i = 0u; i < count; i++) {
        const caekf_bxcan_frame_t *fr = &t->fake.tx_log[i];
        const caekf_msg_info_t *info;
        caekf_msg_t msg;
        uint8_t lost = 0u;
        CHECK(t, !fr->ide && !fr->rtr && fr->dlc == CAEKF_CAN_DLC, "tx: not a standard data frame of 8 bytes", fr->id);
        CHECK(t, caekf_proto_msg_from_id(fr->id, &msg) == CAEKF_PROTO_OK, "tx: unknown CAN ID", fr->id);
        CHECK(t, caekf_proto_msg_info(msg, &info) == CAEKF_PROTO_OK && info->dir == CAEKF_DIR_FROM_ESTIMATOR,
              "tx: message of the wrong direction", fr->id);
        CHECK(t, caekf_e2e_check(&t->est_rx[msg], info->data_id, 1u, fr->data, fr->dlc, &lost) == CAEKF_E2E_OK,
              "tx: E2E check failed (CRC or alive counter)", fr->id);
        t->taken[i] = *fr;
    }
    t->fake.tx_count = 0u;
    *n = count;
    return 0;
}

static unsigned frame_step(const uint8_t *d)
{
    /* STEP: 16 bits from bit 12, little-endian bit order */
    return ((unsigned)d[1] >> 4) | ((unsigned)d[2] << 4) | (((unsigned)d[3] & 0x0Fu) << 12);
}

static int check_init(caekf_mcu_selftest_t *t)
{
    const caekf_bxcan_regs_t *r = &t->fake.regs;
    const caekf_bxcan_timing_t expect = {3u, 11u, 2u, 1u};
    uint32_t btr = 0u;
    CHECK(t, (r->MSR & (CAEKF_BXCAN_MSR_INAK | CAEKF_BXCAN_MSR_SLAK)) == 0u, "init: controller not in normal mode",
          r->MSR);
    CHECK(t,
          (r->MCR & (CAEKF_BXCAN_MCR_TXFP | CAEKF_BXCAN_MCR_ABOM | CAEKF_BXCAN_MCR_INRQ | CAEKF_BXCAN_MCR_SLEEP)) ==
              (CAEKF_BXCAN_MCR_TXFP | CAEKF_BXCAN_MCR_ABOM),
          "init: MCR options", r->MCR);
    (void)caekf_bxcan_timing_btr(&expect, &btr);
    CHECK(t, r->BTR == btr, "init: BTR is not 1 Mbit/s at 42 MHz (BRP 3, TS1 11, TS2 2, SJW 1)", r->BTR);
    /* 15 input IDs (the profiles' and a mechanism's), 4 per 16-bit list bank */
    CHECK(t,
          t->fw.filter_banks == 4u && (r->FA1R & 0xFu) == 0xFu && (r->FM1R & 0xFu) == 0xFu && (r->FS1R & 0xFu) == 0u &&
              (r->FFA1R & 0xFu) == 0u && (r->FMR & CAEKF_BXCAN_FMR_FINIT) == 0u,
          "init: filter banks 0..3 not active 16-bit lists for FIFO 0", r->FA1R);
    return 0;
}

static int check_filters(caekf_mcu_selftest_t *t)
{
    static const struct {
        uint32_t id;
        uint8_t ide, rtr;
    } foreign[] = {{0x123u, 0u, 0u}, {0x180u, 0u, 0u}, {0x100u, 1u, 0u}, {0x100u, 0u, 1u}, {0x0C3u, 0u, 0u}};
    unsigned i;
    uint32_t before = t->fake.rx_filtered;
    for (i = 0u; i < sizeof foreign / sizeof foreign[0]; i++) {
        caekf_bxcan_frame_t bx;
        memset(&bx, 0, sizeof bx);
        bx.id = foreign[i].id;
        bx.ide = foreign[i].ide;
        bx.rtr = foreign[i].rtr;
        bx.dlc = 8u;
        CHECK(t, caekf_bxcan_fake_deliver(&t->fake, &bx) == 0, "filters: a frame for someone else was accepted", bx.id);
    }
    CHECK(t, t->fake.rx_filtered - before == i, "filters: rejections not counted", t->fake.rx_filtered - before);
    return 0;
}

static int send_param(caekf_mcu_selftest_t *t, const caekf_msg_param_t *p)
{
    uint8_t d[CAEKF_CAN_DLC];
    memset(d, 0, sizeof d);
    CHECK(t, caekf_proto_encode_param(p, d) == CAEKF_PROTO_OK, "bench: encode CTRL_PARAM", p->param_id);
    return bench_send(t, CAEKF_MSG_CTRL_PARAM, d);
}

/* A preset's value in the shortest decimal mantissa/exponent form the wire takes (presets are short
 * decimals: 0, 1, 1000). */
static int preset_param(caekf_mcu_selftest_t *t, unsigned i, caekf_msg_param_t *p)
{
    const caekf_fixture_preset_t *pr = &caekf_fixture_presets[SELFTEST_PRESET];
    double m = pr->value[i], v = 0.0;
    int exp10 = 0;
    while (m != 0.0 && m != (double)(int64_t)m && exp10 > -18) {
        m *= 10.0;
        exp10--;
    }
    p->param_id = pr->id[i];
    p->param_exp10 = (int8_t)exp10;
    p->param_mantissa = (int64_t)m;
    CHECK(t, caekf_proto_param_value(p, &v) == CAEKF_PROTO_OK && v == pr->value[i], "bench: preset value not exact",
          pr->id[i]);
    return 0;
}

/* The paper's settings and then the preset's, as CTRL_PARAM frames, and CTRL_RESET. */
static int configure(caekf_mcu_selftest_t *t)
{
    uint8_t d[CAEKF_CAN_DLC];
    const caekf_bxcan_frame_t *out = t->taken;
    const unsigned n_params = CAEKF_N_PAPER_PARAMS + caekf_fixture_presets[SELFTEST_PRESET].n;
    caekf_msg_reset_t rst;
    caekf_msg_ack_t ack;
    caekf_msg_param_t p;
    unsigned i, n, acks = 0u;
    for (i = 0u; i < CAEKF_N_PAPER_PARAMS; i++) {
        p.param_id = caekf_paper_params[i].id;
        p.param_exp10 = caekf_paper_params[i].exp10;
        p.param_mantissa = caekf_paper_params[i].mantissa;
        if (send_param(t, &p)) {
            return 1;
        }
    }
    for (i = 0u; i < caekf_fixture_presets[SELFTEST_PRESET].n; i++) {
        if (preset_param(t, i, &p) || send_param(t, &p)) {
            return 1;
        }
    }
    rst.n_params = (uint8_t)n_params;
    rst.token = SELFTEST_TOKEN;
    memset(d, 0, sizeof d);
    CHECK(t, caekf_proto_encode_reset(&rst, d) == CAEKF_PROTO_OK, "bench: encode CTRL_RESET", 0);
    if (bench_send(t, CAEKF_MSG_CTRL_RESET, d)) {
        return 1;
    }
    CHECK(t, settle(t), "configure: firmware did not go idle", t->fake.fifo_count);
    if (take_tx(t, &n)) {
        return 1;
    }
    for (i = 0u; i < n; i++) {
        if (out[i].id != 0x0C8u) {
            continue; /* EST_HEALTH bursts may come in between */
        }
        CHECK(t, caekf_proto_decode_ack(out[i].data, &ack) == CAEKF_PROTO_OK, "configure: EST_ACK does not decode", i);
        CHECK(t, ack.ack_status == (int8_t)CAEKF_ACK_ACCEPTED, "configure: configuration refused (ACK_STATUS)",
              ack.ack_status);
        CHECK(t,
              ack.token == SELFTEST_TOKEN && ack.n_params_rx == n_params &&
                  ack.bad_param == (uint8_t)CAEKF_ACK_BAD_PARAM_NONE,
              "configure: EST_ACK fields", ack.n_params_rx);
        acks++;
    }
    CHECK(t, acks == 1u, "configure: expected exactly one EST_ACK", acks);
    return 0;
}

static int run_step(caekf_mcu_selftest_t *t, uint16_t step)
{
    uint8_t d[CAEKF_CAN_DLC];
    const caekf_bxcan_frame_t *out = t->taken;
    unsigned i, n, k = 0u;
    double u = 5.0 * (double)(step % 7u), y1 = 1.0e-6 * (double)step, y4 = -0.5e-6 * (double)step;
    double gamma = 0.0;
    uint16_t s;
    caekf_msg_step_t sm;
    CHECK(t, caekf_proto_encode_value(CAEKF_MSG_BENCH_U, step, u, d) >= 0, "bench: encode BENCH_U", step);
    if (bench_send(t, CAEKF_MSG_BENCH_U, d)) {
        return 1;
    }
    CHECK(t, caekf_proto_encode_value(CAEKF_MSG_BENCH_Y1, step, y1, d) >= 0, "bench: encode BENCH_Y1", step);
    if (bench_send(t, CAEKF_MSG_BENCH_Y1, d)) {
        return 1;
    }
    CHECK(t, caekf_proto_encode_value(CAEKF_MSG_BENCH_Y4, step, y4, d) >= 0, "bench: encode BENCH_Y4", step);
    if (bench_send(t, CAEKF_MSG_BENCH_Y4, d)) {
        return 1;
    }
    CHECK(t, settle(t), "step: firmware did not go idle", step);
    if (take_tx(t, &n)) {
        return 1;
    }
    for (i = 0u; i < n; i++) {
        if (out[i].id == 0x0C9u) {
            continue; /* EST_HEALTH */
        }
        CHECK(t, k < N_STEP_MSGS, "step: more estimate frames than one step has", out[i].id);
        {
            const caekf_msg_info_t *info;
            (void)caekf_proto_msg_info(step_msgs[k], &info);
            CHECK(t, out[i].id == info->can_id, "step: estimate frames out of order (CAN ID)", out[i].id);
        }
        CHECK(t, frame_step(out[i].data) == step, "step: estimate frame with another STEP", frame_step(out[i].data));
        if (step_msgs[k] == CAEKF_MSG_EST_GAMMA) {
            CHECK(t,
                  caekf_proto_decode_value(CAEKF_MSG_EST_GAMMA, out[i].data, &s, &gamma) == CAEKF_PROTO_OK &&
                      isfinite(gamma) && gamma > 0.0,
                  "step: EST_GAMMA not a finite positive stiffness", step);
        }
        if (step_msgs[k] == CAEKF_MSG_EST_STEP) {
            CHECK(t, caekf_proto_decode_step(out[i].data, &sm) == CAEKF_PROTO_OK, "step: EST_STEP does not decode",
                  step);
            CHECK(t, sm.step_status >= 0, "step: estimator step status negative", sm.step_status);
            t->est_step_status_sum += (uint32_t)sm.step_status;
        }
        k++;
    }
    CHECK(t, k == N_STEP_MSGS, "step: estimate frames missing (EST_STEP must close the step)", k);
    t->steps_ok++;
    return 0;
}

/* Production profile: BENCH_U and BENCH_YP in; EST_PROD out first, then (default page period 20) page
 * (step - 1) % 20 of EST_PAGE while that is < 11. */
static int run_step_prod(caekf_mcu_selftest_t *t, uint16_t step)
{
    uint8_t d[CAEKF_CAN_DLC];
    const caekf_bxcan_frame_t *out = t->taken;
    const unsigned page = (unsigned)(step - 1u) % 20u;
    const unsigned want = (page < CAEKF_PAGE_COUNT) ? 2u : 1u;
    const caekf_msg_info_t *prod, *pg;
    caekf_msg_yp_t yp;
    caekf_msg_prod_t pm;
    caekf_msg_page_t pp;
    unsigned i, n, k = 0u;
    yp.step = (uint8_t)(step & 0xFFu);
    yp.y1 = 1.0e-6 * (double)step;
    yp.y4 = -0.5e-6 * (double)step;
    CHECK(t, caekf_proto_encode_value(CAEKF_MSG_BENCH_U, step, 5.0 * (double)(step % 7u), d) >= 0,
          "bench: encode BENCH_U", step);
    if (bench_send(t, CAEKF_MSG_BENCH_U, d)) {
        return 1;
    }
    CHECK(t, caekf_proto_encode_yp(&yp, d) == CAEKF_PROTO_OK, "bench: encode BENCH_YP", step);
    if (bench_send(t, CAEKF_MSG_BENCH_YP, d)) {
        return 1;
    }
    CHECK(t, settle(t), "step: firmware did not go idle", step);
    if (take_tx(t, &n)) {
        return 1;
    }
    (void)caekf_proto_msg_info(CAEKF_MSG_EST_PROD, &prod);
    (void)caekf_proto_msg_info(CAEKF_MSG_EST_PAGE, &pg);
    for (i = 0u; i < n; i++) {
        if (out[i].id == 0x0C9u) {
            continue; /* EST_HEALTH */
        }
        CHECK(t, k < want, "step: more estimate frames than a production step has", out[i].id);
        if (k == 0u) {
            CHECK(t, out[i].id == prod->can_id, "step: EST_PROD must come first", out[i].id);
            CHECK(t,
                  caekf_proto_decode_prod(out[i].data, &pm) == CAEKF_PROTO_OK && pm.step == (uint8_t)step &&
                      isfinite(pm.gamma) && pm.gamma > 0.0,
                  "step: EST_PROD not this step's finite positive stiffness", step);
        } else {
            CHECK(t, out[i].id == pg->can_id, "step: the frame after EST_PROD is not EST_PAGE", out[i].id);
            CHECK(t, caekf_proto_decode_page(out[i].data, &pp) == CAEKF_PROTO_OK && pp.step == step && pp.page == page,
                  "step: EST_PAGE of another step or page", pp.page);
        }
        k++;
    }
    CHECK(t, k == want, "step: production estimate frames missing", k);
    t->steps_ok++;
    return 0;
}

static int check_overrun(caekf_mcu_selftest_t *t)
{
    uint8_t d[CAEKF_CAN_DLC];
    const caekf_bxcan_frame_t *out = t->taken;
    caekf_msg_status_req_t req;
    caekf_bxcan_frame_t bx;
    caekf_can_frame_t f;
    unsigned i, n, acks = 0u;
    uint32_t overruns = t->fw.can.cnt.rx_overruns;
    int stored[4];
    /* Four CTRL_STATUS_REQ frames while the firmware does not poll: the 4th overruns FIFO 0. */
    for (i = 0u; i < 4u; i++) {
        req.token = (uint8_t)(0x10u + i);
        memset(d, 0, sizeof d);
        CHECK(t, caekf_proto_encode_status_req(&req, d) == CAEKF_PROTO_OK, "bench: encode CTRL_STATUS_REQ", i);
        memcpy(f.data, d, CAEKF_CAN_DLC);
        CHECK(t,
              caekf_proto_seal(CAEKF_MSG_CTRL_STATUS_REQ, t->bench_counter[CAEKF_MSG_CTRL_STATUS_REQ], &f) ==
                  CAEKF_PROTO_OK,
              "bench: seal", i);
        t->bench_counter[CAEKF_MSG_CTRL_STATUS_REQ] =
            (uint8_t)((t->bench_counter[CAEKF_MSG_CTRL_STATUS_REQ] + 1u) & CAEKF_E2E_COUNTER_MASK);
        memset(&bx, 0, sizeof bx);
        bx.id = f.id;
        bx.dlc = f.dlc;
        memcpy(bx.data, f.data, sizeof bx.data);
        stored[i] = caekf_bxcan_fake_deliver(&t->fake, &bx);
    }
    CHECK(t, stored[0] == 1 && stored[1] == 1 && stored[2] == 1 && stored[3] == -1, "overrun: fake FIFO depth",
          stored[3]);
    CHECK(t, settle(t), "overrun: firmware did not go idle", t->fake.fifo_count);
    CHECK(t, t->fw.can.cnt.rx_overruns - overruns == 1u, "overrun: driver did not count exactly one overrun",
          t->fw.can.cnt.rx_overruns - overruns);
    if (take_tx(t, &n)) {
        return 1;
    }
    for (i = 0u; i < n; i++) {
        caekf_msg_ack_t ack;
        if (out[i].id == 0x0C8u && caekf_proto_decode_ack(out[i].data, &ack) == CAEKF_PROTO_OK &&
            ack.ack_status == (int8_t)CAEKF_ACK_STATUS) {
            acks++;
        }
    }
    /* frames 1 and 2 answered; the 4th replaced the 3rd (RFLM 0) and jumps the alive counter by 2 */
    CHECK(t, acks == 2u, "overrun: expected two status answers", acks);
    return 0;
}

int caekf_mcu_selftest_run(caekf_mcu_selftest_t *t, caekf_mcu_now_fn_t now, void *now_ctx, unsigned steps)
{
    caekf_mcu_fw_config_t cfg;
    caekf_mcu_status_t st;
    unsigned k;
    if (t == NULL || now == NULL) {
        return 1;
    }
    (void)caekf_mcu_fw_config_default(&cfg);
    cfg.regs = &t->fake.regs;
    cfg.filter_regs = &t->fake.regs;
    cfg.now = now;
    cfg.now_ctx = now_ctx;
    cfg.app.profile = t->profile;
    cfg.can.wait_limit = 1000u;
    cfg.can.wait_hook = caekf_bxcan_fake_hook; /* the fake controller acknowledges while we wait */
    cfg.can.wait_ctx = &t->fake;
    CHECK(t, caekf_bxcan_timing_compute(APB1_HZ, BITRATE, 875u, &cfg.can.timing) == CAEKF_BXCAN_OK, "init: timing", 0);
    st = caekf_mcu_fw_init(&t->fw, &cfg);
    CHECK(t, st == CAEKF_MCU_OK, "init: caekf_mcu_fw_init failed (value: bxCAN status)", t->fw.can_status);
    if (check_init(t) || check_filters(t) || configure(t)) {
        return 1;
    }
    for (k = 1u; k <= steps; k++) {
        if (t->profile == (uint8_t)CAEKF_PROFILE_PRODUCTION ? run_step_prod(t, (uint16_t)k)
                                                            : run_step(t, (uint16_t)k)) {
            return 1;
        }
    }
    if (check_overrun(t)) {
        return 1;
    }
    CHECK(t, t->fw.hal.cnt.tx_queue_full == 0u && t->fw.hal.cnt.tx_errors == 0u, "hal: transmit errors",
          t->fw.hal.cnt.tx_errors);
    CHECK(t, t->fw.can.cnt.tx_ok == t->frames_out, "driver: TX completions differ from frames sent",
          t->fw.can.cnt.tx_ok);
    return 0;
}
