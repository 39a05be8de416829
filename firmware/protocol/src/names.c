/* Names of the wire enumerations, spelled as in caekf.dbc (signal names); parameter names come from the settings schema (caekf_param_key). */
#include <stddef.h>

#include "caekf/caekf_proto.h"
#include "caekf_proto_frames_table.h" /* generated from caekf.dbc */

static const char *const counter_names[CAEKF_CNT_COUNT] = {CAEKF_COUNTER_NAMES};

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
