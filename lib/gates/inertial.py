"""Sacrum orientation and gravity-removed acceleration in the global frame (gates paper, "EKS 1").

The paper gets segment orientations from strap-down integration with the *joint* drift correction of a
full-body sensor suit (Fasel et al. 2017d, 2018).  With the single sacrum sensor of this suite the drift
correction uses what that sensor alone offers:

* gyro bias from the static posture at the start, and again at the finish, interpolated linearly in time
  between the two.  A standing body sways (an inverted pendulum: a few mrad at 0.1-0.6 Hz), so the mean
  angular rate over a few seconds is off by the net sway over the window (measured: 0.005-0.01 rad/s, a
  tilt error growing by 0.3-0.6 deg/s); :func:`static_gyro_bias` therefore takes the bias that keeps the
  gyro-propagated gravity direction on the accelerometer's (a linear fit over the window, which the real
  tilt of the sway does not move and its small linear accelerations hardly do), and the mean rate only
  about the vertical, which gravity cannot see;
* initial roll and pitch by levelling the static start (mean specific force), yaw = 0: the global frame J
  has "x forward with respect to the athlete's still posture at start", z down (the suite's convention;
  the paper's Y-up frame is the same frame with other axis names), origin at the sacrum at start;
* the tilt error left at the finish (strap-down gravity direction vs the measured specific force in the
  static finish posture) is removed by a rotation growing linearly over the run (from the end of the
  static start to the beginning of the static finish).

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


def static_gyro_bias(t: np.ndarray, acc: np.ndarray, gyr: np.ndarray) -> np.ndarray:
    """Gyro bias [rad/s] over a static posture in which the body may sway.

    The mean rate ``b0`` is a first guess.  With it removed, the gyro is integrated over the window
    (attitude relative to the window's first sample), and the accelerometer's gravity direction
    ``u = -f/|f|`` is carried into that reference frame.  With the right bias that direction stays put:
    the sway's real tilt is in both the gyro and the accelerometer and cancels; a residual bias ``db``
    turns it at the rate ``r = db x u0``.  A straight line fitted to the carried direction gives ``r``,
    and ``db = u0 x r`` (the part across gravity; the part along it is invisible to gravity and keeps
    the mean rate).

    Parameters
    ----------
    t : ndarray (n,)
        Times [s] of the window.
    acc, gyr : ndarray (n, 3)
        Specific force [m/s^2] and angular rate [rad/s], body frame.

    Returns
    -------
    ndarray (3,)
        Bias [rad/s], body frame.
    """
    b0 = gyr.mean(axis=0)
    if t.size < 10 or t[-1] - t[0] < 0.5:
        return b0
    q = integrate_body_rates(np.array([1.0, 0.0, 0.0, 0.0]), t, interval_mean_rates(gyr - b0))
    u = -acc / np.maximum(np.linalg.norm(acc, axis=1, keepdims=True), 1e-9)
    m = dcm_from_quat(q)  # reference -> body
    u_ref = np.einsum("kji,kj->ki", m, u)
    tc = t - t.mean()
    rate = (tc[:, None] * (u_ref - u_ref.mean(axis=0))).sum(axis=0) / max(float((tc * tc).sum()), 1e-12)
    u0 = u_ref.mean(axis=0)
    u0 /= np.linalg.norm(u0)
    return b0 + np.cross(u0, rate - u0 * rate.dot(u0))


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
    b0 = static_gyro_bias(t[s0:s1], acc[s0:s1], gyr[s0:s1])
    b1 = static_gyro_bias(t[f0:f1], acc[f0:f1], gyr[f0:f1])
    # the bias and tilt corrections change while the athlete moves: from the end of the static start to the
    # beginning of the static finish (a ramp from the windows' middles would tilt the standing body already)
    tb0, tb1 = t[s1 - 1], t[f0]
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


def static_gravity(t: np.ndarray, acc: np.ndarray, static: Static) -> np.ndarray:
    """The gravity the accelerometer itself reads [m/s^2] at every sample: ``|f|`` averaged over the static
    start and over the static finish, interpolated linearly in time over the motion between them.

    Removing this instead of the site's normal gravity takes the accelerometer's scale-factor and bias errors
    out of the vertical channel (a 1 % scale error alone reads 0.1 m/s^2 of vertical acceleration for the
    whole run: hundreds of metres after double integration, which the zero-velocity updates cannot fold back).
    """
    s0, s1 = static.start
    f0, f1 = static.finish
    g0 = float(np.linalg.norm(acc[s0:s1], axis=1).mean())
    g1 = float(np.linalg.norm(acc[f0:f1], axis=1).mean())
    tb0, tb1 = t[s1 - 1], t[f0]
    frac = np.clip((t - tb0) / max(tb1 - tb0, 1e-9), 0.0, 1.0)
    return g0 + (g1 - g0) * frac


def global_acceleration(q_bj: np.ndarray, acc: np.ndarray, g: float | np.ndarray) -> np.ndarray:
    """Gravity-removed acceleration in the global frame: ``a = M_BJ^T f + (0, 0, g)`` (z down) [m/s^2]; ``g`` a
    constant or one value per sample (:func:`static_gravity`)."""
    m = dcm_from_quat(q_bj)
    f = np.einsum("...ji,...j->...i", m, acc)
    f[:, 2] += g
    return f
