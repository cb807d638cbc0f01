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
from sportfusion.gates.sim import FINE_DT, VARIANTS, GatesConfig, body_rates, simulate_gates


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
    assert d.min() >= 0.15 and d.max() <= 1.6 and np.median(d) < 0.9  # the unit passes 0.2-1.5 m from the magnets
    f = sim.fine
    on_course = (f["t"] > sim.crossings["t"][0]) & (f["t"] < sim.crossings["t"][-1])
    speed = np.linalg.norm(f["vel"][on_course], axis=1)
    assert 14.0 < speed.min() and speed.max() < 26.5  # 15-25 m/s of the snow point; the body moves about it
    # turn sides alternate and the gate is on the inside of the turn (R turn <=> the magnet is to the right),
    # checked where the unit passes clearly beside it
    turns = sim.crossings["turn"]
    assert all(a != b for a, b in zip(turns[:-1], turns[1:], strict=False))
    beside = 0
    for j, k in enumerate(sim.crossings["k"]):
        v = f["vel"][k]
        rel = sim.magnet_centres[j] - f["pos"][k]
        lateral = (v[0] * rel[1] - v[1] * rel[0]) / np.hypot(v[0], v[1])
        if abs(lateral) > 0.15:
            beside += 1
            assert (lateral > 0) == (turns[j] == "R")
    assert beside >= 10


def test_truth_is_kinematically_consistent(sim):
    f = sim.fine
    dpos = np.diff(f["pos"], axis=0) / FINE_DT
    vmid = (f["vel"][1:] + f["vel"][:-1]) / 2
    assert np.median(np.abs(dpos - vmid)) < 1e-3
    assert np.abs(f["acc"]).max() < 60  # no spikes (GS: up to 3-4 g at the unit)
    # standing: the body sways (a centimetre), it does not travel
    k4 = int(4.0 / FINE_DT)
    assert np.ptp(f["pos"][:k4], axis=0).max() < 0.05 and np.linalg.norm(f["vel"][:k4], axis=1).max() < 0.1
    assert np.ptp(f["pos"][-k4:], axis=0).max() < 0.05 and np.linalg.norm(f["vel"][-k4:], axis=1).max() < 0.1


def test_truth_attitude_is_smooth(sim):
    # bounded angular rate and acceleration: no kink in the body's attitude (the unit's gyro would see it)
    w = body_rates(sim.fine["q"], FINE_DT)
    alpha = np.gradient(w, FINE_DT, axis=0)
    assert np.abs(w).max() < 8.0  # rad/s
    assert np.abs(alpha).max() < 150.0  # rad/s^2 (a hockey stop's turn: about 25)


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
    # standing: only the chip's errors (bias, scale and misalignment on gravity: a few 0.01 m/s^2)
    still = floats(s, "t")[imu] < 4.0
    assert np.abs(err[still].mean(axis=0)).max() < 0.15 and err[still].std(axis=0).max() < 0.1
    # skiing: the chatter (1.5 m/s^2 RMS at 20 m/s, 8-60 Hz) averages out; what is left is bias and scale
    assert np.abs(err.mean(axis=0)).max() < 0.25
    assert 0.5 < err.std(axis=0).mean() < 3.0
    # gyro: the static start measures the bias (a few 0.01 rad/s) and the sway (a few 0.01 rad/s)
    gyr = col(s, "gyr_x", "gyr_y", "gyr_z")[imu]
    assert np.abs(gyr[still].mean(axis=0)).max() < 0.06
    # magnetometer at 125 Hz, quantised to 0.1 uT; far from the magnets it measures the Earth field
    # (plus a few uT of the start hut, the anomaly and the athlete's equipment)
    mag_rows = np.isfinite(floats(s, "mag_x"))
    assert np.isclose(np.median(np.diff(floats(s, "t")[mag_rows])), 1 / 125)
    mb = col(s, "mag_x", "mag_y", "mag_z")[mag_rows][:200]
    assert np.allclose(mb / 0.1, np.round(mb / 0.1), atol=1e-6)
    earth = reference_field(cfg.site[0], cfg.site[1], cfg.site[2], cfg.date)
    qb = col(tr, "true_q0", "true_q1", "true_q2", "true_q3")[mag_rows][:200]
    assert np.abs(mb - to_body(qb, earth)).mean() < 4.0


def test_magnet_peaks_follow_the_cube_law(sim):
    # the stack's field is not a dipole's, but its peaks still fall with about the cube of the distance:
    # the estimator's cube law (calibrated on dipole passes) is within 0.1 m for passes under 0.7 m
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


def test_magnet_field_is_the_scene_s(sim):
    # the magnetometer, with the unit's errors and the equipment taken out roughly, sees the scene's field:
    # at each close pass its peak excess matches the scene's excess at the true position within 10 %
    s = sim.session
    mag_rows = np.isfinite(floats(s, "mag_x"))
    tm = floats(s, "t")[mag_rows]
    mb = np.linalg.norm(col(s, "mag_x", "mag_y", "mag_z")[mag_rows], axis=1)
    be = np.linalg.norm(sim.scene.earth_ned)
    ratio = []
    for tc, k, d in zip(sim.crossings["t"], sim.crossings["k"], sim.crossings["distance"], strict=True):
        if d > 0.6:
            continue
        w = np.abs(tm - tc) < 0.03
        model = np.linalg.norm(sim.scene.field_ned(sim.fine["pos"][k][None])[0])
        ratio.append((mb[w].max() - be) / (model - be))
    assert len(ratio) >= 8 and abs(np.median(ratio) - 1.0) < 0.1


def test_survey_local_and_wgs84(sim):
    srv = sim.survey
    xyz = col(srv, "x", "y", "z")
    e = xyz - sim.magnets
    assert np.abs(e[:, :2]).max() < 0.1 and np.abs(e[:, 2]).max() < 0.15 and np.abs(e).max() > 0
    # the survey is the snow above each magnet: the stick's centre lies 0.09-0.14 m under it
    depth = sim.magnet_centres[:, 2] - sim.magnets[:, 2]
    assert 0.08 < depth.min() and depth.max() < 0.15
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


def test_variants_change_what_they_say():
    assert set(VARIANTS) >= {"nominal", "stray-iron", "tilted", "weak", "flipped", "wide", "still", "sensor"}
    assert GatesConfig(variant="flipped").magnets.polarity == "up"
    assert GatesConfig(variant="weak").magnets.moment < 0.5 * GatesConfig().magnets.moment
    assert GatesConfig(variant="still").static == 30.0
    assert GatesConfig(variant="stray-iron").stray.pylons == 3
    assert GatesConfig(variant="wide", wide_fraction=0.5).wide_fraction == 0.5  # an explicit field wins
    with pytest.raises(ValueError, match="unknown variant"):
        GatesConfig(variant="nope")
    # a short course per variant that changes the magnetic scene: the passes still see the magnets
    for v, check in (
        ("flipped", lambda m: m[2] < 0),  # moment up (z down): the field above it points up
        ("tilted", lambda m: True),
    ):
        sim = simulate_gates(GatesConfig(seed=4, variant=v, n_gates=4, static=2.0))
        mom = sim.scene.magnets[0].moment
        assert check(mom) and 25 < np.linalg.norm(mom) < 40  # the paper's stack: about 32 A m^2


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
