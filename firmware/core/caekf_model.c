/* The contact model of any lumped mechanism on a line: the contact law (eq. 16 with exponent n and
 * Hunt-Crossley damping), the implicit step (eq. 19's backward Euler or the trapezoidal rule) with its
 * residual and Newton solve, eq. (10)'s F. */
#include "caekf_model_internal.h"

#include "caekf/caekf.h"
#include "caekf_linalg.h"
#include "caekf_math.h"

/* Compiler hints only. The loops of the step path (the Newton solve, its matrix, F's right-hand sides) are
 * written out where the build's sizes are constants and the step runs them many times (substeps or the
 * trapezoidal rule); the one-step build keeps these loops (less flash; its inner loops over the links' pattern
 * are written out). add_contact_block is written into its callers where the build fixes the links (the
 * contacts' ends are constants; on the step's path: the Newton matrix and F), a function elsewhere (less
 * flash). */
#if CAEKF_FIXED_LINKS
#define ADD_CONTACT_BLOCK_INLINE CAEKF_HOT_INLINE
#else
#define ADD_CONTACT_BLOCK_INLINE static
#endif /* CAEKF_FIXED_LINKS */
#if CAEKF_FIXED_LINKS && !CAEKF_ONE_STEP_BE
#define UNROLL_STEP CAEKF_UNROLL_SIZED
#else
#define UNROLL_STEP
#endif /* CAEKF_FIXED_LINKS && !CAEKF_ONE_STEP_BE */

/* delta^n and n delta^(n-1) for delta > 0: the Hertz (1.5) and linear (1) laws exactly, others by pow. */
CAEKF_HOT_INLINE void power_law(caekf_scalar_t d, caekf_scalar_t n, caekf_scalar_t *dn, caekf_scalar_t *dn1)
{
    if (n == CAEKF_C(1.5)) {
        const caekf_scalar_t sd = CAEKF_SQRT(d);
        *dn = d * sd;
        *dn1 = sd; /* times n by the caller, in the order eq. (17) is written: 1.5 gamma sqrt(delta) */
    } else if (n == 1) {
        *dn = d;
        *dn1 = 1;
    } else {
        *dn = CAEKF_POW(d, n);
        *dn1 = CAEKF_POW(d, n - 1);
    }
}

/* w^T x over the model's nq positions (or velocities, x + nq). */
static caekf_scalar_t structure_dot(const caekf_model_t *m, const caekf_scalar_t *w, const caekf_scalar_t *x)
{
    caekf_scalar_t s = 0;
    int j;
    for (j = 0; j < CAEKF_DIM_NQ(m); ++j) {
        s += w[j] * x[j];
    }
    return s;
}

caekf_scalar_t caekf_model_contact_dot(const caekf_model_t *m, int c, const caekf_scalar_t *x)
{
    const int i = CAEKF_CONTACT_I(m, c), j = CAEKF_CONTACT_J(m, c);
    if (CAEKF_IS_STRUCTURE(m)) {
        return structure_dot(m, CAEKF_STRUCTURE_W(m, c), x);
    }
    return (i >= 0 ? x[i] : 0) - (j >= 0 ? x[j] : 0);
}

/* Gauss-Hermite rule, 20 nodes (symmetric): the 10 positive nodes of the weight exp(-x^2) and their
 * weights over sqrt(pi), which sum to 1 over all 20. E[g(t)] for t ~ N(mu, s^2) is
 * sum_k w_k (g(mu + sqrt(2) s x_k) + g(mu - sqrt(2) s x_k)). */
#define SLR_NODES 10
/* In the build's scalar type (each the double rounded once, as a conversion at run time would; a float
 * build converts nothing per node). */
static const caekf_scalar_t slr_x[SLR_NODES] = {(caekf_scalar_t)0.2453407083009012, (caekf_scalar_t)0.7374737285453944,
                                                (caekf_scalar_t)1.2340762153953231, (caekf_scalar_t)1.7385377121165861,
                                                (caekf_scalar_t)2.2549740020892757, (caekf_scalar_t)2.7888060584281305,
                                                (caekf_scalar_t)3.3478545673832163, (caekf_scalar_t)3.9447640401156252,
                                                (caekf_scalar_t)4.6036824495507442, (caekf_scalar_t)5.3874808900112328};
static const caekf_scalar_t slr_w[SLR_NODES] = {
    (caekf_scalar_t)2.6079306344955488e-01, (caekf_scalar_t)1.6173933398399998e-01,
    (caekf_scalar_t)6.1506372063976897e-02, (caekf_scalar_t)1.3997837447101022e-02,
    (caekf_scalar_t)1.8301031310804900e-03, (caekf_scalar_t)1.2882627996192928e-04,
    (caekf_scalar_t)4.4021210902308510e-06, (caekf_scalar_t)6.1274902599829280e-08,
    (caekf_scalar_t)2.4820623623151755e-10, (caekf_scalar_t)1.2578006724379234e-13};

/* E[max(0, t)^n] (*e) and E[max(0, t)^(n-1)] (*e1, the law's slope over n gamma) for t ~ N(d, s^2).
 * Nodes beyond 7.6 s of d add nothing, so the expectations are those of the law itself once s << d. */
static void slr_moments(caekf_scalar_t d, caekf_scalar_t s, caekf_scalar_t n, caekf_scalar_t *e, caekf_scalar_t *e1)
{
    /* Node pairs d -/+ u, u = s sqrt(2) x_k: -(s sqrt(2) x_k) is exact, so these are the nodes
     * d + sgn s sqrt(2) x_k, taken in that order (minus first). */
    const caekf_scalar_t sr = s * CAEKF_SQRT(CAEKF_C(2.0));
    caekf_scalar_t a = 0, a1 = 0;
    /* The nodes grow with x_k (rounding is monotone): none is positive if the outermost is not, and the
     * sums stay 0 (the open side, most steps). */
    if (d + sr * slr_x[SLR_NODES - 1] > 0) {
        int k;
        CAEKF_UNROLL_SIZED /* a sized build (one that sized for them) takes the nodes as constants */
            for (k = 0; k < SLR_NODES; ++k)
        {
            const caekf_scalar_t u = sr * slr_x[k], t0 = d - u, t1 = d + u;
            caekf_scalar_t tn, tn1;
            if (t0 > 0) {
                power_law(t0, n, &tn, &tn1);
                a += slr_w[k] * tn;
                a1 += slr_w[k] * tn1;
            }
            if (t1 > 0) {
                power_law(t1, n, &tn, &tn1);
                a += slr_w[k] * tn;
                a1 += slr_w[k] * tn1;
            }
        }
    }
    *e = a;
    *e1 = a1;
}
/* A contact whose force enters the Newton matrix and F: closed, or (statistically linearised) an uncertain
 * contact's tangents. */
#define CONTACT_ON(c) ((c).delta > 0 || (CAEKF_HAS_SLR && (c).dfc_ddelta != 0))

/* Eqs. (16)-(17) generalised: f = gamma delta^n (1 + lambda d delta/dt) while delta > 0, never pulling
 * (a Hunt-Crossley factor below 0 gives f = 0 and no derivatives). gamma is the state's; n, lambda and
 * the gap are the state's when estimated, else the model's. */
/* caekf_model_contact; without `tangents` a statistically linearised contact gets its force and penetration
 * only (a Newton update that does not build the Newton matrix reads nothing else). */
CAEKF_HOT_INLINE void contact_law(const caekf_model_t *m, int c, const caekf_scalar_t *x, caekf_contact_t *out,
                                  int tangents)
{
    (void)tangents; /* read only where contacts are linearised statistically */
    const int i = CAEKF_CONTACT_I(m, c), j = CAEKF_CONTACT_J(m, c), nq = CAEKF_DIM_NQ(m);
    const caekf_scalar_t gamma = CAEKF_METHOD_GAMMA_LOG(m) ? CAEKF_EXP(x[2 * nq + c]) : x[2 * nq + c];
    caekf_scalar_t n = CAEKF_METHOD_CONTACT_N(m, c), lambda = CAEKF_METHOD_LAMBDA(m, c), gap = m->p.contact_gap[c], d;
    int damped = lambda != 0;
    const unsigned char *law = m->law_state[c];
    if (CAEKF_HAS_LAW_PARAMS) { /* the estimated ones are states */
        if (law[CAEKF_LAW_N] != 0) {
            n = x[law[CAEKF_LAW_N]];
        }
        if (law[CAEKF_LAW_LAMBDA] != 0) {
            lambda = x[law[CAEKF_LAW_LAMBDA]];
            damped = 1; /* its derivative is needed even at lambda = 0 */
        }
        if (law[CAEKF_LAW_GAP] != 0) {
            gap = x[law[CAEKF_LAW_GAP]];
        }
        *CAEKF_DFC_DN_STORE(out) = 0;
        *CAEKF_DFC_DLAMBDA_STORE(out) = 0;
    }
    d = CAEKF_IS_STRUCTURE(m) ? structure_dot(m, CAEKF_STRUCTURE_W(m, c), x) - gap
                              : (i >= 0 ? x[i] : 0) - (j >= 0 ? x[j] : 0) - gap;
    out->delta = d;
    out->fc = 0;
    out->dfc_ddelta = 0;
    out->dfc_drate = 0;
    out->dfc_dgamma = 0;
    if (CAEKF_HAS_SLR && CAEKF_SLR_S(m)[c] > 0) { /* set only for the laws caekf_model_slr_law linearises */
        /* Statistically linearised tangents (setting contact_slr_p): the force is the law's own, its
         * tangents in delta and gamma the expectations of the law's over delta ~ N(d, slr_s^2) (the
         * regression slopes of the force on the states, Stein's lemma): the tangents of a contact whose
         * penetration is uncertain are neither the stiff ones of the predicted penetration nor zero
         * on the open side of eq. (21). */
        caekf_scalar_t e = 0, e1 = 0, dn = 0, dn1 = 0;
        if (tangents) {
            slr_moments(d, CAEKF_SLR_S(m)[c], n, &e, &e1);
        }
        if (d > 0) {
            power_law(d, n, &dn, &dn1);
        }
        out->fc = gamma * dn;
        out->dfc_ddelta = n * gamma * e1;
        out->dfc_dgamma = CAEKF_METHOD_GAMMA_LOG(m) ? gamma * e : e; /* df/d(ln gamma) = gamma df/dgamma */
        return;
    }
    if (d > 0) {
        caekf_scalar_t dn, dn1;
        power_law(d, n, &dn, &dn1);
        if (!damped) { /* elastic: exactly eq. (17) */
            out->dfc_dgamma = dn;
            out->fc = gamma * dn;
            out->dfc_ddelta = n * gamma * dn1;
        } else {
            const caekf_scalar_t rate = CAEKF_IS_STRUCTURE(m) ? structure_dot(m, CAEKF_STRUCTURE_W(m, c), x + nq)
                                                              : (i >= 0 ? x[nq + i] : 0) - (j >= 0 ? x[nq + j] : 0);
            const caekf_scalar_t h = 1 + lambda * rate;
            if (h > 0) {
                out->dfc_dgamma = dn * h;
                out->fc = gamma * out->dfc_dgamma;
                out->dfc_ddelta = n * gamma * dn1 * h;
                out->dfc_drate = gamma * dn * lambda;
                if (CAEKF_HAS_LAW_PARAMS) {
                    *CAEKF_DFC_DLAMBDA_STORE(out) = gamma * dn * rate;
                }
            }
        }
        if (CAEKF_HAS_LAW_PARAMS && law[CAEKF_LAW_N] != 0) { /* d(delta^n)/dn = delta^n ln(delta) */
            *CAEKF_DFC_DN_STORE(out) = out->fc * CAEKF_LOG(d);
        }
        if (CAEKF_METHOD_GAMMA_LOG(m)) { /* df/d(ln gamma) = gamma df/dgamma = f */
            out->dfc_dgamma = out->fc;
        }
    }
}

