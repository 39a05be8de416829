#include "truth.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "caekf/caekf_model.h"
#include "dop853_coefficients.h"

#define CAEKF_PI 3.141592653589793238462643383279502884
#define TRUTH_N CAEKF_TRUTH_N
#define TRUTH_LINE 4096
#define TRUTH_SERIES_MAX_ROWS 2000000L /* as the measurement CSVs (CAEKF_CSV_MAX_ROWS) */
#define TRUTH_MAX_STEPS 100000000L     /* whole run */
#define TRUTH_MIN_STEP 1e-14           /* [s] */
#define TRUTH_ROOT_MAX_ITER 200

/* splitmix64 (public-domain constants), uniform in (0, 1] from its top 53 bits. */
static double uniform01(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return ((double)(z >> 11) + 1.0) * (1.0 / 9007199254740992.0);
}

/* One normal deviate per call (Box-Muller, cosine branch only: simple to reproduce). */
static double gaussian(uint64_t *state)
{
    double u1 = uniform01(state);
    double u2 = uniform01(state);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * CAEKF_PI * u2);
}

void caekf_truth_options_default(caekf_truth_options_t *opt)
{
    opt->method = CAEKF_TRUTH_DOP853;
    opt->rtol = 1e-13;
    opt->atol_q = 1e-15;
    opt->atol_v = 1e-13;
    opt->series = NULL;
}

/* ---------------------------------------------------------------- input time series */

static int series_fail(char *err, unsigned err_len, const char *path, unsigned long line, const char *what, FILE *f)
{
    if (f != NULL) {
        fclose(f);
    }
    snprintf(err, err_len, "%s:%lu: %s", path, line, what);
    return 3; /* CAEKF_EXIT_INPUT */
}

/* Splits line in place at commas into at most max fields (spaces around each trimmed). Returns the
 * field count, or max + 1 when there are more. */
static int split_fields(char *line, char **field, int max)
{
    int n = 0;
    char *p = line;
    for (;;) {
        char *comma = strchr(p, ','), *e;
        if (comma != NULL) {
            *comma = '\0';
        }
        while (*p == ' ' || *p == '\t') {
            ++p;
        }
        e = p + strlen(p);
        while (e > p && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r' || e[-1] == '\n')) {
            *--e = '\0';
        }
        if (n == max) {
            return max + 1;
        }
        field[n++] = p;
        if (comma == NULL) {
            return n;
        }
        p = comma + 1;
    }
}

#define SERIES_MAX_FIELDS 64

