/* caekf-replay: runs the estimator (a scenario, optionally a preset) over a recorded measurement CSV (the
 * mechanism's columns, caekf_csv_columns: t,u,y1,y4 for the paper). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "caekf/caekf.h"
#include "common/csv.h"
#include "common/scenario.h"
#include "common/tool.h"

typedef struct {
    long rows, rejected;
    double gamma_min_seen, p_norm_max;
    long iters_sum;
    int iters_max;
    uint32_t flags_seen;
    double gamma_last[CAEKF_MAX_CONTACTS];
} summary_t;

/* The name of estimated mechanism parameter j (the state n - nm + j): its scenario key, m<body>,
 * spring<link>_k or spring<link>_c. */
static void mech_name(char *out, size_t len, const caekf_model_t *m, int j)
{
    const int e = m->mech_elem[j] + 1;
    if (m->mech_kind[j] == CAEKF_MECH_MASS) {
        snprintf(out, len, "m%d", e);
    } else {
        snprintf(out, len, "spring%d_%c", e, m->mech_kind[j] == CAEKF_MECH_STIFFNESS ? 'k' : 'c');
    }
}

/* The output header: t, q1.., v1.., gamma (contact 1), gamma2.., the estimated law parameters (n, lambda,
 * gap of contact 1, then n2, ..., in the state's order), the estimated mechanism parameters (their scenario
 * keys: m2, spring1_k, spring3_c, ..., in the state's order), p_norm, p_gg, p_gg2.., the mechanism
 * parameters' variances (p_m2, p_spring1_k, ...), flags, newton_iters, nis. */
static void write_header(FILE *f, const caekf_model_t *m)
{
    static const char *const law_names[CAEKF_LAW_COUNT] = {"n", "lambda", "gap"};
    char name[CAEKF_CSV_NAME_LEN];
    const int nq = m->nq, nc = m->nc;
    int i, k;
    fputs("t", f);
    for (i = 0; i < 2 * nq; ++i) {
        fprintf(f, ",%c%d", i < nq ? 'q' : 'v', i % nq + 1);
    }
    for (i = 0; i < nc; ++i) {
        caekf_csv_series_name(name, "gamma", i, nc, 1);
        fprintf(f, ",%s", name);
    }
    for (i = 0; i < nc; ++i) {
        for (k = 0; k < CAEKF_LAW_COUNT; ++k) {
            if (m->law_state[i][k] != 0) {
                caekf_csv_series_name(name, law_names[k], i, nc, 1);
                fprintf(f, ",%s", name);
            }
        }
    }
    for (i = 0; i < m->nm; ++i) {
        char key[24];
        mech_name(key, sizeof key, m, i);
        fprintf(f, ",%s", key);
    }
    for (i = 0; i < CAEKF_MAX_SENSORS; ++i) { /* the sensors' estimated offsets */
        if (m->sensor_bias[i] != 0) {
            fprintf(f, ",sensor%d_bias", i + 1);
        }
    }
    fputs(",p_norm", f);
    for (i = 0; i < nc; ++i) {
        caekf_csv_series_name(name, "p_gg", i, nc, 1);
        fprintf(f, ",%s", name);
    }
    for (i = 0; i < m->nm; ++i) {
        char key[24];
        mech_name(key, sizeof key, m, i);
        fprintf(f, ",p_%s", key);
    }
    for (i = 0; i < CAEKF_MAX_SENSORS; ++i) {
        if (m->sensor_bias[i] != 0) {
            fprintf(f, ",p_sensor%d_bias", i + 1);
        }
    }
    fputs(",flags,newton_iters,nis\n", f);
}

