/* Fixed-size linear algebra: LU with pivoting and several right-hand sides, the refusing 2x2
 * symmetric inverse, the PSD test, Jacobi eigenvalues and the PSD repair. */
#include <math.h>
#include <string.h>

#include "caekf_linalg.h"
#include "caekf_math.h"
#include "unity.h"

#if CAEKF_USE_FLOAT
#define TOL 1e-4
#else
#define TOL 1e-12
#endif

void setUp(void) {}
void tearDown(void) {}

#if CAEKF_LA_GENERAL_LU /* the build has the LU of any size */
static void test_lu_solves_several_rhs_with_pivoting(void)
{
    /* a[0][0] = 0 forces a row exchange. */
    caekf_scalar_t a[4][4] = {{0, 2, 1, 0}, {3, 1, 0, 1}, {1, 0, 4, 2}, {2, 1, 1, 5}};
    caekf_scalar_t x[4][3] = {{1, -2, 0.5f}, {2, 0, -1}, {-1, 3, 2}, {0.25f, 1, -3}};
    caekf_scalar_t b[4][3];
    int piv[4], i, j, k;
    for (i = 0; i < 4; ++i) {
        for (j = 0; j < 3; ++j) {
            caekf_scalar_t s = 0;
            for (k = 0; k < 4; ++k) {
                s += a[i][k] * x[k][j];
            }
            b[i][j] = s;
        }
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_lu_factor(&a[0][0], 4, piv, CAEKF_EPS * 16));
    TEST_ASSERT_EQUAL_INT(1, piv[0]); /* largest |a_i0| is row 1 */
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_lu_solve(&a[0][0], 4, piv, &b[0][0], 3, 3));
    for (i = 0; i < 4; ++i) {
        for (j = 0; j < 3; ++j) {
            TEST_ASSERT_DOUBLE_WITHIN(TOL * 10, (double)x[i][j], (double)b[i][j]);
        }
    }
}

static void test_lu_refuses_singular_and_nan(void)
{
    caekf_scalar_t a[3][3] = {{1, 2, 3}, {2, 4, 6}, {1, 0, 1}}; /* row 1 = 2 row 0 */
    caekf_scalar_t n[2][2] = {{1, 0}, {0, 1}};
    int piv[3];
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_lu_factor(&a[0][0], 3, piv, CAEKF_EPS * 16));
    n[1][1] = (caekf_scalar_t)NAN;
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_lu_factor(&n[0][0], 2, piv, CAEKF_EPS * 16));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_lu_factor(&n[0][0], 0, piv, CAEKF_EPS * 16));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_lu_factor(&n[0][0], CAEKF_LA_MAX_N + 1, piv, CAEKF_EPS));
}

#endif

#if CAEKF_LA_LU4
/* The written-out 4 x 4 kernel: solves, and refuses a singular or NaN matrix, at every step. */
static void test_lu4_solves_and_refuses(void)
{
    caekf_scalar_t a[16] = {4, 1, 0, 0, 1, 5, 2, 0, 0, 2, 6, 1, 0, 0, 1, 3};
    caekf_scalar_t x[4] = {1, 2, 3, 4}, b[4];
    int piv[4], i, j;
    for (i = 0; i < 4; ++i) {
        b[i] = 0;
        for (j = 0; j < 4; ++j) {
            b[i] += a[4 * i + j] * x[j];
        }
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_lu4_factor_tol(a, piv, CAEKF_EPS * 16 * 6));
    caekf_lu4_solve(a, piv, b, 1, 1);
    for (i = 0; i < 4; ++i) {
        TEST_ASSERT_DOUBLE_WITHIN(TOL * 10, (double)x[i], (double)b[i]);
    }
    for (i = 0; i < 4; ++i) { /* row i a copy of row i - 1 (or zero): singular at step i */
        caekf_scalar_t s[16] = {4, 1, 0, 0, 1, 5, 2, 0, 0, 2, 6, 1, 0, 0, 1, 3};
        for (j = 0; j < 4; ++j) {
            s[4 * i + j] = i > 0 ? s[4 * (i - 1) + j] : 0;
        }
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_lu4_factor_tol(s, piv, CAEKF_EPS * 16 * 6));
        s[4 * i + i] = (caekf_scalar_t)NAN;
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_lu4_factor_tol(s, piv, CAEKF_EPS * 16 * 6));
    }
}

