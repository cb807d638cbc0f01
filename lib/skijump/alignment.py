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

from sportfusion.core.stats import median
from sportfusion.estimators.quest import quest
from sportfusion.skijump import _ski_native


def body_to_start(t: np.ndarray, gyr: np.ndarray, bias: np.ndarray, last_only: bool = False) -> np.ndarray:
    """Rotation matrices ``C_k`` (n, 3, 3) taking body-frame vectors at step k into the body frame of step 0.

    ``C_k+1 = C_k exp([w_k dt x])`` with the bias-corrected rate ``w_k = gyr_k - bias`` [rad/s] held over
    each step (Rodrigues); ``t`` [s] (n,), ``gyr`` [rad/s] (n, 3), ``bias`` [rad/s] (3,).  ``last_only``:
    only ``C_{n-1}`` (1, 3, 3).  Where the C extension is built, one sequential product in C (an rts-smooth
    day pays this twice per jump: ~1 ms each in numpy); else numpy (:func:`_body_to_start_numpy`).
    """
    mod = _ski_native.native()
    if mod is None or t.size < 2:
        return _body_to_start_numpy(t, gyr, bias, last_only)
    out = np.empty((1 if last_only else t.size, 3, 3))
    f64 = np.ascontiguousarray
    mod.body_to_start(f64(t, dtype=float), f64(gyr, dtype=float), f64(bias, dtype=float), out)
    return out


def _body_to_start_numpy(t: np.ndarray, gyr: np.ndarray, bias: np.ndarray, last_only: bool = False) -> np.ndarray:
    """:func:`body_to_start` in numpy (the reference): ``last_only`` by a pairwise product tree (n products
    instead of n log n), else the prefix products by doubling."""
    n = t.size
    c = np.empty((n, 3, 3))
    c[0] = np.eye(3)
    if n < 2:
        return c[-1:] if last_only else c
    phi = (gyr[:-1] - bias) * np.diff(t)[:, None]
    ang = np.linalg.norm(phi, axis=1)
    small = ang < 1e-12
    axis = phi / np.where(small, 1.0, ang)[:, None]
    s, cc = np.sin(ang), 1.0 - np.cos(ang)
    kx = np.zeros((n - 1, 3, 3))
    kx[:, 0, 1], kx[:, 0, 2], kx[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    kx[:, 1, 0], kx[:, 2, 0], kx[:, 2, 1] = axis[:, 2], -axis[:, 1], axis[:, 0]
    step = np.eye(3) + s[:, None, None] * kx + cc[:, None, None] * (kx @ kx)
    if last_only:
        while step.shape[0] > 1:  # (s0 s1)(s2 s3)...: the order of the factors is kept
            if step.shape[0] % 2:
                step = np.concatenate([step, np.eye(3)[None]])
            step = step[0::2] @ step[1::2]
        return step
    # prefix products step_0 @ ... @ step_k by doubling (log2(n) batched products, not n small ones):
    # after the round with shift d, step[k] is the product of the last 2d factors ending at k
    d = 1
    while d < n - 1:
        nxt = step.copy()
        nxt[d:] = step[:-d] @ step[d:]
        step, d = nxt, 2 * d
    c[1:] = step
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
    # per in-run epoch: the GNSS fixes bounding +-half_window around it (all epochs at once)
    tf = t[allfix]
    lo = allfix[np.searchsorted(tf, t[fix] - half_window)]
    hi = allfix[np.minimum(np.searchsorted(tf, t[fix] + half_window, "right"), allfix.size) - 1]
    ok = (hi > lo) & (t[hi] - t[lo] >= half_window)
    lo, hi = lo[ok], hi[ok]
    acc = (vel[hi] - vel[lo]) / (t[hi] - t[lo])[:, None]
    body = np.vstack([f0[rest[: last + 1]].mean(axis=0), (csum[hi + 1] - csum[lo]) / (hi + 1 - lo)[:, None]])
    ref_a = np.vstack([[0.0, 0.0, -g0], acc - np.array([0.0, 0.0, g0])])
    if ref_a.shape[0] < min_epochs + 1:
        return None
    tilt = np.degrees(np.arccos(np.clip(-ref_a[1:, 2] / np.linalg.norm(ref_a[1:], axis=1), -1, 1)))
    if tilt.max() < min_tilt_deg:
        return None
    w = np.ones(ref_a.shape[0])
    q, loss = quest(body[None], ref_a, w / w.sum())
    if not (loss[0] <= max_loss):
        return None
    return q[0]


def gnss_latency(
    t: np.ndarray,
    u: np.ndarray,
    x: np.ndarray,
    vel: np.ndarray,
    g0: float,
    span: tuple[float, float],
    max_latency: float = 0.3,
    step: float = 0.005,
    with_std: bool = False,
) -> float | None | tuple[float | None, float]:
    """The GNSS time-stamp latency [s] (the fix stamped t describes t - latency) from a smoothed pass.

    The accelerometer, rotated into NED by the smoothed attitude ``x[:, 6:10]`` (``q_BO``) and corrected by
    the smoothed bias ``x[:, 13:16]``, plus gravity, is integrated to a velocity at the IMU's own time;
    the GNSS velocity is that curve delayed.  Over ``span`` (t0, t1) [s] -- the in-run, take-off and
    flight, where the velocity changes fast -- the delay minimising the misfit (after removing a constant
    and a linear drift per axis: the integration constant and a residual bias) is searched on a ``step``
    grid in ``[-max_latency, max_latency]`` and refined by a parabola.  Returns None with fewer than 20
    GNSS velocities in the span or a minimum on the grid's edge (not a delay the data show).

    ``with_std``: also its standard error [s] from the parabola's curvature ``c''`` and the misfit per
    degree of freedom ``s^2`` (``sqrt(2 s^2 / c'')``; inf where the parabola does not bend up): ``(tau, std)``.
    """
    from sportfusion.core.rotations import dcm_from_quat

    sel = (t >= span[0]) & (t <= span[1])
    k = np.flatnonzero(sel)
    gk = k[np.isfinite(vel[k, 0])]
    if gk.size < 20 or k.size < 10:
        return (None, float("inf")) if with_std else None
    ts = t[k]
    m = dcm_from_quat(x[k, 6:10])  # NED -> body
    a = np.einsum("nji,nj->ni", m, u[k, 3:6] - x[k, 13:16]) + np.array([0.0, 0.0, g0])
    v_imu = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (a[1:] + a[:-1]) * np.diff(ts)[:, None], axis=0)])
    tg, vg = t[gk], vel[gk]
    # only fixes whose every trial delay falls inside the IMU's span: np.interp would hold the integrated
    # velocity's first or last value beyond it, and the in-run's acceleration there pulled the delay ~4 ms
    # short (issue 39: -4 ms on the paper's sensors without latency, 0.0457 s for 0.05 s noise-free)
    inside = (tg - max_latency >= ts[0]) & (tg + max_latency <= ts[-1])
    tg, vg = tg[inside], vg[inside]
    if tg.size < 20:
        return (None, float("inf")) if with_std else None
    grid = np.arange(-max_latency, max_latency + step / 2, step)
    mod = _ski_native.native()
    if mod is None:
        c = _latency_misfit_numpy(ts, v_imu, tg, vg, grid)
    else:  # the same sums delay by delay in C (~1 ms per jump less: a training day pays it per jump)
        c = np.empty(grid.size)
        f64 = np.ascontiguousarray
        vg = f64(vg, dtype=float)
        mod.latency_misfit(f64(ts, dtype=float), f64(v_imu), f64(tg, dtype=float), vg, grid, np.empty_like(vg), c)
    i = int(np.argmin(c))
    if i == 0 or i == grid.size - 1:
        return (None, float("inf")) if with_std else None
    den = c[i - 1] - 2 * c[i] + c[i + 1]
    off = 0.5 * (c[i - 1] - c[i + 1]) / den if den > 0 else 0.0
    tau = float(grid[i] + off * step)
    if not with_std:
        return tau
    dof = max(3 * tg.size - 6, 1)
    curv = den / step**2
    std = float(np.sqrt(2.0 * max(float(c[i]), 0.0) / dof / curv)) if curv > 0 else float("inf")
    return tau, std


