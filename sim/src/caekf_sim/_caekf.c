/*
 * The C estimator (firmware/core) as a CPython extension module. Compiled twice by sim/CMakeLists.txt from
 * this one file: caekf_sim._caekf_double (CAEKF_USE_FLOAT=0) and caekf_sim._caekf_float (CAEKF_USE_FLOAT=1).
 * This is the low-level layer; caekf_sim.binding wraps it (numpy arrays, settings objects, documentation).
 *
 * Nothing here re-implements the estimator: settings are filled and checked by caekf_settings_default /
 * caekf_settings_validate (by parameter id: the schema's), scenarios map to settings through
 * host/common/scenario.c (the code caekf-replay runs), and the loop of `Estimator._run` calls caekf_step / caekf_predict and the accessors
 * exactly as caekf-replay does. Only the numpy-free plumbing (dicts, buffers) lives in this file.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "caekf/caekf.h"
#include "common/scenario.h"
#if !CAEKF_USE_FLOAT
#include "common/truth.h" /* the truth is double only: host/common/truth.c, as caekf-truth runs it */
#endif

#define CB_CAT2(a, b) a##b
#define CB_CAT(a, b) CB_CAT2(a, b)
#define CB_STR2(a) #a
#define CB_STR(a) CB_STR2(a)
#define CB_MODNAME CB_STR(CAEKF_BIND_MODULE)

#ifndef CAEKF_BIND_SOURCE_HASH
#define CAEKF_BIND_SOURCE_HASH "unknown"
#endif

/* ---- settings as values by parameter id --------------------------------------------------------------
 * Settings travel as a sequence of CAEKF_PARAM_COUNT numbers indexed by CTRL_PARAM id (the settings schema's
 * ids): caekf_settings_set / caekf_settings_get do the addressing, so no setting is named in this file. */

static PyObject *settings_error(const caekf_setting_error_t *err, const caekf_settings_t *s)
{
    char text[200];
    (void)caekf_setting_error_text(err, s, text, sizeof text);
    PyErr_Format(PyExc_ValueError, "settings refused: %s", text); /* caekf-replay's message */
    return NULL;
}

/* Defaults (caekf_settings_default), then every value of `seq`. Values are only converted here; checking
 * their ranges is caekf_settings_validate's job. */
static int settings_from_values(PyObject *seq_obj, caekf_settings_t *s)
{
    PyObject *seq = PySequence_Fast(seq_obj, "settings must be a sequence of numbers by parameter id");
    Py_ssize_t i, n;
    int rc = 0;
    (void)caekf_settings_default(s);
    if (seq == NULL) {
        return -1;
    }
    n = PySequence_Fast_GET_SIZE(seq);
    if (n != (Py_ssize_t)CAEKF_PARAM_COUNT) {
        PyErr_Format(PyExc_ValueError, "settings need %u values (one per parameter id), got %zd",
                     (unsigned)CAEKF_PARAM_COUNT, n);
        Py_DECREF(seq);
        return -1;
    }
    for (i = 0; i < n && rc == 0; ++i) {
        caekf_setting_error_t err;
        double v = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, i)), stored;
        if (v == 0.0 && caekf_settings_get(s, (unsigned)i, &stored) != CAEKF_OK) {
            continue; /* an element beyond this build's capacity reads as 0 (settings_to_values) */
        }
        if (v == -1.0 && PyErr_Occurred()) {
            PyErr_Format(PyExc_TypeError, "setting %s needs a number", caekf_param_key((unsigned)i));
            rc = -1;
        } else if (caekf_settings_set(s, (unsigned)i, v, &err) != CAEKF_OK) {
            (void)settings_error(&err, s);
            rc = -1;
        }
    }
    Py_DECREF(seq);
    return rc;
}

static PyObject *settings_to_values(const caekf_settings_t *s)
{
    PyObject *t = PyTuple_New((Py_ssize_t)CAEKF_PARAM_COUNT);
    unsigned i;
    for (i = 0; t != NULL && i < CAEKF_PARAM_COUNT; ++i) {
        double v = 0.0;
        PyObject *f;
        (void)caekf_settings_get(s, i, &v);
        f = PyFloat_FromDouble(v);
        if (f == NULL) {
            Py_DECREF(t);
            return NULL;
        }
        PyTuple_SET_ITEM(t, (Py_ssize_t)i, f);
    }
    return t;
}

/* ---- scenario (host/common/scenario.h, keys from the schema) ------------------------------------------ */

/* The keys `dict` gives are set and marked given; the others keep the schema's default (an error when the
 * key has none and `need_all`). */
static int scenario_from_dict(PyObject *dict, caekf_scenario_t *sc, int need_all)
{
    unsigned i;
    memset(sc, 0, sizeof *sc);
    if (!PyDict_Check(dict)) {
        PyErr_SetString(PyExc_TypeError, "scenario must be a dict of scenario keys");
        return -1;
    }
    for (i = 0; i < CAEKF_SCENARIO_KEY_COUNT; ++i) {
        const caekf_scenario_key_t *k = &caekf_scenario_keys[i];
        PyObject *v = PyDict_GetItemString(dict, k->key);
        double d = k->default_value;
        if (v != NULL) {
            d = PyFloat_AsDouble(v);
            if (d == -1.0 && PyErr_Occurred()) {
                PyErr_Format(PyExc_TypeError, "scenario key %s needs a number", k->key);
                return -1;
            }
            sc->given[i] = 1;
        } else if (k->required && need_all) {
            PyErr_Format(PyExc_KeyError, "scenario lacks '%s'", k->key);
            return -1;
        }
        *(double *)(void *)((char *)sc + k->offset) = d;
    }
    return 0;
}

/* ---- buffers ---------------------------------------------------------------------------------------- */

/* A C-contiguous buffer of `n` items of format `fmt` (one struct character) and item size `size`, or None
 * when `optional`. Returns 0 (view->buf NULL for None) or -1 with an exception. */
static int get_buffer(PyObject *obj, Py_buffer *view, const char *what, char fmt, Py_ssize_t size, Py_ssize_t n,
                      int writable, int optional)
{
    const char *f;
    memset(view, 0, sizeof *view);
    if (obj == Py_None && optional) {
        return 0;
    }
    if (PyObject_GetBuffer(obj, view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0)) != 0) {
        PyErr_Clear();
        PyErr_Format(PyExc_TypeError, "%s must be a C-contiguous%s array", what, writable ? " writable" : "");
        return -1;
    }
    f = view->format ? view->format : "B";
    if (*f == '<' || *f == '=' || *f == '@') {
        ++f;
    }
    if (view->itemsize != size || f[0] != fmt || f[1] != '\0' || view->len != n * size) {
        PyErr_Format(PyExc_ValueError, "%s must hold %zd items of format '%c' (got %zd of '%s')", what, n, fmt,
                     view->itemsize ? view->len / view->itemsize : 0, view->format ? view->format : "B");
        PyBuffer_Release(view);
        view->buf = NULL;
        return -1;
    }
    return 0;
}

