/* Functions shared by the app's source files. Not part of the public API. */
#ifndef CAEKF_APP_INTERNAL_H
#define CAEKF_APP_INTERNAL_H

#include "caekf/caekf_app.h"

#define CAEKF_APP_MAGIC 0xCAEF0A99u

/* Adds n to a counter (wraps modulo 2^32, like PX4's perf counters). */
void caekf_app_count(caekf_app_t *app, unsigned counter_id, uint32_t n);

/* Seals (ID, DLC, alive counter, CRC) and transmits; counts TX_FRAMES or TX_ERRORS. */
void caekf_app_send(caekf_app_t *app, caekf_msg_t msg, caekf_can_frame_t *frame);

/* Step assembly (app_assembly.c). */
void caekf_app_assembly_reset(caekf_app_t *app);
void caekf_app_assembly_input(caekf_app_t *app, caekf_msg_t msg, const uint8_t data[CAEKF_CAN_FD_MAX_LEN],
                              uint32_t now_us);
void caekf_app_assembly_timeout(caekf_app_t *app, uint32_t now_us);

/* The estimate frames of one step (app_output.c). */
void caekf_app_send_estimate(caekf_app_t *app, uint16_t step, caekf_status_t status, const caekf_report_t *report,
                             uint16_t app_flags);

/* Configuration frames (app_config.c). */
void caekf_app_handle_param(caekf_app_t *app, const uint8_t data[CAEKF_CAN_DLC]);
void caekf_app_handle_reset(caekf_app_t *app, const uint8_t data[CAEKF_CAN_DLC]);

/* Acknowledgements and health (app_health.c). */
void caekf_app_send_ack(caekf_app_t *app, uint8_t token, int8_t status, uint8_t bad_param, uint8_t n_params_rx);
void caekf_app_handle_status_req(caekf_app_t *app, const uint8_t data[CAEKF_CAN_DLC]);
void caekf_app_send_health(caekf_app_t *app);

#endif /* CAEKF_APP_INTERNAL_H */
