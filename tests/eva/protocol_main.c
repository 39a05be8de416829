/*
 * Frama-C EVA driver of firmware/protocol (tools/eva.py, target `protocol`; docs/eva.md).
 *
 * Every bus-facing entry point of the protocol library is called once with ALL its inputs unknown: each
 * payload byte any of 0..255 (Frama_C_make_unknown), every DLC, length, data ID, counter, max_delta and CAN
 * ID its whole type's range, every message id over the enumeration and one past it, a receiver's E2E state
 * any bytes, and each pointer argument either NULL or valid (Frama_C_nondet_ptr). The encoders (the send
 * path) get structs of arbitrary bytes, doubles included (NaN, infinities, every finite value). EVA then
 * proves, or reports as an alarm, every out-of-bounds access, invalid pointer, signed overflow, read of an
 * uninitialised value, division by zero and float-to-integer overflow for all of these inputs at once.
 *
 * Each call gets fresh unknown inputs (any_bytes before it), so no call's result constrains the next one.
 * Only the contract each function states in its header is assumed (a payload buffer of CAEKF_CAN_DLC or
 * CAEKF_CAN_FD_MAX_LEN bytes, as the app passes its caekf_can_frame_t's data).
 */
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "__fc_builtin.h"
#include "caekf/caekf_crc16.h"
#include "caekf/caekf_crc8.h"
#include "caekf/caekf_e2e.h"
#include "caekf/caekf_proto.h"

static uint8_t data[CAEKF_CAN_FD_MAX_LEN];

/* Every byte of obj unknown (any value, initialised). */
static void any_bytes(void *obj, size_t size) { Frama_C_make_unknown((char *)obj, size); }

static uint32_t any_u32(void) { return Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu); }

static uint16_t any_u16(void) { return (uint16_t)Frama_C_interval(0, 0xFFFF); }

static uint8_t any_u8(void) { return (uint8_t)Frama_C_interval(0, 0xFF); }

/* Every message id, and one past the last (an id no table has). */
static caekf_msg_t any_msg(void) { return (caekf_msg_t)Frama_C_interval(0, (int)CAEKF_MSG_COUNT); }

/* The payload buffer refilled with unknown bytes; NULL or the buffer. */
static uint8_t *any_payload(void)
{
    any_bytes(data, sizeof data);
    return (uint8_t *)Frama_C_nondet_ptr(NULL, data);
}

static void crcs(void)
{
    uint8_t c8 = 0u;
    const size_t len = (size_t)Frama_C_interval(0, (int)CAEKF_CAN_FD_MAX_LEN);
    const uint8_t *p = any_payload();
    (void)caekf_crc8_update(any_u8(), p, len);
    (void)caekf_crc16_update(any_u16(), p, len);
    (void)caekf_crc8(p, len, (uint8_t *)Frama_C_nondet_ptr(NULL, &c8));
}

static void e2e(void)
{
    caekf_e2e_rx_t rx;
    uint8_t lost = 0u;
    uint8_t c8 = 0u;
    uint16_t c16 = 0u;
    uint8_t *p;
    caekf_e2e_rx_t *prx = (caekf_e2e_rx_t *)Frama_C_nondet_ptr(NULL, &rx);
    uint8_t *plost = (uint8_t *)Frama_C_nondet_ptr(NULL, &lost);

    (void)caekf_e2e_rx_init(prx);
    /* receive: any receiver state, any frame */
    any_bytes(&rx, sizeof rx);
    p = any_payload();
    (void)caekf_e2e_check(prx, any_u16(), any_u8(), p, any_u8(), plost);
    any_bytes(&rx, sizeof rx);
    p = any_payload();
    (void)caekf_e2e_check_fd(prx, any_u16(), any_u8(), p, any_u8(), any_u8(), plost);
    p = any_payload();
    (void)caekf_e2e_crc(any_u16(), p, (uint8_t *)Frama_C_nondet_ptr(NULL, &c8));
    p = any_payload();
    (void)caekf_e2e_crc16(any_u16(), p, any_u8(), (uint16_t *)Frama_C_nondet_ptr(NULL, &c16));
    /* send */
    p = any_payload();
    (void)caekf_e2e_protect(any_u16(), any_u8(), p);
    p = any_payload();
    (void)caekf_e2e_protect_fd(any_u16(), any_u8(), p, any_u8());
}

