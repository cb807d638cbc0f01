"""Geodesy: WGS84 <-> local NED <-> a local (hill) frame rotated by an azimuth.

Frames (``docs/frames.md``; ski-jumping paper §3.3.1)
--------------------------------------------------------------------
* NED: origin at a geodetic point ``(lat0, lon0, h0)``, axes north, east, down
  [m], exact: WGS84 geodetic -> ECEF in closed form and the topocentric rotation
  (ellipsoidal heights) -- what pyproj's ``cart`` + ``topocentric`` pipeline
  computes, done in numpy for the forward direction; the inverse uses that
  pyproj pipeline (input lon, lat, h; it returns E, N, U; NED = (N, E, -U)).
* local / hill frame: the NED frame turned about the down axis by the azimuth
  ``psi`` (clockwise from north to the frame's x axis): x forward, y right,
  z down.  The ski-jumping hill frame is this frame with the origin at the
  take-off edge and ``psi = psi_N`` (eqs 30-31).  The NED <-> local rotation
  is done in one place, :func:`sportfusion.core.rotations.ned_to_local` /
  :func:`sportfusion.core.rotations.local_to_ned`, re-exported here.

The paper's small-area formulas (eqs 27-29) are available as
``method="paper"``.  Measured against pymap3d (``bench/bench_gps2hill.py``,
points within +-50 m of the origin's height, Oberstdorf HS106 origin) the
largest 3D difference is 1.3 mm at 100 m from the origin, 11 mm at 300 m,
13 cm at 1 km and 3.1 m at 5 km, growing with the square of the distance: the
vertical part is the Earth's curvature drop ``d^2 / 2R`` (7 mm at 300 m) and the
horizontal part comes mostly from using ``cos(mu0)`` instead of ``cos(mu)`` in
eq 28 (9 mm at 300 m).  Over a ski jump (a few hundred metres) that is below
GNSS noise; the exact pipeline (agreeing with pymap3d to ~1e-8 m) is the default.

Gravity: :func:`normal_gravity` (WGS84 Somigliana with the free-air
correction, ``docs/frames.md``) from :mod:`sportfusion.core.gravity`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.gravity import normal_gravity
from sportfusion.core.rotations import local_to_ned, ned_to_local
from sportfusion.core.session import with_columns
from sportfusion.core.stats import median

if TYPE_CHECKING:  # imported where used: a command that never calls it does not pay the import
    from pyproj import Transformer

__all__ = [
    "Frame",
    "AXES",
    "GNSS_COLUMNS",
    "HEIGHT_REFS",
    "Heights",
    "track_heights",
    "auto_origin",
    "METHODS",
    "geodetic_to_ned",
    "ned_to_geodetic",
    "geodetic_to_ned_paper",
    "ned_to_geodetic_paper",
    "geodetic_to_local",
    "local_to_geodetic",
    "m_no",
    "rotate_horizontal_sigmas",
    "gnss_local_columns",
    "gnss_to_frame",
    "local_to_ned",
    "ned_to_local",
    "normal_gravity",
]

#: Axis description written into the ``frame`` metadata.
AXES = "x forward, y right, z down"
#: Columns gps2hill needs: latitude [deg], longitude [deg]; heights come from ``h`` / ``h_msl`` where present.
GNSS_COLUMNS = ("lat", "lon")
#: Height references of a frame (``frame.height_ref``) and of ``gnss_z``: WGS84 ellipsoidal heights,
#: heights above mean sea level (a local frame on an MSL-only track, ``--origin auto``), or none (a 2-D
#: track: ``gnss_z`` null).  A hill frame is always ellipsoidal.
HEIGHT_REFS = ("ellipsoidal", "msl", "none")
#: Geodetic -> NED methods: the exact pyproj pipeline, or the paper's eqs 27-29.
METHODS = ("pyproj", "paper")

#: WGS84 ellipsoid (paper Table 2).
WGS84_A = 6378137.0
WGS84_E2 = 0.0818191908426**2


@dataclass(frozen=True)
class Frame:
    """A local frame: origin ``(lat [deg], lon [deg], h [m] ellipsoidal)`` and azimuth of x [deg]."""

    lat: float
    lon: float
    h: float
    azimuth_deg: float = 0.0
    name: str = "local"
    height_ref: str = "ellipsoidal"

    def __post_init__(self) -> None:
        vals = (self.lat, self.lon, self.h, self.azimuth_deg)
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in vals):
            raise InputError(f"frame origin/azimuth must be finite numbers, got {vals}")
        if not -90 <= self.lat <= 90 or not -180 <= self.lon <= 360:
            raise InputError(f"frame origin ({self.lat}, {self.lon}) is not a latitude/longitude in degrees")
        if self.height_ref not in HEIGHT_REFS:
            raise InputError(
                f"frame height reference {self.height_ref!r} is unknown, expected {', '.join(HEIGHT_REFS)}"
            )

    @property
    def origin(self) -> tuple[float, float, float]:
        return (float(self.lat), float(self.lon), float(self.h))

    def to_meta(self) -> dict[str, Any]:
        """The ``frame`` metadata entry: name, origin, azimuth_deg, axes, height_ref (see :data:`HEIGHT_REFS`)."""
        return {
            "name": self.name,
            "origin": list(self.origin),
            "azimuth_deg": float(self.azimuth_deg),
            "axes": AXES,
            "height_ref": self.height_ref,
        }

    @classmethod
    def from_meta(cls, frame: Mapping[str, Any]) -> Frame:
        """Frame from a table's ``frame`` metadata."""
        lat, lon, h = frame["origin"]
        ref = str(frame.get("height_ref", "ellipsoidal"))
        return cls(float(lat), float(lon), float(h), float(frame["azimuth_deg"]), str(frame.get("name", "local")), ref)

    def from_geodetic(
        self, lat: np.ndarray, lon: np.ndarray, h: np.ndarray, method: str = "pyproj"
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """WGS84 -> this frame's ``(x, y, z)`` [m]; see :func:`geodetic_to_local`."""
        return geodetic_to_local(lat, lon, h, self.origin, self.azimuth_deg, method)

    def to_geodetic(
        self, x: np.ndarray, y: np.ndarray, z: np.ndarray, method: str = "pyproj"
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """This frame's ``(x, y, z)`` -> WGS84 ``(lat, lon, h)``; see :func:`local_to_geodetic`."""
        return local_to_geodetic(x, y, z, self.origin, self.azimuth_deg, method)


@functools.lru_cache(maxsize=32)
def _topocentric(lat0: float, lon0: float, h0: float) -> Transformer:
    from pyproj import Transformer

    return Transformer.from_pipeline(
        "+proj=pipeline +step +proj=cart +ellps=WGS84 "
        f"+step +proj=topocentric +ellps=WGS84 +lat_0={lat0!r} +lon_0={lon0!r} +h_0={h0!r}"
    )


def _arrays(*vals: Any) -> list[np.ndarray]:
    return [np.asarray(v, dtype=float) for v in np.broadcast_arrays(*vals)]


def geodetic_to_ned(
    lat: np.ndarray, lon: np.ndarray, h: np.ndarray, origin: tuple[float, float, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """WGS84 geodetic -> NED about ``origin`` (exact: the closed-form geodetic -> ECEF conversion and the
    topocentric rotation, the computation of pyproj's ``cart`` + ``topocentric`` pipeline, in numpy so that a
    command does not import pyproj; equal to pyproj to ~1e-9 m, ``tests/test_frames.py``).

    Parameters
    ----------
    lat, lon : array
        Geodetic latitude and longitude [deg].
    h : array
        Ellipsoidal height [m].
    origin : (lat0 [deg], lon0 [deg], h0 [m])
        Origin of the NED frame.

    Returns
    -------
    n, e, d : arrays [m]
        NaN where an input is NaN.
    """
    lat, lon, h = _arrays(lat, lon, h)
    x, y, z = _ecef(np.radians(lat), np.radians(lon), h)
    p0, l0 = math.radians(float(origin[0])), math.radians(float(origin[1]))
    x0, y0, z0 = _ecef(p0, l0, float(origin[2]))
    dx, dy, dz = x - x0, y - y0, z - z0
    sp, cp, sl, cl = math.sin(p0), math.cos(p0), math.sin(l0), math.cos(l0)
    n = -sp * cl * dx - sp * sl * dy + cp * dz
    e = -sl * dx + cl * dy
    d = -(cp * cl * dx + cp * sl * dy + sp * dz)
    return n, e, d


def _ecef(lat: Any, lon: Any, h: Any) -> tuple[Any, Any, Any]:
    """WGS84 geodetic (lat, lon [rad], h [m]) -> Earth-centred Earth-fixed (X, Y, Z) [m] (closed form)."""
    s, c = np.sin(lat), np.cos(lat)
    nu = WGS84_A / np.sqrt(1.0 - _E2 * s * s)  # prime-vertical radius of curvature
    return (nu + h) * c * np.cos(lon), (nu + h) * c * np.sin(lon), (nu * (1.0 - _E2) + h) * s


_F = 1.0 / 298.257223563  # WGS84 flattening (PROJ's ellps=WGS84)
_E2 = _F * (2.0 - _F)  # first eccentricity squared, from the flattening as PROJ derives it


def ned_to_geodetic(
    n: np.ndarray, e: np.ndarray, d: np.ndarray, origin: tuple[float, float, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """NED about ``origin`` [m] -> WGS84 ``(lat [deg], lon [deg], h [m])`` (inverse of :func:`geodetic_to_ned`)."""
    n, e, d = _arrays(n, e, d)
    lon, lat, h = _topocentric(*map(float, origin)).transform(e, n, -d, direction="INVERSE")
    return np.asarray(lat, float), np.asarray(lon, float), np.asarray(h, float)


def _radii(lat0_deg: float) -> tuple[float, float]:
    """Meridian and prime-vertical radii of curvature ``M, N`` [m] at ``lat0`` (paper Table 2)."""
    s2 = math.sin(math.radians(lat0_deg)) ** 2
    w = 1 - WGS84_E2 * s2
    return WGS84_A * (1 - WGS84_E2) / w**1.5, WGS84_A / math.sqrt(w)


def geodetic_to_ned_paper(
    lat: np.ndarray, lon: np.ndarray, h: np.ndarray, origin: tuple[float, float, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """WGS84 -> NED by the paper's small-area formulas, eqs 27-29.

    ``x_O = (M + h)(mu - mu0)``, ``y_O = (N + h) cos(mu0)(lambda - lambda0)``,
    ``z_O = -(h - h0)`` with angles in radians and ``M, N`` at ``mu0``
    (Table 2).  Units as :func:`geodetic_to_ned`.
    """
    lat, lon, h = _arrays(lat, lon, h)
    lat0, lon0, h0 = map(float, origin)
    M, N = _radii(lat0)
    n = (M + h) * np.radians(lat - lat0)
    e = (N + h) * math.cos(math.radians(lat0)) * np.radians(lon - lon0)
    return n, e, -(h - h0)


def ned_to_geodetic_paper(
    n: np.ndarray, e: np.ndarray, d: np.ndarray, origin: tuple[float, float, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact inverse of :func:`geodetic_to_ned_paper` (eqs 27-29 solved for lat, lon, h)."""
    n, e, d = _arrays(n, e, d)
    lat0, lon0, h0 = map(float, origin)
    M, N = _radii(lat0)
    h = h0 - d
    lat = lat0 + np.degrees(n / (M + h))
    lon = lon0 + np.degrees(e / ((N + h) * math.cos(math.radians(lat0))))
    return lat, lon, h


def m_no(azimuth_deg: float) -> np.ndarray:
    """Eq 31: the 3x3 matrix taking NED coordinates into the local frame (``r_N = M_NO r_O``).

    Built from :func:`sportfusion.core.rotations.ned_to_local` so the rotation lives in one place.
    """
    return ned_to_local(np.eye(3), azimuth_deg).T


def _check_method(method: str) -> None:
    if method not in METHODS:
        raise InputError(f"method {method!r} is unknown; expected one of {', '.join(METHODS)}")


def geodetic_to_local(
    lat: np.ndarray,
    lon: np.ndarray,
    h: np.ndarray,
    origin: tuple[float, float, float],
    azimuth_deg: float,
    method: str = "pyproj",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """WGS84 -> local frame (x along ``azimuth_deg``, y right, z down) [m], eqs 27-31.

    Parameters
    ----------
    lat, lon : array
        Geodetic latitude and longitude [deg].
    h : array
        Ellipsoidal height [m].
    origin : (lat0 [deg], lon0 [deg], h0 [m])
        Frame origin (the take-off edge for a hill).
    azimuth_deg : float
        Azimuth of the x axis, clockwise from north [deg] (``psi_N``).
    method : {"pyproj", "paper"}
        Exact topocentric pipeline (default) or the small-area eqs 27-29.
    """
    _check_method(method)
    to_ned = geodetic_to_ned if method == "pyproj" else geodetic_to_ned_paper
    n, e, d = to_ned(lat, lon, h, origin)
    loc = ned_to_local(np.stack([n, e, d], axis=-1), azimuth_deg)
    return loc[..., 0], loc[..., 1], loc[..., 2]


def local_to_geodetic(
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    origin: tuple[float, float, float],
    azimuth_deg: float,
    method: str = "pyproj",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Local frame ``(x, y, z)`` [m] -> WGS84 ``(lat [deg], lon [deg], h [m])``; inverse of :func:`geodetic_to_local`."""
    _check_method(method)
    x, y, z = _arrays(x, y, z)
    ned = local_to_ned(np.stack([x, y, z], axis=-1), azimuth_deg)
    from_ned = ned_to_geodetic if method == "pyproj" else ned_to_geodetic_paper
    return from_ned(ned[..., 0], ned[..., 1], ned[..., 2], origin)


def rotate_horizontal_sigmas(
    sigma_n: np.ndarray, sigma_e: np.ndarray, azimuth_deg: float, cov_ne: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """North/east 1-sigma [m] (and covariance [m^2]) -> x/y 1-sigma [m] of the rotated frame.

    ``Sigma_xy = R Sigma_ne R^T`` with ``R`` the upper 2x2 of :func:`m_no`;
    ``cov_ne`` defaults to 0 (uncorrelated north and east errors).
    """
    sn, se = _arrays(sigma_n, sigma_e)
    cne = np.zeros_like(sn) if cov_ne is None else np.asarray(cov_ne, dtype=float)
    cov = np.zeros(sn.shape + (3, 3))
    cov[..., 0, 0] = sn**2
    cov[..., 1, 1] = se**2
    cov[..., 0, 1] = cov[..., 1, 0] = cne
    R = m_no(azimuth_deg)
    out = R @ cov @ R.T
    return np.sqrt(out[..., 0, 0]), np.sqrt(out[..., 1, 1])


@dataclass
class Heights:
    """The heights of a GNSS track as :func:`track_heights` found them.

    Attributes
    ----------
    ellipsoidal : numpy.ndarray
        WGS84 ellipsoidal height per row [m], NaN where unknown.
    msl : numpy.ndarray
        Height above mean sea level per row [m] (``h_msl``), NaN where unknown.
    ref : str
        Best reference of the track, one of :data:`HEIGHT_REFS`.
    geoid_offset_m : float or None
        Geoid separation N [m] used to turn ``h_msl`` into ``h`` (None: not used).
    geoid_source : str or None
        Where N came from: ``"--geoid-offset"`` or ``"receiver"`` (median of ``h - h_msl`` over
        the rows that have both, i.e. the receiver's own geoid separation).
    """

    ellipsoidal: np.ndarray
    msl: np.ndarray
    ref: str
    geoid_offset_m: float | None = None
    geoid_source: str | None = None


def track_heights(table: pa.Table, geoid_offset: float | None = None) -> Heights:
    """Ellipsoidal heights of a track from ``h`` and ``h_msl``, never mixing the two silently.

    ``h`` (ellipsoidal) is used where it has a value.  Rows with only ``h_msl``
    get ``h = h_msl + N`` with ``N`` = ``geoid_offset`` [m] when given, else the
    receiver's own separation (median of ``h - h_msl`` where a row has both,
    e.g. NMEA GGA fixes with and without the separation field).  Without
    either, such rows have no ellipsoidal height and the track's reference is
    ``"msl"`` (if no row has ``h``) - never ``h_msl`` passed off as ``h``.

    Parameters
    ----------
    table : pyarrow.Table
        Session with ``h`` and/or ``h_msl`` [m] (either may be missing).
    geoid_offset : float, optional
        Geoid separation N at the site [m] (``h = h_msl + N``).
    """
    n = table.num_rows
    h = schema.floats(table, "h") if "h" in table.column_names else np.full(n, np.nan)
    msl = schema.floats(table, "h_msl") if "h_msl" in table.column_names else np.full(n, np.nan)
    if geoid_offset is not None and not math.isfinite(geoid_offset):
        raise InputError(f"geoid offset {geoid_offset} is not a finite number of metres")
    only_msl = ~np.isfinite(h) & np.isfinite(msl)
    both = np.isfinite(h) & np.isfinite(msl)
    offset, source = None, None
    if only_msl.any() and geoid_offset is not None:
        offset, source = float(geoid_offset), "--geoid-offset"
    elif only_msl.any() and both.any():
        offset, source = float(median(h[both] - msl[both])), "receiver"
    if offset is not None:
        h = np.where(only_msl, msl + offset, h)
    ref = "ellipsoidal" if np.isfinite(h).any() else ("msl" if np.isfinite(msl).any() else "none")
    return Heights(h, msl, ref, offset, source)


def auto_origin(table: pa.Table, heights: Heights | None = None) -> tuple[float, float, float, str]:
    """``--origin auto``: the first fix of the track as the frame origin.

    The first row (in time) with ``lat`` and ``lon`` - and a valid fix
    (``gnss_fix`` > 0) where the table has ``gnss_fix`` - and a height of the
    track's best reference (:func:`track_heights`): ellipsoidal, else MSL; a
    2-D track takes height 0 m (reference ``"none"``; the horizontal scale
    error of that choice is h/R, 0.03 % at 2000 m).

    Returns
    -------
    lat, lon : float
        Origin [deg].
    h : float
        Origin height [m] in the reference returned.
    ref : str
        One of :data:`HEIGHT_REFS`.
    """
    hts = heights if heights is not None else track_heights(table)
    lat, lon = schema.floats(table, "lat"), schema.floats(table, "lon")
    ok = np.isfinite(lat) & np.isfinite(lon)
    if "gnss_fix" in table.column_names:
        fix = schema.floats(table, "gnss_fix")
        if (ok & (fix > 0)).any():
            ok &= fix > 0
    z = {"ellipsoidal": hts.ellipsoidal, "msl": hts.msl, "none": np.zeros(lat.shape)}[hts.ref]
    with_h = ok & np.isfinite(z)
    if not with_h.any():
        raise InputError("no row has both lat and lon; expected GNSS fixes for --origin auto")
    i = int(np.argmax(with_h))
    return float(lat[i]), float(lon[i]), float(z[i]), hts.ref


def gnss_local_columns(
    table: pa.Table, frame: Frame, method: str = "pyproj", geoid_offset: float | None = None
) -> dict[str, np.ndarray]:
    """GNSS columns of a session in a local frame (what ``gps2hill`` adds).

    Parameters
    ----------
    table : pyarrow.Table
        Session with ``lat lon`` [deg] and heights ``h`` (ellipsoidal) and/or
        ``h_msl`` [m] (null where the receiver gave no fix; see
        :func:`track_heights`) and optionally sigmas: ``gnss_sigma_n
        gnss_sigma_e`` [m] (with ``gnss_sdne``, RTKLIB's signed square root of
        the north-east covariance [m]), else ``gnss_sigma_h`` [m, per axis];
        ``gnss_sigma_v`` [m].
    frame : Frame
        Target frame.  Its ``height_ref`` decides which heights are used:
        ``"ellipsoidal"`` needs ellipsoidal heights (MSL-only tracks are
        refused, naming ``--geoid-offset``); ``"msl"`` uses ``h_msl``;
        ``"none"`` (or a track without any height) gives ``gnss_z`` null and
        places every fix at the origin's height for x and y.
    method : {"pyproj", "paper"}
        See :func:`geodetic_to_local`.
    geoid_offset : float, optional
        Geoid separation N [m] for rows with only ``h_msl`` (``h = h_msl + N``).

    Returns
    -------
    dict
        ``gnss_x gnss_y gnss_z`` [m] (NaN -> null where lat/lon (or the
        height) is null), and ``std_gnss_x std_gnss_y`` / ``std_gnss_z`` [m]
        where the sigmas exist.  Horizontal sigmas are rotated by the azimuth
        (per-axis ``gnss_sigma_h`` is rotation invariant); the vertical sigma
        carries over to z.  Velocities are not touched (``vel_n vel_e vel_d`` stay NED).
    """
    schema.require_columns(table, GNSS_COLUMNS, "gps2hill (WGS84 latitude and longitude)")
    lat, lon = (schema.floats(table, c) for c in ("lat", "lon"))
    if not (np.isfinite(lat) & np.isfinite(lon)).any():
        raise InputError("no row has both lat and lon; expected GNSS fixes to convert")
    hts = track_heights(table, geoid_offset)
    two_d = frame.height_ref == "none" or hts.ref == "none"
    if two_d:
        h = np.full(lat.shape, frame.h)
    elif frame.height_ref == "msl":
        if not np.isfinite(hts.msl).any():
            raise InputError(
                "the frame's heights are above mean sea level but the table has no h_msl; "
                "expected heights above mean sea level (or give --origin auto)"
            )
        h = hts.msl
    elif hts.ref == "msl":
        n_msl = int(np.isfinite(hts.msl).sum())
        raise InputError(
            f"the track has heights above mean sea level only (h_msl, {n_msl} rows) and the frame's origin is "
            "ellipsoidal; give --geoid-offset M (geoid separation N at the site, h = h_msl + N) or --origin auto"
        )
    else:
        h = hts.ellipsoidal
    ok = np.isfinite(lat) & np.isfinite(lon) & np.isfinite(h)
    x = np.full(lat.shape, np.nan)
    y, z = x.copy(), x.copy()
    x[ok], y[ok], z[ok] = frame.from_geodetic(lat[ok], lon[ok], h[ok], method)
    if two_d:
        z[:] = np.nan
    out = {"gnss_x": x, "gnss_y": y, "gnss_z": z}
    names = set(table.column_names)
    sx = sy = None
    if "gnss_sigma_h" in names:
        sx = schema.floats(table, "gnss_sigma_h")
        sy = sx.copy()
    if {"gnss_sigma_n", "gnss_sigma_e"} <= names:
        sn, se = schema.floats(table, "gnss_sigma_n"), schema.floats(table, "gnss_sigma_e")
        cne = None
        if "gnss_sdne" in names:
            sd = np.nan_to_num(schema.floats(table, "gnss_sdne"))
            cne = np.sign(sd) * sd**2
        rx, ry = rotate_horizontal_sigmas(sn, se, frame.azimuth_deg, cne)
        have = np.isfinite(rx) & np.isfinite(ry)
        sx = rx if sx is None else np.where(have, rx, sx)
        sy = ry if sy is None else np.where(have, ry, sy)
    if sx is not None:
        out["std_gnss_x"], out["std_gnss_y"] = sx, sy
    if "gnss_sigma_v" in names and not two_d:
        out["std_gnss_z"] = schema.floats(table, "gnss_sigma_v")
    return out


#: Local-frame estimate columns whose meaning depends on the frame.
_FRAME_BOUND = ("x", "y", "z", "vx", "vy", "vz", "ax", "ay", "az")


def gnss_to_frame(
    table: pa.Table,
    meta: dict[str, Any],
    frame: Frame,
    method: str = "pyproj",
    hill_meta: dict[str, Any] | None = None,
    geoid_offset: float | None = None,
) -> tuple[pa.Table, dict[str, Any]]:
    """``gps2hill``: add the GNSS columns in ``frame`` and record the frame in the metadata.

    Columns from :func:`gnss_local_columns` are added (replacing earlier
    ones); every other column, ``vel_n vel_e vel_d`` included, passes through.
    ``meta["frame"]`` becomes ``frame.to_meta()`` plus ``gnss_z_ref`` (the
    height reference of ``gnss_z``: ``"none"`` for a 2-D track) and, where
    ``h_msl`` was turned into ``h``, ``geoid_offset_m`` and ``geoid_source``;
    ``meta["hill"]`` the hill's metadata when one is given.  ``geoid_offset``
    [m]: see :func:`track_heights`.

    Raises
    ------
    InputError
        No lat/lon/h columns or fixes, or the table already holds estimates
        (``x y z ...``) in a different frame.
    """
    old = meta.get("frame")
    if old is not None and any(c in table.column_names for c in _FRAME_BOUND):
        same = np.allclose(old["origin"], frame.origin, rtol=0, atol=1e-9) and math.isclose(
            float(old["azimuth_deg"]), frame.azimuth_deg, abs_tol=1e-9
        )
        if not same:
            raise InputError(
                f"the table already holds estimates in frame origin {old['origin']}, azimuth {old['azimuth_deg']} deg; "
                "converting GNSS into another frame would mix frames, expected the same --origin/--azimuth"
            )
    cols = gnss_local_columns(table, frame, method, geoid_offset)
    out = with_columns(table, cols)
    new_meta = dict(meta)
    new_meta["frame"] = frame.to_meta()
    hts = track_heights(table, geoid_offset)
    new_meta["frame"]["gnss_z_ref"] = "none" if hts.ref == "none" else frame.height_ref
    if hts.geoid_offset_m is not None and frame.height_ref == "ellipsoidal":
        new_meta["frame"]["geoid_offset_m"] = hts.geoid_offset_m
        new_meta["frame"]["geoid_source"] = hts.geoid_source
    if hill_meta is not None:
        new_meta["hill"] = hill_meta
    return out, new_meta
