/* Branches of the core that the other suites do not take (issue 31), second part: a link written ground end
 * first, contacts against the ground on either side and what accelerometers read there, two inputs of either
 * kind in one mechanism, the paper's switch-off with one or three sensors and in Joseph form, the flush of a
 * tiny covariance by the constraint, Newton's iteration cap, the statistically linearised switch on either
 * side of p = 1/2, ln gamma without a lower bound, the settings' law-parameter rules, the second-order term
 * off, and the roll-back of a step whose Newton matrix is not finite. Unsized builds only (the mechanisms
 * here are not the paper's). */
#include <math.h>
#include <string.h>

#include "caekf_filter.h"
#include "caekf_model_internal.h"
#include "test_support.h"
#include "unity.h"

static caekf_t est, other;
static caekf_settings_t good;

void setUp(void) { paper_settings(&good, EXP_SWITCHED_HIGHQ_CONSTRAINED); }
void tearDown(void) {}

/* Runs s over the truth until time t_end (a second input at rest), every step required to succeed; returns
 * the flags' union and counts the steps with a contact active. */
static uint32_t run_until(caekf_t *e, const caekf_settings_t *s, double t_end, long *active)
{
    truth_rec_t r;
    uint32_t all = 0;
    *active = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(e, s));
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (truth_next(&r) == 1 && r.t < t_end) {
        caekf_report_t rep;
        const caekf_scalar_t y[2] = {(caekf_scalar_t)r.y1, (caekf_scalar_t)r.y4};
        const caekf_scalar_t u[2] = {(caekf_scalar_t)r.u, 0};
        const caekf_status_t st = caekf_step(e, u, y, &rep);
        if (st != CAEKF_OK) {
            truth_close();
            TEST_ASSERT_EQUAL_INT_MESSAGE(CAEKF_OK, st, "a step failed");
        }
        all |= rep.flags;
        *active += (rep.flags & CAEKF_FLAG_CONTACT_ACTIVE) != 0;
    }
    truth_close();
    return all;
}

/* Every state and variance of the estimator finite, every variance > 0. */
static void expect_sound(const caekf_t *e)
{
    caekf_scalar_t var[CAEKF_N], x[CAEKF_N];
    int n, ny, nu, i;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_sizes(e, &n, &ny, &nu));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_variances(e, var));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(e, x));
    for (i = 0; i < n; ++i) {
        TEST_ASSERT_TRUE(isfinite((double)x[i]) && isfinite((double)var[i]) && var[i] > 0);
    }
}

/* Guards the ground end written first (spring{i}_a = 0): link 1 as (ground, body 1) instead of (body 1,
 * ground), its stiffness and damper estimated (their columns of F, trapezoidal: at x_k and x_{k-1}, over the
 * substeps in contact) and a load cell in it (reading k (q_a - q_b) + c (v_a - v_b): the other sign, so it is
 * given the other sign), estimates as the link written body first, step by step through contact. */
static void test_a_link_written_ground_first_estimates_the_same(void)
{
    caekf_settings_t a = good, b;
    caekf_scalar_t xa[CAEKF_N], xb[CAEKF_N];
    truth_rec_t r;
    double worst = 0;
    long k = 0, active = 0;
    int i, n, ny, nu;
    TEST_ASSERT_TRUE(good.model.spring_a[0] == 1 && good.model.spring_b[0] == 0);
    a.model.discretisation = CAEKF_DISCRETISATION_TRAPEZOIDAL;
    a.contact_substeps = 5;
    a.model.spring_k_sigma[0] = (caekf_scalar_t)0.05;
    a.model.spring_c_sigma[0] = (caekf_scalar_t)0.05;
    a.model.sensors = 3;
    a.model.sensor_kind[2] = CAEKF_SENSOR_LINK_FORCE;
    a.model.sensor_link[2] = 1;
    a.model.sensor_body[2] = 1; /* read by validation only */
    a.sensor_sigma[2] = (caekf_scalar_t)1e-3;
    b = a;
    b.model.spring_a[0] = 0;
    b.model.spring_b[0] = 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &a));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&other, &b));
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (k < 14000 && truth_next(&r) == 1) {
        const double cell = (double)a.model.spring_k[0] * r.q[0] + (double)a.model.spring_c[0] * r.v[0];
        const caekf_scalar_t u[1] = {(caekf_scalar_t)r.u};
        const caekf_scalar_t ya[3] = {(caekf_scalar_t)r.y1, (caekf_scalar_t)r.y4, (caekf_scalar_t)cell};
        const caekf_scalar_t yb[3] = {ya[0], ya[1], -ya[2]};
        caekf_report_t ra, rb;
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, u, ya, &ra));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&other, u, yb, &rb));
        TEST_ASSERT_EQUAL_UINT32(ra.flags, rb.flags);
        active += (ra.flags & CAEKF_FLAG_CONTACT_ACTIVE) != 0;
        ++k;
    }
    truth_close();
    TEST_ASSERT_TRUE(active > 20);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_sizes(&est, &n, &ny, &nu));
    TEST_ASSERT_EQUAL_INT(PAPER_N + 2, n); /* ln k1 and ln c1 after gamma */
    (void)caekf_get_state(&est, xa);
    (void)caekf_get_state(&other, xb);
    for (i = 0; i < n; ++i) {
        worst = fmax(worst, fabs((double)xa[i] - (double)xb[i]) / fmax(fabs((double)xa[i]), i < 4 ? 1e-3 : 1e-2));
    }
    TEST_ASSERT_TRUE_MESSAGE(worst < (CAEKF_USE_FLOAT ? 1e-3 : 1e-9), "the link's ends, either way round, differ");
    TEST_ASSERT_TRUE(xa[PAPER_N] != a.model.spring_k[0]); /* the stiffness moved */
}

