/* A linear structure given as its matrices (caekf_init_structure, docs/structure.md): the paper's chain written
 * as M, K, C, B_u, w and sensor rows estimates as the chain does; a dense structure's Jacobians, F and sensor rows
 * match finite differences and eq. (10); structures the core cannot take are refused. */
#include <math.h>
#include <string.h>

#include "caekf_model_internal.h"
#include "test_support.h"
#include "unity.h"

#define DENSE_DOFS 6

void setUp(void) {}
void tearDown(void) {}

/* The chain of the settings s as matrices: its model's K and C, its masses, its contact's e_a - e_b, its
 * inputs' bodies and its sensors' bodies (arrays row-major, sized for the capacity). */
typedef struct {
    caekf_scalar_t mass[CAEKF_NQ], K[CAEKF_NQ * CAEKF_NQ], C[CAEKF_NQ * CAEKF_NQ];
    caekf_scalar_t bu[CAEKF_NQ * CAEKF_MAX_INPUTS], w[CAEKF_MAX_CONTACTS * CAEKF_NQ], h[CAEKF_MAX_SENSORS * CAEKF_NQ];
    caekf_structure_t st;
} matrices_t;

static void chain_as_matrices(const caekf_settings_t *s, const caekf_model_t *line, matrices_t *mx)
{
    const caekf_model_params_t *p = &s->model;
    const int nq = p->bodies;
    int i, j;
    memset(mx, 0, sizeof *mx);
    for (i = 0; i < nq; ++i) {
        mx->mass[i] = p->m[i];
        for (j = 0; j < nq; ++j) {
            mx->K[i * nq + j] = line->K[i][j];
            mx->C[i * nq + j] = line->C[i][j];
        }
    }
    for (i = 0; i < p->inputs; ++i) {
        mx->bu[(p->input_body[i] - 1) * p->inputs + i] = 1;
    }
    for (i = 0; i < p->contacts; ++i) {
        if (p->contact_a[i] > 0) {
            mx->w[i * nq + p->contact_a[i] - 1] = 1;
        }
        if (p->contact_b[i] > 0) {
            mx->w[i * nq + p->contact_b[i] - 1] = -1;
        }
    }
    for (i = 0; i < p->sensors; ++i) {
        mx->h[i * nq + p->sensor_body[i] - 1] = 1;
    }
    mx->st.dofs = nq;
    mx->st.mass = mx->mass;
    mx->st.stiffness = mx->K;
    mx->st.damping = mx->C;
    mx->st.inputs = mx->bu;
    mx->st.contacts = mx->w;
    mx->st.sensors = mx->h;
}

/* The paper's run, the chain by its settings and as matrices side by side: gamma and the state agree to
 * rounding (the matrices' path sums rows of H and w where the chain indexes bodies), through every contact. */
static void check_chain_as_matrices(int discretisation, int substeps, int acceleration_sensor)
{
    static caekf_t line, structure;
    static matrices_t mx;
    caekf_settings_t s;
    caekf_report_t rl, rs;
    truth_rec_t r;
    long k = 0, contact_steps = 0;
    double worst_gamma = 0, worst_q = 0;
    paper_settings(&s, -1);
    s.model.discretisation = discretisation;
    s.contact_substeps = substeps;
    if (acceleration_sensor) { /* the fourth body's accelerometer: its value from the model in both */
        s.model.sensor_kind[1] = CAEKF_SENSOR_ACCELERATION;
        s.sensor_sigma[1] = (caekf_scalar_t)1e-3;
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&line, &s));
    chain_as_matrices(&s, &line.model, &mx);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init_structure(&structure, &s, &mx.st));
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (k < 20000 && truth_next(&r) == 1) {
        const caekf_scalar_t u[1] = {(caekf_scalar_t)r.u};
        caekf_scalar_t y[2] = {(caekf_scalar_t)r.y1, (caekf_scalar_t)r.y4};
        caekf_scalar_t gl, gs, xl[CAEKF_N], xs[CAEKF_N];
        int i;
        if (acceleration_sensor) { /* read as the chain's model reads it at the truth's state */
            caekf_scalar_t row[CAEKF_N], x[CAEKF_N];
            for (i = 0; i < CAEKF_N; ++i) {
                x[i] = 0;
            }
            for (i = 0; i < 4; ++i) {
                x[i] = (caekf_scalar_t)r.q[i];
                x[4 + i] = (caekf_scalar_t)r.v[i];
            }
            x[8] = (caekf_scalar_t)paper_gamma_true();
            caekf_model_sensor(&line.model, &s.model, 1, x, u, u, &y[1], row);
        }
        if (k == 0) {
            TEST_ASSERT_EQUAL_INT(caekf_correct(&line, u, y, &rl), caekf_correct(&structure, u, y, &rs));
        } else {
            TEST_ASSERT_EQUAL_INT(caekf_step(&line, u, y, &rl), caekf_step(&structure, u, y, &rs));
        }
        TEST_ASSERT_EQUAL_UINT32(rl.flags, rs.flags);
        contact_steps += (rl.flags & CAEKF_FLAG_CONTACT_ACTIVE) != 0;
        (void)caekf_get_gamma(&line, &gl);
        (void)caekf_get_gamma(&structure, &gs);
        (void)caekf_get_state(&line, xl);
        (void)caekf_get_state(&structure, xs);
        worst_gamma = fmax(worst_gamma, fabs((double)gs / (double)gl - 1));
        for (i = 0; i < 4; ++i) {
            worst_q = fmax(worst_q, fabs((double)xs[i] - (double)xl[i]) / 1e-3);
        }
        ++k;
    }
    truth_close();
    TEST_ASSERT_TRUE(contact_steps > 100);
    TEST_ASSERT_TRUE_MESSAGE(worst_gamma < (CAEKF_USE_FLOAT ? 1e-2 : 1e-8), "gamma differs beyond rounding");
    TEST_ASSERT_TRUE_MESSAGE(worst_q < (CAEKF_USE_FLOAT ? 1e-3 : 1e-9), "positions differ beyond rounding");
}

