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

/* The model's own defence (caekf_settings_validate says which parameter is wrong). Returns 0 if valid. */
int caekf_model_params_check(const caekf_model_params_t *p);

/* Derives the matrices. Returns 0, or -1 when the parameters are invalid (model left unchanged). */
int caekf_model_init(caekf_model_t *m, const caekf_model_params_t *p);

void caekf_model_contact(const caekf_model_t *m, const caekf_scalar_t q[CAEKF_NQ], caekf_scalar_t gamma,
                         caekf_contact_t *c);

/* Eq. (19) residual g_d(x_k, x_{k-1}, u_k) of the augmented state x = [q; v; gamma]:
 *   rows 0..3: (q_k - q_{k-1})/dt - v_k
 *   rows 4..7: M (v_k - v_{k-1})/dt + C v_k + K q_k - B_u u_k - B_c f_c(q_k, gamma_k)
 *   row 8:     gamma_k - gamma_{k-1} */
void caekf_model_residual(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                          const caekf_scalar_t xprev[CAEKF_N], caekf_scalar_t u, caekf_scalar_t g[CAEKF_N]);

/* Analytic Jacobians of eq. (19): dg/dx_k at x_k (gamma included) and dg/dx_{k-1} (constant). */
void caekf_model_jacobians(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                           caekf_scalar_t Jk[CAEKF_N][CAEKF_N], caekf_scalar_t Jprev[CAEKF_N][CAEKF_N]);

/* Newton-Raphson solve of eq. (19) for x_k given x_{k-1} and u_k (gamma_k = gamma_{k-1}).
 * Unknown v_k (q_k = q_{k-1} + dt v_k), initial guess v_{k-1}. Converged when the largest momentum-row
 * residual is <= rtol times the largest row's sum of term magnitudes (a norm-wise backward error). At most max_iter
 * iterations (clamped to CAEKF_NEWTON_MAX_ITER). Returns 0 when converged, 1 when the bound was hit,
 * 2 on a singular Jacobian (x_k holds the last iterate in both cases). *iters = linear solves done. */
int caekf_model_newton(const caekf_model_t *m, const caekf_scalar_t xprev[CAEKF_N], caekf_scalar_t u,
                       int max_iter, caekf_scalar_t rtol, caekf_scalar_t xk[CAEKF_N], int *iters);

/* Eq. (10) F = -(dg/dx_k)^-1 dg/dx_{k-1}, computed from the structure of eq. (19): one 4x4 LU of
 * A = M/dt + C + dt K_t (K_t including the contact tangent) instead of a 9x9 inverse. The last row is
 * [0 ... 0 1] by construction. Returns 0, or -1 if A is singular. */
int caekf_model_transition(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                           caekf_scalar_t F[CAEKF_N][CAEKF_N]);

/* The v-rows of F only (4 x 9), which is all the filter needs: F's q-rows are I + dt * (v-rows) and its
 * gamma row is e_gamma. Returns 0, or -1 if A is singular. */
int caekf_model_transition_v(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                             caekf_scalar_t fv[CAEKF_NQ][CAEKF_N]);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_MODEL_H */
