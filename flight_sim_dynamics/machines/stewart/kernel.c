/*
 * flight_sim_dynamics.machines.stewart._kernel: the hexapod's solve
 * (docs/design/stewart.md, (S1)-(S23)) for one sample (solve) or a batch
 * (solve_batch), and the twin's RK4 loop (integrate: core/simulation.py),
 * writing into caller-provided float64 buffers. A transcription
 * of kinematics.py, dynamics.py and the status rule of solver.py, equation by
 * equation (divisions by L_i and c theta_2 as products with their reciprocals,
 * computed once per leg); the numpy code is the reference
 * (test/machines/stewart/test_stewart_kernel.py checks the two agree). Function
 * names follow the Python ones.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define DOF 6   /* pose coordinates (and legs): the size of the shared headers' rows */
#include "kernel_support.h"

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <string.h>

/* The contracts with the Python side, as X-macro lists: the C enum and the
   exported table (PyInit__kernel) come from one line (the X-macros:
   core/kernel_support.h); kernel.py checks them. */

/* a body fixed to the platform (model.RigidBody) and a leg body (model.LegBody) */
#define RIGID_ROW(X) X(R_MASS, "mass", 1) X(R_COM, "com", 3) X(R_INERTIA, "inertia", 9)
enum { RIGID_ROW(AS_OFFSET) RIGID_SIZE };
#define LEG_ROW(X) \
    X(K_MASS, "mass", 1) X(K_COM, "com_distance", 1) X(K_ACROSS, "inertia_across", 1) \
    X(K_ALONG, "inertia_along", 1)
enum { LEG_ROW(AS_OFFSET) LEG_SIZE };

/* the packed model (kernel.pack_model): attribute paths of StewartModel, sizes;
   a joint-angle limit that is off (None) is packed as +inf */
#define PACKED_MODEL(X) \
    X(P_BASE, "base_joints", 18) X(P_JOINTS, "platform_joints", 18) \
    X(P_AXES, "base_axes", 18) X(P_FRAMES, "leg_frames", 54) X(P_HOME, "home", 3) \
    X(P_HOME_LENGTHS, "home_lengths", 6) X(P_GRAVITY, "gravity", 1) \
    X(P_PLATFORM, "platform", RIGID_SIZE) X(P_PAYLOAD, "payload", RIGID_SIZE) \
    X(P_CYLINDER, "cylinder", LEG_SIZE) X(P_ROD, "rod", LEG_SIZE) \
    X(P_VISCOUS, "friction.viscous", 6) X(P_COULOMB, "friction.coulomb", 6) \
    X(P_SMOOTHING, "friction.smoothing_velocity", 1) \
    X(P_LENGTH_MIN, "limits.length_min", 1) X(P_LENGTH_MAX, "limits.length_max", 1) \
    X(P_MAX_SPEED, "limits.max_speed", 1) X(P_MAX_FORCE, "limits.max_force", 1) \
    X(P_MAX_COND, "limits.max_jacobian_condition", 1) \
    X(P_U_MAX, "limits.u_joint_max_angle", 1) \
    X(P_S_MAX, "limits.spherical_joint_max_angle", 1)
enum { PACKED_MODEL(AS_OFFSET) P_SIZE };

/* effects bits (effects.EFFECT_NAMES, any order) */
#define EFFECT_LIST(X) \
    X(E_GRAVITY, "gravity") X(E_PLATFORM, "platform_inertia") X(E_PAYLOAD, "payload") \
    X(E_LEG, "leg_inertia") X(E_CRANK, "crank_inertia") /* no cranks: no terms */ \
    X(E_VP, "velocity_products") X(E_FRICTION, "friction")
enum { EFFECT_LIST(AS_INDEX) N_EFFECTS };
enum { EFFECT_LIST(AS_BIT) E_ALL = (1 << N_EFFECTS) - 1 };

/* one result row: the StewartSolution fields (the checked ones first, O_LENGTH
   to O_TWIST_JACOBIAN_END), the status code and its info, the pose solved for
   (as given: kept in a void row) */
#define RESULT_ROW(X) \
    X(O_LENGTH, "length", 6) X(O_STROKE, "stroke", 6) X(O_RATE, "rate", 6) \
    X(O_ACCELERATION, "acceleration", 6) X(O_FORCE, "force", 6) X(O_POWER, "power", 6) \
    X(O_JOINTS, "joints", 18) X(O_JOINT_RATES, "joint_rates", 18) \
    X(O_JOINT_ACCELERATIONS, "joint_accelerations", 18) \
    X(O_SPHERICAL, "spherical_angles", 6) X(O_JACOBIAN, "jacobian", 36) \
    X(O_TWIST_JACOBIAN, "twist_jacobian", 36) X(O_COND, "jacobian_condition", 1) \
    X(O_STATUS, "status", 1) X(O_INFO, "info", 1) X(O_POSE, "pose", 6)
enum { RESULT_ROW(AS_OFFSET) OUT_SIZE };
_Static_assert((O_TWIST_JACOBIAN_END + 1 - O_LENGTH) % 4 == 0,
               "the checked fields are read four at a time");

/* status codes, by severity (core.status: SEVERITY) */
#define STATUS_LIST(X) \
    X(S_OK, "ok") X(S_LIMIT, "limit") X(S_NEAR_SINGULAR, "near_singular") \
    X(S_UNREACHABLE, "unreachable") X(S_INVALID, "invalid_input")
enum { STATUS_LIST(AS_ENUM) N_STATUS };

/* info of an unreachable sample: leg + 6 x why (solver.py, UNREACHABLE_*) */
#define UNREACHABLE_LIST(X) \
    X(U_LENGTH, "degenerate_length") X(U_NOT_FINITE, "not_finite") X(U_JOINT, "u_joint")
enum { UNREACHABLE_LIST(AS_ENUM) N_UNREACHABLE };

#define RESULTS_NOT_FINITE (-1)     /* info of results that overflow (core.status) */
#define U_JOINT_TOLERANCE 1e-6      /* model.U_JOINT_TOLERANCE */
#define MIN_LENGTH 1e-9             /* model.MIN_LENGTH */
#define MAX_SOLVED_CONDITION 1e12   /* model.MAX_SOLVED_CONDITION */
/* a result row's jacobian_condition not computed by solve (conditions() computes it) */
#define NOT_COMPUTED -1.0
#define SINGULAR DBL_MAX            /* core.status.SINGULAR */

typedef struct { double x, y, z; } v3;