/* ---- Report: the caller's tuple subclass (a NamedTuple), shared by both modules ------------------------ */

static PyTypeObject *report_type = NULL;

static PyObject *make_report(caekf_status_t st, const caekf_report_t *rep)
{
    PyObject *t;
    if (report_type == NULL) {
        t = PyTuple_New(5);
    } else {
        t = report_type->tp_alloc(report_type, 5);
    }
    if (t == NULL) {
        return NULL;
    }
    PyTuple_SET_ITEM(t, 0, PyLong_FromUnsignedLong((unsigned long)rep->flags));
    PyTuple_SET_ITEM(t, 1, PyFloat_FromDouble((double)rep->nis));
    PyTuple_SET_ITEM(t, 2, PyLong_FromLong(rep->newton_iters));
    PyTuple_SET_ITEM(t, 3, PyFloat_FromDouble((double)rep->delta));
    PyTuple_SET_ITEM(t, 4, PyLong_FromLong((long)st));
    if (PyTuple_GET_ITEM(t, 0) == NULL || PyTuple_GET_ITEM(t, 1) == NULL || PyTuple_GET_ITEM(t, 2) == NULL ||
        PyTuple_GET_ITEM(t, 3) == NULL || PyTuple_GET_ITEM(t, 4) == NULL) {
        Py_DECREF(t);
        return NULL;
    }
    return t;
}

/* ---- Estimator ------------------------------------------------------------------------------------- */

/* The sizes of the mechanism an instance runs (caekf_get_sizes, after init): n states
 * x = [q_1..q_nq, v_1..v_nq, gamma_1..gamma_nc], ny sensors, nu inputs. */
/* A structure given as matrices (Estimator(settings, structure=...), docs/structure.md): the caller's float64
 * arrays in the build's scalar, kept for reset (caekf_init_structure reads them once). */
typedef struct {
    caekf_scalar_t mass[CAEKF_NQ], k[CAEKF_NQ * CAEKF_NQ], c[CAEKF_NQ * CAEKF_NQ];
    caekf_scalar_t bu[CAEKF_NQ * CAEKF_MAX_INPUTS], w[CAEKF_MAX_CONTACTS * CAEKF_NQ], h[CAEKF_MAX_SENSORS * CAEKF_NQ];
    caekf_structure_t st;
} structure_copy_t;

typedef struct {
    PyObject_HEAD
    caekf_t est;
    caekf_settings_t settings;
    structure_copy_t structure;
    int has_structure;
    int ready;
    int n, ny, nu, nq, nc;
} EstObject;

static void est_sizes(EstObject *self)
{
    (void)caekf_get_sizes(&self->est, &self->n, &self->ny, &self->nu);
    self->nc = self->est.cfg.model.contacts;
    self->nq = self->est.model.nq; /* n also counts the law's and the mechanism's parameters */
}

/* Parses structure = (dofs, mass, K, C, Bu, W, H), float64 arrays of dofs, dofs x dofs (twice), dofs x inputs,
 * contacts x dofs and sensors x dofs entries (C-contiguous; Bu None without inputs), into self->structure. */
static int structure_from_tuple(EstObject *self, PyObject *tuple)
{
    const caekf_model_params_t *p = &self->settings.model;
    structure_copy_t *sc = &self->structure;
    caekf_scalar_t *dst[6];
    Py_ssize_t count[6];
    static const char *names[6] = {"mass", "K", "C", "Bu", "W", "H"};
    long dofs;
    int i;
    if (!PyTuple_Check(tuple) || PyTuple_GET_SIZE(tuple) != 7) {
        PyErr_SetString(PyExc_TypeError, "structure must be (dofs, mass, K, C, Bu, W, H)");
        return -1;
    }
    dofs = PyLong_AsLong(PyTuple_GET_ITEM(tuple, 0));
    if (dofs == -1 && PyErr_Occurred()) {
        return -1;
    }
    if (dofs < 1 || dofs > CAEKF_NQ) {
        PyErr_Format(PyExc_ValueError, "structure: %ld degrees of freedom, this build takes 1 .. %d", dofs, CAEKF_NQ);
        return -1;
    }
    dst[0] = sc->mass, dst[1] = sc->k, dst[2] = sc->c, dst[3] = sc->bu, dst[4] = sc->w, dst[5] = sc->h;
    count[0] = dofs, count[1] = dofs * dofs, count[2] = dofs * dofs, count[3] = dofs * p->inputs;
    count[4] = p->contacts * dofs, count[5] = p->sensors * dofs;
    memset(sc, 0, sizeof *sc);
    for (i = 0; i < 6; ++i) {
        Py_buffer v;
        Py_ssize_t k;
        if (get_buffer(PyTuple_GET_ITEM(tuple, i + 1), &v, names[i], 'd', sizeof(double), count[i], 0,
                       count[i] == 0) != 0) {
            return -1;
        }
        for (k = 0; k < count[i] && v.buf != NULL; ++k) {
            dst[i][k] = (caekf_scalar_t)((const double *)v.buf)[k];
        }
        PyBuffer_Release(&v);
    }
    sc->st.dofs = (int)dofs;
    sc->st.mass = sc->mass;
    sc->st.stiffness = sc->k;
    sc->st.damping = sc->c;
    sc->st.inputs = sc->bu;
    sc->st.contacts = sc->w;
    sc->st.sensors = sc->h;
    self->has_structure = 1;
    return 0;
}

/* caekf_init, or caekf_init_structure for an instance given a structure. */
static caekf_status_t est_init_c(EstObject *self)
{
    return self->has_structure ? caekf_init_structure(&self->est, &self->settings, &self->structure.st)
                               : caekf_init(&self->est, &self->settings);
}

