/* caekf-replay: runs the estimator (a scenario, optionally a preset) over a recorded t,u,y1,y4 CSV. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "caekf/caekf.h"
#include "common/csv.h"
#include "common/scenario.h"

typedef struct {
    long rows, rejected;
    double gamma_min_seen, p_norm_max;
    long iters_sum;
    int iters_max;
    uint32_t flags_seen;
    double gamma_last;
} summary_t;

static void usage(FILE *f)
{
    unsigned b;
    fputs("usage: caekf-replay --scenario FILE [--in CSV|-] [--out CSV|-] [--experiment PRESET]\n"
          "         [--mode canonical|switched] [--constraint on|off] [--q-gamma-scale X]\n"
          "         [--switchoff consistent|paper] [--joseph] [--no-repair] [--allow-nonfinite]\n"
          "         [--gate NIS] [--missing-y-predict] [--summary]\n"
          "Reads a CSV whose header starts t,u,y1,y4 (extra columns ignored; stdin by default) and writes\n"
          "t,q1,q2,q3,q4,v1,v2,v3,v4,gamma,p_norm,p_gg,flags,newton_iters,nis (stdout by default).\n"
          "Settings: the schema's defaults (the recommended estimator), the scenario's values, then the\n"
          "preset named by --experiment, then the explicit flags. Presets:\n"
          "p_norm is the 2-norm of P in physical units; p_gg its gamma variance; nis the normalised\n"
          "innovation squared of the step's correction. --gate sets gamma_gate_nis (0: off).\n"
          "--allow-nonfinite passes NaN/Inf fields to the estimator (which rejects them) instead of\n"
          "refusing the input. --missing-y-predict: a row whose y1 and y4 are both empty is a step without\n"
          "measurement (caekf_predict, the firmware's bridge over lost steps). --summary prints one line of\n"
          "statistics to stderr.\n",
          f);
    for (b = 0; b < CAEKF_PRESET_COUNT; ++b) {
        fprintf(f, "  %-28s %s\n", caekf_presets[b].name, caekf_presets[b].doc);
    }
    fputs("flags bits:\n", f);
    for (b = 0; b < CAEKF_FLAG_COUNT; ++b) {
        fprintf(f, "  %4u  %s\n", 1u << b, caekf_flag_name(b));
    }
    fputs("exit status: 0 ok, 2 usage, 3 bad scenario or settings, 4 malformed input, 5 I/O error\n", f);
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
    int joseph = 0, no_repair = 0, allow_nonfinite = 0, want_summary = 0, allow_missing = 0;
    caekf_scenario_t sc;
    caekf_settings_t s;
    caekf_t est;
    caekf_csv_t csv;
    caekf_meas_t m;
    summary_t sum;
    FILE *fin, *fout;
    char err[512];
    const caekf_preset_t *preset = NULL;
    caekf_setting_error_t bad;
    int i, rc;

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
                return 2;
            }
        } else if (strcmp(a, "--gate") == 0 && has) {
            char *end;
            gate = strtod(argv[++i], &end);
            if (*end != '\0' || !(gate >= 0) || !isfinite(gate)) {
                fprintf(stderr, "caekf-replay: --gate needs a finite number >= 0\n");
                return 2;
            }
        } else if (strcmp(a, "--joseph") == 0) joseph = 1;
        else if (strcmp(a, "--no-repair") == 0) no_repair = 1;
        else if (strcmp(a, "--allow-nonfinite") == 0) allow_nonfinite = 1;
        else if (strcmp(a, "--missing-y-predict") == 0) allow_missing = 1;
        else if (strcmp(a, "--summary") == 0) want_summary = 1;
        else if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            return 0;
        } else {
            fprintf(stderr, "caekf-replay: unknown or incomplete argument '%s' (see --help)\n", a);
            return 2;
        }
    }
    if (scenario == NULL) {
        fprintf(stderr, "caekf-replay: --scenario is required (see --help)\n");
        return 2;
    }
    if (experiment != NULL && (preset = caekf_preset_find(experiment)) == NULL) {
        fprintf(stderr, "caekf-replay: unknown experiment '%s' (see --help)\n", experiment);
        return 2;
    }
    if (caekf_scenario_load(scenario, &sc, err, sizeof err) != 0 ||
        caekf_scenario_settings(&sc, preset, &s, scenario, err, sizeof err) != 0) {
        fprintf(stderr, "caekf-replay: %s\n", err);
        return 3;
    }
    if (mode != NULL) {
        if (strcmp(mode, "canonical") == 0) s.mode = CAEKF_MODE_CANONICAL;
        else if (strcmp(mode, "switched") == 0) s.mode = CAEKF_MODE_SWITCHED;
        else { fprintf(stderr, "caekf-replay: bad --mode '%s'\n", mode); return 2; }
    }
    if (constraint != NULL) {
        if (strcmp(constraint, "on") == 0) s.constraint_enabled = 1;
        else if (strcmp(constraint, "off") == 0) s.constraint_enabled = 0;
        else { fprintf(stderr, "caekf-replay: bad --constraint '%s'\n", constraint); return 2; }
    }
    if (switchoff != NULL) {
        if (strcmp(switchoff, "consistent") == 0) s.switchoff = CAEKF_SWITCHOFF_CONSISTENT;
        else if (strcmp(switchoff, "paper") == 0) s.switchoff = CAEKF_SWITCHOFF_PAPER;
        else { fprintf(stderr, "caekf-replay: bad --switchoff '%s'\n", switchoff); return 2; }
    }
    if (q_gamma_scale >= 0) s.q_gamma_scale = (caekf_scalar_t)q_gamma_scale;
    if (gate >= 0) s.gamma_gate_nis = (caekf_scalar_t)gate;
    if (joseph) s.cov_update = CAEKF_COV_JOSEPH;
    if (no_repair) s.cov_repair_enabled = 0;
    if (caekf_settings_validate(&s, &bad) != CAEKF_OK) {
        (void)caekf_setting_error_text(&bad, &s, err, sizeof err);
        fprintf(stderr, "caekf-replay: settings refused: %s\n", err);
        return 3;
    }
    if (caekf_init(&est, &s) != CAEKF_OK) {
        fprintf(stderr, "caekf-replay: estimator initialisation failed\n");
        return 3;
    }

    fin = strcmp(in, "-") == 0 ? stdin : fopen(in, "r");
    if (fin == NULL) {
        perror(in);
        return 5;
    }
    fout = strcmp(out, "-") == 0 ? stdout : fopen(out, "w");
    if (fout == NULL) {
        perror(out);
        return 5;
    }
    if (caekf_csv_open(&csv, fin, strcmp(in, "-") == 0 ? "<stdin>" : in, allow_nonfinite) != 0) {
        fprintf(stderr, "caekf-replay: %s\n", csv.err);
        return 4;
    }
    csv.allow_missing_y = allow_missing;
    memset(&sum, 0, sizeof sum);
    sum.gamma_min_seen = INFINITY;
    fputs("t,q1,q2,q3,q4,v1,v2,v3,v4,gamma,p_norm,p_gg,flags,newton_iters,nis\n", fout);
    while ((rc = caekf_csv_next(&csv, &m)) == 1) {
        caekf_scalar_t y[CAEKF_NY], x[CAEKF_N], P[CAEKF_N][CAEKF_N], pn = 0;
        caekf_report_t rep;
        y[0] = (caekf_scalar_t)m.y1;
        y[1] = (caekf_scalar_t)m.y4;
        if ((m.has_y ? caekf_step(&est, (caekf_scalar_t)m.u, y, &rep)
                     : caekf_predict(&est, (caekf_scalar_t)m.u, &rep)) != CAEKF_OK) {
            sum.rejected++;
        }
        (void)caekf_get_state(&est, x);
        (void)caekf_get_covariance(&est, P);
        (void)caekf_get_cov_norm2(&est, &pn);
        fprintf(fout, "%.17g", m.t);
        for (i = 0; i < CAEKF_N; ++i) {
            fprintf(fout, ",%.17g", (double)x[i]);
        }
        fprintf(fout, ",%.17g,%.17g,%lu,%d,%.9g\n", (double)pn, (double)P[CAEKF_IG][CAEKF_IG],
                (unsigned long)rep.flags, rep.newton_iters, (double)rep.nis);
        sum.rows++;
        sum.iters_sum += rep.newton_iters;
        if (rep.newton_iters > sum.iters_max) sum.iters_max = rep.newton_iters;
        sum.flags_seen |= rep.flags;
        if ((double)x[CAEKF_IG] < sum.gamma_min_seen) sum.gamma_min_seen = (double)x[CAEKF_IG];
        if ((double)pn > sum.p_norm_max) sum.p_norm_max = (double)pn;
        sum.gamma_last = (double)x[CAEKF_IG];
    }
    if (rc < 0) {
        fprintf(stderr, "caekf-replay: %s\n", csv.err);
        return 4;
    }
    if (fout != stdout && fclose(fout) != 0) {
        perror(out);
        return 5;
    }
    if (want_summary) {
        /* One row: experiment scalar rows rejected final_err_% min_gamma max_pnorm iters_mean iters_max flags */
        fprintf(stderr, "%-28s %-6s %7ld %5ld %+10.4f %12.4e %12.4e %6.3f %4d ",
                experiment != NULL ? experiment : "default", CAEKF_SCALAR_NAME,
                sum.rows, sum.rejected, 100.0 * (sum.gamma_last / sc.gamma - 1.0), sum.gamma_min_seen, sum.p_norm_max,
                sum.rows ? (double)sum.iters_sum / (double)sum.rows : 0.0, sum.iters_max);
        print_flags(stderr, sum.flags_seen);
        fputc('\n', stderr);
    }
    return 0;
}