static inline v3 vec(double x, double y, double z) { v3 r = {x, y, z}; return r; }
static inline v3 load(const double *p) { return vec(p[0], p[1], p[2]); }
static inline v3 add(v3 a, v3 b) { return vec(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline v3 sub(v3 a, v3 b) { return vec(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline v3 scale(double s, v3 a) { return vec(s * a.x, s * a.y, s * a.z); }
static inline double dot(v3 a, v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline v3 cross(v3 a, v3 b)
{ return vec(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
static inline v3 mat_vec(const double m[3][3], v3 c)
{
    return vec(m[0][0] * c.x + m[0][1] * c.y + m[0][2] * c.z,
               m[1][0] * c.x + m[1][1] * c.y + m[1][2] * c.z,
               m[2][0] * c.x + m[2][1] * c.y + m[2][2] * c.z);
}
/* m^T c */
static inline v3 mat_t_vec(const double m[3][3], v3 c)
{
    return vec(m[0][0] * c.x + m[1][0] * c.y + m[2][0] * c.z,
               m[0][1] * c.x + m[1][1] * c.y + m[2][1] * c.z,
               m[0][2] * c.x + m[1][2] * c.y + m[2][2] * c.z);
}

static const v3 ZERO = {0.0, 0.0, 0.0};

/* ---- The platform (S1)-(S3): kinematics.platform_motion ---- */
typedef struct {
    v3 p, v, omega, a, eps;
    double R[3][3], E[3][3];
} platform_motion;

/* rates 0: the motion of the same accelerations from rest (qd = 0) */
/* R (S1) of the angles q[3..5] */
static void rotation_of(const double *q, double R[3][3])
{
    double cr = cos(q[3]), sr = sin(q[3]), cp = cos(q[4]), sp = sin(q[4]);
    double cy = cos(q[5]), sy = sin(q[5]);
    double r[3][3] = {{cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr},
                      {sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr},
                      {-sp, cp * sr, cp * cr}};
    memcpy(R, r, sizeof r);
}

static void platform_motion_of(const double *P, const double *q, const double *qd,
                               const double *qdd, int rates, platform_motion *pm)
{
    double cp = cos(q[4]), sp = sin(q[4]), cy = cos(q[5]), sy = sin(q[5]);
    rotation_of(q, pm->R);                                                          /* (S1) */
    double E[3][3] = {{cy * cp, -sy, 0.0}, {sy * cp, cy, 0.0}, {-sp, 0.0, 1.0}};   /* (S2) */
    memcpy(pm->E, E, sizeof E);
    pm->p = add(load(P + P_HOME), load(q));
    v3 ang_dd = load(qdd + 3);
    pm->a = load(qdd);
    if (rates) {
        double pd = qd[4], yd = qd[5];
        double Ed[3][3] = {{-sy * cp * yd - cy * sp * pd, -cy * yd, 0.0},           /* (S3) */
                           {cy * cp * yd - sy * sp * pd, -sy * yd, 0.0},
                           {-cp * pd, 0.0, 0.0}};
        v3 ang_d = load(qd + 3);
        pm->v = load(qd);
        pm->omega = mat_vec(E, ang_d);
        pm->eps = add(mat_vec(E, ang_dd), mat_vec(Ed, ang_d));
    } else {
        pm->v = ZERO;
        pm->omega = ZERO;
        pm->eps = mat_vec(E, ang_dd);
    }
}

/* ---- Leg i (S4)-(S13) ---- */
typedef struct {
    v3 r, u, a1, a1xu;                   /* (S4)-(S5) */
    double L, s2, c2;                    /* s2, c2: sin, cos theta_2 */
    double inv_L, inv_c2;                /* 1 / L, 1 / c theta_2 */
} leg_position;

typedef struct {
    v3 vP, ud, omega;                    /* (S6)-(S9) */
    double Ld, theta1d, theta2d, sigma;
} leg_velocity;

typedef struct {
    v3 aP, udd, eps;                     /* (S10)-(S13) */
    double Ldd, theta1dd, theta2dd;
} leg_acceleration;

/* kinematics.leg_positions: r = R p_i, d = p + r - B_i, L = |d|, u = d / L (S4),
   sin and cos theta_2 (S5) */
static void leg_position_of(const double *P, int i, const platform_motion *pm,
                            leg_position *g)
{
    g->r = mat_vec(pm->R, load(P + P_JOINTS + 3 * i));
    v3 d = sub(add(pm->p, g->r), load(P + P_BASE + 3 * i));
    g->L = sqrt(dot(d, d));
    g->inv_L = 1.0 / g->L;
    g->u = scale(g->inv_L, d);
    g->a1 = load(P + P_AXES + 3 * i);
    g->s2 = dot(g->u, g->a1);
    g->a1xu = cross(g->a1, g->u);
    g->c2 = sqrt(dot(g->a1xu, g->a1xu));
    g->inv_c2 = 1.0 / g->c2;
}

/* The joint angles of leg i of axis u: theta_1 = atan2(-e2 . u, e3 . u),
   theta_2 = atan2(a_1 . u, |a_1 x u|) (S5) (kinematics.leg_positions) and the
   spherical joint's acos(u . z), z = R e_3 (kinematics.spherical_joint_angles).
   A third of a sample: a batch computes them only where a joint-angle limit is
   set (JOINT_ANGLES_NEEDED), else joint_angles() does on first read; a single
   solve always (a node publishes them every cycle). */
static void leg_angles(const double *P, int i, v3 u, v3 z, double *theta1, double *theta2,
                       double *spherical)
{
    v3 a1 = load(P + P_AXES + 3 * i), a1xu = cross(a1, u);
    const double *C = P + P_FRAMES + 9 * i;      /* C_i = [e1 e2 e3], row-major */
    double local1 = C[1] * u.x + C[4] * u.y + C[7] * u.z;
    double local2 = C[2] * u.x + C[5] * u.y + C[8] * u.z;
    *theta1 = atan2(-local1, local2);
    *theta2 = atan2(dot(u, a1), sqrt(dot(a1xu, a1xu)));
    double c = dot(u, z);
    *spherical = acos(c < -1.0 ? -1.0 : c > 1.0 ? 1.0 : c);
}

#define JOINT_ANGLES_NEEDED(P) (P[P_U_MAX] < INFINITY || P[P_S_MAX] < INFINITY)

/* kinematics.leg_velocities: (S6)-(S9) */
static void leg_velocity_of(const leg_position *g, const platform_motion *pm, leg_velocity *w)
{
    w->vP = add(pm->v, cross(pm->omega, g->r));
    w->Ld = dot(g->u, w->vP);
    w->ud = scale(g->inv_L, sub(w->vP, scale(w->Ld, g->u)));
    w->theta1d = dot(g->a1xu, w->ud) * (g->inv_c2 * g->inv_c2);
    w->theta2d = dot(g->a1, w->ud) * g->inv_c2;
    w->sigma = g->s2 * w->theta1d;
    w->omega = add(cross(g->u, w->ud), scale(w->sigma, g->u));
}

/* kinematics.leg_accelerations: (S10)-(S13) */
static void leg_acceleration_of(const leg_position *g, const leg_velocity *w,
                                const platform_motion *pm, leg_acceleration *k)
{
    v3 o = pm->omega;
    k->aP = add(add(pm->a, cross(pm->eps, g->r)), cross(o, cross(o, g->r)));
    v3 u = g->u, ud = w->ud;
    double L = g->L;
    k->Ldd = dot(u, k->aP) + L * dot(ud, ud);
    k->udd = scale(g->inv_L, sub(sub(k->aP, scale(k->Ldd, u)), scale(2.0 * w->Ld, ud)));
    double inv_c2sq = g->inv_c2 * g->inv_c2;
    double a1ud = dot(g->a1, ud);
    k->theta1dd = (dot(g->a1xu, k->udd) + 2.0 * g->s2 * a1ud * w->theta1d) * inv_c2sq;
    k->theta2dd = (dot(g->a1, k->udd) + g->s2 * a1ud * a1ud * inv_c2sq) * g->inv_c2;
    double sigma_d = g->s2 * k->theta1dd + a1ud * w->theta1d;
    k->eps = add(add(cross(u, k->udd), scale(sigma_d, u)), scale(w->sigma, ud));
}

/* ---- Dynamics (S14)-(S23): dynamics.py ---- */

/* I_k x with I_k = I_across Pi + I_along u u^T (S15) */
static inline v3 axisymmetric_product(const double *body, v3 u, v3 x)
{
    v3 along = scale(dot(u, x), u);
    return add(scale(body[K_ACROSS], sub(x, along)), scale(body[K_ALONG], along));
}

/* G_i, the leg's inertia and weight carried to P_i (S14), (S15), (S20):
   dynamics.leg_forces, leg_moment, carried_force */
static v3 carried_force(const double *P, int fx, const leg_position *g, const leg_velocity *w,
                        const leg_acceleration *k)
{
    const double *cyl = P + P_CYLINDER, *rod = P + P_ROD;
    v3 F1 = ZERO, F2 = ZERO;
    if (fx & E_LEG) {                                                  /* (S14) */
        F1 = scale(cyl[K_MASS] * cyl[K_COM], k->udd);
        F2 = scale(rod[K_MASS], sub(k->aP, scale(rod[K_COM], k->udd)));
    }
    if (fx & E_GRAVITY) {                   /* - m_k g, g = (0, 0, -gravity) */
        double g_z = -P[P_GRAVITY];
        F1.z = F1.z - cyl[K_MASS] * g_z;
        F2.z = F2.z - rod[K_MASS] * g_z;
    }
    v3 u = g->u;
    v3 m = sub(scale(cyl[K_COM], F1), scale(rod[K_COM], F2));
    v3 T = sub(m, scale(dot(u, m), u));                                /* Pi_i (...) */
    if (fx & E_LEG) {                                                  /* N_i (S15) */
        double leg[LEG_SIZE];
        leg[K_ACROSS] = cyl[K_ACROSS] + rod[K_ACROSS];    /* both turn with omega_i */
        leg[K_ALONG] = cyl[K_ALONG] + rod[K_ALONG];
        v3 N = add(axisymmetric_product(leg, u, k->eps),
                   cross(w->omega, axisymmetric_product(leg, u, w->omega)));
        T = add(add(T, cross(N, u)),
                scale(g->s2 * dot(u, N) * (g->inv_c2 * g->inv_c2), g->a1xu));
    }
    return add(F2, scale(g->inv_L, T));
}

/* (F_0, N_0 + rho x F_0) of a body on the platform about its origin (S16):
   dynamics.rigid_body_wrench; the inertia terms only if `inertia`, the weight
   only if `weight` */
static void rigid_body_wrench(const double *body, const double *P, const platform_motion *pm,
                              int weight, int inertia, v3 *F, v3 *M)
{
    v3 rho = mat_vec(pm->R, load(body + R_COM));
    v3 g = vec(0.0, 0.0, -P[P_GRAVITY]);
    double m = body[R_MASS];
    v3 moment = ZERO;
    v3 force;
    if (inertia) {
        v3 o = pm->omega, e = pm->eps;
        v3 a_c = add(add(pm->a, cross(e, rho)), cross(o, cross(o, rho)));
        force = scale(m, weight ? sub(a_c, g) : a_c);
        /* R I_c R^T eps + omega x R I_c R^T omega = R (I_c eps_b + omega_b x I_c omega_b),
           eps_b = R^T eps, omega_b = R^T omega: the body's frame */
        const double (*I)[3] = (const double (*)[3])(body + R_INERTIA);
        v3 ob = mat_t_vec(pm->R, o), eb = mat_t_vec(pm->R, e);
        moment = mat_vec(pm->R, add(mat_vec(I, eb), cross(ob, mat_vec(I, ob))));
    } else {
        force = scale(-m, g);
    }
    *F = add(*F, force);
    *M = add(*M, add(moment, cross(rho, force)));
}

/* dynamics.has_inertia: the scene moves some body */
static inline int has_inertia(const double *P, int fx)
{
    return (fx & (E_PLATFORM | E_LEG)) || ((fx & E_PAYLOAD) && P[P_PAYLOAD + R_MASS] > 0.0);
}

/* inv = A^-1 (6x6, row-major) by Gauss-Jordan elimination with partial
   pivoting, in place on inv; 0 if A is exactly singular */
static int invert6(double A[6][6], double inv[6][6])
{
    int swapped[6];
    memcpy(inv, A, 36 * sizeof(double));
    double (*a)[6] = inv;
    for (int k = 0; k < 6; k++) {
        int p = k;
        for (int r = k + 1; r < 6; r++)
            if (fabs(a[r][k]) > fabs(a[p][k]))
                p = r;
        if (!(a[p][k] != 0.0))
            return 0;
        swapped[k] = p;
        if (p != k)
            for (int j = 0; j < 6; j++) {
                double t = a[k][j]; a[k][j] = a[p][j]; a[p][j] = t;
            }
        double piv = 1.0 / a[k][k];
        a[k][k] = 1.0;
        for (int j = 0; j < 6; j++)
            a[k][j] *= piv;
        for (int i = 0; i < 6; i++) {
            if (i == k)
                continue;
            double f = a[i][k];
            a[i][k] = 0.0;
            for (int j = 0; j < 6; j++)
                a[i][j] -= f * a[k][j];
        }
    }
    for (int k = 5; k >= 0; k--)
        if (swapped[k] != k)
            for (int i = 0; i < 6; i++) {
                double t = a[i][k]; a[i][k] = a[i][swapped[k]]; a[i][swapped[k]] = t;
            }
    return 1;
}

/* the Frobenius condition ||A||_F ||A^-1||_F, an upper bound of the 2-norm
   condition (and at most 6 times it) */
static double frobenius_condition(const double A[6][6], const double inv[6][6])
{
    double a = 0.0, b = 0.0;
    for (int r = 0; r < 6; r++)
        for (int c = 0; c < 6; c++) {
            a += A[r][c] * A[r][c];
            b += inv[r][c] * inv[r][c];
        }
    return sqrt(a) * sqrt(b);
}

/* One Jacobi rotation of the columns x, y (length 6) that makes them
   orthogonal, unless it would change their squared norms by less than 1e-16
   of the smaller one (the singular values are then final); 1 if it rotated.
   Norms and product are computed afresh each time (updated norms lose the
   small singular values' relative accuracy). The angle's tangent
   t = sign(d) 2 xy / (|d| + hypot(d, 2 xy)), d = yy - xx (Rutishauser's
   t = sign(zeta) / (|zeta| + sqrt(1 + zeta^2)), zeta = d / (2 xy)), with
   cos = 1 / sqrt(1 + t^2): two square roots and one division. */
static inline int rotate(double *x, double *y)
{
    double xx = 0.0, yy = 0.0, xy = 0.0;
    for (int r = 0; r < 6; r++) {
        xx += x[r] * x[r];
        yy += y[r] * y[r];
        xy += x[r] * y[r];
    }
    double d = yy - xx, small = 1e-16 * (xx < yy ? xx : yy);
    if (xy * xy <= small * fabs(d))     /* |t xy| <= xy^2 / |d|: settled */
        return 0;
    double e = d >= 0.0 ? 2.0 * xy : -2.0 * xy;     /* t = e / D */
    double D = fabs(d) + sqrt(d * d + e * e);
    if (!(fabs(e * xy) > small * D))    /* |t xy|: the change of the squared norms */
        return 0;
    double inv = 1.0 / sqrt(D * D + e * e);
    double c = D * inv, s = e * inv;
    for (int r = 0; r < 6; r++) {
        double a = x[r], b = y[r];
        x[r] = c * a - s * b;
        y[r] = s * a + c * b;
    }
    return 1;
}

/* The pairs of a Jacobi sweep in rounds of three disjoint pairs (a round-robin
   tournament): the three rotations of a round are independent of each other.
   The first round pairs the columns of J the hexapod couples (u_x with
   (r x u)_y, u_y with (r x u)_x, u_z with (r x u)_z: surge-pitch, sway-roll,
   heave-yaw), which saves about a tenth of the sweeps on the shipped machines. */
static const int ROUNDS[5][3][2] = {
    {{5, 2}, {3, 1}, {0, 4}}, {{5, 1}, {2, 4}, {3, 0}},
    {{5, 4}, {1, 0}, {2, 3}}, {{5, 0}, {4, 3}, {1, 2}},
    {{5, 3}, {0, 2}, {4, 1}}};

/* 2-norm condition sigma_max / sigma_min of the 6x6 J (row-major) by one-sided
   Jacobi (Hestenes): plane rotations make J's columns orthogonal, the singular
   values are then their norms, to high relative accuracy (numpy's SVD in
   kinematics.jacobian_condition has J's 2-norm error). SINGULAR where J is
   singular or not finite. */
static double jacobian_condition(const double *J)
{
    double a[6][6];             /* a[c]: column c */
    for (int c = 0; c < 6; c++)
        for (int r = 0; r < 6; r++) {
            if (!isfinite(J[6 * r + c]))
                return SINGULAR;
            a[c][r] = J[6 * r + c];
        }
    for (int sweep = 0; sweep < 30; sweep++) {
        int rotated = 0;
        for (int k = 0; k < 5; k++)
            for (int m = 0; m < 3; m++)
                rotated |= rotate(a[ROUNDS[k][m][0]], a[ROUNDS[k][m][1]]);
        if (!rotated)
            break;
    }
    double hi = 0.0, lo = INFINITY;
    for (int c = 0; c < 6; c++) {
        double s = 0.0;
        for (int r = 0; r < 6; r++)
            s += a[c][r] * a[c][r];
        hi = s > hi ? s : hi;
        lo = s < lo ? s : lo;
    }
    double cond = sqrt(hi) / sqrt(lo);
    return isfinite(cond) ? cond : SINGULAR;
}

/* The wrench (F, M) the actuators balance at the motion pm of the legs g, w, k
   (S14)-(S21): dynamics.generalised_wrench; without velocity products the
   inertia of the same accelerations from rest */
static void generalised_wrench(const double *P, int fx, const double *q, const double *qd,
                               const double *qdd, const platform_motion *pm,
                               const leg_position *g, const leg_velocity *w,
                               const leg_acceleration *k, double *wrench)
{
    platform_motion rest;                        /* no velocity products: from rest */
    const platform_motion *dyn = pm;
    const leg_velocity *dw = w;
    const leg_acceleration *dk = k;
    leg_velocity w0[6];
    leg_acceleration k0[6];
    if (!(fx & E_VP) && has_inertia(P, fx)) {
        platform_motion_of(P, q, qd, qdd, 0, &rest);
        dyn = &rest;
        for (int i = 0; i < 6; i++) {
            leg_velocity_of(&g[i], dyn, &w0[i]);
            leg_acceleration_of(&g[i], &w0[i], dyn, &k0[i]);
        }
        dw = w0;
        dk = k0;
    }
    v3 F = ZERO, M = ZERO;                                              /* w_0 (S16) */
    int weight = (fx & E_GRAVITY) != 0;
    if ((fx & E_PLATFORM) || weight)
        rigid_body_wrench(P + P_PLATFORM, P, dyn, weight, (fx & E_PLATFORM) != 0, &F, &M);
    if ((fx & E_PAYLOAD) && P[P_PAYLOAD + R_MASS] > 0.0)
        rigid_body_wrench(P + P_PAYLOAD, P, dyn, weight, 1, &F, &M);
    if (fx & (E_LEG | E_GRAVITY)) {                                     /* (S20)-(S21) */
        v3 sG = ZERO, sM = ZERO;
        for (int i = 0; i < 6; i++) {
            v3 G = carried_force(P, fx, &g[i], &dw[i], &dk[i]);
            sG = add(sG, G);
            sM = add(sM, cross(g[i].r, G));
        }
        F = add(F, sG);
        M = add(M, sM);
    }
    wrench[0] = F.x; wrench[1] = F.y; wrench[2] = F.z;
    wrench[3] = M.x; wrench[4] = M.y; wrench[5] = M.z;
}

/* ---- One sample: solver._evaluate, _status, _clean ---- */

static void void_row(double *out, int code, int info)
{
    memset(out, 0, O_POSE * sizeof(double));
    out[O_STATUS] = code;
    out[O_INFO] = info;
}

/* One sample, everything it calls inlined into it (GCC and clang): about a
   tenth of a sample saved, measured on the default machine */
#if defined(__GNUC__)
__attribute__((flatten))
#endif
static void solve_one(const double *P, int fx, const double *q, const double *qd,
                      const double *qdd, int angles, double *out)
{
    memcpy(out + O_POSE, q, 6 * sizeof(double));
    for (int j = 0; j < 18; j++) {          /* solver._first_bad_input */
        double x = j < 6 ? q[j] : j < 12 ? qd[j - 6] : qdd[j - 12];
        if (!isfinite(x)) {
            void_row(out, S_INVALID, j);
            return;
        }
    }
    platform_motion pm;
    platform_motion_of(P, q, qd, qdd, 1, &pm);                        /* (S1)-(S3) */
    leg_position g[6];
    leg_velocity w[6];
    leg_acceleration k[6];
    double *J = out + O_TWIST_JACOBIAN, *JL = out + O_JACOBIAN;
    int degenerate = -1;
    v3 z = vec(pm.R[0][2], pm.R[1][2], pm.R[2][2]);
    for (int i = 0; i < 6; i++) {
        leg_position_of(P, i, &pm, &g[i]);                             /* (S4)-(S5) */
        leg_velocity_of(&g[i], &pm, &w[i]);                            /* (S6)-(S9) */
        leg_acceleration_of(&g[i], &w[i], &pm, &k[i]);                 /* (S10)-(S13) */
        out[O_LENGTH + i] = g[i].L;
        out[O_STROKE + i] = g[i].L - P[P_HOME_LENGTHS + i];
        out[O_RATE + i] = w[i].Ld;
        out[O_ACCELERATION + i] = k[i].Ldd;
        double *jt = out + O_JOINTS + 3 * i, *jr = out + O_JOINT_RATES + 3 * i,
               *ja = out + O_JOINT_ACCELERATIONS + 3 * i;
        jt[2] = g[i].L;
        if (angles)
            leg_angles(P, i, g[i].u, z, &jt[0], &jt[1], &out[O_SPHERICAL + i]);
        else {                                   /* joint_angles() on first read */
            jt[0] = jt[1] = 0.0;
            out[O_SPHERICAL + i] = NOT_COMPUTED;
        }
        jr[0] = w[i].theta1d; jr[1] = w[i].theta2d; jr[2] = w[i].Ld;
        ja[0] = k[i].theta1dd; ja[1] = k[i].theta2dd; ja[2] = k[i].Ldd;
        v3 m = cross(g[i].r, g[i].u);            /* (S21): J row i = [u^T (r x u)^T] */
        double row[6] = {g[i].u.x, g[i].u.y, g[i].u.z, m.x, m.y, m.z};
        for (int j = 0; j < 3; j++) {            /* (S22): J_L = [J[:, :3] J[:, 3:] E] */
            J[6 * i + j] = row[j];
            J[6 * i + 3 + j] = row[3 + j];
            JL[6 * i + j] = row[j];
            JL[6 * i + 3 + j] = row[3] * pm.E[0][j] + row[4] * pm.E[1][j] + row[5] * pm.E[2][j];
        }
        if (degenerate < 0 && !(g[i].L > MIN_LENGTH && g[i].c2 >= U_JOINT_TOLERANCE))
            degenerate = i;                      /* kinematics.degenerate_legs */
    }
    /* an unreachable sample is void whatever its condition. J's 2-norm
       condition is at most its Frobenius condition: where that is within both
       limits, the condition is not needed for the status and is left to
       conditions() (NOT_COMPUTED; the Jacobi sweeps are half a solve). */
    double cond = SINGULAR, X[6][6];             /* X = J^-T */
    int solvable = 0;
    if (degenerate < 0) {
        double JT[6][6];
        for (int r = 0; r < 6; r++)
            for (int c = 0; c < 6; c++)
                JT[r][c] = J[6 * c + r];
        int invertible = invert6(JT, X);
        double bound = P[P_MAX_COND] < MAX_SOLVED_CONDITION ? P[P_MAX_COND]
                                                            : MAX_SOLVED_CONDITION;
        if (invertible && frobenius_condition((const double (*)[6])J, X) <= bound)
            cond = NOT_COMPUTED;
        else
            cond = jacobian_condition(J);
        solvable = invertible && cond < MAX_SOLVED_CONDITION;
    }

    /* the wrench the actuators balance (S14)-(S21): dynamics.generalised_wrench */
    double wrench[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    if (solvable)
        generalised_wrench(P, fx, q, qd, qdd, &pm, g, w, k, wrench);
    for (int i = 0; i < 6; i++) {
        double f = NAN;                          /* no forces through a singular J */
        if (solvable) {                          /* f = J^-T wrench (S21) */
            f = 0.0;
            for (int c = 0; c < 6; c++)
                f += X[i][c] * wrench[c];
        }
        if (fx & E_FRICTION)                                            /* (S23) */
            f = f + (P[P_VISCOUS + i] * w[i].Ld
                     + P[P_COULOMB + i] * tanh(w[i].Ld / P[P_SMOOTHING]));
        out[O_FORCE + i] = f;
        out[O_POWER + i] = f * w[i].Ld;
    }

    /* the status rule, worst first (solver._status) */
    double zero[4] = {0.0, 0.0, 0.0, 0.0};       /* x * 0: NaN unless x is finite */
    for (int j = O_LENGTH; j + 3 <= O_TWIST_JACOBIAN_END; j += 4)
        for (int m = 0; m < 4; m++)
            zero[m] += out[j + m] * 0.0;
    int finite = (zero[0] + zero[1]) + (zero[2] + zero[3]) == 0.0;
    int over = 0;    /* solver._over_limits: a usage of limits.usages above 1, as compared here */
    for (int i = 0; i < 6; i++) {
        double L = out[O_LENGTH + i];
        over |= (L < P[P_LENGTH_MIN]) | (L > P[P_LENGTH_MAX])
            | (fabs(out[O_RATE + i]) > P[P_MAX_SPEED])
            | (fabs(out[O_FORCE + i]) > P[P_MAX_FORCE]);
        const double *jt = out + O_JOINTS + 3 * i;
        over |= angles && ((fabs(jt[0]) > P[P_U_MAX]) | (fabs(jt[1]) > P[P_U_MAX])
                           | (out[O_SPHERICAL + i] > P[P_S_MAX]));
    }
    int code = over ? S_LIMIT : S_OK, info = 0;
    if (!finite) {
        code = S_INVALID;
        info = RESULTS_NOT_FINITE;
    }
    if (!(cond <= P[P_MAX_COND])) {
        code = S_NEAR_SINGULAR;
        info = solvable && finite;
    }
    if (degenerate >= 0) {                       /* solver._unreachable_info */
        double L = g[degenerate].L, t1, t2, sph;
        leg_angles(P, degenerate, g[degenerate].u, z, &t1, &t2, &sph);
        int why = (isfinite(L) && L <= MIN_LENGTH) ? U_LENGTH
            : !(isfinite(L) && isfinite(t1) && isfinite(t2)) ? U_NOT_FINITE : U_JOINT;
        code = S_UNREACHABLE;
        info = degenerate + 6 * why;
    }
    if (code >= S_UNREACHABLE) {                 /* solver._clean: a void sample is 0 */
        void_row(out, code, info);
        return;
    }
    for (int j = O_LENGTH; !finite && j <= O_TWIST_JACOBIAN_END; j++)  /* and what is not */
        if (!isfinite(out[j]))                                          /* finite */
            out[j] = 0.0;
    out[O_COND] = cond;
    out[O_STATUS] = code;
    out[O_INFO] = info;
}

/* ---- The twin's RK4 loop (core.simulation.integrate) for a tabulated force law ---- */

/* The columns of the wrench of unit pose accelerations from rest, no weight
   (S10)-(S21): W[r][j] = d wrench_r / d qdd_j, the inertia of the platform,
   the payload and the legs. Each leg's carried force G_i (S14)-(S15), (S20)
   is linear in the acceleration a_P of its joint, a_P of a unit qdd_j = a_j +
   eps_j x r_i (S10), eps_j = E e_j (S2). */
static void unit_wrenches(const double *P, int fx, const platform_motion *pm,
                          const leg_position *g, double W[6][6])
{
    v3 lin[6], ang[6];                      /* a and eps of each unit qdd_j */
    for (int j = 0; j < 6; j++) {
        lin[j] = j < 3 ? vec(j == 0, j == 1, j == 2) : ZERO;
        ang[j] = j < 3 ? ZERO : vec(pm->E[0][j - 3], pm->E[1][j - 3], pm->E[2][j - 3]);
    }
    v3 F[6], M[6];
    for (int j = 0; j < 6; j++)
        F[j] = M[j] = ZERO;
    for (int b = 0; b < 2; b++) {           /* rigid_body_wrench at rest, no weight (S16) */
        const double *body = b == 0 ? P + P_PLATFORM : P + P_PAYLOAD;
        if (b == 0 ? !(fx & E_PLATFORM) : !((fx & E_PAYLOAD) && body[R_MASS] > 0.0))
            continue;
        v3 rho = mat_vec(pm->R, load(body + R_COM));
        double RI[3][3], Ib[3][3];                               /* R I_c R^T */
        const double *I = body + R_INERTIA;
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++)
                RI[i][k] = pm->R[i][0] * I[k] + pm->R[i][1] * I[3 + k] + pm->R[i][2] * I[6 + k];
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++)
                Ib[i][k] = RI[i][0] * pm->R[k][0] + RI[i][1] * pm->R[k][1]
                    + RI[i][2] * pm->R[k][2];
        for (int j = 0; j < 6; j++) {
            v3 force = scale(body[R_MASS], add(lin[j], cross(ang[j], rho)));
            F[j] = add(F[j], force);
            M[j] = add(M[j], add(mat_vec(Ib, ang[j]), cross(rho, force)));
        }
    }
    if (fx & E_LEG) {                                                   /* (S20)-(S21) */
        const double *cyl = P + P_CYLINDER, *rod = P + P_ROD;
        double I_pm = cyl[K_MASS] * cyl[K_COM] * cyl[K_COM] + rod[K_MASS] * rod[K_COM] * rod[K_COM];
        double I_across = cyl[K_ACROSS] + rod[K_ACROSS], I_along = cyl[K_ALONG] + rod[K_ALONG];
        for (int i = 0; i < 6; i++) {
            /* at rest udd = Pi a_P / L (S10)-(S11), theta_1dd = (a_1 x u) . udd / c^2
               (S12), eps = u x udd + s theta_1dd u (S13), so carried_force is
               G = m_rod a_P + alpha Pi a_P / L + beta ((a_1 x u) . a_P) (a_1 x u) */
            double inv_L = g[i].inv_L, s2 = g[i].s2, ic2 = g[i].inv_c2 * g[i].inv_c2;
            double alpha = ((I_pm + I_across) * inv_L - 2.0 * rod[K_MASS] * rod[K_COM]) * inv_L;
            double beta = s2 * s2 * I_along * ic2 * ic2 * inv_L * inv_L;
            const double u[3] = {g[i].u.x, g[i].u.y, g[i].u.z};
            const double n[3] = {g[i].a1xu.x, g[i].a1xu.y, g[i].a1xu.z};
            v3 A[3];                                /* G_i = A_i a_P, column by column */
            for (int c = 0; c < 3; c++) {
                double col[3];
                for (int r = 0; r < 3; r++)
                    col[r] = (r == c ? rod[K_MASS] + alpha : 0.0) - alpha * u[r] * u[c]
                             + beta * n[r] * n[c];
                A[c] = vec(col[0], col[1], col[2]);
            }
            for (int j = 0; j < 6; j++) {
                v3 G;
                if (j < 3) {                        /* a_P = e_j */
                    G = A[j];
                } else {
                    v3 aP = cross(ang[j], g[i].r);
                    G = add(add(scale(aP.x, A[0]), scale(aP.y, A[1])), scale(aP.z, A[2]));
                }
                F[j] = add(F[j], G);
                M[j] = add(M[j], cross(g[i].r, G));
            }
        }
    }
    for (int j = 0; j < 6; j++) {
        W[0][j] = F[j].x; W[1][j] = F[j].y; W[2][j] = F[j].z;
        W[3][j] = M[j].x; W[4][j] = M[j].y; W[5][j] = M[j].z;
    }
}

/* The terms of f = M qdd + b at (q, qd) (forward_dynamics.affine_terms) with
   the leg lengths and rates, for a stage of the twin: 1 when the state can be
   simulated; 0 when it stops or is left to the Python code (input or results
   not finite, a leg unreachable, J's condition maybe beyond
   limits.max_jacobian_condition). M = J^-T W (S21) from unit_wrenches; b = J^-T
   wrench(q, qd, 0) + friction (S14)-(S23). */
static int stage_terms(const double *P, int fx, const double *q, const double *qd,
                       double *L, double *Ld, double M[6][6], double *b)
{
    static const double REST[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    for (int j = 0; j < 6; j++)
        if (!(isfinite(q[j]) && isfinite(qd[j])))
            return 0;
    platform_motion pm;
    platform_motion_of(P, q, qd, REST, 1, &pm);                        /* (S1)-(S3) */
    leg_position g[6];
    leg_velocity w[6];
    leg_acceleration k[6];
    double J[6][6], JT[6][6], X[6][6];          /* X = J^-T */
    for (int i = 0; i < 6; i++) {
        leg_position_of(P, i, &pm, &g[i]);                             /* (S4) */
        if (!(g[i].L > MIN_LENGTH && g[i].c2 >= U_JOINT_TOLERANCE))
            return 0;
        leg_velocity_of(&g[i], &pm, &w[i]);                            /* (S6)-(S9) */
        leg_acceleration_of(&g[i], &w[i], &pm, &k[i]);                 /* (S10)-(S13) */
        L[i] = g[i].L;
        Ld[i] = w[i].Ld;
        v3 m = cross(g[i].r, g[i].u);            /* (S21): J row i = [u^T (r x u)^T] */
        double row[6] = {g[i].u.x, g[i].u.y, g[i].u.z, m.x, m.y, m.z};
        for (int j = 0; j < 6; j++)
            J[i][j] = JT[j][i] = row[j];
    }
    if (!invert6(JT, X))
        return 0;
    /* solve's rule: near_singular beyond the limit, no forces from 1e12 on */
    double bound = P[P_MAX_COND] < MAX_SOLVED_CONDITION ? P[P_MAX_COND]
                                                        : 0.5 * MAX_SOLVED_CONDITION;
    if (!(frobenius_condition(J, X) <= bound) && !(jacobian_condition(&J[0][0]) <= bound))
        return 0;                                /* the Python code gives the status */
    double wrench[6], W[6][6];
    generalised_wrench(P, fx, q, qd, REST, &pm, g, w, k, wrench);
    unit_wrenches(P, fx, &pm, g, W);
    for (int r = 0; r < 6; r++) {
        double f = 0.0;
        for (int c = 0; c < 6; c++) {
            f += X[r][c] * wrench[c];
            double s = 0.0;
            for (int m = 0; m < 6; m++)
                s += X[r][m] * W[m][c];
            M[r][c] = s;
            if (!isfinite(s))
                return 0;
        }
        if (fx & E_FRICTION)                                            /* (S23) */
            f = f + (P[P_VISCOUS + r] * w[r].Ld
                     + P[P_COULOMB + r] * tanh(w[r].Ld / P[P_SMOOTHING]));
        if (!isfinite(f))
            return 0;
        b[r] = f;
    }
    return 1;
}

/* core.simulation.stage at (q, qd), stage j; 0 when the stage stops or is left
   to the Python code (stage_terms, or M not surely within
   core.forward_dynamics.MAX_MASS_CONDITION (1e8) by its Frobenius condition,
   or qdd not finite) */
static int stage(const double *P, int fx, const tabulated_law *law, Py_ssize_t j,
                 const double *q, const double *qd, double *qdd, double *force)
{
    double L[6], Ld[6], M[6][6], b[6], Minv[6][6], rhs[6];
    if (!stage_terms(P, fx, q, qd, L, Ld, M, b))
        return 0;
    for (int m = 0; m < 6; m++) {
        double command = law->ff[6 * j + m];
        if (law->servo) {
            command = command + law->kp[m] * (law->length_ref[6 * j + m] - L[m])
                      + law->kd[m] * (law->rate_ref[6 * j + m] - Ld[m]);
            command = deliver(command, Ld[m], law->max_force, law->max_speed);
        }
        force[m] = command;
        rhs[m] = command - b[m];
    }
    double A[6][6];
    memcpy(A, M, sizeof A);
    if (!invert6(A, Minv) || !(frobenius_condition(M, Minv) <= 1e8))
        return 0;
    int finite = 1;
    for (int m = 0; m < 6; m++) {
        double a = 0.0;
        for (int c = 0; c < 6; c++)
            a += Minv[m][c] * rhs[c];
        qdd[m] = a;
        finite = finite && isfinite(a);
    }
    return finite;
}

#define EFFECT_BITS_MAX E_ALL
/* a batch's rows shared out to threads (in_parallel, below) */
typedef void (*row_job)(const void *job, Py_ssize_t begin, Py_ssize_t end);
static void in_parallel(row_job run, const void *job, Py_ssize_t n);
#define SOLVE_ROWS(job, n) in_parallel(solve_rows, job, n)
#include "kernel_bindings.h"

/* ---- Python bindings ---- */


PyDoc_STRVAR(solve_doc,
"solve(params, effects, out, q, qd, qdd) -> (status, info, jacobian_condition)\n\n"
"One sample: q, qd, qdd lists or tuples of 6 floats; fills the writable buffer `out`\n"
"(OUT_SIZE float64) and returns the row's scalars (jacobian_condition NOT_COMPUTED\n"
"where the status does not need it: conditions()). params: the packed model\n"
"(kernel.pack_model); effects: the bit set (EFFECTS).");

static PyObject *py_solve(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double x[18];
    int fx;
    if (nargs != 6) {
        PyErr_SetString(PyExc_TypeError, "solve() takes 6 arguments");
        return NULL;
    }
    if (effect_bits(args[1], &fx) < 0 || dof_floats(args[3], "q", x) < 0
            || dof_floats(args[4], "qd", x + 6) < 0 || dof_floats(args[5], "qdd", x + 12) < 0)
        return NULL;
    Py_buffer pv, ov;
    if (get_doubles(args[0], &pv, P_SIZE, 0, "packed model") < 0)
        return NULL;
    if (get_doubles(args[2], &ov, OUT_SIZE, 1, "out") < 0) {
        PyBuffer_Release(&pv);
        return NULL;
    }
    double *out = (double *)ov.buf;
    solve_one((const double *)pv.buf, fx, x, x + 6, x + 12, 1, out);
    PyBuffer_Release(&pv);
    PyBuffer_Release(&ov);
    return Py_BuildValue("(iid)", (int)out[O_STATUS], (int)out[O_INFO], out[O_COND]);
}

/* A batch's samples (rows) are independent: they are shared out to one thread
   per usable CPU, at least MIN_SAMPLES_PER_THREAD each (starting a thread costs
   about as much as a few dozen samples). */
#define MIN_SAMPLES_PER_THREAD 1024
#define MAX_THREADS 16

typedef struct {
    row_job run;
    const void *job;
    Py_ssize_t begin, end;
} rows_part;

static void *run_part(void *arg)
{
    const rows_part *p = (const rows_part *)arg;
    p->run(p->job, p->begin, p->end);
    return NULL;
}

static int usable_cpus(void)
{
#if defined(__linux__)
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0)
        return CPU_COUNT(&set);
#endif
    return 1;
}

/* run(job, begin, end) over rows 0 to n, on as many threads as pay; the
   calling thread takes the first part (a thread that cannot start leaves its
   part to it). Called without the GIL. */
static void in_parallel(row_job run, const void *job, Py_ssize_t n)
{
    Py_ssize_t parts = n / MIN_SAMPLES_PER_THREAD;
    if (parts < 2) {                 /* one part: no thread, no look at the CPUs */
        run(job, 0, n);
        return;
    }
    int cpus = usable_cpus();
    if (parts > cpus)
        parts = cpus;
    if (parts > MAX_THREADS)
        parts = MAX_THREADS;
    if (parts < 1)
        parts = 1;
    rows_part part[MAX_THREADS];
    pthread_t thread[MAX_THREADS];
    int started[MAX_THREADS] = {0};
    for (Py_ssize_t k = 0; k < parts; k++) {
        part[k] = (rows_part){run, job, n * k / parts, n * (k + 1) / parts};
        if (k > 0)
            started[k] = pthread_create(&thread[k], NULL, run_part, &part[k]) == 0;
    }
    run_part(&part[0]);
    for (Py_ssize_t k = 1; k < parts; k++) {
        if (started[k])
            pthread_join(thread[k], NULL);
        else
            run_part(&part[k]);
    }
}

static void solve_rows(const void *job, Py_ssize_t begin, Py_ssize_t end)
{
    const batch_job *b = (const batch_job *)job;
    for (Py_ssize_t i = begin; i < end; i++)
        solve_one(b->P, b->fx, b->q + 6 * i, b->qd + 6 * i, b->qdd + 6 * i,
                  JOINT_ANGLES_NEEDED(b->P), b->out + OUT_SIZE * i);
}

PyDoc_STRVAR(solve_batch_doc,
"solve_batch(params, effects, q, qd, qdd, out) -> None\n\n"
"N samples: q, qd, qdd C-contiguous (N, 6) float64 buffers, out a writable\n"
"C-contiguous (N, OUT_SIZE) float64 buffer; each row as solve's, but the joint\n"
"angles left NOT_COMPUTED unless a joint-angle limit is set: joint_angles().\n"
"Releases the GIL and shares the samples out to one thread per usable CPU (at\n"
"least 1024 each).");

PyDoc_STRVAR(conditions_doc,
"conditions(jacobians, out) -> None\n\n"
"The 2-norm condition of each twist Jacobian: jacobians a C-contiguous (N, 36)\n"
"float64 buffer (each row J row-major), out a writable (N,) float64 buffer.\n"
"What solve leaves NOT_COMPUTED in a result row. Releases the GIL and shares the\n"
"rows out as solve_batch does.");

typedef struct {
    const double *J;
    double *cond;
} conditions_job;

static void condition_rows(const void *job, Py_ssize_t begin, Py_ssize_t end)
{
    const conditions_job *c = (const conditions_job *)job;
    for (Py_ssize_t i = begin; i < end; i++)
        c->cond[i] = jacobian_condition(c->J + 36 * i);
}

static PyObject *py_conditions(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "conditions() takes 2 arguments");
        return NULL;
    }
    Py_buffer out, jv;
    Py_ssize_t n = get_rows(args[1], &out, 1, 1, "out");
    if (n < 0)
        return NULL;
    if (get_doubles(args[0], &jv, 36 * n, 0, "jacobians") < 0) {
        PyBuffer_Release(&out);
        return NULL;
    }
    conditions_job job = {(const double *)jv.buf, (double *)out.buf};
    Py_BEGIN_ALLOW_THREADS
    in_parallel(condition_rows, &job, n);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&jv);
    PyBuffer_Release(&out);
    Py_RETURN_NONE;
}

PyDoc_STRVAR(joint_angles_doc,
"joint_angles(params, rows) -> None\n\n"
"Fills in place the joint angles (theta_1, theta_2 of each leg in 'joints',\n"
"'spherical_angles') of every result row that solve_batch left NOT_COMPUTED (its\n"
"spherical angles): rows a writable C-contiguous (N, OUT_SIZE) float64 buffer,\n"
"params the packed model the rows were solved with. Releases the GIL and shares\n"
"the rows out as solve_batch does.");

typedef struct {
    const double *P;
    double *rows;
} angles_job;

static void angle_rows(const void *job, Py_ssize_t begin, Py_ssize_t end)
{
    const angles_job *a = (const angles_job *)job;
    for (Py_ssize_t k = begin; k < end; k++) {
        double *out = a->rows + OUT_SIZE * k;
        if (out[O_SPHERICAL] != NOT_COMPUTED)
            continue;
        double R[3][3];
        rotation_of(out + O_POSE, R);
        v3 z = vec(R[0][2], R[1][2], R[2][2]);
        for (int i = 0; i < 6; i++) {
            double *jt = out + O_JOINTS + 3 * i;
            leg_angles(a->P, i, load(out + O_TWIST_JACOBIAN + 6 * i), z, &jt[0], &jt[1],
                       &out[O_SPHERICAL + i]);
        }
    }
}

static PyObject *py_joint_angles(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "joint_angles() takes 2 arguments");
        return NULL;
    }
    Py_buffer pv, rv;
    if (get_doubles(args[0], &pv, P_SIZE, 0, "packed model") < 0)
        return NULL;
    Py_ssize_t n = get_rows(args[1], &rv, OUT_SIZE, 1, "rows");
    if (n < 0) {
        PyBuffer_Release(&pv);
        return NULL;
    }
    angles_job job = {(const double *)pv.buf, (double *)rv.buf};
    Py_BEGIN_ALLOW_THREADS
    in_parallel(angle_rows, &job, n);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&pv);
    PyBuffer_Release(&rv);
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"solve", (PyCFunction)(void (*)(void))py_solve, METH_FASTCALL, solve_doc},
    {"solve_batch", (PyCFunction)(void (*)(void))py_solve_batch, METH_FASTCALL,
     solve_batch_doc},
    {"integrate", (PyCFunction)(void (*)(void))py_integrate, METH_FASTCALL, integrate_doc},
    {"conditions", (PyCFunction)(void (*)(void))py_conditions, METH_FASTCALL, conditions_doc},
    {"joint_angles", (PyCFunction)(void (*)(void))py_joint_angles, METH_FASTCALL,
     joint_angles_doc},
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_kernel",
    "Compiled solve and twin loop of the 6-UPS hexapod (see kernel.py).", -1, methods
};

