/* Codec of the per-step frames (BENCH_U/U2/Y1/Y4/S*_POS/S*_VEL, EST_* value frames, EST_STEP) on the C pack/unpack that
 * cantools generates from caekf.dbc at build time (sim/src/caekf_sim/codegen.py): the bit layout comes
 * from the DBC only. Here: cantools' scaling (round half to even of value / LSB, float32 bit patterns),
 * range clipping, and the refusal of non-finite inputs; the E2E layer seals the frames afterwards. */
#include <stddef.h>
#include <string.h>

#include "bitfield.h"
#include "caekf/caekf_proto.h"
#include "caekf_can.h"
#include "caekf_proto_frames_table.h" /* CAEKF_VALUE_MESSAGES: generated from caekf.dbc */

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

/* A value as the generated struct holds it: int64 raw for the scaled signals, the float32 itself
 * (bit pattern copied, so no conversion can alter it) for the float signals. */
#define SET_int(dst, raw, bits) ((dst) = (raw))
#define SET_float(dst, raw, bits) memcpy(&(dst), &(bits), sizeof(uint32_t))
#define GET_int(src, raw, bits) ((raw) = (src))
#define GET_float(src, raw, bits) memcpy(&(bits), &(src), sizeof(uint32_t))

/* One object for whichever message a call handles: the stack holds the largest struct, not all 31. */
#define UNION_MEMBER(id, name, field, kind) struct caekf_can_##name##_t name;
typedef union {
    CAEKF_VALUE_MESSAGES(UNION_MEMBER)
} value_frame_t;
#undef UNION_MEMBER

static int pack_value(caekf_msg_t msg, uint16_t step, int64_t raw, uint32_t bits, uint8_t data[CAEKF_CAN_DLC])
{
    value_frame_t m;
    memset(&m, 0, sizeof m);
    switch (msg) {
#define PACK_CASE(id, name, field, kind)     \
    case id:                                 \
        m.name.step = step;                  \
        SET_##kind(m.name.field, raw, bits); \
        return caekf_can_##name##_pack(data, &m.name, CAEKF_CAN_DLC);
        CAEKF_VALUE_MESSAGES(PACK_CASE)
#undef PACK_CASE
    default: return -1;
    }
}

static int unpack_value(caekf_msg_t msg, const uint8_t data[CAEKF_CAN_DLC], uint16_t *step, int64_t *raw,
                        uint32_t *bits)
{
    value_frame_t m;
    int r;
    switch (msg) {
#define UNPACK_CASE(id, name, field, kind)                           \
    case id:                                                         \
        r = caekf_can_##name##_unpack(&m.name, data, CAEKF_CAN_DLC); \
        *step = m.name.step;                                         \
        GET_##kind(m.name.field, *raw, *bits);                       \
        return r;
        CAEKF_VALUE_MESSAGES(UNPACK_CASE)
#undef UNPACK_CASE
    default: return -1;
    }
}

