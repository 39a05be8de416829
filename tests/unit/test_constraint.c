/* The inequality constraint of Sec. 3.3 (eqs. 28-30): gamma >= gamma_min after every step, nothing
 * non-finite, the sequential perfect measurement equal to the batch [H; D] correction, and the
 * singular paths (refused innovation, unusable gamma variance) handled with flags, not NaN. */
#include <math.h>
#include <string.h>

#include "caekf_filter.h"
#include "caekf_linalg.h"
#include "test_support.h"
#include "unity.h"

#define N PAPER_N
#define IG PAPER_IG

#if CAEKF_USE_FLOAT
#define EQ_RTOL 2e-3
#else
#define EQ_RTOL 1e-9
#endif

void setUp(void) {}
void tearDown(void) {}

/* The filter's upper-triangle steps on full symmetric matrices. */
static int correct_full(caekf_scalar_t z[N], paper_mat_t P, const caekf_scalar_t y[2], caekf_scalar_t r, int joseph,
                        uint32_t *flags)
{
    caekf_scalar_t nis;
    caekf_filter_dims_t d;
    static caekf_correct_work_t work;
    int st;
    paper_filter_dims(&d, r, CAEKF_GAMMA_LIVE);
    st = caekf_correct_upper(z, &P[0][0], y, joseph, &d, 0, &nis, flags, &work);
    if (st == 0) {
        caekf_mirror_upper(&P[0][0], N);
    }
    return st;
}

static void constrain_full(caekf_scalar_t z[N], paper_mat_t P, caekf_scalar_t zmin, caekf_scalar_t s_gamma,
                           caekf_scalar_t gamma_min_phys, uint32_t *flags)
{
    (void)caekf_constrain_upper(z, &P[0][0], N, IG, zmin, 0, s_gamma, gamma_min_phys, flags);
    caekf_mirror_upper(&P[0][0], N);
}

typedef struct {
    double gamma_min;
    long applied, below, nonfinite;
} cwatch_t;

static void cwatch(const caekf_t *est, const caekf_report_t *rep, caekf_status_t st, const truth_rec_t *t, void *ctx)
{
    cwatch_t *w = ctx;
    caekf_scalar_t x[CAEKF_N];
    int i;
    (void)t;
    (void)st;
    (void)caekf_get_state(est, x);
    if ((double)x[IG] < w->gamma_min * (1 - 1e-9)) {
        w->below++;
    }
    for (i = 0; i < N; ++i) {
        int j;
        w->nonfinite += !isfinite((double)est->z[i]);
        for (j = 0; j < N; ++j) {
            w->nonfinite += !isfinite((double)EST_P(est, i, j));
        }
    }
    w->applied += (rep->flags & CAEKF_FLAG_CONSTRAINT_APPLIED) != 0;
}

static void test_constrained_highq_stays_above_gamma_min(void)
{
    static caekf_t est;
    caekf_settings_t s;
    cwatch_t w;
    caekf_scalar_t g;
    memset(&w, 0, sizeof w);
    w.gamma_min = paper_gamma_min();
    paper_settings(&s, EXP_SWITCHED_HIGHQ_CONSTRAINED);
    TEST_ASSERT_EQUAL_INT32(paper_steps(), run_paper(&est, &s, cwatch, &w));
    TEST_ASSERT_EQUAL_INT32(0, w.below);
    TEST_ASSERT_EQUAL_INT32(0, w.nonfinite);
    TEST_ASSERT_TRUE_MESSAGE(w.applied > 0, "the constraint must have been exercised");
    (void)caekf_get_gamma(&est, &g);
    TEST_ASSERT_DOUBLE_WITHIN(0.02, 1.0, (double)g / paper_gamma_true());
}

/* 3x3 inverse by cofactors, double. */
static void inv3(double a[3][3], double r[3][3])
{
    double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                 a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    r[0][0] = (a[1][1] * a[2][2] - a[1][2] * a[2][1]) / det;
    r[0][1] = (a[0][2] * a[2][1] - a[0][1] * a[2][2]) / det;
    r[0][2] = (a[0][1] * a[1][2] - a[0][2] * a[1][1]) / det;
    r[1][0] = (a[1][2] * a[2][0] - a[1][0] * a[2][2]) / det;
    r[1][1] = (a[0][0] * a[2][2] - a[0][2] * a[2][0]) / det;
    r[1][2] = (a[0][2] * a[1][0] - a[0][0] * a[1][2]) / det;
    r[2][0] = (a[1][0] * a[2][1] - a[1][1] * a[2][0]) / det;
    r[2][1] = (a[0][1] * a[2][0] - a[0][0] * a[2][1]) / det;
    r[2][2] = (a[0][0] * a[1][1] - a[0][1] * a[1][0]) / det;
}