void caekf_model_contact(const caekf_model_t *m, int c, const caekf_scalar_t *x, caekf_contact_t *out)
{
    contact_law(m, c, x, out, 1);
}

/* The force of contact c at x without the statistically linearised tangents (the substeps' chord update). */
static void contact_force(const caekf_model_t *m, int c, const caekf_scalar_t *x, caekf_contact_t *out)
{
    contact_law(m, c, x, out, 0);
}

/* Adds s * (e_i - e_j)(e_i - e_j)^T to the nq x nq matrix a (leading dimension ld); ground ends (-1)
 * drop out. Entry order: (i,i), (i,j), (j,i), (j,j). */
ADD_CONTACT_BLOCK_INLINE void add_contact_block(caekf_scalar_t *a, int ld, int i, int j, caekf_scalar_t s)
{
    if (i >= 0) {
        a[i * ld + i] += s;
        if (j >= 0) {
            a[i * ld + j] -= s;
        }
    }
    if (j >= 0) {
        if (i >= 0) {
            a[j * ld + i] -= s;
        }
        a[j * ld + j] += s;
    }
}

/* Adds s w w^T to the nq x nq matrix a (leading dimension ld): a structure's contact; rows where w is 0 are
 * skipped (a contact's w is often sparse). */
static void add_structure_block(const caekf_model_t *m, const caekf_scalar_t *w, caekf_scalar_t *a, int ld,
                                caekf_scalar_t s)
{
    const int nq = CAEKF_DIM_NQ(m);
    int i, j;
    for (i = 0; i < nq; ++i) {
        if (w[i] != 0) {
            const caekf_scalar_t si = s * w[i];
            for (j = 0; j < nq; ++j) {
                a[i * ld + j] += si * w[j];
            }
        }
    }
}

/* Adds s b_c b_c^T to the nq x nq matrix a: contact c's w_c of a structure, e_a - e_b on a line. */
ADD_CONTACT_BLOCK_INLINE void add_contact_outer(const caekf_model_t *m, int c, caekf_scalar_t *a, int ld,
                                                caekf_scalar_t s)
{
    if (CAEKF_IS_STRUCTURE(m)) {
        add_structure_block(m, CAEKF_STRUCTURE_W(m, c), a, ld, s);
        return;
    }
    add_contact_block(a, ld, CAEKF_CONTACT_I(m, c), CAEKF_CONTACT_J(m, c), s);
}

/* A structure's loads in its momentum rows: -B_u u, + sum_c w_c f_c (and their terms' sizes). */
static void structure_loads(const caekf_model_t *m, const caekf_scalar_t *u, const caekf_contact_t *ct,
                            caekf_scalar_t *r, caekf_scalar_t *mag)
{
    const int nq = CAEKF_DIM_NQ(m);
    int i, k;
    for (k = 0; k < CAEKF_DIM_NU(m); ++k) {
        const caekf_scalar_t *b = CAEKF_STRUCTURE_BU(m, k);
        for (i = 0; i < nq; ++i) {
            const caekf_scalar_t t = b[i] * u[k];
            r[i] -= t;
            if (mag != 0) {
                mag[i] += CAEKF_FABS(t);
            }
        }
    }
    for (k = 0; k < CAEKF_DIM_NC(m); ++k) {
        const caekf_scalar_t *w = CAEKF_STRUCTURE_W(m, k);
        for (i = 0; i < nq; ++i) {
            const caekf_scalar_t t = w[i] * ct[k].fc;
            r[i] += t;
            if (mag != 0) {
                mag[i] += CAEKF_FABS(t);
            }
        }
    }
}

/* Momentum rows of eq. (19) for (q_k, v_k) with the contacts' forces f; optionally the magnitude of each
 * row's terms, which is what the residual's rounding error scales with. Input i is a force on its body;
 * contact c enters the residual as +f_c on body a and -f_c on body b. */
static void momentum_residual(const caekf_model_t *m, const caekf_scalar_t *x, const caekf_scalar_t *vprev,
                              const caekf_scalar_t *u, const caekf_contact_t *ct, caekf_scalar_t *r,
                              caekf_scalar_t *mag)
{
    const int nq = CAEKF_DIM_NQ(m), nc = CAEKF_DIM_NC(m), nu = CAEKF_DIM_NU(m);
    const caekf_scalar_t *q = x, *v = x + nq;
    int i, k;
    if (CAEKF_FIXED_LINKS) {
        /* The links' pattern is the build's (constants: written out, no index loads), the same operations in
         * the same order as below; a link of zero stiffness and damping adds its zero terms. */
        CAEKF_UNROLL_SIZED
        for (i = 0; i < nq; ++i) {
            const caekf_scalar_t inertia = m->m_dt[i] * (v[i] - vprev[i]);
            caekf_scalar_t s = inertia, a = CAEKF_FABS(inertia);
            CAEKF_UNROLL_SIZED
            for (k = 0; k < CAEKF_ROW_NNZ(m, i); ++k) {
                const int j = CAEKF_ROW_NZ(m, i)[k];
                const caekf_scalar_t kq = m->K[i][j] * q[j], cv = m->C[i][j] * v[j];
                s += kq + cv;
                a += CAEKF_FABS(kq) + CAEKF_FABS(cv);
            }
            r[i] = s;
            if (mag != 0) {
                mag[i] = a;
            }
        }
    } else {
        for (i = 0; i < nq; ++i) {
            const caekf_scalar_t inertia = m->m_dt[i] * (v[i] - vprev[i]);
            const caekf_scalar_t *Ki = m->K[i], *Ci = m->C[i];
            const unsigned char *nz = CAEKF_ROW_NZ(m, i);
            caekf_scalar_t s = inertia;
            if (CAEKF_ROW_NNZ(m, i) == 2) { /* a body with one neighbour (a chain's end or pair): written out */
                const int j0 = nz[0], j1 = nz[1];
                const caekf_scalar_t kq0 = Ki[j0] * q[j0], cv0 = Ci[j0] * v[j0];
                const caekf_scalar_t kq1 = Ki[j1] * q[j1], cv1 = Ci[j1] * v[j1];
                r[i] = s + (kq0 + cv0) + (kq1 + cv1);
                if (mag != 0) {
                    mag[i] =
                        CAEKF_FABS(inertia) + (CAEKF_FABS(kq0) + CAEKF_FABS(cv0)) + (CAEKF_FABS(kq1) + CAEKF_FABS(cv1));
                }
                continue;
            }
            for (k = 0; k < CAEKF_ROW_NNZ(m, i); ++k) { /* K and C's nonzeros of row i, ascending */
                const int j = nz[k];
                s += Ki[j] * q[j] + Ci[j] * v[j];
            }
            r[i] = s;
            if (mag != 0) {
                caekf_scalar_t a = CAEKF_FABS(inertia);
                for (k = 0; k < CAEKF_ROW_NNZ(m, i); ++k) {
                    const int j = nz[k];
                    a += CAEKF_FABS(Ki[j] * q[j]) + CAEKF_FABS(Ci[j] * v[j]);
                }
                mag[i] = a;
            }
        }
    }
    if (CAEKF_IS_STRUCTURE(m)) {
        structure_loads(m, u, ct, r, mag);
        return;
    }
    for (k = 0; k < nu; ++k) {
        const int b = m->p.input_body[k] - 1;
        r[b] -= u[k];
        if (mag != 0) {
            mag[b] += CAEKF_FABS(u[k]);
        }
    }
    for (k = 0; k < nc; ++k) {
        const int i_ = CAEKF_CONTACT_I(m, k), j_ = CAEKF_CONTACT_J(m, k);
        if (i_ >= 0) {
            r[i_] += ct[k].fc;
        }
        if (j_ >= 0) {
            r[j_] -= ct[k].fc;
        }
        if (mag != 0) {
            if (i_ >= 0) {
                mag[i_] += CAEKF_FABS(ct[k].fc);
            }
            if (j_ >= 0) {
                mag[j_] += CAEKF_FABS(ct[k].fc);
            }
        }
    }
}

