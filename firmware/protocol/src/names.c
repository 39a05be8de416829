/* Names of the wire enumerations, spelled as in caekf.dbc (signal names); parameter names come from the settings schema (caekf_param_key). */
#include <stddef.h>

#include "caekf/caekf_proto.h"

static const char *const counter_names[CAEKF_CNT_COUNT] = {
    "RX_OK",      "RX_UNKNOWN_ID", "RX_BAD_DLC",      "RX_BAD_CRC",       "RX_COUNTER_JUMP", "RX_DUPLICATE",
    "RX_LOST",    "RX_BAD_VALUE",  "RX_UNCONFIGURED", "RX_LATE",          "RX_REPEATED",     "RX_HAL_ERROR",
    "STEPS_DONE", "STEPS_FAILED",  "STEPS_TIMED_OUT", "STEPS_SUPERSEDED", "STEPS_SKIPPED",   "TX_FRAMES",
    "TX_ERRORS",  "TX_SATURATED",  "CFG_ACCEPTED",    "CFG_REFUSED",      "PARAMS_RX",       "STATUS_REQUESTS",
};

static caekf_proto_status_t lookup(const char *const *table, unsigned count, unsigned index, const char **name)
{
    if (name == NULL) {
        return CAEKF_PROTO_ERR_NULL;
    }
    if (index >= count) {
        return CAEKF_PROTO_ERR_RANGE;
    }
    *name = table[index];
    return CAEKF_PROTO_OK;
}

caekf_proto_status_t caekf_proto_counter_name(unsigned counter_id, const char **name)
{
    return lookup(counter_names, CAEKF_CNT_COUNT, counter_id, name);
}
