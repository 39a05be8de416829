/*
 * caekf firmware application: runs the estimator behind the CAN protocol of caekf.dbc, over a HAL.
 *
 * The app knows frames, never sockets or peripherals: the HAL moves frames and tells the time. The
 * estimator knows numbers, never frames. All state lives in one caller-owned caekf_app_t.
 *
 *   caekf_app_config_t cfg;  caekf_app_config_default(&cfg);
 *   caekf_app_hal_t hal = { ctx, my_receive, my_transmit, my_now_us };
 *   static caekf_app_t app;  caekf_app_init(&app, &hal, &cfg);
 *   for (;;) { wait for a frame or a few ms; caekf_app_poll(&app); }
 *
 * Per step the bench sends BENCH_U, BENCH_Y1 and BENCH_Y4 (or BENCH_U and BENCH_YP) with the same STEP;
 * when u, y1 and y4 are in, the app runs caekf_step and sends, in the DIAGNOSTICS profile, EST_GAMMA,
 * EST_Q1..4, EST_V1..4, EST_P_NORM, EST_P_GG and last EST_STEP; in the PRODUCTION profile EST_PROD and,
 * at the first 11 steps of every page period, one EST_PAGE. A partial step is dropped (and counted) when it times out or when a newer step starts.
 * Configuration: CTRL_PARAM frames stage settings, CTRL_RESET commits them (re-initialising) and is
 * answered by EST_ACK; a refused configuration leaves the running one untouched.
 */
#ifndef CAEKF_APP_H
#define CAEKF_APP_H

#include <stdint.h>

#include "caekf/caekf.h"
#include "caekf/caekf_e2e.h"
#include "caekf/caekf_proto.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    CAEKF_APP_OK = 0,
    CAEKF_APP_ERR_NULL = -1,     /* a required pointer was NULL */
    CAEKF_APP_ERR_CONFIG = -2,   /* app configuration or HAL incomplete */
    CAEKF_APP_ERR_SETTINGS = -3, /* estimator settings refused: running configuration unchanged */
    /* -4 is retired */
    CAEKF_APP_ERR_PARAM = -5, /* unknown parameter id or a value the parameter cannot take */
    CAEKF_APP_ERR_INIT = -6   /* caekf_init failed after validation passed */
} caekf_app_status_t;

/* The app's only door to the outside. Called from caekf_app_poll only, never re-entered. */
/* Steps missing between two estimated steps are bridged by prediction-only steps (caekf_predict with
 * the last input held), at most this many per gap, so the estimator stays on the bench's clock
 * instead of blaming the time shift on gamma. Bounds the work of one poll. */
#ifndef CAEKF_APP_MAX_GAP_PREDICT
#define CAEKF_APP_MAX_GAP_PREDICT 1000
#endif

typedef struct {
    void *ctx; /* handed back to every call */
    /* Non-blocking. 1: a frame was written to *frame; 0: nothing pending; negative: error (counted). */
    int (*receive)(void *ctx, caekf_can_frame_t *frame);
    /* 0: queued; negative: error (counted, the frame is not retried). */
    int (*transmit)(void *ctx, const caekf_can_frame_t *frame);
    /* Monotonic time in microseconds. May wrap at 2^32: the app only uses differences. */
    uint32_t (*now_us)(void *ctx);
} caekf_app_hal_t;

typedef struct {
    uint32_t step_timeout_us;    /* a partial step older than this is dropped (default 20 ms) */
    uint32_t status_period_us;   /* EST_HEALTH burst period, 0 = only on request (default 1 s) */
    uint32_t e2e_resync_us;      /* silence on a message after which any counter is accepted (default 500 ms) */
    uint8_t e2e_max_delta;       /* largest accepted alive-counter step, 1..15 (default 1: consecutive) */
    uint8_t max_frames_per_poll; /* bound on the frames one poll takes from the HAL (default 64) */
    uint8_t profile;             /* caekf_profile_t: the estimate frames sent (default DIAGNOSTICS) */
    uint16_t page_period_steps;  /* PRODUCTION: EST_PAGE pages 0..10 go out at the first 11 steps of every
                                    period of this many steps; 0 = only after a CTRL_STATUS_REQ, else
                                    >= CAEKF_PAGE_COUNT (default 20) */
    int16_t id_offset;           /* runtime CAN ID base: every message travels at its DBC ID + this
                                    (caekf_proto_id_offset_check: all IDs within 0..0x7FF; default 0) */
} caekf_app_config_t;