static void test_sequential_perfect_measurement_equals_batch_eq29(void)
{
    caekf_scalar_t P[N][N], z[N], y[2];
    double Pd[N][N], zd[N], S[3][3], Si[3][3], G[N][3], e[3];
    const int rows[3] = {PAPER_IY1, PAPER_IY4, IG};
    const double r = 0.01, zmin = 2.0;
    uint32_t flags = 0;
    int i, j, k;
    test_spd_matrix(P);
    for (i = 0; i < N; ++i) {
        z[i] = (caekf_scalar_t)(0.1 * i - 0.3);
        zd[i] = (double)z[i];
        for (j = 0; j < N; ++j) Pd[i][j] = (double)P[i][j];
    }
    z[IG] = zd[IG] = 2.5;
    y[0] = (caekf_scalar_t)-2.0; /* pulls gamma below zmin through the correlations */
    y[1] = (caekf_scalar_t)-3.0;
    TEST_ASSERT_EQUAL_INT(0, correct_full(z, P, y, (caekf_scalar_t)r, 0, &flags));
    TEST_ASSERT_TRUE_MESSAGE((double)z[IG] < zmin, "test setup: the y-correction must violate the bound");
    constrain_full(z, P, (caekf_scalar_t)zmin, 1, (caekf_scalar_t)zmin, &flags);
    TEST_ASSERT_TRUE(flags & CAEKF_FLAG_CONSTRAINT_APPLIED);
    TEST_ASSERT_FALSE(flags & CAEKF_FLAG_CONSTRAINT_CLAMPED);
    /* Batch: H^c = [H; D], R^c = blkdiag(R, R, 0), y^c = [y; zmin] from the prior (eqs. 29-30). */
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j) S[i][j] = Pd[rows[i]][rows[j]] + ((i == j && i < 2) ? r : 0);
    inv3(S, Si);
    e[0] = (double)y[0] - zd[PAPER_IY1];
    e[1] = (double)y[1] - zd[PAPER_IY4];
    e[2] = zmin - zd[IG];
    for (i = 0; i < N; ++i)
        for (j = 0; j < 3; ++j) {
            G[i][j] = 0;
            for (k = 0; k < 3; ++k) G[i][j] += Pd[i][rows[k]] * Si[k][j];
        }
    for (i = 0; i < N; ++i) {
        double zb = zd[i] + G[i][0] * e[0] + G[i][1] * e[1] + G[i][2] * e[2];
        TEST_ASSERT_DOUBLE_WITHIN(EQ_RTOL * (1 + fabs(zb)), zb, (double)z[i]);
        for (j = 0; j < N; ++j) {
            double pb = Pd[i][j];
            for (k = 0; k < 3; ++k) pb -= G[i][k] * Pd[rows[k]][j];
            TEST_ASSERT_DOUBLE_WITHIN(EQ_RTOL * 10, pb, (double)P[i][j]);
        }
    }
    TEST_ASSERT_EQUAL_DOUBLE(zmin, (double)z[IG]);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, (double)P[IG][IG]);
}

static void test_zero_gamma_variance_falls_back_to_clamp(void)
{
    caekf_scalar_t P[N][N], before[N][N], z[N];
    uint32_t flags = 0;
    int i;
    test_spd_matrix(P);
    for (i = 0; i < N; ++i) {
        P[i][IG] = P[IG][i] = 0; /* just after a constraint: gamma's variance is exactly 0 */
        z[i] = (caekf_scalar_t)0.5;
    }
    z[IG] = (caekf_scalar_t)0.5;
    memcpy(before, P, sizeof P);
    constrain_full(z, P, 1, 1, 1, &flags);
    TEST_ASSERT_TRUE(flags & CAEKF_FLAG_CONSTRAINT_APPLIED);
    TEST_ASSERT_TRUE(flags & CAEKF_FLAG_CONSTRAINT_CLAMPED);
    TEST_ASSERT_TRUE(flags & CAEKF_FLAG_SINGULAR_INNOVATION);
    TEST_ASSERT_TRUE((double)z[IG] >= 1.0);
    TEST_ASSERT_EQUAL_DOUBLE(0.5, (double)z[0]);
    TEST_ASSERT_TRUE(memcmp(before, P, sizeof P) == 0);
}