#endif

#if CAEKF_LA_GENERAL_LU && CAEKF_LA_LU4
/* The 4 x 4 kernel is the general LU bit for bit: factors, pivots and the matrix left behind, also when
 * an exchange hands over to the general loop at step 0, 1 or 2 or a step refuses. */
static void test_lu4_is_the_general_lu(void)
{
    static const caekf_scalar_t cases[8][16] = {
        {4, 1, 0, 0, 1, 5, 2, 0, 0, 2, 6, 1, 0, 0, 1, 3},                     /* diagonally dominant */
        {1, 2, 3, 4, 5, 6, 7, 8, 2, 1, 9, 3, 4, 4, 1, 7},                     /* exchange at step 0 */
        {9, 1, 2, 3, 1, 1, 2, 1, 2, 8, 1, 1, 3, 1, 1, 9},                     /* exchange at step 1 */
        {9, 1, 1, 1, 1, 9, 1, 1, 1, 1, 1, 1, 1, 1, 8, 9},                     /* exchange at step 2 */
        {2, 1, 0, 0, 1, 2, 1, 0, 0, 1, 2, 1, 2, 4, 2, (caekf_scalar_t)1e-30}, /* late refusal */
        {-3, 1, 1, 1, 1, -3, (caekf_scalar_t)0.5f, 0, 1, 0, 4, 1, 0, 1, 1, -5},
        /* exchange at step 1 for row 2 although the multiplier l10 (0.9) exceeds it */
        {1, 0, 1, 2, (caekf_scalar_t)0.9, (caekf_scalar_t)0.1, 3, 1, 0, (caekf_scalar_t)0.5, 2, 1, 0,
         (caekf_scalar_t)0.2, 1, 4},
        /* exchange at step 1 for row 3, its next entry small */
        {1, 0, 1, 2, (caekf_scalar_t)0.5, (caekf_scalar_t)0.3, 3, 1, 0, (caekf_scalar_t)0.1, 2, 1, 0,
         (caekf_scalar_t)0.8, (caekf_scalar_t)0.05, 4}};
    int c;
    for (c = 0; c < 8; ++c) {
        caekf_scalar_t a[16], b[16];
        int pa[4] = {-1, -1, -1, -1}, pb[4] = {-1, -1, -1, -1};
        int ra, rb;
        memcpy(a, cases[c], sizeof a);
        memcpy(b, cases[c], sizeof b);
        ra = caekf_lu_factor_tol(a, 4, pa, CAEKF_EPS * 16 * 9);
        rb = caekf_lu4_factor_tol(b, pb, CAEKF_EPS * 16 * 9);
        TEST_ASSERT_EQUAL_INT(ra, rb);
        TEST_ASSERT_EQUAL_MEMORY(a, b, sizeof a);
        if (ra == CAEKF_LA_OK) {
            TEST_ASSERT_EQUAL_INT_ARRAY(pa, pb, 4);
        }
    }
    { /* a pivot equal to the threshold is refused by both, at the last step too */
        caekf_scalar_t a[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, (caekf_scalar_t)0.25}, b[16];
        int pa[4], pb[4];
        memcpy(b, a, sizeof a);
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_lu_factor_tol(a, 4, pa, (caekf_scalar_t)0.25));
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_lu4_factor_tol(b, pb, (caekf_scalar_t)0.25));
    }
}
#endif

#if CAEKF_LA_GENERAL_LU && CAEKF_LA_LU4
/* The 4 x 4 solve is the general solve bit for bit, with dense factors (every L and U entry used) and the row
 * exchanges of each case, for two right-hand sides in a wider array (ldb 3: its third column untouched). */
