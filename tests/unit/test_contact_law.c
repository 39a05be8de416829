/* The whole contact law as states (docs/contact-law.md): the exponent n, the Hunt-Crossley damping lambda
 * and the gap estimated with gamma (also as ln gamma). The residual's Jacobians against central finite
 * differences including the law-parameter columns, eq. (10)'s structured F against the full inverse, the
 * switch-off of every parameter of an open contact, bounds enforced over the active set, the refusals of
 * validation, and the accessors. Builds without room for law parameters (an MCU build sized for the
 * paper's mechanism) ignore the suite. */
#include <math.h>
#include <string.h>

#include "caekf_model_internal.h"
#include "test_support.h"
#include "unity.h"

#define NL (PAPER_N + 3) /* the paper's states, then n, lambda and gap of its contact */
#define IN PAPER_N
#define IL (PAPER_N + 1)
#define IGAP (PAPER_N + 2)

#if CAEKF_USE_FLOAT
#define JAC_RTOL 3e-2
#define F_RTOL 3e-3
#define SECOND_ORDER_RTOL 0.3
#else
#define JAC_RTOL 1e-6
#define F_RTOL 1e-8
#define SECOND_ORDER_RTOL 1e-4
#endif

#if CAEKF_MAX_LAW_PARAMS >= 3

static caekf_model_t model;
static const caekf_scalar_t u_prev[1] = {(caekf_scalar_t)0.2}, u_now[1] = {(caekf_scalar_t)0.3};

/* The paper's settings with every law parameter of contact 1 estimated (initial values near the truth). */
static void law_settings(caekf_settings_t *s, int discretisation, int gamma_log)
{
    paper_settings(s, -1);
    s->model.discretisation = discretisation;
    s->model.gamma_log = gamma_log;
    s->model.contact_estimate_n[0] = s->model.contact_estimate_lambda[0] = s->model.contact_estimate_gap[0] = 1;
    s->n0[0] = (caekf_scalar_t)1.45;
    s->sigma_n0[0] = (caekf_scalar_t)0.05;
    s->lambda0[0] = (caekf_scalar_t)150;
    s->sigma_lambda0[0] = (caekf_scalar_t)100;
    s->gap0[0] = (caekf_scalar_t)1.0002e-3;
    s->sigma_gap0[0] = (caekf_scalar_t)2e-7;
    s->n_max[0] = (caekf_scalar_t)3;
}

/* A state with penetration `delta` (at the state's own gap) and some motion; law states set. */
static void make_state(caekf_scalar_t x[CAEKF_N], double delta, int gamma_log)
{
    const double gap = 1.0001e-3;
    paper_moving_state(x, gap, delta, gamma_log ? log(1.1e8) : 1.1e8);
    x[IN] = (caekf_scalar_t)1.4;
    x[IL] = (caekf_scalar_t)200;
    x[IGAP] = (caekf_scalar_t)gap;
}

static double fd_step(int j, int gamma_log)
{
    static const double base[NL] = {1e-9, 1e-9, 1e-9, 1e-9, 1e-7, 1e-7, 1e-7, 1e-7, 1e2, 1e-6, 1e-3, 1e-10};
    double h = base[j];
    if (j == PAPER_IG && gamma_log) {
        h = 1e-6;
    }
    return CAEKF_USE_FLOAT ? h * (j == PAPER_IG && !gamma_log ? 100 : 300) : h;
}

static void init_model(int discretisation, int gamma_log)
{
    caekf_settings_t s;
    law_settings(&s, discretisation, gamma_log);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&model, &s.model));
    TEST_ASSERT_EQUAL_INT(NL, model.n);
    TEST_ASSERT_EQUAL_INT(IN, model.law_state[0][CAEKF_LAW_N]);
    TEST_ASSERT_EQUAL_INT(IL, model.law_state[0][CAEKF_LAW_LAMBDA]);
    TEST_ASSERT_EQUAL_INT(IGAP, model.law_state[0][CAEKF_LAW_GAP]);
}

