"""FIT and TCX readers on files written here.

FIT files are written with Garmin's official FIT SDK (``garmin-fit-sdk``, a
test extra, its ``Encoder``); our reader decodes them with ``fitdecode``, and
the fixes and first-fix time are checked against the values put in and
against the SDK's own ``Decoder`` (an independent decode).
"""

from __future__ import annotations

import calendar
import datetime as dt
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli
from garmin_fit_sdk import Decoder, Encoder, Profile
from garmin_fit_sdk import Stream as FitStream

from sportfusion.core import io as sfio
from sportfusion.core.errors import InputError
from sportfusion.ingest import Options, detect_format, read_recording

MN = Profile["mesg_num"]
T0 = dt.datetime(2024, 1, 20, 10, 0, 0, tzinfo=dt.UTC)
FIT_EPOCH = 631065600


def semi(deg: float) -> int:
    return int(round(deg / 180.0 * 2**31))


def track(n: int = 30) -> dict[str, np.ndarray]:
    """A short ski track: lat/lon [deg], altitude MSL [m], speed [m/s], heart rate, cadence, power."""
    k = np.arange(n)
    return {
        "lat": 47.3 + 1e-4 * k + 2e-5 * np.sin(k / 3.0),
        "lon": 11.4 + 5e-5 * k,
        "alt": 1800.0 - 2.0 * k,
        "speed": 8.0 + 0.1 * k,
        "hr": 120 + k % 20,
        "cad": 60 + k % 7,
        "power": 150 + 3 * k,
    }


def write_fit(path: Path, n: int = 30, *, enhanced: bool = True, sensors: bool = False) -> dict:
    """An activity FIT file: records at 1 Hz from T0 (+ optional camera-style IMU messages on system time)."""
    trk = track(n)
    enc = Encoder()
    enc.on_mesg(MN["FILE_ID"], {"type": "activity", "manufacturer": "garmin", "product": 1, "time_created": T0})
    for i in range(n):
        rec = {
            "timestamp": T0 + dt.timedelta(seconds=i),
            "position_lat": semi(trk["lat"][i]),
            "position_long": semi(trk["lon"][i]),
            "heart_rate": int(trk["hr"][i]),
            "cadence": int(trk["cad"][i]),
            "power": int(trk["power"][i]),
        }
        if enhanced:
            rec |= {"enhanced_altitude": float(trk["alt"][i]), "enhanced_speed": float(trk["speed"][i])}
        else:
            rec |= {"altitude": float(trk["alt"][i]), "speed": float(trk["speed"][i])}
        if i == 3:  # a record without a fix (still indoors / searching)
            del rec["position_lat"], rec["position_long"]
        enc.on_mesg(MN["RECORD"], rec)
    if sensors:
        # the camera's clock: system time 1000.25 s <-> UTC T0 + 0.5 s
        enc.on_mesg(
            MN["TIMESTAMP_CORRELATION"],
            {
                "timestamp": T0,
                "fractional_timestamp": 0.5,
                "system_timestamp": 1000,
                "fractional_system_timestamp": 0.25,
            },
        )
        for st, factor, div in (("accelerometer", 1, 1000), ("gyroscope", 1, 100)):
            enc.on_mesg(
                MN["THREE_D_SENSOR_CALIBRATION"],
                {
                    "timestamp": T0,
                    "sensor_type": st,
                    "calibration_factor": factor,
                    "calibration_divisor": div,
                    "level_shift": 32768,
                    "offset_cal": [10, -10, 0],
                    "orientation_matrix": [0, 1, 0, 1, 0, 0, 0, 0, -1],  # swap x/y, flip z
                },
            )
        for s in range(3):
            offs = [0, 10, 20, 30]
            enc.on_mesg(
                MN["ACCELEROMETER_DATA"],
                {
                    "timestamp": 1001 + s,
                    "timestamp_ms": 0,
                    "sample_time_offset": offs,
                    "accel_x": [32768 + 10 + 1000] * 4,  # (raw - shift - off) / 1000 = 1 g
                    "accel_y": [32768 - 10] * 4,  # 0 g
                    "accel_z": [32768 + 500] * 4,  # 0.5 g
                },
            )
            enc.on_mesg(
                MN["GYROSCOPE_DATA"],
                {
                    "timestamp": 1001 + s,
                    "timestamp_ms": 500,
                    "sample_time_offset": [0, 20],
                    "gyro_x": [32768 + 10] * 2,  # 0 deg/s
                    "gyro_y": [32768 - 10 + 9000] * 2,  # 90 deg/s
                    "gyro_z": [32768] * 2,
                },
            )
            enc.on_mesg(
                MN["MAGNETOMETER_DATA"],
                {
                    "timestamp": 1001 + s,
                    "timestamp_ms": 0,
                    "sample_time_offset": [0],
                    "calibrated_mag_x": [0.2],
                    "calibrated_mag_y": [-0.05],
                    "calibrated_mag_z": [0.4],
                },
            )
    path.write_bytes(enc.close())
    return trk


