/* caekf-truth: the measurement record of a scenario (CSV t,u,y1,y4 + true states), optionally also as
 * little-endian float64 records for the MCU test images. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/csv.h" /* CAEKF_CSV_MAX_ROWS: the truth is the replay's input */
#include "common/scenario.h"
#include "common/tool.h"
#include "common/truth.h"

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
    fputs("usage: caekf-truth --scenario FILE [--out CSV|-] [--bin FILE] [--no-csv] [--quiet]\n"
          "                   [--method dop853|backward-euler] [--rtol R] [--atol-q A] [--atol-v A]\n"
          "Writes CSV columns t,u,y1,y4,q1,q2,q3,q4,v1,v2,v3,v4,delta for k = 1..round(t_end/dt).\n"
          "--bin also writes the same 13 columns as little-endian float64 records; --no-csv skips the CSV.\n"
          "dop853 (default): the continuous model, adaptive Dormand-Prince 8(5,3) with every contact event\n"
          "located and the integration restarted there (rtol 1e-13, atol 1e-15 m, 1e-13 m/s by default).\n"
          "backward-euler: eq. (19) at dt/truth_substeps, Newton-solved (the truth of earlier versions).\n"
          "A summary (contact episodes, max penetration, steps or Newton iterations) goes to stderr.\n"
          "Exit status 5 when the integration failed (DOP853) or a Newton solve did not converge; outputs are\n"
          "written to temporary files renamed at the end, so a failed run leaves none.\n",
          f);
}

