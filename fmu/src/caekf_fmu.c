/* The FMUs' instance, independent of the FMI version: the estimator (caekf_init, caekf_step, caekf_predict,
 * caekf_correct of the double core) or the plant (the DOP853 truth of host/common/truth.c, one sample per
 * communication step). Compiled once per role, with that role's generated variable table
 * (caekf_fmu_vars.h). One heap block per instance holds everything: no globals, so instances run side by
 * side. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "caekf/caekf.h"
#include "caekf_fmu_vars.h"
#include "common/scenario.h"
#include "common/truth.h"
#include "fmu_roles.h"

#define CAEKF_FMU_PI 3.141592653589793238462643383279502884
#define ROLE_COUNT (CAEKF_FMU_OUT_STEPS + 1)
#define ROLE_MAX_INDEX 32 /* elements per role: the largest capacity (springs: 12) and the flag bits */

typedef enum { ST_INSTANTIATED, ST_INIT, ST_STEP, ST_TERMINATED, ST_ERROR } fmu_state_t;

struct caekf_fmu {
    char name[128];
    caekf_fmu_logger_t logger;
    void *env;
    int logging_on;
    fmu_state_t state;
    double t0, t;                    /* start time, the next communication point */
    long k;                          /* communication steps done */
    caekf_scenario_t sc;             /* the parameters, as a scenario (given[]: set by the scenario or the master) */
    double val[CAEKF_FMU_VAR_COUNT]; /* inputs and outputs */
    int vr_of[ROLE_COUNT][ROLE_MAX_INDEX];
#if CAEKF_FMU_IS_PLANT
    caekf_truth_stepper_t plant;
#else
    caekf_settings_t s;
    caekf_t est;
    caekf_report_t rep;
    caekf_status_t status;
    double t_sample;
    caekf_scalar_t u_hold[CAEKF_MAX_INPUTS];
#endif
};

static void flog(caekf_fmu_t *f, int status, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    const char *category = status >= CAEKF_FMU_ERROR     ? "logStatusError"
                           : status == CAEKF_FMU_WARNING ? "logStatusWarning"
                                                         : "logEvents";
    if (f == NULL || f->logger == NULL || (status == CAEKF_FMU_OK && !f->logging_on)) {
        return;
    }
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    f->logger(f->env, f->name, status, category, msg);
}

static int fail(caekf_fmu_t *f, const char *fmt, const char *what)
{
    flog(f, CAEKF_FMU_ERROR, fmt, what);
    return CAEKF_FMU_ERROR;
}

static double *slot(caekf_fmu_t *f, unsigned row)
{
    return (double *)(void *)((char *)&f->sc + caekf_scenario_keys[row].offset);
}

/* Key row's element in use: its array's count covers it (as the scenario loader decides). */
static int in_use(caekf_fmu_t *f, unsigned row)
{
    const caekf_scenario_key_t *k = &caekf_scenario_keys[row];
    return k->in_use_key < 0 || (double)k->index < *slot(f, (unsigned)k->in_use_key);
}

static void load_parameters(caekf_fmu_t *f)
{
    unsigned i;
    memset(&f->sc, 0, sizeof f->sc);
    for (i = 0; i < CAEKF_SCENARIO_KEY_COUNT; ++i) {
        *slot(f, i) = caekf_scenario_keys[i].default_value;
    }
    for (i = 0; i < CAEKF_FMU_VAR_COUNT; ++i) {
        if (caekf_fmu_vars[i].role == CAEKF_FMU_PARAM) {
            *slot(f, caekf_fmu_vars[i].index) = caekf_fmu_vars[i].start;
        } else {
            f->val[i] = caekf_fmu_vars[i].start;
        }
    }
    for (i = 0; i < CAEKF_FMU_SCENARIO_COUNT; ++i) {
        *slot(f, caekf_fmu_scenario[i].key) = caekf_fmu_scenario[i].value;
        f->sc.given[caekf_fmu_scenario[i].key] = 1;
    }
}

