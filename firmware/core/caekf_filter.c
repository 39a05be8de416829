/* Prediction, correction, switch-off, constraint and covariance health on the scaled state. */
#include "caekf_filter.h"

#include "caekf/caekf.h"
#include "caekf_linalg.h"
#include "caekf_math.h"

#define AT(P, n, i, j) ((P)[(i) * (n) + (j)])

/* The filter's sizes: constants in a build sized for one mechanism (the branches for other sizes and
 * the loop bounds then fold away), the instance's otherwise. SIZED_N: the size of the n x n matrices the
 * functions below are given (a sized build runs its mechanism's n only, a constant there; the argument
 * otherwise). BOUNDED_STATE(g): parameter state g that a bound is applied to, a constant where the state has one
 * bounded parameter (contact 1's gamma). */
#if CAEKF_SIZED
#define DIM_NQ(d) ((void)(d), CAEKF_SIZED_BODIES)
#define DIM_N(d) ((void)(d), CAEKF_SIZED_N)
#define DIM_NY(d) ((void)(d), CAEKF_SIZED_SENSORS)
#define SIZED_N(n) ((void)(n), DIM_N((const caekf_filter_dims_t *)0))
#define BOUNDED_STATE(g) (CAEKF_SIZED_CONTACTS == 1 && CAEKF_SIZED_LAW_PARAMS == 0 ? 2 * CAEKF_SIZED_BODIES : (g))
#else
#define DIM_NQ(d) ((d)->nq)
#define DIM_N(d) ((d)->n)
#define DIM_NY(d) ((d)->ny)
#define SIZED_N(n) (n)
#define BOUNDED_STATE(g) (g)
#endif /* CAEKF_SIZED */
/* The covariance correction's form and the gammas' switch-off: the sized configuration's (CAEKF_SIZED_METHOD,
 * so the other form's code folds away), the caller's otherwise. */
#if CAEKF_SIZED_METHOD
#define JOSEPH_FORM(joseph) ((void)(joseph), CAEKF_SIZED_COV_UPDATE == CAEKF_COV_JOSEPH)
#define FROZEN_PAPER(policy) (CAEKF_SIZED_SWITCHOFF == CAEKF_SWITCHOFF_PAPER && (policy) == CAEKF_GAMMA_FROZEN_PAPER)
#else
#define JOSEPH_FORM(joseph) (joseph)
#define FROZEN_PAPER(policy) ((policy) == CAEKF_GAMMA_FROZEN_PAPER)
#endif /* CAEKF_SIZED_METHOD */
/* Substeps' q-rows of F and the trapezoidal rule's c2: never given where the build cannot run them. */
#define FQ_GIVEN(fq) (CAEKF_HAS_SUBSTEPS && (fq) != 0)
#define C2_GIVEN(c2) (CAEKF_HAS_TRAPEZOIDAL && (c2) != 0)
/* P_ij of a matrix kept as its upper triangle. */
#define UP(P, n, i, j) ((i) <= (j) ? AT(P, n, i, j) : AT(P, n, j, i))

/* Off-diagonal covariances below CAEKF_TINY are flushed to 0 as they are written: decaying
 * cross-covariances otherwise become subnormal, which costs 5x in float on x86 and means nothing
 * next to the O(1) scaled variances. */
CAEKF_HOT_INLINE caekf_scalar_t flush(caekf_scalar_t v) { return CAEKF_FABS(v) < CAEKF_TINY ? 0 : v; }

void caekf_mirror_upper(caekf_scalar_t *P, int n)
{
    int i, j;
    for (i = 1; i < n; ++i) {
        for (j = 0; j < i; ++j) {
            AT(P, n, i, j) = AT(P, n, j, i);
        }
    }
}

void caekf_fv_compact(caekf_scalar_t fv[CAEKF_NQ][CAEKF_N], int nq, int n, caekf_fv_pattern_t *pat)
{
    int i, j, dense = 1;
    for (i = 0; i < nq; ++i) {
        unsigned char k = 0;
        const caekf_scalar_t *f = fv[i];
        for (j = 0; j < n && f[j] != 0; ++j) { /* a dense row (in contact) is left as it is */
        }
        if (j == n) {
            pat->nnz[i] = (unsigned char)n;
            continue;
        }
        dense = 0;
        for (j = 0; j < n; ++j) {
            if (fv[i][j] != 0) { /* a NaN is kept: it must reach P and be caught */
                pat->nz[i][k] = (unsigned char)j;
                fv[i][k++] = fv[i][j]; /* k <= j: in place */
            }
        }
        pat->nnz[i] = k;
    }
    pat->dense = (unsigned char)dense;
}

