/*
 * The model's internals: the pieces of eq. (19) and eq. (10) the estimator step is built from. Private to
 * firmware/core (and its unit tests): the public model API is caekf_model.h.
 */
#ifndef CAEKF_MODEL_INTERNAL_H
#define CAEKF_MODEL_INTERNAL_H

#include "caekf/caekf_model.h"

/* Run-time sizes of a model. A build sized for one mechanism (CAEKF_SIZED, generated from its scenario)
 * has them as constants, so the compiler sees fixed loop bounds. */
#if CAEKF_SIZED
#define CAEKF_DIM_NQ(m) ((void)(m), CAEKF_SIZED_BODIES)
#define CAEKF_DIM_NC(m) ((void)(m), CAEKF_SIZED_CONTACTS)
#define CAEKF_DIM_NU(m) ((void)(m), CAEKF_SIZED_INPUTS)
#define CAEKF_DIM_N(m) ((void)(m), CAEKF_SIZED_N)
#define CAEKF_DIM_NM(m) ((void)(m), CAEKF_SIZED_MECH_PARAMS)
#define CAEKF_DIM_NB(m) ((void)(m), CAEKF_SIZED_BIASES)
#define CAEKF_DIM_IS4(nq) ((void)(nq), CAEKF_SIZED_BODIES == 4) /* only one LU kernel is then linked */
#define CAEKF_INPUTS_STORE(m) ((void)(m), (int *)0)
#else
#define CAEKF_DIM_NQ(m) ((m)->nq)
#define CAEKF_DIM_NC(m) ((m)->nc)
#define CAEKF_DIM_NU(m) ((m)->p.inputs)
#define CAEKF_DIM_N(m) ((m)->n)
#define CAEKF_DIM_NM(m) ((m)->nm)
#define CAEKF_DIM_NB(m) ((m)->nb)
#define CAEKF_DIM_IS4(nq) ((nq) == 4)
#define CAEKF_INPUTS_STORE(m) (&(m)->p.inputs)
#endif /* CAEKF_SIZED */
/* Accessors of what a build's layouts may lack. A read gives the member, or where the layout lacks it the
 * constant it stands for, so that a branch on it compiles out. Storage to write (..._STORE) is the member, or a
 * null pointer of its type where the layout lacks it: code that writes it sits under if (the switch), which
 * compiles out there. */

/* The base-displacement inputs (CAEKF_HAS_BASE_INPUTS): their count, input k's link (1-based, 0: a force) and
 * its stiffness and damper now; constants 0 where the build's inputs are all forces. */
#if CAEKF_HAS_BASE_INPUTS
#define CAEKF_DIM_NBASE(m) ((m)->nbase)
#define CAEKF_BASE_LINK(m, k) ((int)(m)->base_link[k])
#define CAEKF_BASE_K(m, k) ((m)->base_k[k])
#define CAEKF_BASE_C(m, k) ((m)->base_c[k])
#define CAEKF_NBASE_STORE(m) (&(m)->nbase)
#define CAEKF_BASE_LINK_STORE(m) ((m)->base_link)
#define CAEKF_BASE_K_STORE(m) ((m)->base_k)
#define CAEKF_BASE_C_STORE(m) ((m)->base_c)
#else
#define CAEKF_DIM_NBASE(m) ((void)(m), 0)
#define CAEKF_BASE_LINK(m, k) ((void)(m), (void)(k), 0)
#define CAEKF_BASE_K(m, k) ((void)(m), (void)(k), (caekf_scalar_t)0)
#define CAEKF_BASE_C(m, k) ((void)(m), (void)(k), (caekf_scalar_t)0)
#define CAEKF_NBASE_STORE(m) ((void)(m), (int *)0)
#define CAEKF_BASE_LINK_STORE(m) ((void)(m), (unsigned char *)0)
#define CAEKF_BASE_K_STORE(m) ((void)(m), (caekf_scalar_t *)0)
#define CAEKF_BASE_C_STORE(m) ((void)(m), (caekf_scalar_t *)0)
#endif /* CAEKF_HAS_BASE_INPUTS */
/* The first mechanism parameter's state: the mechanism's parameters, then the sensors' offsets, end x. */
#define CAEKF_DIM_MECH0(m) (CAEKF_DIM_N(m) - CAEKF_DIM_NM(m) - CAEKF_DIM_NB(m))

