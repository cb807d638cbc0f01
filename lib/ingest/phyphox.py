"""phyphox CSV exports: a ZIP, an unpacked folder, or one set's CSV file.

An export holds one ``<set>.csv`` per data set plus ``meta/time.csv`` and
``meta/device.csv``.  Each set becomes one stream named after its file.

Dialects
    Separator comma, tab or semicolon with a decimal point, or tab or
    semicolon with a decimal comma: detected per file
    (:func:`sportfusion.ingest._text.dialect`), never assumed.  ``NaN``
    cells (and empty ones) are nulls.

Headers, matched by meaning (case, spacing and unit spelling free)
    ``Time``/``t`` -> time [s]; ``Acceleration x`` (the "with g" set: specific
    force) -> ``acc_x`` [m/s^2]; ``Gyroscope x`` / ``Angular velocity x`` /
    ``Rotation rate x`` -> ``gyr_x`` [rad/s]; ``Magnetic field x`` ->
    ``mag_x`` [uT]; ``Pressure`` -> ``pressure`` [Pa, from hPa];
    ``Latitude``/``Longitude`` -> ``lat``/``lon`` [deg]; ``Altitude WGS84``
    (or ``Height WGS84``) -> ``h`` [m] ellipsoidal; ``Altitude``/``Height``
    -> ``h_msl`` [m]; ``Speed``/``Velocity`` -> ``gnss_speed`` [m/s];
    ``Direction``/``Course``/``Heading`` -> ``gnss_course`` [deg];
    ``vel_n``/``vel_e`` = speed (cos, sin)(course); ``Horizontal Accuracy`` ->
    ``gnss_sigma_h`` = accuracy / 1.5096 (the platforms report the radius of
    the 68 % circle; a circular Gaussian with per-axis sigma s has that radius
    at s sqrt(-2 ln 0.32) = 1.5096 s); ``Vertical Accuracy`` ->
    ``gnss_sigma_v`` (a 68 % one-dimensional bound, ~1 sigma); ``Satellites``
    -> ``gnss_sats``.  Invalid markers are nulls: a negative speed or course
    (iOS writes -1 for unknown, also in custom experiments' ``GPS.csv``), a
    course outside [0, 360) deg, an accuracy of 0 (not reported); a negative
    horizontal accuracy (iOS: the fix is invalid) nulls the latitude and
    longitude, a negative vertical accuracy the heights; one warning counts
    them.  Units in the headers are converted (deg/s, mT, mbar,
    km/h, ...).  Derived columns (``Absolute ...``, ``Distance``) are not
    read.  ``Linear Acceleration x`` (without g) is not specific force: such a
    set is skipped with a warning.  A set with no known column is skipped
    with a warning naming its headers.

iOS dialect
    Experiments made in the iOS app from sensors ("simple experiments",
    phyphox-ios ``SimpleExperimentSerializer.swift``) write axis-only headers
    ``X (m/s^2)``, ``X (rad/s)``, ``X (µT)``, ``X (hPa)`` in sets named
    ``Accelerometer``, ``Linear Accelerometer``, ``Gyroscope``,
    ``Magnetometer``, ``Barometer``; the unit says which sensor it is, a set
    name with "linear" is linear acceleration.  Their Location set labels
    ``Vertical Accuracy (°)`` although the value is in metres (the app's own
    view shows it with unit m): read as metres, with a warning.

Never sunk by one quirk
    A column holding text is left out and named in a warning; a set that
    cannot be read at all (no time column, not a table) is skipped with a
    warning when the export has other sets.

Clock
    Set times are seconds of experiment time.  ``meta/time.csv`` rows
    (``START``/``PAUSE`` with the system's Unix time) map experiment time to
    UTC: a sample at experiment time ``e`` after the START row
    ``(e_i, s_i)`` is at UTC ``s_i + (e - e_i)``.  The system time text
    (``2023-04-19 13:09:38.397 UTC+02:00``) is used when it has a zone and
    agrees with the number within 1.5 s, because phyphox writes the number
    with ten significant digits (whole seconds).  The recording's epoch is
    the first START.  Without ``meta/time.csv`` the export has no absolute
    time (warning) and ``t`` is experiment time.
"""

