/* Scenario file (+ preset) -> caekf_app_settings_t, through the same parameter ids as CTRL_PARAM
 * (caekf_settings_set), so a scenario configured locally and one sent over CAN give the same estimator. */
#include "host_settings.h"

#include "common/scenario.h"

int host_settings_from_scenario(const char *path, const char *preset, caekf_app_settings_t *s, char *err,
                                unsigned err_len)
{
    caekf_scenario_t sc;
    const caekf_preset_t *p = NULL;
    if (preset != NULL) {
        p = caekf_preset_find(preset);
        if (p == NULL) {
            snprintf(err, err_len, "unknown preset '%s'", preset);
            return -1;
        }
    }
    if (caekf_scenario_load(path, &sc, err, err_len) != 0) {
        return -1;
    }
    return caekf_scenario_settings(&sc, p, &s->est, path, err, err_len);
}
