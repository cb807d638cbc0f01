"""Saturated IMU samples in the ski-jump smoother: the policy (issue 17).

The smoother is driven by the IMU (eq 22): each step integrates the gyroscope
and accelerometer sample.  When an axis clips at the sensor range (the
landing impact and ski chatter easily exceed +-16 g, +-2000 deg/s), its true
value is unknown -- only known to be beyond the range -- and integrating the
clipped value as if it were exact biases velocity, position and attitude.

Policy:

1. Clipped samples are found per axis by :func:`sportfusion.core.saturation.clipped`:
   at the configured range (``SmootherConfig.gyr_range``, ``acc_range``; 0 = from the
   data: runs of samples at the axis' extreme value).
2. The clipped samples and those within ``clip_margin`` seconds of them (the
   rest of the burst, whose mean the clipping has biased) get the input noise
   ``q_gyr_clipped`` [rad/s], ``q_acc_clipped`` [m/s^2] (1-sigma per sample, instead of
   Table 4's ``q_gyr``, ``q_acc``) on the affected axes: the smoother keeps the
   measured (clipped) value as its best guess but lets GNSS, magnetometer and
   the hill constraints correct it, and the covariance (``std_*``) grows honestly
   over the clipped stretch.
3. ``rts-smooth`` says in one warning line how many steps were affected.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sportfusion.core.saturation import clipped
from sportfusion.core.stats import median


def clipped_steps(t: np.ndarray, u: np.ndarray, cfg: Any) -> np.ndarray:
    """(n, 6) bool: IMU axes (gyro x y z, acc x y z) clipped or within ``cfg.clip_margin`` [s] of a clipped sample.

    Parameters
    ----------
    t : ndarray (n,)
        Step times [s].
    u : ndarray (n, 6)
        Gyroscope [rad/s] and accelerometer [m/s^2] samples.
    cfg : SmootherConfig
        ``gyr_range``, ``acc_range`` (0: from the data), ``clip_margin``.
    """
    gr = cfg.gyr_range if cfg.gyr_range > 0 else None
    ar = cfg.acc_range if cfg.acc_range > 0 else None
    m = np.concatenate([clipped(u[:, :3], gr), clipped(u[:, 3:], ar)], axis=1)
    if not m.any() or cfg.clip_margin <= 0 or t.size < 2:
        return m
    out = m.copy()
    for c in np.flatnonzero(m.any(axis=0)):
        tc = t[m[:, c]]
        j = np.searchsorted(tc, t)
        near = np.zeros(t.size, bool)
        lo = np.clip(j - 1, 0, tc.size - 1)
        hi = np.clip(j, 0, tc.size - 1)
        near |= np.abs(t - tc[lo]) <= cfg.clip_margin + 1e-9
        near |= np.abs(t - tc[hi]) <= cfg.clip_margin + 1e-9
        out[:, c] = near
    return out


def step_noise(inp: Any, cfg: Any) -> np.ndarray:
    """(n, 6) input-noise variances per step: Table 4's, inflated on the clipped axes (see the module text)."""
    base = np.array([cfg.q_gyr] * 3 + [cfg.q_acc] * 3) ** 2
    qd = np.tile(base, (inp.t.size, 1))
    if inp.clipped is not None and inp.clipped.any():
        big = np.array([cfg.q_gyr_clipped] * 3 + [cfg.q_acc_clipped] * 3) ** 2
        qd = np.where(inp.clipped, np.maximum(big, base), qd)
    return np.ascontiguousarray(qd)


def clipped_message(inp: Any) -> str | None:
    """One warning line when steps were clipped, else None."""
    if inp.clipped is None or not inp.clipped.any():
        return None
    g = int(inp.clipped[:, :3].any(axis=1).sum())
    a = int(inp.clipped[:, 3:].any(axis=1).sum())
    return (
        f"IMU saturated (clipped at the sensor range): {g} gyroscope and {a} accelerometer step(s) "
        "integrated with inflated input noise"
    )


def mag_innovation_outliers(
    resid: np.ndarray | None, t: np.ndarray, r_mag: float, window: float = 1.0, factor: float = 1.6
) -> np.ndarray:
    """(n,) True on the magnetometer steps of stretches whose innovations are too large (a disturbance).

    The running RMS of the magnetometer innovation norm over ``window`` [s] is compared with
    ``factor * sqrt(3) * r_mag`` (three axes of 1-sigma ``r_mag`` [uT]; on clean simulated jumps
    the running RMS stays below 1.15 times that size).  Where it is larger, the magnetometer is taken
    as disturbed: a disturbance that keeps the field's strength (so that
    :func:`sportfusion.core.magdisturb.mag_disturbed` does not see it) still turns the field.
    """
    n = t.size
    out = np.zeros(n, dtype=bool)
    if resid is None or n < 3:
        return out
    e = np.linalg.norm(resid, axis=1)
    ok = np.isfinite(e)
    if ok.sum() < 10:
        return out
    k = max(int(round(window / float(median(np.diff(t))))), 3)
    box = np.ones(k)
    s2 = np.convolve(np.where(ok, e**2, 0.0), box, "same")
    cnt = np.convolve(ok.astype(float), box, "same")
    rms = np.sqrt(s2 / np.maximum(cnt, 1.0))
    bad = (rms > factor * math.sqrt(3.0) * r_mag) & (cnt >= k / 4)
    if not bad.any():
        return out
    # the whole window around a flagged centre
    return (np.convolve(bad.astype(float), box, "same") > 0) & ok
