"""Write simulated sensor data as the raw files real devices produce.

These writers let the whole pipeline be exercised from raw recordings:
a phyphox CSV export (ZIP) for the phone's IMU and magnetometer, and an
NMEA 0183 log for a GPS logger.  They follow the formats described in
``docs/formats.md`` (phyphox comma dialect, quoted headers, numbers
like ``9.810000000E0``; GGA/RMC/GST sentences with checksums).
"""

from __future__ import annotations

import io
import zipfile
from datetime import UTC, datetime
from functools import reduce
from pathlib import Path

import numpy as np
import pyarrow as pa

PHYPHOX_SETS = {
    "Accelerometer": (
        "Acceleration x (m/s^2)",
        "Acceleration y (m/s^2)",
        "Acceleration z (m/s^2)",
        "Absolute acceleration (m/s^2)",
    ),
    "Gyroscope": ("Gyroscope x (rad/s)", "Gyroscope y (rad/s)", "Gyroscope z (rad/s)", "Absolute (rad/s)"),
    "Magnetometer": ("Magnetic field x (µT)", "Magnetic field y (µT)", "Magnetic field z (µT)", "Absolute field (µT)"),
}
LOCATION_HEADERS = (
    "Latitude (°)",
    "Longitude (°)",
    "Altitude (m)",
    "Altitude WGS84 (m)",
    "Speed (m/s)",
    "Direction (°)",
    "Distance (km)",
    "Horizontal Accuracy (m)",
    "Vertical Accuracy (m)",
    "Satellites",
)


def _num(v: float) -> str:
    """phyphox number format: 9 decimals in scientific notation, e.g. ``9.810000000E0``."""
    if not np.isfinite(v):
        return "NaN"
    mant, exp = f"{v:.9E}".split("E")
    return f"{mant}E{int(exp)}"


def _csv(headers: tuple[str, ...], columns: list[np.ndarray]) -> str:
    lines = [",".join(f'"{h}"' for h in headers)]
    for row in zip(*columns, strict=True):
        lines.append(",".join(_num(float(v)) for v in row))
    return "\n".join(lines) + "\n"


def write_phyphox_zip(
    path: str | Path,
    epoch_utc: float,
    imu: dict[str, tuple[np.ndarray, np.ndarray]],
    location: tuple[np.ndarray, dict[str, np.ndarray]] | None = None,
    device: str = "sportfusion simulated phone",
) -> None:
    """Write a phyphox CSV export (ZIP).

    Parameters
    ----------
    path : path
        Output ``.zip``.
    epoch_utc : float
        Unix time [s] of experiment time 0 (the START row of ``meta/time.csv``).
    imu : dict
        Set name (``Accelerometer``, ``Gyroscope``, ``Magnetometer``) ->
        (t [s], values (n, 3)) in m/s^2, rad/s, uT.
    location : (t, dict), optional
        Location set: t [s] and columns keyed by :data:`LOCATION_HEADERS`
        (deg, m, m/s, deg, km, m, m, count); missing keys are written as NaN.
    """
    buf = io.BytesIO()
    stamp_tuple = datetime.fromtimestamp(epoch_utc, tz=UTC).timetuple()[:6]
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as archive:
        zf = _FixedDateZip(archive, stamp_tuple)
        for name, (t, xyz) in imu.items():
            xyz = np.asarray(xyz, float)
            cols = [np.asarray(t, float), xyz[:, 0], xyz[:, 1], xyz[:, 2], np.linalg.norm(xyz, axis=1)]
            zf.writestr(f"{name}.csv", _csv(("Time (s)", *PHYPHOX_SETS[name]), cols))
        if location is not None:
            t, cols = location
            n = len(t)
            data = [np.asarray(t, float)] + [
                np.asarray(cols.get(h, np.full(n, np.nan)), float) for h in LOCATION_HEADERS
            ]
            zf.writestr("Location.csv", _csv(("Time (s)", *LOCATION_HEADERS), data))
        stamp = datetime.fromtimestamp(epoch_utc, tz=UTC).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3] + " UTC+00:00"
        zf.writestr(
            "meta/time.csv",
            '"event","experiment time","system time","system time text"\n'
            f'"START",{_num(0.0)},{epoch_utc:.3f},"{stamp}"\n',
        )
        zf.writestr(
            "meta/device.csv",
            '"property","value"\n"deviceModel","' + device + '"\n"deviceBrand","sportfusion"\n"deviceRelease","sim"\n',
        )
    Path(path).write_bytes(buf.getvalue())


