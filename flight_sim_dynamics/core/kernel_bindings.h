/* The bindings written once for the machines' kernels, included by
   machines/<name>/kernel.c after its physics. It defines first:
   - DOF (its number of coordinates and legs), P_SIZE (packed model doubles),
     OUT_SIZE (result row doubles), EFFECT_BITS_MAX (the largest effect bit set
     it takes);
   - stage(): one RK4 stage of the twin, the accelerations and the delivered
     forces of a state, 0 when it stops (its force law: kernel_support.h's
     tabulated_law);
   - SOLVE_ROWS(job, n): how a batch runs the rows 0..n of a batch_job (below):
     solve_rows(job, 0, n) in one call, or shared out to threads; the kernel
     defines solve_rows(job, begin, end) (each row by its one-sample solve) and
     solve_batch_doc.
   Here: the twin's RK4 loop (core.simulation.integrate) with its binding
   integrate(), and the binding solve_batch(). */
#ifndef FSD_KERNEL_BINDINGS_H
#define FSD_KERNEL_BINDINGS_H

/* Rows k0..steps of Q, QD, QDD, F (DOF numbers each), the same operations in
   the same order as the Python loop; returns the first row whose step did not
   complete. */
static Py_ssize_t rk4(const double *P, int fx, const tabulated_law *law, double h,
                      Py_ssize_t k0, Py_ssize_t steps, double *Q, double *QD,
                      double *QDD, double *F)
{
    double q[DOF], qd[DOF];
    memcpy(q, Q + DOF * k0, sizeof q);
    memcpy(qd, QD + DOF * k0, sizeof qd);
    for (Py_ssize_t k = k0; k <= steps; k++) {
        double a1[DOF], a2[DOF], a3[DOF], a4[DOF], f1[DOF], f[DOF];
        double q2[DOF], v2[DOF], q3[DOF], v3[DOF], q4[DOF], v4[DOF];
        memcpy(Q + DOF * k, q, sizeof q);
        memcpy(QD + DOF * k, qd, sizeof qd);
        if (!stage(P, fx, law, 2 * k, q, qd, a1, f1))
            return k;
        if (k < steps) {
            for (int i = 0; i < DOF; i++) {
                q2[i] = q[i] + 0.5 * h * qd[i];
                v2[i] = qd[i] + 0.5 * h * a1[i];
            }
            if (!stage(P, fx, law, 2 * k + 1, q2, v2, a2, f))
                return k;
            for (int i = 0; i < DOF; i++) {
                q3[i] = q[i] + 0.5 * h * v2[i];
                v3[i] = qd[i] + 0.5 * h * a2[i];
            }
            if (!stage(P, fx, law, 2 * k + 1, q3, v3, a3, f))
                return k;
            for (int i = 0; i < DOF; i++) {
                q4[i] = q[i] + h * v3[i];
                v4[i] = qd[i] + h * a3[i];
            }
            if (!stage(P, fx, law, 2 * k + 2, q4, v4, a4, f))
                return k;
            double qn[DOF], qdn[DOF];
            int finite = 1;
            for (int i = 0; i < DOF; i++) {
                qn[i] = q[i] + (h / 6.0) * (qd[i] + 2.0 * (v2[i] + v3[i]) + v4[i]);
                qdn[i] = qd[i] + (h / 6.0) * (a1[i] + 2.0 * (a2[i] + a3[i]) + a4[i]);
                finite = finite && isfinite(qn[i]) && isfinite(qdn[i]);
            }
            if (!finite)
                return k;
            memcpy(q, qn, sizeof q);
            memcpy(qd, qdn, sizeof qd);
        }
        memcpy(QDD + DOF * k, a1, sizeof a1);
        memcpy(F + DOF * k, f1, sizeof f1);
    }
    return steps + 1;
}

/* the effect bit set of a binding's argument (ValueError beyond EFFECT_BITS_MAX) */
static int effect_bits(PyObject *obj, int *fx)
{
    long bits = PyLong_AsLong(obj);
    if (bits == -1 && PyErr_Occurred())
        return -1;
    if (bits < 0 || bits > EFFECT_BITS_MAX) {
        PyErr_SetString(PyExc_ValueError, "unknown effect bits");
        return -1;
    }
    *fx = (int)bits;
    return 0;
}

PyDoc_STRVAR(integrate_doc,
"integrate(params, effects, ff, length_ref, rate_ref, kp, kd, max_force, max_speed,\n"
"          servo, h, k0, steps, q, qd, qdd, force) -> int\n\n"
"RK4 rows k0 to steps of a TabulatedLaw (tables (2 steps + 1, DOF), gains DOF, rows\n"
"(steps + 1, DOF), C-contiguous float64); the first row not completed\n"
"(kernel.integrate_rows). Releases the GIL while it runs.");

