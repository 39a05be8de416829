/* Codec of the control frames beyond what the DBC generates (caekf_proto_messages.c: CTRL_RESET, CTRL_PARAM,
 * CTRL_STATUS_REQ, EST_ACK): a CTRL_PARAM's value, and EST_HEALTH's pages of counters, on the C pack/unpack
 * that cantools generates from caekf.dbc at build time. */
#include <stddef.h>
#include <string.h>

#include "caekf/caekf_proto.h"
#include "caekf_can.h"
#include "caekf_proto_frames_table.h" /* the signals' lengths and the counters' fields: generated from caekf.dbc */
#include "codec_status.h"

#define EXP10_MAX 22 /* 10^22 is the largest power of ten a double holds exactly */

caekf_proto_status_t caekf_proto_param_value(const caekf_msg_param_t *m, double *value)
{
    static const double powers_of_ten[EXP10_MAX + 1] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                                        1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                                        1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    if (m == NULL || value == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (m->param_exp10 > EXP10_MAX || m->param_exp10 < -EXP10_MAX) {
        return CAEKF_PROTO_ERR_VALUE;
    }
    if (m->param_exp10 >= 0) {
        *value = (double)m->param_mantissa * powers_of_ten[m->param_exp10];
    } else {
        *value = (double)m->param_mantissa / powers_of_ten[-m->param_exp10];
    }
    return CAEKF_PROTO_OK;
}

/* Counter id's field in the generated EST_HEALTH struct (page id / 2 carries it). */
static uint32_t *health_counter(struct caekf_can_est_health_t *g, unsigned id)
{
#define COUNTER_FIELD(name) &g->name,
    /* cppcheck-suppress constVariable ; the field is returned for writing */
    uint32_t *const field[CAEKF_CNT_COUNT] = {CAEKF_COUNTER_FIELDS(COUNTER_FIELD)};
#undef COUNTER_FIELD
    return field[id];
}

caekf_proto_status_t caekf_proto_encode_health(const caekf_msg_health_t *m, uint8_t data[CAEKF_CAN_DLC])
{
    struct caekf_can_est_health_t g;
    if (m == NULL || data == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (m->page >= CAEKF_HEALTH_PAGES) {
        return CAEKF_PROTO_ERR_RANGE;
    }
    (void)memset(&g, 0, sizeof g);
    g.page = m->page;
    *health_counter(&g, 2u * m->page) = m->counter_a & CAEKF_HEALTH_COUNTER_MASK;
    *health_counter(&g, 2u * m->page + 1u) = m->counter_b & CAEKF_HEALTH_COUNTER_MASK;
    return caekf_proto_packed(caekf_can_est_health_pack(data, &g, CAEKF_CAN_DLC), CAEKF_CAN_DLC, 0);
}

caekf_proto_status_t caekf_proto_decode_health(const uint8_t data[CAEKF_CAN_DLC], caekf_msg_health_t *m)
{
    struct caekf_can_est_health_t g;
    const caekf_proto_status_t st = CAEKF_PROTO_UNPACKED(m, data, caekf_can_est_health_unpack(&g, data, CAEKF_CAN_DLC));
    if (st != CAEKF_PROTO_OK) {
        return st;
    }
    if (g.page >= CAEKF_HEALTH_PAGES) {
        return CAEKF_PROTO_ERR_VALUE;
    }
    m->page = g.page;
    m->counter_a = *health_counter(&g, 2u * g.page);
    m->counter_b = *health_counter(&g, 2u * g.page + 1u);
    return CAEKF_PROTO_OK;
}