/* The products of eq. (12) are dot products with a row of Fv over its nonzeros, summed with the column
 * index ascending from s = 0: exactly the order of the plain dense loops, so every result is bit for
 * bit the same whatever the mechanism's sparsity (without contact, K, C and M couple only linked
 * bodies and the gamma columns are 0). */
/* sum_k a[k] b[k], k ascending from 0 (the plain loop's order), four terms per turn. */
CAEKF_HOT_INLINE caekf_scalar_t dot(const caekf_scalar_t *a, const caekf_scalar_t *b, int n)
{
    caekf_scalar_t s = 0;
    int k;
    CAEKF_UNROLL_DOT /* a sized build knows n: written out even at -Os; else four terms a turn, in the same order */
        for (k = 0; k < n; ++k)
    {
        s += a[k] * b[k];
    }
    return s;
}

/* The row a, to be held across dot products: copied into buf where the build knows n (written out, so
 * that the copy lives in registers), else a itself (a copy of unknown length would not stay there). */
CAEKF_HOT_INLINE const caekf_scalar_t *held_row(caekf_scalar_t *buf, const caekf_scalar_t *a, int n)
{
    int k;
    if (!CAEKF_SIZED) {
        return a;
    }
    CAEKF_UNROLL_SIZED
    for (k = 0; k < n; ++k) {
        buf[k] = a[k];
    }
    return buf;
}

/* A dense row f of Fv times P: tv[j] = f . P_j (P symmetric), tq[j] = P_ij + c tv[j]; f is held (in
 * registers when sized) across the rows of P. */
CAEKF_NOINLINE static void fp_row_dense(const caekf_scalar_t *f, const caekf_scalar_t *P, const caekf_scalar_t *pi,
                                        caekf_scalar_t *tq, caekf_scalar_t *tv, caekf_scalar_t c, int n)
{
    caekf_scalar_t buf[CAEKF_N];
    const caekf_scalar_t *const fr = held_row(buf, f, n);
    const caekf_scalar_t *pj = P;
    int j;
    for (j = 0; j < n; ++j, pj += n) {
        const caekf_scalar_t s = dot(fr, pj, n);
        tv[j] = s;
        tq[j] = pi[j] + c * s;
    }
}

/* tf[j] = f . P_j and tg[j] = g . P_j (P symmetric) for two dense rows f, g of F (the product of substep
 * maps): each entry of P is read once for both; f and g are held (in registers when sized) across the
 * rows of P. */
CAEKF_NOINLINE static void f_rows2_dense(const caekf_scalar_t *f, const caekf_scalar_t *g, const caekf_scalar_t *P,
                                         caekf_scalar_t *tf, caekf_scalar_t *tg, int n)
{
    caekf_scalar_t buf_f[CAEKF_N], buf_g[CAEKF_N];
    const caekf_scalar_t *const fr = held_row(buf_f, f, n), *const gr = held_row(buf_g, g, n);
    const caekf_scalar_t *pj = P;
    int j, k;
    for (j = 0; j < n; ++j, pj += n) {
        caekf_scalar_t sf = fr[0] * pj[0], sg = gr[0] * pj[0];
        CAEKF_UNROLL_SIZED
        for (k = 1; k < n; ++k) {
            sf += fr[k] * pj[k];
            sg += gr[k] * pj[k];
        }
        tf[j] = sf;
        tg[j] = sg;
    }
}

/* After substeps (every row of F dense): the x-block's upper triangle of T F^T + Q in place, with
 * F = [Fq; Fv] and T = F P: rows a and a + 1 of T are held (in registers when sized) against each row
 * b >= a of F, so each row of F is read once per pair. Row a of T only feeds row a of P-; the gamma columns
 * are T's. Off-diagonal entries are flushed as they are final. */