static void test_inconsistent_gamma_column_falls_back_to_clamp(void)
{
    caekf_scalar_t P[N][N], z[N];
    uint32_t flags = 0;
    int i;
    test_spd_matrix(P);
    P[IG][IG] = (caekf_scalar_t)1e-6; /* |P_ig|^2 > P_ii P_gg: no valid covariance, the gain would explode */
    for (i = 0; i < N; ++i) z[i] = 0;
    constrain_full(z, P, 1, 1, 1, &flags);
    TEST_ASSERT_TRUE(flags & CAEKF_FLAG_CONSTRAINT_CLAMPED);
    for (i = 0; i < IG; ++i) TEST_ASSERT_EQUAL_DOUBLE(0.0, (double)z[i]);
}

static void test_singular_innovation_is_refused_with_a_flag(void)
{
    caekf_scalar_t P[N][N], z[N], y[2] = {1, 1}, Pb[N][N], zb[N];
    uint32_t flags = 0;
    int i, j;
    for (i = 0; i < N; ++i)
        for (j = 0; j < N; ++j) P[i][j] = (i == j) ? 1 : 0;
    /* q1 and q4 perfectly correlated with a negligible R: S is singular to working precision. */
    P[PAPER_IY1][PAPER_IY4] = P[PAPER_IY4][PAPER_IY1] = 1;
    for (i = 0; i < N; ++i) z[i] = 0;
    memcpy(Pb, P, sizeof P);
    memcpy(zb, z, sizeof z);
    TEST_ASSERT_EQUAL_INT(-1, correct_full(z, P, y, (caekf_scalar_t)1e-30, 1, &flags));
    TEST_ASSERT_TRUE(flags & CAEKF_FLAG_SINGULAR_INNOVATION);
    TEST_ASSERT_TRUE(memcmp(Pb, P, sizeof P) == 0);
    TEST_ASSERT_TRUE(memcmp(zb, z, sizeof z) == 0);
}

#if !(CAEKF_SIZED && CAEKF_SIZED_CONTACTS == 1 && CAEKF_SIZED_LAW_PARAMS == 0) /* else gamma is the only bound */
/* A bound on a state with states after it (a law parameter, another contact's gamma): the perfect measurement
 * is the rank-one update z + P e_g (zb - z_g) / P_gg, P - P e_g e_g^T P / P_gg, on every entry before and after
 * the state, lower and upper bound alike. */
static void test_a_bound_on_a_middle_state_is_the_rank_one_update(void)
{
    const int g = 3;
    int is_max;
    for (is_max = 0; is_max < 2; ++is_max) {
        caekf_scalar_t P[N][N], z[N];
        double Pd[N][N], zd[N], zb;
        uint32_t flags = 0;
        int i, j;
        test_spd_matrix(P);
        for (i = 0; i < N; ++i) {
            z[i] = (caekf_scalar_t)(0.1 * i - 0.3);
            zd[i] = (double)z[i];
            for (j = 0; j < N; ++j) Pd[i][j] = (double)P[i][j];
        }
        zb = zd[g] + (is_max ? -0.4 : 0.4); /* z_g violates it */
        TEST_ASSERT_EQUAL_INT(
            1, caekf_constrain_upper(z, &P[0][0], N, g, (caekf_scalar_t)zb, is_max, 1, (caekf_scalar_t)zb, &flags));
        caekf_mirror_upper(&P[0][0], N);
        TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_CONSTRAINT_APPLIED, flags);
        for (i = 0; i < N; ++i) {
            const double ze = i == g ? zb : zd[i] + Pd[i][g] / Pd[g][g] * (zb - zd[g]);
            TEST_ASSERT_DOUBLE_WITHIN(EQ_RTOL * (1 + fabs(ze)), ze, (double)z[i]);
            for (j = 0; j < N; ++j) {
                const double pe = i == g || j == g ? 0.0 : Pd[i][j] - Pd[i][g] * Pd[g][j] / Pd[g][g];
                TEST_ASSERT_DOUBLE_WITHIN(EQ_RTOL * 10, pe, (double)P[i][j]);
            }
        }
    }
}
#endif

