/* The truth: the continuous model of the scenario's mechanism (the same equations as eq. 19's backward
 * Euler, before discretisation: M v' = B u(t) - C v - K q - sum_c b_c f_c, K and C from the links as
 * caekf_model_init builds them) with the scenario's true gammas, sampled every dt. Always double,
 * whatever the estimator's scalar type. Inputs: the scenario's sines u_i(t) = amp_i sin(2 pi freq_i t +
 * phase_i), or a time series (caekf_input_series_t) linearly interpolated, end values held.
 *
 * Default method (CAEKF_TRUTH_DOP853): the explicit Dormand-Prince 8(5,3) pair with adaptive steps
 * (error per step <= 1 in the norm of rtol, atol), every step clipped to the sample grid, and contact
 * events located: the force gamma * delta^1.5 is only C^1 at delta = 0, so each step that may cross
 * delta = 0 of any contact (a sign change at its ends, or an interior extremum of the cubic Hermite interpolant of
 * delta beyond 0) is shortened to the crossing, found by the Illinois method on delta(one step of size
 * s), and the integration restarts there with that contact's mode switched (open: force 0; closed:
 * the law while delta > 0). One event function per contact; the earliest crossing in a step is located. No Newton solve anywhere, so nothing can fail to converge; a step size
 * below 1e-14 s or more than 10^8 steps is reported as a failure.
 *
 * Legacy method (CAEKF_TRUTH_BACKWARD_EULER): backward Euler of eq. (19) at dt / truth_substeps,
 * Newton-solved (the truth of earlier versions; the filter's own discretisation). */
#ifndef CAEKF_HOST_TRUTH_H
#define CAEKF_HOST_TRUTH_H

#include <stdint.h>

#include "scenario.h"

typedef enum { CAEKF_TRUTH_DOP853 = 0, CAEKF_TRUTH_BACKWARD_EULER = 1 } caekf_truth_method_t;

/* Input samples: u[j * inputs + i] is input i at t[j]; t strictly increasing, rows >= 2. */
typedef struct {
    long rows;
    int inputs;
    double *t, *u; /* malloc'ed (caekf_input_series_free) */
} caekf_input_series_t;

/* Reads a CSV with a header naming t and the inputs: u (or u1) for one input, u1..u<inputs> otherwise,
 * in any column order, extra columns ignored; every field a finite number, t strictly increasing, at
 * least 2 rows (sim/src/caekf_sim/mechanism.py read_input_csv). Returns 0, or CAEKF_EXIT_INPUT (3) /
 * CAEKF_EXIT_IO (4) with a one-line message "FILE:LINE: rule" in err. */
int caekf_input_series_read(const char *path, int inputs, caekf_input_series_t *s, char *err, unsigned err_len);

/* The inputs at time t (np.interp: linear, end values held outside [t_0, t_last]). */
void caekf_input_series_at(const caekf_input_series_t *s, double t, double *u);

/* The inputs' rates at time t (a base displacement's du/dt): the samples' central differences, (u_{j+1} -
 * u_{j-1}) / (t_{j+1} - t_{j-1}) (one-sided at the ends), interpolated as np.interp does; 0 outside [t_0,
 * t_last], where the values are held. */
void caekf_input_series_rate_at(const caekf_input_series_t *s, double t, double *du);

void caekf_input_series_free(caekf_input_series_t *s);

typedef struct {
    caekf_truth_method_t method;
    const caekf_input_series_t *series; /* NULL: the scenario's sines; else its inputs must match */
    double rtol;                        /* DOP853: relative tolerance per step (default 1e-13) */
    double atol_q;                      /* absolute tolerance on positions [m] (default 1e-15) */
    double atol_v;                      /* absolute tolerance on velocities [m/s] (default 1e-13) */
} caekf_truth_options_t;

typedef struct {
    double t;
    int inputs, sensors, bodies, contacts; /* the sizes in use */
    double u[CAEKF_MAX_INPUTS];            /* the inputs at t */
    double y[CAEKF_MAX_SENSORS];           /* sensor readings (q or v of the sensor's body) plus noise */
    double q[CAEKF_MAX_BODIES], v[CAEKF_MAX_BODIES];
    double delta[CAEKF_MAX_CONTACTS]; /* penetration of each contact */
    int newton_iters;                 /* backward Euler: sum over the substeps of this sample */
    int newton_failed;                /* backward Euler: substeps whose Newton did not converge */
    int steps;                        /* DOP853: accepted steps in this sample interval (event restarts included) */
    int rejected;                     /* DOP853: rejected steps */
    int events;                       /* DOP853: contact events (closing or opening) located in this interval */
    int failed;                       /* DOP853: step size underflow or step budget exhausted (the run stops) */
} caekf_truth_sample_t;

