/* The text of a settings refusal, for host tools and logs. A separate object: an MCU image that never
 * prints one does not link it (or the names). */
#include <stdio.h>

#include "caekf/caekf.h"

caekf_status_t caekf_setting_error_text(const caekf_setting_error_t *err, const caekf_settings_t *s, char *buf,
                                        unsigned len)
{
    const char *name, *why;
    caekf_setting_rule_t rule;
    char element[48], value[40] = "";
    double v;
    if (err == 0 || buf == 0 || len == 0) {
        return CAEKF_ERR_NULL;
    }
    if (err->reason == CAEKF_SETTING_UNKNOWN_ID) {
        snprintf(buf, len, "parameter id %u: no such setting", (unsigned)err->param_id);
        return CAEKF_OK;
    }
    name = caekf_setting_name(err->setting);
    if (name == 0) {
        name = "?";
    }
    if (caekf_setting_rule(err->setting < CAEKF_SETTING_COUNT ? err->setting : 0u, &rule) == CAEKF_OK &&
        rule.count > 1) {
        snprintf(element, sizeof element, "%s[%u]", name, (unsigned)err->index);
    } else {
        snprintf(element, sizeof element, "%s", name);
    }
    if (s != 0 && caekf_settings_get(s, err->param_id, &v) == CAEKF_OK) {
        snprintf(value, sizeof value, " = %.17g", v);
    }
    switch (err->reason) {
    case CAEKF_SETTING_OK: snprintf(buf, len, "settings valid"); return CAEKF_OK;
    case CAEKF_SETTING_BELOW_GAMMA_MIN: why = "must be within gamma_min .. gamma_max while constraint_enabled"; break;
    case CAEKF_SETTING_NOT_SCALABLE:
        why = "a value the estimator derives from it is not finite in " CAEKF_SCALAR_NAME;
        break;
    case CAEKF_SETTING_OVER_CAPACITY:
        why = "exceeds the build's capacity (CAEKF_MAX_* and CAEKF_NEWTON_MAX_ITER, caekf_config.h)";
        break;
    case CAEKF_SETTING_NOT_INTEGER: why = "must be an integer"; break;
    case CAEKF_SETTING_NEEDED:
        why = "must be > 0: the settings use it (a velocity sensor, an estimated law parameter)";
        break;
    case CAEKF_SETTING_NOT_POSITIVE: why = "must be > 0 with gamma_log (the filter estimates ln gamma)"; break;
    case CAEKF_SETTING_OUTSIDE_BOUNDS:
        why = "outside the estimated parameter's bounds (its _min and _max; a maximum must not be below the minimum)";
        break;
    case CAEKF_SETTING_BAD_BODY:
        why = "must name a body of the mechanism (1..bodies; 0 = ground where allowed) other than the other end";
        break;
    case CAEKF_SETTING_BAD_LINK:
        why = "a base_displacement input must name a link of the mechanism (1..springs) with one end on the ground "
              "(0), and no link twice";
        break;
    case CAEKF_SETTING_UNSUPPORTED:
        why = "this build is sized for another mechanism or step method (CAEKF_SIZED: the counts, and with "
              "CAEKF_SIZED_METHOD the step method, must equal its own)";
        break;
    default: why = caekf_setting_rule_text(err->setting); break;
    }
    snprintf(buf, len, "%s%s: %s", element, value, why != 0 ? why : "refused");
    return CAEKF_OK;
}
