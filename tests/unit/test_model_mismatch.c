/* The model-mismatch monitor (settings mismatch_window, mismatch_ratio, mismatch_adapt; docs/mismatch.md):
 * the mean NIS per sensor it keeps follows its formula, an exact model is never flagged and its estimate
 * is unchanged, a spring 3 % off (k1) is flagged, the adapted Q_x lets the gate go, and a refused step leaves
 * the monitor as it was. The paper's noise-free truth (its filter model is exact). */
#include <math.h>
#include <string.h>

#include "test_support.h"
#include "unity.h"

#define IG PAPER_IG
/* The monitor's mean against the formula in double: its own scalar's rounding over 60,000 steps. */
#define MEAN_TOL (CAEKF_USE_FLOAT ? 1e-2 : 1e-9)
/* Steps whose flag may differ from the formula's in double: float's mean can sit on the other side of the ratio. */
#define FLAG_TOL (CAEKF_USE_FLOAT ? 100 : 0)

void setUp(void) {}
void tearDown(void) {}

typedef struct {
    long steps, flagged, gated_late; /* steps; steps flagged MODEL_MISMATCH; gated in the last 10 s */
    long flag_wrong;                 /* steps whose MODEL_MISMATCH flag is not the formula's */
    uint32_t last_flags;
    double nis_mean, q_scale; /* at the end */
    double mean_ref_err;      /* largest |caekf_get_mismatch's mean - the formula's from rep.nis| */
    double q_ref_err;         /* largest relative |caekf_get_mismatch's q_scale - the formula's| */
    caekf_scalar_t x[CAEKF_N];
} mm_run_t;

/* The paper's switched filter with the monitor set as given, spring 1 (k1, body 1 to the ground: it sets the quasi-static positions) of the filter's model
 * multiplied by k1_factor, over the paper's truth. The test recomputes the monitor's mean from each
 * step's reported NIS, in double. */
static mm_run_t run(int window, double ratio, int adapt, double k1_factor)
{
    static caekf_t est;
    caekf_settings_t s;
    mm_run_t res;
    truth_rec_t r;
    double mean = 1, q = 1;
    memset(&res, 0, sizeof res);
    paper_settings(&s, EXP_SWITCHED);
    s.mismatch_window = window;
    s.mismatch_ratio = (caekf_scalar_t)ratio;
    s.mismatch_adapt = adapt;
    s.model.spring_k[0] = (caekf_scalar_t)((double)s.model.spring_k[0] * k1_factor);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &s));
    TEST_ASSERT_EQUAL_INT(0, truth_open());
    while (truth_next(&r) == 1) {
        const caekf_scalar_t y[2] = {(caekf_scalar_t)r.y1, (caekf_scalar_t)r.y4};
        caekf_report_t rep;
        caekf_scalar_t m, qs;
        const caekf_status_t st = caekf_step(&est, (const caekf_scalar_t[]){(caekf_scalar_t)r.u}, y, &rep);
        TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_mismatch(&est, &m, &qs));
        if (st != CAEKF_OK) { /* a wrong model may drive float into a rolled-back step: the monitor kept */
            TEST_ASSERT_TRUE(st == CAEKF_ERR_SINGULAR || st == CAEKF_ERR_NUMERIC);
            TEST_ASSERT_TRUE(res.steps == 0 || ((double)m == res.nis_mean && (double)qs == res.q_scale));
            res.steps++;
            continue;
        }
        if (window > 0 && !(rep.flags & CAEKF_FLAG_SINGULAR_INNOVATION)) { /* a correction was computed */
            mean += (fmin((double)rep.nis / 2, 100.0) - mean) / window;
            res.mean_ref_err = fmax(res.mean_ref_err, fabs((double)m - mean) / fmax(mean, 1.0));
            if (adapt && (q > 1 || mean > ratio)) { /* Q_x's factor: q (1 + (mean - 1) / window) within [1, 1e12] */
                q = fmin(fmax(q * (1 + (mean - 1) / window), 1.0), 1e12);
            }
            res.q_ref_err = fmax(res.q_ref_err, fabs((double)qs - q) / q);
        }
        if (window > 0) {
            res.flag_wrong += ((rep.flags & CAEKF_FLAG_MODEL_MISMATCH) != 0) != (mean > ratio || q > 1);
        }
        res.flagged += (rep.flags & CAEKF_FLAG_MODEL_MISMATCH) != 0;
        res.gated_late += res.steps >= paper_steps() - 10000 && (rep.flags & CAEKF_FLAG_GAMMA_GATED) != 0;
        res.last_flags = rep.flags;
        res.nis_mean = (double)m;
        res.q_scale = (double)qs;
        res.steps++;
    }
    truth_close();
    TEST_ASSERT_EQUAL_INT32(paper_steps(), res.steps);
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_state(&est, res.x));
    return res;
}

