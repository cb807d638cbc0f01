"""Garmin FIT activity files (watches, bike computers, action cameras).

Decoder
    ``fitdecode`` (MIT licence, pure Python, maintained).  It was chosen over
    Garmin's own ``garmin-fit-sdk`` package because it streams the file frame
    by frame with a strict CRC check and raises distinct errors for a bad
    header, a bad CRC and a file cut short (so a broken file is refused with
    one line naming the fault), it exposes each field's value after the
    profile's scale/offset and component expansion (``enhanced_*`` filled
    from the 16-bit fields), and its processor hook lets us keep FIT
    ``date_time`` values as raw integers, which is needed to tell UTC stamps
    from stamps relative to the device's power-on.  The official SDK is used
    by the tests as an independent encoder and reference decoder.

Time
    FIT ``date_time`` counts seconds since 1989-12-31 00:00:00 UTC.  A value
    below ``0x10000000`` is *system time* (seconds since the device powered
    on, FIT protocol section "Date Time"); such stamps are moved onto UTC
    with the file's ``timestamp_correlation`` message (UTC = system time +
    ``timestamp + fractional_timestamp - system_timestamp -
    fractional_system_timestamp``; with several, that offset is interpolated
    linearly in system time, following the device clock's drift).  Without a correlation the recording
    keeps the device clock (no absolute time) and a warning says so.
    ``t`` counts from the first UTC second of the file.  A record clock that
    jumps by a day or more (a watch whose clock was set mid-file: records 20
    days apart while the session's ``total_elapsed_time`` is an hour) is
    reported in one warning and kept as written, never silently re-based;
    ``spline-smooth`` splits the track there.

Columns (units)
    ``record`` messages (one ``fit_record`` stream): ``lat``/``lon`` [deg]
    from semicircles (x 180 / 2^31); ``h_msl`` [m] from
    ``enhanced_altitude``, else ``altitude`` -- FIT altitude is height above
    mean sea level, so it is never written as the ellipsoidal ``h`` (with
    ``--geoid-offset N`` also ``h`` = h_msl + N); ``gnss_speed`` [m/s]
    from ``enhanced_speed``, else ``speed``; ``heart_rate`` [1/min];
    ``cadence`` [1/min] (plus ``fractional_cadence``); ``power`` [W];
    ``gnss_sigma_h`` [m] from ``gps_accuracy``; ``temperature`` [degC].
    Records stay in file order; records at one time are folded by ingest's
    one time-ordering policy (``core.session.order_by_time``: the first in
    file order wins, later ones fill its nulls; counted).

    ``accelerometer_data`` / ``gyroscope_data`` / ``magnetometer_data``
    (action cameras, some watches): one sample per ``sample_time_offset``
    [ms] after ``timestamp`` + ``timestamp_ms``.  Values from the
    ``calibrated_*`` fields (g, deg/s, G), else ``compressed_calibrated_accel``
    (mG), else the raw counts through the latest ``three_d_sensor_calibration``
    of that sensor: ``R ((raw - level_shift - offset_cal) factor / divisor)``
    with ``R`` the orientation matrix / 65535.  Written as ``acc_*``
    [m/s^2], ``gyr_*`` [rad/s], ``mag_*`` [uT].  Raw counts without a
    calibration are dropped with a warning.

Invalid markers
    FIT marks a field without a value by its base type's *invalid* value
    (FIT protocol, "Base Types": 0x7F sint8, 0xFF uint8/enum, 0x7FFF sint16,
    0xFFFF uint16, 0x7FFFFFFF sint32 -- e.g. a position without a fix --,
    0xFFFFFFFF uint32, NaN float, 0 for the ``z`` types).  ``fitdecode``
    returns None for those (also per element of an array field); they are
    read as null, never as a value, and counted per column in one warning.
    No column is derived from them.

Errors
    A truncated file, a bad CRC or a bad header raise
    :class:`~sportfusion.core.errors.InputError` with one line.  Quirks the
    decoder can step over (an invalid field size in a definition message, a
    developer field without its description) are counted in one warning.
"""

from __future__ import annotations

import math
import struct
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream
from sportfusion.ingest import Options, Recording

