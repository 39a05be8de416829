#include "truth.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "caekf/caekf_model.h"
#include "dop853_coefficients.h"

#define CAEKF_PI 3.141592653589793238462643383279502884
#define TRUTH_N 8
#define TRUTH_MAX_STEPS 100000000L /* whole run */
#define TRUTH_MIN_STEP 1e-14       /* [s] */
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
}

/* Fills a sample from the state and adds the measurement noise. */
static void sample_fill(const caekf_scenario_t *sc, long k, const double x[TRUTH_N], uint64_t *rng,
                        caekf_truth_sample_t *out)
{
    int i;
    out->t = (double)k * sc->dt;
    out->u = caekf_scenario_input(sc, out->t);
    for (i = 0; i < 4; ++i) {
        out->q[i] = x[i];
        out->v[i] = x[4 + i];
    }
    out->delta = x[1] - x[2] - sc->contact1_gap;
    out->y1 = out->q[0];
    out->y4 = out->q[3];
    if (sc->noise_std > 0) {
        out->y1 += sc->noise_std * gaussian(rng);
        out->y4 += sc->noise_std * gaussian(rng);
    }
}

/* ---------------------------------------------------------------- backward Euler (legacy) */

static int truth_run_backward_euler(const caekf_scenario_t *sc, int (*emit)(const caekf_truth_sample_t *, void *),
                                    void *ctx)
{
    caekf_model_params_t p;
    caekf_model_t model;
    double x[CAEKF_N] = {0}, xn[CAEKF_N];
    long steps = caekf_scenario_steps(sc);
    int sub = (int)sc->truth_substeps;
    double h = sc->dt / sub;
    uint64_t rng = (uint64_t)sc->seed;
    long k;
    int s, i;
    caekf_scenario_model(sc, h, &p);
    if (caekf_model_init(&model, &p) != 0) {
        return -1;
    }
    x[CAEKF_IG] = sc->contact1_gamma;
    for (k = 1; k <= steps; ++k) {
        caekf_truth_sample_t out = {0};
        for (s = 1; s <= sub; ++s) {
            double t = (double)(k - 1) * sc->dt + (double)s * h;
            int it = 0;
            if (caekf_model_newton(&model, x, caekf_scenario_input(sc, t), CAEKF_NEWTON_MAX_ITER, DBL_EPSILON * 256, xn,
                                   &it) != 0) {
                out.newton_failed++;
            }
            out.newton_iters += it;
            for (i = 0; i < CAEKF_N; ++i) {
                x[i] = xn[i];
            }
        }
        sample_fill(sc, k, x, &rng, &out);
        if (emit(&out, ctx) != 0) {
            return -1;
        }
    }
    return 0;
}

/* ---------------------------------------------------------------- continuous model, DOP853 + events */

typedef struct {
    const caekf_scenario_t *sc;
    double minv[4];
    double K[4][4], C[4][4];
    double atol[TRUTH_N], rtol;
    int closed; /* contact mode: 0 open (no force), 1 closed (gamma max(delta, 0)^1.5) */
} plant_t;

static void chain(double a1, double a12, double a34, double a4, double A[4][4])
{
    int i, j;
    for (i = 0; i < 4; ++i) {
        for (j = 0; j < 4; ++j) {
            A[i][j] = 0;
        }
    }
    A[0][0] = a1 + a12;
    A[0][1] = A[1][0] = -a12;
    A[1][1] = a12;
    A[2][2] = a34;
    A[2][3] = A[3][2] = -a34;
    A[3][3] = a34 + a4;
}

/* x' = f(t, x): q' = v, M v' = e1 u(t) - C v - K q + [0, -f_c, +f_c, 0]. */
static void rhs(const plant_t *p, double t, const double x[TRUTH_N], double f[TRUTH_N])
{
    double a[4];
    int i, j;
    for (i = 0; i < 4; ++i) {
        double s = 0;
        for (j = 0; j < 4; ++j) {
            s += p->K[i][j] * x[j] + p->C[i][j] * x[4 + j];
        }
        a[i] = -s;
        f[i] = x[4 + i];
    }
    a[0] += caekf_scenario_input(p->sc, t);
    if (p->closed) {
        double d = x[1] - x[2] - p->sc->contact1_gap;
        if (d > 0) {
            double fc = p->sc->contact1_gamma * d * sqrt(d);
            a[1] -= fc;
            a[2] += fc;
        }
    }
    for (i = 0; i < 4; ++i) {
        f[4 + i] = a[i] * p->minv[i];
    }
}

