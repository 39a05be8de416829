/*
 * caekf compile-time options. Every option a build may set is documented here, in one place.
 *
 *   CAEKF_USE_FLOAT          0 (default): caekf_scalar_t is double. 1: float (Cortex-M4F class).
 *   CAEKF_NEWTON_MAX_ITER    hard upper bound on Newton iterations per step (default 20). The run-time
 *                            setting `newton_max_iter` may only lower it.
 *   CAEKF_JACOBI_MAX_SWEEPS  bound on cyclic Jacobi sweeps used by the eigen routines (P norm and
 *                            covariance repair; default 12, 9x9 converges in about 6).
 *   CAEKF_MAX_BODIES, CAEKF_MAX_SPRINGS, CAEKF_MAX_INPUTS, CAEKF_MAX_SENSORS, CAEKF_MAX_CONTACTS
 *                            the mechanism capacity of the build: storage for that many bodies, links,
 *                            input forces, sensors and contacts. Generated (caekf/caekf_capacity.h):
 *                            the schema's capacity, or with CAEKF_SIZED = 1 exactly one scenario's
 *                            mechanism (CMake: -DCAEKF_MECHANISM=path/to/scenario.toml), whose counts
 *                            CAEKF_SIZED_* the settings must then equal.
 *   CAEKF_MAX_DOFS           degrees of freedom of the positions q (generated): a host build's structure given
 *                            as matrices (caekf_init_structure, docs/structure.md) has up to this many (the
 *                            schema's [structure] dofs); a sized build, its bodies.
 *   CAEKF_MAX_LAW_PARAMS     contact-law parameters (n, lambda, gap) the build can estimate besides the
 *                            gammas: 3 per contact, or exactly the sized scenario's (generated too).
 *   CAEKF_MAX_MECH_PARAMS    mechanism parameters (masses, stiffnesses, dampers) the build can estimate
 *                            (settings m{i}_sigma, spring{i}_k_sigma, spring{i}_c_sigma > 0)
 *   CAEKF_MAX_BIASES         sensor offsets the build can estimate (setting sensor{i}_bias_sigma > 0)
 *   CAEKF_SIZED_BASE_INPUTS  generated in a build sized for one scenario (CAEKF_SIZED): its inputs that are a
 *                            base displacement (input{i}_kind); 0 compiles the base input's code out
 *                            (CAEKF_HAS_BASE_INPUTS) and refuses the kind (CAEKF_SETTING_UNSUPPORTED).
 *   CAEKF_SIZED_METHOD       generated (caekf/caekf_capacity.h), 1 in a build sized for one configuration
 *                            of a scenario (CMake: -DCAEKF_MECHANISM=scenario.toml
 *                            -DCAEKF_MECHANISM_PRESET=preset): its step method is then fixed as well,
 *                            CAEKF_SIZED_DISCRETISATION, CAEKF_SIZED_CONTACT_SUBSTEPS, CAEKF_SIZED_SLR
 *                            (statistically linearised contacts: contact_slr_p > 0), the covariance
 *                            correction's form CAEKF_SIZED_COV_UPDATE, the gammas' switch-off
 *                            CAEKF_SIZED_SWITCHOFF, whether any contact is damped CAEKF_SIZED_DAMPED
 *                            (contact_lambda nonzero or estimated) and, when every contact has the same
 *                            exponent, CAEKF_SIZED_CONTACT_N. The code of other methods compiles out (the
 *                            trapezoidal rule, the substeps and their model, the other covariance form and
 *                            switch-off, the damped law, pow for an exponent of 1.5 or 1); settings asking
 *                            for another are refused (CAEKF_SETTING_UNSUPPORTED) and the schema's defaults
 *                            are the fixed values. Derived from it: CAEKF_HAS_SUBSTEPS,
 *                            CAEKF_HAS_TRAPEZOIDAL, CAEKF_ONE_STEP_BE, CAEKF_HAS_SLR, CAEKF_HAS_DAMPING.
 *   CAEKF_MODEL_ORACLES      1: the library has the model's reference residual, Jacobians and full F (test
 *                            oracles the estimator never calls). Default: 1, 0 with CAEKF_SIZED_METHOD.
 *   CAEKF_PSD_WRITTEN_OUT_MAX_N  a build sized for substeps writes the full PSD test of P out for its
 *                            state's n (the same operations, a third of the instructions) when n is at most
 *                            this (default 12: the paper's 9, its whole contact law's 12). Its text grows
 *                            as n^3: at n = 18 (8 bodies, 2 contacts) 26 KB for 2 % of the worst step, so a
 *                            larger state keeps the loop.
 *
 */
