/*
 * Soak: the reference scenario looped to millions of steps with the switched-highq-constrained
 * preset (consistent switch-off), checking the estimator after every step.
 *
 *   caekf-soak [--steps N] [--quiet]        (default 10^7 steps; --quiet: no per-lap lines)
 *
 * The truth (paper_truth.bin, 60 s at 1 kHz) restarts from t = 0 at the end of each 60 s lap while the
 * estimator keeps running: the state jump at the seam (the truth returns to rest, v ~ 4e-4 m/s, q ~ 1e-6 m
 * at t = 60 s) is a realistic disturbance, like a bench restarting without a CTRL_RESET.
 *
 * Checked every step (all in double, from the public accessors):
 *   - the step returns CAEKF_OK;
 *   - P finite and symmetric: max |P_ij - P_ji| / sqrt(P_ii P_jj) within 8 eps of the scalar type;
 *   - P positive semidefinite: LDL^T of the correlation form D^-1/2 P D^-1/2 with pivots >= -1024 eps
 *     (the library's own tolerance), zero-variance rows must have zero covariances;
 *   - gamma >= gamma_min;
 * and per lap: Newton iterations (mean, max), flags raised. Newton must not grow: the last complete lap's
 * mean may exceed the first lap's by at most 5 % + 0.05 and its max by at most 1.
 * Exit status 0 when every check held, 1 otherwise, 2 when the truth cannot be read.
 */
#define _POSIX_C_SOURCE 200809L
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "caekf/caekf.h"
#include "test_support.h"

#define N CAEKF_N
#define LAP_MAX 200000L

typedef struct {
    double u, y1, y4;
} sample_t;

typedef struct {
    long steps;
    double newton_sum;
    int newton_max;
    long newton_not_converged;
    long repairs, indefinite, constraint_applied, contact, gated;
    long psd_fail, asym_fail, nonfinite, status_fail, gamma_fail;
    double min_gamma, max_asym, min_pivot;
} stats_t;

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void stats_reset(stats_t *s)
{
    memset(s, 0, sizeof *s);
    s->min_gamma = HUGE_VAL;
    s->min_pivot = HUGE_VAL;
}

static void stats_merge(stats_t *into, const stats_t *s)
{
    into->steps += s->steps;
    into->newton_sum += s->newton_sum;
    if (s->newton_max > into->newton_max) {
        into->newton_max = s->newton_max;
    }
    into->newton_not_converged += s->newton_not_converged;
    into->repairs += s->repairs;
    into->indefinite += s->indefinite;
    into->constraint_applied += s->constraint_applied;
    into->gated += s->gated;
    into->contact += s->contact;
    into->psd_fail += s->psd_fail;
    into->asym_fail += s->asym_fail;
    into->nonfinite += s->nonfinite;
    into->status_fail += s->status_fail;
    into->gamma_fail += s->gamma_fail;
    into->min_gamma = fmin(into->min_gamma, s->min_gamma);
    into->max_asym = fmax(into->max_asym, s->max_asym);
    into->min_pivot = fmin(into->min_pivot, s->min_pivot);
}

/* LDL^T of the correlation form of a symmetric P, in double. Returns the smallest pivot (1 for an
 * all-zero P), or -HUGE_VAL when a zero-variance or zero-pivot direction still has coupling. */
static double psd_min_pivot(const double P[N][N], double tol)
{
    double C[N][N], d[N];
    int idx[N];
    int n = 0, i, j, k;
    double min_piv = 1.0;
    for (i = 0; i < N; ++i) {
        if (P[i][i] > 0.0) {
            idx[n++] = i;
        } else {
            if (P[i][i] < 0.0) {
                return P[i][i];
            }
            for (j = 0; j < N; ++j) { /* zero variance: the row must be zero */
                if (P[i][j] != 0.0) {
                    return -HUGE_VAL;
                }
            }
        }
    }
    for (i = 0; i < n; ++i) {
        d[i] = sqrt(P[idx[i]][idx[i]]);
    }
    for (i = 0; i < n; ++i) {
        for (j = 0; j < n; ++j) {
            C[i][j] = P[idx[i]][idx[j]] / (d[i] * d[j]);
        }
    }
    for (k = 0; k < n; ++k) { /* in place: C's lower part becomes L, its diagonal D */
        double piv = C[k][k];
        for (j = 0; j < k; ++j) {
            piv -= C[k][j] * C[k][j] * C[j][j];
        }
        C[k][k] = piv;
        if (piv < min_piv) {
            min_piv = piv;
        }
        for (i = k + 1; i < n; ++i) {
            double s = C[i][k];
            for (j = 0; j < k; ++j) {
                s -= C[i][j] * C[k][j] * C[j][j];
            }
            if (piv > tol) {
                C[i][k] = s / piv;
            } else {
                if (fabs(s) > sqrt(tol)) { /* a (numerically) zero pivot with coupling left */
                    return -HUGE_VAL;
                }
                C[i][k] = 0.0;
            }
        }
    }
    return min_piv;
}