/* The inputs as the forces the momentum rows take (docs/mechanism.md "Base excitation"): a force as it is; a
 * base displacement u of a link of stiffness k and damper c, the force on its body k u + c (u - u_prev) / hs at
 * the step's end (fe) and k u_prev at its start (fs, the trapezoidal rule's G(x_{k-1}, u_{k-1})). The
 * trapezoidal rule's rows are both ends' forces (the mean times 2): k (u + u_prev) + 2 c (u - u_prev) / dt,
 * whose damper term is c du/dt's mean over the step exactly for u linear in time; backward Euler's (hs = dt)
 * the end's. Substeps interpolate u linearly: the same with their own hs. */
static void base_forces(const caekf_model_t *m, const caekf_scalar_t *u_prev, const caekf_scalar_t *u,
                        caekf_scalar_t *fe, caekf_scalar_t *fs)
{
    int k;
    for (k = 0; k < CAEKF_DIM_NU(m); ++k) {
        if (CAEKF_BASE_LINK(m, k) != 0) {
            fe[k] = CAEKF_BASE_K(m, k) * u[k] + CAEKF_BASE_C(m, k) * (u[k] - u_prev[k]) / m->hs;
            fs[k] = CAEKF_BASE_K(m, k) * u_prev[k];
        } else {
            fe[k] = u[k];
            fs[k] = u_prev[k];
        }
    }
}

/* Every contact's law at x (its own gammas and law parameters). */
static void contacts_at(const caekf_model_t *m, const caekf_scalar_t *x, caekf_contact_t *ct)
{
    const int nc = CAEKF_DIM_NC(m);
    int i;
    for (i = 0; i < nc; ++i) {
        caekf_model_contact(m, i, x, &ct[i]);
    }
}

/* Whether any contact is closed (delta > 0): the Newton matrix and F then differ from the constants. */
static int any_contact(const caekf_contact_t *ct, int nc)
{
    int i, any = 0;
    for (i = 0; i < nc; ++i) {
        any |= CONTACT_ON(ct[i]);
    }
    return any;
}

int caekf_model_any_contact(const caekf_model_t *m, const caekf_scalar_t *x)
{
    caekf_contact_t ct[CAEKF_MAX_CONTACTS + 1];
    contacts_at(m, x, ct);
    return any_contact(ct, CAEKF_DIM_NC(m));
}

/* Adds s b_c to column col of the nq rows at `rows` (leading dimension CAEKF_N): +s on body a's row,
 * -s on body b's (ground ends drop out). */
static void add_contact_column(const caekf_model_t *m, int c, caekf_scalar_t *rows, int col, caekf_scalar_t s)
{
    const int a = CAEKF_CONTACT_I(m, c), b = CAEKF_CONTACT_J(m, c);
    if (CAEKF_IS_STRUCTURE(m)) { /* s w_c */
        const caekf_scalar_t *w = CAEKF_STRUCTURE_W(m, c);
        int i;
        for (i = 0; i < CAEKF_DIM_NQ(m); ++i) {
            rows[i * CAEKF_N + col] += s * w[i];
        }
        return;
    }
    if (a >= 0) {
        rows[a * CAEKF_N + col] += s;
    }
    if (b >= 0) {
        rows[b * CAEKF_N + col] -= s;
    }
}

/* Adds s times contact c's force derivatives with respect to its parameter states (gamma, and n, lambda
 * and gap when estimated) along b_c, into the parameter columns of the nq rows at `rows`. */
static void add_param_columns(const caekf_model_t *m, int c, const caekf_contact_t *ct, caekf_scalar_t s,
                              caekf_scalar_t *rows)
{
    add_contact_column(m, c, rows, 2 * CAEKF_DIM_NQ(m) + c, s * ct->dfc_dgamma);
    if (CAEKF_HAS_LAW_PARAMS) {
        const unsigned char *law = m->law_state[c];
        if (law[CAEKF_LAW_N] != 0) {
            add_contact_column(m, c, rows, law[CAEKF_LAW_N], s * *CAEKF_DFC_DN_STORE(ct));
        }
        if (law[CAEKF_LAW_LAMBDA] != 0) {
            add_contact_column(m, c, rows, law[CAEKF_LAW_LAMBDA], s * *CAEKF_DFC_DLAMBDA_STORE(ct));
        }
        if (law[CAEKF_LAW_GAP] != 0) { /* delta = q_a - q_b - gap */
            add_contact_column(m, c, rows, law[CAEKF_LAW_GAP], -s * ct->dfc_ddelta);
        }
    }
}

#define LU_REL_TOL (CAEKF_EPS * 16)

/* A0's entry (i, j): M/hs + C + hs K. */
CAEKF_HOT_INLINE caekf_scalar_t a0_entry(const caekf_model_t *m, int i, int j)
{
    return m->C[i][j] + m->hs * m->K[i][j] + (i == j ? m->m_dt[i] : 0);
}

/* A = M/hs + C + hs K + sum_c (hs f_c'(delta) + f_c'(rate)) b_c b_c^T: the Jacobian of the momentum
 * rows with respect to v_k once q_k is substituted (dq_k/dv_k = hs). Returns the LU refusal
 * threshold LU_REL_TOL * max|A_ij| (a maximum does not depend on the order it is taken in; a NaN
 * makes the LU refuse either way). */
static caekf_scalar_t newton_matrix(const caekf_model_t *m, const caekf_contact_t *ct, caekf_scalar_t *A)
{
    const int nq = CAEKF_DIM_NQ(m), nc = CAEKF_DIM_NC(m);
    caekf_scalar_t amax = 0;
    int i;
    if (CAEKF_ONE_STEP_BE) { /* A0 from its upper triangle: M/hs + C + hs K is symmetric bit for bit (links add to
                               * both sides) */
        const caekf_scalar_t *a = m->A0;
        CAEKF_UNROLL_SIZED
        for (i = 0; i < nq; ++i) {
            int j;
            A[i * nq + i] = *a++;
            CAEKF_UNROLL_SIZED
            for (j = i + 1; j < nq; ++j) {
                A[i * nq + j] = A[j * nq + i] = *a++;
            }
        }
    } else {
        UNROLL_STEP
        for (i = 0; i < nq * nq; ++i) {
            A[i] = m->A0[i];
        }
    }
    for (i = 0; i < nc; ++i) {
        if (CONTACT_ON(ct[i])) {
            add_contact_outer(m, i, A, nq, m->hs * ct[i].dfc_ddelta + ct[i].dfc_drate);
        }
    }
    if (CAEKF_A0_MAX_OPEN) { /* the entries outside the one contact's block are A0's: their maximum is a constant */
        const int e[2] = {CAEKF_CONTACT_I(m, 0), CAEKF_CONTACT_J(m, 0)};
        int a, b;
        amax = *CAEKF_A0_MAX_OPEN_STORE(m);
        for (a = 0; a < 2; ++a) {
            for (b = 0; b < 2; ++b) {
                if (e[a] >= 0 && e[b] >= 0) {
                    amax = caekf_max(amax, CAEKF_FABS(A[e[a] * nq + e[b]]));
                }
            }
        }
    } else {
        CAEKF_UNROLL_SIZED
        for (i = 0; i < nq * nq; ++i) {
            amax = caekf_max(amax, CAEKF_FABS(A[i]));
        }
    }
    return LU_REL_TOL * amax;
}

/* LU of A with the threshold: over the Newton matrix's pattern where the build fixes the links, else the
 * 4-body kernels where they apply; each the general LU's operations (the kernels: caekf_kernels.c). */
static int factor(caekf_scalar_t *A, int nq, int *piv, caekf_scalar_t tol)
{
    if (CAEKF_FIXED_LINKS) {
        return caekf_lu_factor_sized(A, piv, tol) == CAEKF_LA_OK ? 0 : -1;
    }
    if (!CAEKF_LA_GENERAL_LU) {
        return caekf_lu4_factor_tol(A, piv, tol) == CAEKF_LA_OK ? 0 : -1;
    }
    return (CAEKF_DIM_IS4(nq) ? caekf_lu4_factor_tol(A, piv, tol) : caekf_lu_factor_tol(A, nq, piv, tol)) == CAEKF_LA_OK
               ? 0
               : -1;
}

static void solve(const caekf_scalar_t *lu, int nq, const int *piv, caekf_scalar_t *b, int nrhs, int ldb)
{
    if (CAEKF_FIXED_LINKS) {
        caekf_lu_solve_sized(lu, piv, b, nrhs, ldb);
    } else if (!CAEKF_LA_GENERAL_LU || CAEKF_DIM_IS4(nq)) {
        caekf_lu4_solve(lu, piv, b, nrhs, ldb);
    } else {
        (void)caekf_lu_solve(lu, nq, piv, b, nrhs, ldb);
    }
}

/* solve with a kept LU: A0's (a constant one) or its own */
static void solve_lu(const caekf_model_t *m, const caekf_newton_lu_t *lu, caekf_scalar_t *b, int nrhs, int ldb)
{
    if (lu->constant) {
        solve(m->A0_lu, CAEKF_DIM_NQ(m), m->A0_piv, b, nrhs, ldb);
    } else {
        solve(lu->lu, CAEKF_DIM_NQ(m), lu->piv, b, nrhs, ldb);
    }
}

/* The Newton solve (caekf_model_newton) with the contacts passed on: those of each iterate left in ct, those at
 * x_{k-1} given in ct0 (NULL: evaluated here), the first update's LU given in first (NULL: its own). Its one
 * copy is the substeps' entry point caekf_model_newton_ct where a build has substeps, else caekf_model_newton. */
