/* caekf-bench: estimator steps per second on a recorded scenario, per preset. The inputs are
 * loaded first, so only caekf_step is timed. Prints a table; asserts nothing. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "caekf/caekf.h"
#include "common/csv.h"
#include "common/scenario.h"


static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(int argc, char **argv)
{
    static caekf_meas_t rows[CAEKF_CSV_MAX_ROWS];
    caekf_scenario_t sc;
    char err[512];
    long n;
    int e, repeats = 3;
    if (argc < 3) {
        fprintf(stderr, "usage: caekf-bench SCENARIO TRUTH_CSV [REPEATS]\n");
        return 2;
    }
    if (argc > 3) {
        repeats = atoi(argv[3]);
        if (repeats < 1) repeats = 1;
    }
    if (caekf_scenario_load(argv[1], &sc, err, sizeof err) != 0) {
        fprintf(stderr, "caekf-bench: %s\n", err);
        return 3;
    }
    if ((n = caekf_csv_load(argv[2], rows, CAEKF_CSV_MAX_ROWS, err, sizeof err)) < 0) {
        fprintf(stderr, "caekf-bench: %s\n", err);
        return 4;
    }
    printf("%-28s %-6s %10s %14s %12s\n", "experiment", "scalar", "steps", "steps/s (best)", "ns/step");
    for (e = 0; e < (int)CAEKF_PRESET_COUNT; ++e) {
        caekf_settings_t s;
        caekf_t est;
        double best = 0;
        int r;
        if (caekf_scenario_settings(&sc, &caekf_presets[e], &s, argv[1], err, sizeof err) != 0) {
            fprintf(stderr, "caekf-bench: %s\n", err);
            return 3;
        }
        for (r = 0; r < repeats; ++r) {
            long k;
            double t0, dt;
            volatile caekf_scalar_t sink;
            caekf_scalar_t g;
            if (caekf_init(&est, &s) != CAEKF_OK) {
                fprintf(stderr, "caekf-bench: settings refused\n");
                return 3;
            }
            t0 = now_s();
            for (k = 0; k < n; ++k) {
                caekf_scalar_t y[2];
                y[0] = (caekf_scalar_t)rows[k].y1;
                y[1] = (caekf_scalar_t)rows[k].y4;
                (void)caekf_step(&est, (caekf_scalar_t)rows[k].u, y, NULL);
            }
            dt = now_s() - t0;
            (void)caekf_get_gamma(&est, &g);
            sink = g;
            (void)sink;
            if ((double)n / dt > best) best = (double)n / dt;
        }
        printf("%-28s %-6s %10ld %14.0f %12.1f\n", caekf_presets[e].name, CAEKF_SCALAR_NAME, n,
               best, 1e9 / best);
    }
    return 0;
}