static int est_init(EstObject *self, PyObject *args, PyObject *kwds)
{
    PyObject *values, *structure = Py_None;
    caekf_setting_error_t err;
    static char *kwlist[] = {"settings", "structure", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O|O:Estimator", kwlist, &values, &structure)) {
        return -1;
    }
    if (settings_from_values(values, &self->settings) != 0) {
        return -1;
    }
    if (caekf_settings_validate(&self->settings, &err) != CAEKF_OK) {
        (void)settings_error(&err, &self->settings);
        return -1;
    }
    self->has_structure = 0;
    if (structure != Py_None && structure_from_tuple(self, structure) != 0) {
        return -1;
    }
    if (est_init_c(self) != CAEKF_OK) {
        PyErr_SetString(PyExc_ValueError, self->has_structure
                                              ? "structure refused: a line's sensor kind, input kind or declared "
                                                "mass or link, K or C not symmetric, or M not positive"
                                              : "estimator initialisation failed");
        return -1;
    }
    est_sizes(self);
    self->ready = 1;
    return 0;
}

static int check_ready(EstObject *self)
{
    if (!self->ready) {
        PyErr_SetString(PyExc_RuntimeError, "estimator not initialised");
        return -1;
    }
    return 0;
}

/* `count` numbers into out: a tuple or list, any 1-D buffer of doubles (a numpy row) or another sequence.
 * `what` names them in the one-line error: "y needs 2 numbers (one per sensor [m or m/s])". A sequence
 * of another length is a ValueError, anything else a TypeError. */
static int parse_values(PyObject *obj, double *out, int count, const char *what, const char *each)
{
    Py_ssize_t len = -1;
    int i;
    if (PyTuple_CheckExact(obj) || PyList_CheckExact(obj)) {
        len = PySequence_Fast_GET_SIZE(obj);
        if (len == count) {
            for (i = 0; i < count; ++i) {
                out[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(obj, i));
                if (out[i] == -1.0 && PyErr_Occurred()) {
                    break;
                }
            }
            if (i == count) {
                return 0;
            }
        }
    } else if (PyObject_CheckBuffer(obj)) {
        Py_buffer v;
        if (PyObject_GetBuffer(obj, &v, PyBUF_FORMAT | PyBUF_STRIDES) == 0) {
            const char *f = v.format ? v.format : "B";
            if (*f == '<' || *f == '=' || *f == '@') {
                ++f;
            }
            if (v.ndim == 1 && f[0] == 'd' && f[1] == '\0') {
                len = v.shape[0];
                if (len == count) {
                    for (i = 0; i < count; ++i) {
                        out[i] = *(const double *)(const void *)((const char *)v.buf + i * v.strides[0]);
                    }
                    PyBuffer_Release(&v);
                    return 0;
                }
            }
            PyBuffer_Release(&v);
        }
        PyErr_Clear();
    }
    if (len < 0 || len == count) {
        PyObject *seq = PySequence_Check(obj) ? PySequence_Fast(obj, "") : NULL;
        if (seq != NULL) {
            len = PySequence_Fast_GET_SIZE(seq);
            for (i = 0; len == count && i < count; ++i) {
                out[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, i));
                if (out[i] == -1.0 && PyErr_Occurred()) {
                    len = -1;
                }
            }
            Py_DECREF(seq);
            if (len == count) {
                return 0;
            }
        }
    }
    PyErr_Clear();
    if (len >= 0 && len != count) {
        PyErr_Format(PyExc_ValueError, "%s needs %d number%s (%s), got %zd", what, count, count == 1 ? "" : "s",
                     each, len);
    } else {
        PyErr_Format(PyExc_TypeError, "%s must be a sequence of %d number%s (%s)", what, count,
                     count == 1 ? "" : "s", each);
    }
    return -1;
}

/* A number rather than a sequence: a float, an int, a numpy scalar or 0-d array, anything else that is
 * no sequence (PyFloat_AsDouble then decides). */
static int is_number(PyObject *obj)
{
    Py_buffer v;
    int ndim;
    if (PyFloat_Check(obj) || PyLong_Check(obj) || !PySequence_Check(obj)) {
        return 1;
    }
    if (!PyObject_CheckBuffer(obj) || PyObject_GetBuffer(obj, &v, PyBUF_FORMAT | PyBUF_STRIDES) != 0) {
        PyErr_Clear();
        return 0;
    }
    ndim = v.ndim;
    PyBuffer_Release(&v);
    return ndim == 0;
}

/* The inputs u: a number when the mechanism has one input, else a sequence of `inputs` numbers (None or an
 * empty sequence without inputs). */
static int parse_u(const EstObject *self, PyObject *obj, caekf_scalar_t *u)
{
    double ud[CAEKF_MAX_INPUTS + 1];
    int i;
    if (self->nu == 0 && obj == Py_None) {
        return 0;
    }
    if (self->nu == 1 && is_number(obj)) {
        ud[0] = PyFloat_AsDouble(obj);
        if (ud[0] == -1.0 && PyErr_Occurred()) {
            PyErr_Clear();
            PyErr_SetString(PyExc_TypeError, "u must be a number (the input force [N])");
            return -1;
        }
    } else if (parse_values(obj, ud, self->nu, "u", "one force per input [N]") != 0) {
        return -1;
    }
    for (i = 0; i < self->nu; ++i) {
        u[i] = (caekf_scalar_t)ud[i];
    }
    return 0;
}

static PyObject *est_step(EstObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double yd[CAEKF_MAX_SENSORS];
    caekf_scalar_t u[CAEKF_MAX_INPUTS + 1], y[CAEKF_MAX_SENSORS];
    caekf_report_t rep;
    caekf_status_t st;
    int i;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "step(u, y) takes the inputs u [N] and the measurements y [m or m/s]");
        return NULL;
    }
    if (check_ready(self) != 0 || parse_u(self, args[0], u) != 0 ||
        parse_values(args[1], yd, self->ny, "y", "one per sensor [m or m/s]") != 0) {
        return NULL;
    }
    for (i = 0; i < self->ny; ++i) {
        y[i] = (caekf_scalar_t)yd[i];
    }
    st = caekf_step(&self->est, u, y, &rep);
    return make_report(st, &rep);
}

static PyObject *est_predict(EstObject *self, PyObject *arg)
{
    caekf_scalar_t u[CAEKF_MAX_INPUTS + 1];
    caekf_report_t rep;
    caekf_status_t st;
    if (check_ready(self) != 0 || parse_u(self, arg, u) != 0) {
        return NULL;
    }
    st = caekf_predict(&self->est, u, &rep);
    return make_report(st, &rep);
}

