/* The ski-jump EKF + RTS loop as a C extension: the fast path of rts-smooth's engine.
 *
 * Its numpy reference is sportfusion.estimators.kalman.ekf_rts driven by
 * sportfusion.skijump.smoother_engine.model_callables (the model of skijump/model.py: eqs 10-22, 35-51), and the
 * standard deviations of sportfusion.skijump.smoother_outputs._std_from_cov; tests/test_rts_smooth.py compares the
 * two on the same inputs (states to 1e-9, covariances to 1e-10).  The same equations, arranged for speed:
 *
 * - the measurements of a step (all with a diagonal R) are applied one scalar at a time, every residual and
 *   Jacobian evaluated at the prior x_k|k-1 and corrected by -h (x - x_k|k-1) for the rows applied before it:
 *   with a diagonal R this is algebraically the stacked update; each scalar update is the Joseph form with the
 *   optimal gain, which reduces to the symmetric rank-1 P - (P h)(P h)^T / s (as g g^T with g = P h / sqrt(s));
 * - covariances are stored packed (upper triangle, 253 numbers for 22 states), and the smoothed covariance
 *   overwrites the filtered one in the backward pass; where only the std rows are wanted, a long run keeps them
 *   for one block of steps at a time: the backward pass runs each block's forward pass again from a checkpoint
 *   (the prior state and covariance at the block's first step) kept by the first forward pass;
 * - the backward pass forms Phi_k and P_k+1|k again from x_k|k and P_k|k (or reads the forward pass's, pred),
 *   and uses that the parameters are constant states without process noise (eq 22): the rows of the RTS gain
 *   that belong to them are exactly [0 I], so only the 10 rows of the kinematic states are solved for;
 * - positive definiteness is checked by finite positive variances after every update and prediction, and by
 *   the Cholesky factor of every P_k+1|k in the backward pass;
 * - the output's standard deviations are formed from each smoothed covariance as it is made (std_row).
 *
 * Beyond that, the loops skip the known zeros of A and Phi (position and magnetometer columns), the backward
 * pass reuses the prediction's Phi P for the gain, and the loops are arranged for vectors and registers; every
 * element still sums the same nonzero terms in the same order, so the baseline build (-DSKI_NO_CLONES) gives
 * the results of the plain loops to the last bit, and the AVX2/FMA clone differs from them by FMA's single
 * rounding (~1e-11 on 60k steps).  The two helpers of the alignment (body_to_start, latency_misfit) mirror
 * numpy functions of sportfusion.skijump.alignment, named where they are defined.
 *
 * Arrays travel through the buffer protocol (no numpy headers needed to build); the Python side
 * (sportfusion.skijump._ski_native) passes C-contiguous float64 arrays and preallocated outputs.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

#include "../core/_buffers.h"
#include "../core/_quat.h"

#define N 22
#define NP 253
#define NSTD 28
#define NPAR 27
#define NRES 16
/* a step's stored prediction (pred): T = Phi_top P (10 x N) and the upper triangle of P_k+1|k's kinematic block */
#define NT (10 * N + 55)

/* GCC's and Clang's extensions (prefetches, noinline, vector types); -DSKI_PLAIN_C builds without them, as other
   compilers do: the way to test that path with GCC */
#if defined(__GNUC__) && !defined(SKI_PLAIN_C)
#define SKI_GNU 1
#else
#define SKI_GNU 0
#endif

#if SKI_GNU
#define PREFETCH(p) __builtin_prefetch(p)
#define INLINE inline __attribute__((always_inline)) /* compiled inside its caller's clone */
#else
#define PREFETCH(p) ((void)0)
#define INLINE inline
#endif

/* Runtime dispatch: with GCC 11 or later on x86-64 Linux (glibc's ifunc), the hot functions are compiled twice,
   for x86-64-v3 (AVX2 and FMA: about 20 % less time here) and for the baseline x86-64, and the loader picks one by
   the CPU.  Other compilers and platforms (or -DSKI_NO_CLONES) build the baseline alone.  FMA rounds a * b + c once:
   results differ from the baseline build's in the last bits. */
#if defined(__x86_64__) && defined(__linux__) && defined(__GLIBC__) && defined(__GNUC__) && !defined(__clang__) && \
    __GNUC__ >= 11 && !defined(SKI_NO_CLONES)
#define HOT __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define HOT
#endif

/* GCC's and Clang's vector types: the hot products' accumulators held in registers (GCC spills plain arrays of
   them to the stack).  Without SKI_GNU, plain C loops instead; the two agree to ~1e-11 (some sums run in another
   order). */
#if SKI_GNU
#define SKI_VEC 1
typedef double v4 __attribute__((vector_size(32)));
static const v4 V4_ZERO = {0.0, 0.0, 0.0, 0.0};
/* unaligned loads and stores of 4 doubles (through pointers: a vector argument or return value would change the
   baseline clone's ABI) */
static inline void load4(v4 *v, const double *p) { memcpy(v, p, sizeof(*v)); }
static inline void store4(double *p, const v4 *v) { memcpy(p, v, sizeof(*v)); }
#else
#define SKI_VEC 0
#endif

/* the columns of A (and of Phi - I) that can be nonzero */
#define A_LO 3
#define A_HI 16
/* a row of the Cholesky factor with the gain's right-hand side beside it (chol_solve) */
#define NW (N + 10)

/* vectors of N are cleared by copying zeros: GCC clears them with rep stos otherwise, whose start-up costs more
   than the clearing */
static const double ZEROS[N];
#define ZERO(a) memcpy(a, ZEROS, sizeof(a))

/* a function of its own, compiled for the baseline target (never fused into the AVX2/FMA clones): the results
   stay those of the previous builds to the last bit */
#if SKI_GNU
__attribute__((noinline))
#endif
static void mbo(const double *q, double M[3][3]) {
    quat_mbo(q[0], q[1], q[2], q[3], M);
}

static void dmdq(const double *q, double D[4][3][3]) {
    double q0 = 2 * q[0], q1 = 2 * q[1], q2 = 2 * q[2], q3 = 2 * q[3];
    D[0][0][0] = q0; D[0][0][1] = q3; D[0][0][2] = -q2;
    D[0][1][0] = -q3; D[0][1][1] = q0; D[0][1][2] = q1;
    D[0][2][0] = q2; D[0][2][1] = -q1; D[0][2][2] = q0;
    D[1][0][0] = q1; D[1][0][1] = q2; D[1][0][2] = q3;
    D[1][1][0] = q2; D[1][1][1] = -q1; D[1][1][2] = q0;
    D[1][2][0] = q3; D[1][2][1] = -q0; D[1][2][2] = -q1;
    D[2][0][0] = -q2; D[2][0][1] = q1; D[2][0][2] = -q0;
    D[2][1][0] = q1; D[2][1][1] = q2; D[2][1][2] = q3;
    D[2][2][0] = q0; D[2][2][1] = q3; D[2][2][2] = -q2;
    D[3][0][0] = -q3; D[3][0][1] = q0; D[3][0][2] = q1;
    D[3][1][0] = -q0; D[3][1][1] = -q3; D[3][1][2] = q2;
    D[3][2][0] = q1; D[3][2][1] = q2; D[3][2][2] = q3;
}

/* the kinematics (eqs 22, 44-46): model.f_aug */
static void f_kin(const double *x, const double *u, double g0, const double *mno, double *out) {
    double M[3][3];
    for (int i = 0; i < N; i++) out[i] = 0.0;
    mbo(x + 6, M);
    double wx = u[0] - x[10], wy = u[1] - x[11], wz = u[2] - x[12];
    double vx = x[3], vy = x[4], vz = x[5];
    double vo0 = M[0][0] * vx + M[1][0] * vy + M[2][0] * vz;
    double vo1 = M[0][1] * vx + M[1][1] * vy + M[2][1] * vz;
    double vo2 = M[0][2] * vx + M[1][2] * vy + M[2][2] * vz;
    for (int i = 0; i < 3; i++) out[i] = mno[3 * i] * vo0 + mno[3 * i + 1] * vo1 + mno[3 * i + 2] * vo2;
    out[3] = u[3] - x[13] + g0 * M[0][2] - (wy * vz - wz * vy);
    out[4] = u[4] - x[14] + g0 * M[1][2] - (wz * vx - wx * vz);
    out[5] = u[5] - x[15] + g0 * M[2][2] - (wx * vy - wy * vx);
    double q0 = x[6], q1 = x[7], q2 = x[8], q3 = x[9];
    out[6] = 0.5 * (-q1 * wx - q2 * wy - q3 * wz);
    out[7] = 0.5 * (q0 * wx - q3 * wy + q2 * wz);
    out[8] = 0.5 * (q3 * wx + q0 * wy - q1 * wz);
    out[9] = 0.5 * (-q2 * wx + q1 * wy + q0 * wz);
}