static void check_step(caekf_t *est, stats_t *st, const caekf_report_t *rep, caekf_status_t status, double gamma_min)
{
    static caekf_scalar_t Ps[N][N];
    double P[N][N];
    caekf_scalar_t g;
    double asym = 0.0, piv;
    int i, j, finite = 1;
    const double eps = (double)CAEKF_EPS;

    st->steps++;
    if (status != CAEKF_OK) {
        st->status_fail++;
    }
    st->newton_sum += rep->newton_iters;
    if (rep->newton_iters > st->newton_max) {
        st->newton_max = rep->newton_iters;
    }
    st->newton_not_converged += (rep->flags & CAEKF_FLAG_NEWTON_NOT_CONVERGED) != 0u;
    st->repairs += (rep->flags & CAEKF_FLAG_COV_REPAIRED) != 0u;
    st->indefinite += (rep->flags & CAEKF_FLAG_COV_INDEFINITE) != 0u;
    st->constraint_applied += (rep->flags & CAEKF_FLAG_CONSTRAINT_APPLIED) != 0u;
    st->contact += (rep->flags & CAEKF_FLAG_CONTACT_ACTIVE) != 0u;
    st->gated += (rep->flags & CAEKF_FLAG_GAMMA_GATED) != 0u;

    (void)caekf_get_covariance(est, Ps);
    for (i = 0; i < N; ++i) {
        for (j = 0; j < N; ++j) {
            P[i][j] = (double)Ps[i][j];
            finite &= isfinite(P[i][j]) != 0;
        }
    }
    if (!finite) {
        st->nonfinite++;
        return;
    }
    for (i = 0; i < N; ++i) {
        for (j = 0; j < i; ++j) {
            const double scale = sqrt(fabs(P[i][i] * P[j][j]));
            const double a = fabs(P[i][j] - P[j][i]);
            const double rel = (scale > 0.0) ? a / scale : (a > 0.0 ? HUGE_VAL : 0.0);
            if (rel > asym) {
                asym = rel;
            }
        }
    }
    st->max_asym = fmax(st->max_asym, asym);
    if (asym > 8.0 * eps) {
        st->asym_fail++;
    }
    for (i = 0; i < N; ++i) { /* the test below reads the upper triangle as the symmetric P */
        for (j = 0; j < i; ++j) {
            P[i][j] = P[j][i];
        }
    }
    piv = psd_min_pivot((const double(*)[N])P, 1024.0 * eps);
    st->min_pivot = fmin(st->min_pivot, piv);
    if (piv < -1024.0 * eps) {
        st->psd_fail++;
    }
    (void)caekf_get_gamma(est, &g);
    st->min_gamma = fmin(st->min_gamma, (double)g);
    if (!((double)g >= gamma_min)) {
        st->gamma_fail++;
    }
}

static long failures(const stats_t *s)
{
    return s->psd_fail + s->asym_fail + s->nonfinite + s->status_fail + s->gamma_fail;
}