/* The paper's chain between two ground stops, body 1's far side (contact (ground, 1)) and body 4's (contact
 * (4, ground)), both damped, driven by a force on body 1 and a base displacement of link 1 (ground - body 1):
 * the model the sensor test reads. */
static void two_ground_stops(caekf_settings_t *b, caekf_model_t *m)
{
    *b = good;
    b->model.contacts = 2;
    b->model.contact_a[0] = 0;
    b->model.contact_b[0] = 1;
    b->model.contact_lambda[0] = (caekf_scalar_t)50;
    b->model.contact_a[1] = 4;
    b->model.contact_b[1] = 0;
    b->model.contact_gap[1] = (caekf_scalar_t)2e-5;
    b->model.contact_n[1] = (caekf_scalar_t)1.5;
    b->model.contact_lambda[1] = (caekf_scalar_t)80;
    b->gamma0[1] = good.gamma0[0];
    b->sigma_gamma0[1] = good.sigma_gamma0[0];
    b->sigma_q_gamma[1] = good.sigma_q_gamma[0];
    b->gamma_min[1] = good.gamma_min[0];
    b->model.inputs = 2;
    b->model.input_kind[0] = CAEKF_INPUT_FORCE;
    b->model.input_body[0] = 1;
    b->model.input_kind[1] = CAEKF_INPUT_BASE_DISPLACEMENT;
    b->model.input_link[1] = 1;
    b->model.sensors = 3;
    b->model.sensor_kind[0] = CAEKF_SENSOR_ACCELERATION;
    b->model.sensor_body[0] = 1;
    b->model.sensor_kind[1] = CAEKF_SENSOR_ACCELERATION;
    b->model.sensor_body[1] = 4;
    b->model.sensor_kind[2] = CAEKF_SENSOR_RELATIVE;
    b->model.sensor_body[2] = 2;
    b->model.sensor_ref[2] = 0; /* against the ground */
    b->sensor_sigma[0] = b->sensor_sigma[1] = b->sensor_sigma[2] = (caekf_scalar_t)1e-3;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(b, 0));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(m, &b->model));
}

/* Guards the sensors at ground ends: accelerometers on bodies 1 and 4, each pushed by a damped contact with
 * the ground (its ground end first, and last), body 1 driven by a force and by its link's base displacement at
 * once, and a relative sensor against the ground: the values against the momentum balance written out, the
 * rows (q, v, gamma) against central differences of the values. */