/* Settings the bench configures: the estimator's, by parameter id (CTRL_PARAM). Named presets are the
 * bench's business: they arrive as ordinary settings. */
typedef struct {
    caekf_settings_t est;
} caekf_app_settings_t;

/* The step being assembled from the bench's frames. */
typedef struct {
    uint8_t open;       /* 1 while a step is partially received */
    uint8_t have;       /* bit per value: 1 << i input i (BENCH_U, BENCH_U2), 1 << (CAEKF_MAX_INPUTS + s) sensor s */
    uint16_t step;      /* STEP of the frames */
    uint32_t opened_us; /* time of its first frame */
    double u[CAEKF_MAX_INPUTS];  /* the mechanism's inputs */
    double y[CAEKF_MAX_SENSORS]; /* its sensors, in sensor order */
} caekf_app_slot_t;

typedef struct {
    caekf_app_hal_t hal;
    caekf_app_config_t cfg;

    caekf_t est;                 /* the running estimator */
    caekf_app_settings_t active; /* settings it was built from */
    uint8_t configured;

    /* CTRL_PARAM staging: starts from `active` (or defaults) at the first CTRL_PARAM after a reset. */
    caekf_app_settings_t staged;
    uint8_t staging;
    uint8_t staged_count; /* CTRL_PARAM frames received into `staged` (saturates at 255) */
    int8_t staged_error;  /* caekf_ack_status_t of the first bad CTRL_PARAM, 0 if none */
    uint8_t staged_bad_param;

    caekf_app_slot_t slot;
    uint16_t last_closed_step;       /* last step estimated or dropped: frames up to it are late */
    uint16_t last_run_step;          /* last step estimated: a jump in STEP is a step gap */
    double last_u[CAEKF_MAX_INPUTS]; /* inputs of that step, held over a gap's prediction-only steps */
    uint8_t have_closed, have_run;

    caekf_e2e_rx_t rx[CAEKF_MSG_COUNT];   /* receive side, used for bench messages */
    uint32_t rx_last_us[CAEKF_MSG_COUNT]; /* last CRC-valid frame, for the re-sync timeout */
    uint8_t tx_counter[CAEKF_MSG_COUNT];  /* alive counters of the messages we send */
    uint32_t last_status_us;
    uint16_t page_phase; /* PRODUCTION: steps since the period started; page = phase while < 11 */

    uint32_t counters[CAEKF_CNT_COUNT];           /* caekf_counter_id_t; wrap modulo 2^32 */
    caekf_scalar_t cov_scratch[CAEKF_N][CAEKF_N]; /* P for EST_P_GG: here rather than on the stack */
    uint32_t init_magic;
} caekf_app_t;

caekf_app_status_t caekf_app_config_default(caekf_app_config_t *cfg);

/* Binds the HAL (every function pointer required) and the configuration. The estimator starts
 * unconfigured: bench frames are counted as RX_UNCONFIGURED until a CTRL_RESET or caekf_app_configure. */
caekf_app_status_t caekf_app_init(caekf_app_t *app, const caekf_app_hal_t *hal, const caekf_app_config_t *cfg);

/* Takes up to cfg.max_frames_per_poll frames from the HAL and handles them, drops a timed-out partial
 * step, and sends the periodic EST_HEALTH burst. Never blocks (unless the HAL does). */
caekf_app_status_t caekf_app_poll(caekf_app_t *app);

/* What a CTRL_RESET does, for local configuration (e.g. a scenario file): validates, re-initialises
 * the estimator and forgets the step history. On refusal nothing changes; *bad_param (may be NULL)
 * receives the caekf_param_id_t of the first offending setting or CAEKF_ACK_BAD_PARAM_NONE. */
caekf_app_status_t caekf_app_configure(caekf_app_t *app, const caekf_app_settings_t *settings, uint8_t *bad_param);

caekf_app_status_t caekf_app_counter(const caekf_app_t *app, unsigned counter_id, uint32_t *value);

/* Settings helpers, shared by CTRL_PARAM and scenario readers. */
caekf_app_status_t caekf_app_settings_default(caekf_app_settings_t *s);
/* Sets one parameter (caekf_settings_set). Integer parameters need an integral value. */
caekf_app_status_t caekf_app_settings_set(caekf_app_settings_t *s, unsigned param_id, double value);
/* Parameter id of a scenario key / DBC name (e.g. "sigma_r"). CAEKF_APP_ERR_PARAM if unknown. */
caekf_app_status_t caekf_app_param_id(const char *name, unsigned *param_id);

const char *caekf_app_status_str(caekf_app_status_t st);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_APP_H */
