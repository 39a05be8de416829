/*
 * Wire-level enumerations of the caekf CAN protocol. Each mirrors a value table or a signal list of
 * caekf.dbc (the source of truth); tests/protocol cross-checks both.
 */
#ifndef CAEKF_PROTO_IDS_H
#define CAEKF_PROTO_IDS_H

#ifdef __cplusplus
extern "C" {
#endif

/* CTRL_RESET.EXPERIMENT: the paper's four experiments (see shared SCENARIO.md). */
typedef enum {
    CAEKF_EXPERIMENT_CANONICAL = 0,                  /* AEKF of Table 1 */
    CAEKF_EXPERIMENT_SWITCHED = 1,                   /* AEKF for contact, Q_gamma as given */
    CAEKF_EXPERIMENT_SWITCHED_HIGHQ = 2,             /* Q_gamma times highq_scale */
    CAEKF_EXPERIMENT_SWITCHED_HIGHQ_CONSTRAINED = 3, /* ... and gamma >= gamma_min */
    CAEKF_EXPERIMENT_COUNT = 4
} caekf_proto_experiment_t;
#define CAEKF_EXPERIMENT_NONE 255u /* EST_ACK.EXPERIMENT while not configured */

/* CTRL_PARAM.PARAM_ID. Names (caekf_proto_param_name) equal the scenario file keys. */
typedef enum {
    CAEKF_PARAM_M1 = 0, CAEKF_PARAM_M2, CAEKF_PARAM_M3, CAEKF_PARAM_M4,
    CAEKF_PARAM_K1, CAEKF_PARAM_K12, CAEKF_PARAM_K34, CAEKF_PARAM_K4,
    CAEKF_PARAM_C1, CAEKF_PARAM_C12, CAEKF_PARAM_C34, CAEKF_PARAM_C4,
    CAEKF_PARAM_GAP, CAEKF_PARAM_DT,
    CAEKF_PARAM_Q0_1, CAEKF_PARAM_Q0_2, CAEKF_PARAM_Q0_3, CAEKF_PARAM_Q0_4,
    CAEKF_PARAM_V0_1, CAEKF_PARAM_V0_2, CAEKF_PARAM_V0_3, CAEKF_PARAM_V0_4,
    CAEKF_PARAM_GAMMA0, CAEKF_PARAM_SIGMA_Q0, CAEKF_PARAM_SIGMA_V0, CAEKF_PARAM_SIGMA_GAMMA0,
    CAEKF_PARAM_SIGMA_QX_Q, CAEKF_PARAM_SIGMA_QX_V, CAEKF_PARAM_SIGMA_Q_GAMMA, CAEKF_PARAM_SIGMA_R,
    CAEKF_PARAM_GAMMA_MIN,
    CAEKF_PARAM_HIGHQ_SCALE,     /* Q_gamma factor of the highq experiments (paper: 1000) */
    CAEKF_PARAM_SWITCHOFF,       /* caekf_switchoff_t */
    CAEKF_PARAM_COV_UPDATE,      /* caekf_cov_update_t */
    CAEKF_PARAM_COV_REPAIR,      /* 0 or 1 */
    CAEKF_PARAM_NEWTON_MAX_ITER, /* integer */
    CAEKF_PARAM_NEWTON_RTOL,
    CAEKF_PARAM_GAMMA_GATE_NIS,  /* innovation gate on the gamma correction, 0 = off */
    CAEKF_PARAM_COUNT
} caekf_param_id_t;

/* EST_ACK.ACK_STATUS. */
typedef enum {
    CAEKF_ACK_STATUS = 1,               /* answer to CTRL_STATUS_REQ */
    CAEKF_ACK_ACCEPTED = 0,             /* configuration accepted, estimator re-initialised */
    CAEKF_ACK_REFUSED_SETTINGS = -1,    /* caekf_settings_validate refused; BAD_PARAM names the field */
    CAEKF_ACK_REFUSED_INCOMPLETE = -2,  /* N_PARAMS differs from the CTRL_PARAM frames accepted */
    CAEKF_ACK_REFUSED_EXPERIMENT = -3,  /* unknown experiment */
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
