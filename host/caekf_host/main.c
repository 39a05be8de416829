/*
 * caekf-host: the caekf firmware application on Linux, bound to a SocketCAN interface.
 *
 *   caekf-host --iface vcan0 [--scenario FILE [--preset NAME]] [options]
 *
 * It waits for frames (poll with a small timeout, no busy loop), lets the app handle them, and on
 * SIGINT/SIGTERM stops cleanly and prints the app's counters. Exit status: 0 after a signal or
 * --run-for, 1 on a setup error, 2 on a usage error.
 */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "caekf/caekf_app.h"
#include "host_settings.h"
#include "socketcan_hal.h"

#define ERR_LEN 512

static volatile sig_atomic_t stop_signal = 0; /* host program: the one global, written by the handler */

static void on_signal(int sig) { stop_signal = sig; }

typedef struct {
    const char *iface;
    const char *scenario;
    const char *preset;
    long step_timeout_ms;
    long status_period_ms;
    long max_delta;
    int profile;      /* caekf_profile_t */
    long page_period; /* steps, PRODUCTION */
    long id_offset;   /* runtime CAN ID base: DBC ID + this on the bus */
    long poll_ms;
    double run_for_s; /* 0: until a signal */
    int quiet;
    int kernel_filter;
    int echo; /* probe: no estimator, BENCH_Y4 answered at once as an EST_STEP with its bytes */
} options_t;

static void usage(FILE *out)
{
    fprintf(out, "usage: caekf-host [--iface NAME] [--scenario FILE [--preset NAME]] [options]\n"
                 "       caekf-host --help | --version\n"
                 "  --iface NAME            SocketCAN interface (default vcan0; a real can0 works the same)\n"
                 "  --scenario FILE         configure the estimator from a scenario file at start-up\n"
                 "                          (otherwise it waits for CTRL_PARAM/CTRL_RESET from the bench)\n"
                 "  --preset NAME           with --scenario: apply a named preset of the settings schema\n"
                 "                          (the paper's canonical, switched, switched-highq,\n"
                 "                          switched-highq-constrained); --experiment is a synonym\n"
                 "  --step-timeout-ms N     drop a partially received step after N ms (default 20)\n"
                 "  --status-period-ms N    send EST_HEALTH every N ms, 0 = only on request (default 1000)\n"
                 "  --profile NAME          estimate frames: diagnostics (12 per step, default) or production\n"
                 "                          (EST_PROD per step + EST_PAGE pages, for a real 1 Mbit/s bus) or fd\n"
                 "                          (BENCH_FD in, EST_FD out: one 20- and one 64-byte CAN FD frame per\n"
                 "                          step; vcan0 needs `ip link set vcan0 mtu 72`)\n"
                 "  --page-period N         production: the 11 EST_PAGE pages at the first 11 steps of every N\n"
                 "                          (0 = only after a status request, else >= 11; default 20)\n"
                 "  --id-offset N           move every CAN ID by N (decimal or 0x hex, may be negative), for a\n"
                 "                          bus that already uses the DBC's IDs; all must stay within\n"
                 "                          0..0x7FF. The bench takes the same (caekf-sim hil run --id-offset)\n"
                 "  --max-delta N           largest accepted E2E alive-counter step, 1..15 (default 1)\n"
                 "  --poll-ms N             longest wait for a frame before the app checks timeouts (default 5)\n"
                 "  --run-for SECONDS       exit by itself after this long (default: run until SIGINT/SIGTERM)\n"
                 "  --kernel-filter         let the kernel drop frames the estimator does not receive (busy\n"
                 "                          buses; they are then not counted). Default: every frame reaches\n"
                 "                          the app and each foreign one is counted in RX_UNKNOWN_ID\n"
                 "  --echo                  timing probe: no estimator; every BENCH_Y4 (production: BENCH_YP, fd: "
                 "BENCH_FD; a step's last input frame)\n"
                 "                          is sent straight back with EST_STEP's ID and its own bytes, so the\n"
                 "                          bench measures the bus and the machine without the estimator\n"
                 "  --quiet                 print only errors and the final counters\n");
}