/* What the settings s's sensors read on the truth's mechanism (the paper's chain, its one contact) at record r:
 * positions and velocities from the record, an acceleration from the chain's model at the record's state. */
static void truth_readings(const caekf_settings_t *s, const truth_rec_t *r, const caekf_scalar_t *u, caekf_scalar_t *y)
{
    static caekf_model_t m;
    static caekf_settings_t t;
    caekf_scalar_t x[CAEKF_N], row[CAEKF_N];
    int i;
    paper_settings(&t, -1);
    t.model.inputs = s->model.inputs;
    t.model.sensors = s->model.sensors;
    for (i = 0; i < CAEKF_MAX_INPUTS; ++i) {
        t.model.input_kind[i] = s->model.input_kind[i];
        t.model.input_body[i] = s->model.input_body[i];
    }
    for (i = 0; i < CAEKF_MAX_SENSORS; ++i) {
        t.model.sensor_kind[i] = s->model.sensor_kind[i];
        t.model.sensor_body[i] = s->model.sensor_body[i];
    }
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&m, &t.model));
    for (i = 0; i < CAEKF_N; ++i) {
        x[i] = 0;
    }
    for (i = 0; i < 4; ++i) {
        x[i] = (caekf_scalar_t)r->q[i];
        x[4 + i] = (caekf_scalar_t)r->v[i];
    }
    x[8] = (caekf_scalar_t)paper_gamma_true();
    for (i = 0; i < s->model.sensors; ++i) {
        const int b = s->model.sensor_body[i] - 1;
        switch (s->model.sensor_kind[i]) {
        case CAEKF_SENSOR_VELOCITY: y[i] = (caekf_scalar_t)r->v[b]; break;
        case CAEKF_SENSOR_ACCELERATION: caekf_model_sensor(&m, &t.model, i, x, u, u, &y[i], row); break;
        default: y[i] = (caekf_scalar_t)r->q[b]; break;
        }
    }
}

static caekf_t cmp_line, cmp_structure; /* compare_chain_and_matrices' estimators, read after it */

/* The settings s run by the chain (cmp_line) and by the chain written as matrices (cmp_structure), side by
 * side over `steps` of the truth (a second input at rest, each sensor reading the truth's mechanism:
 * truth_readings): every step's status and flags the same, every contact's law and the positions within the
 * tolerances (relative; positions over 1 mm). Returns the union of the flags and counts the steps each contact
 * was closed in the chain's estimate (its penetration at the estimate, from the line's model). */
static uint32_t compare_chain_and_matrices(const caekf_settings_t *s, long steps, double law_tol, double q_tol,
                                           long closed[CAEKF_MAX_CONTACTS])
{
    static matrices_t mx;
    caekf_t *const line = &cmp_line, *const structure = &cmp_structure;
    caekf_report_t rl, rs;
    truth_rec_t r;
    long k = 0;
    double worst_law = 0, worst_q = 0;
    uint32_t all = 0;
    int c;
    for (c = 0; c < CAEKF_MAX_CONTACTS; ++c) {
        closed[c] = 0;
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(line, s));
    chain_as_matrices(s, &line->model, &mx);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init_structure(structure, s, &mx.st));
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (k < steps && truth_next(&r) == 1) {
        const caekf_scalar_t u[2] = {(caekf_scalar_t)r.u, 0};
        caekf_scalar_t y[CAEKF_MAX_SENSORS], xl[CAEKF_N], xs[CAEKF_N];
        caekf_status_t stl, sts;
        int i;
        truth_readings(s, &r, u, y);
        stl = caekf_step(line, u, y, &rl);
        sts = caekf_step(structure, u, y, &rs);
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, stl);
        TEST_ASSERT_EQUAL_INT(stl, sts);
        TEST_ASSERT_EQUAL_UINT32(rl.flags, rs.flags);
        all |= rl.flags;
        (void)caekf_get_state(line, xl);
        (void)caekf_get_state(structure, xs);
        for (c = 0; c < s->model.contacts; ++c) {
            caekf_scalar_t law_l[4], law_s[4];
            caekf_contact_t ct;
            int j;
            (void)caekf_get_contact_law(line, c, &law_l[0], &law_l[1], &law_l[2], &law_l[3]);
            (void)caekf_get_contact_law(structure, c, &law_s[0], &law_s[1], &law_s[2], &law_s[3]);
            for (j = 0; j < 4; ++j) {
                worst_law =
                    fmax(worst_law, fabs((double)law_s[j] - (double)law_l[j]) / fmax(fabs((double)law_l[j]), 1e-3));
            }
            caekf_model_contact(&line->model, c, xl, &ct);
            closed[c] += ct.delta > 0;
        }
        for (i = 0; i < 4; ++i) {
            worst_q = fmax(worst_q, fabs((double)xs[i] - (double)xl[i]) / 1e-3);
        }
        ++k;
    }
    truth_close();
    TEST_ASSERT_EQUAL_INT(steps, k);
    TEST_ASSERT_TRUE_MESSAGE(worst_law < law_tol, "a contact's law differs beyond rounding");
    TEST_ASSERT_TRUE_MESSAGE(worst_q < q_tol, "positions differ beyond rounding");
    return all;
}

