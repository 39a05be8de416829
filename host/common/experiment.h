/* The paper's four experiments (SCENARIO.md) as estimator settings built from a scenario. */
#ifndef CAEKF_HOST_EXPERIMENT_H
#define CAEKF_HOST_EXPERIMENT_H

#include "caekf/caekf.h"
#include "scenario.h"

typedef enum {
    CAEKF_EXP_CANONICAL = 0,
    CAEKF_EXP_SWITCHED = 1,
    CAEKF_EXP_SWITCHED_HIGHQ = 2,
    CAEKF_EXP_SWITCHED_HIGHQ_CONSTRAINED = 3,
    CAEKF_EXP_COUNT = 4
} caekf_experiment_t;

/* Name <-> id; returns -1 for an unknown name. */
int caekf_experiment_from_name(const char *name);
const char *caekf_experiment_name(caekf_experiment_t e);

/* Model from the scenario's plant; estimator settings from its estimator section and experiment e. */
void caekf_experiment_model(const caekf_scenario_t *sc, double dt, caekf_model_params_t *p);
caekf_status_t caekf_experiment_settings(const caekf_scenario_t *sc, caekf_experiment_t e, caekf_settings_t *s);

#endif
