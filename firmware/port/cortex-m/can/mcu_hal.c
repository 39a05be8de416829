/* The app HAL over bxCAN and the firmware wiring: see mcu_hal.h. */
#include "mcu_hal.h"

#include <stddef.h>
#include <string.h>

#define EXT_ID_MASK 0x1FFFFFFFu

int caekf_mcu_hal_init(caekf_mcu_hal_t *h, caekf_bxcan_t *can, caekf_mcu_now_fn_t now, void *now_ctx)
{
    /* cppcheck-suppress unassignedVariable ; static storage: all zero, the value it stands for */
    static const caekf_mcu_hal_counters_t zero;
    if (h == NULL || can == NULL || now == NULL) {
        return -1;
    }
    h->can = can;
    h->now = now;
    h->now_ctx = now_ctx;
    h->txq_head = 0u;
    h->txq_count = 0u;
    h->cnt = zero;
    return 0;
}

static void to_driver(const caekf_can_frame_t *in, caekf_bxcan_frame_t *out)
{
    out->ide = (uint8_t)((in->id & CAEKF_CAN_ID_EXT_FLAG) != 0u);
    out->id = out->ide ? (in->id & EXT_ID_MASK) : in->id;
    out->rtr = 0u;
    out->dlc = in->dlc;
    out->fmi = 0u;
    out->time = 0u;
    memcpy(out->data, in->data, sizeof out->data);
}

/* Queue -> mailboxes, oldest first; stops at the first BUSY (or bus-off: the frames wait). */
static void drain(caekf_mcu_hal_t *h)
{
    unsigned n;
    for (n = 0u; n < CAEKF_MCU_TXQ_LEN && h->txq_count > 0u; n++) {
        caekf_bxcan_frame_t fr;
        caekf_bxcan_status_t st;
        to_driver(&h->txq[h->txq_head], &fr);
        st = caekf_bxcan_transmit(h->can, &fr, NULL);
        if (st == CAEKF_BXCAN_BUSY || st == CAEKF_BXCAN_ERR_BUS_OFF) {
            return;
        }
        if (st != CAEKF_BXCAN_OK) {
            h->cnt.tx_errors++; /* cannot happen for validated frames: dropped, not retried */
        }
        h->txq_head = (h->txq_head + 1u) % CAEKF_MCU_TXQ_LEN;
        h->txq_count--;
    }
}

static int hal_receive(void *ctx, caekf_can_frame_t *out)
{
    caekf_mcu_hal_t *h = (caekf_mcu_hal_t *)ctx;
    caekf_bxcan_frame_t fr;
    caekf_bxcan_status_t st = caekf_bxcan_receive(h->can, &fr);
    if (st == CAEKF_BXCAN_EMPTY) {
        return 0;
    }
    if (st != CAEKF_BXCAN_OK) {
        h->cnt.rx_errors++;
        return (int)st;
    }
    if (fr.rtr) {
        h->cnt.rx_rtr++;
        return CAEKF_MCU_HAL_ERR_RTR;
    }
    out->id = fr.ide ? (fr.id | CAEKF_CAN_ID_EXT_FLAG) : fr.id;
    out->dlc = (uint8_t)(fr.dlc > CAEKF_CAN_DLC ? CAEKF_CAN_DLC : fr.dlc);
    memcpy(out->data, fr.data, sizeof fr.data);
    return 1;
}

/* Every frame goes through the queue (order by construction, even if a mailbox frees up between two
 * register reads), then as many as fit move into the mailboxes. */
static int hal_transmit(void *ctx, const caekf_can_frame_t *frame)
{
    caekf_mcu_hal_t *h = (caekf_mcu_hal_t *)ctx;
    caekf_bxcan_error_state_t es;
    if (frame->dlc > CAEKF_CAN_DLC) {
        h->cnt.tx_errors++;
        return CAEKF_MCU_HAL_ERR_DLC;
    }
    if (caekf_bxcan_error_state(h->can, &es) != CAEKF_BXCAN_OK || es.bus_off) {
        h->cnt.tx_errors++; /* bus-off: refused (queued frames wait for the recovery) */
        return CAEKF_BXCAN_ERR_BUS_OFF;
    }
    drain(h);
    if (h->txq_count >= CAEKF_MCU_TXQ_LEN) {
        h->cnt.tx_queue_full++;
        return CAEKF_MCU_HAL_ERR_TXQ_FULL;
    }
    h->txq[(h->txq_head + h->txq_count) % CAEKF_MCU_TXQ_LEN] = *frame;
    h->txq_count++;
    drain(h);
    if (h->txq_count > 0u) { /* the new frame is the last in the queue: it waits */
        h->cnt.tx_queued++;
        if (h->txq_count > h->cnt.txq_high_water) {
            h->cnt.txq_high_water = h->txq_count;
        }
    }
    return 0;
}

