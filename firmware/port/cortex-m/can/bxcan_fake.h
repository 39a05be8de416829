/*
 * bxcan_fake.h - a bxCAN controller simulated over a register block in RAM, for the host unit tests
 * (tests/unit/port) and the on-target selftest image (QEMU's mps2 machines have no bxCAN).
 *
 * Point the driver at &fake.regs. RAM cannot react to a write by itself, so the model reacts when
 * caekf_bxcan_fake_step() runs (pass caekf_bxcan_fake_hook as the driver's wait_hook so that it also
 * runs inside the driver's bounded waits). A step:
 *   - acknowledges MCR.INRQ / SLEEP in MSR.INAK / SLAK (unless ack_init / ack_leave are cleared);
 *   - applies the driver's writes to RF0R (RFOM0 release, FULL0/FOVR0 clear) and TSR (RQCPx clear):
 *     a write is recognised as the register holding something else than the model last published;
 *   - "sends" every mailbox with TIxR.TXRQ (lowest first) into tx_log, sets TME/RQCP/TXOK; in
 *     loopback mode (BTR.LBKM) the frame is also received;
 *   - publishes FIFO 0's oldest message in the RX output mailbox and FMP0/FULL0/FOVR0 in RF0R.
 * Frames arrive from the bus with caekf_bxcan_fake_deliver(): acceptance filtering as the reference
 * manual describes it (scales, modes, FIFO assignment, filter match index and priority), FIFO 0 of
 * depth 3, overrun per MCR.RFLM. Frames a filter sends to FIFO 1 are only counted.
 */
#ifndef CAEKF_BXCAN_FAKE_H
#define CAEKF_BXCAN_FAKE_H

#include <stdint.h>

#include "bxcan.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CAEKF_BXCAN_FAKE_TX_LOG 64u

typedef struct {
    caekf_bxcan_regs_t regs; /* the "peripheral" */

    uint8_t ack_init;  /* 1 (default): INAK follows INRQ set, SLAK follows SLEEP */
    uint8_t ack_leave; /* 1 (default): INAK clears when INRQ clears (bus idle seen at once) */

    caekf_bxcan_frame_t fifo[CAEKF_BXCAN_RX_FIFO_DEPTH]; /* FIFO 0, oldest first */
    unsigned fifo_count;
    uint8_t full_flag, fovr_flag;
    uint32_t tsr_state;         /* TSR as the hardware holds it */
    uint32_t pub_rf0r, pub_tsr; /* what the model last wrote to RF0R / TSR */

    caekf_bxcan_frame_t tx_log[CAEKF_BXCAN_FAKE_TX_LOG]; /* transmitted frames, in order */
    unsigned tx_count;                                   /* frames in tx_log */
    uint32_t tx_total;     /* all frames transmitted (tx_log keeps the first CAEKF_BXCAN_FAKE_TX_LOG) */
    uint32_t rx_delivered; /* frames stored in FIFO 0 */
    uint32_t rx_filtered;  /* frames no active filter accepted */
    uint32_t rx_fifo1;     /* frames accepted for FIFO 1 (not modelled further) */
    uint32_t rx_lost;      /* frames lost to an overrun */
    uint32_t rx_offline;   /* frames arriving while the controller was in initialisation or sleep */
    uint32_t steps;        /* calls of caekf_bxcan_fake_step */
} caekf_bxcan_fake_t;

/* Register reset values, empty FIFO and log, acknowledges on. */
void caekf_bxcan_fake_reset(caekf_bxcan_fake_t *f);
/* The hardware's reaction to the driver's writes; see above. */
void caekf_bxcan_fake_step(caekf_bxcan_fake_t *f);
/* caekf_bxcan_wait_hook_t calling caekf_bxcan_fake_step(ctx). */
void caekf_bxcan_fake_hook(void *ctx);
/* A frame arrives from the bus. 1 stored in FIFO 0, 0 rejected by the filters (or sent to FIFO 1,
 * or the controller is not in normal mode), -1 lost to an overrun (with RFLM 0 the newest message replaces the last one: the old one is lost). */
int caekf_bxcan_fake_deliver(caekf_bxcan_fake_t *f, const caekf_bxcan_frame_t *frame);
/* Filter decision only: 1 and *fifo, *fmi if a filter accepts the frame, else 0. */
int caekf_bxcan_fake_match(const caekf_bxcan_fake_t *f, const caekf_bxcan_frame_t *frame, unsigned *fifo,
                           unsigned *fmi);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_BXCAN_FAKE_H */