CAEKF_NOINLINE static void tf_upper_dense(caekf_scalar_t *T, caekf_scalar_t fq[CAEKF_NQ][CAEKF_N],
                                          caekf_scalar_t fv[CAEKF_NQ][CAEKF_N], const caekf_scalar_t *q_diag, int nq,
                                          int n)
{
    const int nx = 2 * nq;
    int a, b, k;
    for (a = 0; a < nx; a += 2) { /* nx is even */
        caekf_scalar_t ta[CAEKF_N], tb[CAEKF_N];
        caekf_scalar_t *const ra = T + a * n, *const rb = ra + n;
        CAEKF_UNROLL_SIZED
        for (k = 0; k < n; ++k) {
            ta[k] = ra[k];
            tb[k] = rb[k];
        }
        for (b = a; b < nx; ++b) {
            const caekf_scalar_t *const f = b < nq ? fq[b] : fv[b - nq];
            /* cppcheck-suppress uninitvar ; ta and tb are copied above for every k < n (n >= 1) */
            caekf_scalar_t sa = ta[0] * f[0], sb = tb[0] * f[0];
            CAEKF_UNROLL_SIZED
            for (k = 1; k < n; ++k) {
                sa += ta[k] * f[k];
                sb += tb[k] * f[k];
            }
            ra[b] = b == a ? sa + q_diag[a] : flush(sa);
            if (b == a + 1) {
                rb[b] = sb + q_diag[b];
            } else if (b > a + 1) {
                rb[b] = flush(sb);
            }
        }
        for (k = nx; k < n; ++k) {
            ra[k] = flush(ra[k]);
            rb[k] = flush(rb[k]);
        }
    }
}

/* w[j] = t . Fv_j for j = j0 .. nq - 1 with every row of Fv dense; t is held (in registers when sized). */
CAEKF_NOINLINE static void w_dense(const caekf_scalar_t *t, caekf_scalar_t fv[CAEKF_NQ][CAEKF_N], int j0, int nq, int n,
                                   caekf_scalar_t *w)
{
    caekf_scalar_t buf[CAEKF_N];
    const caekf_scalar_t *const tr = held_row(buf, t, n);
    int j;
    for (j = j0; j < nq; ++j) {
        w[j] = dot(tr, fv[j], n);
    }
}

/* T = F P without substeps: the v-rows Fv P, the q-rows P_q + c (Fv P), row by row over each row's nonzeros
 * (compacted: pat). */
static void fp_rows(const caekf_scalar_t *P, caekf_scalar_t *T, caekf_scalar_t fv[CAEKF_NQ][CAEKF_N],
                    const caekf_fv_pattern_t *pat, caekf_scalar_t c, int nq, int n)
{
    const unsigned char *cnt = pat->nnz;
    int i, j, k;
    for (i = 0; i < nq; ++i) {
        const unsigned char *idx = pat->nz[i];
        const caekf_scalar_t *f = fv[i], *pi = P + i * n, *pj = P;
        caekf_scalar_t *tq = T + i * n, *tv = T + (nq + i) * n;
        if (cnt[i] == n) { /* a dense row (in contact): no indices (nz is not written) */
            fp_row_dense(f, P, pi, tq, tv, c, n);
            continue;
        }
        if (cnt[i] == 4) { /* a link-free row of a chain: the 4 terms held in registers */
            const caekf_scalar_t f0 = f[0], f1 = f[1], f2 = f[2], f3 = f[3];
            const int i0 = idx[0], i1 = idx[1], i2 = idx[2], i3 = idx[3];
            for (j = 0; j < n; ++j, pj += n) {
                caekf_scalar_t s = 0;
                s += f0 * pj[i0];
                s += f1 * pj[i1];
                s += f2 * pj[i2];
                s += f3 * pj[i3];
                tv[j] = s;
                tq[j] = pi[j] + c * s;
            }
            continue;
        }
        for (j = 0; j < n; ++j, pj += n) {
            caekf_scalar_t s = 0;
            for (k = 0; k < cnt[i]; ++k) {
                s += f[k] * pj[idx[k]];
            }
            tv[j] = s;
            tq[j] = pi[j] + c * s;
        }
    }
}

/* The parameter rows of P- (rows nx .. n-1, upper triangle): F's are identity rows, so the parameters' block is
 * P's, plus Q_gamma while live (eq. 21); switched off as the paper has it, the parameter's column too (eqs.
 * 23-24: only P_xx propagates). */
static void param_rows(const caekf_scalar_t *P, caekf_scalar_t *T, const caekf_scalar_t *q_diag,
                       const caekf_filter_dims_t *d, int nx, int n)
{
    int i, j;
    for (i = nx; i < n; ++i) {
        const caekf_gamma_policy_t policy = (caekf_gamma_policy_t)d->policy[i - nx];
        for (j = i; j < n; ++j) {
            AT(T, n, i, j) = AT(P, n, i, j);
        }
        if (policy == CAEKF_GAMMA_LIVE) {
            AT(T, n, i, i) += q_diag[i];
        } else if (FROZEN_PAPER(policy)) {
            for (j = 0; j <= i; ++j) {
                AT(T, n, j, i) = AT(P, n, j, i);
            }
        }
    }
}

