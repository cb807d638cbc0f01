"""Sensor Logger exports written here from the app's documentation: nanosecond times, platforms, files."""

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
from sportfusion.ingest import phyphox, read_recording, sensorlogger, xsens

BIN = Path(sys.executable).parent
T0 = 1_698_501_144_401_773_123  # ns since the Unix epoch (19 digits)
# 1 ns, 10 ms + 7 ns, 20 ms: steps float64 cannot hold at 1.7e18 ns (its spacing there is 256 ns)
STEPS = np.array([0, 1, 10_000_007, 20_000_000], dtype=np.int64)


def rows(times, cols):
    return "".join(
        ",".join([str(int(t)), f"{(t - T0) * 1e-9:.9f}", *(repr(float(c)) for c in r)]) + "\n"
        for t, r in zip(times, cols, strict=True)
    )


def export(
    tmp_path: Path, platform: str = "iOS", total: bool = False, as_zip: bool = False, standard: str = ""
) -> Path:
    d = tmp_path / f"rec_{platform}_{total}_{as_zip}"
    d.mkdir()
    t = T0 + STEPS
    lin = np.array([[0.1, 0.2, 0.3], [0.0, -0.1, 0.2], [0.5, 0.5, 0.5], [1.0, 0.0, -1.0]])
    grav = np.array([[0.0, 0.0, -9.8], [0.0, 0.1, -9.79], [0.2, 0.0, -9.7], [0.0, 0.0, -9.81]])
    files = {
        "Metadata.csv": "version,device name,recording time,platform,appVersion"
        + (",standardisation" if standard else "")
        + f"\n3,Phone,2023-10-28_13-52-24,{platform},1.30.0"
        + (f",{standard}" if standard else "")
        + "\n",
        "Accelerometer.csv": "time,seconds_elapsed,z,y,x\n" + rows(t, lin[:, ::-1]),
        "Gravity.csv": "time,seconds_elapsed,z,y,x\n" + rows(t, grav[:, ::-1]),
        "Gyroscope.csv": "time,seconds_elapsed,z,y,x\n" + rows(t, [[0.3, 0.2, 0.1]] * 4),
        "Magnetometer.csv": "time,seconds_elapsed,z,y,x\n" + rows(t[:2], [[-40.0, 5.0, 20.0]] * 2),
        "Barometer.csv": "time,seconds_elapsed,relativeAltitude,pressure\n" + rows(t[:1], [[0.0, 912.5]]),
        "Location.csv": "time,seconds_elapsed,bearingAccuracy,speedAccuracy,verticalAccuracy,horizontalAccuracy,"
        "speed,bearing,altitude,longitude,latitude\n"
        + rows([T0 + 5_000_000], [[1.0, 0.5, 3.0, 4.5288, 2.0, 90.0, 947.9, 10.2945, 47.4049]])
        + rows([T0 + 1_005_000_000], [[-1.0, -1.0, -1.0, 3.0192, -1.0, -1.0, 948.0, 10.2946, 47.405]]),
        "Orientation.csv": "time,seconds_elapsed,qz,qy,qx,qw,roll,pitch,yaw\n" + rows(t[:1], [[0, 0, 0, 1, 0, 0, 0]]),
    }
    if total:
        files["TotalAcceleration.csv"] = "time,seconds_elapsed,z,y,x\n" + rows(t, (lin + 9.0)[:, ::-1])
    for k, v in files.items():
        (d / k).write_text(v)
    if as_zip:
        z = tmp_path / f"{d.name}.zip"
        with zipfile.ZipFile(z, "w") as zf:
            for k, v in files.items():
                zf.writestr(k, v)
        return z
    return d


def stream(rec, name):
    return next(s for s in rec.streams if s.name == name)


def col(s, name):
    return np.asarray(s.columns[name], dtype=float)