def sdk_records(path: Path) -> list[dict]:
    """Records as the official SDK decodes them (the independent reference)."""
    msgs, errors = Decoder(FitStream.from_byte_array(bytearray(path.read_bytes()))).read()
    assert not errors
    return msgs["record_mesgs"]


def stream(rec, name):
    return next(s for s in rec.streams if s.name == name)


@pytest.mark.parametrize("enhanced", [True, False])
def test_fit_records_match_the_reference_decoder(tmp_path, enhanced):
    p = tmp_path / "act.fit"
    trk = write_fit(p, enhanced=enhanced)
    assert detect_format(p) == "fit"
    rec = read_recording(p)
    s = stream(rec, "fit_record")
    ref = sdk_records(p)
    # first-fix time: the SDK's datetime of the first record with a position
    first_ref = next(r for r in ref if "position_lat" in r)["timestamp"]
    lat = np.asarray(s.columns["lat"])
    first = np.flatnonzero(np.isfinite(lat))[0]
    assert rec.epoch_utc + s.t[first] == pytest.approx(first_ref.timestamp(), abs=1e-6)
    assert rec.epoch_utc == calendar.timegm(T0.timetuple())
    # fixes: semicircles -> deg, equal to the SDK's semicircles scaled, and to what was written (1 semicircle)
    sdk_lat = np.array([r.get("position_lat", np.nan) for r in ref], float) * 180.0 / 2**31
    sdk_lon = np.array([r.get("position_long", np.nan) for r in ref], float) * 180.0 / 2**31
    np.testing.assert_allclose(lat, sdk_lat, rtol=0, atol=1e-12, equal_nan=True)
    np.testing.assert_allclose(np.asarray(s.columns["lon"]), sdk_lon, rtol=0, atol=1e-12, equal_nan=True)
    ok = np.isfinite(lat)
    assert not ok[3] and ok.sum() == 29
    np.testing.assert_allclose(lat[ok], trk["lat"][ok], atol=180 / 2**31)
    # altitude is MSL: h_msl, never h; speed m/s, heart rate, cadence, power
    assert "h" not in s.columns
    np.testing.assert_allclose(s.columns["h_msl"], trk["alt"], atol=0.2 + 1e-9)  # 1/5 m resolution
    np.testing.assert_allclose(s.columns["gnss_speed"], trk["speed"], atol=1e-3 + 1e-9)
    np.testing.assert_array_equal(s.columns["heart_rate"], trk["hr"])
    np.testing.assert_array_equal(s.columns["cadence"], trk["cad"])
    np.testing.assert_array_equal(s.columns["power"], trk["power"])
    np.testing.assert_allclose(s.t, np.arange(30.0))


def test_fit_geoid_offset_gives_ellipsoidal_h(tmp_path):
    p = tmp_path / "act.fit"
    trk = write_fit(p)
    s = stream(read_recording(p, opts=Options(geoid_offset=47.5)), "fit_record")
    np.testing.assert_allclose(s.columns["h"], trk["alt"] + 47.5, atol=0.21)


def test_fit_camera_sensors_calibrated_and_put_on_utc(tmp_path):
    p = tmp_path / "cam.fit"
    write_fit(p, sensors=True)
    rec = read_recording(p)
    assert rec.epoch_utc == calendar.timegm(T0.timetuple())
    acc = stream(rec, "accelerometer")
    # system 1001 s is UTC T0 + 1001 - 1000.25 + 0.5 = T0 + 1.25 s
    np.testing.assert_allclose(acc.t[:4], 1.25 + np.array([0, 0.01, 0.02, 0.03]), atol=1e-9)
    assert acc.t.size == 12
    g = 9.80665
    # orientation matrix swaps x/y and flips z: body = (y_cal, x_cal, -z_cal) = (0, 1 g, -0.5 g)
    np.testing.assert_allclose(acc.columns["acc_x"], 0.0, atol=1e-9)
    np.testing.assert_allclose(acc.columns["acc_y"], g, atol=1e-9)
    np.testing.assert_allclose(acc.columns["acc_z"], -0.5 * g, atol=1e-9)
    gyr = stream(rec, "gyroscope")
    np.testing.assert_allclose(gyr.t[:2], [1.75, 1.77], atol=1e-9)
    np.testing.assert_allclose(gyr.columns["gyr_x"], math.radians(90.0), atol=1e-9)
    np.testing.assert_allclose(gyr.columns["gyr_y"], 0.0, atol=1e-9)
    mag = stream(rec, "magnetometer")
    np.testing.assert_allclose(mag.columns["mag_x"], 20.0, atol=1e-4)  # 0.2 G = 20 uT
    np.testing.assert_allclose(mag.columns["mag_z"], 40.0, atol=1e-4)


