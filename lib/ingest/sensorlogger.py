"""Sensor Logger (the phone app by Kelvin Choi) CSV exports: a ZIP, its unpacked folder, or one file.

An export holds one CSV per sensor (``Accelerometer.csv``, ``Gravity.csv``,
``TotalAcceleration.csv`` (Android), ``Gyroscope.csv``, ``Magnetometer.csv``,
``Barometer.csv``, ``Location.csv``, ...) and ``Metadata.csv`` (version,
device name, recording time, platform, appVersion, ...).  Every sensor file
starts with the columns ``time`` (integer nanoseconds since the Unix epoch,
UTC) and ``seconds_elapsed`` (seconds since the recording's start button),
then the sensor's values, e.g. ``z,y,x``.  Facts from the app's own
documentation (github.com/tszheichoi/awesome-sensor-logger: README,
UNITS.md, COORDINATES.md, CROSSPLATFORM.md).

Time
    ``time`` is read as a 64-bit integer and the session epoch (the earliest
    sample of all files) is subtracted in integer nanoseconds before anything
    becomes float64, so ``t`` keeps the nanoseconds.  Rows repeating a time
    their file already gave (the app documents sensors re-sending cached
    values) are dropped, the first kept, and counted in a warning.  A file without ``time``
    falls back to ``seconds_elapsed`` without an absolute clock (warning).

Early exports (2021, ``Metadata.csv`` version 2)
    Motion files are ``time,z,y,x`` without ``seconds_elapsed``: read from
    ``time`` alone (sniffed as Sensor Logger when ``Metadata.csv`` names a
    version and platform or device, beside files named like its sensors).
    A ``time`` column in seconds, milliseconds or microseconds (told by its
    magnitude: the unit that puts it in the years 2000-2100) is scaled to
    nanoseconds, with a warning.  On iOS the motion files and
    ``Location.csv`` were stamped on clocks hours apart: every file starts
    within seconds of the start button, so a file whose first time is more
    than 10 min from ``Location.csv``'s (else from the clock most files
    share) is shifted onto it by the difference of the first times, rounded
    to whole quarter hours when within 90 s of one (a time-zone error); one
    warning names the files, the shift and how it was found.

Specific force (``acc_x/y/z``, m/s^2, device axes x right, y up along the
screen, z out of the screen)
    ``Accelerometer.csv`` is acceleration *without* gravity on both
    platforms, so it alone is not specific force.  ``TotalAcceleration.csv``
    (Android: raw accelerometer, with gravity) is used when present; else
    ``Accelerometer + Gravity``, with gravity interpolated to the
    accelerometer's times when the two files are not stamped together
    (warning).  iOS reports both with the opposite sign (inertial-force
    convention) unless "Standardise Units & Frames" is on: then the sum is
    negated.  The platform comes from ``Metadata.csv`` (``platform``); the
    standardisation from a metadata column whose name contains ``standard``
    (true/1/yes/on).  Without a platform the Android sign is assumed
    (warning).  Gyroscope (rad/s) and magnetometer (uT) need no change.

Location
    ``latitude``/``longitude`` -> ``lat``/``lon`` [deg]; ``altitude`` -> ``h``
    (the app documents it as height above the WGS84 ellipsoid);
    ``altitudeAboveMeanSeaLevel`` (iOS) -> ``h_msl``; ``speed`` ->
    ``gnss_speed`` and ``bearing`` -> ``gnss_course`` (negative: invalid ->
    null), ``vel_n``/``vel_e`` from the two; ``horizontalAccuracy`` (radius of
    the 68 % circle) -> ``gnss_sigma_h`` = accuracy / 1.5096 as for phyphox;
    ``verticalAccuracy`` -> ``gnss_sigma_v`` (negative or zero: null).  A
    negative horizontal accuracy (iOS: the fix is invalid) nulls latitude and
    longitude, a negative vertical accuracy the heights.

``Barometer.csv`` ``pressure`` [mbar] -> ``pressure`` [Pa].  Other files
(uncalibrated sensors, orientation, compass, watch, battery, ...) are named
in one warning and not read.
"""

from __future__ import annotations

import math
import zipfile
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream
from sportfusion.ingest import Options, Recording
from sportfusion.ingest._text import decode, floats, read_delimited, read_zip_members

#: Radius of the 68 % circle of a circular Gaussian, in per-axis sigmas: sqrt(-2 ln 0.32).
ACCURACY_68_TO_SIGMA = math.sqrt(-2.0 * math.log(0.32))
#: Files read (lower-case stem -> stream name).
SENSORS = ("totalacceleration", "accelerometer", "gravity", "gyroscope", "magnetometer", "barometer", "location")
_TRUE = {"true", "1", "yes", "on", "standardised", "standardized"}


