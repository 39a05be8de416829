/* Codec of the per-step frames that carry physical values (BENCH_U/U2/Y1/Y4/S*_POS/S*_VEL, the EST_* value
 * frames, BENCH_YP, EST_PROD, EST_PAGE, BENCH_FD, EST_FD) on the C pack/unpack that cantools generates from
 * caekf.dbc at build time (sim/src/caekf_sim/codegen.py): the bit layout comes from the DBC only. Here:
 * cantools' scaling (round half to even of value / LSB, float32 bit patterns), range clipping, and the
 * refusal of non-finite inputs; the E2E layer seals the frames afterwards. The value frames share one codec
 * (CAEKF_VALUE_MESSAGES); each of the others maps its own API struct (pages, arrays) onto its signals. EST_STEP's
 * codec is generated (caekf_proto_messages.c). */
#include <stddef.h>
#include <string.h>

#include "scaling.h"
#include "caekf/caekf_proto.h"
#include "caekf_can.h"
#include "caekf_proto_frames_table.h" /* CAEKF_VALUE_MESSAGES: generated from caekf.dbc */
#include "codec_status.h"

static caekf_proto_status_t layout_of(caekf_msg_t msg, const caekf_msg_info_t **info)
{
    caekf_proto_status_t st = caekf_proto_msg_info(msg, info);
    if (st != CAEKF_PROTO_OK) {
        return st;
    }
    if ((*info)->layout != (uint8_t)CAEKF_LAYOUT_INT36 && (*info)->layout != (uint8_t)CAEKF_LAYOUT_FLOAT32) {
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
    (void)memset(&m, 0, sizeof m);
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
    if (info->layout == (uint8_t)CAEKF_LAYOUT_INT36) {
        clipped = caekf_scaled_to_raw(value, info->lsb, 36u, &raw);
    } else {
        clipped = caekf_float32_bits(value, &bits);
    }
    return caekf_proto_packed(pack_value(msg, step, raw, bits, data), CAEKF_CAN_DLC, clipped);
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
    if (info->layout == (uint8_t)CAEKF_LAYOUT_INT36) {
        v = (double)raw * info->lsb; /* as cantools: raw * scale */
    } else if (caekf_float32_value(bits, &v) != 0) {
        return CAEKF_PROTO_ERR_VALUE; /* NaN or infinity never reaches the estimator */
    } else {
        /* v holds the finite float32 value */
    }
    *step = s;
    *value = v;
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
    (void)memset(&g, 0, sizeof g);
    g.step = m->step;
    g.y1 = (int32_t)r1;
    g.y4 = (int32_t)r4;
    return caekf_proto_packed(caekf_can_bench_yp_pack(data, &g, CAEKF_CAN_DLC), CAEKF_CAN_DLC, clipped);
}

caekf_proto_status_t caekf_proto_decode_yp(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_yp_t *m)
{
    struct caekf_can_bench_yp_t g;
    const caekf_proto_status_t st = CAEKF_PROTO_UNPACKED(m, data, caekf_can_bench_yp_unpack(&g, data, CAEKF_CAN_DLC));
    if (st == CAEKF_PROTO_OK) {
        m->step = g.step;
        m->y1 = (double)g.y1 * CAEKF_YP_LSB; /* as cantools: raw * scale */
        m->y4 = (double)g.y4 * CAEKF_YP_LSB;
    }
    return st;
}

/* float32 of an output value as the generated struct holds it (bit pattern copied). */
static int put_f32(float *dst, double value)
{
    uint32_t bits = 0u;
    int clipped = caekf_float32_bits(value, &bits);
    (void)memcpy(dst, &bits, sizeof bits);
    return clipped;
}

static double get_f32(const float *src)
{
    uint32_t bits;
    double v = 0.0;
    (void)memcpy(&bits, src, sizeof bits);
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
    (void)memset(&g, 0, sizeof g);
    g.step = (uint8_t)(m->step & CAEKF_PROD_STEP_MASK);
    g.flags = (uint16_t)(m->flags & CAEKF_PROD_FLAGS_MASK);
    clipped = put_f32(&g.gamma, m->gamma);
    return caekf_proto_packed(caekf_can_est_prod_pack(data, &g, CAEKF_CAN_DLC), CAEKF_CAN_DLC, clipped);
}

caekf_proto_status_t caekf_proto_decode_prod(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_prod_t *m)
{
    struct caekf_can_est_prod_t g;
    const caekf_proto_status_t st = CAEKF_PROTO_UNPACKED(m, data, caekf_can_est_prod_unpack(&g, data, CAEKF_CAN_DLC));
    if (st == CAEKF_PROTO_OK) {
        m->step = g.step;
        m->flags = g.flags;
        m->gamma = get_f32(&g.gamma);
    }
    return st;
}

/* EST_PAGE's float32 value of page p (< CAEKF_PAGE_STEP_INFO) in the generated struct. */
static float *page_value(struct caekf_can_est_page_t *g, unsigned p)
{
    /* cppcheck-suppress constVariable ; the slot is returned for writing */
    float *const slot[CAEKF_PAGE_STEP_INFO] = {&g->q1, &g->q2, &g->q3, &g->q4,     &g->v1,
                                               &g->v2, &g->v3, &g->v4, &g->p_norm, &g->p_gamma_gamma};
    return slot[p];
}

caekf_proto_status_t caekf_proto_encode_page(const caekf_msg_page_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    struct caekf_can_est_page_t g;
    int clipped = 0;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (m->page >= CAEKF_PAGE_COUNT) {
        return CAEKF_PROTO_ERR_RANGE;
    }
    (void)memset(&g, 0, sizeof g);
    g.page = m->page;
    g.step = m->step;
    if (m->page == CAEKF_PAGE_STEP_INFO) {
        g.flags = m->info.flags;
        g.newton_iters = m->info.newton_iters;
        g.step_status = m->info.step_status;
    } else {
        clipped = put_f32(page_value(&g, m->page), m->value);
    }
    return caekf_proto_packed(caekf_can_est_page_pack(data, &g, CAEKF_CAN_DLC), CAEKF_CAN_DLC, clipped);
}

caekf_proto_status_t caekf_proto_decode_page(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_page_t *m)
{
    struct caekf_can_est_page_t g;
    const caekf_proto_status_t st = CAEKF_PROTO_UNPACKED(m, data, caekf_can_est_page_unpack(&g, data, CAEKF_CAN_DLC));
    if (st != CAEKF_PROTO_OK) {
        return st;
    }
    if (g.page >= CAEKF_PAGE_COUNT) {
        return CAEKF_PROTO_ERR_VALUE;
    }
    m->page = g.page;
    m->step = g.step;
    m->value = 0.0;
    m->info.step = g.step;
    m->info.flags = 0u;
    m->info.newton_iters = 0u;
    m->info.step_status = 0;
    if (g.page == CAEKF_PAGE_STEP_INFO) {
        m->info.flags = g.flags;
        m->info.newton_iters = g.newton_iters;
        m->info.step_status = g.step_status;
    } else {
        m->value = get_f32(page_value(&g, g.page));
    }
    return CAEKF_PROTO_OK;
}

/* --- CAN FD profile ---------------------------------------------------------------------------- */

/* EST_FD's scaled value i (q1..q4, v1..v4) in the generated struct, and its LSB. */
static int64_t *fd_scaled(struct caekf_can_est_fd_t *g, unsigned i, double *lsb)
{
    /* cppcheck-suppress constVariable ; the slot is returned for writing */
    int64_t *const slot[8] = {&g->q1, &g->q2, &g->q3, &g->q4, &g->v1, &g->v2, &g->v3, &g->v4};
    *lsb = i < 4u ? CAEKF_SCALE_EST_FD_Q1 : CAEKF_SCALE_EST_FD_V1;
    return slot[i];
}

caekf_proto_status_t caekf_proto_encode_fd_in(const caekf_msg_fd_in_t *m, uint8_t data[CAEKF_CAN_FD_MAX_LEN])
{
    struct caekf_can_bench_fd_t g;
    int clipped;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    (void)memset(&g, 0, sizeof g);
    g.step = m->step;
    clipped = put_f32(&g.u, m->u);
    clipped |= caekf_scaled_to_raw(m->y1, CAEKF_SCALE_BENCH_FD_Y1, CAEKF_BITS_BENCH_FD_Y1, &g.y1);
    clipped |= caekf_scaled_to_raw(m->y4, CAEKF_SCALE_BENCH_FD_Y4, CAEKF_BITS_BENCH_FD_Y4, &g.y4);
    return caekf_proto_packed(caekf_can_bench_fd_pack(data, &g, CAEKF_FD_IN_LEN), CAEKF_FD_IN_LEN, clipped);
}

caekf_proto_status_t caekf_proto_decode_fd_in(const uint8_t data[CAEKF_CAN_FD_MAX_LEN], caekf_msg_fd_in_t *m)
{
    struct caekf_can_bench_fd_t g;
    uint32_t bits;
    double u = 0.0;
    const caekf_proto_status_t st = CAEKF_PROTO_UNPACKED(m, data, caekf_can_bench_fd_unpack(&g, data, CAEKF_FD_IN_LEN));
    if (st != CAEKF_PROTO_OK) {
        return st;
    }
    (void)memcpy(&bits, &g.u, sizeof bits);
    if (caekf_float32_value(bits, &u) != 0) {
        return CAEKF_PROTO_ERR_VALUE; /* inputs: NaN and infinities are refused */
    }
    m->step = g.step;
    m->u = u;
    m->y1 = (double)g.y1 * CAEKF_SCALE_BENCH_FD_Y1; /* as cantools: raw * scale */
    m->y4 = (double)g.y4 * CAEKF_SCALE_BENCH_FD_Y4;
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_encode_fd_out(const caekf_msg_fd_out_t *m, uint8_t data[CAEKF_CAN_FD_MAX_LEN])
{
    struct caekf_can_est_fd_t g;
    int clipped = 0;
    unsigned i;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    (void)memset(&g, 0, sizeof g);
    for (i = 0; i < 8u; i++) {
        double lsb;
        int64_t *const raw = fd_scaled(&g, i, &lsb);
        clipped |= caekf_scaled_to_raw(m->x[i], lsb, CAEKF_BITS_EST_FD_Q1, raw);
    }
    clipped |= put_f32(&g.gamma, m->x[8]);
    clipped |= put_f32(&g.p_norm, m->p_norm);
    clipped |= put_f32(&g.p_gamma_gamma, m->p_gg);
    g.step = m->step;
    g.flags = m->info.flags;
    g.newton_iters = m->info.newton_iters;
    g.step_status = m->info.step_status;
    return caekf_proto_packed(caekf_can_est_fd_pack(data, &g, CAEKF_FD_OUT_LEN), CAEKF_FD_OUT_LEN, clipped);
}

caekf_proto_status_t caekf_proto_decode_fd_out(const uint8_t data[CAEKF_CAN_FD_MAX_LEN], caekf_msg_fd_out_t *m)
{
    struct caekf_can_est_fd_t g;
    unsigned i;
    const caekf_proto_status_t st = CAEKF_PROTO_UNPACKED(m, data, caekf_can_est_fd_unpack(&g, data, CAEKF_FD_OUT_LEN));
    if (st != CAEKF_PROTO_OK) {
        return st;
    }
    for (i = 0; i < 8u; i++) {
        double lsb;
        const int64_t raw = *fd_scaled(&g, i, &lsb);
        m->x[i] = (double)raw * lsb;
    }
    m->x[8] = get_f32(&g.gamma);
    m->p_norm = get_f32(&g.p_norm);
    m->p_gg = get_f32(&g.p_gamma_gamma);
    m->step = g.step;
    m->info.step = g.step;
    m->info.flags = g.flags;
    m->info.newton_iters = g.newton_iters;
    m->info.step_status = g.step_status;
    return CAEKF_PROTO_OK;
}