#: FIT date_time epoch (1989-12-31T00:00:00Z) in Unix seconds.
FIT_EPOCH = 631065600
#: date_time values below this are seconds since device power-on (system time).
SYSTEM_TIME_MAX = 0x10000000
SEMICIRCLE_DEG = 180.0 / 2**31
#: key (not a FIT field name) under which a message lists its fields that held their base type's invalid value
INVALID = "\0invalid"
#: record column -> the FIT fields it is read from
_RECORD_SOURCES = {
    "lat/lon": ("position_lat", "position_long"),
    "h_msl": ("enhanced_altitude", "altitude"),
    "gnss_speed": ("enhanced_speed", "speed"),
    "heart_rate": ("heart_rate",),
    "power": ("power",),
    "gnss_sigma_h": ("gps_accuracy",),
    "cadence": ("cadence",),
    "temperature": ("temperature",),
}
G0 = 9.80665

#: sensor message -> (column prefix, field stem, calibrated unit -> SI factor, sensor_type of its calibration)
_SENSORS = {
    "accelerometer_data": ("acc", "accel", G0, 0),
    "gyroscope_data": ("gyr", "gyro", math.pi / 180.0, 1),
    "magnetometer_data": ("mag", "mag", 100.0, 2),  # gauss -> uT
}


def sniff(path: Path, head: bytes) -> bool:
    """True when the header holds the ``.FIT`` signature (bytes 8-11)."""
    return len(head) >= 12 and head[8:12] == b".FIT" and head[0] in (12, 14)


def _messages(path: Path) -> tuple[list[tuple[str, dict[str, Any]]], list[str]]:
    """Every data message as (name, {field: value}) with date_time kept as integers, and decoder quirks.

    CRC mismatches and a file cut short raise; recoverable quirks of real
    files (an invalid field size in a definition, a developer field without
    its description) are tolerated by the decoder and returned as one note.
    """
    import warnings as pywarnings

    import fitdecode  # imported here: only FIT inputs pay for it

    out: list[tuple[str, dict[str, Any]]] = []
    notes: list[str] = []
    try:
        with pywarnings.catch_warnings(record=True) as caught:
            pywarnings.simplefilter("always")
            with fitdecode.FitReader(
                str(path),
                processor=fitdecode.DataProcessorBase(),
                check_crc=fitdecode.CrcCheck.RAISE,
                error_handling=fitdecode.ErrorHandling.WARN,
            ) as fit:
                for frame in fit:
                    if frame.frame_type != fitdecode.FIT_FRAME_DATA:
                        continue
                    fields: dict[str, Any] = {}
                    invalid = []
                    for f in frame.fields:
                        if f.value is not None and f.name not in fields:
                            fields[f.name] = f.value
                        elif f.value is None and f.raw_value is None:
                            invalid.append(f.name)  # the base type's invalid value, nulled by the decoder
                    if invalid:
                        fields[INVALID] = frozenset(invalid)
                    out.append((frame.name, fields))
        if caught:
            first = str(caught[0].message).splitlines()[0] if str(caught[0].message) else "?"
            notes.append(f"{len(caught)} decoding quirk(s) tolerated (first: {first})")
    except fitdecode.FitEOFError as exc:
        raise InputError(f"{path}: FIT file is truncated ({_first_line(exc)}); expected a complete FIT file") from exc
    except fitdecode.FitCRCError as exc:
        raise InputError(f"{path}: FIT file is corrupt (CRC mismatch: {_first_line(exc)})") from exc
    except fitdecode.FitHeaderError as exc:
        raise InputError(f"{path}: not a readable FIT file ({_first_line(exc)}); expected a FIT header") from exc
    except (fitdecode.FitError, ValueError, KeyError, IndexError, struct.error) as exc:
        raise InputError(f"{path}: FIT file is corrupt ({_first_line(exc)})") from exc
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from exc
    return out, notes


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _num(v: Any) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        return math.nan
    return x if math.isfinite(x) else math.nan


def _clock_offsets(messages: list[tuple[str, dict[str, Any]]]) -> tuple[np.ndarray, np.ndarray] | None:
    """(system time [s], UTC minus system time [s]) of every usable ``timestamp_correlation`` message."""
    pairs: dict[float, float] = {}
    for name, f in messages:
        if name != "timestamp_correlation":
            continue
        ts, sys_ts = f.get("timestamp"), f.get("system_timestamp")
        if not isinstance(ts, (int, float)) or not isinstance(sys_ts, (int, float)) or ts < SYSTEM_TIME_MAX:
            continue
        utc = ts + _num(f.get("fractional_timestamp", 0.0) or 0.0)
        if "timestamp_ms" in f and "fractional_timestamp" not in f:
            utc += _num(f["timestamp_ms"]) / 1000.0
        sysv = sys_ts + _num(f.get("fractional_system_timestamp", 0.0) or 0.0)
        if "system_timestamp_ms" in f and "fractional_system_timestamp" not in f:
            sysv += _num(f["system_timestamp_ms"]) / 1000.0
        if math.isfinite(utc) and math.isfinite(sysv):
            pairs.setdefault(float(sysv), float(utc - sysv))
    if not pairs:
        return None
    keys = np.array(sorted(pairs))
    return keys, np.array([pairs[k] for k in keys])


