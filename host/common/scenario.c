#include "scenario.h"

#define CAEKF_PI 3.141592653589793238462643383279502884

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

#define NKEYS CAEKF_SCENARIO_KEY_COUNT
#define NROWS CAEKF_SCENARIO_ROW_COUNT

static double *slot(caekf_scenario_t *sc, unsigned k)
{
    return (double *)(void *)((char *)sc + caekf_scenario_keys[k].offset);
}

/* An enum written by name ("velocity", quoted as TOML wants): its index in names ("a|b"), or -1. */
static int enum_index(const char *names, const char *val)
{
    size_t n = strlen(val);
    int i = 0;
    if (names == NULL || n < 2 || val[0] != '"' || val[n - 1] != '"') {
        return -1;
    }
    while (*names != '\0') {
        size_t len = strcspn(names, "|");
        if (len == n - 2 && strncmp(names, val + 1, len) == 0) {
            return i;
        }
        names += len + (names[len] == '|');
        ++i;
    }
    return -1;
}

/* Whether key k's element is in use: its array's count (already final) covers it. */
static int in_use(const caekf_scenario_t *sc, unsigned k)
{
    const caekf_scenario_key_t *key = &caekf_scenario_keys[k];
    return key->in_use_key < 0 ||
           (double)key->index <
               *(const double *)(const void *)((const char *)sc + caekf_scenario_keys[key->in_use_key].offset);
}

static int fail(FILE *f, char *err, unsigned err_len, const char *fmt, const char *path, unsigned lineno,
                const char *what)
{
    if (f != NULL) {
        fclose(f);
    }
    snprintf(err, err_len, fmt, path, lineno, what);
    return -1;
}

