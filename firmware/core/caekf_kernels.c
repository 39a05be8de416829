/* The linear-algebra kernels, whole functions chosen by the build (CMSIS-DSP style; the selection:
 * caekf_kernels.h): the LU of any size and the dense solve, the 4 x 4 LU written out, the LU over the Newton
 * matrix's pattern where the build fixes the links, and the full PSD test of P, written out for a sized
 * state's n. Each variant runs the operations of the general one in the same order: the same bits. */
#include "caekf_linalg.h"

#include "caekf_math.h"

#define A_(m, n, i, j) ((m)[(i) * (n) + (j)])
/* Partial-pivoting LU from elimination step k0 on (steps before it done, without row exchanges). */
static caekf_la_status_t lu_factor_from(caekf_scalar_t *a, int n, int piv[], caekf_scalar_t tol, int k0)
{
    int i, j, k;
    for (k = k0; k < n; ++k) {
        caekf_scalar_t *ak = a + k * n;
        caekf_scalar_t best = CAEKF_FABS(ak[k]);
        int p = k;
        for (i = k + 1; i < n; ++i) {
            caekf_scalar_t cand = CAEKF_FABS(A_(a, n, i, k));
            if (cand > best) {
                best = cand;
                p = i;
            }
        }
        /* Written as !(best > tol) so that a NaN pivot is refused too. */
        if (!(best > tol)) {
            return CAEKF_LA_SINGULAR;
        }
        piv[k] = p;
        if (p != k) {
            caekf_scalar_t *ap = a + p * n;
            for (j = 0; j < n; ++j) {
                caekf_scalar_t t = ak[j];
                ak[j] = ap[j];
                ap[j] = t;
            }
        }
        for (i = k + 1; i < n; ++i) {
            caekf_scalar_t *ai = a + i * n;
            caekf_scalar_t l = ai[k] / ak[k];
            ai[k] = l;
            for (j = k + 1; j < n; ++j) {
                ai[j] -= l * ak[j];
            }
        }
    }
    return CAEKF_LA_OK;
}

#if CAEKF_LA_GENERAL_LU
caekf_la_status_t caekf_lu_factor(caekf_scalar_t *a, int n, int piv[], caekf_scalar_t rel_tol)
{
    int i;
    caekf_scalar_t amax = 0;
    if (!caekf_la_size_ok(n)) {
        return CAEKF_LA_BAD_SIZE;
    }
    for (i = 0; i < n * n; ++i) {
        amax = caekf_max(amax, CAEKF_FABS(a[i]));
    }
    return lu_factor_from(a, n, piv, rel_tol * amax, 0);
}

caekf_la_status_t caekf_lu_factor_tol(caekf_scalar_t *a, int n, int piv[], caekf_scalar_t tol)
{
    return caekf_la_size_ok(n) ? lu_factor_from(a, n, piv, tol, 0) : CAEKF_LA_BAD_SIZE;
}
#endif /* CAEKF_LA_GENERAL_LU */

#if CAEKF_LA_DENSE_SOLVE
/* The solve with the factors of caekf_lu_factor_from, sizes checked by the caller. */
static void lu_solve(const caekf_scalar_t *lu, int n, const int piv[], caekf_scalar_t *b, int nrhs, int ldb)
{
    int i, j, c;
    for (c = 0; c < nrhs; ++c) { /* column by column: each column sees the same operations */
        caekf_scalar_t *x = b + c;
        for (i = 0; i < n; ++i) {
            caekf_scalar_t t = x[i * ldb];
            x[i * ldb] = x[piv[i] * ldb];
            x[piv[i] * ldb] = t;
        }
        for (i = 1; i < n; ++i) { /* forward: L has a unit diagonal */
            for (j = 0; j < i; ++j) {
                x[i * ldb] -= A_(lu, n, i, j) * x[j * ldb];
            }
        }
        for (i = n - 1; i >= 0; --i) { /* backward */
            caekf_scalar_t inv_d = (caekf_scalar_t)1 / A_(lu, n, i, i);
            for (j = i + 1; j < n; ++j) {
                x[i * ldb] -= A_(lu, n, i, j) * x[j * ldb];
            }
            x[i * ldb] *= inv_d;
        }
    }
}
#endif /* CAEKF_LA_DENSE_SOLVE */

