/* The truth: backward Euler of eq. (19) at dt / truth_substeps, Newton-solved, sampled every dt,
 * with the scenario's true gamma. Always double, whatever the estimator's scalar type. */
#ifndef CAEKF_HOST_TRUTH_H
#define CAEKF_HOST_TRUTH_H

#include "scenario.h"

typedef struct {
    double t, u, y1, y4;
    double q[4], v[4];
    double delta;
    int newton_iters; /* sum over the substeps of this sample */
    int newton_failed;
} caekf_truth_sample_t;

/* Calls emit(sample, ctx) for k = 1 .. steps (t_k = k dt). Returns 0, or nonzero when emit or the
 * model setup fails. Measurement noise: Gaussian, std noise_std, from a splitmix64 generator seeded
 * with `seed` and the Box-Muller transform (see truth.c), so other implementations can reproduce it. */
int caekf_truth_run(const caekf_scenario_t *sc, int (*emit)(const caekf_truth_sample_t *, void *), void *ctx);

#endif