class _FixedDateZip:
    """writestr with a fixed member date, so the same data give the same bytes."""

    def __init__(self, archive: zipfile.ZipFile, date_time: tuple[int, ...]) -> None:
        self.archive = archive
        self.date_time = date_time

    def writestr(self, name: str, text: str) -> None:
        info = zipfile.ZipInfo(name, date_time=self.date_time)  # type: ignore[arg-type]
        info.compress_type = zipfile.ZIP_DEFLATED
        self.archive.writestr(info, text)


def nmea_sentence(body: str) -> str:
    """Wrap a sentence body (without ``$`` and ``*hh``) with its XOR checksum."""
    checksum = reduce(lambda a, c: a ^ ord(c), body, 0)
    return f"${body}*{checksum:02X}"


def _latlon(lat: float, lon: float) -> tuple[str, str, str, str]:
    la, lo = abs(lat), abs(lon)
    lat_s = f"{int(la):02d}{(la - int(la)) * 60:010.7f}"
    lon_s = f"{int(lo):03d}{(lo - int(lo)) * 60:010.7f}"
    return lat_s, "N" if lat >= 0 else "S", lon_s, "E" if lon >= 0 else "W"


def write_nmea(
    path: str | Path,
    epoch_utc: float,
    t: np.ndarray,
    lat: np.ndarray,
    lon: np.ndarray,
    h_msl: np.ndarray,
    geoid_sep: float,
    speed: np.ndarray,
    course: np.ndarray,
    sigma_n: np.ndarray,
    sigma_e: np.ndarray,
    sigma_v: np.ndarray,
    fix: np.ndarray | None = None,
    sats: int = 9,
    hdop: float = 0.9,
    talker: str = "GP",
) -> None:
    """Write an NMEA 0183 log with GGA, RMC and GST sentences per epoch.

    Parameters
    ----------
    epoch_utc : float
        Unix time [s] of t = 0.
    t : ndarray
        Epoch times [s].
    lat, lon : ndarray
        WGS84 latitude and longitude [deg].
    h_msl : ndarray
        Altitude above mean sea level [m]; ellipsoidal h = h_msl + geoid_sep.
    geoid_sep : float
        Geoid separation N [m] written in GGA.
    speed, course : ndarray
        Speed over ground [m/s] (written in knots) and course [deg true].
    sigma_n, sigma_e, sigma_v : ndarray
        GST 1-sigma position errors [m].
    fix : ndarray of int, optional
        GGA quality codes (default 1, GPS fix).
    """
    fix = np.ones(len(t), int) if fix is None else np.asarray(fix, int)
    lines = []
    for i, ti in enumerate(np.asarray(t, float)):
        dt = datetime.fromtimestamp(epoch_utc + ti, tz=UTC)
        hms = dt.strftime("%H%M%S.") + f"{dt.microsecond // 10000:02d}"
        la, ns, lo, ew = _latlon(float(lat[i]), float(lon[i]))
        lines.append(
            nmea_sentence(
                f"{talker}GGA,{hms},{la},{ns},{lo},{ew},{fix[i]},{sats:02d},{hdop:.1f},"
                f"{h_msl[i]:.3f},M,{geoid_sep:.3f},M,,"
            )
        )
        status = "A" if fix[i] > 0 else "V"
        lines.append(
            nmea_sentence(
                f"{talker}RMC,{hms},{status},{la},{ns},{lo},{ew},{speed[i] / 0.514444:.3f},{course[i] % 360:.2f},"
                f"{dt.strftime('%d%m%y')},,,A"
            )
        )
        lines.append(
            nmea_sentence(
                f"{talker}GST,{hms},,{sigma_n[i]:.3f},{sigma_e[i]:.3f},0.0,{sigma_n[i]:.3f},{sigma_e[i]:.3f},{sigma_v[i]:.3f}"
            )
        )
    Path(path).write_text("\r\n".join(lines) + "\r\n")


