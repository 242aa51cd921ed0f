/* The twin's RK4 loop (core.simulation.integrate), written once for the
   machines' kernels: included by machines/<name>/kernel.c after its stage()
   (one RK4 stage: the accelerations and the delivered forces of a state, 0 when
   it stops), its tabulated_law and DOF, its number of coordinates. Rows k0..steps
   of Q, QD, QDD, F (DOF numbers each), the same operations in the same order as
   the Python loop; returns the first row whose step did not complete. */
#ifndef FSD_KERNEL_RK4_H
#define FSD_KERNEL_RK4_H

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

#endif