/* A second contact against the ground on body 1's far side (its first end the ground: delta = -q1 - gap, the
 * force +f on body 1), damped hard enough that the law lets go (1 + lambda d delta/dt <= 0) while still
 * penetrating; ln gamma with its second-order noise, the first contact's law statistically linearised (the
 * Hertz exponent, and 2: a power the law takes by pow), a second measured input (both inputs' noise as Q), an
 * accelerometer on body 1, a pure damper between bodies 1 and 3 (a C entry with no K entry) and a heavier
 * body 3: the chain and its matrices estimate alike, both contacts closing. */
static void test_a_ground_stop_two_inputs_and_an_accelerometer_as_matrices(void)
{
    caekf_settings_t s;
    long closed[CAEKF_MAX_CONTACTS];
    uint32_t flags;
    int power;
    for (power = 0; power < 2; ++power) {
        paper_settings(&s, -1);
        if (power) { /* about the Hertz law's force at the truth's penetrations */
            s.model.contact_n[0] = 2;
            s.gamma0[0] = (caekf_scalar_t)6e10;
            s.sigma_gamma0[0] = (caekf_scalar_t)2e10;
        }
        s.model.contacts = 2;
        s.model.contact_a[1] = 0;
        s.model.contact_b[1] = 1;
        s.model.contact_gap[1] = (caekf_scalar_t)1.2e-3;
        s.model.contact_n[1] = (caekf_scalar_t)1.5;
        s.model.contact_lambda[1] = (caekf_scalar_t)3e4; /* s/m: lets go above 0.033 mm/s apart */
        s.gamma0[1] = (caekf_scalar_t)1e7;
        s.sigma_gamma0[1] = (caekf_scalar_t)1e7;
        s.sigma_q_gamma[1] = (caekf_scalar_t)1e5;
        s.gamma_min[1] = (caekf_scalar_t)1e5;
        s.model.gamma_log = 1;
        s.law_second_order = 1;
        s.contact_slr_p = (caekf_scalar_t)0.01;
        s.model.inputs = 2;
        s.model.input_kind[1] = CAEKF_INPUT_FORCE;
        s.model.input_body[1] = 4;
        s.input_sigma[0] = (caekf_scalar_t)1e-3;
        s.input_sigma[1] = (caekf_scalar_t)1e-3;
        s.model.sensor_kind[1] = CAEKF_SENSOR_ACCELERATION;
        s.model.sensor_body[1] = 1;
        s.sensor_sigma[1] = (caekf_scalar_t)1e-2;
        s.model.m[2] = (caekf_scalar_t)1.25; /* unequal masses along the contact's w */
        s.model.springs = 5;
        s.model.spring_a[4] = 1;
        s.model.spring_b[4] = 3;
        s.model.spring_k[4] = 0;
        s.model.spring_c[4] = 2;
        flags =
            compare_chain_and_matrices(&s, 14000, CAEKF_USE_FLOAT ? 1e-2 : 1e-8, CAEKF_USE_FLOAT ? 1e-3 : 1e-9, closed);
        TEST_ASSERT_TRUE(closed[0] > 20 && closed[1] > 100);
        TEST_ASSERT_TRUE((flags & CAEKF_FLAG_CONTACT_ACTIVE) != 0);
    }
}

/* The contact's law parameters estimated within tight bounds (each put back on them: the constraint's bound of
 * a law parameter), an accelerometer on the contact's body 2 (its row over the law's states): the exponent,
 * damping and gap together, or the damping alone with the elastic laws statistically linearised (a damped
 * law keeps its own tangents). The chain and its matrices estimate alike, and every law parameter ends within
 * its bounds. */