static void test_sensors_at_ground_stops_with_a_force_and_a_base_input(void)
{
    static caekf_model_t m;
    caekf_settings_t b;
    const caekf_model_params_t *p = &b.model;
    caekf_scalar_t x[CAEKF_N], row[CAEKF_N], v;
    const caekf_scalar_t u[2] = {(caekf_scalar_t)0.3, (caekf_scalar_t)2e-5},
                         up[2] = {(caekf_scalar_t)0.2, (caekf_scalar_t)1e-5};
    caekf_contact_t c0, c1;
    double a1, a4, x_[CAEKF_N];
    int i, j;
    two_ground_stops(&b, &m);
    for (i = 0; i < CAEKF_N; ++i) {
        x[i] = 0;
    }
    x[0] = -(p->contact_gap[0] + (caekf_scalar_t)2e-6); /* body 1 past its stop */
    x[1] = (caekf_scalar_t)-4e-4;
    x[2] = (caekf_scalar_t)1e-5;
    x[3] = p->contact_gap[1] + (caekf_scalar_t)3e-6; /* body 4 past its stop */
    x[4] = (caekf_scalar_t)-1e-4;
    x[5] = (caekf_scalar_t)2e-4;
    x[6] = (caekf_scalar_t)-3e-4;
    x[7] = (caekf_scalar_t)2e-4;
    x[8] = (caekf_scalar_t)1.1e8;
    x[9] = (caekf_scalar_t)2e7;
    for (i = 0; i < CAEKF_N; ++i) {
        x_[i] = (double)x[i];
    }
    caekf_model_contact(&m, 0, x, &c0);
    caekf_model_contact(&m, 1, x, &c1);
    TEST_ASSERT_TRUE(c0.fc > 0 && c1.fc > 0 && c0.dfc_drate != 0 && c1.dfc_drate != 0);
    a1 = ((double)u[0] + (double)p->spring_k[0] * (double)u[1] +
          (double)p->spring_c[0] * ((double)u[1] - (double)up[1]) / (double)p->dt - (double)p->spring_k[0] * x_[0] -
          (double)p->spring_c[0] * x_[4] - (double)p->spring_k[1] * (x_[0] - x_[1]) -
          (double)p->spring_c[1] * (x_[4] - x_[5]) + (double)c0.fc) /
         (double)p->m[0];
    a4 = (-(double)p->spring_k[2] * (x_[3] - x_[2]) - (double)p->spring_c[2] * (x_[7] - x_[6]) -
          (double)p->spring_k[3] * x_[3] - (double)p->spring_c[3] * x_[7] - (double)c1.fc) /
         (double)p->m[3];
    caekf_model_sensor(&m, p, 0, x, u, up, &v, row);
    TEST_ASSERT_DOUBLE_WITHIN(fabs(a1) * (CAEKF_USE_FLOAT ? 1e-4 : 1e-10), a1, (double)v);
    caekf_model_sensor(&m, p, 1, x, u, up, &v, row);
    TEST_ASSERT_DOUBLE_WITHIN(fabs(a4) * (CAEKF_USE_FLOAT ? 1e-4 : 1e-10), a4, (double)v);
    caekf_model_sensor(&m, p, 2, x, u, up, &v, row);
    TEST_ASSERT_TRUE(v == x[1]);
    for (j = 0; j < m.n; ++j) {
        TEST_ASSERT_TRUE(row[j] == (j == 1 ? 1 : 0));
    }
    for (i = 0; i < 2 && !CAEKF_USE_FLOAT; ++i) { /* the accelerometers' rows: central differences */
        caekf_scalar_t r0[CAEKF_N], ra[CAEKF_N];
        caekf_model_sensor(&m, p, i, x, u, up, &v, r0);
        for (j = 0; j < m.n; ++j) {
            caekf_scalar_t xa[CAEKF_N], xb[CAEKF_N], va, vb;
            const double h = j < 4 ? 1e-10 : j < 8 ? 1e-8 : 1e2;
            memcpy(xa, x, sizeof xa);
            memcpy(xb, x, sizeof xb);
            xa[j] += (caekf_scalar_t)h;
            xb[j] -= (caekf_scalar_t)h;
            caekf_model_sensor(&m, p, i, xa, u, up, &va, ra);
            caekf_model_sensor(&m, p, i, xb, u, up, &vb, ra);
            TEST_ASSERT_DOUBLE_WITHIN(1e-5 * fabs((double)r0[j]) + 1e-9, (double)r0[j],
                                      ((double)va - (double)vb) / ((double)xa[j] - (double)xb[j]));
        }
        TEST_ASSERT_TRUE(r0[i == 0 ? 4 : 7] != 0); /* v of its body: the damped contact's rate */
    }
}

/* The chain with a force on body 1 and link 4 (body 4 - ground) driven at its ground end, link 1's stiffness
 * uncertain (a ground link no input moves): the step's residual at its Newton solution is zero (both inputs
 * as the forces the rows take), the input columns and ln k1's column against central differences of the step
 * (an error held over the step: per end that takes it). */