static PyObject *py_integrate(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 17) {
        PyErr_SetString(PyExc_TypeError, "integrate() takes 17 arguments");
        return NULL;
    }
    int fx;
    if (effect_bits(args[1], &fx) < 0)
        return NULL;
    int servo = PyObject_IsTrue(args[9]);
    double max_force = PyFloat_AsDouble(args[7]), max_speed = PyFloat_AsDouble(args[8]);
    double h = PyFloat_AsDouble(args[10]);
    Py_ssize_t k0 = PyLong_AsSsize_t(args[11]), steps = PyLong_AsSsize_t(args[12]);
    if (servo < 0 || PyErr_Occurred())
        return NULL;
    if (steps < 1 || k0 < 0 || k0 > steps || steps > (PY_SSIZE_T_MAX / (32 * DOF))) {
        PyErr_SetString(PyExc_ValueError, "need 0 <= k0 <= steps, steps >= 1");
        return NULL;
    }
    /* buffers: params, ff, length_ref, rate_ref, kp, kd, q, qd, qdd, force */
    static const int arg[10] = {0, 2, 3, 4, 5, 6, 13, 14, 15, 16};
    static const char *const names[10] = {"packed model", "ff", "length_ref", "rate_ref",
                                          "kp", "kd", "q", "qd", "qdd", "force"};
    Py_ssize_t stages = DOF * (2 * steps + 1), rows = DOF * (steps + 1);
    const Py_ssize_t sizes[10] = {P_SIZE, stages, stages, stages, DOF, DOF, rows, rows,
                                   rows, rows};
    Py_buffer views[10];
    int got = 0;
    PyObject *result = NULL;
    for (; got < 10; got++)
        if (get_doubles(args[arg[got]], &views[got], sizes[got], got >= 6, names[got]) < 0)
            goto done;
    {
        tabulated_law law;
        law.ff = (const double *)views[1].buf;
        law.length_ref = (const double *)views[2].buf;
        law.rate_ref = (const double *)views[3].buf;
        memcpy(law.kp, views[4].buf, sizeof law.kp);
        memcpy(law.kd, views[5].buf, sizeof law.kd);
        law.max_force = max_force;
        law.max_speed = max_speed;
        law.servo = servo;
        Py_ssize_t reached;
        Py_BEGIN_ALLOW_THREADS
        reached = rk4((const double *)views[0].buf, fx, &law, h, k0, steps,
                      (double *)views[6].buf, (double *)views[7].buf, (double *)views[8].buf,
                      (double *)views[9].buf);
        Py_END_ALLOW_THREADS
        result = PyLong_FromSsize_t(reached);
    }
done:
    for (int i = 0; i < got; i++)
        PyBuffer_Release(&views[i]);
    return result;
}

/* A batch: the packed model, the effect bits, N rows of q, qd, qdd (DOF
   numbers each) and of out (OUT_SIZE numbers each). */
typedef struct {
    const double *P, *q, *qd, *qdd;
    double *out;
    int fx;
} batch_job;

static void solve_rows(const void *job, Py_ssize_t begin, Py_ssize_t end);

static PyObject *py_solve_batch(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 6) {
        PyErr_SetString(PyExc_TypeError, "solve_batch() takes 6 arguments");
        return NULL;
    }
    int fx;
    if (effect_bits(args[1], &fx) < 0)
        return NULL;
    Py_buffer views[5];     /* q (its size gives N), params, qd, qdd, out */
    int got = 0;
    PyObject *result = NULL;
    Py_ssize_t n = get_rows(args[2], &views[0], DOF, 0, "q");
    if (n < 0)
        return NULL;
    static const int arg[5] = {2, 0, 3, 4, 5};
    static const char *const names[5] = {"q", "packed model", "qd", "qdd", "out"};
    const Py_ssize_t sizes[5] = {DOF * n, P_SIZE, DOF * n, DOF * n, OUT_SIZE * n};
    for (got = 1; got < 5; got++)
        if (get_doubles(args[arg[got]], &views[got], sizes[got], got == 4, names[got]) < 0)
            goto done;
    {
        batch_job job = {(const double *)views[1].buf, (const double *)views[0].buf,
                         (const double *)views[2].buf, (const double *)views[3].buf,
                         (double *)views[4].buf, fx};
        Py_BEGIN_ALLOW_THREADS
        SOLVE_ROWS(&job, n);
        Py_END_ALLOW_THREADS
    }
    Py_INCREF(Py_None);
    result = Py_None;
done:
    for (int i = 0; i < got; i++)
        PyBuffer_Release(&views[i]);
    return result;
}

#endif
