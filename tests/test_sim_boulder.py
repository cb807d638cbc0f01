"""Bouldering simulator: the route and the hand's plan, sensor consistency with the truth
(strapdown integration recovers the trajectory), magnetic disturbance, determinism, CLI."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from sportfusion.climbing import _so3
from sportfusion.climbing.holds import validate
from sportfusion.climbing.sim import VARIANTS, BoulderConfig, disturbance_field, simulate_boulder
from sportfusion.core import io as sfio
from sportfusion.core import schema

CLEAN = dict(
    gyr_noise=0.0,
    gyr_bias=0.0,
    acc_noise=0.0,
    acc_bias=0.0,
    acc_scale=0.0,
    gyr_scale=0.0,
    misalignment=0.0,
    mag_noise=0.0,
    mag_bias=0.0,
    p_impact=0.0,
    gyr_bias_walk=0.0,
    acc_temp=0.0,
    gyr_temp=0.0,
)


def _xyz(table, prefix):
    return np.column_stack([schema.floats(table, f"{prefix}{a}") for a in "xyz"])


@pytest.fixture(scope="module")
def clean():
    return simulate_boulder(BoulderConfig(seed=2, imu_rate=100, **CLEAN))


def test_error_free_sensors_integrate_back_to_the_truth(clean):
    s, tr = clean.session, clean.truth
    t = schema.floats(s, "t")
    acc, gyr = _xyz(s, "acc_"), _xyz(s, "gyr_")
    q = np.column_stack([schema.floats(tr, f"true_q{i}") for i in range(4)])
    r_true = np.swapaxes(_so3.matrix_from_quat(q), 1, 2)  # truth stores map -> sensor
    v_true, p_true = _xyz(tr, "true_v"), _xyz(tr, "true_")
    dt = np.diff(t)
    g = np.array([0.0, 0.0, -9.81])
    # one step of eq 6 from every true state reproduces the next true state
    r_next = r_true[:-1] @ _so3.exp(gyr[:-1] * dt[:, None])
    assert np.abs(r_next - r_true[1:]).max() < 1e-9
    v_next = v_true[:-1] + dt[:, None] * (np.einsum("nij,nj->ni", r_true[:-1], acc[:-1]) + g)
    assert np.abs(v_next - v_true[1:]).max() < 1e-6
    # integrating the whole trial: position within 5 mm (trapezoid vs the exact path)
    p = p_true[0] + np.vstack([np.zeros(3), np.cumsum(0.5 * (v_true[1:] + v_true[:-1]) * dt[:, None], axis=0)])
    assert np.abs(p - p_true).max() < 5e-3
    # the magnetometer is the rotated (disturbed) reference field
    hm = validate(clean.holds, clean.holds_meta)
    assert np.allclose(np.linalg.norm(hm.magnetic_field), 1.0)


def test_route_and_plan_follow_the_issue(clean):
    hm = validate(clean.holds, clean.holds_meta)
    ids, pos = hm.route_holds(clean.route)
    assert 10 <= ids.size <= 20
    assert len(hm.start_holds[clean.route]) == 2 and clean.start_hold in hm.start_holds[clean.route]
    top = hm.position(hm.top_holds[clean.route])
    assert 3.5 < top[2] < 5.0 and top[2] == pos[:, 2].max()
    assert len(hm.routes) == 3 and hm.up.tolist() == [0.0, 0.0, 1.0]
    assert clean.holds_meta["frame"]["axes"].endswith("z up")
    moves = [s.t1 - s.t0 for s in clean.segments if s.kind == "move" and not s.adjust]
    assert min(moves) >= 0.3 - 1e-9 and max(moves) <= 2.0 + 1e-9
    first = clean.segments[0]
    assert first.kind == "grip" and first.hold == clean.start_hold
    assert 0 < clean.descent_time < clean.segments[-1].t1


def test_grips_are_at_holds_or_on_the_wall():
    kinds = {"wall": 0, "adjust": 0, "off": 0}
    for seed in range(6):
        sim = simulate_boulder(BoulderConfig(seed=seed, imu_rate=60))
        hm = validate(sim.holds, sim.holds_meta)
        p = _xyz(sim.truth, "true_")
        grip = sim.truth.column("true_grip").to_numpy(zero_copy_only=False)
        hold = np.asarray(sim.truth.column("true_hold").fill_null(-2).to_numpy(), dtype=int)
        v = np.linalg.norm(_xyz(sim.truth, "true_v"), axis=1)
        # still hands, rolling about the grip point (a slap rings for a few tens of ms at a grip's start)
        assert np.percentile(v[grip], 98) < 0.05
        _, route_pos = hm.route_holds(sim.route)
        for k in np.flatnonzero(grip)[::25]:
            if hold[k] >= 0:
                d = np.linalg.norm(p[k] - hm.position(hold[k]))
                kinds["off"] += d > 0.12
                assert d < 0.25
            else:
                kinds["wall"] += 1
                assert np.linalg.norm(route_pos - p[k], axis=1).min() > 0.2
        kinds["adjust"] += sim.truth_meta["climbing"]["adjustments"]
    assert all(v > 0 for v in kinds.values()), kinds


def test_clipping_occurs_and_is_at_the_range():
    hits = 0
    for seed in range(8):
        sim = simulate_boulder(BoulderConfig(seed=seed, imu_rate=100))
        acc = _xyz(sim.session, "acc_")
        assert np.abs(acc).max() <= 160.0
        hits += int((np.abs(acc) >= 160.0).any())
    assert hits >= 1


def test_disturbance_is_a_dipole():
    m = np.array([0.0, 0.0, 0.02])
    dip = [(np.zeros(3), m)]
    p = np.array([[0.5, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.5]])
    b = disturbance_field(p, dip)
    assert np.allclose(b[0], -m / 0.5**3)  # equatorial: -m / r^3
    assert np.allclose(b[1], b[0] / 8)  # decays with r^3
    assert np.allclose(b[2], 2 * m / 0.5**3)  # axial: 2 m / r^3


def test_same_seed_same_tables_different_seed_different():
    a = simulate_boulder(BoulderConfig(seed=7, imu_rate=60))
    b = simulate_boulder(BoulderConfig(seed=7, imu_rate=60))
    c = simulate_boulder(BoulderConfig(seed=8, imu_rate=60))
    assert a.session.equals(b.session) and a.truth.equals(b.truth) and a.holds.equals(b.holds)
    assert not a.session.equals(c.session)


def test_cli_writes_session_truth_and_holds(tmp_path):
    from sportfusion.tools.simulate import main

    out, truth, holds = tmp_path / "s.parquet", tmp_path / "t.parquet", tmp_path / "h.parquet"
    args = ["boulder", "--seed", "3", "--imu-rate", "60", "--route-holds", "10"]
    res = CliRunner().invoke(main, [*args, "--truth", str(truth), "--holds", str(holds), "-o", str(out)])
    assert res.exit_code == 0, res.output
    s, sm = sfio.read_table(str(out), kind="session")
    tt, _ = sfio.read_table(str(truth), kind="truth")
    h, hmeta = sfio.read_table(str(holds), kind="holds")
    assert s.num_rows == tt.num_rows and s.column("t").equals(tt.column("t"))
    assert sm["units"]["mag_x"] == "1" and sm["climbing"]["route"] in set(h.column("route").to_pylist())
    assert hmeta["provenance"][-1]["tool"] == "simulate boulder"
    assert tt.column("true_hold").type == schema.lookup("hold").type
    res = CliRunner().invoke(main, ["boulder", "--help"])
    assert res.exit_code == 0 and "Example" in res.output and "[Hz]" in res.output


def test_truth_attitude_is_smooth(clean):
    # bounded angular rate and acceleration of the hand (no slaps in this trial; a slap would ring the hand by
    # about 0.04 rad at 30 Hz, 1400 rad/s^2)
    q = np.column_stack([schema.floats(clean.truth, f"true_q{i}") for i in range(4)])
    t = schema.floats(clean.truth, "t")
    r = _so3.matrix_from_quat(q)
    w = _so3.log(np.swapaxes(r[:-1], 1, 2) @ r[1:]) / np.diff(t)[:, None]
    alpha = np.diff(w, axis=0) / np.diff(t)[1:, None]
    assert np.abs(w).max() < 10.0 and np.abs(alpha).max() < 200.0  # rad/s, rad/s^2 (measured: 5, 65)


def test_variants_and_the_extra_unit_errors():
    assert set(VARIANTS) >= {"nominal", "steel-wall", "volumes", "rests", "wall-grips", "sensor", "big-hand"}
    assert BoulderConfig(variant="rests").grip_scale == 3.0
    assert BoulderConfig(variant="rests", grip_scale=2.0).grip_scale == 2.0  # an explicit field wins
    with pytest.raises(ValueError, match="unknown variant"):
        BoulderConfig(variant="nope")
    base = simulate_boulder(BoulderConfig(seed=5, imu_rate=60, route_holds=10))
    rest = simulate_boulder(BoulderConfig(seed=5, imu_rate=60, route_holds=10, variant="rests"))
    assert rest.segments[-1].t1 > 1.8 * base.segments[-1].t1
    vol = simulate_boulder(BoulderConfig(seed=5, imu_rate=60, route_holds=10, variant="volumes"))
    hm = validate(vol.holds, vol.holds_meta)
    d = [np.linalg.norm(sg.c0 - hm.position(sg.hold)) for sg in vol.segments if sg.kind == "grip" and sg.hold >= 0]
    assert max(d) > 0.1  # grips far from the centres of big holds
    # the plan does not depend on the unit's extra errors (a second random stream)
    hot = simulate_boulder(BoulderConfig(seed=5, imu_rate=60, route_holds=10, temp_rise=30.0))
    assert hot.truth.equals(base.truth) and not hot.session.equals(base.session)


def test_hold_map_is_the_documented_format():
    # written by the simulator itself, read by the estimator's validator
    sim = simulate_boulder(BoulderConfig(seed=9, imu_rate=60, route_holds=12))
    hm = validate(sim.holds, sim.holds_meta)
    assert sim.holds_meta["kind"] == "holds" and set(hm.routes) == set(sim.holds.column("route").to_pylist())
    assert all(len(v) == 2 for v in hm.start_holds.values()) and hm.top_holds
    assert hm.magnetic_field is not None and np.isclose(np.linalg.norm(hm.magnetic_field), 1.0)
