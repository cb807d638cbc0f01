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
