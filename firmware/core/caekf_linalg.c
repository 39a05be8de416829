#include "caekf_linalg.h"

#include "caekf_math.h"

#define A_(m, n, i, j) ((m)[(i) * (n) + (j)])

caekf_la_status_t caekf_sym2_inverse(caekf_scalar_t a, caekf_scalar_t b, caekf_scalar_t c, caekf_scalar_t rel_tol,
                                     caekf_scalar_t inv[3])
{
    caekf_scalar_t det = a * c - b * b;
    if (!(a > 0) || !(c > 0) || !(det > rel_tol * a * c)) {
        return CAEKF_LA_SINGULAR;
    }
    inv[0] = c / det;
    inv[1] = -b / det;
    inv[2] = a / det;
    return CAEKF_LA_OK;
}

/* Plane rotation of two strided vectors: x <- c x - s y, y <- s x + c y. */
static void rotate(caekf_scalar_t *x, caekf_scalar_t *y, int stride, int n, caekf_scalar_t c, caekf_scalar_t s)
{
    int k;
    for (k = 0; k < n; ++k, x += stride, y += stride) {
        caekf_scalar_t xk = *x, yk = *y;
        *x = c * xk - s * yk;
        *y = s * xk + c * yk;
    }
}

caekf_la_status_t caekf_sym_eigen(caekf_scalar_t *a, int n, caekf_scalar_t *v)
{
    int sweep, p, q;
    if (!caekf_la_size_ok(n)) {
        return CAEKF_LA_BAD_SIZE;
    }
    if (v != 0) {
        for (p = 0; p < n; ++p) {
            for (q = 0; q < n; ++q) {
                A_(v, n, p, q) = (p == q) ? 1 : 0;
            }
        }
    }
    for (sweep = 0; sweep < CAEKF_JACOBI_MAX_SWEEPS; ++sweep) {
        caekf_scalar_t off = 0, diag = 0;
        for (p = 0; p < n; ++p) {
            diag += A_(a, n, p, p) * A_(a, n, p, p);
            for (q = p + 1; q < n; ++q) {
                off += A_(a, n, p, q) * A_(a, n, p, q);
            }
        }
        if (!CAEKF_ISFINITE(off + diag)) {
            return CAEKF_LA_NOT_FINITE; /* a NaN would pass the test below as converged */
        }
        if (!(off > CAEKF_EPS * CAEKF_EPS * diag)) {
            return CAEKF_LA_OK;
        }
        for (p = 0; p < n - 1; ++p) {
            for (q = p + 1; q < n; ++q) {
                caekf_scalar_t apq = A_(a, n, p, q);
                caekf_scalar_t theta, t, c, s;
                if (apq == 0) {
                    continue;
                }
                /* Rotation annihilating a_pq (Golub & Van Loan, symmetric Schur 2x2). */
                theta = (A_(a, n, q, q) - A_(a, n, p, p)) / (2 * apq);
                t = (theta >= 0 ? 1 : -1) / (CAEKF_FABS(theta) + CAEKF_SQRT(theta * theta + 1));
                if (!CAEKF_ISFINITE(t)) {
                    t = 0; /* theta overflowed: a_pq is negligible */
                }
                c = 1 / CAEKF_SQRT(t * t + 1);
                s = t * c;
                rotate(a + p, a + q, n, n, c, s);         /* A <- A J (columns p, q) */
                rotate(a + p * n, a + q * n, 1, n, c, s); /* A <- J^T A (rows p, q) */
                if (v != 0) {
                    rotate(v + p, v + q, n, n, c, s);
                }
            }
        }
    }
    return CAEKF_LA_OK; /* bound reached: the result is still a valid similarity transform */
}

caekf_la_status_t caekf_sym_norm2(const caekf_scalar_t *a, int n, caekf_scalar_t *w, caekf_scalar_t *norm2)
{
    caekf_scalar_t best = 0;
    caekf_la_status_t st;
    int i;
    if (!caekf_la_size_ok(n)) {
        return CAEKF_LA_BAD_SIZE;
    }
    for (i = 0; i < n * n; ++i) {
        w[i] = a[i];
    }
    st = caekf_sym_eigen(w, n, 0);
    for (i = 0; i < n; ++i) {
        best = caekf_max(best, CAEKF_FABS(A_(w, n, i, i)));
    }
    *norm2 = best;
    return st;
}

caekf_la_status_t caekf_psd_repair(caekf_scalar_t *a, int n, caekf_scalar_t *v)
{
    caekf_scalar_t lam[CAEKF_LA_MAX_N];
    caekf_scalar_t d[CAEKF_LA_MAX_N];
    caekf_la_status_t st;
    int i, j, k;
    if (!caekf_la_size_ok(n)) {
        return CAEKF_LA_BAD_SIZE;
    }
    /* Negative or non-finite variances cannot be normalised: drop those rows and columns first
     * (which leaves the other diagonal entries alone). */
    for (i = 0; i < n; ++i) {
        caekf_scalar_t aii = A_(a, n, i, i);
        if (!(aii > 0) || !CAEKF_ISFINITE(aii)) {
            for (j = 0; j < n; ++j) {
                A_(a, n, i, j) = 0;
                A_(a, n, j, i) = 0;
            }
        }
        d[i] = CAEKF_SQRT(A_(a, n, i, i)); /* for a <- D^-1/2 a D^-1/2 in place */
    }
    for (i = 0; i < n; ++i) {
        for (j = 0; j < n; ++j) {
            caekf_scalar_t dd = d[i] * d[j];
            A_(a, n, i, j) = dd > 0 ? A_(a, n, i, j) / dd : 0;
        }
    }
    st = caekf_sym_eigen(a, n, v);
    for (k = 0; k < n; ++k) {
        lam[k] = caekf_max(A_(a, n, k, k), 0);
    }
    for (i = 0; i < n; ++i) { /* a = D^1/2 V diag(max(lam, 0)) V^T D^1/2, symmetric by construction */
        for (j = i; j < n; ++j) {
            caekf_scalar_t s = 0;
            for (k = 0; k < n; ++k) {
                s += A_(v, n, i, k) * lam[k] * A_(v, n, j, k);
            }
            s *= d[i] * d[j];
            A_(a, n, i, j) = s;
            A_(a, n, j, i) = s;
        }
    }
    return st;
}