static void check_law_parameters_as_matrices(int all)
{
    caekf_settings_t s;
    uint32_t flags;
    caekf_scalar_t g, nn, lam, gap;
    long closed[CAEKF_MAX_CONTACTS];
    paper_settings(&s, EXP_SWITCHED_HIGHQ_CONSTRAINED);
    s.model.contact_estimate_n[0] = all;
    s.n0[0] = s.model.contact_n[0];
    s.sigma_n0[0] = (caekf_scalar_t)0.1;
    s.sigma_q_n[0] = (caekf_scalar_t)0.01;
    s.n_min[0] = s.model.contact_n[0] * (caekf_scalar_t)0.999;
    s.n_max[0] = s.model.contact_n[0] * (caekf_scalar_t)1.001;
    s.model.contact_estimate_lambda[0] = 1;
    s.lambda0[0] = 0;
    s.sigma_lambda0[0] = (caekf_scalar_t)0.5;
    s.sigma_q_lambda[0] = (caekf_scalar_t)0.05;
    s.lambda_min[0] = 0;
    s.lambda_max[0] = (caekf_scalar_t)(all ? 0.01 : 1e-6);
    s.model.contact_estimate_gap[0] = all;
    s.gap0[0] = s.model.contact_gap[0];
    s.sigma_gap0[0] = s.model.contact_gap[0] * (caekf_scalar_t)0.1;
    s.sigma_q_gap[0] = s.model.contact_gap[0] * (caekf_scalar_t)0.01;
    s.gap_min[0] = s.model.contact_gap[0] * (caekf_scalar_t)0.999;
    s.gap_max[0] = s.model.contact_gap[0] * (caekf_scalar_t)1.001;
    s.law_second_order = 1;
    s.contact_slr_p = (caekf_scalar_t)(all ? 0 : 0.01);
    s.model.sensor_kind[1] = CAEKF_SENSOR_ACCELERATION;
    s.model.sensor_body[1] = 2;
    s.sensor_sigma[1] = (caekf_scalar_t)1e-2;
    flags = compare_chain_and_matrices(&s, 14000, CAEKF_USE_FLOAT ? 1e-2 : 1e-8, CAEKF_USE_FLOAT ? 1e-3 : 1e-9, closed);
    TEST_ASSERT_TRUE(closed[0] > 20);
    TEST_ASSERT_TRUE((flags & CAEKF_FLAG_CONSTRAINT_APPLIED) != 0);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_contact_law(&cmp_structure, 0, &g, &nn, &lam, &gap));
    TEST_ASSERT_TRUE(!all || (nn >= s.n_min[0] && nn <= s.n_max[0]));
    TEST_ASSERT_TRUE(lam >= s.lambda_min[0] && lam <= s.lambda_max[0]);
    TEST_ASSERT_TRUE(!all || (gap >= s.gap_min[0] && gap <= s.gap_max[0]));
    TEST_ASSERT_TRUE(g >= s.gamma_min[0]);
}

static void test_estimated_law_parameters_on_a_structure_as_matrices(void) { check_law_parameters_as_matrices(1); }

static void test_an_estimated_damping_alone_on_a_structure_as_matrices(void) { check_law_parameters_as_matrices(0); }

static void test_the_chain_as_matrices_estimates_as_the_chain(void)
{
    check_chain_as_matrices(CAEKF_DISCRETISATION_TRAPEZOIDAL, 5, 0);
}

static void test_the_chain_as_matrices_by_backward_euler_one_step(void)
{
    check_chain_as_matrices(CAEKF_DISCRETISATION_BACKWARD_EULER, 1, 0);
}

static void test_the_chain_as_matrices_with_an_accelerometer(void)
{
    check_chain_as_matrices(CAEKF_DISCRETISATION_TRAPEZOIDAL, 5, 1);
}

/* A dense structure: every mode coupled, a contact and an input along dense vectors, three sensors (position,
 * velocity, acceleration rows). */
static void dense_structure(caekf_settings_t *s, matrices_t *mx)
{
    const int n = DENSE_DOFS;
    int i, j;
    paper_settings(s, -1);
    memset(mx, 0, sizeof *mx);
    s->model.sensors = 3;
    s->model.sensor_kind[0] = CAEKF_SENSOR_POSITION;
    s->model.sensor_kind[1] = CAEKF_SENSOR_VELOCITY;
    s->model.sensor_kind[2] = CAEKF_SENSOR_ACCELERATION;
    s->model.sensor_body[2] = 1;
    s->sensor_sigma[2] = (caekf_scalar_t)1e-3;
    s->sigma_rv = (caekf_scalar_t)1e-6;
    s->model.contact_gap[0] = (caekf_scalar_t)1e-3;
    for (i = 0; i < n; ++i) {
        mx->mass[i] = (caekf_scalar_t)(1.0 + 0.1 * i);
        for (j = 0; j < n; ++j) { /* diagonally dominant: positive definite */
            const double off = 100.0 / (1 + i + j);
            mx->K[i * n + j] = (caekf_scalar_t)(i == j ? 4e4 * (1 + i) : off);
            mx->C[i * n + j] = (caekf_scalar_t)(i == j ? 2.0 + i : 0.01 * off);
        }
        mx->bu[i] = (caekf_scalar_t)(1.0 - 0.3 * i);
        mx->w[i] = (caekf_scalar_t)(0.5 + 0.25 * i * (i % 2 ? -1 : 1));
        mx->h[i] = (caekf_scalar_t)(0.2 * (i + 1));
        mx->h[n + i] = (caekf_scalar_t)(i == 3 ? 1 : 0.1);
        mx->h[2 * n + i] = (caekf_scalar_t)(i % 3 == 0 ? 1 : -0.5);
    }
    mx->st.dofs = n;
    mx->st.mass = mx->mass;
    mx->st.stiffness = mx->K;
    mx->st.damping = mx->C;
    mx->st.inputs = mx->bu;
    mx->st.contacts = mx->w;
    mx->st.sensors = mx->h;
}

