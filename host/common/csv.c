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

int caekf_csv_columns(const caekf_model_params_t *p, caekf_csv_columns_t *c)
{
    int i, k = 0;
    if (p->inputs < 0 || p->inputs > CAEKF_MAX_INPUTS || p->sensors < 0 || p->sensors > CAEKF_MAX_SENSORS) {
        return -1;
    }
    memset(c, 0, sizeof *c);
    c->inputs = p->inputs;
    c->sensors = p->sensors;
    snprintf(c->name[k++], CAEKF_CSV_NAME_LEN, "t");
    for (i = 0; i < p->inputs; ++i) {
        caekf_csv_series_name(c->name[k++], "u", i, p->inputs, 0);
    }
    for (i = 0; i < p->sensors; ++i) { /* docs/sensors.md: y<body>, yv<body>, ya<body>, yr<body>_<ref>, yf<link> */
        static const char *const prefix[] = {"y", "yv", "ya", "yr", "yf"};
        const int kind = (int)p->sensor_kind[i];
        if (kind == CAEKF_SENSOR_RELATIVE) {
            snprintf(c->name[k++], CAEKF_CSV_NAME_LEN, "yr%d_%d", p->sensor_body[i] % 1000, p->sensor_ref[i] % 1000);
        } else if (kind == CAEKF_SENSOR_LINK_FORCE) {
            snprintf(c->name[k++], CAEKF_CSV_NAME_LEN, "yf%d", p->sensor_link[i] % 1000);
        } else {
            snprintf(c->name[k++], CAEKF_CSV_NAME_LEN, "%s%d", prefix[kind >= 0 && kind < 3 ? kind : 0],
                     p->sensor_body[i] % 1000);
        }
    }
    c->count = k;
    return 0;
}

int caekf_csv_scenario_columns(const caekf_scenario_t *sc, caekf_csv_columns_t *c)
{
    caekf_model_params_t p;
    caekf_scenario_model(sc, sc->dt, &p);
    return caekf_csv_columns(&p, c);
}

void caekf_meas_scalars(const caekf_meas_t *m, const caekf_csv_columns_t *c, caekf_scalar_t *u, caekf_scalar_t *y)
{
    int i;
    for (i = 0; i < c->inputs; ++i) {
        u[i] = (caekf_scalar_t)m->u[i];
    }
    for (i = 0; i < c->sensors; ++i) {
        y[i] = (caekf_scalar_t)m->y[i];
    }
}

void caekf_csv_series_name(char out[CAEKF_CSV_NAME_LEN], const char *base, int index, int count, int first_plain)
{
    if (count == 1 || (first_plain && index == 0)) {
        snprintf(out, CAEKF_CSV_NAME_LEN, "%.6s", base);
    } else {
        snprintf(out, CAEKF_CSV_NAME_LEN, "%.6s%d", base, (index + 1) % 1000);
    }
}

int caekf_csv_write_names(FILE *f, const caekf_csv_columns_t *c)
{
    int i;
    for (i = 0; i < c->count; ++i) {
        if (fprintf(f, i ? ",%s" : "%s", c->name[i]) < 0) {
            return -1;
        }
    }
    return 0;
}

/* "t,u,y1,y4" into buf. */
static void join_names(const caekf_csv_columns_t *c, char *buf, size_t len)
{
    size_t used = 0;
    int i;
    buf[0] = '\0';
    for (i = 0; i < c->count && used < len; ++i) {
        int n = snprintf(buf + used, len - used, i ? ",%s" : "%s", c->name[i]);
        if (n < 0) {
            break;
        }
        used += (size_t)n;
    }
}