static int parse_long_base(const char *text, int base, long lo, long hi, long *out)
{
    char *end = NULL;
    long v;
    errno = 0;
    v = strtol(text, &end, base);
    if (errno != 0 || end == text || *end != '\0' || v < lo || v > hi) {
        return -1;
    }
    *out = v;
    return 0;
}

static int parse_long(const char *text, long lo, long hi, long *out) { return parse_long_base(text, 10, lo, hi, out); }

/* Returns 0 to run, 1 to exit 0 (help, version), 2 on a usage error. */
static int parse_args(int argc, char **argv, options_t *o)
{
    int i;
    o->iface = "vcan0";
    o->scenario = NULL;
    o->preset = NULL;
    o->step_timeout_ms = 20;
    o->status_period_ms = 1000;
    o->profile = (int)CAEKF_PROFILE_DIAGNOSTICS;
    o->page_period = 20;
    o->id_offset = 0;
    o->max_delta = 1;
    o->poll_ms = 5;
    o->run_for_s = 0.0;
    o->quiet = 0;
    o->kernel_filter = 0;
    o->echo = 0;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = (i + 1 < argc) ? argv[i + 1] : NULL;
        int takes_value = 1;
        int bad = 0;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            return 1;
        } else if (strcmp(a, "--version") == 0) {
            /* the CMake project version (compile definition), as every host tool prints it */
            printf("caekf-host %s (%s)\n", CAEKF_VERSION, CAEKF_SCALAR_NAME);
            return 1;
        } else if (strcmp(a, "--quiet") == 0) {
            o->quiet = 1;
            takes_value = 0;
        } else if (strcmp(a, "--echo") == 0) {
            o->echo = 1;
            takes_value = 0;
        } else if (strcmp(a, "--kernel-filter") == 0) {
            o->kernel_filter = 1;
            takes_value = 0;
        } else if (v == NULL) {
            bad = 1;
        } else if (strcmp(a, "--iface") == 0) {
            o->iface = v;
        } else if (strcmp(a, "--scenario") == 0) {
            o->scenario = v;
        } else if (strcmp(a, "--preset") == 0 || strcmp(a, "--experiment") == 0) {
            o->preset = v;
        } else if (strcmp(a, "--step-timeout-ms") == 0) {
            bad = parse_long(v, 1, 4000000, &o->step_timeout_ms);
        } else if (strcmp(a, "--status-period-ms") == 0) {
            bad = parse_long(v, 0, 4000000, &o->status_period_ms);
        } else if (strcmp(a, "--profile") == 0) {
            if (strcmp(v, "diagnostics") == 0) {
                o->profile = (int)CAEKF_PROFILE_DIAGNOSTICS;
            } else if (strcmp(v, "production") == 0) {
                o->profile = (int)CAEKF_PROFILE_PRODUCTION;
            } else if (strcmp(v, "fd") == 0) {
                o->profile = (int)CAEKF_PROFILE_FD;
            } else {
                bad = 1;
            }
        } else if (strcmp(a, "--page-period") == 0) {
            bad = parse_long(v, 0, 65535, &o->page_period) ||
                  (o->page_period != 0 && o->page_period < (long)CAEKF_PAGE_COUNT);
        } else if (strcmp(a, "--id-offset") == 0) {
            bad = parse_long_base(v, 0, -(long)CAEKF_CAN_SFF_MAX, (long)CAEKF_CAN_SFF_MAX, &o->id_offset) ||
                  caekf_proto_id_offset_check((int32_t)o->id_offset) != CAEKF_PROTO_OK;
        } else if (strcmp(a, "--max-delta") == 0) {
            bad = parse_long(v, 1, 15, &o->max_delta);
        } else if (strcmp(a, "--poll-ms") == 0) {
            bad = parse_long(v, 1, 1000, &o->poll_ms);
        } else if (strcmp(a, "--run-for") == 0) {
            char *end = NULL;
            o->run_for_s = strtod(v, &end);
            bad = (end == v || *end != '\0' || !(o->run_for_s > 0.0));
        } else {
            bad = 1;
        }
        if (bad) {
            fprintf(stderr, "caekf-host: bad or incomplete option '%s%s%s'\n", a, v ? " " : "", v ? v : "");
            usage(stderr);
            return 2;
        }
        i += takes_value;
    }
    return 0;
}

