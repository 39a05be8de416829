/* Prediction, correction, switch-off, constraint and covariance health on the scaled state. */
#include "caekf_filter.h"

#include "caekf/caekf.h"
#include "caekf_linalg.h"
#include "caekf_math.h"

#define NQ CAEKF_NQ
#define N CAEKF_N
#define IG CAEKF_IG

CAEKF_STATIC_ASSERT(CAEKF_NY == 2, two_position_sensors);
CAEKF_STATIC_ASSERT(CAEKF_IY1 < NQ && CAEKF_IY4 < NQ, sensors_measure_positions);

/* Mirrors the upper triangle into the lower one, flushing off-diagonal values below CAEKF_TINY to 0:
 * decaying cross-covariances otherwise become subnormal, which costs 5x in float on x86 and means
 * nothing next to the O(1) scaled variances. */
static void mirror_upper(caekf_mat_t P)
{
    int i, j;
    for (i = 1; i < N; ++i) {
        for (j = 0; j < i; ++j) {
            caekf_scalar_t v = P[j][i];
            if (CAEKF_FABS(v) < CAEKF_TINY) {
                v = 0;
                P[j][i] = 0;
            }
            P[i][j] = v;
        }
    }
}

static void save_gamma_column(caekf_mat_t P, caekf_scalar_t col[N])
{
    int i;
    for (i = 0; i < N; ++i) {
        col[i] = P[i][IG];
    }
}

static void restore_gamma_column(caekf_mat_t P, const caekf_scalar_t col[N])
{
    int i;
    for (i = 0; i < N; ++i) {
        P[i][IG] = col[i];
        P[IG][i] = col[i];
    }
}

void caekf_predict_covariance(caekf_mat_t P, caekf_mat_t T, caekf_scalar_t fv[NQ][N], caekf_scalar_t c,
                              const caekf_scalar_t q_diag[N], caekf_gamma_policy_t policy)
{
    caekf_scalar_t W[N][NQ]; /* (F P) Fv^T */
    int i, j, k;
    /* T = F P first; T F^T then overwrites T in place (row i only reads T's row i upper part). */
    for (i = 0; i < NQ; ++i) { /* v-rows of F P, then q-rows = P_q + c (F P)_v */
        for (j = 0; j < N; ++j) {
            caekf_scalar_t s = 0;
            for (k = 0; k < N; ++k) {
                s += fv[i][k] * P[k][j];
            }
            T[NQ + i][j] = s;
        }
    }
    for (i = 0; i < NQ; ++i) {
        for (j = 0; j < N; ++j) {
            T[i][j] = P[i][j] + c * T[NQ + i][j];
        }
    }
    for (j = 0; j < N; ++j) {
        T[IG][j] = P[IG][j];
    }
    for (i = 0; i < N; ++i) { /* (F P) F^T: v-columns, then q-columns, gamma column = T's */
        for (j = 0; j < NQ; ++j) {
            caekf_scalar_t s = 0;
            if (i > NQ + j) {
                continue; /* only the upper triangle of the symmetric result is formed */
            }
            for (k = 0; k < N; ++k) {
                s += T[i][k] * fv[j][k];
            }
            W[i][j] = s;
        }
    }
    for (i = 0; i < N; ++i) {
        for (j = i; j < IG; ++j) {
            T[i][j] = (j < NQ) ? T[i][j] + c * W[i][j] : W[i][j - NQ];
        }
    }
    mirror_upper(T);
    for (i = 0; i < IG; ++i) {
        T[i][i] += q_diag[i];
    }
    if (policy == CAEKF_GAMMA_LIVE) {
        T[IG][IG] += q_diag[IG]; /* eq. (21): Q_gamma only while gamma is observable */
    } else if (policy == CAEKF_GAMMA_FROZEN_PAPER) {
        for (i = 0; i < N; ++i) { /* eqs. (23)-(24): only P_xx propagates */
            T[i][IG] = P[i][IG];
            T[IG][i] = P[IG][i];
        }
    }
}

