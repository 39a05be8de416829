/*
 * The filter's building blocks on the scaled state z = S^-1 x and scaled covariance P (internal).
 * H selects z[0] (q1) and z[3] (q4): the structure is used instead of multiplying by H.
 * Within a step the work covariance is kept as its upper triangle only (the *_upper functions read
 * and write j >= i; caekf_mirror_upper completes a full symmetric matrix).
 */
#ifndef CAEKF_FILTER_H
#define CAEKF_FILTER_H

#include <stdint.h>

#include "caekf/caekf_config.h"

#define CAEKF_IY1 0 /* state index measured by y1 (q1) */
#define CAEKF_IY4 3 /* state index measured by y4 (q4) */

typedef caekf_scalar_t caekf_mat_t[CAEKF_N][CAEKF_N];

/* How gamma is handled in this step. */
typedef enum {
    CAEKF_GAMMA_LIVE = 0,         /* canonical, or switched with contact active */
    CAEKF_GAMMA_FROZEN_SCHMIDT,   /* switched, inactive, consistent variant */
    CAEKF_GAMMA_FROZEN_PAPER      /* switched, inactive, eqs. 23-27 literally */
} caekf_gamma_policy_t;

/* Copies the upper triangle into the lower one. */
void caekf_mirror_upper(caekf_mat_t P);

/* Eq. (12) P- = F P F^T + Q with the structure of eq. (10): fv holds the v-rows of the scaled F and
 * the q-rows are I + c * fv (c = dt s_v / s_q); the gamma row is e_gamma. Q_gamma is skipped and the
 * gamma row/column handled per policy (eqs. 21-24). P: full symmetric; P_pred: upper triangle only.
 * contact == 0 promises the contact-free F: fv's gamma column is 0 and it is block diagonal over
 * bodies (1,2) and (3,4) (exact zeros elsewhere), which the products then skip. */
void caekf_predict_covariance(caekf_mat_t P, caekf_mat_t P_pred, caekf_scalar_t fv[CAEKF_NQ][CAEKF_N],
                              caekf_scalar_t c, const caekf_scalar_t q_diag[CAEKF_N], caekf_gamma_policy_t policy,
                              int contact);

/* Eqs. (13)-(15), or (25)-(27) with the policy, for y_s = [q1, q4] / s_q. Standard or Joseph form.
 * Returns 0, or sets CAEKF_FLAG_SINGULAR_INNOVATION and leaves z, P untouched. *nis: the normalised
 * innovation squared; with gate > 0 and nis above it a live gamma is held for this correction
 * (Schmidt gain, flag GAMMA_GATED). */
int caekf_correct_upper(caekf_scalar_t z[CAEKF_N], caekf_mat_t P, const caekf_scalar_t y_s[CAEKF_NY],
                        caekf_scalar_t r, int joseph, caekf_gamma_policy_t policy, caekf_scalar_t gate,
                        caekf_scalar_t *nis, uint32_t *flags);

/* Eqs. (28)-(30): if z_gamma < zmin, the perfect measurement D z = zmin (D = e_gamma, R = 0).
 * Processing it after the y-correction equals repeating the correction with [H; D] and
 * blkdiag(R, 0) (independent measurements can be processed in sequence), and keeps the refusal test
 * on one scalar: the posterior variance of gamma. If that variance is not usable (<= tiny, or P's
 * gamma column violates Cauchy-Schwarz), the documented fallback clamps gamma to zmin and leaves
 * the other states and P alone (flags CONSTRAINT_CLAMPED | SINGULAR_INNOVATION).
 * gamma_min_phys and s_gamma guarantee z * s_gamma >= gamma_min_phys after rounding. */
void caekf_constrain_upper(caekf_scalar_t z[CAEKF_N], caekf_mat_t P, caekf_scalar_t zmin, caekf_scalar_t s_gamma,
                           caekf_scalar_t gamma_min_phys, uint32_t *flags);

/* Covariance health of an upper-triangle P: a cheap necessary test every step (P_ii >= 0,
 * P_ij^2 <= P_ii P_jj) and, when full_check, the complete PSD test (LDL^T of the correlation form).
 * A failure is flagged COV_INDEFINITE; with repair allowed P is repaired (flag COV_REPAIRED; P is then
 * full). Never silent. Returns 1 when every entry of P is finite (afterwards), else 0. */
int caekf_covariance_health(caekf_mat_t P, int full_check, int repair, caekf_mat_t scratch, uint32_t *flags);

#endif /* CAEKF_FILTER_H */