def test_fit_without_correlation_drops_device_clock_streams(tmp_path):
    p = tmp_path / "cam.fit"
    enc = Encoder()
    enc.on_mesg(MN["FILE_ID"], {"type": "activity", "manufacturer": "garmin", "product": 1, "time_created": T0})
    enc.on_mesg(MN["RECORD"], {"timestamp": T0, "position_lat": semi(47.0), "position_long": semi(11.0)})
    enc.on_mesg(
        MN["MAGNETOMETER_DATA"],
        {
            "timestamp": 1001,
            "sample_time_offset": [0],
            "calibrated_mag_x": [0.2],
            "calibrated_mag_y": [0.0],
            "calibrated_mag_z": [0.4],
        },
    )
    p.write_bytes(enc.close())
    rec = read_recording(p)
    assert [s.name for s in rec.streams] == ["fit_record"]
    assert any("timestamp_correlation" in w for w in rec.warnings)


def test_fit_cli_ingests_without_format(tmp_path):
    p = tmp_path / "act.fit"
    write_fit(p, sensors=True)
    r = run_cli(["ingest", str(p)])
    assert r.returncode == 0, r.stderr
    table = sfio.table_from_bytes(r.stdout)
    meta = sfio.get_meta(table)
    assert {"lat", "lon", "h_msl", "heart_rate", "power", "acc_x", "gyr_x", "mag_x"} <= set(table.column_names)
    assert meta["sources"][0]["format"] == "fit"
    assert table.schema.field("heart_rate").metadata[b"unit"] == b"1/min"