static void test_lu4_solve_is_the_general_solve(void)
{
    static const caekf_scalar_t cases[5][16] = {
        {4, 1, 2, 3, 1, 5, 2, 1, 2, 2, 6, 1, 3, 1, 1, 7},  /* dense, no exchange */
        {1, 2, 3, 4, 5, 6, 7, 8, 2, 1, 9, 3, 4, 4, 1, 7},  /* exchange at step 0 */
        {9, 1, 2, 3, 1, 1, 2, 1, 2, 8, 1, 1, 3, 1, 1, 9},  /* exchange at step 1 */
        {9, 1, 1, 1, 1, 9, 1, 1, 1, 1, 1, 1, 1, 1, 8, 9},  /* exchange at step 2 */
        {1, 2, 3, 4, 2, 5, 1, 3, 8, 1, 2, 2, 3, 3, 9, 1}}; /* exchanges at several steps */
    int c, i;
    for (c = 0; c < 5; ++c) {
        caekf_scalar_t a[16], b[16], x[12], y[12], rhs[12];
        int pa[4], pb[4];
        memcpy(a, cases[c], sizeof a);
        memcpy(b, cases[c], sizeof b);
        for (i = 0; i < 12; ++i) {
            rhs[i] = x[i] = y[i] = (caekf_scalar_t)(i % 3 == 2 ? 99 : 1 + i * (i % 2 ? -1 : 2));
        }
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_lu_factor_tol(a, 4, pa, CAEKF_EPS * 16 * 9));
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_lu4_factor_tol(b, pb, CAEKF_EPS * 16 * 9));
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_lu_solve(a, 4, pa, x, 2, 3));
        caekf_lu4_solve(b, pb, y, 2, 3);
        TEST_ASSERT_EQUAL_MEMORY(x, y, sizeof x);
        for (i = 0; i < 4; ++i) { /* and it is the solution: A x = b for the first column */
            const double r = (double)cases[c][4 * i] * (double)x[0] + (double)cases[c][4 * i + 1] * (double)x[3] +
                             (double)cases[c][4 * i + 2] * (double)x[6] + (double)cases[c][4 * i + 3] * (double)x[9];
            TEST_ASSERT_DOUBLE_WITHIN(TOL * 100, (double)rhs[3 * i], r);
            TEST_ASSERT_EQUAL_DOUBLE(99.0, (double)x[3 * i + 2]);
        }
    }
}
#endif

#if CAEKF_FIXED_LINKS
/* Whether (i, j) lies in the Newton matrix's pattern with its fill-in (the generated tables). */
static int in_lu_pattern(int i, int j)
{
    static const unsigned char upper_nnz[] = CAEKF_SIZED_LU_UPPER_NNZ, lower_nnz[] = CAEKF_SIZED_LU_LOWER_NNZ;
    static const unsigned char upper[][CAEKF_SIZED_LU_UPPER_WIDTH] = CAEKF_SIZED_LU_UPPER_NZ;
    static const unsigned char lower[][CAEKF_SIZED_LU_LOWER_WIDTH] = CAEKF_SIZED_LU_LOWER_NZ;
    int s;
    for (s = 0; s < upper_nnz[i]; ++s) {
        if (upper[i][s] == j) {
            return 1;
        }
    }
    for (s = 0; s < lower_nnz[i]; ++s) {
        if (lower[i][s] == j) {
            return 1;
        }
    }
    return i == j;
}

/* The oracle: the textbook LU with partial pivoting (first strictly largest pivot, refused unless above
 * tol) and its solve, in the order caekf_lu_factor and caekf_lu_solve document. */