int caekf_correct(caekf_scalar_t z[N], caekf_mat_t P, const caekf_scalar_t y_s[CAEKF_NY], caekf_scalar_t r, int joseph,
                  caekf_gamma_policy_t policy, caekf_mat_t scratch, uint32_t *flags)
{
    caekf_scalar_t Si[3];
    caekf_scalar_t G[N][CAEKF_NY];
    caekf_scalar_t e0, e1;
    caekf_scalar_t gcol[N];
    int i, j;
    /* Eq. (13): S = H P- H^T + R is the (q1, q4) block of P plus R. */
    if (caekf_sym2_inverse(P[CAEKF_IY1][CAEKF_IY1] + r, P[CAEKF_IY1][CAEKF_IY4], P[CAEKF_IY4][CAEKF_IY4] + r,
                           CAEKF_EPS * 16, Si) != CAEKF_LA_OK) {
        *flags |= CAEKF_FLAG_SINGULAR_INNOVATION;
        return -1;
    }
    if (policy == CAEKF_GAMMA_FROZEN_PAPER) {
        save_gamma_column(P, gcol);
    }
    for (i = 0; i < N; ++i) {
        caekf_scalar_t a = P[i][CAEKF_IY1], b = P[i][CAEKF_IY4];
        G[i][0] = a * Si[0] + b * Si[1];
        G[i][1] = a * Si[1] + b * Si[2];
    }
    if (policy != CAEKF_GAMMA_LIVE) {
        G[IG][0] = 0; /* eq. (26) with gamma frozen: a Schmidt ("consider") gain */
        G[IG][1] = 0;
    }
    e0 = y_s[0] - z[CAEKF_IY1]; /* eq. (14) */
    e1 = y_s[1] - z[CAEKF_IY4];
    for (i = 0; i < N; ++i) {
        z[i] += G[i][0] * e0 + G[i][1] * e1;
    }
    if (!joseph) {
        /* Eq. (15) on the upper triangle: P+ = P - G (H P). With the gamma gain zeroed, row gamma of
         * this product would stay stale; taking the upper triangle and mirroring gives the Schmidt
         * result P_xg <- (I - G_x H_x) P_xg, P_gg unchanged. */
        caekf_scalar_t hp1[N], hp4[N]; /* H P, copied: the update overwrites those rows */
        for (j = 0; j < N; ++j) {
            hp1[j] = P[CAEKF_IY1][j];
            hp4[j] = P[CAEKF_IY4][j];
        }
        for (i = 0; i < N; ++i) {
            for (j = i; j < N; ++j) {
                P[i][j] -= G[i][0] * hp1[j] + G[i][1] * hp4[j];
            }
        }
    } else {
        /* Joseph: P+ = (I - G H) P (I - G H)^T + G R G^T, with A P computed first (in scratch). */
        caekf_scalar_t(*AP)[N] = scratch;
        for (i = 0; i < N; ++i) {
            for (j = 0; j < N; ++j) {
                AP[i][j] = P[i][j] - (G[i][0] * P[CAEKF_IY1][j] + G[i][1] * P[CAEKF_IY4][j]);
            }
        }
        for (i = 0; i < N; ++i) {
            for (j = i; j < N; ++j) {
                P[i][j] = AP[i][j] - AP[i][CAEKF_IY1] * G[j][0] - AP[i][CAEKF_IY4] * G[j][1] +
                          r * (G[i][0] * G[j][0] + G[i][1] * G[j][1]);
            }
        }
    }
    mirror_upper(P);
    if (policy == CAEKF_GAMMA_FROZEN_PAPER) {
        restore_gamma_column(P, gcol); /* eq. (27): only P_xx is corrected */
    }
    return 0;
}

void caekf_constrain(caekf_scalar_t z[N], caekf_mat_t P, caekf_scalar_t zmin, caekf_scalar_t s_gamma,
                     caekf_scalar_t gamma_min_phys, uint32_t *flags)
{
    caekf_scalar_t s = P[IG][IG];
    caekf_scalar_t dz = zmin - z[IG];
    int usable = s > CAEKF_EPS * CAEKF_EPS;
    int i, j, k;
    if (!(z[IG] < zmin)) {
        return;
    }
    *flags |= CAEKF_FLAG_CONSTRAINT_APPLIED;
    for (i = 0; i < IG && usable; ++i) { /* a valid covariance has P_ig^2 <= P_ii P_gg */
        usable = P[i][IG] * P[i][IG] <= P[i][i] * s * (1 + CAEKF_EPS * 64) + CAEKF_EPS * CAEKF_EPS;
    }
    if (usable) {
        /* Scalar perfect measurement (R = 0): gain k = P e_g / P_gg, P+ = P - P e_g e_g^T P / P_gg.
         * The standard and the Joseph forms coincide here. Row/column gamma become exactly 0. */
        for (i = 0; i < IG; ++i) {
            z[i] += P[i][IG] / s * dz;
        }
        for (i = 0; i < IG; ++i) {
            for (j = i; j < IG; ++j) {
                P[i][j] -= P[i][IG] * P[j][IG] / s;
            }
        }
        for (i = 0; i < N; ++i) {
            P[i][IG] = 0;
        }
        mirror_upper(P);
    } else {
        *flags |= CAEKF_FLAG_CONSTRAINT_CLAMPED | CAEKF_FLAG_SINGULAR_INNOVATION;
    }
    z[IG] = zmin;
    /* Rounding of zmin * s_gamma must not land below gamma_min: step up by ulps (bounded). */
    for (k = 0; k < 4 && z[IG] * s_gamma < gamma_min_phys; ++k) {
        z[IG] += CAEKF_FABS(z[IG]) * CAEKF_EPS + (caekf_scalar_t)1e-30;
    }
}

/* Every valid covariance has P_ii >= 0 and P_ij^2 <= P_ii P_jj; failing either is the common way
 * P goes bad (|corr| > 1, as eqs. 23-27 produce). Cheap enough for every step. */
static int screen_fails(caekf_mat_t P)
{
    int i, j;
    for (i = 0; i < N; ++i) {
        if (!(P[i][i] >= 0)) {
            return 1;
        }
        for (j = i + 1; j < N; ++j) {
            if (P[i][j] * P[i][j] > P[i][i] * P[j][j] * (1 + CAEKF_EPS * 64)) {
                return 1;
            }
        }
    }
    return 0;
}

void caekf_covariance_health(caekf_mat_t P, int full_check, int repair, caekf_mat_t scratch, uint32_t *flags)
{
    if (!screen_fails(P)) {
        /* Tolerance on the correlation form: rounding grows with the ~N-term sums of each update. */
        if (!full_check || caekf_psd_check(&P[0][0], N, CAEKF_EPS * 1024, &scratch[0][0]) == CAEKF_LA_OK) {
            return;
        }
    }
    *flags |= CAEKF_FLAG_COV_INDEFINITE;
    if (repair) {
        (void)caekf_psd_repair(&P[0][0], N, &scratch[0][0]);
        *flags |= CAEKF_FLAG_COV_REPAIRED;
    }
}
