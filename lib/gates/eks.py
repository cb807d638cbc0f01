"""The paper's 15-state extended Kalman smoother of the sacrum (EKS 1 and EKS 2), with 3 drift-rate states
added (18), run by the suite's one smoother core :func:`sportfusion.estimators.kalman.ekf_rts`.

State (global frame J: z down, origin at the sacrum at start, azimuth 0 at the static start)::

    x = [p (3), v (3), a (3), o (3), eps (3), w (3)]

position, velocity and acceleration of the sacrum, a position offset ``o`` (the translation between the
inertial track and the anchors' frame: anchors measure ``p + o``), three small Euler angles ``eps``
of residual orientation drift, and their rate ``w`` (not in the paper: a gyro's residual misalignment
rectifies the turns' roll and yaw swings into a steady drift of the heading, 0.05-0.1 deg/s on the
simulator, which the rate carries past the last anchor instead of freezing it there).

Time-index convention (:mod:`sportfusion.estimators.kalman`): step k is sample k of the smoother grid (time
``t[k]``); ``propagate(k, x_{k|k})`` returns ``x_{k+1|k}``, ``Phi_k`` (maps the error of ``x_k`` onto
``x_{k+1}``) and ``Qd_k``.

* Transition: constant acceleration (the paper's "constant-acceleration model"): ``p' = p + v dt +
  a dt^2/2``, ``v' = v + a dt``, ``a' = a`` + white jerk of PSD ``q_jerk``; ``o`` constant; ``eps' = eps + w dt``
  plus a random walk of PSD ``q_eps`` plus ``q_rot`` times the squared rotation rate: a gyro's residual scale
  factor and axis misalignment turn the attitude error while the body rotates (on the simulator a 0.2 deg
  misalignment rectifies a GS run's roll and yaw swings into 1-4 deg of yaw drift; a hockey stop's
  1.2 rad turn times a 0.5 % scale error is 0.3 deg), hardly while it glides straight or stands.
* Acceleration measurement at every step: the gravity-removed acceleration of the strap-down orientation,
  which is off by the small rotation ``eps``: with ``C_est = (I - [eps x]) C_true`` and the specific force
  ``f = a - g`` (``g = (0, 0, g)``), ``a_meas = C_est f + g = a + (a - g) x eps``; Jacobians
  ``I - [eps x]`` (a) and ``[(a - g) x]`` (eps) -- the non-linear term that makes the smoother extended.
* Zero-velocity updates in the static postures at start and finish (``v = 0``), and the start position
  ``p(0) = 0`` (prior).
* Anchor updates (EKS 2): at a matched crossing, ``p + o = g_n - r_rel`` (surveyed magnet minus the
  relative anchor offset), variance ``sigma_anchor^2`` per axis (1 m in the first iteration, 0.1 m in the
  second) or a pass fit's covariance.

The smoother may run at a rate below the IMU's (``rate``, default 100 Hz): the acceleration is averaged
over each step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sportfusion.core.rotations import skew
from sportfusion.estimators.kalman import Measurement, SmootherResult, ekf_rts

N_STATES = 18
P_, V_, A_, O_, E_, W_ = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 15), slice(15, 18)


@dataclass(frozen=True)
class EKSParams:
    """Noise parameters of the 15-state EKS (units in brackets).

    Attributes
    ----------
    q_jerk : float
        PSD of the white jerk driving the acceleration [(m/s^3)^2/Hz].
    q_eps : float
        PSD of the orientation-drift random walk [rad^2/s].
    q_rot : float
        Orientation-drift variance per second and squared rotation rate [rad^2/s per (rad/s)^2].
    q_eps_rate : float
        PSD of the drift rate's random walk [rad^2/s^3].
    sigma_eps_rate0 : float
        Prior 1-sigma of the drift rate [rad/s].
    sigma_acc : float
        1-sigma of one averaged acceleration measurement [m/s^2] (vibration, model errors).
    sigma_zupt : float
        1-sigma of the zero-velocity pseudo-measurements [m/s].
    sigma_eps0 : tuple
        Prior 1-sigma of the drift angles about x, y, z [rad].
    sigma_offset0 : float
        Prior 1-sigma of the position offset [m].
    """

    q_jerk: float = 400.0
    q_eps: float = 2e-6
    q_rot: float = 2e-5
    q_eps_rate: float = 1e-8
    sigma_eps_rate0: float = 2e-3
    sigma_acc: float = 0.6
    sigma_zupt: float = 0.02
    sigma_eps0: tuple[float, float, float] = (0.01, 0.01, 0.05)
    sigma_offset0: float = 5.0


def transition(dt: float, p: EKSParams) -> tuple[np.ndarray, np.ndarray]:
    """``Phi`` and ``Qd`` of the constant-acceleration model with offset, drift and drift-rate states (exact for
    white jerk; the drift rate feeds the drift through ``Phi`` only)."""
    Phi = np.eye(N_STATES)
    i3 = np.eye(3)
    Phi[P_, V_] = i3 * dt
    Phi[P_, A_] = i3 * dt * dt / 2
    Phi[V_, A_] = i3 * dt
    q = p.q_jerk
    Q = np.zeros((N_STATES, N_STATES))
    blk = q * np.array(
        [
            [dt**5 / 20, dt**4 / 8, dt**3 / 6],
            [dt**4 / 8, dt**3 / 3, dt**2 / 2],
            [dt**3 / 6, dt**2 / 2, dt],
        ]
    )
    for i in range(3):
        for j in range(3):
            Q[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] = i3 * blk[i, j]
    Q[E_, E_] = i3 * p.q_eps * dt
    Phi[E_, W_] = i3 * dt
    Q[W_, W_] = i3 * p.q_eps_rate * dt
    return Phi, Q


@dataclass
class Anchor:
    """An anchor update at smoother step ``k``: ``p + o`` measured as ``z`` [m] with 1-sigma ``sigma`` [m]
    per axis, or with the full covariance ``cov`` (3, 3) [m^2] when given (a pass fit's)."""

    k: int
    z: np.ndarray
    sigma: float
    cov: np.ndarray | None = None


def run_eks(
    t: np.ndarray,
    acc: np.ndarray,
    g: float,
    zupt: np.ndarray,
    anchors: list[Anchor] | None = None,
    params: EKSParams | None = None,
    offset0: np.ndarray | None = None,
    rot_rate: np.ndarray | None = None,
) -> SmootherResult:
    """Run the 15-state EKS over the smoother grid.

    Parameters
    ----------
    t : ndarray (N,)
        Step times [s], increasing; uniform in the normal case, longer steps where the IMU dropped
        samples or stopped (each step uses its own length).
    acc : ndarray (N, 3)
        Gravity-removed acceleration in the global frame at the steps [m/s^2].
    g : float
        Gravity [m/s^2].
    zupt : ndarray of bool (N,)
        Steps in the static postures (zero-velocity updates).
    anchors : list of Anchor, optional
        Position updates (EKS 2); none in EKS 1.
    params : EKSParams, optional
    offset0 : ndarray (3,), optional
        Prior mean of the position offset [m] (default 0).
    rot_rate : ndarray (N,), optional
        Rotation rate of the body at the steps [rad/s] (drives ``q_rot``); default none.

    Returns
    -------
    SmootherResult
        From :func:`sportfusion.estimators.kalman.ekf_rts`; ``x_smooth[:, 0:3]`` is the sacrum position, ``9:12`` the
        offset (anchor frame = ``p + o``).
    """
    p = params or EKSParams()
    n = t.size
    # the real time step of every step (a dropped sample or a gap makes a longer one: the constant-acceleration
    # model bridges it with the process noise of its length); one transition per distinct step length
    steps = np.diff(t)
    cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def trans(k: int) -> tuple[np.ndarray, np.ndarray]:
        key = round(float(steps[k]), 9)
        if key not in cache:
            cache[key] = transition(key, p)
        return cache[key]

    gv = np.array([0.0, 0.0, g])
    R_acc = np.full(3, p.sigma_acc**2)
    R_zupt = np.full(3, p.sigma_zupt**2)
    H_zupt = np.zeros((3, N_STATES))
    H_zupt[:, V_] = np.eye(3)
    H_anchor = np.zeros((3, N_STATES))
    H_anchor[:, P_] = np.eye(3)
    H_anchor[:, O_] = np.eye(3)
    by_step: dict[int, list[Anchor]] = {}
    for an in anchors or []:
        by_step.setdefault(int(an.k), []).append(an)

    def propagate(k: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        Phi, Qd = trans(k)
        if rot_rate is not None and p.q_rot > 0:
            Qd = Qd.copy()
            Qd[E_, E_] += np.eye(3) * (p.q_rot * rot_rate[k] ** 2 * steps[k])
        return Phi @ x, Phi, Qd

    def measure(k: int, x: np.ndarray) -> list[Measurement]:
        a, eps = x[A_], x[E_]
        u = a - gv
        h = a + np.cross(u, eps)
        H = np.zeros((3, N_STATES))
        H[:, A_] = np.eye(3) - skew(eps)
        H[:, E_] = skew(u)
        out = [Measurement(acc[k] - h, H, R_acc, "acc")]
        if zupt[k]:
            out.append(Measurement(-x[V_], H_zupt, R_zupt, "zupt"))
        for an in by_step.get(k, ()):
            r_an = np.full(3, an.sigma**2) if an.cov is None else an.cov
            out.append(Measurement(an.z - x[P_] - x[O_], H_anchor, r_an, "anchor"))
        return out

    x0 = np.zeros(N_STATES)
    x0[A_] = acc[0]
    if offset0 is not None:
        x0[O_] = offset0
    P0 = np.diag(
        np.concatenate(
            [
                np.full(3, 1e-6),
                np.full(3, 1e-4),
                np.full(3, 1.0),
                np.full(3, p.sigma_offset0**2),
                np.asarray(p.sigma_eps0) ** 2,
                np.full(3, p.sigma_eps_rate0**2),
            ]
        )
    )
    return ekf_rts(x0, P0, n, propagate, measure, t=t)


def decimate(t: np.ndarray, x: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Average samples ``x`` (times ``t`` [s]) over the steps of a uniform grid at ``rate`` [Hz] (step centres)."""
    dt = 1.0 / rate
    edges = np.arange(t[0], t[-1] + dt, dt)
    idx = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, edges.size - 1)
    cnt = np.bincount(idx, minlength=edges.size)
    out = np.stack([np.bincount(idx, weights=x[:, j], minlength=edges.size) for j in range(x.shape[1])], axis=-1)
    ok = cnt > 0
    tc = edges + dt / 2
    out = out[ok] / cnt[ok, None]
    return tc[ok], out
