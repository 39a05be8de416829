/*
 * The sensors' measurement model (docs/sensors.md): what each sensor reads at the augmented state, and its
 * row of H. A position or velocity sensor reads one state; the sensors of real rigs read more:
 *   acceleration  the model's acceleration of a body at the state (eq. 19's momentum balance at x_k, with
 *                 the contact force), M^-1 (B_u u - K q - C v + B_c f_c) (a base displacement u of a link (k,
 *                 c): k u + c (u - u_prev) / dt on its body, the rate over the last step);
 *   relative      a body's position relative to another's (a strain gauge or an LVDT across a link);
 *   link_force    the force in a spring-damper link, k (q_a - q_b) + c (v_a - v_b) (a load cell; a ground
 *                 end a base input moves is at u, moving at (u - u_prev) / dt).
 * Any sensor may carry an estimated offset, added to what it reads.
 */
#include "caekf_model_internal.h"

/* The state of the estimated mechanism parameter of that kind and element (its ln(value / setting)), or -1. */
static int mech_state(const caekf_model_t *m, int kind, int elem)
{
    const int j = caekf_model_mech_index(m, kind, elem);
    return j >= 0 ? CAEKF_DIM_MECH0(m) + j : -1;
}

/* A mass, stiffness or damper's value now: the estimate's when it is estimated (*state its state), else
 * the setting's (*state -1). */
static caekf_scalar_t mech_now(const caekf_model_t *m, const caekf_model_params_t *p, int kind, int elem, int *state)
{
    *state = mech_state(m, kind, elem);
    if (*state >= 0) {
        return m->mech_value[*state - CAEKF_DIM_MECH0(m)];
    }
    return kind == CAEKF_MECH_MASS ? p->m[elem] : kind == CAEKF_MECH_STIFFNESS ? p->spring_k[elem] : p->spring_c[elem];
}

/* x[i], 0 for the ground (i < 0). */
static caekf_scalar_t at(const caekf_scalar_t *x, int i) { return i >= 0 ? x[i] : 0; }

/* x[i], or for the ground (i < 0) g: where a base input has moved a link's ground end. */
static caekf_scalar_t at_or(const caekf_scalar_t *x, int i, caekf_scalar_t g) { return i >= 0 ? x[i] : g; }

/* Link l's ground end: its displacement (*gq) and rate (*gv) from the base input that moves it (the rate over
 * the last step), 0 and 0 when none does. */
static void ground_end(const caekf_model_t *m, int l, const caekf_scalar_t *u, const caekf_scalar_t *u_prev,
                       caekf_scalar_t *gq, caekf_scalar_t *gv)
{
    int k;
    *gq = 0;
    *gv = 0;
    for (k = 0; k < CAEKF_DIM_NU(m) && CAEKF_DIM_NBASE(m) > 0; ++k) {
        if (CAEKF_BASE_LINK(m, k) == l + 1) {
            *gq = u[k];
            *gv = (u[k] - u_prev[k]) / m->p.dt;
        }
    }
}

/* row[i] += s, nothing for the ground (i < 0). */
static void add(caekf_scalar_t *row, int i, caekf_scalar_t s)
{
    if (i >= 0) {
        row[i] += s;
    }
}