/* one RK4 step of the kinematics (the input u0 at the start, (u0 + u1) / 2 at the midpoints, u1 at the end):
   model.rk4_aug */
HOT static void rk4(const double *x, const double *u0, const double *u1, double dt, double g0, const double *mno,
                double *out) {
    double k1[N], k2[N], k3[N], k4[N], xt[N], um[6];
    for (int i = 0; i < 6; i++) um[i] = 0.5 * (u0[i] + u1[i]);
    f_kin(x, u0, g0, mno, k1);
    for (int i = 0; i < N; i++) xt[i] = x[i] + 0.5 * dt * k1[i];
    f_kin(xt, um, g0, mno, k2);
    for (int i = 0; i < N; i++) xt[i] = x[i] + 0.5 * dt * k2[i];
    f_kin(xt, um, g0, mno, k3);
    for (int i = 0; i < N; i++) xt[i] = x[i] + dt * k3[i];
    f_kin(xt, u1, g0, mno, k4);
    for (int i = 0; i < N; i++) out[i] = x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
}

/* top rows of Phi = I + A dt + (A dt)^2 / 2 and Qd = Gamma Q Gamma^T (eqs 7, 9, 13): model.jac_a, model.jac_f and
   model.discrete, without the zeros of the parameter rows */
HOT static void phi_qd(const double *x, const double *u, double dt, double g0, const double *mno, const double *qd,
                   double Phi[10][N], double Qd[10][10]) {
    double A[10][A_HI], F[10][6], G[10][6], M[3][3], D[4][3][3];
    for (int i = 0; i < 10; i++) /* columns 0-2 are never read */
        for (int j = A_LO; j < A_HI; j++) A[i][j] = 0.0;
    mbo(x + 6, M);
    dmdq(x + 6, D);
    const double *v = x + 3;
    double q0 = x[6], q1 = x[7], q2 = x[8], q3 = x[9];
    double wx = u[0] - x[10], wy = u[1] - x[11], wz = u[2] - x[12];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            A[i][3 + j] = mno[3 * i] * M[j][0] + mno[3 * i + 1] * M[j][1] + mno[3 * i + 2] * M[j][2];
    for (int k = 0; k < 4; k++) {
        double t0 = D[k][0][0] * v[0] + D[k][1][0] * v[1] + D[k][2][0] * v[2];
        double t1 = D[k][0][1] * v[0] + D[k][1][1] * v[1] + D[k][2][1] * v[2];
        double t2 = D[k][0][2] * v[0] + D[k][1][2] * v[1] + D[k][2][2] * v[2];
        for (int i = 0; i < 3; i++) A[i][6 + k] = mno[3 * i] * t0 + mno[3 * i + 1] * t1 + mno[3 * i + 2] * t2;
        for (int i = 0; i < 3; i++) A[3 + i][6 + k] = g0 * D[k][i][2];
    }
    A[3][4] = wz; A[3][5] = -wy;
    A[4][3] = -wz; A[4][5] = wx;
    A[5][3] = wy; A[5][4] = -wx;
    A[3][11] = v[2]; A[3][12] = -v[1];
    A[4][10] = -v[2]; A[4][12] = v[0];
    A[5][10] = v[1]; A[5][11] = -v[0];
    for (int i = 0; i < 3; i++) A[3 + i][13 + i] = -1.0;
    A[6][7] = -0.5 * wx; A[6][8] = -0.5 * wy; A[6][9] = -0.5 * wz;
    A[7][6] = 0.5 * wx; A[7][8] = 0.5 * wz; A[7][9] = -0.5 * wy;
    A[8][6] = 0.5 * wy; A[8][7] = -0.5 * wz; A[8][9] = 0.5 * wx;
    A[9][6] = 0.5 * wz; A[9][7] = 0.5 * wy; A[9][8] = -0.5 * wx;
    double xi0[3] = {-q1, -q2, -q3}, xi1[3] = {q0, -q3, q2}, xi2[3] = {q3, q0, -q1}, xi3[3] = {-q2, q1, q0};
    for (int j = 0; j < 3; j++) {
        A[6][10 + j] = -0.5 * xi0[j];
        A[7][10 + j] = -0.5 * xi1[j];
        A[8][10 + j] = -0.5 * xi2[j];
        A[9][10 + j] = -0.5 * xi3[j];
    }
    for (int i = 0; i < 10; i++)
        for (int j = 0; j < 6; j++) F[i][j] = 0.0;
    for (int i = 3; i < 10; i++)
        for (int j = 0; j < 3; j++) F[i][j] = A[i][10 + j];
    for (int i = 0; i < 3; i++) F[3 + i][3 + i] = -1.0;
    /* A's columns 0-2 (position) and 16-21 (magnetometer states) are zero, and so are F's rows 0-2: the
       sums run over m = 3..9 only and Phi is the identity outside columns 3-15.  Skipping exact zeros
       leaves every sum as the dense one (same order, the same additions of nonzero terms). */
    double h2 = 0.5 * dt * dt;
    for (int i = 0; i < 10; i++) {
        double a[10]; /* row i of A^2: the sums over m (constant length, unrolled) side by side across j */
        for (int m = A_LO; m < 10; m++) a[m] = A[i][m];
        for (int j = 0; j < A_LO; j++) Phi[i][j] = 0.0;
        for (int j = A_LO; j < A_HI; j++) {
            double a2 = 0.0;
            for (int m = A_LO; m < 10; m++) a2 += a[m] * A[m][j];
            Phi[i][j] = A[i][j] * dt + h2 * a2;
        }
        for (int j = A_HI; j < N; j++) Phi[i][j] = 0.0;
        Phi[i][i] += 1.0;
    }
    for (int i = 0; i < 10; i++)
        for (int j = 0; j < 6; j++) {
            double af = 0.0;
            for (int m = A_LO; m < 10; m++) af += A[i][m] * F[m][j];
            G[i][j] = dt * F[i][j] + h2 * af;
        }
    /* Qd = G diag(qd) G^T: each element sums over m in order; computed row by row across j (independent sums,
       not one chain of dependent additions after another), the upper triangle kept */
    double Gq[10][6], GT[6][10];
    for (int i = 0; i < 10; i++)
        for (int m = 0; m < 6; m++) {
            Gq[i][m] = G[i][m] * qd[m];
            GT[m][i] = G[i][m];
        }
    for (int i = 0; i < 10; i++) {
        double s[10];
        for (int j = 0; j < 10; j++) {
            double v = 0.0;
            for (int m = 0; m < 6; m++) v += Gq[i][m] * GT[m][j];
            s[j] = v;
        }
        for (int j = i; j < 10; j++) {
            Qd[i][j] = s[j];
            Qd[j][i] = s[j];
        }
    }
}

/* the prediction's blocks outside the kinematic one: rows/columns 0-9 x 10-21 are T's (Phi is the identity on the
   parameters, which have no process noise), the parameter block is P's */
static inline void outer_blocks(double T[10][N], double P[N][N], double out[N][N]) {
    for (int i = 0; i < 10; i++)
        for (int j = 10; j < N; j++) {
            out[i][j] = T[i][j];
            out[j][i] = T[i][j];
        }
    for (int i = 10; i < N; i++)
        for (int j = i; j < N; j++) {
            out[i][j] = P[i][j];
            out[j][i] = P[i][j];
        }
}

/* out = Phi P Phi^T + Qd with Phi = [[Phi_top], [0 I]]; T = Phi_top P (10 x 22) is returned for the
   backward pass.  Phi_top is the identity in columns 0-2 and zero in columns 16-21 (phi_qd), so the products
   run over columns 3-15 and the identity; every element sums its nonzero terms in the order of the dense
   product, row by row as vector updates (j innermost) */