static void usage(FILE *f)
{
    unsigned b;
    fputs(
        "usage: caekf-replay --scenario FILE [--in CSV|-] [--out CSV|-] [--experiment PRESET]\n"
        "         [--version] [--help]\n"
        "         [--mode canonical|switched] [--constraint on|off] [--q-gamma-scale X]\n"
        "         [--switchoff consistent|paper] [--joseph] [--no-repair] [--allow-nonfinite]\n"
        "         [--gate NIS] [--missing-y-predict] [--no-t-check] [--summary]\n"
        "Reads a CSV whose header starts with the mechanism's measurement columns: t, the inputs (u, or\n"
        "u1..u<inputs>), one column per sensor (y<body> position, yv<body> velocity, in sensor order);\n"
        "the paper's t,u,y1,y4 (extra columns ignored; stdin by default; t strictly increasing by the\n"
        "scenario's dt within 1 %; at most 2,000,000 rows). The scenario's q0, v0 are the state at t = 0:\n"
        "a first row at t = 0 is a correction only, any other first row is one dt after the start.\n"
        "Writes t,q1..q<bodies>,v1..v<bodies>, gamma\n"
        "(contact 1) and gamma2.. (further contacts), p_norm, p_gg (contact 1) and p_gg2.., flags,\n"
        "newton_iters, nis (stdout by default; the paper:\n"
        "t,q1,q2,q3,q4,v1,v2,v3,v4,gamma,p_norm,p_gg,flags,newton_iters,nis). Estimated law parameters\n"
        "(contact{i}_estimate_n/lambda/gap) follow the gammas as n, lambda, gap (n2, ... for contact 2);\n"
        "estimated mechanism parameters (m{i}_sigma, spring{i}_k_sigma, spring{i}_c_sigma > 0) follow them\n"
        "by their scenario keys (m2, spring1_k, spring3_c: masses, stiffnesses, dampers), their variances\n"
        "after the p_gg columns as p_m2, p_spring1_k, ...\n"
        "Settings: the schema's defaults (the recommended estimator), the scenario's values, then the\n"
        "preset named by --experiment, then the explicit flags. Presets:\n"
        "p_norm is the 2-norm of P in physical units; p_gg its gamma variance; nis the normalised\n"
        "innovation squared of the step's correction. --gate sets gamma_gate_nis (0: off).\n"
        "--allow-nonfinite passes NaN/Inf fields to the estimator (which rejects them) instead of\n"
        "refusing the input. --missing-y-predict: a row whose sensor fields are all empty is a step without\n"
        "measurement (caekf_predict, the firmware's bridge over lost steps). --no-t-check: t must increase\n"
        "but its steps are not checked against dt (rows deliberately not evenly spaced). --summary prints one line of\n"
        "statistics to stderr. The whole input is checked before anything is written; the output file\n"
        "appears (renamed from a temporary file beside it) only when the run succeeded.\n",
        f);
    for (b = 0; b < CAEKF_PRESET_COUNT; ++b) {
        fprintf(f, "  %-28s %s\n", caekf_presets[b].name, caekf_presets[b].doc);
    }
    fputs("flags bits:\n", f);
    for (b = 0; b < CAEKF_FLAG_COUNT; ++b) {
        fprintf(f, "  %4u  %s\n", 1u << b, caekf_flag_name(b));
    }
    fputs(CAEKF_EXIT_TABLE, f);
}

/* Final error of contact c's gamma against the scenario's true contact{c}_gamma [%], as text in buf: "-"
 * when the scenario has no truth (a recording: the truth-only key is NaN). */
static const char *gamma_error(const caekf_scenario_t *sc, const double *gamma_last, int c, char *buf, size_t len)
{
    char key[32];
    double truth = NAN;
    snprintf(key, sizeof key, "contact%d_gamma", c + 1);
    (void)caekf_scenario_value(sc, key, &truth);
    if (isnan(truth)) {
        snprintf(buf, len, "-");
    } else {
        snprintf(buf, len, "%+.4f", 100.0 * (gamma_last[c] / truth - 1.0));
    }
    return buf;
}

