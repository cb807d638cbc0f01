"""Compiled (numba) EKF + RTS loop for the ski-jump model: the fast path of ``rts-smooth``.

The same equations as :func:`sportfusion.estimators.kalman.ekf_rts` driven by the callables
of :mod:`sportfusion.skijump.smoother` (the reference path, which the tests compare
this one with to round-off): eqs 10-21 with the model of
:mod:`sportfusion.skijump.model`.  Differences in the arithmetic only:

* the measurements of a step (all with diagonal ``R``) are applied one scalar
  at a time, every residual and Jacobian evaluated at the prior ``x_{k|k-1}``
  and corrected by ``-h (x - x_{k|k-1})`` for the rows applied before it: with
  a diagonal ``R`` this is algebraically the stacked update; each scalar update
  is the Joseph form with the optimal gain, which reduces to the symmetric rank-1
  ``P - (P h)(P h)^T / s`` (computed as ``g g^T`` with ``g = P h / sqrt(s)``);
* covariances are stored packed (upper triangle, 253 numbers for 22 states),
  and the smoothed covariance overwrites the filtered one in the backward pass:
  memory is one packed covariance and three state vectors per step;
* the backward pass recomputes ``Phi_k`` and ``P_{k+1|k}`` from ``x_{k|k}`` and
  ``P_{k|k}`` instead of storing them, and uses that the parameters are constant
  states without process noise (eq 22): the rows of the RTS gain that belong to
  them are exactly ``[0 I]``, so only the 10 rows of the kinematic states are solved for;
* sums may be re-associated (numba fast-math without the no-NaN flag) so that
  the row loops vectorise;
* positive definiteness is checked by finite positive variances after every
  update and prediction, and by the Cholesky factorisation of every
  ``P_{k+1|k}`` in the backward pass (the reference path factorises every ``P``);
* work arrays (and the backward pass's Cholesky factor) are allocated once per call, not per step.

The kernels compile once and are cached on disk (``cache=True``); the first call
in a fresh environment costs the compile time (tens of seconds), later
processes load it in about a second.
"""

from __future__ import annotations

import numpy as np

from sportfusion.core._numba import preload_cython_blas

preload_cython_blas()  # before numba: its BLAS check then skips importing the scipy.linalg package
from numba import njit  # noqa: E402

from sportfusion.skijump._ski_native import NP, NRES, NSTD, RESIDUALS, N, unpack_many  # noqa: E402, F401  (the shared layout)

#: fast-math flags: re-association (vectorised sums) but no "no-NaN/no-inf" assumption, so the
#: finiteness checks stay.
_FM = {"reassoc", "contract", "arcp", "nsz"}


@njit(cache=True)
def _pack(P, out):
    m = 0
    for i in range(N):
        for j in range(i, N):
            out[m] = P[i, j]
            m += 1


@njit(cache=True)
def _unpack(p, P):
    m = 0
    for i in range(N):
        for j in range(i, N):
            P[i, j] = p[m]
            P[j, i] = p[m]
            m += 1


@njit(cache=True)
def _mbo(q, M):
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    M[0, 0] = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    M[0, 1] = 2 * (q1 * q2 + q0 * q3)
    M[0, 2] = 2 * (q1 * q3 - q0 * q2)
    M[1, 0] = 2 * (q1 * q2 - q0 * q3)
    M[1, 1] = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3
    M[1, 2] = 2 * (q2 * q3 + q0 * q1)
    M[2, 0] = 2 * (q0 * q2 + q1 * q3)
    M[2, 1] = 2 * (q2 * q3 - q0 * q1)
    M[2, 2] = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3


