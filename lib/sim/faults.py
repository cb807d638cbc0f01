"""Realistic recording faults injected into a session table (for tests and ``bench/bench_faults.py``).

Each function takes a session table (column ``t`` [s] and the sensor columns of
:mod:`sportfusion.core.schema`) and returns a new table with one fault; the truth
of a simulated session stays valid (the faults are sensor artefacts, the motion
does not change).  Missing samples are written as nulls, as a reader does for a
sensor that did not sample on a row.

* :func:`saturate_imu`: short impact bursts (damped ~80 Hz oscillations, zero
  mean) added to the IMU, then the accelerometer and gyroscope clipped to their
  ranges (default +-16 g, +-2000 deg/s), as a MEMS sensor does.
* :func:`drop_imu_samples`: a fraction of the IMU samples missing at random,
  plus optional short gaps.
* :func:`gnss_outage`: every GNSS column null over a span.
* :func:`mag_disturbance`: a magnetic disturbance (a field added to the
  magnetometer, e.g. a steel structure or a lift pylon) over a span.
* :func:`duplicate_times`: a few rows repeated (same time), as a faulty logger writes them.
"""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.stats import median

#: Default accelerometer range of a consumer/sports IMU [m/s^2] (16 g).
ACC_RANGE = 16.0 * 9.80665
#: Default gyroscope range [rad/s] (2000 deg/s).
GYR_RANGE = math.radians(2000.0)

ACC = ("acc_x", "acc_y", "acc_z")
GYR = ("gyr_x", "gyr_y", "gyr_z")
MAG = ("mag_x", "mag_y", "mag_z")
#: Columns that come from the GNSS receiver.
GNSS = (
    "lat",
    "lon",
    "h",
    "h_msl",
    "gnss_x",
    "gnss_y",
    "gnss_z",
    "vel_n",
    "vel_e",
    "vel_d",
    "gnss_fix",
    "gnss_sats",
    "gnss_hdop",
    "gnss_sigma_h",
    "gnss_sigma_v",
    "gnss_sigma_n",
    "gnss_sigma_e",
    "gnss_speed",
    "gnss_course",
    "gnss_age",
    "gnss_ratio",
    "rtk_q",
    "std_gnss_x",
    "std_gnss_y",
    "std_gnss_z",
)


def _replace(table: pa.Table, name: str, values: np.ndarray, mask: np.ndarray | None = None) -> pa.Table:
    """Column ``name`` replaced by ``values`` (null where ``mask`` or where the old column was null)."""
    old = table.column(name)
    null = np.asarray(old.is_null().to_numpy(zero_copy_only=False), dtype=bool)
    if mask is not None:
        null = null | mask
    arr = pa.array(np.asarray(values, dtype=np.float64), type=pa.float64(), mask=null)
    return table.set_column(table.column_names.index(name), name, arr)


def _null_rows(table: pa.Table, names: tuple[str, ...], rows: np.ndarray) -> pa.Table:
    for name in names:
        if name not in table.column_names:
            continue
        col = table.column(name).combine_chunks()
        null = np.asarray(col.is_null().to_numpy(zero_copy_only=False), dtype=bool) | rows
        if pa.types.is_floating(col.type):
            vals = np.asarray(col.to_numpy(zero_copy_only=False), dtype=np.float64)
            arr = pa.array(np.where(null, 0.0, vals), type=col.type, mask=null)
        else:
            vals = col.to_pylist()
            arr = pa.array([None if n else v for v, n in zip(vals, null, strict=True)], type=col.type)
        table = table.set_column(table.column_names.index(name), name, arr)
    return table