/* A state of the dense structure with the contact's penetration delta (w^T q = gap + delta). */
static void dense_state(const matrices_t *mx, caekf_scalar_t x[CAEKF_N], double delta, double gamma)
{
    const int n = DENSE_DOFS;
    double wq = 0, ww = 0;
    int i;
    for (i = 0; i < CAEKF_N; ++i) {
        x[i] = 0;
    }
    for (i = 0; i < n; ++i) {
        x[i] = (caekf_scalar_t)(1e-4 * sin(1.0 + i));
        x[n + i] = (caekf_scalar_t)(1e-3 * cos(2.0 + i));
        wq += (double)mx->w[i] * (double)x[i];
        ww += (double)mx->w[i] * (double)mx->w[i];
    }
    for (i = 0; i < n; ++i) { /* along w: w^T q moves by the whole shortfall */
        x[i] = (caekf_scalar_t)((double)x[i] + (1e-3 + delta - wq) * (double)mx->w[i] / ww);
    }
    x[2 * n] = (caekf_scalar_t)gamma;
}

#if CAEKF_MODEL_ORACLES && !CAEKF_USE_FLOAT
static void check_dense_at(int discretisation, double delta, double delta_prev)
{
    static caekf_model_t m;
    static matrices_t mx;
    static caekf_scalar_t xk[CAEKF_N], xp[CAEKF_N], Jk[CAEKF_N][CAEKF_N], Jp[CAEKF_N][CAEKF_N], F[CAEKF_N][CAEKF_N];
    const caekf_scalar_t u0[1] = {(caekf_scalar_t)0.2}, u1[1] = {(caekf_scalar_t)0.3};
    caekf_settings_t s;
    double err;
    int i, j;
    const int n = 2 * DENSE_DOFS + 1;
    dense_structure(&s, &mx);
    s.model.discretisation = discretisation;
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init_structure(&m, &s.model, &mx.st));
    TEST_ASSERT_EQUAL_INT(n, m.n);
    dense_state(&mx, xk, delta, 1.1e8);
    dense_state(&mx, xp, delta_prev, 1.1e8);
    caekf_model_jacobians(&m, xk, xp, Jk, Jp);
    for (j = 0; j < n; ++j) { /* the residual's Jacobian against central differences */
        caekf_scalar_t a[CAEKF_N], b[CAEKF_N], ga[CAEKF_N], gb[CAEKF_N];
        const double step = j < DENSE_DOFS ? 1e-10 : j < 2 * DENSE_DOFS ? 1e-8 : 1e2;
        memcpy(a, xk, sizeof a);
        memcpy(b, xk, sizeof b);
        a[j] += (caekf_scalar_t)step;
        b[j] -= (caekf_scalar_t)step;
        caekf_model_residual(&m, a, xp, u0, u1, ga);
        caekf_model_residual(&m, b, xp, u0, u1, gb);
        for (i = 0; i < n; ++i) {
            const double fd = ((double)ga[i] - (double)gb[i]) / ((double)a[j] - (double)b[j]);
            double rowmax = 0;
            int c;
            for (c = 0; c < n; ++c) {
                rowmax = fmax(rowmax, fabs((double)Jk[i][c]));
            }
            TEST_ASSERT_DOUBLE_WITHIN(1e-5 * (fabs((double)Jk[i][j]) + 1e-3 * rowmax), (double)Jk[i][j], fd);
        }
    }
    TEST_ASSERT_EQUAL_INT(0, caekf_model_transition(&m, xk, xp, F));
    err = test_eq10_error(Jk, Jp, F, n);
    TEST_ASSERT_TRUE(err >= 0 && err <= 1e-9);
    for (i = 0; i < 3; ++i) { /* each sensor's row against central differences of its value */
        caekf_scalar_t row[CAEKF_N], ra[CAEKF_N], value, va, vb;
        caekf_model_sensor(&m, &s.model, i, xk, u1, u0, &value, row);
        for (j = 0; j < n; ++j) {
            caekf_scalar_t a[CAEKF_N], b[CAEKF_N];
            const double step = j < DENSE_DOFS ? 1e-10 : j < 2 * DENSE_DOFS ? 1e-8 : 1e2;
            memcpy(a, xk, sizeof a);
            memcpy(b, xk, sizeof b);
            a[j] += (caekf_scalar_t)step;
            b[j] -= (caekf_scalar_t)step;
            caekf_model_sensor(&m, &s.model, i, a, u1, u0, &va, ra);
            caekf_model_sensor(&m, &s.model, i, b, u1, u0, &vb, ra);
            TEST_ASSERT_DOUBLE_WITHIN(1e-5 * fabs((double)row[j]) + 1e-9, (double)row[j],
                                      ((double)va - (double)vb) / ((double)a[j] - (double)b[j]));
        }
    }
}

static void test_a_dense_structure_is_eq10_of_its_residual(void)
{
    check_dense_at(CAEKF_DISCRETISATION_BACKWARD_EULER, 2e-6, 1.5e-6);
    check_dense_at(CAEKF_DISCRETISATION_TRAPEZOIDAL, 2e-6, 1.5e-6);
    check_dense_at(CAEKF_DISCRETISATION_TRAPEZOIDAL, 1e-6, -2e-6); /* entering */
    check_dense_at(CAEKF_DISCRETISATION_TRAPEZOIDAL, -5e-6, -4e-6);
}
#endif