static int newton_solve(const caekf_model_t *m, const caekf_scalar_t xprev[CAEKF_N], const caekf_scalar_t *u_prev,
                        const caekf_scalar_t *u, int max_iter, caekf_scalar_t rtol, caekf_scalar_t xk[CAEKF_N],
                        int *iters, caekf_scalar_t work[4 * CAEKF_NQ], caekf_contact_t *ct, const caekf_contact_t *ct0,
                        const caekf_newton_lu_t *first)
{
    const int nq = CAEKF_DIM_NQ(m), nc = CAEKF_DIM_NC(m);
    const caekf_scalar_t *qp = xprev;
    const caekf_scalar_t *vp = xprev + nq;
    caekf_scalar_t *q = xk;
    caekf_scalar_t *v = xk + nq;
    const caekf_scalar_t dt = m->p.dt, hs = m->hs;
    caekf_scalar_t *const g0 = work, *const mag0 = work + CAEKF_NQ;                  /* trapezoidal: the step's start */
    caekf_scalar_t *const r = work + 2 * CAEKF_NQ, *const mag = work + 3 * CAEKF_NQ; /* each iterate's */
    caekf_scalar_t f[2 * CAEKF_MAX_INPUTS];     /* base displacements as forces: the end's, the start's */
    const caekf_scalar_t *fe = u, *fs = u_prev; /* the inputs as forces at the step's end and start */
    int it, i;
    int result = 1;
    if (max_iter > CAEKF_NEWTON_MAX_ITER) {
        max_iter = CAEKF_NEWTON_MAX_ITER;
    }
    if (CAEKF_DIM_NBASE(m) > 0) {
        base_forces(m, u_prev, u, f, f + CAEKF_MAX_INPUTS);
        fe = f;
        fs = f + CAEKF_MAX_INPUTS;
    }
    if (CAEKF_METHOD_TRAP(m)) { /* step_start_force, with the contacts at x_{k-1} when they are known */
        if (ct0 == 0) {
            contacts_at(m, xprev, ct);
            ct0 = ct;
        }
        momentum_residual(m, xprev, vp, fs, ct0, g0, mag0);
    }
    UNROLL_STEP
    for (i = 0; i < nq; ++i) { /* initial guess v_k = v_{k-1} */
        v[i] = vp[i];
        q[i] = CAEKF_METHOD_TRAP(m) ? qp[i] + hs * (v[i] + vp[i]) : qp[i] + dt * v[i];
    }
    for (i = 2 * nq; i < CAEKF_DIM_N(m); ++i) { /* random walks: gamma_k = gamma_{k-1}, law parameters */
        xk[i] = xprev[i];
    }
    for (it = 0; it <= max_iter; ++it) {
        /* cppcheck-suppress variableScope ; declarations at the top of the block are this file's style */
        caekf_scalar_t A[CAEKF_NQ * CAEKF_NQ];
        /* cppcheck-suppress variableScope ; declarations at the top of the block are this file's style */
        int piv[CAEKF_NQ];
        /* cppcheck-suppress variableScope ; declarations at the top of the block are this file's style */
        caekf_scalar_t rmax = 0, magmax = 0;
        /* With substeps the first update takes the given LU (the Jacobian at the step's start): the contacts'
         * forces only, unless the bound stops the loop here (x_k's contacts are then these, tangents and all). */
        const int chord = CAEKF_HAS_SUBSTEPS && it == 0 && first != 0 && max_iter > 0;
        for (i = 0; i < nc; ++i) {
            if (chord) {
                contact_force(m, i, xk, &ct[i]);
            } else {
                caekf_model_contact(m, i, xk, &ct[i]);
            }
        }
        /* The test needs at least one update (it solves the linear part exactly): no sizes before. */
        momentum_residual(m, xk, vp, fe, ct, r, it > 0 ? mag : 0);
        if (CAEKF_METHOD_TRAP(m)) {
            UNROLL_STEP
            for (i = 0; i < nq; ++i) {
                r[i] += g0[i];
                if (it > 0) {
                    mag[i] += mag0[i];
                }
            }
        }
        if (it > 0) {
            UNROLL_STEP
            for (i = 0; i < nq; ++i) {
                rmax = caekf_max(rmax, CAEKF_FABS(r[i]));
                magmax = caekf_max(magmax, mag[i]);
            }
            /* Norm-wise test: a lightly loaded row cannot be resolved better than the rounding that
             * the coupled solve spreads from the heavily loaded ones. Written so that NaN never
             * converges. */
            if (rmax <= rtol * magmax) {
                result = 0;
                break;
            }
        }
        if (it == max_iter) {
            break; /* bound reached: x_k keeps the last iterate */
        }
        if (chord) {
            solve_lu(m, first, r, 1, 1);
        } else if (any_contact(ct, nc)) { /* contact: the tangents change A; else the constant LU */
            if (factor(A, nq, piv, newton_matrix(m, ct, A)) != 0) {
                result = 2;
                break;
            }
            solve(A, nq, piv, r, 1, 1);
        } else {
            solve(m->A0_lu, nq, m->A0_piv, r, 1, 1);
        }
        UNROLL_STEP
        for (i = 0; i < nq; ++i) {
            v[i] -= r[i];
            q[i] = CAEKF_METHOD_TRAP(m) ? qp[i] + hs * (v[i] + vp[i]) : qp[i] + dt * v[i];
        }
    }
    *iters = it;
    return result;
}

int caekf_model_newton(const caekf_model_t *m, const caekf_scalar_t xprev[CAEKF_N], const caekf_scalar_t *u_prev,
                       const caekf_scalar_t *u, int max_iter, caekf_scalar_t rtol, caekf_scalar_t xk[CAEKF_N],
                       int *iters, caekf_scalar_t work[4 * CAEKF_NQ])
{
    caekf_contact_t ct[CAEKF_MAX_CONTACTS + 1]; /* each iterate's contacts (first the step's start) */
    if (CAEKF_HAS_SUBSTEPS) {                   /* the solve's one copy */
        return caekf_model_newton_ct(m, xprev, u_prev, u, max_iter, rtol, xk, iters, work, ct, 0, 0);
    }
    return newton_solve(m, xprev, u_prev, u, max_iter, rtol, xk, iters, work, ct, 0, 0);
}

/* Right-hand sides of the linearised step, A dv_k = -(dg/dx_{k-1}) dx_{k-1}, one column per component of
 * x_{k-1}: backward Euler -K_t dq + M/hs dv - sum_c b_c f_c'(gamma) dgamma_c with the tangents at x_k;
 * the trapezoidal rule adds the step's start, -K_t0 dq - (C_t0 + hs K_t) dv - sum_c b_c f_c0'(gamma),
 * with the tangents at x_{k-1} (ct0; NULL for backward Euler). */
static void transition_rhs(const caekf_model_t *m, const caekf_contact_t *ct, const caekf_contact_t *ct0,
                           caekf_scalar_t fv[CAEKF_NQ][CAEKF_N])
{
    const int nq = CAEKF_DIM_NQ(m), nc = CAEKF_DIM_NC(m), n = CAEKF_DIM_N(m);
    int i, j;
    if (CAEKF_FIXED_LINKS) {
        /* The links' pattern is the build's: outside it K and C are +0, so the entries below are -0 there
         * (-0, -0 - 0 and -(hs 0 + 0); backward Euler's v-columns +0) and the parameter columns 0; the
         * pattern's entries (and the diagonal's M/hs) by the operations below. */
        UNROLL_STEP
        for (i = 0; i < nq; ++i) {
            int k;
            CAEKF_UNROLL_SIZED
            for (j = 0; j < nq; ++j) {
                fv[i][j] = -CAEKF_C(0.0);
                fv[i][nq + j] = ct0 != 0 ? -CAEKF_C(0.0) : 0;
            }
            CAEKF_UNROLL_SIZED
            for (j = 2 * nq; j < n; ++j) {
                fv[i][j] = 0;
            }
            CAEKF_UNROLL_SIZED
            for (k = 0; k < CAEKF_ROW_NNZ(m, i); ++k) {
                j = CAEKF_ROW_NZ(m, i)[k];
                fv[i][j] = -m->K[i][j];
                if (ct0 != 0) {
                    fv[i][j] -= m->K[i][j];
                    fv[i][nq + j] = -(m->hs * m->K[i][j] + m->C[i][j]);
                }
            }
            if (ct0 != 0) {
                fv[i][nq + i] += m->m_dt[i];
            } else {
                fv[i][nq + i] = m->m_dt[i];
            }
        }
    } else {
        UNROLL_STEP
        for (i = 0; i < nq; ++i) {
            CAEKF_UNROLL_SIZED
            for (j = 0; j < nq; ++j) {
                fv[i][j] = -m->K[i][j];
            }
            CAEKF_UNROLL_SIZED
            for (j = nq; j < n; ++j) {
                fv[i][j] = 0;
            }
            if (ct0 != 0) {
                CAEKF_UNROLL_SIZED
                for (j = 0; j < nq; ++j) {
                    fv[i][j] -= m->K[i][j];
                    fv[i][nq + j] = -(m->hs * m->K[i][j] + m->C[i][j]);
                }
                fv[i][nq + i] += m->m_dt[i];
            } else {
                fv[i][nq + i] = m->m_dt[i];
            }
        }
    }
    for (i = 0; i < nc; ++i) {
        if (CONTACT_ON(ct[i])) {
            add_contact_outer(m, i, &fv[0][0], CAEKF_N, -ct[i].dfc_ddelta);
            if (ct0 != 0) {
                add_contact_outer(m, i, &fv[0][nq], CAEKF_N, -m->hs * ct[i].dfc_ddelta);
            }
            add_param_columns(m, i, &ct[i], -1, &fv[0][0]);
        }
        if (ct0 != 0 && CONTACT_ON(ct0[i])) {
            add_contact_outer(m, i, &fv[0][0], CAEKF_N, -ct0[i].dfc_ddelta);
            add_contact_outer(m, i, &fv[0][nq], CAEKF_N, -ct0[i].dfc_drate);
            add_param_columns(m, i, &ct0[i], -1, &fv[0][0]);
        }
    }
}

