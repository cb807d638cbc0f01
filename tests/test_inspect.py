"""inspect: the text view names columns with unit/type/nulls, sensor rates, metadata and rows; --csv, --json."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pyarrow as pa
import pytest
from click.testing import CliRunner

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import schema
from sportfusion.core.describe import sensor_rates
from sportfusion.core.session import Stream, merge_streams
from sportfusion.tools.inspect_cmd import main


def session_bytes() -> tuple[bytes, pa.Table]:
    t_imu = np.arange(200) * 0.01  # 100 Hz, 0 .. 1.99 s
    t_gps = 0.05 + np.arange(10) * 0.2  # 5 Hz, 0.05 .. 1.85 s
    table, _ = merge_streams(
        [
            Stream("imu", t_imu, {"acc_x": np.sin(t_imu), "gyr_x": np.cos(t_imu)}),
            Stream("gps", t_gps, {"lat": 47.4 + 1e-6 * np.arange(10), "gnss_fix": np.full(10, 4)}),
        ]
    )
    meta = sfmeta.new_meta("session", 1_742_032_800.0)
    meta["frame"] = {"name": "hill", "origin": [47.4, 10.3, 900.0], "azimuth_deg": 12.5, "axes": "x forward"}
    meta["hill"] = {"name": "oberstdorf-hs137"}
    meta["events"] = [{"name": "takeoff", "t": 1.23}]
    meta = sfmeta.add_provenance(meta, "ingest", {"raw": ["a.zip"]})
    return sfio.table_to_bytes(table, meta), table


def run(args: list[str], data: bytes):
    res = CliRunner().invoke(main, args, input=data)
    assert res.exit_code == 0, res.output
    return res.stdout


def test_plain_view_has_every_part():
    data, table = session_bytes()
    out = run(["--rows", "3"], data)
    lines = out.splitlines()
    assert lines[0] == f"kind: session   rows: {table.num_rows}   columns: 5"
    assert "time origin (t = 0): 2025-03-15T10:00:00.000000Z" in out
    gps_nulls = table.num_rows - 10
    row = next(ln for ln in lines if ln.strip().startswith("lat "))
    assert "double" in row and "[deg]" in row and f"nulls {gps_nulls} " in row
    row = next(ln for ln in lines if ln.strip().startswith("gnss_fix "))
    assert "int16" in row and "[1]" in row
    acc = next(ln for ln in lines if ln.strip().startswith("accelerometer "))
    assert "200 samples" in acc and "0.000 .. 1.990 s" in acc and "100 Hz" in acc
    gnss = next(ln for ln in lines if ln.strip().startswith("gnss "))
    assert "10 samples" in gnss and "0.050 .. 1.850 s" in gnss and " 5 Hz" in gnss
    assert '"azimuth_deg": 12.5' in out and "oberstdorf-hs137" in out and '"takeoff"' in out
    assert "1. ingest" in out and "raw=['a.zip']" in out
    head = lines.index("head:")
    tail = lines.index("tail:")
    assert tail - head == 5  # title, header, 3 rows
    assert lines[head + 2].split()[0] == "0.000"  # seconds with 3 decimals
    assert lines[-1].split()[0] == f"{table.column('t')[-1].as_py():.3f}"


def test_csv_dumps_every_row_and_json_the_metadata():
    data, table = session_bytes()
    rows = list(csv.reader(io.StringIO(run(["--csv"], data))))
    assert rows[0] == table.column_names
    assert len(rows) - 1 == table.num_rows
    assert float(rows[6][0]) == table.column("t")[5].as_py()
    doc = json.loads(run(["--json"], data))
    assert doc["metadata"] == sfio.read_table(io.BytesIO(data))[1]
    assert doc["rows"] == table.num_rows
    units = {c["name"]: c["unit"] for c in doc["columns"]}
    assert [c["name"] for c in doc["columns"]] == table.column_names
    for name in table.column_names:
        assert units[name] == (schema.unit_of(name) or ""), name
    res = CliRunner().invoke(main, ["--csv", "--json"], input=data)
    assert res.exit_code == 2


def test_sensor_rates_of_an_irregular_stream_use_the_median_step():
    t = np.array([0.0, 0.1, 0.2, 0.3, 1.3])  # one gap
    table = pa.table({"t": t, "mag_x": [1.0, 2.0, 3.0, 4.0, 5.0]})
    (r,) = sensor_rates(table)
    assert r["sensor"] == "magnetometer" and r["samples"] == 5
    assert abs(r["rate_hz"] - 10.0) < 1e-9  # the mean step would say 3.08 Hz
    assert (r["t_first"], r["t_last"]) == (0.0, 1.3)


def test_rows_print_lat_lon_to_a_millimetre_and_json_lists_units():
    """6 significant digits would print 47.4049 (~10 m); a decimetre needs >= 6 decimals, we print 8."""
    t = np.arange(4) * 0.1
    lat = 47.40491234 + 1e-7 * np.arange(4)
    table, _ = merge_streams([Stream("gps", t, {"lat": lat, "lon": 10.29451234 + 0 * t, "h": 948.1234 + 0 * t})])
    data = sfio.table_to_bytes(table, sfmeta.new_meta("session", 1.7e9))
    out = run(["--rows", "2"], data)
    head = out.splitlines()[out.splitlines().index("head:") + 2]
    assert "47.40491234" in head and "10.29451234" in head and "948.123" in head
    doc = json.loads(run(["--json"], data))
    units = {c["name"]: c["unit"] for c in doc["columns"]}
    assert units == {"t": "s", "lat": "deg", "lon": "deg", "h": "m"}
    assert doc["sensors"][0]["sensor"] == "gnss" and doc["sensors"][0]["rate_hz"] == pytest.approx(10.0)