static void message_table(void)
{
    const caekf_msg_info_t *info = NULL;
    caekf_msg_t msg = CAEKF_MSG_CTRL_RESET;
    uint32_t id = 0u;
    caekf_can_frame_t frame;
    int32_t offset;
    const char *name = NULL;
    caekf_msg_t *pmsg = (caekf_msg_t *)Frama_C_nondet_ptr(NULL, &msg);

    (void)caekf_proto_msg_info(any_msg(), (const caekf_msg_info_t **)Frama_C_nondet_ptr(NULL, &info));
    (void)caekf_proto_msg_from_id(any_u32(), pmsg);
    (void)caekf_proto_counter_name(any_u32(), (const char **)Frama_C_nondet_ptr(NULL, &name));
    /* The ID offset: every int32, in three ranges so that EVA follows each on its own (below -0x7FF and above
     * 0x7FF every ID leaves 0..0x7FF at the first row). A frame's lookup with an offset the check accepted (its
     * contract: caekf_app_init refuses the others). */
    offset = (int32_t)any_u32();
    if (offset < -(int32_t)CAEKF_CAN_SFF_MAX) {
        (void)caekf_proto_id_offset_check(offset);
        (void)caekf_proto_bus_id(any_msg(), offset, (uint32_t *)Frama_C_nondet_ptr(NULL, &id));
    } else if (offset > (int32_t)CAEKF_CAN_SFF_MAX) {
        (void)caekf_proto_id_offset_check(offset);
        (void)caekf_proto_bus_id(any_msg(), offset, (uint32_t *)Frama_C_nondet_ptr(NULL, &id));
    } else {
        (void)caekf_proto_bus_id(any_msg(), offset, (uint32_t *)Frama_C_nondet_ptr(NULL, &id));
        if (caekf_proto_id_offset_check(offset) == CAEKF_PROTO_OK) {
            (void)caekf_proto_msg_from_bus_id(any_u32(), offset, pmsg);
        }
    }
    any_bytes(&frame, sizeof frame);
    (void)caekf_proto_seal(any_msg(), any_u8(), (caekf_can_frame_t *)Frama_C_nondet_ptr(NULL, &frame));
}

/* decode(any payload or NULL, out or NULL), then encode(any struct or NULL, buffer or NULL). */
#define ROUND(type, dec, enc)                              \
    do {                                                   \
        type m_;                                           \
        type *pm_ = (type *)Frama_C_nondet_ptr(NULL, &m_); \
        (void)dec(any_payload(), pm_);                     \
        any_bytes(&m_, sizeof m_);                         \
        (void)enc(pm_, any_payload());                     \
    } while (0)

/* decode(any payload or NULL, out or NULL). */
#define DECODE(type, dec)                                                \
    do {                                                                 \
        type m_;                                                         \
        (void)dec(any_payload(), (type *)Frama_C_nondet_ptr(NULL, &m_)); \
    } while (0)

/* NaN (nan != 0), else any other double: every finite one and both infinities. */
static double any_double(unsigned nan)
{
    double v;
    if (nan != 0u) {
        return (double)NAN;
    }
    v = Frama_C_double_interval(-DBL_MAX, DBL_MAX);
    if (Frama_C_nondet(0, 1) != 0) {
        v = Frama_C_nondet(0, 1) != 0 ? (double)INFINITY : -(double)INFINITY;
    }
    return v;
}

/* As ROUND, with the page nibble (byte 1, bits 4..7) of the payload to decode set to `page`. */
#define ROUND_PAGE(type, dec, enc, page)                        \
    do {                                                        \
        type m_;                                                \
        type *pm_ = (type *)Frama_C_nondet_ptr(NULL, &m_);      \
        uint8_t *p_ = any_payload();                            \
        data[1] = (uint8_t)((data[1] & 0x0Fu) | ((page) << 4)); \
        (void)dec(p_, pm_);                                     \
        any_bytes(&m_, sizeof m_);                              \
        (void)enc(pm_, any_payload());                          \
    } while (0)

