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
CAEKF_STATIC_ASSERT(CAEKF_IY1 == 0, q1_row_is_all_upper_triangle);

/* Off-diagonal covariances below CAEKF_TINY are flushed to 0 as they are written: decaying
 * cross-covariances otherwise become subnormal, which costs 5x in float on x86 and means nothing
 * next to the O(1) scaled variances. */
static caekf_scalar_t flush(caekf_scalar_t v) { return CAEKF_FABS(v) < CAEKF_TINY ? 0 : v; }

/* The step works on the upper triangle only; the lower one is filled where a full matrix is needed. */
void caekf_mirror_upper(caekf_mat_t P)
{
    int i, j;
    for (i = 1; i < N; ++i) {
        for (j = 0; j < i; ++j) {
            P[i][j] = P[j][i];
        }
    }
}

/* The products of eq. (12) below are dot products of 9-vectors, summed for k ascending from s = 0:
 * exactly the order of the plain loops they replace, so every result is bit for bit the same. One
 * operand is held in registers across the other's rows. Without contact F is block diagonal over
 * bodies (1,2) and (3,4) (K, C, M are) and its gamma column is 0: those entries are exact zeros and
 * are skipped, as adding their zero products changes no sum. */
CAEKF_STATIC_ASSERT(N == 9 && NQ == 4, eq12_kernels_are_written_for_9_states_of_2_blocks);

/* Row i of F P and of its q-part: y[j] = (Fv P)_ij = f . P_j (P symmetric), tq[j] = P_ij + c y[j];
 * t = tq, y = t + NQ * N (rows i and NQ + i of the same matrix). b < 0: dense f, else f's block. */
static void predict_fp_row(const caekf_scalar_t *f, const caekf_scalar_t *pj, const caekf_scalar_t *pi,
                           caekf_scalar_t *t, caekf_scalar_t c, int b)
{
    const caekf_scalar_t *const end = t + N;
    if (b < 0) {
        const caekf_scalar_t f0 = f[0], f1 = f[1], f2 = f[2], f3 = f[3], f4 = f[4], f5 = f[5], f6 = f[6],
                             f7 = f[7], f8 = f[8];
        for (; t != end; ++t, ++pi, pj += N) {
            caekf_scalar_t s = 0;
            s += f0 * pj[0];
            s += f1 * pj[1];
            s += f2 * pj[2];
            s += f3 * pj[3];
            s += f4 * pj[4];
            s += f5 * pj[5];
            s += f6 * pj[6];
            s += f7 * pj[7];
            s += f8 * pj[8];
            t[NQ * N] = s;
            *t = *pi + c * s;
        }
    } else {
        const caekf_scalar_t f0 = f[b], f1 = f[b + 1], f4 = f[b + NQ], f5 = f[b + NQ + 1];
        for (pj += b; t != end; ++t, ++pi, pj += N) {
            caekf_scalar_t s = 0;
            s += f0 * pj[0];
            s += f1 * pj[1];
            s += f4 * pj[NQ];
            s += f5 * pj[NQ + 1];
            t[NQ * N] = s;
            *t = *pi + c * s;
        }
    }
}

