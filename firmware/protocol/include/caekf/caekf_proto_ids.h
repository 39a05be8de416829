/*
 * Wire-level enumerations of the caekf CAN protocol. Each mirrors a value table or a signal list of
 * caekf.dbc (the source of truth); tests/protocol cross-checks both.
 */
#ifndef CAEKF_PROTO_IDS_H
#define CAEKF_PROTO_IDS_H

#ifdef __cplusplus
extern "C" {
#endif

/* CTRL_PARAM.PARAM_ID: the estimator's parameter ids (CAEKF_PARAM_*, caekf_param_key), generated from
 * the settings schema into caekf/caekf_settings_schema.h; the DBC's value table is generated too. */

/* EST_ACK.ACK_STATUS. */
typedef enum {
    CAEKF_ACK_STATUS = 1,              /* answer to CTRL_STATUS_REQ */
    CAEKF_ACK_ACCEPTED = 0,            /* configuration accepted, estimator re-initialised */
    CAEKF_ACK_REFUSED_SETTINGS = -1,   /* caekf_settings_validate refused; BAD_PARAM names the field */
    CAEKF_ACK_REFUSED_INCOMPLETE = -2, /* N_PARAMS differs from the CTRL_PARAM frames accepted */
    /* -3 is retired (a value the wire no longer carries) */
    CAEKF_ACK_REFUSED_PARAM = -4,       /* a CTRL_PARAM frame had an unknown id or an unusable value */
    CAEKF_ACK_REFUSED_NO_SETTINGS = -5, /* N_PARAMS = 0 but nothing was ever configured */
    CAEKF_ACK_REFUSED_INIT = -6         /* caekf_init failed for another reason */
} caekf_ack_status_t;
#define CAEKF_ACK_BAD_PARAM_NONE 255u
#define CAEKF_ACK_STATE_CONFIGURED 0x01u
#define CAEKF_ACK_STATE_STAGED 0x02u

/* EST_HEALTH counters; page p carries counters 2p and 2p+1. */
typedef enum {
    CAEKF_CNT_RX_OK = 0,
    CAEKF_CNT_RX_UNKNOWN_ID,
    CAEKF_CNT_RX_BAD_DLC,
    CAEKF_CNT_RX_BAD_CRC,
    CAEKF_CNT_RX_COUNTER_JUMP,
    CAEKF_CNT_RX_DUPLICATE,
    CAEKF_CNT_RX_LOST,
    CAEKF_CNT_RX_BAD_VALUE,
    CAEKF_CNT_RX_UNCONFIGURED,
    CAEKF_CNT_RX_LATE,
    CAEKF_CNT_RX_REPEATED,
    CAEKF_CNT_RX_HAL_ERROR,
    CAEKF_CNT_STEPS_DONE,
    CAEKF_CNT_STEPS_FAILED,
    CAEKF_CNT_STEPS_TIMED_OUT,
    CAEKF_CNT_STEPS_SUPERSEDED,
    CAEKF_CNT_STEPS_SKIPPED,
    CAEKF_CNT_TX_FRAMES,
    CAEKF_CNT_TX_ERRORS,
    CAEKF_CNT_TX_SATURATED,
    CAEKF_CNT_CFG_ACCEPTED,
    CAEKF_CNT_CFG_REFUSED,
    CAEKF_CNT_PARAMS_RX,
    CAEKF_CNT_STATUS_REQUESTS,
    CAEKF_CNT_COUNT
} caekf_counter_id_t;
#define CAEKF_HEALTH_PAGES (CAEKF_CNT_COUNT / 2)
#define CAEKF_HEALTH_COUNTER_MASK 0xFFFFFFu /* counters travel modulo 2^24 */

/* EST_STEP.FLAGS: bits 0..11 are the estimator's CAEKF_FLAG_*; the app adds these. */
#define CAEKF_STEP_FLAG_SATURATED (1u << 12)         /* an output value was clipped to its signal range */
#define CAEKF_STEP_FLAG_STEP_GAP (1u << 13)          /* steps before this one were never estimated */
#define CAEKF_STEP_FLAG_PNORM_UNAVAILABLE (1u << 14) /* P_NORM could not be computed (sent as NaN) */

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_PROTO_IDS_H */
