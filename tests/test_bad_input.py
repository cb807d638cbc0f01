"""Bad input at the edge (issue 17): option values, side files, NaN in estimates, warnings, hostile files."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import warnings
import zipfile
from pathlib import Path

import click
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from conftest import BIN, ROOT, session_bytes

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core.errors import InputError
from sportfusion.core.session import drop_impossible, nonfinite_to_null
from sportfusion.tools._cli import Tool, one_line, tool
from sportfusion.tools._options import Finite

FIX = ROOT / "fixtures"
JUMP = FIX / "skijump" / "session.parquet"


def _script(name: str) -> click.Command:
    import importlib
    import tomllib

    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    module, func = scripts[name].split(":")
    return getattr(importlib.import_module(module), func)


def invoke(argv: list[str], stdin: bytes = b""):
    """Run a console script in-process; returns click's Result (stdout_bytes, stderr, exit_code)."""
    return CliRunner().invoke(_script(argv[0]), argv[1:], input=stdin)


def _error_lines(res) -> list[str]:
    return [ln for ln in res.stderr.splitlines() if ln.startswith("Error:")]


# -- 2. option values validated at the edge ------------------------------------------------------------

USAGE_CASES = [
    (["detect-events", "--kind", "jump", "--min-speed", "nan"], "[0, 100] m/s"),
    (["dmc-attitude", "--lowpass", "1e-9"], "[0.01, 1000] Hz or 0"),
    (["dmc-attitude", "--free-fall", "1e300"], "m/s^2"),
    (["ingest", "--rate", "nan", "x.csv"], "Hz"),
    (["gate-anchor", "--sigma-second", "1e300"], "m"),
    (["dmc-attitude", "--g0", "nan"], "[9.7, 9.9] m/s^2"),
    (["detect-events", "--threshold", "nan"], "rad/s"),
    (["detect-events", "--threshold", "-inf"], "rad/s"),
    (["gps2hill", "--origin", "47,10,1e300"], "[-1000, 10000] m"),
    (["gps2hill", "--origin", "91,10,900"], "[-90, 90] deg"),
    (["gps2hill", "--hill", "oberstdorf_hs106", "--hill-set", "e=1e300"], "[-100000, 100000] m"),
    (["gps2hill", "--hill", "oberstdorf_hs106", "--hill-set", "lat=nan"], "[-90, 90]"),
    (["detect-events", "--kind", "gates", "--gate-background", "1e9"], "[0.05, 60] s"),
    (["pf-holds", "--route", ""], "route name"),
    (["rts-smooth", "--takeoff", "1,nan"], "s"),
    (["dmc-attitude", "--site", ""], "3 comma-separated numbers"),
    (["simulate", "skijump", "--outage", "1,inf"], "s"),
    (["spline-smooth", "--segment", "1:2=nan"], "[0, 1]"),
    (["spline-smooth", "--lambda", "nan"], "--lambda"),
    (["ingest", "--offset", "gnss=inf", "x.csv"], "s"),
    (["gps2hill", "--origin", "47,10,900", "-o", "/no/such/folder/x.parquet"], "does not exist"),
]


@pytest.mark.parametrize(("argv", "needle"), USAGE_CASES, ids=[" ".join(a) for a, _ in USAGE_CASES])
def test_nonsense_option_values_are_usage_errors_naming_the_range(argv, needle):
    # a valid input on stdin: the option, not the data, must be what is refused
    res = invoke(argv, JUMP.read_bytes())
    assert res.exit_code == 2, (res.exit_code, res.stderr)
    assert res.stdout_bytes == b""
    errors = _error_lines(res)
    assert len(errors) == 1, res.stderr
    assert needle in errors[0] or needle in res.stderr, errors[0]


def test_finite_type_keeps_documented_inf_and_zero():
    t = Finite(0.01, 1000, "Hz", zero_ok=True)
    assert t.convert("0", None, None) == 0.0
    assert t.convert("5", None, None) == 5.0
    for bad in ("1e-9", "nan", "inf", "2000"):
        with pytest.raises(click.BadParameter):
            t.convert(bad, None, None)
    off = Finite(0, 100, "rad/s", allow_inf=True)
    assert off.convert("inf", None, None) == float("inf")
    with pytest.raises(click.BadParameter):
        off.convert("-inf", None, None)


def test_every_float_option_of_every_command_is_finite_checked():
    sys.path.insert(0, str(ROOT / "bench"))
    from bench_bad_input import commands

    plain = []
    for name, cmd in commands().items():
        for p in cmd.params:
            if isinstance(p.type, click.types.FloatParamType) and not isinstance(p.type, Finite):
                plain.append(f"{name} {p.name}")
    assert plain == []


def _race_session() -> bytes:
    res = CliRunner().invoke(_script("simulate"), ["skirace", "--duration", "12", "--static", "2", "-q"])
    assert res.exit_code == 0, res.stderr
    return res.stdout_bytes