void caekf_model_free_transition_v(const caekf_model_t *m, caekf_scalar_t fv[CAEKF_NQ][CAEKF_N])
{
    const int nq = CAEKF_DIM_NQ(m), n = CAEKF_DIM_N(m);
    int i, j;
    if (CAEKF_ONE_STEP_BE) {                          /* not kept: the same operations as derive_values' */
        caekf_contact_t none[CAEKF_MAX_CONTACTS + 1]; /* every contact open: only delta = 0 is read */
        for (i = 0; i <= CAEKF_MAX_CONTACTS; ++i) {
            none[i].delta = 0;
            none[i].dfc_ddelta = 0;
        }
        transition_rhs(m, none, 0, fv);
        solve(m->A0_lu, nq, m->A0_piv, &fv[0][0], n, CAEKF_N);
        return;
    }
    for (i = 0; i < nq; ++i) {
        for (j = 0; j < n; ++j) {
            fv[i][j] = CAEKF_FV0(m)[i][j];
        }
    }
}

/* F's v-rows from the contacts at x_k (ct) and, trapezoidal, at x_{k-1} (ct0): its one copy is the substeps'
 * entry point caekf_model_transition_ct where a build has substeps, else caekf_model_transition_v_at's. */
CAEKF_HOT_INLINE int transition_solve(const caekf_model_t *m, const caekf_contact_t *ct, const caekf_contact_t *ct0,
                                      caekf_scalar_t fv[CAEKF_NQ][CAEKF_N])
{
    const int nq = CAEKF_DIM_NQ(m), nc = CAEKF_DIM_NC(m), n = CAEKF_DIM_N(m);
    caekf_scalar_t A[CAEKF_NQ * CAEKF_NQ];
    int piv[CAEKF_NQ];
    const int closed = any_contact(ct, nc), closed0 = CAEKF_METHOD_TRAP(m) ? any_contact(ct0, nc) : 0;
    if (!closed && !closed0) { /* linear step: the constant F */
        caekf_model_free_transition_v(m, fv);
        return 0;
    }
    if (closed && factor(A, nq, piv, newton_matrix(m, ct, A)) != 0) {
        return -1;
    }
    transition_rhs(m, ct, CAEKF_METHOD_TRAP(m) ? ct0 : 0, fv); /* solved in place */
    if (closed) {
        solve(A, nq, piv, &fv[0][0], n, CAEKF_N);
    } else { /* trapezoidal, closed only at the step's start: A is A0 */
        solve(m->A0_lu, nq, m->A0_piv, &fv[0][0], n, CAEKF_N);
    }
    return 0;
}

#if CAEKF_HAS_SUBSTEPS
/* The substeps' entry points (caekf_model_internal.h): only a build with substeps has them. */

int caekf_model_contacts_any(const caekf_model_t *m, const caekf_scalar_t *x, caekf_contact_t *ct)
{
    if (x != 0) {
        contacts_at(m, x, ct);
    }
    return any_contact(ct, CAEKF_DIM_NC(m));
}

/* Out of line, so that caekf_model_newton calls it rather than taking a second copy of the solve. */
CAEKF_NOINLINE int caekf_model_newton_ct(const caekf_model_t *m, const caekf_scalar_t xprev[CAEKF_N],
                                         const caekf_scalar_t *u_prev, const caekf_scalar_t *u, int max_iter,
                                         caekf_scalar_t rtol, caekf_scalar_t xk[CAEKF_N], int *iters,
                                         caekf_scalar_t work[4 * CAEKF_NQ], caekf_contact_t *ct,
                                         const caekf_contact_t *ct0, const caekf_newton_lu_t *first)
{
    return newton_solve(m, xprev, u_prev, u, max_iter, rtol, xk, iters, work, ct, ct0, first);
}

int caekf_model_newton_lu(const caekf_model_t *m, const caekf_contact_t *ct, caekf_newton_lu_t *lu)
{
    const int nq = CAEKF_DIM_NQ(m);
    lu->constant = !any_contact(ct, CAEKF_DIM_NC(m));
    return lu->constant ? 0 : factor(lu->lu, nq, lu->piv, newton_matrix(m, ct, lu->lu));
}

/* S <- F_j S for the substep's map F_j, without forming F_j: its v-rows are A^-1 R with R the right-hand
 * sides of transition_rhs, and R's v-columns are kq M/hs - A (+ the rate tangents' change, trapezoidal), so
 *   v-rows of F_j S = A^-1 W - [trapezoidal] S_v,  W = Q S_q + kq M/hs S_v + (r - r0) b b^T S_v + P E,
 * with Q = -(kq K + the contacts' tangents) (kq = 2 trapezoidal, 1 backward Euler), P E the parameter
 * columns, and the q-rows S_q + c2 S_v + hs (v-rows) = S_q + hs A^-1 W (c2 = hs trapezoidal, 0 backward
 * Euler). A is the Newton matrix at x_k, whose LU is left in lu. w: n columns of nq rows of scratch. */
int caekf_model_substep_map(const caekf_model_t *m, const caekf_contact_t *ct, const caekf_contact_t *ct0,
                            caekf_scalar_t sq[CAEKF_NQ][CAEKF_N], caekf_scalar_t sv[CAEKF_NQ][CAEKF_N],
                            caekf_newton_lu_t *lu, caekf_scalar_t w[CAEKF_NQ][CAEKF_N])
{
    const int nq = CAEKF_DIM_NQ(m), nc = CAEKF_DIM_NC(m), n = CAEKF_DIM_N(m), trap = CAEKF_METHOD_TRAP(m);
    const caekf_scalar_t hs = m->hs, kq = trap ? 2 : 1;
    int i, j, k, c;
    if (caekf_model_newton_lu(m, ct, lu) != 0) {
        return -1;
    }
    UNROLL_STEP
    for (i = 0; i < nq; ++i) { /* the links: kq M/hs S_v - kq K S_q */
        const caekf_scalar_t mi = kq * m->m_dt[i];
        caekf_scalar_t kk[CAEKF_NQ];
        UNROLL_STEP
        for (k = 0; k < CAEKF_ROW_NNZ(m, i); ++k) {
            kk[k] = kq * m->K[i][CAEKF_ROW_NZ(m, i)[k]];
        }
        CAEKF_UNROLL_SIZED
        for (j = 0; j < n; ++j) {
            caekf_scalar_t acc = mi * sv[i][j];
            UNROLL_STEP
            for (k = 0; k < CAEKF_ROW_NNZ(m, i); ++k) {
                /* cppcheck-suppress uninitvar ; kk is written above for every k of this loop */
                acc -= kk[k] * sq[CAEKF_ROW_NZ(m, i)[k]][j];
            }
            w[i][j] = acc;
        }
    }
    for (c = 0; c < nc; ++c) { /* the contacts' tangents at either end, and their parameter columns */
        const int a = CAEKF_CONTACT_I(m, c), b = CAEKF_CONTACT_J(m, c);
        const int on = CONTACT_ON(ct[c]), on0 = trap && CONTACT_ON(ct0[c]);
        caekf_scalar_t dq, dr;
        if (!on && !on0) {
            continue;
        }
        dq = (on ? ct[c].dfc_ddelta : 0) + (on0 ? ct0[c].dfc_ddelta : 0);
        dr = trap ? (on ? ct[c].dfc_drate : 0) - (on0 ? ct0[c].dfc_drate : 0) : 0;
        if (CAEKF_IS_STRUCTURE(m)) { /* the same along w_c */
            const caekf_scalar_t *wc = CAEKF_STRUCTURE_W(m, c);
            for (j = 0; j < n; ++j) {
                caekf_scalar_t dqj = 0, dvj = 0, t;
                for (i = 0; i < nq; ++i) {
                    dqj += wc[i] * sq[i][j];
                    dvj += wc[i] * sv[i][j];
                }
                t = dr * dvj - dq * dqj;
                for (i = 0; i < nq; ++i) {
                    w[i][j] += t * wc[i];
                }
            }
        } else {
            CAEKF_UNROLL_SIZED
            for (j = 0; j < n; ++j) {
                const caekf_scalar_t dqj = (a >= 0 ? sq[a][j] : 0) - (b >= 0 ? sq[b][j] : 0);
                const caekf_scalar_t dvj = (a >= 0 ? sv[a][j] : 0) - (b >= 0 ? sv[b][j] : 0);
                const caekf_scalar_t t = dr * dvj - dq * dqj;
                if (a >= 0) {
                    w[a][j] += t;
                }
                if (b >= 0) {
                    w[b][j] -= t;
                }
            }
        }
        if (on) {
            add_param_columns(m, c, &ct[c], -1, &w[0][0]);
        }
        if (on0) {
            add_param_columns(m, c, &ct0[c], -1, &w[0][0]);
        }
    }
    solve_lu(m, lu, &w[0][0], n, CAEKF_N);
    UNROLL_STEP
    for (i = 0; i < nq; ++i) {
        CAEKF_UNROLL_SIZED
        for (j = 0; j < n; ++j) { /* trapezoidal c2 = hs: S_q + hs (S_v + A^-1 W - S_v); backward Euler c2 = 0 */
            sq[i][j] += hs * w[i][j];
            sv[i][j] = trap ? w[i][j] - sv[i][j] : w[i][j];
        }
    }
    return 0;
}

/* Out of line, as caekf_model_newton_ct. */
CAEKF_NOINLINE int caekf_model_transition_ct(const caekf_model_t *m, const caekf_contact_t *ct,
                                             const caekf_contact_t *ct0, caekf_scalar_t fv[CAEKF_NQ][CAEKF_N])
{
    return transition_solve(m, ct, ct0, fv);
}
#endif /* CAEKF_HAS_SUBSTEPS */

int caekf_model_transition_v_at(const caekf_model_t *m, const caekf_contact_t *ct, const caekf_scalar_t xprev[CAEKF_N],
                                caekf_scalar_t fv[CAEKF_NQ][CAEKF_N])
{
    caekf_contact_t ct0[CAEKF_MAX_CONTACTS + 1];
    if (CAEKF_METHOD_TRAP(m)) {
        contacts_at(m, xprev, ct0);
    }
    if (CAEKF_HAS_SUBSTEPS) { /* the one copy */
        return caekf_model_transition_ct(m, ct, ct0, fv);
    }
    return transition_solve(m, ct, ct0, fv);
}

