/* Configuration over CAN: CTRL_PARAM stages settings, CTRL_RESET commits them (or refuses them and
 * keeps the running configuration), EST_ACK answers. */
#include <stddef.h>

#include "app_internal.h"

static void stage_error(caekf_app_t *app, uint8_t param_id)
{
    if (app->staged_error == 0) { /* report the first problem: later ones are often its echo */
        app->staged_error = (int8_t)CAEKF_ACK_REFUSED_PARAM;
        app->staged_bad_param = param_id;
    }
}

void caekf_app_handle_param(caekf_app_t *app, const uint8_t data[CAEKF_CAN_DLC])
{
    caekf_msg_param_t m;
    double value;
    (void)caekf_proto_decode_param(data, &m);
    if (!app->staging) {
        if (app->configured != 0u) {
            app->staged = app->active;
        } else {
            (void)caekf_app_settings_default(&app->staged);
        }
        app->staging = 1;
        app->staged_count = 0;
        app->staged_error = 0;
        app->staged_bad_param = (uint8_t)CAEKF_ACK_BAD_PARAM_NONE;
    }
    if (app->staged_count < 255u) {
        app->staged_count++;
    }
    if (caekf_proto_param_value(&m, &value) != CAEKF_PROTO_OK || m.param_id >= (uint8_t)CAEKF_PARAM_COUNT) {
        caekf_app_count(app, CAEKF_CNT_RX_BAD_VALUE, 1u);
        stage_error(app, m.param_id);
        return;
    }
    caekf_app_count(app, CAEKF_CNT_RX_OK, 1u);
    caekf_app_count(app, CAEKF_CNT_PARAMS_RX, 1u);
    if (caekf_app_settings_set(&app->staged, m.param_id, value) != CAEKF_APP_OK) {
        stage_error(app, m.param_id);
    }
}

static int8_t commit(caekf_app_t *app, const caekf_msg_reset_t *r, uint8_t *bad_param)
{
    const uint8_t received = app->staging ? app->staged_count : 0u;
    caekf_app_status_t st;
    *bad_param = (uint8_t)CAEKF_ACK_BAD_PARAM_NONE;
    if (app->staging && app->staged_error != 0) {
        *bad_param = app->staged_bad_param;
        return app->staged_error;
    }
    if (r->n_params != received) {
        return (int8_t)CAEKF_ACK_REFUSED_INCOMPLETE; /* a CTRL_PARAM frame was lost or rejected */
    }
    if (received == 0u && !app->configured) {
        return (int8_t)CAEKF_ACK_REFUSED_NO_SETTINGS;
    }
    st = caekf_app_configure(app, received ? &app->staged : &app->active, bad_param);
    if (st == CAEKF_APP_OK) {
        return (int8_t)CAEKF_ACK_ACCEPTED;
    }
    return (int8_t)((st == CAEKF_APP_ERR_INIT) ? CAEKF_ACK_REFUSED_INIT : CAEKF_ACK_REFUSED_SETTINGS);
}

void caekf_app_handle_reset(caekf_app_t *app, const uint8_t data[CAEKF_CAN_DLC])
{
    caekf_msg_reset_t r;
    uint8_t bad_param;
    int8_t status;
    uint8_t received;
    (void)caekf_proto_decode_reset(data, &r);
    caekf_app_count(app, CAEKF_CNT_RX_OK, 1u);
    received = app->staging ? app->staged_count : 0u;
    status = commit(app, &r, &bad_param);
    app->staging = 0; /* accepted or not, the staged values are spent */
    caekf_app_count(app, (status == (int8_t)CAEKF_ACK_ACCEPTED) ? CAEKF_CNT_CFG_ACCEPTED : CAEKF_CNT_CFG_REFUSED, 1u);
    caekf_app_send_ack(app, r.token, status, bad_param, received);
}

caekf_app_status_t caekf_app_configure(caekf_app_t *app, const caekf_app_settings_t *settings, uint8_t *bad_param)
{
    caekf_setting_error_t err;
    if (bad_param != NULL) {
        *bad_param = (uint8_t)CAEKF_ACK_BAD_PARAM_NONE;
    }
    if (app == NULL || settings == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    if (app->init_magic != CAEKF_APP_MAGIC) {
        return CAEKF_APP_ERR_CONFIG;
    }
    /* settings may be app->staged or app->active: read only, and copied last (an exact overlap) */
    if (caekf_settings_validate(&settings->est, &err) != CAEKF_OK) {
        if (bad_param != NULL) {
            *bad_param = err.param_id;
        }
        return CAEKF_APP_ERR_SETTINGS;
    }
    if (caekf_init(&app->est, &settings->est) != CAEKF_OK) {
        return CAEKF_APP_ERR_INIT;
    }
    if (settings != &app->active) {
        app->active = *settings;
    }
    app->configured = 1;
    caekf_app_assembly_reset(app);
    return CAEKF_APP_OK;
}