void caekf_predict_covariance(const caekf_scalar_t *P, caekf_scalar_t *T, caekf_scalar_t fv[CAEKF_NQ][CAEKF_N],
                              const caekf_fv_pattern_t *pat, caekf_scalar_t c, caekf_scalar_t c2,
                              caekf_scalar_t fq[CAEKF_NQ][CAEKF_N], const caekf_scalar_t *q_diag,
                              const caekf_filter_dims_t *d)
{
    const int nq = DIM_NQ(d), n = DIM_N(d), nx = 2 * nq;
    const unsigned char *cnt = pat->nnz;
    caekf_scalar_t w[CAEKF_NQ];
    const int all_dense = pat->dense;
    int i, j, k;
    if (FQ_GIVEN(fq)) { /* after substeps (every row dense): T = F P, q-row i and v-row i at once */
        for (i = 0; i < nq; ++i) {
            f_rows2_dense(fq[i], fv[i], P, T + i * n, T + (nq + i) * n, n);
        }
    } else {
        fp_rows(P, T, fv, pat, c, nq, n);
    }
    if (!FQ_GIVEN(fq) && C2_GIVEN(c2)) { /* the trapezoidal rule's q-rows also carry c2 * I in the v-columns */
        for (i = 0; i < nq; ++i) {
            const caekf_scalar_t *pv = P + (nq + i) * n;
            caekf_scalar_t *tq = T + i * n;
            for (j = 0; j < n; ++j) {
                tq[j] += c2 * pv[j];
            }
        }
    }
    /* Upper triangle of T F^T + Q row by row, in place: row i only reads row i of T. w = T_i Fv^T
     * gives the v-columns; a q-row's q-columns are T_q + c w; the gamma columns are T's. Off-diagonal
     * entries are flushed as they are final. */
    if (FQ_GIVEN(fq)) {
        tf_upper_dense(T, fq, fv, q_diag, nq, n);
    }
    for (i = FQ_GIVEN(fq) ? nx : 0; i < nx; ++i) { /* after substeps the x-block is done */
        caekf_scalar_t *t = T + i * n;
        caekf_scalar_t dd;
        const int j0 = i < nq ? 0 : i - nq;
        if (all_dense) { /* in contact */
            w_dense(t, fv, j0, nq, n, w);
        }
        for (j = all_dense ? nq : j0; j < nq; ++j) {
            const unsigned char *idx = pat->nz[j];
            const caekf_scalar_t *f = fv[j];
            caekf_scalar_t s = 0;
            if (cnt[j] == n) {
                s = dot(t, f, n);
            } else if (cnt[j] == 4) {
                s += t[idx[0]] * f[0];
                s += t[idx[1]] * f[1];
                s += t[idx[2]] * f[2];
                s += t[idx[3]] * f[3];
            } else {
                for (k = 0; k < cnt[j]; ++k) {
                    s += t[idx[k]] * f[k];
                }
            }
            w[j] = s;
        }
        if (i < nq) {
            dd = t[i] + c * w[i];
            if (C2_GIVEN(c2)) { /* T's v-columns are still T's here: they are overwritten below */
                dd += c2 * t[nq + i];
                for (j = i + 1; j < nq; ++j) {
                    t[j] = flush(t[j] + c * w[j] + c2 * t[nq + j]);
                }
            } else {
                for (j = i + 1; j < nq; ++j) {
                    t[j] = flush(t[j] + c * w[j]);
                }
            }
            j = nq;
        } else {
            dd = w[i - nq];
            j = i + 1;
        }
        t[i] = dd + q_diag[i];
        for (; j < nx; ++j) {
            t[j] = flush(w[j - nq]);
        }
        for (j = nx; j < n; ++j) {
            t[j] = flush(t[j]);
        }
    }
    param_rows(P, T, q_diag, d, nx, n);
}

/* The sensors are rows of H (dims rows), in builds that have them (CAEKF_HAS_SENSOR_ROWS). */
#define ROWS(d) (CAEKF_HAS_SENSOR_ROWS && (d)->rows)

/* H P H^T's entry (k, l): P's at the sensed states, or with rows of H the correction's product. */
static caekf_scalar_t hph(const caekf_scalar_t *P, const caekf_filter_dims_t *d, const caekf_correct_work_t *work,
                          int k, int l)
{
    return ROWS(d) ? work->hph[k][l] : UP(P, DIM_N(d), d->h[k], d->h[l]);
}

