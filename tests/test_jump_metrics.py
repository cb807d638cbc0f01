"""jump-metrics: per-jump figures against the simulator's truth, the profile foot, the CLI."""

from __future__ import annotations

import io

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import run_cli

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.skijump.hillfile import load_hill
from sportfusion.skijump.metrics import jump_metrics, jump_metrics_table, profile_foot

FIX = "fixtures/skijump/"
HILL = "oberstdorf_hs106"


def _truth_as_estimate() -> tuple[pa.Table, dict]:
    """The truth renamed to estimate columns, with the true events: an exact 'smoothed' session."""
    truth, tmeta = sfio.read_table(FIX + "truth.parquet", kind="truth")
    cols = {"t": truth.column("t")}
    for n in ("x", "y", "z", "vx", "vy", "vz"):
        cols[n] = truth.column(f"true_{n}")
    cols["event"] = truth.column("event")
    meta = {**tmeta, "kind": "session"}
    # the exact times beside the event rows, as detect-events writes them (the full physics' events fall
    # between rows: the take-off on the truth's 1 ms grid, the rows 1-9 ms apart)
    tt = tmeta["skijump"]["times"]
    exact = {"kind": "jump", "jumps": [{"takeoff": tt["takeoff"], "touchdown": tt["touchdown"]}]}
    meta["events"] = [*(meta.get("events") or []), exact]
    return pa.table(cols), meta


def test_profile_foot_inverts_a_normal_offset():
    hill = load_hill(HILL)
    prof = hill.profile
    for xp in (20.0, 60.0, 83.14, 100.0, 150.0):
        z = prof.z(xp, "landing")
        d = prof.dzdx(xp, "landing")
        n = np.array([-d, 1.0]) / np.hypot(d, 1.0)  # normal in (x, z); points below... flip to above
        for h in (0.3, 2.5):
            px, pz = np.array([xp, z]) - h * n  # above the slope (z down)
            assert abs(profile_foot(hill, px, pz) - xp) < 1e-6


def test_metrics_of_the_true_trajectory_match_the_simulator():
    table, meta = _truth_as_estimate()
    hill = load_hill(HILL)
    fig = meta["skijump"]["figures"]
    times = meta["skijump"]["times"]
    out, jmeta, msg = jump_metrics_table(table, meta, hill)
    assert jmeta["kind"] == "jumps" and out.num_rows == 1
    row = {c: out.column(c)[0].as_py() for c in out.column_names}
    assert row["jump"] == 1  # jumps are numbered from 1 everywhere
    assert row["t_takeoff"] == pytest.approx(times["takeoff"], abs=1e-9)
    assert row["flight_time"] == pytest.approx(fig["flight_time"], abs=1e-6)
    assert row["takeoff_speed"] == pytest.approx(fig["takeoff_speed"], abs=0.02)
    # the simulator's jump length: the foot of the sensor's normal at the touch-down
    assert row["jump_length"] == pytest.approx(fig["jump_length"], abs=0.02)
    # at the touch-down instant, between the rows (the full physics' touch-down is on its 1 ms grid)
    t_rows = schema.floats(table, "t")
    assert row["touchdown_x"] == pytest.approx(
        np.interp(times["touchdown"], t_rows, schema.floats(table, "x")), abs=1e-6
    )
    # vertical height above the profile >= the normal clearance, and a few metres at most on a normal hill
    truth, _ = sfio.read_table(FIX + "truth.parquet", kind="truth")
    clear = schema.floats(truth, "true_clearance")
    assert np.nanmax(clear) - 1e-6 <= row["max_height"] < 6.0
    assert jmeta["jump_length"] == [row["jump_length"]]
    # the one-line summary: numbered from 1, km/h beside m/s
    v = row["takeoff_speed"]
    assert msg == f"jump 1: {row['jump_length']:.1f} m, {v:.1f} m/s ({v * 3.6:.1f} km/h)"


def test_events_outside_the_estimate_are_refused():
    table, meta = _truth_as_estimate()
    t = schema.floats(table, "t")
    pos = np.zeros((t.size, 3))
    with pytest.raises(InputError, match="outside"):
        jump_metrics(t, pos, pos, [(t[-1] + 1, t[-1] + 2)], load_hill(HILL))


def test_cli_writes_jumps_table_and_refuses_missing_events():
    table, meta = _truth_as_estimate()
    res = run_cli(["jump-metrics", "--hill", HILL], stdin=sfio.table_to_bytes(table, meta))
    assert res.returncode == 0, res.stderr.decode()
    out = pq.read_table(io.BytesIO(res.stdout))
    m = sfmeta.decode(out.schema.metadata[b"sportfusion"])
    assert m["kind"] == "jumps" and m["provenance"][-1]["tool"] == "jump-metrics"
    assert out.num_rows == 1 and "jump_length" in out.column_names
    res = run_cli(["jump-metrics", "--hill", HILL], stdin=sfio.table_to_bytes(table.drop_columns(["event"]), meta))
    assert res.returncode == 1
    lines = res.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and "take-off/touch-down events" in lines[0]