static int ref_lu(caekf_scalar_t *a, int n, int *piv, caekf_scalar_t tol)
{
    int i, j, k;
    for (k = 0; k < n; ++k) {
        int p = k;
        for (i = k + 1; i < n; ++i) {
            if (fabs((double)a[i * n + k]) > fabs((double)a[p * n + k])) {
                p = i;
            }
        }
        if (!(fabs((double)a[p * n + k]) > (double)tol)) {
            return CAEKF_LA_SINGULAR;
        }
        piv[k] = p;
        for (j = 0; j < n; ++j) {
            const caekf_scalar_t t = a[k * n + j];
            a[k * n + j] = a[p * n + j];
            a[p * n + j] = t;
        }
        for (i = k + 1; i < n; ++i) {
            a[i * n + k] /= a[k * n + k];
            for (j = k + 1; j < n; ++j) {
                a[i * n + j] -= a[i * n + k] * a[k * n + j];
            }
        }
    }
    return CAEKF_LA_OK;
}

static void ref_solve(const caekf_scalar_t *lu, int n, const int *piv, caekf_scalar_t *b, int nrhs)
{
    int i, j, c;
    for (c = 0; c < nrhs; ++c) {
        for (i = 0; i < n; ++i) {
            const caekf_scalar_t t = b[i * nrhs + c];
            b[i * nrhs + c] = b[piv[i] * nrhs + c];
            b[piv[i] * nrhs + c] = t;
        }
        for (i = 1; i < n; ++i) {
            for (j = 0; j < i; ++j) {
                b[i * nrhs + c] -= lu[i * n + j] * b[j * nrhs + c];
            }
        }
        for (i = n - 1; i >= 0; --i) {
            const caekf_scalar_t inv_d = (caekf_scalar_t)1 / lu[i * n + i];
            for (j = i + 1; j < n; ++j) {
                b[i * nrhs + c] -= lu[i * n + j] * b[j * nrhs + c];
            }
            b[i * nrhs + c] *= inv_d;
        }
    }
}

/* Equal values, a zero of either sign equal to the other, NaN to NaN. */
static int same_value(caekf_scalar_t a, caekf_scalar_t b) { return a == b || (a != a && b != b); }

/* The LU over the pattern is the dense LU bit for bit (to a zero's sign): factors, pivots and solves of
 * random matrices with the pattern, diagonally dominant (no exchange) or not (the dense loop takes over at
 * an exchange), and refusals. */
static void test_lu_sized_is_the_dense_lu(void)
{
    enum { n = CAEKF_SIZED_BODIES };
    unsigned seed = 12345u;
    int trial, exchanged = 0, plain = 0, refused = 0;
    for (trial = 0; trial < 400; ++trial) {
        caekf_scalar_t a[n * n], b[n * n], ra_[n * 3], rb_[n * 3], amax = 0;
        int pa[n], pb[n], i, j, sa, sb;
        for (i = 0; i < n; ++i) {
            for (j = 0; j < n; ++j) {
                seed = seed * 1103515245u + 12345u;
                a[i * n + j] = in_lu_pattern(i, j) ? (caekf_scalar_t)((int)(seed >> 16 & 0x7fff) - 16384) / 4096 : 0;
            }
            if (trial % 3 == 0) { /* diagonally dominant */
                a[i * n + i] += (caekf_scalar_t)(8 * n);
            }
            if (trial % 40 == 1 && i == n - 1) { /* a zero pivot at the last step */
                for (j = 0; j < n; ++j) {
                    a[i * n + j] = 0;
                }
            }
            if (trial % 40 == 2 && i == n / 2) {
                a[i * n + i] = (caekf_scalar_t)NAN;
            }
        }
        for (i = 0; i < n * n; ++i) {
            b[i] = a[i];
            amax = caekf_max(amax, CAEKF_FABS(a[i]));
        }
        for (i = 0; i < n * 3; ++i) {
            ra_[i] = rb_[i] = (caekf_scalar_t)(i % 7) - 3;
        }
        sa = ref_lu(a, n, pa, amax * CAEKF_EPS * 16);
        sb = caekf_lu_factor_sized(b, pb, amax * CAEKF_EPS * 16);
        TEST_ASSERT_EQUAL_INT(sa, sb);
        for (i = 0; i < n * n; ++i) {
            TEST_ASSERT_TRUE(same_value(a[i], b[i]));
        }
        if (sa != CAEKF_LA_OK) {
            ++refused;
            continue;
        }
        TEST_ASSERT_EQUAL_INT_ARRAY(pa, pb, n);
        j = 1; /* whether the LU kept the rows in order */
        for (i = 0; i < n; ++i) {
            j &= pa[i] == i;
        }
        exchanged += !j;
        plain += j;
        ref_solve(a, n, pa, ra_, 3);
        caekf_lu_solve_sized(b, pb, rb_, 3, 3);
        for (i = 0; i < n * 3; ++i) {
            TEST_ASSERT_TRUE(same_value(ra_[i], rb_[i]));
        }
    }
    TEST_ASSERT_TRUE(plain > 100); /* both paths and the refusals were taken */
    TEST_ASSERT_TRUE(n < 2 || exchanged > 10);
    TEST_ASSERT_TRUE(refused >= 10);
}
#endif