int caekf_model_transition_v(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                             const caekf_scalar_t xprev[CAEKF_N], caekf_scalar_t fv[CAEKF_NQ][CAEKF_N])
{
    caekf_contact_t ct[CAEKF_MAX_CONTACTS + 1];
    contacts_at(m, xk, ct);
    return caekf_model_transition_v_at(m, ct, xprev, fv);
}

/* Adds value to the link matrix entries of link (a, b) (body numbers, 0 = ground). */
CAEKF_NOINLINE static void add_link(caekf_scalar_t out[CAEKF_NQ][CAEKF_NQ], int a, int b, caekf_scalar_t value)
{
    add_contact_block(&out[0][0], CAEKF_NQ, a - 1, b - 1, value);
}

/* The factor on a setting's value: mult[j] for the estimated mechanism parameter j of that kind and
 * element, else 1 (mult NULL: every value the setting's). */
int caekf_model_mech_index(const caekf_model_t *m, int kind, int elem)
{
    int j;
    for (j = 0; j < CAEKF_DIM_NM(m); ++j) {
        if (m->mech_kind[j] == kind && m->mech_elem[j] == elem) {
            return j;
        }
    }
    return -1;
}

static caekf_scalar_t mech_factor(const caekf_model_t *m, const caekf_scalar_t *mult, int kind, int elem)
{
    const int j = mult != 0 ? caekf_model_mech_index(m, kind, elem) : -1;
    return j >= 0 ? mult[j] : 1;
}

/* A kind of mechanism parameter's settings: its values (m, spring_k or spring_c) and their declared
 * relative standard deviations. */
static const caekf_scalar_t *mech_settings(const caekf_model_params_t *p, int kind, const caekf_scalar_t **sigma)
{
    *sigma = kind == CAEKF_MECH_MASS        ? p->m_sigma
             : kind == CAEKF_MECH_STIFFNESS ? p->spring_k_sigma
                                            : p->spring_c_sigma;
    return kind == CAEKF_MECH_MASS ? p->m : kind == CAEKF_MECH_STIFFNESS ? p->spring_k : p->spring_c;
}

caekf_scalar_t caekf_model_mech_setting(const caekf_model_t *m, const caekf_model_params_t *p, int j,
                                        caekf_scalar_t *sigma)
{
    const caekf_scalar_t *sig, *value = mech_settings(p, m->mech_kind[j], &sig);
    if (sigma != 0) {
        *sigma = sig[m->mech_elem[j]];
    }
    return value[m->mech_elem[j]];
}

/* The estimated mechanism parameters (settings m{i}_sigma, spring{i}_k_sigma, spring{i}_c_sigma > 0):
 * states after the law parameters, masses first, then stiffnesses, then dampers. */
static void mech_states(caekf_model_t *m, const caekf_model_params_t *p)
{
    int i, kind;
    m->nm = 0;
    for (kind = CAEKF_MECH_MASS; kind <= CAEKF_MECH_DAMPER; ++kind) {
        const int count = kind == CAEKF_MECH_MASS ? p->bodies : p->springs;
        const caekf_scalar_t *sigma, *value = mech_settings(p, kind, &sigma);
        for (i = 0; i < count && m->nm < CAEKF_MAX_MECH_PARAMS; ++i) {
            if (sigma[i] > 0) {
                const int j = m->nm++;
                m->mech_kind[j] = (unsigned char)kind;
                m->mech_elem[j] = (unsigned char)i;
                m->mech_a[j] = (signed char)(kind == CAEKF_MECH_MASS ? i : p->spring_a[i] - 1);
                m->mech_b[j] = (signed char)(kind == CAEKF_MECH_MASS ? i : p->spring_b[i] - 1);
                m->mech_value[j] = value[i];
            }
        }
    }
    m->n += m->nm;
}

/* The base-displacement inputs of the settings (input{i}_kind): each one's link, and as its body the link's
 * end that is not the ground (validation checked that one end is). */
static void base_inputs(caekf_model_t *m, const caekf_model_params_t *p)
{
    int i;
    if (!CAEKF_HAS_BASE_INPUTS) {
        return;
    }
    *CAEKF_NBASE_STORE(m) = 0;
    for (i = 0; i < CAEKF_MAX_INPUTS; ++i) {
        CAEKF_BASE_LINK_STORE(m)[i] = 0;
        if (i < p->inputs && p->input_kind[i] == CAEKF_INPUT_BASE_DISPLACEMENT) {
            const int l = p->input_link[i] - 1;
            CAEKF_BASE_LINK_STORE(m)[i] = (unsigned char)p->input_link[i];
            m->p.input_body[i] = p->spring_a[l] != 0 ? p->spring_a[l] : p->spring_b[l];
            ++*CAEKF_NBASE_STORE(m);
        }
    }
}

/* The base inputs' links' stiffness and damper at mult (derive_values). */
static void base_values(caekf_model_t *m, const caekf_model_params_t *p, const caekf_scalar_t *mult)
{
    int i;
    for (i = 0; i < CAEKF_DIM_NU(m); ++i) {
        const int l = CAEKF_BASE_LINK(m, i) - 1;
        if (l >= 0) {
            CAEKF_BASE_K_STORE(m)[i] = p->spring_k[l] * mech_factor(m, mult, CAEKF_MECH_STIFFNESS, l);
            CAEKF_BASE_C_STORE(m)[i] = p->spring_c[l] * mech_factor(m, mult, CAEKF_MECH_DAMPER, l);
        }
    }
}

/* The matrices derived from the values: K, C, M / hs, A0 and its LU, the contact-free F; the estimated
 * mechanism parameters at mult[j] times their settings' values (mult NULL: the settings'). */
static int derive_values(caekf_model_t *m, const caekf_model_params_t *p, const caekf_scalar_t *mult)
{
    caekf_contact_t none[CAEKF_MAX_CONTACTS + 1]; /* every contact open: only delta = 0 is read */
    const int nq = m->nq;
    int i, j;
    for (i = 0; i <= CAEKF_MAX_CONTACTS; ++i) {
        none[i].delta = 0;
        none[i].dfc_ddelta = 0;
    }
    for (j = 0; mult != 0 && j < CAEKF_DIM_NM(m); ++j) {
        m->mech_value[j] = mult[j] * caekf_model_mech_setting(m, p, j, 0);
    }
    if (CAEKF_IS_STRUCTURE(m)) { /* K and C are the structure's own (caekf_model_init_structure) */
        for (i = 0; i < nq; ++i) {
            m->m_dt[i] = CAEKF_STRUCTURE_MASS(m)[i] / m->hs;
        }
    } else {
        for (i = 0; i < CAEKF_NQ; ++i) {
            for (j = 0; j < CAEKF_NQ; ++j) {
                m->K[i][j] = 0;
                m->C[i][j] = 0;
            }
        }
        /* Links in order, each adding its 2x2 pattern: a link to ground adds to one diagonal entry. */
        for (i = 0; i < p->springs; ++i) {
            add_link(m->K, p->spring_a[i], p->spring_b[i],
                     p->spring_k[i] * mech_factor(m, mult, CAEKF_MECH_STIFFNESS, i));
            add_link(m->C, p->spring_a[i], p->spring_b[i], p->spring_c[i] * mech_factor(m, mult, CAEKF_MECH_DAMPER, i));
        }
        for (i = 0; i < nq; ++i) {
            m->m_dt[i] = p->m[i] * mech_factor(m, mult, CAEKF_MECH_MASS, i) / m->hs;
        }
    }
    if (CAEKF_DIM_NBASE(m) > 0) {
        base_values(m, p, mult);
    }
    for (i = 0; i < nq; ++i) {
        if (!CAEKF_FIXED_LINKS) {
            CAEKF_ROW_NNZ_STORE(m)[i] = 0;
        }
        for (j = 0; j < nq; ++j) {
            const caekf_scalar_t a = a0_entry(m, i, j);
            if (!CAEKF_ONE_STEP_BE) {
                m->A0[i * nq + j] = a;
            } else if (j >= i) { /* row i of the upper triangle follows rows 0 .. i-1 (nq - k entries each) */
                m->A0[i * nq - i * (i - 1) / 2 + j - i] = a;
            }
            m->A0_lu[i * nq + j] = a;
            if (!CAEKF_FIXED_LINKS && (m->K[i][j] != 0 || m->C[i][j] != 0)) { /* the pattern of row i */
                CAEKF_ROW_NZ_STORE(m)[i][CAEKF_ROW_NNZ_STORE(m)[i]++] = (unsigned char)j;
            }
        }
    }
    /* A0 = M/hs + C + hs K is positive definite for valid parameters; the check is belt and braces. */
    {
        caekf_scalar_t amax = 0;     /* the LU's threshold, as caekf_lu_factor takes it */
        caekf_scalar_t open_max = 0; /* CAEKF_A0_MAX_OPEN: the largest outside contact 1's block */
        for (i = 0; i < nq * nq; ++i) {
            amax = caekf_max(amax, CAEKF_FABS(m->A0_lu[i]));
            if (CAEKF_A0_MAX_OPEN && ((i / nq != m->contact_i[0] && i / nq != m->contact_j[0]) ||
                                      (i % nq != m->contact_i[0] && i % nq != m->contact_j[0]))) {
                open_max = caekf_max(open_max, CAEKF_FABS(m->A0_lu[i]));
            }
        }
        if (CAEKF_A0_MAX_OPEN) {
            *CAEKF_A0_MAX_OPEN_STORE(m) = open_max;
        }
        if (factor(m->A0_lu, nq, m->A0_piv, LU_REL_TOL * amax) != 0) {
            return -1;
        }
    }
    if (!CAEKF_ONE_STEP_BE) { /* the contact-free F, kept */
        transition_rhs(m, none, CAEKF_METHOD_TRAP(m) ? none : 0, CAEKF_FV0(m));
        solve(m->A0_lu, nq, m->A0_piv, &CAEKF_FV0(m)[0][0], m->n, CAEKF_N);
    }
    return 0;
}