#ifndef CAEKF_CONFIG_H
#define CAEKF_CONFIG_H

#include <float.h>

#ifndef CAEKF_USE_FLOAT
#define CAEKF_USE_FLOAT 0
#endif

#ifndef CAEKF_NEWTON_MAX_ITER
#define CAEKF_NEWTON_MAX_ITER 20
#endif

#ifndef CAEKF_JACOBI_MAX_SWEEPS
#define CAEKF_JACOBI_MAX_SWEEPS 12
#endif

#if CAEKF_USE_FLOAT
typedef float caekf_scalar_t;
#define CAEKF_EPS FLT_EPSILON
#define CAEKF_TINY 1e-30f /* off-diagonal covariances below this are flushed to 0 (no subnormals) */
#define CAEKF_SCALAR_NAME "float"
#else
typedef double caekf_scalar_t;
#define CAEKF_EPS DBL_EPSILON
#define CAEKF_TINY 1e-290
#define CAEKF_SCALAR_NAME "double"
#endif

/* Mechanism capacity: generated from the settings schema, or sized for one scenario (CMake option
 * CAEKF_MECHANISM). */
#include "caekf/caekf_capacity.h"

/* The step method a build runs: one fixed by a build sized for one configuration (CAEKF_SIZED_METHOD,
 * generated), else any. The instance holds the substeps' model only where substeps can run. */
#if CAEKF_SIZED_METHOD
#define CAEKF_HAS_SUBSTEPS (CAEKF_SIZED_CONTACT_SUBSTEPS > 1)
#define CAEKF_HAS_TRAPEZOIDAL (CAEKF_SIZED_DISCRETISATION == 1) /* CAEKF_DISCRETISATION_TRAPEZOIDAL */
#else
#define CAEKF_HAS_SUBSTEPS 1
#define CAEKF_HAS_TRAPEZOIDAL 1
#endif
/* One backward-Euler step per sample only: the model keeps no contact-free F (recomputed where it is
 * needed, by the same operations) and the contact-free Newton matrix only as its upper triangle, and the
 * instance no inputs of the step's start (only the trapezoidal rule and the substeps read them): a smaller
 * instance. */
#define CAEKF_ONE_STEP_BE (!CAEKF_HAS_SUBSTEPS && !CAEKF_HAS_TRAPEZOIDAL)
/* The links' ends fixed at build time (CAEKF_SIZED_SPRING_A/B and their pattern of K and C, generated from
 * the sized scenario; settings with other ends are refused) in every build sized for one configuration:
 * the residual, the Newton matrix and F are written for that pattern, without index loads (the same
 * operations in the same order, so the same bits). */
#define CAEKF_FIXED_LINKS (CAEKF_SIZED_METHOD)
/* Statistically linearised contacts (setting contact_slr_p > 0): a run-time choice of the estimator, or
 * in a build sized for one configuration part of its method (CAEKF_SIZED_SLR, generated): compiled in and
 * required there when the configuration has them, else left out and the setting refused. */
#if CAEKF_SIZED_METHOD
#define CAEKF_HAS_SLR CAEKF_SIZED_SLR
#else
#define CAEKF_HAS_SLR 1
#endif
/* Hunt-Crossley damping in the contacts' law (a contact_lambda nonzero, or lambda estimated): compiled in,
 * or in a build sized for one configuration only where its scenario has it (CAEKF_SIZED_DAMPED, generated),
 * else the law is elastic and a nonzero contact_lambda is refused. */
#if CAEKF_SIZED_METHOD
#define CAEKF_HAS_DAMPING CAEKF_SIZED_DAMPED
#else
#define CAEKF_HAS_DAMPING 1
#endif

/* Sensors that read more than one state (acceleration, relative, link force, or an estimated offset): the
 * correction takes their rows of H. A build sized for one scenario compiles that in only where its sensors
 * need it (CAEKF_SIZED_SENSOR_ROWS, generated). */
#if CAEKF_SIZED
#define CAEKF_HAS_SENSOR_ROWS CAEKF_SIZED_SENSOR_ROWS
#else
#define CAEKF_HAS_SENSOR_ROWS 1
#endif