/* d g / d x_k and d g / d x_{k-1} of the residual against central differences, every column. */
static void check_jacobians(int discretisation, int gamma_log)
{
    caekf_scalar_t xk[CAEKF_N], xp[CAEKF_N], Jk[CAEKF_N][CAEKF_N], Jp[CAEKF_N][CAEKF_N];
    int i, j, side;
    init_model(discretisation, gamma_log);
    make_state(xk, 2e-6, gamma_log);
    make_state(xp, 1.5e-6, gamma_log);
    xp[4] = (caekf_scalar_t)2.5e-3;
    caekf_model_jacobians(&model, xk, xp, Jk, Jp);
    for (side = 0; side < 2; ++side) {
        caekf_scalar_t(*J)[CAEKF_N] = side == 0 ? Jk : Jp;
        for (j = 0; j < NL; ++j) {
            caekf_scalar_t a[CAEKF_N], b[CAEKF_N], ga[CAEKF_N], gb[CAEKF_N];
            const caekf_scalar_t *base = side == 0 ? xk : xp;
            double h;
            memcpy(a, base, sizeof a);
            memcpy(b, base, sizeof b);
            a[j] += (caekf_scalar_t)fd_step(j, gamma_log);
            b[j] -= (caekf_scalar_t)fd_step(j, gamma_log);
            h = (double)a[j] - (double)b[j];
            caekf_model_residual(&model, side == 0 ? a : xk, side == 0 ? xp : a, u_prev, u_now, ga);
            caekf_model_residual(&model, side == 0 ? b : xk, side == 0 ? xp : b, u_prev, u_now, gb);
            for (i = 0; i < NL; ++i) {
                const double fd = ((double)ga[i] - (double)gb[i]) / h;
                double rowmax = 0;
                int c;
                for (c = 0; c < NL; ++c) {
                    rowmax = fmax(rowmax, fabs((double)J[i][c]));
                }
                TEST_ASSERT_DOUBLE_WITHIN(JAC_RTOL * (fabs((double)J[i][j]) + 1e-3 * rowmax), (double)J[i][j], fd);
            }
        }
    }
    /* The law columns are really exercised: the force depends on each parameter in contact. */
    TEST_ASSERT_TRUE(Jk[PAPER_NQ + 1][IN] != 0 && Jk[PAPER_NQ + 1][IL] != 0 && Jk[PAPER_NQ + 1][IGAP] != 0);
}

static void test_jacobians_with_law_states_backward_euler(void)
{
    check_jacobians(CAEKF_DISCRETISATION_BACKWARD_EULER, 0);
}
static void test_jacobians_with_law_states_trapezoidal(void) { check_jacobians(CAEKF_DISCRETISATION_TRAPEZOIDAL, 0); }
static void test_jacobians_with_log_gamma(void) { check_jacobians(CAEKF_DISCRETISATION_TRAPEZOIDAL, 1); }

/* The structured F of eq. (10) equals -(dg/dx_k)^-1 dg/dx_{k-1} in the law columns too. */
static void check_transition(int discretisation, int gamma_log, double delta, double delta_prev)
{
    caekf_scalar_t xk[CAEKF_N], xp[CAEKF_N], Jk[CAEKF_N][CAEKF_N], Jp[CAEKF_N][CAEKF_N], F[CAEKF_N][CAEKF_N];
    double err;
    init_model(discretisation, gamma_log);
    make_state(xk, delta, gamma_log);
    make_state(xp, delta_prev, gamma_log);
    caekf_model_jacobians(&model, xk, xp, Jk, Jp);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_transition(&model, xk, xp, F));
    err = test_eq10_error(Jk, Jp, F, NL);
    TEST_ASSERT_TRUE(err >= 0 && err <= F_RTOL);
    if (delta > 0) { /* the law states move the bodies in contact */
        TEST_ASSERT_TRUE(F[PAPER_NQ + 1][IN] != 0 && F[PAPER_NQ + 1][IL] != 0 && F[PAPER_NQ + 1][IGAP] != 0);
    }
}

static void test_transition_with_law_states(void)
{
    check_transition(CAEKF_DISCRETISATION_BACKWARD_EULER, 0, 2e-6, 1.5e-6);
    check_transition(CAEKF_DISCRETISATION_TRAPEZOIDAL, 0, 2e-6, 1.5e-6);
    check_transition(CAEKF_DISCRETISATION_TRAPEZOIDAL, 1, 2e-6, 1.5e-6);
    check_transition(CAEKF_DISCRETISATION_TRAPEZOIDAL, 0, -2e-6, 1e-6); /* leaving: the start still acts */
}

