/* The contact model: eq. (16) contact law, eq. (19) residual and Jacobians, Newton, eq. (10) F. */
#include "caekf_model_internal.h"

#include "caekf/caekf.h"

#include <stddef.h>

#include "caekf_linalg.h"
#include "caekf_math.h"

/* Bodies 2 and 3 (0-based 1 and 2) are the contact pair. */
#define B2 1
#define B3 2

CAEKF_STATIC_ASSERT(CAEKF_NQ == 4, model_has_four_bodies);
CAEKF_STATIC_ASSERT(CAEKF_N == 2 * CAEKF_NQ + 1, augmented_state_is_q_v_gamma);

/* The paper's chain, the one mechanism this core computes: links (a, b) in this order, the contact
 * (2, 3) with the Hertz law, the input on body 1, position sensors on bodies 1 and 4. */
static const signed char chain_links[4][2] = {{1, 0}, {1, 2}, {3, 4}, {4, 0}};
static const signed char chain_sensors[2] = {1, 4};
CAEKF_STATIC_ASSERT(CAEKF_MAX_SPRINGS == 4 && CAEKF_MAX_SENSORS == 2 && CAEKF_MAX_INPUTS == 1 &&
                        CAEKF_MAX_CONTACTS == 1,
                    core_is_sized_for_the_chain);

int caekf_model_unsupported(const caekf_model_params_t *p)
{
    int i;
    if (p->bodies != CAEKF_NQ) {
        return (int)CAEKF_PARAM_BODIES;
    }
    if (p->springs != 4) {
        return (int)CAEKF_PARAM_SPRINGS;
    }
    for (i = 0; i < 4; ++i) {
        if (p->spring_a[i] != chain_links[i][0]) {
            return (int)CAEKF_PARAM_SPRING_A + i;
        }
        if (p->spring_b[i] != chain_links[i][1]) {
            return (int)CAEKF_PARAM_SPRING_B + i;
        }
    }
    if (p->inputs != 1 || p->input_body[0] != 1) {
        return p->inputs != 1 ? (int)CAEKF_PARAM_INPUTS : (int)CAEKF_PARAM_INPUT_BODY;
    }
    if (p->sensors != 2) {
        return (int)CAEKF_PARAM_SENSORS;
    }
    for (i = 0; i < 2; ++i) {
        if (p->sensor_body[i] != chain_sensors[i]) {
            return (int)CAEKF_PARAM_SENSOR_BODY + i;
        }
        if (p->sensor_kind[i] != CAEKF_SENSOR_POSITION) {
            return (int)CAEKF_PARAM_SENSOR_KIND + i;
        }
    }
    if (p->contacts != 1) {
        return (int)CAEKF_PARAM_CONTACTS;
    }
    if (p->contact_a[0] != B2 + 1 || p->contact_b[0] != B3 + 1) {
        return p->contact_a[0] != B2 + 1 ? (int)CAEKF_PARAM_CONTACT_A : (int)CAEKF_PARAM_CONTACT_B;
    }
    if (p->contact_n[0] != CAEKF_C(1.5)) {
        return (int)CAEKF_PARAM_CONTACT_N;
    }
    if (p->contact_lambda[0] != 0) {
        return (int)CAEKF_PARAM_CONTACT_LAMBDA;
    }
    return -1;
}

/* The model's own defence: finite values, masses and dt > 0, links and gap >= 0, a supported mechanism. */
int caekf_model_params_check(const caekf_model_params_t *p)
{
    int i;
    if (caekf_model_unsupported(p) >= 0 || !CAEKF_ISFINITE(p->dt) || !(p->dt > 0) ||
        !CAEKF_ISFINITE(p->contact_gap[0]) || !(p->contact_gap[0] >= 0)) {
        return 1;
    }
    for (i = 0; i < CAEKF_NQ; ++i) {
        if (!CAEKF_ISFINITE(p->m[i]) || !(p->m[i] > 0)) {
            return 1;
        }
    }
    for (i = 0; i < 4; ++i) {
        if (!CAEKF_ISFINITE(p->spring_k[i]) || !(p->spring_k[i] >= 0) || !CAEKF_ISFINITE(p->spring_c[i]) ||
            !(p->spring_c[i] >= 0)) {
            return 1;
        }
    }
    return 0;
}

