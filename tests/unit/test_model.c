/* The model's step, backward Euler (eq. 19) and trapezoidal: analytic Jacobians against central finite
 * differences (in and out of contact), the structured F of eq. (10) against -(dg/dx_k)^-1 dg/dx_{k-1},
 * and Newton over the whole reference scenario, including a forced failure that must be reported. */
#include <math.h>
#include <string.h>

#include "caekf_model_internal.h"
#include "test_support.h"
#include "unity.h"

#define N PAPER_N /* the paper's mechanism: loops; arrays have the build's capacity */

#if CAEKF_MODEL_ORACLES /* the finite-difference checks of the reference functions */
#if CAEKF_USE_FLOAT
#define JAC_RTOL 3e-2
#define F_RTOL 2e-3
static const double fd_step[N] = {1e-7, 1e-7, 1e-7, 1e-7, 1e-5, 1e-5, 1e-5, 1e-5, 1e4};
#else
#define JAC_RTOL 1e-6
#define F_RTOL 1e-9
static const double fd_step[N] = {1e-9, 1e-9, 1e-9, 1e-9, 1e-7, 1e-7, 1e-7, 1e-7, 1e2};
#endif
#endif

static caekf_model_t model;
static int discretisation = CAEKF_DISCRETISATION_BACKWARD_EULER; /* of the tests being run */
#if CAEKF_HAS_SUBSTEPS && CAEKF_MODEL_ORACLES
static double contact_lambda = 0; /* Hunt-Crossley damping of the substep product's test [s/m] */
#endif
static const caekf_scalar_t u_prev[1] = {(caekf_scalar_t)0.2}, u_now[1] = {(caekf_scalar_t)0.3};
/* The contact's ends: 0 the paper's (bodies 2 and 3); 1 body 1 into body 2; 2 body 2 into body 1 (the first body,
 * index 0, at either end). */
static int contact_ends = 0;

/* The settings' contact ends, and those of the first body's variants. */
static void set_contact_ends(caekf_settings_t *s)
{
    if (contact_ends != 0) {
        s->model.contact_a[0] = contact_ends == 1 ? 1 : 2;
        s->model.contact_b[0] = contact_ends == 1 ? 2 : 1;
    }
}

void setUp(void)
{
    caekf_settings_t s;
    paper_settings(&s, EXP_SWITCHED);
    s.model.discretisation = discretisation;
    set_contact_ends(&s);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&model, &s.model));
}
void tearDown(void) {}

/* A state with penetration `delta` (<= 0: no contact) and some motion. */
static void make_state(caekf_scalar_t x[CAEKF_N], double delta)
{
    paper_moving_state(x, 1.0e-3, delta, 1.1e8);
    if (contact_ends == 1) { /* q1 - q2 - gap = delta */
        x[0] = (caekf_scalar_t)((double)x[1] + 1.0e-3 + delta);
    } else if (contact_ends == 2) { /* q2 - q1 - gap = delta */
        x[1] = (caekf_scalar_t)((double)x[0] + 1.0e-3 + delta);
    }
}

#if CAEKF_MODEL_ORACLES /* the library has the reference residual, Jacobians and F */
static void check_jacobians_at(double delta)
{
    caekf_scalar_t xk[CAEKF_N], xp[CAEKF_N], Jk[CAEKF_N][CAEKF_N], Jp[CAEKF_N][CAEKF_N];
    int i, j;
    make_state(xk, delta);
    make_state(xp, delta * 0.9);
    xp[4] = (caekf_scalar_t)2.5e-3;
    caekf_model_jacobians(&model, xk, xp, Jk, Jp);
    for (j = 0; j < N; ++j) {
        caekf_scalar_t a[CAEKF_N], b[CAEKF_N], ga[CAEKF_N], gb[CAEKF_N];
        double h;
        /* d/dx_k */
        memcpy(a, xk, sizeof a);
        memcpy(b, xk, sizeof b);
        a[j] += (caekf_scalar_t)fd_step[j];
        b[j] -= (caekf_scalar_t)fd_step[j];
        h = (double)a[j] - (double)b[j]; /* the step actually taken after rounding */
        caekf_model_residual(&model, a, xp, u_prev, u_now, ga);
        caekf_model_residual(&model, b, xp, u_prev, u_now, gb);
        for (i = 0; i < N; ++i) {
            double fd = ((double)ga[i] - (double)gb[i]) / h;
            double rowmax = 0;
            int c;
            for (c = 0; c < N; ++c) {
                rowmax = fmax(rowmax, fabs((double)Jk[i][c]));
            }
            TEST_ASSERT_DOUBLE_WITHIN(JAC_RTOL * (fabs((double)Jk[i][j]) + 1e-3 * rowmax), (double)Jk[i][j], fd);
        }
        /* d/dx_{k-1} */
        memcpy(a, xp, sizeof a);
        memcpy(b, xp, sizeof b);
        a[j] += (caekf_scalar_t)fd_step[j];
        b[j] -= (caekf_scalar_t)fd_step[j];
        h = (double)a[j] - (double)b[j];
        caekf_model_residual(&model, xk, a, u_prev, u_now, ga);
        caekf_model_residual(&model, xk, b, u_prev, u_now, gb);
        for (i = 0; i < N; ++i) {
            double fd = ((double)ga[i] - (double)gb[i]) / h;
            double rowmax = 0;
            int c;
            for (c = 0; c < N; ++c) {
                rowmax = fmax(rowmax, fabs((double)Jp[i][c]));
            }
            TEST_ASSERT_DOUBLE_WITHIN(JAC_RTOL * (fabs((double)Jp[i][j]) + 1e-3 * rowmax), (double)Jp[i][j], fd);
        }
    }
}

