/* caekf-truth: the measurement record of a scenario's mechanism (CSV: t, the inputs, the sensors, then
 * the true states and penetrations), optionally also as little-endian float64 records for the MCU test
 * images. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/csv.h" /* CAEKF_CSV_MAX_ROWS: the truth is the replay's input; the column names */
#include "common/scenario.h"
#include "common/tool.h"
#include "common/truth.h"

#define TRUTH_MAX_COLUMNS (CAEKF_CSV_MAX_COLUMNS + 2 * CAEKF_MAX_BODIES + CAEKF_MAX_CONTACTS)

typedef struct {
    FILE *csv;
    FILE *bin;
    long samples;
    long newton_iters, newton_max, newton_failed;
    long steps, rejected, events, failed;
    double max_delta;
    int in_contact;
    long episodes;
    double episode_start;
    int quiet;
} truth_sink_t;

static void usage(FILE *f)
{
    fputs("usage: caekf-truth --scenario FILE [--out CSV|-] [--bin FILE] [--no-csv] [--quiet] [--inputs CSV]\n"
          "                   [--method dop853|backward-euler] [--rtol R] [--atol-q A] [--atol-v A]\n"
          "       caekf-truth --help | --version\n"
          "The scenario must give the truth-only keys (contact{i}_gamma, input{i}_amp/_freq/_phase, t_end,\n"
          "truth_substeps, noise_std, seed).\n"
          "Writes CSV columns t, the inputs (u, or u1..u<inputs>), one column per sensor (y<body> for a\n"
          "position sensor, yv<body> for a velocity sensor, in sensor order), q1..q<bodies>, v1..v<bodies>,\n"
          "and the penetrations (delta, or delta1..delta<contacts>) for k = 1..round(t_end/dt); for the\n"
          "paper's mechanism t,u,y1,y4,q1,q2,q3,q4,v1,v2,v3,v4,delta.\n"
          "--bin also writes the same columns as little-endian float64 records; --no-csv skips the CSV.\n"
          "--inputs CSV: the inputs from a time series instead of the scenario's sines (header t,u or\n"
          "t,u1 for one input, t,u1,u2 for two; extra columns ignored; linear interpolation, end values held;\n"
          "a base displacement's rate from the samples' central differences).\n"
          "Measurement noise: noise_std on position sensors, noise_std_v on velocity sensors.\n"
          "dop853 (default): the continuous model, adaptive Dormand-Prince 8(5,3) with every contact event\n"
          "located and the integration restarted there (rtol 1e-13, atol 1e-15 m, 1e-13 m/s by default).\n"
          "backward-euler: eq. (19) at dt/truth_substeps, Newton-solved (the truth of earlier versions).\n"
          "A summary (contact episodes, max penetration, steps or Newton iterations) goes to stderr.\n"
          "Exit status 5 when the integration failed (DOP853) or a Newton solve did not converge; outputs are\n"
          "written to temporary files renamed at the end, so a failed run leaves none.\n" CAEKF_EXIT_TABLE,
          f);
}

static int emit(const caekf_truth_sample_t *s, void *ctx)
{
    truth_sink_t *k = ctx;
    double rec[TRUTH_MAX_COLUMNS], dmax = 0;
    int i, n = 0, any = 0;
    rec[n++] = s->t;
    for (i = 0; i < s->inputs; ++i) {
        rec[n++] = s->u[i];
    }
    for (i = 0; i < s->sensors; ++i) {
        rec[n++] = s->y[i];
    }
    for (i = 0; i < s->bodies; ++i) {
        rec[n++] = s->q[i];
    }
    for (i = 0; i < s->bodies; ++i) {
        rec[n++] = s->v[i];
    }
    for (i = 0; i < s->contacts; ++i) {
        rec[n++] = s->delta[i];
        if (s->delta[i] > 0) {
            any = 1;
        }
        if (i == 0 || s->delta[i] > dmax) {
            dmax = s->delta[i];
        }
    }
    if (k->csv != NULL) {
        for (i = 0; i < n; ++i) {
            if (fprintf(k->csv, i ? ",%.17g" : "%.17g", rec[i]) < 0) {
                return -1;
            }
        }
        fputc('\n', k->csv);
    }
    if (k->bin != NULL && fwrite(rec, sizeof rec[0], (size_t)n, k->bin) != (size_t)n) {
        return -1;
    }
    k->samples++;
    k->newton_iters += s->newton_iters;
    k->newton_failed += s->newton_failed;
    k->steps += s->steps;
    k->rejected += s->rejected;
    k->events += s->events;
    k->failed += s->failed;
    if (s->newton_iters > k->newton_max) {
        k->newton_max = s->newton_iters;
    }
    if (dmax > k->max_delta) {
        k->max_delta = dmax;
    }
    if (any && !k->in_contact) {
        k->in_contact = 1;
        k->episodes++;
        k->episode_start = s->t;
        if (!k->quiet && k->episodes <= 20) {
            fprintf(stderr, "contact from %.3f s", s->t);
        }
    } else if (!any && k->in_contact) {
        k->in_contact = 0;
        if (!k->quiet && k->episodes <= 20) {
            fprintf(stderr, " to %.3f s\n", s->t);
        }
    }
    return 0;
}

