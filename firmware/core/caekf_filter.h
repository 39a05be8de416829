/*
 * The filter's building blocks on the scaled state z = S^-1 x and scaled covariance P (internal).
 * Matrices are n x n, row-major with leading dimension n (the augmented state [q; v; parameters]: the
 * gammas, then the estimated law parameters), in buffers of the build's capacity; a sized build
 * (CAEKF_SIZED) runs its mechanism's n only, and there an n argument must be that n (the loops use the
 * constant). H selects one position or velocity per sensor: the structure is used instead of multiplying
 * by H. Within a step the work covariance is kept as its upper triangle only (the *_upper functions read
 * and write j >= i; caekf_mirror_upper completes a full symmetric matrix).
 */
#ifndef CAEKF_FILTER_H
#define CAEKF_FILTER_H

#include <stdint.h>

#include "caekf/caekf_model.h"
#include "caekf_math.h"

/* How a parameter (a gamma or an estimated law parameter) is handled in this step. */
typedef enum {
    CAEKF_GAMMA_LIVE = 0,       /* canonical, or switched with its contact active */
    CAEKF_GAMMA_FROZEN_SCHMIDT, /* switched, contact inactive, consistent variant */
    CAEKF_GAMMA_FROZEN_PAPER    /* switched, contact inactive, eqs. 23-27 literally */
} caekf_gamma_policy_t;

/* Compacts fv's rows in place to their nonzeros (fv[i][k] is column pat->nz[i][k]): the products skip
 * the exact zeros, as adding a zero product changes no sum. */
void caekf_fv_compact(caekf_scalar_t fv[CAEKF_NQ][CAEKF_N], int nq, int n, caekf_fv_pattern_t *pat);

/* Marks every row of fv dense (nothing moved): the products then run over all n columns. For finite
 * operands that is the compacted result bit for bit: a zero product added to a sum started at +0 changes
 * nothing (x + 0 = x for x != 0, +0 + -0 = +0), so a step in contact (rows dense in practice) skips the
 * scan for zeros. */
CAEKF_HOT_INLINE void caekf_fv_dense(int nq, int n, caekf_fv_pattern_t *pat)
{
    int i;
    CAEKF_UNROLL_SIZED
    for (i = 0; i < nq; ++i) {
        pat->nnz[i] = (unsigned char)n;
    }
    pat->dense = 1;
}

/* Copies the upper triangle into the lower one. */
void caekf_mirror_upper(caekf_scalar_t *P, int n);

/* Eq. (12) P- = F P F^T + Q with the structure of eq. (10): fv holds the v-rows of the scaled F (compacted)
 * and the q-rows are [I, c2 I, 0] + c * fv (c = hs s_v / s_q, c2 = (dt - hs) s_v / s_q: 0 for backward
 * Euler), or, when fq is not NULL, fq's dense rows (the product of substep maps; c, c2 unused); the gamma
 * rows are identity rows. Q_gamma and the gamma
 * rows/columns are handled per gamma policy (eqs. 21-24). P: full symmetric; P_pred: upper triangle. */
void caekf_predict_covariance(const caekf_scalar_t *P, caekf_scalar_t *P_pred, caekf_scalar_t fv[CAEKF_NQ][CAEKF_N],
                              const caekf_fv_pattern_t *pat, caekf_scalar_t c, caekf_scalar_t c2,
                              caekf_scalar_t fq[CAEKF_NQ][CAEKF_N], const caekf_scalar_t *q_diag,
                              const caekf_filter_dims_t *d);

/* Eqs. (13)-(15), or (25)-(27) with the policies, for the scaled measurements y_s. Standard or Joseph
 * form. Returns 0, or sets CAEKF_FLAG_SINGULAR_INNOVATION and leaves z, P untouched. *nis: the
 * normalised innovation squared; with gate > 0 and nis above it every live gamma is held for this
 * correction (Schmidt gain, flag GAMMA_GATED). */
int caekf_correct_upper(caekf_scalar_t *z, caekf_scalar_t *P, const caekf_scalar_t *y_s, int joseph,
                        const caekf_filter_dims_t *d, caekf_scalar_t gate, caekf_scalar_t *nis, uint32_t *flags,
                        caekf_correct_work_t *work);

/* Eqs. (28)-(30) for the parameter at state g and one of its bounds zb (scaled): if z_g < zb (or, with
 * is_max, z_g > zb), the perfect measurement D z = zb (D = e_g, R = 0). Processing it after the
 * y-correction equals repeating the correction with [H; D] and blkdiag(R, 0) (independent measurements
 * can be processed in sequence), and keeps the refusal test on one scalar: the posterior variance of the
 * parameter. If that variance is not usable (<= tiny, or P's column g violates Cauchy-Schwarz), the
 * documented fallback clamps the parameter to zb and leaves the other states and P alone (flags
 * CONSTRAINT_CLAMPED | SINGULAR_INNOVATION). bound_phys and s_g guarantee that z_g * s_g is within
 * bound_phys after rounding. Returns 1 when the bound was violated (and is now enforced), else 0. */
int caekf_constrain_upper(caekf_scalar_t *z, caekf_scalar_t *P, int n, int g, caekf_scalar_t zb, int is_max,
                          caekf_scalar_t s_g, caekf_scalar_t bound_phys, uint32_t *flags);

/* Covariance health of an upper-triangle P: a cheap necessary test every step (P_ii >= 0,
 * P_ij^2 <= P_ii P_jj) and, when full_check, the complete PSD test (LDL^T of the correlation form).
 * A failure is flagged COV_INDEFINITE; with repair allowed P is repaired (flag COV_REPAIRED; P is then
 * full). Never silent. Returns 1 when every entry of P (afterwards) and of the state z (n values) is
 * finite, else 0. */
int caekf_covariance_health(caekf_scalar_t *P, const caekf_scalar_t *z, int n, int full_check, int repair,
                            caekf_scalar_t *scratch, uint32_t *flags);

#endif /* CAEKF_FILTER_H */