static void check_mixed_inputs(int discretisation, double delta)
{
    static caekf_model_t m;
    caekf_settings_t b = good;
    caekf_scalar_t xp[CAEKF_N], xk[CAEKF_N], g[CAEKF_NQ][CAEKF_MAX_INPUTS], fv[CAEKF_NQ][CAEKF_N], res[CAEKF_N];
    caekf_scalar_t work[4 * CAEKF_NQ];
    caekf_contact_t ct[CAEKF_MAX_CONTACTS + 1];
    const caekf_scalar_t up[2] = {(caekf_scalar_t)0.2, (caekf_scalar_t)2e-5},
                         u[2] = {(caekf_scalar_t)0.3, (caekf_scalar_t)3e-5};
    const double hu[2] = {1e-4, 1e-8}, hm = 1e-6,
                 end_scale = discretisation == CAEKF_DISCRETISATION_TRAPEZOIDAL ? 2 : 1;
    double worst = 0;
    int it, i, k;
    if (CAEKF_USE_FLOAT) {
        TEST_IGNORE_MESSAGE("central differences of the step: the double build checks them");
    }
    b.model.discretisation = discretisation;
    b.model.inputs = 2;
    b.model.input_kind[1] = CAEKF_INPUT_BASE_DISPLACEMENT;
    b.model.input_link[1] = 4;
    b.model.spring_k_sigma[0] = (caekf_scalar_t)0.05;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, 0));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&m, &b.model));
    TEST_ASSERT_EQUAL_INT(1, m.nm);
    paper_moving_state(xp, (double)b.model.contact_gap[0], delta, 1.1e8);
    TEST_ASSERT_EQUAL_INT(
        0, caekf_model_newton(&m, xp, up, u, CAEKF_NEWTON_MAX_ITER, (caekf_scalar_t)1e-15, xk, &it, work));
    caekf_model_residual(&m, xk, xp, up, u, res);
    for (i = 0; i < 2 * PAPER_NQ; ++i) { /* each row against its own terms' size: velocities, then forces */
        worst = fmax(worst, fabs((double)res[i]) / (i < PAPER_NQ ? 1e-3 : 1e2));
    }
    TEST_ASSERT_TRUE_MESSAGE(worst < 1e-10, "the step's residual at its solution");
    caekf_model_contact(&m, 0, xk, &ct[0]);
    TEST_ASSERT_TRUE(ct[0].delta > 0);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_input_columns(&m, ct, g));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_mech_columns(&m, ct, xp, xk, up, u, 0, fv));
    for (k = 0; k < 2; ++k) { /* input k held off by +-hu over the whole step */
        caekf_scalar_t ua[2], ub[2], upa[2], upb[2], xa[CAEKF_N], xb[CAEKF_N];
        double err;
        memcpy(ua, u, sizeof ua);
        memcpy(ub, u, sizeof ub);
        memcpy(upa, up, sizeof upa);
        memcpy(upb, up, sizeof upb);
        ua[k] += (caekf_scalar_t)hu[k];
        upa[k] += (caekf_scalar_t)hu[k];
        ub[k] -= (caekf_scalar_t)hu[k];
        upb[k] -= (caekf_scalar_t)hu[k];
        TEST_ASSERT_EQUAL_INT(
            0, caekf_model_newton(&m, xp, upa, ua, CAEKF_NEWTON_MAX_ITER, (caekf_scalar_t)1e-15, xa, &it, work));
        TEST_ASSERT_EQUAL_INT(
            0, caekf_model_newton(&m, xp, upb, ub, CAEKF_NEWTON_MAX_ITER, (caekf_scalar_t)1e-15, xb, &it, work));
        err = test_fd_column_error(xa, xb, PAPER_NQ, 2 * hu[k], &g[0][k], CAEKF_MAX_INPUTS, end_scale);
        TEST_ASSERT_TRUE(err >= 0);
        TEST_ASSERT_DOUBLE_WITHIN(1e-5, 0.0, err);
    }
    { /* ln k1 */
        caekf_scalar_t mult[1], xa[CAEKF_N], xb[CAEKF_N];
        double err;
        mult[0] = (caekf_scalar_t)exp(hm);
        TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&m, &b.model, mult));
        TEST_ASSERT_EQUAL_INT(
            0, caekf_model_newton(&m, xp, up, u, CAEKF_NEWTON_MAX_ITER, (caekf_scalar_t)1e-15, xa, &it, work));
        mult[0] = (caekf_scalar_t)exp(-hm);
        TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&m, &b.model, mult));
        TEST_ASSERT_EQUAL_INT(
            0, caekf_model_newton(&m, xp, up, u, CAEKF_NEWTON_MAX_ITER, (caekf_scalar_t)1e-15, xb, &it, work));
        err = test_fd_column_error(xa, xb, PAPER_NQ, 2 * hm, &fv[0][m.n - 1], CAEKF_N, 1.0);
        TEST_ASSERT_TRUE(err >= 0);
        TEST_ASSERT_DOUBLE_WITHIN(1e-5, 0.0, err);
    }
}

static void test_a_force_and_a_base_input_backward_euler(void)
{
    check_mixed_inputs(CAEKF_DISCRETISATION_BACKWARD_EULER, 2e-6);
}

static void test_a_force_and_a_base_input_trapezoidal(void)
{
    check_mixed_inputs(CAEKF_DISCRETISATION_TRAPEZOIDAL, 5e-6);
}

/* The same mechanism estimated through contact with both inputs measured (their noise as Q) and the
 * uncertain stiffness: every step succeeds, the covariance stays sound. */
static void test_a_force_and_a_base_input_estimated_through_contact(void)
{
    caekf_settings_t b = good;
    long active;
    b.model.inputs = 2;
    b.model.input_kind[1] = CAEKF_INPUT_BASE_DISPLACEMENT;
    b.model.input_link[1] = 4;
    b.model.spring_k_sigma[0] = (caekf_scalar_t)0.05;
    b.input_sigma[0] = (caekf_scalar_t)1e-3;
    b.input_sigma[1] = (caekf_scalar_t)1e-7;
    (void)run_until(&est, &b, 13.5, &active);
    TEST_ASSERT_TRUE(active > 0);
    expect_sound(&est);
}