/* Rows of H (work->row, scaled): H P into work->hp and H P H^T into work->hph, from P's upper triangle. */
static void sensed_rows(const caekf_scalar_t *P, const caekf_filter_dims_t *d, caekf_correct_work_t *work)
{
    const int n = DIM_N(d), ny = DIM_NY(d);
    int i, j, k, l;
    for (k = 0; k < ny; ++k) {
        const caekf_scalar_t *h = work->row[k];
        for (i = 0; i < n; ++i) {
            caekf_scalar_t s = 0;
            for (j = 0; j < n; ++j) {
                s += h[j] * UP(P, n, j, i);
            }
            work->hp[k][i] = s;
        }
    }
    for (k = 0; k < ny; ++k) {
        for (l = k; l < ny; ++l) {
            caekf_scalar_t s = 0;
            for (i = 0; i < n; ++i) {
                s += work->hp[k][i] * work->row[l][i];
            }
            work->hph[k][l] = work->hph[l][k] = s;
        }
    }
}

/* S^-1 of the innovation covariance S = H P H^T + R (ny x ny). Two sensors: the closed form; otherwise an
 * LU. Returns 0, or -1 when S is not positive definite. */
static int innovation_inverse(const caekf_scalar_t *P, const caekf_filter_dims_t *d, const caekf_correct_work_t *work,
                              caekf_scalar_t Si[CAEKF_MAX_SENSORS][CAEKF_MAX_SENSORS])
{
    const int ny = DIM_NY(d);
    caekf_scalar_t S[CAEKF_MAX_SENSORS * CAEKF_MAX_SENSORS];
    caekf_scalar_t I[CAEKF_MAX_SENSORS * CAEKF_MAX_SENSORS];
    int piv[CAEKF_MAX_SENSORS];
    int k, l;
    if (ny == 2) {
        caekf_scalar_t inv[3];
        if (caekf_sym2_inverse(hph(P, d, work, 0, 0) + d->r[0], hph(P, d, work, 0, 1), hph(P, d, work, 1, 1) + d->r[1],
                               CAEKF_EPS * 16, inv) != CAEKF_LA_OK) {
            return -1;
        }
        Si[0][0] = inv[0];
        Si[0][1] = Si[1][0] = inv[1];
        Si[1][1] = inv[2];
        return 0;
    }
    if (!CAEKF_LA_GENERAL_LU) { /* every build without the general LU has two sensors */
        return 0;
    }
    for (k = 0; k < ny; ++k) {
        for (l = 0; l < ny; ++l) {
            S[k * ny + l] = hph(P, d, work, k, l) + (k == l ? d->r[k] : 0);
            I[k * ny + l] = k == l ? 1 : 0;
        }
        if (!(S[k * ny + k] > 0)) {
            return -1;
        }
    }
    if (caekf_lu_factor(S, ny, piv, CAEKF_EPS * 16) != CAEKF_LA_OK) {
        return -1;
    }
    (void)caekf_lu_solve(S, ny, piv, I, ny, ny);
    for (k = 0; k < ny; ++k) {
        for (l = 0; l < ny; ++l) {
            Si[k][l] = I[k * ny + l];
        }
    }
    return 0;
}

/* Column h of a symmetric matrix kept as its upper triangle: rows above h, then row h. */
static void upper_col(const caekf_scalar_t *P, int n, int h, caekf_scalar_t *out)
{
    int i;
    for (i = 0; i < h; ++i) {
        out[i] = AT(P, n, i, h);
    }
    for (; i < n; ++i) {
        out[i] = AT(P, n, h, i);
    }
}

/* Eq. (15) on the upper triangle of P: P+ = P - G (H P). With a parameter's gain zeroed (live 0), its row of this
 * product would stay stale; the upper triangle alone gives the Schmidt result P_xg <- P_xg - G_x (H P)_g, P_gg
 * unchanged. Rows and columns of skip (eq. 27, the paper's switch-off) are left. */
