"""The ski-race simulator: truth self-consistency, sensor errors as configured, determinism, CLI."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.core import io as sfio
from sportfusion.core.gravity import normal_gravity
from sportfusion.core.magfield import reference_field
from sportfusion.core.rotations import local_to_ned, to_body
from sportfusion.core.schema import floats
from sportfusion.skirace.sim import FINE_DT, SkiRaceConfig, simulate_skirace


@pytest.fixture(scope="module")
def sim():
    return simulate_skirace(SkiRaceConfig(seed=1))


def col(table, *names):
    return np.column_stack([floats(table, n) for n in names])


def test_truth_is_kinematically_consistent(sim):
    f = sim.fine
    # velocity integrates to position, acceleration is the derivative of velocity
    dpos = np.diff(f["pos"], axis=0) / FINE_DT
    vmid = (f["vel"][1:] + f["vel"][:-1]) / 2
    assert np.max(np.abs(dpos - vmid)) < 1e-9
    dv = np.diff(f["vel"], axis=0) / FINE_DT
    amid = (f["acc"][1:] + f["acc"][:-1]) / 2
    assert np.median(np.abs(dv - amid)) < 1e-3
    # in flight the body falls freely (1 ms edges aside)
    fl = f["flight"]
    assert fl.sum() > 1000
    assert np.median(np.abs(f["acc"][fl][:, 2] - normal_gravity(46.4975, 2200.0))) < 1e-6
    # racing speeds, turns with lateral acceleration, and the skier ends far down the slope
    speed = np.linalg.norm(f["vel"], axis=1)
    assert 20 < speed.max() < 40
    assert f["pos"][-1, 0] > 800 and f["pos"][-1, 2] > 200


def test_gnss_errors_as_configured(sim):
    s, tr = sim.session, sim.truth
    pos = col(s, "gnss_x", "gnss_y", "gnss_z")
    has = np.isfinite(pos[:, 0])
    err = pos[has] - col(tr, "true_x", "true_y", "true_z")[has]
    fix = floats(s, "gnss_fix")[has]
    fixed = fix == 4
    std_fixed = err[fixed].std(axis=0)
    np.testing.assert_allclose(std_fixed, [0.01, 0.01, 0.02], rtol=0.2)
    assert (fix == 5).sum() > 20
    assert np.sqrt(np.mean(err[~fixed] ** 2)) > 5 * np.sqrt(np.mean(err[fixed] ** 2))  # float offsets
    t = floats(s, "t")[has]
    assert abs(np.median(np.diff(t)) - 0.1) < 1e-9
    assert np.diff(t).max() > 0.5  # losses of lock
    # reported sigmas: optimistic for float, as configured
    assert set(np.unique(floats(s, "gnss_sigma_h")[has])) == {0.015, 0.15}


def test_geodetic_columns_match_local_ones(sim):
    pymap3d = pytest.importorskip("pymap3d")
    s = sim.session
    lat, lon, h = (floats(s, c) for c in ("lat", "lon", "h"))
    ok = np.isfinite(lat)
    n, e, d = pymap3d.geodetic2ned(lat[ok], lon[ok], h[ok], 46.4975, 9.8365, 2200.0)
    local = col(s, "gnss_x", "gnss_y", "gnss_z")[ok]
    np.testing.assert_allclose(np.column_stack((n, e, d)), local_to_ned(local, 160.0), atol=1e-6)


def test_dmc_signals(sim):
    s, tr = sim.session, sim.truth
    acc = col(s, "acc_x", "acc_y", "acc_z")
    rows = np.isfinite(acc[:, 0])
    acc = acc[rows]
    t = floats(s, "t")[rows]
    assert abs(np.median(np.diff(t)) - 0.02) < 1e-9
    q = col(tr, "true_q0", "true_q1", "true_q2", "true_q3")[rows]
    mag = col(s, "mag_x", "mag_y", "mag_z")[rows]
    m_ref = reference_field(46.4975, 9.8365, 2200.0, "2026-02-10T10:00:00Z")
    m_true = to_body(q, np.broadcast_to(m_ref, mag.shape))
    assert np.median(np.linalg.norm(mag - m_true, axis=1)) < 1.0  # uT: bias + scale + noise
    g = normal_gravity(46.4975, 2200.0)
    a_ned = local_to_ned(col(tr, "true_ax", "true_ay", "true_az")[rows], 160.0)
    f_true = to_body(q, a_ned - [0.0, 0.0, g])
    err = np.linalg.norm(acc - f_true, axis=1)
    static = t < 5.0
    assert np.median(err[static]) < 0.2  # bias + noise
    assert 0.3 < np.median(err[~static]) < 1.5  # plus ski vibration
    # roll leans into the turns
    lat_acc = (a_ned[:, 0] * -np.sin(np.radians(160)) + a_ned[:, 1] * np.cos(np.radians(160)))[~static]
    assert np.corrcoef(floats(tr, "true_roll")[rows][~static], lat_acc)[0, 1] > 0.8


def test_gyro_integrates_to_the_truth_attitude():
    """Integrating the error-free gyro (Earth rate removed) reproduces the truth attitude at the IMU rows."""
    from sportfusion.core.rotations import dcm_from_quat, integrate_body_rates, quat_angle
    from sportfusion.skirace.attitude import OMEGA_EARTH

    errors = {"gyr_bias": 0.0, "gyr_bias_walk": 0.0, "gyr_scale": 0.0, "gyr_noise": 0.0, "gyr_vibration": 0.0}
    cfg = SkiRaceConfig(seed=3, duration=20.0, **errors)
    s = simulate_skirace(cfg)
    rows = np.isfinite(floats(s.session, "gyr_x"))
    t = floats(s.session, "t")[rows]
    gyr = col(s.session, "gyr_x", "gyr_y", "gyr_z")[rows]
    q_true = col(s.truth, "true_q0", "true_q1", "true_q2", "true_q3")[rows]
    phi = np.radians(cfg.site[0])
    w_ie = OMEGA_EARTH * np.array([np.cos(phi), 0.0, -np.sin(phi)])
    earth = np.einsum("nij,j->ni", dcm_from_quat(q_true), w_ie)  # what the gyro adds (at the sample, ~1e-9 off)
    q = integrate_body_rates(q_true[0], t, gyr - earth)
    assert np.degrees(quat_angle(q, q_true).max()) < 1e-5
    # the landing impacts and the start make the largest rates: well inside the range, never clipped
    assert np.abs(gyr).max() < cfg.gyr_range
    # left in, the Earth rate (7.3e-5 rad/s) turns the attitude by its rate times the duration
    drift = np.degrees(quat_angle(integrate_body_rates(q_true[0], t, gyr), q_true)[-1])
    assert 0.02 < drift < np.degrees(OMEGA_EARTH * t[-1]) * 1.01


def test_gyro_errors_as_configured_and_other_sensors_unchanged(sim):
    from sportfusion.core.rotations import body_rates

    s = sim.session
    rows = np.isfinite(floats(s, "gyr_x"))
    t = floats(s, "t")[rows]
    gyr = col(s, "gyr_x", "gyr_y", "gyr_z")[rows]
    w_true = body_rates(t, col(sim.truth, "true_q0", "true_q1", "true_q2", "true_q3")[rows])
    err = gyr - w_true
    static = t < 5.0
    assert abs(np.median(np.diff(t)) - 0.02) < 1e-9  # the IMU rate, same rows as the accelerometer
    assert np.array_equal(rows, np.isfinite(floats(s, "acc_x")))
    # standing: a constant-ish bias (1-sigma 0.01 rad/s per axis) plus 0.002 rad/s white noise
    bias0 = err[static].mean(axis=0)
    assert 1e-4 < np.abs(bias0).max() < 0.04
    np.testing.assert_allclose(err[static].std(axis=0), 0.002, rtol=0.25)
    # skiing: vibration 0.01 rad/s per sample on top; the bias walks slowly (2e-4 rad/s/sqrt(s))
    run = t > 10.0
    np.testing.assert_allclose(np.std(np.diff(err[run], axis=0), axis=0) / np.sqrt(2), 0.0102, rtol=0.15)
    assert np.abs(err[run].mean(axis=0) - bias0).max() < 0.01
    # the gyro has its own random stream: the other sensors and the truth are those of a run without it
    no = simulate_skirace(SkiRaceConfig(seed=1, gyro=False))
    assert "gyr_x" not in no.session.column_names
    assert s.drop_columns(["gyr_x", "gyr_y", "gyr_z"]).equals(no.session) and sim.truth.equals(no.truth)


def test_deterministic():
    a = simulate_skirace(SkiRaceConfig(seed=4, duration=15.0, float_episodes=1, lock_losses=1, jumps=1))
    b = simulate_skirace(SkiRaceConfig(seed=4, duration=15.0, float_episodes=1, lock_losses=1, jumps=1))
    c = simulate_skirace(SkiRaceConfig(seed=5, duration=15.0, float_episodes=1, lock_losses=1, jumps=1))
    assert a.session.equals(b.session) and a.truth.equals(b.truth)
    assert not a.session.equals(c.session)


def simulate(args: list[str]):
    """Run ``simulate`` in-process (the group's console script is registered separately)."""
    from click.testing import CliRunner

    from sportfusion.tools.simulate import main

    return CliRunner().invoke(main, args)


def test_cli_writes_session_and_truth(tmp_path):
    truth = tmp_path / "truth.parquet"
    res = simulate(
        ["skirace", "--seed", "2", "--duration", "12", "--truth", str(truth), "--imu-rate", "100", "--gnss-rate", "20"]
    )
    assert res.exit_code == 0, res.output
    table = sfio.table_from_bytes(res.stdout_bytes)
    meta = sfio.get_meta(table)
    assert meta["kind"] == "session" and meta["frame"]["azimuth_deg"] == 160.0
    assert meta["provenance"][-1]["tool"] == "simulate skirace"
    t_truth, m_truth = sfio.read_table(truth)
    assert m_truth["kind"] == "truth"
    np.testing.assert_array_equal(floats(t_truth, "t"), floats(table, "t"))
    gnss_t = floats(table, "t")[np.isfinite(floats(table, "gnss_x"))]
    assert abs(np.median(np.diff(gnss_t)) - 0.05) < 1e-9
    assert simulate(["skirace", "--gnss-rate", "50"]).exit_code == 2
    bad = simulate(["skirace", "--date", "not-a-date"])
    assert bad.exit_code == 1 and "Error: simulate skirace:" in bad.stderr
