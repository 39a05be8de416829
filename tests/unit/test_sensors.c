/* The sensors of real rigs (docs/sensors.md): each kind's row of H (acceleration, relative position, link
 * force, an estimated offset) against central differences of what it reads, with the contact closed and
 * every kind of parameter state present (gamma or ln gamma, n, lambda, gap, a mass, a stiffness, a damper,
 * an offset); and the correction with rows of H equal, bit for bit, to the one with each sensor reading
 * one state when the rows are those unit rows. */
#include <math.h>
#include <string.h>

#include "caekf_filter.h"
#include "caekf_model_internal.h"
#include "test_support.h"
#include "unity.h"

static caekf_settings_t settings;
static caekf_model_t model;
static const caekf_scalar_t u_now[1] = {(caekf_scalar_t)0.3};

void setUp(void) {}
void tearDown(void) {}

/* The paper's chain, damped contact (2-3) with n, lambda and gap estimated, body 2's mass and link 2's
 * stiffness and damper uncertain, and four sensors: body 2's acceleration, body 3 relative to body 2, the
 * force in link 2 and body 1's position with an offset. */
static void rig(int gamma_log)
{
    paper_settings(&settings, EXP_SWITCHED);
    settings.model.gamma_log = gamma_log;
    settings.model.contact_lambda[0] = (caekf_scalar_t)0.4;
    settings.model.contact_estimate_n[0] = 1;
    settings.model.contact_estimate_lambda[0] = 1;
    settings.model.contact_estimate_gap[0] = 1;
    settings.model.m_sigma[1] = (caekf_scalar_t)0.03;
    settings.model.spring_k_sigma[1] = (caekf_scalar_t)0.03;
    settings.model.spring_c_sigma[1] = (caekf_scalar_t)0.03;
    settings.model.sensors = 4;
    settings.model.sensor_kind[0] = CAEKF_SENSOR_ACCELERATION;
    settings.model.sensor_body[0] = 2;
    settings.model.sensor_kind[1] = CAEKF_SENSOR_RELATIVE;
    settings.model.sensor_body[1] = 3;
    settings.model.sensor_ref[1] = 2;
    settings.model.sensor_kind[2] = CAEKF_SENSOR_LINK_FORCE;
    settings.model.sensor_link[2] = 2;
    settings.model.sensor_body[2] = 1; /* read by no kind but position, velocity and acceleration */
    settings.model.sensor_kind[3] = CAEKF_SENSOR_POSITION;
    settings.model.sensor_body[3] = 1;
    settings.model.sensor_bias_sigma[3] = (caekf_scalar_t)1e-6;
    TEST_ASSERT_EQUAL_INT(0, caekf_model_init(&model, &settings.model));
    TEST_ASSERT_EQUAL_INT(9 + 3 + 3 + 1, model.n);
    TEST_ASSERT_EQUAL_INT(1, model.nb);
    TEST_ASSERT_EQUAL_INT(15, model.sensor_bias[3]);
}

/* A moving state with the contact closed by 2 um, the parameters off their settings. */
static void rig_state(caekf_scalar_t x[CAEKF_N], int gamma_log)
{
    const caekf_scalar_t mult[3] = {(caekf_scalar_t)1.02, (caekf_scalar_t)0.97, (caekf_scalar_t)1.05};
    paper_moving_state(x, 0.0, 2e-6, 1.1e8);
    if (gamma_log) {
        x[8] = (caekf_scalar_t)log(1.1e8);
    }
    x[9] = (caekf_scalar_t)1.45;   /* n */
    x[10] = (caekf_scalar_t)0.35;  /* lambda */
    x[11] = (caekf_scalar_t)1e-7;  /* gap */
    x[12] = (caekf_scalar_t)0.02;  /* ln(m2 / setting) */
    x[13] = (caekf_scalar_t)-0.03; /* ln(k2 / setting) */
    x[14] = (caekf_scalar_t)0.05;  /* ln(c2 / setting) */
    x[15] = (caekf_scalar_t)3e-7;  /* body 1's sensor offset */
    TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&model, &settings.model, mult));
    x[12] = (caekf_scalar_t)log(1.02);
    x[13] = (caekf_scalar_t)log(0.97);
    x[14] = (caekf_scalar_t)log(1.05);
}

