"""In-motion alignment over the in-run (skijump.alignment): gyro carrying, attitude against the truth."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sportfusion.core.rotations import quat_angle
from sportfusion.core.schema import floats
from sportfusion.skijump.alignment import body_to_start, inrun_attitude
from sportfusion.skijump.hillfile import load_hill
from sportfusion.skijump.smoother import _initial_rest, initial_state
from sportfusion.skijump.smoother_inputs import SmootherConfig, session_inputs

HILL = "oberstdorf_hs106"


def test_body_to_start_against_scipy_rotations():
    # a rate that turns its axis: piecewise constant steps composed by scipy as the independent reference
    rng = np.random.default_rng(4)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.005, 0.015, 400)])
    gyr = np.column_stack([np.sin(3 * t), 0.5 * np.cos(2 * t), 0.3 + 0.0 * t]) + 0.01
    bias = np.array([0.01, 0.01, 0.01])
    c = body_to_start(t, gyr, bias)
    ref = Rotation.identity()
    for k in range(t.size - 1):
        ref = ref * Rotation.from_rotvec((gyr[k] - bias) * (t[k + 1] - t[k]))
    np.testing.assert_allclose(c[-1], ref.as_matrix(), atol=1e-10)
    np.testing.assert_allclose(np.einsum("kij,kil->kjl", c, c), np.broadcast_to(np.eye(3), c.shape), atol=1e-10)


@pytest.fixture(scope="module")
def jump():
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

    hill = load_hill(HILL)
    sim = simulate_skijump(hill, SkiJumpConfig(seed=7))
    tt = sim.truth_meta["skijump"]["times"]
    cfg = SmootherConfig()
    inp, _ = session_inputs(sim.session, sim.session_meta, hill, cfg, [tt["takeoff"]], [tt["touchdown"]])
    q_true = np.array([floats(sim.truth, f"true_q{i}")[0] for i in range(4)])
    return inp, cfg, q_true


def test_inrun_alignment_beats_the_magnetometer_heading(jump):
    inp, cfg, q_true = jump
    rest = _initial_rest(inp, cfg)
    x0, _ = initial_state(inp, SmootherConfig(inrun_align=False))
    q = inrun_attitude(inp.t, inp.u, inp.vel, rest, inp.inrun, inp.g0, x0[10:13])
    assert q is not None
    err_align = np.degrees(quat_angle(q, q_true))
    err_mag = np.degrees(quat_angle(x0[6:10], q_true))  # rest QUEST with the biased magnetometer
    assert err_align < 2.0, err_align
    assert err_align < err_mag, (err_align, err_mag)
    x1, _ = initial_state(inp, cfg)  # the default start uses it
    np.testing.assert_allclose(x1[6:10], q, atol=1e-12)


def test_no_inrun_no_alignment(jump):
    inp, cfg, _ = jump
    rest = _initial_rest(inp, cfg)
    none = np.zeros(inp.t.size, bool)
    assert inrun_attitude(inp.t, inp.u, inp.vel, rest, none, inp.g0, np.zeros(3)) is None
    # a standing athlete (no tilt of the specific force) gives no heading either
    still = inp.u.copy()
    still[:, 3:6] = inp.u[rest, 3:6].mean(axis=0)
    still[:, 0:3] = 0.0
    vel0 = np.where(np.isfinite(inp.vel), 0.0, np.nan)
    assert inrun_attitude(inp.t, still, vel0, rest, inp.inrun, inp.g0, np.zeros(3)) is None


def test_inconsistent_observations_are_refused(jump):
    inp, cfg, _ = jump
    rest = _initial_rest(inp, cfg)
    x0, _ = initial_state(inp, SmootherConfig(inrun_align=False))
    noisy = inp.vel + np.random.default_rng(1).normal(0.0, 3.0, inp.vel.shape)  # GNSS velocity off by metres/s
    assert inrun_attitude(inp.t, inp.u, noisy, rest, inp.inrun, inp.g0, x0[10:13]) is None
