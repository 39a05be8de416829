/* The truth: the continuous model of the 4-body chain (the same equations as eq. 19's backward Euler,
 * before discretisation) with the scenario's true gamma, sampled every dt. Always double, whatever the
 * estimator's scalar type.
 *
 * Default method (CAEKF_TRUTH_DOP853): the explicit Dormand-Prince 8(5,3) pair with adaptive steps
 * (error per step <= 1 in the norm of rtol, atol), every step clipped to the sample grid, and contact
 * events located: the force gamma * delta^1.5 is only C^1 at delta = 0, so each step that may cross
 * delta = 0 (a sign change at its ends, or an interior extremum of the cubic Hermite interpolant of
 * delta beyond 0) is shortened to the crossing, found by the Illinois method on delta(one step of size
 * s), and the integration restarts there with the contact mode switched (open: force 0; closed:
 * gamma * max(delta, 0)^1.5). No Newton solve anywhere, so nothing can fail to converge; a step size
 * below 1e-14 s or more than 10^8 steps is reported as a failure.
 *
 * Legacy method (CAEKF_TRUTH_BACKWARD_EULER): backward Euler of eq. (19) at dt / truth_substeps,
 * Newton-solved (the truth of earlier versions; the filter's own discretisation). */
#ifndef CAEKF_HOST_TRUTH_H
#define CAEKF_HOST_TRUTH_H

#include "scenario.h"

typedef enum { CAEKF_TRUTH_DOP853 = 0, CAEKF_TRUTH_BACKWARD_EULER = 1 } caekf_truth_method_t;

typedef struct {
    caekf_truth_method_t method;
    double rtol;      /* DOP853: relative tolerance per step (default 1e-13) */
    double atol_q;    /* absolute tolerance on positions [m] (default 1e-15) */
    double atol_v;    /* absolute tolerance on velocities [m/s] (default 1e-13) */
} caekf_truth_options_t;

typedef struct {
    double t, u, y1, y4;
    double q[4], v[4];
    double delta;
    int newton_iters;  /* backward Euler: sum over the substeps of this sample */
    int newton_failed; /* backward Euler: substeps whose Newton did not converge */
    int steps;         /* DOP853: accepted steps in this sample interval (event restarts included) */
    int rejected;      /* DOP853: rejected steps */
    int events;        /* DOP853: contact events (closing or opening) located in this interval */
    int failed;        /* DOP853: step size underflow or step budget exhausted (the run stops) */
} caekf_truth_sample_t;

/* Defaults above. */
void caekf_truth_options_default(caekf_truth_options_t *opt);

/* Calls emit(sample, ctx) for k = 1 .. steps (t_k = k dt), starting at rest (q = v = 0) at t = 0.
 * Returns 0; 1 when the integrator failed (DOP853; the failing sample is emitted with failed = 1 and
 * the run stops); -1 when emit or the model setup fails. Measurement noise: Gaussian, std noise_std,
 * from a splitmix64 generator seeded with `seed` and the Box-Muller transform (see truth.c), so other
 * implementations can reproduce it; the same for both methods. opt may be NULL (defaults). */
int caekf_truth_run(const caekf_scenario_t *sc, const caekf_truth_options_t *opt,
                    int (*emit)(const caekf_truth_sample_t *, void *), void *ctx);

#endif