from __future__ import annotations

import datetime as dt
import math
import re
import zipfile
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream
from sportfusion.ingest import Options, Recording
from sportfusion.ingest._text import UNITS, decode, floats, read_delimited, read_zip_members, split_header, unit_factor

#: Radius of the 68 % circle of a circular Gaussian, in per-axis sigmas: sqrt(-2 ln 0.32).
ACCURACY_68_TO_SIGMA = math.sqrt(-2.0 * math.log(0.32))

#: (name pattern, column, unit of the column); the first match wins.
RULES: tuple[tuple[re.Pattern[str], str, str], ...] = tuple(
    (re.compile(p), c, u)
    for p, c, u in (
        (r"^(time|t)$", "t", "s"),
        (r"^linear acceleration ([xyz])$", "linear", ""),
        (r"^(absolute|abs\b|distance)", "derived", ""),
        (r"^acceleration ([xyz])$", "acc_{}", "m/s^2"),
        (r"^(?:gyroscope|angular velocity|rotation rate|gyro) ([xyz])$", "gyr_{}", "rad/s"),
        (r"^(?:magnetic field|magnetometer|magnetic flux density) ([xyz])$", "mag_{}", "uT"),
        (r"^(?:pressure|air pressure)$", "pressure", "Pa"),
        (r"^latitude$", "lat", "deg"),
        (r"^longitude$", "lon", "deg"),
        # phyphox's Location "Height (m)" is its buffer z, height above mean sea level on both platforms;
        # its buffer zwgs84 is ellipsoidal.  Android (phyphox/phyphox-android,
        # app/src/main/java/de/rwth_aachen/phyphox/GpsInput.java): z = Location.getAltitude() (WGS84
        # ellipsoid) minus the EGM84 geoid height of its GpsGeoid, zwgs84 = getAltitude().  iOS
        # (phyphox/phyphox-ios, ExperimentGPSInput.swift): z = CLLocation.altitude (mean sea level),
        # zwgs84 = z + GpsGeoid height.  So Height -> h_msl, Height WGS84 -> h.
        (r"^(?:altitude|height) ?\(?(?:wgs ?84|ellipsoidal)\)?$", "h", "m"),
        (r"^(?:altitude|height)$", "h_msl", "m"),
        (r"^(?:speed|velocity)$", "gnss_speed", "m/s"),
        (r"^(?:direction|course|heading|bearing)$", "gnss_course", "deg"),
        (r"^horizontal accuracy$", "gnss_sigma_h", "m"),
        (r"^vertical accuracy$", "gnss_sigma_v", "m"),
        (r"^(?:satellites|sats)$", "gnss_sats", "1"),
    )
)
_TEXT_TIME = re.compile(r"(\d{4}-\d{2}-\d{2})[ T](\d{2}:\d{2}:\d{2}(?:\.\d+)?)\s*(?:UTC|GMT)?\s*([+-]\d{2}:?\d{2}|Z)")


def match_header(header: str) -> tuple[str, str, str] | None:
    """Column name, its unit and the unit written in a phyphox header; None when unknown."""
    name, unit = split_header(header)
    for pat, col, target in RULES:
        m = pat.match(name)
        if m:
            return (col.format(m.group(m.lastindex)) if "{}" in col else col), target, unit
    return None


def _first_cell(data: bytes) -> str:
    line = decode(data[:512]).lstrip().splitlines()[0] if data.strip() else ""
    return re.split(r"[,;\t]", line, maxsplit=1)[0].strip().strip('"')


def _looks_like_set(data: bytes) -> bool:
    cell = _first_cell(data)
    return bool(cell) and split_header(cell)[0] in ("time", "t") and "(" in cell


def _head(p: Path) -> bytes:
    try:
        with p.open("rb") as fh:
            return fh.read(512)
    except OSError:
        return b""