/* Keeps a function called more than once out of line: inlined copies cost flash on the MCU. */
#if defined(__GNUC__)
#define NOINLINE __attribute__((noinline))
#else
#define NOINLINE
#endif

static void zero(caekf_scalar_t *a, int n)
{
    int i;
    for (i = 0; i < n; ++i) {
        a[i] = 0;
    }
}

static void copy(caekf_scalar_t *dst, const caekf_scalar_t *src, int n)
{
    int i;
    for (i = 0; i < n; ++i) {
        dst[i] = src[i];
    }
}

/* Chain topology: ground -a- 1 -b- 2 | 3 -c- 4 -d- ground. */
NOINLINE static void chain_matrix(caekf_scalar_t out[CAEKF_NQ][CAEKF_NQ], caekf_scalar_t a, caekf_scalar_t b,
                                  caekf_scalar_t c, caekf_scalar_t d)
{
    zero(&out[0][0], CAEKF_NQ * CAEKF_NQ);
    out[0][0] = a + b;
    out[0][1] = -b;
    out[1][0] = -b;
    out[1][1] = b;
    out[2][2] = c;
    out[2][3] = -c;
    out[3][2] = -c;
    out[3][3] = c + d;
}

/* Eq. (16)-(17): f_c = gamma delta^1.5 while delta > 0. */
void caekf_model_contact(const caekf_model_t *m, const caekf_scalar_t q[CAEKF_NQ], caekf_scalar_t gamma,
                         caekf_contact_t *c)
{
    caekf_scalar_t d = q[B2] - q[B3] - m->p.contact_gap[0];
    c->delta = d;
    if (d > 0) {
        caekf_scalar_t sd = CAEKF_SQRT(d);
        c->dfc_dgamma = d * sd;
        c->fc = gamma * c->dfc_dgamma;
        c->dfc_ddelta = CAEKF_C(1.5) * gamma * sd;
    } else {
        c->fc = 0;
        c->dfc_ddelta = 0;
        c->dfc_dgamma = 0;
    }
}

/* Momentum rows of eq. (19) for (q_k, v_k); optionally the magnitude of each row's terms, which is
 * what the residual's rounding error scales with. The contact force enters as +f_c on body 2 and
 * -f_c on body 3 (the residual carries -B_c f_c with B_c = [0, -1, +1, 0]). */
static void momentum_residual(const caekf_model_t *m, const caekf_scalar_t q[CAEKF_NQ], const caekf_scalar_t v[CAEKF_NQ],
                              const caekf_scalar_t vprev[CAEKF_NQ], caekf_scalar_t u, caekf_scalar_t fc,
                              caekf_scalar_t r[CAEKF_NQ], caekf_scalar_t mag[CAEKF_NQ])
{
    int i;
    for (i = 0; i < CAEKF_NQ; ++i) {
        /* K and C couple bodies (1,2) and (3,4) only (chain_matrix): the other terms are exact
         * zeros, which change neither sum. */
        const int b = i & 2;
        const caekf_scalar_t *k = &m->K[i][b], *c = &m->C[i][b], *qb = q + b, *vb = v + b;
        const caekf_scalar_t inertia = m->m_dt[i] * (v[i] - vprev[i]);
        const caekf_scalar_t kq0 = k[0] * qb[0], cv0 = c[0] * vb[0];
        const caekf_scalar_t kq1 = k[1] * qb[1], cv1 = c[1] * vb[1];
        r[i] = inertia + (kq0 + cv0) + (kq1 + cv1);
        if (mag != 0) {
            mag[i] = CAEKF_FABS(inertia) + (CAEKF_FABS(kq0) + CAEKF_FABS(cv0)) + (CAEKF_FABS(kq1) + CAEKF_FABS(cv1));
        }
    }
    r[0] -= u;
    r[B2] += fc;
    r[B3] -= fc;
    if (mag != 0) {
        mag[0] += CAEKF_FABS(u);
        mag[B2] += CAEKF_FABS(fc);
        mag[B3] += CAEKF_FABS(fc);
    }
}

