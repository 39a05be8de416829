/* What every part of the app shares: its counters (EST_HEALTH's) and its transmit path (E2E seal, the bus ID
 * offset, the HAL, the transmit counters). */
#include <stddef.h>

#include "app_internal.h"

void caekf_app_count(caekf_app_t *app, unsigned counter_id, uint32_t n)
{
    if (counter_id < (unsigned)CAEKF_CNT_COUNT) {
        app->counters[counter_id] += n;
    }
}

void caekf_app_send(caekf_app_t *app, caekf_msg_t msg, caekf_can_frame_t *frame)
{
    (void)caekf_proto_seal(msg, app->tx_counter[msg], frame);
    frame->id = (uint32_t)((int32_t)frame->id + app->cfg.id_offset); /* valid: checked at init */
    app->tx_counter[msg] = (uint8_t)((app->tx_counter[msg] + 1u) & CAEKF_E2E_COUNTER_MASK);
    if (app->hal.transmit(app->hal.ctx, frame) < 0) {
        caekf_app_count(app, CAEKF_CNT_TX_ERRORS, 1u);
    } else {
        caekf_app_count(app, CAEKF_CNT_TX_FRAMES, 1u);
    }
}

caekf_app_status_t caekf_app_counter(const caekf_app_t *app, unsigned counter_id, uint32_t *value)
{
    if (app == NULL || value == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    if (counter_id >= (unsigned)CAEKF_CNT_COUNT) {
        return CAEKF_APP_ERR_PARAM;
    }
    *value = app->counters[counter_id];
    return CAEKF_APP_OK;
}
