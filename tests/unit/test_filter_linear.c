/* With contact never active the estimator must be an ordinary linear Kalman filter. The reference
 * filter here is written independently, in double and physical units, from the theta-method matrices
 * (theta = 1 backward Euler, 1/2 trapezoidal, h = dt):
 *   [I, -theta h I; theta h K, M + theta h C] x_k = [I, (1-theta) h I; -(1-theta) h K, M - (1-theta) h C] x_{k-1}
 *                                                  + [0; h B_u (theta u_k + (1-theta) u_{k-1})].
 * It also pins the time convention: the first step holds its own input (u_{k-1} = u_k), and a sample at
 * t0 given to caekf_correct is a correction without a time update whose input starts the next step. */
#include <math.h>
#include <string.h>

#include "test_support.h"
#include "unity.h"

#define NX 8
#define STEPS 3000

#if CAEKF_USE_FLOAT
#define X_RTOL 2e-3
#define P_RTOL 2e-2
#else
#define X_RTOL 1e-8
#define P_RTOL 1e-7
#endif

void setUp(void) {}
void tearDown(void) {}

typedef struct {
    double F[NX][NX], Ainv[NX][NX];
    double x[NX], P[NX][NX];
    double qd[NX], r, dt, theta, u_prev;
    int u_prev_known;
    double m[4];
} linear_kf_t;

static void kf_init(linear_kf_t *kf, const caekf_settings_t *s)
{
    const caekf_model_params_t *p = &s->model;
    double K[4][4] = {{0}}, C[4][4] = {{0}}, A[NX][NX] = {{0}}, B[NX][NX] = {{0}};
    int i, j, k;
    double dt = (double)p->dt;
    const double th = p->discretisation == CAEKF_DISCRETISATION_TRAPEZOIDAL ? 0.5 : 1.0;
    kf->theta = th;
    kf->u_prev = 0;
    kf->u_prev_known = 0;
    K[0][0] = (double)p->spring_k[0] + (double)p->spring_k[1];
    K[0][1] = K[1][0] = -(double)p->spring_k[1];
    K[1][1] = (double)p->spring_k[1];
    K[2][2] = (double)p->spring_k[2];
    K[2][3] = K[3][2] = -(double)p->spring_k[2];
    K[3][3] = (double)p->spring_k[2] + (double)p->spring_k[3];
    C[0][0] = (double)p->spring_c[0] + (double)p->spring_c[1];
    C[0][1] = C[1][0] = -(double)p->spring_c[1];
    C[1][1] = (double)p->spring_c[1];
    C[2][2] = (double)p->spring_c[2];
    C[2][3] = C[3][2] = -(double)p->spring_c[2];
    C[3][3] = (double)p->spring_c[2] + (double)p->spring_c[3];
    for (i = 0; i < 4; ++i) {
        kf->m[i] = (double)p->m[i];
        A[i][i] = 1;
        A[i][4 + i] = -th * dt;
        B[i][i] = 1;
        B[i][4 + i] = (1 - th) * dt;
        for (j = 0; j < 4; ++j) {
            A[4 + i][j] = th * dt * K[i][j];
            A[4 + i][4 + j] = (i == j ? kf->m[i] : 0) + th * dt * C[i][j];
            B[4 + i][j] = -(1 - th) * dt * K[i][j];
            B[4 + i][4 + j] = (i == j ? kf->m[i] : 0) - (1 - th) * dt * C[i][j];
        }
    }
    TEST_ASSERT_EQUAL_INT(0, test_invert(&A[0][0], &kf->Ainv[0][0], NX));
    for (i = 0; i < NX; ++i)
        for (j = 0; j < NX; ++j) {
            double acc = 0;
            for (k = 0; k < NX; ++k) acc += kf->Ainv[i][k] * B[k][j];
            kf->F[i][j] = acc;
        }
    memset(kf->P, 0, sizeof kf->P);
    for (i = 0; i < 4; ++i) {
        kf->x[i] = 0;
        kf->x[4 + i] = 0;
        kf->P[i][i] = (double)s->sigma_q0 * (double)s->sigma_q0;
        kf->P[4 + i][4 + i] = (double)s->sigma_v0 * (double)s->sigma_v0;
        kf->qd[i] = (double)s->sigma_qx_q * (double)s->sigma_qx_q;
        kf->qd[4 + i] = (double)s->sigma_qx_v * (double)s->sigma_qx_v;
    }
    kf->r = (double)s->sigma_r * (double)s->sigma_r;
    kf->dt = dt;
}