def sniff(path: Path, head: bytes) -> bool:
    """ZIP/folder with ``meta/time.csv`` or a set CSV, or one CSV whose first header is ``Time (s)``."""
    if path.is_dir():
        if (path / "meta" / "time.csv").is_file():
            return True
        return any(_looks_like_set(_head(p)) for p in sorted(path.glob("*.csv"))[:20])
    if head.startswith(b"PK\x03\x04"):
        try:
            with zipfile.ZipFile(path) as zf:
                names = [n for n in zf.namelist() if n.lower().endswith(".csv")]
                if any(n.endswith("meta/time.csv") for n in names):
                    return True
                return any(_looks_like_set(zf.open(n).read(512)) for n in names[:20])
        except (zipfile.BadZipFile, OSError):
            return False
    return head.lstrip(b"\xef\xbb\xbf").startswith(b'"') and _looks_like_set(head)


def _members(path: Path) -> dict[str, bytes]:
    """Relative POSIX path -> bytes of every CSV of the export."""
    out: dict[str, bytes] = {}
    try:
        if path.is_dir():
            for p in sorted(path.rglob("*.csv")):
                out[p.relative_to(path).as_posix()] = p.read_bytes()
        elif zipfile.is_zipfile(path):
            with zipfile.ZipFile(path) as zf:
                names = [n for n in sorted(zf.namelist()) if n.lower().endswith(".csv") and not n.endswith("/")]
                out.update(read_zip_members(zf, names, str(path)))
        else:
            out[path.name] = path.read_bytes()
            meta = path.parent / "meta"
            for p in sorted(meta.glob("*.csv")) if meta.is_dir() else []:
                out[f"meta/{p.name}"] = p.read_bytes()
    except (OSError, zipfile.BadZipFile) as exc:
        raise InputError(f"cannot read {path}: {exc}") from exc
    return out


def _is_meta(name: str) -> bool:
    parts = PurePosixPath(name).parts
    return len(parts) >= 2 and parts[-2].lower() == "meta"


def _parse_text_time(text: str) -> float | None:
    m = _TEXT_TIME.search(text or "")
    if not m:
        return None
    zone = m.group(3)
    zone = "+00:00" if zone == "Z" else (zone if ":" in zone else zone[:3] + ":" + zone[3:])
    try:
        return dt.datetime.fromisoformat(f"{m.group(1)}T{m.group(2)}{zone}").timestamp()
    except ValueError:
        return None