/* w[jj] = t . Fv_jj for jj = j0..NQ-1, t held in registers (t may be overwritten afterwards). */
static void predict_w(const caekf_scalar_t *t, caekf_scalar_t fv[NQ][N], int j0, caekf_scalar_t w[NQ], int contact)
{
    const caekf_scalar_t t0 = t[0], t1 = t[1], t2 = t[2], t3 = t[3], t4 = t[4], t5 = t[5], t6 = t[6], t7 = t[7],
                         t8 = t[8];
    const caekf_scalar_t *f = fv[j0];
    int jj;
    if (contact) {
        for (jj = j0; jj < NQ; ++jj, f += N) {
            caekf_scalar_t s = 0;
            s += t0 * f[0];
            s += t1 * f[1];
            s += t2 * f[2];
            s += t3 * f[3];
            s += t4 * f[4];
            s += t5 * f[5];
            s += t6 * f[6];
            s += t7 * f[7];
            s += t8 * f[8];
            w[jj] = s;
        }
        return;
    }
    for (jj = j0; jj < 2; ++jj, f += N) {
        caekf_scalar_t s = 0;
        s += t0 * f[0];
        s += t1 * f[1];
        s += t4 * f[4];
        s += t5 * f[5];
        w[jj] = s;
    }
    for (jj = j0 > 2 ? j0 : 2, f = fv[jj]; jj < NQ; ++jj, f += N) {
        caekf_scalar_t s = 0;
        s += t2 * f[2];
        s += t3 * f[3];
        s += t6 * f[6];
        s += t7 * f[7];
        w[jj] = s;
    }
}

void caekf_predict_covariance(caekf_mat_t P, caekf_mat_t T, caekf_scalar_t fv[NQ][N], caekf_scalar_t c,
                              const caekf_scalar_t q_diag[N], caekf_gamma_policy_t policy, int contact)
{
    caekf_scalar_t w[NQ];
    int i;
    for (i = 0; i < NQ; ++i) { /* T = F P: v-rows Fv P, q-rows P_q + c (Fv P) */
        predict_fp_row(fv[i], P[0], P[i], T[i], c, contact ? -1 : (i & 2));
    }
    /* Upper triangle of T F^T + Q row by row, in place: row i only reads row i of T. w = T_i Fv^T
     * gives the v-columns; a q-row's q-columns are T_q + c w; the gamma column is T's. Off-diagonal
     * entries are flushed as they are final. */
    for (i = 0; i < IG; ++i) {
        caekf_scalar_t *t = T[i];
        caekf_scalar_t d, *tj;
        const caekf_scalar_t *wj;
        predict_w(t, fv, i < NQ ? 0 : i - NQ, w, contact);
        if (i < NQ) {
            d = t[i] + c * w[i];
            for (tj = t + i + 1, wj = w + i + 1; tj != t + NQ; ++tj, ++wj) {
                *tj = flush(*tj + c * *wj);
            }
            tj = t + NQ;
        } else {
            d = w[i - NQ];
            tj = t + i + 1;
        }
        t[i] = d + q_diag[i];
        for (wj = w + (tj - t - NQ); tj != t + IG; ++tj, ++wj) {
            *tj = flush(*wj);
        }
        t[IG] = flush(t[IG]);
    }
    T[IG][IG] = P[IG][IG];
    if (policy == CAEKF_GAMMA_LIVE) {
        T[IG][IG] += q_diag[IG]; /* eq. (21): Q_gamma only while gamma is observable */
    } else if (policy == CAEKF_GAMMA_FROZEN_PAPER) {
        for (i = 0; i < N; ++i) { /* eqs. (23)-(24): only P_xx propagates */
            T[i][IG] = P[i][IG];
        }
    }
}