@pytest.mark.parametrize("as_zip", [False, True], ids=["folder", "zip"])
def test_ios_export_nanosecond_times_and_specific_force(tmp_path, as_zip):
    p = export(tmp_path, "iOS", as_zip=as_zip)
    head = p.read_bytes()[:4096] if p.is_file() else b""
    assert sensorlogger.sniff(p, head) and not phyphox.sniff(p, head) and not xsens.sniff(p, head)
    rec = read_recording(p)
    assert rec.format == "sensorlogger"
    # the epoch is the first sample; relative times keep every nanosecond
    assert rec.epoch_utc == pytest.approx(1_698_501_144.401773123, abs=1e-6)
    acc = stream(rec, "Accelerometer")
    np.testing.assert_allclose(acc.t, STEPS * 1e-9, rtol=0, atol=1e-15)
    assert acc.t[1] == pytest.approx(1e-9, abs=1e-18)
    # iOS (not standardised): specific force = -(acceleration without gravity + gravity)
    lin = np.array([0.1, 0.2, 0.3])
    grav = np.array([0.0, 0.0, -9.8])
    got = np.array([col(acc, f"acc_{a}")[0] for a in "xyz"])
    np.testing.assert_allclose(got, -(lin + grav), atol=1e-12)
    assert got[2] == pytest.approx(9.5)  # phone flat, screen up: +z specific force
    gyr = stream(rec, "Gyroscope")
    assert [col(gyr, f"gyr_{a}")[0] for a in "xyz"] == pytest.approx([0.1, 0.2, 0.3])  # file order z,y,x
    mag = stream(rec, "Magnetometer")
    assert [col(mag, f"mag_{a}")[0] for a in "xyz"] == pytest.approx([20.0, 5.0, -40.0])
    assert col(stream(rec, "Barometer"), "pressure") == pytest.approx([91250.0])
    loc = stream(rec, "Location")
    np.testing.assert_allclose(loc.t, [0.005, 1.005], atol=1e-12)
    assert col(loc, "lat").tolist() == [47.4049, 47.405]
    # h: documented as height above the WGS84 ellipsoid; Core Location's negative verticalAccuracy says the
    # altitude is invalid (Apple: "a negative value indicates that the altitude value is invalid"): null
    h = col(loc, "h")
    assert h[0] == 947.9 and math.isnan(h[1])
    sig = col(loc, "gnss_sigma_h")
    assert sig[0] == pytest.approx(4.5288 / math.sqrt(-2 * math.log(0.32))) and sig[1] == pytest.approx(
        3.0192 / math.sqrt(-2 * math.log(0.32))
    )
    sv, sp = col(loc, "gnss_sigma_v"), col(loc, "gnss_speed")
    assert sv[0] == 3.0 and math.isnan(sv[1]) and sp[0] == 2.0 and math.isnan(sp[1])  # -1: invalid
    assert col(loc, "vel_e")[0] == pytest.approx(2.0) and col(loc, "vel_n")[0] == pytest.approx(0.0, abs=1e-12)
    assert any("Orientation.csv" in w for w in rec.warnings)
    assert rec.meta["device"]["platform"] == "iOS"


def test_android_total_acceleration_and_standardised_ios(tmp_path):
    rec = read_recording(export(tmp_path, "Android", total=True))
    acc = stream(rec, "TotalAcceleration")
    assert [col(acc, f"acc_{a}")[0] for a in "xyz"] == pytest.approx([9.1, 9.2, 9.3])
    assert rec.meta["acc_from"] == "TotalAcceleration"
    assert "Accelerometer.csv, Gravity.csv not read: TotalAcceleration.csv gives the specific force" in rec.warnings
    rec = read_recording(export(tmp_path, "iOS", standard="true"))
    acc = stream(rec, "Accelerometer")
    assert col(acc, "acc_z")[0] == pytest.approx(0.3 - 9.8)  # standardised: Android sign, no flip