typedef struct {
    long steps, frozen_steps, applied;
    int moved_while_open; /* a law state changed on a step its contact was open before any contact */
    int above_max;        /* n above n_max after a step */
    int seen_contact;     /* the contact has closed once */
    caekf_scalar_t prev[CAEKF_N];
    double n_max;
    double gap_max;        /* the gap's maximum (0: none) */
    int above_gap_max;     /* the gap above it after a step */
    double n_top, gap_top; /* the largest n and gap after a step */
} run_ctx_t;

static void watch(const caekf_t *est, const caekf_report_t *rep, caekf_status_t st, const truth_rec_t *truth,
                  void *vctx)
{
    run_ctx_t *ctx = (run_ctx_t *)vctx;
    caekf_scalar_t x[CAEKF_N];
    (void)truth;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, st);
    (void)caekf_get_state(est, x);
    ctx->seen_contact |= (rep->flags & CAEKF_FLAG_CONTACT_ACTIVE) != 0;
    if (!ctx->seen_contact) {
        ctx->frozen_steps += (rep->flags & CAEKF_FLAG_GAMMA_FROZEN) != 0;
        if (ctx->steps > 0 && (x[IN] != ctx->prev[IN] || x[IL] != ctx->prev[IL] || x[IGAP] != ctx->prev[IGAP])) {
            ctx->moved_while_open = 1;
        }
    }
    ctx->applied += (rep->flags & CAEKF_FLAG_CONSTRAINT_APPLIED) != 0;
    ctx->above_max |= (double)x[IN] > ctx->n_max;
    ctx->above_gap_max |= ctx->gap_max > 0 && (double)x[IGAP] > ctx->gap_max;
    ctx->n_top = ctx->steps == 0 || (double)x[IN] > ctx->n_top ? (double)x[IN] : ctx->n_top;
    ctx->gap_top = ctx->steps == 0 || (double)x[IGAP] > ctx->gap_top ? (double)x[IGAP] : ctx->gap_top;
    memcpy(ctx->prev, x, sizeof x);
    ctx->steps++;
}

/* Over the reference run: every law parameter is frozen (bit for bit) while the contact has never closed,
 * and an upper bound on n below the truth is enforced on every step as a perfect measurement. */
static void test_law_states_freeze_and_respect_their_bounds(void)
{
    caekf_settings_t s;
    caekf_t est;
    run_ctx_t ctx;
    caekf_scalar_t g, n, lambda, gap;
    law_settings(&s, CAEKF_DISCRETISATION_TRAPEZOIDAL, 1);
    s.n_max[0] = (caekf_scalar_t)1.47; /* below the truth, 1.5: the correction keeps pushing against it */
    memset(&ctx, 0, sizeof ctx);
    ctx.n_max = (double)s.n_max[0];
    TEST_ASSERT_EQUAL_INT(paper_steps(), run_paper(&est, &s, watch, &ctx));
    TEST_ASSERT_TRUE(ctx.frozen_steps > 10000); /* the first contact comes near 12.8 s */
    TEST_ASSERT_FALSE(ctx.moved_while_open);
    TEST_ASSERT_TRUE(ctx.applied > 0);
    TEST_ASSERT_FALSE(ctx.above_max);
    /* held on the bound itself, not short of it: within two roundings of n_max */
    TEST_ASSERT_TRUE(ctx.n_top >= ctx.n_max * (1 - 2.5 * (double)CAEKF_EPS));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_contact_law(&est, 0, &g, &n, &lambda, &gap));
    TEST_ASSERT_TRUE(g > 0 && (double)n <= ctx.n_max && lambda >= 0 && gap > 0);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_get_contact_law(&est, 1, &g, 0, 0, 0));
}

/* A maximum below 1 (a gap in metres) is a bound too: the gap started and held below the truth, on its maximum
 * (within two roundings) and never above it. */
