/* An in-memory HAL and a scripted bench for the app tests: no sockets, time set by the test. */
#ifndef CAEKF_TEST_FAKE_HAL_H
#define CAEKF_TEST_FAKE_HAL_H

#include "caekf/caekf_app.h"

#define FAKE_QUEUE_LEN 256u

typedef struct {
    caekf_can_frame_t rx[FAKE_QUEUE_LEN]; /* frames waiting for the app */
    unsigned rx_head, rx_count;
    caekf_can_frame_t tx[FAKE_QUEUE_LEN]; /* frames the app sent */
    unsigned tx_count;
    uint32_t now_us;
    int rx_errors_pending; /* receive() fails this many times first */
    int tx_fail;           /* transmit() fails while set */
    uint8_t bench_counter[CAEKF_MSG_COUNT];
    caekf_e2e_rx_t bench_rx[CAEKF_MSG_COUNT]; /* the bench's check of what the app sends */
    int32_t id_offset;                        /* the bench's runtime CAN ID base (caekf_app_config_t.id_offset) */
} fake_hal_t;

void fake_hal_init(fake_hal_t *f, caekf_app_hal_t *hal);
void fake_push(fake_hal_t *f, const caekf_can_frame_t *frame);
void fake_tx_clear(fake_hal_t *f);

/* Bench side: encode, seal with the bench's next alive counter, queue for the app. */
void bench_send(fake_hal_t *f, caekf_msg_t msg, caekf_can_frame_t *frame);
void bench_value(fake_hal_t *f, caekf_msg_t msg, uint16_t step, double value);
void bench_step(fake_hal_t *f, uint16_t step, double u, double y1, double y4);
void bench_param(fake_hal_t *f, unsigned param_id, int exp10, int64_t mantissa);
void bench_reset(fake_hal_t *f, unsigned n_params, unsigned token);
void bench_status_req(fake_hal_t *f, unsigned token);

/* Index of the i-th transmitted frame of `msg` (0-based), or -1. */
int fake_tx_find(const fake_hal_t *f, caekf_msg_t msg, unsigned nth);
/* Count of transmitted frames of `msg`. */
unsigned fake_tx_count(const fake_hal_t *f, caekf_msg_t msg);
/* E2E-checks a transmitted frame as the bench would, counter continuity included: check each frame once. */
int fake_tx_e2e_ok(fake_hal_t *f, unsigned index);
/* DLC and CRC of a transmitted frame only (stateless). */
int fake_tx_crc_ok(const fake_hal_t *f, unsigned index);

#endif
