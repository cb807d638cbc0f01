"""Generic CSV through a column map: dialects, units, time units, errors; values hand-computed."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sportfusion.core import io as sfio
from sportfusion.core.errors import InputError
from sportfusion.core.meta import epoch_unix
from sportfusion.ingest import Options, csvmap

BIN = Path(sys.executable).parent


def write(tmp_path: Path, text: str, name: str = "log.csv") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def vals(rec, col):
    v = rec.streams[0].columns[col]
    return np.array(v.to_pylist(), dtype=float) if hasattr(v, "to_pylist") else np.asarray(v, dtype=float)


@pytest.mark.parametrize(
    "text",
    [
        "Time,AccX,GyrZ,Note\n0,1,90,a\n100,0.5,NaN,b\n250,2,-180,c\n",
        "Time;AccX;GyrZ;Note\n0;1;90;a\n100;0,5;NaN;b\n250;2;-180;c\n",
        "Time\tAccX\tGyrZ\tNote\n0\t1\t90\ta\n100\t0,5\t\tb\n250\t2\t-180\tc\n",
    ],
    ids=["comma", "semicolon-decimal-comma", "tab-decimal-comma-empty-cell"],
)
def test_mapped_columns_units_and_time_unit(tmp_path, text):
    opts = Options(
        column_map={"t": "Time", "acc_x": "AccX", "gyr_z": "GyrZ"},
        time_unit="ms",
        units={"acc_x": "g", "gyr_z": "deg/s"},
    )
    rec = csvmap.read(write(tmp_path, text), opts)
    s = rec.streams[0]
    np.testing.assert_allclose(s.t, [0.0, 0.1, 0.25])
    np.testing.assert_allclose(vals(rec, "acc_x"), [9.80665, 4.903325, 19.6133])
    g = vals(rec, "gyr_z")
    assert g[0] == pytest.approx(math.pi / 2) and math.isnan(g[1]) and g[2] == pytest.approx(-math.pi)
    assert rec.epoch_utc is None
    assert rec.warnings == ["column(s) not mapped and not read: Note"]


def test_unix_and_iso_times_give_an_epoch(tmp_path):
    p = write(tmp_path, "ts,lat\n1742032800000,47.0\n1742032800500,47.1\n")
    rec = csvmap.read(p, Options(column_map={"t": "ts", "lat": "lat"}, time_unit="ms"))
    assert rec.epoch_utc == 1742032800.0
    np.testing.assert_allclose(rec.streams[0].t, [0.0, 0.5])
    p = write(tmp_path, "when,lat\n2025-03-15T10:00:00.25Z,47.0\n2025-03-15T11:00:01+01:00,47.1\n", "iso.csv")
    rec = csvmap.read(p, Options(column_map={"t": "when", "lat": "lat"}, time_unit="iso"))
    assert rec.epoch_utc == pytest.approx(1742032800.25)
    np.testing.assert_allclose(rec.streams[0].t, [0.0, 0.75])


def test_normalised_magnetometer_declared(tmp_path):
    p = write(tmp_path, "t,mx\n0,0.5\n1,0.6\n")
    rec = csvmap.read(p, Options(column_map={"t": "t", "mag_x": "mx"}, units={"mag_x": "1"}))
    assert rec.meta["units"] == {"mag_x": "1"}
    assert vals(rec, "mag_x").tolist() == [0.5, 0.6]


def test_errors_name_the_problem(tmp_path):
    p = write(tmp_path, "Time,AccX\n0,1\n1,x\n")
    with pytest.raises(InputError, match="time column mapped"):
        csvmap.read(p, Options(column_map={"acc_x": "AccX"}))
    with pytest.raises(InputError, match="acc_x=Ax: no such header; the file has Time, AccX"):
        csvmap.read(p, Options(column_map={"t": "Time", "acc_x": "Ax"}))
    with pytest.raises(InputError, match="'AccX' holds text"):
        csvmap.read(p, Options(column_map={"t": "Time", "acc_x": "AccX"}))
    q = write(tmp_path, "Time,AccX\n0,1\n", "q.csv")
    with pytest.raises(InputError, match="unknown unit 'furlong'"):
        csvmap.read(q, Options(column_map={"t": "Time", "acc_x": "AccX"}, units={"acc_x": "furlong"}))
    with pytest.raises(InputError, match="'deg/s' does not convert"):
        csvmap.read(q, Options(column_map={"t": "Time", "acc_x": "AccX"}, units={"acc_x": "deg/s"}))
    with pytest.raises(InputError, match="not ISO-8601"):
        csvmap.read(q, Options(column_map={"t": "Time", "acc_x": "AccX"}, time_unit="iso"))
    assert not csvmap.sniff(q, q.read_bytes())


def test_command_with_map_picks_the_generic_reader(tmp_path):
    p = write(tmp_path, "Time;AccX;AccY;AccZ\n0;0,1;0;1\n10;0,2;0;1\n")
    out = tmp_path / "s.parquet"
    cmd = [str(BIN / "ingest"), str(p), "--map", "t=Time,acc_x=AccX", "--map", "acc_y=AccY,acc_z=AccZ"]
    cmd += ["--time-unit", "ms", "--units", "acc_x=g,acc_y=g,acc_z=g", "-o", str(out)]
    proc = subprocess.run(cmd, capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    table, meta = sfio.read_table(out, kind="session")
    assert table.column("t").to_pylist() == [0.0, 0.01]
    assert table.column("acc_x").to_pylist() == pytest.approx([0.980665, 1.96133])
    assert table.column("acc_z").to_pylist() == pytest.approx([9.80665, 9.80665])
    assert epoch_unix(meta) is None and meta["sources"][0]["format"] == "csvmap"
    # without --map a plain CSV is not recognised: one Error line, nothing on stdout
    proc = subprocess.run([str(BIN / "ingest"), str(p), "-o", str(out)], capture_output=True, timeout=120)
    assert proc.returncode == 1 and proc.stdout == b""
    assert proc.stderr.decode().startswith("Error: ingest:") and "--map" in proc.stderr.decode()


def test_declared_invalid_markers_are_null_and_counted(tmp_path):
    """--invalid: the markers a logger documents are null (matched as written, before unit conversion);
    values that merely look like markers elsewhere, and undeclared columns, are untouched."""
    text = (
        "time,speed,course,AccX,AccY,AccZ,alt\n"
        "0,1.5,90,0.1,0.2,1.0,500\n"
        "1,-1.0,-1,-999,0.2,1.0,---\n"  # unknown speed and course (iOS), the logger's -999 and ---
        "2,2.5,-1,0.1,9999,-1,501\n"  # acc_z -1 g is a value: only -999/9999 are declared for acc
        "3,3.0,180,0.1,0.2,1.0,502\n"
    )
    p = write(tmp_path, text)
    cmap = {"t": "time", "gnss_speed": "speed", "gnss_course": "course", "h_msl": "alt"}
    cmap |= {f"acc_{a}": f"Acc{a.upper()}" for a in "xyz"}
    opts = Options(
        column_map=cmap,
        units={"gnss_speed": "km/h", "acc": "g"},
        invalid={"gnss_speed": "-1", "gnss_course": "-1", "acc": "-999/9999", "h_msl": "---"},
    )
    rec = csvmap.read(p, opts)
    np.testing.assert_allclose(vals(rec, "gnss_speed"), [1.5 / 3.6, np.nan, 2.5 / 3.6, 3.0 / 3.6], equal_nan=True)
    np.testing.assert_allclose(vals(rec, "gnss_course"), [90, np.nan, np.nan, 180], equal_nan=True)
    np.testing.assert_allclose(vals(rec, "acc_x"), np.array([0.1, np.nan, 0.1, 0.1]) * 9.80665, equal_nan=True)
    np.testing.assert_allclose(vals(rec, "acc_y"), np.array([0.2, 0.2, np.nan, 0.2]) * 9.80665, equal_nan=True)
    np.testing.assert_allclose(vals(rec, "acc_z"), np.array([1.0, 1.0, -1.0, 1.0]) * 9.80665)
    np.testing.assert_allclose(vals(rec, "h_msl"), [500, np.nan, 501, 502], equal_nan=True)
    assert not any(k.startswith("vel_") for k in rec.streams[0].columns)
    (line,) = [w for w in rec.warnings if "invalid markers" in w]
    assert "1 gnss_speed (-1)" in line and "2 gnss_course (-1)" in line and "1 h_msl (---)" in line
    assert "1 acc_x (-999/9999)" in line and "1 acc_y (-999/9999)" in line and "acc_z" not in line
    # without --invalid nothing is guessed: -1 km/h stays a (nonsense) value
    plain = csvmap.read(p, Options(column_map={"t": "time", "gnss_speed": "speed"}))
    assert vals(plain, "gnss_speed")[1] == -1.0
    # '*' declares a marker for every mapped column but t; t takes none
    star = csvmap.read(p, Options(column_map={"t": "time", "gnss_course": "course"}, invalid={"*": "-1"}))
    assert np.isnan(vals(star, "gnss_course")[1:3]).all()
    with pytest.raises(InputError, match="time column takes no invalid markers"):
        csvmap.read(p, Options(column_map={"t": "time"}, invalid={"t": "0"}))
    with pytest.raises(InputError, match="does not map"):
        csvmap.read(p, Options(column_map={"t": "time"}, invalid={"gyr": "0"}))


def test_invalid_option_on_the_command_line(tmp_path):
    p = write(tmp_path, "time,speed\n0,1.5\n1,-1\n2,2.0\n")
    r = subprocess.run(
        [BIN / "ingest", str(p), "--map", "t=time,gnss_speed=speed", "--invalid", "gnss_speed=-1"],
        capture_output=True,
    )
    assert r.returncode == 0, r.stderr
    assert "invalid markers (declared by --invalid) read as null: 1 gnss_speed (-1)" in r.stderr.decode()
    t = sfio.table_from_bytes(r.stdout)
    assert t.column("gnss_speed").to_pylist()[1] is None
    gpx = tmp_path / "a.gpx"
    gpx.write_text(
        '<?xml version="1.0"?><gpx version="1.1" creator="t" xmlns="http://www.topografix.com/GPX/1/1"><trk><trkseg>'
        '<trkpt lat="47" lon="11"><time>2024-01-01T00:00:00Z</time></trkpt></trkseg></trk></gpx>'
    )
    r = subprocess.run([BIN / "ingest", str(gpx), "--invalid", "h=-1"], capture_output=True)
    assert r.returncode == 2 and r.stdout == b"" and "--invalid" in r.stderr.decode()
