/* EST_ACK and the EST_HEALTH counter pages. */
#include <stddef.h>

#include "app_internal.h"

void caekf_app_send_ack(caekf_app_t *app, uint8_t token, int8_t status, uint8_t bad_param, uint8_t n_params_rx)
{
    caekf_msg_ack_t a;
    caekf_can_frame_t f;
    a.token = token;
    a.ack_status = status;
    a.bad_param = bad_param;
    a.n_params_rx = n_params_rx;
    a.state =
        (uint8_t)((app->configured ? CAEKF_ACK_STATE_CONFIGURED : 0u) | (app->staging ? CAEKF_ACK_STATE_STAGED : 0u));
    (void)caekf_proto_encode_ack(&a, f.data);
    caekf_app_send(app, CAEKF_MSG_EST_ACK, &f);
}

void caekf_app_send_health(caekf_app_t *app)
{
    unsigned page;
    for (page = 0; page < (unsigned)CAEKF_HEALTH_PAGES; page++) {
        caekf_msg_health_t h;
        caekf_can_frame_t f;
        h.page = (uint8_t)page;
        /* Read both counters first: sending this page changes TX_FRAMES. */
        h.counter_a = app->counters[2u * page];
        h.counter_b = app->counters[2u * page + 1u];
        (void)caekf_proto_encode_health(&h, f.data);
        caekf_app_send(app, CAEKF_MSG_EST_HEALTH, &f);
    }
}

void caekf_app_handle_status_req(caekf_app_t *app, const uint8_t data[CAEKF_CAN_DLC])
{
    caekf_msg_status_req_t r;
    (void)caekf_proto_decode_status_req(data, &r);
    caekf_app_count(app, CAEKF_CNT_RX_OK, 1u);
    caekf_app_count(app, CAEKF_CNT_STATUS_REQUESTS, 1u);
    caekf_app_send_ack(app, r.token, (int8_t)CAEKF_ACK_STATUS, (uint8_t)CAEKF_ACK_BAD_PARAM_NONE,
                       app->staging ? app->staged_count : 0u);
    caekf_app_send_health(app);
    app->page_phase = 0u; /* PRODUCTION: every EST_PAGE over the next CAEKF_PAGE_COUNT steps */
}
