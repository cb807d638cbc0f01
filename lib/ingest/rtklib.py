"""RTKLIB solution files (``.pos`` from rtkpost / rnx2rtkp / rtknavi), llh or xyz output.

Header
    Lines starting with ``%``.  The column header line (the ``%`` line that
    names the position columns) gives the layout; a column's values are
    found by its name, so any column order RTKLIB writes is read:

    - time: ``GPST``, ``UTC`` or ``JST``, written either as
      ``yyyy/mm/dd hh:mm:ss.sss`` or as GPS week and seconds of week;
    - position: ``latitude(deg) longitude(deg) height(m)``, the
      degree-minute-second form ``latitude(d'") longitude(d'")`` (three
      values each, the sign on the degrees), or
      ``x-ecef(m) y-ecef(m) z-ecef(m)``;
    - ``Q ns sdn sde sdu sdne sdeu sdun age ratio`` (xyz: ``sdx sdy sdz sdxy
      sdyz sdzx``) and optionally velocity ``vn ve vu sdvn sdve sdvu ...``
      (xyz: ``vx vy vz sdvx sdvy sdvz sdvxy sdvyz sdvzx``).

    ``e-baseline(m) n-baseline(m) u-baseline(m)`` (relative to the base:
    RTKLIB's ``out-solformat=enu``), with ``sde sdn sdu sden sdnu sdue``.
    The base position comes from ``Options.base`` (``--base LAT,LON,H``) or
    the header's ``% ref pos : lat lon height`` line (degrees, or
    degree-minute-second; ellipsoidal height); without either the file is
    refused in one line naming ``--base``.  The rover is the base's ECEF
    position plus the baseline rotated back from the base's east-north-up
    (the inverse of RTKLIB's ``ecef2enu``), then geodetic (pyproj); the
    sigmas are taken in the base's east-north-up (the same axes as the
    rover's within a few km).

    The comment ``% (lat/lon/height=WGS84/ellipsoidal,...)`` or
    ``.../geodetic`` (or any ``%`` line saying ``ellipsoidal``/``geodetic``)
    tells the height: ellipsoidal (RTKLIB's default) -> ``h``; geodetic
    (above the geoid) -> ``h_msl`` with ``h`` null and a warning.
    The Tokyo datum is refused.

Time
    ``t`` is UTC.  GPST -> UTC subtracts the GPS-UTC leap seconds valid at
    that instant, from :data:`LEAP_SECONDS` (18 s since 2017-01-01; older
    files get their own count; the rule is RTKLIB's ``gpst2utc``).  JST is
    UTC + 9 h.  GPS week/seconds count from 1980-01-06 00:00:00 GPST.

Columns (units)
    ``lat``, ``lon`` [deg], ``h`` [m] (xyz is converted with pyproj, WGS84).
    ``rtk_q``: RTKLIB's Q as written; ``gnss_fix``: Q mapped onto the NMEA
    GGA codes (:data:`Q_TO_FIX`): 1 fix -> 4 (RTK fixed), 2 float -> 5 (RTK
    float), 3 sbas -> 2 (differential), 4 dgps -> 2, 5 single -> 1,
    6 ppp -> 1, 7 dead reckoning (RTKLIB demo5) -> 6.
    ``gnss_sats`` = ns.  ``gnss_sigma_n/e/v`` [m] = sdn/sde/sdu,
    ``gnss_sdne/gnss_sdeu/gnss_sdun`` [m] = sdne/sdeu/sdun (signed square
    roots of the covariances), ``gnss_sigma_h`` = sqrt((sdn^2 + sde^2)/2).
    For xyz the ECEF covariance from sdx..sdzx is rotated into local
    north-east-up at the solution to give the same columns.
    ``gnss_age`` [s] = age, ``gnss_ratio`` = ratio.
    Velocity, when present: ``vel_n`` = vn, ``vel_e`` = ve, ``vel_d`` = -vu
    [m/s], ``std_vel_n/e/d`` = sdvn/sdve/sdvu (xyz: rotated like the
    position covariance).

Invalid markers
    Q = 0 (``SOLQ_NONE``, no solution) and a position at the ECEF origin
    (the empty solution: x = y = z = 0; lat -90 deg, lon 0 deg, height
    -6378137 m in llh) null the epoch's position, velocity and sigma
    columns (``rtk_q``/``gnss_fix`` keep Q), counted in one warning.

Solution lines that do not match the header (wrong number of values, not
numbers) are skipped and counted in one warning.
"""

