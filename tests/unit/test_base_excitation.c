/* Base excitation (setting input{i}_kind = base_displacement; docs/mechanism.md "Base excitation"): an input that
 * moves a link's ground end by u [m] adds k u + c du/dt on the link's body, discretised in the step as
 * k u_k + c (u_k - u_{k-1}) / dt (backward Euler) or k (u_k + u_{k-1}) / 2 + c (u_k - u_{k-1}) / dt (trapezoidal).
 * Checked: a body riding on the table stays on it (exact for both rules); the step's derivatives in u_k and
 * u_{k-1}, the input columns (the gain of an error held over the step) and the mechanism's columns against
 * central differences of the Newton step itself; the measured input's process noise; what an accelerometer
 * and a load cell in the driven link read; the validation of the link. */
#include <math.h>
#include <string.h>

#include "caekf_model_internal.h"
#include "test_support.h"
#include "unity.h"

#define NQ PAPER_NQ
#define NM 3 /* body 1's mass, link 1's stiffness and damper: the driven link's */
/* Relative tolerance of a result written out here, and the Newton test's, in the build's scalar. */
#define REL (CAEKF_USE_FLOAT ? 1e-5 : 1e-12)
#define NEWTON_RTOL ((caekf_scalar_t)(256 * CAEKF_EPS))

static caekf_settings_t settings;
static caekf_model_t model;
/* the table's displacement at the step's start and end [m] */
static const caekf_scalar_t u_prev[1] = {(caekf_scalar_t)2e-4}, u_now[1] = {(caekf_scalar_t)3e-4};

void setUp(void) {}
void tearDown(void) {}

/* The paper's chain on a shaker table: link 1 (body 1 - ground) driven at its ground end by input 1; with
 * `uncertain`, body 1's mass and link 1's stiffness and damper declared uncertain (3 %). */
static void shaker(int discretisation, int uncertain)
{
    paper_settings(&settings, EXP_SWITCHED);
    settings.model.discretisation = discretisation;
    settings.model.input_kind[0] = CAEKF_INPUT_BASE_DISPLACEMENT;
    settings.model.input_link[0] = 1;
    settings.model.input_body[0] = 3; /* unused for a base input: the link says the body */
    if (uncertain) {
        settings.model.m_sigma[0] = (caekf_scalar_t)0.03;
        settings.model.spring_k_sigma[0] = (caekf_scalar_t)0.03;
        settings.model.spring_c_sigma[0] = (caekf_scalar_t)0.03;
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&settings, 0));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&model, &settings.model));
    TEST_ASSERT_EQUAL_INT(1, model.p.input_body[0]);
}

/* The step from xp with the mechanism's parameters at mult (NULL: the settings') and the inputs up, u: x_k. */
static void step_at(const caekf_scalar_t *xp, const caekf_scalar_t *mult, const caekf_scalar_t *up,
                    const caekf_scalar_t *u, caekf_scalar_t xk[CAEKF_N])
{
    caekf_scalar_t work[4 * CAEKF_NQ], ones[NM] = {1, 1, 1};
    int it;
    if (model.nm > 0) {
        TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&model, &settings.model, mult != 0 ? mult : ones));
    }
    TEST_ASSERT_EQUAL_INT(
        0, caekf_model_newton(&model, xp, up, u, CAEKF_NEWTON_MAX_ITER, (caekf_scalar_t)1e-15, xk, &it, work));
    if (model.nm > 0) {
        TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&model, &settings.model, ones));
    }
}

/* The velocities' central difference (a - b) / span against s times the column col (leading dimension ld),
 * within 1e-5 of the difference's largest entry. */
static void check_column(const caekf_scalar_t *a, const caekf_scalar_t *b, double span, const caekf_scalar_t *col,
                         int ld, double s)
{
    const double err = test_fd_column_error(a, b, NQ, span, col, ld, s);
    TEST_ASSERT_TRUE(err >= 0);
    TEST_ASSERT_DOUBLE_WITHIN(1e-5, 0.0, err);
}

/* A body on a spring-damper to the table (no contact), riding on it: q = u, v = the table's speed w. The
 * table moving at constant speed keeps it there, exactly, by either rule: the step's k u and c du/dt balance
 * the link's k q and c v (a dropped or mis-signed term moves it off). */