caekf_fmu_t *caekf_fmu_new(const char *instance_name, const char *token, caekf_fmu_logger_t logger, void *env,
                           int logging_on)
{
    caekf_fmu_t *f;
    unsigned i, r;
    if (token == NULL || strcmp(token, CAEKF_FMU_TOKEN) != 0) {
        if (logger != NULL) {
            logger(env, instance_name != NULL ? instance_name : "", CAEKF_FMU_ERROR, "logStatusError",
                   "instantiation token does not match " CAEKF_FMU_MODEL_IDENTIFIER "'s modelDescription.xml");
        }
        return NULL;
    }
    f = calloc(1, sizeof *f);
    if (f == NULL) {
        if (logger != NULL) {
            logger(env, instance_name != NULL ? instance_name : "", CAEKF_FMU_ERROR, "logStatusError", "out of memory");
        }
        return NULL;
    }
    snprintf(f->name, sizeof f->name, "%s", instance_name != NULL ? instance_name : "");
    f->logger = logger;
    f->env = env;
    f->logging_on = logging_on;
    for (r = 0; r < ROLE_COUNT; ++r) {
        for (i = 0; i < ROLE_MAX_INDEX; ++i) {
            f->vr_of[r][i] = -1;
        }
    }
    for (i = 0; i < CAEKF_FMU_VAR_COUNT; ++i) {
        const caekf_fmu_var_t *v = &caekf_fmu_vars[i];
        if (v->role == CAEKF_FMU_PARAM) {
            /* the generated table and the scenario reader's come from the same schema: check they agree */
            if (v->index >= CAEKF_SCENARIO_KEY_COUNT || strcmp(caekf_scenario_keys[v->index].key, v->name) != 0) {
                flog(f, CAEKF_FMU_ERROR, "parameter %s does not match the scenario reader's table (stale build)",
                     v->name);
                free(f);
                return NULL;
            }
        } else if (v->index < ROLE_MAX_INDEX) {
            f->vr_of[v->role][v->index] = (int)i;
        }
    }
    load_parameters(f);
    f->state = ST_INSTANTIATED;
    return f;
}

void caekf_fmu_free(caekf_fmu_t *f) { free(f); }

void caekf_fmu_set_logging(caekf_fmu_t *f, int on) { f->logging_on = on; }

double caekf_fmu_time(const caekf_fmu_t *f) { return f->t; }

int caekf_fmu_unsupported(caekf_fmu_t *f, const char *function)
{
    return fail(f, "%s is not supported by this FMU (co-simulation only, no FMU state)", function);
}

int caekf_fmu_enter_init(caekf_fmu_t *f, double start_time)
{
    if (f->state != ST_INSTANTIATED) {
        return fail(f, "%s: only after instantiation", "enterInitializationMode");
    }
    if (!isfinite(start_time)) {
        return fail(f, "%s: the start time must be finite", "enterInitializationMode");
    }
#if CAEKF_FMU_IS_PLANT
    if (start_time != 0) {
        return fail(f, "%s: the plant starts at rest at t = 0 (its samples are t = k dt): start time must be 0",
                    "enterInitializationMode");
    }
#endif
    f->t0 = f->t = start_time;
    f->state = ST_INIT;
    return CAEKF_FMU_OK;
}

static void set_out(caekf_fmu_t *f, int role, unsigned index, double v)
{
    if (index < ROLE_MAX_INDEX && f->vr_of[role][index] >= 0) {
        f->val[f->vr_of[role][index]] = v;
    }
}

