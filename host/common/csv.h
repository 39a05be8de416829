/* Reader for measurement CSVs: a header whose first columns are t,u,y1,y4, then numeric rows with the
 * header's column count. Errors carry the line number. */
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
    char err[256];
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

/* Reads a whole measurement CSV file into rows[0..max_rows). Returns the row count, or -1 with a
 * message (unreadable file, malformed row, more than max_rows rows) in err. */
long caekf_csv_load(const char *path, caekf_meas_t *rows, long max_rows, char *err, unsigned err_len);

#endif
