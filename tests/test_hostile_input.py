"""Hostile but ordinary input (issue 38, items 5, 8, 9): one clear line naming the real cause, bounded reads,
and a time column in the wrong unit refused.  Every case checks the exit code and that stderr is one line."""

from __future__ import annotations

import io
import json
import os
import subprocess
import threading
import zipfile
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from conftest import BIN, ROOT, run_cli

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core.errors import InputError
from sportfusion.core.timeunit import time_unit_problem

JUMP = ROOT / "fixtures" / "skijump" / "session.parquet"
TRUTH = ROOT / "fixtures" / "skijump" / "truth.parquet"
RAW = ROOT / "fixtures" / "skijump" / "raw"
ORIGIN = ["--origin", "47.4,10.3,900", "-q"]


def one_error(stderr: bytes | str) -> str:
    text = stderr.decode() if isinstance(stderr, bytes) else stderr
    lines = [ln for ln in text.splitlines() if ln.strip()]
    assert len(lines) == 1, text
    assert lines[0].startswith("Error: ") and "internal error" not in lines[0] and "Traceback" not in text, text
    return lines[0]


def usage_error(stderr: bytes | str) -> str:
    """click's usage error: its Error line (the Usage/Try lines above it are click's convention)."""
    text = stderr.decode() if isinstance(stderr, bytes) else stderr
    lines = [ln for ln in text.splitlines() if ln.startswith("Error:")]
    assert len(lines) == 1 and "Traceback" not in text, text
    return lines[0]


def parquet_with(table: pa.Table, raw_meta: bytes) -> bytes:
    """Parquet bytes of ``table`` with the given raw ``sportfusion`` metadata (not validated on the way)."""
    buf = io.BytesIO()
    pq.write_table(table.replace_schema_metadata({b"sportfusion": raw_meta}), buf)
    return buf.getvalue()


GOOD_META = json.dumps(sfmeta.new_meta("session", 1.7e9)).encode()


# -- 5. time in the wrong unit ----------------------------------------------------------------------------------


def _imu_session(rate: float, seconds: float, factor: float = 1.0) -> pa.Table:
    n = int(rate * seconds)
    t = np.arange(n) / rate * factor
    rng = np.random.default_rng(0)
    return pa.table({"t": t, "acc_x": rng.normal(0, 1, n), "gyr_x": rng.normal(0, 0.1, n)})


def _gnss_session(rate: float, seconds: float, speed: float, factor: float = 1.0, velocity: str = "ned") -> pa.Table:
    n = int(rate * seconds)
    tt = np.arange(n) / rate
    heading = 0.3 * np.sin(tt / 60.0)  # a winding course: the straight-line distance is a bit shorter
    north = np.cumsum(speed * np.cos(heading) / rate)
    east = np.cumsum(speed * np.sin(heading) / rate)
    cols: dict[str, object] = {
        "t": tt * factor,
        "lat": 46.0 + north / 111_320.0,
        "lon": 9.0 + east / (111_320.0 * np.cos(np.radians(46.0))),
    }
    if velocity == "ned":
        cols |= {"vel_n": speed * np.cos(heading), "vel_e": speed * np.sin(heading)}
    elif velocity == "speed":
        cols |= {"gnss_speed": np.full(n, speed)}
    return pa.table(cols)


@pytest.mark.parametrize(("factor", "unit"), [(1e3, "milliseconds"), (1e6, "microseconds"), (1e9, "nanoseconds")])
def test_imu_time_in_a_smaller_unit_is_named(factor, unit):
    assert time_unit_problem(_imu_session(100.0, 30.0)) is None
    problem = time_unit_problem(_imu_session(100.0, 30.0, factor))
    assert problem is not None and unit in problem


@pytest.mark.parametrize(("factor", "unit"), [(1e3, "milliseconds"), (1e6, "microseconds")])
def test_gnss_time_in_ms_is_found_by_its_speed(factor, unit):
    problem = time_unit_problem(_gnss_session(10.0, 120.0, 20.0, factor))
    assert problem is not None and unit in problem and "20" in problem


def test_slow_loggers_in_seconds_are_not_refused():
    assert time_unit_problem(_gnss_session(1.0, 3600.0, 5.0)) is None  # 1 Hz GNSS, an hour
    assert time_unit_problem(_gnss_session(0.1, 8 * 3600.0, 3.0, velocity="speed")) is None  # a watch every 10 s
    assert time_unit_problem(_gnss_session(0.1, 10 * 86400.0, 1.5, velocity="none")) is None  # 10 days, positions only
    # a watch at 0.1 Hz that also logs a (slow) accelerometer beside consistent GNSS: the speed check rules
    watch = _gnss_session(0.1, 3600.0, 3.0, velocity="speed").append_column("acc_x", pa.array(np.zeros(360)))
    assert time_unit_problem(watch) is None


