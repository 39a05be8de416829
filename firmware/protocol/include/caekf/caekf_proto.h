/*
 * caekf CAN protocol: frame type, message table and the allocation-free codec of caekf.dbc.
 *
 * Layers: caekf_proto_encode_* fill payload bytes 1..7 (E2E fields zero); caekf_proto_seal() adds
 * ID, DLC, alive counter and CRC. On receive, check E2E first (caekf_e2e_check), then decode.
 * Encoding follows cantools exactly: scaled integers are round-half-even of value / LSB, float
 * signals are IEEE-754 float32, little-endian bit order. tests/protocol compares both byte for byte.
 */
#ifndef CAEKF_PROTO_H
#define CAEKF_PROTO_H

#include <stdint.h>

#include "caekf/caekf_proto_frames.h" /* generated from caekf.dbc at build time */

#ifdef __cplusplus
extern "C" {
#endif

#define CAEKF_CAN_DLC 8u         /* bytes of a classic frame: every message but the CAN FD profile's */
#define CAEKF_CAN_FD_MAX_LEN 64u /* bytes of the longest CAN FD frame */
#define CAEKF_FD_IN_LEN CAEKF_MSG_LEN_BENCH_FD
#define CAEKF_FD_OUT_LEN CAEKF_MSG_LEN_EST_FD
#define CAEKF_CAN_ID_EXT_FLAG 0x80000000u /* set by a HAL for 29-bit IDs: never a caekf message */

typedef struct {
    uint32_t id; /* 11-bit standard ID, or 29-bit ID | CAEKF_CAN_ID_EXT_FLAG */
    uint8_t dlc; /* data length in bytes: 0..8 classic, up to 64 for a CAN FD frame */
    uint8_t data[CAEKF_CAN_FD_MAX_LEN];
} caekf_can_frame_t;

typedef enum {
    CAEKF_PROTO_OK = 0,
    CAEKF_PROTO_SATURATED = 1, /* encoded, but a value was outside its signal range and clipped */
    CAEKF_PROTO_ERR_NULL = -1,
    CAEKF_PROTO_ERR_MSG = -2,   /* unknown message, or the message does not have this layout */
    CAEKF_PROTO_ERR_VALUE = -3, /* a decoded float is not finite or a field is outside its set */
    CAEKF_PROTO_ERR_RANGE = -4  /* a field to encode is outside its set: nothing written */
} caekf_proto_status_t;

/* Protocol profiles: which frames carry a step. The app sends the estimate frames of its profile;
 * it accepts the input frames of every profile. */
typedef enum {
    CAEKF_PROFILE_DIAGNOSTICS = 0, /* the mechanism's input frames in (the paper: BENCH_U/Y1/Y4), EST_GAMMA, EST_Q/V
                                      of every body, EST_P_NORM, EST_P_GG (+ EST_GAMMA2, EST_P_GG2), EST_STEP out
                                      per step (vcan, the HIL reference; the paper: 12 frames) */
    CAEKF_PROFILE_PRODUCTION = 1,  /* BENCH_U + BENCH_YP in, EST_PROD out per step, EST_PAGE pages */
    CAEKF_PROFILE_FD = 2,          /* CAN FD: BENCH_FD in, EST_FD out per step (E2E with CRC-16) */
    CAEKF_PROFILE_COUNT
} caekf_profile_t;

typedef enum { CAEKF_DIR_TO_ESTIMATOR = 0, CAEKF_DIR_FROM_ESTIMATOR = 1 } caekf_dir_t;

typedef struct {
    const char *name; /* DBC message name */
    uint16_t can_id;
    uint16_t data_id; /* E2E data ID (DBC attribute E2E_DataID) */
    uint8_t layout;   /* caekf_layout_t */
    uint8_t dir;      /* caekf_dir_t */
    uint8_t len;      /* payload bytes: CAEKF_CAN_DLC, or a CAN FD frame's length (E2E with CRC-16) */
    double lsb;       /* value LSB of CAEKF_LAYOUT_INT36 messages, else 0 */
} caekf_msg_info_t;

caekf_proto_status_t caekf_proto_msg_info(caekf_msg_t msg, const caekf_msg_info_t **info);
/* CAEKF_PROTO_ERR_MSG for IDs that are not in the protocol (extended IDs included). */
caekf_proto_status_t caekf_proto_msg_from_id(uint32_t can_id, caekf_msg_t *msg);

/* Runtime ID base, for a bus that already uses the DBC's IDs: every message travels at its DBC ID +
 * id_offset. The block moves as a whole (relative order, hence arbitration priority, kept); the E2E
 * data IDs stay the DBC's. An offset is valid when every ID stays within 0..CAEKF_CAN_SFF_MAX
 * (CAEKF_PROTO_ERR_RANGE otherwise; caekf_proto_bus_id refuses invalid offsets the same way). */
#define CAEKF_CAN_SFF_MAX 0x7FFu
caekf_proto_status_t caekf_proto_id_offset_check(int32_t id_offset);
/* The bus ID of msg at id_offset. */
caekf_proto_status_t caekf_proto_bus_id(caekf_msg_t msg, int32_t id_offset, uint32_t *can_id);
/* The message travelling at bus ID can_id with id_offset (CAEKF_PROTO_ERR_MSG: not ours). Per frame, so
 * the offset is not re-checked: check it once (caekf_app_init does). */
caekf_proto_status_t caekf_proto_msg_from_bus_id(uint32_t can_id, int32_t id_offset, caekf_msg_t *msg);

/* Sets ID and DLC (the message's length), writes the alive counter and the CRC (CRC-16 for CAN FD frames). */
caekf_proto_status_t caekf_proto_seal(caekf_msg_t msg, uint8_t counter, caekf_can_frame_t *frame);

/* Step value frames (INT36 and FLOAT32 layouts: BENCH_U/U2/Y1/Y4/S*_POS/S*_VEL, EST_GAMMA/GAMMA2/Q/V/P_NORM/
 * P_GG/P_GG2).
 * Encode: out-of-range values are clipped and CAEKF_PROTO_SATURATED returned (NaN in an INT36 signal
 * becomes 0, saturated); float signals carry NaN and infinities unchanged.
 * Decode: CAEKF_PROTO_ERR_VALUE for a non-finite float; outputs are written only on success. */
caekf_proto_status_t caekf_proto_encode_value(caekf_msg_t msg, uint16_t step, double value,
                                              uint8_t data[CAEKF_CAN_DLC]);
caekf_proto_status_t caekf_proto_decode_value(caekf_msg_t msg, const uint8_t data[CAEKF_CAN_DLC], uint16_t *step,
                                              double *value);

/* The messages whose signals are integers as they travel (CTRL_RESET, CTRL_PARAM, CTRL_STATUS_REQ, EST_ACK,
 * EST_STEP): their structs (caekf_msg_<name>_t, one field per signal) and codecs are generated from the DBC.
 * CTRL_PARAM: value = param_mantissa * 10^param_exp10 (caekf_proto_param_value). EST_ACK.bad_param is a
 * CAEKF_PARAM_* id (+ element) or CAEKF_ACK_BAD_PARAM_NONE, state the CAEKF_ACK_STATE_* bits; EST_STEP.flags
 * is CAEKF_FLAG_* | CAEKF_STEP_FLAGS_*, step_status the step's caekf_status_t. */
#include "caekf/caekf_proto_messages.h" /* generated from caekf.dbc at build time */

typedef struct {
    uint8_t page;       /* 0 .. CAEKF_HEALTH_PAGES-1 */
    uint32_t counter_a; /* counter 2*page, sent modulo 2^24 */
    uint32_t counter_b; /* counter 2*page+1 */
} caekf_msg_health_t;

/* Encode refuses pages >= CAEKF_HEALTH_PAGES; counters are reduced modulo 2^24. */
caekf_proto_status_t caekf_proto_encode_health(const caekf_msg_health_t *m, uint8_t data[CAEKF_CAN_DLC]);
caekf_proto_status_t caekf_proto_decode_health(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_health_t *m);

/* Production profile frames. */
/* CAEKF_YP_LSB, CAEKF_YP_BITS, CAEKF_PROD_FLAGS_MASK, CAEKF_PAGE_COUNT, CAEKF_PAGE_STEP_INFO: generated from the
 * DBC (caekf/caekf_proto_frames.h). */

typedef struct {
    uint8_t step;  /* STEP modulo 2^8 (the app unwraps it against BENCH_U's 16-bit STEP) */
    double y1, y4; /* m */
} caekf_msg_yp_t;

typedef struct {
    uint8_t step;   /* STEP modulo 2^8 (CAEKF_PROD_STEP_MASK) */
    uint16_t flags; /* the estimator's flags (CAEKF_PROD_FLAGS_MASK) */
    double gamma;   /* sent as float32 */
} caekf_msg_prod_t;

typedef struct {
    uint8_t page; /* 0..3 q1..q4, 4..7 v1..v4, 8 P_NORM, 9 P_GAMMA_GAMMA, 10 step info */
    uint16_t step;
    double value;          /* pages 0..9, sent as float32 */
    caekf_msg_step_t info; /* page 10 (info.step is ignored: `step` is sent) */
} caekf_msg_page_t;

/* BENCH_YP: out-of-range positions are clipped (CAEKF_PROTO_SATURATED); NaN becomes 0, saturated. */
caekf_proto_status_t caekf_proto_encode_yp(const caekf_msg_yp_t *m, uint8_t data[CAEKF_CAN_DLC]);
caekf_proto_status_t caekf_proto_decode_yp(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_yp_t *m);
/* EST_PROD / EST_PAGE: float values beyond the float32 range are clipped (SATURATED), NaN and
 * infinities travel unchanged (outputs: the decoders return them too). encode_page refuses pages
 * >= CAEKF_PAGE_COUNT (CAEKF_PROTO_ERR_RANGE); decode_page returns CAEKF_PROTO_ERR_VALUE for them. */
caekf_proto_status_t caekf_proto_encode_prod(const caekf_msg_prod_t *m, uint8_t data[CAEKF_CAN_DLC]);
caekf_proto_status_t caekf_proto_decode_prod(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_prod_t *m);
caekf_proto_status_t caekf_proto_encode_page(const caekf_msg_page_t *m, uint8_t data[CAEKF_CAN_DLC]);
caekf_proto_status_t caekf_proto_decode_page(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_page_t *m);

/* CAN FD profile frames (20 and 64 bytes). */
typedef struct {
    uint16_t step;
    double u;      /* N, float32 on the wire */
    double y1, y4; /* m, LSB 1e-12 m */
} caekf_msg_fd_in_t;

typedef struct {
    uint16_t step;
    double x[9];           /* q1..q4 (LSB 1e-12 m), v1..v4 (LSB 1e-10 m/s), gamma (float32) */
    double p_norm, p_gg;   /* float32 */
    caekf_msg_step_t info; /* FLAGS, NEWTON_ITERS, STEP_STATUS (info.step is ignored: `step` is sent) */
} caekf_msg_fd_out_t;

/* BENCH_FD: encode clips positions to their range (SATURATED), NaN y becomes 0, saturated; decode refuses a
 * non-finite U (CAEKF_PROTO_ERR_VALUE). EST_FD: positions and velocities clipped as in the diagnostics
 * frames, float values as EST_PROD's. Payload bytes 0..2 (CRC-16, counter) are left for the E2E seal. */
caekf_proto_status_t caekf_proto_encode_fd_in(const caekf_msg_fd_in_t *m, uint8_t data[CAEKF_CAN_FD_MAX_LEN]);
caekf_proto_status_t caekf_proto_decode_fd_in(const uint8_t data[CAEKF_CAN_FD_MAX_LEN], caekf_msg_fd_in_t *m);
caekf_proto_status_t caekf_proto_encode_fd_out(const caekf_msg_fd_out_t *m, uint8_t data[CAEKF_CAN_FD_MAX_LEN]);
caekf_proto_status_t caekf_proto_decode_fd_out(const uint8_t data[CAEKF_CAN_FD_MAX_LEN], caekf_msg_fd_out_t *m);

/* mantissa * 10^exp10 as a double. Exact (correctly rounded, the same double a decimal parser gives)
 * because |mantissa| < 2^53 and 10^|exp10| <= 10^22 are exact and one IEEE division or
 * multiplication rounds once. CAEKF_PROTO_ERR_VALUE if |exp10| > 22. */
caekf_proto_status_t caekf_proto_param_value(const caekf_msg_param_t *m, double *value);

/* Counter names as in caekf.dbc (signal names). ERR_RANGE for an unknown value. Parameter names:
 * caekf_param_key (the settings schema). */
caekf_proto_status_t caekf_proto_counter_name(unsigned counter_id, const char **name);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_PROTO_H */
