"""phyphox CSV exports: every dialect and quirk, written here as small files; values checked exactly."""

from __future__ import annotations

import math
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from sportfusion.core import io as sfio
from sportfusion.core.errors import InputError
from sportfusion.core.meta import epoch_unix
from sportfusion.core.session import validate_time
from sportfusion.ingest import Options, bouldering, combine, gpx, nmea, phyphox, read_recording, rtklib, xsens
from sportfusion.sim.rawfiles import write_nmea, write_phyphox_zip

BIN = Path(sys.executable).parent
EPOCH = 1_742_032_800.0  # 2025-03-15 10:00:00 UTC

ACC = ("Acceleration x (m/s^2)", "Acceleration y (m/s^2)", "Acceleration z (m/s^2)", "Absolute acceleration (m/s^2)")
GYR = ("Gyroscope x (rad/s)", "Gyroscope y (rad/s)", "Gyroscope z (rad/s)", "Absolute (rad/s)")
MAG = ("Magnetic Field x (µT)", "Magnetic Field y (µT)", "Magnetic Field z (µT)", "Absolute field (µT)")
LOC = (
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
DIALECTS = {
    "comma": (",", "."),
    "tab": ("\t", "."),
    "semicolon": (";", "."),
    "tab-decimal-comma": ("\t", ","),
    "semicolon-decimal-comma": (";", ","),
}


def num(v: float, dec: str = ".") -> str:
    """phyphox's number format (9 decimals, scientific) with the dialect's decimal mark."""
    if not math.isfinite(v):
        return "NaN"
    mant, exp = f"{v:.9E}".split("E")
    return f"{mant}E{int(exp)}".replace(".", dec)


def csv_text(headers, rows, sep, dec, quoted=True):
    head = sep.join(f'"{h}"' if quoted else h for h in headers)
    return head + "\n" + "".join(sep.join(num(v, dec) for v in row) + "\n" for row in rows)


def sensors():
    """Small known data: 4 IMU samples per set, 3 location rows with one NaN cell."""
    t = np.array([0.0, 0.01, 0.02, 0.03])
    acc = np.array([[0.1, 0.2, 9.81], [0.15, -0.25, 9.7], [1e-3, 2.5e-4, 9.9], [-0.5, 0.0, 10.1]])
    gyr = acc[:, ::-1] * 0.01
    mag = np.array([[21.4, 1.5, 43.4], [21.5, 1.4, 43.3], [21.3, 1.6, 43.5], [21.4, 1.5, 43.4]])
    tl = np.array([0.005, 1.005, 2.005])
    loc = np.array(
        [
            [47.4049, 10.2945, 900.0, 947.9, 0.0, math.nan, 0.0, 4.5288, 3.0, 9],
            [47.40491, 10.29451, 899.5, 947.4, 2.0, 90.0, 0.001, 3.0192, 2.0, 10],
            [47.40492, 10.29452, 899.0, math.nan, 2.0, 180.0, 0.002, 3.0192, 2.0, 10],
        ]
    )
    return t, acc, gyr, mag, tl, loc


def export(tmp_path: Path, sep: str, dec: str, as_zip: bool = True, time_rows=None, name: str = "run") -> Path:
    t, acc, gyr, mag, tl, loc = sensors()
    files = {}
    for fname, heads, xyz in (("Accelerometer", ACC, acc), ("Gyroscope", GYR, gyr), ("Magnetometer", MAG, mag)):
        rows = [[ti, *v, float(np.linalg.norm(v))] for ti, v in zip(t, xyz, strict=True)]
        files[f"{fname}.csv"] = csv_text(("Time (s)", *heads), rows, sep, dec)
    files["Location.csv"] = csv_text(("Time (s)", *LOC), [[ti, *r] for ti, r in zip(tl, loc, strict=True)], sep, dec)
    if time_rows is None:
        time_rows = [("START", 0.0, EPOCH, "2025-03-15 11:00:00.000 UTC+01:00")]
    q = '"'
    files["meta/time.csv"] = (
        sep.join(f'"{h}"' for h in ("event", "experiment time", "system time", "system time text"))
        + "\n"
        + "".join(f'"{e}"{sep}{num(x, dec)}{sep}{num(s, dec)}{sep}{q}{txt}{q}\n' for e, x, s, txt in time_rows)
    )
    files["meta/device.csv"] = f'"property"{sep}"value"\n"deviceModel"{sep}"Pixel 7"\n'
    if as_zip:
        p = tmp_path / f"{name}.zip"
        with zipfile.ZipFile(p, "w") as zf:
            for k, v in files.items():
                zf.writestr(k, v)
    else:
        p = tmp_path / name
        for k, v in files.items():
            (p / k).parent.mkdir(parents=True, exist_ok=True)
            (p / k).write_text(v, encoding="utf-8")
    return p


def stream(rec, name):
    return next(s for s in rec.streams if s.name == name)


def values(s, col):
    v = s.columns[col]
    return np.array(v.to_pylist(), dtype=float) if hasattr(v, "to_pylist") else np.asarray(v, dtype=float)


@pytest.mark.parametrize("as_zip", [True, False], ids=["zip", "folder"])
@pytest.mark.parametrize("dialect", list(DIALECTS))
def test_every_dialect_reads_the_same_numbers(tmp_path, dialect, as_zip):
    sep, dec = DIALECTS[dialect]
    p = export(tmp_path, sep, dec, as_zip)
    assert phyphox.sniff(p, p.read_bytes()[:4096] if p.is_file() else b"")
    rec = read_recording(p)
    assert rec.format == "phyphox"
    assert rec.epoch_utc == EPOCH
    t, acc, gyr, mag, tl, loc = sensors()
    a, g, m, lo = (stream(rec, n) for n in ("Accelerometer", "Gyroscope", "Magnetometer", "Location"))
    # phyphox numbers carry 10 significant digits: compare at 1e-9 relative
    np.testing.assert_allclose(a.t, t, rtol=0, atol=1e-12)
    for k, axis in enumerate("xyz"):
        np.testing.assert_allclose(values(a, f"acc_{axis}"), acc[:, k], rtol=1e-9)
        np.testing.assert_allclose(values(g, f"gyr_{axis}"), gyr[:, k], rtol=1e-9)
        np.testing.assert_allclose(values(m, f"mag_{axis}"), mag[:, k], rtol=1e-9)
    assert set(a.columns) == {"acc_x", "acc_y", "acc_z"}  # the derived "Absolute" column is not read
    np.testing.assert_allclose(lo.t, tl, atol=1e-12)
    np.testing.assert_allclose(values(lo, "lat"), loc[:, 0], rtol=1e-9)
    np.testing.assert_allclose(values(lo, "h_msl"), loc[:, 2], rtol=1e-9)
    h = values(lo, "h")  # Altitude WGS84 is h; its NaN cell stays missing
    np.testing.assert_allclose(h[:2], loc[:2, 3], rtol=1e-9)
    assert np.isnan(h[2])
    np.testing.assert_allclose(values(lo, "gnss_sigma_h"), loc[:, 7] / math.sqrt(-2 * math.log(0.32)), rtol=1e-9)
    np.testing.assert_allclose(values(lo, "gnss_sigma_v"), loc[:, 8], rtol=1e-9)
    assert values(lo, "gnss_sats").tolist() == [9, 10, 10]
    # velocity from speed and direction; speed 0 without a direction is a standstill
    np.testing.assert_allclose(values(lo, "vel_n"), [0.0, 0.0, -2.0], atol=1e-9)
    np.testing.assert_allclose(values(lo, "vel_e"), [0.0, 2.0, 0.0], atol=1e-9)
    assert "Distance (km)" not in str(rec.warnings)
    assert rec.meta["device"] == {"deviceModel": "Pixel 7"}


def test_dialect_detection_is_not_fooled_by_decimal_points_under_tab():
    from sportfusion.ingest._text import dialect

    assert dialect('"Time (s)"\t"a"\n1.5E0\t2.0E0\n') == ("\t", ".")
    assert dialect('"Time (s)";"a"\n1,5E0;2,0E0\n') == (";", ",")
    assert dialect('"Time (s)";"a"\nNaN;NaN\n1,5;2\n') == (";", ",")
    assert dialect("Time (s),a\n1.5,2\n") == (",", ".")


def test_old_and_ios_headers_matched_by_meaning(tmp_path):
    d = tmp_path / "ios"
    d.mkdir()
    (d / "Location.csv").write_text(
        '"Time (s)","Latitude (°)","Longitude (°)","Height (m)","Velocity (km/h)","Direction (°)"\n'
        "0.0E0,4.74E1,1.03E1,9.0E2,3.6E1,0.0E0\n"
    )
    (d / "Gyroscope.csv").write_text(
        '"time (s)","Angular velocity X (deg/s)","Angular velocity Y (deg/s)","Angular velocity Z (deg/s)"\n'
        "0.0E0,1.8E2,0.0E0,-9.0E1\n"
    )
    (d / "Magnetometer.csv").write_text(  # greek mu, lower-case field
        '"Time (s)","Magnetic field x (μT)","Magnetic field y (μT)","Magnetic field z (mT)"\n0.0E0,2.0E1,1.0E0,4.3E-2\n'
    )
    (d / "Pressure.csv").write_text('"Time (s)","Pressure (hPa)"\n0.0E0,9.1E2\n')
    rec = phyphox.read(d, Options())
    loc, gyr, mag, pres = (stream(rec, n) for n in ("Location", "Gyroscope", "Magnetometer", "Pressure"))
    assert values(loc, "h_msl").tolist() == [900.0]  # Height is above mean sea level
    assert "h" not in loc.columns
    assert values(loc, "gnss_speed") == pytest.approx([10.0])  # 36 km/h
    assert values(gyr, "gyr_x") == pytest.approx([math.pi]) and values(gyr, "gyr_z") == pytest.approx([-math.pi / 2])
    assert values(mag, "mag_z") == pytest.approx([43.0])  # mT -> uT
    assert values(pres, "pressure") == pytest.approx([91000.0])  # hPa -> Pa
    assert rec.epoch_utc is None and any("no meta/time.csv" in w for w in rec.warnings)


def test_time_csv_places_sets_on_utc_across_a_pause_and_prefers_the_precise_text(tmp_path):
    rows = [
        ("START", 0.0, 1.742032800e9, "2025-03-15 10:00:00.250 UTC+00:00"),
        ("PAUSE", 0.02, 1.742032800e9, "2025-03-15 10:00:00.270 UTC+00:00"),
        ("START", 0.02, 1.742032810e9, "2025-03-15 10:00:10.500 UTC+00:00"),
    ]
    rec = phyphox.read(export(tmp_path, ",", ".", time_rows=rows), Options())
    assert rec.epoch_utc == pytest.approx(EPOCH + 0.25, abs=1e-6)  # the number alone says EPOCH + 0
    acc = stream(rec, "Accelerometer")
    # samples 0, 0.01 before the pause; 0.02, 0.03 after the restart at 10:00:10.500
    np.testing.assert_allclose(acc.t, [0.0, 0.01, 10.25, 10.26], atol=1e-9)


def test_time_text_disagreeing_with_the_number_warns(tmp_path):
    rows = [("START", 0.0, EPOCH, "2025-03-15 10:00:05.000 UTC+00:00")]
    rec = phyphox.read(export(tmp_path, ",", ".", time_rows=rows), Options())
    assert rec.epoch_utc == EPOCH
    assert any("disagree" in w for w in rec.warnings)


def test_linear_acceleration_and_unknown_sets_skipped_with_warnings(tmp_path):
    d = tmp_path / "x"
    d.mkdir()
    (d / "Linear Acceleration.csv").write_text(
        '"Time (s)","Linear Acceleration x (m/s^2)","Linear Acceleration y (m/s^2)","Linear Acceleration z (m/s^2)"\n'
        "0.0E0,1.0E0,0.0E0,0.0E0\n"
    )
    (d / "Light.csv").write_text('"Time (s)","Illuminance (lx)"\n0.0E0,3.0E2\n')
    (d / "Accelerometer.csv").write_text('"Time (s)","Acceleration x (m/s^2)"\n0.0E0,1.0E0\n1.0E-2,NaN\n')
    rec = phyphox.read(d, Options())
    assert [s.name for s in rec.streams] == ["Accelerometer"]
    assert np.isnan(values(rec.streams[0], "acc_x")[1])
    assert any("not specific force" in w for w in rec.warnings)
    assert any("Light.csv: no known column (Illuminance (lx))" in w for w in rec.warnings)
    (d / "Accelerometer.csv").unlink()
    with pytest.raises(InputError, match="none of the sets"):
        phyphox.read(d, Options())


def test_missing_time_cell_is_an_error(tmp_path):
    d = tmp_path / "x"
    d.mkdir()
    (d / "Accelerometer.csv").write_text('"Time (s)","Acceleration x (m/s^2)"\n0.0E0,1.0E0\nNaN,2.0E0\n')
    with pytest.raises(InputError, match="row 3 has no time"):
        phyphox.read(d, Options())


def test_single_set_csv_and_sniffers_claim_only_their_own(tmp_path):
    p = tmp_path / "Accelerometer.csv"
    p.write_text('"Time (s)";"Acceleration x (m/s^2)"\n0,0E0;1,5E0\n')
    head = p.read_bytes()
    assert read_recording(p).format == "phyphox"
    assert values(read_recording(p).streams[0], "acc_x").tolist() == [1.5]
    others = (bouldering, rtklib, xsens, nmea, gpx)
    assert not any(m.sniff(p, head) for m in others)
    assert not phyphox.sniff(Path("x.nmea"), b"$GPGGA,120000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*4C\r\n")
    assert not phyphox.sniff(Path("x.csv"), b"Time,AccX\n0,1\n")  # a generic CSV needs --map


def test_round_trip_of_the_simulators_phyphox_writer(tmp_path):
    rng = np.random.default_rng(4)
    t = np.arange(50) * 0.01
    imu = {k: (t, rng.normal(0, 5, (50, 3))) for k in ("Accelerometer", "Gyroscope", "Magnetometer")}
    p = tmp_path / "sim.zip"
    write_phyphox_zip(p, EPOCH + 0.123, imu)
    rec = read_recording(p)
    assert rec.epoch_utc == pytest.approx(EPOCH + 0.123, abs=1e-6)
    for name, col in (("Accelerometer", "acc"), ("Gyroscope", "gyr"), ("Magnetometer", "mag")):
        s = stream(rec, name)
        got = np.column_stack([values(s, f"{col}_{a}") for a in "xyz"])
        np.testing.assert_allclose(got, imu[name][1], rtol=1e-9, atol=1e-12)


def test_phyphox_plus_nmea_keeps_every_sample_on_one_increasing_clock(tmp_path):
    """The issue's check: merged counts equal the inputs' counts and t is strictly increasing."""
    rng = np.random.default_rng(7)
    t_imu = np.arange(300) * 0.01  # 100 Hz for 3 s
    imu = {k: (t_imu, rng.normal(0, 1, (300, 3))) for k in ("Accelerometer", "Gyroscope")}
    zp = tmp_path / "phone.zip"
    write_phyphox_zip(zp, EPOCH, imu)
    tg = 0.5 + np.arange(20) * 0.1  # GPS logger starts 0.5 s later, 10 Hz
    n = tg.size
    log = tmp_path / "gps.nmea"
    write_nmea(
        log, EPOCH, tg, 47.4 + 1e-5 * np.arange(n), np.full(n, 10.3), np.full(n, 900.0), 47.9,
        np.full(n, 20.0), np.full(n, 45.0), np.full(n, 0.5), np.full(n, 0.6), np.full(n, 1.0),
    )  # fmt: skip
    out = tmp_path / "s.parquet"
    proc = subprocess.run([str(BIN / "ingest"), str(zp), str(log), "-o", str(out)], capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    table, meta = sfio.read_table(out, kind="session")
    t = validate_time(table)
    assert np.all(np.diff(t) > 0)
    for col, count in (("acc_x", 300), ("gyr_x", 300), ("lat", n)):
        c = table.column(col)
        assert len(c) - c.null_count == count
    # shared instants share rows: the union of 300 IMU and 20 GPS times, all GPS times on the IMU grid
    assert table.num_rows == np.unique(np.round(np.concatenate([t_imu, tg]), 9)).size
    lat_t = t[table.column("lat").is_valid().to_numpy(zero_copy_only=False)]
    np.testing.assert_allclose(lat_t, tg, atol=1e-6)  # NMEA times carry 10 ms
    assert epoch_unix(meta) == EPOCH
    assert [s["format"] for s in meta["sources"]] == ["phyphox", "nmea"]


def test_combine_counts_with_offset_instead_of_utc(tmp_path):
    p = export(tmp_path, ";", ",", time_rows=[("START", 0.0, EPOCH, "")])
    d = tmp_path / "noclock"
    d.mkdir()
    (d / "Accelerometer.csv").write_text('"Time (s)","Acceleration x (m/s^2)"\n0.0E0,1.0E0\n5.0E-3,2.0E0\n')
    table, meta, warnings = combine([read_recording(p), read_recording(d)], {"noclock": 0.001})
    acc = table.column("acc_x").to_pylist()
    t = table.column("t").to_numpy()
    assert sum(v is not None for v in acc) == 4 + 2
    got = [ti for ti, v in zip(t, acc, strict=True) if v in (1.0, 2.0)]
    assert got == pytest.approx([0.001, 0.006])
    assert not any("has no absolute time; it starts at session t = 0" in w for w in warnings)  # offset given


def test_ios_simple_experiment_export_without_meta(tmp_path):
    """Sets and headers as phyphox iOS writes them for a sensor experiment made in the app
    (SimpleExperimentSerializer): axis-only headers, Barometer "X (hPa)", "Vertical Accuracy (°)"."""
    d = tmp_path / "ios_run"
    d.mkdir()
    (d / "Accelerometer.csv").write_text(
        '"Time (s)","X (m/s^2)","Y (m/s^2)","Z (m/s^2)"\n1.0E-2,1.5E-1,-2.0E-1,9.81E0\n2.0E-2,1.0E-1,0.0E0,9.8E0\n'
    )
    (d / "Linear Accelerometer.csv").write_text('"Time (s)","X (m/s^2)","Y (m/s^2)","Z (m/s^2)"\n1.0E-2,0,0,0\n')
    (d / "Gyroscope.csv").write_text('"Time (s)","X (rad/s)","Y (rad/s)","Z (rad/s)"\n1.0E-2,1.0E-2,2.0E-2,3.0E-2\n')
    (d / "Magnetometer.csv").write_text('"Time (s)","X (µT)","Y (µT)","Z (µT)"\n1.5E-2,2.0E1,1.0E0,-4.3E1\n')
    (d / "Barometer.csv").write_text('"Time (s)","X (hPa)"\n5.0E-1,9.125E2\n')
    (d / "Proximity.csv").write_text('"Time (s)","Distance (cm)"\n5.0E-1,5.0E0\n')
    (d / "Location.csv").write_text(
        '"Time (s)","Latitude (°)","Longitude (°)","Height (m)","Velocity (m/s)","Direction (°)",'
        '"Horizontal Accuracy (m)","Vertical Accuracy (°)","Status"\n'
        "1.0E0,4.74E1,1.03E1,9.0E2,2.0E0,9.0E1,4.5288E0,3.0E0,Active\n"
        "2.0E0,4.74E1,1.03E1,9.01E2,2.0E0,9.0E1,4.5288E0,NaN,Active\n"
    )
    rec = read_recording(d)
    assert rec.format == "phyphox" and rec.epoch_utc is None
    names = [s.name for s in rec.streams]
    assert "Linear Accelerometer" not in names and "Proximity" not in names
    acc, gyr, mag, baro, loc = (
        stream(rec, n) for n in ("Accelerometer", "Gyroscope", "Magnetometer", "Barometer", "Location")
    )
    np.testing.assert_allclose(acc.t, [0.01, 0.02])
    assert values(acc, "acc_x").tolist() == [0.15, 0.1] and values(acc, "acc_z").tolist() == [9.81, 9.8]
    assert values(gyr, "gyr_z").tolist() == [0.03]
    assert values(mag, "mag_z").tolist() == [-43.0]
    assert values(baro, "pressure").tolist() == [91250.0]
    assert values(loc, "gnss_sigma_v")[0] == 3.0 and np.isnan(values(loc, "gnss_sigma_v")[1])
    assert values(loc, "h_msl").tolist() == [900.0, 901.0]
    w = "\n".join(rec.warnings)
    assert "'Vertical Accuracy (°)' read as metres" in w
    assert "Location.csv: column(s) Status hold text" in w  # one odd column does not sink the set
    assert "no meta/time.csv" in w and "not specific force" in w


def test_one_unreadable_set_does_not_sink_the_export_and_offset_places_it(tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    (d / "Accelerometer.csv").write_text('"Time (s)","Acceleration x (m/s^2)"\n0.0E0,1.0E0\n1.0E-2,2.0E0\n')
    (d / "Light.csv").write_text('"Time (s)","Illuminance (lx)"\nnot a time,3\n')
    out = tmp_path / "s.parquet"
    cmd = [str(BIN / "ingest"), str(d), "--offset", "run=2.5", "-o", str(out)]
    proc = subprocess.run(cmd, capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    err = proc.stderr.decode()
    assert "set not read" in err and "Light.csv" in err and "no absolute time" in err
    table, meta = sfio.read_table(out, kind="session")
    np.testing.assert_allclose(table.column("t").to_numpy(), [2.5, 2.51])
    assert epoch_unix(meta) is None


def test_ios_gps_csv_invalid_markers_are_null(tmp_path):
    """A custom experiment's GPS.csv from iOS: -1 for unknown speed and course, a negative accuracy for an
    invalid fix (Core Location's markers) are nulls, never a speed of -1 m/s or an invented vel_n."""
    from sportfusion.ingest import read_recording

    p = tmp_path / "GPS.csv"
    p.write_text(
        '"Time (s)","Latitude (°)","Longitude (°)","Height (m)","Speed (m/s)","Direction (°)",'
        '"Horizontal Accuracy (m)","Vertical Accuracy (m)"\n'
        "0.0,47.1,9.5,500.0,-1,-1,5.0,3.0\n"
        "1.0,47.10001,9.5,500.5,2.0,-1,5.0,-1\n"
        "2.0,47.10002,9.5,501.0,2.0,90.0,-1,3.0\n"
        "3.0,47.10003,9.5,501.5,0.0,-1,4.0,3.0\n"
    )
    rec = read_recording(p)
    (st,) = rec.streams
    c = {k: np.asarray(v, dtype=float) for k, v in st.columns.items()}
    assert math.isnan(c["gnss_speed"][0]) and c["gnss_speed"][1] == 2.0
    assert np.isnan(c["gnss_course"][[0, 1, 3]]).all() and c["gnss_course"][2] == 90.0
    # no velocity where speed or course is unknown; a speed of 0 needs no course
    assert np.isnan(c["vel_n"][:2]).all() and c["vel_e"][2] == pytest.approx(2.0) and c["vel_n"][3] == 0.0
    assert np.isnan(c["lat"][2]) and np.isnan(c["lon"][2]) and c["lat"][1] == 47.10001  # negative h. accuracy
    assert np.isnan(c["h_msl"][1]) and c["h_msl"][2] == 501.0  # negative vertical accuracy: no altitude
    assert np.isnan(c["gnss_sigma_h"][2]) and np.isnan(c["gnss_sigma_v"][1])
    assert any("invalid markers" in w for w in rec.warnings)