def _header(data: bytes) -> list[str]:
    line = decode(data[:1024]).lstrip().splitlines()[0] if data.strip() else ""
    return [c.strip().strip('"').lower() for c in line.split(",")]


#: value columns of the sensor files read (a 2021 export's motion files are ``time,z,y,x`` alone)
_VALUE_COLUMNS = {"x", "y", "z", "pressure", "relativealtitude", "latitude", "longitude", "altitude", "speed",
                  "bearing", "horizontalaccuracy", "verticalaccuracy", "speedaccuracy", "bearingaccuracy",
                  "altitudeabovemeansealevel"}  # fmt: skip


def _is_sensor_file(data: bytes) -> bool:
    cells = _header(data)
    return len(cells) >= 2 and cells[0] == "time" and cells[1] == "seconds_elapsed"


def _is_old_sensor_file(name: str, data: bytes) -> bool:
    """A sensor file of a 2021 export: named like a sensor, ``time`` first, then only value columns."""
    cells = _header(data)
    return (
        PurePosixPath(name).stem.lower() in SENSORS
        and len(cells) >= 2
        and cells[0] == "time"
        and all(c in _VALUE_COLUMNS or c == "seconds_elapsed" for c in cells[1:])
    )


def _is_metadata(data: bytes) -> bool:
    cells = _header(data)
    return "version" in cells and ("platform" in cells or "device name" in cells)


def _export_like(files: list[tuple[str, bytes]]) -> bool:
    """A folder's or ZIP's CSVs (name, first bytes): a sensor file, or Metadata.csv beside 2021 sensor files."""
    if any(_is_sensor_file(d) for _, d in files):
        return True
    meta = any(PurePosixPath(n).stem.lower() == "metadata" and _is_metadata(d) for n, d in files)
    return meta and any(_is_old_sensor_file(n, d) for n, d in files)


def sniff(path: Path, head: bytes) -> bool:
    """A folder or ZIP holding a CSV that starts ``time,seconds_elapsed`` (or a 2021 export: Metadata.csv and
    sensor files ``time,z,y,x``), or one such CSV."""
    if path.is_dir():
        files = []
        for p in sorted(path.glob("*.csv"))[:40]:
            try:
                with p.open("rb") as fh:
                    files.append((p.name, fh.read(1024)))
            except OSError:
                continue
        return _export_like(files)
    if head.startswith(b"PK\x03\x04"):
        try:
            with zipfile.ZipFile(path) as zf:
                names = [n for n in zf.namelist() if n.lower().endswith(".csv")][:40]
                return _export_like([(n, zf.open(n).read(1024)) for n in names])
        except (zipfile.BadZipFile, OSError):
            return False
    return _is_sensor_file(head)


def _members(path: Path) -> dict[str, tuple[str, bytes]]:
    """Lower-case file stem -> (file name, bytes) of every CSV of the export."""
    out: dict[str, tuple[str, bytes]] = {}
    try:
        if path.is_dir():
            for p in sorted(path.glob("*.csv")):
                out[p.stem.lower()] = (p.name, p.read_bytes())
        elif zipfile.is_zipfile(path):
            with zipfile.ZipFile(path) as zf:
                names = [n for n in sorted(zf.namelist()) if n.lower().endswith(".csv") and not n.endswith("/")]
                for name, data in read_zip_members(zf, names, str(path)).items():
                    out[PurePosixPath(name).stem.lower()] = (PurePosixPath(name).name, data)
        else:
            out[path.stem.lower()] = (path.name, path.read_bytes())
    except (OSError, zipfile.BadZipFile) as exc:
        raise InputError(f"cannot read {path}: {exc}") from exc
    return out


def _metadata(data: bytes) -> dict[str, str]:
    try:
        table = read_delimited(decode(data), "Metadata.csv", numeric=False)
    except InputError:
        return {}
    if table.num_rows == 0:
        return {}
    row = table.slice(0, 1).to_pylist()[0]
    return {str(k).strip(): ("" if v is None else str(v).strip()) for k, v in row.items()}


