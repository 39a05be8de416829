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

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_the_chain_as_matrices_estimates_as_the_chain);
    RUN_TEST(test_the_chain_as_matrices_by_backward_euler_one_step);
    RUN_TEST(test_the_chain_as_matrices_with_an_accelerometer);
#if CAEKF_MODEL_ORACLES && !CAEKF_USE_FLOAT
    RUN_TEST(test_a_dense_structure_is_eq10_of_its_residual);
#endif
    RUN_TEST(test_a_structure_accelerometer_reads_the_momentum_balance);
    RUN_TEST(test_an_estimator_on_a_dense_structure_runs_through_contact);
    RUN_TEST(test_a_structure_the_core_cannot_take_is_refused);
    return UNITY_END();
}