/* The plant as the truth integrates it (caekf_truth_start fills it from the scenario). */
#define CAEKF_TRUTH_N (2 * CAEKF_MAX_BODIES) /* capacity of the integrated state [q; v] */
typedef struct {
    const caekf_input_series_t *series;
    int nq, nc, ni, ns, n;
    double amp[CAEKF_MAX_INPUTS], freq[CAEKF_MAX_INPUTS], phase[CAEKF_MAX_INPUTS];
    int input_body[CAEKF_MAX_INPUTS]; /* 0-based */
    /* a base displacement (input{i}_kind): its link's stiffness and damper, k u + c du/dt on its body; a force:
     * input_base 0 */
    int input_base[CAEKF_MAX_INPUTS];
    double input_k[CAEKF_MAX_INPUTS], input_c[CAEKF_MAX_INPUTS];
    int sensor_body[CAEKF_MAX_SENSORS], sensor_kind[CAEKF_MAX_SENSORS]; /* 0-based body; caekf_sensor_kind_t */
    int sensor_ref[CAEKF_MAX_SENSORS]; /* a relative sensor's reference body (0-based, -1 = ground) */
    int sensor_a[CAEKF_MAX_SENSORS], sensor_b[CAEKF_MAX_SENSORS];    /* a link-force sensor's link ends */
    double sensor_k[CAEKF_MAX_SENSORS], sensor_c[CAEKF_MAX_SENSORS]; /* and its stiffness and damper */
    int sensor_input[CAEKF_MAX_SENSORS]; /* the base input moving that link's ground end (0-based), or -1 */
    double noise[CAEKF_MAX_SENSORS];     /* std of each sensor's noise */
    double bias[CAEKF_MAX_SENSORS];      /* each sensor's constant offset (truth key sensor{i}_bias) */
    int ca[CAEKF_MAX_CONTACTS], cb[CAEKF_MAX_CONTACTS]; /* 0-based ends, -1 = ground */
    double gap[CAEKF_MAX_CONTACTS], cn[CAEKF_MAX_CONTACTS], lam[CAEKF_MAX_CONTACTS], gamma[CAEKF_MAX_CONTACTS];
    double minv[CAEKF_MAX_BODIES];
    double K[CAEKF_MAX_BODIES][CAEKF_MAX_BODIES], C[CAEKF_MAX_BODIES][CAEKF_MAX_BODIES];
    double atol[CAEKF_TRUTH_N], rtol;
    int closed[CAEKF_MAX_CONTACTS]; /* contact mode: 0 open (no force), 1 closed (the law while delta > 0) */
} caekf_truth_plant_t;

/* The DOP853 truth one sample at a time (caekf_truth_run's own loop; the plant FMU, fmu/, steps it the
 * same way, so its samples equal caekf-truth's bit for bit). Plain data: no pointer but to the scenario
 * (and its series), which must outlive it. */
typedef struct {
    const caekf_scenario_t *sc;
    caekf_truth_plant_t p;
    double y[CAEKF_TRUTH_N], k0[CAEKF_TRUTH_N]; /* the state at t and f(t, y) */
    double t, h;                                /* time reached, next step size */
    long k, total;                              /* samples emitted, DOP853 steps taken */
    uint64_t rng;                               /* the measurement noise's generator */
    int failed;
} caekf_truth_stepper_t;

/* Starts at rest (q = v = 0) at t = 0. opt may be NULL (defaults; its method is ignored: DOP853).
 * Returns 0, or -1 when the model refuses the scenario's mechanism or the options are invalid. */
int caekf_truth_start(caekf_truth_stepper_t *st, const caekf_scenario_t *sc, const caekf_truth_options_t *opt);

/* Integrates to the next sample, t_k = k dt (k = 1, 2, ...), and fills it (noise included). Returns 0, or
 * 1 when the integration failed (out->failed; every later call fails too). */
int caekf_truth_advance(caekf_truth_stepper_t *st, caekf_truth_sample_t *out);

/* Defaults above. */
void caekf_truth_options_default(caekf_truth_options_t *opt);

/* Calls emit(sample, ctx) for k = 1 .. steps (t_k = k dt), starting at rest (q = v = 0) at t = 0.
 * Returns 0; 1 when the integrator failed (DOP853; the failing sample is emitted with failed = 1 and
 * the run stops); -1 when emit or the model setup fails. Measurement noise: Gaussian, std noise_std on
 * position sensors and noise_std_v on velocity sensors, from a splitmix64 generator seeded with `seed`
 * and the Box-Muller transform (see truth.c), so other implementations can reproduce it: one draw per
 * sensor with a nonzero std, in sensor order, each sample; the same for both methods. opt may be NULL (defaults). */
int caekf_truth_run(const caekf_scenario_t *sc, const caekf_truth_options_t *opt,
                    int (*emit)(const caekf_truth_sample_t *, void *), void *ctx);

#endif
