/*
 * Wire-level constants of the caekf CAN protocol that the DBC states in its comments (bits of EST_ACK.STATE
 * and EST_STEP.FLAGS); its value tables and signal lists are generated (caekf/caekf_proto_frames.h).
 */
#ifndef CAEKF_PROTO_IDS_H
#define CAEKF_PROTO_IDS_H

#ifdef __cplusplus
extern "C" {
#endif

/* CTRL_PARAM.PARAM_ID: the estimator's parameter ids (CAEKF_PARAM_*, caekf_param_key), generated from
 * the settings schema into caekf/caekf_settings_schema.h; the DBC's value table is generated too. */

/* EST_ACK.ACK_STATUS (caekf_ack_status_t) and EST_HEALTH's counters (caekf_counter_id_t) are generated from
 * the DBC (caekf/caekf_proto_frames.h). */
#define CAEKF_ACK_BAD_PARAM_NONE 255u
#define CAEKF_ACK_STATE_CONFIGURED 0x01u
#define CAEKF_ACK_STATE_STAGED 0x02u

#define CAEKF_HEALTH_PAGES (CAEKF_CNT_COUNT / 2)

/* EST_STEP.FLAGS: bits 0..11 are the estimator's CAEKF_FLAG_*; the app adds these. */
#define CAEKF_STEP_FLAG_SATURATED (1u << 12)         /* an output value was clipped to its signal range */
#define CAEKF_STEP_FLAG_STEP_GAP (1u << 13)          /* steps before this one were never estimated */
#define CAEKF_STEP_FLAG_PNORM_UNAVAILABLE (1u << 14) /* P_NORM could not be computed (sent as NaN) */

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_PROTO_IDS_H */
