/*
 * flight_sim_dynamics.machines.staicu._kernel: the solver's scalar path (paper eq. 5-23)
 * for one cycle (solve) or a batch (solve_batch), and the twin's affine terms
 * and RK4 loop. A line-by-line transcription of kinematics.py, dynamics.py,
 * status_rule.py, forward_dynamics.py and core/simulation.py, in the same order of
 * operations (the Python code is the reference; test/machines/staicu/test_kernel.py and
 * test_twin_kernel.py check the two agree). Function names follow the Python ones.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define DOF 3   /* pose coordinates (and legs): the size of the shared headers' rows */
#include "kernel_support.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* The contracts with the Python side, as X-macro lists: the C enum and the
   exported table (PyInit__kernel) come from one line (the X-macros:
   core/kernel_support.h); kernel.py checks them. */

/* bodies with mass: the model's bodies (model.BODY_NAMES, any order), then the payload */
#define BODY_LIST(X) \
    X(CYL_A, "cylinder_a") X(PIS_A, "piston_a") X(ROD, "rod") X(PLATFORM, "platform") \
    X(CYL_B, "cylinder_b") X(PIS_B, "piston_b") X(CYL_C, "cylinder_c") X(PIS_C, "piston_c") \
    X(CRANK_D, "crank_d") X(CRANK_E, "crank_e") X(PAYLOAD, "payload")
enum { BODY_LIST(AS_ENUM) N_BODIES };

/* one body in the packed model: attributes of model.Body */
#define BODY_ROW(X) X(B_MASS, "mass", 1) X(B_COM, "com", 3) X(B_INERTIA, "inertia", 9)
enum { BODY_ROW(AS_OFFSET) BODY_SIZE };

/* the packed model (kernel.pack_model): attribute paths of model.Model, sizes */
#define PACKED_MODEL(X) \
    X(P_D1, "geometry.d1", 1) X(P_D2, "geometry.d2", 1) X(P_D3, "geometry.d3", 1) \
    X(P_D4, "geometry.d4", 1) X(P_D5, "geometry.d5", 1) X(P_L1, "geometry.l1", 1) \
    X(P_L2, "geometry.l2", 1) X(P_L3, "geometry.l3", 1) X(P_L4, "geometry.l4", 1) \
    X(P_L5, "geometry.l5", 1) X(P_L6, "geometry.l6", 1) X(P_B, "geometry.b", 1) \
    X(P_H, "geometry.h", 1) X(P_HG, "geometry.h_G", 1) X(P_SA, "geometry.s_A", 1) \
    X(P_SB, "geometry.s_B", 1) X(P_SC, "geometry.s_C", 1) \
    X(P_L0, "geometry.L0", 3)                   /* leg lengths at zero stroke */ \
    X(P_ZERO, "central.joint_zero", 12)         /* joint values at q = 0 */ \
    X(P_GRAVITY, "gravity", 1) \
    X(P_BODIES, "bodies", N_BODIES * BODY_SIZE) /* BODY_LIST order, BODY_ROW each */ \
    X(P_VISCOUS, "friction.viscous", 3) \
    X(P_COULOMB, "friction.coulomb", 3) \
    X(P_SMOOTHING, "friction.smoothing_velocity", 1) \
    X(P_STROKE_MIN, "limits.stroke_min", 1) X(P_STROKE_MAX, "limits.stroke_max", 1) \
    X(P_MAX_SPEED, "limits.max_speed", 1) X(P_MAX_FORCE, "limits.max_force", 1) \
    X(P_MAX_KIN, "limits.max_kinematic_condition", 1) \
    X(P_MAX_JAC, "limits.max_jacobian_condition", 1)
enum { PACKED_MODEL(AS_OFFSET) P_SIZE };

/* effects bits (effects.EFFECT_NAMES, any order); E_HAS_PAYLOAD: the model has one */
#define EFFECT_LIST(X) \
    X(E_GRAVITY, "gravity") X(E_PLATFORM, "platform_inertia") X(E_PAYLOAD, "payload") \
    X(E_LEG, "leg_inertia") X(E_CRANK, "crank_inertia") X(E_VP, "velocity_products") \
    X(E_FRICTION, "friction")
enum { EFFECT_LIST(AS_INDEX) N_EFFECTS };
enum { EFFECT_LIST(AS_BIT) E_HAS_PAYLOAD = 1 << N_EFFECTS };

/* one result row: Solution fields, then the status code and its info */
#define RESULT_ROW(X) \
    X(O_LENGTH, "length", 3) X(O_STROKE, "stroke", 3) X(O_RATE, "rate", 3) \
    X(O_ACCELERATION, "acceleration", 3) X(O_FORCE, "force", 3) X(O_POWER, "power", 3) \
    X(O_JOINTS, "joints", 12) X(O_JOINT_RATES, "joint_rates", 12) \
    X(O_JOINT_ACCELERATIONS, "joint_accelerations", 12) X(O_JACOBIAN, "jacobian", 9) \
    X(O_BETA, "beta", 1) X(O_KIN, "kinematic_condition", 1) \
    X(O_JAC, "jacobian_condition", 1) X(O_STATUS, "status", 1) X(O_INFO, "info", 1)
enum { RESULT_ROW(AS_OFFSET) OUT_SIZE };

/* status codes, by severity (status.py: SEVERITY) */
#define STATUS_LIST(X) \
    X(S_OK, "ok") X(S_LIMIT, "limit") X(S_NEAR_SINGULAR, "near_singular") \
    X(S_UNREACHABLE, "unreachable") X(S_INVALID, "invalid_input")
enum { STATUS_LIST(AS_ENUM) N_STATUS };

/* the loops in the order they are checked (kinematics.LOOPS) */
#define LOOP_LIST(X) \
    X(LOOP_D, "D") X(LOOP_E, "E") X(LOOP_E2, "E2 on rod") X(LOOP_A, "A") X(LOOP_B, "B") \
    X(LOOP_C, "C")
enum { LOOP_LIST(AS_ENUM) N_LOOPS };

/* info of an invalid sample whose results overflow (status.RESULTS_NOT_FINITE) */
#define RESULTS_NOT_FINITE (-1)

typedef struct { double x, y, z; } v3;