/* z = 0 and P the identity but P_jj = 4 and P_jk = P_kj = c: the correlation of states j and k is c / 2. */
static void correlated_pair(caekf_scalar_t z[N], paper_mat_t P, int j, int k, caekf_scalar_t c)
{
    int a, b;
    for (a = 0; a < N; ++a) {
        z[a] = 0;
        for (b = 0; b < N; ++b) P[a][b] = a == b ? 1 : 0;
    }
    P[j][j] = 4;
    P[j][k] = P[k][j] = c;
}

/* A state perfectly correlated with gamma (P_ig^2 = P_ii P_gg exactly, a valid semidefinite covariance: e.g.
 * after another perfect measurement) keeps the update usable; a correlation of 1.2 does not (clamped). */
static void test_perfect_correlation_is_usable_and_more_is_clamped(void)
{
    caekf_scalar_t P[N][N], z[N];
    uint32_t flags = 0;
    correlated_pair(z, P, 0, IG, 2); /* corr(q1, gamma) = 1 */
    constrain_full(z, P, 1, 1, 1, &flags);
    TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_CONSTRAINT_APPLIED, flags);
    TEST_ASSERT_EQUAL_DOUBLE(2.0, (double)z[0]); /* q1 moves with gamma: 2 dz */
    TEST_ASSERT_EQUAL_DOUBLE(0.0, (double)P[0][0]);
    correlated_pair(z, P, 0, IG, (caekf_scalar_t)2.4); /* corr 1.2: no covariance */
    flags = 0;
    constrain_full(z, P, 1, 1, 1, &flags);
    TEST_ASSERT_TRUE(flags & CAEKF_FLAG_CONSTRAINT_CLAMPED);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, (double)z[0]);
}

/* The covariance's health: a perfect correlation is healthy (semidefinite, not indefinite); an indefinite
 * upper triangle is repaired as the symmetric matrix it stands for, whatever the lower triangle holds. */
static void test_health_accepts_perfect_correlation_and_repairs_the_upper_triangle(void)
{
    static caekf_scalar_t P[N][N], Q[N][N], scratch[N * N];
    caekf_scalar_t z[N];
    uint32_t flags = 0;
    int i, j;
    correlated_pair(z, P, 0, 3, 2);
    TEST_ASSERT_EQUAL_INT(1, caekf_covariance_health(&P[0][0], z, N, 1, 1, scratch, &flags));
    TEST_ASSERT_EQUAL_UINT32(0, flags);
    TEST_ASSERT_EQUAL_DOUBLE(2.0, (double)P[0][3]);
    /* indefinite: corr(q1, q2) = 1.5 in the upper triangle, the lower one stale */
    test_spd_matrix(P);
    for (i = 0; i < N; ++i)
        for (j = 0; j < N; ++j) P[i][j] = i == j ? 1 : (j > i ? P[i][j] / 10 : 0);
    P[0][1] = (caekf_scalar_t)1.5;
    memcpy(Q, P, sizeof P);
    caekf_mirror_upper(&Q[0][0], N);
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_repair(&Q[0][0], N, scratch));
    TEST_ASSERT_EQUAL_INT(1, caekf_covariance_health(&P[0][0], z, N, 1, 1, scratch, &flags));
    TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_COV_INDEFINITE | CAEKF_FLAG_COV_REPAIRED, flags);
    for (i = 0; i < N; ++i)
        for (j = i; j < N; ++j) TEST_ASSERT_DOUBLE_WITHIN(EQ_RTOL, (double)Q[i][j], (double)P[i][j]);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_constrained_highq_stays_above_gamma_min);
    RUN_TEST(test_sequential_perfect_measurement_equals_batch_eq29);
    RUN_TEST(test_zero_gamma_variance_falls_back_to_clamp);
    RUN_TEST(test_inconsistent_gamma_column_falls_back_to_clamp);
    RUN_TEST(test_singular_innovation_is_refused_with_a_flag);
#if !(CAEKF_SIZED && CAEKF_SIZED_CONTACTS == 1 && CAEKF_SIZED_LAW_PARAMS == 0)
    RUN_TEST(test_a_bound_on_a_middle_state_is_the_rank_one_update);
#endif
    RUN_TEST(test_perfect_correlation_is_usable_and_more_is_clamped);
    RUN_TEST(test_health_accepts_perfect_correlation_and_repairs_the_upper_triangle);
    return UNITY_END();
}
