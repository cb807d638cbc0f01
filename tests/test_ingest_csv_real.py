"""Generic CSVs as loggers write them: no header, columns by number, raw counts, ticks, per-input maps,
our own ``inspect --csv`` read back, and a session Parquet merged with raw files in one ingest call."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core.errors import InputError
from sportfusion.core.meta import epoch_unix
from sportfusion.core.session import Stream, merge_streams
from sportfusion.ingest import Options, csvmap, read_recording
from sportfusion.ingest._text import parse_unit, scaled_factor

BIN = Path(sys.executable).parent
G = 9.80665
EPOCH = 1_767_618_000.0  # 2026-01-05 13:00:00 UTC


def vals(rec, name):
    v = rec.streams[0].columns[name]
    return np.array(v.to_pylist(), dtype=float) if hasattr(v, "to_pylist") else np.asarray(v, dtype=float)


def test_scaled_units_parse():
    assert parse_unit("0.000244g") == (0.000244, "g")
    assert parse_unit("4.375e-3 deg/s") == (4.375e-3, "deg/s")
    assert parse_unit("0.1*mG") == (0.1, "mG")
    assert parse_unit("1") == (1.0, "1") and parse_unit("deg/s") == (1.0, "deg/s")
    assert scaled_factor("mg", "m/s^2", "x") == pytest.approx(G / 1000)
    assert scaled_factor("2", "m/s^2", "x") == 2.0  # a number alone scales into the column's unit
    assert scaled_factor("0.0001s", "s", "x") == pytest.approx(1e-4)


def test_headerless_logger_counts_and_ticks(tmp_path):
    """A 16-bit IMU logger: tick counter at 400 Hz, +-2 g (16384 counts/g), +-250 deg/s (131 counts/(deg/s))."""
    p = tmp_path / "imu.csv"
    p.write_text("1000 16384 0 -8192 131 0 -262\n1001 0 16384 0 0 13.1 0\n1003 -16384 0 0 0 0 1310\n")
    opts = Options(
        column_map={"t": "1", "acc_x": "2", "acc_y": "3", "acc_z": "4", "gyr_x": "5", "gyr_y": "6", "gyr_z": "7"},
        units={"t": "ticks", "acc": f"{1 / 16384!r}g", "gyr": f"{1 / 131!r}deg/s"},
        rate=400.0,
    )
    rec = csvmap.read(p, opts)
    np.testing.assert_allclose(rec.streams[0].t, [2.5, 2.5025, 2.5075], atol=1e-12)  # ticks / 400 Hz
    assert rec.epoch_utc is None
    np.testing.assert_allclose(vals(rec, "acc_x"), [G, 0.0, -G], atol=1e-12)
    np.testing.assert_allclose(vals(rec, "acc_z"), [-G / 2, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(vals(rec, "gyr_y"), [0.0, math.radians(0.1), 0.0], atol=1e-12)
    np.testing.assert_allclose(vals(rec, "gyr_z"), [math.radians(-2), 0.0, math.radians(10)], atol=1e-12)
    assert rec.meta["header"].startswith("none")
    with pytest.raises(InputError, match="needs the sampling rate"):
        csvmap.read(p, Options(column_map={"t": "1", "acc_x": "2"}, units={"t": "ticks"}))
    with pytest.raises(InputError, match="the file has 7 column"):
        csvmap.read(p, Options(column_map={"t": "1", "acc_x": "9"}))
    with pytest.raises(InputError, match="nor any gyr_"):
        csvmap.read(p, Options(column_map={"t": "1", "acc_x": "2"}, units={"gyr": "deg/s"}))


def test_numbers_on_a_file_with_a_header_and_unix_nanoseconds(tmp_path):
    p = tmp_path / "log.csv"
    t0 = 1_767_618_000_123_456_789
    p.write_text(f"stamp;ax;ay\n{t0};1;2\n{t0 + 3};1;2\n{t0 + 10_000_000};-1000;2\n")
    rec = csvmap.read(p, Options(column_map={"t": "1", "acc_x": "2"}, units={"t": "ns", "acc_x": "mg"}))
    assert rec.epoch_utc == pytest.approx(EPOCH + 0.123456789, abs=1e-6)
    np.testing.assert_allclose(rec.streams[0].t, [0.0, 3e-9, 0.01], rtol=0, atol=1e-15)
    np.testing.assert_allclose(vals(rec, "acc_x"), [G / 1000, G / 1000, -G])
    assert rec.warnings == ["column(s) not mapped and not read: ay"]


def _session(tmp_path: Path) -> Path:
    t_imu = np.arange(6) * 0.01
    t_gps = np.array([0.0, 0.05])
    rng = np.random.default_rng(2)
    acc = rng.normal(0, 3, (6, 3))
    streams = [
        Stream("imu", t_imu, {f"acc_{a}": acc[:, k] for k, a in enumerate("xyz")} | {"mag_x": acc[:, 0] / 50}),
        Stream(
            "gps",
            t_gps,
            {
                "lat": np.array([47.123456789012, 47.123457]),
                "lon": np.array([10.1, 10.100001]),
                "h": np.array([900.25, 900.5]),
                "gnss_fix": np.array([4, 5], dtype=np.int16),
            },
        ),
        Stream("ev", np.array([0.03]), {"event": pa.array(["takeoff"]), "grip": pa.array([True])}),
    ]
    table, _ = merge_streams(streams)
    meta = sfmeta.new_meta("session", EPOCH + 0.5)
    meta["units"] = {"mag_x": "1"}
    meta["frame"] = {
        "name": "ned",
        "origin": [47.0, 10.0, 900.0],
        "azimuth_deg": 0.0,
        "axes": "x north, y east, z down",
    }
    p = tmp_path / "s.parquet"
    sfio.write_table(table, meta, p)
    return p


def test_inspect_csv_reads_back_without_a_map(tmp_path):
    src = _session(tmp_path)
    table0, _ = sfio.read_table(src, kind="session")
    csv = tmp_path / "s.csv"
    with csv.open("wb") as fh:
        proc = subprocess.run([str(BIN / "inspect"), str(src), "--csv"], stdout=fh, stderr=subprocess.PIPE, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    out = tmp_path / "back.parquet"
    proc = subprocess.run([str(BIN / "ingest"), str(csv), "-o", str(out)], capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    assert "t is relative" in proc.stderr.decode()  # the CSV carries no epoch: said, not guessed
    table, meta = sfio.read_table(out, kind="session")
    assert meta["sources"][0]["format"] == "csvmap" and epoch_unix(meta) is None
    np.testing.assert_allclose(table.column("t").to_numpy(), table0.column("t").to_numpy(), rtol=0, atol=1e-12)
    for name in ("acc_x", "acc_y", "acc_z", "mag_x", "lat", "lon", "h"):
        a, b = table0.column(name).to_pylist(), table.column(name).to_pylist()
        assert [x is None for x in a] == [x is None for x in b], name
        np.testing.assert_allclose([x for x in b if x is not None], [x for x in a if x is not None], rtol=1e-15)
    assert (
        table.column("gnss_fix").type == pa.int16()
        and table.column("gnss_fix").to_pylist() == table0.column("gnss_fix").to_pylist()
    )
    assert table.column("event").to_pylist() == table0.column("event").to_pylist()
    assert table.column("grip").to_pylist() == table0.column("grip").to_pylist()
    assert table.schema.field("lat").metadata[b"unit"] == b"deg"
    assert table.schema.field("acc_x").metadata[b"unit"] == b"m/s^2"
    assert meta["units"] == {"mag_x": "1"}  # a normalised magnetometer stays normalised
    assert csvmap.sniff(csv, csv.read_bytes()[:4096])


POS = """\
% program   : RTKPOST ver.2.4.3 b34
% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,ns=# of satellites)
%  UTC                   latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio
2026/01/05 13:00:01.000    47.000000000   10.000000000   900.0000   1  12   0.0050   0.0040   0.0120   0.0010  -0.0020   0.0030   0.00  999.9
2026/01/05 13:00:01.200    47.000001000   10.000001000   900.0100   2  12   0.1500   0.2000   0.4000  -0.0500   0.0600  -0.0700   0.20    2.1
"""


def test_pos_headerless_imu_and_a_session_merge_in_one_call(tmp_path):
    pos = tmp_path / "rover.pos"
    pos.write_text(POS)
    imu = tmp_path / "imu.csv"  # Unix milliseconds, counts of 1 mg
    imu.write_text("".join(f"{int((EPOCH + 1) * 1000) + 10 * k},{k},0,1000\n" for k in range(30)))
    sess = _session(tmp_path)
    out = tmp_path / "m.parquet"
    cmd = [str(BIN / "ingest"), str(pos), str(imu), str(sess), "-o", str(out)]
    cmd += ["--map", "imu.csv:t=1,acc_x=2,acc_y=3,acc_z=4", "--units", "imu.csv:t=ms,acc=mg"]
    proc = subprocess.run(cmd, capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    table, meta = sfio.read_table(out, kind="session")
    assert [s["format"] for s in meta["sources"]] == ["rtklib", "csvmap", "session"]
    assert epoch_unix(meta) == pytest.approx(EPOCH + 0.5)  # the session's epoch is the earliest
    t = table.column("t").to_numpy()
    acc_z = table.column("acc_z").to_numpy(zero_copy_only=False)
    imu_rows = np.isclose(acc_z, G, atol=1e-12)
    assert imu_rows.sum() == 30
    np.testing.assert_allclose(t[imu_rows][:2], [0.5, 0.51], atol=1e-9)  # 13:00:01 UTC on a 13:00:00.5 clock
    assert table.column("rtk_q").to_pylist().count(2) == 1
    lat_rows = ~np.isnan(table.column("lat").to_numpy(zero_copy_only=False))
    assert lat_rows.sum() == 2 + 2  # two fixes from the .pos, two from the session
    assert meta["units"] == {"mag_x": "1"} and meta["frame"]["name"] == "ned"  # carried from the session
    # a prefix naming no input is a usage error
    bad = [str(BIN / "ingest"), str(pos), str(imu), "--map", "nope.csv:t=1", "-o", str(out)]
    proc = subprocess.run(bad, capture_output=True, timeout=120)
    assert proc.returncode == 2 and proc.stdout == b"" and b"not one of the inputs" in proc.stderr


def test_contract_csv_field_in_microtesla_stays_microtesla(tmp_path):
    p = tmp_path / "own.csv"
    p.write_text('"t","mag_x","mag_y","mag_z","gnss_fix"\n0,20.5,1,43.25,4\n0.01,20.5,1.5,43,\n')
    rec = read_recording(p)
    assert rec.format == "csvmap" and "units" not in rec.meta
    assert vals(rec, "mag_z").tolist() == [43.25, 43.0]
    assert rec.streams[0].columns["gnss_fix"].to_pylist() == [4, None]
    p.write_text('"t","mag_x","mag_y","mag_z"\n0,0.4,0.02,0.9\n')
    rec = read_recording(p)
    assert rec.meta["units"] == {"mag_x": "1", "mag_y": "1", "mag_z": "1"}
    assert any("read as normalised" in w for w in rec.warnings)


def test_comment_lines_and_iso_times_in_a_headerless_file(tmp_path):
    p = tmp_path / "logger.txt"
    p.write_text(
        "# logger v2.1, serial 42\n# units: mg\n2026-01-05T13:00:00.000Z;12;-980\n2026-01-05T13:00:00.010Z;10;-981\n"
    )
    rec = csvmap.read(
        p, Options(column_map={"t": "1", "acc_x": "2", "acc_z": "3"}, time_unit="iso", units={"acc": "mg"})
    )
    assert rec.epoch_utc == pytest.approx(EPOCH)
    np.testing.assert_allclose(rec.streams[0].t, [0.0, 0.01], atol=1e-9)
    np.testing.assert_allclose(vals(rec, "acc_z"), [-0.980 * G, -0.981 * G])
    assert rec.warnings == ["2 leading comment line(s) skipped"]
