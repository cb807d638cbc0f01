"""Grip detector (moving-window low motion) and range violations; the detect-events grips CLI."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from click.testing import CliRunner
from conftest import session_bytes

from sportfusion.climbing.grips import GripParams, detect_grips, grip_columns, range_violations
from sportfusion.climbing.sim import BoulderConfig, simulate_boulder
from sportfusion.core import io as sfio
from sportfusion.core import schema
from sportfusion.tools.detect_events import main

OFF = dict(mean_threshold=np.inf, acc_threshold=np.inf)


def _reference_stat(w: np.ndarray, window: int) -> np.ndarray:
    """The paper implementation's statistic, window by window: sum of per-axis population stds."""
    half = window // 2
    out = np.full(w.shape[0], np.inf)
    for k in range(half, w.shape[0] - half):
        out[k] = w[k - half : k + half].std(axis=0).sum()
    return out


def test_statistic_matches_a_direct_window_loop():
    rng = np.random.default_rng(0)
    w = rng.normal(0, 1, (300, 3)) * np.linspace(0.05, 1.5, 300)[:, None] + 3.0
    ref = _reference_stat(w, 28)
    thr = float(np.median(ref[np.isfinite(ref)]))
    got = detect_grips(w, GripParams(threshold=thr, **OFF))
    assert np.array_equal(got, ref < thr)
    assert got.any() and not got.all()


def test_first_and_last_half_window_are_never_grips():
    w = np.zeros((100, 3))
    got = detect_grips(w, GripParams(window=28))
    assert not got[:14].any() and not got[-14:].any()
    assert got[14:-14].all()
    assert not detect_grips(np.zeros((20, 3)), GripParams(window=28)).any()


def test_steady_turning_and_translation_are_not_grips():
    n = 200
    turning = np.tile([0.0, 0.0, 1.0], (n, 1))  # 1 rad/s, zero spread
    assert detect_grips(turning, GripParams(**OFF))[14:-14].all()  # the spread test alone passes it
    assert not detect_grips(turning).any()  # the mean-rate test does not
    acc = np.zeros((n, 3))
    acc[:, 0] = 5.0 * np.sin(np.linspace(0, 6 * np.pi, n))  # a hand moving without turning
    assert not detect_grips(np.zeros((n, 3)), acc=acc)[30:-30].any()


def test_world_frame_rotation_is_applied():
    rng = np.random.default_rng(2)
    w = rng.normal(0, 0.05, (120, 3))
    r = np.repeat(np.eye(3)[None], 120, axis=0)
    assert np.array_equal(detect_grips(w, GripParams(**OFF), r), detect_grips(w, GripParams(**OFF)))
    # a rotation that turns with the hand cancels a steady body rate: rate in world = 0
    spin = np.zeros((120, 3))
    spin[:, 2] = 2.0
    assert not detect_grips(spin)[14:-14].any()


def test_range_violations_at_the_limits():
    p = GripParams()
    acc = np.array([[0, 0, 9.8], [160.0, 0, 0], [0, -160.0, 0], [159.9, 0, 0], [0, 0, 0]])
    gyr = np.zeros((5, 3))
    gyr[4, 1] = np.deg2rad(2000.0)
    assert range_violations(acc, gyr, p).tolist() == [False, True, True, False, True]


@pytest.fixture(scope="module")
def sim():
    return simulate_boulder(BoulderConfig(seed=5, route_holds=10, imu_rate=60))


def test_detected_grips_on_a_simulated_trial_are_still_hands(sim):
    cols, counts = grip_columns(sim.session)
    grip = cols["grip"].to_numpy(zero_copy_only=False)
    v = np.column_stack([schema.floats(sim.truth, f"true_v{a}") for a in "xyz"])
    true_grip = sim.truth.column("true_grip").to_numpy(zero_copy_only=False)
    speed = np.linalg.norm(v, axis=1)
    assert speed[grip].max() < 0.05  # no moving sample is called a grip (ZUPT safe)
    assert (grip & true_grip).sum() > 0.6 * true_grip.sum()  # windows shave the grip ends
    n_true = sum(1 for s in sim.segments if s.kind == "grip")
    assert counts["grips"] >= 0.7 * n_true


def test_grip_columns_null_off_the_imu_rows(sim):
    s = sim.session.slice(0, 400)
    extra = pa.table({"t": pa.array(s.column("t").to_numpy()[:-1] + 0.004)})
    t = np.sort(np.r_[s.column("t").to_numpy(), extra.column("t").to_numpy()])
    idx = np.searchsorted(t, s.column("t").to_numpy())
    cols = {"t": t}
    for name in s.column_names[1:]:
        full = np.full(t.size, np.nan)
        full[idx] = schema.floats(s, name)
        cols[name] = full
    table = pa.table({k: schema.to_arrow(k, v) for k, v in cols.items()})
    out, _ = grip_columns(table)
    g = out["grip"]
    assert g.null_count == t.size - idx.size
    ref, _ = grip_columns(s)
    assert np.array_equal(np.asarray(g.to_pylist(), dtype=object)[idx].astype(bool), ref["grip"].to_numpy(False))


def _invoke(args: list[str], data: bytes):
    """Run detect-events in-process (CliRunner): exit code, stdout bytes, stderr text."""
    res = CliRunner().invoke(main, args, input=data)
    return res.exit_code, res.stdout_bytes, res.stderr


def test_cli_adds_columns_and_keeps_the_rest(sim, tmp_path):
    data = sfio.table_to_bytes(sim.session, sim.meta)
    code, out, err = _invoke(["--kind", "grips"], data)
    assert code == 0, err
    path = tmp_path / "out.parquet"
    path.write_bytes(out)
    table, meta = sfio.read_table(str(path))
    assert table.column("grip").type == pa.bool_() and table.column("imu_saturated").type == pa.bool_()
    for name in sim.session.column_names:
        assert table.column(name).equals(sim.session.column(name))
    assert meta["provenance"][-1]["tool"] == "detect-events"
    assert meta["provenance"][-1]["params"]["window"] == 28
    assert meta["climbing"] == sim.meta["climbing"]
    assert "grips" in err


def test_cli_missing_gyroscope_is_one_line():
    code, out, err = _invoke(["--kind", "grips"], session_bytes({"acc_x": np.zeros(20)}))
    assert code == 1 and out == b""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: detect-events: ") and "gyr_x" in lines[0]


def test_cli_help_names_units_and_example():
    res = CliRunner().invoke(main, ["--help"])
    assert res.exit_code == 0
    for text in ("Example", "[samples]", "[rad/s]", "[m/s^2]", "[deg/s]", "grips"):
        assert text in res.output
