/* Estimator settings by parameter id (CTRL_PARAM and scenario keys): the core's schema tables do the
 * work, so the app lists no setting. */
#include <stddef.h>
#include <string.h>

#include "app_internal.h"

caekf_app_status_t caekf_app_settings_default(caekf_app_settings_t *s)
{
    if (s == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    (void)caekf_settings_default(&s->est);
    return CAEKF_APP_OK;
}

caekf_app_status_t caekf_app_param_id(const char *name, unsigned *param_id)
{
    unsigned i;
    if (name == NULL || param_id == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    for (i = 0; i < CAEKF_PARAM_COUNT; i++) {
        if (strcmp(caekf_param_key(i), name) == 0) {
            *param_id = i;
            return CAEKF_APP_OK;
        }
    }
    return CAEKF_APP_ERR_PARAM;
}

caekf_app_status_t caekf_app_settings_set(caekf_app_settings_t *s, unsigned param_id, double value)
{
    if (s == NULL) {
        return CAEKF_APP_ERR_NULL;
    }
    /* Range and finiteness: caekf_settings_validate at commit. */
    return caekf_settings_set(&s->est, param_id, value, NULL) == CAEKF_OK ? CAEKF_APP_OK : CAEKF_APP_ERR_PARAM;
}