CAEKF_HOT_INLINE void update_standard(caekf_scalar_t *P, caekf_scalar_t (*G)[CAEKF_MAX_SENSORS],
                                      caekf_scalar_t (*hp)[CAEKF_N], const unsigned char *live,
                                      const unsigned char *skip, int any_skip, int n, int nx, int ny)
{
    int i, j, k;
    for (i = 0; i < n; ++i) {
        caekf_scalar_t *p = &AT(P, n, i, 0);
        if (skip[i]) {
            continue;
        }
        if (ny == 2) { /* two sensors: the gains held in registers */
            const caekf_scalar_t g0 = G[i][0], g1 = G[i][1];
            const caekf_scalar_t *h0 = hp[0], *h1 = hp[1];
            p[i] -= g0 * h0[i] + g1 * h1[i];
            if (!any_skip) {
                for (j = i + 1; j < n; ++j) {
                    p[j] = flush(p[j] - (g0 * h0[j] + g1 * h1[j]));
                }
                continue;
            }
            for (j = i + 1; j < n; ++j) {
                if (!skip[j]) {
                    p[j] = flush(p[j] - (g0 * h0[j] + g1 * h1[j]));
                }
            }
            continue;
        }
        for (j = i; j < n; ++j) {
            caekf_scalar_t s = 0;
            if (skip[j]) {
                continue;
            }
            for (k = 0; k < ny; ++k) {
                s += G[i][k] * hp[k][j];
            }
            p[j] = j == i ? p[j] - s : flush(p[j] - s);
        }
    }
    /* A held parameter i (gain 0) before a live state j: the upper triangle keeps P_ij, which is row j's
     * update P_ji - G_j (H P)_i (the Schmidt result on both sides); the row loop above left it. Only a
     * state with more than one parameter has such pairs. */
    for (i = nx; CAEKF_NP > 1 && i < n; ++i) {
        if (live[i] || skip[i]) {
            continue;
        }
        for (j = i + 1; j < n; ++j) {
            caekf_scalar_t s = 0;
            if (!live[j] || skip[j]) {
                continue;
            }
            for (k = 0; k < ny; ++k) {
                s += G[j][k] * hp[k][i];
            }
            AT(P, n, i, j) = flush(AT(P, n, i, j) - s);
        }
    }
}

/* Joseph: P+ = (A P) A^T + G R G^T with A = I - G H, i.e. A P - (A P)_{:,sensed} G^T + G R G^T, on the upper
 * triangle of P. Row i of A P at the sensed states comes from the copies of H P (P is symmetric). R enters as r_0
 * times the ratios r_k / r_0 (exactly 1 when the sensors share R). Rows and columns of skip are left. */
CAEKF_HOT_INLINE void update_joseph(caekf_scalar_t *P, caekf_scalar_t (*G)[CAEKF_MAX_SENSORS],
                                    caekf_scalar_t (*hp)[CAEKF_N], const unsigned char *skip,
                                    const caekf_filter_dims_t *d, const caekf_correct_work_t *work, int n, int ny)
{
    caekf_scalar_t rr[CAEKF_MAX_SENSORS];
    int i, j, k, l;
    for (k = 0; k < ny; ++k) {
        rr[k] = d->r[k] / d->r[0];
    }
    for (i = 0; i < n; ++i) {
        caekf_scalar_t a[CAEKF_MAX_SENSORS], gr[CAEKF_MAX_SENSORS];
        if (skip[i]) {
            continue;
        }
        for (k = 0; k < ny; ++k) {
            caekf_scalar_t s = 0;
            for (l = 0; l < ny; ++l) {
                s += G[i][l] * (ROWS(d) ? work->hph[l][k] : hp[l][d->h[k]]); /* the prior's H P H^T */
            }
            a[k] = hp[k][i] - s;
            gr[k] = G[i][k] * rr[k];
        }
        for (j = i; j < n; ++j) {
            caekf_scalar_t s = 0, rg = 0, v;
            if (skip[j]) {
                continue;
            }
            for (k = 0; k < ny; ++k) {
                s += G[i][k] * hp[k][j];
                rg += gr[k] * G[j][k];
            }
            v = AT(P, n, i, j) - s;
            for (k = 0; k < ny; ++k) {
                v -= a[k] * G[j][k];
            }
            v += d->r[0] * rg;
            AT(P, n, i, j) = j > i ? flush(v) : v;
        }
    }
}

