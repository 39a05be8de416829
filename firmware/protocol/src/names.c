/* Names of the wire enumerations, spelled as in caekf.dbc (value tables and signal names). */
#include <stddef.h>

#include "caekf/caekf_proto.h"

static const char *const param_names[CAEKF_PARAM_COUNT] = {
    "m1", "m2", "m3", "m4", "k1", "k12", "k34", "k4", "c1", "c12", "c34", "c4", "gap", "dt",
    "q0_1", "q0_2", "q0_3", "q0_4", "v0_1", "v0_2", "v0_3", "v0_4",
    "gamma0", "sigma_q0", "sigma_v0", "sigma_gamma0", "sigma_qx_q", "sigma_qx_v", "sigma_q_gamma", "sigma_r",
    "gamma_min", "highq_scale", "switchoff", "cov_update", "cov_repair", "newton_max_iter", "newton_rtol",
    "gamma_gate_nis",
};

static const char *const counter_names[CAEKF_CNT_COUNT] = {
    "RX_OK", "RX_UNKNOWN_ID", "RX_BAD_DLC", "RX_BAD_CRC", "RX_COUNTER_JUMP", "RX_DUPLICATE",
    "RX_LOST", "RX_BAD_VALUE", "RX_UNCONFIGURED", "RX_LATE", "RX_REPEATED", "RX_HAL_ERROR",
    "STEPS_DONE", "STEPS_FAILED", "STEPS_TIMED_OUT", "STEPS_SUPERSEDED", "STEPS_SKIPPED",
    "TX_FRAMES", "TX_ERRORS", "TX_SATURATED", "CFG_ACCEPTED", "CFG_REFUSED", "PARAMS_RX",
    "STATUS_REQUESTS",
};

static const char *const experiment_names[CAEKF_EXPERIMENT_COUNT] = {
    "canonical", "switched", "switched-highq", "switched-highq-constrained",
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

caekf_proto_status_t caekf_proto_param_name(unsigned param_id, const char **name)
{
    return lookup(param_names, CAEKF_PARAM_COUNT, param_id, name);
}

caekf_proto_status_t caekf_proto_counter_name(unsigned counter_id, const char **name)
{
    return lookup(counter_names, CAEKF_CNT_COUNT, counter_id, name);
}

caekf_proto_status_t caekf_proto_experiment_name(unsigned experiment, const char **name)
{
    return lookup(experiment_names, CAEKF_EXPERIMENT_COUNT, experiment, name);
}
