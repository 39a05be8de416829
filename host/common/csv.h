/* Reader for measurement CSVs: a header whose first columns are the mechanism's measurement columns
 * (caekf_csv_columns: t, the inputs, the sensors; the paper's t,u,y1,y4), then numeric rows with the
 * header's column count and a strictly increasing t stepping by the scenario's dt (within
 * CAEKF_CSV_DT_TOL). Errors are one line: "FILE:LINE: rule". */
#ifndef CAEKF_HOST_CSV_H
#define CAEKF_HOST_CSV_H

#include <stdio.h>

#include "caekf/caekf_model.h"
#include "scenario.h"

#define CAEKF_CSV_NAME_LEN 12 /* "delta2", "yv8", "p_gg2" and their terminator */
#define CAEKF_CSV_MAX_COLUMNS (1 + CAEKF_MAX_INPUTS + CAEKF_MAX_SENSORS)

/* The measurement columns of a mechanism, in order: t; u (one input) or u1..u<ni>; one column per sensor,
 * y<body> (position) or yv<body> (velocity). The one place these names are made (caekf-truth writes
 * them, the readers expect them). */
typedef struct {
    int inputs, sensors, count; /* count = 1 + inputs + sensors */
    char name[CAEKF_CSV_MAX_COLUMNS][CAEKF_CSV_NAME_LEN];
} caekf_csv_columns_t;

/* Fills c from the mechanism (sizes already validated: within the capacity). Returns 0, or -1 when a
 * size is outside the capacity. */
int caekf_csv_columns(const caekf_model_params_t *p, caekf_csv_columns_t *c);

/* The measurement columns of a loaded scenario's mechanism (caekf_scenario_model, not validated here:
 * names only). Returns 0, or -1 when a size is outside the capacity (the reader's ranges exclude it). */
int caekf_csv_scenario_columns(const caekf_scenario_t *sc, caekf_csv_columns_t *c);

/* Names an element of a per-contact or per-body series: "base" when it is the only one (count == 1),
 * else "base<index + 1>"; with first_plain, element 0 is always "base" (gamma, gamma2, ...). */
void caekf_csv_series_name(char out[CAEKF_CSV_NAME_LEN], const char *base, int index, int count, int first_plain);

/* Writes names[0..count-1] joined by commas (no line end). Returns 0, or -1 on a write error. */
int caekf_csv_write_names(FILE *f, const caekf_csv_columns_t *c);

typedef struct {
    FILE *f;
    const char *name;
    unsigned long line;
    int columns;
    int allow_nonfinite;
    int allow_missing_y;      /* all sensor fields empty: a step without measurement */
    caekf_csv_columns_t want; /* the expected leading columns */
    double dt;                /* > 0: t must step by dt (relative tolerance CAEKF_CSV_DT_TOL); 0: only increase */
    double prev_t;
    int have_prev;
    char err[512];
} caekf_csv_t;

typedef struct {
    double t;
    double u[CAEKF_MAX_INPUTS];  /* want.inputs in use */
    double y[CAEKF_MAX_SENSORS]; /* want.sensors in use */
    int has_y;                   /* 0 only for rows whose sensor fields are all empty, when allow_missing_y */
} caekf_meas_t;

/* Reads and checks the header against want. Returns 0 or -1 (message in r->err). */
int caekf_csv_open(caekf_csv_t *r, FILE *f, const char *name, int allow_nonfinite, const caekf_csv_columns_t *want);

/* Returns 1 with a row, 0 at end of input, -1 on a malformed row (message in r->err). */
int caekf_csv_next(caekf_csv_t *r, caekf_meas_t *m);

#define CAEKF_CSV_MAX_ROWS 2000000L /* whole-file loads: 33 min at 1 ms */
#define CAEKF_CSV_DT_TOL 0.01       /* |t[k] - t[k-1] - dt| <= 1 % of dt */

/* Reads a whole measurement CSV ("-": stdin) into a malloc'ed array (*rows, free() it), checking every
 * row before returning: header, column count, numbers, t strictly increasing (by dt when dt > 0), at least one
 * data row, at most CAEKF_CSV_MAX_ROWS rows. Returns the row count, or -CAEKF_EXIT_INPUT (bad content)
 * or -CAEKF_EXIT_IO (missing file, a directory, read error) with a one-line message in err. */
/* A row's inputs and sensor readings in the estimator's scalar type (u: inputs, y: sensors). */
void caekf_meas_scalars(const caekf_meas_t *m, const caekf_csv_columns_t *c, caekf_scalar_t *u, caekf_scalar_t *y);

long caekf_csv_read(const char *path, const caekf_csv_columns_t *want, double dt, int allow_nonfinite,
                    int allow_missing_y, caekf_meas_t **rows, char *err, unsigned err_len);

/* caekf_csv_read with the columns of the scenario's mechanism (also returned in *want). */
long caekf_csv_read_for(const char *path, const caekf_scenario_t *sc, double dt, int allow_nonfinite,
                        int allow_missing_y, caekf_csv_columns_t *want, caekf_meas_t **rows, char *err,
                        unsigned err_len);

#endif