/* Every parameter in use against its schema rule (as the scenario loader checks a file). */
static int check_parameters(caekf_fmu_t *f)
{
    unsigned i;
    for (i = 0; i < CAEKF_FMU_VAR_COUNT; ++i) {
        const caekf_fmu_var_t *v = &caekf_fmu_vars[i];
        const caekf_scenario_key_t *k;
        if (v->role != CAEKF_FMU_PARAM) {
            continue;
        }
        k = &caekf_scenario_keys[v->index];
        if (in_use(f, v->index) && !caekf_setting_rule_ok((unsigned)k->rule_code, k->lo, k->hi, *slot(f, v->index))) {
            flog(f, CAEKF_FMU_ERROR, "parameter %s = %.17g: %s", k->key, *slot(f, v->index), k->rule);
            return CAEKF_FMU_ERROR;
        }
    }
    return CAEKF_FMU_OK;
}

#if CAEKF_FMU_IS_PLANT

static void plant_outputs(caekf_fmu_t *f, const caekf_truth_sample_t *smp, int valid)
{
    unsigned i;
    for (i = 0; i < CAEKF_MAX_INPUTS; ++i) {
        set_out(f, CAEKF_FMU_OUT_U, i, (int)i < smp->inputs ? smp->u[i] : 0.0);
    }
    for (i = 0; i < CAEKF_MAX_SENSORS; ++i) {
        set_out(f, CAEKF_FMU_OUT_Y, i, (int)i < smp->sensors ? smp->y[i] : 0.0);
    }
    for (i = 0; i < CAEKF_MAX_BODIES; ++i) {
        set_out(f, CAEKF_FMU_OUT_Q, i, (int)i < smp->bodies ? smp->q[i] : 0.0);
        set_out(f, CAEKF_FMU_OUT_V, i, (int)i < smp->bodies ? smp->v[i] : 0.0);
    }
    for (i = 0; i < CAEKF_MAX_CONTACTS; ++i) {
        set_out(f, CAEKF_FMU_OUT_DELTA, i, (int)i < smp->contacts ? smp->delta[i] : 0.0);
    }
    set_out(f, CAEKF_FMU_OUT_Y_VALID, 0, valid);
}

static int role_init(caekf_fmu_t *f)
{
    char err[256];
    caekf_truth_sample_t s0;
    const caekf_truth_plant_t *p = &f->plant.p;
    int i;
    if (caekf_scenario_need_truth(&f->sc, f->name, err, sizeof err) != 0) {
        return fail(f, "%s", err);
    }
    if (caekf_truth_start(&f->plant, &f->sc, NULL) != 0) {
        return fail(f, "%s: the mechanism is refused by the model (bodies, links, sensors or contacts)", f->name);
    }
    /* At t = 0 the plant rests (q = v = 0); the inputs are the sines at 0, no sensor sample yet. */
    memset(&s0, 0, sizeof s0);
    s0.inputs = p->ni;
    s0.sensors = p->ns;
    s0.bodies = p->nq;
    s0.contacts = p->nc;
    for (i = 0; i < p->ni; ++i) {
        s0.u[i] = p->amp[i] * sin(p->phase[i]);
    }
    for (i = 0; i < p->nc; ++i) {
        s0.delta[i] = -p->gap[i];
    }
    plant_outputs(f, &s0, 0);
    set_out(f, CAEKF_FMU_OUT_EVENTS, 0, 0);
    set_out(f, CAEKF_FMU_OUT_STEPS, 0, 0);
    return CAEKF_FMU_OK;
}

static int role_step(caekf_fmu_t *f)
{
    caekf_truth_sample_t smp;
    const int failed = caekf_truth_advance(&f->plant, &smp);
    plant_outputs(f, &smp, !failed);
    set_out(f, CAEKF_FMU_OUT_EVENTS, 0, f->val[f->vr_of[CAEKF_FMU_OUT_EVENTS][0]] + smp.events);
    set_out(f, CAEKF_FMU_OUT_STEPS, 0, f->val[f->vr_of[CAEKF_FMU_OUT_STEPS][0]] + smp.steps);
    if (failed) {
        flog(f, CAEKF_FMU_ERROR, "the integration failed at t = %.17g (step size underflow or step budget)", smp.t);
        return CAEKF_FMU_ERROR;
    }
    return CAEKF_FMU_OK;
}