class _Clock:
    """FIT date_time (+ fraction) -> seconds since ``ref`` (a FIT date_time), UTC where possible.

    Subtracting ``ref`` before adding fractions keeps sub-millisecond
    resolution (float64 near 1e9 s resolves only ~0.1 us steps of sums).
    """

    def __init__(self, offsets: tuple[np.ndarray, np.ndarray] | None, ref: int) -> None:
        self.offsets = offsets
        self.ref = ref
        self.uncorrected = 0

    def __call__(self, stamp: Any, frac: float = 0.0) -> float:
        if not isinstance(stamp, (int, float)):
            return math.nan
        if stamp >= SYSTEM_TIME_MAX:
            return float(stamp - self.ref) + frac
        if self.offsets is not None:
            # several correlations follow the device clock's drift (linear between them, constant outside)
            off = float(np.interp(float(stamp) + frac, self.offsets[0], self.offsets[1]))
            return float(stamp - self.ref) + (off + frac)
        self.uncorrected += 1
        return float(stamp) + frac


def _first_utc(messages: list[tuple[str, dict[str, Any]]]) -> int | None:
    """Smallest UTC ``timestamp`` of any message (FIT date_time), None if every stamp is device time."""
    stamps = [
        f["timestamp"] for _, f in messages if isinstance(f.get("timestamp"), int) and f["timestamp"] >= SYSTEM_TIME_MAX
    ]
    return min(stamps) if stamps else None


def _records(messages: list[tuple[str, dict[str, Any]]], clock: _Clock, opts: Options) -> tuple[dict, list[str]]:
    times: list[float] = []
    rows: list[dict[str, float]] = []
    nulled: dict[str, int] = {}
    for name, f in messages:
        if name != "record":
            continue
        t = clock(f.get("timestamp"))
        if not math.isfinite(t):
            continue
        row: dict[str, float] = {}
        lat, lon = _num(f.get("position_lat")), _num(f.get("position_long"))
        if math.isfinite(lat) and math.isfinite(lon):
            row["lat"], row["lon"] = lat * SEMICIRCLE_DEG, lon * SEMICIRCLE_DEG
        alt = _num(f.get("enhanced_altitude", f.get("altitude")))
        if math.isfinite(alt):
            row["h_msl"] = alt
        spd = _num(f.get("enhanced_speed", f.get("speed")))
        if math.isfinite(spd):
            row["gnss_speed"] = spd
        for src, col in (("heart_rate", "heart_rate"), ("power", "power"), ("gps_accuracy", "gnss_sigma_h")):
            v = _num(f.get(src))
            if math.isfinite(v):
                row[col] = v
        cad = _num(f.get("cadence"))
        if math.isfinite(cad):
            row["cadence"] = cad + (_num(f.get("fractional_cadence")) if "fractional_cadence" in f else 0.0)
        temp = _num(f.get("temperature"))
        if math.isfinite(temp):
            row["temperature"] = temp
        bad = f.get(INVALID)
        if bad:
            for col, srcs in _RECORD_SOURCES.items():
                if col.split("/")[0] not in row and any(k in bad for k in srcs):
                    nulled[col] = nulled.get(col, 0) + 1
        times.append(t)
        rows.append(row)
    warnings: list[str] = []
    if nulled:
        warnings.append(_invalid_line("record", nulled))
    if not rows:
        return {}, warnings
    ts = np.array(times)  # file order: ingest's time-ordering policy sorts and folds repeats (counted)
    names: list[str] = []
    for r in rows:
        names += [k for k in r if k not in names]
    cols = {k: np.array([r.get(k, math.nan) for r in rows]) for k in names}
    if "h_msl" in cols and opts.geoid_offset is not None:
        cols["h"] = cols["h_msl"] + float(opts.geoid_offset)
    return {"t": ts, **cols}, warnings


def _invalid_line(kind: str, nulled: dict[str, int]) -> str:
    """One warning naming how many values of each column held FIT's invalid marker."""
    return (
        f"invalid markers (FIT's 'invalid' value of the field's base type, e.g. 0x7FFFFFFF for a sint32 position, "
        f"0xFFFF for a uint16, 0xFF for a uint8) read as null in {kind} messages: "
        + ", ".join(f"{n} {k}" for k, n in nulled.items())
    )