@njit(cache=True)
def _dmdq(q, D):
    q0, q1, q2, q3 = 2 * q[0], 2 * q[1], 2 * q[2], 2 * q[3]
    D[0, 0, 0], D[0, 0, 1], D[0, 0, 2] = q0, q3, -q2
    D[0, 1, 0], D[0, 1, 1], D[0, 1, 2] = -q3, q0, q1
    D[0, 2, 0], D[0, 2, 1], D[0, 2, 2] = q2, -q1, q0
    D[1, 0, 0], D[1, 0, 1], D[1, 0, 2] = q1, q2, q3
    D[1, 1, 0], D[1, 1, 1], D[1, 1, 2] = q2, -q1, q0
    D[1, 2, 0], D[1, 2, 1], D[1, 2, 2] = q3, -q0, -q1
    D[2, 0, 0], D[2, 0, 1], D[2, 0, 2] = -q2, q1, -q0
    D[2, 1, 0], D[2, 1, 1], D[2, 1, 2] = q1, q2, q3
    D[2, 2, 0], D[2, 2, 1], D[2, 2, 2] = q0, q3, -q2
    D[3, 0, 0], D[3, 0, 1], D[3, 0, 2] = -q3, q0, q1
    D[3, 1, 0], D[3, 1, 1], D[3, 1, 2] = -q0, -q3, q2
    D[3, 2, 0], D[3, 2, 1], D[3, 2, 2] = q1, q2, q3


@njit(cache=True)
def _f(x, u, g0, mno, out, M):
    for i in range(N):
        out[i] = 0.0
    _mbo(x[6:10], M)
    wx, wy, wz = u[0] - x[10], u[1] - x[11], u[2] - x[12]
    vx, vy, vz = x[3], x[4], x[5]
    vo0 = M[0, 0] * vx + M[1, 0] * vy + M[2, 0] * vz
    vo1 = M[0, 1] * vx + M[1, 1] * vy + M[2, 1] * vz
    vo2 = M[0, 2] * vx + M[1, 2] * vy + M[2, 2] * vz
    for i in range(3):
        out[i] = mno[i, 0] * vo0 + mno[i, 1] * vo1 + mno[i, 2] * vo2
    out[3] = u[3] - x[13] + g0 * M[0, 2] - (wy * vz - wz * vy)
    out[4] = u[4] - x[14] + g0 * M[1, 2] - (wz * vx - wx * vz)
    out[5] = u[5] - x[15] + g0 * M[2, 2] - (wx * vy - wy * vx)
    q0, q1, q2, q3 = x[6], x[7], x[8], x[9]
    out[6] = 0.5 * (-q1 * wx - q2 * wy - q3 * wz)
    out[7] = 0.5 * (q0 * wx - q3 * wy + q2 * wz)
    out[8] = 0.5 * (q3 * wx + q0 * wy - q1 * wz)
    out[9] = 0.5 * (-q2 * wx + q1 * wy + q0 * wz)


@njit(cache=True)
def _rk4(x, u0, u1, dt, g0, mno, out, M, wk, um):
    """One RK4 step of the kinematics; ``wk`` (5, N) and ``um`` (6,) are work arrays (no allocation per step)."""
    for i in range(6):
        um[i] = 0.5 * (u0[i] + u1[i])
    k1, k2, k3, k4, xt = wk[0], wk[1], wk[2], wk[3], wk[4]
    _f(x, u0, g0, mno, k1, M)
    for i in range(N):
        xt[i] = x[i] + 0.5 * dt * k1[i]
    _f(xt, um, g0, mno, k2, M)
    for i in range(N):
        xt[i] = x[i] + 0.5 * dt * k2[i]
    _f(xt, um, g0, mno, k3, M)
    for i in range(N):
        xt[i] = x[i] + dt * k3[i]
    _f(xt, u1, g0, mno, k4, M)
    for i in range(N):
        out[i] = x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True)