def _clock(data: bytes, what: str, warnings: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Experiment times and Unix times of the START rows of ``meta/time.csv``."""
    table = read_delimited(decode(data), what, numeric=False)
    if table.num_columns < 3 or table.num_rows == 0:
        raise InputError(f"{what}: expected rows event, experiment time, system time[, system time text]")
    names = table.column_names
    events = [str(v or "").strip().upper() for v in table.column(names[0]).to_pylist()]
    exp = floats(table, names[1])
    sys_ = floats(table, names[2])
    texts = table.column(names[3]).to_pylist() if len(names) > 3 else [None] * len(events)
    e_out, s_out = [], []
    for ev, e, s, txt in zip(events, exp, sys_, texts, strict=True):
        if ev != "START":
            continue
        from_text = _parse_text_time(str(txt)) if txt is not None else None
        if from_text is not None and (not np.isfinite(s) or abs(from_text - s) <= 1.5):
            s = from_text
        elif from_text is not None:
            warnings.append(f"{what}: system time {s} and its text {txt!r} disagree; the number is used")
        if np.isfinite(e) and np.isfinite(s):
            e_out.append(float(e))
            s_out.append(float(s))
    if not e_out:
        raise InputError(f"{what}: no START row with an experiment time and a system time; expected START rows")
    order = np.argsort(e_out, kind="stable")
    return np.asarray(e_out)[order], np.asarray(s_out)[order]


def _device(data: bytes, what: str) -> dict[str, Any]:
    try:
        table = read_delimited(decode(data), what, numeric=False)
    except InputError:
        return {}
    if table.num_columns < 2:
        return {}
    keys = table.column(0).to_pylist()
    vals = table.column(1).to_pylist()
    return {str(k): (v if isinstance(v, (int, float)) else str(v)) for k, v in zip(keys, vals, strict=True) if k}


#: An axis-only header (``X (m/s^2)``, the iOS "simple experiment" sets) -> sensor by the unit's quantity.
_AXIS_ONLY = re.compile(r"^([xyz])$")
_QUANTITY = {"m/s^2": "acc", "rad/s": "gyr", "uT": "mag", "Pa": "pressure"}


def _axis_header(header: str, set_name: str) -> tuple[str, str, str] | None:
    """``X (m/s^2)`` in set ``Accelerometer`` -> ``("acc_x", "m/s^2", "m/s^2")``; None when not such a header.

    The unit says which sensor it is (m/s^2, rad/s, uT, hPa and the units that
    convert to them); a set whose name says "linear" is linear acceleration.
    """
    name, unit = split_header(header)
    m = _AXIS_ONLY.match(name)
    if not m or not unit:
        return None
    canon = UNITS.get(unit, (None,))[0]
    kind = _QUANTITY.get(canon or "")
    if kind is None:
        return None
    if kind == "acc" and "linear" in set_name.lower():
        return "linear", "", unit
    if kind == "pressure":
        return ("pressure", "Pa", unit) if m.group(1) == "x" else None
    return f"{kind}_{m.group(1)}", canon or "", unit


def _set_stream(name: str, data: bytes, warnings: list[str]) -> Stream | None:
    """One set's CSV -> a stream of the columns it has (None when nothing is known).

    A column holding text (an auxiliary column some experiments add) is left
    out with a warning naming it; the rest of the set is read.
    """
    dropped: list[str] = []
    table = read_delimited(decode(data), name, dropped=dropped)
    if dropped:
        warnings.append(f"{name}: column(s) {', '.join(dropped)} hold text, not numbers: not read")
    stem = PurePosixPath(name).stem
    mapped: dict[str, tuple[str, str, str]] = {}
    unknown: list[str] = []
    for header in table.column_names:
        hit = match_header(header) or _axis_header(header, stem)
        if hit is None:
            unknown.append(header)
        elif hit[0] == "linear":
            warnings.append(
                f"{name}: linear acceleration (without g) is not specific force and is not read; "
                "export the 'Acceleration with g' experiment for acc_x/y/z"
            )
            return None
        elif hit[0] != "derived" and hit[0] not in {v[0] for v in mapped.values()}:
            mapped[header] = hit
    time_header = next((h for h, v in mapped.items() if v[0] == "t"), None)
    if time_header is None:
        raise InputError(f"{name}: no time column (headers {', '.join(table.column_names)}); expected 'Time (s)'")
    if len(mapped) == 1:
        warnings.append(f"{name}: no known column ({', '.join(unknown)}); set not read")
        return None
    if unknown:
        warnings.append(f"{name}: column(s) {', '.join(unknown)} not read")
    t = floats(table, time_header) * unit_factor(mapped[time_header][2] or "s", "s", f"{name}: {time_header}")
    bad = ~np.isfinite(t)
    if bad.any():
        raise InputError(f"{name}: row {int(np.argmax(bad)) + 2} has no time (NaN); expected a time on every row")
    cols: dict[str, object] = {}
    for header, (col, target, unit) in mapped.items():
        if col == "t":
            continue
        v = floats(table, header)
        if col in ("gnss_sigma_h", "gnss_sigma_v"):
            if unit in ("°", "deg"):  # iOS writes "Vertical Accuracy (°)" for a value in metres
                warnings.append(f"{name}: {header!r} read as metres (phyphox labels this accuracy with a wrong unit)")
                unit = "m"
            v = v * unit_factor(unit or "m", "m", f"{name}: {header}")
            cols["_acc_h" if col == "gnss_sigma_h" else "_acc_v"] = v.copy()  # the sign marks invalid fixes
            if col == "gnss_sigma_h":
                v = v / ACCURACY_68_TO_SIGMA
            v = np.where(v > 0, v, np.nan)  # 0 means "not reported"
        elif col == "gnss_sats":
            v = pa.array(np.where(np.isfinite(v), v, 0).astype(np.int64), mask=~np.isfinite(v)).cast(pa.int16())
        else:
            v = v * unit_factor(unit or target, target, f"{name}: {header}")
        cols[col] = v
    _null_invalid_location(cols, name, warnings)
    if "gnss_speed" in cols and "gnss_course" in cols:
        speed, course = np.asarray(cols["gnss_speed"]), np.radians(np.asarray(cols["gnss_course"]))
        course = np.where(speed == 0.0, np.where(np.isfinite(course), course, 0.0), course)
        cols["vel_n"] = speed * np.cos(course)
        cols["vel_e"] = speed * np.sin(course)
    stem = PurePosixPath(name).stem
    return Stream(stem, t, cols)


def _null_invalid_location(cols: dict[str, object], name: str, warnings: list[str]) -> None:
    """Null the platforms' invalid markers in a Location set (in place), counted in one warning.

    iOS (Core Location, which phyphox-ios writes through) reports -1 for an unknown speed and course and a
    negative accuracy for an invalid fix: a negative horizontal accuracy means latitude and longitude are
    invalid, a negative vertical accuracy that the altitude is.  Android writes 0 for an accuracy it does not
    have.  A speed below 0, a course outside [0, 360) deg, and a non-positive accuracy are no values.
    """
    nulled: list[str] = []

    def drop(col: str, bad: np.ndarray) -> None:
        if col in cols and bad.any():
            v = np.array(cols[col], dtype=float)
            n = int(np.count_nonzero(bad & np.isfinite(v)))
            v[bad] = np.nan
            cols[col] = v
            if n:
                nulled.append(f"{n} {col}")

    if "gnss_speed" in cols:
        sp = np.asarray(cols["gnss_speed"], float)
        drop("gnss_speed", sp < 0)
    if "gnss_course" in cols:
        c = np.asarray(cols["gnss_course"], float)
        drop("gnss_course", (c < 0) | (c >= 360))
    for acc, what in (("_acc_h", ("lat", "lon")), ("_acc_v", ("h", "h_msl"))):
        if acc in cols:
            bad = np.asarray(cols.pop(acc), float) < 0
            for col in what:
                drop(col, bad)
    if nulled:
        warnings.append(
            f"{name}: invalid markers (negative speed, course or accuracy: unknown) read as null: {', '.join(nulled)}"
        )


def read(path: Path, opts: Options) -> Recording:
    """Read a phyphox CSV export into one stream per set (see the module docstring)."""
    members = _members(path)
    warnings: list[str] = []
    meta_files = {PurePosixPath(n).name.lower(): d for n, d in members.items() if _is_meta(n)}
    sets = {n: d for n, d in members.items() if not _is_meta(n)}
    if not sets:
        raise InputError(f"{path}: no set CSV in this phyphox export; expected e.g. Accelerometer.csv")
    streams = []
    for n, d in sets.items():
        try:
            st = _set_stream(n, d, warnings)
        except InputError as exc:
            if len(sets) == 1:
                raise
            warnings.append(f"set not read: {exc}")
            continue
        if st is not None:
            streams.append(st)
    if not streams:
        raise InputError(
            f"{path}: none of the sets ({', '.join(sets)}) has a known column; expected acceleration with g, "
            "gyroscope, magnetometer, location or pressure"
        )
    epoch = None
    if "time.csv" in meta_files:
        e, s = _clock(meta_files["time.csv"], "meta/time.csv", warnings)
        epoch = float(s[0])
        for st in streams:
            i = np.clip(np.searchsorted(e, st.t, side="right") - 1, 0, e.size - 1)
            st.t = (s[i] - epoch) + (st.t - e[i])
    else:
        warnings.append(
            "no meta/time.csv: the export has no absolute time, t is experiment time; "
            "align it with other inputs by --offset NAME=SECONDS"
        )
    meta: dict[str, Any] = {"sets": [st.name for st in streams]}
    if "device.csv" in meta_files:
        meta["device"] = _device(meta_files["device.csv"], "meta/device.csv")
    return Recording(str(path), "phyphox", streams, epoch, meta, warnings)