static void test_sym2_inverse_and_refusals(void)
{
    caekf_scalar_t inv[3];
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_sym2_inverse(4, 1, 3, CAEKF_EPS * 16, inv));
    TEST_ASSERT_DOUBLE_WITHIN(TOL, 3.0 / 11.0, (double)inv[0]);
    TEST_ASSERT_DOUBLE_WITHIN(TOL, -1.0 / 11.0, (double)inv[1]);
    TEST_ASSERT_DOUBLE_WITHIN(TOL, 4.0 / 11.0, (double)inv[2]);
    /* Rank one plus a negligible R: the determinant is rounding noise, so it is refused. */
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse(1 + (caekf_scalar_t)1e-20, 1, 1 + (caekf_scalar_t)1e-20,
                                                                CAEKF_EPS * 16, inv));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse(0, 0, 1, CAEKF_EPS * 16, inv));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse(-1, 0, 1, CAEKF_EPS * 16, inv));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse((caekf_scalar_t)NAN, 0, 1, CAEKF_EPS * 16, inv));
}

/* The refusal threshold is relative to a c, whatever a and c are on their own: a = 100, c = 0.01 (a c = 1) with
 * the determinant at half and at twice rel_tol, and the same with a and c exchanged. */
static void test_sym2_inverse_threshold_is_relative_to_a_times_c(void)
{
    const caekf_scalar_t rel_tol = (caekf_scalar_t)1e-6;
    caekf_scalar_t inv[3];
    const caekf_scalar_t b_half = CAEKF_SQRT((caekf_scalar_t)100 * (caekf_scalar_t)0.01 - (caekf_scalar_t)5e-7);
    const caekf_scalar_t b_twice = CAEKF_SQRT((caekf_scalar_t)100 * (caekf_scalar_t)0.01 - (caekf_scalar_t)2e-6);
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse(100, b_half, (caekf_scalar_t)0.01, rel_tol, inv));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_SINGULAR, caekf_sym2_inverse((caekf_scalar_t)0.01, b_half, 100, rel_tol, inv));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_sym2_inverse(100, b_twice, (caekf_scalar_t)0.01, rel_tol, inv));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_sym2_inverse((caekf_scalar_t)0.01, b_twice, 100, rel_tol, inv));
}

#if CAEKF_LA_GENERAL_LU
/* Sizes: 1 x 1 is a matrix; 0, a right-hand side count below 1 or a leading dimension below it are refused. */
static void test_sizes_from_one_and_refused_shapes(void)
{
    caekf_scalar_t a[1] = {4}, b[4] = {8, 0, 0, 0}, w[4];
    int piv[1];
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_lu_factor_tol(a, 1, piv, (caekf_scalar_t)1e-12));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_lu_solve(a, 1, piv, b, 1, 1));
    TEST_ASSERT_EQUAL_DOUBLE(2.0, (double)b[0]);
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_lu_solve(a, 0, piv, b, 1, 1));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_lu_solve(a, 1, piv, b, 0, 1));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_lu_solve(a, 1, piv, b, 2, 1));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_check(a, 1, CAEKF_EPS * 1024, w));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_sym_eigen(a, 1, w));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_BAD_SIZE, caekf_sym_eigen(a, 0, w));
}
#endif