/* Inputs that are a prescribed displacement of a link's ground end (setting input{i}_kind =
 * base_displacement, docs/mechanism.md): compiled in, or in a build sized for one scenario only where its
 * inputs have one (CAEKF_SIZED_BASE_INPUTS, generated); else every input is a force and a base input is
 * refused. */
#if CAEKF_SIZED
#define CAEKF_HAS_BASE_INPUTS (CAEKF_SIZED_BASE_INPUTS > 0)
#else
#define CAEKF_HAS_BASE_INPUTS 1
#endif
/* The estimator keeps the inputs of the last step: the trapezoidal rule's and the substeps' start, and a base
 * displacement's rate. */
#define CAEKF_KEEPS_U_PREV (!CAEKF_ONE_STEP_BE || CAEKF_HAS_BASE_INPUTS)

/* A structure given as its matrices (caekf_init_structure): in the builds for any mechanism; a build sized for
 * one mechanism on a line stores none of it. */
#define CAEKF_HAS_STRUCTURES (!CAEKF_SIZED)

/* Model dimensions. */
/* Storage of the augmented state x = [q; v; gamma_1..gamma_nc; law parameters] (a mechanism uses
 * n = 2 bodies + contacts + the n, lambda and gap it estimates). */
/* A sized build's state: 2 bodies, the gammas, the law's and the mechanism's parameters (one definition for
 * every file that takes the sized n as a constant). */
#if CAEKF_SIZED
#define CAEKF_SIZED_N                                                                                   \
    (2 * CAEKF_SIZED_BODIES + CAEKF_SIZED_CONTACTS + CAEKF_SIZED_LAW_PARAMS + CAEKF_SIZED_MECH_PARAMS + \
     CAEKF_SIZED_BIASES)
#endif

#define CAEKF_NQ CAEKF_MAX_DOFS
/* estimated parameters: the contacts' gammas and law parameters, then the mechanism's (masses, links), then
 * the sensors' offsets */
#define CAEKF_NP (CAEKF_MAX_CONTACTS + CAEKF_MAX_LAW_PARAMS + CAEKF_MAX_MECH_PARAMS + CAEKF_MAX_BIASES)
#define CAEKF_MECH_STORE (CAEKF_MAX_MECH_PARAMS > 0 ? CAEKF_MAX_MECH_PARAMS : 1)
#define CAEKF_N (2 * CAEKF_NQ + CAEKF_NP)
/* Arrays with one element per estimated parameter: at least one (C has no empty arrays). */
#define CAEKF_NP_STORE (CAEKF_NP > 0 ? CAEKF_NP : 1)
#ifndef CAEKF_MODEL_ORACLES
#define CAEKF_MODEL_ORACLES (!CAEKF_SIZED_METHOD)
#endif
#ifndef CAEKF_PSD_WRITTEN_OUT_MAX_N
#define CAEKF_PSD_WRITTEN_OUT_MAX_N 12
#endif /* !CAEKF_PSD_WRITTEN_OUT_MAX_N */

/* C99 static assert (no _Static_assert before C11). */
#define CAEKF_STATIC_ASSERT(cond, name) typedef char caekf_static_assert_##name[(cond) ? 1 : -1]

CAEKF_STATIC_ASSERT(CAEKF_MAX_DOFS >= CAEKF_MAX_BODIES && CAEKF_N <= 255, dofs_hold_the_bodies_and_states_fit_a_byte);
CAEKF_STATIC_ASSERT(CAEKF_MAX_BODIES >= 1 && CAEKF_MAX_SPRINGS >= 0 && CAEKF_MAX_INPUTS >= 0 &&
                        CAEKF_MAX_SENSORS >= 1 && CAEKF_MAX_CONTACTS >= 0 && CAEKF_MAX_LAW_PARAMS >= 0 &&
                        CAEKF_MAX_LAW_PARAMS <= 3 * CAEKF_MAX_CONTACTS,
                    capacities_are_counts);
/* The bounds of the contacts' parameters are bits of a uint32_t (the mechanism's have none). */
CAEKF_STATIC_ASSERT(CAEKF_MAX_CONTACTS + CAEKF_MAX_LAW_PARAMS <= 32, bounded_parameters_fit_a_word);

#endif /* CAEKF_CONFIG_H */