/* One sample: a time update (unless `predict` is 0, a sample at the estimate's own time), then the
 * correction by the sensors h (state indices) with variances rv, ny of them. */
static double kf_step_sensors(linear_kf_t *kf, double u, const double *y, const int *h, const double *rv, int ny,
                              int predict)
{
    double nis = 0;
    double xp[NX], T[NX][NX], Pp[NX][NX], S[4 * 4], Si[4 * 4], G[NX][4], e[4];
    int i, j, k, l;
    const double u0 = kf->u_prev_known ? kf->u_prev : u;
    kf->u_prev = u;
    kf->u_prev_known = 1;
    if (!predict) {
        memcpy(xp, kf->x, sizeof xp);
        memcpy(Pp, kf->P, sizeof Pp);
    } else {
        for (i = 0; i < NX; ++i) { /* x- = F x + Ainv [0; dt B_u (theta u_k + (1 - theta) u_{k-1})] */
            double acc = kf->Ainv[i][4] * kf->dt * (kf->theta * u + (1 - kf->theta) * u0);
            for (k = 0; k < NX; ++k) acc += kf->F[i][k] * kf->x[k];
            xp[i] = acc;
        }
        for (i = 0; i < NX; ++i)
            for (j = 0; j < NX; ++j) {
                double acc = 0;
                for (k = 0; k < NX; ++k) acc += kf->F[i][k] * kf->P[k][j];
                T[i][j] = acc;
            }
        for (i = 0; i < NX; ++i)
            for (j = 0; j < NX; ++j) {
                double acc = (i == j) ? kf->qd[i] : 0;
                for (k = 0; k < NX; ++k) acc += T[i][k] * kf->F[j][k];
                Pp[i][j] = acc;
            }
    }
    for (k = 0; k < ny; ++k) {
        for (l = 0; l < ny; ++l) S[k * ny + l] = Pp[h[k]][h[l]] + (k == l ? rv[k] : 0);
        e[k] = y[k] - xp[h[k]];
    }
    TEST_ASSERT_EQUAL_INT(0, test_invert(S, Si, ny));
    for (k = 0; k < ny; ++k)
        for (l = 0; l < ny; ++l) nis += e[k] * Si[k * ny + l] * e[l];
    for (i = 0; i < NX; ++i)
        for (k = 0; k < ny; ++k) {
            G[i][k] = 0;
            for (l = 0; l < ny; ++l) G[i][k] += Pp[i][h[l]] * Si[l * ny + k];
        }
    for (i = 0; i < NX; ++i) {
        kf->x[i] = xp[i];
        for (k = 0; k < ny; ++k) kf->x[i] += G[i][k] * e[k];
    }
    for (i = 0; i < NX; ++i)
        for (j = 0; j < NX; ++j) {
            kf->P[i][j] = Pp[i][j];
            for (k = 0; k < ny; ++k) kf->P[i][j] -= G[i][k] * Pp[h[k]][j];
        }
    return nis;
}

/* The paper's two position sensors, bodies 1 and 4. */
static void kf_step(linear_kf_t *kf, double u, double y1, double y4, int predict)
{
    const double y[2] = {y1, y4}, rv[2] = {kf->r, kf->r};
    const int h[2] = {0, 3};
    (void)kf_step_sensors(kf, u, y, h, rv, 2, predict);
}