static void test_jacobians_match_finite_differences_in_contact(void)
{
    caekf_contact_t c;
    caekf_scalar_t x[CAEKF_N];
    make_state(x, 2e-6);
    caekf_model_contact(&model, 0, x, &c);
    TEST_ASSERT_TRUE(c.delta > 0 && c.fc > 0 && c.dfc_ddelta > 0);
    check_jacobians_at(2e-6);
}

static void test_jacobians_match_finite_differences_out_of_contact(void)
{
    caekf_contact_t c;
    caekf_scalar_t x[CAEKF_N];
    make_state(x, -5e-6);
    caekf_model_contact(&model, 0, x, &c);
    TEST_ASSERT_TRUE(c.delta < 0);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, (double)c.fc);
    check_jacobians_at(-5e-6);
}

/* F at x_k with penetration delta, from x_{k-1} with penetration delta_prev. */
static void check_transition_at(double delta, double delta_prev)
{
    caekf_scalar_t xk[CAEKF_N], xp[CAEKF_N], Jk[CAEKF_N][CAEKF_N], Jp[CAEKF_N][CAEKF_N], F[CAEKF_N][CAEKF_N];
    double err;
    int i, j;
    make_state(xk, delta);
    make_state(xp, delta_prev);
    xp[5] = (caekf_scalar_t)-1.5e-3;
    caekf_model_jacobians(&model, xk, xp, Jk, Jp);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_transition(&model, xk, xp, F));
    err = test_eq10_error(Jk, Jp, F, N);
    TEST_ASSERT_TRUE(err >= 0 && err <= F_RTOL);
    /* The known zero block and the random walk row of eq. (23). */
    for (j = 0; j < N - 1; ++j) {
        TEST_ASSERT_EQUAL_DOUBLE(0.0, (double)F[N - 1][j]);
    }
    TEST_ASSERT_EQUAL_DOUBLE(1.0, (double)F[N - 1][N - 1]);
    if (delta <= 0 && (delta_prev <= 0 || discretisation == CAEKF_DISCRETISATION_BACKWARD_EULER)) {
        for (i = 0; i < N - 1; ++i) {
            TEST_ASSERT_EQUAL_DOUBLE(0.0, (double)F[i][N - 1]); /* gamma does not act without contact */
        }
    }
}

static void test_structured_transition_equals_eq10(void)
{
    check_transition_at(2e-6, 1.5e-6);
    check_transition_at(-5e-6, -4e-6);
    check_transition_at(-5e-6, 1e-6); /* leaving contact: the trapezoidal rule's start is still closed */
    check_transition_at(1e-6, -2e-6); /* entering */
}

#endif

static void test_newton_converges_over_the_reference_scenario(void)
{
    truth_rec_t r;
    caekf_scalar_t xp[CAEKF_N], xk[CAEKF_N], work[4 * CAEKF_NQ], u_last = 0;
    long n = 0, contact = 0, iters = 0;
    int max_it = 0, rc, i;
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    memset(xp, 0, sizeof xp);
    xp[8] = (caekf_scalar_t)paper_gamma_true();
    while ((rc = truth_next(&r)) == 1) {
        int it = -1;
        const caekf_scalar_t u = (caekf_scalar_t)r.u;
        int st = caekf_model_newton(&model, xp, n > 0 ? &u_last : &u, &u, CAEKF_NEWTON_MAX_ITER,
                                    (caekf_scalar_t)(CAEKF_EPS * 256), xk, &it, work);
        TEST_ASSERT_EQUAL_INT_MESSAGE(0, st, "Newton did not converge on the reference scenario");
        TEST_ASSERT_TRUE(it >= 1 && it <= CAEKF_NEWTON_MAX_ITER);
        max_it = it > max_it ? it : max_it;
        iters += it;
        contact += r.delta > 0;
        /* Next step starts from the truth (the estimator's situation: a good previous estimate). */
        for (i = 0; i < 4; ++i) {
            xp[i] = (caekf_scalar_t)r.q[i];
            xp[4 + i] = (caekf_scalar_t)r.v[i];
        }
        u_last = u;
        n++;
    }
    truth_close();
    TEST_ASSERT_EQUAL_INT(0, rc);
    TEST_ASSERT_EQUAL_INT32(paper_steps(), n);
    TEST_ASSERT_TRUE_MESSAGE(contact > 1000, "the scenario must exercise contact");
    /* Contact steps need real Newton iterations; in float the trapezoidal step usually meets 256 eps after
     * one (its start-of-step half is exact). */
    TEST_ASSERT_TRUE(max_it >= (CAEKF_USE_FLOAT && discretisation == CAEKF_DISCRETISATION_TRAPEZOIDAL ? 1 : 2));
    TEST_ASSERT_TRUE(max_it <= 6); /* far inside the bound */
    TEST_ASSERT_TRUE((double)iters / (double)n < 1.5);
}

