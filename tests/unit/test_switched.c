/* The switch-off of Sec. 3.2: gamma and P_gamma,gamma frozen bit for bit while contact is inactive;
 * the consistent variant keeps P a valid covariance (|corr| <= 1) over the whole scenario; the paper's
 * literal eqs. (23)-(27) do not: frozen cross-covariances let P turn indefinite. */
#include <math.h>
#include <string.h>

#include "test_support.h"
#include "unity.h"

#if CAEKF_USE_FLOAT
#define CORR_TOL 1e-5 /* float rounding of the correlation itself */
#else
#define CORR_TOL 1e-9
#endif

void setUp(void) {}
void tearDown(void) {}

typedef struct {
    caekf_scalar_t gamma_prev, pgg_prev;
    long frozen_steps, contact_steps, mismatches;
    double max_corr;
    uint32_t flags_seen;
} watch_t;

static double max_abs_corr(const caekf_t *est)
{
    double m = 0;
    int i, j;
    for (i = 0; i < est->model.n; ++i) {
        for (j = i + 1; j < est->model.n; ++j) {
            double d = (double)EST_P(est, i, i) * (double)EST_P(est, j, j);
            if (d > 0) {
                m = fmax(m, fabs((double)EST_P(est, i, j)) / sqrt(d));
            }
        }
    }
    return m;
}

static void watch_step(const caekf_t *est, const caekf_report_t *rep, caekf_status_t st, const truth_rec_t *t,
                       void *ctx)
{
    watch_t *w = ctx;
    (void)t;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, st);
    w->flags_seen |= rep->flags;
    if (rep->flags & CAEKF_FLAG_GAMMA_FROZEN) {
        w->frozen_steps++;
        if (memcmp(&w->gamma_prev, &est->z[PAPER_IG], sizeof w->gamma_prev) != 0 ||
            memcmp(&w->pgg_prev, &EST_P(est, PAPER_IG, PAPER_IG), sizeof w->pgg_prev) != 0) {
            w->mismatches++;
        }
    }
    if (rep->flags & CAEKF_FLAG_CONTACT_ACTIVE) {
        w->contact_steps++;
    }
    w->gamma_prev = est->z[PAPER_IG];
    w->pgg_prev = EST_P(est, PAPER_IG, PAPER_IG);
    w->max_corr = fmax(w->max_corr, max_abs_corr(est));
}

static watch_t run(caekf_switchoff_t variant, int repair)
{
    static caekf_t est;
    caekf_settings_t s;
    watch_t w;
    memset(&w, 0, sizeof w);
    paper_settings(&s, EXP_SWITCHED);
    s.switchoff = variant;
    s.cov_repair_enabled = repair;
    TEST_ASSERT_EQUAL_INT(CAEKF_OK, caekf_init(&est, &s));
    w.gamma_prev = est.z[PAPER_IG];
    w.pgg_prev = EST_P(&est, PAPER_IG, PAPER_IG);
    TEST_ASSERT_EQUAL_INT32(paper_steps(), run_paper(&est, &s, watch_step, &w));
    return w;
}

static void test_consistent_freezes_gamma_bitwise_and_stays_a_covariance(void)
{
    watch_t w = run(CAEKF_SWITCHOFF_CONSISTENT, 1);
    TEST_ASSERT_TRUE(w.frozen_steps > 10000);
    TEST_ASSERT_TRUE(w.contact_steps > 1000);
    TEST_ASSERT_EQUAL_INT32(0, w.mismatches);
    TEST_ASSERT_TRUE_MESSAGE(w.max_corr <= 1 + CORR_TOL, "a correlation coefficient exceeded 1");
    TEST_ASSERT_FALSE_MESSAGE(w.flags_seen & CAEKF_FLAG_COV_REPAIRED, "consistent P needed no repair");
}

static void test_paper_variant_turns_indefinite(void)
{
    watch_t w = run(CAEKF_SWITCHOFF_PAPER, 0);
    TEST_ASSERT_EQUAL_INT32(0, w.mismatches); /* it freezes gamma too */
    TEST_ASSERT_TRUE_MESSAGE(w.max_corr > 1.5, "eqs. 23-27 read literally should break |corr| <= 1");
    TEST_ASSERT_TRUE(w.flags_seen & CAEKF_FLAG_COV_INDEFINITE); /* detected, never silent */
    TEST_ASSERT_FALSE(w.flags_seen & CAEKF_FLAG_COV_REPAIRED);
}

static void test_paper_variant_with_repair_is_flagged(void)
{
    watch_t w = run(CAEKF_SWITCHOFF_PAPER, 1);
    TEST_ASSERT_TRUE(w.flags_seen & CAEKF_FLAG_COV_REPAIRED);
    TEST_ASSERT_TRUE(w.max_corr <= 1 + 1e-3);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_consistent_freezes_gamma_bitwise_and_stays_a_covariance);
    RUN_TEST(test_paper_variant_turns_indefinite);
    RUN_TEST(test_paper_variant_with_repair_is_flagged);
    return UNITY_END();
}
