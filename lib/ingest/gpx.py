"""GPX 1.1 (and 1.0) tracks, parsed with gpxpy.

Only tracks are read (``<trk>/<trkseg>/<trkpt>``): every segment of every
track, concatenated in file order.  Routes and waypoints are not
trajectories and are ignored.  A point whose latitude or longitude is out of
range (|lat| > 90, |lon| > 180, or not a number) makes the file unreadable:
one error line names the point.

Columns (units)
    ``lat``, ``lon`` [deg].  Heights (docs/recordings-gnss.md): ``<ele>`` is
    height above mean sea level by the GPX convention -> ``h_msl`` [m].  ``h``
    [m] ellipsoidal is written only where it is known: ``<ele>`` +
    ``Options.geoid_offset`` (``--geoid-offset N``) when given, else ``<ele>``
    + the point's own ``<geoidheight>``.  A point without ``<ele>`` takes its
    height from a vendor extension element when it has one: local names
    ``altitude``/``alt``/``elevation``/``height`` are MSL (the GPX
    convention), ``ellipsoidalAltitude``/``ellipsoidalHeight``/``hae`` are
    ellipsoidal.  A track with no height at all has neither column (a 2-D
    track: ``gps2hill`` gives it ``gnss_x``/``gnss_y`` with ``gnss_z`` null).
    ``label`` (text): the ``<name>`` of the track a point belongs to (a ski app
    writes one track per 'Lift', 'Downhill', 'Hold'), written when any track
    has a name.
    ``gnss_speed`` [m/s] and ``gnss_course`` [deg] from ``<speed>``/
    ``<course>`` (GPX 1.0) or an extension element of that name (Garmin
    TrackPointExtension and the like), and then ``vel_n``/``vel_e`` [m/s]
    = speed (cos, sin)(course); a negative speed or course (-1: unknown) is
    null.  ``gnss_sigma_h`` [m] from an accuracy extension (local name
    ``accuracy``, ``hAcc``, ``horizontalAccuracy``, ...: the radius of the
    68 % circle, / 1.5096 as for the phone formats; a negative one marks an
    invalid fix, whose position is nulled) and ``gnss_sigma_v`` from
    ``vAcc``/``verticalAccuracy`` (negative: the heights are nulled); the
    spline weights each fix by them.  ``gnss_hdop`` from ``<hdop>`` (99.99
    and above: "no value", null),
    ``gnss_sats`` from ``<sat>``, ``gnss_fix`` from ``<fix>`` mapped onto
    the NMEA GGA codes: none 0, 2d 1, 3d 1, dgps 2, pps 3.

Time
    Times are absolute (UTC; times without a zone are taken as UTC).  The
    order of the points does not matter: a time that steps back or repeats
    is handled by ingest's one time-ordering policy
    (:func:`sportfusion.core.session.order_by_time`: stable sort, exact
    duplicates dropped, same-time points folded, all counted).  Points
    without a ``<time>`` get a NaN time, so the policy drops them and names
    them in a warning; when fewer than two points (or fewer than half of
    them) have a time, or all points share one time,
    :class:`~sportfusion.core.errors.InputError` names the problem and
    points to ``--no-time``.  With ``Options.no_time`` the point index is the
    time (``t`` = 0, 1, 2, ... s), the recording has no absolute time and a
    warning says so.
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

#: Extension elements (local names, any namespace, case-free) holding a fix's stated accuracy [m]: the radius
#: of the 68 % circle (Android ``getAccuracy``, iOS ``horizontalAccuracy``) and the vertical 68 % bound.
_EXT_HACC = ("accuracy", "hacc", "horizontalaccuracy", "horizontal_accuracy", "haccuracy", "hor_acc", "precision")
_EXT_VACC = ("vacc", "verticalaccuracy", "vertical_accuracy", "vaccuracy", "ver_acc")
#: Radius of the 68 % circle of a circular Gaussian, in per-axis sigmas: sqrt(-2 ln 0.32).
ACCURACY_68_TO_SIGMA = math.sqrt(-2.0 * math.log(0.32))
#: An HDOP of this or more is a "no value" marker (99.99)
HDOP_UNKNOWN = 99.0
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
    _check_range(path, lat, lon)

    if opts.no_time:
        t = np.arange(n, dtype=np.float64)
        epoch = None
        warnings.append("--no-time: t is the track point index (1 s per point); the track has no absolute time")
    else:
        t, epoch = _times(path, points)

    cols: dict[str, object] = {"lat": lat, "lon": lon}
    cols.update(_heights(points, opts, warnings))
    names = [trk.name.strip() if trk.name and trk.name.strip() else None for trk in doc.tracks]
    if any(names):
        cols["label"] = pa.array(
            [names[i] for i, trk in enumerate(doc.tracks) for seg in trk.segments for _ in seg.points],
            type=pa.string(),
        )

    speed = np.array([_first(p.speed, _extension_value(p, "speed")) for p in points], dtype=np.float64)
    course = np.array([_first(p.course, _extension_value(p, "course")) for p in points], dtype=np.float64)
    if np.isfinite(speed).any():
        cols["gnss_speed"] = speed
    if np.isfinite(course).any():
        cols["gnss_course"] = course
    if (np.isfinite(speed) & np.isfinite(course)).any():
        cols["vel_n"] = speed * np.cos(np.radians(course))
        cols["vel_e"] = speed * np.sin(np.radians(course))
    speed = np.where(speed >= 0, speed, np.nan)  # -1: unknown (iOS loggers)
    course = np.where((course >= 0) & (course < 360), course, np.nan)
    if "gnss_speed" in cols:
        cols["gnss_speed"] = speed
    if "gnss_course" in cols:
        cols["gnss_course"] = course
    if "vel_n" in cols:
        cols["vel_n"] = speed * np.cos(np.radians(course))
        cols["vel_e"] = speed * np.sin(np.radians(course))
    hdop = np.array([_first(p.horizontal_dilution) for p in points], dtype=np.float64)
    hdop = np.where((hdop > 0) & (hdop < HDOP_UNKNOWN), hdop, np.nan)
    if np.isfinite(hdop).any():
        cols["gnss_hdop"] = hdop
    hacc = np.array([_first(*(_extension_value(p, k) for k in _EXT_HACC)) for p in points], dtype=np.float64)
    vacc = np.array([_first(*(_extension_value(p, k) for k in _EXT_VACC)) for p in points], dtype=np.float64)
    if np.isfinite(hacc).any():
        bad = hacc < 0  # Core Location: a negative accuracy marks an invalid fix
        if bad.any():
            lat[bad] = lon[bad] = np.nan
            warnings.append(
                f"{int(bad.sum())} point(s) with a negative horizontal accuracy (invalid fix): position null"
            )
        cols["gnss_sigma_h"] = np.where(hacc > 0, hacc, np.nan) / ACCURACY_68_TO_SIGMA
    if np.isfinite(vacc).any():
        for k in ("h", "h_msl"):
            if k in cols:
                cols[k] = np.where(vacc < 0, np.nan, np.asarray(cols[k], float))
        cols["gnss_sigma_v"] = np.where(vacc > 0, vacc, np.nan)
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


def _check_range(path: Path, lat: np.ndarray, lon: np.ndarray) -> None:
    """InputError naming the first point whose latitude or longitude is not a valid angle."""
    bad = ~(np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) <= 90.0) & (np.abs(lon) <= 180.0))
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(
            f"{path}: track point {i} has latitude {lat[i]:g}, longitude {lon[i]:g} ({int(bad.sum())} such point(s)); "
            "expected latitude -90..90 and longitude -180..180 degrees"
        )


#: Extension elements read as a height where a point has no ``<ele>``: MSL names, ellipsoidal names.
_EXT_MSL = ("altitude", "alt", "elevation", "height")
_EXT_ELLIPSOIDAL = ("ellipsoidalaltitude", "ellipsoidalheight", "hae")


def _heights(points: list[Any], opts: Options, warnings: list[str]) -> dict[str, np.ndarray]:
    """``h_msl`` and ``h`` [m] where known (see the module docstring); no column when none is known."""
    n = len(points)
    ele = np.array([np.nan if p.elevation is None else p.elevation for p in points], dtype=np.float64)
    ext_msl = np.full(n, np.nan)
    ext_ell = np.full(n, np.nan)
    for i in np.flatnonzero(~np.isfinite(ele)):
        p = points[i]
        ext_ell[i] = _first(*(_extension_value(p, k) for k in _EXT_ELLIPSOIDAL))
        ext_msl[i] = _first(*(_extension_value(p, k) for k in _EXT_MSL))
    msl = np.where(np.isfinite(ele), ele, ext_msl)
    if opts.geoid_offset is not None:
        h = msl + float(opts.geoid_offset)
    else:
        geoid = np.array([np.nan if p.geoid_height is None else p.geoid_height for p in points])
        h = msl + geoid
    h = np.where(np.isfinite(h), h, ext_ell)
    out: dict[str, np.ndarray] = {}
    if np.isfinite(msl).any():
        out["h_msl"] = msl
        finite = msl[np.isfinite(msl)]
        if finite.size > 1 and (finite == 0.0).all():
            warnings.append("every <ele> is 0 m: the logger probably wrote no elevation")
    if np.isfinite(h).any():
        out["h"] = h
    if not out:
        warnings.append("no point has a height (<ele> or a height extension): a 2-D track, gnss_z will be null")
    elif "h" not in out:
        warnings.append(
            "<ele> is height above mean sea level (h_msl), no ellipsoidal h: for a hill frame give "
            "--geoid-offset M (geoid separation N at the site) here or to gps2hill"
        )
    return out


def _times(path: Path, points: list[Any]) -> tuple[np.ndarray, float]:
    """Seconds since the earliest point and that point's Unix time (NaN where a point has no time).

    InputError when fewer than two points have a time or all share one time.
    """
    hint = "or give --no-time to use the point index as time"
    n = len(points)
    missing = [i for i, p in enumerate(points) if p.time is None]
    timed = n - len(missing)
    if missing and (timed < 2 or timed < len(missing)):
        raise InputError(
            f"{path}: {len(missing)} of {n} track point(s) have no <time> (first: point {missing[0]}); "
            f"expected a time on every point, {hint}"
        )
    whole = np.zeros(n, dtype=np.int64)
    frac = np.full(n, np.nan)
    for i, p in enumerate(points):
        if p.time is not None:
            whole[i], frac[i] = _unix(p.time)
    timed_idx = np.flatnonzero(np.isfinite(frac))
    i0 = int(timed_idx[np.lexsort((frac[timed_idx], whole[timed_idx]))[0]])  # the earliest point is the epoch
    t = (whole - whole[i0]).astype(np.float64) + (frac - frac[i0])
    ok = np.isfinite(t)
    if timed > 1 and (t[ok] == 0.0).all():
        raise InputError(
            f"{path}: all {timed} track points have the same time {points[i0].time}; expected increasing times, {hint}"
        )
    return t, float(whole[i0]) + float(frac[i0])