static double seconds_since(const struct timespec *t0)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)(t.tv_sec - t0->tv_sec) + 1e-9 * (double)(t.tv_nsec - t0->tv_nsec);
}

static void print_counters(const caekf_app_t *app)
{
    unsigned i;
    printf("caekf-host: counters\n");
    for (i = 0; i < (unsigned)CAEKF_CNT_COUNT; i++) {
        const char *name = "?";
        uint32_t v = 0;
        (void)caekf_proto_counter_name(i, &name);
        (void)caekf_app_counter(app, i, &v);
        printf("  %-18s %lu\n", name, (unsigned long)v);
    }
}

/* Reports configuration changes made over CAN, by watching the app's counters. */
static void report_config_changes(const caekf_app_t *app, uint32_t *seen_accepted, uint32_t *seen_refused)
{
    uint32_t acc = 0, ref = 0;
    (void)caekf_app_counter(app, CAEKF_CNT_CFG_ACCEPTED, &acc);
    (void)caekf_app_counter(app, CAEKF_CNT_CFG_REFUSED, &ref);
    if (acc != *seen_accepted) {
        printf("caekf-host: configuration accepted\n");
    }
    if (ref != *seen_refused) {
        printf("caekf-host: configuration refused, the running one kept\n");
    }
    *seen_accepted = acc;
    *seen_refused = ref;
}

static int configure_from_scenario(caekf_app_t *app, const options_t *o)
{
    static caekf_app_settings_t settings;
    char err[ERR_LEN];
    uint8_t bad = 0;
    caekf_app_status_t st;
    if (host_settings_from_scenario(o->scenario, o->preset, &settings, err, sizeof err) != 0) {
        fprintf(stderr, "caekf-host: %s\n", err);
        return -1;
    }
    st = caekf_app_configure(app, &settings, &bad);
    if (st != CAEKF_APP_OK) {
        const char *name = caekf_param_key(bad);
        fprintf(stderr, "caekf-host: %s: %s (parameter %s)\n", o->scenario, caekf_app_status_str(st),
                name != NULL ? name : "unknown");
        return -1;
    }
    return 0;
}

/* The echo probe: what the bench measures with the estimator replaced by a copy of its input. */
static unsigned long echo_frames(const caekf_app_hal_t *hal, uint32_t in_id, uint32_t out_id)
{
    caekf_can_frame_t f;
    unsigned long n = 0;
    unsigned i;
    for (i = 0; i < SOCKETCAN_BATCH; i++) {
        int got = hal->receive(hal->ctx, &f);
        if (got == 0) {
            break;
        }
        if (got > 0 && f.id == in_id) {
            f.id = out_id;
            if (hal->transmit(hal->ctx, &f) == 0) {
                n++;
            }
        }
    }
    return n;
}