def _latency_misfit_numpy(
    ts: np.ndarray, v_imu: np.ndarray, tg: np.ndarray, vg: np.ndarray, grid: np.ndarray
) -> np.ndarray:
    """:func:`gnss_latency`'s misfit (g,) at every delay of ``grid`` (ascending) [s]: the IMU velocity ``v_imu``
    (k, 3) at times ``ts`` interpolated to ``tg - delay`` for every fix, subtracted from ``vg`` (f, 3), a constant
    and a drift over ``tg`` removed per axis; the squares left, summed (numpy; the C extension's reference)."""
    # the misfit at every grid delay at once: (fixes, delays, 3) residuals, constant and drift removed
    # queried fix by fix, each fix's delays ascending: np.interp's search from the previous index then holds
    # (3x faster than delay by delay; the same values)
    tq = (tg[:, None] - grid[None, ::-1]).ravel()
    vi = np.stack([np.interp(tq, ts, v_imu[:, j]) for j in range(3)], axis=-1).reshape(tg.size, grid.size, 3)
    r = vg[:, None] - vi  # delays descending along axis 1
    # least squares on a constant and a drift per delay and axis: the basis 1, tg - mean(tg) is orthogonal, so
    # the constant is the mean and the drift's share of the squares (sum tc r)^2 / sum tc^2
    r -= r.mean(axis=0)
    tc = tg - tg.mean()
    s1 = np.tensordot(tc, r, axes=(0, 0))  # (delays, 3)
    return (np.einsum("igc,igc->g", r, r) - np.einsum("gc,gc->g", s1, s1) / float(tc @ tc))[::-1]


def shift_gnss(
    t: np.ndarray, pos: np.ndarray, vel_hill: np.ndarray, vel: np.ndarray, latency: float
) -> tuple[np.ndarray, np.ndarray]:
    """GNSS position and velocity per step moved ``latency`` [s] earlier (to the time they describe).

    Each fix goes to the step nearest its true time and is carried over the remaining fraction of a step
    along its own velocity (position) and the GNSS velocity's change (velocity).  ``pos`` [m] and
    ``vel_hill`` [m/s] are in the hill frame, ``vel`` in NED [m/s]; NaN where no fix; fixes that would
    fall before the first step are dropped.
    """
    n = t.size
    dt = float(median(np.diff(t))) if n > 1 else 1.0
    s = int(round(latency / dt))
    rem = latency - s * dt  # the part of the latency left after moving by s steps [s]
    gp = np.flatnonzero(np.isfinite(pos[:, 0]))
    gv = np.flatnonzero(np.isfinite(vel[:, 0]))
    out_p, out_v = np.full_like(pos, np.nan), np.full_like(vel, np.nan)
    for idx, src, out, rate in ((gp, pos, out_p, vel_hill), (gv, vel, out_v, None)):
        if idx.size == 0:
            continue
        if rate is None:  # the velocity's change per second between fixes
            d = np.gradient(src[idx], t[idx], axis=0) if idx.size > 1 else np.zeros((1, 3))
        else:
            d = np.where(np.isfinite(rate[idx]), rate[idx], 0.0)
        dst = idx - s
        ok = (dst >= 0) & (dst < n)
        out[dst[ok]] = src[idx[ok]] + d[ok] * rem
    return out_p, out_v
