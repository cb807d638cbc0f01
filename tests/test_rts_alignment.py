"""In-motion alignment over the in-run (skijump.alignment): gyro carrying, attitude against the truth."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sportfusion.core.rotations import quat_angle
from sportfusion.core.schema import floats
from sportfusion.skijump.alignment import body_to_start, inrun_attitude
from sportfusion.skijump.hillfile import load_hill
from sportfusion.skijump.smoother_inputs import SmootherConfig, session_inputs
from sportfusion.skijump.smoother_start import _initial_rest, initial_state

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
    for n in (1, 2, 3, 7, 64, t.size):  # the product tree, odd and even counts
        last = body_to_start(t[:n], gyr[:n], bias, last_only=True)
        assert last.shape == (1, 3, 3)
        np.testing.assert_allclose(last[0], body_to_start(t[:n], gyr[:n], bias)[-1], atol=1e-12)
    np.testing.assert_allclose(np.einsum("kij,kil->kjl", c, c), np.broadcast_to(np.eye(3), c.shape), atol=1e-10)


def test_body_to_start_in_c_matches_numpy():
    from sportfusion.skijump import _ski_native
    from sportfusion.skijump.alignment import _body_to_start_numpy

    mod = _ski_native.native()
    if mod is None:
        pytest.skip("the C extension sportfusion.skijump._ski_c is not built")
    rng = np.random.default_rng(11)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.005, 0.015, 999)])
    gyr = rng.normal(0.0, 2.0, (t.size, 3))
    gyr[5] = 0.0  # a zero rate: the small-angle branch
    bias = np.array([0.02, -0.01, 0.03])
    gyr[6] = bias
    for n in (1, 2, 3, 64, t.size):
        for last in (False, True):
            got = body_to_start(t[:n], gyr[:n], bias, last_only=last)
            want = _body_to_start_numpy(t[:n], gyr[:n], bias, last_only=last)
            assert got.shape == want.shape
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    # a strided gyro (the IMU table's first three columns) is read as given
    u = np.column_stack([gyr, gyr * 2.0])
    np.testing.assert_allclose(body_to_start(t, u[:, 0:3], bias), _body_to_start_numpy(t, gyr, bias), atol=1e-12)
    with pytest.raises(ValueError, match="out must hold"):
        mod.body_to_start(t, np.ascontiguousarray(gyr), bias, np.empty((2, 3, 3)))
    with pytest.raises(ValueError, match="gyr"):
        mod.body_to_start(t, np.ascontiguousarray(gyr[:-1]), bias, np.empty((1, 3, 3)))


@pytest.fixture(scope="module")
def jump():
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

    hill = load_hill(HILL)
    # the paper's sensor models: the alignment's own accuracy (on the full physics' misaligned, vibrating,
    # filtered IMU it is 2.2 deg for this seed; bench/bench_skijump_independent.py measures the whole smoother there)
    sim = simulate_skijump(hill, SkiJumpConfig(seed=7, physics="paper"))
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


def test_shift_gnss_moves_fixes_to_the_time_they_describe():
    from sportfusion.skijump.alignment import shift_gnss

    t = np.arange(0.0, 10.0, 0.01)
    v = np.array([20.0, 1.0, -3.0])
    a = np.array([0.5, 0.0, 0.2])
    truth_p = t[:, None] * v + 0.5 * t[:, None] ** 2 * a
    truth_v = v + t[:, None] * a
    tau = 0.0937  # late stamps: the fix stamped t holds the state at t - tau
    fix = np.zeros(t.size, bool)
    fix[50::10] = True
    pos = np.full((t.size, 3), np.nan)
    vel = np.full((t.size, 3), np.nan)
    pos[fix] = (t[fix] - tau)[:, None] * v + 0.5 * (t[fix] - tau)[:, None] ** 2 * a
    vel[fix] = v + (t[fix] - tau)[:, None] * a
    p2, v2 = shift_gnss(t, pos, vel, vel, tau)
    got = np.isfinite(p2[:, 0])
    assert got.sum() == fix.sum()
    np.testing.assert_allclose(p2[got], truth_p[got], atol=2e-3)  # second order: a rem^2 / 2 with rem <= 5 ms
    np.testing.assert_allclose(v2[got], truth_v[got], atol=1e-9)


def test_lever_arm_removal_inverts_the_antenna_model():
    from sportfusion.core import rotations
    from sportfusion.skijump.smoother_passes import _remove_lever_arm

    rng = np.random.default_rng(3)
    n = 50
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = rng.normal(0, 1.0, (n, 3))
    lever = np.array([0.1, 0.3, -0.5])
    r = rng.normal(0, 10, (n, 3))
    v = rng.normal(0, 5, (n, 3))
    az = 312.6
    # the simulator's antenna (an independent formula: rotations.to_ned of body vectors)
    r_ant = r + rotations.ned_to_local(rotations.to_ned(q, np.broadcast_to(lever, (n, 3))), az)
    v_ant = v + rotations.to_ned(q, np.cross(w, lever))

    class Seg:
        pass

    seg = Seg()
    seg.pos, seg.vel, seg.azimuth_deg = r_ant.copy(), v_ant.copy(), az
    seg.u = np.hstack([w + 0.01, np.zeros((n, 3))])
    xs = np.zeros((n, 22))
    xs[:, 6:10] = q
    xs[:, 10:13] = 0.01  # gyro bias: the rate is gyro minus bias
    _remove_lever_arm(seg, xs, lever)
    np.testing.assert_allclose(seg.pos, r, atol=1e-12)
    np.testing.assert_allclose(seg.vel, v, atol=1e-12)


def test_gnss_latency_against_per_delay_least_squares():
    """The misfit by sums (constant = mean, drift orthogonal to it) equals np.linalg.lstsq delay by delay."""
    from sportfusion.skijump.alignment import gnss_latency

    rng = np.random.default_rng(8)
    g0, lat = 9.81, 0.07
    t = np.arange(0.0, 12.0, 0.01)
    a_ned = np.column_stack([3.0 * np.sin(0.9 * t), 2.0 * np.cos(1.3 * t), 1.5 * np.sin(2.1 * t + 0.4)])
    v_true = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (a_ned[1:] + a_ned[:-1]) * 0.01, axis=0)])

    x = np.zeros((t.size, 22))
    x[:, 6] = 1.0  # body = NED
    u = np.zeros((t.size, 6))
    u[:, 3:6] = a_ned - [0.0, 0.0, g0] + 0.02  # specific force with a residual bias (a drift in velocity)
    vel = np.full((t.size, 3), np.nan)
    k = np.arange(0, t.size, 10)
    vel[k] = np.column_stack([np.interp(t[k] - lat, t, v_true[:, j]) for j in range(3)]) + 1.5  # offset
    vel[k] += 0.01 * rng.standard_normal((k.size, 3))
    span = (1.0, 11.0)
    tau = gnss_latency(t, u, x, vel, g0, span)

    # reference: the IMU velocity as the function integrates it, each delay fitted by lstsq
    sel = np.flatnonzero((t >= span[0]) & (t <= span[1]))
    gk = sel[np.isfinite(vel[sel, 0])]
    gk = gk[(t[gk] - 0.3 >= t[sel][0]) & (t[gk] + 0.3 <= t[sel][-1])]  # every trial delay inside the IMU's span
    a = u[sel, 3:6] + [0.0, 0.0, g0]
    v_imu = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (a[1:] + a[:-1]) * 0.01, axis=0)])
    basis = np.column_stack([np.ones(gk.size), t[gk]])
    grid = np.arange(-0.3, 0.3 + 0.0025, 0.005)
    cost = []
    for d in grid:
        vi = np.column_stack([np.interp(t[gk] - d, t[sel], v_imu[:, j]) for j in range(3)])
        cost.append(np.linalg.lstsq(basis, vel[gk] - vi, rcond=None)[1].sum())
    c = np.array(cost)
    i = int(np.argmin(c))
    ref = grid[i] + 0.5 * (c[i - 1] - c[i + 1]) / (c[i - 1] - 2 * c[i] + c[i + 1]) * 0.005
    assert tau == pytest.approx(ref, abs=1e-9)
    assert abs(tau - lat) < 0.002


def test_latency_misfit_in_c_matches_numpy():
    """The C extension's misfit sums equal the numpy reference's at every delay, fixes near both ends of the IMU
    record included (the interpolation held at the ends), on uneven IMU steps."""
    from sportfusion.skijump import _ski_native
    from sportfusion.skijump.alignment import _latency_misfit_numpy

    mod = _ski_native.native()
    if mod is None:
        pytest.skip("C extension not built")
    rng = np.random.default_rng(3)
    ts = np.cumsum(rng.uniform(0.008, 0.012, 900))
    v = np.cumsum(rng.normal(size=(900, 3)), axis=0) * 0.05 + [20.0, -3.0, 1.0]
    tg = ts[::9] + 0.001
    vg = np.column_stack([np.interp(tg - 0.04, ts, v[:, j]) for j in range(3)]) + 0.02 * rng.normal(size=(tg.size, 3))
    grid = np.arange(-0.3, 0.3 + 0.0025, 0.005)
    want = _latency_misfit_numpy(ts, v, tg, vg, grid)
    got = np.empty(grid.size)
    mod.latency_misfit(ts, v, tg, vg, grid, np.empty_like(vg), got)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9 * want.max())
    assert abs(grid[int(np.argmin(got))] - 0.04) < 0.006
    with pytest.raises(ValueError, match="latency_misfit: expected"):
        mod.latency_misfit(ts, v, tg, vg, grid, np.empty(3 * tg.size - 3), got)


@pytest.mark.slow
def test_gnss_latency_found_and_removed():
    from sportfusion.evaluate import errors
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump
    from sportfusion.skijump.smoother import rts_smooth_table

    hill = load_hill(HILL)
    res = {}
    for lat in (0.0, 0.12):
        # the paper's sensors (GNSS at the IMU, on its samples): the estimator against a latency alone; the full
        # physics' 5.5 ms anti-aliasing delay and helmet lever arm shift the estimate (bench_skijump_independent)
        sim = simulate_skijump(hill, SkiJumpConfig(seed=11, gnss_latency=lat, physics="paper"))
        tt = sim.truth_meta["skijump"]["times"]
        kw = {"takeoff": [tt["takeoff"]], "touchdown": [tt["touchdown"]]}
        for name, cfg in (("on", SmootherConfig()), ("off", SmootherConfig(estimate_latency=False))):
            est, meta, _ = rts_smooth_table(sim.session, sim.session_meta, hill, cfg, **kw)
            e = errors(est, sim.truth, sim.session_meta["frame"]["azimuth_deg"])[2]
            res[lat, name] = (
                np.sqrt(np.nanmean(e["x"] ** 2 + e["y"] ** 2 + e["z"] ** 2)),
                meta["rts"]["gnss_latency_s"][0],
            )
    assert abs(res[0.12, "on"][1] - 0.12) < 0.01
    assert res[0.0, "on"][1] is None or abs(res[0.0, "on"][1]) < 0.02  # below the threshold: nothing moved
    assert res[0.12, "on"][0] < 0.2 < res[0.12, "off"][0]  # metres of along-track error without the estimate
    assert res[0.0, "on"][0] < 1.1 * res[0.0, "off"][0] + 1e-3  # no latency: as before


def test_simulated_wind_changes_the_flight_not_the_planned_length():
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

    hill = load_hill(HILL)
    # the paper mode: the motion without the full physics' flutter and chatter, which would hide the gusts' share
    calm = simulate_skijump(hill, SkiJumpConfig(seed=5, physics="paper"))
    windy = simulate_skijump(hill, SkiJumpConfig(seed=5, wind=(3.0, 1.5), physics="paper"))
    # the planner finds the lift for the seed's distance with the wind included
    assert abs(windy.truth_meta["jump_length"] - calm.truth_meta["jump_length"]) < 0.3
    assert windy.truth_meta["skijump"]["motion"]["cla_flight"] != calm.truth_meta["skijump"]["motion"]["cla_flight"]

    # the headwind's gusts show in the flight's specific force (the IMU measures them)
    def flight_wiggle(sim):  # |a| in mid-flight about its cubic trend [m/s^2]: the gusts' share
        tt = sim.truth_meta["skijump"]["times"]
        t = floats(sim.truth, "t")
        fl = (t > tt["takeoff"] + 0.8) & (t < tt["touchdown"] - 0.3)
        a = np.linalg.norm(np.column_stack([floats(sim.truth, f"true_a{c}") for c in "xyz"])[fl], axis=1)
        return float(np.std(a - np.polyval(np.polyfit(t[fl], a, 3), t[fl])))

    assert flight_wiggle(windy) > 3 * flight_wiggle(calm)


def test_after_rest_carries_the_attitude_forward_by_the_gyro():
    """_after_rest moves the step-0 state to step r: the attitude turned by the bias-corrected gyro (scipy
    composes the same piecewise-constant rotations), everything else as it is."""
    from types import SimpleNamespace

    from sportfusion.core.rotations import dcm_from_quat
    from sportfusion.skijump.smoother_start import _after_rest

    rng = np.random.default_rng(5)
    t = np.arange(300) * 0.01
    bias = np.array([0.01, -0.02, 0.005])
    gyr = bias + np.column_stack([0.3 * np.sin(2 * t), 0.2 + 0 * t, -0.1 * np.cos(t)])
    x0 = rng.normal(size=22)
    q0 = rng.normal(size=4)
    x0[6:10] = q0 / np.linalg.norm(q0)
    x0[10:13] = bias
    seg = SimpleNamespace(t=t, u=np.column_stack([gyr, np.zeros((t.size, 3))]))
    r = 200
    x = _after_rest(seg, x0, r)
    turn = Rotation.identity()  # body r -> body 0
    for k in range(r):
        turn = turn * Rotation.from_rotvec((gyr[k] - bias) * (t[k + 1] - t[k]))
    want = turn.as_matrix().T @ dcm_from_quat(x0[6:10])  # NED -> body at r
    np.testing.assert_allclose(dcm_from_quat(x[6:10]), want, atol=1e-10)
    assert x[6] >= 0.0
    np.testing.assert_array_equal(np.delete(x, range(6, 10)), np.delete(x0, range(6, 10)))
    # no rotation over the rest: the attitude is the step-0 one (up to sign)
    seg.u[:, 0:3] = bias
    q = _after_rest(seg, x0, r)[6:10]
    assert np.degrees(quat_angle(q, x0[6:10])) < 1e-6


def test_forward_start_runs_from_the_rests_end(jump, monkeypatch):
    """With start_after_rest (the default) the forward run over the start window begins where the rest at the
    gate ends; without it at the segment's first step.  Both then smooth the whole segment from step 0."""
    from sportfusion.skijump import smoother_engine as E
    from sportfusion.skijump.smoother_passes import smooth_inputs

    inp, cfg, _ = jump
    firsts = []
    orig = E.run

    def spy(seg, cfg_, x0, P0, use_c, smooth=True, *a, **k):
        firsts.append((float(seg.t[0]), int(seg.t.size), bool(smooth)))
        return orig(seg, cfg_, x0, P0, use_c, smooth, *a, **k)

    monkeypatch.setattr(E, "run", spy)
    if not E.compiled():
        pytest.skip("the C loop is not built: the numpy path runs the same windows, slowly")
    rest_end = int(_initial_rest(inp, cfg).sum()) - 1
    assert rest_end > 0
    for after, start in ((True, inp.t[rest_end]), (False, inp.t[0])):
        firsts.clear()
        smooth_inputs(inp, SmootherConfig(start_after_rest=after), keep_cov=False)
        forward = [f for f in firsts if not f[2]]
        assert len(forward) == 1 and forward[0][0] == start
        assert any(f[2] and f[0] == inp.t[0] and f[1] == inp.t.size for f in firsts)


