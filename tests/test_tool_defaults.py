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