int caekf_correct_upper(caekf_scalar_t *z, caekf_scalar_t *P, const caekf_scalar_t *y_s, int joseph,
                        const caekf_filter_dims_t *d, caekf_scalar_t gate, caekf_scalar_t *nis, uint32_t *flags,
                        caekf_correct_work_t *work)
{
    const int n = DIM_N(d), ny = DIM_NY(d), nx = 2 * DIM_NQ(d);
    caekf_scalar_t Si[CAEKF_MAX_SENSORS][CAEKF_MAX_SENSORS];
    caekf_scalar_t(*const G)[CAEKF_MAX_SENSORS] = work->gain;
    caekf_scalar_t(*const hp)[CAEKF_N] = work->hp; /* H P = the sensed rows of P, from its upper triangle */
    caekf_scalar_t e[CAEKF_MAX_SENSORS];
    unsigned char live[CAEKF_N], skip[CAEKF_N];
    int any_live = 0, any_skip = 0;
    /* cppcheck-suppress variableScope ; declarations at the top of the block are this file's style */
    int i, k, l;
    if (ROWS(d)) {
        sensed_rows(P, d, work);
    }
    if (innovation_inverse(P, d, work, Si) != 0) {
        *flags |= CAEKF_FLAG_SINGULAR_INNOVATION;
        return -1;
    }
    for (k = 0; k < ny; ++k) {
        e[k] = y_s[k] - (ROWS(d) ? work->hx[k] : z[d->h[k]]); /* eq. (14) */
    }
    /* Normalised innovation squared e^T S^-1 e: chi-square with ny degrees of freedom while the filter
     * is consistent. Far above that, the linearisation behind the gamma gain no longer holds (e.g. the
     * first measurement after a gap in contact): the gammas are held this step as consider states. */
    if (ny == 2) {
        *nis = e[0] * (Si[0][0] * e[0] + 2 * Si[0][1] * e[1]) + Si[1][1] * e[1] * e[1];
    } else {
        *nis = 0;
        for (k = 0; k < ny; ++k) {
            caekf_scalar_t s = 0;
            for (l = 0; l < ny; ++l) {
                s += Si[k][l] * e[l];
            }
            *nis += e[k] * s;
        }
    }
    for (i = 0; i < nx; ++i) {
        live[i] = 1;
        skip[i] = 0;
    }
    for (i = nx; i < n; ++i) {
        const int policy = d->policy[i - nx];
        live[i] = (unsigned char)(policy == CAEKF_GAMMA_LIVE);
        /* Eq. (27), paper switch-off: only P_xx is corrected, the gamma's row and column are left. */
        skip[i] = (unsigned char)FROZEN_PAPER(policy);
        any_live |= live[i];
        any_skip |= skip[i];
    }
    if (any_live && gate > 0 && *nis > gate) {
        for (i = nx; i < n; ++i) {
            live[i] = 0;
        }
        *flags |= CAEKF_FLAG_GAMMA_GATED;
    }
    if (ny == 2) { /* two sensors, written out: the same operations as the loops below */
        const int h0 = d->h[0], h1 = d->h[1];
        const caekf_scalar_t s00 = Si[0][0], s01 = Si[0][1], s11 = Si[1][1], e0 = e[0], e1 = e[1];
        if (!ROWS(d)) {
            upper_col(P, n, h0, hp[0]);
            upper_col(P, n, h1, hp[1]);
        }
        for (i = 0; i < n; ++i) {
            const caekf_scalar_t a = hp[0][i], b = hp[1][i];
            /* eq. (26) with a gamma frozen: a Schmidt ("consider") gain of 0 on it */
            const int on = i < nx || live[i];
            G[i][0] = on ? a * s00 + b * s01 : 0;
            G[i][1] = on ? a * s01 + b * s11 : 0;
            z[i] += G[i][0] * e0 + G[i][1] * e1;
        }
    } else {
        for (i = 0; i < n && !ROWS(d); ++i) {
            for (k = 0; k < ny; ++k) {
                hp[k][i] = UP(P, n, d->h[k], i);
            }
        }
        for (i = 0; i < n; ++i) {
            caekf_scalar_t dz = 0;
            for (k = 0; k < ny; ++k) {
                caekf_scalar_t s = 0;
                for (l = 0; l < ny; ++l) {
                    s += hp[l][i] * Si[l][k];
                }
                G[i][k] = live[i] ? s : 0;
            }
            for (k = 0; k < ny; ++k) {
                dz += G[i][k] * e[k];
            }
            z[i] += dz;
        }
    }
    if (!JOSEPH_FORM(joseph)) {
        update_standard(P, G, hp, live, skip, any_skip, n, nx, ny);
    } else {
        update_joseph(P, G, hp, skip, d, work, n, ny);
    }
    return 0;
}