def test_lowpass_above_nyquist_is_one_line_from_the_library():
    res = invoke(["dmc-attitude", "--lowpass", "40", "-q"], _race_session())  # IMU at 50 Hz: Nyquist 25 Hz
    assert res.exit_code == 1, res.stderr
    assert res.stdout_bytes == b""
    assert res.stderr.strip().count("\n") == 0
    assert "Nyquist frequency 25 Hz" in res.stderr


# -- side files -----------------------------------------------------------------------------------------


def test_binary_calibration_csv_is_a_clean_error(tmp_path):
    cal = tmp_path / "magnet.csv"
    cal.write_bytes(bytes(range(256)) * 50)
    res = invoke(["detect-events", "--kind", "gates", "--magnet-calibration", str(cal)], JUMP.read_bytes())
    assert res.exit_code == 1, res.stderr
    assert res.stderr.strip().startswith("Error: detect-events: calibration table")
    assert "internal" not in res.stderr and res.stderr.strip().count("\n") == 0


def _with_value(path: Path, col: str, row: int, value: float, dest: Path) -> Path:
    table, meta = sfio.read_table(path)
    v = table.column(col).to_numpy(zero_copy_only=False).copy()
    v[row] = value
    table = table.set_column(table.column_names.index(col), col, pa.array(v))
    sfio.write_table(table, meta, dest)
    return dest


@pytest.mark.parametrize("value", [np.nan, np.inf, 1e300])
def test_survey_and_hold_map_with_non_finite_positions_are_refused(tmp_path, value):
    survey = _with_value(FIX / "gates" / "survey.parquet", "x", 3, value, tmp_path / "survey.parquet")
    with pytest.raises(InputError, match=r"column x holds 1 NaN.*\(row 3\)"):
        sfio.read_table(survey, kind="gates")
    holds = _with_value(FIX / "climbing" / "holds.parquet", "z", 0, value, tmp_path / "holds.parquet")
    from sportfusion.climbing.holds import read_holds

    with pytest.raises(InputError, match="column z holds 1"):
        read_holds(str(holds))


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        ({"time": {"epoch_utc": "9999-01-01T00:00:00Z"}}, "1970..2099"),
        ({"frame": {"name": "hill", "origin": [91.0, 10.0, 900.0], "azimuth_deg": 0.0}}, "lat -90..90"),
        ({"frame": {"name": "hill", "origin": [47.0, 10.0, 900.0], "azimuth_deg": 1e300}}, "azimuth_deg"),
    ],
)
def test_metadata_out_of_range_is_refused_in_one_line(change, needle):
    table = pq.read_table(JUMP)
    meta = json.loads(table.schema.metadata[b"sportfusion"])
    meta.update(change)
    table = table.replace_schema_metadata({**table.schema.metadata, b"sportfusion": json.dumps(meta).encode()})
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    res = invoke(["detect-events", "--kind", "jump"], sink.getvalue().to_pybytes())
    assert res.exit_code == 1, res.stderr
    assert needle in res.stderr and res.stderr.strip().count("\n") == 0


def test_hill_toml_is_data_never_code(tmp_path):
    marker = tmp_path / "pwned"
    bad = tmp_path / "evil.toml"
    bad.write_text(
        f"name = \"__import__('os').system('touch {marker}')\"\n"
        "[certificate]\n"
        'type = "ICR2008"\n'
        f"e = \"__import__('os').system('touch {marker}')\"\n"
        "[site]\n"
        "lat = { nested = [1, 2, [3, { deeper = true }]] }\n"
    )
    for argv in (["gps2hill", "--hill", str(bad)], ["rts-smooth", "--config", str(bad)]):
        res = invoke(argv, JUMP.read_bytes())
        assert res.exit_code in (1, 2), res.stderr
        assert len(_error_lines(res)) == 1 and "internal" not in res.stderr, res.stderr
    assert not marker.exists()


# -- 3. never a NaN/inf in an estimate column -----------------------------------------------------------


def test_nonfinite_to_null_touches_estimates_only():
    table = pa.table(
        {
            "t": [0.0, 1.0, 2.0],
            "acc_x": [np.nan, 1.0, np.inf],  # raw sensor: kept as read
            "x": [np.nan, 1.0, -np.inf],
            "std_x": [0.1, np.nan, 0.2],
            "given": [np.nan, 0.0, 0.0],  # named in keep: passed through
        }
    )
    out, counts = nonfinite_to_null(table, {"given"})
    assert counts == {"x": 2, "std_x": 1}
    assert out.column("x").to_pylist() == [None, 1.0, None]
    assert out.column("std_x").null_count == 1
    assert np.isnan(out.column("acc_x").to_numpy(zero_copy_only=False)[0])
    assert np.isnan(out.column("given").to_numpy(zero_copy_only=False)[0])