#: a step of the record clock longer than this [s] is a clock jump worth a line (a day)
CLOCK_JUMP = 86400.0


def _duration(d: float) -> str:
    return f"{d / 86400:.1f} d" if abs(d) >= 86400 else f"{d / 3600:.1f} h"


def _clock_jumps(t: np.ndarray, messages: list[tuple[str, dict[str, Any]]]) -> str | None:
    """One line when the record clock jumps by a day or more (or steps back), naming the jump and the file's
    own elapsed time (``session`` ``total_elapsed_time``); None otherwise.  The times are kept as written:
    a watch whose clock was reset mid-file is reported, not silently re-based."""
    if t.size < 2:
        return None
    d = np.diff(t)
    big = np.flatnonzero(np.abs(d) >= CLOCK_JUMP)
    if big.size == 0:
        return None
    elapsed = [_num(f.get("total_elapsed_time")) for n, f in messages if n == "session"]
    elapsed = [e for e in elapsed if math.isfinite(e)]
    span = float(np.nanmax(t) - np.nanmin(t))
    first = int(big[0])
    what = (
        f"jumps {'forward' if d[first] > 0 else 'back'} by {_duration(float(abs(d[first])))} after record {first} "
        f"(t = {t[first]:.0f} s on the file's clock)"
    )
    if big.size > 1:
        what += f", and {big.size - 1} more time(s)"
    if elapsed:
        total = sum(elapsed)
        own = (
            f"while the file's own elapsed time (session total_elapsed_time) is {_duration(total)}"
            if total < span - 0.5 * CLOCK_JUMP
            else f"and the file's own elapsed time ({_duration(total)}) spans it too"
        )
    else:
        own = "(the file has no session elapsed time to compare)"
    return (
        f"the record clock {what} {own}: the device's clock was set mid-file; the timeline is kept as written "
        "(spline-smooth splits the track at the jump, no distance is counted across it)"
    )


def _calibrations(messages: list[tuple[str, dict[str, Any]]]) -> dict[int, list[tuple[int, dict[str, Any]]]]:
    """sensor_type -> [(message index, calibration fields)]."""
    cal: dict[int, list[tuple[int, dict[str, Any]]]] = defaultdict(list)
    for i, (name, f) in enumerate(messages):
        if name == "three_d_sensor_calibration":
            st = f.get("sensor_type")
            st = {"accelerometer": 0, "gyroscope": 1, "compass": 2}.get(st, st) if isinstance(st, str) else st
            if isinstance(st, int):
                cal[st].append((i, f))
    return cal


def _apply_cal(raw: np.ndarray, cal: dict[str, Any]) -> np.ndarray:
    """Counts (n, 3) -> calibrated unit via a three_d_sensor_calibration message."""
    factor = _num(cal.get("calibration_factor", cal.get("accel_cal_factor", cal.get("gyro_cal_factor"))))
    divisor = _num(cal.get("calibration_divisor"))
    shift = _num(cal.get("level_shift", 0))
    off = np.asarray(cal.get("offset_cal", (0, 0, 0)), dtype=np.float64).reshape(-1)
    mat = cal.get("orientation_matrix")
    if not (math.isfinite(factor) and math.isfinite(divisor) and divisor != 0) or off.size != 3:
        raise ValueError("incomplete calibration")
    v = (raw - shift - off) * factor / divisor
    if mat is not None and len(mat) == 9:
        # fitdecode applies the profile's scale (65535) to orientation_matrix
        m = np.asarray(mat, dtype=np.float64).reshape(3, 3)
        v = v @ m.T
    return v


