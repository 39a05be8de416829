/* Initial estimator settings for caekf-host from the shared scenario file (host/common/scenario.h). */
#ifndef CAEKF_HOST_SETTINGS_H
#define CAEKF_HOST_SETTINGS_H

#include "caekf/caekf_app.h"

/* Reads the scenario's model and estimator values into app settings (defaults for the rest).
 * Returns 0, or -1 with the reason in err. */
int host_settings_from_scenario(const char *path, caekf_app_settings_t *s, char *err, unsigned err_len);

/* Experiment by name ("switched-highq") or number; -1 if unknown. */
int host_experiment_parse(const char *text);

#endif