@pytest.mark.parametrize("damage", ["truncated", "crc", "body"])
def test_broken_fit_exits_1_with_one_line(tmp_path, damage):
    good = tmp_path / "good.fit"
    write_fit(good)
    data = bytearray(good.read_bytes())
    if damage == "truncated":
        data = data[: len(data) // 2]
    elif damage == "crc":
        data[-1] ^= 0xFF
    else:
        data[len(data) // 2] ^= 0x5A
    p = tmp_path / "bad.fit"
    p.write_bytes(bytes(data))
    with pytest.raises(InputError, match="truncated|corrupt"):
        read_recording(p)
    r = run_cli(["ingest", str(p)])
    assert r.returncode == 1
    assert r.stdout == b""
    lines = r.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: ingest:"), lines
    assert "Traceback" not in r.stderr.decode()


TCX = """

\ufeff<?xml version="1.0" encoding="UTF-8"?>
<TrainingCenterDatabase xmlns="http://www.garmin.com/xmlschemas/TrainingCenterDatabase/v2"
  xmlns:ns3="http://www.garmin.com/xmlschemas/ActivityExtension/v2">
 <Activities><Activity Sport="Other"><Id>2024-01-20T10:00:00Z</Id>
  <Lap StartTime="2024-01-20T10:00:00Z"><Track>
{points}
  </Track></Lap></Activity></Activities>
</TrainingCenterDatabase>
"""


def tcx_point(t, lat=None, lon=None, alt=None, hr=None, speed=None, watts=None, cad=None):
    pos = f"<Position><LatitudeDegrees>{lat}</LatitudeDegrees><LongitudeDegrees>{lon}</LongitudeDegrees></Position>"
    out = f"<Trackpoint><Time>{t}</Time>"
    if lat is not None:
        out += pos
    if alt is not None:
        out += f"<AltitudeMeters>{alt}</AltitudeMeters>"
    if hr is not None:
        out += f"<HeartRateBpm><Value>{hr}</Value></HeartRateBpm>"
    if cad is not None:
        out += f"<Cadence>{cad}</Cadence>"
    if speed is not None or watts is not None:
        out += "<Extensions><ns3:TPX>"
        out += f"<ns3:Speed>{speed}</ns3:Speed>" if speed is not None else ""
        out += f"<ns3:Watts>{watts}</ns3:Watts>" if watts is not None else ""
        out += "</ns3:TPX></Extensions>"
    return out + "</Trackpoint>"


def test_tcx_reads_points_with_whitespace_and_bom_before_declaration(tmp_path):
    pts = [
        tcx_point("2024-01-20T10:00:00Z", hr=100),  # no position yet
        tcx_point("2024-01-20T10:00:01.500Z", 47.1, 11.2, 1500.5, 101, 4.5, 210, 80),
        tcx_point("2024-01-20T11:00:02+01:00", 47.1001, 11.2002, 1499.0, 102, 5.0, 220, 81),
        "<Trackpoint><HeartRateBpm><Value>99</Value></HeartRateBpm></Trackpoint>",  # no time
    ]
    p = tmp_path / "a.tcx"
    p.write_text(TCX.format(points="\n".join(pts)), encoding="utf-8")
    assert detect_format(p) == "tcx"
    rec = read_recording(p)
    s = rec.streams[0]
    assert rec.epoch_utc == calendar.timegm(T0.timetuple())
    np.testing.assert_allclose(s.t, [0.0, 1.5, 2.0])
    np.testing.assert_allclose(s.columns["lat"], [np.nan, 47.1, 47.1001], equal_nan=True)
    np.testing.assert_allclose(s.columns["h_msl"], [np.nan, 1500.5, 1499.0], equal_nan=True)
    np.testing.assert_allclose(s.columns["heart_rate"], [100, 101, 102])
    np.testing.assert_allclose(s.columns["gnss_speed"], [np.nan, 4.5, 5.0], equal_nan=True)
    np.testing.assert_allclose(s.columns["power"], [np.nan, 210, 220], equal_nan=True)
    assert "h" not in s.columns
    assert any("without a readable <Time>" in w for w in rec.warnings)
    assert any("no Position" in w for w in rec.warnings)
    r = run_cli(["ingest", str(p)])
    assert r.returncode == 0, r.stderr
    table = sfio.table_from_bytes(r.stdout)
    assert table.num_rows == 3


def test_tcx_broken_xml_exits_1(tmp_path):
    p = tmp_path / "b.tcx"
    p.write_text(TCX.format(points=tcx_point("2024-01-20T10:00:00Z", 47, 11))[:-60])
    r = run_cli(["ingest", str(p)])
    assert r.returncode == 1 and r.stdout == b""
    assert r.stderr.decode().startswith("Error: ingest:") and len(r.stderr.decode().strip().splitlines()) == 1


def test_fit_device_clock_drift_follows_several_correlations(tmp_path):
    p = tmp_path / "cam.fit"
    enc = Encoder()
    enc.on_mesg(MN["FILE_ID"], {"type": "activity", "manufacturer": "garmin", "product": 1, "time_created": T0})
    enc.on_mesg(MN["RECORD"], {"timestamp": T0, "position_lat": semi(47.0), "position_long": semi(11.0)})
    # system 1000 s = T0; system 2000 s = T0 + 1000.1 s (the device clock loses 0.1 s in 1000 s)
    enc.on_mesg(MN["TIMESTAMP_CORRELATION"], {"timestamp": T0, "system_timestamp": 1000})
    enc.on_mesg(
        MN["TIMESTAMP_CORRELATION"],
        {"timestamp": T0 + dt.timedelta(seconds=1000), "fractional_timestamp": 0.1, "system_timestamp": 2000},
    )
    mag = {"calibrated_mag_x": [0.2], "calibrated_mag_y": [0.0], "calibrated_mag_z": [0.4]}
    for sys_t in (1500, 2500):
        enc.on_mesg(MN["MAGNETOMETER_DATA"], {"timestamp": sys_t, "sample_time_offset": [0], **mag})
    p.write_bytes(enc.close())
    rec = read_recording(p)
    m = stream(rec, "magnetometer")
    np.testing.assert_allclose(m.t, [500.05, 1500.1], atol=1e-6)  # interpolated inside, constant outside


def test_fit_out_of_order_and_repeated_records_follow_the_time_policy(tmp_path):
    p = tmp_path / "odd.fit"
    enc = Encoder()
    enc.on_mesg(MN["FILE_ID"], {"type": "activity", "manufacturer": "garmin", "product": 1, "time_created": T0})
    for s, hr in ((0, 100), (2, 102), (1, 101), (2, 150)):  # a backwards second, then a repeat that disagrees
        enc.on_mesg(
            MN["RECORD"],
            {
                "timestamp": T0 + dt.timedelta(seconds=s),
                "position_lat": semi(47.0 + s * 1e-5),
                "position_long": semi(11.0),
                "heart_rate": hr,
            },
        )
    p.write_bytes(enc.close())
    r = run_cli(["ingest", str(p)])
    assert r.returncode == 0, r.stderr
    table = sfio.table_from_bytes(r.stdout)
    np.testing.assert_allclose(table.column("t").to_numpy(), [0.0, 1.0, 2.0])
    np.testing.assert_allclose(table.column("heart_rate").to_numpy(), [100, 101, 102])  # the first in file order wins
    assert "backward" in r.stderr.decode() and "conflict" in r.stderr.decode()  # reported, not silent


def test_fit_record_clock_jump_of_days_is_reported_and_kept(tmp_path):
    """A watch whose record clock jumps 20 days mid-file while its session's elapsed time is 20 minutes:
    one warning names the jump and the elapsed time; the timeline is kept as written (not re-based)."""
    p = tmp_path / "jump.fit"
    enc = Encoder()
    enc.on_mesg(MN["FILE_ID"], {"type": "activity", "manufacturer": "garmin", "product": 1, "time_created": T0})
    times = [T0 + dt.timedelta(seconds=s) for s in range(600)]
    times += [T0 + dt.timedelta(days=20, seconds=600 + s) for s in range(600)]
    for i, ts in enumerate(times):
        enc.on_mesg(
            MN["RECORD"],
            {"timestamp": ts, "position_lat": semi(47.0 + i * 2e-5), "position_long": semi(11.0), "heart_rate": 120},
        )
    enc.on_mesg(
        MN["SESSION"],
        {"timestamp": times[-1], "start_time": T0, "total_elapsed_time": 1200.0, "total_timer_time": 1200.0},
    )
    p.write_bytes(enc.close())
    rec = read_recording(p)
    (st,) = [s for s in rec.streams if s.name == "fit_record"]
    d = np.diff(st.t)
    assert d.max() == pytest.approx(20 * 86400 + 1.0)  # kept as written
    line = next(w for w in rec.warnings if "record clock" in w)
    assert "forward by 20.0 d" in line and "elapsed time" in line and "0.3 h" in line and "kept as written" in line


def test_tcx_schema_invalid_markers_are_null_and_counted(tmp_path):
    """Cadence 255, heart rate 0, a negative speed and a position off the globe are no values (TCX v2 schema)."""
    pts = [
        tcx_point("2024-01-20T10:00:00Z", 47.1, 11.2, 1500.0, 120, 4.0, 200, 80),
        tcx_point("2024-01-20T10:00:01Z", 47.1001, 11.2001, 1500.5, 0, -1, 210, 255),
        tcx_point("2024-01-20T10:00:02Z", 180.0, 360.0, 1501.0, 121, 4.2, 220, 81),
        tcx_point("2024-01-20T10:00:03Z", 47.1003, 11.2003, 1501.5, 122, 4.3, 230, 82),
    ]
    p = tmp_path / "m.tcx"
    p.write_text(TCX.format(points="\n".join(pts)), encoding="utf-8")
    rec = read_recording(p)
    c = rec.streams[0].columns
    np.testing.assert_allclose(c["cadence"], [80, np.nan, 81, 82], equal_nan=True)
    np.testing.assert_allclose(c["heart_rate"], [120, np.nan, 121, 122], equal_nan=True)
    np.testing.assert_allclose(c["gnss_speed"], [4.0, np.nan, 4.2, 4.3], equal_nan=True)
    np.testing.assert_allclose(c["lat"], [47.1, 47.1001, np.nan, 47.1003], equal_nan=True)
    np.testing.assert_allclose(c["lon"], [11.2, 11.2001, np.nan, 11.2003], equal_nan=True)
    np.testing.assert_allclose(c["power"], [200, 210, 220, 230])  # valid values untouched
    assert not any(k.startswith("vel_") for k in c)  # nothing derived from the markers
    (line,) = [w for w in rec.warnings if "invalid markers" in w]
    assert "1 cadence" in line and "1 heart_rate" in line and "1 gnss_speed" in line and "1 lat/lon" in line
    r = run_cli(["ingest", str(p)])
    assert r.returncode == 0, r.stderr
    assert "invalid markers" in r.stderr.decode()


def test_fit_base_type_invalid_values_are_null_and_counted(tmp_path):
    """A record whose fields hold FIT's invalid values (0x7FFFFFFF sint32 position, 0xFF uint8, 0xFFFF uint16,
    0xFFFFFFFF uint32, 0x7F sint8) reads as nulls, counted in one warning; the valid records are untouched."""
    enc = Encoder()
    enc.on_mesg(MN["FILE_ID"], {"type": "activity", "manufacturer": "garmin", "product": 1, "time_created": T0})
    good = {
        "position_lat": semi(47.3),
        "position_long": semi(11.4),
        "heart_rate": 120,
        "cadence": 80,
        "power": 200,
        "enhanced_altitude": 1800.0,
        "enhanced_speed": 5.0,
        "temperature": 5,
    }
    invalid = {
        "position_lat": 0x7FFFFFFF,
        "position_long": 0x7FFFFFFF,
        "heart_rate": 0xFF,
        "cadence": 0xFF,
        "power": 0xFFFF,
        "enhanced_altitude": 0xFFFFFFFF / 5 - 500,  # scale 5, offset 500: the raw value is 0xFFFFFFFF
        "enhanced_speed": 0xFFFFFFFF / 1000,  # scale 1000
        "temperature": 0x7F,
    }
    for i in range(4):
        enc.on_mesg(MN["RECORD"], {"timestamp": T0 + dt.timedelta(seconds=i), **(invalid if i == 2 else good)})
    p = tmp_path / "inv.fit"
    p.write_bytes(enc.close())
    assert sdk_records(p)[2].get("heart_rate") in (None, 255)  # the SDK decodes the marker too (no value)
    rec = read_recording(p)
    c = stream(rec, "fit_record").columns
    for col, v in (
        ("lat", 47.3),
        ("h_msl", 1800.0),
        ("gnss_speed", 5.0),
        ("heart_rate", 120),
        ("cadence", 80),
        ("power", 200),
        ("temperature", 5),
    ):
        np.testing.assert_allclose(c[col], [v, v, np.nan, v], equal_nan=True, atol=1e-6, err_msg=col)
    assert not any(k.startswith("vel_") for k in c)
    (line,) = [w for w in rec.warnings if "invalid markers" in w]
    for part in ("1 lat/lon", "1 h_msl", "1 gnss_speed", "1 heart_rate", "1 cadence", "1 power", "1 temperature"):
        assert part in line


def test_fit_invalid_array_elements_of_imu_messages_are_null(tmp_path):
    """A raw count holding uint16's invalid value (0xFFFF) in an accelerometer message is no value: that
    sample's calibrated vector (every axis goes through the orientation matrix) is null, counted."""
    enc = Encoder()
    enc.on_mesg(MN["FILE_ID"], {"type": "activity", "manufacturer": "garmin", "product": 1, "time_created": T0})
    enc.on_mesg(MN["RECORD"], {"timestamp": T0, "position_lat": semi(47.3), "position_long": semi(11.4)})
    cal = {"calibration_factor": 1, "calibration_divisor": 1000, "level_shift": 32768, "offset_cal": [0, 0, 0]}
    enc.on_mesg(
        MN["THREE_D_SENSOR_CALIBRATION"],
        {"timestamp": T0, "sensor_type": "accelerometer", **cal, "orientation_matrix": [1, 0, 0, 0, 1, 0, 0, 0, 1]},
    )
    for s in range(2):
        enc.on_mesg(
            MN["ACCELEROMETER_DATA"],
            {
                "timestamp": T0 + dt.timedelta(seconds=s),
                "timestamp_ms": 0,
                "sample_time_offset": [0, 500],
                "accel_x": [32768, 0xFFFF if s == 1 else 32768],
                "accel_y": [32768, 32768],
                "accel_z": [32768 + 1000, 32768 + 1000],  # 1 g
            },
        )
    p = tmp_path / "acc.fit"
    p.write_bytes(enc.close())
    rec = read_recording(p)
    acc = stream(rec, "accelerometer")
    np.testing.assert_allclose(acc.columns["acc_z"], [9.80665] * 3 + [np.nan], atol=1e-9, equal_nan=True)
    assert np.isnan(acc.columns["acc_x"][3]) and np.isfinite(acc.columns["acc_x"][:3]).all()
    (line,) = [w for w in rec.warnings if "invalid markers" in w]
    assert "accelerometer_data messages: 3 acc_x/y/z" in line