static uint32_t hal_now_us(void *ctx)
{
    caekf_mcu_hal_t *h = (caekf_mcu_hal_t *)ctx;
    return h->now(h->now_ctx);
}

void caekf_mcu_hal_bind(caekf_mcu_hal_t *h, caekf_app_hal_t *hal)
{
    if (h == NULL || hal == NULL) {
        return;
    }
    hal->ctx = h;
    hal->receive = hal_receive;
    hal->transmit = hal_transmit;
    hal->now_us = hal_now_us;
}

caekf_bxcan_status_t caekf_mcu_hal_service(caekf_mcu_hal_t *h)
{
    if (h == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    drain(h);
    return caekf_bxcan_service(h->can);
}

unsigned caekf_mcu_hal_rx_ids(int32_t id_offset, uint16_t *ids, unsigned max)
{
    unsigned m, n = 0u;
    for (m = 0u; m < (unsigned)CAEKF_MSG_COUNT; m++) {
        const caekf_msg_info_t *info;
        uint32_t id = 0u;
        if (caekf_proto_msg_info((caekf_msg_t)m, &info) != CAEKF_PROTO_OK || info->dir != CAEKF_DIR_TO_ESTIMATOR ||
            caekf_proto_bus_id((caekf_msg_t)m, id_offset, &id) != CAEKF_PROTO_OK) {
            continue;
        }
        if (ids != NULL && n < max) {
            ids[n] = (uint16_t)id;
        }
        n++;
    }
    return n;
}

caekf_bxcan_status_t caekf_mcu_hal_program_filters(caekf_bxcan_regs_t *filter_regs, unsigned first_bank,
                                                   int32_t id_offset, unsigned *banks_used)
{
    uint16_t ids[CAEKF_MSG_COUNT];
    unsigned n = caekf_mcu_hal_rx_ids(id_offset, ids, (unsigned)CAEKF_MSG_COUNT);
    return caekf_bxcan_filter_list16(filter_regs, first_bank, ids, n, 0u, banks_used);
}

/* ---- firmware wiring ------------------------------------------------------------------------- */

caekf_mcu_status_t caekf_mcu_fw_config_default(caekf_mcu_fw_config_t *cfg)
{
    if (cfg == NULL) {
        return CAEKF_MCU_ERR_NULL;
    }
    cfg->regs = NULL;
    cfg->filter_regs = NULL;
    cfg->first_filter_bank = 0u;
    (void)caekf_bxcan_config_default(&cfg->can);
    cfg->now = NULL;
    cfg->now_ctx = NULL;
    (void)caekf_app_config_default(&cfg->app);
    return CAEKF_MCU_OK;
}

caekf_mcu_status_t caekf_mcu_fw_init(caekf_mcu_fw_t *fw, const caekf_mcu_fw_config_t *cfg)
{
    caekf_app_hal_t hal;
    if (fw == NULL || cfg == NULL || cfg->regs == NULL || cfg->now == NULL) {
        return CAEKF_MCU_ERR_NULL;
    }
    fw->app_status = CAEKF_APP_OK;
    fw->filter_banks = 0u;
    fw->can_status = caekf_bxcan_init(&fw->can, cfg->regs, &cfg->can);
    if (fw->can_status != CAEKF_BXCAN_OK) {
        return CAEKF_MCU_ERR_CAN;
    }
    fw->can_status = caekf_mcu_hal_program_filters(cfg->filter_regs != NULL ? cfg->filter_regs : cfg->regs,
                                                   cfg->first_filter_bank, cfg->app.id_offset, &fw->filter_banks);
    if (fw->can_status != CAEKF_BXCAN_OK) {
        return CAEKF_MCU_ERR_FILTER;
    }
    (void)caekf_mcu_hal_init(&fw->hal, &fw->can, cfg->now, cfg->now_ctx);
    caekf_mcu_hal_bind(&fw->hal, &hal);
    fw->app_status = caekf_app_init(&fw->app, &hal, &cfg->app);
    if (fw->app_status != CAEKF_APP_OK) {
        return CAEKF_MCU_ERR_APP;
    }
    return CAEKF_MCU_OK;
}

caekf_app_status_t caekf_mcu_fw_poll(caekf_mcu_fw_t *fw)
{
    caekf_app_status_t st;
    if (fw == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    (void)caekf_mcu_hal_service(&fw->hal);
    st = caekf_app_poll(&fw->app);
    (void)caekf_mcu_hal_service(&fw->hal);
    return st;
}

const char *caekf_mcu_status_str(caekf_mcu_status_t st)
{
    switch (st) {
    case CAEKF_MCU_OK: return "ok";
    case CAEKF_MCU_ERR_NULL: return "null pointer";
    case CAEKF_MCU_ERR_CAN: return "CAN controller init failed";
    case CAEKF_MCU_ERR_FILTER: return "CAN filter programming failed";
    case CAEKF_MCU_ERR_APP: return "app init failed";
    }
    return "unknown";
}
