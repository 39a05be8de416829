/* The message table of caekf.dbc: IDs, E2E data IDs, layouts and value LSBs. */
#include <stddef.h>

#include "caekf/caekf_e2e.h"
#include "caekf/caekf_proto.h"
#include "caekf_proto_frames_table.h" /* generated from caekf.dbc */

/* Data ID = 0xCA00 | low byte of the CAN ID (the DBC's E2E_DataID): unique here, and unlike the CAN ID. */
static const caekf_msg_info_t msg_table[CAEKF_MSG_COUNT] = {CAEKF_MSG_TABLE_ROWS};

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
    /* Beyond +-SFF_MAX no table id lands on the bus; checked first, the sums below cannot overflow. */
    if (id_offset > (int32_t)CAEKF_CAN_SFF_MAX || id_offset < -(int32_t)CAEKF_CAN_SFF_MAX) {
        return CAEKF_PROTO_ERR_RANGE;
    }
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