#else /* the estimator */

static void estimator_outputs(caekf_fmu_t *f)
{
    caekf_scalar_t x[CAEKF_N], var[CAEKF_N], pn = 0;
    const caekf_model_t *m = &f->est.model;
    const int nq = m->nq, nc = m->nc, n = m->n;
    unsigned i;
    int k;
    (void)caekf_get_state(&f->est, x);
    (void)caekf_get_variances(&f->est, var);
    (void)caekf_get_cov_norm2(&f->est, &pn);
    for (i = 0; i < CAEKF_MAX_BODIES; ++i) {
        const int on = (int)i < nq;
        set_out(f, CAEKF_FMU_OUT_Q, i, on ? (double)x[i] : 0.0);
        set_out(f, CAEKF_FMU_OUT_V, i, on ? (double)x[nq + (int)i] : 0.0);
        set_out(f, CAEKF_FMU_OUT_VAR_Q, i, on ? (double)var[i] : 0.0);
        set_out(f, CAEKF_FMU_OUT_VAR_V, i, on ? (double)var[nq + (int)i] : 0.0);
    }
    for (i = 0; i < CAEKF_MAX_CONTACTS; ++i) {
        caekf_scalar_t g = 0, cn = 0, lam = 0, gap = 0;
        const int on = (int)i < nc;
        if (on) {
            (void)caekf_get_contact_law(&f->est, (int)i, &g, &cn, &lam, &gap);
        }
        set_out(f, CAEKF_FMU_OUT_GAMMA, i, on ? (double)x[2 * nq + (int)i] : 0.0);
        set_out(f, CAEKF_FMU_OUT_N, i, (double)cn);
        set_out(f, CAEKF_FMU_OUT_LAMBDA, i, (double)lam);
        set_out(f, CAEKF_FMU_OUT_GAP, i, (double)gap);
        set_out(f, CAEKF_FMU_OUT_VAR_GAMMA, i, on ? (double)var[2 * nq + (int)i] : 0.0);
        set_out(f, CAEKF_FMU_OUT_VAR_N, i,
                on && m->law_state[i][CAEKF_LAW_N] ? (double)var[m->law_state[i][CAEKF_LAW_N]] : 0.0);
        set_out(f, CAEKF_FMU_OUT_VAR_LAMBDA, i,
                on && m->law_state[i][CAEKF_LAW_LAMBDA] ? (double)var[m->law_state[i][CAEKF_LAW_LAMBDA]] : 0.0);
        set_out(f, CAEKF_FMU_OUT_VAR_GAP, i,
                on && m->law_state[i][CAEKF_LAW_GAP] ? (double)var[m->law_state[i][CAEKF_LAW_GAP]] : 0.0);
    }
    for (i = 0; i < ROLE_MAX_INDEX; ++i) {
        set_out(f, CAEKF_FMU_OUT_VAR_MECH_MASS, i, 0.0);
        set_out(f, CAEKF_FMU_OUT_VAR_MECH_STIFFNESS, i, 0.0);
        set_out(f, CAEKF_FMU_OUT_VAR_MECH_DAMPER, i, 0.0);
    }
    for (k = 0; k < m->nm; ++k) { /* the estimated mechanism parameters: the last nm states */
        static const int role[3] = {CAEKF_FMU_OUT_VAR_MECH_MASS, CAEKF_FMU_OUT_VAR_MECH_STIFFNESS,
                                    CAEKF_FMU_OUT_VAR_MECH_DAMPER};
        if (m->mech_kind[k] < 3) {
            set_out(f, role[m->mech_kind[k]], m->mech_elem[k], (double)var[n - m->nm + k]);
        }
    }
    set_out(f, CAEKF_FMU_OUT_NIS, 0, (double)f->rep.nis);
    set_out(f, CAEKF_FMU_OUT_P_NORM, 0, (double)pn);
    set_out(f, CAEKF_FMU_OUT_DELTA, 0, (double)f->rep.delta);
    set_out(f, CAEKF_FMU_OUT_T_SAMPLE, 0, f->t_sample);
    set_out(f, CAEKF_FMU_OUT_FLAGS, 0, (double)f->rep.flags);
    set_out(f, CAEKF_FMU_OUT_NEWTON, 0, (double)f->rep.newton_iters);
    set_out(f, CAEKF_FMU_OUT_STATUS, 0, (double)f->status);
    for (i = 0; i < CAEKF_FLAG_COUNT; ++i) {
        set_out(f, CAEKF_FMU_OUT_FLAG, i, (double)((f->rep.flags >> i) & 1u));
    }
}

