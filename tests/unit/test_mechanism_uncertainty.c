/* Uncertain mechanism parameters and measured inputs (settings m{i}_sigma, spring{i}_k_sigma,
 * spring{i}_c_sigma, input{i}_sigma; docs/mechanism.md): F's columns for ln(value) and the input gain
 * dv_k/du_k against central differences of the Newton step itself (both discretisations, in and out of
 * contact), the model following the parameters' values, the estimator's state layout and accessors, and
 * the estimator learning a spring that is off. */
#include <math.h>
#include <string.h>

#include "caekf_model_internal.h"
#include "test_support.h"
#include "unity.h"

#define NQ PAPER_NQ
#define NM 12 /* every mass, stiffness and damper of the paper's chain */

static caekf_settings_t settings;
static caekf_model_t model;
static const caekf_scalar_t u_prev[1] = {(caekf_scalar_t)0.2}, u_now[1] = {(caekf_scalar_t)0.3};

void setUp(void) {}
void tearDown(void) {}

/* The paper's chain with every parameter declared uncertain (3 %), under `discretisation`. */
static void declare_all(int discretisation)
{
    int i;
    paper_settings(&settings, EXP_SWITCHED);
    settings.model.discretisation = discretisation;
    for (i = 0; i < settings.model.bodies; ++i) {
        settings.model.m_sigma[i] = (caekf_scalar_t)0.03;
    }
    for (i = 0; i < settings.model.springs; ++i) {
        settings.model.spring_k_sigma[i] = (caekf_scalar_t)0.03;
        settings.model.spring_c_sigma[i] = (caekf_scalar_t)0.03;
    }
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&model, &settings.model));
}

/* A state with penetration `delta` (<= 0: no contact) and some motion; parameters at their settings. */
static void make_state(caekf_scalar_t x[CAEKF_N], double delta) { paper_moving_state(x, 1.0e-3, delta, 1.1e8); }

/* The step from xp with the parameters at mult (NULL: the settings') and the input u: x_k. */
static void step_at(const caekf_scalar_t *xp, const caekf_scalar_t *mult, const caekf_scalar_t *u,
                    caekf_scalar_t xk[CAEKF_N])
{
    caekf_scalar_t work[4 * CAEKF_NQ], ones[NM];
    int it, j;
    for (j = 0; j < NM; ++j) {
        ones[j] = 1;
    }
    TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&model, &settings.model, mult != 0 ? mult : ones));
    TEST_ASSERT_EQUAL_INT(
        0, caekf_model_newton(&model, xp, u_prev, u, CAEKF_NEWTON_MAX_ITER, (caekf_scalar_t)1e-15, xk, &it, work));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&model, &settings.model, ones));
}

/* Central differences (double): their step in ln(value) and their tolerance, relative to a column's
 * largest entry (truncation h^2 and rounding eps / h). */
#define FD_H 1e-6
#define FD_TOL 1e-5

/* A column of nq rows (leading dimension ld) against the central difference (a - b) / span of the
 * velocities, within FD_TOL of the column's largest entry. */
static void check_column(const caekf_scalar_t *a, const caekf_scalar_t *b, double span, const caekf_scalar_t *col,
                         int ld)
{
    const double err = test_fd_column_error(a, b, NQ, span, col, ld, 1.0);
    TEST_ASSERT_TRUE(err >= 0);
    TEST_ASSERT_DOUBLE_WITHIN(FD_TOL, 0.0, err);
}