/* The dense structure's acceleration sensor reads the model's acceleration: M^-1 (B_u u - K q - C v - w f). */
static void test_a_structure_accelerometer_reads_the_momentum_balance(void)
{
    static caekf_model_t m;
    static matrices_t mx;
    caekf_settings_t s;
    caekf_scalar_t x[CAEKF_N], row[CAEKF_N], value;
    const caekf_scalar_t u[1] = {(caekf_scalar_t)0.7};
    caekf_contact_t ct;
    double expected = 0;
    int i, j;
    dense_structure(&s, &mx);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init_structure(&m, &s.model, &mx.st));
    dense_state(&mx, x, 3e-6, 2e8);
    caekf_model_contact(&m, 0, x, &ct);
    TEST_ASSERT_TRUE(ct.fc > 0);
    for (i = 0; i < DENSE_DOFS; ++i) {
        double force = (double)mx.bu[i] * 0.7 - (double)mx.w[i] * (double)ct.fc;
        for (j = 0; j < DENSE_DOFS; ++j) {
            force -= (double)mx.K[i * DENSE_DOFS + j] * (double)x[j] +
                     (double)mx.C[i * DENSE_DOFS + j] * (double)x[DENSE_DOFS + j];
        }
        expected += (double)mx.h[2 * DENSE_DOFS + i] * force / (double)mx.mass[i];
    }
    caekf_model_sensor(&m, &s.model, 2, x, u, u, &value, row);
    TEST_ASSERT_DOUBLE_WITHIN((CAEKF_USE_FLOAT ? 1e-4 : 1e-9) * fabs(expected) + 1e-12, expected, (double)value);
}

/* An estimator on the dense structure runs through contact (substeps, the trapezoidal rule) and its gamma moves
 * towards a stiffer truth simulated by the structure's own model. */
static void test_an_estimator_on_a_dense_structure_runs_through_contact(void)
{
    static caekf_t est;
    static caekf_model_t truth;
    static matrices_t mx;
    caekf_settings_t s;
    caekf_report_t rep;
    caekf_scalar_t x[CAEKF_N], xn[CAEKF_N], work[4 * CAEKF_NQ], gamma, u_prev[1] = {0};
    long k, contact = 0;
    int i, it;
    dense_structure(&s, &mx);
    s.model.contact_gap[0] = (caekf_scalar_t)2e-5;
    s.gamma0[0] = (caekf_scalar_t)5e7;
    s.sigma_gamma0[0] = (caekf_scalar_t)5e7;
    s.sigma_r = (caekf_scalar_t)(CAEKF_USE_FLOAT ? 1e-7 : 1e-9); /* float: innovations resolvable in 24 bits */
    s.sigma_rv = (caekf_scalar_t)(CAEKF_USE_FLOAT ? 1e-4 : 1e-6);
    s.sensor_sigma[2] = (caekf_scalar_t)(CAEKF_USE_FLOAT ? 1e-2 : 1e-4);
    s.contact_substeps = 1; /* the truth's step */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init_structure(&est, &s, &mx.st));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init_structure(&truth, &s.model, &mx.st));
    for (i = 0; i < CAEKF_N; ++i) {
        x[i] = 0;
    }
    x[2 * DENSE_DOFS] = (caekf_scalar_t)1e8;
    for (k = 0; k < 4000; ++k) {
        const caekf_scalar_t u[1] = {(caekf_scalar_t)(40.0 * sin(2 * 3.14159265358979 * 9.0 * (double)k * 1e-3))};
        caekf_scalar_t y[3], row[CAEKF_N];
        caekf_model_newton(&truth, x, k > 0 ? u_prev : u, u, 20, (caekf_scalar_t)1e-12, xn, &it, work);
        u_prev[0] = u[0];
        memcpy(x, xn, sizeof x);
        for (i = 0; i < 3; ++i) {
            caekf_model_sensor(&truth, &s.model, i, x, u, u, &y[i], row);
        }
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, u, y, &rep));
        contact += (rep.flags & CAEKF_FLAG_CONTACT_ACTIVE) != 0;
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_gamma(&est, &gamma));
    TEST_ASSERT_TRUE(contact > 50);
    TEST_ASSERT_TRUE_MESSAGE(fabs((double)gamma / 1e8 - 1) < 0.05, "gamma did not reach the truth's 1e8");
}

/* Each rule of caekf_model_structure_check refuses, and leaves an instance initialised before untouched. */
static void test_a_structure_the_core_cannot_take_is_refused(void)
{
    static caekf_t est;
    static matrices_t mx;
    caekf_settings_t s, bad;
    caekf_scalar_t before[CAEKF_N], after[CAEKF_N];
    dense_structure(&s, &mx);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init_structure(&est, &s, &mx.st));
    (void)caekf_get_state(&est, before);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_init_structure(&est, &s, 0));
    mx.K[1] = (caekf_scalar_t)((double)mx.K[1] * 1.5); /* K_01 != K_10 */
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_init_structure(&est, &s, &mx.st));
    dense_structure(&s, &mx);
    mx.mass[3] = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_init_structure(&est, &s, &mx.st));
    dense_structure(&s, &mx);
    mx.w[2] = (caekf_scalar_t)NAN;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_init_structure(&est, &s, &mx.st));
    dense_structure(&s, &mx);
    mx.st.dofs = CAEKF_NQ + 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_init_structure(&est, &s, &mx.st));
    dense_structure(&s, &mx);
    bad = s;
    bad.model.sensor_kind[0] = CAEKF_SENSOR_LINK_FORCE; /* a line's link */
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_init_structure(&est, &bad, &mx.st));
    bad = s;
    bad.model.m_sigma[0] = (caekf_scalar_t)0.03; /* a line's mass */
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_init_structure(&est, &bad, &mx.st));
    (void)caekf_get_state(&est, after);
    TEST_ASSERT_EQUAL_MEMORY(before, after, sizeof before);
}