from __future__ import annotations

import calendar
import datetime as dt
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
from pyproj import Transformer

from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream
from sportfusion.ingest import Options, Recording

#: (UTC date from which it holds, GPS - UTC [s]), from IERS Bulletin C.
LEAP_SECONDS: tuple[tuple[dt.date, int], ...] = (
    (dt.date(1981, 7, 1), 1),
    (dt.date(1982, 7, 1), 2),
    (dt.date(1983, 7, 1), 3),
    (dt.date(1985, 7, 1), 4),
    (dt.date(1988, 1, 1), 5),
    (dt.date(1990, 1, 1), 6),
    (dt.date(1991, 1, 1), 7),
    (dt.date(1992, 7, 1), 8),
    (dt.date(1993, 7, 1), 9),
    (dt.date(1994, 7, 1), 10),
    (dt.date(1996, 1, 1), 11),
    (dt.date(1997, 7, 1), 12),
    (dt.date(1999, 1, 1), 13),
    (dt.date(2006, 1, 1), 14),
    (dt.date(2009, 1, 1), 15),
    (dt.date(2012, 7, 1), 16),
    (dt.date(2015, 7, 1), 17),
    (dt.date(2017, 1, 1), 18),
)
#: 1980-01-06 00:00:00 (start of GPS week 0) in Unix seconds.
GPS_EPOCH_UNIX = 315964800
#: RTKLIB solution quality Q -> NMEA GGA quality code.
Q_TO_FIX = {0: 0, 1: 4, 2: 5, 3: 2, 4: 2, 5: 1, 6: 1, 7: 6}
TIME_SYSTEMS = ("GPST", "UTC", "JST")
_POSITION = {"latitude(deg)": "llh", "latitude(d'\")": "dms", "x-ecef(m)": "xyz", "e-baseline(m)": "enu"}


def sniff(path: Path, head: bytes) -> bool:
    """True for ``%`` header lines naming a GPST/UTC/JST time and RTKLIB columns, or a ``.pos`` with a ``%`` header."""
    lines = [ln.strip() for ln in head.lstrip(b"\xef\xbb\xbf").decode("latin-1").splitlines() if ln.strip()]
    header = []
    for ln in lines:
        if not ln.startswith("%"):
            break
        header.append(ln)
    if not header:
        return False
    if path.suffix.lower() == ".pos":
        return True
    timed = any(re.search(r"\b(GPST|UTC|JST)\b", ln) for ln in header)
    marks = ("latitude(", "x-ecef(", "e-baseline(", "RTKPOST", "RTKLIB", "RTKNAVI", "rnx2rtkp", "obs start")
    return timed and any(m in ln for ln in header for m in marks)