/* The links' ends fixed at build time (CAEKF_FIXED_LINKS; the settings' ends are refused unless they are the
 * sized scenario's): contact c's ends (0-based bodies, -1: ground) and the nonzero columns of K's and C's row i
 * (ascending: CAEKF_ROW_NZ(m, i)[0 .. CAEKF_ROW_NNZ(m, i) - 1]) are constants, else the model's. */
#if CAEKF_FIXED_LINKS
static const signed char caekf_sized_contact_a[] = CAEKF_SIZED_CONTACT_A,
                         caekf_sized_contact_b[] = CAEKF_SIZED_CONTACT_B;
static const unsigned char caekf_sized_link_nnz[CAEKF_SIZED_BODIES] = CAEKF_SIZED_LINK_NNZ;
static const unsigned char caekf_sized_link_nz[CAEKF_SIZED_BODIES][CAEKF_SIZED_LINK_WIDTH] = CAEKF_SIZED_LINK_NZ;
#define CAEKF_CONTACT_I(m, c) ((void)(m), caekf_sized_contact_a[c] - 1)
#define CAEKF_CONTACT_J(m, c) ((void)(m), caekf_sized_contact_b[c] - 1)
/* (the tables themselves, not through a comma: the compiler then knows their bounds) */
#define CAEKF_ROW_NNZ(m, i) (caekf_sized_link_nnz[i])
#define CAEKF_ROW_NZ(m, i) (caekf_sized_link_nz[i])
#define CAEKF_ROW_NNZ_STORE(m) ((void)(m), (unsigned char *)0)
#define CAEKF_ROW_NZ_STORE(m) ((void)(m), (unsigned char(*)[CAEKF_NQ])0)
#else
#define CAEKF_CONTACT_I(m, c) ((m)->contact_i[c])
#define CAEKF_CONTACT_J(m, c) ((m)->contact_j[c])
#define CAEKF_ROW_NNZ(m, i) ((m)->nnz[i])
#define CAEKF_ROW_NZ(m, i) ((m)->nz[i])
#define CAEKF_ROW_NNZ_STORE(m) ((m)->nnz)
#define CAEKF_ROW_NZ_STORE(m) ((m)->nz)
#endif /* CAEKF_FIXED_LINKS */

/* A structure given as matrices (w, B_u's columns, the sensors' rows), or bodies on a line: a constant in the
 * builds without structures, so their code compiles out. */
#if CAEKF_HAS_STRUCTURES
#define CAEKF_IS_STRUCTURE(m) ((m)->structure)
#define CAEKF_STRUCTURE_MASS(m) ((m)->mass)
#define CAEKF_STRUCTURE_W(m, c) ((m)->w[c])
#define CAEKF_STRUCTURE_BU(m, k) ((m)->bu[k])
#define CAEKF_STRUCTURE_H(m, k) ((m)->h[k])
#define CAEKF_IS_STRUCTURE_STORE(m) (&(m)->structure)
#else
#define CAEKF_IS_STRUCTURE(m) ((void)(m), 0)
#define CAEKF_STRUCTURE_MASS(m) ((void)(m), (caekf_scalar_t *)0)
#define CAEKF_STRUCTURE_W(m, c) ((void)(m), (void)(c), (caekf_scalar_t *)0)
#define CAEKF_STRUCTURE_BU(m, k) ((void)(m), (void)(k), (caekf_scalar_t *)0)
#define CAEKF_STRUCTURE_H(m, k) ((void)(m), (void)(k), (caekf_scalar_t *)0)
#define CAEKF_IS_STRUCTURE_STORE(m) ((void)(m), (int *)0)
#endif /* CAEKF_HAS_STRUCTURES */

/* One backward-Euler step per sample (CAEKF_ONE_STEP_BE): the model keeps no contact-free F (fv0), it is
 * recomputed where needed. */
#if CAEKF_ONE_STEP_BE
#define CAEKF_FV0(m) ((void)(m), (caekf_scalar_t(*)[CAEKF_N])0)
#else
#define CAEKF_FV0(m) ((m)->fv0)
#endif /* CAEKF_ONE_STEP_BE */