int caekf_correct_upper(caekf_scalar_t z[N], caekf_mat_t P, const caekf_scalar_t y_s[CAEKF_NY], caekf_scalar_t r,
                        int joseph, caekf_gamma_policy_t policy, caekf_scalar_t gate, caekf_scalar_t *nis,
                        uint32_t *flags)
{
    caekf_scalar_t Si[3];
    caekf_scalar_t G[N][CAEKF_NY];
    caekf_scalar_t hp1[N], hp4[N]; /* H P = rows q1, q4 of P (= its columns), from the upper triangle */
    caekf_scalar_t e0, e1;
    /* Eq. (27), paper switch-off: only P_xx is corrected, the gamma column is left as it is. */
    const int jend = policy == CAEKF_GAMMA_FROZEN_PAPER ? IG : N;
    /* cppcheck-suppress variableScope ; declarations at the top of the block are this file's style */
    int i, j;
    /* Eq. (13): S = H P- H^T + R is the (q1, q4) block of P plus R. */
    if (caekf_sym2_inverse(P[CAEKF_IY1][CAEKF_IY1] + r, P[CAEKF_IY1][CAEKF_IY4], P[CAEKF_IY4][CAEKF_IY4] + r,
                           CAEKF_EPS * 16, Si) != CAEKF_LA_OK) {
        *flags |= CAEKF_FLAG_SINGULAR_INNOVATION;
        return -1;
    }
    e0 = y_s[0] - z[CAEKF_IY1]; /* eq. (14) */
    e1 = y_s[1] - z[CAEKF_IY4];
    /* Normalised innovation squared e^T S^-1 e: chi-square with 2 degrees of freedom while the filter
     * is consistent. Far above that, the linearisation behind the gamma gain no longer holds (e.g. the
     * first measurement after a gap in contact): gamma is held this step as a consider state. */
    *nis = e0 * (Si[0] * e0 + 2 * Si[1] * e1) + Si[2] * e1 * e1;
    if (policy == CAEKF_GAMMA_LIVE && gate > 0 && *nis > gate) {
        policy = CAEKF_GAMMA_FROZEN_SCHMIDT;
        *flags |= CAEKF_FLAG_GAMMA_GATED;
    }
    for (i = 0; i < N; ++i) {
        hp1[i] = P[CAEKF_IY1][i];
        hp4[i] = i < CAEKF_IY4 ? P[i][CAEKF_IY4] : P[CAEKF_IY4][i];
        G[i][0] = hp1[i] * Si[0] + hp4[i] * Si[1];
        G[i][1] = hp1[i] * Si[1] + hp4[i] * Si[2];
    }
    if (policy != CAEKF_GAMMA_LIVE) {
        G[IG][0] = 0; /* eq. (26) with gamma frozen: a Schmidt ("consider") gain */
        G[IG][1] = 0;
    }
    for (i = 0; i < N; ++i) {
        z[i] += G[i][0] * e0 + G[i][1] * e1;
    }
    if (!joseph) {
        /* Eq. (15) on the upper triangle: P+ = P - G (H P). With the gamma gain zeroed, row gamma of
         * this product would stay stale; the upper triangle alone gives the Schmidt result
         * P_xg <- (I - G_x H_x) P_xg, P_gg unchanged. */
        for (i = 0; i < jend; ++i) {
            const caekf_scalar_t g0 = G[i][0], g1 = G[i][1];
            const caekf_scalar_t *h1 = hp1 + i, *h4 = hp4 + i;
            caekf_scalar_t *p = P[i] + i, *const pend = P[i] + jend;
            *p -= g0 * *h1 + g1 * *h4;
            while (++p != pend) {
                ++h1;
                ++h4;
                *p = flush(*p - (g0 * *h1 + g1 * *h4));
            }
        }
    } else {
        /* Joseph: P+ = (A P) A^T + G R G^T with A = I - G H, i.e. A P - (A P)_{:,q1 q4} G^T + r G G^T.
         * Row i of A P at q1 and q4 comes from the copies of H P (P is symmetric). */
        for (i = 0; i < jend; ++i) {
            const caekf_scalar_t g0 = G[i][0], g1 = G[i][1];
            const caekf_scalar_t a1 = hp1[i] - (g0 * hp1[CAEKF_IY1] + g1 * hp4[CAEKF_IY1]);
            const caekf_scalar_t a4 = hp4[i] - (g0 * hp1[CAEKF_IY4] + g1 * hp4[CAEKF_IY4]);
            caekf_scalar_t *p = P[i];
            for (j = i; j < jend; ++j) {
                caekf_scalar_t v = p[j] - (g0 * hp1[j] + g1 * hp4[j]) - a1 * G[j][0] - a4 * G[j][1] +
                                   r * (g0 * G[j][0] + g1 * G[j][1]);
                p[j] = j > i ? flush(v) : v;
            }
        }
    }
    return 0;
}