/* the declarations at the top, as Python objects (read by kernel.py) */
static const field PACKED_FIELDS[] = { PACKED_MODEL(AS_FIELD) };
static const field RIGID_FIELDS[] = { RIGID_ROW(AS_FIELD) };
static const field LEG_FIELDS[] = { LEG_ROW(AS_FIELD) };
static const field RESULT_FIELDS[] = { RESULT_ROW(AS_FIELD) };
static const field EFFECT_FIELDS[] = { EFFECT_LIST(AS_BIT_FIELD) };
static const char *const STATUS_NAMES[] = { STATUS_LIST(AS_NAME) };
static const char *const UNREACHABLE_NAMES[] = { UNREACHABLE_LIST(AS_NAME) };


PyMODINIT_FUNC PyInit__kernel(void)
{
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddIntConstant(m, "P_SIZE", P_SIZE) < 0
            || PyModule_AddIntConstant(m, "OUT_SIZE", OUT_SIZE) < 0
            || PyModule_AddIntConstant(m, "RIGID_SIZE", RIGID_SIZE) < 0
            || PyModule_AddIntConstant(m, "LEG_SIZE", LEG_SIZE) < 0
            || PyModule_AddIntConstant(m, "RESULTS_NOT_FINITE", RESULTS_NOT_FINITE) < 0
            || add_object(m, "U_JOINT_TOLERANCE", PyFloat_FromDouble(U_JOINT_TOLERANCE)) < 0
            || add_object(m, "MIN_LENGTH", PyFloat_FromDouble(MIN_LENGTH)) < 0
            || add_object(m, "MAX_SOLVED_CONDITION", PyFloat_FromDouble(MAX_SOLVED_CONDITION)) < 0
            || add_object(m, "NOT_COMPUTED", PyFloat_FromDouble(NOT_COMPUTED)) < 0
            || add_object(m, "PACKED", fields_dict(PACKED_FIELDS, COUNT(PACKED_FIELDS), 0)) < 0
            || add_object(m, "RIGID_ROW", fields_dict(RIGID_FIELDS, COUNT(RIGID_FIELDS), 0)) < 0
            || add_object(m, "LEG_ROW", fields_dict(LEG_FIELDS, COUNT(LEG_FIELDS), 0)) < 0
            || add_object(m, "OUT", fields_dict(RESULT_FIELDS, COUNT(RESULT_FIELDS), 0)) < 0
            || add_object(m, "EFFECTS", fields_dict(EFFECT_FIELDS, COUNT(EFFECT_FIELDS), 1)) < 0
            || add_object(m, "STATUS", names_tuple(STATUS_NAMES, COUNT(STATUS_NAMES))) < 0
            || add_object(m, "UNREACHABLE",
                          names_tuple(UNREACHABLE_NAMES, COUNT(UNREACHABLE_NAMES))) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