void caekf_model_residual(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                          const caekf_scalar_t xprev[CAEKF_N], caekf_scalar_t u, caekf_scalar_t g[CAEKF_N])
{
    caekf_contact_t c;
    int i;
    caekf_model_contact(m, xk, xk[CAEKF_IG], &c);
    for (i = 0; i < CAEKF_NQ; ++i) {
        g[i] = (xk[i] - xprev[i]) / m->p.dt - xk[CAEKF_NQ + i];
    }
    momentum_residual(m, xk, xk + CAEKF_NQ, xprev + CAEKF_NQ, u, c.fc, g + CAEKF_NQ, 0);
    g[CAEKF_IG] = xk[CAEKF_IG] - xprev[CAEKF_IG];
}

void caekf_model_jacobians(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                           caekf_scalar_t Jk[CAEKF_N][CAEKF_N], caekf_scalar_t Jprev[CAEKF_N][CAEKF_N])
{
    caekf_contact_t c;
    int i, j;
    caekf_scalar_t inv_dt = 1 / m->p.dt;
    caekf_model_contact(m, xk, xk[CAEKF_IG], &c);
    zero(&Jk[0][0], CAEKF_N * CAEKF_N);
    zero(&Jprev[0][0], CAEKF_N * CAEKF_N);
    for (i = 0; i < CAEKF_NQ; ++i) {
        Jk[i][i] = inv_dt;
        Jk[i][CAEKF_NQ + i] = -1;
        Jprev[i][i] = -inv_dt;
        Jprev[CAEKF_NQ + i][CAEKF_NQ + i] = -m->m_dt[i];
        for (j = 0; j < CAEKF_NQ; ++j) {
            Jk[CAEKF_NQ + i][j] = m->K[i][j];
            Jk[CAEKF_NQ + i][CAEKF_NQ + j] = m->C[i][j] + (i == j ? m->m_dt[i] : 0);
        }
    }
    /* Contact tangent: d(+-f_c)/dq through delta = q2 - q3 - gap, and d/dgamma. */
    Jk[CAEKF_NQ + B2][B2] += c.dfc_ddelta;
    Jk[CAEKF_NQ + B2][B3] -= c.dfc_ddelta;
    Jk[CAEKF_NQ + B3][B2] -= c.dfc_ddelta;
    Jk[CAEKF_NQ + B3][B3] += c.dfc_ddelta;
    Jk[CAEKF_NQ + B2][CAEKF_IG] = c.dfc_dgamma;
    Jk[CAEKF_NQ + B3][CAEKF_IG] = -c.dfc_dgamma;
    Jk[CAEKF_IG][CAEKF_IG] = 1;
    Jprev[CAEKF_IG][CAEKF_IG] = -1;
}

#define LU_REL_TOL (CAEKF_EPS * 16)

/* A = M/dt + C + dt (K + K_c): the Jacobian of the momentum rows with respect to v_k once
 * q_k = q_{k-1} + dt v_k is substituted; K_c = f_c'(delta) n n^T with n = [0, 1, -1, 0]. Returns the
 * LU refusal threshold LU_REL_TOL * max|A_ij|: only the contact block differs from A0, and a maximum
 * does not depend on the order it is taken in (a NaN in the block makes the LU refuse either way). */