def _ns(table: pa.Table, what: str, warnings: list[str] | None = None) -> np.ndarray | None:
    """The ``time`` column as int64 nanoseconds (exact), None when the file has none."""
    if "time" not in table.column_names:
        return None
    col = table.column("time").combine_chunks()
    if col.null_count:
        i = int(np.argmax(~np.asarray(col.is_valid().to_numpy(zero_copy_only=False))))
        raise InputError(f"{what}: row {i + 2} has no time; expected integer nanoseconds on every row")
    if pa.types.is_integer(col.type):
        return col.cast(pa.int64()).to_numpy()
    if pa.types.is_string(col.type):
        try:
            return np.array([int(str(v).strip()) for v in col.to_pylist()], dtype=np.int64)
        except ValueError as exc:
            raise InputError(
                f"{what}: column 'time' is not integer nanoseconds; expected e.g. 1698501144401773000"
            ) from exc
    # a re-saved file may hold the times as floating point: nanoseconds beyond 2**53 are lost already; an
    # early export may write seconds (or ms, us) with decimals: scaled here, before anything is rounded
    v = col.cast(pa.float64()).to_numpy(zero_copy_only=False)
    scale = next((f for f in (1, 10**3, 10**6, 10**9) if v.size and _NS_2000 <= v[0] * f < _NS_2100), 1)
    if scale != 1 and warnings is not None:
        unit = {10**3: "microseconds", 10**6: "milliseconds", 10**9: "seconds"}[scale]
        warnings.append(f"{what}: 'time' is in {unit} (by its size), not nanoseconds: scaled")
    return np.round(v * scale).astype(np.int64)


#: Unix times [ns] of 2000-01-01 and 2100-01-01: a ``time`` column is absolute when it falls between
_NS_2000, _NS_2100 = 946684800 * 10**9, 4102444800 * 10**9


def _as_ns(v: np.ndarray, what: str, warnings: list[str]) -> np.ndarray:
    """``time`` values -> Unix nanoseconds: exports write nanoseconds; a file in us, ms or s (by magnitude:
    the unit that puts its first time in the years 2000-2100) is scaled, with a warning."""
    first = int(v[0]) if v.size else 0
    if v.size == 0 or _NS_2000 <= first < _NS_2100:
        return v
    for unit, f in (("microseconds", 10**3), ("milliseconds", 10**6), ("seconds", 10**9)):
        if _NS_2000 <= first * f < _NS_2100 and v.dtype.kind in "iu":
            warnings.append(f"{what}: 'time' is in {unit} (by its size), not nanoseconds: scaled")
            return v * f
    return v  # not a Unix time in any unit: the clock check below says so


def _align_clocks(ns: dict[str, np.ndarray | None], fnames: dict[str, str], warnings: list[str]) -> None:
    """Put files stamped on different clocks on the clock of ``Location.csv`` (in place), one warning.

    Early iOS exports (2021) stamped the motion files (Core Motion's clock) and ``Location.csv`` (Core
    Location's, UTC) on clocks hours apart.  Every file of a recording starts within seconds of the start
    button (a GNSS fix may take a minute), so a file whose first time is more than 10 min from the
    reference's is on another clock.  The reference is ``Location.csv`` (absolute, GNSS-disciplined),
    else the clock most files share.  Such a file is shifted by the difference of the first times; when
    that difference is within 90 s of a whole number of quarter hours (a time-zone error) it is rounded
    to it, which removes the GNSS start delay from the estimate.
    """
    have = {k: v for k, v in ns.items() if v is not None and v.size}
    if len(have) < 2:
        return
    first = {k: int(v.min()) for k, v in have.items()}
    if "location" in first:
        ref = first["location"]
        ref_name = fnames["location"]
    else:
        groups = sorted(first.values())
        ref = max(groups, key=lambda x: sum(abs(y - x) < 600 * 10**9 for y in groups))
        ref_name = "most files"
    far = {k: f for k, f in first.items() if abs(f - ref) > 600 * 10**9}
    if not far:
        return
    shifts: dict[int, list[str]] = {}
    for k, f in far.items():
        d = ref - f
        q = 900 * 10**9  # a quarter hour
        whole = round(d / q) * q
        shift = whole if abs(d - whole) <= 90 * 10**9 else d
        ns[k] = ns[k] + shift  # type: ignore[operator]
        shifts.setdefault(shift, []).append(fnames[k])
    for shift, names in shifts.items():
        sec = shift / 1e9
        how = (
            "a whole number of quarter hours (a time-zone error)"
            if shift % (900 * 10**9) == 0
            else "their first samples aligned (uncertain by the GNSS start delay)"
        )
        warnings.append(
            f"{', '.join(sorted(names))} stamped on a clock {abs(sec) / 3600:.2f} h "
            f"{'behind' if sec > 0 else 'ahead of'} {ref_name}'s: shifted by {sec:+.3f} s onto it, {how}"
        )