static PyObject *est_state_into(EstObject *self, PyObject *arg)
{
    Py_buffer v;
    caekf_scalar_t x[CAEKF_N];
    int i;
    if (check_ready(self) != 0 || get_buffer(arg, &v, "out", 'd', sizeof(double), self->n, 1, 0) != 0) {
        return NULL;
    }
    (void)caekf_get_state(&self->est, x);
    for (i = 0; i < self->n; ++i) {
        ((double *)v.buf)[i] = (double)x[i];
    }
    PyBuffer_Release(&v);
    Py_RETURN_NONE;
}

static PyObject *est_cov_into(EstObject *self, PyObject *arg)
{
    Py_buffer v;
    caekf_scalar_t P[CAEKF_N][CAEKF_N];
    int i, j;
    if (check_ready(self) != 0 ||
        get_buffer(arg, &v, "out", 'd', sizeof(double), (Py_ssize_t)self->n * self->n, 1, 0) != 0) {
        return NULL;
    }
    (void)caekf_get_covariance(&self->est, P);
    for (i = 0; i < self->n; ++i) {
        for (j = 0; j < self->n; ++j) {
            ((double *)v.buf)[i * self->n + j] = (double)P[i][j];
        }
    }
    PyBuffer_Release(&v);
    Py_RETURN_NONE;
}

static PyObject *est_gamma(EstObject *self, void *closure)
{
    caekf_scalar_t g = 0;
    (void)closure;
    if (check_ready(self) != 0) {
        return NULL;
    }
    if (caekf_get_gamma(&self->est, &g) != CAEKF_OK) {
        PyErr_SetString(PyExc_ValueError, "this mechanism has no contact, so no gamma");
        return NULL;
    }
    return PyFloat_FromDouble((double)g);
}

static PyObject *est_p_norm(EstObject *self, PyObject *unused)
{
    caekf_scalar_t n = 0;
    (void)unused;
    if (check_ready(self) != 0) {
        return NULL;
    }
    (void)caekf_get_cov_norm2(&self->est, &n);
    return PyFloat_FromDouble((double)n);
}

static PyObject *est_mismatch(EstObject *self, PyObject *unused)
{
    caekf_scalar_t mean = 0, q_scale = 0;
    (void)unused;
    if (check_ready(self) != 0) {
        return NULL;
    }
    (void)caekf_get_mismatch(&self->est, &mean, &q_scale);
    return Py_BuildValue("(dd)", (double)mean, (double)q_scale);
}

static PyObject *est_step_count(EstObject *self, void *closure)
{
    (void)closure;
    return PyLong_FromUnsignedLong((unsigned long)self->est.step_count);
}

/* The mechanism's sizes (0 before init). */
static PyObject *est_size(EstObject *self, void *closure)
{
    const char *which = (const char *)closure;
    int v = which[0] == 'n' ? self->n : which[0] == 's' ? self->ny : which[0] == 'i' ? self->nu
                                      : which[0] == 'b' ? self->nq : self->nc;
    return PyLong_FromLong(v);
}

static PyObject *est_last_flags(EstObject *self, void *closure)
{
    (void)closure;
    return PyLong_FromUnsignedLong((unsigned long)self->est.last_flags);
}

static PyObject *est_settings(EstObject *self, PyObject *unused)
{
    (void)unused;
    if (check_ready(self) != 0) {
        return NULL;
    }
    return settings_to_values(&self->settings);
}

static PyObject *est_reset(EstObject *self, PyObject *unused)
{
    (void)unused;
    if (check_ready(self) != 0) {
        return NULL;
    }
    if (est_init_c(self) != CAEKF_OK) {
        PyErr_SetString(PyExc_RuntimeError, "caekf_init refused settings it accepted before");
        return NULL;
    }
    Py_RETURN_NONE;
}

/* The whole instance as bytes (caekf_t holds no pointers): pickling and copies within one build. */
static PyObject *est_get_raw(EstObject *self, PyObject *unused)
{
    (void)unused;
    if (check_ready(self) != 0) {
        return NULL;
    }
    return PyBytes_FromStringAndSize((const char *)&self->est, (Py_ssize_t)sizeof self->est);
}

static PyObject *est_set_raw(EstObject *self, PyObject *arg)
{
    char *buf;
    Py_ssize_t len;
    if (check_ready(self) != 0 || PyBytes_AsStringAndSize(arg, &buf, &len) != 0) {
        return NULL;
    }
    if (len != (Py_ssize_t)sizeof self->est) {
        PyErr_SetString(PyExc_ValueError, "estimator state from another build of caekf");
        return NULL;
    }
    memcpy(&self->est, buf, sizeof self->est);
    est_sizes(self);
    Py_RETURN_NONE;
}

/* log det S of the correction just made, S = H P- H' + R, from the posterior covariance (physical units).
 * With R = diag(r_i) and B = H P+ H' (the sensors' block), B = A - A S^-1 A = A S^-1 R for A = H P- H', so
 * R - B = R S^-1 R and log det S = 2 log det R - log det(R - B). Exact for the standard and Joseph
 * corrections and the switched filter's consider update (the gain rows of q and v are optimal); not for
 * steps whose constraint or covariance repair changed P afterwards (flags CONSTRAINT_APPLIED,
 * COV_REPAIRED) nor steps without a correction: NaN there. */
