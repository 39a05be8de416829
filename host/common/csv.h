/* Reader for measurement CSVs: a header whose first columns are t,u,y1,y4, then numeric rows with the
 * header's column count and a strictly increasing t stepping by the scenario's dt (within
 * CAEKF_CSV_DT_TOL). Errors are one line: "FILE:LINE: rule". */
#ifndef CAEKF_HOST_CSV_H
#define CAEKF_HOST_CSV_H

#include <stdio.h>

typedef struct {
    FILE *f;
    const char *name;
    unsigned long line;
    int columns;
    int allow_nonfinite;
    int allow_missing_y;    /* empty y1 and y4 fields: a step without measurement */
    double dt;              /* > 0: t must step by dt (relative tolerance CAEKF_CSV_DT_TOL); 0: only increase */
    double prev_t;
    int have_prev;
    char err[512];
} caekf_csv_t;

typedef struct {
    double t, u, y1, y4;
    int has_y; /* 0 only for rows with empty y1, y4 when allow_missing_y */
} caekf_meas_t;

/* Reads and checks the header. Returns 0 or -1 (message in r->err). */
int caekf_csv_open(caekf_csv_t *r, FILE *f, const char *name, int allow_nonfinite);

/* Returns 1 with a row, 0 at end of input, -1 on a malformed row (message in r->err). */
int caekf_csv_next(caekf_csv_t *r, caekf_meas_t *m);

#define CAEKF_CSV_MAX_ROWS 2000000L /* whole-file loads: 33 min at 1 ms */
#define CAEKF_CSV_DT_TOL 0.01       /* |t[k] - t[k-1] - dt| <= 1 % of dt */

/* Reads a whole measurement CSV ("-": stdin) into a malloc'ed array (*rows, free() it), checking every
 * row before returning: header, column count, numbers, t strictly increasing (by dt when dt > 0), at least one
 * data row, at most CAEKF_CSV_MAX_ROWS rows. Returns the row count, or -CAEKF_EXIT_INPUT (bad content)
 * or -CAEKF_EXIT_IO (missing file, a directory, read error) with a one-line message in err. */
long caekf_csv_read(const char *path, double dt, int allow_nonfinite, int allow_missing_y, caekf_meas_t **rows,
                    char *err, unsigned err_len);

#endif
