"""The ski-jump estimation model of the ERTS smoother (skijump eqs 22, 35-51) with analytic Jacobians.

Augmented state (eq 22), ``n = 22``::

    x = [r_N (3) [m], v_B (3) [m/s], q_BO (4) [-],                         (40)
         d_omega (3) [rad/s], d_a (3) [m/s^2], d_m (3) [uT], dS_m (3) [-]]  (42)

Input ``u = [omega_B,gyro, a_B,acc]`` (eq 41), process noise
``w = [w_gyro, w_acc]`` (eq 43).  The kinematics are
:func:`sportfusion.skijump.kinematics.f` (eqs 44-47, errata sign in eq 45)
driven by the bias-corrected rates ``omega = omega_gyro - d_omega - w_gyro`` and
specific force ``a = a_acc - d_a - w_acc``; the parameters have zero derivative.

Outputs (eqs 38, 39, 49, 50)::

    GNSS position   r_N                                      (hill frame)
    GNSS velocity   v_O = M_BO^T v_B                         (NED)
    magnetometer    (1 + diag(dS_m)) M_BO m_O,WMM + d_m      (body)

Constraints (eqs 32-34, 51): ``c_q = |q| - 1``, ``c_V,IR = z - z_IR(x)``,
``c_H,IR = y``, ``c_V,LA = z - z_LA(x)``.

Table 4's process-noise values are the variances of the per-sample input noise
(the simulator draws them so), so the step covariance is ``Gamma Q Gamma^T``
with ``Gamma`` of eq 9 (:func:`discrete`).
"""

from __future__ import annotations

import numpy as np

from sportfusion.core.rotations import skew
from sportfusion.skijump.kinematics import m_bo

__all__ = [
    "N",
    "STATE",
    "I_R",
    "I_V",
    "I_Q",
    "I_BG",
    "I_BA",
    "I_BM",
    "I_SM",
    "dm_dq",
    "f_aug",
    "jac_a",
    "jac_f",
    "discrete",
    "rk4_aug",
    "h_vel",
    "h_mag",
    "H_vel",
    "H_mag",
    "c_q",
    "C_q",
]

N = 22
STATE = (
    "x",
    "y",
    "z",
    "vbx",
    "vby",
    "vbz",
    "q0",
    "q1",
    "q2",
    "q3",
    *(f"bias_gyr_{a}" for a in "xyz"),
    *(f"bias_acc_{a}" for a in "xyz"),
    *(f"bias_mag_{a}" for a in "xyz"),
    *(f"scale_mag_{a}" for a in "xyz"),
)
I_R, I_V, I_Q = slice(0, 3), slice(3, 6), slice(6, 10)
I_BG, I_BA, I_BM, I_SM = slice(10, 13), slice(13, 16), slice(16, 19), slice(19, 22)


def dm_dq(q: np.ndarray) -> np.ndarray:
    """Derivatives of ``M_BO`` (eq 47) w.r.t. ``q0..q3``: array (..., 4, 3, 3) for ``q`` (..., 4)."""
    q = np.asarray(q, dtype=float)
    q0, q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    mats = (
        ((q0, q3, -q2), (-q3, q0, q1), (q2, -q1, q0)),
        ((q1, q2, q3), (q2, -q1, q0), (q3, -q0, -q1)),
        ((-q2, q1, -q0), (q1, q2, q3), (q0, q3, -q2)),
        ((-q3, q0, q1), (-q0, -q3, q2), (q1, q2, q3)),
    )
    return 2.0 * np.stack([np.stack([np.stack(r, -1) for r in m], -2) for m in mats], -3)


def _xi(q: np.ndarray) -> np.ndarray:
    q0, q1, q2, q3 = q
    return np.array([[-q1, -q2, -q3], [q0, -q3, q2], [q3, q0, -q1], [-q2, q1, q0]])


def _omega(w: np.ndarray) -> np.ndarray:
    wx, wy, wz = w
    return np.array([[0.0, -wx, -wy, -wz], [wx, 0.0, wz, -wy], [wy, -wz, 0.0, wx], [wz, wy, -wx, 0.0]])


def f_aug(x: np.ndarray, u: np.ndarray, g0: float, m_no: np.ndarray) -> np.ndarray:
    """Eq 22 with eqs 44-46: derivative of the augmented state (noise-free).

    Parameters
    ----------
    x : array (22,)
    u : array (6,)
        Measured ``[omega_gyro [rad/s], a_acc [m/s^2]]``.
    g0 : float
        Gravity [m/s^2].
    m_no : array (3, 3)
        NED -> hill frame (eq 31).
    """
    v = x[3:6]
    q = x[6:10]
    w = u[:3] - x[10:13]
    a = u[3:6] - x[13:16]
    m = m_bo(q)
    out = np.zeros(N)
    out[0:3] = m_no @ (m.T @ v)
    out[3:6] = a + g0 * m[:, 2] - np.cross(w, v)
    out[6:10] = 0.5 * _xi(q) @ w
    return out