static double log_det_s(const EstObject *self, caekf_status_t st, uint32_t flags, const caekf_scalar_t *u)
{
    const uint32_t skip = CAEKF_FLAG_NO_MEASUREMENT | CAEKF_FLAG_INPUT_REJECTED | CAEKF_FLAG_NUMERIC_ROLLBACK |
                          CAEKF_FLAG_CONSTRAINT_APPLIED | CAEKF_FLAG_COV_REPAIRED;
    const caekf_t *e = &self->est;
    const int n = self->n, ny = self->ny;
    double a[CAEKF_MAX_SENSORS][CAEKF_MAX_SENSORS], r[CAEKF_MAX_SENSORS], sd[CAEKF_MAX_SENSORS], log_r2 = 0.0, det = 1.0;
    int i, j, k;
    if (st != CAEKF_OK || (flags & skip)) {
        return (double)NAN;
    }
    for (i = 0; i < ny; ++i) { /* each sensor's noise std: its own, or the position or velocity sensors' */
        sd[i] = e->cfg.sensor_sigma[i] > 0                                 ? (double)e->cfg.sensor_sigma[i]
                : e->cfg.model.sensor_kind[i] == CAEKF_SENSOR_VELOCITY ? (double)e->cfg.sigma_rv
                                                                       : (double)e->cfg.sigma_r;
    }
    if (e->dims.rows) { /* sensors read rows of H (docs/sensors.md): B from the rows at the posterior state */
        caekf_scalar_t hrow[CAEKF_MAX_SENSORS][CAEKF_N];
        caekf_scalar_t xs[CAEKF_N], hv;
        for (i = 0; i < n; ++i) {
            xs[i] = e->z[i] * e->scale[i];
        }
        for (i = 0; i < ny; ++i) {
            caekf_model_sensor(&e->model, &e->cfg.model, i, xs, u, u, &hv, hrow[i]); /* the rows: u_prev = u */
            r[i] = (double)e->dims.r[i] * sd[i] * sd[i];
            log_r2 += 2.0 * log(r[i]);
        }
        for (i = 0; i < ny; ++i) {
            for (j = 0; j < ny; ++j) {
                double b = 0.0;
                int p, q;
                for (p = 0; p < n; ++p) {
                    for (q = 0; q < n; ++q) {
                        b += (double)hrow[i][p] * (double)(e->P[p * n + q] * e->scale[p] * e->scale[q]) *
                             (double)hrow[j][q];
                    }
                }
                a[i][j] = (i == j ? r[i] : 0.0) - b;
            }
        }
    }
    for (i = 0; i < ny && !e->dims.rows; ++i) {
        r[i] = sd[i] * sd[i];
        log_r2 += 2.0 * log(r[i]);
        for (j = 0; j < ny; ++j) {
            const int si = e->dims.h[i], sj = e->dims.h[j];
            /* caekf_get_covariance's expression, element by element (the same bits) */
            a[i][j] = (i == j ? r[i] : 0.0) - (double)(e->P[si * n + sj] * e->scale[si] * e->scale[sj]);
        }
    }
    if (ny == 1) {
        det = a[0][0];
    } else if (ny == 2) {
        det = a[0][0] * a[1][1] - a[0][1] * a[0][1];
    } else {
        /* Gaussian elimination; R - B is symmetric positive definite when the correction was a plain one,
         * so a pivot <= 0 means it was not: NaN. */
        for (k = 0; k < ny && det > 0; ++k) {
            det *= a[k][k];
            for (i = k + 1; i < ny && a[k][k] > 0; ++i) {
                const double f = a[i][k] / a[k][k];
                for (j = k; j < ny; ++j) {
                    a[i][j] -= f * a[k][j];
                }
            }
        }
    }
    return det > 0 ? log_r2 - log(det) : (double)NAN;
}

/* _run(u, y, has_y, x, p_diag, flags, newton_iters, nis, delta, status, p_norm, log_det_s, correct_first)
 *
 * The replay loop of caekf-replay over `steps` rows, from this estimator's current state, without the GIL.
 * y: steps * sensors doubles (one row per step) [m or m/s], which sets `steps`; u: steps * inputs doubles
 * [N]; has_y: steps bytes (0: caekf_predict) or None. Outputs (None to skip): x steps * n doubles, p_diag
 * steps * n doubles (diagonal of P in physical units), flags uint32, newton_iters int32, nis, delta [m]
 * doubles, status int8, p_norm doubles (2-norm of P, the costly Jacobi sweeps) and log_det_s doubles
 * (log det of the innovation covariance, log_det_s() above), one per step. correct_first: row 0 is a sample
 * at the estimate's own time (t0), corrected without a time update (caekf_correct), as caekf-replay does. */
static PyObject *est_run(EstObject *self, PyObject *args)
{
    PyObject *o[12];
    Py_buffer b[12];
    Py_ssize_t steps, k;
    int i, ok = 1;
    static const char *const names[12] = {"u", "y", "has_y", "x", "p_diag", "flags", "newton_iters", "nis",
                                          "delta", "status", "p_norm", "log_det_s"};
    static const char fmts[12] = {'d', 'd', '?', 'd', 'd', 'I', 'i', 'd', 'd', 'b', 'd', 'd'};
    static const Py_ssize_t sizes[12] = {8, 8, 1, 8, 8, 4, 4, 8, 8, 1, 8, 8};
    int per_step[12] = {0, 0, 1, 0, 0, 1, 1, 1, 1, 1, 1, 1};
    const double *u, *y;
    const unsigned char *has_y;
    double *x, *pdiag, *nis, *delta, *pnorm, *logdet;
    uint32_t *flags;
    int32_t *iters;
    signed char *status;
    int n, ny, nu, correct_first = 0;

    if (!PyArg_ParseTuple(args, "OOOOOOOOOOOO|p:_run", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7],
                          &o[8], &o[9], &o[10], &o[11], &correct_first)) {
        return NULL;
    }
    if (check_ready(self) != 0) {
        return NULL;
    }
    n = self->n;
    ny = self->ny;
    nu = self->nu;
    per_step[0] = nu;
    per_step[1] = ny;
    per_step[3] = n;
    per_step[4] = n;
    memset(b, 0, sizeof b);
    {
        Py_buffer probe;
        if (PyObject_GetBuffer(o[1], &probe, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) != 0) {
            PyErr_Clear();
            PyErr_SetString(PyExc_TypeError, "y must be a C-contiguous float64 array");
            return NULL;
        }
        steps = probe.itemsize > 0 && ny > 0 ? probe.len / probe.itemsize / ny : 0;
        PyBuffer_Release(&probe);
    }
    for (i = 0; i < 12; ++i) {
        if (get_buffer(o[i], &b[i], names[i], fmts[i], sizes[i], steps * per_step[i], i >= 3, i >= 2) != 0) {
            ok = 0;
            break;
        }
    }
    if (!ok) {
        for (i = 0; i < 12; ++i) {
            if (b[i].buf != NULL || b[i].obj != NULL) {
                PyBuffer_Release(&b[i]);
            }
        }
        return NULL;
    }
    u = (const double *)b[0].buf;
    y = (const double *)b[1].buf;
    has_y = (const unsigned char *)b[2].buf;
    x = (double *)b[3].buf;
    pdiag = (double *)b[4].buf;
    flags = (uint32_t *)b[5].buf;
    iters = (int32_t *)b[6].buf;
    nis = (double *)b[7].buf;
    delta = (double *)b[8].buf;
    status = (signed char *)b[9].buf;
    pnorm = (double *)b[10].buf;
    logdet = (double *)b[11].buf;

    Py_BEGIN_ALLOW_THREADS
    for (k = 0; k < steps; ++k) {
        caekf_report_t rep;
        caekf_status_t st;
        caekf_scalar_t xs[CAEKF_N], us[CAEKF_MAX_INPUTS + 1];
        int with_y = has_y == NULL || has_y[k] != 0;
        for (i = 0; i < nu; ++i) {
            us[i] = (caekf_scalar_t)u[k * nu + i];
        }
        if (with_y) {
            caekf_scalar_t ys[CAEKF_MAX_SENSORS];
            for (i = 0; i < ny; ++i) {
                ys[i] = (caekf_scalar_t)y[k * ny + i];
            }
            st = k == 0 && correct_first ? caekf_correct(&self->est, us, ys, &rep) : caekf_step(&self->est, us, ys, &rep);
        } else {
            st = caekf_predict(&self->est, us, &rep);
        }
        if (x != NULL) {
            (void)caekf_get_state(&self->est, xs);
            for (i = 0; i < n; ++i) {
                x[k * n + i] = (double)xs[i];
            }
        }
        if (pdiag != NULL) {
            (void)caekf_get_variances(&self->est, xs);
            for (i = 0; i < n; ++i) {
                pdiag[k * n + i] = (double)xs[i];
            }
        }
        if (logdet != NULL) {
            logdet[k] = log_det_s(self, st, rep.flags, us);
        }
        if (pnorm != NULL) {
            caekf_scalar_t pn = 0;
            (void)caekf_get_cov_norm2(&self->est, &pn);
            pnorm[k] = (double)pn;
        }
        if (flags != NULL) flags[k] = rep.flags;
        if (iters != NULL) iters[k] = rep.newton_iters;
        if (nis != NULL) nis[k] = (double)rep.nis;
        if (delta != NULL) delta[k] = (double)rep.delta;
        if (status != NULL) status[k] = (signed char)st;
    }
    Py_END_ALLOW_THREADS

    for (i = 0; i < 12; ++i) {
        if (b[i].obj != NULL) {
            PyBuffer_Release(&b[i]);
        }
    }
    Py_RETURN_NONE;
}