static int role_init(caekf_fmu_t *f)
{
    char err[256];
    /* the schema's defaults, the given parameters, validated: what caekf-replay does with a scenario file */
    if (caekf_scenario_settings(&f->sc, NULL, &f->s, f->name, err, sizeof err) != 0) {
        return fail(f, "settings refused: %s", err);
    }
    if (caekf_init(&f->est, &f->s) != CAEKF_OK) {
        return fail(f, "%s: estimator initialisation failed", f->name);
    }
    memset(&f->rep, 0, sizeof f->rep);
    memset(f->u_hold, 0, sizeof f->u_hold);
    f->status = CAEKF_OK;
    f->t_sample = f->t0;
    estimator_outputs(f);
    return CAEKF_FMU_OK;
}

/* The sample at communication point f->t: a step (a correction alone at the start time), or a time update
 * when a sensor in use has no valid sample. */
static int role_step(caekf_fmu_t *f)
{
    caekf_scalar_t u[CAEKF_MAX_INPUTS + 1], y[CAEKF_MAX_SENSORS];
    const int ni = f->s.model.inputs, ns = f->s.model.sensors;
    int i, all = 1;
    memset(u, 0, sizeof u);
    memset(y, 0, sizeof y);
    for (i = 0; i < ni; ++i) {
        if (f->val[f->vr_of[CAEKF_FMU_IN_U_VALID][i]] != 0) {
            f->u_hold[i] = (caekf_scalar_t)f->val[f->vr_of[CAEKF_FMU_IN_U][i]];
        }
        u[i] = f->u_hold[i];
    }
    for (i = 0; i < ns; ++i) {
        y[i] = (caekf_scalar_t)f->val[f->vr_of[CAEKF_FMU_IN_Y][i]];
        all &= f->val[f->vr_of[CAEKF_FMU_IN_Y_VALID][i]] != 0;
    }
    if (f->k == 0) {
        /* q0, v0 are the state at the start time: a sample there is a correction without a time update
         * (caekf-replay's first row at t = 0); without one the estimate stays the initial one. */
        if (all) {
            f->status = caekf_correct(&f->est, u, y, &f->rep);
        } else {
            memset(&f->rep, 0, sizeof f->rep);
            f->status = CAEKF_OK;
        }
    } else {
        f->status = all ? caekf_step(&f->est, u, y, &f->rep) : caekf_predict(&f->est, u, &f->rep);
    }
    f->t_sample = f->t;
    estimator_outputs(f);
    if (f->status != CAEKF_OK) {
        flog(f, CAEKF_FMU_WARNING, "step at t = %.17g: %s (flags %lu); the estimate is kept", f->t,
             caekf_status_str(f->status), (unsigned long)f->rep.flags);
        return CAEKF_FMU_WARNING;
    }
    return CAEKF_FMU_OK;
}

#endif

