/*
 * Fixed-size dense linear algebra for the sizes the estimator uses (n <= CAEKF_LA_MAX_N). Matrices
 * are row-major arrays with leading dimension n (or ldb for right-hand sides). No allocation: callers
 * own every buffer (`work` arguments are n x n scratch, so stack use stays small on an MCU); loops
 * are bounded by CAEKF_LA_MAX_N.
 */
#ifndef CAEKF_LINALG_H
#define CAEKF_LINALG_H

#include "caekf/caekf_config.h"
#include "caekf_kernels.h" /* which kernels the build has */

#define CAEKF_LA_MAX_N CAEKF_N

typedef enum {
    CAEKF_LA_OK = 0,
    CAEKF_LA_SINGULAR = 1, /* a pivot fell below the refusal threshold (cf. ARM_MATH_SINGULAR) */
    CAEKF_LA_BAD_SIZE = 2,
    CAEKF_LA_NOT_PSD = 3,
    CAEKF_LA_NOT_FINITE = 4 /* a NaN or infinite entry (or squares that overflow) */
} caekf_la_status_t;

/* A size the routines take. */
static inline int caekf_la_size_ok(int n) { return n >= 1 && n <= CAEKF_LA_MAX_N; }

/* The LU kernels: declared for every build, defined in caekf_kernels.c for the builds that run them (code that
 * names one another build lacks sits under if of a constant false there, and compiles out). */

/* LU with partial pivoting, in place: PA = LU. A pivot whose magnitude is <= rel_tol * max|a_ij| is
 * refused (CAEKF_LA_SINGULAR) instead of being divided by. */
caekf_la_status_t caekf_lu_factor(caekf_scalar_t *a, int n, int piv[], caekf_scalar_t rel_tol);

/* caekf_lu_factor with the refusal threshold given (tol = rel_tol * max|a_ij|, from a caller who knows the
 * largest entry already): bit for bit the same. */
caekf_la_status_t caekf_lu_factor_tol(caekf_scalar_t *a, int n, int piv[], caekf_scalar_t tol);

/* Solves A X = B for nrhs right-hand sides stored as the columns of b (n x nrhs, leading dim ldb). */
caekf_la_status_t caekf_lu_solve(const caekf_scalar_t *lu, int n, const int piv[], caekf_scalar_t *b, int nrhs,
                                 int ldb);

/* caekf_lu_factor for n = 4 with the refusal threshold given (tol = rel_tol * max|a_ij|, from a
 * caller who knows the largest entry already): bit for bit the same, faster. */
caekf_la_status_t caekf_lu4_factor_tol(caekf_scalar_t *a, int piv[4], caekf_scalar_t tol);

/* caekf_lu_solve for n = 4 (lu row-major 4 x 4), bit for bit the same, faster. */
void caekf_lu4_solve(const caekf_scalar_t *lu, const int piv[4], caekf_scalar_t *b, int nrhs, int ldb);

/* The LU with partial pivoting (caekf_lu_factor's, with the refusal threshold given) of a matrix with the Newton matrix's pattern
 * (CAEKF_SIZED_LU_UPPER_NZ / _LOWER_NZ, its fill-in included): the same operations on the pattern's
 * entries, the others skipped (they subtract l * 0 or 0 * u), so the factors are the same bit for bit up
 * to the sign of a zero wherever they are finite. A step that would exchange rows hands over to the
 * dense loop. */
caekf_la_status_t caekf_lu_factor_sized(caekf_scalar_t *a, int piv[], caekf_scalar_t tol);

/* The solve with such factors, alike: the pattern's operations where the LU exchanged no rows,
 * the dense solve where it did. */
void caekf_lu_solve_sized(const caekf_scalar_t *lu, const int piv[], caekf_scalar_t *b, int nrhs, int ldb);

/* Inverse of a symmetric 2x2 [a b; b c]. Refused (SINGULAR) when the determinant is <= rel_tol * a c
 * or a, c <= 0: an innovation covariance must be positive definite. */
caekf_la_status_t caekf_sym2_inverse(caekf_scalar_t a, caekf_scalar_t b, caekf_scalar_t c, caekf_scalar_t rel_tol,
                                     caekf_scalar_t inv[3]);

/* Positive-semidefiniteness test: LDL^T of a, its pivots and couplings judged as those of the correlation
 * form D^-1/2 A D^-1/2 (scale invariant, D = diag a); pivots within tol of zero count as zero (such
 * directions must then have no coupling left). Reads the upper triangle of the symmetric a only. */
caekf_la_status_t caekf_psd_check(const caekf_scalar_t *a, int n, caekf_scalar_t tol, caekf_scalar_t *work);

/* Cyclic Jacobi eigen-decomposition of a symmetric matrix: on return a's diagonal holds the
 * eigenvalues and v (may be NULL) the eigenvectors as columns. At most CAEKF_JACOBI_MAX_SWEEPS sweeps. */
caekf_la_status_t caekf_sym_eigen(caekf_scalar_t *a, int n, caekf_scalar_t *v);

/* Largest |eigenvalue| of a symmetric matrix (its 2-norm), computed on a copy. */
caekf_la_status_t caekf_sym_norm2(const caekf_scalar_t *a, int n, caekf_scalar_t *work, caekf_scalar_t *norm2);

/* PSD repair: negative eigenvalues of the correlation form clipped to 0, variances kept. */
caekf_la_status_t caekf_psd_repair(caekf_scalar_t *a, int n, caekf_scalar_t *work);

#endif /* CAEKF_LINALG_H */