/* A structure's matrices and vectors into the model (st NULL: bodies on a line). */
static void load_structure(caekf_model_t *m, const caekf_model_params_t *p, const caekf_structure_t *st)
{
    int i, j;
    if (!CAEKF_HAS_STRUCTURES) { /* bodies on a line only */
        return;
    }
    *CAEKF_IS_STRUCTURE_STORE(m) = st != 0;
    if (st == 0) {
        return;
    }
    for (i = 0; i < st->dofs; ++i) {
        CAEKF_STRUCTURE_MASS(m)[i] = st->mass[i];
        for (j = 0; j < st->dofs; ++j) {
            m->K[i][j] = st->stiffness[i * st->dofs + j];
            m->C[i][j] = st->damping != 0 ? st->damping[i * st->dofs + j] : 0;
        }
        for (j = 0; j < p->inputs; ++j) {
            CAEKF_STRUCTURE_BU(m, j)[i] = st->inputs[i * p->inputs + j];
        }
        for (j = 0; j < p->contacts; ++j) {
            CAEKF_STRUCTURE_W(m, j)[i] = st->contacts[j * st->dofs + i];
        }
        for (j = 0; j < p->sensors; ++j) {
            CAEKF_STRUCTURE_H(m, j)[i] = st->sensors[j * st->dofs + i];
        }
    }
}

static int model_init(caekf_model_t *m, const caekf_model_params_t *p, const caekf_structure_t *st)
{
    int i, j, nq;
    if (caekf_model_params_check(p) != 0) {
        return -1;
    }
    if (!CAEKF_HAS_STRUCTURES) {
        st = 0;
    }
    load_structure(m, p, st);
    /* The run-time values the model reads (a sized build's count, exponent and method are constants). */
    m->p.dt = p->dt;
    if (!CAEKF_SIZED) {
        *CAEKF_INPUTS_STORE(m) = p->inputs;
    }
    for (i = 0; i < CAEKF_MAX_INPUTS; ++i) {
        m->p.input_body[i] = p->input_body[i];
    }
    base_inputs(m, p);
    for (i = 0; i < CAEKF_MAX_CONTACTS; ++i) {
        m->p.contact_gap[i] = p->contact_gap[i];
        if (CAEKF_HAS_CONTACT_N) {
            CAEKF_CONTACT_N_STORE(m)[i] = p->contact_n[i];
        }
        if (CAEKF_HAS_DAMPING) {
            CAEKF_LAMBDA_STORE(m)[i] = p->contact_lambda[i];
        }
    }
    if (!CAEKF_SIZED_METHOD) {
        *CAEKF_GAMMA_LOG_STORE(m) = p->gamma_log;
        *CAEKF_TRAP_STORE(m) = p->discretisation == CAEKF_DISCRETISATION_TRAPEZOIDAL;
    }
    for (i = 0; CAEKF_HAS_SLR && i < CAEKF_MAX_CONTACTS; ++i) {
        CAEKF_SLR_S(m)[i] = 0;
    }
    m->hs = p->discretisation == CAEKF_DISCRETISATION_TRAPEZOIDAL ? p->dt / 2 : p->dt;
    nq = st != 0 ? st->dofs : p->bodies;
    m->nq = nq;
    m->nc = p->contacts;
    m->n = 2 * nq + p->contacts;
    for (i = 0; i < CAEKF_NP_STORE; ++i) {
        m->param_contact[i] = (unsigned char)(i < p->contacts ? i : 0);
    }
    for (i = 0; i < CAEKF_MAX_CONTACTS; ++i) { /* the estimated law parameters, after the gammas */
        const int *const flags[CAEKF_LAW_COUNT] = {p->contact_estimate_n, p->contact_estimate_lambda,
                                                   p->contact_estimate_gap};
        for (j = 0; j < CAEKF_LAW_COUNT; ++j) {
            m->law_state[i][j] = 0;
            if (i < p->contacts && flags[j][i]) {
                m->param_contact[m->n - 2 * nq] = (unsigned char)i;
                m->law_state[i][j] = (unsigned char)m->n++;
            }
        }
    }
    for (i = 0; i < p->contacts; ++i) {
        m->contact_i[i] = p->contact_a[i] - 1;
        m->contact_j[i] = p->contact_b[i] - 1;
    }
    mech_states(m, p);
    m->nb = 0;
    for (i = 0; i < CAEKF_MAX_SENSORS; ++i) { /* the sensors' offsets: the last states */
        m->sensor_bias[i] = 0;
        if (i < p->sensors && p->sensor_bias_sigma[i] > 0 && m->nb < CAEKF_MAX_BIASES) {
            m->sensor_bias[i] = (unsigned char)m->n++;
            m->nb++;
        }
    }
    return derive_values(m, p, 0);
}

int caekf_model_init(caekf_model_t *m, const caekf_model_params_t *p) { return model_init(m, p, 0); }

/* Every entry of the rows x cols array a finite (NULL: none to read). */
static int all_finite(const caekf_scalar_t *a, int rows, int cols)
{
    int i;
    for (i = 0; a != 0 && i < rows * cols; ++i) {
        if (!CAEKF_ISFINITE(a[i])) {
            return 0;
        }
    }
    return 1;
}

/* The n x n array a symmetric bit for bit (the Newton matrix and F take its rows as its columns). */
static int symmetric(const caekf_scalar_t *a, int n)
{
    int i, j;
    for (i = 0; a != 0 && i < n; ++i) {
        for (j = i + 1; j < n; ++j) {
            if (a[i * n + j] != a[j * n + i]) {
                return 0;
            }
        }
    }
    return 1;
}

int caekf_model_structure_check(const caekf_model_params_t *p, const caekf_structure_t *st)
{
    int i, n;
    if (!CAEKF_HAS_STRUCTURES || p == 0 || st == 0 || st->dofs < 1 || st->dofs > CAEKF_NQ || st->mass == 0 ||
        st->stiffness == 0 || (p->inputs > 0 && st->inputs == 0) || (p->contacts > 0 && st->contacts == 0) ||
        st->sensors == 0) {
        return -1;
    }
    n = st->dofs;
    if (!all_finite(st->mass, n, 1) || !all_finite(st->stiffness, n, n) || !all_finite(st->damping, n, n) ||
        !all_finite(st->inputs, n, p->inputs) || !all_finite(st->contacts, p->contacts, n) ||
        !all_finite(st->sensors, p->sensors, n) || !symmetric(st->stiffness, n) || !symmetric(st->damping, n)) {
        return -1;
    }
    for (i = 0; i < n; ++i) {
        if (!(st->mass[i] > 0)) {
            return -1;
        }
    }
    for (i = 0; i < p->sensors; ++i) { /* rows of q, v or the acceleration */
        if (p->sensor_kind[i] > CAEKF_SENSOR_ACCELERATION) {
            return -1;
        }
    }
    for (i = 0; i < p->inputs; ++i) { /* a base displacement moves a link's end: a line's */
        if (p->input_kind[i] != CAEKF_INPUT_FORCE) {
            return -1;
        }
    }
    for (i = 0; i < p->bodies; ++i) { /* the mechanism parameters are a line's masses and links */
        if (p->m_sigma[i] > 0) {
            return -1;
        }
    }
    for (i = 0; i < p->springs; ++i) {
        if (p->spring_k_sigma[i] > 0 || p->spring_c_sigma[i] > 0) {
            return -1;
        }
    }
    return 0;
}

int caekf_model_init_structure(caekf_model_t *m, const caekf_model_params_t *p, const caekf_structure_t *st)
{
    if (caekf_model_structure_check(p, st) != 0) {
        return -1;
    }
    return model_init(m, p, st);
}

int caekf_model_set_mech(caekf_model_t *m, const caekf_model_params_t *p, const caekf_scalar_t *mult)
{
    return derive_values(m, p, mult);
}

/* B_u's entry of body row i and input k, -dg/du_k: 1 on a force's body row; a base displacement's -dg/du_k -
 * dg/du_{k-1} = k (+ c / hs - c / hs; the trapezoidal rule's start adds k again, the callers' twice the one
 * end) on its body's row, per end that takes it. */
static caekf_scalar_t input_rhs(const caekf_model_t *m, int i, int k)
{
    if (CAEKF_IS_STRUCTURE(m)) {
        return CAEKF_STRUCTURE_BU(m, k)[i];
    }
    if (i != m->p.input_body[k] - 1) {
        return 0;
    }
    return CAEKF_DIM_NBASE(m) > 0 && CAEKF_BASE_LINK(m, k) != 0 ? CAEKF_BASE_K(m, k) : 1;
}

int caekf_model_input_columns(const caekf_model_t *m, const caekf_contact_t *ct,
                              caekf_scalar_t g[CAEKF_NQ][CAEKF_MAX_INPUTS])
{
    const int nq = CAEKF_DIM_NQ(m), nu = CAEKF_DIM_NU(m);
    caekf_scalar_t A[CAEKF_NQ * CAEKF_NQ];
    int piv[CAEKF_NQ];
    int i, k;
    if (factor(A, nq, piv, newton_matrix(m, ct, A)) != 0) {
        return -1;
    }
    for (i = 0; i < nq; ++i) {
        for (k = 0; k < nu; ++k) {
            g[i][k] = input_rhs(m, i, k);
        }
    }
    solve(A, nq, piv, &g[0][0], nu, CAEKF_MAX_INPUTS);
    return 0;
}

/* Link l's ground end at the step's end (*g1) and start (*g0): its displacement (damper 0) or its rate, the
 * same at both ends (damper 1), from the base input that moves it; 0 when none does. */
static void ground_end(const caekf_model_t *m, int l, int damper, const caekf_scalar_t *u_prev, const caekf_scalar_t *u,
                       caekf_scalar_t *g1, caekf_scalar_t *g0)
{
    int k;
    *g1 = 0;
    *g0 = 0;
    for (k = 0; k < CAEKF_DIM_NU(m); ++k) {
        if (CAEKF_BASE_LINK(m, k) == l + 1) {
            *g1 = damper ? (u[k] - u_prev[k]) / m->p.dt : u[k];
            *g0 = damper ? *g1 : u_prev[k];
        }
    }
}

