/*
 * bxcan.h - register-level polling driver for the STM32 bxCAN controller (STM32F4/F7), no vendor
 * headers, no heap, no interrupts, every loop bounded.
 *
 *   caekf_bxcan_config_t cfg;
 *   caekf_bxcan_config_default(&cfg);
 *   caekf_bxcan_timing_compute(42000000u, 1000000u, 875u, &cfg.timing); // APB1 42 MHz, 1 Mbit/s
 *   static caekf_bxcan_t can;
 *   caekf_bxcan_init(&can, (caekf_bxcan_regs_t *)CAEKF_BXCAN1_BASE, &cfg);
 *   caekf_bxcan_filter_list16(can.regs, 0u, ids, n_ids, 0u, NULL);
 *   ... caekf_bxcan_transmit(&can, &frame, NULL);  caekf_bxcan_receive(&can, &frame);
 *       caekf_bxcan_service(&can);  // TX completions and error state, once per main-loop pass
 *
 * Clocks, pins and the RCC enable of the peripheral are the board's business (done before init).
 *
 * Waiting for the hardware: entering and leaving initialisation mode need the controller's
 * acknowledge (MSR.INAK). Each wait is at most cfg.wait_limit register reads; cfg.wait_hook (if not
 * NULL) is called once per iteration: on a part it can be a short delay (so the bound is a time), in
 * the tests it is the fake controller reacting (bxcan_fake.h). A wait that runs out returns a
 * timeout status and leaves the controller as it is.
 *
 * Mailbox handling: a TX mailbox is free when TSR.TMEx is set and TIxR.TXRQ is clear (the same on
 * silicon; the second condition keeps a RAM register block from being overwritten before the fake
 * has "sent" it). The lowest free mailbox is used. With cfg.tx_fifo_order (MCR.TXFP, default on)
 * pending mailboxes leave in request order, which the caekf app relies on (EST_STEP closes a step).
 * Completions (TSR.RQCPx with TXOKx/TERRx/ALSTx) are counted by caekf_bxcan_service, or by
 * caekf_bxcan_transmit when it refills a mailbox whose completion was not collected yet (a new request
 * clears RQCP in hardware), so each request is counted once.
 */
#ifndef CAEKF_BXCAN_H
#define CAEKF_BXCAN_H

#include <stdint.h>

#include "bxcan_regs.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    CAEKF_BXCAN_OK = 0,
    CAEKF_BXCAN_EMPTY = 1,              /* receive: FIFO 0 holds no message */
    CAEKF_BXCAN_BUSY = 2,               /* transmit: no free mailbox, nothing written */
    CAEKF_BXCAN_ERR_NULL = -1,          /* a required pointer was NULL */
    CAEKF_BXCAN_ERR_PARAM = -2,         /* a configuration value or frame field out of range: nothing written */
    CAEKF_BXCAN_ERR_INIT_TIMEOUT = -3,  /* entering initialisation mode was never acknowledged (INAK) */
    CAEKF_BXCAN_ERR_START_TIMEOUT = -4, /* leaving initialisation mode was never acknowledged (no bus idle seen) */
    CAEKF_BXCAN_ERR_STATE = -5,         /* the driver is not started (init failed or never ran) */
    CAEKF_BXCAN_ERR_BUS_OFF = -6        /* the controller is bus-off: transmit refused */
} caekf_bxcan_status_t;

/* Bit timing in time quanta: bit = (1 + ts1 + ts2) tq, tq = prescaler / f_APB1, sample point after
 * 1 + ts1 quanta. */
typedef struct {
    uint16_t prescaler; /* 1..1024 */
    uint8_t ts1;        /* 1..16 */
    uint8_t ts2;        /* 1..8 */
    uint8_t sjw;        /* 1..4, at most ts2 */
} caekf_bxcan_timing_t;

typedef void (*caekf_bxcan_wait_hook_t)(void *ctx);

