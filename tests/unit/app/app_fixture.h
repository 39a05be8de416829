/* Shared set-up of the app tests: the reference scenario's estimator settings (SCENARIO.md, paper.toml)
 * and an app bound to the fake HAL. */
#ifndef CAEKF_TEST_APP_FIXTURE_H
#define CAEKF_TEST_APP_FIXTURE_H

#include "fake_hal.h"

extern fake_hal_t fake;
extern caekf_app_t app;

/* Fresh fake HAL and app (unconfigured), default app configuration with the periodic status off. */
void fixture_start(void);
/* Paper settings as caekf_app_settings_t. */
void fixture_paper_settings(caekf_app_settings_t *s);
/* Sends the paper settings as CTRL_PARAM frames; returns how many were sent. */
unsigned fixture_send_paper_params(fake_hal_t *f);
/* Configures the app locally with the paper settings and `experiment`. */
void fixture_configure(unsigned experiment);
/* Polls until the fake receive queue is empty (bounded). */
void fixture_poll_all(void);
uint32_t counter(unsigned id);

#endif
