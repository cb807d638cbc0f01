"""In-motion alignment over the in-run: the initial attitude from the specific force of the start.

At rest the accelerometer sees only gravity, and the heading comes from the magnetometer, whose
hard-iron bias (Table 3's prior) leaves it off by several to tens of degrees; the first smoother pass
then starts outside the EKF's linear regime and the start has to be re-linearised
(``SmootherConfig.passes``).  Down the in-run the athlete accelerates along the track: the specific
force ``f = a - g`` tilts towards the in-run's direction, and its horizontal part fixes the heading
without the magnetometer.  With the gyro carrying every in-run sample back to the first body frame,
the rest (``f = -g``) and the in-run epochs (``a`` from differences of the GNSS velocity) are
vector observations of one attitude, solved by QUEST.
"""

from __future__ import annotations

import numpy as np

from sportfusion.estimators.quest import quest


def body_to_start(t: np.ndarray, gyr: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """Rotation matrices ``C_k`` (n, 3, 3) taking body-frame vectors at step k into the body frame of step 0.

    ``C_k+1 = C_k exp([w_k dt x])`` with the bias-corrected rate ``w_k = gyr_k - bias`` [rad/s] held over
    each step (Rodrigues).
    """
    n = t.size
    c = np.empty((n, 3, 3))
    c[0] = np.eye(3)
    if n < 2:
        return c
    phi = (gyr[:-1] - bias) * np.diff(t)[:, None]
    ang = np.linalg.norm(phi, axis=1)
    small = ang < 1e-12
    axis = phi / np.where(small, 1.0, ang)[:, None]
    s, cc = np.sin(ang), 1.0 - np.cos(ang)
    kx = np.zeros((n - 1, 3, 3))
    kx[:, 0, 1], kx[:, 0, 2], kx[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    kx[:, 1, 0], kx[:, 2, 0], kx[:, 2, 1] = axis[:, 2], -axis[:, 1], axis[:, 0]
    step = np.eye(3) + s[:, None, None] * kx + cc[:, None, None] * (kx @ kx)
    for k in range(n - 1):
        c[k + 1] = c[k] @ step[k]
    return c


def inrun_attitude(
    t: np.ndarray,
    u: np.ndarray,
    vel: np.ndarray,
    rest: np.ndarray,
    inrun: np.ndarray,
    g0: float,
    bias_gyr: np.ndarray,
    half_window: float = 0.5,
    min_epochs: int = 10,
    min_tilt_deg: float = 5.0,
    max_loss: float = 0.005,
) -> np.ndarray | None:
    """The attitude ``q_BO`` at step 0 from the rest and the in-run's specific force (QUEST), or None.

    Parameters
    ----------
    t : ndarray (n,)
        Step times [s].
    u : ndarray (n, 6)
        Gyro [rad/s] and accelerometer [m/s^2] per step.
    vel : ndarray (n, 3)
        GNSS velocity in NED [m/s], NaN where no fix.
    rest : ndarray of bool (n,)
        The rest at the start (the body frame of step 0 holds still there).
    inrun : ndarray of bool (n,)
        Steps on the in-run.
    g0 : float
        Gravity [m/s^2].
    bias_gyr : ndarray (3,)
        Gyro bias [rad/s] (the rest's mean rate).
    half_window : float
        Half-length of the interval [s] over which each epoch's acceleration is the GNSS velocity
        difference and the body specific force the gyro-carried mean.
    min_epochs : int
        Fewer in-run GNSS epochs than this: None.
    min_tilt_deg : float
        The in-run's specific force must tilt away from gravity by at least this much [deg] on some
        epoch (else the heading is not observable): else None.
    max_loss : float
        Largest Wahba loss ``1 - lambda_max`` [1] accepted (0.005: the vectors disagree by about
        6 deg rms); above it the observations do not fit one attitude (a GNSS velocity that jumps,
        a sensor that moved on the body) and the function returns None.

    Returns
    -------
    ndarray (4,) or None
        ``q_BO`` (scalar first) of the body frame at step 0.
    """
    fix = np.flatnonzero(inrun & np.isfinite(vel[:, 0]))
    if fix.size < min_epochs or not rest.any():
        return None
    last = int(fix[-1])
    ti = t[: last + 1]
    c = body_to_start(ti, u[: last + 1, 0:3], bias_gyr)
    f0 = np.einsum("kij,kj->ki", c, u[: last + 1, 3:6])  # specific force carried into body frame 0
    csum = np.vstack([np.zeros((1, 3)), np.cumsum(f0, axis=0)])
    allfix = np.flatnonzero(np.isfinite(vel[: last + 1, 0]))
    body, ref = [f0[rest[: last + 1]].mean(axis=0)], [np.array([0.0, 0.0, -g0])]
    for k in fix:
        lo = allfix[np.searchsorted(t[allfix], t[k] - half_window)]
        hi = allfix[min(np.searchsorted(t[allfix], t[k] + half_window, "right"), allfix.size) - 1]
        if hi <= lo or t[hi] - t[lo] < half_window:
            continue
        acc = (vel[hi] - vel[lo]) / (t[hi] - t[lo])
        body.append((csum[hi + 1] - csum[lo]) / (hi + 1 - lo))
        ref.append(acc - np.array([0.0, 0.0, g0]))
    if len(ref) < min_epochs + 1:
        return None
    ref_a = np.asarray(ref)
    tilt = np.degrees(np.arccos(np.clip(-ref_a[1:, 2] / np.linalg.norm(ref_a[1:], axis=1), -1, 1)))
    if tilt.max() < min_tilt_deg:
        return None
    w = np.ones(len(ref))
    q, loss = quest(np.asarray(body)[None], ref_a, w / w.sum())
    if not (loss[0] <= max_loss):
        return None
    return q[0]