/* F's v-rows from the contacts' laws the estimator already has (eq. 21) equal those the model evaluates
 * itself, bit for bit, closed (the Newton matrix with the contact's tangents) and open (the constant F). */
static void test_transition_at_given_contacts_is_the_same(void)
{
    static const double deltas[2] = {2e-6, -2e-6};
    int k;
    for (k = 0; k < 2; ++k) {
        caekf_scalar_t xk[CAEKF_N], xp[CAEKF_N], fa[CAEKF_NQ][CAEKF_N], fb[CAEKF_NQ][CAEKF_N];
        caekf_contact_t ct[CAEKF_MAX_CONTACTS + 1];
        int c;
        make_state(xk, deltas[k]);
        make_state(xp, deltas[k] * 0.9);
        memset(fa, 0, sizeof fa);
        memset(fb, 0, sizeof fb);
        for (c = 0; c < model.nc; ++c) {
            caekf_model_contact(&model, c, xk, &ct[c]);
        }
        TEST_ASSERT_EQUAL_INT(0, caekf_model_transition_v(&model, xk, xp, fa));
        TEST_ASSERT_EQUAL_INT(0, caekf_model_transition_v_at(&model, ct, xp, fb));
        TEST_ASSERT_EQUAL_MEMORY(fa, fb, sizeof fa);
        TEST_ASSERT_TRUE(k == 1 || ct[0].delta > 0);
    }
}

static void test_forced_newton_failure_is_reported(void)
{
    caekf_scalar_t xp[CAEKF_N], xk[CAEKF_N], work[4 * CAEKF_NQ];
    int it = 0;
    make_state(xp, 2e-6);
    /* One iteration cannot meet an absurd tolerance in contact: status 1, the iterate is kept. */
    TEST_ASSERT_EQUAL_INT(1, caekf_model_newton(&model, xp, u_prev, u_now, 1, (caekf_scalar_t)1e-30, xk, &it, work));
    TEST_ASSERT_EQUAL_INT(1, it);
    TEST_ASSERT_TRUE(isfinite((double)xk[1]));
    /* Through the estimator: the step completes and raises NEWTON_NOT_CONVERGED. */
    {
        caekf_settings_t s;
        caekf_t est;
        caekf_report_t rep;
        caekf_scalar_t y[2] = {0, 0};
        paper_settings(&s, EXP_SWITCHED);
        s.model.discretisation = discretisation;
        s.newton_max_iter = 1;
        s.newton_rtol = (caekf_scalar_t)1e-30;
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &s));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, (const caekf_scalar_t[]){(caekf_scalar_t)0.5}, y, &rep));
        TEST_ASSERT_TRUE(rep.flags & CAEKF_FLAG_NEWTON_NOT_CONVERGED);
        TEST_ASSERT_EQUAL_INT(1, rep.newton_iters);
    }
}

#if CAEKF_HAS_SUBSTEPS
/* The substeps' entry points, which are handed the contacts instead of evaluating them again, give
 * caekf_model_newton's and caekf_model_transition_v's results bit for bit: x_k, the iterations, the
 * contacts left at x_k, and F's v-rows (entering, leaving, in and out of contact). */
static void check_contacts_passed_on(double delta, double delta_prev)
{
    caekf_scalar_t xp[CAEKF_N], xk[CAEKF_N], xk_ct[CAEKF_N], work[4 * CAEKF_NQ];
    caekf_scalar_t fv[CAEKF_NQ][CAEKF_N], fv_ct[CAEKF_NQ][CAEKF_N];
    caekf_contact_t ct0[CAEKF_MAX_CONTACTS], ct[CAEKF_MAX_CONTACTS], c;
    int it = -1, it_ct = -2, pass;
    make_state(xp, delta_prev);
    xp[5] = (caekf_scalar_t)(delta > delta_prev ? 1.5e-3 : -1.5e-3);
    caekf_model_contact(&model, 0, xp, &ct0[0]);
    for (pass = 0; pass < 2; ++pass) { /* the start's contacts given, then evaluated inside */
        const int st = caekf_model_newton(&model, xp, u_prev, u_now, CAEKF_NEWTON_MAX_ITER,
                                          (caekf_scalar_t)(CAEKF_EPS * 256), xk, &it, work);
        TEST_ASSERT_EQUAL_INT(st, caekf_model_newton_ct(&model, xp, u_prev, u_now, CAEKF_NEWTON_MAX_ITER,
                                                        (caekf_scalar_t)(CAEKF_EPS * 256), xk_ct, &it_ct, work, ct,
                                                        pass == 0 ? ct0 : 0, 0));
        TEST_ASSERT_EQUAL_INT(it, it_ct);
        TEST_ASSERT_EQUAL_MEMORY(xk, xk_ct, N * sizeof xk[0]);
    }
    caekf_model_contact(&model, 0, xk, &c);
    TEST_ASSERT_EQUAL_MEMORY(&c, &ct[0], sizeof c);
    /* a state of its own for the map, so that the contact's state at x_k is the one asked for */
    make_state(xk, delta);
    caekf_model_contact(&model, 0, xk, &ct[0]);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_transition_v(&model, xk, xp, fv));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_transition_ct(&model, ct, ct0, fv_ct));
    for (it = 0; it < PAPER_NQ; ++it) { /* the mechanism's rows and columns (the capacity's tail is unused) */
        TEST_ASSERT_EQUAL_MEMORY(fv[it], fv_ct[it], N * sizeof fv[0][0]);
    }
}