static void test_a_gap_maximum_below_the_truth_holds(void)
{
    caekf_settings_t s;
    caekf_t est;
    run_ctx_t ctx;
    law_settings(&s, CAEKF_DISCRETISATION_TRAPEZOIDAL, 0);
    s.gap0[0] = (caekf_scalar_t)0.9997e-3;
    s.gap_max[0] = (caekf_scalar_t)0.9999e-3; /* the truth is 1e-3 */
    memset(&ctx, 0, sizeof ctx);
    ctx.n_max = 1e300;
    ctx.gap_max = (double)s.gap_max[0];
    TEST_ASSERT_EQUAL_INT(paper_steps(), run_paper(&est, &s, watch, &ctx));
    TEST_ASSERT_TRUE(ctx.applied > 0);
    TEST_ASSERT_FALSE(ctx.above_gap_max);
    TEST_ASSERT_TRUE(ctx.gap_top >= ctx.gap_max * (1 - 2.5 * (double)CAEKF_EPS));
}

/* The law's second-order term (the Gaussian second-order filter's process noise, docs/contact-law.md): a
 * prediction in contact adds to the velocities of the contact's bodies a and b the variance
 * 1/2 tr(H P H P) (hs / m_a)(hs / m_b), H the Hessian of the force in the law's states (ln gamma, n, lambda,
 * gap), P their predicted covariance. With the states' and the parameters' blocks uncorrelated and the
 * parameters' block scaled by t, everything else a prediction does is linear in t: the second difference
 * over t = 0, 1, 2 of the velocities' covariance is tr((H P)^2) (hs / m_a)(hs / m_b) alone. H here by central
 * differences of the force (caekf_model_contact). */
static double sq_m(caekf_scalar_t v) { return (double)v * (double)v; }

static double force_at(const caekf_model_t *m, const caekf_scalar_t *x0, const int *idx, const double *dx)
{
    caekf_scalar_t x[CAEKF_N];
    caekf_contact_t ct;
    int i;
    memcpy(x, x0, sizeof x);
    for (i = 0; i < 4; ++i) {
        x[idx[i]] = (caekf_scalar_t)((double)x0[idx[i]] + dx[i]);
    }
    caekf_model_contact(m, 0, x, &ct);
    return (double)ct.fc;
}

