/* What the machines' kernels (machines/<name>/kernel.c) share, included by
   each after Python.h and its DOF (coordinates and legs): the X-macros of
   their contracts with the Python side (kernel.py checks them), the exported
   tables, the buffer checks of their bindings, and the twin's force law and
   the actuators' delivery rule of core.servo. */
#ifndef FSD_KERNEL_SUPPORT_H
#define FSD_KERNEL_SUPPORT_H

#include <math.h>
#include <string.h>

/* core.servo.TabulatedLaw: the stage forces ff (stages x DOF), and for a
   servo the leg lengths and rates of the reference, gains and actuator limits */
typedef struct {
    const double *ff, *length_ref, *rate_ref;
    double kp[DOF], kd[DOF], max_force, max_speed;
    int servo;
} tabulated_law;

/* The contracts as X-macro lists: the C enum and the exported table
   (PyInit__kernel) come from one line. */
#define AS_ENUM(id, name) id,
#define AS_NAME(id, name) name,
/* id, id_END = id + size - 1: the next id follows the last double of this one */
#define AS_OFFSET(id, name, size) id, id##_END = id + (size) - 1,
#define AS_FIELD(id, name, size) {name, id, size},
#define AS_INDEX(id, name) id##_INDEX,
#define AS_BIT(id, name) id = 1 << id##_INDEX,
#define AS_BIT_FIELD(id, name) {name, id, 1},
#define COUNT(a) (sizeof (a) / sizeof (a)[0])

typedef struct { const char *name; int offset, size; } field;

/* NaN-propagating max and min, as numpy's maximum and minimum */
static inline double nmax(double a, double b) { return (a >= b || isnan(a)) ? a : b; }
static inline double nmin(double a, double b) { return (a <= b || isnan(a)) ? a : b; }

/* core.servo.deliver for one actuator */
static double deliver(double command, double rate, double max_force, double max_speed)
{
    double force = nmin(nmax(command, -max_force), max_force);
    double drive = max_force * nmax(0.0, 1.0 - fabs(rate) / max_speed);
    if (force * rate > 0.0)
        return (force > 0.0 ? 1.0 : -1.0) * nmin(fabs(force), drive);
    return force;
}

/* a C-contiguous float64 buffer of exactly n doubles (writable if asked) */
static int get_doubles(PyObject *obj, Py_buffer *view, Py_ssize_t n, int writable,
                       const char *name)
{
    if (PyObject_GetBuffer(obj, view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT
                           | (writable ? PyBUF_WRITABLE : 0)) < 0)
        return -1;
    if (view->len != n * (Py_ssize_t)sizeof(double) || view->format == NULL
            || strcmp(view->format, "d") != 0) {
        PyErr_Format(PyExc_ValueError, "%s must be %zd float64 numbers", name, n);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

/* A C-contiguous float64 buffer of N rows of `row` numbers, writable if
   asked: N, or -1 with a ValueError naming it */
static Py_ssize_t get_rows(PyObject *obj, Py_buffer *view, Py_ssize_t row, int writable,
                           const char *name)
{
    if (PyObject_GetBuffer(obj, view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT
                           | (writable ? PyBUF_WRITABLE : 0)) < 0)
        return -1;
    Py_ssize_t n = view->len / (row * (Py_ssize_t)sizeof(double));
    if (view->len != n * row * (Py_ssize_t)sizeof(double) || view->format == NULL
            || strcmp(view->format, "d") != 0) {
        PyErr_Format(PyExc_ValueError, "%s must be (N, %zd) float64 numbers", name, row);
        PyBuffer_Release(view);
        return -1;
    }
    return n;
}

/* DOF numbers of a list or tuple of exactly DOF Python floats (a TypeError
   otherwise: the machine's solver then checks and converts them) */
static int dof_floats(PyObject *t, const char *name, double *x)
{
    if (!(PyTuple_CheckExact(t) || PyList_CheckExact(t)) || PySequence_Fast_GET_SIZE(t) != DOF) {
        PyErr_Format(PyExc_TypeError, "%s must be a list or tuple of %d floats", name, DOF);
        return -1;
    }
    PyObject **items = PySequence_Fast_ITEMS(t);
    for (int i = 0; i < DOF; i++) {
        if (!PyFloat_CheckExact(items[i])) {
            PyErr_Format(PyExc_TypeError, "%s must be a list or tuple of %d floats", name, DOF);
            return -1;
        }
        x[i] = PyFloat_AS_DOUBLE(items[i]);
    }
    return 0;
}

/* {name: (offset, size)}, or with bits_only {name: bit} */
static PyObject *fields_dict(const field *f, size_t n, int bits_only)
{
    PyObject *d = PyDict_New();
    for (size_t i = 0; d != NULL && i < n; i++) {
        PyObject *v = bits_only ? PyLong_FromLong(f[i].offset)
                                : Py_BuildValue("(ii)", f[i].offset, f[i].size);
        if (v == NULL || PyDict_SetItemString(d, f[i].name, v) < 0)
            Py_CLEAR(d);
        Py_XDECREF(v);
    }
    return d;
}

static PyObject *names_tuple(const char *const *names, size_t n)
{
    PyObject *t = PyTuple_New((Py_ssize_t)n);
    for (size_t i = 0; t != NULL && i < n; i++) {
        PyObject *v = PyUnicode_FromString(names[i]);
        if (v == NULL)
            Py_CLEAR(t);
        else
            PyTuple_SET_ITEM(t, (Py_ssize_t)i, v);
    }
    return t;
}

static int add_object(PyObject *m, const char *name, PyObject *value)
{
    int rc = value == NULL ? -1 : PyModule_AddObjectRef(m, name, value);
    Py_XDECREF(value);
    return rc;
}

#endif
