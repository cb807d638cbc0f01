"""GPX 1.1 (and 1.0) tracks, parsed with gpxpy.

Only tracks are read (``<trk>/<trkseg>/<trkpt>``): every segment of every
track, concatenated in file order.  Routes and waypoints are not
trajectories and are ignored.

Columns (units)
    ``lat``, ``lon`` [deg]; ``h_msl`` [m] = ``<ele>`` (GPX elevations are
    heights above mean sea level); ``h`` [m] ellipsoidal = ``<ele>`` +
    ``Options.geoid_offset`` (``--geoid-offset N``) when given, else
    ``<ele>`` + the point's own ``<geoidheight>`` when it has one, else null
    with one warning (a point without ``<ele>`` has both null).
    ``gnss_speed`` [m/s] and ``gnss_course`` [deg] from ``<speed>``/
    ``<course>`` (GPX 1.0) or an extension element of that name (Garmin
    TrackPointExtension and the like), and then ``vel_n``/``vel_e`` [m/s]
    = speed (cos, sin)(course).  ``gnss_hdop`` from ``<hdop>``,
    ``gnss_sats`` from ``<sat>``, ``gnss_fix`` from ``<fix>`` mapped onto
    the NMEA GGA codes: none 0, 2d 1, 3d 1, dgps 2, pps 3.

Time
    Every point needs a ``<time>``; times must increase (a repeated time is
    accepted only for an exact repeat of the previous point, e.g. where two
    segments meet; the merge folds it into one row).  Points without time,
    all points at one time, or a time going backwards raise
    :class:`~sportfusion.core.errors.InputError` naming the problem and pointing
    to ``--no-time``.  With ``Options.no_time`` the point index is the time
    (``t`` = 0, 1, 2, ... s), the recording has no absolute time and a
    warning says so.  Times without a zone are taken as UTC.
"""

from __future__ import annotations

import calendar
import datetime as dt
import math
from pathlib import Path
from typing import Any

import gpxpy
import gpxpy.gpx
import numpy as np
import pyarrow as pa

from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream
from sportfusion.ingest import Options, Recording

#: GPX ``<fix>`` -> NMEA GGA quality code.
FIX_TO_QUALITY = {"none": 0, "2d": 1, "3d": 1, "3": 1, "dgps": 2, "pps": 3}


def sniff(path: Path, head: bytes) -> bool:
    """True when the head holds a ``<gpx`` element."""
    return b"<gpx" in head


def _extension_value(point: Any, name: str) -> float | None:
    """First numeric extension element whose local name is ``name`` (any namespace, any depth)."""
    for ext in point.extensions or []:
        for el in ext.iter():
            tag = el.tag.rsplit("}", 1)[-1] if isinstance(el.tag, str) else ""
            if tag.lower() == name and el.text and el.text.strip():
                try:
                    v = float(el.text)
                except ValueError:
                    continue
                if math.isfinite(v):
                    return v
    return None


def _unix(t: dt.datetime) -> tuple[int, float]:
    """Whole Unix seconds and the fraction of a second of a datetime (naive = UTC)."""
    if t.tzinfo is not None:
        t = t.astimezone(dt.UTC)
    return calendar.timegm(t.timetuple()), t.microsecond / 1e6


