/* The names of statuses, for hosts, logs and tools: in the names library (<core>_names) with the names of
 * the settings and flags (generated: caekf_settings_names.c), so the estimator itself carries no strings
 * (an MCU image links them only if it prints one). */
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
