/* caekf-bench: estimator steps per second on a recorded scenario, per preset. The inputs are
 * loaded (and checked) first, so only caekf_step is timed. Prints a table; asserts nothing. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "caekf/caekf.h"
#include "common/csv.h"
#include "common/scenario.h"
#include "common/tool.h"

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void usage(FILE *f)
{
    fputs("usage: caekf-bench SCENARIO TRUTH_CSV [REPEATS]\n"
          "       caekf-bench --help | --version\n"
          "Steps per second of caekf_step for every preset over the rows of TRUTH_CSV (the mechanism's\n"
          "columns as caekf-truth writes them, t,u,y1,y4... for the paper; t strictly increasing by the\n"
          "scenario's dt within 1 %), best of REPEATS runs (a positive integer,\n"
          "default 3). Prints a table to stdout; writes no file.\n" CAEKF_EXIT_TABLE,
          f);
}

int main(int argc, char **argv)
{
    caekf_meas_t *rows = NULL;
    caekf_csv_columns_t cols;
    caekf_scenario_t sc;
    char err[1024];
    long n;
    int e, rc, repeats = 3;
    if (argc == 2 && (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0)) {
        usage(stdout);
        return CAEKF_EXIT_OK;
    }
    if (argc == 2 && strcmp(argv[1], "--version") == 0) {
        caekf_tool_version("caekf-bench", CAEKF_SCALAR_NAME);
        return CAEKF_EXIT_OK;
    }
    if (argc < 3 || argc > 4 || argv[1][0] == '-' || argv[2][0] == '-') {
        fprintf(stderr, "caekf-bench: usage: caekf-bench SCENARIO TRUTH_CSV [REPEATS] (see --help)\n");
        return CAEKF_EXIT_USAGE;
    }
    if (argc > 3) {
        char *end;
        long r;
        errno = 0;
        r = strtol(argv[3], &end, 10);
        if (end == argv[3] || *end != '\0' || errno != 0 || r < 1 || r > INT_MAX) {
            fprintf(stderr, "caekf-bench: REPEATS '%s' must be a positive integer\n", argv[3]);
            return CAEKF_EXIT_USAGE;
        }
        repeats = (int)r;
    }
    if ((rc = caekf_tool_check_input(argv[1], 0, err, sizeof err)) != 0) {
        fprintf(stderr, "caekf-bench: %s\n", err);
        return rc;
    }
    if (caekf_scenario_load(argv[1], &sc, err, sizeof err) != 0) {
        fprintf(stderr, "caekf-bench: %s\n", err);
        return CAEKF_EXIT_INPUT;
    }
    if ((n = caekf_csv_read_for(argv[2], &sc, sc.dt, 0, 0, &cols, &rows, err, sizeof err)) < 0) {
        fprintf(stderr, "caekf-bench: %s\n", err);
        return (int)-n;
    }
    for (e = 0; e < (int)CAEKF_PRESET_COUNT; ++e) { /* every preset's settings checked before any output */
        caekf_settings_t s;
        if (caekf_scenario_settings(&sc, &caekf_presets[e], &s, argv[1], err, sizeof err) != 0) {
            fprintf(stderr, "caekf-bench: %s\n", err);
            free(rows);
            return CAEKF_EXIT_INPUT;
        }
    }
    printf("%-28s %-6s %10s %14s %12s\n", "experiment", "scalar", "steps", "steps/s (best)", "ns/step");
    for (e = 0; e < (int)CAEKF_PRESET_COUNT; ++e) {
        caekf_settings_t s;
        caekf_t est;
        double best = 0;
        int r;
        (void)caekf_scenario_settings(&sc, &caekf_presets[e], &s, argv[1], err, sizeof err);
        for (r = 0; r < repeats; ++r) {
            long k;
            double t0, dt;
            volatile caekf_scalar_t sink;
            caekf_scalar_t g;
            if (caekf_init(&est, &s) != CAEKF_OK) {
                fprintf(stderr, "caekf-bench: %s: estimator initialisation failed (%s)\n", argv[1],
                        caekf_presets[e].name);
                free(rows);
                return CAEKF_EXIT_NUMERIC;
            }
            t0 = now_s();
            for (k = 0; k < n; ++k) {
                caekf_scalar_t u[CAEKF_MAX_INPUTS + 1], y[CAEKF_MAX_SENSORS];
                caekf_meas_scalars(&rows[k], &cols, u, y);
                (void)caekf_step(&est, u, y, NULL);
            }
            dt = now_s() - t0;
            (void)caekf_get_gamma(&est, &g);
            sink = g;
            (void)sink;
            if (dt > 0 && (double)n / dt > best) best = (double)n / dt;
        }
        printf("%-28s %-6s %10ld %14.0f %12.1f\n", caekf_presets[e].name, CAEKF_SCALAR_NAME, n, best,
               best > 0 ? 1e9 / best : 0.0);
    }
    free(rows);
    return CAEKF_EXIT_OK;
}