static void check_columns(int discretisation, double delta)
{
    caekf_scalar_t xp[CAEKF_N], xk[CAEKF_N], fv[CAEKF_NQ][CAEKF_N], g[CAEKF_NQ][CAEKF_MAX_INPUTS];
    caekf_contact_t ct[CAEKF_MAX_CONTACTS + 1];
    const double h = FD_H;
    int i, j, first;
    if (CAEKF_USE_FLOAT) { /* the float Newton step stops at 256 eps: its differences say nothing at this step */
        TEST_IGNORE_MESSAGE("central differences of the step: the double build checks them");
    }
    declare_all(discretisation);
    first = model.n - model.nm;
    TEST_ASSERT_EQUAL_INT(NM, model.nm);
    TEST_ASSERT_EQUAL_INT(2 * NQ + 1 + NM, model.n);
    make_state(xp, delta);
    step_at(xp, 0, u_now, xk);
    caekf_model_contact(&model, 0, xk, &ct[0]);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_mech_columns(&model, ct, xp, xk, u_prev, u_now, 0, fv));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_input_columns(&model, ct, g));
    for (j = 0; j < NM; ++j) { /* d v_k / d ln(value_j) */
        caekf_scalar_t mult[NM], a[CAEKF_N], b[CAEKF_N];
        for (i = 0; i < NM; ++i) {
            mult[i] = 1;
        }
        mult[j] = (caekf_scalar_t)exp(h);
        step_at(xp, mult, u_now, a);
        mult[j] = (caekf_scalar_t)exp(-h);
        step_at(xp, mult, u_now, b);
        check_column(a, b, 2 * h, &fv[0][first + j], CAEKF_N);
    }
    { /* d v_k / d u_k */
        const caekf_scalar_t du = (caekf_scalar_t)1e-4, up[1] = {u_now[0] + du}, um[1] = {u_now[0] - du};
        caekf_scalar_t a[CAEKF_N], b[CAEKF_N];
        step_at(xp, 0, up, a);
        step_at(xp, 0, um, b);
        check_column(a, b, 2 * (double)du, &g[0][0], CAEKF_MAX_INPUTS);
    }
}

static void test_columns_match_the_step_backward_euler_in_contact(void)
{
    check_columns(CAEKF_DISCRETISATION_BACKWARD_EULER, 2e-6);
}
static void test_columns_match_the_step_backward_euler_open(void)
{
    check_columns(CAEKF_DISCRETISATION_BACKWARD_EULER, -5e-6);
}
static void test_columns_match_the_step_trapezoidal_in_contact(void)
{
    check_columns(CAEKF_DISCRETISATION_TRAPEZOIDAL, 2e-6);
}
static void test_columns_match_the_step_trapezoidal_open(void)
{
    check_columns(CAEKF_DISCRETISATION_TRAPEZOIDAL, -5e-6);
}

/* The model's matrices follow the values: a stiffness doubled is K's links doubled, a mass its M/hs. */
static void test_the_model_follows_the_values(void)
{
    caekf_scalar_t mult[NM];
    caekf_model_t base;
    int j;
    declare_all(CAEKF_DISCRETISATION_TRAPEZOIDAL);
    base = model;
    for (j = 0; j < NM; ++j) {
        mult[j] = 1;
    }
    mult[0] = 2;  /* m1 */
    mult[NQ] = 3; /* spring 1's k: body 1 to the ground */
    TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&model, &settings.model, mult));
    TEST_ASSERT_EQUAL_DOUBLE(2 * (double)base.m_dt[0], (double)model.m_dt[0]);
    TEST_ASSERT_EQUAL_DOUBLE((double)base.m_dt[1], (double)model.m_dt[1]);
    TEST_ASSERT_EQUAL_DOUBLE((double)base.K[0][0] + 2 * (double)settings.model.spring_k[0], (double)model.K[0][0]);
    TEST_ASSERT_EQUAL_DOUBLE(3 * (double)settings.model.spring_k[0], (double)model.mech_value[NQ]);
}

/* The estimator: the states after gamma, their values and variances through the accessors, a spring 5 %
 * stiffer in the truth than in the settings learnt (states: m1, then spring 1's k) (well within its declared 3 %: 1.6 sigma), and a
 * mechanism beyond the capacity refused. */
