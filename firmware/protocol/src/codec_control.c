/* Codec of the control frames: CTRL_RESET, CTRL_PARAM, CTRL_STATUS_REQ, EST_ACK, EST_HEALTH. */
#include <stddef.h>
#include <string.h>

#include "bitfield.h"
#include "caekf/caekf_proto.h"
#include "caekf_proto_frames_table.h" /* the fields' positions: generated from caekf.dbc */

#define EXP10_MAX 22 /* 10^22 is the largest power of ten a double holds exactly */
/* Every EST_HEALTH page carries its two counters where page 0 has RX_OK and RX_UNKNOWN_ID (the generator
 * checks it). */
#define HEALTH_LOWER CAEKF_FIELD_EST_HEALTH_RX_OK
#define HEALTH_UPPER CAEKF_FIELD_EST_HEALTH_RX_UNKNOWN_ID

caekf_proto_status_t caekf_proto_encode_reset(const caekf_msg_reset_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    memset(data, 0, CAEKF_CAN_DLC);
    caekf_bits_put(data, CAEKF_FIELD_CTRL_RESET_N_PARAMS, m->n_params);
    caekf_bits_put(data, CAEKF_FIELD_CTRL_RESET_TOKEN, m->token);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_reset(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_reset_t *m)
{
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    m->n_params = (uint8_t)caekf_bits_get(data, CAEKF_FIELD_CTRL_RESET_N_PARAMS);
    m->token = (uint8_t)caekf_bits_get(data, CAEKF_FIELD_CTRL_RESET_TOKEN);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_encode_param(const caekf_msg_param_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    const int64_t mant_max = (int64_t)(((uint64_t)1u << (CAEKF_BITS_CTRL_PARAM_PARAM_MANTISSA - 1u)) - 1u);
    const int exp_max = (1 << (CAEKF_BITS_CTRL_PARAM_PARAM_EXP10 - 1u)) - 1;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (m->mantissa > mant_max || m->mantissa < -mant_max - 1 || m->exp10 > exp_max || m->exp10 < -exp_max - 1) {
        return CAEKF_PROTO_ERR_RANGE;
    }
    memset(data, 0, CAEKF_CAN_DLC);
    caekf_bits_put(data, CAEKF_FIELD_CTRL_PARAM_PARAM_ID, m->param_id);
    caekf_bits_put_signed(data, CAEKF_FIELD_CTRL_PARAM_PARAM_EXP10, m->exp10);
    caekf_bits_put_signed(data, CAEKF_FIELD_CTRL_PARAM_PARAM_MANTISSA, m->mantissa);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_param(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_param_t *m)
{
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    m->param_id = (uint8_t)caekf_bits_get(data, CAEKF_FIELD_CTRL_PARAM_PARAM_ID);
    m->exp10 = (int8_t)caekf_bits_get_signed(data, CAEKF_FIELD_CTRL_PARAM_PARAM_EXP10);
    m->mantissa = caekf_bits_get_signed(data, CAEKF_FIELD_CTRL_PARAM_PARAM_MANTISSA);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_param_value(const caekf_msg_param_t *m, double *value)
{
    static const double powers_of_ten[EXP10_MAX + 1] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                                        1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                                        1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    if (m == NULL || value == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (m->exp10 > EXP10_MAX || m->exp10 < -EXP10_MAX) {
        return CAEKF_PROTO_ERR_VALUE;
    }
    if (m->exp10 >= 0) {
        *value = (double)m->mantissa * powers_of_ten[m->exp10];
    } else {
        *value = (double)m->mantissa / powers_of_ten[-m->exp10];
    }
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_encode_status_req(const caekf_msg_status_req_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    memset(data, 0, CAEKF_CAN_DLC);
    caekf_bits_put(data, CAEKF_FIELD_CTRL_STATUS_REQ_TOKEN, m->token);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_status_req(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_status_req_t *m)
{
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    m->token = (uint8_t)caekf_bits_get(data, CAEKF_FIELD_CTRL_STATUS_REQ_TOKEN);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_encode_ack(const caekf_msg_ack_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    memset(data, 0, CAEKF_CAN_DLC);
    caekf_bits_put(data, CAEKF_FIELD_EST_ACK_TOKEN, m->token);
    caekf_bits_put_signed(data, CAEKF_FIELD_EST_ACK_ACK_STATUS, m->status);
    caekf_bits_put(data, CAEKF_FIELD_EST_ACK_BAD_PARAM, m->bad_param);
    caekf_bits_put(data, CAEKF_FIELD_EST_ACK_N_PARAMS_RX, m->n_params_rx);
    caekf_bits_put(data, CAEKF_FIELD_EST_ACK_STATE, m->state);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_ack(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_ack_t *m)
{
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    m->token = (uint8_t)caekf_bits_get(data, CAEKF_FIELD_EST_ACK_TOKEN);
    m->status = (int8_t)caekf_bits_get_signed(data, CAEKF_FIELD_EST_ACK_ACK_STATUS);
    m->bad_param = (uint8_t)caekf_bits_get(data, CAEKF_FIELD_EST_ACK_BAD_PARAM);
    m->n_params_rx = (uint8_t)caekf_bits_get(data, CAEKF_FIELD_EST_ACK_N_PARAMS_RX);
    m->state = (uint8_t)caekf_bits_get(data, CAEKF_FIELD_EST_ACK_STATE);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_encode_health(const caekf_msg_health_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (m->page >= CAEKF_HEALTH_PAGES) {
        return CAEKF_PROTO_ERR_RANGE;
    }
    memset(data, 0, CAEKF_CAN_DLC);
    caekf_bits_put(data, CAEKF_FIELD_EST_HEALTH_PAGE, m->page);
    caekf_bits_put(data, HEALTH_LOWER, m->counter_a & CAEKF_HEALTH_COUNTER_MASK);
    caekf_bits_put(data, HEALTH_UPPER, m->counter_b & CAEKF_HEALTH_COUNTER_MASK);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_health(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_health_t *m)
{
    uint8_t page;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    page = (uint8_t)caekf_bits_get(data, CAEKF_FIELD_EST_HEALTH_PAGE);
    if (page >= CAEKF_HEALTH_PAGES) {
        return CAEKF_PROTO_ERR_VALUE;
    }
    m->page = page;
    m->counter_a = (uint32_t)caekf_bits_get(data, HEALTH_LOWER);
    m->counter_b = (uint32_t)caekf_bits_get(data, HEALTH_UPPER);
    return CAEKF_PROTO_OK;
}