/* Sensor k's value at x with state j moved by d, the mechanism parameters' moves applied to the model. */
static double value_at(const caekf_scalar_t *x0, int k, int j, double d)
{
    caekf_scalar_t x[CAEKF_N], row[CAEKF_N], mult[3], v;
    int i;
    for (i = 0; i < CAEKF_N; ++i) {
        x[i] = x0[i];
    }
    x[j] = (caekf_scalar_t)((double)x[j] + d);
    for (i = 0; i < 3; ++i) {
        mult[i] = (caekf_scalar_t)exp((double)x[12 + i]);
    }
    TEST_ASSERT_EQUAL_INT(0, caekf_model_set_mech(&model, &settings.model, mult));
    caekf_model_sensor(&model, &settings.model, k, x, u_now, u_now, &v, row);
    return (double)v;
}

/* Every entry of every sensor's row against (h(x + d e_j) - h(x - d e_j)) / 2d. */
static void check_rows(int gamma_log)
{
    static const double step[16] = {1e-12, 1e-12, 1e-12, 1e-12, 1e-9, 1e-9, 1e-9, 1e-9,
                                    0,     1e-7,  1e-7,  1e-13, 1e-7, 1e-7, 1e-7, 1e-12};
    caekf_scalar_t x[CAEKF_N], row[CAEKF_N], v;
    int k, j;
    if (CAEKF_USE_FLOAT) {
        TEST_IGNORE_MESSAGE("central differences: the double build checks them");
    }
    rig(gamma_log);
    rig_state(x, gamma_log);
    for (k = 0; k < 4; ++k) {
        double big = 0;
        (void)value_at(x, k, 0, 0.0); /* the model at x's mechanism parameters */
        caekf_model_sensor(&model, &settings.model, k, x, u_now, u_now, &v, row);
        for (j = 0; j < model.n; ++j) { /* the row's size: its entries times their steps */
            const double d = j == 8 ? (gamma_log ? 1e-7 : 1.0) : step[j];
            big = fmax(big, fabs((double)row[j]) * d);
        }
        for (j = 0; j < model.n; ++j) {
            const double d = j == 8 ? (gamma_log ? 1e-7 : 1.0) : step[j];
            const double fd = (value_at(x, k, j, d) - value_at(x, k, j, -d)) / (2 * d);
            TEST_ASSERT_DOUBLE_WITHIN(1e-6 * big / d + 1e-7 * fabs(fd), fd, (double)row[j]);
        }
    }
}

static void test_rows_match_central_differences(void) { check_rows(0); }
static void test_rows_match_central_differences_with_ln_gamma(void) { check_rows(1); }

/* What each kind reads, written out for the rig's state. */
static void test_values_are_what_each_kind_reads(void)
{
    caekf_scalar_t x[CAEKF_N], row[CAEKF_N], v;
    double k2, c2;
    int a, b;
    rig(0);
    rig_state(x, 0);
    k2 = (double)settings.model.spring_k[1] * 0.97;
    c2 = (double)settings.model.spring_c[1] * 1.05;
    a = settings.model.spring_a[1] - 1;
    b = settings.model.spring_b[1] - 1;
    caekf_model_sensor(&model, &settings.model, 1, x, u_now, u_now, &v, row);
    TEST_ASSERT_EQUAL_DOUBLE((double)(x[2] - x[1]), (double)v);
    caekf_model_sensor(&model, &settings.model, 2, x, u_now, u_now, &v, row);
    TEST_ASSERT_DOUBLE_WITHIN((CAEKF_USE_FLOAT ? 1e-5 : 1e-9) * fabs((double)v),
                              k2 * ((a >= 0 ? (double)x[a] : 0) - (b >= 0 ? (double)x[b] : 0)) +
                                  c2 * ((a >= 0 ? (double)x[4 + a] : 0) - (b >= 0 ? (double)x[4 + b] : 0)),
                              (double)v);
    caekf_model_sensor(&model, &settings.model, 3, x, u_now, u_now, &v, row);
    TEST_ASSERT_EQUAL_DOUBLE((double)(x[0] + x[15]), (double)v);
}

