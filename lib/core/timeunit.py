"""Is a session's time column in seconds?  A plausibility check against the sensors' own sampling.

A session whose ``t`` is in milliseconds (a CSV's time column read without ``--time-unit ms``) is
otherwise a valid session: strictly increasing, finite.  Every estimate made from it is wrong by
orders of magnitude (a skier at 0.03 m/s), with nothing but gap warnings to say so.  Two pieces of
evidence tell the unit without a declared rate:

1. **Kinematics**: where GNSS positions come with the receiver's own speed (``vel_n``/``vel_e`` or
   ``gnss_speed``), the distance between fixes over their time difference must match that speed
   while moving (> 2 m/s).  A ratio near 1e-3 means milliseconds (1e-6 microseconds, 1e-9
   nanoseconds); a ratio near 1 confirms seconds and ends the check.  A real slow logger (1 Hz
   GNSS, a watch logging every 10 s) passes: its positions and speeds agree.
2. **Inertial sampling**: an accelerometer, gyroscope or magnetometer samples at 5 Hz .. 20 kHz.
   Samples 2 s or more apart (the median interval) that give such a rate read as milliseconds (or
   micro-/nanoseconds) are taken for that unit.  GNSS-only sessions are never judged by their rate.
3. **Span**: a session longer than :data:`MAX_SPAN_S` (3 years) is in a smaller unit.

``SPORTFUSION_TIME_CHECK=off`` turns the check off (a recording that really is that odd).
"""

from __future__ import annotations

import os

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.stats import median

#: Units a wrong time column is likely in, as the factor from seconds.
UNITS = ((1e3, "milliseconds", "ms"), (1e6, "microseconds", "us"), (1e9, "nanoseconds", "ns"))
#: Rates an inertial sensor (accelerometer, gyroscope, magnetometer) samples at [Hz].
IMU_RATE_HZ = (5.0, 20000.0)
#: Inertial samples this far apart (median) or more are suspect [s].
IMU_SLOW_S = 2.0
#: Speed above which the GNSS positions are compared with the reported speed [m/s].
MOVING_MS = 2.0
#: Longest plausible session [s] (3 years).
MAX_SPAN_S = 1e8
_IMU = (("accelerometer", "acc_x"), ("gyroscope", "gyr_x"), ("magnetometer", "mag_x"))
_EARTH_M_PER_DEG = 111_320.0


def time_unit_problem(table: pa.Table) -> str | None:
    """Why column ``t`` of a session looks like another unit than seconds, or None when it looks right.

    Judged on the first :data:`ROWS` rows, read in place (no copy of a column as long as the table).
    """
    if "t" not in table.column_names or table.num_rows < 3:
        return None
    t, _ = _leading(table, "t")
    kin = _kinematic_ratio(table, t)
    if kin is not None:
        ratio, apparent, speed = kin
        if ratio > 0.1:
            return None  # positions and speeds agree: seconds
        if ratio < 0.03:
            f, long, short = min(UNITS, key=lambda u: abs(np.log10(u[0] * ratio)))
            return (
                f"column 't' looks like {long} ({short}), not seconds: the GNSS positions move at a median "
                f"{apparent:.3g} m/s while the receiver reports {speed:.3g} m/s (~{f:g}x faster)"
            )
    for sensor, col in _IMU:
        if col not in table.column_names:
            continue
        _, valid = _leading(table, col)
        ts = t if valid is None else t[valid]
        if ts.size < 10:
            continue
        dt = float(median(np.diff(ts)))
        if dt < IMU_SLOW_S:
            continue
        for f, long, short in UNITS:
            if IMU_RATE_HZ[0] <= f / dt <= IMU_RATE_HZ[1]:
                return (
                    f"column 't' looks like {long} ({short}), not seconds: the {sensor}'s samples are {dt:.4g} s "
                    f"apart ({1 / dt:.3g} Hz; {f / dt:.4g} Hz if t is in {short})"
                )
    tt = table.column("t")
    span = float(tt[len(tt) - 1].as_py() - tt[0].as_py())
    if span > MAX_SPAN_S:
        f, long, short = next((u for u in UNITS if span / u[0] <= MAX_SPAN_S), UNITS[-1])
        return f"column 't' looks like {long} ({short}), not seconds: the session spans {span / 3.156e7:.3g} years"
    return None