/* The largest |A0_ij| outside the one contact's block (CAEKF_A0_MAX_OPEN). */
#if CAEKF_A0_MAX_OPEN
#define CAEKF_A0_MAX_OPEN_STORE(m) (&(m)->a0_max_open)
#else
#define CAEKF_A0_MAX_OPEN_STORE(m) ((void)(m), (caekf_scalar_t *)0)
#endif /* CAEKF_A0_MAX_OPEN */

/* The contacts' penetration std for statistically linearised tangents (CAEKF_HAS_SLR). */
#if CAEKF_HAS_SLR
#define CAEKF_SLR_S(m) ((m)->slr_s)
#else
#define CAEKF_SLR_S(m) ((void)(m), (caekf_scalar_t *)0)
#endif /* CAEKF_HAS_SLR */

/* A contact's force derivatives by its estimated exponent and lambda (CAEKF_HAS_LAW_PARAMS). */
#if CAEKF_HAS_LAW_PARAMS
#define CAEKF_DFC_DN_STORE(ct) (&(ct)->dfc_dn)
#define CAEKF_DFC_DLAMBDA_STORE(ct) (&(ct)->dfc_dlambda)
#else
#define CAEKF_DFC_DN_STORE(ct) ((void)(ct), (caekf_scalar_t *)0)
#define CAEKF_DFC_DLAMBDA_STORE(ct) ((void)(ct), (caekf_scalar_t *)0)
#endif /* CAEKF_HAS_LAW_PARAMS */

/* Contact c's w_c^T x over the positions at x (or, with x + nq, the velocities): q_a - q_b - for bodies on a
 * line, without the gap. */
caekf_scalar_t caekf_model_contact_dot(const caekf_model_t *m, int c, const caekf_scalar_t *x);

/* The step method: constants in a build sized for one configuration (CAEKF_SIZED_METHOD), so the code of
 * the other methods compiles out; the settings' otherwise. */
#if CAEKF_SIZED_METHOD
#define CAEKF_METHOD_TRAP(m) ((void)(m), CAEKF_SIZED_DISCRETISATION == CAEKF_DISCRETISATION_TRAPEZOIDAL)
#define CAEKF_METHOD_SUBSTEPS(cfg) ((void)(cfg), CAEKF_SIZED_CONTACT_SUBSTEPS)
#define CAEKF_PARAMS_GAMMA_LOG(p) ((void)(p), CAEKF_SIZED_GAMMA_LOG)
#define CAEKF_METHOD_SWITCHOFF(cfg) ((void)(cfg), CAEKF_SIZED_SWITCHOFF)
#define CAEKF_TRAP_STORE(m) ((void)(m), (int *)0)
#define CAEKF_GAMMA_LOG_STORE(m) ((void)(m), (int *)0)
#else
#define CAEKF_METHOD_TRAP(m) ((m)->trap)
#define CAEKF_METHOD_SUBSTEPS(cfg) ((cfg)->contact_substeps)
#define CAEKF_PARAMS_GAMMA_LOG(p) ((p)->gamma_log)
#define CAEKF_METHOD_SWITCHOFF(cfg) ((cfg)->switchoff)
#define CAEKF_TRAP_STORE(m) (&(m)->trap)
#define CAEKF_GAMMA_LOG_STORE(m) (&(m)->p.gamma_log)
#endif                                                            /* CAEKF_SIZED_METHOD */
#define CAEKF_METHOD_GAMMA_LOG(m) CAEKF_PARAMS_GAMMA_LOG(&(m)->p) /* of a model */
/* Contact c's Hunt-Crossley lambda (the setting; an estimated one is a state): 0 where no contact of the
 * build is damped (CAEKF_HAS_DAMPING). */
