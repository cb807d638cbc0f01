"""Grip events: the moving-window low-motion detector and sensor-range violations.

The detector of the climbing paper's implementation (after Ladha et al.'s
ClimbAX): the angular rate, rotated into the world frame by the device's own
orientation when it is available, is examined in a window of ``window`` samples
centred on sample k (samples ``k - window//2 .. k + window//2 - 1``); the
per-axis standard deviations are summed and compared with ``threshold``.  The
first and the last ``window//2`` samples are never grips.

A standard deviation alone also passes a hand that turns at a steady rate or
moves without turning, so two more window statistics must stay low (each can
be switched off with an infinite limit): the norm of the window's *mean*
angular rate (``mean_threshold``, the "mean angular rate" of the dataset's
description) and the summed per-axis standard deviation of the specific force
(``acc_threshold``, the paper's "low acceleration phases").

Range violations: a sample whose accelerometer or gyroscope reading reaches
the sensor range on any axis (the dataset's limits: 160 m/s^2, 2000 deg/s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyarrow as pa

from sportfusion.climbing import _so3
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.windows import window_mean_std

IMU_COLUMNS = ("gyr_x", "gyr_y", "gyr_z")
DEV_Q = ("dev_q0", "dev_q1", "dev_q2", "dev_q3")


@dataclass(frozen=True)
class GripParams:
    """Parameters of the grip detector and the range check.

    Attributes
    ----------
    window : int
        Moving-window length [samples] (28 in the paper's implementation).
    threshold : float
        Largest sum of the per-axis angular-rate standard deviations in a grip [rad/s].
    mean_threshold : float
        Largest norm of the window's mean angular rate in a grip [rad/s] (inf: off).
    acc_threshold : float
        Largest sum of the per-axis specific-force standard deviations in a grip [m/s^2] (inf: off).
    acc_limit : float
        Accelerometer range [m/s^2]; a reading at or beyond it on any axis is a violation.
    gyr_limit : float
        Gyroscope range [rad/s] (2000 deg/s).
    world_frame : bool
        Rotate the angular rate into the world frame with ``dev_q0..3`` when present.
    """

    window: int = 28
    threshold: float = 0.6
    mean_threshold: float = 0.3
    acc_threshold: float = 1.0
    acc_limit: float = 160.0
    gyr_limit: float = float(np.deg2rad(2000.0))
    world_frame: bool = True


def _window_stats(x: np.ndarray, half: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre indices k, window means (m, 3) and summed per-axis standard deviations (m,)."""
    x = np.where(np.isfinite(x), x, 0.0)
    k = np.arange(half, x.shape[0] - half)
    mean, std = window_mean_std(x, k - half, k + half)  # window [k - half, k + half)
    return k, mean, std.sum(axis=1)


def detect_grips(
    gyr: np.ndarray,
    params: GripParams | None = None,
    r_world: np.ndarray | None = None,
    acc: np.ndarray | None = None,
) -> np.ndarray:
    """Boolean grip flag per sample.

    Parameters
    ----------
    gyr : numpy.ndarray, shape (n, 3)
        Angular rate in the sensor frame [rad/s], one row per IMU sample.
    params : GripParams, optional
    r_world : numpy.ndarray, shape (n, 3, 3), optional
        Sensor-to-world rotation per sample; rate and specific force are rotated into the world frame first.
    acc : numpy.ndarray, shape (n, 3), optional
        Specific force in the sensor frame [m/s^2]; without it the specific-force test is skipped.

    Returns
    -------
    numpy.ndarray of bool, shape (n,)
    """
    p = params or GripParams()
    if p.window < 2:
        raise InputError(f"grip window is {p.window} samples; expected at least 2")
    w = np.asarray(gyr, dtype=np.float64)
    f = None if acc is None else np.asarray(acc, dtype=np.float64)
    if r_world is not None:
        w = np.einsum("nij,nj->ni", r_world, w)
        f = None if f is None else np.einsum("nij,nj->ni", r_world, f)
    n = w.shape[0]
    half = p.window // 2
    out = np.zeros(n, dtype=bool)
    if n < 2 * half + 1:
        return out
    k, mean, spread = _window_stats(w, half)
    ok = spread < p.threshold
    if np.isfinite(p.mean_threshold):
        ok &= np.linalg.norm(mean, axis=1) < p.mean_threshold
    del mean, spread
    if f is not None and np.isfinite(p.acc_threshold):
        ok &= _window_stats(f, half)[2] < p.acc_threshold
    out[k] = ok
    return out


def _to_world(q: np.ndarray, *vectors: np.ndarray, chunk: int = 1 << 14) -> tuple[np.ndarray, ...]:
    """``vectors`` (n, 3) rotated by the unit-normalised quaternions ``q`` (n, 4, sensor to world), as
    :func:`detect_grips` does with ``r_world``, a chunk of rows at a time (no (n, 3, 3) matrices)."""
    out = tuple(np.empty_like(v) for v in vectors)
    for s in range(0, q.shape[0], chunk):
        qs = q[s : s + chunk]
        r = _so3.matrix_from_quat(qs / np.linalg.norm(qs, axis=1)[:, None])
        for v, o in zip(vectors, out, strict=True):
            o[s : s + chunk] = np.einsum("nij,nj->ni", r, v[s : s + chunk])
    return out


def range_violations(acc: np.ndarray, gyr: np.ndarray, params: GripParams | None = None) -> np.ndarray:
    """True where any accelerometer [m/s^2] or gyroscope [rad/s] axis reaches the sensor range."""
    p = params or GripParams()
    a = np.abs(np.asarray(acc, dtype=np.float64))
    g = np.abs(np.asarray(gyr, dtype=np.float64))
    return (a >= p.acc_limit).any(axis=1) | (g >= p.gyr_limit).any(axis=1)


def grip_columns(table: pa.Table, params: GripParams | None = None) -> tuple[dict[str, pa.Array], dict[str, int]]:
    """``grip`` and ``imu_saturated`` for a session table.

    The detector runs on the rows where the gyroscope sampled; other rows get
    null.  ``dev_q0..3`` (sensor to world, scalar first, as the Xsens export
    gives it) is used to rotate the rate into the world frame when present.

    Returns
    -------
    columns : dict
        ``grip`` and ``imu_saturated`` as Arrow arrays (bool, null off the IMU rows).
    counts : dict
        ``grips`` (number of grip intervals), ``grip_samples``, ``saturated``.
    """
    p = params or GripParams()
    schema.require_columns(table, (*IMU_COLUMNS, "acc_x", "acc_y", "acc_z"), "grip detection")
    gyr = schema.float_columns(table, IMU_COLUMNS)
    rows = np.isfinite(gyr).all(axis=1)
    if rows.sum() < p.window + 1:
        raise InputError(
            f"only {int(rows.sum())} gyroscope samples; expected more than the grip window of {p.window} samples"
        )
    gyr = gyr[rows]  # the IMU rows only, each array once (a long trial's memory)
    acc = np.nan_to_num(schema.float_columns(table, [f"acc_{a}" for a in "xyz"])[rows])
    sat = range_violations(acc, gyr, p)
    w, f = gyr, acc
    if p.world_frame and all(c in table.column_names for c in DEV_Q):
        q = schema.float_columns(table, DEV_Q)[rows]
        if np.isfinite(q).all() and (np.linalg.norm(q, axis=1) > 0.5).all():
            w, f = _to_world(q, gyr, acc)
        del q
    grip = detect_grips(w, p, None, f)
    del w, f
    n = table.num_rows
    mask = ~rows
    g_full = np.zeros(n, dtype=bool)
    s_full = np.zeros(n, dtype=bool)
    g_full[rows], s_full[rows] = grip, sat
    starts = int((grip & ~np.r_[False, grip[:-1]]).sum())
    cols = {"grip": schema.numeric_array(g_full, mask), "imu_saturated": schema.numeric_array(s_full, mask)}
    return cols, {"grips": starts, "grip_samples": int(grip.sum()), "saturated": int(sat.sum())}