#define CAEKF_BXCAN_DEFAULT_WAIT_LIMIT 100000u /* register reads per wait when cfg.wait_limit == 0 */
#define CAEKF_BXCAN_RFOM_SPIN 32u              /* reads waiting for a FIFO release to complete */

typedef struct {
    caekf_bxcan_timing_t timing;
    uint8_t tx_fifo_order;             /* MCR.TXFP: 1 chronological (default), 0 lowest identifier first */
    uint8_t auto_bus_off_recovery;     /* MCR.ABOM (default 1) */
    uint8_t no_auto_retransmit;        /* MCR.NART (default 0) */
    uint8_t rx_fifo_locked;            /* MCR.RFLM: 1 keep the old messages on overrun (default 0: newest wins) */
    uint8_t loopback;                  /* BTR.LBKM (test mode, default 0) */
    uint8_t silent;                    /* BTR.SILM (test mode, default 0) */
    uint32_t wait_limit;               /* iterations of each bounded wait; 0: CAEKF_BXCAN_DEFAULT_WAIT_LIMIT */
    caekf_bxcan_wait_hook_t wait_hook; /* called once per wait iteration, may be NULL */
    void *wait_ctx;
} caekf_bxcan_config_t;

/* A classic CAN frame as the driver sees it. */
typedef struct {
    uint32_t id;   /* 11-bit (ide 0) or 29-bit (ide 1) identifier */
    uint8_t ide;   /* 1: extended identifier */
    uint8_t rtr;   /* 1: remote frame */
    uint8_t dlc;   /* transmit: 0..8; receive: the raw 4-bit DLC (9..15 mean 8 bytes) */
    uint8_t fmi;   /* receive: filter match index */
    uint16_t time; /* receive: time stamp (TTCM only) */
    uint8_t data[8];
} caekf_bxcan_frame_t;

/* Counters: all wrap modulo 2^32. */
typedef struct {
    uint32_t rx_frames;       /* frames read from FIFO 0 */
    uint32_t rx_overruns;     /* RF0R.FOVR0 seen (at least one message lost each time) */
    uint32_t rx_full;         /* RF0R.FULL0 seen */
    uint32_t tx_requests;     /* frames placed in a mailbox */
    uint32_t tx_busy;         /* transmit calls that found no free mailbox */
    uint32_t tx_ok;           /* completed requests with TXOK */
    uint32_t tx_failed;       /* completed requests without TXOK (error, arbitration lost with NART, abort) */
    uint32_t tx_arb_lost;     /* completions with ALST */
    uint32_t bus_off;         /* entries into bus-off (ESR.BOFF rising) */
    uint32_t error_passive;   /* entries into error passive (ESR.EPVF rising) */
    uint32_t bus_off_refused; /* transmit calls refused while bus-off */
} caekf_bxcan_counters_t;

typedef struct {
    caekf_bxcan_regs_t *regs;
    caekf_bxcan_counters_t cnt;
    uint32_t wait_limit;
    caekf_bxcan_wait_hook_t wait_hook;
    void *wait_ctx;
    uint8_t started; /* 1 after a successful init */
    uint8_t in_bus_off;
    uint8_t in_error_passive;
} caekf_bxcan_t;

/* Error state snapshot (ESR). */
typedef struct {
    uint8_t tec, rec; /* transmit / receive error counters */
    uint8_t lec;      /* last error code 0..7 */
    uint8_t warning, passive, bus_off;
} caekf_bxcan_error_state_t;

/* Defaults: TXFP and ABOM on, everything else off, timing zero (must be set), wait limit default. */
caekf_bxcan_status_t caekf_bxcan_config_default(caekf_bxcan_config_t *cfg);

/* Timing for `bitrate` from the APB1 clock `pclk_hz`, sample point as close as possible to
 * `sample_permille` (e.g. 875 = 87.5 %), preferring more quanta per bit on ties; sjw = 1. Only exact
 * bit rates (pclk divisible by bitrate * quanta) for 8..25 quanta per bit. ERR_PARAM if none fits. */
