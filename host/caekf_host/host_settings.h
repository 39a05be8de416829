/* Initial estimator settings for caekf-host from a scenario file (host/common/scenario.h). */
#ifndef CAEKF_HOST_SETTINGS_H
#define CAEKF_HOST_SETTINGS_H

#include <stdio.h>

#include "caekf/caekf_app.h"

/* The scenario's values over the schema's defaults, then the named preset's (NULL: none), validated.
 * Returns 0, or -1 with a one-line reason in err. */
int host_settings_from_scenario(const char *path, const char *preset, caekf_app_settings_t *s, char *err,
                                unsigned err_len);

#endif