/* Guards a measured input's trend with an uncertain mass by the trapezoidal rule (the trend's shift of x_k takes
 * both ends of the step): every step succeeds and the mass is learnt within 20 %. */
static void test_a_measured_input_and_an_uncertain_mass_trapezoidal(void)
{
    caekf_settings_t b = good;
    caekf_scalar_t x[CAEKF_N];
    long active;
    b.model.discretisation = CAEKF_DISCRETISATION_TRAPEZOIDAL;
    b.model.m_sigma[0] = (caekf_scalar_t)0.05;
    b.input_sigma[0] = (caekf_scalar_t)1e-3;
    (void)run_until(&est, &b, 13.5, &active);
    TEST_ASSERT_TRUE(active > 0);
    expect_sound(&est);
    TEST_ASSERT_EQUAL_UINT32(1u, est.input_trend_known);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, x));
    TEST_ASSERT_FLOAT_WITHIN(0.2f * (float)good.model.m[0], (float)good.model.m[0], (float)x[PAPER_N]);
}

/* The x-block's Kalman update written out in double: z_x += K (y - H z), P_xx -= K H P_xx, K = P_xH S^-1,
 * S = H P_xx H^T + R, for sensors reading states h[0..ny-1] (P: the full matrix). */
static void reference_update(paper_mat_t P0, const caekf_scalar_t *z0, const caekf_filter_dims_t *d,
                             const caekf_scalar_t *y, double Pr[PAPER_N][PAPER_N], double zr[PAPER_N])
{
    double S[9], Si[9], K[PAPER_N][3];
    const int ny = d->ny, nx = 2 * PAPER_NQ;
    int i, j, k, l;
    for (k = 0; k < ny; ++k) {
        for (l = 0; l < ny; ++l) {
            S[k * ny + l] = (double)P0[d->h[k]][d->h[l]] + (k == l ? (double)d->r[k] : 0);
        }
    }
    TEST_ASSERT_EQUAL_INT(0, test_invert(S, Si, ny));
    for (i = 0; i < nx; ++i) {
        for (k = 0; k < ny; ++k) {
            K[i][k] = 0;
            for (l = 0; l < ny; ++l) {
                K[i][k] += (double)P0[i][d->h[l]] * Si[l * ny + k];
            }
        }
    }
    for (i = 0; i < PAPER_N; ++i) {
        zr[i] = (double)z0[i];
        for (j = 0; j < PAPER_N; ++j) {
            Pr[i][j] = (double)P0[i][j];
        }
    }
    for (i = 0; i < nx; ++i) {
        for (k = 0; k < ny; ++k) {
            zr[i] += K[i][k] * ((double)y[k] - (double)z0[d->h[k]]);
        }
        for (j = 0; j < nx; ++j) {
            for (k = 0; k < ny; ++k) {
                Pr[i][j] -= K[i][k] * (double)P0[d->h[k]][j];
            }
        }
    }
}

/* Guards the paper's switch-off (eq. 27: gamma frozen, only P_xx corrected, gamma's row and column left) with
 * one and three sensors and in Joseph form: the state, P_xx and the untouched gamma row against the update
 * written out. */
static void check_paper_switch_off(int ny, int joseph)
{
    static paper_mat_t P, P0;
    static caekf_correct_work_t work;
    static double Pr[PAPER_N][PAPER_N];
    caekf_filter_dims_t d;
    caekf_scalar_t z[PAPER_N], z0[PAPER_N], nis = 0;
    const caekf_scalar_t y[3] = {(caekf_scalar_t)0.3, (caekf_scalar_t)-0.2, (caekf_scalar_t)0.5};
    double zr[PAPER_N];
    uint32_t flags = 0;
    int i, j;
    test_spd_matrix(P);
    paper_filter_dims(&d, (caekf_scalar_t)0.5, CAEKF_GAMMA_FROZEN_PAPER);
    d.ny = ny;
    d.h[2] = 5;
    d.r[2] = (caekf_scalar_t)0.7;
    for (i = 0; i < PAPER_N; ++i) {
        z[i] = z0[i] = (caekf_scalar_t)(0.1 * i - 0.3);
        for (j = 0; j < PAPER_N; ++j) {
            P0[i][j] = P[i][j];
        }
    }
    reference_update(P0, z0, &d, y, Pr, zr);
    TEST_ASSERT_EQUAL_INT(0, caekf_correct_upper(z, &P[0][0], y, joseph, &d, 0, &nis, &flags, &work));
    TEST_ASSERT_TRUE(nis > 0);
    for (i = 0; i < PAPER_N; ++i) {
        TEST_ASSERT_DOUBLE_WITHIN(CAEKF_USE_FLOAT ? 1e-5 : 1e-12, zr[i], (double)z[i]);
        for (j = i; j < PAPER_N; ++j) {
            if (j == PAPER_IG) { /* gamma's column: as it was */
                TEST_ASSERT_TRUE(P[i][j] == P0[i][j]);
            } else {
                TEST_ASSERT_DOUBLE_WITHIN(CAEKF_USE_FLOAT ? 1e-5 : 1e-12, Pr[i][j], (double)P[i][j]);
            }
        }
    }
    TEST_ASSERT_TRUE(z[PAPER_IG] == z0[PAPER_IG]);
}