def _xyz(table: pa.Table, what: str) -> np.ndarray:
    missing = [a for a in "xyz" if a not in table.column_names]
    if missing:
        raise InputError(f"{what}: no column(s) {', '.join(missing)}; expected time,seconds_elapsed,z,y,x")
    return np.column_stack([floats(table, a) for a in "xyz"])


def _location(table: pa.Table, ios: bool = False) -> dict[str, object]:
    names = set(table.column_names)
    cols: dict[str, object] = {}

    def valid(name: str, positive: bool = False) -> np.ndarray:
        v = floats(table, name)
        return np.where((v > 0) if positive else (v >= 0), v, np.nan)

    for src, dst in (
        ("latitude", "lat"),
        ("longitude", "lon"),
        ("altitude", "h"),
        ("altitudeabovemeansealevel", "h_msl"),
    ):
        if src in names:
            cols[dst] = floats(table, src)
    if "speed" in names:
        cols["gnss_speed"] = valid("speed")
    if "bearing" in names:
        course = valid("bearing")
        cols["gnss_course"] = np.where(course < 360, course, np.nan)
    if "speed" in names and "bearing" in names:
        speed, course = np.asarray(cols["gnss_speed"]), np.radians(np.asarray(cols["gnss_course"]))
        course = np.where(speed == 0.0, np.where(np.isfinite(course), course, 0.0), course)
        cols["vel_n"] = speed * np.cos(course)
        cols["vel_e"] = speed * np.sin(course)
    if "horizontalaccuracy" in names:
        cols["gnss_sigma_h"] = valid("horizontalaccuracy", True) / ACCURACY_68_TO_SIGMA
        bad = ios & (floats(table, "horizontalaccuracy") < 0)  # iOS: latitude and longitude are invalid
        for c in ("lat", "lon"):
            if c in cols:
                cols[c] = np.where(bad, np.nan, np.asarray(cols[c], float))
    if "verticalaccuracy" in names:
        cols["gnss_sigma_v"] = valid("verticalaccuracy", True)
        bad = ios & (floats(table, "verticalaccuracy") < 0)  # iOS: the altitude is invalid
        for c in ("h", "h_msl"):
            if c in cols:
                cols[c] = np.where(bad, np.nan, np.asarray(cols[c], float))
    return cols