def _phi_qd(x, u, dt, g0, mno, qd, Phi, Qd, M, D, A, F, G):
    """Top rows of ``Phi = I + A dt + (A dt)^2 / 2`` and ``Qd = Gamma Q Gamma^T`` (eqs 7, 9, 13).

    The parameter rows of ``A`` are zero (eq 22), so ``Phi = [[Phi1, Phi2], [0, I]]`` with
    ``Phi[:10]`` (10, 22) written to ``Phi`` and ``Qd`` nonzero only in its top-left 10 x 10
    block, written to ``Qd`` (10, 10).  Same arithmetic as the dense reference, without the zeros.
    ``A`` (10, N), ``F`` (10, 6), ``G`` (10, 6) are work arrays.
    """
    A[:, :] = 0.0
    _mbo(x[6:10], M)
    _dmdq(x[6:10], D)
    v = x[3:6]
    q0, q1, q2, q3 = x[6], x[7], x[8], x[9]
    wx, wy, wz = u[0] - x[10], u[1] - x[11], u[2] - x[12]
    for i in range(3):
        for j in range(3):
            A[i, 3 + j] = mno[i, 0] * M[j, 0] + mno[i, 1] * M[j, 1] + mno[i, 2] * M[j, 2]
    for k in range(4):
        # d(M^T v)/dq_k = D_k^T v
        t0 = D[k, 0, 0] * v[0] + D[k, 1, 0] * v[1] + D[k, 2, 0] * v[2]
        t1 = D[k, 0, 1] * v[0] + D[k, 1, 1] * v[1] + D[k, 2, 1] * v[2]
        t2 = D[k, 0, 2] * v[0] + D[k, 1, 2] * v[1] + D[k, 2, 2] * v[2]
        for i in range(3):
            A[i, 6 + k] = mno[i, 0] * t0 + mno[i, 1] * t1 + mno[i, 2] * t2
        for i in range(3):
            A[3 + i, 6 + k] = g0 * D[k, i, 2]
    # -[w]x
    A[3, 4], A[3, 5] = wz, -wy
    A[4, 3], A[4, 5] = -wz, wx
    A[5, 3], A[5, 4] = wy, -wx
    # -[v]x on the gyro bias
    A[3, 11], A[3, 12] = v[2], -v[1]
    A[4, 10], A[4, 12] = -v[2], v[0]
    A[5, 10], A[5, 11] = v[1], -v[0]
    for i in range(3):
        A[3 + i, 13 + i] = -1.0
    # 0.5 Omega(w)
    A[6, 7], A[6, 8], A[6, 9] = -0.5 * wx, -0.5 * wy, -0.5 * wz
    A[7, 6], A[7, 8], A[7, 9] = 0.5 * wx, 0.5 * wz, -0.5 * wy
    A[8, 6], A[8, 7], A[8, 9] = 0.5 * wy, -0.5 * wz, 0.5 * wx
    A[9, 6], A[9, 7], A[9, 8] = 0.5 * wz, 0.5 * wy, -0.5 * wx
    # -0.5 Xi(q)
    xi0 = (-q1, -q2, -q3)
    xi1 = (q0, -q3, q2)
    xi2 = (q3, q0, -q1)
    xi3 = (-q2, q1, q0)
    for j in range(3):
        A[6, 10 + j] = -0.5 * xi0[j]
        A[7, 10 + j] = -0.5 * xi1[j]
        A[8, 10 + j] = -0.5 * xi2[j]
        A[9, 10 + j] = -0.5 * xi3[j]
    # F (rows 0..9; the rest is zero): gyro noise enters like the gyro bias, acc noise like -I
    F[:, :] = 0.0
    for i in range(3, 10):
        for j in range(3):
            F[i, j] = A[i, 10 + j]
    for i in range(3):
        F[3 + i, 3 + i] = -1.0
    for i in range(10):
        for j in range(N):
            a2 = 0.0
            for m in range(10):
                a2 += A[i, m] * A[m, j]
            Phi[i, j] = A[i, j] * dt + 0.5 * dt * dt * a2
        Phi[i, i] += 1.0
    for i in range(10):
        for j in range(6):
            af = 0.0
            for m in range(10):
                af += A[i, m] * F[m, j]
            G[i, j] = dt * F[i, j] + 0.5 * dt * dt * af
    for i in range(10):
        for j in range(i, 10):
            s = 0.0
            for m in range(6):
                s += G[i, m] * qd[m] * G[j, m]
            Qd[i, j] = s
            Qd[j, i] = s


@njit(cache=True, fastmath=_FM)
def _predict_cov(P, Phi, Qd, out, T):
    """``out = Phi P Phi^T + Qd`` for ``Phi = [[Phi[:, :10], Phi[:, 10:]], [0, I]]`` (10 x 22 top rows given);
    ``T`` (10, N) is a work array."""
    T[:, :] = 0.0  # Phi_top P, row-wise (contiguous inner loops)
    for i in range(10):
        for m in range(N):
            a = Phi[i, m]
            if a != 0.0:
                for j in range(N):
                    T[i, j] += a * P[m, j]
    for i in range(10):
        for j in range(i, 10):
            s = Qd[i, j]
            for m in range(N):
                s += T[i, m] * Phi[j, m]
            out[i, j] = s
            out[j, i] = s
        for j in range(10, N):
            out[i, j] = T[i, j]
            out[j, i] = T[i, j]
    for i in range(10, N):
        for j in range(i, N):
            out[i, j] = P[i, j]
            out[j, i] = P[i, j]