static void check_riding(int discretisation)
{
    const double w = 1e-2, t0 = 0.37, dt = 1e-3;
    caekf_scalar_t xp[CAEKF_N] = {0}, xk[CAEKF_N], work[4 * CAEKF_NQ];
    caekf_scalar_t up[1], u[1];
    int it;
    paper_settings(&settings, EXP_SWITCHED);
    settings.model.discretisation = discretisation;
    settings.model.dt = (caekf_scalar_t)dt;
    settings.model.bodies = 1;
    settings.model.m[0] = (caekf_scalar_t)0.5;
    settings.model.springs = 1;
    settings.model.spring_a[0] = 0; /* the ground end first: the body is end b */
    settings.model.spring_b[0] = 1;
    settings.model.spring_k[0] = (caekf_scalar_t)1e3;
    settings.model.spring_c[0] = (caekf_scalar_t)2;
    settings.model.input_kind[0] = CAEKF_INPUT_BASE_DISPLACEMENT;
    settings.model.input_link[0] = 1;
    settings.model.sensors = 1;
    settings.model.sensor_body[0] = 1;
    settings.model.contacts = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&settings, 0));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&model, &settings.model));
    up[0] = (caekf_scalar_t)(w * t0);
    u[0] = (caekf_scalar_t)(w * (t0 + dt));
    xp[0] = up[0];
    xp[1] = (caekf_scalar_t)w;
    TEST_ASSERT_EQUAL_INT(0, caekf_model_newton(&model, xp, up, u, CAEKF_NEWTON_MAX_ITER, NEWTON_RTOL, xk, &it, work));
    TEST_ASSERT_DOUBLE_WITHIN(REL * w, w, (double)xk[1]);
    TEST_ASSERT_DOUBLE_WITHIN(REL * (double)u[0], (double)u[0], (double)xk[0]);
}

static void test_a_body_riding_the_table_stays_on_it_backward_euler(void)
{
    check_riding(CAEKF_DISCRETISATION_BACKWARD_EULER);
}

static void test_a_body_riding_the_table_stays_on_it_trapezoidal(void)
{
    check_riding(CAEKF_DISCRETISATION_TRAPEZOIDAL);
}

/* From a moving state with penetration delta (<= 0: open): the step's derivative in u_k alone, in u_{k-1}
 * alone, in both together (an error held over the step: the input columns, per end that takes it) and in the
 * mechanism's parameters' logarithms, against central differences of the Newton step. With g = A^-1 k e_1
 * (the input column), the step's residual says dv_k/du_k = g (k + c/hs) / k and dv_k/du_{k-1} = g (k [the
 * trapezoidal rule] - c/hs) / k. */