static void check_second_order(int gamma_log)
{
    static caekf_t est, start;
    caekf_settings_t s;
    truth_rec_t r;
    caekf_report_t rep;
    caekf_scalar_t x[CAEKF_N], u[1] = {0};
    const int idx[4] = {PAPER_IG, IN, IL, IGAP};
    const double h[4] = {gamma_log ? 1e-3 : 1e5, 1e-4, 1.0, 1e-9};
    double dP[3] = {0, 0, 0}, H[4][4], Pt[4][4], c = 0;
    int t, i, j, k, n, nq, a, b;
    law_settings(&s, CAEKF_DISCRETISATION_BACKWARD_EULER, gamma_log);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &s));
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (truth_next(&r) == 1 && r.t < 13.0) {
        const caekf_scalar_t y[2] = {(caekf_scalar_t)r.y1, (caekf_scalar_t)r.y4};
        u[0] = (caekf_scalar_t)r.u;
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, u, y, &rep));
    }
    truth_close();
    TEST_ASSERT_TRUE(rep.flags & CAEKF_FLAG_CONTACT_ACTIVE);
    memcpy(&start, &est, sizeof est);
    n = est.model.n;
    nq = est.model.nq;
    a = CAEKF_CONTACT_I(&est.model, 0);
    b = CAEKF_CONTACT_J(&est.model, 0);
    for (t = 0; t <= 2; ++t) {
        memcpy(&est, &start, sizeof est);
        for (i = 0; i < n; ++i) {
            for (j = 0; j < n; ++j) {
                const int pi = i >= 2 * nq, pj = j >= 2 * nq;
                est.P[i * n + j] = pi != pj ? 0 : pi ? est.P[i * n + j] * (caekf_scalar_t)t : est.P[i * n + j];
            }
        }
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&est, u, &rep));
        TEST_ASSERT_TRUE(rep.flags & CAEKF_FLAG_CONTACT_ACTIVE);
        dP[0] += (t == 1 ? -2 : 1) * (double)est.P[(nq + a) * n + nq + a];
        dP[1] += (t == 1 ? -2 : 1) * (double)est.P[(nq + a) * n + nq + b];
        dP[2] += (t == 1 ? -2 : 1) * (double)est.P[(nq + b) * n + nq + b];
    }
    /* the predicted state in the law's units (ln gamma), and the parameters' covariance there at t = 1 */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, x));
    if (gamma_log) {
        x[PAPER_IG] = (caekf_scalar_t)log((double)x[PAPER_IG]);
    }
    for (i = 0; i < 4; ++i) {
        for (j = 0; j < 4; ++j) {
            double pp[4] = {0, 0, 0, 0}, pm[4] = {0, 0, 0, 0}, mp[4] = {0, 0, 0, 0}, mm[4] = {0, 0, 0, 0};
            pp[i] += h[i];
            pp[j] += h[j];
            pm[i] += h[i];
            pm[j] -= h[j];
            mp[i] -= h[i];
            mp[j] += h[j];
            mm[i] -= h[i];
            mm[j] -= h[j];
            H[i][j] = (force_at(&est.model, x, idx, pp) - force_at(&est.model, x, idx, pm) -
                       force_at(&est.model, x, idx, mp) + force_at(&est.model, x, idx, mm)) /
                      (4 * h[i] * h[j]);
            Pt[i][j] = (double)start.P[idx[i] * n + idx[j]] * (double)start.scale[idx[i]] * (double)start.scale[idx[j]];
        }
    }
    for (i = 0; i < 4; ++i) { /* tr((H P)^2) */
        for (j = 0; j < 4; ++j) {
            double hp_ij = 0, hp_ji = 0;
            for (k = 0; k < 4; ++k) {
                hp_ij += H[i][k] * Pt[k][j];
                hp_ji += H[j][k] * Pt[k][i];
            }
            c += hp_ij * hp_ji;
        }
    }
    c /= (double)start.scale[nq] * (double)start.scale[nq]; /* in the velocities' scaled units */
    TEST_ASSERT_TRUE(c > 0);
    TEST_ASSERT_DOUBLE_WITHIN(SECOND_ORDER_RTOL * c / sq_m(est.model.m_dt[a]), c / sq_m(est.model.m_dt[a]), dP[0]);
    TEST_ASSERT_DOUBLE_WITHIN(SECOND_ORDER_RTOL * c / sq_m(est.model.m_dt[a]),
                              -c / ((double)est.model.m_dt[a] * (double)est.model.m_dt[b]), dP[1]);
    TEST_ASSERT_DOUBLE_WITHIN(SECOND_ORDER_RTOL * c / sq_m(est.model.m_dt[b]), c / sq_m(est.model.m_dt[b]), dP[2]);
}

static void test_second_order_term_is_half_the_trace_of_h_p_squared(void)
{
    check_second_order(1); /* ln gamma: the law is nonlinear in gamma too */
    check_second_order(0);
}

/* caekf_settings_validate names the law setting at fault. */
static void expect_refusal(const caekf_settings_t *s, unsigned param_id, unsigned reason)
{
    caekf_setting_error_t e;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(s, &e));
    TEST_ASSERT_EQUAL_UINT(param_id, e.param_id);
    TEST_ASSERT_EQUAL_UINT(reason, e.reason);
}

static void test_validation_of_law_settings(void)
{
    caekf_settings_t s;
    law_settings(&s, CAEKF_DISCRETISATION_TRAPEZOIDAL, 0);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&s, 0));
    s.sigma_lambda0[0] = 0;
    expect_refusal(&s, CAEKF_PARAM_SIGMA_LAMBDA0, CAEKF_SETTING_NEEDED);
    law_settings(&s, CAEKF_DISCRETISATION_TRAPEZOIDAL, 0);
    s.n0[0] = (caekf_scalar_t)3.5; /* above n_max = 3 */
    expect_refusal(&s, CAEKF_PARAM_N0, CAEKF_SETTING_OUTSIDE_BOUNDS);
    law_settings(&s, CAEKF_DISCRETISATION_TRAPEZOIDAL, 0);
    s.gap_min[0] = (caekf_scalar_t)2e-3;
    s.gap_max[0] = (caekf_scalar_t)1e-3; /* below its minimum */
    expect_refusal(&s, CAEKF_PARAM_GAP_MAX, CAEKF_SETTING_OUTSIDE_BOUNDS);
    law_settings(&s, CAEKF_DISCRETISATION_TRAPEZOIDAL, 1);
    s.gamma0[0] = 0;
    expect_refusal(&s, CAEKF_PARAM_GAMMA0, CAEKF_SETTING_NOT_POSITIVE);
    law_settings(&s, CAEKF_DISCRETISATION_TRAPEZOIDAL, 0);
    s.n_min[0] = s.n0[0]; /* the initial value on its minimum: within */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&s, 0));
    law_settings(&s, CAEKF_DISCRETISATION_TRAPEZOIDAL, 0);
