"""Continuous-time inertial kinematics of the ski-jumping model (skijump eqs 44-47).

State ``x = [r_N (3), v_B (3), q_BO (4)]`` (eq 40): position of the IMU in the
hill frame [m], its velocity resolved in the body (sensor) frame [m/s], and the
attitude quaternion (scalar first) that maps NED vectors into the body frame.
Input ``u = [omega_B (3), a_B (3)]`` (eq 41, bias-free): angular rate of the body
w.r.t. NED [rad/s] and specific force [m/s^2], both in the body frame::

    r_N'  = M_NO M_BO^T v_B                          (44)
    v_B'  = a_B + M_BO g_O - omega_B x v_B           (45, errata sign)
    q_BO' = 1/2 Xi(q) omega_B                         (46)

with ``M_BO`` of eq 47, ``M_NO`` of eq 31 (hill azimuth ``psi_N``) and
``g_O = [0, 0, g0]``.  The printed eq 45 has ``+ omega_B x v_B``; the transport
theorem (inertial derivative ``v_B' + omega x v_B``) gives the minus sign
(integrated as printed, a jump drifts by hundreds of metres).  The Earth's rotation is neglected, as in the
paper.

``M_BO`` is evaluated exactly as printed (no normalisation of ``q``), so a
smoother's Jacobians of :func:`f` are consistent with it; the quaternion norm
is held at one by the paper's constraint ``c_q``.

:func:`rk4_step` is the propagation scheme of the smoother (eq 12): classical
RK4 over one IMU interval with the input linearly interpolated between the two
samples.  All functions broadcast over leading dimensions.
"""

from __future__ import annotations

import numpy as np

from sportfusion.core.rotations import dcm_entries

__all__ = ["STATE", "INPUT", "m_bo", "m_no", "f", "rk4_step", "propagate", "state_from_nav"]

#: Names of the state components, in order.
STATE = ("x", "y", "z", "vbx", "vby", "vbz", "q0", "q1", "q2", "q3")
#: Names of the input components, in order (eq 41).
INPUT = ("gyr_x", "gyr_y", "gyr_z", "acc_x", "acc_y", "acc_z")


def m_bo(q: np.ndarray) -> np.ndarray:
    """Eq 47: NED -> body matrix ``M_BO`` from ``q_BO`` as printed (``q`` not normalised).

    Parameters
    ----------
    q : array, shape (..., 4)
        Quaternion, scalar first.

    Returns
    -------
    array, shape (..., 3, 3)
    """
    q = np.asarray(q, dtype=float)
    if q.shape == (4,):  # one quaternion: on Python floats
        return dcm_entries(*q.tolist(), single=True)
    return dcm_entries(q[..., 0], q[..., 1], q[..., 2], q[..., 3])


def m_no(psi_n: float) -> np.ndarray:
    """Eq 31: NED -> hill frame matrix for the hill azimuth ``psi_n`` [rad] (north -> hill x)."""
    c, s = np.cos(psi_n), np.sin(psi_n)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def f(x: np.ndarray, u: np.ndarray, g0: float, psi_n: float) -> np.ndarray:
    """State derivative ``x' = f(x, u)`` of eqs 44-46 (errata sign in eq 45).

    Parameters
    ----------
    x : array, shape (..., 10)
        ``[r_N [m], v_B [m/s], q_BO [-]]``.
    u : array, shape (..., 6)
        ``[omega_B [rad/s], a_B [m/s^2]]``, true (bias-free) rates and specific force.
    g0 : float
        Gravity magnitude [m/s^2] (``g_O = [0, 0, g0]`` in NED).
    psi_n : float
        Hill azimuth [rad] (rotation from north to the hill x axis).

    Returns
    -------
    array, shape (..., 10)
        ``[r_N' [m/s], v_B' [m/s^2], q_BO' [1/s]]``.
    """
    x = np.asarray(x, dtype=float)
    u = np.asarray(u, dtype=float)
    v = x[..., 3:6]
    q = x[..., 6:10]
    w = u[..., 0:3]
    a = u[..., 3:6]
    m = m_bo(q)
    v_o = np.einsum("...ji,...j->...i", m, v)  # M_BO^T v_B
    r_dot = v_o @ m_no(psi_n).T
    v_dot = a + g0 * m[..., :, 2] - np.cross(w, v)
    q0, q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    wx, wy, wz = w[..., 0], w[..., 1], w[..., 2]
    q_dot = 0.5 * np.stack(
        (
            -q1 * wx - q2 * wy - q3 * wz,
            q0 * wx - q3 * wy + q2 * wz,
            q3 * wx + q0 * wy - q1 * wz,
            -q2 * wx + q1 * wy + q0 * wz,
        ),
        axis=-1,
    )
    return np.concatenate((r_dot, v_dot, q_dot), axis=-1)


def rk4_step(x: np.ndarray, u0: np.ndarray, u1: np.ndarray, dt: float, g0: float, psi_n: float) -> np.ndarray:
    """One RK4 step of :func:`f` over ``dt`` [s] with the input linear between ``u0`` and ``u1``.

    The input at the half step is ``(u0 + u1) / 2`` (eq 12's linear interpolation).
    """
    um = 0.5 * (np.asarray(u0, dtype=float) + np.asarray(u1, dtype=float))
    k1 = f(x, u0, g0, psi_n)
    k2 = f(x + 0.5 * dt * k1, um, g0, psi_n)
    k3 = f(x + 0.5 * dt * k2, um, g0, psi_n)
    k4 = f(x + dt * k3, u1, g0, psi_n)
    return x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def propagate(x0: np.ndarray, t: np.ndarray, u: np.ndarray, g0: float, psi_n: float) -> np.ndarray:
    """Integrate :func:`f` over the sample times ``t`` with :func:`rk4_step`.

    Parameters
    ----------
    x0 : array, shape (10,)
        State at ``t[0]``.
    t : array, shape (n,)
        Input sample times [s], increasing.
    u : array, shape (n, 6)
        Inputs at ``t`` (``[omega_B, a_B]``).
    g0, psi_n : float
        Gravity [m/s^2] and hill azimuth [rad].

    Returns
    -------
    array, shape (n, 10)
        The state at every ``t`` (row 0 is ``x0``).
    """
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)
    out = np.empty((t.size, 10))
    out[0] = x0
    for k in range(t.size - 1):
        out[k + 1] = rk4_step(out[k], u[k], u[k + 1], t[k + 1] - t[k], g0, psi_n)
    return out


def state_from_nav(r_n: np.ndarray, v_o: np.ndarray, q_bo: np.ndarray) -> np.ndarray:
    """Assemble the state from hill-frame position [m], NED velocity [m/s] and ``q_BO``.

    ``v_B = M_BO v_O`` (eq 49 inverted).  Broadcasts over leading dimensions.
    """
    q = np.asarray(q_bo, dtype=float)
    v_b = np.einsum("...ij,...j->...i", m_bo(q), np.asarray(v_o, dtype=float))
    return np.concatenate((np.asarray(r_n, dtype=float), v_b, q), axis=-1)
