/*
 * The 4-body contact model of the paper (Sec. 3.1) discretised by backward Euler: eq. (19) plus the
 * damping term C v_k that the paper's equation omits.
 *
 * Conventions: q_i are displacements from rest, positive from body 1 towards body 4. Bodies 1 and 4
 * are tied to ground (k1/c1, k4/c4), 1-2 and 3-4 are coupled (k12/c12, k34/c34). The penetration is
 * delta = q2 - q3 - gap; the Hertz force f_c = gamma * delta^1.5 for delta > 0 (else 0) acts -f_c on
 * body 2 and +f_c on body 3. The input u is a force on body 1.
 */
#ifndef CAEKF_MODEL_H
#define CAEKF_MODEL_H

#include "caekf/caekf_config.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Physical parameters. Plain data, so a const instance can live in flash. */
typedef struct {
    caekf_scalar_t m[CAEKF_NQ];          /* masses [kg] */
    caekf_scalar_t k1, k12, k34, k4;     /* springs [N/m] */
    caekf_scalar_t c1, c12, c34, c4;     /* dampers [N s/m] */
    caekf_scalar_t gap;                  /* contact gap [m] */
    caekf_scalar_t dt;                   /* step [s] */
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