def gpst_to_utc(gpst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """GPS time -> UTC, both as whole seconds counted like Unix time.

    Parameters
    ----------
    gpst : numpy.ndarray of int
        GPS time [s] as the Unix count of its calendar reading
        (``GPS_EPOCH_UNIX + week*604800 + seconds of week``).

    Returns
    -------
    utc : numpy.ndarray of int
        UTC [s since 1970-01-01 UTC].
    leap : numpy.ndarray of int
        GPS - UTC [s] applied to each element.
    """
    g = np.asarray(gpst, dtype=np.int64)
    leap = np.zeros(g.shape, dtype=np.int64)
    done = np.zeros(g.shape, dtype=bool)
    for day, n in reversed(LEAP_SECONDS):
        start = calendar.timegm(day.timetuple())
        hit = ~done & (g - n >= start)
        leap[hit] = n
        done |= hit
    return g - leap, leap


@dataclass
class _Layout:
    time_system: str
    posf: str  # llh, dms or xyz
    names: list[str]
    index: dict[str, int]  # column name -> first token index
    ntokens: int


def _name(token: str) -> str:
    return re.sub(r"\(.*\)$", "", token).strip().lower()


def _layout(path: Path, header: list[str]) -> _Layout:
    for line in header:
        tokens = line.lstrip("%").replace(",", " ").replace(";", " ").split()
        posf = next((_POSITION[t] for t in tokens if t in _POSITION), None)
        if posf is None:
            continue
        if not tokens or tokens[0] not in TIME_SYSTEMS:
            raise InputError(
                f"{path}: the column header starts with {tokens[0] if tokens else 'nothing'!r}; "
                f"expected a time column {', '.join(TIME_SYSTEMS)}"
            )
        names: list[str] = []
        index: dict[str, int] = {}
        k = 0
        for tok in tokens:
            name = "time" if tok in TIME_SYSTEMS else _name(tok)
            if posf == "dms" and name == "sdue":
                name = "sdun"  # RTKLIB labels the sixth sigma of the d'" form sdue; it is sdun
            width = 2 if name == "time" else 3 if posf == "dms" and name in ("latitude", "longitude") else 1
            names.append(name)
            index.setdefault(name, k)
            k += width
        needed = {"xyz": ("x-ecef", "y-ecef", "z-ecef"), "enu": ("e-baseline", "n-baseline", "u-baseline")}.get(
            posf, ("latitude", "longitude", "height")
        )
        missing = [n for n in (*needed, "q") if n not in index]
        if missing:
            raise InputError(
                f"{path}: the column header lacks {', '.join(missing)}; expected an RTKLIB solution header"
            )
        return _Layout(tokens[0], posf, names, index, k)
    raise InputError(
        f"{path}: no RTKLIB column header ('%  GPST  latitude(deg) longitude(deg) height(m)  Q  ns ...' or x-ecef(m)); "
        "expected a .pos file written with its header (out-outhead=on)"
    )


def _height_kind(path: Path, header: list[str]) -> str:
    for line in header:
        low = line.lower()
        if "tokyo" in low and "lat/lon/height" in low:
            raise InputError(f"{path}: the solution is in the Tokyo datum; expected WGS84 (out-datum=wgs84)")
        if "ellipsoidal" in low:
            return "ellipsoidal"
        if "geodetic" in low:
            return "geodetic"
    return "ellipsoidal"


def _seconds(text: str) -> tuple[int, float]:
    """``"59.250"`` -> (59, 0.25), exact in the whole part."""
    whole, _, frac = text.partition(".")
    if not whole.isdigit() or (frac and not frac.isdigit()):
        raise ValueError(text)
    return int(whole), float("0." + frac) if frac else 0.0


def _time(a: str, b: str) -> tuple[int, float]:
    """Two time tokens (date + clock, or week + seconds of week) -> whole seconds (Unix-like count), fraction."""
    if "/" in a:
        y, mo, d = (int(v) for v in a.split("/"))
        if y < 100:
            y += 2000 if y < 80 else 1900
        hh, mm, ss = b.split(":")
        s, frac = _seconds(ss)
        dt.date(y, mo, d)  # validates the date
        if not (0 <= int(hh) < 24 and 0 <= int(mm) < 60 and s < 61):
            raise ValueError(b)
        return calendar.timegm((y, mo, d, int(hh), int(mm), s, 0, 0, 0)), frac
    week = int(a)
    s, frac = _seconds(b)
    if not (0 <= week <= 9999 and s < 604800):
        raise ValueError(a + " " + b)
    return GPS_EPOCH_UNIX + week * 604800 + s, frac


def _number_table(tokens: list[list[str]], pos: list[int]) -> np.ndarray:
    """The tokens at positions ``pos`` of every line as a float64 table; a bad number gives NaN."""
    n, k = len(tokens), len(pos)
    try:
        flat = np.fromiter(map(float, (t[i] for t in tokens for i in pos)), dtype=np.float64, count=n * k)
        return flat.reshape(n, k)
    except ValueError:  # some token is not a number: convert one by one
        return np.array([[_float_or_nan(t[i]) for i in pos] for t in tokens], dtype=np.float64).reshape(n, k)


def _float_or_nan(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return np.nan


def _split_seconds(text: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``["59.250", ...]`` -> whole seconds (int) and fractions, exact in the whole part."""
    parts = np.char.partition(text, ".")
    if not (np.char.isdigit(parts[:, 0]).all() and np.char.isdigit(np.char.add(parts[:, 2], "0")).all()):
        raise ValueError("seconds")
    return parts[:, 0].astype(np.int64), np.char.add("0.", np.char.add(parts[:, 2], "0")).astype(np.float64)


def _times_vec(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if np.char.count(a, "/").min() == 2:  # yyyy/mm/dd hh:mm:ss.sss
        dates, inv = np.unique(a, return_inverse=True)
        day0 = np.array([_time(d, "00:00:00")[0] for d in dates], dtype=np.int64)[inv.ravel()]
        p1 = np.char.partition(b, ":")
        p2 = np.char.partition(p1[:, 2], ":")
        hh, mm = p1[:, 0].astype(np.int64), p2[:, 0].astype(np.int64)
        sec, frac = _split_seconds(p2[:, 2])
        if not ((hh >= 0) & (hh < 24) & (mm >= 0) & (mm < 60) & (sec < 61)).all():
            raise ValueError("clock")
        return day0 + hh * 3600 + mm * 60 + sec, frac
    if np.char.count(a, "/").max() == 0:  # GPS week, seconds of week
        week = a.astype(np.int64)
        sec, frac = _split_seconds(b)
        if not ((week >= 0) & (week <= 9999) & (sec < 604800)).all():
            raise ValueError("week")
        return GPS_EPOCH_UNIX + week * 604800 + sec, frac
    raise ValueError("mixed time forms")


def _times(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two time-token columns -> whole seconds (Unix-like count), fractions, mask of the valid ones."""
    n = len(a)
    if n:
        try:
            whole, frac = _times_vec(a, b)
            return whole, frac, np.ones(n, dtype=bool)
        except ValueError:
            pass  # some line is bad: parse one by one to find it
    whole, frac, ok = np.zeros(n, dtype=np.int64), np.zeros(n), np.ones(n, dtype=bool)
    for i, (x, y) in enumerate(zip(a, b, strict=True)):
        try:
            whole[i], frac[i] = _time(str(x), str(y))
        except (ValueError, IndexError):
            ok[i] = False
    return whole, frac, ok


def enu_rotation(lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
    """Rotation matrices ECEF -> local east-north-up, one per point, shape (n, 3, 3), rows e, n, u."""
    la, lo = np.radians(lat_deg), np.radians(lon_deg)
    sla, cla, slo, clo = np.sin(la), np.cos(la), np.sin(lo), np.cos(lo)
    z = np.zeros_like(la)
    return np.stack(
        [
            np.stack([-slo, clo, z], axis=-1),
            np.stack([-sla * clo, -sla * slo, cla], axis=-1),
            np.stack([cla * clo, cla * slo, sla], axis=-1),
        ],
        axis=-2,
    )


def _signed_sq(x: np.ndarray) -> np.ndarray:
    return np.sign(x) * x * x


def _signed_sqrt(x: np.ndarray) -> np.ndarray:
    return np.sign(x) * np.sqrt(np.abs(x))


def ecef_cov_to_enu(sd: np.ndarray, sdc: np.ndarray | None, lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """RTKLIB ECEF sigmas -> east-north-up covariance.

    Parameters
    ----------
    sd : numpy.ndarray, shape (n, 3)
        sdx, sdy, sdz [m or m/s].
    sdc : numpy.ndarray, shape (n, 3), or None
        sdxy, sdyz, sdzx: signed square roots of the covariances (None: zero).
    lat, lon : numpy.ndarray
        Where to rotate [deg].

    Returns
    -------
    numpy.ndarray, shape (n, 3, 3)
        Covariance in east, north, up [m^2 or m^2/s^2].
    """
    n = sd.shape[0]
    p = np.zeros((n, 3, 3))
    p[:, 0, 0], p[:, 1, 1], p[:, 2, 2] = (sd * sd).T
    if sdc is not None:
        cxy, cyz, czx = _signed_sq(sdc).T
        p[:, 0, 1] = p[:, 1, 0] = cxy
        p[:, 1, 2] = p[:, 2, 1] = cyz
        p[:, 2, 0] = p[:, 0, 2] = czx
    r = enu_rotation(lat, lon)
    return np.einsum("nij,njk,nlk->nil", r, p, r)


_ECEF_TO_LLH = "+proj=pipeline +step +inv +proj=cart +ellps=WGS84 +step +proj=unitconvert +xy_in=rad +xy_out=deg"


def ecef_to_llh(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """WGS84 ECEF [m] -> latitude, longitude [deg] and ellipsoidal height [m] (pyproj)."""
    lon, lat, h = Transformer.from_pipeline(_ECEF_TO_LLH).transform(x, y, z)
    return np.asarray(lat), np.asarray(lon), np.asarray(h)


def read(path: Path, opts: Options) -> Recording:
    """Read an RTKLIB ``.pos`` solution into one ``rtklib`` stream (see the module docstring)."""
    try:
        text = path.read_bytes().decode("utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from exc
    lines = text.lstrip("\ufeff").splitlines()
    header = [ln.strip() for ln in lines if ln.strip().startswith("%")]
    lay = _layout(path, header)
    height_kind = _height_kind(path, header) if lay.posf in ("llh", "dms") else "ellipsoidal"
    numeric = [n for n in lay.names if n != "time"]
    tokens: list[list[str]] = []
    total = 0
    for ln in lines:
        s = ln.strip()
        if not s or s[0] == "%":
            continue
        total += 1
        tok = s.replace(",", " ").replace(";", " ").split()
        if len(tok) == lay.ntokens:
            tokens.append(tok)
    ti = lay.index["time"]
    whole, frac, ok = _times(
        np.array([t[ti] for t in tokens], dtype=str), np.array([t[ti + 1] for t in tokens], dtype=str)
    )
    # token positions of the numeric values: three for a d'" latitude/longitude, one otherwise
    dms = [n for n in numeric if lay.posf == "dms" and n in ("latitude", "longitude")]
    pos = [lay.index[n] + k for n in numeric for k in (range(3) if n in dms else range(1))]
    vals = _number_table(tokens, pos)
    ok &= np.isfinite(vals).all(axis=1)
    col: dict[str, np.ndarray] = {}
    j = 0
    for name in numeric:
        if name in dms:
            d, m, sec = vals[:, j], vals[:, j + 1], vals[:, j + 2]
            sign = np.array([-1.0 if t[lay.index[name]].startswith("-") else 1.0 for t in tokens])
            col[name] = sign * (np.abs(d) + m / 60.0 + sec / 3600.0)
            j += 3
        else:
            col[name] = vals[:, j]
            j += 1
    bad = total - int(ok.sum())
    if not ok.any():
        raise InputError(
            f"{path}: no solution line matches the column header ({total} line(s), {lay.ntokens} values each expected)"
        )
    warnings: list[str] = []
    if bad:
        warnings.append(
            f"skipped {bad} of {total} solution line(s) that do not match the column header ({lay.ntokens} values expected)"
        )
    col = {k: v[ok] for k, v in col.items()}
    whole, frac = whole[ok], frac[ok]

    w = whole
    leap = np.zeros_like(w)
    if lay.time_system == "GPST":
        w, leap = gpst_to_utc(w)
    elif lay.time_system == "JST":
        w = w - 9 * 3600
    epoch = int(w.min())
    t = (w - epoch).astype(np.float64) + frac

    cols: dict[str, object] = {}
    base = None
    if lay.posf == "xyz":
        lat, lon, h = ecef_to_llh(col["x-ecef"], col["y-ecef"], col["z-ecef"])
        cols.update(lat=lat, lon=lon, h=h)
    elif lay.posf == "enu":
        base = _base(path, header, opts.base, warnings)
        enu = np.column_stack([col["e-baseline"], col["n-baseline"], col["u-baseline"]])
        lat, lon, h = enu_to_llh(enu, *base)
        cols.update(lat=lat, lon=lon, h=h)
    else:
        lat, lon = col["latitude"], col["longitude"]
        cols.update(lat=lat, lon=lon)
        if height_kind == "geodetic":
            cols["h"] = np.full(len(t), np.nan)
            cols["h_msl"] = col["height"]
            warnings.append(
                "heights are geodetic (above the geoid, as the header says): kept in h_msl, ellipsoidal h left null; "
                "write ellipsoidal heights (out-height=ellipsoidal) for h"
            )
        else:
            cols["h"] = col["height"]
    q = col["q"].astype(np.int64)
    cols["gnss_fix"] = pa.array([Q_TO_FIX.get(int(v)) for v in q], type=pa.int16())
    cols["rtk_q"] = pa.array(q, type=pa.int16())
    if "ns" in col:
        cols["gnss_sats"] = pa.array(col["ns"].astype(np.int64), type=pa.int16())
    _sigmas(col, lay.posf, lat, lon, cols)
    if "age" in col:
        cols["gnss_age"] = col["age"]
    if "ratio" in col:
        cols["gnss_ratio"] = col["ratio"]
    _null_no_solution(q, col, lay.posf, cols, warnings)

    meta: dict[str, object] = {
        **({"base": {"lat": base[0], "lon": base[1], "h": base[2]}} if base is not None else {}),
        "time_system": lay.time_system,
        "layout": lay.posf,
        "height": height_kind,
        "gps_utc_leap_s": sorted({int(v) for v in leap}),
    }
    prog = next((ln.split(":", 1)[1].strip() for ln in header if ln.lstrip("% ").startswith("program")), None)
    if prog:
        meta["program"] = prog
    return Recording(str(path), "rtklib", [Stream("rtklib", t, cols)], float(epoch), meta, warnings)


#: Heights below this [m] put the position within ~100 km of the Earth's centre: RTKLIB's empty solution
#: (ECEF 0, 0, 0) written as geodetic coordinates (lat -90 deg, lon 0 deg, height -6378137 m).
CENTRE_HEIGHT = -6.3e6
#: Columns that carry a solution's values (nulled where there is no solution); Q, ns, age, ratio stay.
_SOLUTION_COLS = (
    "lat",
    "lon",
    "h",
    "h_msl",
    "vel_n",
    "vel_e",
    "vel_d",
    "std_vel_n",
    "std_vel_e",
    "std_vel_d",
    "gnss_sigma_n",
    "gnss_sigma_e",
    "gnss_sigma_v",
    "gnss_sigma_h",
    "gnss_sdne",
    "gnss_sdeu",
    "gnss_sdun",
)


def _null_no_solution(
    q: np.ndarray, col: dict[str, np.ndarray], posf: str, cols: dict[str, object], warnings: list[str]
) -> None:
    """Null the values of epochs without a solution (in place), counted in one warning.

    RTKLIB's ``SOLQ_NONE`` (Q = 0) is "no solution"; RTKLIB itself skips such epochs when it writes a
    solution file, but other writers and edited files keep them, and an empty solution holds the ECEF
    origin (x = y = z = 0, written in llh as lat -90 deg, lon 0 deg, height -6378137 m).  Neither is a
    position; ``rtk_q``/``gnss_fix`` keep Q as written.
    """
    none = q == 0
    if posf == "xyz":
        zero = (col["x-ecef"] == 0) & (col["y-ecef"] == 0) & (col["z-ecef"] == 0)
    else:
        hh = np.asarray(cols.get("h_msl") if "h_msl" in cols else cols["h"], float)
        zero = hh < CENTRE_HEIGHT
    bad = none | zero
    if not bad.any():
        return
    for k in _SOLUTION_COLS:
        if k in cols:
            cols[k] = np.where(bad, np.nan, np.asarray(cols[k], float))
    parts = [f"{int(none.sum())} with Q = 0 (no solution)"] if none.any() else []
    if (zero & ~none).any():
        parts.append(f"{int((zero & ~none).sum())} at the Earth's centre (ECEF 0, 0, 0: an empty solution)")
    warnings.append(
        f"invalid markers read as null: {' and '.join(parts)}: position, velocity and sigmas null on "
        f"{int(bad.sum())} of {bad.size} epoch(s)"
    )


_LLH_TO_ECEF = "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad +step +proj=cart +ellps=WGS84"


def enu_to_llh(enu: np.ndarray, lat0: float, lon0: float, h0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """RTKLIB e/n/u baselines [m] from a base at (lat0, lon0 [deg], h0 [m] ellipsoidal) -> WGS84 lat, lon, h.

    RTKLIB writes ``ecef2enu(base, rover - base)``: the rover's ECEF offset rotated into the base's local
    east-north-up.  The inverse rotates back (the rotation's transpose) and adds the base's ECEF position
    (pyproj ``cart``), then converts to geodetic.
    """
    x0, y0, z0 = Transformer.from_pipeline(_LLH_TO_ECEF).transform(lon0, lat0, h0)
    r = enu_rotation(np.array([lat0]), np.array([lon0]))[0]  # rows e, n, u
    d = np.asarray(enu, float) @ r
    return ecef_to_llh(x0 + d[:, 0], y0 + d[:, 1], z0 + d[:, 2])


def _base(
    path: Path, header: list[str], given: tuple[float, float, float] | None, warnings: list[str]
) -> tuple[float, float, float]:
    """The base position (lat, lon [deg], h [m]): ``--base`` or the header's ``ref pos`` line."""
    ref = None
    for line in header:
        body = line.lstrip("%").strip()
        if body.startswith("ref pos") and ":" in body:
            try:
                v = [float(x) for x in body.split(":", 1)[1].replace(",", " ").split()]
            except ValueError:
                continue
            if len(v) == 3:
                ref = (v[0], v[1], v[2])
            elif len(v) == 7:  # d m s d m s h
                sgn = [-1.0 if x < 0 else 1.0 for x in (v[0], v[3])]
                ref = (
                    sgn[0] * (abs(v[0]) + v[1] / 60 + v[2] / 3600),
                    sgn[1] * (abs(v[3]) + v[4] / 60 + v[5] / 3600),
                    v[6],
                )
    if given is not None:
        if ref is not None and (
            abs(ref[0] - given[0]) > 1e-7 or abs(ref[1] - given[1]) > 1e-7 or abs(ref[2] - given[2]) > 1e-3
        ):
            warnings.append(
                f"--base {given[0]:.9f},{given[1]:.9f},{given[2]:.4f} used instead of the header's ref pos "
                f"{ref[0]:.9f},{ref[1]:.9f},{ref[2]:.4f}"
            )
        return given
    if ref is None:
        raise InputError(
            f"{path}: an e/n/u-baseline solution needs its base position, and the header has no 'ref pos' line; "
            "give --base LAT,LON,H (the base's WGS84 latitude, longitude [deg] and ellipsoidal height [m])"
        )
    return ref


def _sigmas(col: dict[str, np.ndarray], posf: str, lat: np.ndarray, lon: np.ndarray, cols: dict[str, object]) -> None:
    """Fill the sigma and velocity columns from either layout."""
    if posf == "xyz":
        if all(k in col for k in ("sdx", "sdy", "sdz")):
            sd = np.column_stack([col["sdx"], col["sdy"], col["sdz"]])
            sdc = np.column_stack([col[k] for k in ("sdxy", "sdyz", "sdzx")]) if "sdzx" in col else None
            q = ecef_cov_to_enu(sd, sdc, lat, lon)
            sn, se, su = np.sqrt(q[:, 1, 1]), np.sqrt(q[:, 0, 0]), np.sqrt(q[:, 2, 2])
            cols.update(gnss_sigma_n=sn, gnss_sigma_e=se, gnss_sigma_v=su)
            cols["gnss_sigma_h"] = np.sqrt((sn * sn + se * se) / 2.0)
            if sdc is not None:
                cols["gnss_sdne"] = _signed_sqrt(q[:, 1, 0])
                cols["gnss_sdeu"] = _signed_sqrt(q[:, 0, 2])
                cols["gnss_sdun"] = _signed_sqrt(q[:, 2, 1])
        if all(k in col for k in ("vx", "vy", "vz")):
            r = enu_rotation(lat, lon)
            enu = np.einsum("nij,nj->ni", r, np.column_stack([col["vx"], col["vy"], col["vz"]]))
            cols.update(vel_n=enu[:, 1], vel_e=enu[:, 0], vel_d=-enu[:, 2])
            if all(k in col for k in ("sdvx", "sdvy", "sdvz")):
                sd = np.column_stack([col["sdvx"], col["sdvy"], col["sdvz"]])
                sdc = np.column_stack([col[k] for k in ("sdvxy", "sdvyz", "sdvzx")]) if "sdvzx" in col else None
                qv = ecef_cov_to_enu(sd, sdc, lat, lon)
                cols.update(
                    std_vel_n=np.sqrt(qv[:, 1, 1]), std_vel_e=np.sqrt(qv[:, 0, 0]), std_vel_d=np.sqrt(qv[:, 2, 2])
                )
        return
    if all(k in col for k in ("sdn", "sde", "sdu")):
        sn, se = col["sdn"], col["sde"]
        cols.update(gnss_sigma_n=sn, gnss_sigma_e=se, gnss_sigma_v=col["sdu"])
        cols["gnss_sigma_h"] = np.sqrt((sn * sn + se * se) / 2.0)
    for k in ("sdne", "sdeu", "sdun"):
        if k in col:
            cols[f"gnss_{k}"] = col[k]
    for src, k in (("sden", "sdne"), ("sdue", "sdeu"), ("sdnu", "sdun")):  # e/n/u-baseline names (same values)
        if posf == "enu" and src in col:
            cols[f"gnss_{k}"] = col[src]
    if all(k in col for k in ("vn", "ve", "vu")):
        cols.update(vel_n=col["vn"], vel_e=col["ve"], vel_d=-col["vu"])
    for src, dst in (("sdvn", "std_vel_n"), ("sdve", "std_vel_e"), ("sdvu", "std_vel_d")):
        if src in col:
            cols[dst] = col[src]