def rk4_aug(x: np.ndarray, u0: np.ndarray, u1: np.ndarray, dt: float, g0: float, m_no: np.ndarray) -> np.ndarray:
    """Eq 12: one RK4 step of :func:`f_aug` with the input linear from ``u0`` to ``u1`` over ``dt`` [s]."""
    um = 0.5 * (u0 + u1)
    k1 = f_aug(x, u0, g0, m_no)
    k2 = f_aug(x + 0.5 * dt * k1, um, g0, m_no)
    k3 = f_aug(x + 0.5 * dt * k2, um, g0, m_no)
    k4 = f_aug(x + dt * k3, u1, g0, m_no)
    return x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def jac_a(x: np.ndarray, u: np.ndarray, g0: float, m_no: np.ndarray) -> np.ndarray:
    """``A = df_aug/dx`` (22, 22) at ``(x, u)``."""
    v = x[3:6]
    q = x[6:10]
    w = u[:3] - x[10:13]
    m = m_bo(q)
    dm = dm_dq(q)
    A = np.zeros((N, N))
    A[0:3, 3:6] = m_no @ m.T
    A[0:3, 6:10] = m_no @ np.einsum("kji,j->ik", dm, v)  # d(M^T v)/dq_k = dM_k^T v
    A[3:6, 3:6] = -skew(w)
    A[3:6, 6:10] = g0 * dm[:, :, 2].T
    A[3:6, 10:13] = -skew(v)  # d(-w x v)/dw = [v]x, dw/db = -I
    A[3:6, 13:16] = -np.eye(3)
    A[6:10, 6:10] = 0.5 * _omega(w)
    A[6:10, 10:13] = -0.5 * _xi(q)
    return A


def jac_f(x: np.ndarray) -> np.ndarray:
    """``F = df_aug/dw`` (22, 6) for ``w = [w_gyro, w_acc]`` (they enter like the biases)."""
    F = np.zeros((N, 6))
    F[3:6, 0:3] = -skew(x[3:6])
    F[3:6, 3:6] = -np.eye(3)
    F[6:10, 0:3] = -0.5 * _xi(x[6:10])
    return F


def discrete(A: np.ndarray, F: np.ndarray, q_diag: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Eqs 7, 9, 13 with second-order series: ``Phi`` (22, 22) and ``Gamma Q Gamma^T`` (22, 22).

    ``q_diag``: variances of the per-sample gyro and accelerometer noise (Table 4), (6,).
    """
    Adt = A * dt
    Phi = np.eye(N) + Adt + 0.5 * (Adt @ Adt)
    Gam = (dt * F) + (0.5 * dt) * (Adt @ F)
    Qd = (Gam * q_diag) @ Gam.T
    return Phi, 0.5 * (Qd + Qd.T)


def h_vel(x: np.ndarray) -> np.ndarray:
    """Eq 49: NED velocity ``M_BO^T v_B`` [m/s]."""
    return m_bo(x[6:10]).T @ x[3:6]


def H_vel(x: np.ndarray) -> np.ndarray:
    """Jacobian (3, 22) of :func:`h_vel`."""
    q = x[6:10]
    H = np.zeros((3, N))
    H[:, 3:6] = m_bo(q).T
    H[:, 6:10] = np.einsum("kji,j->ik", dm_dq(q), x[3:6])
    return H


def h_mag(x: np.ndarray, m_o: np.ndarray) -> np.ndarray:
    """Eq 50: magnetometer model ``(1 + diag(dS_m)) M_BO m_O + d_m`` [uT]."""
    return (1.0 + x[19:22]) * (m_bo(x[6:10]) @ m_o) + x[16:19]


def H_mag(x: np.ndarray, m_o: np.ndarray) -> np.ndarray:
    """Jacobian (3, 22) of :func:`h_mag`."""
    q = x[6:10]
    H = np.zeros((3, N))
    s = 1.0 + x[19:22]
    H[:, 6:10] = s[:, None] * np.einsum("kij,j->ik", dm_dq(q), m_o)
    H[:, 16:19] = np.eye(3)
    H[:, 19:22] = np.diag(m_bo(q) @ m_o)
    return H


def c_q(x: np.ndarray) -> float:
    """Eq 51: quaternion norm constraint ``|q| - 1``."""
    return float(np.linalg.norm(x[6:10]) - 1.0)


def C_q(x: np.ndarray) -> np.ndarray:
    """Jacobian (1, 22) of :func:`c_q`."""
    H = np.zeros((1, N))
    q = x[6:10]
    H[0, 6:10] = q / np.linalg.norm(q)
    return H