static void check_columns(int discretisation, double delta)
{
    caekf_scalar_t xp[CAEKF_N], xk[CAEKF_N], fv[CAEKF_NQ][CAEKF_N], g[CAEKF_NQ][CAEKF_MAX_INPUTS];
    caekf_contact_t ct[CAEKF_MAX_CONTACTS + 1];
    const int trap = discretisation == CAEKF_DISCRETISATION_TRAPEZOIDAL;
    const double hu = 1e-7, hm = 1e-6;
    double k, c_hs;
    int i, j, first;
    if (CAEKF_USE_FLOAT) { /* the float Newton step stops at 256 eps: its differences say nothing at this step */
        TEST_IGNORE_MESSAGE("central differences of the step: the double build checks them");
    }
    shaker(discretisation, 1);
    TEST_ASSERT_EQUAL_INT(NM, model.nm);
    first = model.n - model.nm;
    k = (double)settings.model.spring_k[0];
    c_hs = (double)settings.model.spring_c[0] / (double)model.hs;
    paper_moving_state(xp, 1.0e-3, delta, 1.1e8);
    step_at(xp, 0, u_prev, u_now, xk);
    caekf_model_contact(&model, 0, xk, &ct[0]);
    TEST_ASSERT_EQUAL_INT(delta > 0, ct[0].delta > 0); /* the contact at the step's end, as at its start */
    TEST_ASSERT_EQUAL_INT(0, caekf_model_mech_columns(&model, ct, xp, xk, u_prev, u_now, 0, fv));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_input_columns(&model, ct, g));
    {
        const caekf_scalar_t upp[1] = {u_prev[0] + (caekf_scalar_t)hu}, upm[1] = {u_prev[0] - (caekf_scalar_t)hu};
        const caekf_scalar_t ukp[1] = {u_now[0] + (caekf_scalar_t)hu}, ukm[1] = {u_now[0] - (caekf_scalar_t)hu};
        caekf_scalar_t a[CAEKF_N], b[CAEKF_N];
        step_at(xp, 0, u_prev, ukp, a); /* u_k */
        step_at(xp, 0, u_prev, ukm, b);
        check_column(a, b, 2 * hu, &g[0][0], CAEKF_MAX_INPUTS, (k + c_hs) / k);
        step_at(xp, 0, upp, u_now, a); /* u_{k-1} */
        step_at(xp, 0, upm, u_now, b);
        check_column(a, b, 2 * hu, &g[0][0], CAEKF_MAX_INPUTS, ((trap ? k : 0) - c_hs) / k);
        step_at(xp, 0, upp, ukp, a); /* both: the damper's terms cancel, k per end that takes it */
        step_at(xp, 0, upm, ukm, b);
        check_column(a, b, 2 * hu, &g[0][0], CAEKF_MAX_INPUTS, trap ? 2 : 1);
    }
    for (j = 0; j < NM; ++j) { /* d v_k / d ln(value_j): the link's columns carry k (q_1 - u), c (v_1 - du/dt) */
        caekf_scalar_t mult[NM], a[CAEKF_N], b[CAEKF_N];
        for (i = 0; i < NM; ++i) {
            mult[i] = 1;
        }
        mult[j] = (caekf_scalar_t)exp(hm);
        step_at(xp, mult, u_prev, u_now, a);
        mult[j] = (caekf_scalar_t)exp(-hm);
        step_at(xp, mult, u_prev, u_now, b);
        check_column(a, b, 2 * hm, &fv[0][first + j], CAEKF_N, 1.0);
    }
}

/* In contact (closed at both ends of the step) and open. */
static void test_columns_match_the_step_backward_euler(void)
{
    check_columns(CAEKF_DISCRETISATION_BACKWARD_EULER, 2e-6);
    check_columns(CAEKF_DISCRETISATION_BACKWARD_EULER, -5e-6);
}

static void test_columns_match_the_step_trapezoidal(void)
{
    check_columns(CAEKF_DISCRETISATION_TRAPEZOIDAL, 5e-6);
    check_columns(CAEKF_DISCRETISATION_TRAPEZOIDAL, -5e-6);
}

/* A measured table displacement's noise (input1_sigma [m]): one prediction adds sigma_u^2 G G^T to the bodies'
 * covariance, G = dx_k / du of an error held over the step (the first step holds u: both ends move), here by
 * central differences of the Newton step. Two instances alike but for the input's sigma, in physical units
 * (the accessors); nothing else moves. */