static void print_flags(FILE *f, uint32_t flags)
{
    unsigned b;
    int first = 1;
    for (b = 0; b < CAEKF_FLAG_COUNT; ++b) {
        if (flags & (1u << b)) {
            fprintf(f, "%s%s", first ? "" : "|", caekf_flag_name(b));
            first = 0;
        }
    }
    if (first) {
        fputs("-", f);
    }
}

int main(int argc, char **argv)
{
    const char *scenario = NULL, *in = "-", *out = "-";
    const char *experiment = NULL, *mode = NULL, *constraint = NULL, *switchoff = NULL;
    double q_gamma_scale = -1, gate = -1;
    int joseph = 0, no_repair = 0, allow_nonfinite = 0, want_summary = 0, allow_missing = 0, t_check = 1;
    caekf_scenario_t sc;
    caekf_settings_t s;
    caekf_t est;
    caekf_meas_t *rows = NULL;
    caekf_csv_columns_t cols;
    summary_t sum;
    caekf_output_t o;
    FILE *fout;
    char err[1024];
    const caekf_preset_t *preset = NULL;
    caekf_setting_error_t bad;
    long n, k;
    int i, rc, ig, nc, finite = 1;

    for (i = 1; i < argc; ++i) {
        const char *a = argv[i];
        int has = i + 1 < argc;
        if (strcmp(a, "--scenario") == 0 && has) scenario = argv[++i];
        else if (strcmp(a, "--in") == 0 && has) in = argv[++i];
        else if (strcmp(a, "--out") == 0 && has) out = argv[++i];
        else if (strcmp(a, "--experiment") == 0 && has) experiment = argv[++i];
        else if (strcmp(a, "--mode") == 0 && has) mode = argv[++i];
        else if (strcmp(a, "--constraint") == 0 && has) constraint = argv[++i];
        else if (strcmp(a, "--switchoff") == 0 && has) switchoff = argv[++i];
        else if (strcmp(a, "--q-gamma-scale") == 0 && has) {
            char *end;
            q_gamma_scale = strtod(argv[++i], &end);
            if (*end != '\0' || !(q_gamma_scale >= 0) || !isfinite(q_gamma_scale)) {
                fprintf(stderr, "caekf-replay: --q-gamma-scale needs a finite number >= 0\n");
                return CAEKF_EXIT_USAGE;
            }
        } else if (strcmp(a, "--gate") == 0 && has) {
            char *end;
            gate = strtod(argv[++i], &end);
            if (*end != '\0' || !(gate >= 0) || !isfinite(gate)) {
                fprintf(stderr, "caekf-replay: --gate needs a finite number >= 0\n");
                return CAEKF_EXIT_USAGE;
            }
        } else if (strcmp(a, "--joseph") == 0) joseph = 1;
        else if (strcmp(a, "--no-repair") == 0) no_repair = 1;
        else if (strcmp(a, "--allow-nonfinite") == 0) allow_nonfinite = 1;
        else if (strcmp(a, "--missing-y-predict") == 0) allow_missing = 1;
        else if (strcmp(a, "--summary") == 0) want_summary = 1;
        else if (strcmp(a, "--no-t-check") == 0) t_check = 0;
        else if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            return CAEKF_EXIT_OK;
        } else if (strcmp(a, "--version") == 0) {
            caekf_tool_version("caekf-replay", CAEKF_SCALAR_NAME);
            return CAEKF_EXIT_OK;
        } else {
            fprintf(stderr, "caekf-replay: unknown or incomplete argument '%s' (see --help)\n", a);
            return CAEKF_EXIT_USAGE;
        }
    }
    if (scenario == NULL) {
        fprintf(stderr, "caekf-replay: --scenario is required (see --help)\n");
        return CAEKF_EXIT_USAGE;
    }
    if (experiment != NULL && (preset = caekf_preset_find(experiment)) == NULL) {
        fprintf(stderr, "caekf-replay: unknown experiment '%s' (see --help)\n", experiment);
        return CAEKF_EXIT_USAGE;
    }
    if (mode != NULL && strcmp(mode, "canonical") != 0 && strcmp(mode, "switched") != 0) {
        fprintf(stderr, "caekf-replay: bad --mode '%s' (canonical or switched)\n", mode);
        return CAEKF_EXIT_USAGE;
    }
    if (constraint != NULL && strcmp(constraint, "on") != 0 && strcmp(constraint, "off") != 0) {
        fprintf(stderr, "caekf-replay: bad --constraint '%s' (on or off)\n", constraint);
        return CAEKF_EXIT_USAGE;
    }
    if (switchoff != NULL && strcmp(switchoff, "consistent") != 0 && strcmp(switchoff, "paper") != 0) {
        fprintf(stderr, "caekf-replay: bad --switchoff '%s' (consistent or paper)\n", switchoff);
        return CAEKF_EXIT_USAGE;
    }
    if ((rc = caekf_tool_check_input(scenario, 0, err, sizeof err)) != 0) {
        fprintf(stderr, "caekf-replay: %s\n", err);
        return rc;
    }
    if (caekf_scenario_load(scenario, &sc, err, sizeof err) != 0 ||
        caekf_scenario_settings(&sc, preset, &s, scenario, err, sizeof err) != 0) {
        fprintf(stderr, "caekf-replay: %s\n", err);
        return CAEKF_EXIT_INPUT;
    }
    if (mode != NULL) s.mode = strcmp(mode, "canonical") == 0 ? CAEKF_MODE_CANONICAL : CAEKF_MODE_SWITCHED;
    if (constraint != NULL) s.constraint_enabled = strcmp(constraint, "on") == 0;
    if (switchoff != NULL) {
        s.switchoff = strcmp(switchoff, "consistent") == 0 ? CAEKF_SWITCHOFF_CONSISTENT : CAEKF_SWITCHOFF_PAPER;
    }
    if (q_gamma_scale >= 0) s.q_gamma_scale = (caekf_scalar_t)q_gamma_scale;
    if (gate >= 0) s.gamma_gate_nis = (caekf_scalar_t)gate;
    if (joseph) s.cov_update = CAEKF_COV_JOSEPH;
    if (no_repair) s.cov_repair_enabled = 0;
    if (caekf_settings_validate(&s, &bad) != CAEKF_OK) {
        (void)caekf_setting_error_text(&bad, &s, err, sizeof err);
        fprintf(stderr, "caekf-replay: %s: settings refused: %s\n", scenario, err);
        return CAEKF_EXIT_INPUT;
    }
    /* The whole input is read and checked before any output exists. */
    if ((n = caekf_csv_read_for(in, &sc, t_check ? sc.dt : 0.0, allow_nonfinite, allow_missing, &cols, &rows, err,
                                sizeof err)) < 0) {
        fprintf(stderr, "caekf-replay: %s\n", err);
        return (int)-n;
    }
    if (caekf_init(&est, &s) != CAEKF_OK) {
        fprintf(stderr, "caekf-replay: %s: estimator initialisation failed\n", scenario);
        free(rows);
        return CAEKF_EXIT_NUMERIC;
    }
    if ((rc = caekf_output_open(&o, out, err, sizeof err)) != 0) {
        fprintf(stderr, "caekf-replay: %s\n", err);
        free(rows);
        return rc;
    }
    fout = o.f;
    memset(&sum, 0, sizeof sum);
    sum.gamma_min_seen = INFINITY;
    ig = 2 * est.model.nq;
    nc = est.model.nc;
    write_header(fout, &est.model);
    for (k = 0; k < n; ++k) {
        const caekf_meas_t *m = &rows[k];
        caekf_scalar_t u[CAEKF_MAX_INPUTS + 1], y[CAEKF_MAX_SENSORS], x[CAEKF_N], P[CAEKF_N][CAEKF_N], pn = 0;
        caekf_report_t rep;
        caekf_meas_scalars(m, &cols, u, y);
        caekf_status_t st;
        if (k == 0 && m->has_y && fabs(m->t) <= 0.5 * sc.dt) {
            /* The time convention (docs/discretisation.md): q0, v0 are the state at t = 0, so a first
             * row at t = 0 is corrected without a time update; otherwise it is one dt after the start. */
            st = caekf_correct(&est, u, y, &rep);
        } else {
            st = m->has_y ? caekf_step(&est, u, y, &rep) : caekf_predict(&est, u, &rep);
        }
        if (st != CAEKF_OK) {
            sum.rejected++;
        }
        (void)caekf_get_state(&est, x);
        (void)caekf_get_covariance(&est, P);
        (void)caekf_get_cov_norm2(&est, &pn);
        fprintf(fout, "%.17g", m->t);
        for (i = 0; i < est.model.n; ++i) {
            fprintf(fout, ",%.17g", (double)x[i]);
        }
        fprintf(fout, ",%.17g", (double)pn);
        for (i = 0; i < nc; ++i) {
            fprintf(fout, ",%.17g", (double)P[ig + i][ig + i]);
        }
        for (i = est.model.n - est.model.nm - est.model.nb; i < est.model.n;
             ++i) { /* mechanism's, offsets' variances */
            fprintf(fout, ",%.17g", (double)P[i][i]);
        }
        fprintf(fout, ",%lu,%d,%.9g\n", (unsigned long)rep.flags, rep.newton_iters, (double)rep.nis);
        sum.rows++;
        sum.iters_sum += rep.newton_iters;
        if (rep.newton_iters > sum.iters_max) sum.iters_max = rep.newton_iters;
        sum.flags_seen |= rep.flags;
        if (nc > 0 && (double)x[ig] < sum.gamma_min_seen) sum.gamma_min_seen = (double)x[ig];
        if ((double)pn > sum.p_norm_max) sum.p_norm_max = (double)pn;
        for (i = 0; i < nc; ++i) {
            sum.gamma_last[i] = (double)x[ig + i];
            finite &= isfinite(sum.gamma_last[i]) != 0;
        }
    }
    free(rows);
    if (!finite) {
        caekf_output_abort(&o);
        fprintf(stderr, "caekf-replay: %s: the estimate of gamma is not finite after %ld steps\n",
                strcmp(in, "-") == 0 ? "<stdin>" : in, n);
        return CAEKF_EXIT_NUMERIC;
    }
    if ((rc = caekf_output_commit(&o, err, sizeof err)) != 0) {
        fprintf(stderr, "caekf-replay: %s\n", err);
        return rc;
    }
    if (want_summary) {
        /* One row: experiment scalar rows rejected final_err_% min_gamma max_pnorm iters_mean iters_max flags */
        fprintf(stderr, "%-28s %-6s %7ld %5ld ", experiment != NULL ? experiment : "default", CAEKF_SCALAR_NAME,
                sum.rows, sum.rejected);
        if (nc > 0) {
            fprintf(stderr, "%10s %12.4e ", gamma_error(&sc, sum.gamma_last, 0, err, sizeof err), sum.gamma_min_seen);
        } else { /* no contact, no gamma */
            fprintf(stderr, "%10s %12s ", "-", "-");
        }
        fprintf(stderr, "%12.4e %6.3f %4d ", sum.p_norm_max, sum.rows ? (double)sum.iters_sum / (double)sum.rows : 0.0,
                sum.iters_max);
        print_flags(stderr, sum.flags_seen);
        for (i = 1; i < nc; ++i) { /* further contacts: their final gamma error, after the flags */
            fprintf(stderr, " gamma%d %s", i + 1, gamma_error(&sc, sum.gamma_last, i, err, sizeof err));
        }
        fputc('\n', stderr);
    }
    return CAEKF_EXIT_OK;
}