def test_gnss_latency_with_its_standard_error_and_too_few_fixes():
    """with_std: (tau, std) -- a delayed velocity step found within its standard error; too few fixes: (None, inf)."""
    from sportfusion.skijump.alignment import gnss_latency

    t = np.arange(0.0, 12.0, 0.01)
    n = t.size
    x = np.zeros((n, 22))
    x[:, 6] = 1.0  # level body, north-aligned: the accelerometer reads a - g
    acc_n = 3.0 * np.tanh((t - 6.0) / 0.3)  # a smooth surge along north [m/s^2]
    u = np.zeros((n, 6))
    u[:, 3] = acc_n
    u[:, 5] = -9.81
    v = np.concatenate([[0.0], np.cumsum(0.5 * (acc_n[1:] + acc_n[:-1]) * np.diff(t))])
    vel = np.full((n, 3), np.nan)
    g = np.arange(0, n, 10)
    lag = 0.05
    vel[g, 0] = np.interp(t[g] - lag, t, v) + np.random.default_rng(1).normal(0.0, 0.02, g.size)
    vel[g, 1:] = 0.0
    tau, std = gnss_latency(t, u, x, vel, 9.81, (2.0, 10.0), with_std=True)
    assert abs(tau - lag) < max(3 * std, 0.002) and 0 < std < 0.01
    assert gnss_latency(t, u, x, vel, 9.81, (2.0, 2.5), with_std=True) == (None, float("inf"))
