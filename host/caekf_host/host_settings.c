/* Scenario file -> caekf_app_settings_t, through the same parameter ids as CTRL_PARAM so a scenario
 * configured locally and one sent over CAN give the same estimator. */
#include "host_settings.h"

#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/scenario.h"

static const struct {
    unsigned param_id;
    size_t offset;
} scenario_params[] = {
    {CAEKF_PARAM_M1, offsetof(caekf_scenario_t, m1)},
    {CAEKF_PARAM_M2, offsetof(caekf_scenario_t, m2)},
    {CAEKF_PARAM_M3, offsetof(caekf_scenario_t, m3)},
    {CAEKF_PARAM_M4, offsetof(caekf_scenario_t, m4)},
    {CAEKF_PARAM_K1, offsetof(caekf_scenario_t, k1)},
    {CAEKF_PARAM_K12, offsetof(caekf_scenario_t, k12)},
    {CAEKF_PARAM_K34, offsetof(caekf_scenario_t, k34)},
    {CAEKF_PARAM_K4, offsetof(caekf_scenario_t, k4)},
    {CAEKF_PARAM_C1, offsetof(caekf_scenario_t, c1)},
    {CAEKF_PARAM_C12, offsetof(caekf_scenario_t, c12)},
    {CAEKF_PARAM_C34, offsetof(caekf_scenario_t, c34)},
    {CAEKF_PARAM_C4, offsetof(caekf_scenario_t, c4)},
    {CAEKF_PARAM_GAP, offsetof(caekf_scenario_t, gap)},
    {CAEKF_PARAM_DT, offsetof(caekf_scenario_t, dt)},
    {CAEKF_PARAM_GAMMA0, offsetof(caekf_scenario_t, gamma0)},
    {CAEKF_PARAM_SIGMA_Q0, offsetof(caekf_scenario_t, sigma_q0)},
    {CAEKF_PARAM_SIGMA_V0, offsetof(caekf_scenario_t, sigma_v0)},
    {CAEKF_PARAM_SIGMA_GAMMA0, offsetof(caekf_scenario_t, sigma_gamma0)},
    {CAEKF_PARAM_SIGMA_QX_Q, offsetof(caekf_scenario_t, sigma_qx_q)},
    {CAEKF_PARAM_SIGMA_QX_V, offsetof(caekf_scenario_t, sigma_qx_v)},
    {CAEKF_PARAM_SIGMA_Q_GAMMA, offsetof(caekf_scenario_t, sigma_q_gamma)},
    {CAEKF_PARAM_SIGMA_R, offsetof(caekf_scenario_t, sigma_r)},
    {CAEKF_PARAM_GAMMA_MIN, offsetof(caekf_scenario_t, gamma_min)},
};

int host_settings_from_scenario(const char *path, caekf_app_settings_t *s, char *err, unsigned err_len)
{
    caekf_scenario_t sc;
    unsigned i;
    if (caekf_scenario_load(path, &sc, err, err_len) != 0) {
        return -1;
    }
    (void)caekf_app_settings_default(s);
    for (i = 0; i < sizeof scenario_params / sizeof scenario_params[0]; i++) {
        double v;
        memcpy(&v, (const char *)&sc + scenario_params[i].offset, sizeof v);
        if (caekf_app_settings_set(s, scenario_params[i].param_id, v) != CAEKF_APP_OK) {
            snprintf(err, err_len, "%s: parameter %u refused", path, scenario_params[i].param_id);
            return -1;
        }
    }
    return 0;
}

int host_experiment_parse(const char *text)
{
    unsigned e;
    char *end = NULL;
    long n;
    for (e = 0; e < (unsigned)CAEKF_EXPERIMENT_COUNT; e++) {
        const char *name;
        if (caekf_proto_experiment_name(e, &name) == CAEKF_PROTO_OK && strcmp(name, text) == 0) {
            return (int)e;
        }
    }
    n = strtol(text, &end, 10);
    if (end != text && *end == '\0' && n >= 0 && n < (long)CAEKF_EXPERIMENT_COUNT) {
        return (int)n;
    }
    return -1;
}
