"""evaluate on a jumps table (jump-metrics) against the truth: jump length, take-off speed and timing errors."""

from __future__ import annotations

import io

import numpy as np
import pyarrow as pa
import pytest
from conftest import ROOT, run_cli

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.evaluate import compare_jumps

TRUTH = ROOT / "fixtures" / "skijump" / "truth.parquet"


def _truth_figures():
    _, m = sfio.read_table(TRUTH, kind="truth")
    return m, m["skijump"]["times"], m["skijump"]["figures"]


def _jumps_bytes(t_to: float, t_td: float, length: float, speed: float) -> bytes:
    table = pa.table(
        {
            "jump": pa.array([1], pa.int32()),
            "t_takeoff": [t_to],
            "t_touchdown": [t_td],
            "takeoff_speed": [speed],
            "flight_time": [t_td - t_to],
            "jump_length": [length],
        }
    )
    return sfio.table_to_bytes(table, sfmeta.new_meta("jumps", "2026-01-05T13:00:00Z"))


def test_errors_are_estimate_minus_truth():
    _, times, fig = _truth_figures()
    data = _jumps_bytes(
        times["takeoff"] + 0.02, times["touchdown"] - 0.01, fig["jump_length"] + 0.4, fig["takeoff_speed"] - 0.25
    )
    res = run_cli(["evaluate", "--truth", str(TRUTH)], stdin=data)
    assert res.returncode == 0, res.stderr.decode()
    table, meta = sfio.read_table(io.BytesIO(res.stdout), kind="summary")
    row = table.to_pylist()[0]
    assert row["phase"] == "jump 1" and row["jump"] == 1
    assert row["jump_length_error"] == pytest.approx(0.4, abs=1e-9)
    assert row["takeoff_speed_error"] == pytest.approx(-0.25, abs=1e-9)
    assert row["takeoff_dt"] == pytest.approx(0.02, abs=1e-9) and row["touchdown_dt"] == pytest.approx(-0.01, abs=1e-9)
    ev = meta["evaluation"]["jumps"][0]
    assert ev["takeoff_speed"]["unit"] == "m/s" and ev["jump_length"]["truth"] == pytest.approx(fig["jump_length"])


def test_text_gives_km_h_beside_m_s():
    _, times, fig = _truth_figures()
    data = _jumps_bytes(times["takeoff"], times["touchdown"], fig["jump_length"], fig["takeoff_speed"] + 1.0)
    res = run_cli(["evaluate", "--truth", str(TRUTH), "--format", "text"], stdin=data)
    assert res.returncode == 0, res.stderr.decode()
    text = res.stdout.decode()
    speed = next(ln for ln in text.splitlines() if "take-off speed" in ln)
    kmh = text.splitlines()[text.splitlines().index(speed) + 1]
    assert speed.rstrip().endswith("m/s") and "+1.000" in speed
    assert kmh.rstrip().endswith("km/h") and "+3.60" in kmh  # 1 m/s = 3.6 km/h
    assert f"{fig['takeoff_speed'] * 3.6:.2f}" in kmh


def test_a_jump_far_from_any_true_one_is_not_paired():
    m, times, fig = _truth_figures()
    table, _ = sfio.read_table(io.BytesIO(_jumps_bytes(times["takeoff"] + 30, times["touchdown"] + 30, 80.0, 25.0)))
    cmp = compare_jumps(table, m, max_event_dt=1.0)
    assert np.isnan(cmp.error("jump_length")[0]) and cmp.missed == 1


def test_gnss_flag_with_a_jumps_table_is_a_usage_error():
    _, times, fig = _truth_figures()
    data = _jumps_bytes(times["takeoff"], times["touchdown"], fig["jump_length"], fig["takeoff_speed"])
    res = run_cli(["evaluate", "--truth", str(TRUTH), "--gnss", "--format", "text"], stdin=data)
    assert res.returncode == 2 and res.stdout == b""