@njit(cache=True, fastmath=_FM)
def _scalar(x, P, xp, h, r0, var, Ph, k):
    """One scalar update: residual r0 - h (x - xp). Returns False if not PD.

    The expanded Joseph form with the optimal gain ``k = Ph / s`` equals ``P - Ph Ph^T / s``: one symmetric
    rank-1 update by ``g = Ph / sqrt(s)`` (``g_i g_j = g_j g_i`` keeps P exactly symmetric).
    ``Ph`` and ``k`` (N,) are work arrays (``k`` holds g)."""
    r = r0
    for i in range(N):
        if h[i] != 0.0:
            r -= h[i] * (x[i] - xp[i])
    Ph[:] = 0.0
    for m in range(N):
        a = h[m]
        if a != 0.0:
            for i in range(N):
                Ph[i] += P[m, i] * a  # P symmetric: row m, contiguous
    s0 = 0.0
    for i in range(N):
        s0 += h[i] * Ph[i]
    s = s0 + var
    if not (s > 0.0):
        return False
    rs = r / s
    sq = 1.0 / np.sqrt(s)
    for i in range(N):
        x[i] += Ph[i] * rs
        k[i] = Ph[i] * sq
    for i in range(N):
        gi = k[i]
        for j in range(N):
            P[i, j] -= gi * k[j]
    return True


@njit(cache=True)
def _profile(x, x0, step, z, dz):
    f = (x - x0) / step
    i = int(f)
    if i < 0:
        i = 0
    if i > z.size - 2:
        i = z.size - 2
    a = f - i
    return (1 - a) * z[i] + a * z[i + 1], (1 - a) * dz[i] + a * dz[i + 1]


@njit(cache=True)
def _chol(A, L):
    """Lower Cholesky factor of the symmetric ``A`` into ``L`` (only its lower triangle is written and read);
    False when ``A`` is not positive definite (a pivot that is not finite and positive)."""
    for j in range(N):
        s = A[j, j]
        for m in range(j):
            s -= L[j, m] * L[j, m]
        if not (s > 0.0) or not np.isfinite(s):
            return False
        d = np.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, N):
            v = A[i, j]
            for m in range(j):
                v -= L[i, m] * L[j, m]
            L[i, j] = v / d
    return True


@njit(cache=True)
def _ok(P):
    for i in range(N):
        if not (P[i, i] > 0.0) or not np.isfinite(P[i, i]):
            return False
    return True


@njit(cache=True)
def _sqrt0(v):
    return np.sqrt(v) if v >= 0.0 else (0.0 if v < 0.0 else v)  # negative round-off -> 0, NaN stays