#if CAEKF_LA_GENERAL_LU
caekf_la_status_t caekf_lu_solve(const caekf_scalar_t *lu, int n, const int piv[], caekf_scalar_t *b, int nrhs, int ldb)
{
    if (!caekf_la_size_ok(n) || nrhs < 1 || ldb < nrhs) {
        return CAEKF_LA_BAD_SIZE;
    }
    lu_solve(lu, n, piv, b, nrhs, ldb);
    return CAEKF_LA_OK;
}
#endif /* CAEKF_LA_GENERAL_LU */

#if CAEKF_LA_LU4
/* Step k of the 4 x 4 elimination for row i (k < i): l = a_ik / a_kk, then a_ij -= l a_kj for j = 3 .. k + 1,
 * each entry once (the general loop's operations). */
CAEKF_HOT_INLINE void lu4_eliminate(caekf_scalar_t *a, int k, int i)
{
    caekf_scalar_t *const ri = a + 4 * i;
    const caekf_scalar_t *const rk = a + 4 * k;
    const caekf_scalar_t l = ri[k] / rk[k];
    int j;
    ri[k] = l;
    CAEKF_UNROLL_SIZED
    for (j = 3; j > k; --j) {
        ri[j] -= l * rk[j];
    }
}

caekf_la_status_t caekf_lu4_factor_tol(caekf_scalar_t *a, int piv[4], caekf_scalar_t tol)
{
    /* While partial pivoting keeps the diagonal (no later row strictly larger in column k; A is
     * diagonally dominant in practice) the elimination is written out, step by step (a deliberately
     * unrolled kernel); an exchange goes to the general loop from that step. */
    caekf_scalar_t best = CAEKF_FABS(a[0]);
    if (CAEKF_FABS(a[4]) > best || CAEKF_FABS(a[8]) > best || CAEKF_FABS(a[12]) > best) {
        return lu_factor_from(a, 4, piv, tol, 0);
    }
    if (!(best > tol)) { /* also refuses a NaN pivot */
        return CAEKF_LA_SINGULAR;
    }
    piv[0] = 0;
    lu4_eliminate(a, 0, 1);
    lu4_eliminate(a, 0, 2);
    lu4_eliminate(a, 0, 3);
    best = CAEKF_FABS(a[5]);
    if (CAEKF_FABS(a[9]) > best || CAEKF_FABS(a[13]) > best) {
        return lu_factor_from(a, 4, piv, tol, 1);
    }
    if (!(best > tol)) {
        return CAEKF_LA_SINGULAR;
    }
    piv[1] = 1;
    lu4_eliminate(a, 1, 2);
    lu4_eliminate(a, 1, 3);
    best = CAEKF_FABS(a[10]);
    if (CAEKF_FABS(a[14]) > best) {
        return lu_factor_from(a, 4, piv, tol, 2);
    }
    if (!(best > tol)) {
        return CAEKF_LA_SINGULAR;
    }
    piv[2] = 2;
    lu4_eliminate(a, 2, 3);
    if (!(CAEKF_FABS(a[15]) > tol)) {
        return CAEKF_LA_SINGULAR;
    }
    piv[3] = 3;
    return CAEKF_LA_OK;
}

#endif /* CAEKF_LA_LU4 */

#if CAEKF_LA_LU4
/* The 4x4 solve the model runs on every step: the same operations in the same order as
 * caekf_lu_solve (bit for bit the same results), with the size fixed so that the factors stay in
 * registers across the columns. */
