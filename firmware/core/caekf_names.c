/* The names of statuses and flags, for hosts, logs and tools: in the names library (<core>_names) with the
 * settings' names, so the estimator itself carries no strings (an MCU image links them only if it prints
 * one). */
#include "caekf/caekf.h"

const char *caekf_status_str(caekf_status_t st)
{
    switch (st) {
    case CAEKF_OK: return "ok";
    case CAEKF_ERR_NULL: return "null pointer";
    case CAEKF_ERR_SETTINGS: return "settings refused";
    case CAEKF_ERR_NOT_INIT: return "not initialised";
    case CAEKF_ERR_INPUT: return "non-finite input rejected";
    case CAEKF_ERR_NUMERIC: return "non-finite result, rolled back";
    case CAEKF_ERR_SINGULAR: return "singular matrix, rolled back";
    default: return "unknown status";
    }
}

const char *caekf_flag_name(unsigned bit_index)
{
    static const char *const names[CAEKF_FLAG_COUNT] = {
        "newton_not_converged", "input_rejected",      "constraint_applied", "contact_active",
        "cov_repaired",         "singular_innovation", "constraint_clamped", "numeric_rollback",
        "gamma_frozen",         "cov_indefinite",      "no_measurement",     "gamma_gated"};
    return bit_index < CAEKF_FLAG_COUNT ? names[bit_index] : "unknown";
}