static void compare_with_linear_kf(int mode, int discretisation, int start_at_t0)
{
    caekf_settings_t s;
    linear_kf_t kf;
    static caekf_t est;
    truth_rec_t r;
    caekf_scalar_t gamma0;
    long n = 0;
    int i, j;
    paper_settings(&s, EXP_SWITCHED);
    s.mode = mode;
    s.model.discretisation = discretisation;
    s.model.contact_gap[0] = 1;                         /* 1 m: contact is never active */
    s.v0[0] = (caekf_scalar_t)2e-3;                     /* not at rest: a time shift would show */
    s.q0[0] = (caekf_scalar_t)(start_at_t0 ? 2e-4 : 0); /* the correction at t0 starts from every state */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &s));
    (void)caekf_get_gamma(&est, &gamma0);
    kf_init(&kf, &s);
    kf.x[0] = (double)s.q0[0];
    kf.x[4] = (double)s.v0[0];
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (n < STEPS && truth_next(&r) == 1) {
        caekf_scalar_t y[2], x[CAEKF_N], P[CAEKF_N][CAEKF_N];
        caekf_report_t rep;
        /* Measurements from the contact truth are fine: any data exercises the filter. */
        y[0] = (caekf_scalar_t)r.y1;
        y[1] = (caekf_scalar_t)r.y4;
        if (n == 0 && start_at_t0) { /* this sample is taken as the one at t0 */
            TEST_ASSERT_EQUAL_INT(CAEKF_OK,
                                  caekf_correct(&est, (const caekf_scalar_t[]){(caekf_scalar_t)r.u}, y, &rep));
            TEST_ASSERT_EQUAL_INT(0, rep.newton_iters);
        } else {
            TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, (const caekf_scalar_t[]){(caekf_scalar_t)r.u}, y, &rep));
        }
        TEST_ASSERT_FALSE(rep.flags & CAEKF_FLAG_CONTACT_ACTIVE);
        kf_step(&kf, r.u, r.y1, r.y4, !(n == 0 && start_at_t0));
        (void)caekf_get_state(&est, x);
        (void)caekf_get_covariance(&est, P);
        for (i = 0; i < NX; ++i) {
            double scale = i < 4 ? 1e-3 : 1e-3; /* positions ~mm, velocities ~mm/s */
            TEST_ASSERT_DOUBLE_WITHIN(X_RTOL * (fabs(kf.x[i]) + 1e-6 * scale), kf.x[i], (double)x[i]);
            for (j = 0; j < NX; ++j) {
                double ref = kf.P[i][j];
                double tol = P_RTOL * sqrt(kf.P[i][i] * kf.P[j][j]);
                TEST_ASSERT_DOUBLE_WITHIN(tol, ref, (double)P[i][j]);
            }
        }
        n++;
    }
    truth_close();
    TEST_ASSERT_EQUAL_INT32(STEPS, n);
    if (mode == CAEKF_MODE_SWITCHED) {
        caekf_scalar_t g;
        (void)caekf_get_gamma(&est, &g);
        TEST_ASSERT_TRUE(memcmp(&g, &gamma0, sizeof g) == 0); /* frozen throughout */
    }
}

#if !CAEKF_SIZED /* a build sized for one scenario has its sensors only */
/* Other sensor sets than the paper's two positions, the Kalman filter still: one sensor (the scalar
 * innovation), three (a general S^-1, a velocity among them). kinds[k]: 0 position, 1 velocity. */
static void compare_sensors_with_linear_kf(int ny, const int *bodies, const int *kinds, int discretisation,
                                           int cov_update)
{
    caekf_settings_t s;
    linear_kf_t kf;
    static caekf_t est;
    truth_rec_t r;
    int h[4], i, j, k;
    double rv[4], nis;
    caekf_scalar_t gamma0;
    long n = 0;
    paper_settings(&s, EXP_SWITCHED);
    s.model.discretisation = discretisation;
    s.cov_update = cov_update;
    s.model.contact_gap[0] = 1; /* contact never active */
    s.v0[1] = (caekf_scalar_t)-1e-3;
    s.model.sensors = ny;
    s.sigma_rv = (caekf_scalar_t)3e-5;
    for (k = 0; k < ny; ++k) {
        s.model.sensor_body[k] = bodies[k];
        s.model.sensor_kind[k] = kinds[k] ? CAEKF_SENSOR_VELOCITY : CAEKF_SENSOR_POSITION;
        h[k] = (kinds[k] ? 4 : 0) + bodies[k] - 1;
        rv[k] = kinds[k] ? (double)s.sigma_rv * (double)s.sigma_rv : (double)s.sigma_r * (double)s.sigma_r;
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &s));
    (void)caekf_get_gamma(&est, &gamma0);
    kf_init(&kf, &s);
    kf.x[5] = (double)s.v0[1];
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (n < 1500 && truth_next(&r) == 1) {
        caekf_scalar_t y[4], x[CAEKF_N], P[CAEKF_N][CAEKF_N];
        double yd[4];
        caekf_report_t rep;
        for (k = 0; k < ny; ++k) {
            yd[k] = kinds[k] ? r.v[bodies[k] - 1] : r.q[bodies[k] - 1];
            y[k] = (caekf_scalar_t)yd[k];
        }
        test_fill_stack(0xFF); /* a sensor's work read past ny: a NaN */
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, (const caekf_scalar_t[]){(caekf_scalar_t)r.u}, y, &rep));
        nis = kf_step_sensors(&kf, r.u, yd, h, rv, ny, 1);
        TEST_ASSERT_DOUBLE_WITHIN(P_RTOL * (nis + 1) * 10, nis, (double)rep.nis); /* the innovation's NIS */
        (void)caekf_get_state(&est, x);
        TEST_ASSERT_TRUE(memcmp(&x[PAPER_IG], &gamma0, sizeof gamma0) == 0); /* open: gamma frozen */
        (void)caekf_get_covariance(&est, P);
        for (i = 0; i < NX; ++i) {
            TEST_ASSERT_DOUBLE_WITHIN(X_RTOL * (fabs(kf.x[i]) + 1e-9), kf.x[i], (double)x[i]);
            for (j = 0; j < NX; ++j) {
                TEST_ASSERT_DOUBLE_WITHIN(P_RTOL * sqrt(kf.P[i][i] * kf.P[j][j]), kf.P[i][j], (double)P[i][j]);
            }
        }
        n++;
    }
    truth_close();
    TEST_ASSERT_EQUAL_INT32(1500, n);
}