static void test_paper_switch_off_one_and_three_sensors_and_joseph(void)
{
    check_paper_switch_off(1, 0);
    check_paper_switch_off(3, 0);
    check_paper_switch_off(1, 1);
    check_paper_switch_off(2, 1);
    check_paper_switch_off(3, 1);
}

/* Guards the constraint's flush of the entries after gamma's column: a covariance below CAEKF_TINY there
 * becomes 0 (no subnormals on the MCU), a larger one is kept. */
static void test_the_constraint_flushes_a_tiny_covariance_after_gamma(void)
{
    const caekf_scalar_t tiny = (caekf_scalar_t)(CAEKF_TINY / 2);
    /* upper triangle of 4 x 4, gamma at 2 */
    caekf_scalar_t P[16] = {1, 0, (caekf_scalar_t)0.5, tiny, 0, 1, 0, (caekf_scalar_t)0.25, 0, 0, 1, 0, 0, 0, 0, 1};
    caekf_scalar_t z[4] = {0, 0, -1, 0};
    uint32_t flags = 0;
    TEST_ASSERT_TRUE(tiny > 0);
    TEST_ASSERT_EQUAL_INT(1, caekf_constrain_upper(z, P, 4, 2, 0, 0, 1, 0, &flags));
    TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_CONSTRAINT_APPLIED, flags);
    TEST_ASSERT_TRUE(P[3] == 0);                    /* P_03: tiny - 0.5 P_23 / P_22, flushed */
    TEST_ASSERT_TRUE(P[7] == (caekf_scalar_t)0.25); /* P_13 kept */
    TEST_ASSERT_FLOAT_WITHIN(1e-6f, 0.75f, (float)P[0]);
    TEST_ASSERT_FLOAT_WITHIN(1e-6f, 0.5f, (float)z[0]); /* 0.5 dz */
}

/* Guards Newton's iteration cap: one iteration allowed, the substeps' steps through contact end unconverged
 * (flagged, the step still taken; in double); a cap above CAEKF_NEWTON_MAX_ITER is CAEKF_NEWTON_MAX_ITER. */
static void test_newtons_iteration_cap(void)
{
    static caekf_model_t m;
    caekf_settings_t b = good;
    caekf_scalar_t xp[CAEKF_N], xa[CAEKF_N], xb[CAEKF_N], work[4 * CAEKF_NQ];
    const caekf_scalar_t up[1] = {(caekf_scalar_t)0.2}, u[1] = {(caekf_scalar_t)0.3};
    long active;
    int ia, ib;
    uint32_t flags;
    b.newton_max_iter = 1;
    b.contact_substeps = 5;
    flags = run_until(&est, &b, 13.5, &active);
    TEST_ASSERT_TRUE(active > 0);
    /* float: newton_rtol (a multiple of float's eps) is met by the first update already */
    TEST_ASSERT_TRUE(CAEKF_USE_FLOAT || (flags & CAEKF_FLAG_NEWTON_NOT_CONVERGED) != 0);
    expect_sound(&est);
    b.newton_max_iter = CAEKF_NEWTON_MAX_ITER;
    flags = run_until(&est, &b, 13.5, &active);
    TEST_ASSERT_TRUE(active > 0);
    TEST_ASSERT_EQUAL_UINT32(0, flags & CAEKF_FLAG_NEWTON_NOT_CONVERGED);
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&m, &good.model));
    paper_moving_state(xp, (double)good.model.contact_gap[0], 2e-6, 1.1e8);
    (void)caekf_model_newton(&m, xp, up, u, CAEKF_NEWTON_MAX_ITER, 0, xa, &ia, work); /* rtol 0: every iteration */
    (void)caekf_model_newton(&m, xp, up, u, 10 * CAEKF_NEWTON_MAX_ITER, 0, xb, &ib, work);
    TEST_ASSERT_EQUAL_INT(ia, ib);
    TEST_ASSERT_EQUAL_MEMORY(xa, xb, (size_t)m.n * sizeof xa[0]);
}

/* Guards the statistically linearised switch on either side of p = 1/2, step by step against the predicted
 * penetration the report gives: with p = 0.6 a contact just past its gap (P(delta > 0) = 1/2 there) is not
 * yet active, and none short of it is; with p = 0.4 every contact at or past its gap is active, and some a
 * little short of it are. */