def test_spline_smooth_refuses_a_session_in_ms_in_one_line(tmp_path):
    res = run_cli(["simulate", "skirace", "--duration", "20", "--static", "2", "-q"])
    table, meta = sfio.read_table(io.BytesIO(res.stdout))
    table = table.set_column(0, "t", pa.array(table.column("t").to_numpy() * 1000.0))
    data = sfio.table_to_bytes(table, meta)
    r = run_cli(["spline-smooth", "-q"], stdin=data)
    assert r.returncode == 1 and r.stdout == b""
    assert "milliseconds" in one_error(r.stderr)
    r = subprocess.run(
        [str(BIN / "inspect"), "--rows", "0"],
        input=data,
        capture_output=True,
        env={**os.environ, "SPORTFUSION_TIME_CHECK": "off"},
    )
    assert r.returncode == 0, r.stderr


def test_ingest_of_a_csv_timed_in_ms_names_the_option(tmp_path):
    t = np.arange(0, 20_000, 10.0)  # 100 Hz, in ms
    csv = tmp_path / "log.csv"
    csv.write_text("time,ax\n" + "".join(f"{a:.0f},{b:.3f}\n" for a, b in zip(t, np.zeros_like(t), strict=True)))
    r = run_cli(["ingest", str(csv), "--map", "t=time,acc_x=ax", "-q"])
    assert r.returncode == 1 and "--time-unit ms" in one_error(r.stderr)
    r = run_cli(["ingest", str(csv), "--map", "t=time,acc_x=ax", "--time-unit", "ms", "-q"])
    assert r.returncode == 0, r.stderr


# -- 8. unbounded reads ------------------------------------------------------------------------------------------