def saturate_imu(
    table: pa.Table,
    burst_times: list[float] | tuple[float, ...] = (),
    acc_range: float = ACC_RANGE,
    gyr_range: float = GYR_RANGE,
    burst_acc: float = 30.0 * 9.80665,
    burst_gyr: float = math.radians(4000.0),
    burst_duration: float = 0.05,
    burst_freq: float = 30.0,
    seed: int = 0,
) -> pa.Table:
    """Impact bursts added to the IMU at ``burst_times`` [s], then every IMU sample clipped to its range.

    Parameters
    ----------
    table : pyarrow.Table
        Session with ``acc_* gyr_*`` (m/s^2, rad/s).
    burst_times : sequence of float
        Start of each burst [s] (e.g. the touch-down and a few random instants).
    acc_range, gyr_range : float
        Sensor ranges [m/s^2], [rad/s]; samples beyond are set to +-range.
    burst_acc, burst_gyr : float
        Peak amplitude of a burst [m/s^2], [rad/s] (random direction per axis).
    burst_duration : float
        Decay time constant of a burst [s] (it lasts about 3 of them).
    burst_freq : float
        Oscillation frequency of a burst [Hz]; the sampled burst is made zero-sum (a
        vibration: no net rotation or change of speed), so that any bias comes from the clipping.
    seed : int
        Random generator seed (burst directions and phases).
    """
    rng = np.random.default_rng(seed)
    t = schema.floats(table, "t")
    for names, amp, rng_max in ((ACC, burst_acc, acc_range), (GYR, burst_gyr, gyr_range)):
        for name in names:
            if name not in table.column_names:
                continue
            v = schema.floats(table, name).copy()
            for tb in burst_times:
                tau = t - tb
                # the sensor's own samples only (a session also has rows where only the GNSS sampled)
                on = (tau >= 0) & (tau < 4 * burst_duration) & np.isfinite(v)
                phase = rng.uniform(0, 2 * np.pi)
                a = amp * rng.uniform(0.5, 1.0) * rng.choice((-1.0, 1.0))
                env = np.exp(-tau[on] / burst_duration)
                b = a * env * np.sin(2 * np.pi * burst_freq * tau[on] + phase)
                if env.size:
                    b -= env * (b.sum() / env.sum())  # sampled sum zero: a vibration, no net rotation or speed
                v[on] += b
            table = _replace(table, name, np.clip(v, -rng_max, rng_max))
    return table


def drop_imu_samples(
    table: pa.Table,
    fraction: float = 0.02,
    gaps: list[tuple[float, float]] | tuple[tuple[float, float], ...] = (),
    seed: int = 0,
    columns: tuple[str, ...] = ACC + GYR,
) -> pa.Table:
    """IMU samples missing: ``fraction`` of the IMU rows at random, and every IMU row in each ``(t0, duration)`` gap.

    The rows stay (other sensors may sample on them); the IMU columns become null.
    """
    rng = np.random.default_rng(seed)
    t = schema.floats(table, "t")
    imu = np.isfinite(schema.floats(table, columns[0]))
    drop = imu & (rng.random(t.size) < fraction)
    for t0, dur in gaps:
        drop |= imu & (t >= t0) & (t < t0 + dur)
    return _null_rows(table, columns, drop)


def gnss_outage(table: pa.Table, t0: float, duration: float) -> pa.Table:
    """Every GNSS column (:data:`GNSS`) null from ``t0`` for ``duration`` [s]."""
    t = schema.floats(table, "t")
    return _null_rows(table, GNSS, (t >= t0) & (t < t0 + duration))


def mag_disturbance(
    table: pa.Table, t0: float, duration: float, strength: float = 0.5, ramp: float = 1.0, seed: int = 0
) -> pa.Table:
    """A disturbing field added to ``mag_*`` from ``t0`` for ``duration`` [s].

    The added field has norm ``strength`` times the median field norm of the
    recording (so it works for uT and for normalised units), a random fixed
    direction in the sensor frame (a body-fixed disturbance: a device, a magnet)
    and fades in and out over ``ramp`` seconds.
    """
    rng = np.random.default_rng(seed)
    t = schema.floats(table, "t")
    m = schema.float_columns(table, MAG)
    ok = np.isfinite(m).all(axis=1)
    norm = float(median(np.linalg.norm(m[ok], axis=1))) if ok.any() else 1.0
    d = rng.normal(size=3)
    d *= strength * norm / np.linalg.norm(d)
    w = np.clip(np.minimum(t - t0, t0 + duration - t) / max(ramp, 1e-9), 0.0, 1.0)
    for k, name in enumerate(MAG):
        table = _replace(table, name, m[:, k] + w * d[k])
    return table


def duplicate_times(table: pa.Table, n: int = 3, seed: int = 0) -> pa.Table:
    """``n`` random rows repeated right after themselves (same time)."""
    rng = np.random.default_rng(seed)
    rows = np.sort(rng.choice(np.arange(1, table.num_rows - 1), size=n, replace=False))
    idx = np.sort(np.concatenate([np.arange(table.num_rows), rows]))
    return table.take(pa.array(idx))


def clipped_fraction(table: pa.Table, names: tuple[str, ...], limit: float) -> float:
    """Share of the samples of columns ``names`` at or beyond ``+-limit`` (a check for tests)."""
    v = schema.float_columns(table, names)
    ok = np.isfinite(v)
    return float((np.abs(v[ok]) >= limit).mean()) if ok.any() else 0.0