static int emit(const caekf_truth_sample_t *s, void *ctx)
{
    truth_sink_t *k = ctx;
    double rec[13];
    int i;
    rec[0] = s->t;
    rec[1] = s->u;
    rec[2] = s->y1;
    rec[3] = s->y4;
    for (i = 0; i < 4; ++i) {
        rec[4 + i] = s->q[i];
        rec[8 + i] = s->v[i];
    }
    rec[12] = s->delta;
    if (k->csv != NULL) {
        for (i = 0; i < 13; ++i) {
            if (fprintf(k->csv, i ? ",%.17g" : "%.17g", rec[i]) < 0) {
                return -1;
            }
        }
        fputc('\n', k->csv);
    }
    if (k->bin != NULL && fwrite(rec, sizeof rec, 1, k->bin) != 1) {
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
    if (s->delta > k->max_delta) {
        k->max_delta = s->delta;
    }
    if (s->delta > 0 && !k->in_contact) {
        k->in_contact = 1;
        k->episodes++;
        k->episode_start = s->t;
        if (!k->quiet && k->episodes <= 20) {
            fprintf(stderr, "contact from %.3f s", s->t);
        }
    } else if (s->delta <= 0 && k->in_contact) {
        k->in_contact = 0;
        if (!k->quiet && k->episodes <= 20) {
            fprintf(stderr, " to %.3f s\n", s->t);
        }
    }
    return 0;
}

int main(int argc, char **argv)
{
    const char *scenario = NULL, *out = "-", *bin = NULL;
    caekf_scenario_t sc;
    truth_sink_t sink;
    caekf_truth_options_t opt;
    char err[512] = "";
    caekf_output_t o_csv, o_bin;
    int i, rc;
    memset(&sink, 0, sizeof sink);
    caekf_truth_options_default(&opt);
    for (i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--scenario") == 0 && i + 1 < argc) {
            scenario = argv[++i];
        } else if (strcmp(argv[i], "--out") == 0 && i + 1 < argc) {
            out = argv[++i];
        } else if (strcmp(argv[i], "--bin") == 0 && i + 1 < argc) {
            bin = argv[++i];
        } else if (strcmp(argv[i], "--method") == 0 && i + 1 < argc) {
            ++i;
            if (strcmp(argv[i], "dop853") == 0) {
                opt.method = CAEKF_TRUTH_DOP853;
            } else if (strcmp(argv[i], "backward-euler") == 0) {
                opt.method = CAEKF_TRUTH_BACKWARD_EULER;
            } else {
                fprintf(stderr, "caekf-truth: unknown method '%s' (dop853, backward-euler)\n", argv[i]);
                return 2;
            }
        } else if ((strcmp(argv[i], "--rtol") == 0 || strcmp(argv[i], "--atol-q") == 0 ||
                    strcmp(argv[i], "--atol-v") == 0) && i + 1 < argc) {
            char *end;
            double v = strtod(argv[i + 1], &end);
            if (*end != '\0' || !(v > 0)) {
                fprintf(stderr, "caekf-truth: %s needs a positive number, got '%s'\n", argv[i], argv[i + 1]);
                return 2;
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
            return 0;
        } else {
            fprintf(stderr, "caekf-truth: unknown or incomplete argument '%s'\n", argv[i]);
            usage(stderr);
            return 2;
        }
    }
    if (scenario == NULL) {
        usage(stderr);
        return 2;
    }
    if (caekf_scenario_load(scenario, &sc, err, sizeof err) != 0) {
        fprintf(stderr, "caekf-truth: %s\n", err);
        return 3;
    }
    /* t_end / dt can ask for more rows than any tool reads (dt = 1e-12 or t_end = 1e9 filled the disk):
     * refused before anything is written. */
    if (!(sc.t_end / sc.dt <= (double)CAEKF_CSV_MAX_ROWS)) {
        fprintf(stderr, "caekf-truth: %s: t_end / dt = %.3g samples: the limit is %ld (what caekf-replay reads)\n",
                scenario, sc.t_end / sc.dt, CAEKF_CSV_MAX_ROWS);
        return 3;
    }
    /* Outputs are temporary files renamed at the end (common/tool.h): a failed run leaves nothing behind. */
    if (out != NULL) {
        if (caekf_output_open(&o_csv, out, err, sizeof err) != 0) {
            fprintf(stderr, "caekf-truth: %s\n", err);
            return 4;
        }
        sink.csv = o_csv.f;
    }
    if (bin != NULL) {
        if (caekf_output_open(&o_bin, bin, err, sizeof err) != 0) {
            fprintf(stderr, "caekf-truth: %s\n", err);
            if (out != NULL) {
                caekf_output_abort(&o_csv);
            }
            return 4;
        }
        sink.bin = o_bin.f;
    }
    if (sink.csv != NULL) {
        fputs("t,u,y1,y4,q1,q2,q3,q4,v1,v2,v3,v4,delta\n", sink.csv);
    }
    rc = caekf_truth_run(&sc, &opt, emit, &sink);
    if (sink.in_contact && !sink.quiet) {
        fputs(" (still in contact)\n", stderr);
    }
    if (rc == 0 && sink.newton_failed == 0) {
        if (out != NULL && caekf_output_commit(&o_csv, err, sizeof err) != 0) {
            out = NULL; /* removed by the failed commit */
            rc = -1;
        } else {
            out = NULL;
        }
        if (rc == 0 && bin != NULL && caekf_output_commit(&o_bin, err, sizeof err) != 0) {
            rc = -1;
        }
        bin = NULL;
    }
    if (out != NULL) {
        caekf_output_abort(&o_csv);
    }
    if (bin != NULL) {
        caekf_output_abort(&o_bin);
    }
    if (rc < 0) {
        fprintf(stderr, "caekf-truth: %s\n", err[0] != '\0' ? err : "failed writing output or setting up the model");
        return 4;
    }
    if (rc > 0) {
        fprintf(stderr, "caekf-truth: integration failed at t = %.6f s (step size below 1e-14 s or step budget): "
                "nothing written\n", (double)sink.samples * sc.dt);
        return 5;
    }
    if (sink.newton_failed) {
        fprintf(stderr, "caekf-truth: %ld Newton solves did not converge: nothing written\n", sink.newton_failed);
        return 5;
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
    return 0;
}
