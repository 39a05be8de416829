/* The message table of caekf.dbc: IDs, E2E data IDs, layouts and value LSBs. */
#include <stddef.h>

#include "caekf/caekf_e2e.h"
#include "caekf/caekf_proto.h"

#define POS_LSB 1e-12 /* m per LSB of positions */
#define VEL_LSB 1e-10 /* m/s per LSB of velocities */

/* Data ID = 0xCA00 | low byte of the CAN ID: unique here, and unlike the CAN ID itself. */
static const caekf_msg_info_t msg_table[CAEKF_MSG_COUNT] = {
    {"CTRL_RESET", 0x0C0, 0xCAC0, CAEKF_LAYOUT_RESET, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"CTRL_PARAM", 0x0C1, 0xCAC1, CAEKF_LAYOUT_PARAM, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"CTRL_STATUS_REQ", 0x0C2, 0xCAC2, CAEKF_LAYOUT_STATUS_REQ, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"BENCH_U", 0x100, 0xCA00, CAEKF_LAYOUT_FLOAT32, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"BENCH_Y1", 0x101, 0xCA01, CAEKF_LAYOUT_INT36, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"BENCH_Y4", 0x102, 0xCA02, CAEKF_LAYOUT_INT36, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"EST_ACK", 0x0C8, 0xCAC8, CAEKF_LAYOUT_ACK, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"EST_HEALTH", 0x0C9, 0xCAC9, CAEKF_LAYOUT_HEALTH, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"EST_GAMMA", 0x180, 0xCA80, CAEKF_LAYOUT_FLOAT32, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"EST_Q1", 0x181, 0xCA81, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"EST_Q2", 0x182, 0xCA82, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"EST_Q3", 0x183, 0xCA83, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"EST_Q4", 0x184, 0xCA84, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"EST_V1", 0x185, 0xCA85, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"EST_V2", 0x186, 0xCA86, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"EST_V3", 0x187, 0xCA87, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"EST_V4", 0x188, 0xCA88, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"EST_P_NORM", 0x189, 0xCA89, CAEKF_LAYOUT_FLOAT32, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"EST_P_GG", 0x18A, 0xCA8A, CAEKF_LAYOUT_FLOAT32, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"EST_STEP", 0x18B, 0xCA8B, CAEKF_LAYOUT_STEP, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"BENCH_YP", 0x103, 0xCA03, CAEKF_LAYOUT_YP, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, CAEKF_YP_LSB},
    {"EST_PROD", 0x190, 0xCA90, CAEKF_LAYOUT_PROD, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"EST_PAGE", 0x191, 0xCA91, CAEKF_LAYOUT_PAGE, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"BENCH_FD", 0x104, 0xCA04, CAEKF_LAYOUT_FD_IN, CAEKF_DIR_TO_ESTIMATOR, CAEKF_FD_IN_LEN, 0.0},
    {"EST_FD", 0x192, 0xCA92, CAEKF_LAYOUT_FD_OUT, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_FD_OUT_LEN, 0.0},
    {"BENCH_U2", 0x105, 0xCA05, CAEKF_LAYOUT_FLOAT32, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"BENCH_S3_POS", 0x106, 0xCA06, CAEKF_LAYOUT_INT36, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"BENCH_S4_POS", 0x107, 0xCA07, CAEKF_LAYOUT_INT36, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"BENCH_S1_VEL", 0x108, 0xCA08, CAEKF_LAYOUT_INT36, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"BENCH_S2_VEL", 0x109, 0xCA09, CAEKF_LAYOUT_INT36, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"BENCH_S3_VEL", 0x10A, 0xCA0A, CAEKF_LAYOUT_INT36, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"BENCH_S4_VEL", 0x10B, 0xCA0B, CAEKF_LAYOUT_INT36, CAEKF_DIR_TO_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"EST_Q5", 0x193, 0xCA93, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"EST_Q6", 0x194, 0xCA94, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"EST_Q7", 0x195, 0xCA95, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"EST_Q8", 0x196, 0xCA96, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, POS_LSB},
    {"EST_V5", 0x197, 0xCA97, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"EST_V6", 0x198, 0xCA98, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"EST_V7", 0x199, 0xCA99, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"EST_V8", 0x19A, 0xCA9A, CAEKF_LAYOUT_INT36, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, VEL_LSB},
    {"EST_GAMMA2", 0x19B, 0xCA9B, CAEKF_LAYOUT_FLOAT32, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
    {"EST_P_GG2", 0x19C, 0xCA9C, CAEKF_LAYOUT_FLOAT32, CAEKF_DIR_FROM_ESTIMATOR, CAEKF_CAN_DLC, 0.0},
};

caekf_proto_status_t caekf_proto_msg_info(caekf_msg_t msg, const caekf_msg_info_t **info)
{
    if (info == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if ((unsigned)msg >= (unsigned)CAEKF_MSG_COUNT) {
        return CAEKF_PROTO_ERR_MSG;
    }
    *info = &msg_table[msg];
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_msg_from_id(uint32_t can_id, caekf_msg_t *msg)
{
    return caekf_proto_msg_from_bus_id(can_id, 0, msg);
}

caekf_proto_status_t caekf_proto_id_offset_check(int32_t id_offset)
{
    unsigned i;
    for (i = 0; i < (unsigned)CAEKF_MSG_COUNT; i++) {
        const int32_t id = (int32_t)msg_table[i].can_id + id_offset;
        if (id < 0 || id > (int32_t)CAEKF_CAN_SFF_MAX) {
            return CAEKF_PROTO_ERR_RANGE;
        }
    }
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_bus_id(caekf_msg_t msg, int32_t id_offset, uint32_t *can_id)
{
    if (can_id == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if ((unsigned)msg >= (unsigned)CAEKF_MSG_COUNT) {
        return CAEKF_PROTO_ERR_MSG;
    }
    if (caekf_proto_id_offset_check(id_offset) != CAEKF_PROTO_OK) {
        return CAEKF_PROTO_ERR_RANGE;
    }
    *can_id = (uint32_t)((int32_t)msg_table[msg].can_id + id_offset);
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_msg_from_bus_id(uint32_t can_id, int32_t id_offset, caekf_msg_t *msg)
{
    unsigned i;
    if (msg == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    for (i = 0; i < (unsigned)CAEKF_MSG_COUNT; i++) {
        /* extended IDs carry the flag bit: never equal */
        if ((uint32_t)((int32_t)msg_table[i].can_id + id_offset) == can_id) {
            *msg = (caekf_msg_t)i;
            return CAEKF_PROTO_OK;
        }
    }
    return CAEKF_PROTO_ERR_MSG;
}

caekf_proto_status_t caekf_proto_seal(caekf_msg_t msg, uint8_t counter, caekf_can_frame_t *frame)
{
    if (frame == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if ((unsigned)msg >= (unsigned)CAEKF_MSG_COUNT) {
        return CAEKF_PROTO_ERR_MSG;
    }
    frame->id = msg_table[msg].can_id;
    frame->dlc = msg_table[msg].len;
    if (msg_table[msg].len > CAEKF_CAN_DLC) {
        (void)caekf_e2e_protect_fd(msg_table[msg].data_id, counter, frame->data, msg_table[msg].len);
    } else {
        (void)caekf_e2e_protect(msg_table[msg].data_id, counter, frame->data);
    }
    return CAEKF_PROTO_OK;
}