static void test_slr_switch_on_either_side_of_one_half(void)
{
    caekf_settings_t b = good;
    int k;
    for (k = 0; k < 2; ++k) {
        truth_rec_t r;
        long past_inactive = 0, short_active = 0, active = 0;
        b.contact_slr_p = (caekf_scalar_t)(k == 0 ? 0.6 : 0.4);
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &b));
        TEST_ASSERT_EQUAL_INT(0, truth_open());
        while (truth_next(&r) == 1 && r.t < 13.5) {
            caekf_report_t rep;
            const caekf_scalar_t y[2] = {(caekf_scalar_t)r.y1, (caekf_scalar_t)r.y4}, u[1] = {(caekf_scalar_t)r.u};
            int on;
            TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, u, y, &rep));
            on = (rep.flags & CAEKF_FLAG_CONTACT_ACTIVE) != 0;
            active += on;
            past_inactive += rep.delta >= 0 && !on;
            short_active += rep.delta < 0 && on;
        }
        truth_close();
        TEST_ASSERT_TRUE(active > 0);
        if (k == 0) {
            TEST_ASSERT_TRUE(past_inactive > 0);
            TEST_ASSERT_EQUAL_INT(0, short_active);
        } else {
            TEST_ASSERT_EQUAL_INT(0, past_inactive);
            TEST_ASSERT_TRUE(short_active > 0);
        }
    }
}

/* Guards ln gamma with gamma_min = 0 while constrained: ln 0 is no bound, so only gamma_max bounds it; the run
 * through contact keeps gamma within (0, gamma_max]. */
static void test_log_gamma_without_a_lower_bound(void)
{
    caekf_settings_t b = good;
    caekf_scalar_t g;
    long active;
    b.model.gamma_log = 1;
    b.gamma_min[0] = 0;
    b.gamma_max[0] = good.gamma0[0] * 2;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &b));
    TEST_ASSERT_EQUAL_UINT32(0u, est.bound_lo);
    TEST_ASSERT_EQUAL_UINT32(1u, est.bound_hi);
    (void)run_until(&est, &b, 20.0, &active);
    TEST_ASSERT_TRUE(active > 0);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_gamma(&est, &g));
    TEST_ASSERT_TRUE(g > 0 && (double)g <= (double)b.gamma_max[0] * (1 + 1e-5));
}

/* Guards law_second_order off: two estimators alike but for it (ln gamma, whose law is nonlinear in its state)
 * predict the same covariance until the first step whose prediction is in contact; there the one with the
 * term has the larger variance on the contact's bodies' velocities (1/2 tr(H P H P) added), and the positions
 * alike. */
static void test_the_second_order_term_only_when_asked(void)
{
    static caekf_t with_copy, without_copy;
    static caekf_scalar_t pw[CAEKF_N][CAEKF_N], po[CAEKF_N][CAEKF_N];
    caekf_settings_t b = good;
    truth_rec_t r;
    int found = 0;
    b.model.gamma_log = 1;
    b.law_second_order = 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &b));
    b.law_second_order = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&other, &b));
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (!found && truth_next(&r) == 1) {
        const caekf_scalar_t u[1] = {(caekf_scalar_t)r.u}, y[2] = {(caekf_scalar_t)r.y1, (caekf_scalar_t)r.y4};
        caekf_report_t rw, ro;
        with_copy = est;
        without_copy = other;
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&with_copy, u, &rw));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&without_copy, u, &ro));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(&with_copy, pw));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(&without_copy, po));
        if (rw.flags & CAEKF_FLAG_CONTACT_ACTIVE) {
            const int a = good.model.contact_a[0] - 1, c = good.model.contact_b[0] - 1;
            found = 1;
            TEST_ASSERT_TRUE(pw[PAPER_NQ + a][PAPER_NQ + a] > po[PAPER_NQ + a][PAPER_NQ + a]);
            TEST_ASSERT_TRUE(pw[PAPER_NQ + c][PAPER_NQ + c] > po[PAPER_NQ + c][PAPER_NQ + c]);
            TEST_ASSERT_TRUE(pw[0][0] == po[0][0]);
        } else {
            TEST_ASSERT_EQUAL_MEMORY(po, pw, sizeof pw);
        }
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, u, y, &rw));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&other, u, y, &ro));
    }
    truth_close();
    TEST_ASSERT_TRUE(found);
}

/* Guards the roll-back of a step whose Newton matrix is not finite: a finite input far beyond the model's
 * range (its force overflows the contact's law) is refused as singular, by one step or over substeps, and
 * the estimate is as it was; the next step with a sane input succeeds. */