HOT static void predict_cov(double P[N][N], double Phi[10][N], double Qd[10][10], double out[N][N], double T[10][N]) {
    double PhiT[A_HI][10];
    for (int i = 0; i < 10; i++) {
#if SKI_VEC
        /* a row of 22 as 6 vectors, the last one's 2 extra lanes read from the next row (m <= 15) and dropped */
        v4 s[6], r;
        for (int b = 0; b < 6; b++) {
            s[b] = V4_ZERO;
            if (i < 3) load4(&s[b], P[i] + 4 * b);
        }
        for (int m = A_LO; m < A_HI; m++) {
            double a = Phi[i][m];
            for (int b = 0; b < 6; b++) {
                load4(&r, P[m] + 4 * b);
                s[b] += a * r;
            }
        }
        for (int b = 0; b < 5; b++) store4(T[i] + 4 * b, &s[b]);
        T[i][20] = s[5][0];
        T[i][21] = s[5][1];
#else
        double s[N];
        for (int j = 0; j < N; j++) s[j] = i < 3 ? P[i][j] : 0.0;
        for (int m = A_LO; m < A_HI; m++) {
            double a = Phi[i][m];
            for (int j = 0; j < N; j++) s[j] += a * P[m][j];
        }
        memcpy(T[i], s, sizeof(s));
#endif
    }
    for (int m = A_LO; m < A_HI; m++)
        for (int j = 0; j < 10; j++) PhiT[m][j] = Phi[j][m];
    for (int i = 0; i < 10; i++) {
        double s[10];
        for (int j = 0; j < 10; j++) s[j] = Qd[i][j] + (j < 3 ? T[i][j] : 0.0);
        for (int m = A_LO; m < A_HI; m++) {
            double a = T[i][m];
            for (int j = 0; j < 10; j++) s[j] += a * PhiT[m][j];
        }
        for (int j = i; j < 10; j++) {
            out[i][j] = s[j];
            out[j][i] = s[j];
        }
    }
    outer_blocks(T, P, out);
}

/* one scalar update (kalman._update's Joseph form, one row at a time), residual r0 - h (x - xp); 0 when not
   positive definite.  h's entries
   that can be nonzero are nz[0..cnt) (ascending; the caller knows them: an entry that happens to be 0 adds exact
   zeros).  Reads and updates P's upper triangle only (P is symmetric: mirror() restores the lower one before it is
   read) */
HOT static int scalar(double *x, double P[N][N], const double *xp, const double *h, const int *nz, int cnt, double r0,
                      double var) {
    double Ph[N];
    double r = r0;
    for (int c = 0; c < cnt; c++) r -= h[nz[c]] * (x[nz[c]] - xp[nz[c]]);
    ZERO(Ph);
    for (int c = 0; c < cnt; c++) { /* P h, over h's nonzero entries in order: column m above the diagonal, row m from it */
        int m = nz[c];
        double a = h[m];
        for (int i = 0; i < m; i++) Ph[i] += P[i][m] * a;
        for (int i = m; i < N; i++) Ph[i] += P[m][i] * a;
    }
    double s0 = 0.0;
    for (int c = 0; c < cnt; c++) s0 += h[nz[c]] * Ph[nz[c]];
    double s = s0 + var;
    if (!(s > 0.0)) return 0;
    /* the expanded Joseph form with the optimal gain k = Ph / s is P - Ph Ph^T / s: one symmetric rank-1
       update by g = Ph / sqrt(s) (g_i g_j = g_j g_i: the upper triangle is the whole update) */
    double rs = r / s, g[N], sq = 1.0 / sqrt(s);
    for (int i = 0; i < N; i++) {
        x[i] += Ph[i] * rs;
        g[i] = Ph[i] * sq;
    }
    for (int i = 0; i < N; i++) {
        double gi = g[i];
        for (int j = i; j < N; j++) P[i][j] -= gi * g[j];
    }
    return 1;
}

/* the lower triangle from the upper one */
static void mirror(double P[N][N]) {
    for (int i = 0; i < N; i++)
        for (int j = i + 1; j < N; j++) P[j][i] = P[i][j];
}

static void profile(double x, double x0, double step, const double *z, const double *dz, Py_ssize_t nz, double *zo,
                    double *dzo) {
    double f = (x - x0) / step;
    Py_ssize_t i;
    if (!(f >= 0.0))
        i = 0;
    else if (f > (double)(nz - 2))
        i = nz - 2;
    else
        i = (Py_ssize_t)f;
    double a = f - (double)i;
    *zo = (1 - a) * z[i] + a * z[i + 1];
    *dzo = (1 - a) * dz[i] + a * dz[i + 1];
}

/* Cholesky factor A = U^T U (U upper triangular, U[j][i] the lower factor's L[i][j]) with the forward
   substitution U^T Y = R of a right-hand side R (N x 10) folded in: row j of U carries Y's row j in its columns
   N .. N + 9.  0 when A is not positive definite.  Right-looking: once row j is known it is taken off the
   trailing rows (vector updates along each row).  Every element subtracts the same products in the same order as
   the left-looking dot products L[i][j] = (A[i][j] - sum_m L[i][m] L[j][m]) / L[j][j] and
   Y[i] = (R[i] - sum_m L[i][m] Y[m]) / L[i][i] (Y by the reciprocal), so U and Y are the same. */
HOT static int chol_solve(double A[N][N], double R[N][10], double U[N][NW]) {
    double W[N][NW];
    for (int i = 0; i < N; i++) {
        memcpy(W[i], A[i], sizeof(A[i]));
        memcpy(W[i] + N, R[i], sizeof(R[i]));
    }
    for (int j = 0; j < N; j++) {
        double s = W[j][j];
        if (!(s > 0.0) || !isfinite(s)) return 0;
        double d = sqrt(s), rd = 1.0 / d;
        U[j][j] = d;
        for (int i = j + 1; i < N; i++) U[j][i] = W[j][i] / d;
        for (int i = N; i < NW; i++) U[j][i] = W[j][i] * rd;
        for (int k = j + 1; k < N; k++) {
            /* from the multiple of 4 at or below k: whole vectors of 4 (the extra entries below the diagonal
               are never read; U's are zeros) */
            double f = U[j][k];
            for (int i = k & ~3; i < NW; i += 4) {
                W[k][i] -= f * U[j][i];
                W[k][i + 1] -= f * U[j][i + 1];
                W[k][i + 2] -= f * U[j][i + 2];
                W[k][i + 3] -= f * U[j][i + 3];
            }
        }
    }
    return 1;
}

static int pd_diag(double P[N][N]) {
    for (int i = 0; i < N; i++)
        if (!(P[i][i] > 0.0) || !isfinite(P[i][i])) return 0;
    return 1;
}

static void pack(double P[N][N], double *out) {
    int m = 0;
    for (int i = 0; i < N; i++)
        for (int j = i; j < N; j++) out[m++] = P[i][j];
}

static void unpack(const double *p, double P[N][N]) {
    int m = 0;
    for (int i = 0; i < N; i++)
        for (int j = i; j < N; j++) {
            P[i][j] = p[m];
            P[j][i] = p[m];
            m++;
        }
}

/* row k of an (n, m) output: row-major (ld 0: m items at base + m k), or column-major (item i at base[i ld + k]:
   the rows of a segment inside a session's (m, ld) array, so that every column is contiguous for the table) */
static inline void put_row(double *base, Py_ssize_t ld, Py_ssize_t k, const double *v, int m) {
    if (ld)
        for (int i = 0; i < m; i++) base[i * ld + k] = v[i];
    else
        memcpy(base + (Py_ssize_t)m * k, v, sizeof(double) * m);
}

static double sqrt0(double v) { return v >= 0.0 ? sqrt(v) : (v < 0.0 ? 0.0 : v); }

/* standard deviations at one step: the states' (22), the hill-frame velocity's (3), roll/pitch/yaw's (3) --
   smoother_outputs._std_from_cov's formulas (the Euler angles' Jacobian: smoother_outputs.euler_jacobian) */
