/*
 * The model's internals: the pieces of eq. (19) and eq. (10) the estimator step is built from. Private to
 * firmware/core (and its unit tests): the public model API is caekf_model.h.
 */
#ifndef CAEKF_MODEL_INTERNAL_H
#define CAEKF_MODEL_INTERNAL_H

#include "caekf/caekf_model.h"

/* The first parameter id of a mechanism this core does not compute, or -1 (it computes the paper's chain). */
int caekf_model_unsupported(const caekf_model_params_t *p);

/* The model's own defence (caekf_settings_validate says which parameter is wrong). Returns 0 if valid. */
int caekf_model_params_check(const caekf_model_params_t *p);

/* Eq. (19) residual g_d(x_k, x_{k-1}, u_k) of the augmented state x = [q; v; gamma]:
 *   rows 0..3: (q_k - q_{k-1})/dt - v_k
 *   rows 4..7: M (v_k - v_{k-1})/dt + C v_k + K q_k - B_u u_k - B_c f_c(q_k, gamma_k)
 *   row 8:     gamma_k - gamma_{k-1} */
void caekf_model_residual(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                          const caekf_scalar_t xprev[CAEKF_N], caekf_scalar_t u, caekf_scalar_t g[CAEKF_N]);

/* Analytic Jacobians of eq. (19): dg/dx_k at x_k (gamma included) and dg/dx_{k-1} (constant). */
void caekf_model_jacobians(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                           caekf_scalar_t Jk[CAEKF_N][CAEKF_N], caekf_scalar_t Jprev[CAEKF_N][CAEKF_N]);

/* Eq. (10) F = -(dg/dx_k)^-1 dg/dx_{k-1}, computed from the structure of eq. (19): one 4x4 LU of
 * A = M/dt + C + dt K_t (K_t including the contact tangent) instead of a 9x9 inverse. The last row is
 * [0 ... 0 1] by construction. Returns 0, or -1 if A is singular. */
int caekf_model_transition(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                           caekf_scalar_t F[CAEKF_N][CAEKF_N]);

/* The v-rows of F only (4 x 9), which is all the filter needs: F's q-rows are I + dt * (v-rows) and its
 * gamma row is e_gamma. Returns 0, or -1 if A is singular. */
int caekf_model_transition_v(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                             caekf_scalar_t fv[CAEKF_NQ][CAEKF_N]);

#endif /* CAEKF_MODEL_INTERNAL_H */