def read(path: Path, opts: Options) -> Recording:
    """Read a Sensor Logger export into one stream per sensor file (see the module docstring)."""
    members = _members(path)
    warnings: list[str] = []
    meta_raw = members.pop("metadata", None)
    info = _metadata(meta_raw[1]) if meta_raw is not None else {}
    tables: dict[str, pa.Table] = {}
    fnames = {stem: fname for stem, (fname, _) in members.items()}
    skipped: list[str] = []
    for stem, (fname, data) in members.items():
        if stem not in SENSORS or not (_is_sensor_file(data) or _is_old_sensor_file(fname, data)):
            skipped.append(fname)
            continue
        dropped: list[str] = []
        table = read_delimited(decode(data), fname, dropped=dropped)
        table = table.rename_columns([c.strip().lower() for c in table.column_names])
        if dropped:
            warnings.append(f"{fname}: column(s) {', '.join(dropped)} hold text and are not read")
        if table.num_rows:
            tables[stem] = table
    if skipped:
        warnings.append(f"not read: {', '.join(sorted(skipped))}")
    if not tables:
        raise InputError(
            f"{path}: no sensor file with rows in this Sensor Logger export; expected e.g. Accelerometer.csv, "
            "Gyroscope.csv, Location.csv starting with time,seconds_elapsed"
        )
    ns = {k: _ns(t, fnames[k], warnings) for k, t in tables.items()}
    version = info.get("version", "").strip()
    old_style = [fnames[k] for k, t in tables.items() if "seconds_elapsed" not in t.column_names]
    if old_style:
        warnings.append(
            f"{', '.join(sorted(old_style))}: no seconds_elapsed column (an early export"
            + (f", Metadata version {version}" if version else "")
            + "): times from the 'time' column alone"
        )
    for k, v in list(ns.items()):
        if v is not None:
            ns[k] = _as_ns(v, fnames[k], warnings)
    _align_clocks(ns, fnames, warnings)
    for k, v in ns.items():  # a sensor may re-send cached rows with a time it already gave: keep the first
        if v is None:
            continue
        _, first = np.unique(v, return_index=True)
        if first.size < v.size:
            keep = np.sort(first)
            warnings.append(f"{fnames[k]}: {v.size - keep.size} row(s) repeating an earlier time dropped (first kept)")
            tables[k] = tables[k].take(pa.array(keep))
            ns[k] = v[keep]
    have_ns = [v for v in ns.values() if v is not None]
    epoch_ns = min(int(v.min()) for v in have_ns) if have_ns else None
    epoch = None if epoch_ns is None else float(epoch_ns // 10**9) + (epoch_ns % 10**9) * 1e-9

    def times(stem: str) -> np.ndarray:
        v = ns[stem]
        if v is not None and epoch_ns is not None:
            return (v - epoch_ns).astype(np.float64) * 1e-9
        return floats(tables[stem], "seconds_elapsed")

    if epoch_ns is None:
        warnings.append("no 'time' column: t is seconds_elapsed, without absolute time; align it by --offset")
    elif any(v is None for v in ns.values()):
        missing = [fnames[k] for k, v in ns.items() if v is None]
        raise InputError(f"{path}: {', '.join(missing)} without a 'time' column while others have one")

    platform = info.get("platform", "").strip().lower()
    standard = any("standard" in k.lower() and v.lower() in _TRUE for k, v in info.items())
    if not platform:
        if "totalacceleration" in tables:
            platform = "android"
        elif "location" in tables and "altitudeabovemeansealevel" in tables["location"].column_names:
            platform = "ios"
    sign = -1.0 if (platform == "ios" and not standard) else 1.0

    streams: list[Stream] = []
    acc_from = None
    if "totalacceleration" in tables:
        acc = _xyz(tables["totalacceleration"], "TotalAcceleration.csv")
        streams.append(Stream("TotalAcceleration", times("totalacceleration"), _cols("acc", acc)))
        acc_from = "TotalAcceleration"
        unused = [fnames[k] for k in ("accelerometer", "gravity") if k in tables]
        if unused:
            warnings.append(f"{', '.join(unused)} not read: TotalAcceleration.csv gives the specific force")
    elif "accelerometer" in tables and "gravity" in tables:
        ta, tg = times("accelerometer"), times("gravity")
        lin = _xyz(tables["accelerometer"], "Accelerometer.csv")
        grav = _xyz(tables["gravity"], "Gravity.csv")
        if ta.size == tg.size and np.array_equal(ta, tg):
            g_at = grav
        else:
            g_at = np.column_stack([np.interp(ta, tg, grav[:, k], left=np.nan, right=np.nan) for k in range(3)])
            warnings.append("Gravity.csv is not stamped with Accelerometer.csv: gravity interpolated to its times")
        streams.append(Stream("Accelerometer", ta, _cols("acc", sign * (lin + g_at))))
        acc_from = "Accelerometer + Gravity"
    elif "accelerometer" in tables:
        warnings.append(
            "Accelerometer.csv is acceleration without gravity (not specific force) and there is no Gravity.csv "
            "or TotalAcceleration.csv: acc_x/y/z not read; record Gravity too"
        )
    if acc_from is not None and acc_from != "TotalAcceleration" and not platform:
        warnings.append("platform unknown (no Metadata.csv): acceleration taken in Android's sign convention")
    for stem, name, col in (("gyroscope", "Gyroscope", "gyr"), ("magnetometer", "Magnetometer", "mag")):
        if stem in tables:
            streams.append(Stream(name, times(stem), _cols(col, _xyz(tables[stem], f"{name}.csv"))))
    if "barometer" in tables and "pressure" in tables["barometer"].column_names:
        streams.append(
            Stream("Barometer", times("barometer"), {"pressure": floats(tables["barometer"], "pressure") * 100.0})
        )
    if "location" in tables:
        cols = _location(tables["location"], ios=platform == "ios")
        if cols:
            streams.append(Stream("Location", times("location"), cols))
    if not streams:
        raise InputError(f"{path}: no readable sensor (acceleration with gravity, gyroscope, magnetometer, location)")
    meta: dict[str, Any] = {
        "sensors": [s.name for s in streams],
        "device": {k: v for k, v in info.items() if k.lower() in ("device name", "platform", "appversion", "version")},
        "acc_from": acc_from,
        "acc_sign": sign if acc_from and acc_from != "TotalAcceleration" else 1.0,
    }
    return Recording(str(path), "sensorlogger", streams, epoch, meta, warnings)


def _cols(prefix: str, v: np.ndarray) -> dict[str, object]:
    return {f"{prefix}_{a}": v[:, k] for k, a in enumerate("xyz")}