static void rotated(caekf_scalar_t a[3][3], const double d[3], double angle);

/* Jacobi: a tridiagonal matrix (every coupling next to the diagonal: 2 - sqrt 2, 2, 2 + sqrt 2), and a matrix
 * of tiny entries (1e-9: the convergence test is relative to the diagonal) rebuilt from its eigenvectors. */
static void test_eigen_tridiagonal_and_tiny_matrices(void)
{
    caekf_scalar_t t[9] = {2, 1, 0, 1, 2, 1, 0, 1, 2}, v[9], a[9], w[9];
    const double r2 = sqrt(2.0), expect[3] = {2 - r2, 2, 2 + r2};
    double got[3], tmp;
    int i, j, k;
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_sym_eigen(t, 3, v));
    for (i = 0; i < 3; ++i) {
        got[i] = (double)t[4 * i];
    }
    for (i = 0; i < 3; ++i) { /* sorted */
        for (j = i + 1; j < 3; ++j) {
            if (got[j] < got[i]) {
                tmp = got[i];
                got[i] = got[j];
                got[j] = tmp;
            }
        }
        TEST_ASSERT_DOUBLE_WITHIN(TOL * 10, expect[i], got[i]);
    }
    {
        const double d[3] = {3e-9, 1e-9, 2e-9};
        caekf_scalar_t r[3][3];
        rotated(r, d, 0.4);
        memcpy(a, r, sizeof a);
        memcpy(w, r, sizeof w);
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_sym_eigen(w, 3, v));
        for (i = 0; i < 3; ++i) {
            for (j = 0; j < 3; ++j) {
                double s = 0;
                for (k = 0; k < 3; ++k) {
                    s += (double)v[i * 3 + k] * (double)w[k * 3 + k] * (double)v[j * 3 + k];
                }
                TEST_ASSERT_DOUBLE_WITHIN(TOL * 1e-8, (double)a[i * 3 + j], s);
            }
        }
    }
}

/* The PSD test reads its n x n workspace's upper triangle only: stale values elsewhere in it (and after it)
 * change nothing, also on a zero pivot's coupling check. */
static void test_psd_check_ignores_stale_workspace(void)
{
    caekf_scalar_t w[16];
    caekf_scalar_t semidef[3][3] = {{1, 1, 0}, {1, 1, 0}, {0, 0, 2}}; /* zero pivot at step 1 */
    int i;
    for (i = 0; i < 16; ++i) {
        w[i] = (caekf_scalar_t)1e30;
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_check(&semidef[0][0], 3, CAEKF_EPS * 1024, w));
}

/* A zero or negative variance: its row and column are dropped, in place, and nothing outside the n x n matrix
 * is touched (a guard after it). */
static void test_psd_repair_drops_rows_of_non_positive_variance(void)
{
    caekf_scalar_t buf[9 + 4], v[9];
    const caekf_scalar_t a[9] = {4, 1, 2, 1, 0, 1, 2, 1, 9};
    int i;
    for (i = 0; i < 13; ++i) {
        buf[i] = i < 9 ? a[i] : 77;
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_repair(buf, 3, v));
    for (i = 0; i < 3; ++i) {
        TEST_ASSERT_EQUAL_DOUBLE(0.0, (double)buf[3 + i]);
        TEST_ASSERT_EQUAL_DOUBLE(0.0, (double)buf[3 * i + 1]);
    }
    /* the remaining 2 x 2 [4 2; 2 9] is positive definite: kept */
    TEST_ASSERT_DOUBLE_WITHIN(TOL * 10, 4.0, (double)buf[0]);
    TEST_ASSERT_DOUBLE_WITHIN(TOL * 10, 2.0, (double)buf[2]);
    TEST_ASSERT_DOUBLE_WITHIN(TOL * 10, 2.0, (double)buf[6]);
    TEST_ASSERT_DOUBLE_WITHIN(TOL * 100, 9.0, (double)buf[8]);
    for (i = 9; i < 13; ++i) {
        TEST_ASSERT_EQUAL_DOUBLE(77.0, (double)buf[i]);
    }
}

