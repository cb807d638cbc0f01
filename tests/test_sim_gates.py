"""The magnet-gate course simulator: course as specified, consistent truth and sensors, survey, determinism, CLI."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run_cli

from sportfusion.core import io as sfio
from sportfusion.core.frames import geodetic_to_local
from sportfusion.core.gravity import normal_gravity
from sportfusion.core.magfield import reference_field
from sportfusion.core.rotations import local_to_ned, quat_from_euler, to_body, to_ned
from sportfusion.core.schema import floats
from sportfusion.gates.magnet import default_calibration
from sportfusion.gates.sim import FINE_DT, GatesConfig, body_rates, simulate_gates


@pytest.fixture(scope="module")
def sim():
    return simulate_gates(GatesConfig(seed=3))


def col(table, *names):
    return np.column_stack([floats(table, n) for n in names])


def test_course_is_a_giant_slalom(sim):
    m = sim.magnets
    assert m.shape == (30, 3)
    spacing = np.linalg.norm(np.diff(m, axis=0), axis=1)
    assert spacing.min() > 21.5 and spacing.max() < 28.5  # 22-28 m, approximations aside
    assert 650 < m[-1, 0] - m[0, 0] + 55 < 800  # start 30 m before gate 1, finish 25 m after the last: ~700 m
    assert 120 < m[-1, 2] - m[0, 2] < 160  # drop over the gates (150 m start -> finish)
    d = sim.crossings["distance"]
    assert d.min() >= 0.15 and d.max() <= 1.45 and np.median(d) < 0.9  # the sacrum passes 0.2-1.2 m away
    f = sim.fine
    on_course = (f["t"] > sim.crossings["t"][0]) & (f["t"] < sim.crossings["t"][-1])
    speed = np.linalg.norm(f["vel"][on_course], axis=1)
    assert 14.5 < speed.min() and speed.max() < 25.5
    # turn sides alternate and the gate is on the inside of the turn (R turn <=> the magnet is to the right)
    turns = sim.crossings["turn"]
    assert all(a != b for a, b in zip(turns[:-1], turns[1:], strict=False))
    for j, k in enumerate(sim.crossings["k"]):
        v = f["vel"][k]
        rel = m[j] - f["pos"][k]
        right = v[0] * rel[1] - v[1] * rel[0] > 0
        assert right == (turns[j] == "R")


def test_truth_is_kinematically_consistent(sim):
    f = sim.fine
    dpos = np.diff(f["pos"], axis=0) / FINE_DT
    vmid = (f["vel"][1:] + f["vel"][:-1]) / 2
    assert np.median(np.abs(dpos - vmid)) < 1e-3
    assert np.abs(f["acc"]).max() < 60  # no spikes (GS: ~2-3 g)
    # static at start and finish
    assert np.linalg.norm(f["vel"][: int(4.0 / FINE_DT)], axis=1).max() < 1e-6
    assert np.linalg.norm(f["vel"][-int(4.0 / FINE_DT) :], axis=1).max() < 1e-6


def test_body_rates_of_a_known_rotation():
    t = np.arange(0, 2, 0.001)
    q = quat_from_euler(0.3 * t, 0.1 + 0 * t, 0.7 * t)  # roll and yaw rates, constant pitch
    w = body_rates(q, 0.001)
    # integrate back: Euler rates from body rates (z-y-x) -> the yaw rate is 0.7 rad/s
    phi, th = 0.3 * t, 0.1
    yaw_rate = (w[:, 1] * np.sin(phi) + w[:, 2] * np.cos(phi)) / np.cos(th)
    roll_rate = w[:, 0] + (w[:, 1] * np.sin(phi) + w[:, 2] * np.cos(phi)) * np.tan(th)
    assert np.allclose(yaw_rate[5:-5], 0.7, atol=1e-5)
    assert np.allclose(roll_rate[5:-5], 0.3, atol=1e-5)


def test_imu_measures_the_truth(sim):
    cfg = GatesConfig()
    s, tr = sim.session, sim.truth
    imu = np.isfinite(floats(s, "acc_x"))
    assert np.isclose(np.median(np.diff(floats(s, "t")[imu])), 1 / 500)
    acc = col(s, "acc_x", "acc_y", "acc_z")[imu]
    q = col(tr, "true_q0", "true_q1", "true_q2", "true_q3")[imu]
    a_true = col(tr, "true_ax", "true_ay", "true_az")[imu]
    g = normal_gravity(cfg.site[0], cfg.site[2])
    f_ned = to_ned(q, acc)
    a_est = f_ned + np.array([0, 0, g])
    err = local_to_ned(a_true, cfg.azimuth_deg) - a_est
    # sensor noise (vibration 0.8 m/s^2) averages out; the mean is the bias (0.03 m/s^2 1-sigma)
    assert np.abs(err.mean(axis=0)).max() < 0.15
    assert 0.5 < err.std(axis=0).mean() < 1.2
    # gyro: the static start measures only the bias
    gyr = col(s, "gyr_x", "gyr_y", "gyr_z")[imu]
    st = floats(s, "t")[imu] < 4.0
    assert np.abs(gyr[st].mean(axis=0)).max() < 0.05
    # magnetometer at 125 Hz; far from the magnets it measures the Earth field
    mag_rows = np.isfinite(floats(s, "mag_x"))
    assert np.isclose(np.median(np.diff(floats(s, "t")[mag_rows])), 1 / 125)
    earth = reference_field(cfg.site[0], cfg.site[1], cfg.site[2], cfg.date)
    mb = col(s, "mag_x", "mag_y", "mag_z")[mag_rows][:200]
    qb = col(tr, "true_q0", "true_q1", "true_q2", "true_q3")[mag_rows][:200]
    assert np.abs(mb - to_body(qb, earth)).mean() < 1.0


def test_magnet_peaks_follow_the_cube_law(sim):
    s = sim.session
    mag_rows = np.isfinite(floats(s, "mag_x"))
    tm = floats(s, "t")[mag_rows]
    b = np.linalg.norm(col(s, "mag_x", "mag_y", "mag_z")[mag_rows], axis=1)
    b = b / np.median(b)
    cal = default_calibration()
    err = []
    for tc, d in zip(sim.crossings["t"], sim.crossings["distance"], strict=True):
        w = np.abs(tm - tc) < 0.05
        if d < 0.7:
            err.append(cal.distance(b[w].max()) - d)
    err = np.array(err)
    assert err.size >= 10
    assert np.abs(np.median(err)) < 0.1 and np.percentile(np.abs(err), 90) < 0.3


def test_survey_local_and_wgs84(sim):
    srv = sim.survey
    xyz = col(srv, "x", "y", "z")
    e = xyz - sim.magnets
    assert np.abs(e[:, :2]).max() < 0.1 and np.abs(e[:, 2]).max() < 0.15 and np.abs(e).max() > 0
    assert sim.survey_meta["kind"] == "gates"
    w = simulate_gates(GatesConfig(seed=3), survey_wgs84=True)
    lat, lon, h = (floats(w.survey, c) for c in ("lat", "lon", "h"))
    fr = w.survey_meta["frame"]
    x, y, z = geodetic_to_local(lat, lon, h, tuple(fr["origin"]), fr["azimuth_deg"])
    assert np.abs(np.stack([x, y, z], -1) - xyz).max() < 1e-6  # same seed, same noise
    assert w.session.equals(sim.session)  # deterministic


def test_downhill_variant():
    d = simulate_gates(GatesConfig(seed=1, downhill=True))
    spacing = np.linalg.norm(np.diff(d.magnets, axis=0), axis=1)
    assert spacing.min() > 60 and d.magnets.shape[0] == 12


def test_cli_writes_session_truth_and_survey(tmp_path):
    r = run_cli(
        [
            "simulate",
            "gates",
            "--seed",
            "2",
            "--truth",
            str(tmp_path / "t.parquet"),
            "--gates",
            str(tmp_path / "g.parquet"),
        ],
        stdin=None,
    )
    assert r.returncode == 0, r.stderr
    t, _ = sfio.read_table(str(tmp_path / "t.parquet"), kind="truth")
    assert "true_gate" in t.column_names
    g, gm = sfio.read_table(str(tmp_path / "g.parquet"), kind="gates")
    assert g.num_rows == 30 and gm["frame"]["name"] == "course"
    (tmp_path / "s.parquet").write_bytes(r.stdout)
    s, sm = sfio.read_table(str(tmp_path / "s.parquet"), kind="session")
    assert {"acc_x", "gyr_z", "mag_x"} <= set(s.column_names)