caekf_bxcan_status_t caekf_bxcan_timing_compute(uint32_t pclk_hz, uint32_t bitrate, uint32_t sample_permille,
                                                caekf_bxcan_timing_t *t);
/* BTR value of a timing (no mode bits), or ERR_PARAM for out-of-range fields. */
caekf_bxcan_status_t caekf_bxcan_timing_btr(const caekf_bxcan_timing_t *t, uint32_t *btr);

/* Leaves sleep, enters initialisation mode (bounded wait), writes MCR options, IER = 0 and BTR,
 * leaves initialisation mode (bounded wait). Filters are separate (caekf_bxcan_filter_*). */
caekf_bxcan_status_t caekf_bxcan_init(caekf_bxcan_t *can, caekf_bxcan_regs_t *regs, const caekf_bxcan_config_t *cfg);

/* ---- acceptance filters (on the master instance's registers) ----
 * Each call sets FMR.FINIT, deactivates the banks it writes, programs them, activates them and
 * clears FINIT. Banks must lie below FMR.CAN2SB to belong to CAN1 (not checked: CAN2 users pass
 * their own first bank). `fifo` is 0 or 1. *banks_used (may be NULL) receives the bank count. */

/* Identifier list, dual 16-bit scale: 4 standard data-frame identifiers per bank, the last bank
 * padded with the last identifier. 1..4*(28-first_bank) identifiers, each <= 0x7FF. */
caekf_bxcan_status_t caekf_bxcan_filter_list16(caekf_bxcan_regs_t *regs, unsigned first_bank, const uint16_t *ids,
                                               unsigned n_ids, unsigned fifo, unsigned *banks_used);
/* Identifier mask, dual 16-bit scale: one bank, two filters (id[i], mask[i]); a mask bit 1 means
 * "must match". RTR and IDE must match 0: standard data frames only. ids and masks <= 0x7FF. */
caekf_bxcan_status_t caekf_bxcan_filter_mask16(caekf_bxcan_regs_t *regs, unsigned bank, const uint16_t id[2],
                                               const uint16_t mask[2], unsigned fifo);
/* Deactivates `count` banks from `first_bank`. */
caekf_bxcan_status_t caekf_bxcan_filter_deactivate(caekf_bxcan_regs_t *regs, unsigned first_bank, unsigned count);

/* Non-blocking: copies the frame into the lowest free mailbox and requests transmission.
 * BUSY if no mailbox is free, ERR_BUS_OFF while bus-off, ERR_PARAM for a bad identifier or dlc > 8.
 * *mailbox (may be NULL) receives the mailbox used. */
caekf_bxcan_status_t caekf_bxcan_transmit(caekf_bxcan_t *can, const caekf_bxcan_frame_t *frame, unsigned *mailbox);

/* Non-blocking: reads the oldest message of FIFO 0 and releases it (RFOM0, in the same write that
 * clears FULL0/FOVR0 if they were seen; overruns are counted). EMPTY if nothing is pending. */
caekf_bxcan_status_t caekf_bxcan_receive(caekf_bxcan_t *can, caekf_bxcan_frame_t *frame);

/* Housekeeping, non-blocking: counts and acknowledges completed transmit requests (TSR.RQCPx),
 * tracks bus-off / error-passive entries. ERR_BUS_OFF while bus-off, else OK. */
caekf_bxcan_status_t caekf_bxcan_service(caekf_bxcan_t *can);

caekf_bxcan_status_t caekf_bxcan_error_state(const caekf_bxcan_t *can, caekf_bxcan_error_state_t *st);

/* Number of empty TX mailboxes (0..3). */
unsigned caekf_bxcan_free_mailboxes(const caekf_bxcan_t *can);

const char *caekf_bxcan_status_str(caekf_bxcan_status_t st);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_BXCAN_H */