#if CAEKF_HAS_DAMPING
#define CAEKF_METHOD_LAMBDA(m, c) ((m)->p.contact_lambda[c])
#define CAEKF_LAMBDA_STORE(m) ((m)->p.contact_lambda)
#else
#define CAEKF_METHOD_LAMBDA(m, c) ((void)(m), (void)(c), (caekf_scalar_t)0)
#define CAEKF_LAMBDA_STORE(m) ((void)(m), (caekf_scalar_t *)0)
#endif /* CAEKF_HAS_DAMPING */
/* Contact c's exponent: the build's constant where every contact of the sized scenario has the same. */
#ifdef CAEKF_SIZED_CONTACT_N
#define CAEKF_HAS_CONTACT_N 0 /* the model stores no exponent */
#define CAEKF_SIZED_CONTACT_N_VALUE ((caekf_scalar_t)CAEKF_SIZED_CONTACT_N)
#define CAEKF_METHOD_CONTACT_N(m, c) ((void)(m), (void)(c), CAEKF_SIZED_CONTACT_N_VALUE)
#define CAEKF_CONTACT_N_STORE(m) ((void)(m), (caekf_scalar_t *)0)
#else
#define CAEKF_HAS_CONTACT_N 1
#define CAEKF_SIZED_CONTACT_N_VALUE ((caekf_scalar_t)0) /* none */
#define CAEKF_METHOD_CONTACT_N(m, c) ((m)->p.contact_n[c])
#define CAEKF_CONTACT_N_STORE(m) ((m)->p.contact_n)
#endif /* CAEKF_SIZED_CONTACT_N */

/* The index j (0 .. nm-1) of the estimated mechanism parameter of that kind and element (its body or link),
 * or -1 when it is not estimated. */
int caekf_model_mech_index(const caekf_model_t *m, int kind, int elem);

/* The model's own defence (caekf_settings_validate says which parameter is wrong). Returns 0 if valid. */
int caekf_model_params_check(const caekf_model_params_t *p);

/* The model's reference functions (the residual, its Jacobians, the full F of eq. 10): test oracles for
 * the structured step, which the estimator never calls. A build sized for one configuration
 * (CAEKF_SIZED_METHOD) leaves them out of its library (CAEKF_MODEL_ORACLES, caekf_config.h). */
/* The step's residual g(x_k, x_{k-1}, u_{k-1}, u_k) of the augmented state x = [q; v; gamma], theta = 1
 * (backward Euler, eq. 19) or 1/2 (trapezoidal), G(x, u) = C v + K q - B_u u + sum_c b_c f_c(x, gamma_c):
 *   rows 0..nq-1:     (q_k - q_{k-1})/dt - theta v_k - (1 - theta) v_{k-1}
 *   rows nq..2nq-1:   [M (v_k - v_{k-1})/dt + theta G(x_k, u_k) + (1 - theta) G(x_{k-1}, u_{k-1})] / theta
 *   rows 2nq..n-1:    theta_k - theta_{k-1}, the parameters' random walks (gammas, estimated n, lambda, gap) */
void caekf_model_residual(const caekf_model_t *m, const caekf_scalar_t *xk, const caekf_scalar_t *xprev,
                          const caekf_scalar_t *u_prev, const caekf_scalar_t *u, caekf_scalar_t *g);

/* Analytic Jacobians of that residual: dg/dx_k and dg/dx_{k-1} (gammas included); n x n in arrays of the
 * capacity. */
void caekf_model_jacobians(const caekf_model_t *m, const caekf_scalar_t *xk, const caekf_scalar_t *xprev,
                           caekf_scalar_t Jk[CAEKF_N][CAEKF_N], caekf_scalar_t Jprev[CAEKF_N][CAEKF_N]);

/* Eq. (10) F = -(dg/dx_k)^-1 dg/dx_{k-1}, computed from the residual's structure: one nq x nq LU of
 * A = M/hs + C_t + hs K_t (the contacts' tangents at x_k) instead of an n x n inverse. The gamma rows
 * are identity rows by construction. Returns 0, or -1 if A is singular. */
int caekf_model_transition(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                           const caekf_scalar_t xprev[CAEKF_N], caekf_scalar_t F[CAEKF_N][CAEKF_N]);

/* The v-rows of F only (nq x n), which is all the filter needs: F's q-rows are
 * [I, (dt - hs) I, 0] + hs * (v-rows), and its gamma rows are identity rows. Returns 0, or -1 if A is
 * singular. */
int caekf_model_transition_v(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                             const caekf_scalar_t xprev[CAEKF_N], caekf_scalar_t fv[CAEKF_NQ][CAEKF_N]);

/* caekf_model_transition_v with the contacts' laws at x_k given (caekf_model_contact of each contact at
 * x_k, as the estimator has them for eq. 21): the same result. */