#if CAEKF_MODEL_ORACLES
/* After a step in contact with 4 substeps, the estimator's F (fq, fv: its q- and v-rows, scaled) is the
 * product F_4 F_3 F_2 F_1 of the substep maps, each the reference F of eq. (10) at the substep's solution
 * (the product here in double, plain loops), with an elastic contact and a damped one (whose rate
 * tangents at a map's two ends differ). */
static void test_substep_product_is_the_product_of_the_substep_maps(void)
{
    static caekf_t est;
    caekf_settings_t s;
    caekf_report_t rep;
    caekf_scalar_t y[2], xa[CAEKF_N], xk[CAEKF_N], work[4 * CAEKF_NQ], Fj[CAEKF_N][CAEKF_N];
    const caekf_scalar_t u[1] = {(caekf_scalar_t)0.3};
    const caekf_scalar_t *sc;
    double prod[PAPER_N][PAPER_N], next[PAPER_N][PAPER_N];
    int i, j, k, step, it;
    paper_settings(&s, EXP_SWITCHED);
    s.model.discretisation = discretisation;
    s.contact_substeps = 4;
    s.model.contact_lambda[0] = (caekf_scalar_t)contact_lambda;
    set_contact_ends(&s);
    s.q0[0] = (caekf_scalar_t)1.2e-3;
    s.q0[1] = (caekf_scalar_t)(1.0e-3 + 3e-6); /* body 2 into body 3: the contact is closed at the start */
    s.v0[1] = (caekf_scalar_t)1e-3;
    if (contact_ends != 0) { /* the first body's contact, closing on the springs' pull during the step */
        s.q0[contact_ends == 1 ? 0 : 1] = (caekf_scalar_t)((double)s.q0[contact_ends == 1 ? 1 : 0] + 1.0e-3 + 2e-5);
        s.v0[0] = (caekf_scalar_t)(contact_ends == 1 ? 3e-2 : 0);
        s.v0[1] = (caekf_scalar_t)(contact_ends == 1 ? 0 : 3e-2);
    }
    y[0] = s.q0[0];
    y[1] = s.q0[3];
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &s));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, u, y, &rep));
    TEST_ASSERT_TRUE(rep.flags & CAEKF_FLAG_CONTACT_ACTIVE);
    for (i = 0; i < N; ++i) {
        xa[i] = est.x_prev[i]; /* x_{k-1}, which the step keeps */
        for (j = 0; j < N; ++j) {
            prod[i][j] = i == j ? 1 : 0;
        }
    }
    for (step = 0; step < 4; ++step) { /* the first step holds u over its interval: every substep's input */
        caekf_model_newton(&est.sub_model, xa, u, u, s.newton_max_iter, s.newton_rtol, xk, &it, work);
        TEST_ASSERT_EQUAL_INT(0, caekf_model_transition(&est.sub_model, xk, xa, Fj));
        for (i = 0; i < N; ++i) {
            for (j = 0; j < N; ++j) {
                double acc = 0;
                for (k = 0; k < N; ++k) {
                    acc += (double)Fj[i][k] * prod[k][j];
                }
                next[i][j] = acc;
            }
        }
        memcpy(prod, next, sizeof prod);
        memcpy(xa, xk, sizeof xa);
    }
    sc = est.scale;
    for (i = 0; i < PAPER_NQ; ++i) {
        double qmax = 0, vmax = 0;
        for (j = 0; j < N; ++j) {
            qmax = fmax(qmax, fabs(prod[i][j] * (double)sc[j] / (double)sc[0]));
            vmax = fmax(vmax, fabs(prod[PAPER_NQ + i][j] * (double)sc[j] / (double)sc[PAPER_NQ]));
        }
        for (j = 0; j < N; ++j) {
            TEST_ASSERT_DOUBLE_WITHIN(F_RTOL * qmax, prod[i][j] * (double)sc[j] / (double)sc[0], (double)est.fq[i][j]);
            TEST_ASSERT_DOUBLE_WITHIN(F_RTOL * vmax, prod[PAPER_NQ + i][j] * (double)sc[j] / (double)sc[PAPER_NQ],
                                      (double)est.fv[i][j]);
        }
    }
}
#endif

