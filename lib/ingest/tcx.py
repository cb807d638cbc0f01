"""Garmin Training Center XML (TCX) activities, read with the standard XML parser.

Structure
    ``Activities/Activity/Lap/Track/Trackpoint``; elements are matched by
    their local name, so any namespace prefix (or none) is read.  Leading
    whitespace, blank lines or a byte-order mark before the XML declaration
    (written by some exporters) are tolerated.

Columns (units), per Trackpoint
    ``lat``/``lon`` [deg] from ``Position/LatitudeDegrees``/``LongitudeDegrees``
    (null where the Trackpoint has no Position: indoor, or before the first
    fix); ``h_msl`` [m] from ``AltitudeMeters`` -- TCX altitude is above mean
    sea level, so it is never written as the ellipsoidal ``h`` (with
    ``--geoid-offset N`` also ``h`` = h_msl + N); ``heart_rate`` [1/min] from
    ``HeartRateBpm/Value``; ``cadence`` [1/min] from ``Cadence`` or the
    extension's ``RunCadence``; ``gnss_speed`` [m/s] and ``power`` [W] from
    the ActivityExtension ``TPX/Speed`` and ``TPX/Watts``.

Invalid markers (nulled, counted in one warning)
    Values the Garmin TrainingCenterDatabase v2 / ActivityExtension v2
    schemas rule out: a cadence of 255 (``CadenceValue_t`` is an
    unsignedByte of at most 254; 255 is the FIT uint8 "invalid" that some
    converters copy through), a heart rate below 1 (``HeartRateInBeatsPerMinute_t``
    has minInclusive 1: 0 is "no strap"), a latitude outside [-90, 90] or a
    longitude outside [-180, 180] deg (``DegreesLatitude_t`` /
    ``DegreesLongitude_t``: the whole Position is nulled), and a negative
    ``Speed`` (no speed).  Nothing is derived from a nulled value.

Time
    ``Time`` is ISO 8601 (``Z`` or an offset; no zone = UTC).  Trackpoints
    without a time are dropped and counted in a warning; the others stay in
    file order (ingest's one time-ordering policy sorts them and folds
    repeats, counted).
"""

from __future__ import annotations

import calendar
import datetime as dt
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream
from sportfusion.ingest import Options, Recording

#: TCX element (local name, under the Trackpoint) -> column.
_FIELDS = {
    "AltitudeMeters": "h_msl",
    "Cadence": "cadence",
    "RunCadence": "cadence",
    "Speed": "gnss_speed",
    "Watts": "power",
}


def sniff(path: Path, head: bytes) -> bool:
    """True when the head holds a ``<TrainingCenterDatabase`` element."""
    return b"TrainingCenterDatabase" in head


def _local(tag: object) -> str:
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def _float(text: str | None) -> float:
    try:
        v = float(text) if text is not None else math.nan
    except ValueError:
        return math.nan
    return v if math.isfinite(v) else math.nan


#: column -> test that a value is one of the schema's invalid markers (see the module docstring)
_INVALID = {
    "cadence": lambda v: v > 254,
    "heart_rate": lambda v: v < 1,
    "gnss_speed": lambda v: v < 0,
}


def _invalid_position(row: dict[str, float]) -> bool:
    lat, lon = row.get("lat", math.nan), row.get("lon", math.nan)
    return (math.isfinite(lat) and abs(lat) > 90.0) or (math.isfinite(lon) and abs(lon) > 180.0)


def _time(text: str) -> float | None:
    s = text.strip()
    if s.endswith(("Z", "z")):
        s = s[:-1] + "+00:00"
    try:
        t = dt.datetime.fromisoformat(s)
    except ValueError:
        return None
    if t.tzinfo is not None:
        t = t.astimezone(dt.UTC)
    return calendar.timegm(t.timetuple()) + t.microsecond / 1e6


def read(path: Path, opts: Options) -> Recording:
    """Read the Trackpoints of a TCX file into one ``tcx`` stream (see the module docstring)."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from exc
    data = data.lstrip(b"\xef\xbb\xbf \t\r\n")
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise InputError(f"{path}: not a readable TCX file ({exc}); expected Training Center XML") from exc
    times: list[float] = []
    rows: list[dict[str, float]] = []
    no_time = 0
    nulled: dict[str, int] = {}
    for tp in root.iter():
        if _local(tp.tag) != "Trackpoint":
            continue
        row: dict[str, float] = {}
        t = None
        for el in tp.iter():
            name = _local(el.tag)
            if name == "Time" and el.text:
                t = _time(el.text)
            elif name == "LatitudeDegrees":
                row["lat"] = _float(el.text)
            elif name == "LongitudeDegrees":
                row["lon"] = _float(el.text)
            elif name == "HeartRateBpm":
                row["heart_rate"] = next((_float(c.text) for c in el if _local(c.tag) == "Value"), math.nan)
            elif name in _FIELDS:
                row[_FIELDS[name]] = _float(el.text)
        row = {k: v for k, v in row.items() if math.isfinite(v)}
        if not (math.isfinite(row.get("lat", math.nan)) and math.isfinite(row.get("lon", math.nan))):
            row.pop("lat", None)
            row.pop("lon", None)
        if t is None:
            no_time += 1
            continue
        for k, bad in _INVALID.items():
            if k in row and bad(row[k]):
                del row[k]
                nulled[k] = nulled.get(k, 0) + 1
        if _invalid_position(row):
            row.pop("lat", None)
            row.pop("lon", None)
            nulled["lat/lon"] = nulled.get("lat/lon", 0) + 1
        times.append(t)
        rows.append(row)
    warnings = []
    if no_time:
        warnings.append(f"{no_time} Trackpoint(s) without a readable <Time> dropped")
    if nulled:
        warnings.append(
            "invalid markers (cadence 255, heart rate 0, negative speed, position off the globe: no value per the "
            f"TCX schema) read as null: {', '.join(f'{n} {k}' for k, n in nulled.items())}"
        )
    if not rows:
        raise InputError(f"{path}: no Trackpoint with a <Time>; expected a recorded TCX activity")
    ts = np.array(times)  # file order: ingest's time-ordering policy sorts and folds repeats (counted)
    names: list[str] = []
    for r in rows:
        names += [k for k in r if k not in names]
    cols: dict[str, object] = {k: np.array([r.get(k, math.nan) for r in rows]) for k in names}
    if "h_msl" in cols and opts.geoid_offset is not None:
        cols["h"] = cols["h_msl"] + float(opts.geoid_offset)  # type: ignore[operator]
    no_pos = int(sum("lat" not in r for r in rows))
    if no_pos:
        warnings.append(f"{no_pos} of {len(rows)} Trackpoint(s) have no Position: lat/lon null there")
    epoch = float(math.floor(ts.min()))
    sport = next((a.get("Sport") for a in root.iter() if _local(a.tag) == "Activity"), None)
    meta = {"tcx_sport": sport}
    return Recording(str(path), "tcx", [Stream("tcx", ts - epoch, cols)], epoch, meta, warnings)