#: Rows the check looks at (the first ones: hours of any recording).
ROWS = 1_000_000


def _leading(table: pa.Table, name: str) -> tuple[np.ndarray, np.ndarray | None]:
    """The first :data:`ROWS` values of a numeric column as float64 (a view of the column's buffer where it is
    one float64 chunk: nulls then hold whatever the buffer has) and its validity (None: no nulls)."""
    col = table.column(name)
    arr = col.chunk(0) if col.num_chunks == 1 else col.combine_chunks()
    arr = arr.slice(0, min(len(arr), ROWS))
    valid = None
    if arr.null_count:
        bits = np.unpackbits(np.frombuffer(arr.buffers()[0], np.uint8), bitorder="little")
        valid = bits[arr.offset : arr.offset + len(arr)].astype(bool)
    if arr.type == pa.float64() and arr.buffers()[1] is not None:
        values = np.frombuffer(arr.buffers()[1], np.float64)[arr.offset : arr.offset + len(arr)]
    else:
        values, _ = (
            schema.float_values(arr)
            if pa.types.is_floating(arr.type)
            else (schema.floats(pa.table({name: arr}), name), None)
        )
        values = np.asarray(values, np.float64)
    return values, valid


def check_time_unit(table: pa.Table, name: str = "the session") -> None:
    """Raise :class:`InputError` when :func:`time_unit_problem` finds one (unless SPORTFUSION_TIME_CHECK=off)."""
    if os.environ.get("SPORTFUSION_TIME_CHECK", "").strip().lower() in ("off", "0", "no", "false"):
        return
    problem = time_unit_problem(table)
    if problem is not None:
        raise InputError(
            f"{name}: {problem}; expected t in seconds (ingest --time-unit ms|us|ns reads such a time column; "
            "SPORTFUSION_TIME_CHECK=off skips this check)"
        )


def _kinematic_ratio(table: pa.Table, t: np.ndarray) -> tuple[float, float, float] | None:
    """Median (GNSS displacement / time difference) over the reported speed while moving, or None."""
    names = set(table.column_names)
    pair = (
        ("gnss_x", "gnss_y") if {"gnss_x", "gnss_y"} <= names else ("lat", "lon") if {"lat", "lon"} <= names else None
    )
    vel = ("vel_n", "vel_e") if {"vel_n", "vel_e"} <= names else ("gnss_speed",) if "gnss_speed" in names else None
    if pair is None or vel is None:
        return None
    cols = [_leading(table, c) for c in (*pair, *vel)]
    ok = np.ones(t.size, dtype=bool)
    for _, valid in cols:
        if valid is not None:
            ok &= valid
    rows = np.flatnonzero(ok)  # the GNSS rows (a fraction of an IMU session's)
    if rows.size < 6:
        return None
    a, b = cols[0][0][rows], cols[1][0][rows]
    if pair == ("lat", "lon"):
        a, b = a * _EARTH_M_PER_DEG, b * _EARTH_M_PER_DEG * np.cos(np.radians(a / _EARTH_M_PER_DEG))
    s = np.hypot(cols[2][0][rows], cols[3][0][rows]) if len(vel) == 2 else cols[2][0][rows]
    keep = np.isfinite(a) & np.isfinite(b) & np.isfinite(s)
    a, b, s, tt = a[keep], b[keep], s[keep], t[rows][keep]
    if tt.size < 6:
        return None
    dt = np.diff(tt)
    mean_speed = 0.5 * (s[1:] + s[:-1])
    moving = (mean_speed > MOVING_MS) & (dt > 0)
    if np.count_nonzero(moving) < 5:
        return None
    apparent = np.hypot(np.diff(a), np.diff(b))[moving] / dt[moving]
    ratio = float(median(apparent / mean_speed[moving]))
    return ratio, float(median(apparent)), float(median(mean_speed[moving]))
