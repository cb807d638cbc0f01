"""Reference geomagnetic field from the World Magnetic Model (pygeomag).

pygeomag takes the altitude in **km** and the time as a **decimal year**, and
returns north/east/down components in **nT**; this module converts to and from
the suite's units (m, Unix seconds or ISO dates, uT).
"""

from __future__ import annotations

import calendar
import functools
import warnings
from datetime import UTC, datetime

import numpy as np

from sportfusion.core.errors import InputError

#: Epochs of the WMM coefficient sets shipped with pygeomag (each valid 5 years).
_WMM_EPOCHS = (2010, 2015, 2020, 2025)


def decimal_year(when: float | str | datetime) -> float:
    """Unix seconds, an ISO-8601 string or a datetime -> decimal year (UTC).

    ``2026-01-01T00:00Z`` is 2026.0; the fraction counts days of that year
    (365 or 366).
    """
    if isinstance(when, str):
        try:
            dt = datetime.fromisoformat(when.replace("Z", "+00:00"))
        except ValueError as exc:
            raise InputError(f"date {when!r} is not an ISO-8601 date, expected e.g. 2026-01-15") from exc
    elif isinstance(when, datetime):
        dt = when
    else:
        dt = datetime.fromtimestamp(float(when), tz=UTC)
    if dt.tzinfo is None:
        dt = dt.replace(tzinfo=UTC)
    dt = dt.astimezone(UTC)
    start = datetime(dt.year, 1, 1, tzinfo=UTC)
    days = 366 if calendar.isleap(dt.year) else 365
    return dt.year + (dt - start).total_seconds() / (days * 86400.0)


@functools.lru_cache(maxsize=8)
def _model(epoch: int):  # noqa: ANN202 - pygeomag object
    from pygeomag import GeoMag

    return GeoMag(base_year=epoch)


def reference_field(lat_deg: float, lon_deg: float, h_m: float, when: float | str | datetime) -> np.ndarray:
    """Main geomagnetic field at a site and date, NED components [uT].

    Parameters
    ----------
    lat_deg, lon_deg : float
        Geodetic latitude and longitude [deg].
    h_m : float
        Height above the WGS84 ellipsoid [m] (pygeomag wants km; converted here).
    when : float, str or datetime
        Unix seconds, ISO-8601 date/time, or a datetime (UTC).

    Returns
    -------
    numpy.ndarray, shape (3,)
        ``[north, east, down]`` field [uT] from the WMM coefficient set whose
        5-year span contains the date.

    Raises
    ------
    InputError
        For a date outside the shipped models (2010-2030) or a bad site.
    """
    year = decimal_year(when)
    if not (-90.0 <= lat_deg <= 90.0 and -180.0 <= lon_deg <= 360.0):
        raise InputError(f"site {lat_deg}, {lon_deg} is not a latitude/longitude in degrees")
    epoch = max((e for e in _WMM_EPOCHS if e <= year), default=None)
    if epoch is None or year >= _WMM_EPOCHS[-1] + 5:
        raise InputError(
            f"date {year:.2f} is outside the World Magnetic Model span 2010-2030; give the reference field instead"
        )
    lon = lon_deg - 360.0 if lon_deg > 180.0 else lon_deg
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = _model(epoch).calculate(glat=float(lat_deg), glon=float(lon), alt=float(h_m) / 1000.0, time=year)
    return np.array([res.x, res.y, res.z]) / 1000.0


def inclination_declination(field_ned: np.ndarray) -> tuple[float, float]:
    """Inclination (dip, positive down) and declination (east of north) [deg] of a NED field vector."""
    n, e, d = (float(v) for v in field_ned)
    return float(np.degrees(np.arctan2(d, np.hypot(n, e)))), float(np.degrees(np.arctan2(e, n)))


def field_from_angles(inclination_deg: float, declination_deg: float, intensity: float = 1.0) -> np.ndarray:
    """NED field vector from inclination, declination [deg] and intensity (any unit)."""
    i, d = np.deg2rad(inclination_deg), np.deg2rad(declination_deg)
    return intensity * np.array([np.cos(i) * np.cos(d), np.cos(i) * np.sin(d), np.sin(i)])