/* Guards each rule of caekf_model_structure_check one at a time on the dense structure (taken as it is): a
 * missing argument or array, no degree of freedom, a non-finite entry of each array, C not symmetric, a
 * negative mass, a sensor or input kind of a line, a declared link parameter; caekf_model_init_structure
 * refuses what the check refuses. */
static void test_each_rule_of_the_structure_check(void)
{
    static matrices_t mx;
    static caekf_model_t m;
    caekf_settings_t s, b;
    caekf_structure_t st;
    const caekf_scalar_t nan = (caekf_scalar_t)NAN;
    caekf_scalar_t *const arrays[6] = {mx.mass, mx.K, mx.C, mx.bu, mx.w, mx.h};
    int k;
    dense_structure(&s, &mx);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_structure_check(&s.model, &mx.st));
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_structure_check(0, &mx.st));
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_structure_check(&s.model, 0));
    st = mx.st;
    st.dofs = 0;
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_structure_check(&s.model, &st));
    for (k = 0; k < 6; ++k) { /* each array missing (damping may be: no damping) */
        st = mx.st;
        switch (k) {
        case 0: st.mass = 0; break;
        case 1: st.stiffness = 0; break;
        case 2: st.damping = 0; break;
        case 3: st.inputs = 0; break;
        case 4: st.contacts = 0; break;
        default: st.sensors = 0; break;
        }
        TEST_ASSERT_EQUAL_INT_MESSAGE(k == 2 ? 0 : -1, caekf_model_structure_check(&s.model, &st), "an array missing");
    }
    for (k = 0; k < 6; ++k) { /* a NaN in each array, its last entry (the check must read them all) */
        static const int last[6] = {
            DENSE_DOFS - 1, DENSE_DOFS * DENSE_DOFS - 1, DENSE_DOFS * DENSE_DOFS - 1, DENSE_DOFS - 1,
            DENSE_DOFS - 1, 3 * DENSE_DOFS - 1};
        const caekf_scalar_t keep = arrays[k][last[k]];
        arrays[k][last[k]] = k == 1 ? (caekf_scalar_t)INFINITY : nan;
        TEST_ASSERT_EQUAL_INT_MESSAGE(-1, caekf_model_structure_check(&s.model, &mx.st), "a non-finite entry");
        TEST_ASSERT_EQUAL_INT_MESSAGE(-1, caekf_model_init_structure(&m, &s.model, &mx.st), "a non-finite entry");
        arrays[k][last[k]] = keep;
    }
    mx.C[DENSE_DOFS * DENSE_DOFS - 2] = (caekf_scalar_t)((double)mx.C[DENSE_DOFS * DENSE_DOFS - 2] * 1.5); /* C_54 */
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_structure_check(&s.model, &mx.st));
    dense_structure(&s, &mx);
    mx.mass[DENSE_DOFS - 1] = -1;
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_structure_check(&s.model, &mx.st));
    dense_structure(&s, &mx);
    b = s;
    b.model.sensor_kind[2] = CAEKF_SENSOR_RELATIVE; /* a line's: q_b - q_ref */
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_structure_check(&b.model, &mx.st));
    b = s;
    b.model.input_kind[0] = CAEKF_INPUT_BASE_DISPLACEMENT;
    b.model.input_link[0] = 1;
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_structure_check(&b.model, &mx.st));
    b = s;
    b.model.spring_k_sigma[b.model.springs - 1] = (caekf_scalar_t)0.1;
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_structure_check(&b.model, &mx.st));
    b = s;
    b.model.spring_c_sigma[b.model.springs - 1] = (caekf_scalar_t)0.1;
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_structure_check(&b.model, &mx.st));
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_init_structure(&m, &b.model, &mx.st));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init_structure(&m, &s.model, &mx.st));
}

/* Guards a structure with neither inputs nor contacts (their arrays NULL; steps take no input vector) and one
 * without damping (NULL): it estimates bit for bit as with C all zeros; and, without contacts, every row of F
 * is dense: P after a prediction is F P0 F^T + Q with F from the model (eq. 10). */
static void test_a_structure_without_damping_inputs_or_contacts(void)
{
    static caekf_t a, b;
    static matrices_t mx;
    static caekf_scalar_t P[CAEKF_N][CAEKF_N];
    caekf_settings_t s;
    caekf_structure_t st;
    caekf_report_t ra, rb;
    caekf_scalar_t xa[CAEKF_N], xb[CAEKF_N];
    const int n = 2 * DENSE_DOFS;
    int i, j, k, nn, ny, nu;
    dense_structure(&s, &mx);
    s.model.inputs = 0;
    s.model.contacts = 0;
    for (i = 0; i < DENSE_DOFS * DENSE_DOFS; ++i) {
        mx.C[i] = 0;
    }
    st = mx.st;
    st.inputs = 0;
    st.contacts = 0;
    st.damping = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init_structure(&a, &s, &st));
    mx.st.inputs = 0;
    mx.st.contacts = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init_structure(&b, &s, &mx.st)); /* C given, all zeros */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_sizes(&a, &nn, &ny, &nu));
    TEST_ASSERT_TRUE(nn == n && ny == 3 && nu == 0);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&a, 0, &ra));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(&a, P));
