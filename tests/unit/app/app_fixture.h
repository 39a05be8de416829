/* Shared set-up of the app tests: the reference scenario's estimator settings (paper.toml, through the
 * generated fixture), the schema's presets, and an app bound to the fake HAL. */
#ifndef CAEKF_TEST_APP_FIXTURE_H
#define CAEKF_TEST_APP_FIXTURE_H

#include "caekf_fixture_settings.h"
#include "fake_hal.h"

/* The presets by index (CAEKF_FIXTURE_PRESET_*), or PRESET_NONE for the recommended defaults. */
#define PRESET_NONE (-1)

extern fake_hal_t fake;
extern caekf_app_t app;

/* Fresh fake HAL and app (unconfigured), default app configuration with the periodic status off. */
void fixture_start(void);
/* Paper settings as caekf_app_settings_t, with a preset applied (PRESET_NONE: none). */
void fixture_paper_settings(caekf_app_settings_t *s, int preset);
/* Sends the paper settings and then the preset's as CTRL_PARAM frames; returns how many were sent. */
unsigned fixture_send_paper_params(fake_hal_t *f, int preset);
/* Sends a preset's values as CTRL_PARAM frames (what the bench does to select an experiment). */
unsigned fixture_send_preset(fake_hal_t *f, int preset);
/* Configures the app locally with the paper settings and a preset. */
void fixture_configure(int preset);
/* Polls until the fake receive queue is empty (bounded). */
void fixture_poll_all(void);
uint32_t counter(unsigned id);

#endif