static void test_an_input_beyond_the_models_range_is_rolled_back(void)
{
    static caekf_scalar_t P0[CAEKF_N][CAEKF_N], P1[CAEKF_N][CAEKF_N];
    const caekf_scalar_t huge[1] = {(caekf_scalar_t)(CAEKF_USE_FLOAT ? 1e30 : 1e300)}, zero[1] = {0}, y[2] = {0, 0};
    caekf_scalar_t x0[CAEKF_N], x1[CAEKF_N];
    caekf_settings_t b = good;
    int sub;
    for (sub = 0; sub < 2; ++sub) {
        caekf_report_t rep;
        caekf_status_t st;
        b.model.discretisation = sub ? CAEKF_DISCRETISATION_TRAPEZOIDAL : CAEKF_DISCRETISATION_BACKWARD_EULER;
        b.contact_substeps = sub ? 5 : 1;
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &b));
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, zero, y, &rep));
        (void)caekf_get_state(&est, x0);
        (void)caekf_get_covariance(&est, P0);
        st = caekf_step(&est, huge, y, &rep);
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SINGULAR, st);
        TEST_ASSERT_TRUE((rep.flags & CAEKF_FLAG_NUMERIC_ROLLBACK) != 0);
        (void)caekf_get_state(&est, x1);
        (void)caekf_get_covariance(&est, P1);
        TEST_ASSERT_EQUAL_MEMORY(x0, x1, sizeof x0);
        TEST_ASSERT_EQUAL_MEMORY(P0, P1, sizeof P0);
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, zero, y, &rep));
    }
}

/* Refused by validation with this id and reason. */
static void expect_refused(const caekf_settings_t *bad, unsigned param_id, unsigned reason, const char *what)
{
    caekf_setting_error_t err;
    memset(&err, 0xEE, sizeof err);
    TEST_ASSERT_EQUAL_INT_MESSAGE(CAEKF_ERR_SETTINGS, caekf_settings_validate(bad, &err), what);
    TEST_ASSERT_EQUAL_UINT_MESSAGE(param_id, err.param_id, what);
    TEST_ASSERT_EQUAL_UINT_MESSAGE(reason, err.reason, what);
}

/* Guards the law parameters' rules: an initial exponent below its minimum is outside its bounds; with both
 * contacts' initial dampings outside, the first contact's is named; a refused element of an array setting is
 * named with its index in the text. */
static void test_law_parameter_bounds_and_the_first_contact_named(void)
{
    caekf_settings_t b = good;
    caekf_setting_error_t err;
    char text[200];
    b.model.contact_estimate_n[0] = 1;
    b.n0[0] = (caekf_scalar_t)1.2;
    b.sigma_n0[0] = (caekf_scalar_t)0.1;
    b.n_min[0] = (caekf_scalar_t)1.3;
    expect_refused(&b, CAEKF_PARAM_N0, CAEKF_SETTING_OUTSIDE_BOUNDS, "n0 below n_min");
    b = good;
    b.model.contacts = 2;
    b.model.contact_a[1] = 4;
    b.model.contact_b[1] = 0;
    b.gamma0[1] = good.gamma0[0];
    b.sigma_gamma0[1] = good.sigma_gamma0[0];
    b.gamma_min[1] = good.gamma_min[0];
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&b, 0));
    b.model.contact_estimate_lambda[0] = b.model.contact_estimate_lambda[1] = 1;
    b.lambda0[0] = b.lambda0[1] = (caekf_scalar_t)0.2;
    b.sigma_lambda0[0] = b.sigma_lambda0[1] = (caekf_scalar_t)0.05;
    b.lambda_max[0] = b.lambda_max[1] = (caekf_scalar_t)0.1;
    expect_refused(&b, CAEKF_PARAM_LAMBDA0, CAEKF_SETTING_OUTSIDE_BOUNDS, "both dampings above their maximum");
    b.lambda_max[0] = (caekf_scalar_t)0.3; /* the second contact's alone */
    expect_refused(&b, CAEKF_PARAM_LAMBDA0 + 1, CAEKF_SETTING_OUTSIDE_BOUNDS, "the second damping");
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&b, &err));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_error_text(&err, &b, text, sizeof text));
    TEST_ASSERT_NOT_NULL_MESSAGE(strstr(text, "lambda0[1] = 0.2"), text);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_a_link_written_ground_first_estimates_the_same);
    RUN_TEST(test_sensors_at_ground_stops_with_a_force_and_a_base_input);
    RUN_TEST(test_a_force_and_a_base_input_backward_euler);
    RUN_TEST(test_a_force_and_a_base_input_trapezoidal);
    RUN_TEST(test_a_force_and_a_base_input_estimated_through_contact);
    RUN_TEST(test_a_measured_input_and_an_uncertain_mass_trapezoidal);
    RUN_TEST(test_paper_switch_off_one_and_three_sensors_and_joseph);
    RUN_TEST(test_the_constraint_flushes_a_tiny_covariance_after_gamma);
    RUN_TEST(test_newtons_iteration_cap);
    RUN_TEST(test_slr_switch_on_either_side_of_one_half);
    RUN_TEST(test_log_gamma_without_a_lower_bound);
    RUN_TEST(test_law_parameter_bounds_and_the_first_contact_named);
    RUN_TEST(test_the_second_order_term_only_when_asked);
    RUN_TEST(test_an_input_beyond_the_models_range_is_rolled_back);
    return UNITY_END();
}