int caekf_model_mech_columns(const caekf_model_t *m, const caekf_contact_t *ct, const caekf_scalar_t xprev[CAEKF_N],
                             const caekf_scalar_t xk[CAEKF_N], const caekf_scalar_t *u_prev, const caekf_scalar_t *u,
                             const caekf_scalar_t *dev, caekf_scalar_t fv[CAEKF_NQ][CAEKF_N])
{
    const int nq = CAEKF_DIM_NQ(m), nm = CAEKF_DIM_NM(m), first = CAEKF_DIM_MECH0(m);
    const int trap = CAEKF_METHOD_TRAP(m);
    caekf_scalar_t A[CAEKF_NQ * CAEKF_NQ], moved[2 * CAEKF_NQ];
    const caekf_scalar_t *x = xk; /* x_k's q and v, moved by dev */
    int piv[CAEKF_NQ];
    int i, j;
    if (factor(A, nq, piv, newton_matrix(m, ct, A)) != 0) {
        return -1;
    }
    if (dev != 0) { /* where the inputs less dev would have taken the step, to first order: A^-1 B_u dev less */
        caekf_scalar_t dv[CAEKF_NQ];
        int k;
        for (i = 0; i < nq; ++i) {
            dv[i] = 0;
            for (k = 0; k < CAEKF_DIM_NU(m); ++k) {
                dv[i] += input_rhs(m, i, k) * dev[k];
            }
        }
        solve(A, nq, piv, dv, 1, 1);
        for (i = 0; i < nq; ++i) {
            moved[i] = xk[i] - m->hs * dv[i];
            moved[nq + i] = xk[nq + i] - dv[i];
        }
        x = moved;
    }
    /* -dg/d ln(value): the momentum rows' terms, each the value times its own derivative. A mass: M/hs
     * (v_k - v_{k-1}) on its body's row; a link: K or C times the ends' difference (b_l^T q, b_l^T v) at
     * x_k and, trapezoidal, at x_{k-1} too, +b_l on its ends' rows; a ground end a base input moves is at
     * u (u_{k-1} at x_{k-1}) and moves at (u_k - u_{k-1}) / dt. */
    for (j = 0; j < nm; ++j) {
        const int a = m->mech_a[j], b = m->mech_b[j], off = m->mech_kind[j] == CAEKF_MECH_DAMPER ? nq : 0;
        caekf_scalar_t d, g1 = 0, g0 = 0;
        for (i = 0; i < nq; ++i) {
            fv[i][first + j] = 0;
        }
        if (m->mech_kind[j] == CAEKF_MECH_MASS) {
            fv[a][first + j] = -m->mech_value[j] / m->hs * (x[nq + a] - xprev[nq + a]);
            continue;
        }
        if (CAEKF_DIM_NBASE(m) > 0) {
            ground_end(m, m->mech_elem[j], off != 0, u_prev, u, &g1, &g0);
        }
        d = (a >= 0 ? x[off + a] : g1) - (b >= 0 ? x[off + b] : g1);
        if (trap) {
            d += (a >= 0 ? xprev[off + a] : g0) - (b >= 0 ? xprev[off + b] : g0);
        }
        if (a >= 0) {
            fv[a][first + j] = -m->mech_value[j] * d;
        }
        if (b >= 0) {
            fv[b][first + j] = m->mech_value[j] * d;
        }
    }
    solve(A, nq, piv, &fv[0][first], nm, CAEKF_N);
    return 0;
}

#if CAEKF_MODEL_ORACLES
/* The model's reference functions (caekf_model_internal.h): test oracles the estimator never calls. */

/* The trapezoidal rule's constant part of the momentum rows, G(x_{k-1}, u_{k-1}), and its terms' sizes:
 * the residual with no inertia (v_{k-1} against itself). */
CAEKF_NOINLINE static void step_start_force(const caekf_model_t *m, const caekf_scalar_t *xprev,
                                            const caekf_scalar_t *u_prev, caekf_contact_t *ct0, caekf_scalar_t *g0,
                                            caekf_scalar_t *mag0)
{
    contacts_at(m, xprev, ct0);
    momentum_residual(m, xprev, xprev + CAEKF_DIM_NQ(m), u_prev, ct0, g0, mag0);
}

void caekf_model_residual(const caekf_model_t *m, const caekf_scalar_t *xk, const caekf_scalar_t *xprev,
                          const caekf_scalar_t *u_prev, const caekf_scalar_t *u, caekf_scalar_t *g)
{
    const int nq = CAEKF_DIM_NQ(m);
    caekf_contact_t ct[CAEKF_MAX_CONTACTS + 1];
    caekf_scalar_t f[2 * CAEKF_MAX_INPUTS];     /* base displacements as forces: the end's, the start's */
    const caekf_scalar_t *fe = u, *fs = u_prev; /* the inputs as forces at the step's end and start */
    int i;
    if (CAEKF_DIM_NBASE(m) > 0) {
        base_forces(m, u_prev, u, f, f + CAEKF_MAX_INPUTS);
        fe = f;
        fs = f + CAEKF_MAX_INPUTS;
    }
    contacts_at(m, xk, ct);
    for (i = 0; i < nq; ++i) {
        const caekf_scalar_t v = CAEKF_METHOD_TRAP(m) ? (xk[nq + i] + xprev[nq + i]) / 2 : xk[nq + i];
        g[i] = (xk[i] - xprev[i]) / m->p.dt - v;
    }
    momentum_residual(m, xk, xprev + nq, fe, ct, g + nq, 0);
    if (CAEKF_METHOD_TRAP(m)) {
        caekf_scalar_t g0[CAEKF_NQ], mag0[CAEKF_NQ];
        step_start_force(m, xprev, fs, ct, g0, mag0); /* ct (at x_k) is no longer needed */
        for (i = 0; i < nq; ++i) {
            g[nq + i] += g0[i];
        }
    }
    for (i = 2 * nq; i < CAEKF_DIM_N(m); ++i) { /* random walks: the gammas and law parameters */
        g[i] = xk[i] - xprev[i];
    }
}

/* Adds one contact's tangents to the momentum rows of a Jacobian (row nq .. of J): the force through
 * delta (q columns), its rate (v columns) and the contact's parameter states. */
static void add_contact_tangents(const caekf_model_t *m, int c, const caekf_contact_t *ct,
                                 caekf_scalar_t J[CAEKF_N][CAEKF_N])
{
    const int nq = CAEKF_DIM_NQ(m);
    add_contact_outer(m, c, &J[nq][0], CAEKF_N, ct->dfc_ddelta);
    add_contact_outer(m, c, &J[nq][nq], CAEKF_N, ct->dfc_drate);
    add_param_columns(m, c, ct, 1, &J[nq][0]);
}

void caekf_model_jacobians(const caekf_model_t *m, const caekf_scalar_t *xk, const caekf_scalar_t *xprev,
                           caekf_scalar_t Jk[CAEKF_N][CAEKF_N], caekf_scalar_t Jprev[CAEKF_N][CAEKF_N])
{
    const int nq = CAEKF_DIM_NQ(m), nc = CAEKF_DIM_NC(m), n = CAEKF_DIM_N(m);
    const caekf_scalar_t inv_dt = 1 / m->p.dt, theta = CAEKF_METHOD_TRAP(m) ? CAEKF_C(0.5) : 1;
    caekf_contact_t ct[CAEKF_MAX_CONTACTS + 1], ct0[CAEKF_MAX_CONTACTS + 1];
    int i, j, c;
    for (i = 0; i < n; ++i) {
        for (j = 0; j < n; ++j) {
            Jk[i][j] = 0;
            Jprev[i][j] = 0;
        }
    }
    for (i = 0; i < nq; ++i) {
        Jk[i][i] = inv_dt;
        Jk[i][nq + i] = -theta;
        Jprev[i][i] = -inv_dt;
        Jprev[i][nq + i] = theta - 1;
        Jprev[nq + i][nq + i] = -m->m_dt[i];
        for (j = 0; j < nq; ++j) {
            Jk[nq + i][j] = m->K[i][j];
            Jk[nq + i][nq + j] = m->C[i][j] + (i == j ? m->m_dt[i] : 0);
            if (CAEKF_METHOD_TRAP(m)) { /* the step's start: G(x_{k-1}) */
                Jprev[nq + i][j] = m->K[i][j];
                Jprev[nq + i][nq + j] += m->C[i][j];
            }
        }
    }
    contacts_at(m, xk, ct);
    contacts_at(m, xprev, ct0);
    for (c = 0; c < nc; ++c) {
        add_contact_tangents(m, c, &ct[c], Jk);
        if (CAEKF_METHOD_TRAP(m)) {
            add_contact_tangents(m, c, &ct0[c], Jprev);
        }
    }
    for (i = 2 * nq; i < n; ++i) {
        Jk[i][i] = 1;
        Jprev[i][i] = -1;
    }
}

int caekf_model_transition(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                           const caekf_scalar_t xprev[CAEKF_N], caekf_scalar_t F[CAEKF_N][CAEKF_N])
{
    const int nq = CAEKF_DIM_NQ(m), n = CAEKF_DIM_N(m);
    int i, j;
    /* The v-rows land in F's rows nq .. 2 nq - 1 directly. */
    if (caekf_model_transition_v(m, xk, xprev, (caekf_scalar_t(*)[CAEKF_N]) & F[nq][0]) != 0) {
        return -1;
    }
    /* dq_k = dq_{k-1} + (dt - hs) dv_{k-1} + hs dv_k; dgamma_k = dgamma_{k-1} (eq. 23's last rows). */
    for (i = 0; i < nq; ++i) {
        for (j = 0; j < n; ++j) {
            F[i][j] = m->hs * F[nq + i][j] + (i == j ? 1 : 0) + (j == nq + i ? m->p.dt - m->hs : 0);
        }
    }
    for (i = 2 * nq; i < n; ++i) {
        for (j = 0; j < n; ++j) {
            F[i][j] = i == j ? 1 : 0;
        }
    }
    return 0;
}
#endif /* CAEKF_MODEL_ORACLES */