/* Body b's acceleration at x: the momentum balance's forces over its mass, and their derivatives. */
static caekf_scalar_t acceleration(const caekf_model_t *m, const caekf_model_params_t *p, int b,
                                   const caekf_scalar_t *x, const caekf_scalar_t *u, const caekf_scalar_t *u_prev,
                                   caekf_scalar_t *row)
{
    const int nq = CAEKF_DIM_NQ(m), nc = CAEKF_DIM_NC(m), nu = CAEKF_DIM_NU(m);
    int mass_state, i, c;
    const caekf_scalar_t mass = mech_now(m, p, CAEKF_MECH_MASS, b, &mass_state);
    caekf_scalar_t force = 0, a;
    for (i = 0; i < nu; ++i) {
        if (m->p.input_body[i] - 1 == b) {
            if (CAEKF_BASE_LINK(m, i) != 0) { /* k u + c du/dt: K q and C v hold the link's -k q_b, -c v_b */
                force += CAEKF_BASE_K(m, i) * u[i] + CAEKF_BASE_C(m, i) * (u[i] - u_prev[i]) / m->p.dt;
            } else {
                force += u[i];
            }
        }
    }
    for (i = 0; i < nq; ++i) { /* -K q - C v: K and C at the mechanism parameters' estimates */
        force -= m->K[b][i] * x[i] + m->C[b][i] * x[nq + i];
        row[i] -= m->K[b][i];
        row[nq + i] -= m->C[b][i];
    }
    for (i = 0; i < p->springs; ++i) { /* d(K q)_b / d ln k_l = k_l (q_a - q_b) on the link's ends */
        const int ea = p->spring_a[i] - 1, eb = p->spring_b[i] - 1;
        const caekf_scalar_t side = ea == b ? 1 : eb == b ? -1 : 0;
        int ks, cs;
        const caekf_scalar_t k = mech_now(m, p, CAEKF_MECH_STIFFNESS, i, &ks);
        const caekf_scalar_t cv = mech_now(m, p, CAEKF_MECH_DAMPER, i, &cs);
        caekf_scalar_t gq, gv; /* the ground end: a base input's u and du/dt, else 0 */
        ground_end(m, i, u, u_prev, &gq, &gv);
        if (side != 0) {
            add(row, ks, -side * k * (at_or(x, ea, gq) - at_or(x, eb, gq)));
            add(row, cs, -side * cv * (at_or(x + nq, ea, gv) - at_or(x + nq, eb, gv)));
        }
    }
    for (c = 0; c < nc; ++c) { /* -f on the contact's body a, +f on b */
        const int ca = CAEKF_CONTACT_I(m, c), cb = CAEKF_CONTACT_J(m, c);
        const caekf_scalar_t side = (ca == b ? -1 : 0) + (cb == b ? 1 : 0);
        caekf_contact_t ct;
        if (side == 0) {
            continue;
        }
        caekf_model_contact(m, c, x, &ct);
        force += side * ct.fc;
        add(row, ca, side * ct.dfc_ddelta);
        add(row, cb, -side * ct.dfc_ddelta);
        add(row, ca < 0 ? -1 : nq + ca, side * ct.dfc_drate);
        add(row, cb < 0 ? -1 : nq + cb, -side * ct.dfc_drate);
        row[2 * nq + c] += side * ct.dfc_dgamma;
        if (CAEKF_HAS_LAW_PARAMS) { /* the estimated law parameters' columns */
            if (m->law_state[c][CAEKF_LAW_N] != 0) {
                row[m->law_state[c][CAEKF_LAW_N]] += side * *CAEKF_DFC_DN_STORE(&ct);
            }
            if (m->law_state[c][CAEKF_LAW_LAMBDA] != 0) {
                row[m->law_state[c][CAEKF_LAW_LAMBDA]] += side * *CAEKF_DFC_DLAMBDA_STORE(&ct);
            }
            if (m->law_state[c][CAEKF_LAW_GAP] != 0) {
                row[m->law_state[c][CAEKF_LAW_GAP]] -= side * ct.dfc_ddelta;
            }
        }
    }
    a = force / mass;
    for (i = 0; i < CAEKF_DIM_N(m); ++i) {
        row[i] /= mass;
    }
    add(row, mass_state, -a); /* a = force / (setting exp(theta)) */
    return a;
}

/* Sensor k of a structure (its row h of the positions, velocities or accelerations). The acceleration is
 * M^-1 (B_u u - K q - C v - sum_c w_c f_c): h^T of it reads g = M^-1 h (M diagonal) against each term. */
