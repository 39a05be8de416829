/* The paper's four experiments, the schema's presets (canonical, switched, switched-highq,
 * switched-highq-constrained; sim/src/caekf_sim/schema/settings.toml), over the full 60 s reference
 * scenario, each configured as the reference settings plus the preset's values. The bounds are
 * the paper's claims (Figs. 3-6); the float build must also land within 0.5 % of the double build,
 * whose results caekf-reference wrote into reference_f64.h at build time. */
#include <math.h>
#include <string.h>

#include "reference_f64.h"
#include "test_support.h"
#include "unity.h"

void setUp(void) {}
void tearDown(void) {}

typedef struct {
    double gamma_min_seen, p_norm_max, gamma_final;
    uint32_t flags_seen;
    long negative_steps, errors;
} result_t;

static void collect(const caekf_t *est, const caekf_report_t *rep, caekf_status_t st, const truth_rec_t *t, void *ctx)
{
    result_t *r = ctx;
    caekf_scalar_t g, pn;
    (void)t;
    (void)caekf_get_gamma(est, &g);
    /* caekf_get_cov_norm2 uses the instance's scratch buffers, not the estimate. */
    (void)caekf_get_cov_norm2((caekf_t *)est, &pn);
    r->gamma_min_seen = fmin(r->gamma_min_seen, (double)g);
    r->p_norm_max = fmax(r->p_norm_max, (double)pn);
    r->flags_seen |= rep->flags;
    r->negative_steps += (double)g < 0;
    r->errors += st != CAEKF_OK;
    r->gamma_final = (double)g;
}

static result_t run_gate(int preset, int gate_off)
{
    static caekf_t est;
    caekf_settings_t s;
    result_t r;
    memset(&r, 0, sizeof r);
    r.gamma_min_seen = INFINITY;
    paper_settings(&s, preset);
    if (gate_off) {
        s.gamma_gate_nis = 0;
    }
    TEST_ASSERT_EQUAL_INT32(paper_steps(), run_paper(&est, &s, collect, &r));
    return r;
}

static result_t run(int preset) { return run_gate(preset, 0); }

static result_t canonical, switched, highq, constrained, switched_ungated, constrained_ungated;
static double rel_err(double g) { return g / paper_gamma_true() - 1; }

static void test_switched_converges_within_half_a_percent(void)
{
    TEST_ASSERT_TRUE(fabs(rel_err(switched.gamma_final)) < 0.005);
    TEST_ASSERT_EQUAL_INT32(0, switched.errors);
}

static void test_canonical_is_unstable(void)
{
    TEST_ASSERT_TRUE_MESSAGE(canonical.p_norm_max > 10 * switched.p_norm_max, "canonical ||P|| must blow up");
    TEST_ASSERT_TRUE_MESSAGE(fabs(rel_err(canonical.gamma_final)) > 0.10, "canonical gamma must not settle");
}

static void test_switched_highq_goes_negative_or_diverges(void)
{
    TEST_ASSERT_TRUE(highq.negative_steps > 0 ||
                     (highq.flags_seen & (CAEKF_FLAG_NEWTON_NOT_CONVERGED | CAEKF_FLAG_NUMERIC_ROLLBACK)));
}

static void test_constrained_stays_positive_and_converges(void)
{
    TEST_ASSERT_TRUE(constrained.gamma_min_seen >= paper_gamma_min() * (1 - 1e-9));
    TEST_ASSERT_TRUE(constrained.flags_seen & CAEKF_FLAG_CONSTRAINT_APPLIED);
    TEST_ASSERT_TRUE(fabs(rel_err(constrained.gamma_final)) < 0.02);
}

static void test_innovation_gate_leaves_the_undisturbed_scenario_alone(void)
{
    /* The switched experiments run with the default gate. On the continuous-model truth it may hold
     * gamma for a few steps at a contact onset (NIS just above 25: the filter's backward Euler against
     * the exact motion), but the paper's results stay those of the ungated filter: final gamma within
     * 0.05 % of it. Canonical runs without the gate (Table 1). */
    TEST_ASSERT_DOUBLE_WITHIN(5e-4, 0.0, rel_err(switched.gamma_final) - rel_err(switched_ungated.gamma_final));
    TEST_ASSERT_DOUBLE_WITHIN(5e-4, 0.0, rel_err(constrained.gamma_final) - rel_err(constrained_ungated.gamma_final));
    TEST_ASSERT_EQUAL_UINT32(0, canonical.flags_seen & CAEKF_FLAG_GAMMA_GATED);
}

static void test_matches_the_double_build(void)
{
    /* switched-highq diverges by design; its trajectory is not reproducible across precisions. */
    TEST_ASSERT_DOUBLE_WITHIN(0.005, 1.0, canonical.gamma_final / reference_f64_final_gamma[EXP_CANONICAL]);
    TEST_ASSERT_DOUBLE_WITHIN(0.005, 1.0, switched.gamma_final / reference_f64_final_gamma[EXP_SWITCHED]);
    TEST_ASSERT_DOUBLE_WITHIN(0.005, 1.0,
                              constrained.gamma_final / reference_f64_final_gamma[EXP_SWITCHED_HIGHQ_CONSTRAINED]);
#if !CAEKF_USE_FLOAT
    /* The double build is the reference itself: identical code, identical inputs, identical bits. */
    TEST_ASSERT_EQUAL_DOUBLE(reference_f64_final_gamma[EXP_SWITCHED], switched.gamma_final);
#endif
}

int main(void)
{
    canonical = run(EXP_CANONICAL);
    switched = run(EXP_SWITCHED);
    highq = run(EXP_SWITCHED_HIGHQ);
    constrained = run(EXP_SWITCHED_HIGHQ_CONSTRAINED);
    switched_ungated = run_gate(EXP_SWITCHED, 1);
    constrained_ungated = run_gate(EXP_SWITCHED_HIGHQ_CONSTRAINED, 1);
    UNITY_BEGIN();
    RUN_TEST(test_switched_converges_within_half_a_percent);
    RUN_TEST(test_canonical_is_unstable);
    RUN_TEST(test_switched_highq_goes_negative_or_diverges);
    RUN_TEST(test_constrained_stays_positive_and_converges);
    RUN_TEST(test_innovation_gate_leaves_the_undisturbed_scenario_alone);
    RUN_TEST(test_matches_the_double_build);
    return UNITY_END();
}