HOT static void std_row(const double *x, double P[N][N], const double *mno, double *out) {
    double M[3][3], D[4][3][3], J[3][7];
    for (int i = 0; i < N; i++) out[i] = sqrt0(P[i][i]);
    mbo(x + 6, M);
    dmdq(x + 6, D);
    for (int a = 0; a < 3; a++) {
        for (int j = 0; j < 3; j++) J[a][j] = mno[3 * a] * M[j][0] + mno[3 * a + 1] * M[j][1] + mno[3 * a + 2] * M[j][2];
        for (int k = 0; k < 4; k++) {
            double s = 0.0;
            for (int b = 0; b < 3; b++) s += mno[3 * a + b] * (D[k][0][b] * x[3] + D[k][1][b] * x[4] + D[k][2][b] * x[5]);
            J[a][3 + k] = s;
        }
    }
    for (int a = 0; a < 3; a++) {
        double s = 0.0;
        for (int i = 0; i < 7; i++)
            for (int j = 0; j < 7; j++) s += J[a][i] * P[3 + i][3 + j] * J[a][j];
        out[N + a] = sqrt0(s);
    }
    double q0 = x[6], q1 = x[7], q2 = x[8], q3 = x[9];
    double n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3;
    double m12 = 2 * (q2 * q3 + q0 * q1), m22 = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3;
    double m01 = 2 * (q1 * q2 + q0 * q3), m00 = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3;
    double m02 = 2 * (q1 * q3 - q0 * q2);
    double r1 = m12 * m12 + m22 * m22, r2 = m01 * m01 + m00 * m00;
    double sp = -m02 / n2;
    double c = sqrt(fmax(1.0 - sp * sp, 1e-300));
    double qq[4] = {q0, q1, q2, q3};
    double d12[4] = {2 * q1, 2 * q0, 2 * q3, 2 * q2}, d22[4] = {2 * q0, -2 * q1, -2 * q2, 2 * q3};
    double d01[4] = {2 * q3, 2 * q2, 2 * q1, 2 * q0}, d00[4] = {2 * q0, 2 * q1, -2 * q2, -2 * q3};
    double d02[4] = {-2 * q2, 2 * q3, -2 * q0, 2 * q1};
    for (int i = 0; i < 4; i++) {
        J[0][i] = (m22 * d12[i] - m12 * d22[i]) / r1;
        J[1][i] = -(d02[i] * n2 - m02 * 2 * qq[i]) / (n2 * n2) / c;
        J[2][i] = (m00 * d01[i] - m01 * d00[i]) / r2;
    }
    for (int a = 0; a < 3; a++) {
        double s = 0.0;
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 4; j++) s += J[a][i] * P[6 + i][6 + j] * J[a][j];
        out[N + 3 + a] = sqrt0(s);
    }
}

/* One step of the backward pass (eqs 17-21) once chol_solve has factored P_k+1|k (U, with U^-T (Phi P)[:, :10] in
   its columns N..): the gain's kinematic rows Ct = C[:10]^T, the smoothed state xs from xf + C (xs1 - xp1) and the
   smoothed covariance, written over Ps (P_k+1|n on entry, P_k|n on return: Pf + C (Ps - Pp) C^T, where C's other
   rows are the identity's).  Pp is the whole prediction.  The vector version (SKI_VEC) solves the triangular
   system by columns: its sums run in another order than the plain one's. */
#if SKI_VEC
/* rows of 10 as 3 vectors (the last two lanes zero), rows of 22 as 6 */
HOT static void smooth_step(double U[N][NW], double Pf[N][N], double Pp[N][N], double Ps[N][N], const double *xf,
                            const double *xp1, const double *xs1, double *xs) {
    v4 C[N][3], Dm[N][6], E[10][6];
    const v4 z = V4_ZERO;
    /* U Ct = U^-T Y by columns: each solved row taken off the rows above it (independent updates) */
    for (int i = 0; i < N; i++) {
        load4(&C[i][0], U[i] + N);
        load4(&C[i][1], U[i] + N + 4);
        C[i][2] = (v4){U[i][N + 8], U[i][N + 9], 0.0, 0.0};
    }
    for (int m = N - 1; m >= 0; m--) {
        double d = 1.0 / U[m][m];
        for (int b = 0; b < 3; b++) C[m][b] *= d;
        for (int i = 0; i < m; i++) {
            double a = U[i][m];
            for (int b = 0; b < 3; b++) C[i][b] -= a * C[m][b];
        }
    }
    /* xs = xf + C dx: the kinematic rows, then the parameters' (C's rows there are the identity's) */
    v4 s[3] = {z, z, {xf[8], xf[9], 0.0, 0.0}};
    load4(&s[0], xf);
    load4(&s[1], xf + 4);
    for (int m = 0; m < N; m++) {
        double a = xs1[m] - xp1[m];
        for (int b = 0; b < 3; b++) s[b] += C[m][b] * a;
        if (m >= 10) xs[m] = xf[m] + a;
    }
    store4(xs, &s[0]);
    store4(xs + 4, &s[1]);
    xs[8] = s[2][0];
    xs[9] = s[2][1];
    for (int m = 0; m < N; m++) {
        for (int b = 0; b < 5; b++) {
            v4 a, c;
            load4(&a, Ps[m] + 4 * b);
            load4(&c, Pp[m] + 4 * b);
            Dm[m][b] = a - c;
        }
        Dm[m][5] = (v4){Ps[m][20] - Pp[m][20], Ps[m][21] - Pp[m][21], 0.0, 0.0};
    }
    for (int i = 0; i < 10; i += 2) { /* E = C Dm, two rows at a time */
        v4 e0[6], e1[6];
        for (int b = 0; b < 6; b++) e0[b] = e1[b] = z;
        for (int m = 0; m < N; m++) {
            double a0 = C[m][i / 4][i % 4], a1 = C[m][(i + 1) / 4][(i + 1) % 4];
            for (int b = 0; b < 6; b++) {
                e0[b] += a0 * Dm[m][b];
                e1[b] += a1 * Dm[m][b];
            }
        }
        for (int b = 0; b < 6; b++) {
            E[i][b] = e0[b];
            E[i + 1][b] = e1[b];
        }
    }
    for (int i = 0; i < 10; i += 2) { /* Pf + E C^T, two rows at a time; its upper triangle (Ps mirrors it) */
        v4 s0[3], s1[3];
        for (int b = 0; b < 3; b++) {
            s0[b] = z;
            s1[b] = z;
            for (int l = 0; l < 4; l++) {
                int j = 4 * b + l;
                if (j >= i && j < 10) s0[b][l] = Pf[i][j];
                if (j > i && j < 10) s1[b][l] = Pf[i + 1][j];
            }
        }
        for (int m = 0; m < N; m++) {
            double a0 = E[i][m / 4][m % 4], a1 = E[i + 1][m / 4][m % 4];
            for (int b = 0; b < 3; b++) {
                s0[b] += a0 * C[m][b];
                s1[b] += a1 * C[m][b];
            }
        }
        for (int j = i; j < 10; j++) {
            Ps[i][j] = Ps[j][i] = s0[j / 4][j % 4];
            if (j > i) Ps[i + 1][j] = Ps[j][i + 1] = s1[j / 4][j % 4];
        }
    }
    for (int i = 0; i < 10; i++)
        for (int j = 10; j < N; j++) Ps[i][j] = Ps[j][i] = Pf[i][j] + E[i][j / 4][j % 4];
    for (int i = 10; i < N; i++)
        for (int j = i; j < N; j++) Ps[i][j] = Ps[j][i] = Pf[i][j] + Dm[i][j / 4][j % 4];
}
#else
static void smooth_step(double U[N][NW], double Pf[N][N], double Pp[N][N], double Ps[N][N], const double *xf,
                        const double *xp1, const double *xs1, double *xs) {
    double Ct[N][10], Dm[N][N], E[10][N], dx[N];
    for (int i = N - 1; i >= 0; i--) {
        double v[10];
        for (int j = 0; j < 10; j++) v[j] = U[i][N + j];
        for (int m = i + 1; m < N; m++) {
            double a = U[i][m];
            for (int j = 0; j < 10; j++) v[j] -= a * Ct[m][j];
        }
        double d = 1.0 / U[i][i];
        for (int j = 0; j < 10; j++) Ct[i][j] = v[j] * d;
    }
    for (int m = 0; m < N; m++) dx[m] = xs1[m] - xp1[m];
    {
        double s[10]; /* xs = xf + C dx over the kinematic rows, summed over m in order as vector updates */
        for (int i = 0; i < 10; i++) s[i] = xf[i];
        for (int m = 0; m < N; m++) {
            double a = dx[m];
            for (int i = 0; i < 10; i++) s[i] += Ct[m][i] * a;
        }
        for (int i = 0; i < 10; i++) xs[i] = s[i];
    }
    for (int i = 10; i < N; i++) xs[i] = xf[i] + dx[i];
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++) Dm[i][j] = Ps[i][j] - Pp[i][j];
    for (int i = 0; i < 10; i++) {
        double c[N]; /* E = C Dm, row i; the sums over m in two halves of constant length (unrolled) */
        for (int m = 0; m < N; m++) c[m] = Ct[m][i];
        for (int j = 0; j < N; j++) {
            double v = 0.0;
            for (int m = 0; m < N / 2; m++) v += c[m] * Dm[m][j];
            for (int m = N / 2; m < N; m++) v += c[m] * Dm[m][j];
            E[i][j] = v;
        }
    }
    for (int i = 0; i < 10; i++) {
        double s[10], e[N]; /* Pf + E C^T, row i */
        for (int m = 0; m < N; m++) e[m] = E[i][m];
        for (int j = 0; j < 10; j++) {
            double v = Pf[i][j];
            for (int m = 0; m < N / 2; m++) v += e[m] * Ct[m][j];
            for (int m = N / 2; m < N; m++) v += e[m] * Ct[m][j];
            s[j] = v;
        }
        for (int j = i; j < 10; j++) {
            Ps[i][j] = s[j];
            Ps[j][i] = s[j];
        }
        for (int j = 10; j < N; j++) {
            double v = Pf[i][j] + E[i][j];
            Ps[i][j] = v;
            Ps[j][i] = v;
        }
    }
    for (int i = 10; i < N; i++)
        for (int j = i; j < N; j++) {
            double v = Pf[i][j] + Dm[i][j];
            Ps[i][j] = v;
            Ps[j][i] = v;
        }
}
#endif