@tool("nan-maker", example="nan-maker < in.parquet > out.parquet")
def _nan_maker(t: Tool) -> None:
    """Divide by zero into an estimate column (a test double)."""
    table, meta = t.read()
    acc = table.column("acc_x").to_numpy(zero_copy_only=False)
    x = acc / np.zeros_like(acc)  # 0/0 -> NaN, a/0 -> inf; numpy warns
    warnings.warn("something scipy-ish happened", RuntimeWarning, stacklevel=1)
    t.write(table.append_column("x", pa.array(x)), meta)


def test_write_path_nulls_nan_estimates_counts_them_and_swallows_raw_warnings():
    acc = np.ones(20)
    acc[:5] = 0.0
    gyr = np.full(20, np.nan)  # NaN in a raw column: read as missing, said once
    res = CliRunner().invoke(_nan_maker, [], input=session_bytes({"acc_x": acc, "gyr_x": gyr}))
    assert res.exit_code == 0, res.stderr
    out = pq.read_table(io.BytesIO(res.stdout_bytes))
    x = out.column("x")
    assert x.null_count == 20  # 5 NaN + 15 inf, all null
    assert "RuntimeWarning" not in res.stderr and "Traceback" not in res.stderr
    assert "20 row(s) have no finite estimate in x: written as null" in res.stderr
    assert "numerical warning" in res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 3, lines  # the null count, the warning summary, the dropped raw values
    quiet = CliRunner().invoke(_nan_maker, ["-q"], input=session_bytes({"acc_x": acc, "gyr_x": gyr}))
    assert quiet.stderr.strip().splitlines() == [ln for ln in lines if ln.startswith("Warning:")]


def test_drop_impossible_raw_values():
    table = pa.table({"t": [0.0, 1.0, 2.0], "acc_x": [1.0, 1e300, np.nan], "lat": [47.0, 91.0, None]})
    out, counts = drop_impossible(table)
    assert counts == {"acc_x": 2, "lat": 1}
    assert out.column("acc_x").to_pylist() == [1.0, None, None]
    assert out.column("lat").to_pylist() == [47.0, None, None]


# -- 4. one line, never a raw warning or a schema dump -------------------------------------------------


def test_one_line_keeps_the_headline():
    assert one_line("cannot cast: schema:\n a: double\n b: int64") == "cannot cast: schema"
    assert one_line("x" * 1000).endswith("...") and len(one_line("x" * 1000)) == 400


@tool("multi-liner", example="multi-liner < in.parquet")
def _multi_liner(t: Tool) -> None:
    """Fail with a multi-line message (a test double)."""
    raise InputError("table does not match:\nt: double\nacc_x: string\n-- schema metadata --")


def test_multi_line_errors_are_reduced_to_one():
    res = CliRunner().invoke(_multi_liner, [], input=b"")
    assert res.exit_code == 1
    assert res.stderr.strip() == "Error: multi-liner: table does not match"


# -- 5. hostile files -----------------------------------------------------------------------------------


def _bounded(argv: list[str], limit: int = 1 << 30, env: dict | None = None) -> subprocess.CompletedProcess:
    """Run a console script with its address space capped (RLIMIT_AS)."""
    code = (
        "import resource, subprocess, sys\n"
        f"resource.setrlimit(resource.RLIMIT_AS, ({limit}, {limit}))\n"
        "import os; os.execv(sys.argv[1], sys.argv[1:])\n"
    )
    return subprocess.run(
        [sys.executable, "-c", code, str(BIN / argv[0]), *argv[1:]],
        capture_output=True,
        timeout=300,
        env={**os.environ, **(env or {})},
        stdin=subprocess.DEVNULL,
    )