/* Simplified Newton in the substeps: the first update takes the LU it is given. With the LU at the initial
 * guess it is plain Newton's first update bit for bit; with the one at the step's start (what the substeps
 * give) it converges to plain Newton's x_k within the tolerance, and leaves the contacts at x_k with their
 * tangents (the next map reads them) and, through the substep's map, the LU at x_k. */
static void test_first_update_takes_the_given_lu(void)
{
    caekf_scalar_t xp[CAEKF_N], xg[CAEKF_N], xk[CAEKF_N], xk_lu[CAEKF_N], work[4 * CAEKF_NQ];
    caekf_scalar_t sq[CAEKF_NQ][CAEKF_N], sv[CAEKF_NQ][CAEKF_N], w[CAEKF_NQ][CAEKF_N];
    caekf_contact_t ct0[CAEKF_MAX_CONTACTS], ctg[CAEKF_MAX_CONTACTS], ct[CAEKF_MAX_CONTACTS], c;
    caekf_newton_lu_t at_start, at_guess, at_end, kept;
    const caekf_scalar_t rtol = (caekf_scalar_t)(CAEKF_EPS * 256);
    int it = -1, it_lu = -2, i;
#if CAEKF_HAS_SLR
    model.slr_s[0] = (caekf_scalar_t)1e-6; /* statistically linearised: the tangents cost their own work */
#endif
    make_state(xp, 1.5e-6);
    xp[5] = (caekf_scalar_t)2e-3; /* closing further: the Jacobian moves over the step */
    for (i = 0; i < N; ++i) {     /* Newton's initial guess: v_k = v_{k-1} */
        xg[i] = xp[i];
    }
    for (i = 0; i < PAPER_NQ; ++i) {
        xg[i] = CAEKF_METHOD_TRAP(&model) ? xp[i] + model.hs * (xp[PAPER_NQ + i] + xp[PAPER_NQ + i])
                                          : xp[i] + model.p.dt * xp[PAPER_NQ + i];
    }
    caekf_model_contact(&model, 0, xp, &ct0[0]);
    caekf_model_contact(&model, 0, xg, &ctg[0]);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_newton_lu(&model, ct0, &at_start));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_newton_lu(&model, ctg, &at_guess));
    TEST_ASSERT_FALSE(at_start.constant);
    /* one update: with the guess's LU, plain Newton's; with the start's, another */
    (void)caekf_model_newton_ct(&model, xp, u_prev, u_now, 1, rtol, xk, &it, work, ct, ct0, 0);
    (void)caekf_model_newton_ct(&model, xp, u_prev, u_now, 1, rtol, xk_lu, &it_lu, work, ct, ct0, &at_guess);
    TEST_ASSERT_EQUAL_MEMORY(xk, xk_lu, N * sizeof xk[0]);
    (void)caekf_model_newton_ct(&model, xp, u_prev, u_now, 1, rtol, xk_lu, &it_lu, work, ct, ct0, &at_start);
    TEST_ASSERT_FALSE(memcmp(xk, xk_lu, PAPER_N * sizeof xk[0]) == 0);
    caekf_model_contact(&model, 0, xk_lu, &c); /* the bound stops at x_1: its contacts with their tangents */
    TEST_ASSERT_EQUAL_MEMORY(&c, &ct[0], sizeof c);
    /* to convergence */
    TEST_ASSERT_EQUAL_INT(
        0, caekf_model_newton_ct(&model, xp, u_prev, u_now, CAEKF_NEWTON_MAX_ITER, rtol, xk, &it, work, ct, ct0, 0));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_newton_ct(&model, xp, u_prev, u_now, CAEKF_NEWTON_MAX_ITER, rtol, xk_lu,
                                                   &it_lu, work, ct, ct0, &at_start));
    TEST_ASSERT_TRUE(it_lu >= 1);
    for (i = 0; i < 2 * PAPER_NQ; ++i) {
        TEST_ASSERT_DOUBLE_WITHIN(1e3 * (double)CAEKF_EPS * fabs((double)xk[i]) + 1e-30, (double)xk[i],
                                  (double)xk_lu[i]);
    }
    caekf_model_contact(&model, 0, xk_lu, &c);
    TEST_ASSERT_EQUAL_MEMORY(&c, &ct[0], sizeof c);
    memset(sq, 0, sizeof sq);
    memset(sv, 0, sizeof sv);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_substep_map(&model, ct, ct0, sq, sv, &kept, w));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_newton_lu(&model, ct, &at_end));
    TEST_ASSERT_EQUAL_INT(at_end.constant, kept.constant);
    TEST_ASSERT_EQUAL_MEMORY(at_end.lu, kept.lu, PAPER_NQ * PAPER_NQ * sizeof kept.lu[0]);
    TEST_ASSERT_EQUAL_MEMORY(at_end.piv, kept.piv, PAPER_NQ * sizeof kept.piv[0]);
#if CAEKF_HAS_SLR
    model.slr_s[0] = 0;
#endif
}

static void test_substeps_pass_their_contacts_on_bit_for_bit(void)
{
    check_contacts_passed_on(2e-6, 1.5e-6);
    check_contacts_passed_on(-5e-6, -4e-6);
    check_contacts_passed_on(-5e-6, 1e-6);
    check_contacts_passed_on(1e-6, -2e-6);
}
#endif

