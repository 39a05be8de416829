/*
 * The lumped contact model (paper Sec. 3.1) discretised by backward Euler: eq. (19) plus the damping
 * term C v_k that the paper's equation omits. The mechanism is described by the settings
 * (docs/mechanism.md): bodies on a line, spring-damper links between two bodies or a body and ground
 * (body 0), input forces, sensors and contacts. A contact between bodies a and b has penetration
 * delta = q_a - q_b - gap; its force f = gamma delta^n (1 + lambda d delta/dt) for delta > 0 acts -f on
 * a and +f on b.
 *
 * This core computes the paper's chain: ground -1- 1 -2- 2 | 3 -3- 4 -4- ground, contact (2, 3),
 * n = 1.5, lambda = 0, input on body 1, position sensors on bodies 1 and 4. caekf_model_supported says
 * whether the settings describe it.
 */
#ifndef CAEKF_MODEL_H
#define CAEKF_MODEL_H

#include "caekf/caekf_config.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Sensor kinds (caekf_model_params_t.sensor_kind). */
typedef enum { CAEKF_SENSOR_POSITION = 0, CAEKF_SENSOR_VELOCITY = 1 } caekf_sensor_kind_t;

/* The mechanism. Plain data, so a const instance can live in flash. Body numbers are 1-based, 0 is the
 * ground; only the first `bodies`, `springs`, ... elements of each array are in use. */
typedef struct {
    caekf_scalar_t dt;                              /* step [s] */
    int bodies;
    caekf_scalar_t m[CAEKF_MAX_BODIES];             /* masses [kg] */
    int springs;
    int spring_a[CAEKF_MAX_SPRINGS], spring_b[CAEKF_MAX_SPRINGS]; /* link ends */
    caekf_scalar_t spring_k[CAEKF_MAX_SPRINGS];     /* [N/m] */
    caekf_scalar_t spring_c[CAEKF_MAX_SPRINGS];     /* [N s/m] */
    int inputs;
    int input_body[CAEKF_MAX_INPUTS];
    int sensors;
    int sensor_body[CAEKF_MAX_SENSORS];
    int sensor_kind[CAEKF_MAX_SENSORS];             /* caekf_sensor_kind_t */
    int contacts;
    int contact_a[CAEKF_MAX_CONTACTS], contact_b[CAEKF_MAX_CONTACTS];
    caekf_scalar_t contact_gap[CAEKF_MAX_CONTACTS]; /* [m] */
    caekf_scalar_t contact_n[CAEKF_MAX_CONTACTS];   /* exponent, >= 1 */
    caekf_scalar_t contact_lambda[CAEKF_MAX_CONTACTS]; /* Hunt-Crossley damping [s/m] */
} caekf_model_params_t;

/* Matrices derived once from the parameters. */
typedef struct {
    caekf_model_params_t p;
    caekf_scalar_t K[CAEKF_NQ][CAEKF_NQ];
    caekf_scalar_t C[CAEKF_NQ][CAEKF_NQ];
    caekf_scalar_t m_dt[CAEKF_NQ];                  /* M / dt (diagonal) */
    caekf_scalar_t A0[CAEKF_NQ][CAEKF_NQ];          /* M/dt + C + dt K: Newton matrix without contact */
    /* Without contact the step is linear: A0's LU and the v-rows of F are constants, computed once by
     * the same code the contact path runs, so using them changes no bit of the result. */
    caekf_scalar_t A0_lu[CAEKF_NQ][CAEKF_NQ];
    int A0_piv[CAEKF_NQ];
    caekf_scalar_t A0_absmax_out; /* max |A0_ij| outside the contact block (bodies 2, 3) */
    caekf_scalar_t fv0[CAEKF_NQ][CAEKF_N];
} caekf_model_t;

/* Contact law at positions q: penetration and the force with its derivatives. */
typedef struct {
    caekf_scalar_t delta;      /* q2 - q3 - gap */
    caekf_scalar_t fc;         /* gamma * delta^1.5, 0 if delta <= 0 */
    caekf_scalar_t dfc_ddelta; /* 1.5 gamma delta^0.5 */
    caekf_scalar_t dfc_dgamma; /* delta^1.5 */
} caekf_contact_t;


/* Derives the matrices. Returns 0, or -1 when the parameters are invalid (model left unchanged). */
int caekf_model_init(caekf_model_t *m, const caekf_model_params_t *p);

void caekf_model_contact(const caekf_model_t *m, const caekf_scalar_t q[CAEKF_NQ], caekf_scalar_t gamma,
                         caekf_contact_t *c);

/* Newton-Raphson solve of eq. (19) for x_k given x_{k-1} and u_k (gamma_k = gamma_{k-1}).
 * Unknown v_k (q_k = q_{k-1} + dt v_k), initial guess v_{k-1}. Converged when the largest momentum-row
 * residual is <= rtol times the largest row's sum of term magnitudes (a norm-wise backward error). At most max_iter
 * iterations (clamped to CAEKF_NEWTON_MAX_ITER). Returns 0 when converged, 1 when the bound was hit,
 * 2 on a singular Jacobian (x_k holds the last iterate in both cases). *iters = linear solves done. */
int caekf_model_newton(const caekf_model_t *m, const caekf_scalar_t xprev[CAEKF_N], caekf_scalar_t u,
                       int max_iter, caekf_scalar_t rtol, caekf_scalar_t xk[CAEKF_N], int *iters);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_MODEL_H */