static void test_psd_check_cases(void)
{
    caekf_scalar_t w[9];
    caekf_scalar_t id[3][3] = {{1, 0, 0}, {0, 2, 0}, {0, 0, 3}};
    caekf_scalar_t indef[3][3] = {{1, 2, 0}, {2, 1, 0}, {0, 0, 1}};
    caekf_scalar_t semidef[3][3] = {{1, 1, 0}, {1, 1, 0}, {0, 0, 0}}; /* rank 1 with a zero row */
    caekf_scalar_t coupled_zero[3][3] = {{1, 0, 0.5f}, {0, 1, 0}, {0.5f, 0, 0}};
    caekf_scalar_t corr_above_one[2][2] = {{1e-12f, 1.001e-6f}, {1.001e-6f, 1}}; /* corr 1.001 */
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_check(&id[0][0], 3, CAEKF_EPS * 1024, w));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(&indef[0][0], 3, CAEKF_EPS * 1024, w));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_check(&semidef[0][0], 3, CAEKF_EPS * 1024, w));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(&coupled_zero[0][0], 3, CAEKF_EPS * 1024, w));
    /* Scale invariance: tiny and large variances side by side are judged by correlation. */
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(&corr_above_one[0][0], 2, CAEKF_EPS * 1024, w));
    corr_above_one[0][1] = corr_above_one[1][0] = (caekf_scalar_t)0.999e-6;
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_check(&corr_above_one[0][0], 2, CAEKF_EPS * 1024, w));
}

/* Zero variances anywhere: accepted with a zero row and column, refused with any coupling, whether the
 * coupling sits before or after the zero diagonal in the upper triangle the test reads. */
static void test_psd_check_zero_variances(void)
{
    caekf_scalar_t w[9];
    caekf_scalar_t mid[3][3] = {{2, 0, 1}, {0, 0, 0}, {1, 0, 3}};
    caekf_scalar_t two[3][3] = {{0, 0, 0}, {0, 4, 0}, {0, 0, 0}};
    caekf_scalar_t first_indef[3][3] = {{0, 0, 0}, {0, 1, 2}, {0, 2, 1}};
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_check(&mid[0][0], 3, CAEKF_EPS * 1024, w));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_check(&two[0][0], 3, CAEKF_EPS * 1024, w));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(&first_indef[0][0], 3, CAEKF_EPS * 1024, w));
    mid[0][1] = mid[1][0] = (caekf_scalar_t)0.1; /* coupled to a state before it */
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(&mid[0][0], 3, CAEKF_EPS * 1024, w));
    mid[0][1] = mid[1][0] = 0;
    mid[1][2] = mid[2][1] = (caekf_scalar_t)0.1; /* coupled to a state after it */
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(&mid[0][0], 3, CAEKF_EPS * 1024, w));
    two[0][2] = two[2][0] = (caekf_scalar_t)1e-30; /* two zero variances coupled to each other */
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(&two[0][0], 3, CAEKF_EPS * 1024, w));
}

/* A = R diag(d) R^T with R a rotation in the (0, 2) plane. */
static void rotated(caekf_scalar_t a[3][3], const double d[3], double angle)
{
    double c = cos(angle), s = sin(angle);
    double r[3][3] = {{c, 0, -s}, {0, 1, 0}, {s, 0, c}};
    int i, j, k;
    for (i = 0; i < 3; ++i) {
        for (j = 0; j < 3; ++j) {
            double acc = 0;
            for (k = 0; k < 3; ++k) {
                acc += r[i][k] * d[k] * r[j][k];
            }
            a[i][j] = (caekf_scalar_t)acc;
        }
    }
}

/* A NaN off the diagonal is refused, not taken for converged (it fails every comparison): the 2-norm of P
 * then reports an error instead of a norm of the diagonal. */