def test_endless_non_parquet_stdin_is_refused_after_its_first_bytes():
    p = subprocess.Popen(
        [str(BIN / "gps2hill"), *ORIGIN], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    sent = 0
    chunk = bytes(1 << 16)
    try:
        while sent < 1 << 30:  # /dev/zero's worth; the command must stop reading long before
            p.stdin.write(chunk)
            sent += len(chunk)
    except BrokenPipeError:
        pass
    _, err = p.communicate(timeout=60)
    assert p.returncode == 1 and "PAR1" in one_error(err)
    assert sent < 64 << 20  # it stopped at the magic (what is sent is what the pipe buffer took)


def test_endless_parquet_looking_stdin_stops_at_the_cap(tmp_path):
    env = {**os.environ, "SPORTFUSION_MAX_TABLE_BYTES": str(1 << 20)}
    r_fd, w_fd = os.pipe()

    def feed() -> None:
        try:
            with os.fdopen(w_fd, "wb") as w:
                w.write(b"PAR1")
                for _ in range(1 << 14):  # 1 GiB unless the reader stops
                    w.write(bytes(1 << 16))
        except BrokenPipeError:
            pass

    th = threading.Thread(target=feed)
    th.start()
    with open(tmp_path / "err", "wb") as err:
        p = subprocess.run(
            [str(BIN / "gps2hill"), *ORIGIN], stdin=r_fd, stdout=subprocess.DEVNULL, stderr=err, env=env, timeout=120
        )
    os.close(r_fd)
    th.join(60)
    assert p.returncode == 1 and "SPORTFUSION_MAX_TABLE_BYTES" in one_error((tmp_path / "err").read_bytes())


def test_oversized_metadata_is_refused_before_it_is_parsed():
    table = pa.table({"t": [0.0, 0.01, 0.02]})
    meta = sfmeta.new_meta("session", 1.7e9)
    meta["provenance"] = [{"tool": "x", "version": "0", "params": {"blob": "x" * (9 << 20)}}]
    with pytest.raises(InputError, match="SPORTFUSION_MAX_META_BYTES"):
        sfio.read_table(io.BytesIO(sfio.table_to_bytes(table, meta)))


@pytest.mark.parametrize(
    ("raw", "needle"),
    [
        (b'{"version": 1, "kind": "session", "provenance": [], "x": ' + b"[" * 100 + b"]" * 100 + b"}", "nested"),
        (b'{"version": 1, "kind": "session", "provenance": [], "x": ' + b"[" * 100000 + b"]" * 100000 + b"}", "nested"),
        (b'{"version": 1, "kind": "session", "provenance": [], "x": 1' + b"0" * 5000 + b"}", "number"),
        (b'{"version": 1, "kind": "session", "provenance": [], "x": 1' + b"0" * 30 + b"}", "digits"),
    ],
    ids=["depth-100", "depth-1e5", "int-5000-digits", "int-31-digits"],
)
def test_hostile_metadata_json_is_one_line(raw, needle):
    data = parquet_with(pa.table({"t": [0.0, 0.01, 0.02]}), raw)
    r = run_cli(["inspect"], stdin=data)
    assert r.returncode == 1 and needle in one_error(r.stderr)


def test_duplicate_column_names_are_named():
    table = pa.Table.from_arrays(
        [pa.array([0.0, 0.01, 0.02]), pa.array([1.0] * 3), pa.array([2.0] * 3)], names=["t", "acc_x", "acc_x"]
    )
    r = run_cli(["detect-events", "--kind", "jump"], stdin=parquet_with(table, GOOD_META))
    assert r.returncode == 1 and "'acc_x' appears 2 times" in one_error(r.stderr)


# -- 9. messages that name the real cause ------------------------------------------------------------------------


def test_closed_stdout_and_stdin_are_one_line_usage_errors():
    r = subprocess.run(
        [str(BIN / "gps2hill"), str(JUMP), *ORIGIN],
        capture_output=False,
        stderr=subprocess.PIPE,
        preexec_fn=lambda: os.close(1),
    )
    assert r.returncode == 2 and "standard output is closed" in one_error(r.stderr)
    r = subprocess.run(
        [str(BIN / "gps2hill"), *ORIGIN, "-o", "/nonexistent-dir/x"],
        stderr=subprocess.PIPE,
        preexec_fn=lambda: os.close(0),
    )
    assert r.returncode == 2  # the folder check comes first: still one usage error
    r = subprocess.run([str(BIN / "gps2hill"), *ORIGIN], capture_output=True, preexec_fn=lambda: os.close(0))
    assert r.returncode == 2 and "standard input is closed" in one_error(r.stderr)
    r = subprocess.run([str(BIN / "inspect"), str(JUMP)], stderr=subprocess.PIPE, preexec_fn=lambda: os.close(1))
    assert r.returncode == 2 and "standard output is closed" in one_error(r.stderr)


def test_running_out_of_memory_on_a_valid_file_says_so(monkeypatch):
    def no_memory(data):
        raise pa.lib.ArrowMemoryError("malloc of size 1073741824 failed")

    monkeypatch.setattr(sfio, "_parquet_reader", no_memory)
    from sportfusion.tools.gps2hill import main

    res = CliRunner().invoke(main, [*ORIGIN], input=JUMP.read_bytes())
    assert res.exit_code == 1
    line = one_error(res.stderr)
    assert "not enough memory" in line and "not a readable Parquet" not in line


def test_file_names_with_newlines_and_binary_bytes_stay_on_one_line(tmp_path):
    r = run_cli(["gps2hill", str(tmp_path / "a\nb.parquet"), *ORIGIN])
    assert r.returncode == 1 and "a\\nb.parquet" in one_error(r.stderr)
    odd = tmp_path / "x\ny.csv"
    odd.write_bytes(os.urandom(2000))
    r = run_cli(["ingest", str(odd), "--map", "t=1,acc_x=2", "-q"])
    line = one_error(r.stderr)
    assert r.returncode == 1 and "x\\ny.csv" in line and line.isprintable()


def test_ingest_reads_a_pipe():
    r_fd, w_fd = os.pipe()
    data = (RAW / "gnss.nmea").read_bytes()

    def feed() -> None:
        with os.fdopen(w_fd, "wb") as w:
            w.write(data)

    th = threading.Thread(target=feed)
    th.start()
    try:
        r = subprocess.run(
            [str(BIN / "ingest"), f"/dev/fd/{r_fd}", "-q"], pass_fds=(r_fd,), capture_output=True, timeout=120
        )
    finally:
        os.close(r_fd)
        th.join(60)
    assert r.returncode == 0, r.stderr
    table, meta = sfio.read_table(io.BytesIO(r.stdout))
    assert table.num_rows > 100 and meta["sources"][0]["format"] == "nmea"


def test_damaged_zip_is_one_line(tmp_path):
    data = bytearray((RAW / "phyphox.zip").read_bytes())
    with zipfile.ZipFile(io.BytesIO(bytes(data))) as zf:
        info = next(i for i in zf.infolist() if i.compress_type == zipfile.ZIP_DEFLATED and i.compress_size > 100)
    # the member's data start: the local header (30 bytes) + its name + its extra field
    name_len = int.from_bytes(data[info.header_offset + 26 : info.header_offset + 28], "little")
    extra_len = int.from_bytes(data[info.header_offset + 28 : info.header_offset + 30], "little")
    start = info.header_offset + 30 + name_len + extra_len
    data[start] = 0xFF  # deflate block type 3: reserved, a decompression error
    bad = tmp_path / "flipped.zip"
    bad.write_bytes(bytes(data))
    r = run_cli(["ingest", str(bad), "-q"])
    assert r.returncode == 1 and "ZIP" in one_error(r.stderr)


def test_binary_config_and_negative_seed(tmp_path):
    cfg = tmp_path / "tuning.toml"
    cfg.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe")
    r = run_cli(["rts-smooth", str(JUMP), "--config", str(cfg)])
    assert r.returncode == 1 and "not UTF-8 text" in one_error(r.stderr)
    r = run_cli(["simulate", "boulder", "--seed", "-1"])
    assert r.returncode == 2 and "--seed" in usage_error(r.stderr)


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["simulate", "skijump", "--outage", "5,2"], "ends before it starts"),
        (["simulate", "skijump", "--hill", ""], "--hill"),
        (["gps2hill", "--hill", ""], "--hill"),
        (["compare-runs", "--run", "x.parquet", "--max-gate-distance", "1e-9"], "[0.1, 1000] m"),
    ],
)
def test_nonsense_options_are_usage_errors(argv, needle):
    r = run_cli(argv, stdin=JUMP.read_bytes())
    assert r.returncode == 2 and needle in usage_error(r.stderr)


