/*
 * mcu_selftest.h - the firmware (caekf_mcu_fw_*: bxCAN driver, filters, HAL, app) end to end against
 * the simulated bxCAN of bxcan_fake.h. A test, hence here and not in firmware/: it runs on the host
 * (test_port_mcu_hal) and as the target image caekf_fw_selftest (fw_selftest.c) under QEMU, where no
 * real bxCAN exists.
 *
 * The bench side writes frames into the fake's RX FIFO (3 deep, so the test keeps the firmware
 * polling while it feeds), and reads what the firmware sent from the fake's TX mailboxes:
 *   1. init: enter/leave initialisation acknowledged, 16-bit list filters for the protocol's IDs;
 *   2. frames the estimator must not see are dropped by the hardware filters (foreign ID, an
 *      estimator output ID, an extended and a remote frame with a bench ID);
 *   3. configuration over CAN: the paper's settings and the switched-highq-constrained preset's as
 *      CTRL_PARAM frames (the generated fixture), CTRL_RESET, EST_ACK accepted;
 *   4. `steps` bench steps: BENCH_U/Y1/Y4 in, then the 12 estimate frames of that STEP out, in
 *      order, EST_STEP last, every frame's E2E CRC and alive counter valid, step status >= 0; in the
 *      PRODUCTION profile (t->profile) BENCH_U/YP in, EST_PROD out and one EST_PAGE at the first 11
 *      steps of every 20;
 *   5. an RX overrun (4 frames into the 3-deep FIFO without polling) is counted by the driver.
 */
#ifndef CAEKF_MCU_SELFTEST_H
#define CAEKF_MCU_SELFTEST_H

#include <stdint.h>

#include "bxcan_fake.h"
#include "mcu_hal.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    caekf_bxcan_fake_t fake;
    caekf_mcu_fw_t fw;
    uint8_t bench_counter[CAEKF_MSG_COUNT];
    caekf_e2e_rx_t est_rx[CAEKF_MSG_COUNT];             /* the bench's E2E check of the firmware's frames */
    caekf_bxcan_frame_t taken[CAEKF_BXCAN_FAKE_TX_LOG]; /* frames taken from the fake's TX log */
    const char *failure;                                /* first failed check, NULL if all passed */
    long failure_value;                                 /* a number that goes with it */
    uint32_t frames_in, frames_out, steps_ok;
    uint32_t est_step_status_sum; /* sum of the STEP_STATUS fields seen (0 when all OK) */
    uint8_t profile;              /* caekf_profile_t of the firmware and the bench (prepare: DIAGNOSTICS) */
} caekf_mcu_selftest_t;

/* Resets the fake controller (acknowledges on) and the bench state. Change t->fake's knobs after
 * this and before caekf_mcu_selftest_run to provoke failures. */
void caekf_mcu_selftest_prepare(caekf_mcu_selftest_t *t);
/* Runs the sequence above with `now` as the firmware's microsecond clock. 0 if every check passed,
 * else 1 with t->failure set. */
int caekf_mcu_selftest_run(caekf_mcu_selftest_t *t, caekf_mcu_now_fn_t now, void *now_ctx, unsigned steps);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_MCU_SELFTEST_H */