int caekf_input_series_read(const char *path, int inputs, caekf_input_series_t *s, char *err, unsigned err_len)
{
    char line[TRUTH_LINE], *field[SERIES_MAX_FIELDS + 1], want[CAEKF_MAX_INPUTS + 1][8], msg[200];
    int col[CAEKF_MAX_INPUTS + 1], ncol, i, j;
    long cap = 0;
    unsigned long lineno = 1;
    FILE *f;
    memset(s, 0, sizeof *s);
    if (inputs < 1 || inputs > CAEKF_MAX_INPUTS) {
        snprintf(err, err_len, "%s: the scenario has %d inputs: an input series needs 1 to %d", path, inputs,
                 CAEKF_MAX_INPUTS);
        return 3;
    }
    if ((f = fopen(path, "r")) == NULL) {
        snprintf(err, err_len, "%s: cannot open: %s", path, strerror(errno));
        return 4; /* CAEKF_EXIT_IO */
    }
    if (fgets(line, sizeof line, f) == NULL) {
        return series_fail(err, err_len, path, 1, "empty input: expected a header naming t and the inputs", f);
    }
    if (strchr(line, '\n') == NULL && !feof(f)) {
        return series_fail(err, err_len, path, 1, "header line too long", f);
    }
    ncol = split_fields(line, field, SERIES_MAX_FIELDS);
    if (ncol > SERIES_MAX_FIELDS) {
        return series_fail(err, err_len, path, 1, "more than 64 columns", f);
    }
    snprintf(want[0], sizeof want[0], "t");
    for (i = 0; i < inputs; ++i) {
        snprintf(want[1 + i], sizeof want[1 + i], "u%d", i + 1);
    }
    for (i = 0; i <= inputs; ++i) {
        col[i] = -1;
        for (j = 0; j < ncol && col[i] < 0; ++j) {
            if (strcmp(field[j], want[i]) == 0) {
                col[i] = j;
            }
        }
    }
    if (inputs == 1 && col[1] < 0) { /* one input: u1 or u */
        snprintf(want[1], sizeof want[1], "u");
        for (j = 0; j < ncol && col[1] < 0; ++j) {
            if (strcmp(field[j], "u") == 0) {
                col[1] = j;
            }
        }
    }
    for (i = 0; i <= inputs; ++i) {
        if (col[i] < 0) {
            snprintf(msg, sizeof msg, "missing column '%s' (the scenario has %d input%s: t,%s)", want[i], inputs,
                     inputs == 1 ? "" : "s", inputs == 1 ? "u or t,u1" : "u1,u2");
            return series_fail(err, err_len, path, 1, msg, f);
        }
    }
    s->inputs = inputs;
    while (fgets(line, sizeof line, f) != NULL) {
        double v[CAEKF_MAX_INPUTS + 1] = {0}; /* every column is found in the header (checked above) */
        int nf;
        ++lineno;
        if (strchr(line, '\n') == NULL && !feof(f)) {
            caekf_input_series_free(s);
            return series_fail(err, err_len, path, lineno, "line too long", f);
        }
        if (line[strspn(line, " \t\r\n")] == '\0') {
            continue; /* blank lines are tolerated */
        }
        nf = split_fields(line, field, SERIES_MAX_FIELDS);
        if (nf != ncol) {
            snprintf(msg, sizeof msg, "wrong column count: %d, the header has %d", nf, ncol);
            caekf_input_series_free(s);
            return series_fail(err, err_len, path, lineno, msg, f);
        }
        for (j = 0; j < nf; ++j) {
            char *end;
            double x = strtod(field[j], &end);
            if (end == field[j] || *end != '\0' || !isfinite(x)) {
                snprintf(msg, sizeof msg, "column %d: '%.40s' is not a finite number", j + 1, field[j]);
                caekf_input_series_free(s);
                return series_fail(err, err_len, path, lineno, msg, f);
            }
            for (i = 0; i <= inputs; ++i) {
                if (col[i] == j) {
                    v[i] = x;
                }
            }
        }
        if (s->rows > 0 && !(v[0] > s->t[s->rows - 1])) {
            snprintf(msg, sizeof msg, "t = %.17g does not increase (previous row: %.17g)", v[0], s->t[s->rows - 1]);
            caekf_input_series_free(s);
            return series_fail(err, err_len, path, lineno, msg, f);
        }
        if (s->rows == TRUTH_SERIES_MAX_ROWS) {
            caekf_input_series_free(s);
            return series_fail(err, err_len, path, lineno, "more than 2000000 rows", f);
        }
        if (s->rows == cap) {
            long nc = cap == 0 ? 1024 : 2 * cap;
            double *nt = realloc(s->t, (size_t)nc * sizeof *nt), *nu;
            if (nt != NULL) {
                s->t = nt;
            }
            nu = nt == NULL ? NULL : realloc(s->u, (size_t)nc * (size_t)inputs * sizeof *nu);
            if (nu == NULL) {
                caekf_input_series_free(s);
                fclose(f);
                snprintf(err, err_len, "%s:%lu: out of memory", path, lineno);
                return 4;
            }
            s->u = nu;
            cap = nc;
        }
        s->t[s->rows] = v[0];
        for (i = 0; i < inputs; ++i) {
            s->u[s->rows * inputs + i] = v[1 + i];
        }
        s->rows++;
    }
    if (ferror(f)) {
        caekf_input_series_free(s);
        fclose(f);
        snprintf(err, err_len, "%s: read error", path);
        return 4;
    }
    if (s->rows < 2) {
        caekf_input_series_free(s);
        return series_fail(err, err_len, path, lineno, "need at least 2 data rows", f);
    }
    fclose(f);
    return 0;
}

