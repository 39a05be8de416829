#define _POSIX_C_SOURCE 200809L /* strtok_r */
#include "csv.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MAX_LINE 4096

/* Reads one line; -1 at EOF, -2 when the line does not fit. Strips the line ending. */
static int read_line(caekf_csv_t *r, char *buf)
{
    size_t n;
    if (fgets(buf, MAX_LINE, r->f) == NULL) {
        return -1;
    }
    r->line++;
    n = strlen(buf);
    if (n > 0 && buf[n - 1] != '\n' && !feof(r->f)) {
        return -2;
    }
    while (n > 0 && (buf[n - 1] == '\n' || buf[n - 1] == '\r')) {
        buf[--n] = '\0';
    }
    return 0;
}

static int fail(caekf_csv_t *r, const char *what)
{
    snprintf(r->err, sizeof r->err, "%s:%lu: %s", r->name, r->line, what);
    return -1;
}

int caekf_csv_open(caekf_csv_t *r, FILE *f, const char *name, int allow_nonfinite)
{
    static const char *const want[4] = {"t", "u", "y1", "y4"};
    char buf[MAX_LINE];
    char *tok, *save = NULL;
    int col = 0, rc;
    memset(r, 0, sizeof *r);
    r->f = f;
    r->name = name;
    r->allow_nonfinite = allow_nonfinite;
    rc = read_line(r, buf);
    if (rc == -1) {
        r->line = 1;
        return fail(r, "empty input: expected a header 't,u,y1,y4'");
    }
    if (rc == -2) {
        return fail(r, "header line too long");
    }
    for (tok = strtok_r(buf, ",", &save); tok != NULL; tok = strtok_r(NULL, ",", &save)) {
        while (*tok == ' ') {
            ++tok;
        }
        if (col < 4 && strcmp(tok, want[col]) != 0) {
            char msg[128];
            snprintf(msg, sizeof msg, "bad header: column %d is '%.40s', expected '%s'", col + 1, tok, want[col]);
            return fail(r, msg);
        }
        col++;
    }
    if (col < 4) {
        return fail(r, "bad header: expected at least the columns t,u,y1,y4");
    }
    r->columns = col;
    return 0;
}

int caekf_csv_next(caekf_csv_t *r, caekf_meas_t *m)
{
    char buf[MAX_LINE];
    double v[4];
    int col = 0, rc, missing = 0;
    char *p;
    do {
        rc = read_line(r, buf);
        if (rc == -1) {
            return 0;
        }
        if (rc == -2) {
            return fail(r, "line too long");
        }
    } while (buf[0] == '\0'); /* blank lines are tolerated */
    p = buf;
    for (;;) {
        char *end;
        char *comma = strchr(p, ',');
        if (comma != NULL) {
            *comma = '\0';
        }
        if (col >= 2 && col < 4 && r->allow_missing_y && *p == '\0') {
            v[col] = 0; /* no measurement in this row */
            missing++;
        } else if (col < 4) {
            errno = 0;
            v[col] = strtod(p, &end);
            while (*end == ' ') {
                ++end;
            }
            if (end == p || *end != '\0') {
                char msg[128];
                snprintf(msg, sizeof msg, "column %d: '%.40s' is not a number", col + 1, p);
                return fail(r, msg);
            }
            if (!r->allow_nonfinite && !isfinite(v[col])) {
                char msg[128];
                snprintf(msg, sizeof msg, "column %d: non-finite value '%.40s'", col + 1, p);
                return fail(r, msg);
            }
        }
        col++;
        if (comma == NULL) {
            break;
        }
        p = comma + 1;
    }
    if (col != r->columns) {
        char msg[128];
        snprintf(msg, sizeof msg, "wrong column count: %d, the header has %d", col, r->columns);
        return fail(r, msg);
    }
    if (!isfinite(v[0])) {
        return fail(r, "column 1: t must be finite");
    }
    if (missing == 1) {
        return fail(r, "y1 and y4 must both be present or both be empty");
    }
    m->has_y = missing == 0;
    m->t = v[0];
    m->u = v[1];
    m->y1 = v[2];
    m->y4 = v[3];
    return 1;
}

long caekf_csv_load(const char *path, caekf_meas_t *rows, long max_rows, char *err, unsigned err_len)
{
    caekf_csv_t csv;
    caekf_meas_t extra;
    long n = 0;
    int rc;
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        snprintf(err, err_len, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    if (caekf_csv_open(&csv, f, path, 0) != 0) {
        fclose(f);
        snprintf(err, err_len, "%s", csv.err);
        return -1;
    }
    while (n < max_rows && (rc = caekf_csv_next(&csv, &rows[n])) == 1) {
        n++;
    }
    if (n == max_rows) {
        rc = caekf_csv_next(&csv, &extra);
        if (rc == 1) {
            snprintf(csv.err, sizeof csv.err, "%s: more than %ld rows", path, max_rows);
            rc = -1;
        }
    }
    fclose(f);
    if (rc < 0) {
        snprintf(err, err_len, "%s", csv.err);
        return -1;
    }
    return n;
}