static PyMethodDef est_methods[] = {
    {"step", (PyCFunction)(void (*)(void))est_step, METH_FASTCALL,
     "step(u, y) -> Report: caekf_step with the inputs u [N] (a number for one input, else one per input) "
     "and the measurements y (one per sensor) [m or m/s]."},
    {"predict", (PyCFunction)est_predict, METH_O,
     "predict(u) -> Report: caekf_predict, a time update without measurement (u as for step)."},
    {"p_norm", (PyCFunction)est_p_norm, METH_NOARGS, "2-norm of P in physical units (caekf_get_cov_norm2)."},
    {"mismatch", (PyCFunction)est_mismatch, METH_NOARGS,
     "The model-mismatch monitor: (mean NIS per sensor, factor on Q_x) (caekf_get_mismatch)."},
    {"_state_into", (PyCFunction)est_state_into, METH_O, NULL},
    {"_cov_into", (PyCFunction)est_cov_into, METH_O, NULL},
    {"_settings", (PyCFunction)est_settings, METH_NOARGS, NULL},
    {"reset", (PyCFunction)est_reset, METH_NOARGS, "Back to the initial estimate (caekf_init, same settings)."},
    {"_get_raw", (PyCFunction)est_get_raw, METH_NOARGS, NULL},
    {"_set_raw", (PyCFunction)est_set_raw, METH_O, NULL},
    {"_run", (PyCFunction)est_run, METH_VARARGS, NULL},
    {NULL, NULL, 0, NULL}};

static PyGetSetDef est_getset[] = {
    {"gamma", (getter)est_gamma, NULL, "Stiffness estimate gamma of contact 1 [N/m^n].", NULL},
    {"n", (getter)est_size, NULL, "States n = 2 bodies + contacts.", (void *)"n"},
    {"sensors", (getter)est_size, NULL, "Measurements per step (sensors).", (void *)"s"},
    {"inputs", (getter)est_size, NULL, "Input forces per step.", (void *)"i"},
    {"bodies", (getter)est_size, NULL, "Bodies (positions q, velocities v).", (void *)"b"},
    {"contacts", (getter)est_size, NULL, "Contacts (one gamma each).", (void *)"c"},
    {"step_count", (getter)est_step_count, NULL, "Steps and predictions done since init.", NULL},
    {"last_flags", (getter)est_last_flags, NULL, "Flags of the last step (CAEKF_FLAG_* bits).", NULL},
    {NULL, NULL, NULL, NULL, NULL}};

static PyTypeObject EstType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = CB_MODNAME ".Estimator",
    .tp_basicsize = sizeof(EstObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE,
    .tp_doc = "Low-level caekf_t instance; use caekf_sim.Estimator.",
    .tp_methods = est_methods,
    .tp_getset = est_getset,
    .tp_init = (initproc)est_init,
    .tp_new = PyType_GenericNew,
};

/* ---- module functions ------------------------------------------------------------------------------ */

static PyObject *mod_settings_default(PyObject *m, PyObject *unused)
{
    caekf_settings_t s;
    (void)m;
    (void)unused;
    (void)caekf_settings_default(&s);
    return settings_to_values(&s);
}

/* None, or (param_id, text) of the first refused element. */
static PyObject *mod_settings_validate(PyObject *m, PyObject *values)
{
    caekf_settings_t s;
    caekf_setting_error_t err;
    char text[200];
    (void)m;
    if (settings_from_values(values, &s) != 0) {
        return NULL;
    }
    if (caekf_settings_validate(&s, &err) == CAEKF_OK) {
        Py_RETURN_NONE;
    }
    (void)caekf_setting_error_text(&err, &s, text, sizeof text);
    return Py_BuildValue("(is)", (int)err.param_id, text);
}

/* scenario_settings(dict, preset or None) -> values: caekf_scenario_settings (host/common/scenario.c), the
 * rule caekf-replay runs: this build's defaults, the scenario's keys, the preset's values, validated. */
static PyObject *mod_scenario_settings(PyObject *m, PyObject *args)
{
    PyObject *dict;
    const char *name = NULL;
    const caekf_preset_t *preset = NULL;
    caekf_scenario_t sc;
    caekf_settings_t s;
    char err[300];
    (void)m;
    if (!PyArg_ParseTuple(args, "Oz:scenario_settings", &dict, &name)) {
        return NULL;
    }
    if (name != NULL && (preset = caekf_preset_find(name)) == NULL) {
        PyErr_Format(PyExc_ValueError, "unknown experiment '%s'", name);
        return NULL;
    }
    if (scenario_from_dict(dict, &sc, 0) != 0) {
        return NULL;
    }
    if (caekf_scenario_settings(&sc, preset, &s, "scenario", err, sizeof err) != 0) {
        PyErr_SetString(PyExc_ValueError, err);
        return NULL;
    }
    return settings_to_values(&s);
}