#if CAEKF_MODEL_ORACLES
    {
        static caekf_scalar_t F[CAEKF_N][CAEKF_N];
        caekf_scalar_t x0[CAEKF_N];
        double p0[2 * DENSE_DOFS], worst = 0;
        for (i = 0; i < CAEKF_N; ++i) {
            x0[i] = 0;
        }
        TEST_ASSERT_EQUAL_INT(0, caekf_model_transition(&a.model, x0, x0, F));
        for (i = 0; i < n; ++i) {
            p0[i] = i < DENSE_DOFS ? (double)s.sigma_q0 * (double)s.sigma_q0 : (double)s.sigma_v0 * (double)s.sigma_v0;
        }
        for (i = 0; i < n; ++i) {
            for (j = 0; j < n; ++j) {
                double ref = 0;
                for (k = 0; k < n; ++k) {
                    ref += (double)F[i][k] * p0[k] * (double)F[j][k];
                }
                if (i == j) {
                    const double q = i < DENSE_DOFS ? (double)s.sigma_qx_q : (double)s.sigma_qx_v;
                    ref += q * q;
                }
                worst = fmax(worst, fabs((double)P[i][j] - ref) / sqrt(p0[i] * p0[j]));
            }
        }
        TEST_ASSERT_TRUE_MESSAGE(worst < (CAEKF_USE_FLOAT ? 1e-4 : 1e-10), "P- is not F P0 F^T + Q");
    }
#endif
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&b, 0, &rb));
    for (k = 0; k < 200; ++k) {
        const caekf_scalar_t y[3] = {(caekf_scalar_t)(1e-6 * sin(0.05 * k)), (caekf_scalar_t)(1e-5 * cos(0.05 * k)),
                                     (caekf_scalar_t)(1e-3 * sin(0.1 * k))};
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&a, 0, y, &ra));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&b, 0, y, &rb));
        TEST_ASSERT_EQUAL_UINT32(ra.flags, rb.flags);
    }
    (void)caekf_get_state(&a, xa);
    (void)caekf_get_state(&b, xb);
    TEST_ASSERT_EQUAL_MEMORY(xb, xa, sizeof xa);
    TEST_ASSERT_TRUE(xa[0] != 0);
}

/* A two-dof structure whose Newton matrix M/hs + C + hs K is singular (K_00 = -m_0 / hs^2, a negative
 * stiffness the check cannot see): refused, the instance left uninitialised; with substeps, the singular
 * matrix the substeps' (hs / substeps), not the step's: refused as well. */
static void test_a_structure_with_a_singular_newton_matrix_is_refused(void)
{
    static caekf_t est;
    caekf_scalar_t mass[2] = {1, 2}, K[4] = {0, 0, 0, (caekf_scalar_t)4e4}, bu[2] = {1, 0}, w[2] = {1, -1},
                   h[4] = {1, 0, 0, 1}, x[CAEKF_N];
    caekf_structure_t st;
    caekf_settings_t s;
    int sub;
    paper_settings(&s, -1);
    st.dofs = 2;
    st.mass = mass;
    st.stiffness = K;
    st.damping = 0;
    st.inputs = bu;
    st.contacts = w;
    st.sensors = h;
    for (sub = 0; sub < 2; ++sub) {
        const caekf_scalar_t dt = sub ? s.model.dt / (caekf_scalar_t)5 : s.model.dt;
        const caekf_scalar_t hs = dt / 2; /* trapezoidal */
        s.model.discretisation = CAEKF_DISCRETISATION_TRAPEZOIDAL;
        s.contact_substeps = sub ? 5 : 1;
        K[0] = -(mass[0] / hs) / hs;
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_init_structure(&est, &s, &st));
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NOT_INIT, caekf_get_state(&est, x));
        K[0] = (caekf_scalar_t)4e4; /* the same structure, stiff: taken */
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init_structure(&est, &s, &st));
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_the_chain_as_matrices_estimates_as_the_chain);
    RUN_TEST(test_the_chain_as_matrices_by_backward_euler_one_step);
    RUN_TEST(test_the_chain_as_matrices_with_an_accelerometer);
    RUN_TEST(test_a_ground_stop_two_inputs_and_an_accelerometer_as_matrices);
    RUN_TEST(test_estimated_law_parameters_on_a_structure_as_matrices);
    RUN_TEST(test_an_estimated_damping_alone_on_a_structure_as_matrices);
#if CAEKF_MODEL_ORACLES && !CAEKF_USE_FLOAT
    RUN_TEST(test_a_dense_structure_is_eq10_of_its_residual);
#endif
    RUN_TEST(test_a_structure_accelerometer_reads_the_momentum_balance);
    RUN_TEST(test_an_estimator_on_a_dense_structure_runs_through_contact);
    RUN_TEST(test_a_structure_the_core_cannot_take_is_refused);
    RUN_TEST(test_each_rule_of_the_structure_check);
    RUN_TEST(test_a_structure_without_damping_inputs_or_contacts);
    RUN_TEST(test_a_structure_with_a_singular_newton_matrix_is_refused);
    return UNITY_END();
}