#if CAEKF_USE_FLOAT
    s.sigma_n0[0] = 1e-44f; /* n0 / sigma_n0 overflows */
#else
    s.sigma_n0[0] = 1e-320;
#endif
    expect_refusal(&s, CAEKF_PARAM_SIGMA_N0, CAEKF_SETTING_NOT_SCALABLE);
    law_settings(&s, CAEKF_DISCRETISATION_TRAPEZOIDAL, 0);
    s.n_max[0] = 0; /* no maximum: any minimum goes with it */
    s.n_min[0] = (caekf_scalar_t)1.2;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&s, 0));
    law_settings(&s, CAEKF_DISCRETISATION_TRAPEZOIDAL, 0);
    s.model.contact_estimate_gap[0] = 2; /* a bool */
    expect_refusal(&s, CAEKF_PARAM_ESTIMATE_GAP, CAEKF_SETTING_OUT_OF_RANGE);
}

/* ln gamma: the accessors report gamma and its variance mapped by d gamma = gamma d ln gamma. */
static void test_log_gamma_accessors(void)
{
    caekf_settings_t s;
    caekf_t est;
    caekf_scalar_t x[CAEKF_N], var[CAEKF_N], g;
    static caekf_scalar_t P[CAEKF_N][CAEKF_N];
    law_settings(&s, CAEKF_DISCRETISATION_TRAPEZOIDAL, 1);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &s));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, x));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_gamma(&est, &g));
    TEST_ASSERT_FLOAT_WITHIN(1e-5f * (float)s.gamma0[0], (float)s.gamma0[0], (float)g);
    TEST_ASSERT_EQUAL_FLOAT((float)g, (float)x[PAPER_IG]);
    TEST_ASSERT_EQUAL_FLOAT((float)s.n0[0], (float)x[IN]);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_variances(&est, var));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(&est, P));
    /* P0 of ln gamma is (sigma_gamma0 / gamma0)^2: back in gamma, sigma_gamma0^2 */
    TEST_ASSERT_FLOAT_WITHIN(1e-4f * (float)(s.sigma_gamma0[0] * s.sigma_gamma0[0]),
                             (float)(s.sigma_gamma0[0] * s.sigma_gamma0[0]), (float)var[PAPER_IG]);
    TEST_ASSERT_EQUAL_FLOAT((float)var[PAPER_IG], (float)P[PAPER_IG][PAPER_IG]);
    TEST_ASSERT_FLOAT_WITHIN(1e-6f * (float)(s.sigma_gap0[0] * s.sigma_gap0[0]),
                             (float)(s.sigma_gap0[0] * s.sigma_gap0[0]), (float)var[IGAP]);
}

#endif

void setUp(void) {}
void tearDown(void) {}

int main(void)
{
    UNITY_BEGIN();
#if CAEKF_MAX_LAW_PARAMS >= 3
    RUN_TEST(test_jacobians_with_law_states_backward_euler);
    RUN_TEST(test_jacobians_with_law_states_trapezoidal);
    RUN_TEST(test_jacobians_with_log_gamma);
    RUN_TEST(test_transition_with_law_states);
    RUN_TEST(test_law_states_freeze_and_respect_their_bounds);
    RUN_TEST(test_a_gap_maximum_below_the_truth_holds);
    RUN_TEST(test_second_order_term_is_half_the_trace_of_h_p_squared);
    RUN_TEST(test_validation_of_law_settings);
    RUN_TEST(test_log_gamma_accessors);
#endif
    return UNITY_END();
}