int caekf_constrain_upper(caekf_scalar_t *z, caekf_scalar_t *P, int n_arg, int g_arg, caekf_scalar_t zb, int is_max,
                          caekf_scalar_t s_g, caekf_scalar_t bound_phys, uint32_t *flags)
{
    const int n = SIZED_N(n_arg);
    const int g = BOUNDED_STATE(g_arg);
    const caekf_scalar_t s = AT(P, n, g, g);
    const caekf_scalar_t dz = zb - z[g];
    caekf_scalar_t col[CAEKF_N]; /* P's gamma column, contiguous */
    int usable = s > CAEKF_EPS * CAEKF_EPS;
    /* cppcheck-suppress variableScope ; declarations at the top of the block are this file's style */
    int i, k;
    if (is_max ? !(z[g] > zb) : !(z[g] < zb)) {
        return 0;
    }
    *flags |= CAEKF_FLAG_CONSTRAINT_APPLIED;
    for (i = 0; i < g; ++i) { /* P's gamma column from the upper triangle: rows above g, then row g */
        col[i] = AT(P, n, i, g);
    }
    for (i = g; i < n; ++i) {
        col[i] = AT(P, n, g, i);
    }
    for (i = 0; i < n; ++i) { /* a valid covariance has P_ig^2 <= P_ii P_gg */
        if (i != g) {
            usable &= col[i] * col[i] <= AT(P, n, i, i) * s * (1 + CAEKF_EPS * 64) + CAEKF_EPS * CAEKF_EPS;
        }
    }
    if (usable) {
        /* Scalar perfect measurement (R = 0): gain k = P e_g / P_gg, P+ = P - P e_g e_g^T P / P_gg.
         * The standard and the Joseph forms coincide here. Row/column gamma become exactly 0. Each
         * entry is updated once: the columns before g, then those after it. */
        caekf_scalar_t *pii = P;
        for (i = 0; i < n; ++i, pii += n + 1) { /* pii: P_ii */
            const caekf_scalar_t a = col[i];
            caekf_scalar_t *p = pii, *const pend = pii + (n - i);
            const caekf_scalar_t *cj = col + i;
            if (i == g) {
                continue;
            }
            z[i] += a / s * dz;
            *p -= a * a / s;
            if (i < g) {
                caekf_scalar_t *const pg = pii + (g - i);
                while (++p != pg) {
                    *p = flush(*p - a * *++cj / s);
                }
                *p = 0; /* P_ig */
                ++cj;
            } else {
                AT(P, n, g, i) = 0;
            }
            while (++p != pend) {
                *p = flush(*p - a * *++cj / s);
            }
        }
        AT(P, n, g, g) = 0;
    } else {
        *flags |= CAEKF_FLAG_CONSTRAINT_CLAMPED | CAEKF_FLAG_SINGULAR_INNOVATION;
    }
    z[g] = zb;
    /* Rounding of zb * s_g must not land outside the bound: step inwards by ulps (bounded). */
    for (k = 0; k < 4 && (is_max ? z[g] * s_g > bound_phys : z[g] * s_g < bound_phys); ++k) {
        const caekf_scalar_t ulp = CAEKF_FABS(z[g]) * CAEKF_EPS + (caekf_scalar_t)1e-30;
        z[g] += is_max ? -ulp : ulp;
    }
    return 1;
}

/* Every valid covariance has P_ii >= 0 and P_ij^2 <= P_ii P_jj; failing either is the common way
 * P goes bad (|corr| > 1, as eqs. 23-27 produce). Cheap enough for every step. On the way it sums
 * v * 0 over the upper triangle and the state z into *nf: 0 when every entry is finite, NaN otherwise
 * (one multiply-add per entry instead of a classification); *nf is only complete when the screen passes. */
static int screen_fails(const caekf_scalar_t *P, const caekf_scalar_t *z, int n, caekf_scalar_t *nf)
{
    caekf_scalar_t acc = 0;
    int i;
    for (i = 0; i < n; ++i) {
        const caekf_scalar_t *pij = P + i * n + i, *const pend = P + i * n + n;
        const caekf_scalar_t *pjj = pij;
        const caekf_scalar_t pii = *pij;
        acc += z[i] * 0;
        acc += pii * 0;
        if (!(pii >= 0)) {
            return 1;
        }
        while (++pij != pend) {
            const caekf_scalar_t v = *pij;
            pjj += n + 1;
            acc += v * 0;
            if (v * v > pii * *pjj * (1 + CAEKF_EPS * 64)) {
                return 1;
            }
        }
    }
    *nf = acc;
    return 0;
}

int caekf_covariance_health(caekf_scalar_t *P, const caekf_scalar_t *z, int n_arg, int full_check, int repair,
                            caekf_scalar_t *scratch, uint32_t *flags)
{
    const int n = SIZED_N(n_arg);
    caekf_scalar_t nf = 0;
    int i, j;
    if (!screen_fails(P, z, n, &nf)) {
        /* Tolerance on the correlation form: rounding grows with the ~n-term sums of each update. */
        if (!full_check || caekf_psd_check(P, n, CAEKF_EPS * 1024, scratch) == CAEKF_LA_OK) {
            return nf == 0;
        }
    }
    *flags |= CAEKF_FLAG_COV_INDEFINITE;
    if (repair) {
        caekf_mirror_upper(P, n);
        (void)caekf_psd_repair(P, n, scratch);
        *flags |= CAEKF_FLAG_COV_REPAIRED;
    }
    nf = 0;
    for (i = 0; i < n; ++i) {
        nf += z[i] * 0;
        for (j = i; j < n; ++j) {
            nf += AT(P, n, i, j) * 0;
        }
    }
    return nf == 0;
}
