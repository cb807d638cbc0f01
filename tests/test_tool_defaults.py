"""A default is right for the session in hand or absent: detect-events infers its kind from the metadata."""

from __future__ import annotations

import io

import numpy as np
from conftest import ROOT, run_cli, session_bytes

from sportfusion.core import io as sfio

FIX = ROOT / "fixtures"


def _events(res) -> list[str]:
    table, _ = sfio.read_table(io.BytesIO(res.stdout))
    return [e for e in table.column("event").to_pylist() if e] if "event" in table.column_names else []


def test_detect_events_on_a_ski_jump_finds_the_jump_not_grips():
    res = run_cli(["detect-events"], stdin=(FIX / "skijump" / "session.parquet").read_bytes())
    assert res.returncode == 0, res.stderr.decode()
    assert "--kind jump" in res.stderr.decode()
    table, meta = sfio.read_table(io.BytesIO(res.stdout))
    assert "grip" not in table.column_names
    assert _events(res) == ["takeoff", "touchdown"]
    assert meta["provenance"][-1]["params"]["kind"] == "jump"


def test_detect_events_on_a_climbing_trial_finds_grips():
    res = run_cli(["detect-events", "-q"], stdin=(FIX / "climbing" / "session.parquet").read_bytes())
    assert res.returncode == 0, res.stderr.decode()
    table, _ = sfio.read_table(io.BytesIO(res.stdout))
    assert "grip" in table.column_names and np.any(table.column("grip").to_numpy(zero_copy_only=False))


def test_detect_events_without_kind_on_an_anonymous_session_is_a_usage_error():
    res = run_cli(["detect-events"], stdin=session_bytes({"gyr_x": np.zeros(20)}))
    assert res.returncode == 2 and res.stdout == b""
    err = res.stderr.decode()
    assert "--kind jump" in err and "--kind gates" in err and "names no sport" in err


def test_explicit_kind_wins_over_the_metadata():
    res = run_cli(["detect-events", "--kind", "grips", "-q"], stdin=(FIX / "skijump" / "session.parquet").read_bytes())
    assert res.returncode == 0, res.stderr.decode()
    table, _ = sfio.read_table(io.BytesIO(res.stdout))
    assert "grip" in table.column_names


def test_gps2hill_takes_the_hill_the_session_names():
    data = (FIX / "skijump" / "session.parquet").read_bytes()
    res = run_cli(["gps2hill"], stdin=data)
    assert res.returncode == 0, res.stderr.decode()
    assert "--hill oberstdorf_hs106: the session's hill" in res.stderr.decode()
    given = run_cli(["gps2hill", "--hill", "oberstdorf_hs106", "-q"], stdin=data)
    a, _ = sfio.read_table(io.BytesIO(res.stdout))
    b, _ = sfio.read_table(io.BytesIO(given.stdout))
    for c in ("gnss_x", "gnss_y", "gnss_z"):
        assert a.column(c).equals(b.column(c))


def test_gps2hill_on_a_session_without_a_hill_asks_for_one():
    lat = np.full(20, 47.4)
    res = run_cli(["gps2hill"], stdin=session_bytes({"lat": lat, "lon": lat * 0 + 10.3, "h": lat * 0 + 900.0}))
    assert res.returncode == 2 and res.stdout == b""
    assert "the session names no hill" in res.stderr.decode()


def test_ingest_bouldering_takes_the_trials_only_hand_and_asks_when_there_are_two(tmp_path):
    from test_ingest_bouldering import write_dataset

    from sportfusion.climbing.sim import BoulderConfig, simulate_boulder

    sim = simulate_boulder(BoulderConfig(seed=11, route_holds=10, imu_rate=60))
    trial, _ = write_dataset(tmp_path / "one", sim, hand="righthand")
    res = run_cli(["ingest", str(trial), "-q"])
    assert res.returncode == 0, res.stderr.decode()
    _, meta = sfio.read_table(io.BytesIO(res.stdout))
    assert meta["climbing"]["hand"] == "righthand"
    (trial / "imu_lefthand.csv").write_text((trial / "imu_righthand.csv").read_text())
    res = run_cli(["ingest", str(trial)])
    assert res.returncode == 1 and res.stdout == b""
    err = res.stderr.decode().strip()
    assert err.startswith("Error: ingest: ") and "--hand lefthand or --hand righthand" in err
    assert run_cli(["ingest", str(trial), "--hand", "lefthand", "-q"]).returncode == 0