static PyObject *mod_preset_names(PyObject *m, PyObject *unused)
{
    PyObject *t = PyTuple_New(CAEKF_PRESET_COUNT);
    unsigned i;
    (void)m;
    (void)unused;
    for (i = 0; t != NULL && i < CAEKF_PRESET_COUNT; ++i) {
        PyTuple_SET_ITEM(t, i, PyUnicode_FromString(caekf_presets[i].name));
    }
    return t;
}

static PyObject *mod_status_str(PyObject *m, PyObject *arg)
{
    long v = PyLong_AsLong(arg);
    (void)m;
    if (v == -1 && PyErr_Occurred()) {
        return NULL;
    }
    return PyUnicode_FromString(caekf_status_str((caekf_status_t)v));
}

static PyObject *mod_flag_name(PyObject *m, PyObject *arg)
{
    long v = PyLong_AsLong(arg);
    (void)m;
    if (v == -1 && PyErr_Occurred()) {
        return NULL;
    }
    return PyUnicode_FromString(caekf_flag_name((unsigned)v));
}

static PyObject *mod_set_report_type(PyObject *m, PyObject *arg)
{
    (void)m;
    if (!PyType_Check(arg) || !PyType_IsSubtype((PyTypeObject *)arg, &PyTuple_Type)) {
        PyErr_SetString(PyExc_TypeError, "report type must be a tuple subclass");
        return NULL;
    }
    Py_INCREF(arg);
    Py_XDECREF((PyObject *)report_type);
    report_type = (PyTypeObject *)arg;
    Py_RETURN_NONE;
}


/* ---- the paper's mechanism ------------------------------------------------------------------------- */

/* 0 when `sc` describes the paper's chain (4 bodies, links 1-ground, 1-2, 3-4, 4-ground, the input on body
 * 1, position sensors on bodies 1 and 4, one Hertzian contact 2-3 without damping), else 1 with the first
 * difference in `buf` ("bodies = 3 (the paper's chain has 4)"): what paper-only code (the C truth, the
 * t,u,y1,y4 record formats) must refuse. */
static int paper_mismatch(const caekf_scenario_t *sc, char *buf, size_t len)
{
    static const int spring_a[4] = {1, 1, 3, 4}, spring_b[4] = {0, 2, 4, 0}, sensor_body[2] = {1, 4};
    caekf_model_params_t p;
    int i;
    caekf_scenario_model(sc, sc->dt, &p);
    {
        const char *const name[5] = {"bodies", "springs", "inputs", "sensors", "contacts"};
        const int count[5] = {p.bodies, p.springs, p.inputs, p.sensors, p.contacts}, want[5] = {4, 4, 1, 2, 1};
        for (i = 0; i < 5; ++i) {
            if (count[i] != want[i]) {
                PyOS_snprintf(buf, len, "%s = %d (the paper's chain has %d)", name[i], count[i], want[i]);
                return 1;
            }
        }
    }
    for (i = 0; i < 4; ++i) {
        if (p.spring_a[i] != spring_a[i] || p.spring_b[i] != spring_b[i]) {
            PyOS_snprintf(buf, len, "spring%d links bodies %d-%d (the paper's: %d-%d)", i + 1, p.spring_a[i],
                          p.spring_b[i], spring_a[i], spring_b[i]);
            return 1;
        }
    }
    for (i = 0; i < 2; ++i) {
        if (p.sensor_body[i] != sensor_body[i] || p.sensor_kind[i] != CAEKF_SENSOR_POSITION) {
            PyOS_snprintf(buf, len, "sensor%d is not the paper's position sensor on body %d", i + 1, sensor_body[i]);
            return 1;
        }
    }
    if (p.input_body[0] != 1) {
        PyOS_snprintf(buf, len, "input1_body = %d (the paper's input acts on body 1)", p.input_body[0]);
        return 1;
    }
    if (p.contact_a[0] != 2 || p.contact_b[0] != 3 || p.contact_n[0] != (caekf_scalar_t)1.5 ||
        p.contact_lambda[0] != 0) {
        PyOS_snprintf(buf, len, "contact1 is not the paper's (bodies 2-3, n = 1.5, lambda = 0)");
        return 1;
    }
    return 0;
}

/* paper_mismatch(scenario dict) -> None, or the first difference from the paper's mechanism (text). */
static PyObject *mod_paper_mismatch(PyObject *m, PyObject *dict)
{
    caekf_scenario_t sc;
    char text[160];
    (void)m;
    if (scenario_from_dict(dict, &sc, 0) != 0) {
        return NULL;
    }
    if (paper_mismatch(&sc, text, sizeof text) == 0) {
        Py_RETURN_NONE;
    }
    return PyUnicode_FromString(text);
}

#if !CAEKF_USE_FLOAT
/* ---- truth (double module only) -------------------------------------------------------------------- */

typedef struct {
    double *t, *u, *y, *q, *v, *delta;
    int32_t *iters, *failed;
    long n, k;
    int ni, ny, nq, nc; /* row widths: inputs, sensors, bodies, contacts */
} truth_ctx_t;

static int truth_emit(const caekf_truth_sample_t *s, void *vctx)
{
    truth_ctx_t *c = (truth_ctx_t *)vctx;
    long k = c->k;
    int i;
    if (k >= c->n) {
        return -1;
    }
    c->t[k] = s->t;
    for (i = 0; i < c->ni; ++i) {
        c->u[c->ni * k + i] = s->u[i];
    }
    for (i = 0; i < c->ny; ++i) {
        c->y[c->ny * k + i] = s->y[i];
    }
    for (i = 0; i < c->nq; ++i) {
        c->q[c->nq * k + i] = s->q[i];
        c->v[c->nq * k + i] = s->v[i];
    }
    for (i = 0; i < c->nc; ++i) {
        c->delta[c->nc * k + i] = s->delta[i];
    }
    c->iters[k] = s->newton_iters;
    c->failed[k] = s->newton_failed;
    c->k = k + 1;
    return 0;
}

/* truth(scenario, t, u, y, q, v, delta, newton_iters, newton_failed) -> None: caekf_truth_run into the
 * arrays (n = round(t_end / dt) rows of the mechanism's widths: u n*inputs, y n*sensors, q and v
 * n*bodies, delta n*contacts doubles, the counts int32), without the GIL. */
