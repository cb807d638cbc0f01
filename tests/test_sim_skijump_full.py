"""simulate skijump's full physics (issue 39): one consistent motion, sensed as the hardware does.

Checked against the truth tables with independent arithmetic (trapezoids, core.rotations, interpolation),
never with the smoother's kinematics.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sportfusion.core import rotations, schema
from sportfusion.core.frames import Frame
from sportfusion.skijump.hillfile import load_hill
from sportfusion.skijump.sim.sensors import VARIANTS, Realism
from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

QUIET = {  # every sensor and GNSS error off (the sampling, the filter and the motion stay)
    "gm_h": (1e-12, 60.0),
    "gm_v": (1e-12, 60.0),
    "white_h": 0.0,
    "white_v": 0.0,
    "multipath_rate": 0.0,
    "outlier_prob": 0.0,
    "vel_white": (0.0, 0.0, 0.0),
    "vel_multipath": 0.0,
}


@pytest.fixture(scope="module")
def hill():
    return load_hill("oberstdorf_hs106")


@pytest.fixture(scope="module")
def full(hill):
    return simulate_skijump(hill, SkiJumpConfig(seed=1))


@pytest.fixture(scope="module")
def calm(hill):
    """No chatter, no angular ringing, no sensor or GNSS errors (the body's response to the landing, the filter
    and the sampling stay): 100 Hz samples of 10-80 Hz vibration cannot be integrated back to the motion."""
    r = replace(Realism(), **QUIET, chatter_inrun=0.0, chatter_outrun=0.0, flutter=0.0, chatter_gyr=0.0)
    r = replace(r, ringing_gyr=0.0)
    return simulate_skijump(hill, SkiJumpConfig(seed=2, noise=False, realism=r)), r


def cols(table, *names):
    return np.stack([schema.floats(table, n) for n in names], axis=-1)


def test_rows_are_the_imus_and_the_receivers_instants(full):
    s = full.session
    t = schema.floats(s, "t")
    imu = np.isfinite(schema.floats(s, "acc_x"))
    gnss = np.isfinite(schema.floats(s, "lat"))
    phase = full.truth_meta["skijump"]["imu_phase_s"]
    assert 0.0 < phase < 0.01
    assert np.allclose(np.diff(t[imu]), 0.01) and t[imu][0] == pytest.approx(phase)
    assert np.allclose(t[gnss] / 0.1, np.round(t[gnss] / 0.1))  # whole tenths of GNSS time
    assert not np.any(imu & gnss)  # the two clocks never share an instant
    assert np.array_equal(schema.floats(full.truth, "t"), t)


def test_the_truth_is_one_motion(calm):
    full = calm[0]
    tr = full.truth
    t = schema.floats(tr, "t")
    r, v, a = (
        cols(tr, "true_x", "true_y", "true_z"),
        cols(tr, "true_vx", "true_vy", "true_vz"),
        cols(tr, "true_ax", "true_ay", "true_az"),
    )
    dt = np.diff(t)[:, None]
    # trapezoids of the sampled truth (chatter of 15-80 Hz is under-sampled: centimetres per second at most)
    v_int = v[0] + np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (a[1:] + a[:-1]) * dt, axis=0)])
    r_int = r[0] + np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (v[1:] + v[:-1]) * dt, axis=0)])
    assert np.abs(v_int - v).max() < 0.02
    assert np.abs(r_int - r).max() < 0.05
    # the specific force is the acceleration minus gravity, turned into the body frame by the attitude
    q = cols(tr, "true_q0", "true_q1", "true_q2", "true_q3")
    az = full.truth_meta["frame"]["azimuth_deg"]
    g = full.truth_meta["skijump"]["gravity"]
    f_b = rotations.to_body(q, rotations.local_to_ned(a - [0.0, 0.0, g], az))
    assert np.abs(f_b - cols(tr, "true_acc_x", "true_acc_y", "true_acc_z")).max() < 1e-9
    # the body rate carries the attitude (RK4 on q' = q (x) (0, w) / 2, w linear between the samples)
    w = cols(tr, "true_gyr_x", "true_gyr_y", "true_gyr_z")
    qi = np.empty_like(q)
    qi[0] = q[0]

    def qdot(qk, wk):
        return 0.5 * rotations.quat_multiply(qk, np.concatenate(([0.0], wk)))

    for k in range(t.size - 1):
        h, w0, w1 = t[k + 1] - t[k], w[k], w[k + 1]
        k1 = qdot(qi[k], w0)
        k2 = qdot(qi[k] + 0.5 * h * k1, 0.5 * (w0 + w1))
        k3 = qdot(qi[k] + 0.5 * h * k2, 0.5 * (w0 + w1))
        k4 = qdot(qi[k] + h * k3, w1)
        qi[k + 1] = rotations.quat_normalize(qi[k] + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))
    assert np.degrees(rotations.quat_angle(qi, q)).max() < 0.05


def test_quiet_sensors_are_the_filtered_truth(hill, calm):
    filt, r = calm
    point = simulate_skijump(hill, SkiJumpConfig(seed=2, noise=False, realism=replace(r, antialias="point")))
    s, tr = point.session, point.truth
    imu = np.isfinite(schema.floats(s, "acc_x"))
    # no errors, no filter: the samples are the truth at the IMU's instants (to the 16-bit quantisation)
    for name in ("acc", "gyr"):
        d = cols(s, *(f"{name}_{c}" for c in "xyz"))[imu] - cols(tr, *(f"true_{name}_{c}" for c in "xyz"))[imu]
        assert np.abs(d).max() < 1e-12
    # the 41 Hz anti-aliasing filter: the same samples 5.5 ms late (the take-off push and the landing)
    t = schema.floats(s, "t")[imu]
    acc_f = cols(filt.session, "acc_x", "acc_y", "acc_z")[imu]
    acc_p = cols(s, "acc_x", "acc_y", "acc_z")[imu]
    fine = np.arange(t[0], t[-1], 0.0005)
    lags = np.arange(0.0, 0.0121, 0.0005)
    cost = [
        np.sum(
            (
                np.stack([np.interp(fine - lag, t, acc_p[:, j]) for j in range(3)], -1)
                - np.stack([np.interp(fine, t, acc_f[:, j]) for j in range(3)], -1)
            )
            ** 2
        )
        for lag in lags
    ]
    assert 0.004 <= lags[int(np.argmin(cost))] <= 0.007


def test_gnss_fixes_the_helmet_antenna_late(hill):
    sim = simulate_skijump(hill, SkiJumpConfig(seed=3, noise=False, realism=replace(Realism(), **QUIET)))
    s, tr = sim.session, sim.truth
    frame = Frame.from_meta(sim.session_meta["frame"])
    g = np.isfinite(schema.floats(s, "lat"))
    t = schema.floats(s, "t")
    fix = np.stack(frame.from_geodetic(*(schema.floats(s, c)[g] for c in ("lat", "lon", "h"))), -1)
    lat = sim.truth_meta["skijump"]["gnss_latency_s"]
    assert lat == pytest.approx(0.08)
    ant = cols(tr, "true_gnss_x", "true_gnss_y", "true_gnss_z")
    expect = np.stack([np.interp(t[g] - lat, t, ant[:, j]) for j in range(3)], -1)
    assert np.abs(fix - expect).max() < 5e-3  # interpolation between rows 1-9 ms apart
    # the antenna is 0.54 m from the arm's IMU, and its offset turns with the jumper, not with the arm
    imu = cols(tr, "true_x", "true_y", "true_z")
    arm = np.linalg.norm(ant - imu, axis=1)
    assert np.abs(arm - np.linalg.norm(Realism().antenna)).max() < 0.07  # the head's own 3 cm motion
    q = cols(tr, "true_q0", "true_q1", "true_q2", "true_q3")
    body = rotations.to_body(q, rotations.local_to_ned(ant - imu, frame.azimuth_deg))
    assert np.ptp(body, axis=0).max() > 0.15  # in the phone's frame the lever arm moves by decimetres


def test_gnss_errors_are_slow_and_heavy_tailed(full):
    s, tr = full.session, full.truth
    frame = Frame.from_meta(full.session_meta["frame"])
    g = np.isfinite(schema.floats(s, "lat"))
    t = schema.floats(s, "t")
    fix = np.stack(frame.from_geodetic(*(schema.floats(s, c)[g] for c in ("lat", "lon", "h"))), -1)
    ant = cols(tr, "true_gnss_x", "true_gnss_y", "true_gnss_z")
    lat = full.truth_meta["skijump"]["gnss_latency_s"]
    e = fix - np.stack([np.interp(t[g] - lat, t, ant[:, j]) for j in range(3)], -1)
    step = np.diff(e, axis=0)
    # mostly slow: the fix-to-fix change (sqrt 2 x the white part) is far smaller than the error itself (for
    # white noise the two would be equal); summed over the axes, so that one small drift draw cannot hide it
    assert np.median(np.abs(e), axis=0).sum() > 2.0 * (np.median(np.abs(step), axis=0) / math.sqrt(2)).sum()
    n_wild = full.truth_meta["skijump"]["gnss_outliers"]
    big = np.linalg.norm(e, axis=1) > 7.0
    assert big.sum() >= n_wild  # the wild fixes are there (plus multipath on top of drift now and then)


def test_the_take_off_table_disturbs_the_magnetometer(full, hill):
    tr = full.truth
    q = cols(tr, "true_q0", "true_q1", "true_q2", "true_q3")
    sj = full.truth_meta["skijump"]
    earth = np.asarray(sj["mag_field_ned"]) + np.asarray(sj["mag_anomaly_ned"])
    stray = np.linalg.norm(cols(tr, "true_mag_x", "true_mag_y", "true_mag_z") - rotations.to_body(q, earth), axis=1)
    x = schema.floats(tr, "true_x")
    t = schema.floats(tr, "t")
    inrun = t < sj["times"]["takeoff"]
    assert stray[inrun & (x > -10.0)].max() > 5.0  # tens of uT over the steel
    assert stray[inrun & (x < -40.0)].max() < 0.5
    assert stray[t > sj["times"]["touchdown"] + 1.0].max() < 1.0


@pytest.mark.slow
def test_variants_change_one_effect_only(hill, full):
    from sportfusion.skijump.sim import VARIANT_NAMES

    assert tuple(VARIANTS) == VARIANT_NAMES  # the command's help lists them all
    mp = simulate_skijump(hill, SkiJumpConfig(seed=1, variants=("multipath",)))
    sc = simulate_skijump(hill, SkiJumpConfig(seed=1, variants=("scale",)))
    for other in (mp, sc):
        assert other.truth.column("true_x").equals(full.truth.column("true_x"))  # the same jump
    imu = ("acc_x", "gyr_y", "mag_z")
    gnss = ("lat", "h", "vel_n")
    assert all(mp.session.column(c).equals(full.session.column(c)) for c in imu)
    assert not all(mp.session.column(c).equals(full.session.column(c)) for c in gnss)
    assert all(sc.session.column(c).equals(full.session.column(c)) for c in gnss)
    assert not sc.session.column("acc_x").equals(full.session.column("acc_x"))
    assert sc.truth_meta["skijump"]["realism"]["acc_scale"] == 0.02
    with pytest.raises(Exception, match="unknown variant"):
        simulate_skijump(hill, SkiJumpConfig(seed=1, variants=("gremlins",)))


def test_same_seed_same_tables(hill, full):
    again = simulate_skijump(hill, SkiJumpConfig(seed=1))
    assert again.session.equals(full.session) and again.truth.equals(full.truth)
    assert math.isfinite(full.truth_meta["jump_length"]) and 70.0 < full.truth_meta["jump_length"] < 110.0


@pytest.mark.parametrize("name", ["oberstdorf_hs106", "harrachov_hs210", "breitenberg_hs78"])
def test_the_simulators_hill_from_venue_data_matches_the_certificate_construction(name: str) -> None:
    """The simulator builds its profile from the hill's points (sim/venue.py), apart from hill.py's circles
    and curves: both agree within 1e-8 m in height and jump length, straight beyond the ends."""
    from sportfusion.skijump.hillfile import load_hill
    from sportfusion.skijump.sim.venue import as_sim_hill

    hill = load_hill(name)
    if not hill.has_origin:
        hill = load_hill(name, {"lat": "47.4", "lon": "11.2", "height": "900", "azimuth_deg": "0"})
    sim, prof = as_sim_hill(hill), hill.profile
    xi = np.linspace(prof.points["A"][0] - 5.0, 5.0, 4001)
    xl = np.linspace(-5.0, prof.points["V"][0] + 20.0, 8001)
    np.testing.assert_allclose(sim.z_inrun(xi), prof.z_inrun(xi, extend=True), rtol=0, atol=1e-8)
    np.testing.assert_allclose(sim.z_landing(xl), prof.z_landing(xl, extend=True), rtol=0, atol=1e-8)
    for x in (5.0, prof.points["K"][0], prof.points["L"][0], prof.points["V"][0] + 10.0):
        assert sim.jump_length(x) == pytest.approx(float(prof.jump_length(x, extend=True)), abs=1e-8)
