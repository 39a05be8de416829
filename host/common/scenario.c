#include "scenario.h"

#define CAEKF_PI 3.141592653589793238462643383279502884

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    const char *key;
    size_t offset;
} field_t;

#define F(name) {#name, offsetof(caekf_scenario_t, name)}
static const field_t fields[] = {
    F(m1), F(m2), F(m3), F(m4), F(k1), F(k12), F(k34), F(k4), F(c1), F(c12), F(c34), F(c4),
    F(gap), F(gamma), F(u_amp), F(u_freq), F(u_phase), F(dt), F(t_end), F(truth_substeps),
    F(noise_std), F(seed), F(gamma0), F(sigma_q0), F(sigma_v0), F(sigma_gamma0), F(sigma_qx_q),
    F(sigma_qx_v), F(sigma_q_gamma), F(sigma_r), F(gamma_min)};
#undef F
#define NFIELDS (sizeof fields / sizeof fields[0])

static char *trim(char *s)
{
    char *e;
    while (*s == ' ' || *s == '\t') {
        ++s;
    }
    e = s + strlen(s);
    while (e > s && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r' || e[-1] == '\n')) {
        *--e = '\0';
    }
    return s;
}

int caekf_scenario_load(const char *path, caekf_scenario_t *sc, char *err, unsigned err_len)
{
    char line[512];
    int seen[NFIELDS] = {0};
    unsigned lineno = 0;
    size_t i;
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        snprintf(err, err_len, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    memset(sc, 0, sizeof *sc);
    while (fgets(line, sizeof line, f) != NULL) {
        char *hash, *eq, *key, *val, *end;
        double v;
        ++lineno;
        if (strchr(line, '\n') == NULL && !feof(f)) {
            snprintf(err, err_len, "%s:%u: line too long", path, lineno);
            fclose(f);
            return -1;
        }
        hash = strchr(line, '#');
        if (hash != NULL) {
            *hash = '\0';
        }
        key = trim(line);
        if (*key == '\0') {
            continue;
        }
        eq = strchr(key, '=');
        if (eq == NULL) {
            snprintf(err, err_len, "%s:%u: expected 'key = value'", path, lineno);
            fclose(f);
            return -1;
        }
        *eq = '\0';
        key = trim(key);
        val = trim(eq + 1);
        errno = 0;
        v = strtod(val, &end);
        if (*val == '\0' || *end != '\0' || errno == ERANGE || !isfinite(v)) {
            snprintf(err, err_len, "%s:%u: '%s' is not a finite number", path, lineno, val);
            fclose(f);
            return -1;
        }
        for (i = 0; i < NFIELDS; ++i) {
            if (strcmp(key, fields[i].key) == 0) {
                break;
            }
        }
        if (i == NFIELDS) {
            snprintf(err, err_len, "%s:%u: unknown key '%s'", path, lineno, key);
            fclose(f);
            return -1;
        }
        if (seen[i]) {
            snprintf(err, err_len, "%s:%u: duplicate key '%s'", path, lineno, key);
            fclose(f);
            return -1;
        }
        seen[i] = 1;
        *(double *)((char *)sc + fields[i].offset) = v;
    }
    fclose(f);
    for (i = 0; i < NFIELDS; ++i) {
        if (!seen[i]) {
            snprintf(err, err_len, "%s: missing key '%s'", path, fields[i].key);
            return -1;
        }
    }
    if (!(sc->dt > 0) || !(sc->t_end > 0) || sc->truth_substeps < 1 || sc->noise_std < 0) {
        snprintf(err, err_len, "%s: need dt > 0, t_end > 0, truth_substeps >= 1, noise_std >= 0", path);
        return -1;
    }
    return 0;
}

double caekf_scenario_input(const caekf_scenario_t *sc, double t)
{
    return sc->u_amp * sin(2.0 * CAEKF_PI * sc->u_freq * t + sc->u_phase);
}

long caekf_scenario_steps(const caekf_scenario_t *sc) { return lround(sc->t_end / sc->dt); }