/* The correction's two forms (standard and Joseph) are the same filter. */
static void test_one_position_sensor_is_a_linear_kf(void)
{
    const int bodies[1] = {3}, kinds[1] = {0};
    compare_sensors_with_linear_kf(1, bodies, kinds, CAEKF_DISCRETISATION_BACKWARD_EULER, CAEKF_COV_STANDARD);
    compare_sensors_with_linear_kf(1, bodies, kinds, CAEKF_DISCRETISATION_BACKWARD_EULER, CAEKF_COV_JOSEPH);
}

static void test_three_sensors_with_a_velocity_are_a_linear_kf(void)
{
    const int bodies[3] = {1, 4, 2}, kinds[3] = {0, 0, 1};
    compare_sensors_with_linear_kf(3, bodies, kinds, CAEKF_DISCRETISATION_BACKWARD_EULER, CAEKF_COV_STANDARD);
    compare_sensors_with_linear_kf(3, bodies, kinds, CAEKF_DISCRETISATION_BACKWARD_EULER, CAEKF_COV_JOSEPH);
}

#if CAEKF_MAX_SENSORS >= 4
/* As many sensors as the build has room for (four), two of them velocities. */
static void test_four_sensors_are_a_linear_kf(void)
{
    const int bodies[4] = {2, 3, 1, 4}, kinds[4] = {0, 1, 1, 0};
    compare_sensors_with_linear_kf(4, bodies, kinds, CAEKF_DISCRETISATION_BACKWARD_EULER, CAEKF_COV_STANDARD);
    compare_sensors_with_linear_kf(4, bodies, kinds, CAEKF_DISCRETISATION_BACKWARD_EULER, CAEKF_COV_JOSEPH);
}
#endif
#endif

#define BE CAEKF_DISCRETISATION_BACKWARD_EULER
#define TRAP CAEKF_DISCRETISATION_TRAPEZOIDAL
static void test_switched_without_contact_is_a_linear_kf(void) { compare_with_linear_kf(CAEKF_MODE_SWITCHED, BE, 0); }
static void test_canonical_without_contact_is_a_linear_kf(void) { compare_with_linear_kf(CAEKF_MODE_CANONICAL, BE, 0); }
#if CAEKF_HAS_TRAPEZOIDAL /* the build runs it */
static void test_trapezoidal_without_contact_is_a_linear_kf(void)
{
    compare_with_linear_kf(CAEKF_MODE_SWITCHED, TRAP, 0);
}
static void test_a_sample_at_t0_is_a_correction_only(void) { compare_with_linear_kf(CAEKF_MODE_SWITCHED, TRAP, 1); }
#endif
static void test_a_sample_at_t0_is_a_correction_only_be(void) { compare_with_linear_kf(CAEKF_MODE_CANONICAL, BE, 1); }

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_switched_without_contact_is_a_linear_kf);
    RUN_TEST(test_canonical_without_contact_is_a_linear_kf);
#if CAEKF_HAS_TRAPEZOIDAL /* the build runs it */
    RUN_TEST(test_trapezoidal_without_contact_is_a_linear_kf);
    RUN_TEST(test_a_sample_at_t0_is_a_correction_only);
#endif
    RUN_TEST(test_a_sample_at_t0_is_a_correction_only_be);
#if !CAEKF_SIZED
    RUN_TEST(test_one_position_sensor_is_a_linear_kf);
    RUN_TEST(test_three_sensors_with_a_velocity_are_a_linear_kf);
#if CAEKF_MAX_SENSORS >= 4
    RUN_TEST(test_four_sensors_are_a_linear_kf);
#endif
#endif
    return UNITY_END();
}
