"""Sacrum orientation and gravity-removed acceleration in the global frame (gates paper, "EKS 1").

The paper gets segment orientations from strap-down integration with the *joint* drift correction of a
full-body sensor suit (Fasel et al. 2017d, 2018).  With the single sacrum sensor of this suite the drift
correction uses what that sensor alone offers:

* gyro bias = the mean angular rate in the static posture at the start, and again at the finish; the bias
  is interpolated linearly in time between the two;
* initial roll and pitch by levelling the static start (mean specific force), yaw = 0: the global frame J
  has "x forward with respect to the athlete's still posture at start", z down (the suite's convention;
  the paper's Y-up frame is the same frame with other axis names), origin at the sacrum at start;
* the tilt error left at the finish (strap-down gravity direction vs the measured specific force in the
  static finish posture) is removed by a rotation growing linearly over the run.

The residual orientation drift is left to the three Euler-angle states of the EKS.  When the session has
the attitude columns ``q0..q3`` (q_BO in NED, docs/frames.md) they are used instead (yaw relative to north;
the frame is then the session's local frame).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.rotations import (
    dcm_from_quat,
    integrate_body_rates,
    interval_mean_rates,
    quat_from_euler,
    quat_from_rotvec,
    quat_multiply,
)
from sportfusion.core.stats import median


@dataclass
class Static:
    """Static postures (sample index ranges, end exclusive) at the start and at the finish."""

    start: tuple[int, int]
    finish: tuple[int, int]


def static_windows(
    t: np.ndarray,
    acc: np.ndarray,
    gyr: np.ndarray,
    window: float = 0.5,
    acc_std: float = 0.4,
    gyr_std: float = 0.15,
    min_duration: float = 1.0,
) -> Static:
    """The static postures at the start and finish: the leading and trailing runs of samples whose moving
    standard deviations (``window`` [s]) of ``|acc|`` [m/s^2] and ``|gyr|`` [rad/s] stay below the limits.

    Raises
    ------
    InputError
        When either run is shorter than ``min_duration`` [s] (the EKS needs them for its zero-velocity updates).
    """
    fs = 1.0 / float(median(np.diff(t)))
    w = max(3, int(round(window * fs)))

    def mstd(x: np.ndarray) -> np.ndarray:
        c1 = np.convolve(x, np.ones(w) / w, mode="same")
        c2 = np.convolve(x * x, np.ones(w) / w, mode="same")
        return np.sqrt(np.maximum(c2 - c1 * c1, 0.0))

    quiet = (mstd(np.linalg.norm(acc, axis=1)) < acc_std) & (mstd(np.linalg.norm(gyr, axis=1)) < gyr_std)
    quiet[: w // 2] = quiet[w // 2]
    quiet[-(w // 2) :] = quiet[-(w // 2) - 1]
    n = t.size
    i0 = int(np.argmin(quiet)) if not quiet.all() else n
    j0 = n - int(np.argmin(quiet[::-1])) if not quiet.all() else 0
    # shrink by half a window: the edges of a moving window see the motion late
    s = (0, max(i0 - w // 2, 0))
    f = (min(j0 + w // 2, n), n)
    for name, (a, b) in (("start", s), ("finish", f)):
        if (b - a) / fs < min_duration:
            raise InputError(
                f"no static posture at the {name}: {max(b - a, 0) / fs:.2f} s of low motion, expected at least "
                f"{min_duration:g} s (the zero-velocity updates need the static start and finish of the paper)"
            )
    return Static(s, f)


def _level(f: np.ndarray) -> tuple[float, float]:
    """Roll and pitch [rad] of a body whose mean specific force is ``f`` at rest (z down: f = -g)."""
    roll = float(np.arctan2(-f[1], -f[2]))
    pitch = float(np.arctan2(f[0], np.hypot(f[1], f[2])))
    return roll, pitch


def _tilt(q: np.ndarray, acc: np.ndarray, win: tuple[int, int]) -> np.ndarray:
    """Rotation vector [rad] (J frame) taking the mean strap-down 'down' direction over a static window
    onto the true down (0, 0, 1)."""
    a, b = win
    m = dcm_from_quat(q[a:b])  # M_BJ: J -> body
    f = -acc[a:b] / np.linalg.norm(acc[a:b], axis=1, keepdims=True)
    g = np.einsum("kji,kj->ki", m, f).mean(axis=0)
    g /= np.linalg.norm(g)
    axis = np.cross(g, np.array([0.0, 0.0, 1.0]))
    sn = np.linalg.norm(axis)
    if sn < 1e-12:
        return np.zeros(3)
    return axis / sn * np.arctan2(sn, g[2])


def strapdown(t: np.ndarray, acc: np.ndarray, gyr: np.ndarray, static: Static) -> np.ndarray:
    """Attitude ``q_BJ`` (J -> body, scalar first, the suite's convention) by strap-down with the drift
    correction of the module text.

    Parameters
    ----------
    t : ndarray (n,)
        IMU times [s].
    acc, gyr : ndarray (n, 3)
        Specific force [m/s^2] and angular rate [rad/s], body frame.
    static : Static
        The static postures.

    Returns
    -------
    ndarray (n, 4)
    """
    s0, s1 = static.start
    f0, f1 = static.finish
    b0 = gyr[s0:s1].mean(axis=0)
    b1 = gyr[f0:f1].mean(axis=0)
    tb0, tb1 = t[s0:s1].mean(), t[f0:f1].mean()
    frac = np.clip((t - tb0) / max(tb1 - tb0, 1e-9), 0.0, 1.0)[:, None]
    w = gyr - (b0 + (b1 - b0) * frac)
    roll, pitch = _level(acc[s0:s1].mean(axis=0))
    q_start = quat_from_euler(roll, pitch, 0.0)  # q_BJ is the Hamilton quaternion of body -> J
    q = integrate_body_rates(q_start, t, interval_mean_rates(w))  # body -> J, trapezoid rates
    # tilt at the start (the mean over the posture, not its first sample) and left at the finish
    q = quat_multiply(quat_from_rotvec(_tilt(q, acc, static.start)), q)
    rv = _tilt(q, acc, static.finish)
    ramp = np.clip((t - tb0) / max(tb1 - tb0, 1e-9), 0, 1)[:, None]
    q = quat_multiply(quat_from_rotvec(rv[None, :] * ramp), q)  # rotate the J-side of body->J
    return q


def global_acceleration(q_bj: np.ndarray, acc: np.ndarray, g: float) -> np.ndarray:
    """Gravity-removed acceleration in the global frame: ``a = M_BJ^T f + (0, 0, g)`` (z down) [m/s^2]."""
    m = dcm_from_quat(q_bj)
    f = np.einsum("...ji,...j->...i", m, acc)
    f[:, 2] += g
    return f