static PyObject *mod_truth(PyObject *m, PyObject *args)
{
    PyObject *o[9];
    Py_buffer b[8];
    static const char *const names[8] = {"t", "u", "y", "q", "v", "delta", "newton_iters", "newton_failed"};
    static const char fmts[8] = {'d', 'd', 'd', 'd', 'd', 'd', 'i', 'i'};
    static const Py_ssize_t sizes[8] = {8, 8, 8, 8, 8, 8, 4, 4};
    int per[8] = {1, 1, 1, 1, 1, 1, 1, 1};
    caekf_scenario_t sc;
    truth_ctx_t ctx;
    long n;
    int i, rc, ok = 1;
    (void)m;
    if (!PyArg_ParseTuple(args, "OOOOOOOOO:truth", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8])) {
        return NULL;
    }
    if (scenario_from_dict(o[0], &sc, 1) != 0) {
        return NULL;
    }
    ctx.ni = (int)sc.inputs;
    ctx.ny = (int)sc.sensors;
    ctx.nq = (int)sc.bodies;
    ctx.nc = (int)sc.contacts;
    per[1] = ctx.ni;
    per[2] = ctx.ny;
    per[3] = per[4] = ctx.nq;
    per[5] = ctx.nc;
    if (!(sc.dt > 0) || !(sc.t_end > 0) || !(sc.truth_substeps >= 1)) {
        PyErr_SetString(PyExc_ValueError, "truth needs dt > 0, t_end > 0, truth_substeps >= 1");
        return NULL;
    }
    n = caekf_scenario_steps(&sc);
    memset(b, 0, sizeof b);
    for (i = 0; i < 8; ++i) {
        if (get_buffer(o[i + 1], &b[i], names[i], fmts[i], sizes[i], (Py_ssize_t)n * per[i], 1, 0) != 0) {
            ok = 0;
            break;
        }
    }
    if (!ok) {
        for (i = 0; i < 8; ++i) {
            if (b[i].obj != NULL) {
                PyBuffer_Release(&b[i]);
            }
        }
        return NULL;
    }
    ctx.t = (double *)b[0].buf;
    ctx.u = (double *)b[1].buf;
    ctx.y = (double *)b[2].buf;
    ctx.q = (double *)b[3].buf;
    ctx.v = (double *)b[4].buf;
    ctx.delta = (double *)b[5].buf;
    ctx.iters = (int32_t *)b[6].buf;
    ctx.failed = (int32_t *)b[7].buf;
    ctx.n = n;
    ctx.k = 0;
    Py_BEGIN_ALLOW_THREADS
    rc = caekf_truth_run(&sc, NULL, truth_emit, &ctx); /* caekf-truth's default method */
    Py_END_ALLOW_THREADS
    for (i = 0; i < 8; ++i) {
        PyBuffer_Release(&b[i]);
    }
    if (rc != 0 || ctx.k != n) {
        PyErr_SetString(PyExc_ValueError, "truth refused the scenario's plant (settings or integration)");
        return NULL;
    }
    Py_RETURN_NONE;
}
#endif

static PyMethodDef mod_methods[] = {
    {"settings_default", mod_settings_default, METH_NOARGS, "caekf_settings_default as values by parameter id."},
    {"settings_validate", mod_settings_validate, METH_O,
     "caekf_settings_validate: None, or (param_id, text) of the first element it refuses."},
    {"scenario_settings", mod_scenario_settings, METH_VARARGS,
     "caekf_scenario_settings (host/common/scenario.c): scenario dict + preset name or None -> values."},
    {"preset_names", mod_preset_names, METH_NOARGS, "The presets of the settings schema."},
    {"status_str", mod_status_str, METH_O, "caekf_status_str."},
    {"flag_name", mod_flag_name, METH_O, "caekf_flag_name (bit index)."},
    {"_set_report_type", mod_set_report_type, METH_O, NULL},
    {"paper_mismatch", mod_paper_mismatch, METH_O,
     "None when the scenario dict describes the paper's mechanism, else its first difference (text)."},
#if !CAEKF_USE_FLOAT
    {"truth", mod_truth, METH_VARARGS, "caekf_truth_run (host/common/truth.c) into preallocated arrays."},
#endif
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moddef = {PyModuleDef_HEAD_INIT, CB_MODNAME,
                                    "caekf C estimator (" CAEKF_SCALAR_NAME "), see caekf_sim.binding.", -1,
                                    mod_methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC CB_CAT(PyInit_, CAEKF_BIND_MODULE)(void);
PyMODINIT_FUNC CB_CAT(PyInit_, CAEKF_BIND_MODULE)(void)
{
    PyObject *m;
    unsigned b;
    if (PyType_Ready(&EstType) < 0) {
        return NULL;
    }
    m = PyModule_Create(&moddef);
    if (m == NULL) {
        return NULL;
    }
    Py_INCREF(&EstType);
    if (PyModule_AddObject(m, "Estimator", (PyObject *)&EstType) < 0) {
        Py_DECREF(&EstType);
        Py_DECREF(m);
        return NULL;
    }
    PyModule_AddStringConstant(m, "SCALAR", CAEKF_SCALAR_NAME);
    PyModule_AddStringConstant(m, "SOURCE_HASH", CAEKF_BIND_SOURCE_HASH);
    PyModule_AddIntConstant(m, "N", CAEKF_N); /* the state's capacity; a mechanism uses n <= N */
    PyModule_AddIntConstant(m, "PARAM_COUNT", (long)CAEKF_PARAM_COUNT);
    PyModule_AddIntConstant(m, "MAX_BODIES", CAEKF_MAX_BODIES);
    PyModule_AddIntConstant(m, "MAX_INPUTS", CAEKF_MAX_INPUTS);
    PyModule_AddIntConstant(m, "MAX_SENSORS", CAEKF_MAX_SENSORS);
    PyModule_AddIntConstant(m, "MAX_CONTACTS", CAEKF_MAX_CONTACTS);
    PyModule_AddIntConstant(m, "FLAG_COUNT", CAEKF_FLAG_COUNT);
    PyModule_AddIntConstant(m, "NEWTON_MAX_ITER", CAEKF_NEWTON_MAX_ITER);
    PyModule_AddObject(m, "EPS", PyFloat_FromDouble((double)CAEKF_EPS));
    for (b = 0; b < CAEKF_FLAG_COUNT; ++b) {
        char name[64], *c;
        PyOS_snprintf(name, sizeof name, "FLAG_%s", caekf_flag_name(b));
        for (c = name; *c != '\0'; ++c) {
            if (*c >= 'a' && *c <= 'z') {
                *c = (char)(*c - 'a' + 'A');
            }
        }
        PyModule_AddIntConstant(m, name, (long)(1u << b));
    }
    return m;
}