int main(int argc, char **argv)
{
    static caekf_app_t app; /* ~4 KB: static rather than on the stack */
    static socketcan_t can;
    options_t o;
    caekf_app_config_t cfg;
    caekf_app_hal_t hal;
    struct sigaction sa;
    struct timespec t0;
    char err[ERR_LEN];
    uint32_t seen_accepted = 0, seen_refused = 0;
    uint32_t echo_in = 0, echo_out = 0;
    static const caekf_msg_t echo_msgs[CAEKF_PROFILE_COUNT][2] = {{CAEKF_MSG_BENCH_Y4, CAEKF_MSG_EST_STEP},
                                                                  {CAEKF_MSG_BENCH_YP, CAEKF_MSG_EST_PROD},
                                                                  {CAEKF_MSG_BENCH_FD, CAEKF_MSG_EST_FD}};
    unsigned long echoed = 0;
    int rc = parse_args(argc, argv, &o);
    if (rc != 0) {
        return rc == 1 ? 0 : 2;
    }
    setvbuf(stdout, NULL, _IOLBF, 0); /* line by line into logs of HIL runs */

    /* The scenario is checked before the bus is touched: a typo there is the commoner mistake. */
    can.fd = -1;
    (void)caekf_app_config_default(&cfg);
    cfg.step_timeout_us = (uint32_t)(o.step_timeout_ms * 1000L);
    cfg.status_period_us = (uint32_t)(o.status_period_ms * 1000L);
    cfg.e2e_max_delta = (uint8_t)o.max_delta;
    cfg.profile = (uint8_t)o.profile;
    cfg.page_period_steps = (uint16_t)o.page_period;
    cfg.id_offset = (int16_t)o.id_offset;
    socketcan_hal(&can, &hal);
    if (caekf_app_init(&app, &hal, &cfg) != CAEKF_APP_OK) {
        fprintf(stderr, "caekf-host: app initialisation failed\n");
        return 1;
    }
    if (o.scenario != NULL && configure_from_scenario(&app, &o) != 0) {
        return 1;
    }
    if (socketcan_open(&can, o.iface, o.kernel_filter, cfg.id_offset, err, sizeof err) != 0) {
        fprintf(stderr, "caekf-host: %s\n", err);
        return 1;
    }

    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal; /* no SA_RESTART: poll() returns EINTR and the loop sees the flag */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);

    if (!o.quiet) {
        printf("caekf-host: ready on %s (ifindex %u), scalar %s, %s\n", o.iface, can.ifindex, CAEKF_SCALAR_NAME,
               o.scenario ? "configured from the scenario" : "waiting for CTRL_PARAM/CTRL_RESET");
        if (o.id_offset != 0) {
            printf("caekf-host: CAN IDs moved by %+ld (0x%03lX..)\n", o.id_offset,
                   0x0C0ul + (unsigned long)o.id_offset);
        }
        if (o.scenario) {
            printf("caekf-host: preset %s\n", o.preset != NULL ? o.preset : "none (scenario and defaults)");
        }
    }
    /* the step's last input frame, answered as the frame that closes a step in this profile (its STEP
     * field starts at the same bit in both, so the bench reads the step it sent) */
    if (o.echo && (caekf_proto_bus_id(echo_msgs[o.profile][0], cfg.id_offset, &echo_in) != CAEKF_PROTO_OK ||
                   caekf_proto_bus_id(echo_msgs[o.profile][1], cfg.id_offset, &echo_out) != CAEKF_PROTO_OK)) {
        fprintf(stderr, "caekf-host: --echo: message table incomplete\n");
        return 1;
    }
    if (o.echo && !o.quiet) {
        printf("caekf-host: ECHO PROBE: no estimator; 0x%03lX answered as 0x%03lX\n", (unsigned long)echo_in,
               (unsigned long)echo_out);
    }
    clock_gettime(CLOCK_MONOTONIC, &t0);
    rc = 0;
    while (!stop_signal) {
        if (socketcan_wait(&can, (int)o.poll_ms) < 0) {
            fprintf(stderr, "caekf-host: poll failed: %s\n", strerror(errno));
            rc = 1;
            break;
        }
        if (o.echo) {
            echoed += echo_frames(&hal, echo_in, echo_out);
        } else {
            (void)caekf_app_poll(&app);
        }
        (void)socketcan_flush(&can); /* the frames of this wake-up in one sendmmsg (TX errors counted) */
        if (!o.quiet) {
            report_config_changes(&app, &seen_accepted, &seen_refused);
        }
        if (o.run_for_s > 0.0 && seconds_since(&t0) >= o.run_for_s) {
            break;
        }
    }
    if (stop_signal && !o.quiet) {
        printf("caekf-host: stopping on %s\n", stop_signal == SIGINT ? "SIGINT" : "SIGTERM");
    }
    if (o.echo) {
        printf("caekf-host: echo probe answered %lu frames\n", echoed);
    }
    print_counters(&app);
    if (can.rx_dropped_foreign != 0u) {
        printf("  %-18s %lu\n", "(host) bad size", can.rx_dropped_foreign); /* not a classic CAN frame */
    }
    if (can.rx_rtr != 0u) {
        printf("  %-18s %lu\n", "(host) RTR frames", can.rx_rtr); /* also in RX_HAL_ERROR */
    }
    if (can.tx_dropped != 0u) {
        printf("  %-18s %lu\n", "(host) TX dropped", can.tx_dropped); /* also in TX_ERROR */
    }
    printf("caekf-host: %lu recvmmsg and %lu sendmmsg calls\n", can.syscalls_rx, can.syscalls_tx);
    socketcan_close(&can);
    return rc;
}
