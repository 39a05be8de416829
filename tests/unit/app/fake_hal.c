#include "fake_hal.h"

#include <string.h>

#include "unity.h"

static int fake_receive(void *ctx, caekf_can_frame_t *frame)
{
    fake_hal_t *f = (fake_hal_t *)ctx;
    if (f->rx_errors_pending > 0) {
        f->rx_errors_pending--;
        return -5;
    }
    if (f->rx_count == 0u) {
        return 0;
    }
    *frame = f->rx[f->rx_head];
    f->rx_head = (f->rx_head + 1u) % FAKE_QUEUE_LEN;
    f->rx_count--;
    return 1;
}

static int fake_transmit(void *ctx, const caekf_can_frame_t *frame)
{
    fake_hal_t *f = (fake_hal_t *)ctx;
    if (f->tx_fail) {
        return -105;
    }
    TEST_ASSERT_TRUE_MESSAGE(f->tx_count < FAKE_QUEUE_LEN, "fake tx log full");
    f->tx[f->tx_count++] = *frame;
    return 0;
}

static uint32_t fake_now(void *ctx) { return ((fake_hal_t *)ctx)->now_us; }

void fake_hal_init(fake_hal_t *f, caekf_app_hal_t *hal)
{
    unsigned i;
    memset(f, 0, sizeof *f);
    f->now_us = 0xFFFFC000u; /* near the 32-bit wrap: time differences must survive it */
    for (i = 0; i < (unsigned)CAEKF_MSG_COUNT; i++) {
        (void)caekf_e2e_rx_init(&f->bench_rx[i]);
    }
    hal->ctx = f;
    hal->receive = fake_receive;
    hal->transmit = fake_transmit;
    hal->now_us = fake_now;
}

void fake_push(fake_hal_t *f, const caekf_can_frame_t *frame)
{
    TEST_ASSERT_TRUE_MESSAGE(f->rx_count < FAKE_QUEUE_LEN, "fake rx queue full");
    f->rx[(f->rx_head + f->rx_count) % FAKE_QUEUE_LEN] = *frame;
    f->rx_count++;
}

void fake_tx_clear(fake_hal_t *f) { f->tx_count = 0; }

void bench_send(fake_hal_t *f, caekf_msg_t msg, caekf_can_frame_t *frame)
{
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_seal(msg, f->bench_counter[msg], frame));
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_bus_id(msg, f->id_offset, &frame->id));
    f->bench_counter[msg] = (uint8_t)((f->bench_counter[msg] + 1u) & 0x0Fu);
    fake_push(f, frame);
}

void bench_value(fake_hal_t *f, caekf_msg_t msg, uint16_t step, double value)
{
    caekf_can_frame_t fr;
    TEST_ASSERT_TRUE(caekf_proto_encode_value(msg, step, value, fr.data) >= 0);
    bench_send(f, msg, &fr);
}

void bench_step(fake_hal_t *f, uint16_t step, double u, double y1, double y4)
{
    bench_value(f, CAEKF_MSG_BENCH_U, step, u);
    bench_value(f, CAEKF_MSG_BENCH_Y1, step, y1);
    bench_value(f, CAEKF_MSG_BENCH_Y4, step, y4);
}

void bench_param(fake_hal_t *f, unsigned param_id, int exp10, int64_t mantissa)
{
    caekf_can_frame_t fr;
    caekf_msg_param_t p;
    p.param_id = (uint8_t)param_id;
    p.param_exp10 = (int8_t)exp10;
    p.param_mantissa = mantissa;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_param(&p, fr.data));
    bench_send(f, CAEKF_MSG_CTRL_PARAM, &fr);
}

void bench_reset(fake_hal_t *f, unsigned n_params, unsigned token)
{
    caekf_can_frame_t fr;
    caekf_msg_reset_t r;
    r.n_params = (uint8_t)n_params;
    r.token = (uint8_t)token;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_reset(&r, fr.data));
    bench_send(f, CAEKF_MSG_CTRL_RESET, &fr);
}

void bench_status_req(fake_hal_t *f, unsigned token)
{
    caekf_can_frame_t fr;
    caekf_msg_status_req_t r;
    r.token = (uint8_t)token;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_encode_status_req(&r, fr.data));
    bench_send(f, CAEKF_MSG_CTRL_STATUS_REQ, &fr);
}

int fake_tx_find(const fake_hal_t *f, caekf_msg_t msg, unsigned nth)
{
    uint32_t id = 0;
    unsigned i;
    TEST_ASSERT_EQUAL_INT(CAEKF_PROTO_OK, caekf_proto_bus_id(msg, f->id_offset, &id));
    for (i = 0; i < f->tx_count; i++) {
        if (f->tx[i].id == id) {
            if (nth == 0u) {
                return (int)i;
            }
            nth--;
        }
    }
    return -1;
}

unsigned fake_tx_count(const fake_hal_t *f, caekf_msg_t msg)
{
    unsigned n = 0;
    while (fake_tx_find(f, msg, n) >= 0) {
        n++;
    }
    return n;
}

int fake_tx_e2e_ok(fake_hal_t *f, unsigned index)
{
    caekf_msg_t msg;
    const caekf_msg_info_t *info;
    const caekf_can_frame_t *fr = &f->tx[index];
    if (caekf_proto_msg_from_bus_id(fr->id, f->id_offset, &msg) != CAEKF_PROTO_OK ||
        caekf_proto_msg_info(msg, &info) != CAEKF_PROTO_OK) {
        return 0;
    }
    if (info->len > CAEKF_CAN_DLC) {
        return caekf_e2e_check_fd(&f->bench_rx[msg], info->data_id, 1, fr->data, fr->dlc, info->len, NULL) ==
               CAEKF_E2E_OK;
    }
    return caekf_e2e_check(&f->bench_rx[msg], info->data_id, 1, fr->data, fr->dlc, NULL) == CAEKF_E2E_OK;
}

int fake_tx_crc_ok(const fake_hal_t *f, unsigned index)
{
    caekf_msg_t msg;
    const caekf_msg_info_t *info;
    const caekf_can_frame_t *fr = &f->tx[index];
    uint8_t crc = 0;
    if (caekf_proto_msg_from_bus_id(fr->id, f->id_offset, &msg) != CAEKF_PROTO_OK ||
        caekf_proto_msg_info(msg, &info) != CAEKF_PROTO_OK) {
        return 0;
    }
    (void)caekf_e2e_crc(info->data_id, fr->data, &crc);
    return fr->dlc == CAEKF_CAN_DLC && crc == fr->data[0];
}
