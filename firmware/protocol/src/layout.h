/* Bit positions of the control frames' signals in caekf.dbc (start bit, length), little-endian. Private to
 * the codec. The per-step frames use the pack/unpack generated from the DBC (gen/caekf_can.h). */
#ifndef CAEKF_PROTO_LAYOUT_H
#define CAEKF_PROTO_LAYOUT_H

/* CTRL_RESET */
#define F_RESET_N_PARAMS 24u, 8u
#define F_RESET_TOKEN 32u, 8u

/* CTRL_PARAM */
#define F_PARAM_ID 12u, 8u
#define F_PARAM_EXP10 20u, 6u
#define F_PARAM_MANTISSA 26u, 38u
#define PARAM_EXP10_BITS 6u
#define PARAM_MANTISSA_BITS 38u

/* CTRL_STATUS_REQ */
#define F_STATUS_REQ_TOKEN 16u, 8u

/* EST_ACK */
#define F_ACK_TOKEN 16u, 8u
#define F_ACK_STATUS 24u, 8u
#define F_ACK_BAD_PARAM 32u, 8u
#define F_ACK_N_PARAMS_RX 48u, 8u
#define F_ACK_STATE 56u, 8u

/* EST_HEALTH */
#define F_HEALTH_PAGE 12u, 4u
#define F_HEALTH_A 16u, 24u
#define F_HEALTH_B 40u, 24u

#endif /* CAEKF_PROTO_LAYOUT_H */
