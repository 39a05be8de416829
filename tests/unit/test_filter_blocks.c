/* The covariance prediction (caekf_predict_covariance: eq. 12 with the structure of eq. 10, the parameters'
 * policies of eqs. 21-24) against F P F^T + Q formed densely in double from the same F: its v-rows Fv (dense
 * rows, rows compacted to 3, 4 and 5 nonzeros), its q-rows [I, c2 I, 0] + c Fv (backward Euler: c2 = 0;
 * trapezoidal: c2 > 0) or, after substeps, given rows Fq, and identity rows for the parameter. Each policy:
 * live (Q_gamma added), frozen as a consider state (P_gg kept, its cross-covariances propagated), frozen as
 * the paper writes it (the whole gamma column kept). tools/mutation.py showed the sparse and the substeps'
 * paths unchecked by the estimator-level suites (docs/mutation.md). Also the covariance's health and a bound
 * met exactly. */
#include <math.h>
#include <string.h>

#include "caekf_filter.h"
#include "test_support.h"
#include "unity.h"

#define N PAPER_N
#define NQ PAPER_NQ
#define NX (2 * PAPER_NQ)

#if CAEKF_USE_FLOAT
#define RTOL 1e-5
#else
#define RTOL 1e-12
#endif

void setUp(void) {}
void tearDown(void) {}

/* Fv's rows: row i keeps nnz[i] nonzeros (the rest exact zeros; n: dense). */
static void make_fv(caekf_scalar_t fv[CAEKF_NQ][CAEKF_N], const int nnz[NQ])
{
    int i, j;
    memset(fv, 0, sizeof(caekf_scalar_t) * CAEKF_NQ * CAEKF_N);
    for (i = 0; i < NQ; ++i) {
        for (j = 0; j < N; ++j) {
            const int keep = nnz[i] == N || (j * 7 + i * 3 + 3) % N < nnz[i];
            fv[i][j] = keep ? (caekf_scalar_t)(0.05 * ((i * 5 + j * 3) % 11) - 0.2 + (i == j - NQ ? 0.9 : 0)) : 0;
            if (keep && fv[i][j] == 0) {
                fv[i][j] = (caekf_scalar_t)0.125;
            }
        }
    }
}

/* One prediction against the dense reference. fq: NULL, or the q-rows after substeps. */
static void check_prediction(const int nnz[NQ], double c, double c2, int with_fq, caekf_gamma_policy_t policy)
{
    caekf_scalar_t P[N][N], T[CAEKF_N * CAEKF_N], q[CAEKF_N];
    static caekf_scalar_t fv[CAEKF_NQ][CAEKF_N], fv0[CAEKF_NQ][CAEKF_N], fq[CAEKF_NQ][CAEKF_N];
    caekf_fv_pattern_t pat;
    caekf_filter_dims_t d;
    double F[N][N], FP[N][N], E[N][N];
    int i, j, k;
    test_spd_matrix(P);
    make_fv(fv, nnz);
    memcpy(fv0, fv, sizeof fv);
    for (i = 0; i < N; ++i) {
        q[i] = (caekf_scalar_t)(1e-3 * (i + 1));
    }
    for (i = 0; i < NQ; ++i) {
        for (j = 0; j < N; ++j) {
            fq[i][j] = (caekf_scalar_t)((i == j ? 1.0 : 0.0) + 0.01 * ((i * 3 + j * 5) % 7) - 0.02);
        }
    }
    paper_filter_dims(&d, 1, policy);
    memset(&pat, 0, sizeof pat);
    if (with_fq) {
        caekf_fv_dense(NQ, N, &pat); /* after substeps every row is dense */
    } else {
        caekf_fv_compact(fv, NQ, N, &pat);
    }
    memset(T, 0, sizeof T);
    caekf_predict_covariance(&P[0][0], T, fv, &pat, (caekf_scalar_t)c, (caekf_scalar_t)c2, with_fq ? fq : 0, q, &d);
    /* F dense, in double */
    memset(F, 0, sizeof F);
    for (i = 0; i < NQ; ++i) {
        for (j = 0; j < N; ++j) {
            F[NQ + i][j] = (double)fv0[i][j];
            F[i][j] =
                with_fq ? (double)fq[i][j] : (i == j ? 1.0 : 0.0) + (j == NQ + i ? c2 : 0.0) + c * (double)fv0[i][j];
        }
    }
    for (i = NX; i < N; ++i) {
        F[i][i] = 1;
    }
    for (i = 0; i < N; ++i) {
        for (j = 0; j < N; ++j) {
            FP[i][j] = 0;
            for (k = 0; k < N; ++k) FP[i][j] += F[i][k] * (double)P[k][j];
        }
    }
    for (i = 0; i < N; ++i) {
        for (j = 0; j < N; ++j) {
            E[i][j] = 0;
            for (k = 0; k < N; ++k) E[i][j] += FP[i][k] * F[j][k];
        }
        if (i < NX || policy == CAEKF_GAMMA_LIVE) {
            E[i][i] += (double)q[i];
        }
    }
    if (policy == CAEKF_GAMMA_FROZEN_PAPER) { /* eqs. (23)-(24): the gamma column as it was */
        for (i = 0; i < N; ++i) {
            E[i][N - 1] = (double)P[i][N - 1];
        }
    }
    for (i = 0; i < N; ++i) {
        for (j = i; j < N; ++j) {
            const double scale = sqrt(fabs(E[i][i] * E[j][j])) + 1e-300;
            TEST_ASSERT_DOUBLE_WITHIN(RTOL * scale, E[i][j], (double)T[i * N + j]);
        }
    }
}