static void check_input_noise(int discretisation)
{
    static caekf_t with, without;
    static caekf_scalar_t p_with[CAEKF_N][CAEKF_N], p_without[CAEKF_N][CAEKF_N];
    caekf_scalar_t x0[CAEKF_N], up[CAEKF_N], um[CAEKF_N], x_with[CAEKF_N], x_without[CAEKF_N], work[4 * CAEKF_NQ];
    const double u = 3e-4, h = 1e-7, var = 4e-12; /* sigma_u = 2 um */
    const caekf_scalar_t uk[1] = {(caekf_scalar_t)u}, uhi[1] = {(caekf_scalar_t)(u + h)},
                         ulo[1] = {(caekf_scalar_t)(u - h)};
    double G[CAEKF_N] = {0}, big = 0, worst = 0; /* G: the bodies' states (the gamma's row stays 0) */
    int i, it;
    if (CAEKF_USE_FLOAT) {
        TEST_IGNORE_MESSAGE("central differences of the step: the double build checks them");
    }
    shaker(discretisation, 0);
    settings.v0[0] = (caekf_scalar_t)1e-3;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&without, &settings));
    settings.input_sigma[0] = (caekf_scalar_t)sqrt(var);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&with, &settings));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&with, x0));
    TEST_ASSERT_EQUAL_INT(
        0, caekf_model_newton(&with.model, x0, uhi, uhi, CAEKF_NEWTON_MAX_ITER, (caekf_scalar_t)1e-15, up, &it, work));
    TEST_ASSERT_EQUAL_INT(
        0, caekf_model_newton(&with.model, x0, ulo, ulo, CAEKF_NEWTON_MAX_ITER, (caekf_scalar_t)1e-15, um, &it, work));
    for (i = 0; i < 2 * NQ; ++i) { /* physical: [m, m/s] per m */
        G[i] = ((double)up[i] - (double)um[i]) / (2 * h);
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&with, uk, 0));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_predict(&without, uk, 0));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(&with, p_with));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_covariance(&without, p_without));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&with, x_with));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&without, x_without));
    TEST_ASSERT_EQUAL_MEMORY(x_without, x_with, sizeof x_with);
    for (i = 0; i < with.model.n * with.model.n; ++i) { /* every entry, row-major */
        const int r = i / with.model.n, c = i % with.model.n;
        const double added = (double)p_with[r][c] - (double)p_without[r][c];
        big = fmax(big, var * G[r] * G[r]);
        worst = fmax(worst, fabs(added - var * G[r] * G[c]));
    }
    TEST_ASSERT_TRUE(big > 0);
    TEST_ASSERT_TRUE(worst <= 1e-5 * big);
}

static void test_input_noise_is_the_held_step_gain_squared_backward_euler(void)
{
    check_input_noise(CAEKF_DISCRETISATION_BACKWARD_EULER);
}

static void test_input_noise_is_the_held_step_gain_squared_trapezoidal(void)
{
    check_input_noise(CAEKF_DISCRETISATION_TRAPEZOIDAL);
}

/* An accelerometer on body 1 and a load cell in link 1 read the table: (k (u - q_1) + c (du/dt - v_1) - k12 (q_1 -
 * q_2) - c12 (v_1 - v_2)) / m_1 and k (q_1 - u) + c (v_1 - du/dt), du/dt = (u - u_prev) / dt, written out here;
 * their columns for ln k and ln c carry the table too (central differences of the reading in the value). */
static void test_sensors_read_the_table(void)
{
    caekf_scalar_t x[CAEKF_N], row[CAEKF_N], v_acc, v_cell;
    const caekf_model_params_t *p = &settings.model;
    double du, acc, cell;
    int j;
    shaker(CAEKF_DISCRETISATION_TRAPEZOIDAL, 1);
    settings.model.sensors = 2;
    settings.model.sensor_kind[0] = CAEKF_SENSOR_ACCELERATION;
    settings.model.sensor_body[0] = 1;
    settings.model.sensor_kind[1] = CAEKF_SENSOR_LINK_FORCE;
    settings.model.sensor_link[1] = 1;
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&model, &settings.model));
    paper_moving_state(x, 1.0e-3, -5e-6, 1.1e8);
    du = ((double)u_now[0] - (double)u_prev[0]) / (double)p->dt;
    acc = ((double)p->spring_k[0] * ((double)u_now[0] - (double)x[0]) + (double)p->spring_c[0] * (du - (double)x[NQ]) -
           (double)p->spring_k[1] * ((double)x[0] - (double)x[1]) -
           (double)p->spring_c[1] * ((double)x[NQ] - (double)x[NQ + 1])) /
          (double)p->m[0];
    cell = (double)p->spring_k[0] * ((double)x[0] - (double)u_now[0]) + (double)p->spring_c[0] * ((double)x[NQ] - du);
    caekf_model_sensor(&model, p, 0, x, u_now, u_prev, &v_acc, row);
    TEST_ASSERT_DOUBLE_WITHIN(1e3 * REL * fabs(acc), acc, (double)v_acc);
    caekf_model_sensor(&model, p, 1, x, u_now, u_prev, &v_cell, row);
    TEST_ASSERT_DOUBLE_WITHIN(1e3 * REL * fabs(cell), cell, (double)v_cell);
    /* ln k1, ln c1: d reading / d ln(value) = the link's own term, table included (central differences in
     * ln(value): the double build checks them) */
    for (j = 1; j < NM && !CAEKF_USE_FLOAT; ++j) {
        caekf_scalar_t mult[NM] = {1, 1, 1}, ra[CAEKF_N], hp, hm;
        int s;
        for (s = 0; s < 2; ++s) {
            double col;
            caekf_model_sensor(&model, p, s, x, u_now, u_prev, &hp, row);
            col = (double)row[model.n - NM + j];
            mult[j] = (caekf_scalar_t)exp(1e-6);
            TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&model, p, mult));
            caekf_model_sensor(&model, p, s, x, u_now, u_prev, &hp, ra);
            mult[j] = (caekf_scalar_t)exp(-1e-6);
            TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&model, p, mult));
            caekf_model_sensor(&model, p, s, x, u_now, u_prev, &hm, ra);
            mult[j] = 1;
            TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&model, p, mult));
            TEST_ASSERT_TRUE(col != 0);
            TEST_ASSERT_DOUBLE_WITHIN(1e-6 * fabs(col), ((double)hp - (double)hm) / 2e-6, col);
        }
    }
}