void caekf_lu4_solve(const caekf_scalar_t *lu, const int piv[4], caekf_scalar_t *b, int nrhs, int ldb)
{
    int perm[4] = {0, 1, 2, 3};
    int i, c;
    const caekf_scalar_t l10 = lu[4], l20 = lu[8], l21 = lu[9], l30 = lu[12], l31 = lu[13], l32 = lu[14];
    const caekf_scalar_t u01 = lu[1], u02 = lu[2], u03 = lu[3], u12 = lu[6], u13 = lu[7], u23 = lu[11];
    const caekf_scalar_t d0 = (caekf_scalar_t)1 / lu[0], d1 = (caekf_scalar_t)1 / lu[5],
                         d2 = (caekf_scalar_t)1 / lu[10], d3 = (caekf_scalar_t)1 / lu[15];
    const caekf_scalar_t *r0, *r1, *r2, *r3;
    for (i = 0; i < 4 && (piv[0] | (piv[1] ^ 1) | (piv[2] ^ 2) | (piv[3] ^ 3)) != 0; ++i) {
        /* the row swaps (none without an exchange), applied once as a permutation of the rows */
        int t = perm[i];
        perm[i] = perm[piv[i]];
        perm[piv[i]] = t;
    }
    r0 = b + perm[0] * ldb;
    r1 = b + perm[1] * ldb;
    r2 = b + perm[2] * ldb;
    r3 = b + perm[3] * ldb;
    for (c = 0; c < nrhs; ++c) { /* each column: all four read before any is written */
        caekf_scalar_t x0 = r0[c], x1 = r1[c], x2 = r2[c], x3 = r3[c];
        x1 -= l10 * x0; /* forward: L has a unit diagonal */
        x2 -= l20 * x0;
        x2 -= l21 * x1;
        x3 -= l30 * x0;
        x3 -= l31 * x1;
        x3 -= l32 * x2;
        x3 *= d3; /* backward */
        x2 -= u23 * x3;
        x2 *= d2;
        x1 -= u12 * x2;
        x1 -= u13 * x3;
        x1 *= d1;
        x0 -= u01 * x1;
        x0 -= u02 * x2;
        x0 -= u03 * x3;
        x0 *= d0;
        b[c] = x0;
        b[ldb + c] = x1;
        b[2 * ldb + c] = x2;
        b[3 * ldb + c] = x3;
    }
}

#endif /* CAEKF_LA_LU4 */

#if CAEKF_FIXED_LINKS
/* The Newton matrix's pattern in its LU without exchanges (generated from the sized mechanism): row k's
 * columns right of the diagonal, which are also column k's rows below it (the pattern is symmetric), and
 * row i's columns left of it. The loops over them are written out (constant bounds and columns). */
static const unsigned char lu_upper_nnz[CAEKF_SIZED_BODIES] = CAEKF_SIZED_LU_UPPER_NNZ;
static const unsigned char lu_upper[CAEKF_SIZED_BODIES][CAEKF_SIZED_LU_UPPER_WIDTH] = CAEKF_SIZED_LU_UPPER_NZ;
static const unsigned char lu_lower_nnz[CAEKF_SIZED_BODIES] = CAEKF_SIZED_LU_LOWER_NNZ;
static const unsigned char lu_lower[CAEKF_SIZED_BODIES][CAEKF_SIZED_LU_LOWER_WIDTH] = CAEKF_SIZED_LU_LOWER_NZ;

caekf_la_status_t caekf_lu_factor_sized(caekf_scalar_t *a, int piv[], caekf_scalar_t tol)
{
    enum { n = CAEKF_SIZED_BODIES };
    int k, s, t;
    CAEKF_UNROLL_SIZED
    for (k = 0; k < n; ++k) {
        const caekf_scalar_t *const ak = a + k * n;
        const caekf_scalar_t best = CAEKF_FABS(ak[k]);
        CAEKF_UNROLL_SIZED
        for (s = 0; s < lu_upper_nnz[k]; ++s) { /* partial pivoting would exchange: the dense loop from here */
            if (CAEKF_FABS(a[lu_upper[k][s] * n + k]) > best) {
                return lu_factor_from(a, n, piv, tol, k);
            }
        }
        if (!(best > tol)) { /* also refuses a NaN pivot */
            return CAEKF_LA_SINGULAR;
        }
        piv[k] = k;
        CAEKF_UNROLL_SIZED
        for (s = 0; s < lu_upper_nnz[k]; ++s) {
            caekf_scalar_t *const ai = a + lu_upper[k][s] * n;
            const caekf_scalar_t l = ai[k] / ak[k];
            ai[k] = l;
            CAEKF_UNROLL_SIZED
            for (t = 0; t < lu_upper_nnz[k]; ++t) {
                ai[lu_upper[k][t]] -= l * ak[lu_upper[k][t]];
            }
        }
    }
    return CAEKF_LA_OK;
}