static caekf_scalar_t structure_sensor(const caekf_model_t *m, const caekf_model_params_t *p, int k,
                                       const caekf_scalar_t *x, const caekf_scalar_t *u, caekf_scalar_t *row)
{
    const int nq = CAEKF_DIM_NQ(m);
    const caekf_scalar_t *h = CAEKF_STRUCTURE_H(m, k), *mass = CAEKF_STRUCTURE_MASS(m);
    caekf_scalar_t value = 0;
    int i, j, c;
    if (p->sensor_kind[k] != CAEKF_SENSOR_ACCELERATION) {
        const int off = p->sensor_kind[k] == CAEKF_SENSOR_VELOCITY ? nq : 0;
        for (i = 0; i < nq; ++i) {
            value += h[i] * x[off + i];
            row[off + i] = h[i];
        }
        return value;
    }
    for (i = 0; i < nq; ++i) {
        const caekf_scalar_t g = h[i] / mass[i];
        if (g == 0) {
            continue;
        }
        for (j = 0; j < CAEKF_DIM_NU(m); ++j) {
            value += g * CAEKF_STRUCTURE_BU(m, j)[i] * u[j];
        }
        for (j = 0; j < nq; ++j) {
            value -= g * (m->K[i][j] * x[j] + m->C[i][j] * x[nq + j]);
            row[j] -= g * m->K[i][j];
            row[nq + j] -= g * m->C[i][j];
        }
    }
    for (c = 0; c < CAEKF_DIM_NC(m); ++c) {
        const caekf_scalar_t *w = CAEKF_STRUCTURE_W(m, c);
        caekf_scalar_t gw = 0;
        caekf_contact_t ct;
        for (i = 0; i < nq; ++i) {
            gw += h[i] / mass[i] * w[i];
        }
        caekf_model_contact(m, c, x, &ct);
        value -= gw * ct.fc;
        for (j = 0; j < nq; ++j) {
            row[j] -= gw * ct.dfc_ddelta * w[j];
            row[nq + j] -= gw * ct.dfc_drate * w[j];
        }
        row[2 * nq + c] -= gw * ct.dfc_dgamma;
        if (CAEKF_HAS_LAW_PARAMS) { /* the estimated law parameters' columns */
            if (m->law_state[c][CAEKF_LAW_N] != 0) {
                row[m->law_state[c][CAEKF_LAW_N]] -= gw * *CAEKF_DFC_DN_STORE(&ct);
            }
            if (m->law_state[c][CAEKF_LAW_LAMBDA] != 0) {
                row[m->law_state[c][CAEKF_LAW_LAMBDA]] -= gw * *CAEKF_DFC_DLAMBDA_STORE(&ct);
            }
            if (m->law_state[c][CAEKF_LAW_GAP] != 0) { /* delta = w^T q - gap */
                row[m->law_state[c][CAEKF_LAW_GAP]] += gw * ct.dfc_ddelta;
            }
        }
    }
    return value;
}

void caekf_model_sensor(const caekf_model_t *m, const caekf_model_params_t *p, int k, const caekf_scalar_t *x,
                        const caekf_scalar_t *u, const caekf_scalar_t *u_prev, caekf_scalar_t *value,
                        caekf_scalar_t row[CAEKF_N])
{
    const int nq = CAEKF_DIM_NQ(m), b = p->sensor_body[k] - 1;
    int i;
    for (i = 0; i < CAEKF_DIM_N(m); ++i) {
        row[i] = 0;
    }
    *value = 0;
    if (!CAEKF_HAS_SENSOR_ROWS) { /* a build sized for sensors that each read one state: never called */
        return;
    }
    if (CAEKF_IS_STRUCTURE(m)) {
        *value = structure_sensor(m, p, k, x, u, row);
    } else {
        switch (p->sensor_kind[k]) {
        case CAEKF_SENSOR_VELOCITY:
            *value = x[nq + b];
            row[nq + b] = 1;
            break;
        case CAEKF_SENSOR_ACCELERATION: *value = acceleration(m, p, b, x, u, u_prev, row); break;
        case CAEKF_SENSOR_RELATIVE: {
            const int r = p->sensor_ref[k] - 1;
            *value = x[b] - at(x, r);
            row[b] = 1;
            add(row, r, -1);
            break;
        }
        case CAEKF_SENSOR_LINK_FORCE: {
            const int l = p->sensor_link[k] - 1, ea = p->spring_a[l] - 1, eb = p->spring_b[l] - 1;
            int ks, cs;
            const caekf_scalar_t kv = mech_now(m, p, CAEKF_MECH_STIFFNESS, l, &ks);
            const caekf_scalar_t cv = mech_now(m, p, CAEKF_MECH_DAMPER, l, &cs);
            caekf_scalar_t gq, gv, dq, dv; /* the ground end: a base input's u and du/dt, else 0 */
            ground_end(m, l, u, u_prev, &gq, &gv);
            dq = at_or(x, ea, gq) - at_or(x, eb, gq);
            dv = at_or(x + nq, ea, gv) - at_or(x + nq, eb, gv);
            *value = kv * dq + cv * dv;
            add(row, ea, kv);
            add(row, eb, -kv);
            add(row, ea < 0 ? -1 : nq + ea, cv);
            add(row, eb < 0 ? -1 : nq + eb, -cv);
            add(row, ks, kv * dq);
            add(row, cs, cv * dv);
            break;
        }
        default: /* CAEKF_SENSOR_POSITION */
            *value = x[b];
            row[b] = 1;
            break;
        }
    }
    if (m->sensor_bias[k] != 0) {
        *value += x[m->sensor_bias[k]];
        row[m->sensor_bias[k]] = 1;
    }
}