static const int sparse[NQ] = {4, 3, 5, 4}; /* a chain's rows: 4 nonzeros, and others */
static const int dense[NQ] = {N, N, N, N};  /* in contact */

static void test_backward_euler_rows(void)
{
    check_prediction(sparse, 1e-3 * 10, 0, 0, CAEKF_GAMMA_LIVE);
    check_prediction(sparse, 1e-3 * 10, 0, 0, CAEKF_GAMMA_FROZEN_SCHMIDT);
    check_prediction(dense, 1e-3 * 10, 0, 0, CAEKF_GAMMA_LIVE);
}

#if CAEKF_HAS_TRAPEZOIDAL
static void test_trapezoidal_rows(void)
{
    check_prediction(sparse, 0.5e-3 * 10, 0.5e-3 * 10, 0, CAEKF_GAMMA_LIVE);
    check_prediction(dense, 0.5e-3 * 10, 0.5e-3 * 10, 0, CAEKF_GAMMA_FROZEN_SCHMIDT);
}
#endif

#if !CAEKF_SIZED_METHOD /* a build sized for the consistent switch-off has no paper variant */
static void test_the_paper_switch_off_keeps_the_gamma_column(void)
{
    check_prediction(sparse, 1e-3 * 10, 0, 0, CAEKF_GAMMA_FROZEN_PAPER);
    check_prediction(dense, 1e-3 * 10, 0, 0, CAEKF_GAMMA_FROZEN_PAPER);
}
#endif

#if CAEKF_HAS_SUBSTEPS
static void test_substeps_rows(void)
{
    check_prediction(dense, 0, 0, 1, CAEKF_GAMMA_LIVE);
    check_prediction(dense, 0, 0, 1, CAEKF_GAMMA_FROZEN_SCHMIDT);
}
#endif

/* The covariance's health: every entry of the upper triangle and of the state finite is healthy; a NaN in the
 * state is not, even when P passes; what lies after the n x n matrix in its buffer is not P. */
static void test_health_reads_the_state_and_the_matrix_only(void)
{
    static caekf_scalar_t P[N * N + N], scratch[N * N];
    caekf_scalar_t z[N];
    uint32_t flags = 0;
    int i;
    for (i = 0; i < N * N + N; ++i) {
        P[i] = i < N * N ? (i % (N + 1) == 0 ? 1 : 0) : (caekf_scalar_t)NAN;
    }
    for (i = 0; i < N; ++i) {
        z[i] = (caekf_scalar_t)0.5;
    }
    TEST_ASSERT_EQUAL_INT(1, caekf_covariance_health(P, z, N, 1, 1, scratch, &flags));
    TEST_ASSERT_EQUAL_UINT32(0, flags);
    z[3] = (caekf_scalar_t)NAN;
    TEST_ASSERT_EQUAL_INT(0, caekf_covariance_health(P, z, N, 0, 1, scratch, &flags));
    TEST_ASSERT_EQUAL_UINT32(0, flags); /* P itself is fine */
    /* an indefinite P, repaired: finite afterwards, the NaNs after it are not its entries */
    z[3] = (caekf_scalar_t)0.5;
    P[1] = 2; /* corr(q1, q2) = 2 in the upper triangle */
    TEST_ASSERT_EQUAL_INT(1, caekf_covariance_health(P, z, N, 1, 1, scratch, &flags));
    TEST_ASSERT_EQUAL_UINT32(CAEKF_FLAG_COV_INDEFINITE | CAEKF_FLAG_COV_REPAIRED, flags);
}

/* A parameter exactly on its bound is not outside it: nothing is applied, P untouched, either bound. */
static void test_a_parameter_on_its_bound_is_left_alone(void)
{
    caekf_scalar_t P[N][N], before[N][N], z[N];
    uint32_t flags = 0;
    int i;
    test_spd_matrix(P);
    memcpy(before, P, sizeof P);
    for (i = 0; i < N; ++i) {
        z[i] = (caekf_scalar_t)0.25;
    }
    TEST_ASSERT_EQUAL_INT(
        0, caekf_constrain_upper(z, &P[0][0], N, N - 1, (caekf_scalar_t)0.25, 1, 1, (caekf_scalar_t)0.25, &flags));
    TEST_ASSERT_EQUAL_INT(
        0, caekf_constrain_upper(z, &P[0][0], N, N - 1, (caekf_scalar_t)0.25, 0, 1, (caekf_scalar_t)0.25, &flags));
    TEST_ASSERT_EQUAL_UINT32(0, flags);
    TEST_ASSERT_TRUE(memcmp(before, P, sizeof P) == 0);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_backward_euler_rows);
    RUN_TEST(test_health_reads_the_state_and_the_matrix_only);
    RUN_TEST(test_a_parameter_on_its_bound_is_left_alone);
#if CAEKF_HAS_TRAPEZOIDAL
    RUN_TEST(test_trapezoidal_rows);
#endif
#if !CAEKF_SIZED_METHOD
    RUN_TEST(test_the_paper_switch_off_keeps_the_gamma_column);
#endif
#if CAEKF_HAS_SUBSTEPS
    RUN_TEST(test_substeps_rows);
#endif
    return UNITY_END();
}