/* The sample interval of t (t_0 <= t < t_last): lo with t[lo] <= t < t[lo + 1], by bisection. */
static long series_segment(const caekf_input_series_t *s, double t)
{
    long lo = 0, hi = s->rows - 1;
    while (hi - lo > 1) {
        const long mid = lo + (hi - lo) / 2;
        if (s->t[mid] <= t) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

void caekf_input_series_at(const caekf_input_series_t *s, double t, double *u)
{
    long lo, hi = s->rows - 1;
    int i;
    if (!(t > s->t[0]) || t >= s->t[hi]) { /* end values held (NaN t: the first) */
        const long j = t >= s->t[hi] ? hi : 0;
        for (i = 0; i < s->inputs; ++i) {
            u[i] = s->u[j * s->inputs + i];
        }
        return;
    }
    lo = series_segment(s, t);
    hi = lo + 1;
    for (i = 0; i < s->inputs; ++i) {
        const double u0 = s->u[lo * s->inputs + i], u1 = s->u[hi * s->inputs + i];
        u[i] = (u1 - u0) / (s->t[hi] - s->t[lo]) * (t - s->t[lo]) + u0; /* as np.interp */
    }
}

/* Sample j's rate: the central difference of its neighbours, one-sided at the ends. */
static double series_node_rate(const caekf_input_series_t *s, long j, int i)
{
    const long a = j > 0 ? j - 1 : 0, b = j < s->rows - 1 ? j + 1 : s->rows - 1;
    return (s->u[b * s->inputs + i] - s->u[a * s->inputs + i]) / (s->t[b] - s->t[a]);
}

void caekf_input_series_rate_at(const caekf_input_series_t *s, double t, double *du)
{
    long lo, hi = s->rows - 1;
    int i;
    if (!(t >= s->t[0]) || t > s->t[hi] || t == s->t[hi]) { /* held outside (NaN t: 0); at t_last its own */
        const int last = t == s->t[hi];
        for (i = 0; i < s->inputs; ++i) {
            du[i] = last ? series_node_rate(s, hi, i) : 0.0;
        }
        return;
    }
    lo = series_segment(s, t);
    hi = lo + 1;
    for (i = 0; i < s->inputs; ++i) {
        const double r0 = series_node_rate(s, lo, i), r1 = series_node_rate(s, hi, i);
        du[i] = (r1 - r0) / (s->t[hi] - s->t[lo]) * (t - s->t[lo]) + r0; /* as np.interp */
    }
}

void caekf_input_series_free(caekf_input_series_t *s)
{
    free(s->t);
    free(s->u);
    s->t = NULL;
    s->u = NULL;
    s->rows = 0;
}

/* ---------------------------------------------------------------- the plant */

typedef caekf_truth_plant_t plant_t;

/* A truth-only key of element i (1-based): "contact%d_gamma", "input%d_amp", ... */
static double element_value(const caekf_scenario_t *sc, const char *fmt, int i)
{
    char key[48];
    double v = 0;
    snprintf(key, sizeof key, fmt, i);
    (void)caekf_scenario_value(sc, key, &v); /* the keys exist for every element within the capacity */
    return v;
}

/* The plant of the scenario: the mechanism (K and C from caekf_model_init, in double), the true gammas,
 * the inputs and the sensors' noise. Returns 0, or -1 when the model refuses the parameters or the
 * series does not match the inputs. */
static int plant_setup(const caekf_scenario_t *sc, const caekf_input_series_t *series, plant_t *p,
                       caekf_model_params_t *mp)
{
    caekf_model_t model;
    int i, j;
    memset(p, 0, sizeof *p);
    caekf_scenario_model(sc, sc->dt, mp);
    for (i = 0; i < CAEKF_MAX_CONTACTS; ++i) { /* the plant's law is the scenario's, never estimated */
        mp->contact_estimate_n[i] = mp->contact_estimate_lambda[i] = mp->contact_estimate_gap[i] = 0;
    }
    mp->gamma_log = 0; /* the plant's state holds gamma itself */
    if (caekf_model_init(&model, mp) != 0 || (series != NULL && series->inputs != mp->inputs)) {
        return -1;
    }
    p->series = series;
    p->nq = mp->bodies;
    p->nc = mp->contacts;
    p->ni = mp->inputs;
    p->ns = mp->sensors;
    p->n = 2 * p->nq;
    for (i = 0; i < p->nq; ++i) {
        p->minv[i] = 1.0 / (double)mp->m[i];
        for (j = 0; j < p->nq; ++j) {
            p->K[i][j] = (double)model.K[i][j];
            p->C[i][j] = (double)model.C[i][j];
        }
    }
    for (i = 0; i < p->ni; ++i) {
        const int link = mp->input_link[i] - 1;
        p->input_body[i] = model.p.input_body[i] - 1; /* a base input's: its link's body (caekf_model_init) */
        p->input_base[i] = mp->input_kind[i] == CAEKF_INPUT_BASE_DISPLACEMENT;
        p->input_k[i] = p->input_base[i] ? (double)mp->spring_k[link] : 0;
        p->input_c[i] = p->input_base[i] ? (double)mp->spring_c[link] : 0;
        p->amp[i] = element_value(sc, "input%d_amp", i + 1);
        p->freq[i] = element_value(sc, "input%d_freq", i + 1);
        p->phase[i] = element_value(sc, "input%d_phase", i + 1);
    }
    for (i = 0; i < p->ns; ++i) {
        const int link = mp->sensor_link[i] - 1;
        p->sensor_body[i] = mp->sensor_body[i] - 1;
        p->sensor_kind[i] = (int)mp->sensor_kind[i];
        p->sensor_ref[i] = mp->sensor_ref[i] - 1;
        p->sensor_a[i] = link < mp->springs ? mp->spring_a[link] - 1 : -1;
        p->sensor_b[i] = link < mp->springs ? mp->spring_b[link] - 1 : -1;
        p->sensor_k[i] = link < mp->springs ? (double)mp->spring_k[link] : 0;
        p->sensor_c[i] = link < mp->springs ? (double)mp->spring_c[link] : 0;
        p->sensor_input[i] = -1;
        for (j = 0; j < p->ni && mp->sensor_kind[i] == CAEKF_SENSOR_LINK_FORCE; ++j) {
            if (p->input_base[j] && mp->input_link[j] - 1 == link) {
                p->sensor_input[i] = j;
            }
        }
        p->noise[i] = element_value(sc, "sensor%d_noise", i + 1);
        if (!(p->noise[i] > 0)) {
            p->noise[i] = mp->sensor_kind[i] == CAEKF_SENSOR_VELOCITY ? sc->noise_std_v : sc->noise_std;
        }
        p->bias[i] = element_value(sc, "sensor%d_bias", i + 1);
    }
    for (i = 0; i < p->nc; ++i) {
        p->ca[i] = mp->contact_a[i] - 1;
        p->cb[i] = mp->contact_b[i] - 1;
        p->gap[i] = (double)mp->contact_gap[i];
        p->cn[i] = (double)mp->contact_n[i];
        p->lam[i] = (double)mp->contact_lambda[i];
        p->gamma[i] = element_value(sc, "contact%d_gamma", i + 1);
    }
    return 0;
}

/* The inputs at t and, with du not NULL, their rates (a base displacement's du/dt): the sines and their
 * derivatives, or the series' (caekf_input_series_rate_at). */
static void inputs_at(const plant_t *p, double t, double *u, double *du)
{
    int i;
    if (p->series != NULL) {
        caekf_input_series_at(p->series, t, u);
        if (du != NULL) {
            caekf_input_series_rate_at(p->series, t, du);
        }
        return;
    }
    for (i = 0; i < p->ni; ++i) {
        const double w = 2.0 * CAEKF_PI * p->freq[i];
        u[i] = p->amp[i] * sin(w * t + p->phase[i]);
        if (du != NULL) {
            du[i] = p->amp[i] * w * cos(w * t + p->phase[i]);
        }
    }
}

/* Whether any input is a base displacement. */
static int any_base(const plant_t *p)
{
    int i, any = 0;
    for (i = 0; i < p->ni; ++i) {
        any |= p->input_base[i];
    }
    return any;
}

/* Component i of x (q or v by offset), 0 for the ground (i = -1). */
static double side(const double *x, int i) { return i >= 0 ? x[i] : 0.0; }

static double delta_of(const plant_t *p, int c, const double *x)
{
    return side(x, p->ca[c]) - side(x, p->cb[c]) - p->gap[c];
}

static double rate_of(const plant_t *p, int c, const double *x)
{
    return side(x + p->nq, p->ca[c]) - side(x + p->nq, p->cb[c]);
}

static void rhs(const plant_t *p, double t, const double *x, double *f);

/* What sensor i reads at the state x at time t, noise-free and without its offset (docs/sensors.md). */
static double sensor_value(const plant_t *p, int i, double t, const double *x)
{
    const int b = p->sensor_body[i], nq = p->nq;
    double f[CAEKF_TRUTH_N];
    switch (p->sensor_kind[i]) {
    case CAEKF_SENSOR_VELOCITY: return x[nq + b];
    case CAEKF_SENSOR_ACCELERATION: rhs(p, t, x, f); return f[nq + b];
    case CAEKF_SENSOR_RELATIVE: return x[b] - side(x, p->sensor_ref[i]);
    case CAEKF_SENSOR_LINK_FORCE: {
        /* a ground end a base input moves: at u, moving at du/dt */
        double u[CAEKF_MAX_INPUTS + 1] = {0}, du[CAEKF_MAX_INPUTS + 1] = {0}, gq = 0, gv = 0;
        const int a = p->sensor_a[i], bb = p->sensor_b[i];
        if (p->sensor_input[i] >= 0) {
            inputs_at(p, t, u, du);
            gq = u[p->sensor_input[i]];
            gv = du[p->sensor_input[i]];
        }
        return p->sensor_k[i] * ((a >= 0 ? x[a] : gq) - (bb >= 0 ? x[bb] : gq)) +
               p->sensor_c[i] * ((a >= 0 ? x[nq + a] : gv) - (bb >= 0 ? x[nq + bb] : gv));
    }
    default: return x[b];
    }
}

/* Fills a sample from the state and adds the measurement noise. */
static void sample_fill(const plant_t *p, const caekf_scenario_t *sc, long k, const double *x, uint64_t *rng,
                        caekf_truth_sample_t *out)
{
    int i;
    out->t = (double)k * sc->dt;
    out->inputs = p->ni;
    out->sensors = p->ns;
    out->bodies = p->nq;
    out->contacts = p->nc;
    inputs_at(p, out->t, out->u, NULL);
    for (i = 0; i < p->nq; ++i) {
        out->q[i] = x[i];
        out->v[i] = x[p->nq + i];
    }
    for (i = 0; i < p->nc; ++i) {
        out->delta[i] = delta_of(p, i, x);
    }
    for (i = 0; i < p->ns; ++i) {
        out->y[i] = sensor_value(p, i, out->t, x) + p->bias[i];
    }
    for (i = 0; i < p->ns; ++i) {
        if (p->noise[i] > 0) {
            out->y[i] += p->noise[i] * gaussian(rng);
        }
    }
}

/* ---------------------------------------------------------------- backward Euler (legacy) */

static int truth_run_backward_euler(const caekf_scenario_t *sc, const caekf_truth_options_t *opt,
                                    int (*emit)(const caekf_truth_sample_t *, void *), void *ctx)
{
    caekf_model_params_t mp;
    caekf_model_t model;
    plant_t pl;
    double x[CAEKF_N] = {0}, xn[CAEKF_N], u[CAEKF_MAX_INPUTS + 1] = {0}, u0[CAEKF_MAX_INPUTS + 1] = {0},
           work[4 * CAEKF_NQ];
    long steps = caekf_scenario_steps(sc);
    int sub = (int)sc->truth_substeps;
    double h = sc->dt / sub;
    uint64_t rng = (uint64_t)sc->seed;
    long k;
    int s, i;
    if (plant_setup(sc, opt->series, &pl, &mp) != 0) {
        return -1;
    }
    mp.dt = h;
    mp.discretisation = CAEKF_DISCRETISATION_BACKWARD_EULER; /* the legacy truth, whatever the filter uses */
    if (caekf_model_init(&model, &mp) != 0) {
        return -1;
    }
    for (i = 0; i < pl.nc; ++i) {
        x[2 * model.nq + i] = pl.gamma[i];
    }
    inputs_at(&pl, 0.0, u0, NULL); /* the inputs at the substep's start: a base displacement's rate */
    for (k = 1; k <= steps; ++k) {
        caekf_truth_sample_t out;
        memset(&out, 0, sizeof out);
        for (s = 1; s <= sub; ++s) {
            double t = (double)(k - 1) * sc->dt + (double)s * h;
            int it = 0;
            inputs_at(&pl, t, u, NULL);
            if (caekf_model_newton(&model, x, u0, u, CAEKF_NEWTON_MAX_ITER, DBL_EPSILON * 256, xn, &it, work) != 0) {
                out.newton_failed++;
            }
            out.newton_iters += it;
            for (i = 0; i < model.n; ++i) {
                x[i] = xn[i];
            }
            for (i = 0; i < pl.ni; ++i) {
                u0[i] = u[i];
            }
        }
        sample_fill(&pl, sc, k, x, &rng, &out);
        if (emit(&out, ctx) != 0) {
            return -1;
        }
    }
    return 0;
}

/* ---------------------------------------------------------------- continuous model, DOP853 + events */

/* Contact c's force at x (0 when open or delta <= 0): gamma delta^n (1 + lambda ddelta/dt), >= 0. */
static double contact_force(const plant_t *p, int c, const double *x)
{
    const double d = delta_of(p, c, x);
    double fc;
    if (!p->closed[c] || !(d > 0)) {
        return 0;
    }
    if (p->cn[c] == 1.5) {
        fc = p->gamma[c] * d * sqrt(d);
    } else if (p->cn[c] == 1.0) {
        fc = p->gamma[c] * d;
    } else {
        fc = p->gamma[c] * pow(d, p->cn[c]);
    }
    if (p->lam[c] != 0) {
        const double hc = 1 + p->lam[c] * rate_of(p, c, x);
        fc = hc > 0 ? fc * hc : 0;
    }
    return fc;
}

/* x' = f(t, x): q' = v, M v' = B u(t) - C v - K q - sum_c b_c f_c (-f_c on body a, +f_c on body b). */
static void rhs(const plant_t *p, double t, const double *x, double *f)
{
    double a[CAEKF_MAX_BODIES], u[CAEKF_MAX_INPUTS + 1];
    const int nq = p->nq;
    int i, j, c;
    for (i = 0; i < nq; ++i) {
        double s = 0;
        for (j = 0; j < nq; ++j) {
            s += p->K[i][j] * x[j] + p->C[i][j] * x[nq + j];
        }
        a[i] = -s;
        f[i] = x[nq + i];
    }
    if (any_base(p)) { /* a base displacement: k u + c du/dt on its body (K and C hold -k q, -c v) */
        double du[CAEKF_MAX_INPUTS + 1];
        inputs_at(p, t, u, du);
        for (i = 0; i < p->ni; ++i) {
            a[p->input_body[i]] += p->input_base[i] ? p->input_k[i] * u[i] + p->input_c[i] * du[i] : u[i];
        }
    } else {
        inputs_at(p, t, u, NULL);
        for (i = 0; i < p->ni; ++i) {
            a[p->input_body[i]] += u[i];
        }
    }
    for (c = 0; c < p->nc; ++c) {
        const double fc = contact_force(p, c, x);
        if (fc != 0) {
            if (p->ca[c] >= 0) {
                a[p->ca[c]] -= fc;
            }
            if (p->cb[c] >= 0) {
                a[p->cb[c]] += fc;
            }
        }
    }
    for (i = 0; i < nq; ++i) {
        f[nq + i] = a[i] * p->minv[i];
    }
}

/* One DOP853 step of size h from (t, y) with k0 = f(t, y): y_new, f(t + h, y_new) and the error norm
 * (Hairer's blend of the 5th- and 3rd-order estimators, RMS over the components of err/scale). */
static double dop853_step(const plant_t *p, double t, const double *y, const double *k0, double h, double *ynew,
                          double *kend)
{
    double k[DOP853_STAGES + 1][TRUTH_N], ys[TRUTH_N];
    double e5 = 0, e3 = 0;
    const int n = p->n;
    int s, j, i;
    for (i = 0; i < n; ++i) {
        k[0][i] = k0[i];
    }
    for (s = 1; s < DOP853_STAGES; ++s) {
        for (i = 0; i < n; ++i) {
            double acc = 0;
            for (j = 0; j < s; ++j) {
                acc += dop853_a[s][j] * k[j][i];
            }
            ys[i] = y[i] + h * acc;
        }
        rhs(p, t + dop853_c[s] * h, ys, k[s]);
    }
    for (i = 0; i < n; ++i) {
        double acc = 0;
        for (j = 0; j < DOP853_STAGES; ++j) {
            acc += dop853_b[j] * k[j][i];
        }
        ynew[i] = y[i] + h * acc;
    }
    rhs(p, t + h, ynew, k[DOP853_STAGES]);
    for (i = 0; i < n; ++i) {
        double a5 = 0, a3 = 0, sc;
        kend[i] = k[DOP853_STAGES][i];
        for (j = 0; j <= DOP853_STAGES; ++j) {
            a5 += dop853_e5[j] * k[j][i];
            a3 += dop853_e3[j] * k[j][i];
        }
        sc = p->atol[i] + p->rtol * fmax(fabs(y[i]), fabs(ynew[i]));
        e5 += (a5 / sc) * (a5 / sc);
        e3 += (a3 / sc) * (a3 / sc);
    }
    if (e5 == 0 && e3 == 0) {
        return 0;
    }
    return fabs(h) * e5 / sqrt((e5 + 0.01 * e3) * n);
}

/* Contact c's delta signed so that > 0 means "past the event" for its current mode. */
static double event_g(const plant_t *p, int c, const double *x)
{
    double d = delta_of(p, c, x);
    return p->closed[c] ? -d : d;
}

static double event_at(const plant_t *p, int c, double t, const double *y, const double *k0, double s, double *ys)
{
    double kend[TRUTH_N];
    (void)dop853_step(p, t, y, k0, s, ys, kend);
    return event_g(p, c, ys);
}

/* Returns s_hi in (0, h] such that contact c's event function is > 0 at s_hi (a crossing lies in
 * (0, s_hi]), or 0 when the step [t, t + h] stays on this side. Besides the end point, an interior
 * extremum of the cubic Hermite interpolant of g that comes near 0 is checked by an exact step to it
 * (grazing). */
static double event_bracket(const plant_t *p, int c, double t, const double *y, const double *k0, double h,
                            const double *ynew)
{
    double sgn = p->closed[c] ? -1.0 : 1.0;
    double g0 = event_g(p, c, y), g1 = event_g(p, c, ynew);
    double d0 = sgn * rate_of(p, c, y) * h, d1 = sgn * rate_of(p, c, ynew) * h;
    double a, b, cc, roots[2], ys[TRUTH_N];
    int n = 0, r;
    if (g1 > 0) {
        return h;
    }
    /* p(x) = a x^3 + b x^2 + cc x + g0 on x in [0, 1]; p'(x) = 3a x^2 + 2b x + cc */
    a = 2 * g0 + d0 - 2 * g1 + d1;
    b = -3 * g0 - 2 * d0 + 3 * g1 - d1;
    cc = d0;
    if (fabs(a) > 1e-300) {
        const double disc = 4 * b * b - 12 * a * cc;
        if (disc >= 0) {
            double sq = sqrt(disc);
            roots[n++] = (-2 * b + sq) / (6 * a);
            roots[n++] = (-2 * b - sq) / (6 * a);
        }
    } else if (fabs(b) > 1e-300) {
        roots[n++] = -cc / (2 * b);
    }
    for (r = 0; r < n; ++r) {
        double x = roots[r], px;
        if (!(x > 0 && x < 1)) {
            continue;
        }
        px = ((a * x + b) * x + cc) * x + g0;
        /* the interpolant is only an estimate: check exactly when it comes within 10 % of the ends' scale */
        if (px > -0.1 * (fabs(g0) + fabs(g1)) && event_at(p, c, t, y, k0, x * h, ys) > 0) {
            return x * h;
        }
    }
    return 0;
}

/* Illinois on g(s) = contact c's event function after one step of size s, g(0) <= 0 < g(s_hi). Returns
 * the end of the final bracket on the far side (g > 0) and its state in ys. */
static double event_locate(const plant_t *p, int c, double t, const double *y, const double *k0, double s_hi,
                           double *ys)
{
    double lo = 0, hi = s_hi, glo = event_g(p, c, y), ghi, tmp[TRUTH_N];
    int side_ = 0, it, i;
    ghi = event_at(p, c, t, y, k0, hi, ys);
    for (it = 0; it < TRUTH_ROOT_MAX_ITER && hi - lo > 4 * DBL_EPSILON * (fabs(t) + hi); ++it) {
        double s = (lo * ghi - hi * glo) / (ghi - glo), g;
        if (!(s > lo && s < hi)) {
            s = 0.5 * (lo + hi);
        }
        g = event_at(p, c, t, y, k0, s, tmp);
        if (g > 0) {
            hi = s;
            ghi = g;
            for (i = 0; i < p->n; ++i) {
                ys[i] = tmp[i];
            }
            if (side_ == 1) {
                glo *= 0.5;
            }
            side_ = 1;
        } else {
            lo = s;
            glo = g;
            if (side_ == -1) {
                ghi *= 0.5;
            }
            side_ = -1;
        }
    }
    return hi;
}

/* The earliest contact event in the accepted step [t, t + hh] (ending at ynew): its contact (or -1),
 * the step to it in *s and the state there in ys. */
static int event_first(const plant_t *p, double t, const double *y, const double *k0, double hh, const double *ynew,
                       double *s, double *ys)
{
    double s_hi[CAEKF_MAX_CONTACTS], tmp[TRUTH_N];
    int c, first = -1, i;
    for (c = 0; c < p->nc; ++c) { /* every bracket from the full step first: locating reuses no buffer */
        s_hi[c] = event_bracket(p, c, t, y, k0, hh, ynew);
    }
    for (c = 0; c < p->nc; ++c) { /* s_hi only bounds the crossing: each bracketed contact is located */
        if (s_hi[c] > 0) {
            const double sc = event_locate(p, c, t, y, k0, s_hi[c], tmp);
            if (first < 0 || sc < *s) {
                first = c;
                *s = sc;
                for (i = 0; i < p->n; ++i) {
                    ys[i] = tmp[i];
                }
            }
        }
    }
    return first;
}

int caekf_truth_start(caekf_truth_stepper_t *st, const caekf_scenario_t *sc, const caekf_truth_options_t *opt)
{
    caekf_model_params_t mp;
    caekf_truth_options_t def;
    int i;
    if (opt == NULL) {
        caekf_truth_options_default(&def);
        opt = &def;
    }
    memset(st, 0, sizeof *st);
    if (!(opt->rtol > 0) || !(opt->atol_q > 0) || !(opt->atol_v > 0) ||
        plant_setup(sc, opt->series, &st->p, &mp) != 0) {
        return -1;
    }
    for (i = 0; i < st->p.nq; ++i) {
        st->p.atol[i] = opt->atol_q;
        st->p.atol[st->p.nq + i] = opt->atol_v;
    }
    st->p.rtol = opt->rtol;
    st->sc = sc;
    st->rng = (uint64_t)sc->seed;
    st->t = 0;
    rhs(&st->p, st->t, st->y, st->k0);
    st->h = fmin(sc->dt, 1e-4);
    return 0;
}

int caekf_truth_advance(caekf_truth_stepper_t *st, caekf_truth_sample_t *out)
{
    plant_t *p = &st->p;
    double ynew[TRUTH_N], kend[TRUTH_N], yev[TRUTH_N];
    const long k = st->k + 1;
    const double t_next = (double)k * st->sc->dt;
    int i, c;
    memset(out, 0, sizeof *out);
    if (st->failed) {
        return 1;
    }
    while (st->t < t_next) {
        double rem = t_next - st->t, hh = st->h, err, s;
        int clipped = 0, switched = 0;
        for (c = 0; c < p->nc; ++c) { /* on the far side already (a crossing below every check): switch here */
            if (event_g(p, c, st->y) > 0) {
                p->closed[c] = !p->closed[c];
                switched = 1;
                out->events++;
            }
        }
        if (switched) {
            rhs(p, st->t, st->y, st->k0);
        }
        if (hh >= rem) {
            hh = rem;
            clipped = 1;
        }
        err = dop853_step(p, st->t, st->y, st->k0, hh, ynew, kend);
        if (++st->total > TRUTH_MAX_STEPS) {
            out->failed = 1;
        } else if (!(err <= 1)) {
            st->h = hh * (err < HUGE_VAL ? fmax(0.2, 0.9 * pow(err, -1.0 / 8)) : 0.2);
            out->rejected++;
            if (st->h < TRUTH_MIN_STEP) {
                out->failed = 1;
            } else {
                continue;
            }
        }
        if (out->failed) {
            st->failed = 1;
            st->k = k;
            sample_fill(p, st->sc, k, st->y, &st->rng, out);
            return 1;
        }
        c = event_first(p, st->t, st->y, st->k0, hh, ynew, &s, yev);
        if (c >= 0) {
            st->t = (s >= rem) ? t_next : st->t + s;
            for (i = 0; i < p->n; ++i) {
                st->y[i] = yev[i];
            }
            p->closed[c] = !p->closed[c];
            rhs(p, st->t, st->y, st->k0);
            out->events++;
            out->steps++;
            continue;
        }
        {
            double fac = err > 0 ? fmin(10.0, fmax(0.2, 0.9 * pow(err, -1.0 / 8))) : 10.0;
            double hn = hh * fac;
            st->h = (clipped && hn < st->h) ? st->h : hn;
        }
        st->t = clipped ? t_next : st->t + hh;
        for (i = 0; i < p->n; ++i) {
            st->y[i] = ynew[i];
            st->k0[i] = kend[i];
        }
        out->steps++;
    }
    st->k = k;
    sample_fill(p, st->sc, k, st->y, &st->rng, out);
    return 0;
}

/* The whole run: one caekf_truth_advance per sample (the FMU of the plant steps the same way). */
static int truth_run_dop853(const caekf_scenario_t *sc, const caekf_truth_options_t *opt,
                            int (*emit)(const caekf_truth_sample_t *, void *), void *ctx)
{
    caekf_truth_stepper_t *st = malloc(sizeof *st);
    long steps = caekf_scenario_steps(sc), k;
    int rc = 0;
    if (st == NULL || caekf_truth_start(st, sc, opt) != 0) {
        free(st);
        return -1;
    }
    for (k = 1; k <= steps && rc == 0; ++k) {
        caekf_truth_sample_t out;
        const int failed = caekf_truth_advance(st, &out);
        if (emit(&out, ctx) != 0) {
            rc = -1;
        } else if (failed) {
            rc = 1;
        }
    }
    free(st);
    return rc;
}

int caekf_truth_run(const caekf_scenario_t *sc, const caekf_truth_options_t *opt,
                    int (*emit)(const caekf_truth_sample_t *, void *), void *ctx)
{
    caekf_truth_options_t def;
    if (opt == NULL) {
        caekf_truth_options_default(&def);
        opt = &def;
    }
    if (opt->method == CAEKF_TRUTH_BACKWARD_EULER) {
        return truth_run_backward_euler(sc, opt, emit, ctx);
    }
    return truth_run_dop853(sc, opt, emit, ctx);
}