int caekf_fmu_exit_init(caekf_fmu_t *f)
{
    int rc;
    if (f->state != ST_INIT) {
        return fail(f, "%s: only in initialization mode", "exitInitializationMode");
    }
    if ((rc = check_parameters(f)) != CAEKF_FMU_OK || (rc = role_init(f)) != CAEKF_FMU_OK) {
        f->state = ST_ERROR;
        return rc;
    }
    f->k = 0;
    f->state = ST_STEP;
    return CAEKF_FMU_OK;
}

int caekf_fmu_do_step(caekf_fmu_t *f, double t, double h)
{
    const double dt = f->sc.dt;
    int rc;
    if (f->state != ST_STEP) {
        return fail(f, "%s: only after initialization", "doStep");
    }
    if (!(fabs(h - dt) <= 1e-9 * dt)) {
        flog(f, CAEKF_FMU_ERROR, "doStep: the communication step %.17g s must be dt = %.17g s", h, dt);
        return CAEKF_FMU_ERROR;
    }
    if (!(fabs(t - f->t) <= 1e-3 * dt)) {
        flog(f, CAEKF_FMU_ERROR, "doStep: communication point %.17g s, expected %.17g s (one step of dt each)", t,
             f->t);
        return CAEKF_FMU_ERROR;
    }
    rc = role_step(f);
    if (rc >= CAEKF_FMU_ERROR) {
        f->state = ST_ERROR;
        return rc;
    }
    f->k++;
    f->t = f->t0 + (double)f->k * dt;
    return rc;
}

int caekf_fmu_terminate(caekf_fmu_t *f)
{
    f->state = ST_TERMINATED;
    return CAEKF_FMU_OK;
}

int caekf_fmu_reset(caekf_fmu_t *f)
{
    load_parameters(f);
    f->k = 0;
    f->t = f->t0 = 0;
    f->state = ST_INSTANTIATED;
    return CAEKF_FMU_OK;
}

int caekf_fmu_get(caekf_fmu_t *f, unsigned vr, int type, double *v)
{
    const caekf_fmu_var_t *var;
    if (vr == CAEKF_FMU_TIME_VR && type == CAEKF_FMU_REAL) {
        *v = f->t;
        return CAEKF_FMU_OK;
    }
    if (vr >= CAEKF_FMU_VAR_COUNT) {
        flog(f, CAEKF_FMU_ERROR, "get: no variable with value reference %u", vr);
        return CAEKF_FMU_ERROR;
    }
    var = &caekf_fmu_vars[vr];
    if (var->type != type) {
        return fail(f, "get: %s has another type", var->name);
    }
    *v = var->role == CAEKF_FMU_PARAM ? *slot(f, var->index) : f->val[vr];
    return CAEKF_FMU_OK;
}

int caekf_fmu_set(caekf_fmu_t *f, unsigned vr, int type, double v)
{
    const caekf_fmu_var_t *var;
    if (vr >= CAEKF_FMU_VAR_COUNT) {
        flog(f, CAEKF_FMU_ERROR, "set: no variable with value reference %u", vr);
        return CAEKF_FMU_ERROR;
    }
    var = &caekf_fmu_vars[vr];
    if (var->type != type) {
        return fail(f, "set: %s has another type", var->name);
    }
    if (var->role == CAEKF_FMU_PARAM) {
        /* fixed: the mechanism's structure and every setting are fixed when initialization ends */
        if (f->state != ST_INSTANTIATED && f->state != ST_INIT) {
            return fail(f, "set: %s is a fixed parameter: set it before initialization ends", var->name);
        }
        *slot(f, var->index) = v;
        f->sc.given[var->index] = 1;
        return CAEKF_FMU_OK;
    }
    if (var->role > CAEKF_FMU_IN_Y_VALID) {
        return fail(f, "set: %s is an output", var->name);
    }
    if (f->state == ST_TERMINATED || f->state == ST_ERROR) {
        return fail(f, "set: %s after termination or an error", var->name);
    }
    f->val[vr] = v;
    return CAEKF_FMU_OK;
}