/* the entries of each update's h that can be nonzero (scalar()'s nz): the quaternion norm, the GNSS velocity
   (body velocity and quaternion), the in-run and landing heights (x and z), the in-run's lateral position */
static const int NZ_Q[4] = {6, 7, 8, 9}, NZ_V[7] = {3, 4, 5, 6, 7, 8, 9}, NZ_H[2] = {0, 2}, NZ_Y[1] = {1};

/* The segment's inputs and the loop's constants, as the forward pass reads them */
typedef struct {
    Py_ssize_t n, nir, nla;
    const double *t, *u, *pos, *vel, *mag, *inrun, *landing, *still, *mno, *m_o, *qd, *irz, *irdz, *laz, *ladz, *par;
} Inputs;

/* the size of a checkpoint: the state and the full covariance at the top of a step (before its updates) */
#define NCK (N + N * N)

/* The forward pass (eqs 10-16) over the steps ka <= k < kb from the prior (x, P) at step ka: innovations written
   at row k of resid, filtered states (where x_filt is given) at row k - xo of x_filt; where given, the priors, the packed filtered
   covariances and (pred, only where the step is not the segment's last) the predictions at row k - off of x_pred,
   Pbuf and pred, and at every step k that is a multiple of nb the prior (x, P) at ck + NCK * (k / nb).  Returns the
   failing step or -1, *phase 0 update, 1 prediction.  The same code from the same prior gives the same numbers
   to the bit: the backward pass runs a block of steps again from its checkpoint.  Always inlined into run (its
   two calls compiled inside each of run's clones: as one function, the same contractions into FMA as before
   the forward pass was a function of its own, and the same results to the last bit). */
static INLINE Py_ssize_t forward(const Inputs *in, Py_ssize_t ka, Py_ssize_t kb, Py_ssize_t off, const double *x_init,
                                 const double *P_init, double *x_filt, Py_ssize_t xo, double *resid, double *x_pred,
                                 double *Pbuf, double *pred, double *ck, Py_ssize_t nb, int *phase) {
    const double *par = in->par, *t = in->t, *u = in->u, *pos = in->pos, *vel = in->vel, *mag = in->mag;
    const double *inrun = in->inrun, *landing = in->landing, *still = in->still, *mno = in->mno, *m_o = in->m_o;
    const double *qd = in->qd, *irz = in->irz, *irdz = in->irdz, *laz = in->laz, *ladz = in->ladz;
    Py_ssize_t n = in->n, nir = in->nir, nla = in->nla;
    double g0 = par[0], rmag = par[7], rcq = par[8], rir = par[9], rhir = par[10], rla = par[11];
    const double *rpos = par + 1, *rvel = par + 4;
    double ir_x0 = par[12], ir_step = par[13], la_x0 = par[14], la_step = par[15];
    int use_hill = par[16] != 0.0, use_vel = par[17] != 0.0, use_mag = par[18] != 0.0;
    double rzu = par[20];
    double Pa[N][N], Pb[N][N], Phi[10][N], Qd[10][10], Tf[10][N], M[3][3], D[4][3][3];
    double(*P)[N] = Pa, (*Pn)[N] = Pb; /* the covariance and its prediction, swapped after each step */
    double x[N], xn[N], xp[N], h[N]; /* h: each update sets and scalar() reads only the entries it names */
    memcpy(x, x_init, sizeof(x));
    memcpy(Pa, P_init, sizeof(Pa));
    *phase = 0;
    for (Py_ssize_t k = ka; k < kb; k++) {
        double *rk = resid + NRES * k;
        if (ck && k % nb == 0) {
            memcpy(ck + NCK * (k / nb), x, sizeof(x));
            memcpy(ck + NCK * (k / nb) + N, P, sizeof(Pa));
        }
        memcpy(xp, x, sizeof(xp));
        if (x_pred) memcpy(x_pred + N * (k - off), xp, sizeof(xp));
        double nq = sqrt(xp[6] * xp[6] + xp[7] * xp[7] + xp[8] * xp[8] + xp[9] * xp[9]);
        for (int i = 0; i < 4; i++) h[6 + i] = xp[6 + i] / nq;
        rk[0] = -(nq - 1.0);
        if (!scalar(x, P, xp, h, NZ_Q, 4, -(nq - 1.0), rcq)) return k;
        if (isfinite(pos[3 * k])) {
            for (int i = 0; i < 3; i++) {
                h[i] = 1.0;
                double r0 = pos[3 * k + i] - xp[i];
                rk[1 + i] = r0;
                if (!scalar(x, P, xp, h, &i, 1, r0, rpos[i])) return k;
            }
        }
        if (use_vel && isfinite(vel[3 * k])) {
            mbo(xp + 6, M);
            dmdq(xp + 6, D);
            for (int i = 0; i < 3; i++) {
                double hv = 0.0;
                for (int j = 0; j < 3; j++) {
                    h[3 + j] = M[j][i];
                    hv += M[j][i] * xp[3 + j];
                }
                for (int kk = 0; kk < 4; kk++) h[6 + kk] = D[kk][0][i] * xp[3] + D[kk][1][i] * xp[4] + D[kk][2][i] * xp[5];
                double r0 = vel[3 * k + i] - hv;
                rk[4 + i] = r0;
                if (!scalar(x, P, xp, h, NZ_V, 7, r0, rvel[i])) return k;
            }
        }
        if (use_mag && isfinite(mag[3 * k])) {
            mbo(xp + 6, M);
            dmdq(xp + 6, D);
            for (int i = 0; i < 3; i++) {
                double mb = M[i][0] * m_o[0] + M[i][1] * m_o[1] + M[i][2] * m_o[2];
                double s = 1.0 + xp[19 + i];
                for (int kk = 0; kk < 4; kk++)
                    h[6 + kk] = s * (D[kk][i][0] * m_o[0] + D[kk][i][1] * m_o[1] + D[kk][i][2] * m_o[2]);
                h[16 + i] = 1.0;
                h[19 + i] = mb;
                double r0 = mag[3 * k + i] - (s * mb + xp[16 + i]);
                rk[7 + i] = r0;
                const int nzm[6] = {6, 7, 8, 9, 16 + i, 19 + i};
                if (!scalar(x, P, xp, h, nzm, 6, r0, rmag)) return k;
            }
        }
        if (use_hill) {
            double z, dz;
            if (inrun[k] != 0.0) {
                profile(xp[0], ir_x0, ir_step, irz, irdz, nir, &z, &dz);
                h[0] = -dz;
                h[2] = 1.0;
                rk[10] = z - xp[2];
                if (!scalar(x, P, xp, h, NZ_H, 2, z - xp[2], rir)) return k;
                h[1] = 1.0;
                rk[11] = -xp[1];
                if (!scalar(x, P, xp, h, NZ_Y, 1, -xp[1], rhir)) return k;
            }
            if (landing[k] > 0.0) {
                profile(xp[0], la_x0, la_step, laz, ladz, nla, &z, &dz);
                h[0] = -dz;
                h[2] = 1.0;
                rk[12] = z - xp[2];
                if (!scalar(x, P, xp, h, NZ_H, 2, z - xp[2], rla / landing[k])) return k;
            }
        }
        if (still[k] > 0.0) { /* zero velocity: v_B = 0 */
            for (int i = 0; i < 3; i++) {
                h[3 + i] = 1.0;
                rk[13 + i] = -xp[3 + i];
                const int nzv = 3 + i;
                if (!scalar(x, P, xp, h, &nzv, 1, -xp[3 + i], rzu / still[k])) return k;
            }
        }
        if (!pd_diag(P)) return k;
        if (x_filt) memcpy(x_filt + N * (k - xo), x, sizeof(x));
        if (Pbuf) pack(P, Pbuf + NP * (k - off));
        if (k < n - 1) {
            double dt = t[k + 1] - t[k];
            rk4(x, u + 6 * k, u + 6 * (k + 1), dt, g0, mno, xn);
            phi_qd(x, u + 6 * k, dt, g0, mno, qd + 6 * k, Phi, Qd);
            mirror(P);
            predict_cov(P, Phi, Qd, Pn, Tf);
            if (pred) { /* what the backward pass would form again at this step */
                double *o = pred + NT * (k - off);
                memcpy(o, Tf, sizeof(Tf));
                o += 10 * N;
                for (int i = 0; i < 10; i++)
                    for (int j = i; j < 10; j++) *o++ = Pn[i][j];
            }
            double(*Pt)[N] = P;
            P = Pn;
            Pn = Pt;
            if (!pd_diag(P)) {
                *phase = 1;
                return k + 1;
            }
            memcpy(x, xn, sizeof(x));
        }
    }
    return -1;
}

