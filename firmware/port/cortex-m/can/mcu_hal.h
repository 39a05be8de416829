/*
 * mcu_hal.h - the MCU side of the caekf app HAL (firmware/app/include/caekf/caekf_app.h) over the
 * bxCAN driver, and the wiring of the firmware image (driver + filters + HAL + app).
 *
 *   receive   -> caekf_bxcan_receive (FIFO 0); standard IDs as they are, extended IDs with
 *                CAEKF_CAN_ID_EXT_FLAG (the app counts them as unknown), DLC 9..15 as 8 (like
 *                SocketCAN), remote frames refused with CAEKF_MCU_HAL_ERR_RTR (the filters keep
 *                them out anyway);
 *   transmit  -> a software queue of CAEKF_MCU_TXQ_LEN frames, drained in order into the free
 *                mailboxes at once and by caekf_mcu_hal_service() / later transmits: the app sends
 *                12 frames per step in one poll and bxCAN has only 3 mailboxes. Order is kept
 *                (one queue, mailboxes in chronological TXFP mode). Refused while bus-off;
 *   now_us    -> any monotonic microsecond source (us_clock.h: SysTick on the MCU).
 *
 * The receive filters are the protocol's own list: every message of the table with direction
 * "to estimator" (caekf_proto_msg_info), programmed as 11-bit identifier lists.
 */
#ifndef CAEKF_MCU_HAL_H
#define CAEKF_MCU_HAL_H

#include <stdint.h>

#include "bxcan.h"
#include "caekf/caekf_app.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CAEKF_MCU_TXQ_LEN 32u

#define CAEKF_MCU_HAL_ERR_RTR (-20)      /* receive: a remote frame */
#define CAEKF_MCU_HAL_ERR_TXQ_FULL (-21) /* transmit: mailboxes and queue full */
#define CAEKF_MCU_HAL_ERR_DLC (-22)      /* transmit: dlc > 8 */

typedef uint32_t (*caekf_mcu_now_fn_t)(void *ctx);

typedef struct {
    uint32_t rx_rtr;         /* remote frames refused */
    uint32_t rx_errors;      /* driver errors on receive */
    uint32_t tx_queued;      /* frames that waited in the software queue */
    uint32_t tx_queue_full;  /* frames refused: queue full */
    uint32_t tx_errors;      /* frames refused or dropped by the driver (bus-off, bad frame) */
    uint32_t txq_high_water; /* most frames ever waiting */
} caekf_mcu_hal_counters_t;

typedef struct {
    caekf_bxcan_t *can;
    caekf_mcu_now_fn_t now;
    void *now_ctx;
    caekf_can_frame_t txq[CAEKF_MCU_TXQ_LEN];
    unsigned txq_head, txq_count;
    caekf_mcu_hal_counters_t cnt;
} caekf_mcu_hal_t;

/* 0, or -1 for a NULL argument. The driver must be initialised before frames move. */
int caekf_mcu_hal_init(caekf_mcu_hal_t *h, caekf_bxcan_t *can, caekf_mcu_now_fn_t now, void *now_ctx);
/* Fills the app's HAL: ctx = h, receive / transmit / now_us adapters. */
void caekf_mcu_hal_bind(caekf_mcu_hal_t *h, caekf_app_hal_t *hal);
/* Moves queued frames into free mailboxes (in order), then caekf_bxcan_service. Returns the
 * driver's status (OK, ERR_BUS_OFF, ...). Call once per main-loop pass, before and after the poll. */
caekf_bxcan_status_t caekf_mcu_hal_service(caekf_mcu_hal_t *h);

/* The CAN IDs the estimator receives at the runtime ID base id_offset (caekf_app_config_t.id_offset), in
 * table order: writes min(n, max) IDs, returns n (0 for an invalid offset). */
unsigned caekf_mcu_hal_rx_ids(int32_t id_offset, uint16_t *ids, unsigned max);
/* Programs those IDs as 16-bit identifier lists for FIFO 0 from `first_bank` of the master
 * instance `filter_regs`. */
caekf_bxcan_status_t caekf_mcu_hal_program_filters(caekf_bxcan_regs_t *filter_regs, unsigned first_bank,
                                                   int32_t id_offset, unsigned *banks_used);

/* ---- the firmware: driver + filters + HAL + app ---- */
typedef enum {
    CAEKF_MCU_OK = 0,
    CAEKF_MCU_ERR_NULL = -1,
    CAEKF_MCU_ERR_CAN = -2,    /* caekf_bxcan_init failed: fw->can_status */
    CAEKF_MCU_ERR_FILTER = -3, /* filter programming failed: fw->can_status */
    CAEKF_MCU_ERR_APP = -4     /* caekf_app_init failed: fw->app_status */
} caekf_mcu_status_t;

typedef struct {
    caekf_bxcan_regs_t *regs;        /* the controller */
    caekf_bxcan_regs_t *filter_regs; /* the master instance holding the filter banks (CAN1) */
    unsigned first_filter_bank;
    caekf_bxcan_config_t can;
    caekf_mcu_now_fn_t now;
    void *now_ctx;
    caekf_app_config_t app;
} caekf_mcu_fw_config_t;

typedef struct {
    caekf_bxcan_t can;
    caekf_mcu_hal_t hal;
    caekf_app_t app;
    caekf_bxcan_status_t can_status;
    caekf_app_status_t app_status;
    unsigned filter_banks;
} caekf_mcu_fw_t;

/* Driver defaults (timing still to be set), app defaults, filters from bank 0; regs and now NULL. */
caekf_mcu_status_t caekf_mcu_fw_config_default(caekf_mcu_fw_config_t *cfg);
/* Driver init, filters, HAL, app init (the app starts unconfigured: CTRL_PARAM / CTRL_RESET). */
caekf_mcu_status_t caekf_mcu_fw_init(caekf_mcu_fw_t *fw, const caekf_mcu_fw_config_t *cfg);
/* One main-loop pass: service, caekf_app_poll, service. Returns the app's status. */
caekf_app_status_t caekf_mcu_fw_poll(caekf_mcu_fw_t *fw);

const char *caekf_mcu_status_str(caekf_mcu_status_t st);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_MCU_HAL_H */