static void codecs(void)
{
    uint16_t step = 0u;
    double value = 0.0;
    caekf_msg_param_t param;
    double pv = 0.0;
    unsigned page;
    unsigned nan;
    int msg;

    ROUND(caekf_msg_reset_t, caekf_proto_decode_reset, caekf_proto_encode_reset);
    ROUND(caekf_msg_param_t, caekf_proto_decode_param, caekf_proto_encode_param);
    ROUND(caekf_msg_status_req_t, caekf_proto_decode_status_req, caekf_proto_encode_status_req);
    ROUND(caekf_msg_ack_t, caekf_proto_decode_ack, caekf_proto_encode_ack);
    ROUND(caekf_msg_step_t, caekf_proto_decode_step, caekf_proto_encode_step);
    DECODE(caekf_msg_yp_t, caekf_proto_decode_yp);
    ROUND(caekf_msg_prod_t, caekf_proto_decode_prod, caekf_proto_encode_prod);
    DECODE(caekf_msg_fd_in_t, caekf_proto_decode_fd_in);
    DECODE(caekf_msg_fd_out_t, caekf_proto_decode_fd_out);

    /* The encoders of scaled (integer) signals test a value for NaN before they scale it. Each such value is
     * NaN or any other double, in every combination (bit k of `nan`: value k is NaN), so that EVA follows the
     * two cases apart; the other fields are any bytes. */
    /*@ loop unroll 4; */
    for (nan = 0u; nan < 4u; nan++) {
        caekf_msg_yp_t yp;
        caekf_msg_fd_in_t in;
        any_bytes(&yp, sizeof yp);
        yp.y1 = any_double(nan & 1u);
        yp.y4 = any_double(nan & 2u);
        (void)caekf_proto_encode_yp((const caekf_msg_yp_t *)Frama_C_nondet_ptr(NULL, &yp), any_payload());
        any_bytes(&in, sizeof in);
        in.y1 = any_double(nan & 1u);
        in.y4 = any_double(nan & 2u);
        (void)caekf_proto_encode_fd_in((const caekf_msg_fd_in_t *)Frama_C_nondet_ptr(NULL, &in), any_payload());
    }
    /*@ loop unroll 256; */
    for (nan = 0u; nan < 256u; nan++) {
        caekf_msg_fd_out_t out;
        unsigned k;
        any_bytes(&out, sizeof out);
        /*@ loop unroll 8; */
        for (k = 0u; k < 8u; k++) {
            out.x[k] = any_double(nan & (1u << k));
        }
        (void)caekf_proto_encode_fd_out((const caekf_msg_fd_out_t *)Frama_C_nondet_ptr(NULL, &out), any_payload());
    }

    /* EST_HEALTH and EST_PAGE: which fields the generated unpack writes depends on the page (byte 1's high
     * nibble). Each of the 16 pages on its own, byte 1's low nibble and every other byte unknown: together
     * every payload. */
    /*@ loop unroll 16; */
    for (page = 0u; page < 16u; page++) {
        ROUND_PAGE(caekf_msg_health_t, caekf_proto_decode_health, caekf_proto_encode_health, page);
        ROUND_PAGE(caekf_msg_page_t, caekf_proto_decode_page, caekf_proto_encode_page, page);
    }

    /* The value frames, each message (and one past the last) on its own (the unrolling bound is above
     * CAEKF_MSG_COUNT + 1). The value to encode: NaN, and every other double (infinities included) apart, as the
     * encoder tests for NaN first. */
    /*@ loop unroll 128; */
    for (msg = 0; msg <= (int)CAEKF_MSG_COUNT; msg++) {
        (void)caekf_proto_decode_value((caekf_msg_t)msg, any_payload(), (uint16_t *)Frama_C_nondet_ptr(NULL, &step),
                                       (double *)Frama_C_nondet_ptr(NULL, &value));
        (void)caekf_proto_encode_value((caekf_msg_t)msg, any_u16(), any_double(0u), any_payload());
        (void)caekf_proto_encode_value((caekf_msg_t)msg, any_u16(), any_double(1u), any_payload());
    }

    /* CTRL_PARAM's value: every mantissa and exponent a decoded frame can hold, and beyond. */
    any_bytes(&param, sizeof param);
    (void)caekf_proto_param_value((const caekf_msg_param_t *)Frama_C_nondet_ptr(NULL, &param),
                                  (double *)Frama_C_nondet_ptr(NULL, &pv));
}

int main(void)
{
    crcs();
    e2e();
    message_table();
    codecs();
    return 0;
}
