/* The full PSD test's written-out instance (a build sized for substeps writes it out for its state's n,
 * CAEKF_PSD_WRITTEN_OUT_N) gives the loop's verdict, by the same operations, on PSD, semidefinite and
 * indefinite matrices of every scale: this suite compiles the linear algebra with it set for n = 9 and
 * compares both instances on random matrices. */
#define CAEKF_PSD_WRITTEN_OUT_N 9
#include "caekf_kernels.c" /* the module itself: the loop instance is its static psd_ldl */

#include "unity.h"

#include <string.h>

#define PSD_N CAEKF_PSD_WRITTEN_OUT_N

void setUp(void) {}
void tearDown(void) {}

static uint32_t lcg_state = 12345u;
static double uniform(void) /* in [-1, 1) */
{
    lcg_state = lcg_state * 1664525u + 1013904223u;
    return (double)(lcg_state >> 8) / 8388608.0 - 1.0;
}

/* A = D (B B^T - shift e e^T) D with B of rank `rank`, D spread over `decades` (row `zero`: none, or a zero
 * variance with its row and column). */
static void random_matrix(caekf_scalar_t a[PSD_N * PSD_N], int rank, double shift, double decades, int zero)
{
    double b[PSD_N][PSD_N], e[PSD_N], d[PSD_N];
    int i, j, k;
    for (i = 0; i < PSD_N; ++i) {
        for (k = 0; k < PSD_N; ++k) {
            b[i][k] = k < rank ? uniform() : 0;
        }
        e[i] = uniform();
        d[i] = i == zero ? 0 : pow(10.0, decades * uniform());
    }
    for (i = 0; i < PSD_N; ++i) {
        for (j = 0; j < PSD_N; ++j) {
            double s = -shift * e[i] * e[j];
            for (k = 0; k < PSD_N; ++k) {
                s += b[i][k] * b[j][k];
            }
            a[i * PSD_N + j] = (caekf_scalar_t)(d[i] * s * d[j]);
        }
    }
}

static void test_written_out_instance_gives_the_loops_verdict(void)
{
    static caekf_scalar_t a[PSD_N * PSD_N], w_out[PSD_N * PSD_N], w_loop[PSD_N * PSD_N];
    volatile int n_at_run_time = PSD_N; /* the loop instance: n unknown to the compiler */
    int trial, ok = 0, refused = 0;
    for (trial = 0; trial < 3000; ++trial) {
        const int rank = 1 + trial % PSD_N, zero = trial % 7 == 0 ? trial % PSD_N : -1;
        const double shift = trial % 3 == 0 ? 0 : 1e-4 * (trial % 5) * (trial % 5) * (trial % 5);
        caekf_la_status_t written_out, loop;
        int i;
        random_matrix(a, rank, shift, (trial % 4) * 2.0, zero);
        for (i = 0; i < PSD_N * PSD_N; ++i) {
            w_out[i] = w_loop[i] = 0;
        }
        written_out = caekf_psd_check(a, PSD_N, CAEKF_EPS * 1024, w_out);
        loop = psd_ldl(a, n_at_run_time, CAEKF_EPS * 1024, w_loop);
        TEST_ASSERT_EQUAL_INT(loop, written_out);
        if (loop == CAEKF_LA_OK) {
            TEST_ASSERT_EQUAL_MEMORY(w_loop, w_out, sizeof w_out);
            ++ok;
        } else {
            ++refused;
        }
    }
    /* both verdicts are exercised */
    TEST_ASSERT_TRUE(ok > 300);
    TEST_ASSERT_TRUE(refused > 300);
}

/* The special matrices' verdicts (a NaN, infinite or negative variance; a zero variance with and without a
 * coupling left; a correlation above one; a PSD matrix) by the written-out instance (n = PSD_N) and by the
 * loop caekf_psd_check falls back to for any other n (here 3): the same verdict from both. */
static void test_both_instances_refuse_non_finite_negative_and_coupled_zero_variances(void)
{
    static caekf_scalar_t a[PSD_N * PSD_N], w[PSD_N * PSD_N];
    static const int sizes[2] = {PSD_N, 3};
    const caekf_scalar_t tol = CAEKF_EPS * 1024;
    int k, c, i;
    for (k = 0; k < 2; ++k) {
        const int n = sizes[k];
        for (c = 0; c < 8; ++c) {
            caekf_la_status_t expect = CAEKF_LA_NOT_PSD;
            for (i = 0; i < n * n; ++i) {
                a[i] = i % (n + 1) == 0 ? 1 : 0;
            }
            switch (c) {
            case 0: expect = CAEKF_LA_OK; break;
            case 1: a[(n - 1) * (n + 1)] = (caekf_scalar_t)NAN; break;      /* the last variance */
            case 2: a[(n - 1) * (n + 1)] = (caekf_scalar_t)INFINITY; break; /* the last variance */
            case 3: a[n + 1] = -1; break;
            case 4: /* a zero variance with nothing left to couple: semidefinite */
                a[0] = 0;
                expect = CAEKF_LA_OK;
                break;
            case 5: /* a zero variance still coupled */
                a[0] = 0;
                a[n - 1] = a[(n - 1) * n] = (caekf_scalar_t)0.5;
                break;
            case 6: /* correlation 2: a negative pivot */ a[1] = a[n] = 2; break;
            default: /* correlation 0.5 between the first and the last: PSD, a pivot that eliminates */
                a[n - 1] = a[(n - 1) * n] = (caekf_scalar_t)0.5;
                expect = CAEKF_LA_OK;
                break;
            }
            TEST_ASSERT_EQUAL_INT_MESSAGE(expect, caekf_psd_check(a, n, tol, w), n == PSD_N ? "written out" : "loop");
        }
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_written_out_instance_gives_the_loops_verdict);
    RUN_TEST(test_both_instances_refuse_non_finite_negative_and_coupled_zero_variances);
    return UNITY_END();
}