/* The whole EKF + RTS (kalman.ekf_rts with smoother_engine.model_callables, see the top of this file): the
   forward pass and (smooth) the backward pass; returns the failing step or -1, *phase 0 update, 1 prediction,
   2 backward pass.  nb > 0 (with smooth, where the smoothed covariances are not written back): the backward pass
   goes through blocks of nb steps, last first, each block's forward pass run again from its checkpoint (ck:
   ceil(n / nb) * NCK items), so that x_pred (nb + 1 rows), Pbuf and pred (nb rows) hold one block -- the same
   numbers as with the whole history (nb = 0), for a second forward pass; with xf_block, x_filt too holds one
   block (nb rows: the filtered states are not kept). */
HOT static Py_ssize_t run(const Inputs *in, const double *x0, const double *P0, double *x_filt, int xf_block,
                          double *x_pred, double *x_s, double *Pbuf, double *resid, double *std, double *pred,
                          Py_ssize_t nb, double *ck, int *phase) {
    const double *par = in->par, *t = in->t, *u = in->u, *mno = in->mno, *qd = in->qd;
    Py_ssize_t n = in->n;
    double g0 = par[0];
    int smooth = par[19] != 0.0;
    /* the predictions and filtered covariances are kept for the backward pass, or when asked for */
    int keep = smooth || par[21] != 0.0;
    int write_ps = par[22] != 0.0; /* the smoothed covariances written back over the filtered ones */
    Py_ssize_t ldx = (Py_ssize_t)par[23], lds = (Py_ssize_t)par[25]; /* x_s, std: 0 row-major, else column-major */
    int blocks = smooth && !write_ps && nb > 0 && nb < n;
    Py_ssize_t fail;
    xf_block = xf_block && blocks;
    if (blocks)
        fail = forward(in, 0, n, 0, x0, P0, xf_block ? NULL : x_filt, 0, resid, NULL, NULL, NULL, ck, nb, phase);
    else
        fail = forward(in, 0, n, 0, x0, P0, x_filt, 0, resid, keep ? x_pred : NULL, keep ? Pbuf : NULL,
                       smooth ? pred : NULL, NULL, 1, phase);
    if (fail >= 0) return fail;
    if (!smooth) return -1;
    /* backward pass (eqs 17-21); the smoothed covariance overwrites the filtered one (where write_ps) */
    double Ps[N][N], Pf[N][N], Pp[N][N], T[10][N], Y[N][10], U[N][NW], Phi[10][N], Qd[10][10];
    double xs[N], xs1[N], sd[NSTD]; /* xs1: the smoothed state of the step after (the previous iteration's) */
    Py_ssize_t bl = blocks ? nb : n, nblk = (n + bl - 1) / bl;
    memset(U, 0, sizeof(U));
    for (Py_ssize_t j = nblk - 1; j >= 0; j--) {
        Py_ssize_t k0 = j * bl, k1 = k0 + bl < n ? k0 + bl : n; /* this block's steps; rows k - k0 of the buffers */
        Py_ssize_t xo = xf_block ? k0 : 0;                        /* and rows k - xo of x_filt */
        if (blocks) {
            const double *c = ck + NCK * j;
            fail = forward(in, k0, k1, k0, c, c + N, x_filt, xo, resid, x_pred, Pbuf, pred, NULL, 1, phase);
            if (fail >= 0) return fail;
            if (k1 < n) memcpy(x_pred + N * (k1 - k0), ck + NCK * (j + 1), N * sizeof(double)); /* the next prior */
        }
        if (k1 == n) {
            memcpy(xs1, x_filt + N * (n - 1 - xo), sizeof(xs1));
            put_row(x_s, ldx, n - 1, xs1, N);
            unpack(Pbuf + NP * (n - 1 - k0), Ps);
            std_row(xs1, Ps, mno, sd);
            put_row(std, lds, n - 1, sd, NSTD);
        }
        for (Py_ssize_t k = (k1 < n ? k1 : n - 1) - 1; k >= k0; k--) {
            const double *xf = x_filt + N * (k - xo);
            double *Pk = Pbuf + NP * (k - k0);
            if (k - 2 >= k0) /* the step after next's filtered covariance (2 KB): read while this step computes */
                for (int i = 0; i < NP; i += 8) PREFETCH(Pk - 2 * NP + i);
            unpack(Pk, Pf);
            if (pred) { /* the forward pass's T and kinematic block; the rest of P_k+1|k is T's and Pf's (outer_blocks) */
                const double *o = pred + NT * (k - k0);
                if (k - 1 >= k0)
                    for (int i = 0; i < NT; i += 8) PREFETCH(o - NT + i);
                memcpy(T, o, sizeof(T));
                o += 10 * N;
                for (int i = 0; i < 10; i++)
                    for (int jj = i; jj < 10; jj++) {
                        Pp[i][jj] = *o;
                        Pp[jj][i] = *o++;
                    }
                outer_blocks(T, Pf, Pp);
            } else {
                double dt = t[k + 1] - t[k];
                phi_qd(xf, u + 6 * k, dt, g0, mno, qd + 6 * k, Phi, Qd);
                predict_cov(Pf, Phi, Qd, Pp, T);
            }
            for (int i = 0; i < N; i++)
                if (!(Pp[i][i] > 0.0)) {
                    *phase = 2;
                    return k + 1;
                }
            /* the gain's kinematic rows: Ct = C[:10]^T = Pp^-1 (Phi P)[:, :10] by the two triangular solves;
               (Phi P)[:10] is predict_cov's T, its other rows are P's */
            for (int i = 0; i < N; i++)
                for (int jj = 0; jj < 10; jj++) Y[i][jj] = i < 10 ? T[i][jj] : Pf[i][jj];
            if (!chol_solve(Pp, Y, U)) {
                *phase = 2;
                return k + 1;
            }
            smooth_step(U, Pf, Pp, Ps, xf, x_pred + N * (k + 1 - k0), xs1, xs);
            if (write_ps) pack(Ps, Pk);
            std_row(xs, Ps, mno, sd);
            put_row(x_s, ldx, k, xs, N);
            put_row(std, lds, k, sd, NSTD);
            memcpy(xs1, xs, sizeof(xs1));
        }
    }
    return -1;
}

