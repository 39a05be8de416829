/* Codec of the per-step frames: INT36 and FLOAT32 value frames and EST_STEP. */
#include <stddef.h>
#include <string.h>

#include "bitfield.h"
#include "caekf/caekf_proto.h"
#include "layout.h"

static caekf_proto_status_t layout_of(caekf_msg_t msg, const caekf_msg_info_t **info)
{
    caekf_proto_status_t st = caekf_proto_msg_info(msg, info);
    if (st != CAEKF_PROTO_OK) {
        return st;
    }
    if ((*info)->layout != CAEKF_LAYOUT_INT36 && (*info)->layout != CAEKF_LAYOUT_FLOAT32) {
        return CAEKF_PROTO_ERR_MSG;
    }
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_encode_value(caekf_msg_t msg, uint16_t step, double value, uint8_t data[CAEKF_CAN_DLC])
{
    const caekf_msg_info_t *info;
    caekf_proto_status_t st;
    int clipped;
    if (data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    st = layout_of(msg, &info);
    if (st != CAEKF_PROTO_OK) {
        return st;
    }
    memset(data, 0, CAEKF_CAN_DLC);
    caekf_bits_put(data, F_STEP, step);
    if (info->layout == CAEKF_LAYOUT_INT36) {
        int64_t raw;
        clipped = caekf_scaled_to_raw(value, info->lsb, 36u, &raw);
        caekf_bits_put_signed(data, F_INT36_VALUE, raw);
    } else {
        uint32_t bits;
        clipped = caekf_float32_bits(value, &bits);
        caekf_bits_put(data, F_FLOAT32_VALUE, bits);
    }
    return clipped ? CAEKF_PROTO_SATURATED : CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_value(caekf_msg_t msg, const uint8_t data[CAEKF_CAN_DLC], uint16_t *step,
                                              double *value)
{
    const caekf_msg_info_t *info;
    caekf_proto_status_t st;
    double v;
    if (data == NULL || step == NULL || value == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    st = layout_of(msg, &info);
    if (st != CAEKF_PROTO_OK) {
        return st;
    }
    if (info->layout == CAEKF_LAYOUT_INT36) {
        v = (double)caekf_bits_get_signed(data, F_INT36_VALUE) * info->lsb; /* as cantools: raw * scale */
    } else if (caekf_float32_value((uint32_t)caekf_bits_get(data, F_FLOAT32_VALUE), &v) != 0) {
        return CAEKF_PROTO_ERR_VALUE; /* NaN or infinity never reaches the estimator */
    }
    *step = (uint16_t)caekf_bits_get(data, F_STEP);
    *value = v;
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_encode_step(const caekf_msg_step_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    memset(data, 0, CAEKF_CAN_DLC);
    caekf_bits_put(data, F_STEP, m->step);
    caekf_bits_put(data, F_FLAGS, m->flags);
    caekf_bits_put(data, F_NEWTON_ITERS, m->newton_iters);
    caekf_bits_put_signed(data, F_STEP_STATUS, m->status);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_step(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_step_t *m)
{
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    m->step = (uint16_t)caekf_bits_get(data, F_STEP);
    m->flags = (uint16_t)caekf_bits_get(data, F_FLAGS);
    m->newton_iters = (uint8_t)caekf_bits_get(data, F_NEWTON_ITERS);
    m->status = (int8_t)caekf_bits_get_signed(data, F_STEP_STATUS);
    return CAEKF_PROTO_OK;
}