int caekf_csv_open(caekf_csv_t *r, FILE *f, const char *name, int allow_nonfinite, const caekf_csv_columns_t *want)
{
    char buf[MAX_LINE], names[CAEKF_CSV_MAX_COLUMNS * CAEKF_CSV_NAME_LEN + 1];
    char *tok, *save = NULL;
    int col = 0, rc;
    memset(r, 0, sizeof *r);
    r->f = f;
    r->name = name;
    r->allow_nonfinite = allow_nonfinite;
    r->want = *want;
    join_names(want, names, sizeof names);
    rc = read_line(r, buf);
    if (rc == -1) {
        char msg[200];
        r->line = 1;
        snprintf(msg, sizeof msg, "empty input: expected a header '%s'", names);
        return fail(r, msg);
    }
    if (rc == -2) {
        return fail(r, "header line too long");
    }
    for (tok = strtok_r(buf, ",", &save); tok != NULL; tok = strtok_r(NULL, ",", &save)) {
        while (*tok == ' ') {
            ++tok;
        }
        if (col < want->count && strcmp(tok, want->name[col]) != 0) {
            char msg[128];
            snprintf(msg, sizeof msg, "bad header: column %d is '%.40s', expected '%s'", col + 1, tok, want->name[col]);
            return fail(r, msg);
        }
        col++;
    }
    if (col < want->count) {
        char msg[200];
        snprintf(msg, sizeof msg, "bad header: expected at least the columns %s", names);
        return fail(r, msg);
    }
    r->columns = col;
    return 0;
}

/* "y1 and y4 must both ...", "y1, yv2 and y3 must all ..." */
static int fail_partial(caekf_csv_t *r)
{
    char msg[200];
    size_t used = 0;
    int i, ns = r->want.sensors, first = 1 + r->want.inputs;
    for (i = 0; i < ns && used < sizeof msg; ++i) {
        const char *sep = i == 0 ? "" : i == ns - 1 ? " and " : ", ";
        int n = snprintf(msg + used, sizeof msg - used, "%s%s", sep, r->want.name[first + i]);
        if (n < 0) {
            break;
        }
        used += (size_t)n;
    }
    if (used < sizeof msg) {
        snprintf(msg + used, sizeof msg - used,
                 ns == 2 ? " must both be present or both be empty" : " must all be present or all be empty");
    }
    return fail(r, msg);
}

int caekf_csv_next(caekf_csv_t *r, caekf_meas_t *m)
{
    char buf[MAX_LINE];
    double v[CAEKF_CSV_MAX_COLUMNS];
    const int nw = r->want.count, y0 = 1 + r->want.inputs;
    int col = 0, missing = 0, i;
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
        if (col >= y0 && col < nw && r->allow_missing_y && *p == '\0') {
            v[col] = 0; /* no measurement in this row */
            missing++;
        } else if (col < nw) {
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
    if (missing > 0 && missing < r->want.sensors) {
        return fail_partial(r);
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
            snprintf(msg, sizeof msg,
                     "t steps by %.9g from the previous row, the scenario's dt is %.9g (tolerance %g %%)", d, r->dt,
                     100.0 * CAEKF_CSV_DT_TOL);
            return fail(r, msg);
        }
    }
    r->prev_t = v[0];
    r->have_prev = 1;
    m->has_y = missing == 0;
    m->t = v[0];
    for (i = 0; i < r->want.inputs; ++i) {
        m->u[i] = v[1 + i];
    }
    for (i = 0; i < r->want.sensors; ++i) {
        m->y[i] = v[y0 + i];
    }
    return 1;
}

long caekf_csv_read(const char *path, const caekf_csv_columns_t *want, double dt, int allow_nonfinite,
                    int allow_missing_y, caekf_meas_t **rows, char *err, unsigned err_len)
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
    rc = caekf_csv_open(&csv, f, name, allow_nonfinite, want);
    if (rc == 0) {
        csv.allow_missing_y = allow_missing_y;
        csv.dt = dt;
        while ((rc = caekf_csv_next(&csv, &m)) == 1) {
            if (n == CAEKF_CSV_MAX_ROWS) {
                snprintf(csv.err, sizeof csv.err, "%s:%lu: more than %ld data rows: the size limit is %ld rows", name,
                         csv.line, CAEKF_CSV_MAX_ROWS, CAEKF_CSV_MAX_ROWS);
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

long caekf_csv_read_for(const char *path, const caekf_scenario_t *sc, double dt, int allow_nonfinite,
                        int allow_missing_y, caekf_csv_columns_t *want, caekf_meas_t **rows, char *err,
                        unsigned err_len)
{
    *rows = NULL;
    if (caekf_csv_scenario_columns(sc, want) != 0) {
        snprintf(err, err_len, "%s: more inputs or sensors than this build holds", path);
        return -CAEKF_EXIT_INPUT;
    }
    return caekf_csv_read(path, want, dt, allow_nonfinite, allow_missing_y, rows, err, err_len);
}