static inline v3 vec(double x, double y, double z) { v3 r = {x, y, z}; return r; }
static inline v3 add(v3 a, v3 b) { return vec(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline v3 sub(v3 a, v3 b) { return vec(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline v3 scale(double s, v3 a) { return vec(s * a.x, s * a.y, s * a.z); }
static inline v3 axpy(double s, v3 a, v3 b)   /* s a + b */
{ return vec(s * a.x + b.x, s * a.y + b.y, s * a.z + b.z); }
static inline double dot(v3 a, v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline v3 cross(v3 a, v3 b)
{ return vec(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
static inline v3 zx(v3 a) { return vec(-a.y, a.x, 0.0); }   /* z0 x a, eq. (10) */

typedef struct { v3 x, y, z; } axes3;      /* body axes in the fixed frame */

static inline v3 to_frame(const axes3 *R, v3 v)
{ return vec(dot(R->x, v), dot(R->y, v), dot(R->z, v)); }
static inline v3 from_frame(const axes3 *R, v3 c)
{
    return vec(c.x * R->x.x + c.y * R->y.x + c.z * R->z.x,
               c.x * R->x.y + c.y * R->y.y + c.z * R->z.y,
               c.x * R->x.z + c.y * R->y.z + c.z * R->z.z);
}
static inline v3 mat_vec(const double *m, v3 c)
{
    return vec(m[0] * c.x + m[1] * c.y + m[2] * c.z,
               m[3] * c.x + m[4] * c.y + m[5] * c.z,
               m[6] * c.x + m[7] * c.y + m[8] * c.z);
}
static inline double clip0(double x) { return x > 0.0 ? x : 0.0; }

/* Python's float a % b for b > 0 (sign of the divisor) */
static inline double pymod(double a, double b)
{
    if (a >= 0.0 && a < b)      /* the usual case: fmod(a, b) == a exactly */
        return a + 0.0;         /* (+ 0.0: -0.0 -> +0.0, as below) */
    double m = fmod(a, b);
    if (m != 0.0) {
        if ((b < 0.0) != (m < 0.0))
            m += b;
    } else {
        m = copysign(0.0, b);
    }
    return m;
}

/* ---- Inverse geometry (kinematics.closure, inverse_geometry; eq. 5-8) ---- */
typedef struct {
    v3 G, l, t, n, A3, D2, E2, B4, C4, dA, dB, dC, e2B, e2C, dD, dE;
    double roll, beta, u, LA, LB, LC, hB, hC;
    double raw[12];
    int failed;          /* -1, or the first loop that cannot close (LOOP order) */
} geometric;

static void unit_leg(v3 P4, v3 P1, double *L, v3 *d, double *h, v3 *e2)
{
    v3 v = sub(P4, P1);
    *L = sqrt(dot(v, v));
    *d = scale(1.0 / *L, v);
    *h = hypot(d->x, d->y);
    *e2 = vec(-d->y / *h, d->x / *h, 0.0);
}

static const int ANGLES[8] = {0, 2, 3, 4, 6, 7, 9, 10};

/* angles 0: the joint angles (raw[ANGLES]) are left 0, for a caller that
   reads no joint angle (the twin's RK4 stages) */
static void inverse_geometry(const double *P, const double *q, geometric *g, int angles)
{
    const double d1 = P[P_D1], d2 = P[P_D2], d3 = P[P_D3], d4 = P[P_D4], d5 = P[P_D5];
    const double l5 = P[P_L5], l6 = P[P_L6], b = P[P_B], h = P[P_H];
    double surge = q[0], heave = q[1], roll = q[2];
    g->G = vec(d2 + d3 + d4 + surge, P[P_HG] + heave, 0.0);
    /* loop D (kinematics._crank_d_beta) */
    double c = h - d1;
    double wx = g->G.x - (d2 + d3), wy = g->G.y;
    double rho2 = wx * wx + wy * wy;
    double rho = sqrt(rho2);
    double k = (rho2 + c * c - l5 * l5) / (2.0 * c);
    double disc_d = (rho - k) * (rho + k);
    double beta = atan2(wy, wx) - atan2(sqrt(clip0(disc_d)), k);
    double cb = cos(beta), sb = sin(beta), cr = cos(roll), sr = sin(roll);
    g->roll = roll;
    g->beta = beta;
    g->l = vec(cb, sb, 0.0);
    g->t = vec(sb * sr, -cb * sr, cr);
    g->n = vec(-cr * sb, cr * cb, sr);
    g->A3 = axpy(-h, g->l, g->G);
    g->D2 = axpy(-(h - d1), g->l, g->G);
    /* loop E (kinematics._crank_e_u) */
    wx = g->G.x - d2;
    wy = g->G.y;
    double p = wx * g->l.x + wy * g->l.y;
    double c0 = wx * wx + wy * wy - l6 * l6;
    double disc_e = p * p - c0;
    double root = sqrt(clip0(disc_e));
    double denominator = p + root;
    double u = denominator > 0.0 ? c0 / denominator : p - root;
    g->u = u;
    g->E2 = axpy(-u, g->l, g->G);
    double half_b = 0.5 * b;
    g->B4 = axpy(half_b, g->t, g->G);
    g->C4 = axpy(-half_b, g->t, g->G);
    g->LA = hypot(g->A3.x, g->A3.y);
    g->dA = vec(g->A3.x / g->LA, g->A3.y / g->LA, 0.0);
    v3 B1 = vec(d2 + d3 + d4, 0.0, d5);
    v3 C1 = vec(B1.x, 0.0, -d5);
    unit_leg(g->B4, B1, &g->LB, &g->dB, &g->hB, &g->e2B);
    unit_leg(g->C4, C1, &g->LC, &g->dC, &g->hC, &g->e2C);
    g->dD = vec((g->D2.x - d2 - d3) / l5, g->D2.y / l5, 0.0);
    g->dE = vec((g->E2.x - d2) / l6, g->E2.y / l6, 0.0);
    const double *L0 = P + P_L0;
    double *raw = g->raw;
    raw[1] = g->LA - L0[0];
    raw[5] = g->LB - L0[1];
    raw[8] = g->LC - L0[2];
    raw[11] = (h - d1) - u;
    if (angles) {
        double theta_A = atan2(g->dA.y, g->dA.x);
        raw[0] = theta_A;
        raw[2] = beta - theta_A;
        raw[3] = atan2(g->dB.y, g->dB.x);
        raw[4] = -atan2(g->dB.z, g->hB);
        raw[6] = atan2(g->dC.y, g->dC.x);
        raw[7] = -atan2(g->dC.z, g->hC);
        raw[9] = atan2(g->dD.y, g->dD.x);
        raw[10] = atan2(g->dE.y, g->dE.x);
    }
    const double tiny = 1e-9;
    g->failed = !(disc_d >= 0.0) ? LOOP_D
              : !(disc_e >= 0.0) ? LOOP_E
              : !((u >= 0.0) && (u <= h)) ? LOOP_E2
              : !(g->LA > tiny) ? LOOP_A
              : !((g->LB > tiny) && (g->hB > tiny)) ? LOOP_B
              : !((g->LC > tiny) && (g->hC > tiny)) ? LOOP_C : -1;
    /* joint variables from the central configuration, angles wrapped to (-pi, pi] */
    for (int i = 0; i < 12; i++)
        raw[i] = raw[i] - P[P_ZERO + i];
    for (int i = 0; i < 8; i++) {
        int j = ANGLES[i];
        raw[j] = angles ? pymod(raw[j] + M_PI, 2.0 * M_PI) - M_PI : 0.0;
    }
}

/* ---- Connectivity: block factorisation of Q (kinematics.factorize,
   solve_connectivity; eq. 11-12, 16) ---- */
typedef struct { v3 aD, bD, cA, aE, cE, cB, cC, eB, eC; double detD, detE; } connectivity;

static void factorize(const double *P, const geometric *g, connectivity *f)
{
    v3 D1 = vec(P[P_D2] + P[P_D3], 0.0, 0.0), E1 = vec(P[P_D2], 0.0, 0.0);
    f->aD = zx(sub(g->G, g->D2));
    f->bD = zx(sub(g->D2, D1));
    f->aE = zx(sub(g->E2, E1));
    v3 bE = g->l;
    f->detD = f->aD.x * f->bD.y - f->aD.y * f->bD.x;
    f->cA = zx(sub(g->G, g->A3));
    f->cE = zx(sub(g->G, g->E2));
    f->detE = -(f->aE.x * bE.y - f->aE.y * bE.x);
    f->cB = scale(-1.0, zx(sub(g->B4, g->G)));
    f->cC = scale(-1.0, zx(sub(g->C4, g->G)));
    f->eB = cross(g->e2B, g->dB);
    f->eC = cross(g->e2C, g->dC);
}

static void solve_connectivity(const geometric *g, const connectivity *f, const double *r,
                               double *X)
{
    double beta_dot = (r[8] * f->bD.y - r[9] * f->bD.x) / f->detD;
    X[9] = (f->aD.x * r[9] - f->aD.y * r[8]) / f->detD;
    double rx = r[0] - f->cA.x * beta_dot, ry = r[1] - f->cA.y * beta_dot;
    X[1] = g->dA.x * rx + g->dA.y * ry;
    X[0] = (g->dA.x * ry - g->dA.y * rx) / g->LA;
    X[2] = beta_dot - X[0];
    rx = r[10] - f->cE.x * beta_dot;
    ry = r[11] - f->cE.y * beta_dot;
    X[10] = (-rx * g->l.y + ry * g->l.x) / f->detE;
    X[11] = (f->aE.x * ry - f->aE.y * rx) / f->detE;
    for (int leg = 0; leg < 2; leg++) {
        int k = leg ? 6 : 3, row = leg ? 5 : 2;
        v3 c = leg ? f->cC : f->cB, e2 = leg ? g->e2C : g->e2B, e = leg ? f->eC : f->eB;
        v3 d = leg ? g->dC : g->dB;
        double h = leg ? g->hC : g->hB, L = leg ? g->LC : g->LB;
        v3 rr = vec(r[row] - c.x * beta_dot, r[row + 1] - c.y * beta_dot, r[row + 2]);
        X[k] = dot(e2, rr) / (L * h);
        X[k + 1] = dot(e, rr) / L;
        X[k + 2] = dot(d, rr);
    }
}

/* columns of P per unit surge, heave, roll rate (kinematics.pose_rate_columns, eq. 12) */
static void pose_rate_columns(const geometric *g, double cols[3][12])
{
    v3 lB = cross(g->l, sub(g->B4, g->G)), lC = cross(g->l, sub(g->C4, g->G));
    static const double surge[12] = {1, 0, 1, 0, 0, 1, 0, 0, 1, 0, 1, 0};
    static const double heave[12] = {0, 1, 0, 1, 0, 0, 1, 0, 0, 1, 0, 1};
    memcpy(cols[0], surge, sizeof surge);
    memcpy(cols[1], heave, sizeof heave);
    double roll[12] = {0.0, 0.0, lB.x, lB.y, lB.z, lC.x, lC.y, lC.z, 0.0, 0.0, 0.0, 0.0};
    memcpy(cols[2], roll, sizeof roll);
}

/* S of eq. (16)-(17) (kinematics.acceleration_column) */
static void acceleration_column(const double *P, const geometric *g, const double *V,
                                const double *qd, const double *qdd, double *S)
{
    const double d2 = P[P_D2], d3 = P[P_D3], d4 = P[P_D4], d5 = P[P_D5], h = P[P_H];
    v3 Gdd = vec(qdd[0], qdd[1], 0.0);
    double roll_d = qd[2], roll_dd = qdd[2];
    double beta_d = V[0] + V[2];
    double beta_d2 = beta_d * beta_d;
    v3 zl = zx(g->l);
    double th = V[0], Ld = V[1], LA = g->LA;
    v3 zdA = zx(g->dA);
    S[0] = Gdd.x - 2.0 * Ld * th * zdA.x + th * th * LA * g->dA.x + beta_d2 * h * g->l.x;
    S[1] = Gdd.y - 2.0 * Ld * th * zdA.y + th * th * LA * g->dA.y + beta_d2 * h * g->l.y;
    v3 omega_P = vec(roll_d * g->l.x, roll_d * g->l.y, beta_d);
    v3 eps_bias = axpy(roll_dd, g->l, scale(beta_d * roll_d, zl));
    double base_x = d2 + d3 + d4;
    for (int leg = 0; leg < 2; leg++) {
        int row = leg ? 5 : 2, k = leg ? 6 : 3;
        v3 P4 = leg ? g->C4 : g->B4, P1 = vec(base_x, 0.0, leg ? -d5 : d5);
        v3 d = leg ? g->dC : g->dB, e2 = leg ? g->e2C : g->e2B;
        v3 r = sub(P4, g->G), rho = sub(P4, P1);
        double w10 = V[k], w21 = V[k + 1], Lr = V[k + 2];
        v3 omega = vec(w21 * e2.x, w21 * e2.y, w10);
        v3 platform = cross(eps_bias, r);
        platform = axpy(1.0, cross(omega_P, cross(omega_P, r)), platform);
        v3 chain = scale(w10 * w21, cross(zx(e2), rho));
        chain = axpy(1.0, cross(omega, cross(omega, rho)), chain);
        chain = axpy(2.0 * Lr, cross(omega, d), chain);
        S[row] = Gdd.x + platform.x - chain.x;
        S[row + 1] = Gdd.y + platform.y - chain.y;
        S[row + 2] = Gdd.z + platform.z - chain.z;
    }
    double thD2 = V[9] * V[9], D1x = d2 + d3;
    S[8] = Gdd.x + beta_d2 * (g->G.x - g->D2.x) + thD2 * (g->D2.x - D1x);
    S[9] = Gdd.y + beta_d2 * (g->G.y - g->D2.y) + thD2 * g->D2.y;
    double thE2 = V[10] * V[10], v = V[11];
    S[10] = Gdd.x + 2.0 * v * beta_d * zl.x + beta_d2 * (g->G.x - g->E2.x)
            + thE2 * (g->E2.x - d2);
    S[11] = Gdd.y + 2.0 * v * beta_d * zl.y + beta_d2 * (g->G.y - g->E2.y) + thE2 * g->E2.y;
}

/* ---- Inverse dynamics (dynamics.body_states, required_wrench, joint_forces; eq. 18-22) */
typedef struct {
    int present, moving;
    axes3 R;
    v3 com, omega, eps, acc;
} body_state;

/* add_body of dynamics.body_states: frame, centre of mass and, if inertial,
   a_C = a_ref + eps x rho (+ omega x (omega x rho)), rho = C - ref */
static void add_body(body_state *s, const double *body, axes3 R, v3 origin, v3 omega, v3 eps,
                     v3 ref, v3 acc_ref, int vp)
{
    s->R = R;
    s->com = add(origin, from_frame(&R, vec(body[B_COM], body[B_COM + 1], body[B_COM + 2])));
    if (!s->moving)
        return;
    v3 rho = sub(s->com, ref);
    v3 acc = add(acc_ref, cross(eps, rho));
    if (vp)
        acc = add(acc, cross(omega, cross(omega, rho)));
    s->omega = omega;
    s->eps = eps;
    s->acc = acc;
}

static void body_states(const double *P, int fx, const geometric *g, const double *V,
                        const double *Gamma, const double *qd, const double *qdd,
                        body_state *st)
{
    const int vp = (fx & E_VP) != 0;
    const int payload = (fx & E_PAYLOAD) && (fx & E_HAS_PAYLOAD);
    const v3 zero = vec(0.0, 0.0, 0.0), Z0 = vec(0.0, 0.0, 1.0);
    for (int i = 0; i < N_BODIES; i++) {
        int moving;
        switch (i) {
        case PLATFORM: moving = (fx & E_PLATFORM) != 0; break;
        case PAYLOAD: moving = payload; break;
        case CRANK_D: case CRANK_E: moving = (fx & E_CRANK) != 0; break;
        default: moving = (fx & E_LEG) != 0;
        }
        st[i].moving = moving;
        st[i].present = i == PAYLOAD ? payload : (moving || (fx & E_GRAVITY));
    }
    const double *B = P + P_BODIES;
#define BODY(i) (B + (i) * BODY_SIZE)
    /* chain A */
    v3 zdA = zx(g->dA);
    axes3 RA = {g->dA, zdA, Z0};
    v3 wA = vec(0.0, 0.0, V[0]), eA = vec(0.0, 0.0, Gamma[0]);
    if (st[CYL_A].present)
        add_body(&st[CYL_A], BODY(CYL_A), RA, zero, wA, eA, zero, zero, vp);
    if (st[PIS_A].present) {
        v3 acc_slide = zero;
        if (st[PIS_A].moving) {
            acc_slide = scale(Gamma[1], g->dA);
            if (vp)
                acc_slide = axpy(2.0 * V[1] * V[0], zdA, acc_slide);
        }
        add_body(&st[PIS_A], BODY(PIS_A), RA, g->A3, wA, eA, zero, acc_slide, vp);
    }
    v3 Gdd = vec(qdd[0], qdd[1], 0.0);
    v3 zl = zx(g->l);
    if (st[ROD].present) {
        axes3 R = {g->l, zl, Z0};
        add_body(&st[ROD], BODY(ROD), R, g->A3, vec(0.0, 0.0, V[0] + V[2]),
                 vec(0.0, 0.0, Gamma[0] + Gamma[2]), g->G, Gdd, vp);
    }
    if (st[PLATFORM].present || st[PAYLOAD].present) {
        double beta_d = V[0] + V[2], beta_dd = Gamma[0] + Gamma[2];
        double roll_d = qd[2], roll_dd = qdd[2];
        v3 omega = vec(roll_d * g->l.x, roll_d * g->l.y, beta_d);
        v3 eps = vec(roll_dd * g->l.x, roll_dd * g->l.y, beta_dd);
        if (vp)
            eps = axpy(beta_d * roll_d, zl, eps);
        axes3 R = {g->l, g->n, g->t};
        if (st[PLATFORM].present)
            add_body(&st[PLATFORM], BODY(PLATFORM), R, g->A3, omega, eps, g->G, Gdd, vp);
        if (st[PAYLOAD].present)
            add_body(&st[PAYLOAD], BODY(PAYLOAD), R, g->A3, omega, eps, g->G, Gdd, vp);
    }
    /* chains B, C */
    double base_x = P[P_D2] + P[P_D3] + P[P_D4];
    for (int leg = 0; leg < 2; leg++) {
        int k = leg ? 6 : 3, cyl = leg ? CYL_C : CYL_B, pis = leg ? PIS_C : PIS_B;
        v3 P1 = vec(base_x, 0.0, leg ? -P[P_D5] : P[P_D5]);
        v3 P4 = leg ? g->C4 : g->B4, d = leg ? g->dC : g->dB, e2 = leg ? g->e2C : g->e2B;
        axes3 R = {d, cross(e2, d), e2};
        double w10 = V[k], w21 = V[k + 1];
        v3 omega = vec(w21 * e2.x, w21 * e2.y, w10);
        v3 eps = vec(Gamma[k + 1] * e2.x, Gamma[k + 1] * e2.y, Gamma[k]);
        if (vp)
            eps = axpy(w10 * w21, zx(e2), eps);
        if (st[cyl].present)
            add_body(&st[cyl], BODY(cyl), R, P1, omega, eps, P1, zero, vp);
        if (st[pis].present) {
            v3 acc_slide = scale(Gamma[k + 2], d);
            if (vp)
                acc_slide = axpy(2.0 * V[k + 2], cross(omega, d), acc_slide);
            add_body(&st[pis], BODY(pis), R, P4, omega, eps, P1, acc_slide, vp);
        }
    }
    /* cranks D, E */
    for (int c = 0; c < 2; c++) {
        int i = c ? CRANK_E : CRANK_D, k = c ? 10 : 9;
        if (!st[i].present)
            continue;
        v3 P1 = vec(c ? P[P_D2] : P[P_D2] + P[P_D3], 0.0, 0.0), d = c ? g->dE : g->dD;
        axes3 R = {d, zx(d), Z0};
        add_body(&st[i], BODY(i), R, P1, vec(0.0, 0.0, V[k]), vec(0.0, 0.0, Gamma[k]), P1,
                 zero, vp);
    }
#undef BODY
}

/* F_k0, M_k0 of eq. (21) about `about` (dynamics.required_wrench) */
static void required_wrench(const body_state *s, const double *body, double gravity, v3 about,
                            int vp, v3 *F, v3 *M)
{
    double m = body[B_MASS];
    if (!s->moving) {
        *F = vec(0.0, m * gravity, 0.0);
        *M = cross(sub(s->com, about), *F);
        return;
    }
    v3 a = s->acc;
    *F = vec(m * a.x, m * (a.y + gravity), m * a.z);
    const double *I = body + B_INERTIA;
    v3 moment_body = mat_vec(I, to_frame(&s->R, s->eps));
    if (vp) {
        v3 w = to_frame(&s->R, s->omega);
        moment_body = add(moment_body, cross(w, mat_vec(I, w)));
    }
    *M = add(from_frame(&s->R, moment_body), cross(sub(s->com, about), *F));
}

/* sum of the required wrenches of the listed bodies about `about` */
static void wrench(const double *P, const body_state *st, const int *names, int count,
                   double gravity, v3 about, int vp, v3 *F, v3 *M)
{
    *F = vec(0.0, 0.0, 0.0);
    *M = vec(0.0, 0.0, 0.0);
    for (int i = 0; i < count; i++) {
        int b = names[i];
        if (!st[b].present)
            continue;
        v3 f, m;
        required_wrench(&st[b], P + P_BODIES + b * BODY_SIZE, gravity, about, vp, &f, &m);
        *F = add(*F, f);
        *M = add(*M, m);
    }
}

/* backward recursion of eq. (20)-(22) (dynamics.joint_forces) */
static double joint_forces(const double *P, int fx, const geometric *g, const body_state *st,
                           double *tau)
{
    double grav = (fx & E_GRAVITY) ? P[P_GRAVITY] : 0.0;
    int vp = (fx & E_VP) != 0;
    const v3 zero = vec(0.0, 0.0, 0.0);
    static const int platform[2] = {PLATFORM, PAYLOAD}, rod[1] = {ROD}, pis_a[1] = {PIS_A},
                     cyl_a[1] = {CYL_A};
    v3 A2 = axpy(-P[P_L2], g->dA, g->A3);
    v3 F4, M4, F30, M30, F20, M20, F10, M10;
    wrench(P, st, platform, 2, grav, g->A3, vp, &F4, &M4);
    wrench(P, st, rod, 1, grav, g->A3, vp, &F30, &M30);
    v3 F3 = add(F30, F4), M3 = add(M30, M4);
    wrench(P, st, pis_a, 1, grav, A2, vp, &F20, &M20);
    v3 F2 = add(F20, F3);
    v3 M2 = add(add(M20, M3), cross(sub(g->A3, A2), F3));
    wrench(P, st, cyl_a, 1, grav, zero, vp, &F10, &M10);
    v3 M1 = add(add(M10, M2), cross(A2, F2));
    tau[0] = M1.z;
    tau[1] = dot(g->dA, F2);
    tau[2] = M3.z;
    double tau_43 = dot(g->l, M4);
    double base_x = P[P_D2] + P[P_D3] + P[P_D4];
    for (int leg = 0; leg < 2; leg++) {
        int k = leg ? 6 : 3, pis[1] = {leg ? PIS_C : PIS_B}, cyl[1] = {leg ? CYL_C : CYL_B};
        v3 P1 = vec(base_x, 0.0, leg ? -P[P_D5] : P[P_D5]);
        v3 P4 = leg ? g->C4 : g->B4, d = leg ? g->dC : g->dB, e2 = leg ? g->e2C : g->e2B;
        v3 P3 = axpy(-P[P_L4], d, P4);
        v3 Fp, Mp, Fc, Mc;
        wrench(P, st, pis, 1, grav, P3, vp, &Fp, &Mp);
        wrench(P, st, cyl, 1, grav, P1, vp, &Fc, &Mc);
        v3 Mleg = add(add(Mc, Mp), cross(sub(P3, P1), Fp));
        tau[k] = Mleg.z;
        tau[k + 1] = dot(e2, Mleg);
        tau[k + 2] = dot(d, Fp);
    }
    for (int c = 0; c < 2; c++) {
        int name[1] = {c ? CRANK_E : CRANK_D};
        v3 P1 = vec(c ? P[P_D2] : P[P_D2] + P[P_D3], 0.0, 0.0), F, M;
        wrench(P, st, name, 1, grav, P1, vp, &F, &M);
        tau[c ? 10 : 9] = M.z;
    }
    tau[11] = 0.0;
    return tau_43;
}

/* 2-norm condition number of the 2x2 with columns a, b (status.condition_2x2) */
static double condition_2x2(v3 a, v3 b)
{
    double f2 = a.x * a.x + a.y * a.y + b.x * b.x + b.y * b.y;
    double det = fabs(a.x * b.y - a.y * b.x);
    double sigma_max2 = 0.5 * (f2 + sqrt(clip0((f2 - 2.0 * det) * (f2 + 2.0 * det))));
    return sigma_max2 / det;
}

/* ---- The status rule (status.sample_status): code and info of one sample, the
   worst that applies; a solve stopped at 1 (bad input) or 2 (open loop) has no results. */
static const double NO_LEGS[3] = {0.0, 0.0, 0.0};

static int sample_status(const double *P, int bad_input, int open_loop, int finite, double kin,
                         double jac, const double *stroke, const double *rate,
                         const double *force, double *info)
{
    int near = !((kin <= P[P_MAX_KIN]) && (jac <= P[P_MAX_JAC]));
    int over = 0;    /* a usage of limits.leg_usages above 1, as compared here */
    for (int m = 0; m < 3; m++)
        over |= (stroke[m] < P[P_STROKE_MIN]) | (stroke[m] > P[P_STROKE_MAX])
                | (fabs(rate[m]) > P[P_MAX_SPEED]) | (fabs(force[m]) > P[P_MAX_FORCE]);
    int code = over ? S_LIMIT : S_OK;
    *info = 0.0;
    if (!finite) {                       /* 4: results overflow without a singularity */
        code = S_INVALID;
        *info = RESULTS_NOT_FINITE;
    }
    if (near) {                          /* 3: info 0 = exact singularity */
        code = S_NEAR_SINGULAR;
        *info = finite;
    }
    if (open_loop >= 0) {                /* 2 */
        code = S_UNREACHABLE;
        *info = open_loop;
    }
    if (bad_input >= 0) {                /* 1 */
        code = S_INVALID;
        *info = bad_input;
    }
    return code;
}

/* a sample stopped before any result: the row stays 0 */
static void stop(const double *P, int bad_input, int open_loop, double *out)
{
    out[O_STATUS] = sample_status(P, bad_input, open_loop, 1, 0.0, 0.0, NO_LEGS, NO_LEGS,
                                  NO_LEGS, &out[O_INFO]);
}

/* ---- One sample: solver._solve, then the status rule ---- */
static const int ACTUATED[3] = {1, 5, 8};

/* what a pose and its rates fix, whatever the accelerations: the geometry,
   the factorised Q, the unit-rate columns K, the joint rates V, the actuator
   Jacobian and its inverse */
typedef struct {
    geometric g;
    connectivity f;
    double K[3][12], V[12], J[3][3], Jinv[3][3];
    double W[3][11];     /* virtual joint velocities of eq. (14) per unit leg rate */
} pose_terms;

/* eq. (5)-(12), (14): fills p; returns the first loop that cannot close, or -1 */
static int pose_of(const double *P, const double *q, const double *qd, pose_terms *p,
                   int angles)
{
    geometric *g = &p->g;
    double cols[3][12];
    inverse_geometry(P, q, g, angles);                            /* eq. (5)-(8) */
    if (g->failed >= 0)
        return g->failed;
    factorize(P, g, &p->f);                                       /* eq. (12) */
    pose_rate_columns(g, cols);
    for (int c = 0; c < 3; c++)
        solve_connectivity(g, &p->f, cols[c], p->K[c]);
    double (*K)[12] = p->K;
    for (int j = 0; j < 12; j++)                                  /* eq. (11) */
        p->V[j] = K[0][j] * qd[0] + K[1][j] * qd[1] + K[2][j] * qd[2];
    /* actuator Jacobian J[i][k] = K[k][actuated i], its inverse (adjugate) */
    double (*J)[3] = p->J;
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            J[i][k] = K[k][ACTUATED[i]];
    double a = J[0][0], b = J[0][1], c = J[0][2], d = J[1][0], e = J[1][1], ff = J[1][2],
           gg = J[2][0], h = J[2][1], ii = J[2][2];
    double A = e * ii - ff * h, B = ff * gg - d * ii, C = d * h - e * gg;
    double inv_det = 1.0 / (a * A + b * B + c * C);
    double Jinv[3][3] = {
        {A * inv_det, (c * h - b * ii) * inv_det, (b * ff - c * e) * inv_det},
        {B * inv_det, (a * ii - c * gg) * inv_det, (c * d - a * ff) * inv_det},
        {C * inv_det, (b * gg - a * h) * inv_det, (a * e - b * d) * inv_det}};
    memcpy(p->Jinv, Jinv, sizeof Jinv);
    for (int m = 0; m < 3; m++)
        for (int j = 0; j < 11; j++)
            p->W[m][j] = K[0][j] * Jinv[0][m] + K[1][j] * Jinv[1][m] + K[2][j] * Jinv[2][m];
    return -1;
}

/* eq. (18)-(23) at a pose for the joint accelerations Gd (and qdd, which the
   platform's and the rod's accelerations read directly): the actuator forces
   of the scene fx, friction excluded */
static void actuator_forces(const double *P, int fx, const pose_terms *p, const double *Gd,
                            const double *qd, const double *qdd, double *force, body_state *st)
{
    double tau[12];
    body_states(P, fx, &p->g, p->V, Gd, qd, qdd, st);
    double tau_43 = joint_forces(P, fx, &p->g, st, tau);          /* eq. (18)-(22) */
    /* eq. (14) and (23): virtual joint velocities, virtual work */
    for (int m = 0; m < 3; m++) {
        double sum = 0.0;
        for (int j = 0; j < 11; j++)
            sum += p->W[m][j] * tau[j];
        force[m] = sum + p->Jinv[2][m] * tau_43;
    }
}

/* the rest of solver._solve at a pose p, then the status rule: the row */
static void solve_at(const double *P, int fx, const pose_terms *p, const double *qd,
                     const double *qdd, double *out, body_state *st)
{
    const geometric *g = &p->g;
    double S[12], Gamma[12], Gdyn[12], force[3], rate[3];
    acceleration_column(P, g, p->V, qd, qdd, S);                  /* eq. (17) */
    solve_connectivity(g, &p->f, S, Gamma);                       /* eq. (16) */
    const int any_inertia = (fx & (E_PLATFORM | E_PAYLOAD | E_LEG | E_CRANK)) != 0;
    const double *Gd = Gamma;
    if (!((fx & E_VP) || !any_inertia)) {   /* accelerations from rest: K qdd */
        for (int j = 0; j < 12; j++)
            Gdyn[j] = p->K[0][j] * qdd[0] + p->K[1][j] * qdd[1] + p->K[2][j] * qdd[2];
        Gd = Gdyn;
    }
    actuator_forces(P, fx, p, Gd, qd, qdd, force, st);
    for (int m = 0; m < 3; m++)
        rate[m] = p->V[ACTUATED[m]];
    if (fx & E_FRICTION) {
        const double *vis = P + P_VISCOUS, *cou = P + P_COULOMB;
        for (int m = 0; m < 3; m++)
            force[m] = force[m] + (vis[m] * rate[m]
                                   + cou[m] * tanh(rate[m] / P[P_SMOOTHING]));
    }
    /* conditions (solver.kinematic_condition, solver.jacobian_condition) */
    const connectivity *f = &p->f;
    const double (*J)[3] = p->J, (*Jinv)[3] = p->Jinv;
    double LA = g->LA, LB = g->LB, LC = g->LC;
    double kin = nmax(nmax(nmax(nmax(nmax(LA, 1.0) / nmin(LA, 1.0),
                                     nmax(LB, 1.0) / nmin(LB * g->hB, 1.0)),
                                nmax(LC, 1.0) / nmin(LC * g->hC, 1.0)),
                           condition_2x2(f->aD, f->bD)),
                      condition_2x2(f->aE, g->l));
    double cs = 0.5 * P[P_B], nJ = 0.0, nI = 0.0;
    for (int r = 0; r < 3; r++)
        nJ += J[r][0] * J[r][0] + J[r][1] * J[r][1] + (J[r][2] / cs) * (J[r][2] / cs);
    for (int j = 0; j < 3; j++)
        nI += Jinv[0][j] * Jinv[0][j] + Jinv[1][j] * Jinv[1][j]
              + (cs * Jinv[2][j]) * (cs * Jinv[2][j]);
    double jac = sqrt(nJ * nI);
    /* the result row */
    out[O_LENGTH] = LA;
    out[O_LENGTH + 1] = LB;
    out[O_LENGTH + 2] = LC;
    for (int m = 0; m < 3; m++) {
        out[O_STROKE + m] = g->raw[ACTUATED[m]];
        out[O_RATE + m] = rate[m];
        out[O_ACCELERATION + m] = Gamma[ACTUATED[m]];
        out[O_FORCE + m] = force[m];
        out[O_POWER + m] = force[m] * rate[m];
    }
    for (int j = 0; j < 12; j++) {
        out[O_JOINTS + j] = g->raw[j];
        out[O_JOINT_RATES + j] = p->V[j];
        out[O_JOINT_ACCELERATIONS + j] = Gamma[j];
    }
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            out[O_JACOBIAN + 3 * i + k] = J[i][k];
    /* the status rule (status.all_finite: results and conditions, not beta) */
    int finite = isfinite(kin) && isfinite(jac);
    for (int i = 0; i < O_JACOBIAN; i++)
        finite = finite && isfinite(out[i]);
    double info;
    int code = sample_status(P, -1, -1, finite, kin, jac, out + O_STROKE, rate, force, &info);
    /* no NaN or infinity with any status (solver._clean) */
    if (code >= S_UNREACHABLE) {
        memset(out, 0, OUT_SIZE * sizeof(double));
    } else {
        for (int i = 0; i < O_BETA; i++)
            if (!isfinite(out[i]))
                out[i] = 0.0;
        out[O_BETA] = isfinite(g->beta) ? g->beta : 0.0;
        out[O_KIN] = isfinite(kin) ? kin : DBL_MAX;
        out[O_JAC] = isfinite(jac) ? jac : DBL_MAX;
    }
    out[O_STATUS] = code;
    out[O_INFO] = info;
}

/* one sample into the row `out`; 1 when p holds its pose and st its bodies
   (finite input, every loop closed), 0 when the sample stopped before */
static int solve_posed(const double *P, int fx, const double *q, const double *qd,
                       const double *qdd, double *out, pose_terms *p, body_state *st,
                       int angles)
{
    memset(out, 0, OUT_SIZE * sizeof(double));
    /* non-finite input: nothing is computed (status.first_bad_input) */
    for (int i = 0; i < 9; i++) {
        double v = i < 3 ? q[i] : i < 6 ? qd[i - 3] : qdd[i - 6];
        if (!isfinite(v)) {
            stop(P, i, -1, out);
            return 0;
        }
    }
    int failed = pose_of(P, q, qd, p, angles);
    if (failed >= 0) {
        stop(P, -1, failed, out);
        return 0;
    }
    solve_at(P, fx, p, qd, qdd, out, st);
    return 1;
}

static void solve_one(const double *P, int fx, const double *q, const double *qd,
                      const double *qdd, double *out)
{
    pose_terms p;
    body_state st[N_BODIES];
    solve_posed(P, fx, q, qd, qdd, out, &p, st, 1);
}

/* ---- Forward dynamics (forward_dynamics.affine_terms): f = M qdd + b ---- */
static const double REST[3] = {0.0, 0.0, 0.0};

/* acc and eps of the bodies for the joint accelerations G = K e_j and the
   unit qdd e_j alone: body_states' formulas without velocity terms, on the
   centres of mass com of the pose (0 for a body at rest) */
static void unit_accelerations(const double *P, const geometric *g, const double *G, int j,
                               const v3 *com, v3 *acc, v3 *eps)
{
    v3 Gdd = vec(j == 0, j == 1, 0.0);
    v3 eA = vec(0.0, 0.0, G[0]);
    eps[CYL_A] = eps[PIS_A] = eA;
    acc[CYL_A] = cross(eA, com[CYL_A]);
    acc[PIS_A] = add(scale(G[1], g->dA), cross(eA, com[PIS_A]));
    eps[ROD] = vec(0.0, 0.0, G[0] + G[2]);
    acc[ROD] = add(Gdd, cross(eps[ROD], sub(com[ROD], g->G)));
    double roll_dd = j == 2;
    eps[PLATFORM] = eps[PAYLOAD] = vec(roll_dd * g->l.x, roll_dd * g->l.y, G[0] + G[2]);
    acc[PLATFORM] = add(Gdd, cross(eps[PLATFORM], sub(com[PLATFORM], g->G)));
    acc[PAYLOAD] = add(Gdd, cross(eps[PAYLOAD], sub(com[PAYLOAD], g->G)));
    double base_x = P[P_D2] + P[P_D3] + P[P_D4];
    for (int leg = 0; leg < 2; leg++) {
        int k = leg ? 6 : 3, cyl = leg ? CYL_C : CYL_B, pis = leg ? PIS_C : PIS_B;
        v3 P1 = vec(base_x, 0.0, leg ? -P[P_D5] : P[P_D5]);
        v3 d = leg ? g->dC : g->dB, e2 = leg ? g->e2C : g->e2B;
        eps[cyl] = eps[pis] = vec(G[k + 1] * e2.x, G[k + 1] * e2.y, G[k]);
        acc[cyl] = cross(eps[cyl], sub(com[cyl], P1));
        acc[pis] = add(scale(G[k + 2], d), cross(eps[pis], sub(com[pis], P1)));
    }
    for (int c = 0; c < 2; c++) {
        int i = c ? CRANK_E : CRANK_D;
        v3 P1 = vec(c ? P[P_D2] : P[P_D2] + P[P_D3], 0.0, 0.0);
        eps[i] = vec(0.0, 0.0, G[c ? 10 : 9]);
        acc[i] = cross(eps[i], sub(com[i], P1));
    }
}

/* M of f = M qdd + b at the pose p, bodies in st (forward_dynamics.affine_terms):
   column j is the force of a unit qdd e_j alone (eq. 15-23 are affine in qdd),
   whose body accelerations are the velocities per unit qd_j (a_j, w_j); by
   virtual power (eq. 23) M = J^-T Mq, Mq[i][j] = sum m a_i . a_j + w_i . I w_j. */
static void mass_matrix(const double *P, const pose_terms *p, const body_state *st, double *M)
{
    v3 com[N_BODIES], acc[3][N_BODIES], eps[3][N_BODIES];
    for (int b = 0; b < N_BODIES; b++)
        com[b] = st[b].moving ? st[b].com : vec(0.0, 0.0, 0.0);
    for (int j = 0; j < 3; j++)
        unit_accelerations(P, &p->g, p->K[j], j, com, acc[j], eps[j]);
    double Mq[3][3] = {{0.0}};
    for (int b = 0; b < N_BODIES; b++) {
        if (!st[b].moving)
            continue;
        const double *body = P + P_BODIES + b * BODY_SIZE;
        v3 w[3], Iw[3];
        for (int j = 0; j < 3; j++) {
            w[j] = to_frame(&st[b].R, eps[j][b]);
            Iw[j] = mat_vec(body + B_INERTIA, w[j]);
        }
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                Mq[i][j] += body[B_MASS] * dot(acc[i][b], acc[j][b]) + dot(w[i], Iw[j]);
    }
    for (int m = 0; m < 3; m++)
        for (int j = 0; j < 3; j++)
            M[3 * m + j] = p->Jinv[0][m] * Mq[0][j] + p->Jinv[1][m] * Mq[1][j]
                           + p->Jinv[2][m] * Mq[2][j];
}

/* forward_dynamics.affine_terms: the row of solve(q, qd, 0) in `out`, b and M
   (row-major 3x3), 0 when void; a non-finite entry of M is 0, as solve's numbers. */
static void affine_one(const double *P, int fx, const double *q, const double *qd,
                       double *out, double *M, double *b, int angles)
{
    pose_terms p;
    body_state st[N_BODIES];
    memset(M, 0, 9 * sizeof(double));
    memset(b, 0, 3 * sizeof(double));
    if (!solve_posed(P, fx, q, qd, REST, out, &p, st, angles)
            || out[O_STATUS] >= S_UNREACHABLE)
        return;
    for (int m = 0; m < 3; m++)
        b[m] = out[O_FORCE + m];
    mass_matrix(P, &p, st, M);
    for (int i = 0; i < 9; i++)
        if (!isfinite(M[i]))
            M[i] = 0.0;
}

/* ---- The twin's RK4 loop (core.simulation.integrate) for a tabulated force law ---- */

/* M qdd = r by LU with partial pivoting; 0 unless M is surely within
   forward_dynamics.MAX_MASS_CONDITION (1e8): the Frobenius condition
   ||M||_F ||M^-1||_F bounds the 2-norm one from above, so a state it refuses
   is left to the Python code (exact SVD) to decide */
static int solve3(const double *M, const double *r, double *x)
{
    double a[3][3], y[3];
    for (int i = 0; i < 3; i++) {
        y[i] = r[i];
        for (int j = 0; j < 3; j++)
            a[i][j] = M[3 * i + j];
    }
    double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
                 - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
                 + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    double nM = 0.0, nI = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
            double cof = a[i1][j1] * a[i2][j2] - a[i1][j2] * a[i2][j1];   /* (M^-1)[i][j] det */
            nM += a[i][j] * a[i][j];
            nI += cof * cof;
        }
    double condition = sqrt(nM) * sqrt(nI) / fabs(det);
    if (!(condition <= 1e8))
        return 0;
    for (int k = 0; k < 3; k++) {
        int pivot = k;
        for (int i = k + 1; i < 3; i++)
            if (fabs(a[i][k]) > fabs(a[pivot][k]))
                pivot = i;
        if (pivot != k) {
            for (int j = 0; j < 3; j++) {
                double t = a[k][j]; a[k][j] = a[pivot][j]; a[pivot][j] = t;
            }
            double t = y[k]; y[k] = y[pivot]; y[pivot] = t;
        }
        for (int i = k + 1; i < 3; i++) {
            double l = a[i][k] / a[k][k];
            for (int j = k + 1; j < 3; j++)
                a[i][j] -= l * a[k][j];
            y[i] -= l * y[k];
        }
    }
    for (int k = 2; k >= 0; k--) {
        double s = y[k];
        for (int j = k + 1; j < 3; j++)
            s -= a[k][j] * x[j];
        x[k] = s / a[k][k];
    }
    return isfinite(x[0]) && isfinite(x[1]) && isfinite(x[2]);
}

/* core.simulation.stage at (q, qd), stage j; 0 when the stage stops or is left to the
   Python code (a status that stops, M ill-conditioned, results not finite) */
static int stage(const double *P, int fx, const tabulated_law *law, Py_ssize_t j,
                 const double *q, const double *qd, double *qdd, double *force)
{
    double row[OUT_SIZE], M[9], b[3], rhs[3];
    affine_one(P, fx, q, qd, row, M, b, 0);     /* no joint angle read here */
    if (row[O_STATUS] >= S_NEAR_SINGULAR)
        return 0;
    for (int m = 0; m < 3; m++) {
        double command = law->ff[3 * j + m];
        if (law->servo) {
            command = command + law->kp[m] * (law->length_ref[3 * j + m] - row[O_LENGTH + m])
                      + law->kd[m] * (law->rate_ref[3 * j + m] - row[O_RATE + m]);
            command = deliver(command, row[O_RATE + m], law->max_force, law->max_speed);
        }
        force[m] = command;
        rhs[m] = command - b[m];
    }
    return solve3(M, rhs, qdd);
}

#define EFFECT_BITS_MAX ((E_HAS_PAYLOAD << 1) - 1)
#define SOLVE_ROWS(job, n) solve_rows(job, 0, n)     /* one thread: docs/design/implementations.md */
#include "kernel_bindings.h"

/* ---- Python bindings ---- */

/* The arguments of a one-sample binding: exactly `expected` of them, the
   effect bits in args[1] and `n` lists or tuples of DOF floats from
   args[first] on; -1 with a Python error set otherwise. */
static int one_sample_args(const char *name, PyObject *const *args, Py_ssize_t nargs,
                           Py_ssize_t expected, int first, int n, int *fx, double *x)
{
    static const char *const names[3] = {"q", "qd", "qdd"};
    if (nargs != expected) {
        PyErr_Format(PyExc_TypeError, "%s() takes %d arguments", name, (int)expected);
        return -1;
    }
    if (effect_bits(args[1], fx) < 0)
        return -1;
    for (int i = 0; i < n; i++)
        if (dof_floats(args[first + i], names[i], x + DOF * i) < 0)
            return -1;
    return 0;
}

PyDoc_STRVAR(solve_doc,
"solve(params, effects, out, q, qd, qdd)\n"
"    -> (status, info, beta, kinematic_condition, jacobian_condition)\n\n"
"One sample: q, qd, qdd lists or tuples of 3 floats; fills the writable buffer\n"
"`out` (OUT_SIZE doubles) and returns the scalars of the row. params: the packed\n"
"model (kernel.pack_model); effects: the bit set (EFFECTS).");

static PyObject *py_solve(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double x[9];
    int fx;
    if (one_sample_args("solve", args, nargs, 6, 3, 3, &fx, x) < 0)
        return NULL;
    Py_buffer pv, ov;
    if (get_doubles(args[0], &pv, P_SIZE, 0, "packed model") < 0)
        return NULL;
    if (get_doubles(args[2], &ov, OUT_SIZE, 1, "out") < 0) {
        PyBuffer_Release(&pv);
        return NULL;
    }
    double *out = (double *)ov.buf;
    solve_one((const double *)pv.buf, fx, x, x + 3, x + 6, out);
    PyBuffer_Release(&pv);
    PyBuffer_Release(&ov);
    return Py_BuildValue("(iiddd)", (int)out[O_STATUS], (int)out[O_INFO], out[O_BETA],
                         out[O_KIN], out[O_JAC]);
}

PyDoc_STRVAR(solve_batch_doc,
"solve_batch(params, effects, q, qd, qdd, out) -> None\n\n"
"N samples: q, qd, qdd C-contiguous (N, 3) float64 buffers, out a writable\n"
"C-contiguous (N, OUT_SIZE) float64 buffer. Releases the GIL while it runs.");

static void solve_rows(const void *job, Py_ssize_t begin, Py_ssize_t end)
{
    const batch_job *b = (const batch_job *)job;
    for (Py_ssize_t i = begin; i < end; i++)
        solve_one(b->P, b->fx, b->q + 3 * i, b->qd + 3 * i, b->qdd + 3 * i,
                  b->out + OUT_SIZE * i);
}

PyDoc_STRVAR(affine_doc,
"affine(params, effects, out, M, b, q, qd) -> scalars as solve\n\n"
"The row of solve(q, qd, 0), M (3x3) and b of f = M qdd + b (kernel.affine_row).");

static PyObject *py_affine(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double x[6];
    int fx;
    if (one_sample_args("affine", args, nargs, 7, 5, 2, &fx, x) < 0)
        return NULL;
    static const Py_ssize_t sizes[4] = {P_SIZE, OUT_SIZE, 9, 3};
    static const char *const names[4] = {"packed model", "out", "M", "b"};
    Py_buffer views[4];
    int got = 0;
    PyObject *result = NULL;
    for (; got < 4; got++)
        if (get_doubles(args[got == 0 ? 0 : got + 1], &views[got], sizes[got], got > 0,
                        names[got]) < 0)
            goto done;
    double *out = (double *)views[1].buf;
    affine_one((const double *)views[0].buf, fx, x, x + 3, out, (double *)views[2].buf,
               (double *)views[3].buf, 1);
    result = Py_BuildValue("(iiddd)", (int)out[O_STATUS], (int)out[O_INFO], out[O_BETA],
                           out[O_KIN], out[O_JAC]);
done:
    for (int i = 0; i < got; i++)
        PyBuffer_Release(&views[i]);
    return result;
}


static PyMethodDef methods[] = {
    {"solve", (PyCFunction)(void (*)(void))py_solve, METH_FASTCALL, solve_doc},
    {"solve_batch", (PyCFunction)(void (*)(void))py_solve_batch, METH_FASTCALL,
     solve_batch_doc},
    {"affine", (PyCFunction)(void (*)(void))py_affine, METH_FASTCALL, affine_doc},
    {"integrate", (PyCFunction)(void (*)(void))py_integrate, METH_FASTCALL, integrate_doc},
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_kernel",
    "Compiled scalar path of the flight_sim_dynamics solver (see kernel.py).", -1, methods
};

/* the declarations at the top, as Python objects (read by kernel.py) */
static const field PACKED_FIELDS[] = { PACKED_MODEL(AS_FIELD) };
static const field BODY_FIELDS[] = { BODY_ROW(AS_FIELD) };
static const field RESULT_FIELDS[] = { RESULT_ROW(AS_FIELD) };
static const field EFFECT_FIELDS[] = { EFFECT_LIST(AS_BIT_FIELD) };
static const char *const BODY_NAMES[] = { BODY_LIST(AS_NAME) };
static const char *const STATUS_NAMES[] = { STATUS_LIST(AS_NAME) };
static const char *const LOOP_NAMES[] = { LOOP_LIST(AS_NAME) };


PyMODINIT_FUNC PyInit__kernel(void)
{
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddIntConstant(m, "P_SIZE", P_SIZE) < 0
            || PyModule_AddIntConstant(m, "OUT_SIZE", OUT_SIZE) < 0
            || PyModule_AddIntConstant(m, "BODY_SIZE", BODY_SIZE) < 0
            || PyModule_AddIntConstant(m, "HAS_PAYLOAD", E_HAS_PAYLOAD) < 0
            || PyModule_AddIntConstant(m, "RESULTS_NOT_FINITE", RESULTS_NOT_FINITE) < 0
            || add_object(m, "PACKED", fields_dict(PACKED_FIELDS, COUNT(PACKED_FIELDS), 0)) < 0
            || add_object(m, "BODY_ROW", fields_dict(BODY_FIELDS, COUNT(BODY_FIELDS), 0)) < 0
            || add_object(m, "OUT", fields_dict(RESULT_FIELDS, COUNT(RESULT_FIELDS), 0)) < 0
            || add_object(m, "EFFECTS", fields_dict(EFFECT_FIELDS, COUNT(EFFECT_FIELDS), 1)) < 0
            || add_object(m, "BODIES", names_tuple(BODY_NAMES, COUNT(BODY_NAMES))) < 0
            || add_object(m, "STATUS", names_tuple(STATUS_NAMES, COUNT(STATUS_NAMES))) < 0
            || add_object(m, "LOOPS", names_tuple(LOOP_NAMES, COUNT(LOOP_NAMES))) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
