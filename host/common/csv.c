#define _POSIX_C_SOURCE 200809L /* strtok_r */
#include "csv.h"
#include "tool.h"

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
    int col = 0, missing = 0;
    char *p;
    do {
        int rc = read_line(r, buf);
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
    if (r->have_prev) { /* t strictly increases; with dt > 0 it steps by dt */
        double d = v[0] - r->prev_t;
        char msg[200];
        if (!(d > 0)) {
            snprintf(msg, sizeof msg, "t = %.17g does not increase (previous row: %.17g): t must strictly increase",
                     v[0], r->prev_t);
            return fail(r, msg);
        }
        if (r->dt > 0 && fabs(d - r->dt) > CAEKF_CSV_DT_TOL * r->dt) {
            snprintf(msg, sizeof msg, "t steps by %.9g from the previous row, the scenario's dt is %.9g (tolerance %g %%)",
                     d, r->dt, 100.0 * CAEKF_CSV_DT_TOL);
            return fail(r, msg);
        }
    }
    r->prev_t = v[0];
    r->have_prev = 1;
    m->has_y = missing == 0;
    m->t = v[0];
    m->u = v[1];
    m->y1 = v[2];
    m->y4 = v[3];
    return 1;
}

long caekf_csv_read(const char *path, double dt, int allow_nonfinite, int allow_missing_y, caekf_meas_t **rows,
                    char *err, unsigned err_len)
{
    caekf_csv_t csv;
    caekf_meas_t m;
    caekf_meas_t *buf = NULL;
    long n = 0, cap = 0;
    int rc, is_stdin = strcmp(path, "-") == 0;
    const char *name = is_stdin ? "<stdin>" : path;
    FILE *f;
    *rows = NULL;
    if ((rc = caekf_tool_check_input(path, 1, err, err_len)) != 0) {
        return -rc;
    }
    f = is_stdin ? stdin : fopen(path, "r");
    if (f == NULL) {
        snprintf(err, err_len, "%s: cannot open: %s", path, strerror(errno));
        return -CAEKF_EXIT_IO;
    }
    rc = caekf_csv_open(&csv, f, name, allow_nonfinite);
    if (rc == 0) {
        csv.allow_missing_y = allow_missing_y;
        csv.dt = dt;
        while ((rc = caekf_csv_next(&csv, &m)) == 1) {
            if (n == CAEKF_CSV_MAX_ROWS) {
                snprintf(csv.err, sizeof csv.err, "%s:%lu: more than %ld data rows: the size limit is %ld rows",
                         name, csv.line, CAEKF_CSV_MAX_ROWS, CAEKF_CSV_MAX_ROWS);
                rc = -1;
                break;
            }
            if (n == cap) {
                long nc = cap == 0 ? 4096 : 2 * cap;
                caekf_meas_t *nb = realloc(buf, (size_t)nc * sizeof *nb);
                if (nb == NULL) {
                    snprintf(csv.err, sizeof csv.err, "%s:%lu: out of memory", name, csv.line);
                    rc = -2;
                    break;
                }
                buf = nb;
                cap = nc;
            }
            buf[n++] = m;
        }
    }
    if (rc == 0 && ferror(f)) {
        snprintf(csv.err, sizeof csv.err, "%s: read error: %s", name, strerror(errno));
        rc = -2;
    }
    if (rc == 0 && n == 0) {
        snprintf(csv.err, sizeof csv.err, "%s:%lu: no data rows after the header", name, csv.line);
        rc = -1;
    }
    if (!is_stdin) {
        fclose(f);
    }
    if (rc != 0) {
        snprintf(err, err_len, "%s", csv.err);
        free(buf);
        return rc == -2 ? -CAEKF_EXIT_IO : -CAEKF_EXIT_INPUT;
    }
    *rows = buf;
    return n;
}
