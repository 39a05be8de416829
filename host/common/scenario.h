/* The scenario file: flat `key = value` lines (valid TOML), shared with the Python simulator. Its keys,
 * defaults and ranges are the settings schema's (generated caekf_scenario_schema.h); presets too. */
#ifndef CAEKF_HOST_SCENARIO_H
#define CAEKF_HOST_SCENARIO_H

#include "caekf/caekf.h"
#include "caekf_scenario_schema.h"

/* Reads and checks a scenario file: every key must be known and given once, keys without a default
 * are required (truth-only keys excepted: left out, they are NaN), every value is checked against the
 * schema's range. On failure returns nonzero and writes a one-line message naming the file, the line or
 * key, and the rule. */
int caekf_scenario_load(const char *path, caekf_scenario_t *sc, char *err, unsigned err_len);

/* For tools that simulate a truth: every truth-only key without a default (contact1_gamma, input1_amp,
 * t_end, seed, ...) that is in use must have been given. Returns 0, or -1 with "path: missing key 'X'
 * (...)" in err. */
int caekf_scenario_need_truth(const caekf_scenario_t *sc, const char *path, char *err, unsigned err_len);

/* A preset by name (caekf_presets), or NULL. */
const caekf_preset_t *caekf_preset_find(const char *name);

/* Estimator settings: the schema's defaults, the scenario's values, then the preset's (may be NULL),
 * validated. Returns 0, or nonzero with "path: m[2] = -1: must be > 0"-style text in err. */
int caekf_scenario_settings(const caekf_scenario_t *sc, const caekf_preset_t *preset, caekf_settings_t *s,
                            const char *path, char *err, unsigned err_len);

/* The model of the scenario's plant with step dt (the truth integrates with dt / truth_substeps). */
void caekf_scenario_model(const caekf_scenario_t *sc, double dt, caekf_model_params_t *p);

/* The value of a key (canonical name or alias) as loaded, e.g. "contact2_gamma". Returns 0, or -1 for a
 * key the schema does not have. */
int caekf_scenario_value(const caekf_scenario_t *sc, const char *key, double *v);

/* Input 1's force u(t) = u_amp sin(2 pi u_freq t + u_phase) (the truth handles every input itself). */
double caekf_scenario_input(const caekf_scenario_t *sc, double t);

/* Number of truth samples, round(t_end / dt) (t_end: a truth-only key). */
long caekf_scenario_steps(const caekf_scenario_t *sc);

#endif