void caekf_constrain_upper(caekf_scalar_t z[N], caekf_mat_t P, caekf_scalar_t zmin, caekf_scalar_t s_gamma,
                           caekf_scalar_t gamma_min_phys, uint32_t *flags)
{
    caekf_scalar_t s = P[IG][IG];
    caekf_scalar_t dz = zmin - z[IG];
    caekf_scalar_t col[IG]; /* P's gamma column, contiguous */
    int usable = s > CAEKF_EPS * CAEKF_EPS;
    int i, k;
    if (!(z[IG] < zmin)) {
        return;
    }
    *flags |= CAEKF_FLAG_CONSTRAINT_APPLIED;
    for (i = 0; i < IG; ++i) { /* a valid covariance has P_ig^2 <= P_ii P_gg */
        col[i] = P[i][IG];
        usable = usable && col[i] * col[i] <= P[i][i] * s * (1 + CAEKF_EPS * 64) + CAEKF_EPS * CAEKF_EPS;
    }
    if (usable) {
        /* Scalar perfect measurement (R = 0): gain k = P e_g / P_gg, P+ = P - P e_g e_g^T P / P_gg.
         * The standard and the Joseph forms coincide here. Row/column gamma become exactly 0. */
        for (i = 0; i < IG; ++i) {
            const caekf_scalar_t a = col[i];
            const caekf_scalar_t *cj = col + i;
            caekf_scalar_t *p = P[i] + i, *const pend = P[i] + IG;
            z[i] += a / s * dz;
            *p -= a * a / s;
            while (++p != pend) {
                ++cj;
                *p = flush(*p - a * *cj / s);
            }
            *pend = 0;
        }
        P[IG][IG] = 0;
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
 * P goes bad (|corr| > 1, as eqs. 23-27 produce). Cheap enough for every step. On the way it sums
 * v * 0 over the upper triangle into *nf: 0 when every entry is finite, NaN otherwise (one
 * multiply-add per entry instead of a classification); *nf is only complete when the screen passes. */
static int screen_fails(caekf_mat_t P, caekf_scalar_t *nf)
{
    caekf_scalar_t acc = 0;
    int i;
    for (i = 0; i < N; ++i) {
        const caekf_scalar_t *pij = &P[i][i], *const pend = P[i] + N;
        const caekf_scalar_t *pjj = pij;
        const caekf_scalar_t pii = *pij;
        acc += pii * 0;
        if (!(pii >= 0)) {
            return 1;
        }
        while (++pij != pend) {
            const caekf_scalar_t v = *pij;
            pjj += N + 1;
            acc += v * 0;
            if (v * v > pii * *pjj * (1 + CAEKF_EPS * 64)) {
                return 1;
            }
        }
    }
    *nf = acc;
    return 0;
}

int caekf_covariance_health(caekf_mat_t P, int full_check, int repair, caekf_mat_t scratch, uint32_t *flags)
{
    caekf_scalar_t nf = 0;
    int i, j;
    if (!screen_fails(P, &nf)) {
        /* Tolerance on the correlation form: rounding grows with the ~N-term sums of each update. */
        if (!full_check || caekf_psd_check(&P[0][0], N, CAEKF_EPS * 1024, &scratch[0][0]) == CAEKF_LA_OK) {
            return nf == 0;
        }
    }
    *flags |= CAEKF_FLAG_COV_INDEFINITE;
    if (repair) {
        caekf_mirror_upper(P);
        (void)caekf_psd_repair(&P[0][0], N, &scratch[0][0]);
        *flags |= CAEKF_FLAG_COV_REPAIRED;
    }
    nf = 0;
    for (i = 0; i < N; ++i) {
        for (j = i; j < N; ++j) {
            nf += P[i][j] * 0;
        }
    }
    return nf == 0;
}