def test_compare_runs_checks_its_gates_table(tmp_path):
    from sportfusion.skirace.sim_runs import gates_table, run_table

    a, b = tmp_path / "a.parquet", tmp_path / "b.parquet"
    a.write_bytes(run_table("A"))
    b.write_bytes(run_table("B"))
    gates, gmeta = sfio.read_table(io.BytesIO(gates_table()))
    for name, table in (("nox", gates.drop_columns(["x"])), ("empty", gates.slice(0, 0))):
        path = tmp_path / f"{name}.parquet"
        sfio.write_table(table, gmeta, path)
        r = run_cli(["compare-runs", str(a), "--run", str(b), "--gates", str(path), "-q"])
        assert r.returncode == 1, r.stderr
        assert ("no rows" if name == "empty" else "lacks x y") in one_error(r.stderr)
    # runs with their own gate events: the survey is checked, then said to be unused
    sfio.write_table(gates, gmeta, tmp_path / "g.parquet")
    r = run_cli(["compare-runs", str(a), "--run", str(b), "--gates", str(tmp_path / "g.parquet"), "-q"])
    assert r.returncode == 0 and "not used" in r.stderr.decode()


def test_marker_distances_running_backwards_are_refused(tmp_path):
    from sportfusion.skijump.video.markers import read_markers

    text = (RAW / "landing.markers.csv").read_text().splitlines()
    head = [ln for ln in text if ln.startswith("#") or ln.startswith("distance")]
    rows = [ln.split(",") for ln in text if ln and ln[0].isdigit()]
    read_markers(RAW / "landing.markers.csv")  # the fixture itself is fine
    swapped = [list(r) for r in rows]
    swapped[0][0], swapped[1][0] = swapped[1][0], swapped[0][0]  # two distances of one line exchanged
    reversed_line = [list(r) for r in rows]
    line0 = [r for r in reversed_line if r[1] == rows[0][1]]
    for r, d in zip(line0, [r[0] for r in line0][::-1], strict=True):  # one whole line numbered the other way
        r[0] = d
    for name, table, needle in (("swapped", swapped, "run backwards"), ("reversed", reversed_line, "opposite")):
        path = tmp_path / f"{name}.markers.csv"
        path.write_text("\n".join(head + [",".join(r) for r in table]) + "\n")
        with pytest.raises(InputError, match=needle):
            read_markers(path)


def test_evaluate_refuses_a_truth_without_true_x(tmp_path):
    truth, meta = sfio.read_table(TRUTH)
    path = tmp_path / "truth.parquet"
    sfio.write_table(truth.drop_columns(["true_x"]), meta, path)
    est = run_cli(["rts-smooth", str(JUMP), "--hill", "oberstdorf_hs106", "-q"])
    if est.returncode != 0:  # the fixture needs events first
        events = run_cli(
            ["detect-events", "--kind", "jump", "-q"],
            stdin=run_cli(["gps2hill", str(JUMP), "--hill", "oberstdorf_hs106", "-q"]).stdout,
        )
        est = run_cli(["rts-smooth", "--hill", "oberstdorf_hs106", "-q"], stdin=events.stdout)
    assert est.returncode == 0, est.stderr
    r = run_cli(["evaluate", "--truth", str(path), "--format", "text"], stdin=est.stdout)
    assert r.returncode == 1 and "true_x" in one_error(r.stderr)
    assert Path(path).exists()
