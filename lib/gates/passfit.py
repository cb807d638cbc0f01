"""Where the magnet lies, from the whole pass: the field anomaly around a crossing fitted with a bar magnet.

The paper estimates the sacrum -> magnet offset from the peak intensity alone (its eq 1, then eqs 2-6 with a
body model for the sacrum's height) and names the limits itself: the peak is undersampled, the intensity
falls with the cube of the distance, and "peak intensity could be measured more reliably by ... designing
an advanced curve fitting" (Discussion).  This module does that fitting, with the vector field:

* the magnetometer samples around the crossing are rotated into the global frame with the strap-down
  attitude (a second of gyro integration: drift well under a degree) and the background (Earth field and
  slow disturbances) is removed: a straight line in time fitted per component to two flanking windows;
* the anomaly left, ``dB(t)`` (3 components, 20-100 samples), is fitted with the field of a bar magnet --
  two magnetic charges ``+-|m|/L`` at ``c +- (L/2) m/|m|`` (Furlani 2001; ``L = 0``: a point dipole) --
  seen from the sensor moving along its track ``p(t) = p_c + v dt + a dt^2/2`` (velocity and acceleration
  at the crossing from the smoother): unknowns the magnet's centre ``c`` (3) and moment ``m`` (3: size,
  tilt and polarity are all free);
* a dipole's field is even in the offset, so the magnet below the sensor and its mirror image above give
  nearly the same pass: the fit starts below (from the peak model's offset, both polarities) and a
  solution above the sensor is rejected;
* the covariance of ``c`` is the Gauss-Newton one scaled by the residual variance: a weak or wide pass
  (little signal above the background) gets a large one, so the smoother weights it down instead of
  trusting a guessed distance.

The offset ``c - p_c`` needs neither the sacrum's height above the snow nor the athlete's lean, which the
peak model has to assume.  Fields in any unit (uT or normalised): the geometry does not depend on it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

K_UT = 0.1  # mu0 / (4 pi) in uT m / A, so that the moment comes out in A m^2 when the field is in uT


@dataclass(frozen=True)
class PassFitParams:
    """Settings of the pass fit (units in brackets).

    Attributes
    ----------
    length : float
        Length of the bar magnet between its two charges [m] (the paper's stick: 10 discs, 14.5 cm);
        0: a point dipole.
    window : tuple
        Smallest and largest half-width of the fitted window around the peak [s]; within these, three times
        the peak model's distance over the speed.
    flank : float
        The background windows start ``flank`` half-widths from the peak and are as long again [1].
    min_snr : float
        Smallest peak anomaly over the background's noise for a fit [1].
    max_offset : float
        Largest accepted sensor -> magnet distance [m].
    """

    length: float = 0.145
    window: tuple[float, float] = (0.12, 0.4)
    flank: float = 1.4
    min_snr: float = 6.0
    max_offset: float = 2.5


@dataclass
class PassFit:
    """One crossing's fit: the magnet's centre relative to the sensor at the crossing (global frame).

    Attributes
    ----------
    ok : bool
        The fit converged below the sensor, with enough signal.
    rel : ndarray (3,)
        Magnet centre minus sensor position at the crossing time [m].
    cov : ndarray (3, 3)
        Covariance of ``rel`` [m^2].
    moment : ndarray (3,)
        Fitted moment [A m^2 when the field is in uT].
    snr : float
        Peak anomaly over the background noise [1].
    rms : float
        Residual RMS of the fit [field unit].
    why : str
        What failed, when not ``ok``.
    """

    ok: bool
    rel: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    cov: np.ndarray = field(default_factory=lambda: np.full((3, 3), np.nan))
    moment: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    snr: float = float("nan")
    rms: float = float("nan")
    why: str = ""


def bar_field(p: np.ndarray, centre: np.ndarray, moment: np.ndarray, length: float) -> np.ndarray:
    """Field (n, 3) at points ``p`` (n, 3) [m] of a bar magnet: charges ``+-|m|/L`` at ``c +- (L/2) m/|m|``.

    ``K_UT`` scales it to microtesla for a moment in A m^2; ``length = 0`` gives the point dipole
    ``K (3 (m.r^) r^ - m) / r^3``, the limit of the bar far away.
    """
    m = np.asarray(moment, float)
    r = p - centre
    if length <= 0:
        d = np.maximum(np.linalg.norm(r, axis=1, keepdims=True), 1e-3)
        u = r / d
        return K_UT * (3.0 * (u @ m)[:, None] * u - m) / d**3
    mag = max(float(np.linalg.norm(m)), 1e-12)
    half = 0.5 * length * m / mag
    q = mag / length
    out = np.zeros_like(r)
    for sign in (1.0, -1.0):
        rr = r - sign * half
        d = np.maximum(np.linalg.norm(rr, axis=1, keepdims=True), 1e-3)
        out += sign * q * rr / d**3
    return K_UT * out


def _background(t: np.ndarray, b: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, float]:
    """Straight line in time per component through the samples ``mask``; returns it at every ``t`` and the
    RMS of the samples about it (the background's noise)."""
    a = np.column_stack([np.ones(int(mask.sum())), t[mask]])
    coef, *_ = np.linalg.lstsq(a, b[mask], rcond=None)
    line = np.column_stack([np.ones(t.size), t]) @ coef
    res = b[mask] - line[mask]
    return line, float(np.sqrt(np.mean(res**2))) if res.size else float("nan")


def fit_pass(
    t: np.ndarray,
    b_glob: np.ndarray,
    t_c: float,
    vel: np.ndarray,
    acc: np.ndarray,
    guess: np.ndarray,
    params: PassFitParams | None = None,
) -> PassFit:
    """Fit one pass (see the module text).

    Parameters
    ----------
    t : ndarray (n,)
        Magnetometer times around the crossing [s] (at least the flanking windows).
    b_glob : ndarray (n, 3)
        Field in the global frame (z down) at those times [uT or normalised].
    t_c : float
        Crossing time (the peak) [s].
    vel, acc : ndarray (3,)
        Sensor velocity [m/s] and acceleration [m/s^2] at the crossing, global frame.
    guess : ndarray (3,)
        First guess of the offset sensor -> magnet [m] (e.g. from the peak model).
    params : PassFitParams, optional

    Returns
    -------
    PassFit
    """
    from scipy.optimize import least_squares

    p = params or PassFitParams()
    speed = max(float(np.linalg.norm(vel)), 0.5)
    r0 = float(np.linalg.norm(guess)) if np.isfinite(guess).all() else 0.6
    r0 = float(np.clip(r0, 0.2, p.max_offset))
    half = float(np.clip(3.0 * r0 / speed, *p.window))
    dt = t - t_c
    inner = np.abs(dt) <= half
    outer = (np.abs(dt) >= p.flank * half) & (np.abs(dt) <= 2 * p.flank * half)
    if inner.sum() < 5 or (outer & (dt < 0)).sum() < 3 or (outer & (dt > 0)).sum() < 3:
        return PassFit(False, why="too few samples around the crossing")
    line, noise = _background(dt, b_glob, outer)
    db = (b_glob - line)[inner]
    ti = dt[inner]
    peak = float(np.max(np.linalg.norm(db, axis=1)))
    snr = peak / max(noise, 1e-9)
    if snr < p.min_snr:
        return PassFit(False, snr=snr, why=f"anomaly {snr:.1f} x the background noise")
    track = vel[None, :] * ti[:, None] + 0.5 * acc[None, :] * ti[:, None] ** 2  # sensor relative to p_c
    scale = max(peak, 1e-12)

    def resid(x: np.ndarray) -> np.ndarray:
        return ((bar_field(track, x[:3], x[3:], p.length) - db) / scale).ravel()

    g = np.asarray(guess, float).copy()
    if not np.isfinite(g).all() or g[2] <= 0.05:
        g = np.array([0.0, 0.0, r0])
    m0 = peak * r0**3 / (1.5 * K_UT)
    best = None
    for sign in (1.0, -1.0):  # moment down (adds to the Earth's downward field above it) or up
        x0 = np.concatenate([g, [0.0, 0.0, sign * m0]])
        sol = least_squares(resid, x0, method="lm", max_nfev=400, x_scale=np.r_[0.2, 0.2, 0.2, m0, m0, m0])
        if sol.x[2] <= 0.0:  # above the sensor: the mirror image; restart from its reflection below
            x1 = np.concatenate([-sol.x[:3], sol.x[3:]])
            sol = least_squares(resid, x1, method="lm", max_nfev=400, x_scale=np.r_[0.2, 0.2, 0.2, m0, m0, m0])
        if sol.x[2] > 0.0 and (best is None or sol.cost < best.cost):
            best = sol
    if best is None:
        return PassFit(False, snr=snr, why="no solution below the sensor")
    rel = best.x[:3]
    if not np.isfinite(rel).all() or np.linalg.norm(rel) > p.max_offset:
        return PassFit(False, snr=snr, why="fitted magnet too far")
    n_res = best.fun.size
    dof = max(n_res - 6, 1)
    s2 = 2.0 * best.cost / dof
    jac = best.jac
    try:
        cov = np.linalg.inv(jac.T @ jac) * s2
    except np.linalg.LinAlgError:
        return PassFit(False, snr=snr, why="singular fit")
    return PassFit(True, rel, cov[:3, :3], best.x[3:], snr, float(np.sqrt(s2)) * scale)


def fit_crossings(
    t: np.ndarray,
    q_bj: np.ndarray,
    t_mag: np.ndarray,
    mag: np.ndarray,
    tg: np.ndarray,
    vel: np.ndarray,
    acc: np.ndarray,
    cross: dict[str, np.ndarray],
    guess: np.ndarray,
    params: PassFitParams,
) -> list[PassFit]:
    """:func:`fit_pass` at every crossing: the magnetometer ``mag`` (k, 3) at
    ``t_mag`` [s] rotated into the inertial frame with the attitude ``q_bj`` at the IMU times ``t``, the sensor's
    velocity [m/s] and acceleration [m/s^2] from the smoother steps ``tg``, ``guess`` (M, 3) the peak model's
    offsets [m]."""
    from sportfusion.core.rotations import dcm_from_quat

    k = np.clip(np.searchsorted(t, t_mag), 0, t.size - 1)
    b_glob = np.einsum("kji,kj->ki", dcm_from_quat(q_bj[k]), mag)
    vc = np.stack([np.interp(cross["t"], tg, vel[:, j]) for j in range(3)], axis=-1)
    ac = np.stack([np.interp(cross["t"], tg, acc[:, j]) for j in range(3)], axis=-1)
    out = []
    for m, tc in enumerate(cross["t"]):
        w = np.abs(t_mag - tc) <= 2.2 * params.flank * params.window[1]
        out.append(fit_pass(t_mag[w], b_glob[w], float(tc), vc[m], ac[m], guess[m], params))
    return out