/* The CSV header: the measurement columns (caekf_csv_columns), q1.., v1.., delta or delta1... */
static int write_header(FILE *f, const caekf_model_params_t *mp)
{
    caekf_csv_columns_t cols;
    char name[CAEKF_CSV_NAME_LEN];
    int i, bad;
    if (caekf_csv_columns(mp, &cols) != 0) {
        return -1;
    }
    bad = caekf_csv_write_names(f, &cols);
    for (i = 0; i < 2 * mp->bodies; ++i) {
        bad |= fprintf(f, ",%c%d", i < mp->bodies ? 'q' : 'v', i % mp->bodies + 1) < 0;
    }
    for (i = 0; i < mp->contacts; ++i) {
        caekf_csv_series_name(name, "delta", i, mp->contacts, 0);
        bad |= fprintf(f, ",%s", name) < 0;
    }
    bad |= fputc('\n', f) == EOF;
    return bad ? -1 : 0;
}

int main(int argc, char **argv)
{
    const char *scenario = NULL, *out = "-", *bin = NULL, *inputs = NULL;
    caekf_scenario_t sc;
    caekf_settings_t settings;
    caekf_input_series_t series;
    caekf_output_t ocsv, obin;
    truth_sink_t sink;
    caekf_truth_options_t opt;
    char err[512] = "";
    int i, rc;
    memset(&sink, 0, sizeof sink);
    memset(&series, 0, sizeof series);
    memset(&ocsv, 0, sizeof ocsv);
    memset(&obin, 0, sizeof obin);
    caekf_truth_options_default(&opt);
    for (i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--scenario") == 0 && i + 1 < argc) {
            scenario = argv[++i];
        } else if (strcmp(argv[i], "--out") == 0 && i + 1 < argc) {
            out = argv[++i];
        } else if (strcmp(argv[i], "--bin") == 0 && i + 1 < argc) {
            bin = argv[++i];
        } else if (strcmp(argv[i], "--inputs") == 0 && i + 1 < argc) {
            inputs = argv[++i];
        } else if (strcmp(argv[i], "--method") == 0 && i + 1 < argc) {
            ++i;
            if (strcmp(argv[i], "dop853") == 0) {
                opt.method = CAEKF_TRUTH_DOP853;
            } else if (strcmp(argv[i], "backward-euler") == 0) {
                opt.method = CAEKF_TRUTH_BACKWARD_EULER;
            } else {
                fprintf(stderr, "caekf-truth: unknown method '%s' (dop853, backward-euler)\n", argv[i]);
                return CAEKF_EXIT_USAGE;
            }
        } else if ((strcmp(argv[i], "--rtol") == 0 || strcmp(argv[i], "--atol-q") == 0 ||
                    strcmp(argv[i], "--atol-v") == 0) &&
                   i + 1 < argc) {
            char *end;
            double v = strtod(argv[i + 1], &end);
            if (*end != '\0' || !(v > 0)) {
                fprintf(stderr, "caekf-truth: %s needs a positive number, got '%s'\n", argv[i], argv[i + 1]);
                return CAEKF_EXIT_USAGE;
            }
            if (argv[i][2] == 'r') {
                opt.rtol = v;
            } else if (argv[i][7] == 'q') {
                opt.atol_q = v;
            } else {
                opt.atol_v = v;
            }
            ++i;
        } else if (strcmp(argv[i], "--no-csv") == 0) {
            out = NULL;
        } else if (strcmp(argv[i], "--quiet") == 0) {
            sink.quiet = 1;
        } else if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            usage(stdout);
            return CAEKF_EXIT_OK;
        } else if (strcmp(argv[i], "--version") == 0) {
            caekf_tool_version("caekf-truth", CAEKF_SCALAR_NAME);
            return CAEKF_EXIT_OK;
        } else {
            fprintf(stderr, "caekf-truth: unknown or incomplete argument '%s' (see --help)\n", argv[i]);
            return CAEKF_EXIT_USAGE;
        }
    }
    if (scenario == NULL) {
        fprintf(stderr, "caekf-truth: --scenario is required (see --help)\n");
        return CAEKF_EXIT_USAGE;
    }
    if ((rc = caekf_tool_check_input(scenario, 0, err, sizeof err)) != 0) {
        fprintf(stderr, "caekf-truth: %s\n", err);
        return rc;
    }
    /* Everything is checked before any output exists: the scenario (its mechanism validated as the
     * estimator would), the size, the input series. */
    if (caekf_scenario_load(scenario, &sc, err, sizeof err) != 0 ||
        caekf_scenario_need_truth(&sc, scenario, err, sizeof err) != 0 ||
        caekf_scenario_settings(&sc, NULL, &settings, scenario, err, sizeof err) != 0) {
        fprintf(stderr, "caekf-truth: %s\n", err);
        return CAEKF_EXIT_INPUT;
    }
    /* t_end / dt can ask for more rows than any tool reads (dt = 1e-12 or t_end = 1e9 filled the disk):
     * refused before anything is written. */
    if (!(sc.t_end / sc.dt <= (double)CAEKF_CSV_MAX_ROWS)) {
        fprintf(stderr, "caekf-truth: %s: t_end / dt = %.3g samples: the limit is %ld (what caekf-replay reads)\n",
                scenario, sc.t_end / sc.dt, CAEKF_CSV_MAX_ROWS);
        return CAEKF_EXIT_INPUT;
    }
    if (inputs != NULL) {
        if ((rc = caekf_tool_check_input(inputs, 0, err, sizeof err)) != 0 ||
            (rc = caekf_input_series_read(inputs, settings.model.inputs, &series, err, sizeof err)) != 0) {
            fprintf(stderr, "caekf-truth: %s\n", err);
            return rc;
        }
        opt.series = &series;
    }
    /* Both outputs go to temporary files renamed at the end (an interrupt removes the last one opened:
     * tool.c watches one per process). */
    if ((out != NULL && (rc = caekf_output_open(&ocsv, out, err, sizeof err)) != 0) ||
        (bin != NULL && (rc = caekf_output_open(&obin, bin, err, sizeof err)) != 0)) {
        fprintf(stderr, "caekf-truth: %s\n", err);
        caekf_output_abort(&ocsv);
        caekf_input_series_free(&series);
        return rc;
    }
    sink.csv = ocsv.f;
    sink.bin = obin.f;
    rc = sink.csv != NULL ? write_header(sink.csv, &settings.model) : 0;
    if (rc == 0) {
        rc = caekf_truth_run(&sc, &opt, emit, &sink);
    }
    caekf_input_series_free(&series);
    if (sink.in_contact && !sink.quiet) {
        fputs(" (still in contact)\n", stderr);
    }
    if (rc != 0) {
        caekf_output_abort(&ocsv);
        caekf_output_abort(&obin);
    } else if ((out != NULL && caekf_output_commit(&ocsv, err, sizeof err) != 0) ||
               (bin != NULL && caekf_output_commit(&obin, err, sizeof err) != 0)) {
        caekf_output_abort(&obin);
        fprintf(stderr, "caekf-truth: %s\n", err);
        return CAEKF_EXIT_IO;
    }
    if (rc < 0) {
        fprintf(stderr, "caekf-truth: failed writing output or setting up the model\n");
        return CAEKF_EXIT_IO;
    }
    if (rc > 0) {
        fprintf(stderr,
                "caekf-truth: integration failed at t = %.6f s (step size below 1e-14 s or step budget): nothing "
                "written\n",
                (double)sink.samples * sc.dt);
        return CAEKF_EXIT_NUMERIC;
    }
    if (!sink.quiet && opt.method == CAEKF_TRUTH_DOP853) {
        fprintf(stderr,
                "caekf-truth: %ld samples, %ld contact onsets, max penetration %.4g m, DOP853 steps %ld "
                "(rejected %ld), contact events located %ld\n",
                sink.samples, sink.episodes, sink.max_delta, sink.steps, sink.rejected, sink.events);
    } else if (!sink.quiet) {
        fprintf(stderr,
                "caekf-truth: %ld samples, %ld contact onsets, max penetration %.4g m, Newton iterations per "
                "substep mean %.3f, max per sample %ld, failures %ld\n",
                sink.samples, sink.episodes, sink.max_delta,
                (double)sink.newton_iters / ((double)sink.samples * sc.truth_substeps), sink.newton_max,
                sink.newton_failed);
    }
    return sink.newton_failed ? CAEKF_EXIT_NUMERIC : CAEKF_EXIT_OK;
}
