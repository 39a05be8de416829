/* The app's life cycle and its receive path: HAL -> E2E check -> dispatch by message. */
#include <stddef.h>
#include <string.h>

#include "app_internal.h"

#define DEFAULT_STEP_TIMEOUT_US 20000u
#define DEFAULT_STATUS_PERIOD_US 1000000u
#define DEFAULT_E2E_RESYNC_US 500000u
#define DEFAULT_E2E_MAX_DELTA 1u
#define DEFAULT_MAX_FRAMES_PER_POLL 64u
#define DEFAULT_PAGE_PERIOD_STEPS 20u

caekf_app_status_t caekf_app_config_default(caekf_app_config_t *cfg)
{
    if (cfg == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    cfg->step_timeout_us = DEFAULT_STEP_TIMEOUT_US;
    cfg->status_period_us = DEFAULT_STATUS_PERIOD_US;
    cfg->e2e_resync_us = DEFAULT_E2E_RESYNC_US;
    cfg->e2e_max_delta = DEFAULT_E2E_MAX_DELTA;
    cfg->max_frames_per_poll = DEFAULT_MAX_FRAMES_PER_POLL;
    cfg->profile = (uint8_t)CAEKF_PROFILE_DIAGNOSTICS;
    cfg->page_period_steps = DEFAULT_PAGE_PERIOD_STEPS;
    cfg->id_offset = 0;
    return CAEKF_APP_OK;
}

caekf_app_status_t caekf_app_init(caekf_app_t *app, const caekf_app_hal_t *hal, const caekf_app_config_t *cfg)
{
    unsigned i;
    if (app == NULL || hal == NULL || cfg == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    if (hal->receive == NULL || hal->transmit == NULL || hal->now_us == NULL || cfg->e2e_max_delta < 1u ||
        cfg->e2e_max_delta > 15u || cfg->max_frames_per_poll < 1u || cfg->step_timeout_us == 0u ||
        cfg->profile >= (uint8_t)CAEKF_PROFILE_COUNT ||
        (cfg->page_period_steps != 0u && cfg->page_period_steps < CAEKF_PAGE_COUNT) ||
        caekf_proto_id_offset_check(cfg->id_offset) != CAEKF_PROTO_OK) {
        return CAEKF_APP_ERR_CONFIG;
    }
    (void)memset(app, 0, sizeof *app);
    app->hal = *hal;
    app->cfg = *cfg;
    app->staged_bad_param = (uint8_t)CAEKF_ACK_BAD_PARAM_NONE;
    app->page_phase = (cfg->page_period_steps == 0u) ? (uint16_t)CAEKF_PAGE_COUNT : 0u;
    for (i = 0; i < (unsigned)CAEKF_MSG_COUNT; i++) {
        (void)caekf_e2e_rx_init(&app->rx[i]);
    }
    app->last_status_us = hal->now_us(hal->ctx);
    app->init_magic = CAEKF_APP_MAGIC;
    return CAEKF_APP_OK;
}

/* E2E check of a bench frame; returns 1 when the frame may be used. */
static int e2e_accept(caekf_app_t *app, caekf_msg_t msg, const caekf_msg_info_t *info, const caekf_can_frame_t *f,
                      uint32_t now_us)
{
    uint8_t lost = 0;
    caekf_e2e_status_t st;
    if (app->rx[msg].synced && (uint32_t)(now_us - app->rx_last_us[msg]) > app->cfg.e2e_resync_us) {
        (void)caekf_e2e_rx_init(&app->rx[msg]); /* the sender went quiet (e.g. a new bench run) */
    }
    st = (info->len > CAEKF_CAN_DLC)
             ? caekf_e2e_check_fd(&app->rx[msg], info->data_id, app->cfg.e2e_max_delta, f->data, f->dlc, info->len,
                                  &lost)
             : caekf_e2e_check(&app->rx[msg], info->data_id, app->cfg.e2e_max_delta, f->data, f->dlc, &lost);
    if (st != CAEKF_E2E_ERR_DLC && st != CAEKF_E2E_ERR_CRC) {
        app->rx_last_us[msg] = now_us;
    }
    switch (st) {
    case CAEKF_E2E_OK: caekf_app_count(app, CAEKF_CNT_RX_LOST, lost); return 1;
    case CAEKF_E2E_ERR_DLC: caekf_app_count(app, CAEKF_CNT_RX_BAD_DLC, 1u); break;
    case CAEKF_E2E_ERR_CRC: caekf_app_count(app, CAEKF_CNT_RX_BAD_CRC, 1u); break;
    case CAEKF_E2E_ERR_DUPLICATE: caekf_app_count(app, CAEKF_CNT_RX_DUPLICATE, 1u); break;
    default: caekf_app_count(app, CAEKF_CNT_RX_COUNTER_JUMP, 1u); break;
    }
    return 0;
}

static void handle_frame(caekf_app_t *app, const caekf_can_frame_t *f, uint32_t now_us)
{
    caekf_msg_t msg;
    const caekf_msg_info_t *info;
    if (caekf_proto_msg_from_bus_id(f->id, app->cfg.id_offset, &msg) != CAEKF_PROTO_OK ||
        caekf_proto_msg_info(msg, &info) != CAEKF_PROTO_OK || info->dir != (uint8_t)CAEKF_DIR_TO_ESTIMATOR) {
        caekf_app_count(app, CAEKF_CNT_RX_UNKNOWN_ID, 1u);
        return;
    }
    if (!e2e_accept(app, msg, info, f, now_us)) {
        return;
    }
    switch (info->layout) {
    case CAEKF_LAYOUT_PARAM: caekf_app_handle_param(app, f->data); break;
    case CAEKF_LAYOUT_RESET: caekf_app_handle_reset(app, f->data); break;
    case CAEKF_LAYOUT_STATUS_REQ: caekf_app_handle_status_req(app, f->data); break;
    default: caekf_app_assembly_input(app, msg, f->data, now_us); break;
    }
}

caekf_app_status_t caekf_app_poll(caekf_app_t *app)
{
    unsigned n;
    uint32_t now_us;
    if (app == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    if (app->init_magic != CAEKF_APP_MAGIC) {
        return CAEKF_APP_ERR_CONFIG;
    }
    now_us = app->hal.now_us(app->hal.ctx);
    caekf_app_assembly_timeout(app, now_us);
    for (n = 0; n < app->cfg.max_frames_per_poll; n++) {
        caekf_can_frame_t f;
        int got = app->hal.receive(app->hal.ctx, &f);
        if (got == 0) {
            break;
        }
        if (got < 0) {
            caekf_app_count(app, CAEKF_CNT_RX_HAL_ERROR, 1u);
            break;
        }
        now_us = app->hal.now_us(app->hal.ctx);
        handle_frame(app, &f, now_us);
    }
    caekf_app_assembly_timeout(app, now_us);
    if (app->cfg.status_period_us != 0u && (uint32_t)(now_us - app->last_status_us) >= app->cfg.status_period_us) {
        app->last_status_us = now_us;
        caekf_app_send_health(app);
    }
    return CAEKF_APP_OK;
}

const char *caekf_app_status_str(caekf_app_status_t st)
{
    switch (st) {
    case CAEKF_APP_OK: return "ok";
    case CAEKF_APP_ERR_NULL: return "null pointer";
    case CAEKF_APP_ERR_CONFIG: return "app configuration or HAL incomplete";
    case CAEKF_APP_ERR_SETTINGS: return "estimator settings refused";
    case CAEKF_APP_ERR_PARAM: return "bad parameter";
    case CAEKF_APP_ERR_INIT: return "estimator initialisation failed";
    default: return "unknown status";
    }
}