static const char doc_ekf_rts[] =
    "ekf_rts(n, t, u, pos, vel, mag, inrun, landing, still, x0, P0, mno, m_o, qd, ir_z, ir_dz, la_z, la_dz, par,\n"
    "        x_filt, x_pred, x_smooth, P_packed, resid, std[, pred[, nb, ck]]) -> (fail, phase)\n\n"
    "The ski-jump EKF + RTS (kalman.ekf_rts with smoother_engine.model_callables) on float64 buffers (inrun as 0/1, still a weight); par holds g0,\n"
    "r_pos (3), r_vel (3), r_mag, r_cq, r_ir, r_hir, r_la, ir_x0, ir_step, la_x0, la_step, use_hill, use_vel,\n"
    "use_mag, smooth, r_zupt (variances, not sigmas), keep_cov (0: without smooth, x_pred and P_packed are not\n"
    "written), smoothed_cov (0: with smooth, P_packed keeps the filtered covariances; only std is wanted), then\n"
    "ld and off for x_smooth and for std: ld 0, an (n, 22) / (n, 28) row-major array; else the whole (22, ld) /\n"
    "(28, ld) column-major array, this run's step k in column off + k.\n"
    "Outputs are written in place; fail is -1 or the step at which a covariance stopped being positive\n"
    "definite, phase 0 update, 1 prediction, 2 backward pass.  pred (optional, with smooth; at least (n - 1) * 275\n"
    "items): scratch where the forward pass keeps each step's Phi_top P (10 x 22) and its prediction's kinematic\n"
    "block (upper triangle, 55) for the backward pass, which then does not form them again.  nb > 0 (with smooth and\n"
    "smoothed_cov 0, nb < n): the backward pass goes through blocks of nb steps, each block's forward pass run again\n"
    "from a checkpoint the first pass kept in ck (at least ceil(n / nb) * 506 items); x_pred then holds nb + 1 rows,\n"
    "P_packed and pred nb rows (the same results as without blocks, to the bit); x_filt may then hold nb rows too\n"
    "(the filtered states are not kept: the block's last ones are left in it).";

static PyObject *py_ekf_rts(PyObject *self, PyObject *args) {
    Py_ssize_t n;
    Py_ssize_t nb = 0;
    PyObject *o[24], *opred = Py_None, *ock = Py_None;
    if (!PyArg_ParseTuple(args, "nOOOOOOOOOOOOOOOOOOOOOOOO|OnO", &n, &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6],
                          &o[7], &o[8], &o[9], &o[10], &o[11], &o[12], &o[13], &o[14], &o[15], &o[16], &o[17], &o[18],
                          &o[19], &o[20], &o[21], &o[22], &o[23], &opred, &nb, &ock))
        return NULL;
    if (n < 1) {
        PyErr_SetString(PyExc_ValueError, "ekf_rts: n must be at least 1");
        return NULL;
    }
    /* name, count (negative: at least), writable */
    static const char *names[24] = {"t",   "u",      "pos",    "vel",      "mag",      "inrun", "landing", "still",
                                    "x0",  "P0",     "mno",    "m_o",      "qd",       "ir_z",  "ir_dz",   "la_z",
                                    "la_dz", "par",  "x_filt", "x_pred",   "x_smooth", "P_packed", "resid", "std"};
    Py_ssize_t counts[24] = {n,     6 * n, 3 * n, 3 * n, 3 * n, n,     n,      n,
                             N,     N * N, 9,     3,     6 * n, -2,    -2,     -2,
                             -2,    NPAR,  -N,    -N,    -1,    -NP,    NRES * n, -1};
    Buf b[24];
    int k;
    for (k = 0; k < 24; k++) {
        if (get_buf(o[k], &b[k], counts[k], k >= 18, names[k]) < 0) break;
    }
    PyObject *res = NULL;
    Buf bp, bc;
    int has_pred = 0, has_ck = 0;
    if (k == 24 && opred != Py_None) { /* at least one step of NT (the length is checked below) */
        if (get_buf(opred, &bp, -NT, 1, "pred") < 0) {
            release(&bp, 1);
            k = 23; /* no run; all 24 released below */
        } else {
            has_pred = 1;
        }
    }
    if (k == 24 && ock != Py_None) {
        if (get_buf(ock, &bc, -NCK, 1, "ck") < 0) {
            release(&bc, 1);
            k = 23;
        } else {
            has_ck = 1;
        }
    }
    if (k == 24) {
        Py_ssize_t nir = b[13].view.len / 8, nla = b[15].view.len / 8;
        const double *par = (const double *)b[17].view.buf;
        int keep = par[19] != 0.0 || par[21] != 0.0; /* smooth or keep_cov: x_pred and P_packed are written */
        /* blocks: the backward pass through blocks of nb steps (x_pred nb + 1 rows, P_packed and pred nb) */
        int blocks = par[19] != 0.0 && par[22] == 0.0 && nb > 0 && nb < n;
        Py_ssize_t rows = blocks ? nb : n; /* the rows of P_packed (x_pred: one more with blocks) */
        int xf_block = blocks && b[18].view.len == 8 * N * nb; /* x_filt: n rows, or with blocks nb */
        /* x_smooth and std: row-major (n rows) where par's ld is 0, else column-major (the whole (m, ld) array,
           this run's rows from column off) */
        Py_ssize_t ldx = (Py_ssize_t)par[23], offx = (Py_ssize_t)par[24], lds = (Py_ssize_t)par[25],
                   offs = (Py_ssize_t)par[26];
        int bad_x = ldx ? (par[23] != (double)ldx || offx < 0 || offx + n > ldx || b[20].view.len != 8 * N * ldx)
                        : b[20].view.len != 8 * N * n;
        int bad_s = lds ? (par[25] != (double)lds || offs < 0 || offs + n > lds || b[23].view.len != 8 * NSTD * lds)
                        : b[23].view.len != 8 * NSTD * n;
        if (b[18].view.len != 8 * N * n && !xf_block) {
            PyErr_Format(PyExc_ValueError, "ekf_rts: x_filt: expected %zd float64 items (with blocks: or %zd)", N * n,
                         N * nb);
        } else if (b[14].view.len / 8 != nir || b[16].view.len / 8 != nla) {
            PyErr_SetString(PyExc_ValueError, "ekf_rts: profile tables z and dz differ in length");
        } else if (ldx < 0 || lds < 0 || bad_x || bad_s) {
            PyErr_Format(PyExc_ValueError,
                         "ekf_rts: x_smooth and std: expected %zd x 22 and %zd x 28 float64 items (row-major), or "
                         "22 x ld and 28 x ld with off + n <= ld (column-major)", n, n);
        } else if (keep && (b[19].view.len != 8 * N * (rows + blocks) || b[21].view.len != 8 * NP * rows)) {
            PyErr_Format(PyExc_ValueError, "ekf_rts: x_pred and P_packed: expected %zd and %zd float64 items",
                         N * (rows + blocks), NP * rows);
        } else if (has_pred && bp.view.len < 8 * NT * (blocks ? nb : (n > 1 ? n - 1 : 1))) {
            PyErr_SetString(PyExc_ValueError, "ekf_rts: pred: expected at least n - 1 (with blocks nb) rows of 275");
        } else if (nb < 0 || (blocks && (!has_ck || bc.view.len < 8 * NCK * ((n + nb - 1) / nb)))) {
            PyErr_SetString(PyExc_ValueError, "ekf_rts: nb >= 0; with blocks, ck: at least ceil(n / nb) * 506 items");
        } else {
            const double *p[18];
            for (int i = 0; i < 18; i++) p[i] = (const double *)b[i].view.buf;
            int phase = 0;
            Py_ssize_t fail;
            Py_BEGIN_ALLOW_THREADS
            Inputs in = {n,    nir,  nla,   p[0],  p[1],  p[2],  p[3],  p[4],  p[5], p[6],
                         p[7], p[10], p[11], p[12], p[13], p[14], p[15], p[16], p[17]};
            fail = run(&in, p[8], p[9], (double *)b[18].view.buf, xf_block, (double *)b[19].view.buf,
                       (double *)b[20].view.buf + (ldx ? offx : 0), (double *)b[21].view.buf,
                       (double *)b[22].view.buf, (double *)b[23].view.buf + (lds ? offs : 0),
                       has_pred ? (double *)bp.view.buf : NULL, blocks ? nb : 0,
                       has_ck ? (double *)bc.view.buf : NULL, &phase);
            Py_END_ALLOW_THREADS
            res = Py_BuildValue("ni", fail, phase);
        }
    }
    if (has_pred) release(&bp, 1);
    if (has_ck) release(&bc, 1);
    release(b, k < 24 ? k + 1 : 24); /* the buffers after the one that failed were never taken */
    return res;
}

