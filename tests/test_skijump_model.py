"""The ski-jump smoother model: analytic Jacobians vs finite differences, discretisation, inputs, config."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from sportfusion.core import io as sfio
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.skijump import model as mdl
from sportfusion.skijump.hillfile import load_hill
from sportfusion.skijump.kinematics import m_no
from sportfusion.skijump.smoother_inputs import ProfileTable, SmootherConfig, load_config, session_inputs

FIX = "fixtures/skijump/"


def _state(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = np.zeros(mdl.N)
    x[0:3] = rng.normal(0, 30, 3)
    x[3:6] = rng.normal(0, 15, 3)
    q = rng.normal(size=4)
    x[6:10] = 1.05 * q / np.linalg.norm(q)  # off the unit sphere: the model must not assume |q| = 1
    x[10:22] = rng.normal(0, 0.1, 12)
    return x


def _fd(fun, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    cols = []
    for i in range(x.size):
        d = np.zeros_like(x)
        d[i] = eps
        cols.append((fun(x + d) - fun(x - d)) / (2 * eps))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_state_jacobians_match_finite_differences(seed):
    x = _state(seed)
    u = np.random.default_rng(seed + 10).normal(0, [1, 1, 1, 5, 5, 5])
    mno = m_no(math.radians(312.6))
    g0 = 9.8053
    A = mdl.jac_a(x, u, g0, mno)
    A_fd = _fd(lambda xx: mdl.f_aug(xx, u, g0, mno), x)
    np.testing.assert_allclose(A, A_fd, rtol=0, atol=1e-6 * max(1.0, np.abs(A_fd).max()))
    # the noise enters like the biases: df/dw = -df/du
    F_fd = -_fd(lambda uu: mdl.f_aug(x, uu, g0, mno), u)
    np.testing.assert_allclose(mdl.jac_f(x), F_fd, rtol=0, atol=1e-6)
    # parameters are constant (eq 22)
    assert np.all(mdl.f_aug(x, u, g0, mno)[10:] == 0)


@pytest.mark.parametrize("seed", [0, 3])
def test_output_jacobians_match_finite_differences(seed):
    x = _state(seed)
    m_o = np.array([21.0, 1.2, 43.5])
    np.testing.assert_allclose(mdl.H_vel(x), _fd(mdl.h_vel, x), atol=1e-6)
    np.testing.assert_allclose(mdl.H_mag(x, m_o), _fd(lambda xx: mdl.h_mag(xx, m_o), x), atol=1e-6)
    np.testing.assert_allclose(mdl.C_q(x), _fd(lambda xx: np.array([mdl.c_q(xx)]), x), atol=1e-8)


def test_dm_dq_batched_equals_single():
    q = np.random.default_rng(4).normal(size=(5, 4))
    many = mdl.dm_dq(q)
    assert many.shape == (5, 4, 3, 3)
    for i in range(5):
        np.testing.assert_array_equal(many[i], mdl.dm_dq(q[i]))


def test_discrete_matches_matrix_exponential():
    x = _state(5)
    u = np.array([0.5, -0.3, 1.0, 2.0, -9.0, 1.0])
    mno = m_no(0.3)
    A = mdl.jac_a(x, u, 9.81, mno)
    F = mdl.jac_f(x)
    dt = 0.01
    Phi, Qd = mdl.discrete(A, F, np.full(6, 0.01), dt)
    # second-order series: error of order |A dt|^3 / 6
    err = np.abs(Phi - scipy.linalg.expm(A * dt)).max()
    assert err < np.linalg.norm(A * dt, 2) ** 3 / 6 * 2
    assert np.allclose(Qd, Qd.T) and np.linalg.eigvalsh(Qd).min() > -1e-18
    # Gamma ~ F dt: Qd ~ F Q F^T dt^2 to first order
    np.testing.assert_allclose(Qd, 0.01 * F @ F.T * dt**2, atol=0.02 * np.abs(Qd).max())


def test_rk4_with_true_imu_reproduces_the_truth():
    """Integrating the noise-free truth IMU with zero biases follows the simulated jump (errata eq 45 sign).

    On the paper mode's truth, which keeps to what 100 Hz samples can represent (the fixture's full physics
    has 15-80 Hz chatter: its 100 Hz truth samples cannot be integrated back to the motion)."""
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

    sim = simulate_skijump(load_hill("oberstdorf_hs106"), SkiJumpConfig(seed=1, physics="paper"))
    truth, tmeta = sim.truth, sim.truth_meta
    col = lambda n: schema.floats(truth, n)  # noqa: E731
    t = col("t")
    u = np.stack([col(f"true_{s}_{a}") for s in ("gyr", "acc") for a in "xyz"], axis=-1)
    r = np.stack([col(f"true_{a}") for a in "xyz"], axis=-1)
    v_o = np.stack([col(f"true_vel_{a}") for a in "ned"], axis=-1)
    q = np.stack([col(f"true_q{k}") for k in range(4)], axis=-1)
    from sportfusion.skijump.kinematics import m_bo

    x = np.zeros(mdl.N)
    x[0:3], x[3:6], x[6:10] = r[0], m_bo(q[0]) @ v_o[0], q[0]
    mno = m_no(math.radians(tmeta["frame"]["azimuth_deg"]))
    g0 = tmeta["skijump"]["gravity"]
    n = t.size
    for k in range(n - 1):
        x = mdl.rk4_aug(x, u[k], u[k + 1], t[k + 1] - t[k], g0, mno)
    assert np.linalg.norm(x[0:3] - r[-1]) < 0.5  # whole jump, ~25 s of dead reckoning (sim doc: cm-level)


def test_profile_table_matches_hill():
    hill = load_hill("oberstdorf_hs106")
    for part in ("inrun", "landing"):
        tab = ProfileTable(hill, part)
        segs = hill.profile.segments(part)
        xs = np.linspace(segs[0].x0, segs[-1].x1, 997)
        z_ref = hill.profile.z(xs, part)
        dz_ref = hill.profile.dzdx(xs, part)
        z = np.array([tab(x)[0] for x in xs])
        dz = np.array([tab(x)[1] for x in xs])
        assert np.abs(z - z_ref).max() < 1e-4
        assert np.abs(dz - dz_ref).max() < 2e-3
        np.testing.assert_allclose(tab.many(xs), z, atol=1e-12)


def test_config_defaults_are_tables_3_to_5_and_toml_overrides(tmp_path):
    c = SmootherConfig()
    assert c.p0_pos == (5.0, 5.0, 15.0) and c.p0_quat == 0.1 and c.p0_bias_gyr == 0.0873
    assert (c.q_gyr, c.q_acc) == (0.0175, 0.1)
    # Table 5 but the GNSS position and the hill constraints (issue 39: correlated GNSS errors; bench)
    assert c.r_gnss_pos == (5.0, 5.0, 8.0) and c.r_gnss_vel == (0.1, 0.1, 0.3) and c.r_mag == 5.0
    assert (c.r_c_q, c.r_c_v_ir, c.r_c_h_ir, c.r_c_v_la) == (0.01, 0.05, 0.05, 0.05)
    f = tmp_path / "c.toml"
    f.write_text("q_acc = 0.2\nr_gnss_pos = [1, 1, 2]\nhill_constraints = false\n")
    c2 = load_config(f)
    assert c2.q_acc == 0.2 and c2.r_gnss_pos == (1.0, 1.0, 2.0) and c2.hill_constraints is False
    assert c2.q_gyr == 0.0175
    f.write_text("[rts]\nla_ramp = 0.5\n")
    assert load_config(f).la_ramp == 0.5
    for bad in ("nope = 1", "r_gnss_pos = [1, 2]", "q_acc = -1", "use_mag = 1", "q_acc = "):
        f.write_text(bad + "\n")
        with pytest.raises(InputError, match="config"):
            load_config(f)


def test_session_inputs_windows_on_fixture():
    tab, meta = sfio.read_table(FIX + "session.parquet")
    truth, tmeta = sfio.read_table(FIX + "truth.parquet", kind="truth")
    to = tmeta["skijump"]["times"]["takeoff"]
    td = tmeta["skijump"]["times"]["touchdown"]
    hill = load_hill("oberstdorf_hs106")
    inp, frame = session_inputs(tab, meta, hill, SmootherConfig(), [to], [td])
    assert frame.azimuth_deg == 312.6
    imu = np.isfinite(schema.floats(tab, "acc_x"))
    gnss = np.isfinite(schema.floats(tab, "lat"))
    # the steps are the IMU's rows; each fix (its own rows) goes to the nearest step within half a step
    t_rows = schema.floats(tab, "t")
    near = np.abs(t_rows[gnss][:, None] - t_rows[imu][None, :]).min(axis=1) <= 0.005 + 1e-9
    assert inp.t.size == int(imu.sum()) and np.isfinite(inp.pos[:, 0]).sum() == int(near.sum()) > 250
    # in-run: from the session start (the jumper rests at the gate) to the take-off, inclusive
    # (from the rest's first GNSS epoch within the IMU data: the fixture's first fix, at 0.0 s, precedes the IMU)
    first = float(np.min(t_rows[gnss][t_rows[gnss] >= inp.t[0]]))
    on = (inp.t >= first) & (inp.t <= to)
    assert inp.inrun[on].all() and not inp.inrun[inp.t > to].any() and inp.inrun[on].sum() > 1000
    # landing: nothing before the touch-down, ramp over 0.2 s, then full weight to the end
    assert not (inp.landing[inp.t < td] > 0).any()
    assert inp.landing[-1] == 1.0
    ramp = (inp.t > td) & (inp.t < td + 0.2)
    assert np.all((inp.landing[ramp] > 0) & (inp.landing[ramp] < 1))
    # the reference field is the WMM at the site (about 48 uT total in southern Germany)
    assert 45 < np.linalg.norm(inp.m_o) < 52
    assert inp.m_o[2] > 0  # dip downward in the northern hemisphere


def test_row_samples_onto_steps_when_every_row_is_a_step_and_when_not() -> None:
    """_to_steps: with every row an IMU step, row k is step k (its fast path); with rows between the steps
    (a GNSS row without IMU), each sample goes to the nearest step within half a step, the rest is NaN."""
    from sportfusion.skijump.smoother_inputs import _to_steps

    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.009, 0.011, 500))
    v = rng.normal(size=(500, 3))
    ok = rng.uniform(size=500) < 0.2
    want = np.full_like(v, np.nan)
    want[ok] = v[ok]
    np.testing.assert_array_equal(_to_steps(t, ok, v, t), want)
    # the same samples 1 ms late, on rows of their own between the steps: the general path
    rows = np.sort(np.concatenate((t, t[ok] + 0.001)))
    vals = np.full((rows.size, 3), np.nan)
    mine = np.isin(rows, t[ok] + 0.001)
    vals[mine] = v[ok]
    np.testing.assert_array_equal(_to_steps(rows, mine, vals, t), want)


def test_gnss_fixes_carried_to_their_imu_step() -> None:
    """A receiver's fixes between the IMU's samples (its own clock) move to their step along the GNSS velocity:
    a constant-acceleration track is recovered exactly at the steps (issue 39)."""
    from sportfusion.core.rotations import ned_to_local
    from sportfusion.skijump.smoother_inputs import _carry_to_steps, _to_steps

    az = 312.6
    t = 0.004 + 0.01 * np.arange(300)  # IMU steps, phase 4 ms
    tg = 0.1 * np.arange(30)  # receiver epochs
    rows = np.union1d(t, tg)
    a_ned = np.array([1.5, -0.5, 2.0])
    v0 = np.array([20.0, 5.0, 3.0])
    vel = v0 + rows[:, None] * a_ned  # NED [m/s]
    pos = ned_to_local(v0 * rows[:, None] + 0.5 * a_ned * rows[:, None] ** 2, az)  # hill frame [m]
    fix = np.isin(rows, tg)
    pos_rows, vel_rows = np.where(fix[:, None], pos, np.nan), np.where(fix[:, None], vel, np.nan)
    p2, v2 = _carry_to_steps(rows, t, pos_rows, vel_rows, az)
    on = _to_steps(rows, fix, p2, t)
    k = np.isfinite(on[:, 0])
    assert k.sum() == tg.size
    true_at_steps = ned_to_local(v0 * t[:, None] + 0.5 * a_ned * t[:, None] ** 2, az)
    # position carried along the fix's velocity: exact to a dt^2/2 of the acceleration (4 ms: 16 um)
    assert np.abs(on[k] - true_at_steps[k]).max() < 2e-5
    assert np.abs(_to_steps(rows, fix, pos_rows.copy(), t)[k] - true_at_steps[k]).max() > 0.05  # not carried
    onv = _to_steps(rows, fix, v2, t)
    assert np.abs(onv[k] - (v0 + t[k, None] * a_ned)).max() < 1e-9


def test_gnss_outliers_screened_from_the_smoothed_track() -> None:
    """_screen_gnss: a wild fix and a multipath stretch far from the smoothed track are dropped (position and
    velocity), the slow drift and white noise kept; a clean track loses nothing."""
    from types import SimpleNamespace

    from sportfusion.skijump.smoother_passes import _screen_gnss

    rng = np.random.default_rng(3)
    n = 3000
    xs = np.zeros((n, 22))
    xs[:, 0] = np.linspace(-100.0, 100.0, n)
    pos = np.full((n, 3), np.nan)
    g = np.arange(0, n, 10)
    pos[g] = xs[g, :3] + np.array([1.2, -0.8, 2.0]) + rng.normal(0.0, 0.3, (g.size, 3))  # drift + white
    vel = np.where(np.isfinite(pos), 1.0, np.nan)
    cfg = SmootherConfig()
    seg = SimpleNamespace(pos=pos.copy(), vel=vel.copy())
    assert _screen_gnss(seg, xs, cfg) == 0 and np.array_equal(np.isfinite(seg.pos), np.isfinite(pos))
    bad = pos.copy()
    bad[g[40]] += [25.0, 0.0, 0.0]  # a wild fix
    bad[g[100:130]] += [0.0, 6.0, 3.0]  # 3 s of multipath
    seg = SimpleNamespace(pos=bad, vel=vel.copy())
    assert _screen_gnss(seg, xs, cfg) == 31
    assert np.isnan(seg.pos[g[40]]).all() and np.isnan(seg.vel[g[110]]).all() and np.isfinite(seg.pos[g[50]]).all()
    assert np.isfinite(bad[g[40]]).all()  # the caller's arrays are not written