def _bomb(path: Path, size: int) -> Path:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as zf:
        with zf.open("Accelerometer.csv", "w", force_zip64=True) as fh:
            fh.write(b'"Time (s)","X (m/s^2)","Y (m/s^2)","Z (m/s^2)"\n')
            block = b"0.000000000,0.0,0.0,9.81\n" * 40000
            for _ in range(size // len(block)):
                fh.write(block)
    return path


def _one_line_failure(res: subprocess.CompletedProcess, tool_name: str) -> str:
    assert res.returncode == 1, (res.returncode, res.stderr[-2000:])
    assert res.stdout == b""
    text = res.stderr.decode().strip()
    assert text.count("\n") == 0 and text.startswith(f"Error: {tool_name}: "), text
    assert "internal" not in text
    return text


def test_zip_bomb_refused_by_ratio_in_bounded_memory(tmp_path):
    bomb = _bomb(tmp_path / "bomb.zip", 100 * 1024**2)
    assert bomb.stat().st_size < 2 * 1024**2
    text = _one_line_failure(_bounded(["ingest", str(bomb)]), "ingest")
    assert "decompression bomb" in text and "SPORTFUSION_MAX_ZIP_RATIO" in text


@pytest.mark.slow
def test_gigabyte_zip_bomb_refused_in_one_gib(tmp_path):
    bomb = _bomb(tmp_path / "bomb.zip", 1024**3)
    text = _one_line_failure(_bounded(["ingest", str(bomb)]), "ingest")
    assert "decompression bomb" in text


def test_zip_total_size_limit_is_overridable(tmp_path, monkeypatch):
    from sportfusion.ingest._text import read_zip_members

    p = tmp_path / "a.zip"
    with zipfile.ZipFile(p, "w", zipfile.ZIP_STORED) as zf:
        zf.writestr("a.csv", b"x" * 3 * 1024**2)
    with zipfile.ZipFile(p) as zf:
        assert len(read_zip_members(zf, ["a.csv"], "a.zip")["a.csv"]) == 3 * 1024**2
        monkeypatch.setenv("SPORTFUSION_MAX_UNZIPPED", str(1024**2))
        with pytest.raises(InputError, match="SPORTFUSION_MAX_UNZIPPED"):
            read_zip_members(zf, ["a.csv"], "a.zip")


def test_zip_entries_with_parent_paths_are_never_written(tmp_path):
    from sportfusion.sim.rawfiles import write_phyphox_zip  # noqa: F401  (the real export layout)

    work = tmp_path / "work"
    work.mkdir()
    p = work / "evil.zip"
    csv = b'"Time (s)","X (m/s^2)","Y (m/s^2)","Z (m/s^2)"\n0,0,0,9.81\n0.01,0,0,9.81\n0.02,0,0,9.81\n'
    with zipfile.ZipFile(p, "w") as zf:
        zf.writestr("../../Accelerometer.csv", csv)
        zf.writestr("/tmp/../escape.csv", csv)
    before = set(tmp_path.rglob("*"))
    res = subprocess.run(
        [str(BIN / "ingest"), str(p), "-o", str(work / "out.parquet")], capture_output=True, cwd=work, timeout=120
    )
    assert res.returncode in (0, 1), res.stderr
    assert b"Traceback" not in res.stderr
    created = set(tmp_path.rglob("*")) - before
    assert created <= {work / "out.parquet"}, created
    assert not (tmp_path / "Accelerometer.csv").exists() and not Path("/tmp/escape.csv").exists()


def test_parquet_footer_declaring_a_huge_table_is_refused_in_bounded_memory(tmp_path):
    n = 1_000_000
    t = pa.table({"t": pa.array(np.zeros(n)), "acc_x": pa.nulls(n, pa.float64())})
    t = sfio.finalize(t, sfmeta.new_meta("session", 1.7e9))
    path = tmp_path / "bomb.parquet"
    with pq.ParquetWriter(path, t.schema, compression="zstd") as w:
        for _ in range(150):
            w.write_table(t)
    assert path.stat().st_size < 5 * 1024**2
    text = _one_line_failure(_bounded(["inspect", str(path)]), "inspect")
    assert "declares 150000000 rows" in text


def test_video_frame_budget_is_enforced(monkeypatch):
    from sportfusion.skijump.video.reader import open_video, read_thumbnails, thumb_bytes

    assert thumb_bytes(1920, 1080) == 480 * 270
    cap, info = open_video(FIX / "skijump" / "raw" / "landing.mp4")
    cap.release()
    monkeypatch.setenv("SPORTFUSION_MAX_VIDEO_BYTES", str(thumb_bytes(info.width, info.height) * 3))
    with pytest.raises(InputError, match="SPORTFUSION_MAX_VIDEO_BYTES"):
        read_thumbnails(FIX / "skijump" / "raw" / "landing.mp4")


def test_ingest_never_writes_an_impossible_latitude(tmp_path):
    """A GPX point at latitude 91.5 is a corrupt file (issue 17): refused in one line naming the point, nothing
    on stdout; the same value arriving through a session table is read as missing (drop_impossible)."""
    gpx = tmp_path / "bad.gpx"
    pts = [(91.5, 0), (47.0, 1), (47.00001, 2)]
    body = "".join(
        f'<trkpt lat="{la}" lon="10.0"><ele>900</ele><time>2024-01-01T10:00:0{s}Z</time></trkpt>' for la, s in pts
    )
    gpx.write_text(
        '<?xml version="1.0"?><gpx version="1.1" creator="t" xmlns="http://www.topografix.com/GPX/1/1">'
        f"<trk><trkseg>{body}</trkseg></trk></gpx>"
    )
    res = invoke(["ingest", str(gpx), "-q"])
    assert res.exit_code == 1 and not res.stdout_bytes
    assert "latitude 91.5" in res.stderr and len(res.stderr.strip().splitlines()) == 1