/* One DOP853 step of size h from (t, y) with k0 = f(t, y): y_new, f(t + h, y_new) and the error norm
 * (Hairer's blend of the 5th- and 3rd-order estimators, RMS over the components of err/scale). */
static double dop853_step(const plant_t *p, double t, const double y[TRUTH_N], const double k0[TRUTH_N], double h,
                          double ynew[TRUTH_N], double kend[TRUTH_N])
{
    double k[DOP853_STAGES + 1][TRUTH_N], ys[TRUTH_N];
    double e5 = 0, e3 = 0;
    int s, j, i;
    for (i = 0; i < TRUTH_N; ++i) {
        k[0][i] = k0[i];
    }
    for (s = 1; s < DOP853_STAGES; ++s) {
        for (i = 0; i < TRUTH_N; ++i) {
            double acc = 0;
            for (j = 0; j < s; ++j) {
                acc += dop853_a[s][j] * k[j][i];
            }
            ys[i] = y[i] + h * acc;
        }
        rhs(p, t + dop853_c[s] * h, ys, k[s]);
    }
    for (i = 0; i < TRUTH_N; ++i) {
        double acc = 0;
        for (j = 0; j < DOP853_STAGES; ++j) {
            acc += dop853_b[j] * k[j][i];
        }
        ynew[i] = y[i] + h * acc;
    }
    rhs(p, t + h, ynew, k[DOP853_STAGES]);
    for (i = 0; i < TRUTH_N; ++i) {
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
    return fabs(h) * e5 / sqrt((e5 + 0.01 * e3) * TRUTH_N);
}

/* delta signed so that > 0 means "past the event" for the current mode. */
static double event_g(const plant_t *p, const double x[TRUTH_N])
{
    double d = x[1] - x[2] - p->sc->contact1_gap;
    return p->closed ? -d : d;
}

static double event_at(const plant_t *p, double t, const double y[TRUTH_N], const double k0[TRUTH_N], double s,
                       double ys[TRUTH_N])
{
    double kend[TRUTH_N];
    (void)dop853_step(p, t, y, k0, s, ys, kend);
    return event_g(p, ys);
}

/* Returns s_hi in (0, h] such that the event function is > 0 at s_hi (a crossing lies in (0, s_hi]),
 * or 0 when the step [t, t + h] stays on this side. Besides the end point, an interior extremum of the
 * cubic Hermite interpolant of g that comes near 0 is checked by an exact step to it (grazing). */
static double event_bracket(const plant_t *p, double t, const double y[TRUTH_N], const double k0[TRUTH_N], double h,
                            const double ynew[TRUTH_N])
{
    double sgn = p->closed ? -1.0 : 1.0;
    double g0 = event_g(p, y), g1 = event_g(p, ynew);
    double d0 = sgn * (y[5] - y[6]) * h, d1 = sgn * (ynew[5] - ynew[6]) * h;
    double a, b, c, roots[2], ys[TRUTH_N];
    int n = 0, r;
    if (g1 > 0) {
        return h;
    }
    /* p(x) = a x^3 + b x^2 + c x + g0 on x in [0, 1]; p'(x) = 3a x^2 + 2b x + c */
    a = 2 * g0 + d0 - 2 * g1 + d1;
    b = -3 * g0 - 2 * d0 + 3 * g1 - d1;
    c = d0;
    if (fabs(a) > 1e-300) {
        const double disc = 4 * b * b - 12 * a * c;
        if (disc >= 0) {
            double sq = sqrt(disc);
            roots[n++] = (-2 * b + sq) / (6 * a);
            roots[n++] = (-2 * b - sq) / (6 * a);
        }
    } else if (fabs(b) > 1e-300) {
        roots[n++] = -c / (2 * b);
    }
    for (r = 0; r < n; ++r) {
        double x = roots[r], px;
        if (!(x > 0 && x < 1)) {
            continue;
        }
        px = ((a * x + b) * x + c) * x + g0;
        /* the interpolant is only an estimate: check exactly when it comes within 10 % of the ends' scale */
        if (px > -0.1 * (fabs(g0) + fabs(g1)) && event_at(p, t, y, k0, x * h, ys) > 0) {
            return x * h;
        }
    }
    return 0;
}

/* Illinois on g(s) = event function after one step of size s, g(0) <= 0 < g(s_hi). Returns the end of
 * the final bracket on the far side (g > 0) and its state in ys. */
static double event_locate(const plant_t *p, double t, const double y[TRUTH_N], const double k0[TRUTH_N],
                           double s_hi, double ys[TRUTH_N])
{
    double lo = 0, hi = s_hi, glo = event_g(p, y), ghi, tmp[TRUTH_N];
    int side = 0, it, i;
    ghi = event_at(p, t, y, k0, hi, ys);
    for (it = 0; it < TRUTH_ROOT_MAX_ITER && hi - lo > 4 * DBL_EPSILON * (fabs(t) + hi); ++it) {
        double s = (lo * ghi - hi * glo) / (ghi - glo), g;
        if (!(s > lo && s < hi)) {
            s = 0.5 * (lo + hi);
        }
        g = event_at(p, t, y, k0, s, tmp);
        if (g > 0) {
            hi = s;
            ghi = g;
            for (i = 0; i < TRUTH_N; ++i) {
                ys[i] = tmp[i];
            }
            if (side == 1) {
                glo *= 0.5;
            }
            side = 1;
        } else {
            lo = s;
            glo = g;
            if (side == -1) {
                ghi *= 0.5;
            }
            side = -1;
        }
    }
    return hi;
}

static int truth_run_dop853(const caekf_scenario_t *sc, const caekf_truth_options_t *opt,
                            int (*emit)(const caekf_truth_sample_t *, void *), void *ctx)
{
    plant_t p;
    double y[TRUTH_N] = {0}, k0[TRUTH_N], ynew[TRUTH_N], kend[TRUTH_N];
    double t = 0, h;
    long steps = caekf_scenario_steps(sc), k, total = 0;
    uint64_t rng = (uint64_t)sc->seed;
    int i;
    const double m[4] = {sc->m1, sc->m2, sc->m3, sc->m4};
    for (i = 0; i < 4; ++i) {
        if (!(m[i] > 0)) {
            return -1;
        }
        p.minv[i] = 1.0 / m[i];
        p.atol[i] = opt->atol_q;
        p.atol[4 + i] = opt->atol_v;
    }
    if (!(opt->rtol > 0) || !(opt->atol_q > 0) || !(opt->atol_v > 0)) {
        return -1;
    }
    p.sc = sc;
    p.rtol = opt->rtol;
    p.closed = 0;
    chain(sc->spring1_k, sc->spring2_k, sc->spring3_k, sc->spring4_k, p.K);
    chain(sc->spring1_c, sc->spring2_c, sc->spring3_c, sc->spring4_c, p.C);
    rhs(&p, t, y, k0);
    h = fmin(sc->dt, 1e-4);
    for (k = 1; k <= steps; ++k) {
        caekf_truth_sample_t out = {0};
        double t_next = (double)k * sc->dt;
        while (t < t_next) {
            double rem = t_next - t, hh = h, err, s_hi;
            int clipped = 0;
            if (event_g(&p, y) > 0) { /* on the far side already (a crossing below every check): switch here */
                p.closed = !p.closed;
                rhs(&p, t, y, k0);
                out.events++;
            }
            if (hh >= rem) {
                hh = rem;
                clipped = 1;
            }
            err = dop853_step(&p, t, y, k0, hh, ynew, kend);
            if (++total > TRUTH_MAX_STEPS) {
                out.failed = 1;
            } else if (!(err <= 1)) {
                h = hh * (err < HUGE_VAL ? fmax(0.2, 0.9 * pow(err, -1.0 / 8)) : 0.2);
                out.rejected++;
                if (h < TRUTH_MIN_STEP) {
                    out.failed = 1;
                } else {
                    continue;
                }
            }
            if (out.failed) {
                sample_fill(sc, k, y, &rng, &out);
                return emit(&out, ctx) != 0 ? -1 : 1;
            }
            s_hi = event_bracket(&p, t, y, k0, hh, ynew);
            if (s_hi > 0) {
                double s = event_locate(&p, t, y, k0, s_hi, ynew);
                t = (s >= rem) ? t_next : t + s;
                for (i = 0; i < TRUTH_N; ++i) {
                    y[i] = ynew[i];
                }
                p.closed = !p.closed;
                rhs(&p, t, y, k0);
                out.events++;
                out.steps++;
                continue;
            }
            {
                double fac = err > 0 ? fmin(10.0, fmax(0.2, 0.9 * pow(err, -1.0 / 8))) : 10.0;
                double hn = hh * fac;
                h = (clipped && hn < h) ? h : hn;
            }
            t = clipped ? t_next : t + hh;
            for (i = 0; i < TRUTH_N; ++i) {
                y[i] = ynew[i];
                k0[i] = kend[i];
            }
            out.steps++;
        }
        sample_fill(sc, k, y, &rng, &out);
        if (emit(&out, ctx) != 0) {
            return -1;
        }
    }
    return 0;
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
        return truth_run_backward_euler(sc, emit, ctx);
    }
    return truth_run_dop853(sc, opt, emit, ctx);
}