int caekf_model_transition_v_at(const caekf_model_t *m, const caekf_contact_t *ct, const caekf_scalar_t xprev[CAEKF_N],
                                caekf_scalar_t fv[CAEKF_NQ][CAEKF_N]);

/* The substeps' Newton solve and map, which pass the contacts on instead of evaluating them again at the same
 * state (bit for bit the same results). Defined where a build has substeps (CAEKF_HAS_SUBSTEPS), declared for
 * every build: code that names them under if (CAEKF_HAS_SUBSTEPS) compiles out elsewhere. caekf_model_newton
 * with the contacts at x_k left in ct and, for the trapezoidal rule, those at x_{k-1} given in ct0 (NULL:
 * evaluated here). */
int caekf_model_newton_ct(const caekf_model_t *m, const caekf_scalar_t xprev[CAEKF_N], const caekf_scalar_t *u_prev,
                          const caekf_scalar_t *u, int max_iter, caekf_scalar_t rtol, caekf_scalar_t xk[CAEKF_N],
                          int *iters, caekf_scalar_t work[4 * CAEKF_NQ], caekf_contact_t *ct,
                          const caekf_contact_t *ct0, const caekf_newton_lu_t *first);

/* S <- F_j S (sq, sv: S's q- and v-rows; its parameter rows are identity rows) for the substep map F_j
 * from the contacts at its end (ct) and, trapezoidal, its start (ct0), without forming F_j; the Newton
 * matrix's LU at the end is left in lu. w: scratch of nq rows. Returns -1 on a singular matrix. */
int caekf_model_substep_map(const caekf_model_t *m, const caekf_contact_t *ct, const caekf_contact_t *ct0,
                            caekf_scalar_t sq[CAEKF_NQ][CAEKF_N], caekf_scalar_t sv[CAEKF_NQ][CAEKF_N],
                            caekf_newton_lu_t *lu, caekf_scalar_t w[CAEKF_NQ][CAEKF_N]);

/* The LU of the Newton matrix at the contacts ct (constant: no contact on, A0's). Returns -1 when it is
 * singular. */
int caekf_model_newton_lu(const caekf_model_t *m, const caekf_contact_t *ct, caekf_newton_lu_t *lu);

/* caekf_model_any_contact keeping the contacts at x in ct (x NULL: ct holds them already, only the test).
 * The step passes them on instead of evaluating them again at the same state (the same results). */
int caekf_model_contacts_any(const caekf_model_t *m, const caekf_scalar_t *x, caekf_contact_t *ct);

/* caekf_model_transition_v from the contacts at x_k (ct) and, for the trapezoidal rule, at x_{k-1} (ct0). */
int caekf_model_transition_ct(const caekf_model_t *m, const caekf_contact_t *ct, const caekf_contact_t *ct0,
                              caekf_scalar_t fv[CAEKF_NQ][CAEKF_N]);

/* The v-rows of the constant contact-free F (nq x n): model_init's fv0, or recomputed by the same
 * operations (CAEKF_ONE_STEP_BE). */
void caekf_model_free_transition_v(const caekf_model_t *m, caekf_scalar_t fv[CAEKF_NQ][CAEKF_N]);

/* Whether a contact is closed at x (the step map then differs from the constant linear one). */
int caekf_model_any_contact(const caekf_model_t *m, const caekf_scalar_t *x);
/* 1 when contact c's law is linearised statistically (setting contact_slr_p: tangents and switch): elastic laws of
 * gamma alone. A damped law or one with n, lambda or the gap estimated keeps its own tangents and the sign switch
 * of eq. (21): the switch on P(delta > 0) alone, without the expected tangents, measured worse on the whole law
 * (docs/discretisation.md). */
static inline int caekf_model_slr_law(const caekf_model_t *m, int c)
{
    const unsigned char *law = m->law_state[c];
    if (CAEKF_HAS_LAW_PARAMS && (law[CAEKF_LAW_N] != 0u || law[CAEKF_LAW_LAMBDA] != 0u || law[CAEKF_LAW_GAP] != 0u)) {
        return 0;
    }
    return CAEKF_METHOD_LAMBDA(m, c) == 0;
}

#endif /* CAEKF_MODEL_INTERNAL_H */