#if CAEKF_HAS_SLR
/* E[max(0, t)^a] for t ~ N(d, s^2) by Simpson's rule over d +- 10 s (a fine grid; the kink at 0 costs
 * it some digits, far below the Gauss-Hermite rule's). */
static double expected_power(double d, double s, double a)
{
    const int m = 40000; /* even */
    const double lo = d - 10 * s, h = 20 * s / m;
    double acc = 0;
    int k;
    for (k = 0; k <= m; ++k) {
        const double t = lo + k * h, z = (t - d) / s;
        const double g = (t > 0 ? pow(t, a) : 0) * exp(-z * z / 2) / (s * sqrt(2 * 3.14159265358979323846));
        acc += g * (k == 0 || k == m ? 1 : (k % 2) ? 4 : 2);
    }
    return acc * h / 3;
}

/* Statistically linearised contact (setting contact_slr_p): with a penetration std slr_s the force is the
 * law's own, bit for bit, and its tangents in delta and gamma are the law's expected over
 * N(delta, slr_s^2): n gamma E[delta^(n-1)] and E[delta^n] (20-node Gauss-Hermite: within 10 % around
 * the kink, |delta| <= 2 s, the law's own once delta >> s); nonzero on the open side. */
static void test_slr_tangents_are_the_law_expected_over_the_penetration(void)
{
    static const double k_of_s[] = {-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 3.0, 30.0};
    const double s = 1e-6, n = 1.5;
    caekf_scalar_t x[CAEKF_N];
    caekf_contact_t own, slr;
    unsigned i;
    for (i = 0; i < sizeof k_of_s / sizeof k_of_s[0]; ++i) {
        const double d = k_of_s[i] * s, tol = fabs(k_of_s[i]) <= 2 ? 0.1 : CAEKF_USE_FLOAT ? 1e-3 : 1e-4;
        double e, e1, gamma;
        make_state(x, d);
        gamma = (double)x[8];
        model.slr_s[0] = 0;
        caekf_model_contact(&model, 0, x, &own);
        model.slr_s[0] = (caekf_scalar_t)s;
        caekf_model_contact(&model, 0, x, &slr);
        model.slr_s[0] = 0;
        TEST_ASSERT_EQUAL_MEMORY(&own.fc, &slr.fc, sizeof own.fc);
        TEST_ASSERT_EQUAL_MEMORY(&own.delta, &slr.delta, sizeof own.delta);
        e = expected_power((double)own.delta, s, n);
        e1 = expected_power((double)own.delta, s, n - 1);
        TEST_ASSERT_DOUBLE_WITHIN(tol * e, e, (double)slr.dfc_dgamma);
        TEST_ASSERT_DOUBLE_WITHIN(tol * n * gamma * e1, n * gamma * e1, (double)slr.dfc_ddelta);
        TEST_ASSERT_TRUE(slr.dfc_ddelta > 0); /* sensitivity on the open side too */
        if (k_of_s[i] >= 30) {                /* certain: the law's own tangents */
            TEST_ASSERT_DOUBLE_WITHIN(1e-3 * (double)own.dfc_ddelta, (double)own.dfc_ddelta, (double)slr.dfc_ddelta);
            TEST_ASSERT_DOUBLE_WITHIN(1e-3 * (double)own.dfc_dgamma, (double)own.dfc_dgamma, (double)slr.dfc_dgamma);
        }
    }
}
#endif

#if !CAEKF_SIZED_METHOD /* a build sized for one configuration fixes its contact's ends */
/* The damped law gamma delta^n (1 + lambda r), delta = q_a - q_b - gap, r = v_a - v_b, written here, against the
 * model's for contacts of the first body at either end. */
static void test_the_damped_law_of_a_first_body_contact(void)
{
    int ends;
    for (ends = 1; ends <= 2; ++ends) {
        caekf_settings_t s;
        caekf_model_t m;
        caekf_contact_t c;
        caekf_scalar_t x[CAEKF_N];
        double delta, rate, f;
        const int a = ends == 1 ? 0 : 1, b = ends == 1 ? 1 : 0;
        paper_settings(&s, EXP_SWITCHED);
        s.model.contact_a[0] = a + 1;
        s.model.contact_b[0] = b + 1;
        s.model.contact_lambda[0] = 100; /* 1 + lambda r: 1.5 and 0.5 */
        TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&m, &s.model));
        paper_moving_state(x, 1.0e-3, 0, 1.1e8);
        x[a] = (caekf_scalar_t)((double)x[b] + 1.0e-3 + 2e-6);
        delta = (double)x[a] - (double)x[b] - 1.0e-3;
        rate = (double)x[PAPER_NQ + a] - (double)x[PAPER_NQ + b];
        f = 1.1e8 * pow(delta, (double)s.model.contact_n[0]) * (1 + 100 * rate);
        caekf_model_contact(&m, 0, x, &c);
        TEST_ASSERT_DOUBLE_WITHIN((CAEKF_USE_FLOAT ? 1e-3 : 1e-9) * delta, delta, (double)c.delta);
        TEST_ASSERT_DOUBLE_WITHIN((CAEKF_USE_FLOAT ? 1e-3 : 1e-9) * fabs(f), f, (double)c.fc);
    }
}