/* The correction with unit rows of H is the selection's, bit for bit (standard and Joseph). */
static void check_unit_rows(int joseph)
{
    paper_mat_t P0, Pa, Pb;
    caekf_scalar_t za[CAEKF_N], zb[CAEKF_N], nis_a = 0, nis_b = 0;
    const caekf_scalar_t y[2] = {(caekf_scalar_t)0.7, (caekf_scalar_t)-0.4};
    caekf_filter_dims_t d;
    static caekf_correct_work_t wa, wb;
    uint32_t fa = 0, fb = 0;
    int i, k;
    test_spd_matrix(P0);
    memcpy(Pa, P0, sizeof Pa);
    memcpy(Pb, P0, sizeof Pb);
    for (i = 0; i < CAEKF_N; ++i) {
        za[i] = zb[i] = (caekf_scalar_t)(0.1 * i - 0.3);
    }
    paper_filter_dims(&d, (caekf_scalar_t)0.01, CAEKF_GAMMA_LIVE);
    TEST_ASSERT_EQUAL_INT(0, caekf_correct_upper(za, &Pa[0][0], y, joseph, &d, 0, &nis_a, &fa, &wa));
    memset(&wb, 0, sizeof wb);
    for (k = 0; k < 2; ++k) {
        wb.row[k][d.h[k]] = 1;
        wb.hx[k] = zb[d.h[k]];
    }
    d.rows = 1;
    TEST_ASSERT_EQUAL_INT(0, caekf_correct_upper(zb, &Pb[0][0], y, joseph, &d, 0, &nis_b, &fb, &wb));
    TEST_ASSERT_EQUAL_MEMORY(za, zb, sizeof(caekf_scalar_t) * PAPER_N);
    TEST_ASSERT_EQUAL_MEMORY(Pa, Pb, sizeof Pa);
    TEST_ASSERT_EQUAL_MEMORY(&nis_a, &nis_b, sizeof nis_a);
    TEST_ASSERT_EQUAL_UINT32(fa, fb);
}

static void test_unit_rows_are_the_selection(void) { check_unit_rows(0); }
static void test_unit_rows_are_the_selection_joseph(void) { check_unit_rows(1); }

/* Settings the sensors need: an acceleration's own sigma, a relative sensor's other body, a real link. */
static void test_validation_names_the_sensor_setting(void)
{
    caekf_setting_error_t err;
    rig(0);
    settings.model.contact_estimate_n[0] = settings.model.contact_estimate_lambda[0] = 0; /* theirs: elsewhere */
    settings.model.contact_estimate_gap[0] = 0;
    settings.sensor_sigma[0] = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&settings, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_SENSOR_SIGMA, err.param_id);
    settings.sensor_sigma[0] = (caekf_scalar_t)0.01;
    settings.sensor_sigma[2] = (caekf_scalar_t)0.1;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_settings_validate(&settings, &err));
    settings.model.sensor_ref[1] = 3;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&settings, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_SENSOR_REF + 1, err.param_id);
    settings.model.sensor_ref[1] = 2;
    settings.model.sensor_link[2] = (int)settings.model.springs + 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_SETTINGS, caekf_settings_validate(&settings, &err));
    TEST_ASSERT_EQUAL_UINT(CAEKF_PARAM_SENSOR_LINK + 2, err.param_id);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_rows_match_central_differences);
    RUN_TEST(test_rows_match_central_differences_with_ln_gamma);
    RUN_TEST(test_values_are_what_each_kind_reads);
    RUN_TEST(test_unit_rows_are_the_selection);
    RUN_TEST(test_unit_rows_are_the_selection_joseph);
    RUN_TEST(test_validation_names_the_sensor_setting);
    return UNITY_END();
}