static const char doc_body_to_start[] =
    "body_to_start(t, gyr, bias, out) -> None\n\n"
    "alignment.body_to_start's rotation matrices C_k (body frame of step k -> that of step 0) as one sequential\n"
    "product C_k+1 = C_k exp([w_k dt x]) (Rodrigues, w_k = gyr_k - bias held over the step): t (n), gyr (n, 3),\n"
    "bias (3); out (n, 3, 3) receives every C_k, or (1, 3, 3) only the last.";

/* alignment._body_to_start_numpy's product of the steps' rotations (the numpy reference; the same Rodrigues
   formula and the same order of products) */
static PyObject *py_body_to_start(PyObject *self, PyObject *args) {
    PyObject *o[4];
    if (!PyArg_ParseTuple(args, "OOOO", &o[0], &o[1], &o[2], &o[3])) return NULL;
    Buf b[4];
    if (get_buf(o[0], &b[0], -1, 0, "t") < 0) {
        release(b, 1);
        return NULL;
    }
    Py_ssize_t n = b[0].view.len / 8;
    static const char *names[4] = {"t", "gyr", "bias", "out"};
    Py_ssize_t counts[4] = {n, 3 * n, 3, -9};
    int k;
    for (k = 1; k < 4; k++)
        if (get_buf(o[k], &b[k], counts[k], k == 3, names[k]) < 0) break;
    PyObject *res = NULL;
    if (k == 4) {
        Py_ssize_t nout = b[3].view.len / 72;
        if (n < 1 || b[3].view.len % 72 || (nout != n && nout != 1)) {
            PyErr_Format(PyExc_ValueError, "body_to_start: out must hold %zd or 1 3x3 matrices (n >= 1)", n);
        } else {
            const double *t = b[0].view.buf, *g = b[1].view.buf, *bias = b[2].view.buf;
            double *out = b[3].view.buf, C[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
            if (nout == n) memcpy(out, C, sizeof(C));
            for (Py_ssize_t i = 0; i + 1 < n; i++) {
                double dt = t[i + 1] - t[i], p[3], a[3], K[3][3], S[3][3], R[3][3];
                for (int j = 0; j < 3; j++) p[j] = (g[3 * i + j] - bias[j]) * dt;
                double ang = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
                double d = ang < 1e-12 ? 1.0 : ang, sn = sin(ang), cc = 1.0 - cos(ang);
                for (int j = 0; j < 3; j++) a[j] = p[j] / d;
                K[0][0] = 0.0; K[0][1] = -a[2]; K[0][2] = a[1];
                K[1][0] = a[2]; K[1][1] = 0.0; K[1][2] = -a[0];
                K[2][0] = -a[1]; K[2][1] = a[0]; K[2][2] = 0.0;
                for (int r = 0; r < 3; r++)
                    for (int c = 0; c < 3; c++) {
                        double kk = K[r][0] * K[0][c] + K[r][1] * K[1][c] + K[r][2] * K[2][c];
                        S[r][c] = (r == c ? 1.0 : 0.0) + sn * K[r][c] + cc * kk;
                    }
                for (int r = 0; r < 3; r++)
                    for (int c = 0; c < 3; c++) R[r][c] = C[r][0] * S[0][c] + C[r][1] * S[1][c] + C[r][2] * S[2][c];
                memcpy(C, R, sizeof(C));
                if (nout == n) memcpy(out + 9 * (i + 1), C, sizeof(C));
            }
            if (nout == 1) memcpy(out, C, sizeof(C));
            Py_INCREF(Py_None);
            res = Py_None;
        }
    }
    release(b, k < 4 ? k + 1 : 4);
    return res;
}

static const char doc_latency_misfit[] =
    "latency_misfit(ts, v, tg, vg, grid, work, out) -> None\n\n"
    "alignment.gnss_latency's misfit at every delay of grid (g, ascending) [s]: the IMU velocity v (k, 3) at times\n"
    "ts (k, increasing) interpolated linearly (np.interp: held at the ends) to tg - delay for every fix tg (f,\n"
    "increasing) and subtracted from the GNSS velocities vg (f, 3); per axis the constant (the mean) and the drift\n"
    "over tg - mean(tg) removed; out (g) receives the sum of the squares left.  work: at least 3 f items of scratch.";

/* the residuals' squares left after a constant and a drift per axis, delay by delay: alignment._latency_misfit_numpy
   (gnss_latency's sums) */
static void latency_misfit(Py_ssize_t k, const double *ts, const double *v, Py_ssize_t f, const double *tg,
                           const double *vg, Py_ssize_t g, const double *grid, double *r, double *out) {
    double tm = 0.0, tt = 0.0;
    for (Py_ssize_t i = 0; i < f; i++) tm += tg[i];
    tm /= (double)f;
    for (Py_ssize_t i = 0; i < f; i++) tt += (tg[i] - tm) * (tg[i] - tm);
    for (Py_ssize_t j = 0; j < g; j++) {
        double mean[3] = {0.0, 0.0, 0.0}, s1[3] = {0.0, 0.0, 0.0}, ss = 0.0;
        Py_ssize_t p = 0; /* the fixes' query times ascend: the interval only moves forward */
        for (Py_ssize_t i = 0; i < f; i++) {
            double q = tg[i] - grid[j];
            for (int c = 0; c < 3; c++) {
                double vi;
                if (!(q > ts[0]))
                    vi = v[c];
                else if (!(q < ts[k - 1]))
                    vi = v[3 * (k - 1) + c];
                else {
                    while (ts[p + 1] <= q) p++;
                    double slope = (v[3 * (p + 1) + c] - v[3 * p + c]) / (ts[p + 1] - ts[p]);
                    vi = slope * (q - ts[p]) + v[3 * p + c];
                }
                r[3 * i + c] = vg[3 * i + c] - vi;
                mean[c] += r[3 * i + c];
            }
        }
        for (int c = 0; c < 3; c++) mean[c] /= (double)f;
        for (Py_ssize_t i = 0; i < f; i++)
            for (int c = 0; c < 3; c++) {
                double e = r[3 * i + c] - mean[c];
                ss += e * e;
                s1[c] += (tg[i] - tm) * e;
            }
        out[j] = ss - (s1[0] * s1[0] + s1[1] * s1[1] + s1[2] * s1[2]) / tt;
    }
}

static PyObject *py_latency_misfit(PyObject *self, PyObject *args) {
    PyObject *o[7];
    if (!PyArg_ParseTuple(args, "OOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6])) return NULL;
    Buf b[7];
    static const char *names[7] = {"ts", "v", "tg", "vg", "grid", "work", "out"};
    Py_ssize_t counts[7] = {-2, -6, -2, -6, -1, -6, -1};
    int n;
    for (n = 0; n < 7; n++)
        if (get_buf(o[n], &b[n], counts[n], n >= 5, names[n]) < 0) break;
    PyObject *res = NULL;
    if (n == 7) {
        Py_ssize_t k = b[0].view.len / 8, f = b[2].view.len / 8, g = b[4].view.len / 8;
        if (b[1].view.len != 24 * k || b[3].view.len != 24 * f || b[5].view.len < 24 * f || b[6].view.len != 8 * g) {
            PyErr_SetString(PyExc_ValueError, "latency_misfit: expected v (k, 3), vg (f, 3), work >= 3 f and out (g)");
        } else {
            latency_misfit(k, b[0].view.buf, b[1].view.buf, f, b[2].view.buf, b[3].view.buf, g, b[4].view.buf,
                           b[5].view.buf, b[6].view.buf);
            Py_INCREF(Py_None);
            res = Py_None;
        }
    }
    release(b, n < 7 ? n + 1 : 7);
    return res;
}

static PyMethodDef methods[] = {
    {"ekf_rts", py_ekf_rts, METH_VARARGS, doc_ekf_rts},
    {"body_to_start", py_body_to_start, METH_VARARGS, doc_body_to_start},
    {"latency_misfit", py_latency_misfit, METH_VARARGS, doc_latency_misfit},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_ski_c", "Compiled ski-jump EKF + RTS smoother (smoother_engine's numpy reference, in C).", -1,
    methods,
};

PyMODINIT_FUNC PyInit__ski_c(void) { return PyModule_Create(&module); }