/* A correction at t0 (caekf_correct) judges the contacts at the initial state itself: every body's position, the
 * first body's too (body 1 into body 2, closed from the start). */
static void test_a_correction_at_t0_sees_the_initial_contacts(void)
{
    static caekf_t est;
    caekf_settings_t s;
    caekf_report_t rep;
    const caekf_scalar_t u[1] = {0};
    caekf_scalar_t y[2];
    paper_settings(&s, EXP_SWITCHED);
    s.model.contact_a[0] = 1;
    s.model.contact_b[0] = 2;
    s.q0[1] = (caekf_scalar_t)1e-5;
    s.q0[0] = (caekf_scalar_t)(1e-5 + 1.0e-3 + 3e-6);
    y[0] = s.q0[0];
    y[1] = s.q0[3];
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &s));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_correct(&est, u, y, &rep));
    TEST_ASSERT_TRUE(rep.flags & CAEKF_FLAG_CONTACT_ACTIVE);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 3e-6, (double)rep.delta);
}
#endif

#if CAEKF_MODEL_ORACLES && !CAEKF_SIZED
/* Chains of three and five bodies (nq not 4: the LU of any size instead of the 4 x 4 kernel), springs to the
 * ground at both ends, bodies 2 and 3 in contact: the Newton step solves the residual. */
static void check_newton_on_a_chain(int bodies)
{
    caekf_settings_t s;
    caekf_model_t m;
    caekf_scalar_t xp[CAEKF_N], xk[CAEKF_N], g0[CAEKF_N], g[CAEKF_N], work[4 * CAEKF_NQ];
    double r0 = 0, r = 0;
    int i, it;
    paper_settings(&s, EXP_SWITCHED);
    s.model.discretisation = discretisation;
    s.model.bodies = bodies;
    s.model.springs = bodies + 1;
    for (i = 0; i <= bodies; ++i) { /* ground - 1 - 2 - ... - bodies - ground */
        s.model.spring_a[i] = i == 0 ? 1 : i;
        s.model.spring_b[i] = i == 0 || i == bodies ? 0 : i + 1;
        s.model.spring_k[i] = 1e4;
        s.model.spring_c[i] = 5;
    }
    for (i = 0; i < bodies; ++i) {
        s.model.m[i] = (caekf_scalar_t)(1 + 0.25 * i);
    }
    s.model.sensor_body[1] = bodies;
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&m, &s.model));
    TEST_ASSERT_EQUAL_INT(2 * bodies + 1, m.n);
    for (i = 0; i < CAEKF_N; ++i) {
        xp[i] = 0;
    }
    for (i = 0; i < bodies; ++i) {
        xp[bodies + i] = (caekf_scalar_t)(1e-3 * (i % 2 ? -1 : 1));
    }
    xp[1] = (caekf_scalar_t)(1.0e-3 + 2e-6); /* body 2 into body 3 */
    xp[2 * bodies] = (caekf_scalar_t)1e8;
    caekf_model_residual(&m, xp, xp, u_prev, u_now, g0);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_newton(&m, xp, u_prev, u_now, CAEKF_NEWTON_MAX_ITER,
                                                (caekf_scalar_t)(CAEKF_USE_FLOAT ? 1e-5 : 1e-13), xk, &it, work));
    caekf_model_residual(&m, xk, xp, u_prev, u_now, g);
    for (i = 0; i < 2 * bodies; ++i) {
        r0 = fmax(r0, fabs((double)g0[i]));
        r = fmax(r, fabs((double)g[i]));
    }
    TEST_ASSERT_TRUE(r0 > 0);
    TEST_ASSERT_TRUE(r <= (CAEKF_USE_FLOAT ? 1e-3 : 1e-9) * r0);
    if (discretisation == CAEKF_DISCRETISATION_BACKWARD_EULER) {
        /* and the equations themselves, written here from the settings: m (v - v') / dt + K q + C v - u + the
         * contact's force (-f on body a, +f on body b) = 0, q - q' = dt v */
        const double dt = (double)s.model.dt, gap = (double)s.model.contact_gap[0];
        const double delta = (double)xk[1] - (double)xk[2] - gap;
        const double f = delta > 0 ? (double)xk[2 * bodies] * pow(delta, (double)s.model.contact_n[0]) : 0;
        for (i = 0; i < bodies; ++i) {
            double res = (double)s.model.m[i] * ((double)xk[bodies + i] - (double)xp[bodies + i]) / dt;
            double mag = fabs(res);
            int k;
            for (k = 0; k < bodies + 1; ++k) { /* each spring on body i */
                const int a = s.model.spring_a[k] - 1, b = s.model.spring_b[k] - 1;
                const double ext = (double)xk[a] - (b >= 0 ? (double)xk[b] : 0);
                const double rate = (double)xk[bodies + a] - (b >= 0 ? (double)xk[bodies + b] : 0);
                const double t = (double)s.model.spring_k[k] * ext + (double)s.model.spring_c[k] * rate;
                res += i == a ? t : i == b ? -t : 0;
                mag += i == a || i == b ? fabs(t) : 0;
            }
            res -= i == s.model.input_body[0] - 1 ? (double)u_now[0] : 0;
            res += i == 1 ? f : i == 2 ? -f : 0;
            TEST_ASSERT_DOUBLE_WITHIN((CAEKF_USE_FLOAT ? 1e-3 : 1e-8) * (mag + fabs(f) + 1), 0.0, res);
            TEST_ASSERT_DOUBLE_WITHIN((CAEKF_USE_FLOAT ? 1e-6 : 1e-12) * (fabs((double)xk[i]) + 1e-3),
                                      (double)xp[i] + dt * (double)xk[bodies + i], (double)xk[i]);
        }
    }
}