int caekf_scenario_load(const char *path, caekf_scenario_t *sc, char *err, unsigned err_len)
{
    char line[512];
    unsigned char seen[NKEYS];
    unsigned lineno = 0;
    unsigned i;
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        snprintf(err, err_len, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    memset(seen, 0, sizeof seen);
    memset(sc, 0, sizeof *sc);
    for (i = 0; i < NKEYS; ++i) {
        *slot(sc, i) = caekf_scenario_keys[i].default_value;
    }
    while (fgets(line, sizeof line, f) != NULL) {
        char *hash, *eq, *key, *val, *end;
        double v;
        ++lineno;
        if (strchr(line, '\n') == NULL && !feof(f)) {
            return fail(f, err, err_len, "%s:%u: line too long%s", path, lineno, "");
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
            return fail(f, err, err_len, "%s:%u: expected 'key = value'%s", path, lineno, "");
        }
        *eq = '\0';
        key = trim(key);
        val = trim(eq + 1);
        for (i = 0; i < NROWS; ++i) {
            if (strcmp(key, caekf_scenario_keys[i].key) == 0) {
                break;
            }
        }
        if (i == NROWS) {
            return fail(f, err, err_len, "%s:%u: unknown key '%s'", path, lineno, key);
        }
        i = caekf_scenario_keys[i].canonical; /* an alias sets its key */
        if (seen[i]) {
            return fail(f, err, err_len, "%s:%u: duplicate key '%s' (or another name of it)", path, lineno, key);
        }
        errno = 0;
        v = strtod(val, &end);
        if (enum_index(caekf_scenario_keys[i].enum_names, val) >= 0) {
            v = (double)enum_index(caekf_scenario_keys[i].enum_names, val);
            end = val + strlen(val);
        }
        if (*val == '\0' || *end != '\0' || errno == ERANGE ||
            !caekf_setting_rule_ok((unsigned)caekf_scenario_keys[i].rule_code, caekf_scenario_keys[i].lo,
                                   caekf_scenario_keys[i].hi, v)) {
            char what[160];
            snprintf(what, sizeof what, "%s = %s: %s", key, val, caekf_scenario_keys[i].rule);
            return fail(f, err, err_len, "%s:%u: %s", path, lineno, what);
        }
        seen[i] = 1;
        sc->given[i] = 1;
        *slot(sc, i) = v;
    }
    fclose(f);
    for (i = 0; i < NKEYS; ++i) {
        const caekf_scenario_key_t *k = &caekf_scenario_keys[i];
        if (seen[i] && !in_use(sc, i)) {
            snprintf(err, err_len, "%s: %s is given, but %s = %g leaves it unused", path, k->key,
                     caekf_scenario_keys[k->in_use_key].key, *slot(sc, (unsigned)k->in_use_key));
            return -1;
        }
        /* A truth-only key (no wire id) is needed only to simulate a truth: caekf_scenario_need_truth. */
        if (!seen[i] && k->required && k->param_id >= 0 && in_use(sc, i)) {
            snprintf(err, err_len, "%s: missing key '%s' (it has no default)", path, k->key);
            return -1;
        }
    }
    return 0;
}

int caekf_scenario_need_truth(const caekf_scenario_t *sc, const char *path, char *err, unsigned err_len)
{
    unsigned i;
    for (i = 0; i < NKEYS; ++i) {
        const caekf_scenario_key_t *k = &caekf_scenario_keys[i];
        if (k->param_id < 0 && k->required && !sc->given[i] && in_use(sc, i)) {
            snprintf(err, err_len, "%s: missing key '%s' (it has no default; simulating a truth needs it)", path,
                     k->key);
            return -1;
        }
    }
    return 0;
}

const caekf_preset_t *caekf_preset_find(const char *name)
{
    unsigned i;
    for (i = 0; name != NULL && i < CAEKF_PRESET_COUNT; ++i) {
        if (strcmp(caekf_presets[i].name, name) == 0) {
            return &caekf_presets[i];
        }
    }
    return NULL;
}

/* The wire settings the file gave, set by parameter id over what s holds. Returns 0, or -1 with *e. */
static int set_given(const caekf_scenario_t *sc, caekf_settings_t *s, caekf_setting_error_t *e)
{
    unsigned i;
    for (i = 0; i < NKEYS; ++i) {
        const caekf_scenario_key_t *k = &caekf_scenario_keys[i];
        if (k->param_id >= 0 && sc->given[i] &&
            caekf_settings_set(s, (unsigned)k->param_id, *(const double *)(const void *)((const char *)sc + k->offset),
                               e) != CAEKF_OK) {
            return -1;
        }
    }
    return 0;
}

int caekf_scenario_settings(const caekf_scenario_t *sc, const caekf_preset_t *preset, caekf_settings_t *s,
                            const char *path, char *err, unsigned err_len)
{
    caekf_setting_error_t e;
    char text[200];
    unsigned i;
    (void)caekf_settings_default(s); /* the defaults of this build (newton_rtol scales with its epsilon) */
    if (set_given(sc, s, &e) != 0) {
        (void)caekf_setting_error_text(&e, s, text, sizeof text);
        snprintf(err, err_len, "%s: %s", path, text);
        return -1;
    }
    for (i = 0; preset != NULL && i < preset->n_values; ++i) {
        (void)caekf_settings_set(s, preset->param_id[i], preset->value[i], NULL); /* checked by the generator */
    }
    if (caekf_settings_validate(s, &e) != CAEKF_OK) {
        (void)caekf_setting_error_text(&e, s, text, sizeof text);
        snprintf(err, err_len, "%s: %s%s%s%s", path, text, preset != NULL ? " (with preset " : "",
                 preset != NULL ? preset->name : "", preset != NULL ? ")" : "");
        return -1;
    }
    return 0;
}

void caekf_scenario_model(const caekf_scenario_t *sc, double dt, caekf_model_params_t *p)
{
    caekf_settings_t s;
    caekf_setting_error_t e;
    (void)caekf_settings_default(&s);
    (void)set_given(sc, &s, &e); /* the model's keys are required, so always given */
    *p = s.model;
    p->dt = (caekf_scalar_t)dt;
}

int caekf_scenario_value(const caekf_scenario_t *sc, const char *key, double *v)
{
    unsigned i;
    for (i = 0; i < NROWS; ++i) {
        if (strcmp(key, caekf_scenario_keys[i].key) == 0) {
            *v = *(const double *)(const void *)((const char *)sc +
                                                 caekf_scenario_keys[caekf_scenario_keys[i].canonical].offset);
            return 0;
        }
    }
    return -1;
}

double caekf_scenario_input(const caekf_scenario_t *sc, double t)
{
    return sc->input1_amp * sin(2.0 * CAEKF_PI * sc->input1_freq * t + sc->input1_phase);
}

long caekf_scenario_steps(const caekf_scenario_t *sc) { return lround(sc->t_end / sc->dt); }