@njit(cache=True)
def _std_row(x, P, mno, out, M, D, J):
    """Standard deviations at one step from the (full) covariance ``P``: the states' (22), the hill-frame
    velocity's (3; ``M_NO M_BO^T v_B`` linearised over ``v_B`` and ``q``) and roll, pitch, yaw (3; the analytic
    Jacobian of :func:`sportfusion.skijump.smoother_outputs.euler_jacobian`) into ``out`` (28,).  ``M`` (3, 3),
    ``D`` (4, 3, 3) and ``J`` (3, 7) are work arrays."""
    for i in range(N):
        out[i] = _sqrt0(P[i, i])
    _mbo(x[6:10], M)
    _dmdq(x[6:10], D)
    for a in range(3):
        for j in range(3):
            J[a, j] = mno[a, 0] * M[j, 0] + mno[a, 1] * M[j, 1] + mno[a, 2] * M[j, 2]
        for k in range(4):
            s = 0.0
            for b in range(3):
                s += mno[a, b] * (D[k, 0, b] * x[3] + D[k, 1, b] * x[4] + D[k, 2, b] * x[5])
            J[a, 3 + k] = s
    for a in range(3):
        s = 0.0
        for i in range(7):
            for j in range(7):
                s += J[a, i] * P[3 + i, 3 + j] * J[a, j]
        out[N + a] = _sqrt0(s)
    q0, q1, q2, q3 = x[6], x[7], x[8], x[9]
    n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3
    m12, m22 = 2 * (q2 * q3 + q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3
    m01, m00 = 2 * (q1 * q2 + q0 * q3), q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    m02 = 2 * (q1 * q3 - q0 * q2)
    r1, r2 = m12 * m12 + m22 * m22, m01 * m01 + m00 * m00
    sp = -m02 / n2
    c = np.sqrt(max(1.0 - sp * sp, 1e-300))
    qq = (q0, q1, q2, q3)
    d12 = (2 * q1, 2 * q0, 2 * q3, 2 * q2)
    d22 = (2 * q0, -2 * q1, -2 * q2, 2 * q3)
    d01 = (2 * q3, 2 * q2, 2 * q1, 2 * q0)
    d00 = (2 * q0, 2 * q1, -2 * q2, -2 * q3)
    d02 = (-2 * q2, 2 * q3, -2 * q0, 2 * q1)
    for i in range(4):
        J[0, i] = (m22 * d12[i] - m12 * d22[i]) / r1
        J[1, i] = -(d02[i] * n2 - m02 * 2 * qq[i]) / (n2 * n2) / c
        J[2, i] = (m00 * d01[i] - m01 * d00[i]) / r2
    for a in range(3):
        s = 0.0
        for i in range(4):
            for j in range(4):
                s += J[a, i] * P[6 + i, 6 + j] * J[a, j]
        out[N + 3 + a] = _sqrt0(s)


@njit(cache=True, fastmath=_FM)
def ski_ekf_rts(
    t, u, pos, vel, mag, inrun, landing, still, x0, P0, g0, mno, m_o, qd, rpos, rvel, rmag, rcq, rir, rhir, rla,
    rzu, ir_x0, ir_step, ir_z, ir_dz, la_x0, la_step, la_z, la_dz, use_hill, use_vel, use_mag, smooth,
):  # fmt: skip
    """Forward EKF and backward RTS over all steps (see the module text); ``smooth`` False: the forward
    pass only (``x_smooth`` is then ``x_filt`` and the covariances are the filtered ones).

    Returns
    -------
    x_filt, x_smooth : (n, 22)
    P_smooth : (n, 253) packed
    resid : (n, 16) innovations (RESIDUALS order), NaN where absent
    fail : int, -1 or the step at which a covariance stopped being positive definite
    phase : int, 0 update, 1 prediction, 2 backward pass
    std : (n, NSTD) smoothed standard deviations (:func:`_std_row`; (0, NSTD) when not ``smooth``)
    """
    n = t.size
    x_filt = np.empty((n, N))
    x_pred = np.empty((n, N))
    Pbuf = np.empty((n, NP))
    resid = np.full((n, NRES), np.nan)
    M = np.empty((3, 3))
    D = np.empty((4, 3, 3))
    Phi = np.empty((10, N))
    Qd = np.empty((10, 10))
    Pn = np.empty((N, N))
    h = np.zeros(N)
    x = x0.copy()
    P = P0.copy()
    xn = np.empty(N)
    xp = np.empty(N)
    # work arrays of the step functions: allocated once, not per step
    A = np.empty((10, N))
    F = np.empty((10, 6))
    G = np.empty((10, 6))
    T = np.empty((10, N))
    Ph = np.empty(N)
    kv = np.empty(N)
    wk = np.empty((5, N))
    um = np.empty(6)
    for k in range(n):
        xp[:] = x
        x_pred[k] = xp
        # c_q (eq 51)
        nq = np.sqrt(xp[6] ** 2 + xp[7] ** 2 + xp[8] ** 2 + xp[9] ** 2)
        h[:] = 0.0
        for i in range(4):
            h[6 + i] = xp[6 + i] / nq
        resid[k, 0] = -(nq - 1.0)
        if not _scalar(x, P, xp, h, -(nq - 1.0), rcq, Ph, kv):
            return x_filt, x_filt, Pbuf, resid, k, 0, np.empty((0, NSTD))
        if np.isfinite(pos[k, 0]):
            for i in range(3):
                h[:] = 0.0
                h[i] = 1.0
                r0 = pos[k, i] - xp[i]
                resid[k, 1 + i] = r0
                if not _scalar(x, P, xp, h, r0, rpos[i], Ph, kv):
                    return x_filt, x_filt, Pbuf, resid, k, 0, np.empty((0, NSTD))
        if use_vel and np.isfinite(vel[k, 0]):
            _mbo(xp[6:10], M)
            _dmdq(xp[6:10], D)
            for i in range(3):
                h[:] = 0.0
                hv = 0.0
                for j in range(3):
                    h[3 + j] = M[j, i]
                    hv += M[j, i] * xp[3 + j]
                for kk in range(4):
                    h[6 + kk] = D[kk, 0, i] * xp[3] + D[kk, 1, i] * xp[4] + D[kk, 2, i] * xp[5]
                r0 = vel[k, i] - hv
                resid[k, 4 + i] = r0
                if not _scalar(x, P, xp, h, r0, rvel[i], Ph, kv):
                    return x_filt, x_filt, Pbuf, resid, k, 0, np.empty((0, NSTD))
        if use_mag and np.isfinite(mag[k, 0]):
            _mbo(xp[6:10], M)
            _dmdq(xp[6:10], D)
            for i in range(3):
                h[:] = 0.0
                mb = M[i, 0] * m_o[0] + M[i, 1] * m_o[1] + M[i, 2] * m_o[2]
                s = 1.0 + xp[19 + i]
                for kk in range(4):
                    h[6 + kk] = s * (D[kk, i, 0] * m_o[0] + D[kk, i, 1] * m_o[1] + D[kk, i, 2] * m_o[2])
                h[16 + i] = 1.0
                h[19 + i] = mb
                r0 = mag[k, i] - (s * mb + xp[16 + i])
                resid[k, 7 + i] = r0
                if not _scalar(x, P, xp, h, r0, rmag, Ph, kv):
                    return x_filt, x_filt, Pbuf, resid, k, 0, np.empty((0, NSTD))
        if use_hill:
            if inrun[k]:
                z, dz = _profile(xp[0], ir_x0, ir_step, ir_z, ir_dz)
                h[:] = 0.0
                h[0], h[2] = -dz, 1.0
                resid[k, 10] = z - xp[2]
                if not _scalar(x, P, xp, h, z - xp[2], rir, Ph, kv):
                    return x_filt, x_filt, Pbuf, resid, k, 0, np.empty((0, NSTD))
                h[:] = 0.0
                h[1] = 1.0
                resid[k, 11] = -xp[1]
                if not _scalar(x, P, xp, h, -xp[1], rhir, Ph, kv):
                    return x_filt, x_filt, Pbuf, resid, k, 0, np.empty((0, NSTD))
            if landing[k] > 0.0:
                z, dz = _profile(xp[0], la_x0, la_step, la_z, la_dz)
                h[:] = 0.0
                h[0], h[2] = -dz, 1.0
                resid[k, 12] = z - xp[2]
                if not _scalar(x, P, xp, h, z - xp[2], rla / landing[k], Ph, kv):
                    return x_filt, x_filt, Pbuf, resid, k, 0, np.empty((0, NSTD))
        if still[k] > 0.0:  # zero velocity: v_B = 0
            for i in range(3):
                h[:] = 0.0
                h[3 + i] = 1.0
                resid[k, 13 + i] = -xp[3 + i]
                if not _scalar(x, P, xp, h, -xp[3 + i], rzu / still[k], Ph, kv):
                    return x_filt, x_filt, Pbuf, resid, k, 0, np.empty((0, NSTD))
        if not _ok(P):
            return x_filt, x_filt, Pbuf, resid, k, 0, np.empty((0, NSTD))
        x_filt[k] = x
        _pack(P, Pbuf[k])
        if k < n - 1:
            dt = t[k + 1] - t[k]
            _rk4(x, u[k], u[k + 1], dt, g0, mno, xn, M, wk, um)
            _phi_qd(x, u[k], dt, g0, mno, qd[k], Phi, Qd, M, D, A, F, G)
            _predict_cov(P, Phi, Qd, Pn, T)
            P[:, :] = Pn
            if not _ok(P):
                return x_filt, x_filt, Pbuf, resid, k + 1, 1, np.empty((0, NSTD))
            x[:] = xn
    if not smooth:
        return x_filt, x_filt, Pbuf, resid, -1, 0, np.empty((0, NSTD))
    # backward pass (eqs 17-21); the smoothed covariance overwrites the filtered one
    x_s = np.empty((n, N))
    x_s[n - 1] = x_filt[n - 1]
    Ps = np.empty((N, N))
    _unpack(Pbuf[n - 1], Ps)
    Pf = np.empty((N, N))
    Pp = np.empty((N, N))
    Y = np.empty((N, N))
    Ct = np.empty((N, N))
    Dm = np.empty((N, N))
    E = np.empty((N, N))
    dx = np.empty(N)
    L = np.zeros((N, N))
    std = np.empty((n, NSTD))
    J = np.empty((3, 7))
    _std_row(x_s[n - 1], Ps, mno, std[n - 1], M, D, J)
    for k in range(n - 2, -1, -1):
        _unpack(Pbuf[k], Pf)
        dt = t[k + 1] - t[k]
        _phi_qd(x_filt[k], u[k], dt, g0, mno, qd[k], Phi, Qd, M, D, A, F, G)
        _predict_cov(Pf, Phi, Qd, Pp, T)
        for i in range(N):
            if not (Pp[i, i] > 0.0):
                return x_filt, x_s, Pbuf, resid, k + 1, 2, np.empty((0, NSTD))
        if not _chol(Pp, L):
            return x_filt, x_s, Pbuf, resid, k + 1, 2, np.empty((0, NSTD))
        # The parameter rows of Phi are [0 I] and Qd has no parameter part, so Pp[:, 10:] =
        # (Phi Pf)[:, 10:] and the gain is C = [[C_top], [0 I]]: only C_top = rows 0..9 of
        # Pf Phi^T Pp^{-1} is solved for.  Ct10 = Pp^{-1} (Phi Pf)[:, :10] = C_top^T (22 x 10).
        for i in range(N):
            if i < 10:
                for j in range(10):
                    Y[i, j] = 0.0
                for m in range(N):
                    a = Phi[i, m]
                    if a != 0.0:
                        for j in range(10):
                            Y[i, j] += a * Pf[m, j]
            else:
                for j in range(10):
                    Y[i, j] = Pf[i, j]
            for m in range(i):
                a = L[i, m]
                for j in range(10):
                    Y[i, j] -= a * Y[m, j]
            d = 1.0 / L[i, i]
            for j in range(10):
                Y[i, j] *= d
        for i in range(N - 1, -1, -1):
            for j in range(10):
                Ct[i, j] = Y[i, j]
            for m in range(i + 1, N):
                a = L[m, i]
                for j in range(10):
                    Ct[i, j] -= a * Ct[m, j]
            d = 1.0 / L[i, i]
            for j in range(10):
                Ct[i, j] *= d
        # x_s = x_f + C (x_s[k+1] - x_pred[k+1])
        for m in range(N):
            dx[m] = x_s[k + 1, m] - x_pred[k + 1, m]
        for i in range(10):
            s = x_filt[k, i]
            for m in range(N):
                s += Ct[m, i] * dx[m]
            x_s[k, i] = s
        for i in range(10, N):
            x_s[k, i] = x_filt[k, i] + dx[i]
        # P_s = P_f + C Dm C^T with Dm = P_s[k+1] - P_pred:
        #   top-left  C_top Dm C_top^T,  top-right  C_top Dm[:, 10:],  bottom-right  Dm[10:, 10:]
        for i in range(N):
            for j in range(N):
                Dm[i, j] = Ps[i, j] - Pp[i, j]
        for i in range(10):  # E_top = C_top Dm (10 x 22)
            for j in range(N):
                E[i, j] = 0.0
            for m in range(N):
                a = Ct[m, i]
                for j in range(N):
                    E[i, j] += a * Dm[m, j]
        for i in range(10):
            for j in range(i, 10):
                s = Pf[i, j]
                for m in range(N):
                    s += E[i, m] * Ct[m, j]
                Ps[i, j] = s
                Ps[j, i] = s
            for j in range(10, N):
                s = Pf[i, j] + E[i, j]
                Ps[i, j] = s
                Ps[j, i] = s
        for i in range(10, N):
            for j in range(i, N):
                s = Pf[i, j] + Dm[i, j]
                Ps[i, j] = s
                Ps[j, i] = s
        _pack(Ps, Pbuf[k])
        _std_row(x_s[k], Ps, mno, std[k], M, D, J)
    return x_filt, x_s, Pbuf, resid, -1, 0, std