static void test_newton_solves_chains_of_three_and_five_bodies(void)
{
    check_newton_on_a_chain(3);
    check_newton_on_a_chain(5);
}
#endif

int main(void)
{
    UNITY_BEGIN();
#if CAEKF_HAS_SLR
    RUN_TEST(test_slr_tangents_are_the_law_expected_over_the_penetration);
#endif
#if CAEKF_MODEL_ORACLES
    RUN_TEST(test_jacobians_match_finite_differences_in_contact);
    RUN_TEST(test_jacobians_match_finite_differences_out_of_contact);
    RUN_TEST(test_structured_transition_equals_eq10);
#endif
    RUN_TEST(test_newton_converges_over_the_reference_scenario);
    RUN_TEST(test_transition_at_given_contacts_is_the_same);
    RUN_TEST(test_forced_newton_failure_is_reported);
#if CAEKF_MODEL_ORACLES && !CAEKF_SIZED
    RUN_TEST(test_newton_solves_chains_of_three_and_five_bodies);
#endif
#if !CAEKF_SIZED_METHOD
    RUN_TEST(test_a_correction_at_t0_sees_the_initial_contacts);
    RUN_TEST(test_the_damped_law_of_a_first_body_contact);
#endif
#if CAEKF_HAS_TRAPEZOIDAL /* the build runs it */
    discretisation = CAEKF_DISCRETISATION_TRAPEZOIDAL;
#if CAEKF_MODEL_ORACLES
    RUN_TEST(test_jacobians_match_finite_differences_in_contact);
    RUN_TEST(test_jacobians_match_finite_differences_out_of_contact);
    RUN_TEST(test_structured_transition_equals_eq10);
#endif
    RUN_TEST(test_newton_converges_over_the_reference_scenario);
    RUN_TEST(test_transition_at_given_contacts_is_the_same);
    RUN_TEST(test_forced_newton_failure_is_reported);
#endif
#if CAEKF_HAS_SUBSTEPS /* the substeps' entry points, with either rule */
    discretisation = CAEKF_DISCRETISATION_BACKWARD_EULER;
    RUN_TEST(test_substeps_pass_their_contacts_on_bit_for_bit);
    RUN_TEST(test_first_update_takes_the_given_lu);
#if CAEKF_MODEL_ORACLES
    RUN_TEST(test_substep_product_is_the_product_of_the_substep_maps);
#endif
    discretisation = CAEKF_DISCRETISATION_TRAPEZOIDAL;
    RUN_TEST(test_substeps_pass_their_contacts_on_bit_for_bit);
    RUN_TEST(test_first_update_takes_the_given_lu);
#if CAEKF_MODEL_ORACLES
    RUN_TEST(test_substep_product_is_the_product_of_the_substep_maps);
    contact_lambda = 300; /* a damped contact: the map's rate tangents at both ends */
    RUN_TEST(test_substep_product_is_the_product_of_the_substep_maps);
    discretisation = CAEKF_DISCRETISATION_BACKWARD_EULER;
    RUN_TEST(test_substep_product_is_the_product_of_the_substep_maps);
    contact_lambda = 0;
#endif
#endif
#if CAEKF_MODEL_ORACLES /* a contact of the first body (index 0) at either end, both rules */
    for (contact_ends = 1; contact_ends <= 2; ++contact_ends) {
        discretisation = CAEKF_DISCRETISATION_BACKWARD_EULER;
        RUN_TEST(test_jacobians_match_finite_differences_in_contact);
        RUN_TEST(test_structured_transition_equals_eq10);
#if CAEKF_HAS_TRAPEZOIDAL
        discretisation = CAEKF_DISCRETISATION_TRAPEZOIDAL;
        RUN_TEST(test_jacobians_match_finite_differences_in_contact);
        RUN_TEST(test_structured_transition_equals_eq10);
#endif
#if CAEKF_HAS_SUBSTEPS
        contact_lambda = 300;
        RUN_TEST(test_substep_product_is_the_product_of_the_substep_maps);
        contact_lambda = 0;
#endif
    }
    contact_ends = 0;
    discretisation = CAEKF_DISCRETISATION_BACKWARD_EULER;
#endif
    return UNITY_END();
}