static void test_the_estimator_learns_a_spring(void)
{
    static caekf_t est;
    caekf_scalar_t x[CAEKF_N], var[CAEKF_N];
    caekf_setting_error_t err;
    truth_rec_t r;
    long k = 0;
    paper_settings(&settings, EXP_SWITCHED);
    settings.model.spring_k_sigma[0] = (caekf_scalar_t)0.03;
    settings.model.spring_k[0] = (caekf_scalar_t)((double)settings.model.spring_k[0] / 1.05);
    settings.model.m_sigma[0] = (caekf_scalar_t)0.03;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &settings));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, x));
    TEST_ASSERT_EQUAL_DOUBLE((double)settings.model.m[0], (double)x[2 * NQ + 1]);
    TEST_ASSERT_EQUAL_DOUBLE((double)settings.model.spring_k[0], (double)x[2 * NQ + 2]);
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (k < 20000 && truth_next(&r) == 1) {
        const caekf_scalar_t y[2] = {(caekf_scalar_t)r.y1, (caekf_scalar_t)r.y4};
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, (const caekf_scalar_t[]){(caekf_scalar_t)r.u}, y, 0));
        ++k;
    }
    truth_close();
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, x));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_variances(&est, var));
    {
        const double truth = (double)settings.model.spring_k[0] * 1.05, got = (double)x[2 * NQ + 2];
        TEST_ASSERT_TRUE(fabs(got / truth - 1) < 0.005);
        TEST_ASSERT_TRUE(fabs(got - truth) < 3 * sqrt((double)var[2 * NQ + 2]));
    }
    /* capacity: a sized build estimates exactly its scenario's; the host any within bodies + links */
    settings.model.m_sigma[0] = (caekf_scalar_t)-0.1;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&settings, &err));
    TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_M_SIGMA, err.param_id);
}

/* A measured input's noise (input{i}_sigma): a prediction adds sigma_u^2 g g^T to the bodies' covariance,
 * g = dx_k/du_k of the step (the trapezoidal rule takes each sample in two steps: twice the one-end gain),
 * g here by central differences of the Newton step itself. Two instances alike but for the input's sigma,
 * one prediction each from the same state: the difference of their covariances is that term, and nothing
 * else moves. */
static void check_input_noise(int discretisation)
{
    static caekf_t with, without;
    caekf_scalar_t x[CAEKF_N], xp[CAEKF_N], xm[CAEKF_N], work[4 * CAEKF_NQ];
    const caekf_scalar_t u[1] = {(caekf_scalar_t)0.3};
    const double h = 1e-3, sigma_u = 0.05, factor = discretisation == CAEKF_DISCRETISATION_TRAPEZOIDAL ? 2 : 1;
    caekf_report_t rep;
    double g[2 * NQ], big = 0;
    int i, j, it, n;
    if (CAEKF_USE_FLOAT) {
        TEST_IGNORE_MESSAGE("central differences of the step: the double build checks them");
    }
    paper_settings(&settings, EXP_SWITCHED);
    settings.model.discretisation = discretisation;
    settings.v0[0] = (caekf_scalar_t)1e-3;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&without, &settings));
    settings.input_sigma[0] = (caekf_scalar_t)sigma_u;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&with, &settings));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&with, x));
    {
        const caekf_scalar_t up[1] = {(caekf_scalar_t)(0.3 + h)}, um[1] = {(caekf_scalar_t)(0.3 - h)};
        /* the first step holds u over its interval: u_{k-1} = u_k = 0.3, and the gain is the end's */
        TEST_ASSERT_EQUAL_INT(
            0, caekf_model_newton(&with.model, x, u, up, CAEKF_NEWTON_MAX_ITER, (caekf_scalar_t)1e-15, xp, &it, work));
        TEST_ASSERT_EQUAL_INT(
            0, caekf_model_newton(&with.model, x, u, um, CAEKF_NEWTON_MAX_ITER, (caekf_scalar_t)1e-15, xm, &it, work));
    }
    for (i = 0; i < 2 * NQ; ++i) {
        g[i] = factor * ((double)xp[i] - (double)xm[i]) / (2 * h) / (double)with.scale[i]; /* scaled */
    }
    test_fill_stack(0xFF); /* a local read before it is written: a NaN */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&with, u, &rep));
    TEST_ASSERT_EQUAL_UINT32(0, rep.flags & CAEKF_FLAG_NUMERIC_ROLLBACK);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&without, u, &rep));
    n = with.model.n;
    for (i = 0; i < 2 * NQ; ++i) {
        big = fmax(big, sigma_u * sigma_u * g[i] * g[i]);
    }
    TEST_ASSERT_TRUE(big > 0);
    for (i = 0; i < n; ++i) {
        for (j = 0; j < n; ++j) {
            const double added = (double)with.P[i * n + j] - (double)without.P[i * n + j];
            const double expected = i < 2 * NQ && j < 2 * NQ ? sigma_u * sigma_u * g[i] * g[j] : 0.0;
            TEST_ASSERT_DOUBLE_WITHIN(1e-5 * big, expected, added);
        }
        TEST_ASSERT_TRUE(with.z[i] == without.z[i]);
    }
}