/* Validation names the base input's link, with its own reason, and the text says the rule. */
static void expect_bad_link(unsigned param_id, const char *name)
{
    caekf_setting_error_t err;
    char text[200];
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&settings, &err));
    TEST_ASSERT_EQUAL_UINT8(CAEKF_SETTING_BAD_LINK, err.reason);
    TEST_ASSERT_EQUAL_UINT8(param_id, err.param_id);
    TEST_ASSERT_EQUAL_INT(-1, caekf_model_init(&model, &settings.model));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_setting_error_text(&err, &settings, text, sizeof text));
    TEST_ASSERT_NOT_NULL(strstr(text, name));
    TEST_ASSERT_NOT_NULL(strstr(text, "ground"));
}

static void test_the_link_must_have_a_ground_end(void)
{
    shaker(CAEKF_DISCRETISATION_TRAPEZOIDAL, 0);
    settings.model.input_link[0] = 2; /* bodies 1 and 2 */
    expect_bad_link(CAEKF_PARAM_INPUT_LINK, "input_link[0]");
    settings.model.input_link[0] = 5; /* the paper has 4 links */
    expect_bad_link(CAEKF_PARAM_INPUT_LINK, "input_link[0]");
    settings.model.input_link[0] = 4; /* body 4 - ground: fine, and its body is 4 */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&settings, 0));
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&model, &settings.model));
    TEST_ASSERT_EQUAL_INT(4, model.p.input_body[0]);
    settings.model.inputs = 2; /* a second base input on the same link */
    settings.model.input_kind[1] = CAEKF_INPUT_BASE_DISPLACEMENT;
    settings.model.input_link[1] = 4;
    expect_bad_link(CAEKF_PARAM_INPUT_LINK + 1, "input_link[1]");
    settings.model.input_kind[1] = CAEKF_INPUT_FORCE; /* a force beside it: its body is checked again */
    settings.model.input_body[1] = 5;
    {
        caekf_setting_error_t err;
        TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&settings, &err));
        TEST_ASSERT_EQUAL_UINT8(CAEKF_SETTING_BAD_BODY, err.reason);
        TEST_ASSERT_EQUAL_UINT8(CAEKF_PARAM_INPUT_BODY + 1, err.param_id);
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_a_body_riding_the_table_stays_on_it_backward_euler);
    RUN_TEST(test_a_body_riding_the_table_stays_on_it_trapezoidal);
    RUN_TEST(test_columns_match_the_step_backward_euler);
    RUN_TEST(test_columns_match_the_step_trapezoidal);
    RUN_TEST(test_input_noise_is_the_held_step_gain_squared_backward_euler);
    RUN_TEST(test_input_noise_is_the_held_step_gain_squared_trapezoidal);
    RUN_TEST(test_sensors_read_the_table);
    RUN_TEST(test_the_link_must_have_a_ground_end);
    return UNITY_END();
}