caekf_proto_status_t caekf_proto_encode_value(caekf_msg_t msg, uint16_t step, double value, uint8_t data[CAEKF_CAN_DLC])
{
    const caekf_msg_info_t *info;
    caekf_proto_status_t st;
    int clipped;
    int64_t raw = 0;
    uint32_t bits = 0u;
    if (data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    st = layout_of(msg, &info);
    if (st != CAEKF_PROTO_OK) {
        return st;
    }
    if (info->layout == CAEKF_LAYOUT_INT36) {
        clipped = caekf_scaled_to_raw(value, info->lsb, 36u, &raw);
    } else {
        clipped = caekf_float32_bits(value, &bits);
    }
    if (pack_value(msg, step, raw, bits, data) != (int)CAEKF_CAN_DLC) {
        return CAEKF_PROTO_ERR_MSG;
    }
    return clipped ? CAEKF_PROTO_SATURATED : CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_value(caekf_msg_t msg, const uint8_t data[CAEKF_CAN_DLC], uint16_t *step,
                                              double *value)
{
    const caekf_msg_info_t *info;
    caekf_proto_status_t st;
    int64_t raw = 0;
    uint32_t bits = 0u;
    uint16_t s = 0u;
    double v;
    if (data == NULL || step == NULL || value == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    st = layout_of(msg, &info);
    if (st != CAEKF_PROTO_OK) {
        return st;
    }
    if (unpack_value(msg, data, &s, &raw, &bits) != 0) {
        return CAEKF_PROTO_ERR_MSG;
    }
    if (info->layout == CAEKF_LAYOUT_INT36) {
        v = (double)raw * info->lsb; /* as cantools: raw * scale */
    } else if (caekf_float32_value(bits, &v) != 0) {
        return CAEKF_PROTO_ERR_VALUE; /* NaN or infinity never reaches the estimator */
    }
    *step = s;
    *value = v;
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_encode_step(const caekf_msg_step_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    struct caekf_can_est_step_t g;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    memset(&g, 0, sizeof g);
    g.step = m->step;
    g.flags = m->flags;
    g.newton_iters = m->newton_iters;
    g.step_status = m->status;
    return caekf_can_est_step_pack(data, &g, CAEKF_CAN_DLC) == (int)CAEKF_CAN_DLC ? CAEKF_PROTO_OK
                                                                                  : CAEKF_PROTO_ERR_MSG;
}

caekf_proto_status_t caekf_proto_decode_step(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_step_t *m)
{
    struct caekf_can_est_step_t g;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (caekf_can_est_step_unpack(&g, data, CAEKF_CAN_DLC) != 0) {
        return CAEKF_PROTO_ERR_MSG;
    }
    m->step = g.step;
    m->flags = g.flags;
    m->newton_iters = g.newton_iters;
    m->status = g.step_status;
    return CAEKF_PROTO_OK;
}

/* --- production profile ------------------------------------------------------------------------ */

caekf_proto_status_t caekf_proto_encode_yp(const caekf_msg_yp_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    struct caekf_can_bench_yp_t g;
    int64_t r1 = 0;
    int64_t r4 = 0;
    int clipped;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    clipped = caekf_scaled_to_raw(m->y1, CAEKF_YP_LSB, CAEKF_YP_BITS, &r1);
    clipped |= caekf_scaled_to_raw(m->y4, CAEKF_YP_LSB, CAEKF_YP_BITS, &r4);
    memset(&g, 0, sizeof g);
    g.step = m->step;
    g.y1 = (int32_t)r1;
    g.y4 = (int32_t)r4;
    if (caekf_can_bench_yp_pack(data, &g, CAEKF_CAN_DLC) != (int)CAEKF_CAN_DLC) {
        return CAEKF_PROTO_ERR_MSG;
    }
    return clipped ? CAEKF_PROTO_SATURATED : CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_yp(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_yp_t *m)
{
    struct caekf_can_bench_yp_t g;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (caekf_can_bench_yp_unpack(&g, data, CAEKF_CAN_DLC) != 0) {
        return CAEKF_PROTO_ERR_MSG;
    }
    m->step = g.step;
    m->y1 = (double)g.y1 * CAEKF_YP_LSB; /* as cantools: raw * scale */
    m->y4 = (double)g.y4 * CAEKF_YP_LSB;
    return CAEKF_PROTO_OK;
}

/* float32 of an output value as the generated struct holds it (bit pattern copied). */
static int put_f32(float *dst, double value)
{
    uint32_t bits = 0u;
    int clipped = caekf_float32_bits(value, &bits);
    memcpy(dst, &bits, sizeof bits);
    return clipped;
}

static double get_f32(const float *src)
{
    uint32_t bits;
    double v = 0.0;
    memcpy(&bits, src, sizeof bits);
    (void)caekf_float32_value(bits, &v); /* outputs: NaN and infinities are returned as they are */
    return v;
}

caekf_proto_status_t caekf_proto_encode_prod(const caekf_msg_prod_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    struct caekf_can_est_prod_t g;
    int clipped;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    memset(&g, 0, sizeof g);
    g.step = m->step;
    g.flags = (uint16_t)(m->flags & CAEKF_PROD_FLAGS_MASK);
    clipped = put_f32(&g.gamma, m->gamma);
    if (caekf_can_est_prod_pack(data, &g, CAEKF_CAN_DLC) != (int)CAEKF_CAN_DLC) {
        return CAEKF_PROTO_ERR_MSG;
    }
    return clipped ? CAEKF_PROTO_SATURATED : CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_prod(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_prod_t *m)
{
    struct caekf_can_est_prod_t g;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (caekf_can_est_prod_unpack(&g, data, CAEKF_CAN_DLC) != 0) {
        return CAEKF_PROTO_ERR_MSG;
    }
    m->step = g.step;
    m->flags = g.flags;
    m->gamma = get_f32(&g.gamma);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_encode_page(const caekf_msg_page_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    struct caekf_can_est_page_t g;
    float *slot[CAEKF_PAGE_STEP_INFO];
    int clipped = 0;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (m->page >= CAEKF_PAGE_COUNT) {
        return CAEKF_PROTO_ERR_RANGE;
    }
    memset(&g, 0, sizeof g);
    slot[0] = &g.q1;
    slot[1] = &g.q2;
    slot[2] = &g.q3;
    slot[3] = &g.q4;
    slot[4] = &g.v1;
    slot[5] = &g.v2;
    slot[6] = &g.v3;
    slot[7] = &g.v4;
    slot[8] = &g.p_norm;
    slot[9] = &g.p_gamma_gamma;
    g.page = m->page;
    g.step = m->step;
    if (m->page == CAEKF_PAGE_STEP_INFO) {
        g.flags = m->info.flags;
        g.newton_iters = m->info.newton_iters;
        g.step_status = m->info.status;
    } else {
        clipped = put_f32(slot[m->page], m->value);
    }
    if (caekf_can_est_page_pack(data, &g, CAEKF_CAN_DLC) != (int)CAEKF_CAN_DLC) {
        return CAEKF_PROTO_ERR_MSG;
    }
    return clipped ? CAEKF_PROTO_SATURATED : CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_page(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_page_t *m)
{
    struct caekf_can_est_page_t g;
    const float *slot[CAEKF_PAGE_STEP_INFO];
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (caekf_can_est_page_unpack(&g, data, CAEKF_CAN_DLC) != 0) {
        return CAEKF_PROTO_ERR_MSG;
    }
    if (g.page >= CAEKF_PAGE_COUNT) {
        return CAEKF_PROTO_ERR_VALUE;
    }
    slot[0] = &g.q1;
    slot[1] = &g.q2;
    slot[2] = &g.q3;
    slot[3] = &g.q4;
    slot[4] = &g.v1;
    slot[5] = &g.v2;
    slot[6] = &g.v3;
    slot[7] = &g.v4;
    slot[8] = &g.p_norm;
    slot[9] = &g.p_gamma_gamma;
    m->page = g.page;
    m->step = g.step;
    m->value = 0.0;
    m->info.step = g.step;
    m->info.flags = 0u;
    m->info.newton_iters = 0u;
    m->info.status = 0;
    if (g.page == CAEKF_PAGE_STEP_INFO) {
        m->info.flags = g.flags;
        m->info.newton_iters = g.newton_iters;
        m->info.status = g.step_status;
    } else {
        m->value = get_f32(slot[g.page]);
    }
    return CAEKF_PROTO_OK;
}

/* --- CAN FD profile ---------------------------------------------------------------------------- */

#define POS_LSB 1e-12 /* m per LSB of the 36-bit positions, as the diagnostics frames */
#define VEL_LSB 1e-10 /* m/s per LSB of the 36-bit velocities */
#define FD_SCALED_BITS 36u

caekf_proto_status_t caekf_proto_encode_fd_in(const caekf_msg_fd_in_t *m, uint8_t data[CAEKF_CAN_FD_MAX_LEN])
{
    struct caekf_can_bench_fd_t g;
    int clipped;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    memset(&g, 0, sizeof g);
    g.step = m->step;
    clipped = put_f32(&g.u, m->u);
    clipped |= caekf_scaled_to_raw(m->y1, POS_LSB, FD_SCALED_BITS, &g.y1);
    clipped |= caekf_scaled_to_raw(m->y4, POS_LSB, FD_SCALED_BITS, &g.y4);
    if (caekf_can_bench_fd_pack(data, &g, CAEKF_FD_IN_LEN) != (int)CAEKF_FD_IN_LEN) {
        return CAEKF_PROTO_ERR_MSG;
    }
    return clipped ? CAEKF_PROTO_SATURATED : CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_fd_in(const uint8_t data[CAEKF_CAN_FD_MAX_LEN], caekf_msg_fd_in_t *m)
{
    struct caekf_can_bench_fd_t g;
    uint32_t bits;
    double u = 0.0;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (caekf_can_bench_fd_unpack(&g, data, CAEKF_FD_IN_LEN) != 0) {
        return CAEKF_PROTO_ERR_MSG;
    }
    memcpy(&bits, &g.u, sizeof bits);
    if (caekf_float32_value(bits, &u) != 0) {
        return CAEKF_PROTO_ERR_VALUE; /* inputs: NaN and infinities are refused */
    }
    m->step = g.step;
    m->u = u;
    m->y1 = (double)g.y1 * POS_LSB; /* as cantools: raw * scale */
    m->y4 = (double)g.y4 * POS_LSB;
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_encode_fd_out(const caekf_msg_fd_out_t *m, uint8_t data[CAEKF_CAN_FD_MAX_LEN])
{
    struct caekf_can_est_fd_t g;
    int64_t *scaled[8];
    int clipped = 0;
    unsigned i;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    memset(&g, 0, sizeof g);
    scaled[0] = &g.q1;
    scaled[1] = &g.q2;
    scaled[2] = &g.q3;
    scaled[3] = &g.q4;
    scaled[4] = &g.v1;
    scaled[5] = &g.v2;
    scaled[6] = &g.v3;
    scaled[7] = &g.v4;
    for (i = 0; i < 8u; i++) {
        clipped |= caekf_scaled_to_raw(m->x[i], i < 4u ? POS_LSB : VEL_LSB, FD_SCALED_BITS, scaled[i]);
    }
    clipped |= put_f32(&g.gamma, m->x[8]);
    clipped |= put_f32(&g.p_norm, m->p_norm);
    clipped |= put_f32(&g.p_gamma_gamma, m->p_gg);
    g.step = m->step;
    g.flags = m->info.flags;
    g.newton_iters = m->info.newton_iters;
    g.step_status = m->info.status;
    if (caekf_can_est_fd_pack(data, &g, CAEKF_FD_OUT_LEN) != (int)CAEKF_FD_OUT_LEN) {
        return CAEKF_PROTO_ERR_MSG;
    }
    return clipped ? CAEKF_PROTO_SATURATED : CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_decode_fd_out(const uint8_t data[CAEKF_CAN_FD_MAX_LEN], caekf_msg_fd_out_t *m)
{
    struct caekf_can_est_fd_t g;
    const int64_t *scaled[8];
    unsigned i;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (caekf_can_est_fd_unpack(&g, data, CAEKF_FD_OUT_LEN) != 0) {
        return CAEKF_PROTO_ERR_MSG;
    }
    scaled[0] = &g.q1;
    scaled[1] = &g.q2;
    scaled[2] = &g.q3;
    scaled[3] = &g.q4;
    scaled[4] = &g.v1;
    scaled[5] = &g.v2;
    scaled[6] = &g.v3;
    scaled[7] = &g.v4;
    for (i = 0; i < 8u; i++) {
        m->x[i] = (double)*scaled[i] * (i < 4u ? POS_LSB : VEL_LSB);
    }
    m->x[8] = get_f32(&g.gamma);
    m->p_norm = get_f32(&g.p_norm);
    m->p_gg = get_f32(&g.p_gamma_gamma);
    m->step = g.step;
    m->info.step = g.step;
    m->info.flags = g.flags;
    m->info.newton_iters = g.newton_iters;
    m->info.status = g.step_status;
    return CAEKF_PROTO_OK;
}