static void test_eigen_refuses_a_nan(void)
{
    caekf_scalar_t a[9] = {2, 0, 0, 0, 1, 0, 0, 0, 3}, w[9], nrm = -1;
    a[1] = a[3] = (caekf_scalar_t)NAN;
    memcpy(w, a, sizeof a);
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_FINITE, caekf_sym_eigen(w, 3, 0));
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_FINITE, caekf_sym_norm2(a, 3, w, &nrm));
    a[1] = a[3] = (caekf_scalar_t)INFINITY;
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_FINITE, caekf_sym_norm2(a, 3, w, &nrm));
}

static void test_eigen_norm_and_repair(void)
{
    const double d[3] = {5, 0.5, -2}; /* the negative one mixes with axis 0 */
    caekf_scalar_t a[3][3], w[9], v[9], nrm;
    double eig[3];
    int i;
    rotated(a, d, 0.7);
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_sym_norm2(&a[0][0], 3, w, &nrm));
    TEST_ASSERT_DOUBLE_WITHIN(TOL * 50, 5.0, (double)nrm);
    memcpy(w, a, sizeof a);
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_sym_eigen(w, 3, v));
    for (i = 0; i < 3; ++i) {
        eig[i] = (double)w[i * 3 + i];
    }
    /* The eigenvalues, in any order, are the d's. */
    TEST_ASSERT_DOUBLE_WITHIN(TOL * 50, d[0] + d[1] + d[2], eig[0] + eig[1] + eig[2]);
    TEST_ASSERT_DOUBLE_WITHIN(TOL * 200, d[0] * d[1] * d[2], eig[0] * eig[1] * eig[2]);
    /* Repair: indefinite in, PSD out, variances kept. */
    TEST_ASSERT_EQUAL_INT(CAEKF_LA_NOT_PSD, caekf_psd_check(&a[0][0], 3, CAEKF_EPS * 1024, w));
    {
        caekf_scalar_t diag_before[3] = {a[0][0], a[1][1], a[2][2]};
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_repair(&a[0][0], 3, v));
        TEST_ASSERT_EQUAL_INT(CAEKF_LA_OK, caekf_psd_check(&a[0][0], 3, CAEKF_EPS * 1024, w));
        TEST_ASSERT_DOUBLE_WITHIN(0.5, (double)diag_before[1], (double)a[1][1]); /* untouched axis */
        TEST_ASSERT_TRUE(a[0][0] > 0 && a[2][2] > 0);
        TEST_ASSERT_EQUAL_DOUBLE((double)a[0][2], (double)a[2][0]);
    }
}

int main(void)
{
    UNITY_BEGIN();
#if CAEKF_LA_LU4
    RUN_TEST(test_lu4_solves_and_refuses);
#endif
#if CAEKF_FIXED_LINKS
    RUN_TEST(test_lu_sized_is_the_dense_lu);
#endif
#if CAEKF_LA_GENERAL_LU && CAEKF_LA_LU4
    RUN_TEST(test_lu4_is_the_general_lu);
    RUN_TEST(test_lu4_solve_is_the_general_solve);
#endif
#if CAEKF_LA_GENERAL_LU
    RUN_TEST(test_lu_solves_several_rhs_with_pivoting);
    RUN_TEST(test_lu_refuses_singular_and_nan);
#endif
    RUN_TEST(test_sym2_inverse_and_refusals);
    RUN_TEST(test_sym2_inverse_threshold_is_relative_to_a_times_c);
#if CAEKF_LA_GENERAL_LU
    RUN_TEST(test_sizes_from_one_and_refused_shapes);
#endif
    RUN_TEST(test_eigen_tridiagonal_and_tiny_matrices);
    RUN_TEST(test_psd_check_ignores_stale_workspace);
    RUN_TEST(test_psd_repair_drops_rows_of_non_positive_variance);
    RUN_TEST(test_psd_check_cases);
    RUN_TEST(test_psd_check_zero_variances);
    RUN_TEST(test_eigen_norm_and_repair);
    RUN_TEST(test_eigen_refuses_a_nan);
    return UNITY_END();
}
