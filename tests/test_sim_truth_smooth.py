"""Every simulator's truth is physically possible: bounded angular rate and angular acceleration, bounded
linear acceleration, and positions that agree with the velocities (no step in any of them).

The truth tables are what the estimators are scored against: a step of 25 deg within one sample (the ski-race
simulator's roll at a take-off, before this test) is a motion no body makes, and an estimator that smooths it
is scored as wrong.  Checked on the shipped fixtures and on a fresh simulation (another seed) of each
simulator, from the truth table's own rows:

* angular rate: the mean body rate over each interval between rows (``Log(q_k* q_k+1) / dt``);
* angular acceleration: the change of that rate between consecutive intervals over the time between
  the intervals' midpoints;
* linear acceleration: the change of the true velocity over each interval;
* position against velocity: ``(p_k+1 - p_k) / dt`` against the trapezoid mean of ``v_k, v_k+1``.

Bounds (a body segment's motion in the sport, with room for the simulators' own variety; a step of 1 deg
within one 20 ms row gives 44 rad/s^2 of angular acceleration, a 25 deg step 1100 rad/s^2):

* ski jump (upper arm), ski race (helmet), magnet gates (sacrum): rate <= 360 deg/s, angular
  acceleration <= 100 rad/s^2 (they reach ~190 deg/s and ~45 rad/s^2), linear acceleration <= 10 g;
* bouldering (the back of the hand): rate <= 720 deg/s, angular acceleration <= 300 rad/s^2, except in the
  80 ms after the hand arrives on a hold, where the simulator models a slap (a 30 Hz ring of a few degrees
  decaying in 12 ms: an impact, <= 2000 rad/s^2 and 25 g).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from conftest import ROOT

from sportfusion.core import io as sfio
from sportfusion.core import rotations, schema

G = 9.80665


@dataclass(frozen=True)
class Bounds:
    rate_deg: float  # [deg/s]
    alpha: float  # [rad/s^2]
    lin_g: float  # [g]
    impact_alpha: float = 0.0  # [rad/s^2] within `impact_window` after a grip onset (climbing slaps)
    impact_lin_g: float = 0.0  # [g]
    impact_window: float = 0.0  # [s]


BODY = Bounds(rate_deg=360.0, alpha=100.0, lin_g=10.0)
HAND = Bounds(rate_deg=720.0, alpha=300.0, lin_g=10.0, impact_alpha=2000.0, impact_lin_g=25.0, impact_window=0.08)
BOUNDS = {"skijump": BODY, "skirace": BODY, "gates": BODY, "climbing": HAND}


def _motion(truth: pa.Table) -> dict[str, np.ndarray]:
    t = schema.floats(truth, "t")
    q = schema.float_columns(truth, [f"true_q{i}" for i in range(4)])
    p = schema.float_columns(truth, ["true_x", "true_y", "true_z"])
    v = schema.float_columns(truth, ["true_vx", "true_vy", "true_vz"])
    ok = np.isfinite(q).all(axis=1) & np.isfinite(p).all(axis=1) & np.isfinite(v).all(axis=1)
    assert ok.all(), "the truth has a value on every row"
    dt = np.diff(t)
    w = rotations.body_rates(t, q)[1:]  # mean body rate over each interval [rad/s]
    tm = 0.5 * (t[1:] + t[:-1])
    alpha = np.linalg.norm(np.diff(w, axis=0), axis=1) / np.diff(tm)
    lin = np.linalg.norm(np.diff(v, axis=0), axis=1) / dt
    pv = np.linalg.norm(np.diff(p, axis=0) / dt[:, None] - 0.5 * (v[1:] + v[:-1]), axis=1)
    return {
        "t": t,
        "tm": tm,
        "ta": 0.5 * (tm[1:] + tm[:-1]),
        "dt": dt,
        "rate": np.linalg.norm(w, axis=1),
        "alpha": alpha,
        "lin": lin,
        "pv": pv,
    }


def _impact_mask(times: np.ndarray, truth: pa.Table, window: float) -> np.ndarray:
    """True within ``window`` [s] after (and 20 ms before) every onset of ``true_grip``."""
    if window <= 0 or "true_grip" not in truth.column_names:
        return np.zeros(times.shape, bool)
    t = schema.floats(truth, "t")
    g = np.array([bool(v) for v in truth.column("true_grip").to_pylist()])
    onsets = t[1:][g[1:] & ~g[:-1]]
    near = np.zeros(times.shape, bool)
    for a in onsets:
        near |= (times >= a - 0.02) & (times <= a + window)
    return near


def check_truth(truth: pa.Table, sport: str) -> dict[str, float]:
    """Assert the bounds of ``sport`` on a truth table; returns the measured maxima (for the messages)."""
    b = BOUNDS[sport]
    m = _motion(truth)
    rate_deg = np.degrees(m["rate"])
    k = int(np.argmax(rate_deg))
    assert rate_deg[k] <= b.rate_deg, f"{sport}: angular rate {rate_deg[k]:.0f} deg/s at t = {m['tm'][k]:.3f} s"
    impact_a = _impact_mask(m["ta"], truth, b.impact_window)
    calm = m["alpha"][~impact_a]
    k = int(np.argmax(calm))
    assert calm[k] <= b.alpha, (
        f"{sport}: angular acceleration {calm[k]:.0f} rad/s^2 at t = {m['ta'][~impact_a][k]:.3f} s (a step?)"
    )
    if impact_a.any():
        assert m["alpha"][impact_a].max() <= b.impact_alpha, f"{sport}: a slap beyond {b.impact_alpha} rad/s^2"
    impact_l = _impact_mask(m["tm"], truth, b.impact_window)
    lin_g = m["lin"] / G
    assert lin_g[~impact_l].max() <= b.lin_g, f"{sport}: linear acceleration {lin_g[~impact_l].max():.1f} g"
    if impact_l.any():
        assert lin_g[impact_l].max() <= b.impact_lin_g
    # positions follow the velocities: the trapezoid's error is at most half an interval's change of velocity
    # (in a slap the velocity rings within the interval: half the impact bound's change instead)
    tol = 0.5 * m["dt"] * np.where(impact_l, b.impact_lin_g * G, m["lin"]) + 0.02
    k = int(np.argmax(m["pv"] - tol))
    assert m["pv"][k] <= tol[k], f"{sport}: position step at t = {m['tm'][k]:.3f} s ({m['pv'][k]:.3f} m/s off)"
    return {"rate_deg": float(rate_deg.max()), "alpha": float(m["alpha"].max()), "lin_g": float(lin_g.max())}


@pytest.mark.parametrize("sport", ["skijump", "skirace", "gates", "climbing"])
def test_shipped_fixture_truth_is_smooth(sport: str) -> None:
    truth, _ = sfio.read_table(Path(ROOT) / "fixtures" / sport / "truth.parquet", kind="truth")
    check_truth(truth, sport)


def _fresh(sport: str) -> pa.Table:
    if sport == "skijump":
        from sportfusion.skijump.hillfile import load_hill
        from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

        return simulate_skijump(load_hill("oberstdorf_hs106"), SkiJumpConfig(seed=2)).truth
    if sport == "skirace":
        from sportfusion.skirace.sim import SkiRaceConfig, simulate_skirace

        return simulate_skirace(SkiRaceConfig(seed=2, duration=24.0)).truth
    if sport == "gates":
        from sportfusion.gates.sim import GatesConfig, simulate_gates

        return simulate_gates(GatesConfig(seed=2, n_gates=6)).truth
    from sportfusion.climbing.sim import BoulderConfig, simulate_boulder

    return simulate_boulder(BoulderConfig(seed=2)).truth


@pytest.mark.parametrize("sport", ["skijump", "skirace", "gates", "climbing"])
def test_fresh_simulation_truth_is_smooth(sport: str) -> None:
    check_truth(_fresh(sport), sport)


def test_the_check_finds_a_step() -> None:
    """The check is not blind: a 25 deg roll step within one 20 ms row and a 10 cm position jump both fail."""
    t = np.arange(0.0, 4.0, 0.02)
    roll = np.deg2rad(10.0) * np.sin(2 * np.pi * t / 3.0)
    yaw = 0.3 * t
    v = np.column_stack([np.full_like(t, 10.0), np.zeros_like(t), np.zeros_like(t)])
    p = np.column_stack([10.0 * t, np.zeros_like(t), np.zeros_like(t)])

    def table(roll: np.ndarray, p: np.ndarray) -> pa.Table:
        q = rotations.quat_from_euler(roll, np.zeros_like(t), yaw)
        cols = {"t": t, **{f"true_q{i}": q[:, i] for i in range(4)}}
        cols.update({f"true_{a}": p[:, i] for i, a in enumerate("xyz")})
        cols.update({f"true_v{a}": v[:, i] for i, a in enumerate("xyz")})
        return pa.table(cols)

    check_truth(table(roll, p), "skirace")
    stepped = roll + np.deg2rad(25.0) * (t >= 2.0)
    with pytest.raises(AssertionError, match="angular"):
        check_truth(table(stepped, p), "skirace")
    jumped = p + np.array([0.1, 0.0, 0.0]) * (t >= 2.0)[:, None]
    with pytest.raises(AssertionError, match="position step"):
        check_truth(table(roll, jumped), "skirace")