static void test_the_mean_follows_its_formula(void)
{
    /* Spring 3 % off: the NIS is far above the clip for long stretches, so the clip is exercised too. */
    const mm_run_t wrong = run(500, 3.0, 0, 1.03);
    TEST_ASSERT_TRUE(wrong.nis_mean > 3.0);
    TEST_ASSERT_TRUE(wrong.mean_ref_err < MEAN_TOL);
}

static void test_an_exact_model_is_never_flagged_and_its_estimate_is_unchanged(void)
{
    const mm_run_t off = run(0, 3.0, 1, 1.0), on = run(500, 3.0, 1, 1.0);
    int i;
    TEST_ASSERT_EQUAL_INT32(0, on.flagged);
    TEST_ASSERT_TRUE(on.nis_mean < 3.0);
    TEST_ASSERT_TRUE(on.q_scale == 1.0);
    for (i = 0; i < PAPER_N; ++i) {
        TEST_ASSERT_TRUE(on.x[i] == off.x[i]); /* bit for bit: the monitor only watched */
    }
}

static void test_a_spring_three_percent_off_is_flagged(void)
{
    const mm_run_t wrong = run(500, 3.0, 0, 1.03), off = run(0, 3.0, 0, 1.03);
    TEST_ASSERT_TRUE(wrong.last_flags & CAEKF_FLAG_MODEL_MISMATCH);
    TEST_ASSERT_TRUE(wrong.flagged > wrong.steps / 2);
    TEST_ASSERT_EQUAL_INT32(0, off.flagged); /* window 0: no monitor */
    TEST_ASSERT_TRUE(wrong.q_scale == 1.0);  /* not adapting */
}

static void test_adapting_q_lets_the_gate_go(void)
{
    const mm_run_t held = run(500, 3.0, 0, 1.03), adapted = run(500, 3.0, 1, 1.03);
    TEST_ASSERT_TRUE(adapted.q_scale > 1.0);
    /* the factor and the flag follow their formulas step by step, while the factor grows and once it is above 1 */
    TEST_ASSERT_TRUE(adapted.q_ref_err < MEAN_TOL);
    TEST_ASSERT_TRUE(adapted.flag_wrong <= FLAG_TOL);
    TEST_ASSERT_TRUE(held.flag_wrong <= FLAG_TOL);
    TEST_ASSERT_TRUE(adapted.last_flags & CAEKF_FLAG_MODEL_MISMATCH); /* still said while Q_x is adapted */
    TEST_ASSERT_TRUE(held.gated_late > 0);
    TEST_ASSERT_TRUE(adapted.gated_late < held.gated_late / 10);
}

/* A window of one step: the mean is the last step's NIS per sensor (clipped), and the monitor still works. */
static void test_a_window_of_one_step_is_a_monitor(void)
{
    const mm_run_t one = run(1, 3.0, 0, 1.03);
    TEST_ASSERT_TRUE(one.flagged > 0);
    TEST_ASSERT_TRUE(one.mean_ref_err < MEAN_TOL);
    TEST_ASSERT_TRUE(one.flag_wrong <= FLAG_TOL);
}

static void test_a_refused_step_leaves_the_monitor_as_it_was(void)
{
    static caekf_t est;
    caekf_settings_t s;
    caekf_report_t rep;
    caekf_scalar_t m0, q0, m1, q1;
    const caekf_scalar_t u[1] = {0}, bad[2] = {(caekf_scalar_t)NAN, 0}, y[2] = {(caekf_scalar_t)1e-3, 0};
    paper_settings(&s, EXP_SWITCHED);
    s.mismatch_window = 10;
    s.mismatch_adapt = 1;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &s));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_step(&est, u, y, &rep)); /* a 1 mm innovation: far out */
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_mismatch(&est, &m0, &q0));
    TEST_ASSERT_TRUE(m0 > 1);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_INPUT, caekf_step(&est, u, bad, &rep));
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_get_mismatch(&est, &m1, &q1));
    TEST_ASSERT_TRUE(m1 == m0 && q1 == q0);
    TEST_ASSERT_EQUAL_INT(CAEKF_ERR_NULL, caekf_get_mismatch(0, &m1, &q1));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_the_mean_follows_its_formula);
    RUN_TEST(test_an_exact_model_is_never_flagged_and_its_estimate_is_unchanged);
    RUN_TEST(test_a_spring_three_percent_off_is_flagged);
    RUN_TEST(test_adapting_q_lets_the_gate_go);
    RUN_TEST(test_a_window_of_one_step_is_a_monitor);
    RUN_TEST(test_a_refused_step_leaves_the_monitor_as_it_was);
    return UNITY_END();
}