static void test_input_noise_is_the_step_gain_squared_backward_euler(void)
{
    check_input_noise(CAEKF_DISCRETISATION_BACKWARD_EULER);
}

static void test_input_noise_is_the_step_gain_squared_trapezoidal(void)
{
    check_input_noise(CAEKF_DISCRETISATION_TRAPEZOIDAL);
}

/* The measured inputs' trend (input_trend_window): Holt's tracker follows a ramp exactly once its start has
 * decayed, is kept only where it is used (an uncertain parameter and a noisy input), and a refused step
 * leaves it as it was. */
static void test_the_input_trend_follows_a_ramp(void)
{
    static caekf_t est;
    const caekf_scalar_t y[2] = {0, 0}, bad[1] = {(caekf_scalar_t)NAN};
    const double u0 = 0.3, slope = 1e-3;
    int k;
    paper_settings(&settings, EXP_SWITCHED);
    settings.model.m_sigma[0] = (caekf_scalar_t)0.03;
    settings.input_trend_window = 10; /* lambda 0.9: the start decays as 0.9^k */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &settings));
    for (k = 0; k < 400; ++k) {
        const caekf_scalar_t u[1] = {(caekf_scalar_t)(u0 + slope * k)};
        (void)caekf_step(&est, u, y, 0);
    }
    TEST_ASSERT_EQUAL_UINT32(0, est.input_trend_known); /* an exact input: nothing to track */
    settings.input_sigma[0] = (caekf_scalar_t)0.01;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &settings));
    for (k = 0; k < 400; ++k) {
        const caekf_scalar_t u[1] = {(caekf_scalar_t)(u0 + slope * k)};
        (void)caekf_step(&est, u, y, 0);
    }
    TEST_ASSERT_EQUAL_UINT32(1, est.input_trend_known);
    TEST_ASSERT_DOUBLE_WITHIN(CAEKF_USE_FLOAT ? 1e-5 : 1e-12, u0 + slope * 399, (double)est.input_trend[0][0]);
    TEST_ASSERT_DOUBLE_WITHIN(CAEKF_USE_FLOAT ? 1e-6 : 1e-12, slope, (double)est.input_trend[0][1]);
    { /* the gains: a unit step after a start at 0 gives the level 1 - lambda^2 = 0.19 and the slope
       * (1 - lambda) / (1 + lambda) times that, 0.01 */
        static caekf_t fresh;
        const caekf_scalar_t zero[1] = {0}, one[1] = {1};
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&fresh, &settings));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&fresh, zero, y, 0));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&fresh, one, y, 0));
        TEST_ASSERT_DOUBLE_WITHIN(CAEKF_USE_FLOAT ? 1e-6 : 1e-15, 0.19, (double)fresh.input_trend[0][0]);
        TEST_ASSERT_DOUBLE_WITHIN(CAEKF_USE_FLOAT ? 1e-7 : 1e-15, 0.01, (double)fresh.input_trend[0][1]);
    }
    {
        const caekf_scalar_t level = est.input_trend[0][0], rate = est.input_trend[0][1];
        TEST_ASSERT_NOT_EQUAL(CAEKF_OK, caekf_step(&est, bad, y, 0));
        TEST_ASSERT_TRUE(est.input_trend[0][0] == level && est.input_trend[0][1] == rate);
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_columns_match_the_step_backward_euler_in_contact);
    RUN_TEST(test_columns_match_the_step_backward_euler_open);
    RUN_TEST(test_columns_match_the_step_trapezoidal_in_contact);
    RUN_TEST(test_columns_match_the_step_trapezoidal_open);
    RUN_TEST(test_the_model_follows_the_values);
    RUN_TEST(test_the_estimator_learns_a_spring);
    RUN_TEST(test_input_noise_is_the_step_gain_squared_backward_euler);
    RUN_TEST(test_input_noise_is_the_step_gain_squared_trapezoidal);
    RUN_TEST(test_the_input_trend_follows_a_ramp);
    return UNITY_END();
}