int main(int argc, char **argv)
{
    static sample_t truth[LAP_MAX];
    static caekf_t est;
    caekf_settings_t s;
    truth_rec_t rec;
    long n_truth = 0, steps = 10000000L, k;
    int quiet = 0, rc, i, newton_ok;
    stats_t lap, first, last, total;
    long lap_index = 0, laps_full = 0;
    double t0, t_lap, t_step = 0.0, wall;
    const double gamma_min = paper_gamma_min();

    for (i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--steps") == 0 && i + 1 < argc) {
            steps = strtol(argv[++i], NULL, 10);
        } else if (strcmp(argv[i], "--quiet") == 0) {
            quiet = 1;
        } else {
            fprintf(stderr, "usage: %s [--steps N] [--quiet]\n", argv[0]);
            return 2;
        }
    }
    if (truth_open() != 0) {
        fprintf(stderr, "soak: cannot open the truth record (build the preset first)\n");
        return 2;
    }
    while (n_truth < LAP_MAX && (rc = truth_next(&rec)) == 1) {
        truth[n_truth].u = rec.u;
        truth[n_truth].y1 = rec.y1;
        truth[n_truth].y4 = rec.y4;
        n_truth++;
    }
    truth_close();
    if (n_truth == 0) {
        fprintf(stderr, "soak: empty truth record\n");
        return 2;
    }

    paper_settings(&s, EXP_SWITCHED_HIGHQ_CONSTRAINED);
    s.switchoff = CAEKF_SWITCHOFF_CONSISTENT;
    if (caekf_init(&est, &s) != CAEKF_OK) {
        fprintf(stderr, "soak: paper settings refused\n");
        return 2;
    }
    printf("soak: %s, switched-highq-constrained (consistent), %ld steps, truth lap %ld steps (%.0f s), "
           "restarting at the seam with the estimator running\n",
           CAEKF_SCALAR_NAME, steps, n_truth, (double)n_truth * 1e-3);
    if (!quiet) {
        printf("%5s %8s %12s %12s %10s %9s %5s %7s %6s %6s %7s %6s\n", "lap", "steps", "gamma_end", "gamma_min",
               "max_asym", "min_piv", "psd!", "repair", "constr", "nw_avg", "nw_max", "nw!cv");
    }
    stats_reset(&lap);
    stats_reset(&first);
    stats_reset(&last);
    stats_reset(&total);
    t0 = now_s();
    t_lap = t0;
    for (k = 0; k < steps; ++k) {
        const sample_t *x = &truth[k % n_truth];
        caekf_scalar_t y[CAEKF_MAX_SENSORS];
        caekf_report_t rep;
        caekf_status_t st;
        double a, b;
        y[0] = (caekf_scalar_t)x->y1;
        y[1] = (caekf_scalar_t)x->y4;
        a = now_s();
        st = caekf_step(&est, (const caekf_scalar_t[]){(caekf_scalar_t)x->u}, y, &rep);
        b = now_s();
        t_step += b - a;
        check_step(&est, &lap, &rep, st, gamma_min);
        if ((k + 1) % n_truth == 0 || k + 1 == steps) {
            const int full = lap.steps == n_truth;
            caekf_scalar_t g;
            (void)caekf_get_gamma(&est, &g);
            if (!quiet) {
                printf("%5ld %8ld %12.6g %12.6g %10.3g %9.2g %5ld %7ld %6ld %6.3f %7d %6ld%s\n", lap_index + 1,
                       lap.steps, (double)g, lap.min_gamma, lap.max_asym, lap.min_pivot, lap.psd_fail, lap.repairs,
                       lap.constraint_applied, lap.newton_sum / (double)lap.steps, lap.newton_max,
                       lap.newton_not_converged, full ? "" : " (partial)");
                fflush(stdout);
            }
            if (lap_index == 0) {
                first = lap;
            }
            if (full) {
                last = lap;
                laps_full++;
            }
            stats_merge(&total, &lap);
            stats_reset(&lap);
            lap_index++;
            t_lap = now_s();
        }
    }
    (void)t_lap;
    wall = now_s() - t0;
    newton_ok = laps_full < 2 ||
                (last.newton_sum / (double)last.steps <= 1.05 * first.newton_sum / (double)first.steps + 0.05 &&
                 last.newton_max <= first.newton_max + 1);

    printf("\nsoak summary (%s)\n", CAEKF_SCALAR_NAME);
    printf("  %-34s %ld\n", "steps", total.steps);
    printf("  %-34s %ld (%ld complete)\n", "laps (60 s of truth each)", lap_index, laps_full);
    printf("  %-34s %.1f s\n", "wall time", wall);
    printf("  %-34s %.0f (estimator alone: %.0f, %.3f us/step)\n", "steps/s with checks", (double)total.steps / wall,
           (double)total.steps / t_step, 1e6 * t_step / (double)total.steps);
    printf("  %-34s %.6g (gamma_min %.6g)%s\n", "min gamma", total.min_gamma, gamma_min,
           total.gamma_fail ? "  FAIL" : "");
    printf("  %-34s %.3g (limit %.3g)%s\n", "max |P asymmetry| (relative)", total.max_asym, 8.0 * (double)CAEKF_EPS,
           total.asym_fail ? "  FAIL" : "");
    printf("  %-34s %ld (min LDL pivot of corr(P) %.3g)%s\n", "PSD failures", total.psd_fail, total.min_pivot,
           total.psd_fail ? "  FAIL" : "");
    printf("  %-34s %ld%s\n", "non-finite P", total.nonfinite, total.nonfinite ? "  FAIL" : "");
    printf("  %-34s %ld%s\n", "steps not OK", total.status_fail, total.status_fail ? "  FAIL" : "");
    printf("  %-34s %ld (indefinite flagged %ld)\n", "repairs flagged", total.repairs, total.indefinite);
    printf("  %-34s %ld\n", "contact active (steps)", total.contact);
    printf("  %-34s %ld\n", "constraint applied (steps)", total.constraint_applied);
    printf("  %-34s %ld\n", "gamma gated by the innovation test", total.gated);
    printf("  %-34s %ld\n", "Newton not converged (steps)", total.newton_not_converged);
    printf("  %-34s mean %.4f max %d\n", "Newton iterations, first lap", first.newton_sum / (double)first.steps,
           first.newton_max);
    if (laps_full >= 1) {
        printf("  %-34s mean %.4f max %d%s\n", "Newton iterations, last full lap", last.newton_sum / (double)last.steps,
               last.newton_max, newton_ok ? "" : "  FAIL (growing)");
    }
    printf("soak: %s\n", (failures(&total) == 0 && newton_ok) ? "PASS" : "FAIL");
    return (failures(&total) == 0 && newton_ok) ? 0 : 1;
}