def _sensor(messages: list[tuple[str, dict[str, Any]]], kind: str, clock: _Clock, cal: dict) -> tuple[dict, list[str]]:
    prefix, stem, si, sensor_type = _SENSORS[kind]
    ts: list[np.ndarray] = []
    vals: list[np.ndarray] = []
    dropped = 0
    nulled: dict[str, int] = {}
    for i, (name, f) in enumerate(messages):
        if name != kind:
            continue
        base = clock(f.get("timestamp"), _num(f.get("timestamp_ms", 0)) / 1000.0)
        offs = f.get("sample_time_offset")
        if not math.isfinite(base) or offs is None:
            dropped += 1
            continue
        offs = np.atleast_1d(np.asarray(offs, dtype=np.float64)) / 1000.0
        v = None
        if all(f"calibrated_{stem}_{a}" in f for a in "xyz"):
            v = np.column_stack([np.atleast_1d(np.asarray(f[f"calibrated_{stem}_{a}"], float)) for a in "xyz"])
        elif all(f"compressed_calibrated_{stem}_{a}" in f for a in "xyz"):
            v = np.column_stack(
                [np.atleast_1d(np.asarray(f[f"compressed_calibrated_{stem}_{a}"], float)) / 1000.0 for a in "xyz"]
            )
        elif all(f"{stem}_{a}" in f for a in "xyz"):
            prior = [c for j, c in cal.get(sensor_type, []) if j < i] or [c for _, c in cal.get(sensor_type, [])]
            raw = np.column_stack([np.atleast_1d(np.asarray(f[f"{stem}_{a}"], float)) for a in "xyz"])
            if prior:
                try:
                    v = _apply_cal(raw, prior[-1])
                except ValueError:
                    v = None
        if v is None or v.shape[0] != offs.size:
            dropped += 1
            continue
        ts.append(base + offs)
        vals.append(v * si)
        nan = np.count_nonzero(~np.isfinite(v))  # the decoder gives None (NaN here) for an invalid array element
        if nan:
            nulled[prefix] = nulled.get(prefix, 0) + int(nan)
    warnings = []
    if dropped:
        warnings.append(
            f"{dropped} {kind} message(s) dropped (raw counts without a three_d_sensor_calibration, "
            "or sample counts that do not match)"
        )
    if nulled:
        warnings.append(_invalid_line(kind, {f"{prefix}_x/y/z": n for n in nulled.values()}))
    if not ts:
        return {}, warnings
    t = np.concatenate(ts)  # file order: ingest's time-ordering policy sorts and folds repeats (counted)
    v = np.concatenate(vals)
    return {"t": t, **{f"{prefix}_{a}": v[:, k] for k, a in enumerate("xyz")}}, warnings


def read(path: Path, opts: Options) -> Recording:
    """Read a FIT file's records and 3-D sensor messages (see the module docstring)."""
    messages, warnings = _messages(path)
    ref = _first_utc(messages)
    clock = _Clock(_clock_offsets(messages), ref if ref is not None else 0)
    parts: dict[str, dict] = {}
    device_clock: list[str] = []
    rec, w = _records(messages, clock, opts)
    warnings += w
    if rec:
        parts["fit_record"] = rec
        jump = _clock_jumps(rec["t"], messages)
        if jump:
            warnings.append(jump)
    cal = _calibrations(messages)
    for kind in _SENSORS:
        before = clock.uncorrected
        data, w = _sensor(messages, kind, clock, cal)
        warnings += w
        if data:
            parts[kind.replace("_data", "")] = data
            if clock.uncorrected > before:
                device_clock.append(kind.replace("_data", ""))
    if rec and clock.uncorrected and not device_clock:
        device_clock.append("fit_record")
    if not parts:
        kinds = sorted({n for n, _ in messages})
        raise InputError(
            f"{path}: no record or sensor messages in this FIT file (it holds {', '.join(kinds) or 'nothing'}); "
            "expected an activity with records"
        )
    epoch = None
    if ref is not None and device_clock and len(device_clock) < len(parts):
        warnings.append(
            f"stream(s) {', '.join(device_clock)} dropped: stamped relative to the device's power-on and no "
            "timestamp_correlation message to put them on UTC like the rest of the file"
        )
        parts = {k: v for k, v in parts.items() if k not in device_clock}
    elif device_clock:
        warnings.append(
            "messages stamped relative to the device's power-on and no timestamp_correlation message: "
            "times are on the device clock, the recording has no absolute time"
        )
    t0 = 0.0
    if ref is not None and not (device_clock and len(device_clock) == len(parts)):
        epoch = float(ref + FIT_EPOCH)
    else:
        t0 = float(math.floor(min(float(np.min(p["t"])) for p in parts.values())))
    streams = [Stream(name, p["t"] - t0, {k: v for k, v in p.items() if k != "t"}) for name, p in parts.items()]
    meta: dict[str, Any] = {}
    for name, f in messages:
        if name == "file_id":
            for k in ("manufacturer", "product", "garmin_product", "serial_number", "type"):
                if k in f:
                    meta[f"fit_{k}"] = f[k] if isinstance(f[k], (str, int, float)) else str(f[k])
            break
    return Recording(str(path), "fit", streams, epoch, meta, warnings)
