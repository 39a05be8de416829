/*
 * The lumped contact model (paper Sec. 3.1), discretised implicitly: backward Euler (eq. 19 plus the
 * damping term C v_k that the paper's equation omits) or the trapezoidal rule (docs/discretisation.md). The mechanism is described by the settings
 * (docs/mechanism.md): bodies on a line, spring-damper links between two bodies or a body and ground
 * (body 0), input forces, sensors and contacts. A contact between bodies a and b has penetration
 * delta = q_a - q_b - gap; its force f = gamma delta^n (1 + lambda d delta/dt) for delta > 0 acts -f on
 * a and +f on b.
 */
#ifndef CAEKF_MODEL_H
#define CAEKF_MODEL_H

#include <stdint.h>

#include "caekf/caekf_config.h"
#include "caekf/caekf_settings_types.h" /* generated from the settings schema at build time */

#ifdef __cplusplus
extern "C" {
#endif

/* caekf_model_params_t and the enums of its settings (caekf_sensor_kind_t, caekf_discretisation_t) are
 * generated from the settings schema (caekf/caekf_settings_types.h), like every setting. The two
 * discretisations: docs/discretisation.md. */

/* A contact's law parameters besides gamma (index into caekf_model_t.law_state). */
enum { CAEKF_LAW_N = 0, CAEKF_LAW_LAMBDA = 1, CAEKF_LAW_GAP = 2, CAEKF_LAW_COUNT = 3 };

/* A mechanism parameter's kind (caekf_model_t.mech_kind): settings m{i}_sigma, spring{i}_k_sigma,
 * spring{i}_c_sigma > 0 make them states. */
enum { CAEKF_MECH_MASS = 0, CAEKF_MECH_STIFFNESS = 1, CAEKF_MECH_DAMPER = 2 };

/* A linear structure given as its matrices (docs/structure.md): eq. 19 with M q'' + C q' + K q + sum_c w_c f_c
 * = B_u u, contact c's penetration delta_c = w_c^T q - gap_c, sensor i reading h_i^T q, h_i^T q' or h_i^T q''
 * (its setting sensor{i}_kind: position, velocity or acceleration). The counts of inputs, contacts and sensors
 * are the settings'; the arrays are the caller's, read once by caekf_init_structure (row-major). A structure
 * whose M is not diagonal is first taken to its modal basis (exact; sim's caekf_sim.structure does it). */
typedef struct {
    int dofs;                        /* degrees of freedom, 1 .. CAEKF_MAX_DOFS */
    const caekf_scalar_t *mass;      /* M's diagonal, dofs entries > 0 */
    const caekf_scalar_t *stiffness; /* K, dofs x dofs, symmetric */
    const caekf_scalar_t *damping;   /* C, dofs x dofs, symmetric; NULL: none */
    const caekf_scalar_t *inputs;    /* B_u, dofs x inputs (column k: input k's load vector); NULL without inputs */
    const caekf_scalar_t *contacts;  /* contacts x dofs: row c is w_c */
    const caekf_scalar_t *sensors;   /* sensors x dofs: row i is h_i */
} caekf_structure_t;

/* Builds that can estimate law parameters (CAEKF_MAX_LAW_PARAMS > 0) look them up in the state; the
 * others compile the lookups out. */
#define CAEKF_HAS_LAW_PARAMS (CAEKF_MAX_LAW_PARAMS > 0)

/* A build sized for one mechanism with one contact keeps the largest |A0_ij| outside that contact's block:
 * the Newton matrix's largest entry (the LU's refusal threshold) then takes the block's entries only (a
 * maximum is the same in any order). */
#define CAEKF_A0_MAX_OPEN (CAEKF_SIZED && CAEKF_MAX_CONTACTS == 1)

/* A0's storage: the whole nq x nq, or where the step is one backward-Euler step per sample only its upper
 * triangle. */
#define CAEKF_A0_STORE (CAEKF_ONE_STEP_BE ? CAEKF_NQ * (CAEKF_NQ + 1) / 2 : CAEKF_NQ * CAEKF_NQ)

/* Matrices derived once from the parameters. Sizes: nq bodies, nc contacts, n = 2 nq + nc + ne states
 * (x = [q; v; gamma_1..gamma_nc; the ne estimated law parameters, contact by contact in the order n,
 * lambda, gap]); arrays are sized for the build's capacity. */
/* The mechanism's values the model's functions read at run time (the rest of caekf_model_params_t is
 * derived into the matrices below at init, and the estimator keeps the whole of it in its settings): the
 * same names as there, so a model reads them as m->p.dt etc. */
typedef struct {
    caekf_scalar_t dt;
#if !CAEKF_SIZED /* else the sized count */
    int inputs;
#endif
    int input_body[CAEKF_MAX_INPUTS]; /* the body each input acts on (a base input's: its link's other end) */
    caekf_scalar_t contact_gap[CAEKF_MAX_CONTACTS];
#ifndef CAEKF_SIZED_CONTACT_N /* else the sized exponent */
    caekf_scalar_t contact_n[CAEKF_MAX_CONTACTS];
#endif
#if CAEKF_HAS_DAMPING /* else every contact's law is elastic */
    caekf_scalar_t contact_lambda[CAEKF_MAX_CONTACTS];
#endif
#if !CAEKF_SIZED_METHOD /* else the sized method's */
    int gamma_log;
#endif
} caekf_model_run_params_t;

typedef struct {
    caekf_model_run_params_t p;
    int nq, nc, n;
    /* State index of contact c's n, lambda and gap when estimated, else 0 (state 0 is q_1). */
    unsigned char law_state[CAEKF_MAX_CONTACTS][CAEKF_LAW_COUNT];
    /* The contact of each parameter state 2 nq + k (the gammas first): its switch-off follows that contact. */
    unsigned char param_contact[CAEKF_NP_STORE];
    int contact_i[CAEKF_MAX_CONTACTS], contact_j[CAEKF_MAX_CONTACTS]; /* 0-based ends, -1 = ground */
    /* The estimated mechanism parameters (the last nm states, from state n - nm): their kind, the ends
     * they act between (0-based, -1 = ground; a mass: its body twice), the setting's element (its body or
     * link) and their value now (the setting's times exp of the state, caekf_model_set_mech). */
    int nm;
    unsigned char mech_kind[CAEKF_MECH_STORE], mech_elem[CAEKF_MECH_STORE];
    signed char mech_a[CAEKF_MECH_STORE], mech_b[CAEKF_MECH_STORE];
    caekf_scalar_t mech_value[CAEKF_MECH_STORE];
    /* The sensors' estimated offsets (setting sensor{i}_bias_sigma > 0): the last nb states, in sensor
     * order; sensor_bias[k] is sensor k's offset state, 0 when it has none. */
    int nb;
    unsigned char sensor_bias[CAEKF_MAX_SENSORS];
#if CAEKF_HAS_BASE_INPUTS /* else every input is a force (read through the CAEKF_BASE_* macros) */
    /* The inputs that move a link's ground end (setting input{i}_kind = base_displacement, docs/mechanism.md):
     * how many, each input's link (1-based; 0: a force) and that link's stiffness and damper now (the
     * settings', or the estimates', caekf_model_set_mech). Such an input u adds k u + c du/dt on its body. */
    int nbase;
    unsigned char base_link[CAEKF_MAX_INPUTS];
    caekf_scalar_t base_k[CAEKF_MAX_INPUTS], base_c[CAEKF_MAX_INPUTS];
#endif
#if CAEKF_HAS_STRUCTURES /* else every mechanism is bodies on a line (read through CAEKF_IS_STRUCTURE) */
    /* A structure given as matrices (caekf_model_init_structure): its masses, contacts' w, inputs' columns of
     * B_u and sensors' rows; K and C below are its own. 0: bodies on a line (the settings' links). */
    int structure;
    caekf_scalar_t mass[CAEKF_NQ];
    caekf_scalar_t w[CAEKF_MAX_CONTACTS][CAEKF_NQ];
    caekf_scalar_t bu[CAEKF_MAX_INPUTS][CAEKF_NQ];
    caekf_scalar_t h[CAEKF_MAX_SENSORS][CAEKF_NQ];
#endif
    caekf_scalar_t K[CAEKF_NQ][CAEKF_NQ];
    caekf_scalar_t C[CAEKF_NQ][CAEKF_NQ];
    /* The implicit stage: the momentum rows are scaled so that their v_k-derivative is
     * M/hs + C_t + hs K_t, with hs = dt (backward Euler) or dt/2 (trapezoidal, rows times 2). */
    caekf_scalar_t hs;
#if !CAEKF_SIZED_METHOD /* else the sized method's */
    int trap;           /* trapezoidal: the step's start enters the rows */
#endif
    caekf_scalar_t m_dt[CAEKF_NQ]; /* M / hs (diagonal) */
#if !CAEKF_FIXED_LINKS             /* else the build's constant pattern */
    /* Row i of K and C is nonzero in columns nz[i][0 .. nnz[i]-1] (ascending): the residual skips the
     * structural zeros, which change no sum. */
    unsigned char nz[CAEKF_NQ][CAEKF_NQ];
    unsigned char nnz[CAEKF_NQ];
#endif
    /* A0 = M/hs + C + hs K, the Newton matrix without contact, packed nq x nq. Without contact the step
     * is linear: A0's LU and the v-rows of F are constants, computed once by the same code the contact
     * path runs, so using them changes no bit of the result (CAEKF_ONE_STEP_BE: A0 is kept as its upper
     * triangle, and fv0 is not kept but recomputed where needed, by the same operations). */
    caekf_scalar_t A0[CAEKF_A0_STORE]; /* CAEKF_ONE_STEP_BE: its upper triangle, row by row (it is symmetric) */
    caekf_scalar_t A0_lu[CAEKF_NQ * CAEKF_NQ];
    int A0_piv[CAEKF_NQ];
#if !CAEKF_ONE_STEP_BE
    caekf_scalar_t fv0[CAEKF_NQ][CAEKF_N];
#endif
#if CAEKF_A0_MAX_OPEN
    caekf_scalar_t a0_max_open; /* max |A0_ij| outside the contact's 2 x 2 block (the Newton matrix's rest) */
#endif
#if CAEKF_HAS_SLR
    /* Statistically linearised contact tangents (setting contact_slr_p > 0): the std of each contact's
     * penetration (m), set by the estimator from P each step for the laws it linearises (elastic, gamma
     * alone: caekf_model_slr_law); 0 (caekf_model_init, and every other law): the law's own tangents. */
    caekf_scalar_t slr_s[CAEKF_MAX_CONTACTS];
#endif
} caekf_model_t;

/* The nonzero columns of each v-row of F (nz[i][0 .. nnz[i]-1], ascending): the covariance products
 * skip the exact zeros, which change no sum. */
typedef struct {
    unsigned char nz[CAEKF_NQ][CAEKF_N]; /* not written for a dense row (nnz[i] == n) */
    unsigned char nnz[CAEKF_NQ];
    unsigned char dense; /* every row is dense (in contact) */
} caekf_fv_pattern_t;

/* The filter's sizes and structure (set at init; the policies every step). */
typedef struct {
    int nq, n;                           /* bodies; states */
    int ny;                              /* sensors */
    int rows;                            /* 0: each sensor reads one state (h); 1: the correction's rows */
    int h[CAEKF_MAX_SENSORS];            /* state index each sensor measures (rows == 0) */
    caekf_scalar_t r[CAEKF_MAX_SENSORS]; /* scaled R diagonal */
    uint8_t policy[CAEKF_NP_STORE];      /* how parameter k (state 2 nq + k) is handled this step */
} caekf_filter_dims_t;

/* Work buffers of the correction: the gain and H P (in the instance, off the stack). */
typedef struct {
    caekf_scalar_t gain[CAEKF_N][CAEKF_MAX_SENSORS];
    caekf_scalar_t hp[CAEKF_MAX_SENSORS][CAEKF_N];
    /* Sensors other than one state each (dims rows == 1): H's rows and h(x-), scaled (the caller's), and
     * H P H^T (the correction's). */
    caekf_scalar_t row[CAEKF_MAX_SENSORS][CAEKF_N];
    caekf_scalar_t hx[CAEKF_MAX_SENSORS];
    caekf_scalar_t hph[CAEKF_MAX_SENSORS][CAEKF_MAX_SENSORS];
} caekf_correct_work_t;

/* One contact's law at a state: penetration and the force with its derivatives (the gap's is
 * -dfc_ddelta). */
typedef struct {
    caekf_scalar_t delta;      /* q_a - q_b - gap */
    caekf_scalar_t fc;         /* gamma delta^n (1 + lambda d delta/dt), 0 if delta <= 0 (and >= 0) */
    caekf_scalar_t dfc_ddelta; /* with respect to delta */
    caekf_scalar_t dfc_drate;  /* with respect to d delta/dt (Hunt-Crossley) */
    caekf_scalar_t dfc_dgamma;
#if CAEKF_HAS_LAW_PARAMS
    caekf_scalar_t dfc_dn;      /* with respect to the exponent (only when it is estimated) */
    caekf_scalar_t dfc_dlambda; /* with respect to lambda */
#endif
} caekf_contact_t;

/* The LU of a substep's Newton matrix at its end, which the next substep's first Newton update takes
 * (the Jacobian at that substep's start: one factorisation less per substep). */
typedef struct {
    caekf_scalar_t lu[CAEKF_NQ * CAEKF_NQ];
    int piv[CAEKF_NQ];
    int constant; /* no contact on: A0's LU (the model's) */
} caekf_newton_lu_t;

/* Derives the matrices. Returns 0, or -1 when the parameters are invalid (model left unchanged). */
int caekf_model_init(caekf_model_t *m, const caekf_model_params_t *p);

/* caekf_model_init for a structure given as matrices (st; the settings' bodies, links and ends are not read).
 * Returns 0, or -1 when the parameters or the structure are invalid (caekf_model_structure_check). */
int caekf_model_init_structure(caekf_model_t *m, const caekf_model_params_t *p, const caekf_structure_t *st);

/* Whether st fits the build and the settings p (sizes, finite values, M > 0, K and C symmetric, sensors that
 * read a row, forces for inputs, no declared mechanism parameter): 0, or -1. */
int caekf_model_structure_check(const caekf_model_params_t *p, const caekf_structure_t *st);

/* Estimated mechanism parameter j's setting (its value in p, the settings the model was initialised from)
 * and, with sigma not NULL, its declared relative standard deviation. */
caekf_scalar_t caekf_model_mech_setting(const caekf_model_t *m, const caekf_model_params_t *p, int j,
                                        caekf_scalar_t *sigma);

/* The matrices again with the estimated mechanism parameters at factor[j] times their settings' values
 * (j = 0 .. nm-1, in state order; p: the settings the model was initialised from). Returns 0, or -1
 * when the Newton matrix without contact is singular (the model then holds the new values). */
int caekf_model_set_mech(caekf_model_t *m, const caekf_model_params_t *p, const caekf_scalar_t *factor);

/* dv_k / du = A^-1 B_u, A the Newton matrix at the contacts ct (x_k): how each input's error, held over the
 * step, moves the step's velocities (its positions by hs times as much), per end of the step that takes the
 * input (the trapezoidal rule takes it at both: twice this). B_u's column: e_body for a force, k e_body for a
 * base displacement (the damper's c (u_k - u_{k-1}) / dt does not see an error held over the step). g is
 * nq x inputs. Returns -1 when A is singular. */
int caekf_model_input_columns(const caekf_model_t *m, const caekf_contact_t *ct,
                              caekf_scalar_t g[CAEKF_NQ][CAEKF_MAX_INPUTS]);

/* The mechanism parameters' columns of F's v-rows, dv_k / d ln(value_j), at the step x_{k-1} -> x_k with
 * the contacts at x_k in ct and the inputs u_prev, u at its ends (a base displacement moves its link's ground
 * end): -A^-1 dg/d ln(value_j), A the Newton matrix at x_k. With dev (per input, NULL: none) x_k is first
 * moved to where inputs dev smaller would have taken it, to first order x_k - A^-1 B_u dev (positions hs
 * times as much; dev summed over the ends of the step that take the input). Written into the mechanism's nm
 * columns of fv. Returns 0, or -1 when A is singular. */
int caekf_model_mech_columns(const caekf_model_t *m, const caekf_contact_t *ct, const caekf_scalar_t xprev[CAEKF_N],
                             const caekf_scalar_t xk[CAEKF_N], const caekf_scalar_t *u_prev, const caekf_scalar_t *u,
                             const caekf_scalar_t *dev, caekf_scalar_t fv[CAEKF_NQ][CAEKF_N]);

/* What sensor k reads at the augmented state x with the inputs u, u_prev those of the step before (a base
 * displacement's rate is (u - u_prev) / dt; u_prev = u: at rest) (docs/sensors.md): *value = h_k(x) and
 * row = dh_k/dx, both in physical units (a mechanism parameter's column per ln(value), an offset's per its
 * unit). p: the settings the model was initialised from. */
void caekf_model_sensor(const caekf_model_t *m, const caekf_model_params_t *p, int k, const caekf_scalar_t *x,
                        const caekf_scalar_t *u, const caekf_scalar_t *u_prev, caekf_scalar_t *value,
                        caekf_scalar_t row[CAEKF_N]);

/* Contact c's law at the augmented state x: positions, velocities, its gamma and its estimated law
 * parameters (the others are the model's). */
void caekf_model_contact(const caekf_model_t *m, int c, const caekf_scalar_t *x, caekf_contact_t *out);

/* Newton-Raphson solve of the step for x_k given x_{k-1}, the inputs u_{k-1} at its start (used by the
 * trapezoidal rule, and by a base displacement's rate) and u_k (one per input; the gammas and law parameters
 * carry over). A base displacement u of a link (k, c) enters as the force k u_k + c (u_k - u_{k-1}) / dt
 * (backward Euler), k (u_k + u_{k-1}) / 2 + c (u_k - u_{k-1}) / dt (trapezoidal: the mean of both ends). Backward Euler, eq. (19):
 * unknown v_k, q_k = q_{k-1} + dt v_k. Trapezoidal: q_k = q_{k-1} + dt/2 (v_{k-1} + v_k), and the
 * momentum balance is the mean of its two ends. Initial guess v_{k-1}. Converged when the largest
 * momentum-row residual is <= rtol times the largest row's sum of term magnitudes (a norm-wise backward
 * error). At most max_iter iterations (clamped to CAEKF_NEWTON_MAX_ITER). Returns 0 when converged, 1
 * when the bound was hit, 2 on a singular Jacobian (x_k holds the last iterate in both cases).
 * *iters = linear solves done. work: the residual, its terms' sizes and the trapezoidal rule's constant
 * start-of-step terms (caller-owned, off the stack). */
int caekf_model_newton(const caekf_model_t *m, const caekf_scalar_t xprev[CAEKF_N], const caekf_scalar_t *u_prev,
                       const caekf_scalar_t *u, int max_iter, caekf_scalar_t rtol, caekf_scalar_t xk[CAEKF_N],
                       int *iters, caekf_scalar_t work[4 * CAEKF_NQ]);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_MODEL_H */