static caekf_scalar_t newton_matrix(const caekf_model_t *m, caekf_scalar_t dfc_ddelta,
                                    caekf_scalar_t A[CAEKF_NQ][CAEKF_NQ])
{
    int i;
    caekf_scalar_t kc = m->p.dt * dfc_ddelta;
    caekf_scalar_t amax = m->A0_absmax_out;
    copy(&A[0][0], &m->A0[0][0], CAEKF_NQ * CAEKF_NQ);
    for (i = 0; i < 4; ++i) { /* the 2x2 contact block, row by row: + on its diagonal, - off it */
        caekf_scalar_t *a = &A[B2 + i / 2][B2 + i % 2];
        if (i / 2 == i % 2) {
            *a += kc;
        } else {
            *a -= kc;
        }
        amax = caekf_max(amax, CAEKF_FABS(*a));
    }
    return LU_REL_TOL * amax;
}

int caekf_model_newton(const caekf_model_t *m, const caekf_scalar_t xprev[CAEKF_N], caekf_scalar_t u,
                       int max_iter, caekf_scalar_t rtol, caekf_scalar_t xk[CAEKF_N], int *iters)
{
    const caekf_scalar_t *qp = xprev;
    const caekf_scalar_t *vp = xprev + CAEKF_NQ;
    caekf_scalar_t gamma = xprev[CAEKF_IG];
    caekf_scalar_t *q = xk;
    caekf_scalar_t *v = xk + CAEKF_NQ;
    caekf_scalar_t dt = m->p.dt;
    int it, i;
    int result = 1;
    if (max_iter > CAEKF_NEWTON_MAX_ITER) {
        max_iter = CAEKF_NEWTON_MAX_ITER;
    }
    for (i = 0; i < CAEKF_NQ; ++i) { /* initial guess v_k = v_{k-1} */
        v[i] = vp[i];
        q[i] = qp[i] + dt * v[i];
    }
    xk[CAEKF_IG] = gamma; /* random walk: gamma_k = gamma_{k-1} */
    for (it = 0; it <= max_iter; ++it) {
        caekf_contact_t c;
        caekf_scalar_t r[CAEKF_NQ], mag[CAEKF_NQ];
        caekf_scalar_t A[CAEKF_NQ][CAEKF_NQ];
        /* cppcheck-suppress variableScope ; declarations at the top of the block are this file's style */
        int piv[CAEKF_NQ];
        /* cppcheck-suppress variableScope ; declarations at the top of the block are this file's style */
        caekf_scalar_t rmax = 0, magmax = 0;
        caekf_model_contact(m, q, gamma, &c);
        /* The test needs at least one update (it solves the linear part exactly): no sizes before. */
        momentum_residual(m, q, v, vp, u, c.fc, r, it > 0 ? mag : 0);
        if (it > 0) {
            for (i = 0; i < CAEKF_NQ; ++i) {
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
        if (c.delta > 0) { /* contact: the tangent changes A; else the constant LU */
            if (caekf_lu4_factor_tol(&A[0][0], piv, newton_matrix(m, c.dfc_ddelta, A)) != CAEKF_LA_OK) {
                result = 2;
                break;
            }
            caekf_lu4_solve(&A[0][0], piv, r, 1);
        } else {
            caekf_lu4_solve(&m->A0_lu[0][0], m->A0_piv, r, 1);
        }
        for (i = 0; i < CAEKF_NQ; ++i) {
            v[i] -= r[i];
            q[i] = qp[i] + dt * v[i];
        }
    }
    *iters = it;
    return result;
}

/* Right-hand sides of the linearised eq. (19): A dv_k = -K_t dq_{k-1} + M/dt dv_{k-1}
 * - n delta^1.5 dgamma_{k-1}, one column per component of x_{k-1}. */
static void transition_rhs(const caekf_model_t *m, const caekf_contact_t *c, caekf_scalar_t fv[CAEKF_NQ][CAEKF_N])
{
    const caekf_scalar_t d = c->dfc_ddelta, g = c->dfc_dgamma;
    int i, j;
    zero(&fv[0][0], CAEKF_NQ * CAEKF_N);
    for (i = 0; i < CAEKF_NQ; ++i) {
        for (j = 0; j < CAEKF_NQ; ++j) {
            fv[i][j] = -m->K[i][j];
        }
        fv[i][CAEKF_NQ + i] = m->m_dt[i];
    }
    fv[B2][B2] -= d;
    fv[B2][B3] += d;
    fv[B3][B2] += d;
    fv[B3][B3] -= d;
    fv[B2][CAEKF_IG] = -g;
    fv[B3][CAEKF_IG] = g;
}

int caekf_model_transition_v(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                             caekf_scalar_t fv[CAEKF_NQ][CAEKF_N])
{
    caekf_contact_t c;
    caekf_scalar_t A[CAEKF_NQ][CAEKF_NQ];
    int piv[CAEKF_NQ];
    caekf_model_contact(m, xk, xk[CAEKF_IG], &c);
    if (!(c.delta > 0)) { /* linear step: the constant F */
        copy(&fv[0][0], &m->fv0[0][0], CAEKF_NQ * CAEKF_N);
        return 0;
    }
    if (caekf_lu4_factor_tol(&A[0][0], piv, newton_matrix(m, c.dfc_ddelta, A)) != CAEKF_LA_OK) {
        return -1;
    }
    transition_rhs(m, &c, fv); /* solved in place */
    caekf_lu4_solve(&A[0][0], piv, &fv[0][0], CAEKF_N);
    return 0;
}

int caekf_model_init(caekf_model_t *m, const caekf_model_params_t *p)
{
    const caekf_contact_t none = {0, 0, 0, 0};
    int i, j;
    if (caekf_model_params_check(p) != 0) {
        return -1;
    }
    m->p = *p;
    chain_matrix(m->K, p->spring_k[0], p->spring_k[1], p->spring_k[2], p->spring_k[3]);
    chain_matrix(m->C, p->spring_c[0], p->spring_c[1], p->spring_c[2], p->spring_c[3]);
    m->A0_absmax_out = 0;
    for (i = 0; i < CAEKF_NQ; ++i) {
        m->m_dt[i] = p->m[i] / p->dt;
        for (j = 0; j < CAEKF_NQ; ++j) {
            caekf_scalar_t a = m->C[i][j] + p->dt * m->K[i][j] + (i == j ? m->m_dt[i] : 0);
            m->A0[i][j] = a;
            m->A0_lu[i][j] = a;
            if ((i - B2) * (i - B3) > 0 || (j - B2) * (j - B3) > 0) { /* outside the contact block */
                m->A0_absmax_out = caekf_max(m->A0_absmax_out, CAEKF_FABS(a));
            }
        }
    }
    /* A0 = M/dt + C + dt K is positive definite for valid parameters; the check is belt and braces. */
    if (caekf_lu_factor(&m->A0_lu[0][0], CAEKF_NQ, m->A0_piv, LU_REL_TOL) != CAEKF_LA_OK) {
        return -1;
    }
    transition_rhs(m, &none, m->fv0);
    caekf_lu4_solve(&m->A0_lu[0][0], m->A0_piv, &m->fv0[0][0], CAEKF_N);
    return 0;
}

int caekf_model_transition(const caekf_model_t *m, const caekf_scalar_t xk[CAEKF_N],
                           caekf_scalar_t F[CAEKF_N][CAEKF_N])
{
    int i, j;
    /* The v-rows land in F's rows 4..7 directly. */
    if (caekf_model_transition_v(m, xk, (caekf_scalar_t(*)[CAEKF_N]) & F[CAEKF_NQ][0]) != 0) {
        return -1;
    }
    /* dq_k = dq_{k-1} + dt dv_k; dgamma_k = dgamma_{k-1} (eq. 23's last row). */
    for (i = 0; i < CAEKF_NQ; ++i) {
        for (j = 0; j < CAEKF_N; ++j) {
            F[i][j] = m->p.dt * F[CAEKF_NQ + i][j] + (i == j ? 1 : 0);
        }
    }
    zero(F[CAEKF_IG], CAEKF_N);
    F[CAEKF_IG][CAEKF_IG] = 1;
    return 0;
}
