"""Clipped (saturated) sensor samples: found from the data or from a stated sensor range.

A MEMS accelerometer or gyroscope that is pushed beyond its range returns the
range itself, so a clipped axis shows **runs of samples at the same extreme
value**.  :func:`clipped` marks, per axis:

* every sample at or beyond ``limit`` in magnitude, when a range is given
  (e.g. the documented default of a sensor, :data:`ACC_RANGE`, :data:`GYR_RANGE`);
* else every sample whose magnitude equals the axis' largest magnitude (within
  ``rel_tol``) when that value occurs at least ``min_count`` (3) times (a plateau, or a
  vibration that hits the range on both sides): a continuous signal sampled with
  noise does not repeat its extreme value exactly.  The axes of one sensor share
  its range: once an axis is found clipped at a level, every axis is clipped
  at or beyond it.  For the same reason a plateau is only taken for the range
  when no axis of the sensor reads beyond it (by more than ``range_tol``,
  per-axis scale calibration): a noise-free, quantised signal (an ideal sensor,
  a quiet one whose noise is below one count) repeats the value at the top of
  a slow peak too, far inside the range, and taking that for the range would
  mark every larger sample of every axis as clipped (issue 39: a 0.60 rad/s
  gyro peak and a 6.7 m/s^2 accelerometer peak flagged 2285 of 2871 steps,
  and the ski-jump smoother's 3-D error tripled).

Estimators use the mask to down-weight or skip the clipped samples (their true
value is unknown, only known to be beyond the range): see ``docs/faults.md``.
"""

from __future__ import annotations

import math

import numpy as np

#: Default accelerometer range [m/s^2] (16 g, the largest common range of wearable IMUs).
ACC_RANGE = 16.0 * 9.80665
#: Default gyroscope range [rad/s] (2000 deg/s).
GYR_RANGE = math.radians(2000.0)


def clipped(
    x: np.ndarray, limit: float | None = None, min_count: int = 3, rel_tol: float = 1e-6, range_tol: float = 0.1
) -> np.ndarray:
    """Boolean mask of clipped samples, same shape as ``x`` (n,) or (n, k); NaN is never clipped.

    Parameters
    ----------
    x : ndarray
        Samples of one sensor, one column per axis (any unit).
    limit : float, optional
        Sensor range (same unit): samples with ``|x| >= limit * (1 - rel_tol)`` are clipped.
        When None the range is found from the data (runs at the axis' extreme value).
    min_count : int
        Fewest samples at the extreme value for the axis to count as clipped (data-driven mode).
    rel_tol : float
        Relative tolerance of "equal to the extreme".
    range_tol : float
        Data-driven mode: an axis' plateau counts as the sensor's range only where no axis of ``x`` reads
        more than ``1 + range_tol`` times it in magnitude (the axes share the range, up to per-axis scale).
    """
    a = np.abs(np.asarray(x, dtype=float))
    one = a.ndim == 1
    a2 = a[:, None] if one else a
    out = np.zeros(a2.shape, dtype=bool)
    fin = np.isfinite(a2)
    if limit is not None:
        out = fin & (np.where(fin, a2, 0.0) >= limit * (1.0 - rel_tol))
        return out[:, 0] if one else out
    if not fin.any():
        return out[:, 0] if one else out
    peak = float(np.max(a2[fin]))  # the largest reading of any axis: the range is at least this
    for c in range(a2.shape[1]):
        col = a2[:, c]
        ok = fin[:, c]
        if ok.sum() < min_count:
            continue
        top = float(np.max(col[ok]))
        if top <= 0 or peak > top * (1.0 + range_tol):
            continue  # another axis reads beyond this plateau: it is a peak inside the range, not the range
        at = ok & (np.where(ok, col, 0.0) >= top * (1.0 - rel_tol))
        if at.sum() >= min_count:
            out[:, c] = at
    if out.any():
        level = min(float(np.max(a2[out[:, c], c])) for c in range(a2.shape[1]) if out[:, c].any())
        out = fin & (np.where(fin, a2, 0.0) >= level * (1.0 - rel_tol))
    return out[:, 0] if one else out


def clipped_rows(x: np.ndarray, limit: float | None = None, min_count: int = 3) -> np.ndarray:
    """(n,) True where any axis of ``x`` (n, k) is clipped (see :func:`clipped`)."""
    m = clipped(x, limit, min_count)
    return m if m.ndim == 1 else m.any(axis=1)


def describe(n_clipped: int, sensor: str, limit: float, unit: str) -> str:
    """One line naming the fault: ``"accelerometer clipped at +-156.9 m/s^2 in 12 samples"``."""
    return f"{sensor} clipped at +-{limit:.4g} {unit} in {n_clipped} sample(s)"