def write_session_raw(
    table: pa.Table,
    epoch_utc: float,
    folder: str | Path,
    geoid_sep: float = 47.0,
    device: str = "sportfusion simulated",
) -> list[Path]:
    """Write a simulated session table as the raw files of its devices.

    The IMU channels present (``acc_*`` [m/s^2], ``gyr_*`` [rad/s], ``mag_*`` [uT]) go to a phyphox
    export ``phyphox.zip`` at their own sample times; the GNSS rows (``lat lon h`` [deg, deg, m
    ellipsoidal], ``vel_n vel_e`` [m/s], ``gnss_fix``, ``gnss_sigma_h/v`` [m]) to an NMEA log
    ``gnss.nmea`` (GGA with the fix-quality code, RMC, GST with the sigmas). ``ingest`` of the two
    files gives the session back on the same clock (NMEA times are rounded to 0.01 s).

    Parameters
    ----------
    table : pyarrow.Table
        A session table (``t`` [s] since ``epoch_utc``).
    epoch_utc : float
        Unix time [s] of ``t = 0``.
    folder : path
        Output folder (created).
    geoid_sep : float
        Geoid separation written into GGA [m]; the NMEA altitude is ``h - geoid_sep``.

    Returns
    -------
    list of Path
        The files written.
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    t = table.column("t").to_numpy()

    def cols(names: list[str]) -> tuple[np.ndarray, np.ndarray] | None:
        if not all(n in table.column_names for n in names):
            return None
        v = np.column_stack([np.asarray(table.column(n).to_numpy(zero_copy_only=False), float) for n in names])
        ok = np.all(np.isfinite(v), axis=1)
        return (t[ok], v[ok]) if ok.any() else None

    imu = {}
    for name, prefix in (("Accelerometer", "acc"), ("Gyroscope", "gyr"), ("Magnetometer", "mag")):
        got = cols([f"{prefix}_{a}" for a in "xyz"])
        if got is not None:
            imu[name] = got
    written = []
    if imu:
        write_phyphox_zip(out / "phyphox.zip", epoch_utc, imu, device=device)
        written.append(out / "phyphox.zip")
    pos = cols(["lat", "lon", "h"])
    if pos is not None:
        sel = np.isin(t, pos[0])

        def g(name: str, default: float) -> np.ndarray:
            if name not in table.column_names:
                return np.full(int(sel.sum()), default)
            v = np.asarray(table.column(name).to_numpy(zero_copy_only=False), float)[sel]
            return np.where(np.isfinite(v), v, default)

        vn, ve = g("vel_n", 0.0), g("vel_e", 0.0)
        sh, sv = g("gnss_sigma_h", 1.0), g("gnss_sigma_v", 1.5)
        write_nmea(
            out / "gnss.nmea",
            epoch_utc,
            pos[0],
            pos[1][:, 0],
            pos[1][:, 1],
            pos[1][:, 2] - geoid_sep,
            geoid_sep,
            np.hypot(vn, ve),
            np.degrees(np.arctan2(ve, vn)) % 360.0,
            sh,
            sh,
            sv,
            fix=g("gnss_fix", 1).astype(int),
        )
        written.append(out / "gnss.nmea")
    return written