def read(path: Path, opts: Options) -> Recording:
    """Read the track points of a GPX file into one ``gpx`` stream (see the module docstring)."""
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from exc
    try:
        doc = gpxpy.parse(text)
    except (gpxpy.gpx.GPXException, ValueError, TypeError, AttributeError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{path}: not a readable GPX file ({msg}); expected GPX 1.1 XML") from exc
    points = [p for trk in doc.tracks for seg in trk.segments for p in seg.points]
    if not points:
        nrte = sum(len(r.points) for r in doc.routes)
        raise InputError(
            f"{path}: no track points (<trk><trkseg><trkpt>); found {nrte} route point(s) and "
            f"{len(doc.waypoints)} waypoint(s), which are not read; expected a recorded track"
        )
    warnings: list[str] = []
    n = len(points)
    lat = np.array([p.latitude for p in points], dtype=np.float64)
    lon = np.array([p.longitude for p in points], dtype=np.float64)
    ele = np.array([np.nan if p.elevation is None else p.elevation for p in points], dtype=np.float64)

    if opts.no_time:
        t = np.arange(n, dtype=np.float64)
        epoch = None
        warnings.append("--no-time: t is the track point index (1 s per point); the track has no absolute time")
    else:
        t, epoch = _times(path, points, lat, lon, ele)

    cols: dict[str, object] = {"lat": lat, "lon": lon}
    has_ele = bool(np.isfinite(ele).any())
    if has_ele:
        cols["h_msl"] = ele
        if opts.geoid_offset is not None:
            h = ele + float(opts.geoid_offset)
        else:
            geoid = np.array([np.nan if p.geoid_height is None else p.geoid_height for p in points])
            h = ele + geoid
            missing = int((np.isfinite(ele) & ~np.isfinite(geoid)).sum())
            if missing:
                warnings.append(
                    f"<ele> is height above mean sea level: h (ellipsoidal) left null at {missing} of {n} point(s); "
                    "give --geoid-offset M (geoid separation N at the site) for ellipsoidal h"
                )
        cols["h"] = h
        finite = ele[np.isfinite(ele)]
        if finite.size > 1 and (finite == 0.0).all():
            warnings.append("every <ele> is 0 m: the logger probably wrote no elevation")
    else:
        cols["h_msl"] = ele
        cols["h"] = np.full(n, np.nan)
        warnings.append("no point has an <ele>: h and h_msl are null")

    speed = np.array([_first(p.speed, _extension_value(p, "speed")) for p in points], dtype=np.float64)
    course = np.array([_first(p.course, _extension_value(p, "course")) for p in points], dtype=np.float64)
    if np.isfinite(speed).any():
        cols["gnss_speed"] = speed
    if np.isfinite(course).any():
        cols["gnss_course"] = course
    if (np.isfinite(speed) & np.isfinite(course)).any():
        cols["vel_n"] = speed * np.cos(np.radians(course))
        cols["vel_e"] = speed * np.sin(np.radians(course))
    hdop = np.array([_first(p.horizontal_dilution) for p in points], dtype=np.float64)
    if np.isfinite(hdop).any():
        cols["gnss_hdop"] = hdop
    sats = [p.satellites for p in points]
    if any(s is not None for s in sats):
        cols["gnss_sats"] = pa.array(sats, type=pa.int16())
    fixes = [FIX_TO_QUALITY.get(str(p.type_of_gpx_fix).strip().lower()) if p.type_of_gpx_fix else None for p in points]
    if any(f is not None for f in fixes):
        cols["gnss_fix"] = pa.array(fixes, type=pa.int16())

    meta = {
        "creator": doc.creator,
        "gpx_version": doc.version,
        "tracks": len(doc.tracks),
        "segments": sum(len(trk.segments) for trk in doc.tracks),
    }
    return Recording(str(path), "gpx", [Stream("gpx", t, cols)], epoch, meta, warnings)


def _first(*values: float | None) -> float:
    for v in values:
        if v is not None and math.isfinite(float(v)):
            return float(v)
    return math.nan


def _times(
    path: Path, points: list[Any], lat: np.ndarray, lon: np.ndarray, ele: np.ndarray
) -> tuple[np.ndarray, float]:
    """Seconds since the first point and that point's Unix time; InputError for unusable times."""
    hint = "or give --no-time to use the point index as time"
    n = len(points)
    missing = [i for i, p in enumerate(points) if p.time is None]
    if missing:
        raise InputError(
            f"{path}: {len(missing)} of {n} track point(s) have no <time> (first: point {missing[0]}); "
            f"expected a time on every point, {hint}"
        )
    whole, frac = zip(*(_unix(p.time) for p in points), strict=True)
    w = np.array(whole, dtype=np.int64)
    f = np.array(frac, dtype=np.float64)
    t = (w - w[0]).astype(np.float64) + (f - f[0])
    if n > 1 and (t == t[0]).all():
        raise InputError(
            f"{path}: all {n} track points have the same time {points[0].time}; expected increasing times, {hint}"
        )
    step = np.diff(t)
    same = np.zeros(n - 1, dtype=bool)
    if n > 1:
        same_ele = (ele[1:] == ele[:-1]) | (np.isnan(ele[1:]) & np.isnan(ele[:-1]))
        same = (lat[1:] == lat[:-1]) & (lon[1:] == lon[:-1]) & same_ele
    bad = (step < 0) | ((step == 0) & ~same)
    if bad.any():
        i = int(np.argmax(bad)) + 1
        raise InputError(
            f"{path}: track point {i} at {points[i].time} is not later than point {i - 1} at {points[i - 1].time}; "
            f"expected increasing times, {hint}"
        )
    return t - t[0], float(w[0]) + float(f[0])