def test_gravity_on_its_own_clock_is_interpolated_and_lone_linear_acceleration_refused(tmp_path):
    d = export(tmp_path, "Android")
    (d / "Gravity.csv").write_text(
        "time,seconds_elapsed,z,y,x\n" + rows([T0 - 10_000_000, T0 + 30_000_000], [[9.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    )
    rec = sensorlogger.read(d, None)
    acc = stream(rec, "Accelerometer")
    # gravity z at t = 0: 9 + (10 - 9) * 10/40 = 9.25; plus the linear 0.3
    assert col(acc, "acc_z")[0] == pytest.approx(9.55)
    assert any("interpolated" in w for w in rec.warnings)
    (d / "Gravity.csv").unlink()
    rec = sensorlogger.read(d, None)
    assert not any(s.name == "Accelerometer" for s in rec.streams)
    assert any("without gravity" in w for w in rec.warnings)


def test_command_reads_it_without_format_or_map(tmp_path):
    p = export(tmp_path, "iOS", as_zip=True)
    out = tmp_path / "s.parquet"
    proc = subprocess.run([str(BIN / "ingest"), str(p), "-o", str(out)], capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    table, meta = sfio.read_table(out, kind="session")
    assert epoch_unix(meta) == pytest.approx(1_698_501_144.401773123, abs=1e-6)
    assert meta["sources"][0]["format"] == "sensorlogger"
    t = table.column("t").to_numpy()
    assert t[1] - t[0] == pytest.approx(1e-9, abs=1e-15)  # 1 ns apart survives the session table
    acc = table.column("acc_x")
    assert len(acc) - acc.null_count == 4


def test_bad_time_cell_is_one_clear_error(tmp_path):
    d = tmp_path / "bad"
    d.mkdir()
    (d / "Gyroscope.csv").write_text(f"time,seconds_elapsed,z,y,x\n{T0},0,1,2,3\n,0.01,1,2,3\n")
    with pytest.raises(InputError, match="Gyroscope.csv: row 3 has no time"):
        sensorlogger.read(d, None)


def test_rows_repeating_a_time_are_dropped_and_counted(tmp_path):
    d = tmp_path / "dup"
    d.mkdir()
    (d / "Gyroscope.csv").write_text(
        "time,seconds_elapsed,z,y,x\n"
        f"{T0},0,1,2,3\n{T0 + 10},0,1,2,4\n{T0 + 10},0,9,9,9\n{T0 + 5},0,1,2,5\n{T0},0,1,2,3\n"
    )
    rec = sensorlogger.read(d, None)
    g = stream(rec, "Gyroscope")
    np.testing.assert_allclose(g.t, [0.0, 10e-9, 5e-9], atol=1e-18)  # order kept; merge sorts later
    assert col(g, "gyr_x").tolist() == [3.0, 4.0, 5.0]
    assert rec.warnings == ["Gyroscope.csv: 2 row(s) repeating an earlier time dropped (first kept)"]


T2021 = 1_623_492_930_000_000_000  # 2021-06-12 10:15:30 UTC [ns]


def export_2021(tmp_path: Path, clock_offset_s: float, gnss_delay_s: float = 3.0, as_zip: bool = False) -> Path:
    """An early iOS export (Metadata version 2): motion files ``time,z,y,x`` (no seconds_elapsed) stamped on a
    clock ``clock_offset_s`` behind Location.csv's; the first fix comes ``gnss_delay_s`` after the start."""
    d = tmp_path / f"2021-06-12_12-15-30_{clock_offset_s}"
    d.mkdir()
    n = 200
    tm = T2021 + np.arange(n, dtype=np.int64) * 10_000_000  # 100 Hz, true UTC
    motion = tm - int(clock_offset_s * 1e9)
    tl = T2021 + int(gnss_delay_s * 1e9) + np.arange(3, dtype=np.int64) * 1_000_000_000

    def plain(times, cols):
        return "".join(
            ",".join([str(int(t)), *(repr(float(c)) for c in r)]) + "\n" for t, r in zip(times, cols, strict=True)
        )

    files = {
        "Metadata.csv": "version,device name,recording time,platform\n2,iPhone 11,2021-06-12_12-15-30,ios\n",
        "Accelerometer.csv": "time,z,y,x\n" + plain(motion, [[0.3, 0.2, 0.1]] * n),
        "Gravity.csv": "time,z,y,x\n" + plain(motion, [[-1.0, 0.0, 0.0]] * n),
        "Gyroscope.csv": "time,z,y,x\n" + plain(motion, [[0.03, 0.02, 0.01]] * n),
        "Location.csv": "time,latitude,longitude,altitude,speed,bearing,horizontalAccuracy,verticalAccuracy\n"
        + plain(tl, [[47.4049, 10.2945, 947.9, 1.2, 45.0, 5.0, 3.0]] * 3),
    }
    for k, v in files.items():
        (d / k).write_text(v)
    if as_zip:
        z = tmp_path / f"{d.name}.zip"
        with zipfile.ZipFile(z, "w") as zf:
            for k, v in files.items():
                zf.writestr(k, v)
        return z
    return d


@pytest.mark.parametrize("as_zip", [False, True], ids=["folder", "zip"])
def test_2021_export_read_and_time_zone_offset_removed(tmp_path, as_zip):
    p = export_2021(tmp_path, 2 * 3600.0, as_zip=as_zip)
    assert sensorlogger.sniff(p, p.read_bytes()[:4096] if p.is_file() else b"")
    rec = read_recording(p)
    assert rec.format == "sensorlogger"
    acc, loc = stream(rec, "Accelerometer"), stream(rec, "Location")
    # the clocks are one: the first fix 3.000 s after the first motion sample, exactly (whole 2 h removed)
    assert loc.t[0] - acc.t[0] == pytest.approx(3.0, abs=1e-9)
    assert rec.epoch_utc == pytest.approx(T2021 / 1e9)
    # iOS, not standardised: specific force is -(linear + gravity)
    assert [col(acc, f"acc_{a}")[0] for a in "xyz"] == pytest.approx([-0.1, -0.2, -(0.3 - 1.0)])
    assert [col(stream(rec, "Gyroscope"), f"gyr_{a}")[0] for a in "xyz"] == pytest.approx([0.01, 0.02, 0.03])
    line = next(w for w in rec.warnings if "stamped on a clock" in w)
    assert "2.00 h behind" in line and "+7200.000 s" in line and "time-zone" in line
    assert any("no seconds_elapsed" in w and "version 2" in w for w in rec.warnings)


def test_2021_export_arbitrary_clock_offset_aligned_by_first_samples(tmp_path):
    off = 5000.0 + 17.25  # not a whole quarter hour: aligned by the first samples
    rec = read_recording(export_2021(tmp_path, off, gnss_delay_s=0.5))
    acc, loc = stream(rec, "Accelerometer"), stream(rec, "Location")
    assert loc.t[0] - acc.t[0] == pytest.approx(0.0, abs=1e-9)  # the GNSS delay (0.5 s) is not known
    line = next(w for w in rec.warnings if "stamped on a clock" in w)
    assert "uncertain" in line


def test_2021_export_through_ingest(tmp_path):
    p = export_2021(tmp_path, 3 * 3600.0, as_zip=True)
    r = subprocess.run([str(BIN / "ingest"), str(p)], capture_output=True)
    assert r.returncode == 0, r.stderr.decode()
    table = sfio.table_from_bytes(r.stdout)
    t = table.column("t").to_numpy()
    lat = table.column("lat").to_numpy(zero_copy_only=False)
    assert t[np.isfinite(lat)][0] == pytest.approx(3.0, abs=1e-6)  # on the motion files' clock, 3 s in
    assert b"shifted by +10800.000 s" in r.stderr