void caekf_lu_solve_sized(const caekf_scalar_t *lu, const int piv[], caekf_scalar_t *b, int nrhs, int ldb)
{
    enum { n = CAEKF_SIZED_BODIES };
    caekf_scalar_t inv_d[CAEKF_SIZED_BODIES]; /* each column's 1 / u_ii, computed once */
    int i, s, c;
    CAEKF_UNROLL_SIZED
    for (i = 0; i < n; ++i) {
        if (piv[i] != i) {
            lu_solve(lu, n, piv, b, nrhs, ldb);
            return;
        }
        inv_d[i] = (caekf_scalar_t)1 / lu[i * n + i];
    }
    for (c = 0; c < nrhs; ++c) {
        caekf_scalar_t *const x = b + c;
        CAEKF_UNROLL_SIZED
        for (i = 1; i < n; ++i) { /* forward: L has a unit diagonal */
            CAEKF_UNROLL_SIZED
            for (s = 0; s < lu_lower_nnz[i]; ++s) {
                x[i * ldb] -= lu[i * n + lu_lower[i][s]] * x[lu_lower[i][s] * ldb];
            }
        }
        CAEKF_UNROLL_SIZED
        for (i = n - 1; i >= 0; --i) { /* backward */
            CAEKF_UNROLL_SIZED
            for (s = 0; s < lu_upper_nnz[i]; ++s) {
                x[i * ldb] -= lu[i * n + lu_upper[i][s]] * x[lu_upper[i][s] * ldb];
            }
            x[i * ldb] *= inv_d[i];
        }
    }
}
#endif /* CAEKF_FIXED_LINKS */

/* The full PSD test lies on the worst step of a build sized for substeps (a contact step that also runs
 * it): written out there for the state's n, CAEKF_PSD_WRITTEN_OUT_N (caekf_kernels.h). Elsewhere a loop (the
 * one-step build keeps its text). */
#if CAEKF_PSD_WRITTEN_OUT_N && defined(__GNUC__) && !defined(__clang__)
#define PSD_UNROLL _Pragma("GCC unroll 16")
#else
#define PSD_UNROLL
#endif /* CAEKF_PSD_WRITTEN_OUT_N */

/* caekf_psd_check for a valid n. */
CAEKF_HOT_INLINE caekf_la_status_t psd_ldl(const caekf_scalar_t *a, int n, caekf_scalar_t tol, caekf_scalar_t *w)
{
    int i, j, k;
    PSD_UNROLL
    for (i = 0; i < n; ++i) { /* w <- a's upper triangle; every variance finite and >= 0 */
        const caekf_scalar_t aii = A_(a, n, i, i);
        if (!(aii >= 0) || !CAEKF_ISFINITE(aii)) {
            return CAEKF_LA_NOT_PSD;
        }
        PSD_UNROLL
        for (j = i; j < n; ++j) {
            A_(w, n, i, j) = A_(a, n, i, j);
        }
    }
    /* Outer-product LDL^T on the upper triangle, judged as on the correlation form D^-1/2 A D^-1/2
     * (D = diag A; independent of the state scaling) without forming it: the form's pivot k is
     * w_kk / a_kk and its coupling left in row i is w_ki / sqrt(a_kk a_ii). A zero variance then needs
     * a zero row. */
    PSD_UNROLL
    for (k = 0; k < n; ++k) {
        const caekf_scalar_t *wk = w + k * n;
        const caekf_scalar_t piv = wk[k], t = tol * A_(a, n, k, k);
        if (piv < -t) {
            return CAEKF_LA_NOT_PSD;
        }
        if (piv <= t) {
            /* Zero pivot: a PSD matrix has no coupling left in this direction; |w_ik|^2 <= w_ii w_kk (not
             * squared: a tiny coupling of a zero variance would underflow). */
            for (i = k + 1; i < n; ++i) {
                const caekf_scalar_t wii = A_(w, n, i, i), tii = tol * A_(a, n, i, i);
                if (CAEKF_FABS(wk[i]) > CAEKF_SQRT(t * caekf_max(wii, tii))) {
                    return CAEKF_LA_NOT_PSD;
                }
            }
            continue;
        }
        PSD_UNROLL
        for (i = k + 1; i < n; ++i) {
            caekf_scalar_t *wi = w + i * n;
            const caekf_scalar_t l = wk[i] / piv;
            PSD_UNROLL
            for (j = i; j < n; ++j) {
                wi[j] -= l * wk[j];
            }
        }
    }
    return CAEKF_LA_OK;
}

caekf_la_status_t caekf_psd_check(const caekf_scalar_t *a, int n, caekf_scalar_t tol, caekf_scalar_t *w)
{
    if (!caekf_la_size_ok(n)) {
        return CAEKF_LA_BAD_SIZE;
    }
    if (CAEKF_PSD_WRITTEN_OUT_N != 0 && n == CAEKF_PSD_WRITTEN_OUT_N) { /* the written-out instance */
        return psd_ldl(a, CAEKF_PSD_WRITTEN_OUT_N, tol, w);
    }
    return psd_ldl(a, n, tol, w);
}
