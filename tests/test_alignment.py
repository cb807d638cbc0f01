"""The sequence alignment of crossings to surveyed gates (sportfusion.gates.alignment): runs of missed gates,
noise peaks, a drifting inertial track, a wrong side; and the static gyro bias of a swaying body
(sportfusion.gates.inertial.static_gyro_bias)."""

from __future__ import annotations

import numpy as np

from sportfusion.gates.alignment import align_crossings
from sportfusion.gates.anchors import rotate_z, survey_sides


def _course(rng, n=30):
    sides = rng.choice([-1.0, 1.0]) * (-1.0) ** np.arange(n)
    y = sides * rng.uniform(1.5, 3.5, n)
    x = np.cumsum(np.r_[30.0, rng.uniform(21, 27, n - 1)])
    z = x * np.tan(np.deg2rad(12)) + rng.normal(0, 0.3, n)
    return np.stack([x, y, z], -1)


def test_alignment_with_runs_of_missed_gates_noise_and_drift():
    for seed in range(6):
        rng = np.random.default_rng(seed)
        survey = _course(rng)
        ssd = survey_sides(survey)
        keep = rng.random(30) > 0.3  # a third missed, runs of two and three among them
        keep[[5, 6, 7]] = False
        gates = np.flatnonzero(keep)
        t = 5.0 + 1.2 * gates + rng.normal(0, 0.02, gates.size)
        # the detections as an inertial track sees them: a slow drift (quadratic, metres by the end), a small
        # azimuth error, anchor noise, and a different origin
        drift = np.outer((t - t[0]) ** 2, [0.004, -0.003, 0.001])
        det = rotate_z(survey[gates] + drift + rng.normal(0, 0.1, (gates.size, 3)), np.deg2rad(0.7)) - [400, 9, 80]
        side = ssd[gates].copy()
        # two noise peaks between gates, one with the wrong side
        tn = np.array([t[3] + 0.5, t[-4] + 0.6])
        dn = det[[3, -4]] + [[8.0, 1.0, 0.5], [9.0, -2.0, 1.0]]
        tt = np.concatenate([t, tn])
        dd = np.vstack([det, dn])
        sd = np.concatenate([side, [1.0, -1.0]])
        ids = align_crossings(tt, dd, sd, survey, ssd)
        assert list(ids[: gates.size]) == list(gates), seed
        assert list(ids[gates.size :]) == [-1, -1]


def test_alignment_tells_neighbouring_gates_apart_by_their_displacements():
    rng = np.random.default_rng(9)
    survey = _course(rng, 12)
    ssd = survey_sides(survey)
    gates = np.array([2, 3, 4, 6, 7, 8])  # the first two and gate 5 missed: the first detection is gate 3
    t = 1.2 * gates
    det = survey[gates] + rng.normal(0, 0.1, (gates.size, 3)) + 100.0
    ids = align_crossings(t, det, ssd[gates], survey, ssd)
    assert list(ids) == list(gates)


def test_static_gyro_bias_of_a_swaying_body():
    from sportfusion.core.rotations import quat_from_euler, to_body
    from sportfusion.gates.inertial import static_gyro_bias
    from sportfusion.gates.sim import body_rates

    t = np.arange(0, 5, 0.002)
    naive, new = [], []
    rng = np.random.default_rng(0)
    for _ in range(12):
        # an inverted pendulum (sacrum 1 m above the feet) swaying +-1 cm at 0.15-0.6 Hz
        f1, f2 = rng.uniform(0.15, 0.6, 2)
        p1, p2 = rng.uniform(0, 2 * np.pi, 2)
        d = np.stack([0.01 * np.sin(2 * np.pi * f1 * t + p1), 0.01 * np.sin(2 * np.pi * f2 * t + p2)], -1)
        dd = -np.stack([(2 * np.pi * f1) ** 2 * d[:, 0], (2 * np.pi * f2) ** 2 * d[:, 1]], -1)
        q = quat_from_euler(d[:, 1], -d[:, 0], np.full(t.size, 0.3))
        f = to_body(q, np.column_stack([dd, np.zeros(t.size)]) - [0, 0, 9.81])
        bias = rng.normal(0, 0.01, 3)
        gyr = body_rates(q, 0.002) + bias + rng.normal(0, 0.005, (t.size, 3))
        acc = f + rng.normal(0, 0.05, f.shape) + rng.normal(0, 0.03, 3)
        naive.append(gyr.mean(axis=0) - bias)
        new.append(static_gyro_bias(t, acc, gyr) - bias)
    rms_naive = np.sqrt(np.mean(np.square(naive), axis=0))
    rms_new = np.sqrt(np.mean(np.square(new), axis=0))
    # across gravity (x, y here) the sway's net tilt biases the mean rate; the fit removes most of it
    assert np.all(rms_new[:2] < 0.5 * rms_naive[:2]) and rms_new[:2].max() < 1e-3
    assert abs(rms_new[2] - rms_naive[2]) < 1e-4  # about the vertical: the mean rate, unchanged


def test_alignment_finds_the_azimuth_within_thirty_degrees():
    from sportfusion.gates.alignment import align_with_azimuth

    rng = np.random.default_rng(4)
    survey = _course(rng, 20)
    ssd = survey_sides(survey)
    gates = np.flatnonzero(rng.random(20) > 0.2)
    t = 1.2 * gates
    det = rotate_z(survey[gates] + rng.normal(0, 0.1, (gates.size, 3)), np.deg2rad(-17.0)) + [50.0, -20.0, 3.0]
    ids, alpha, offset = align_with_azimuth(t, det, ssd[gates], survey, ssd, 0.0)
    assert list(ids) == list(gates)
    assert abs(np.rad2deg(alpha) - 17.0) < 0.5
    assert np.abs(rotate_z(det, alpha) + offset - survey[gates]).max() < 0.5


def test_static_gravity_takes_the_accelerometer_scale_out():
    from sportfusion.gates.inertial import Static, global_acceleration, static_gravity

    t = np.arange(0, 20, 0.01)
    f = np.tile([0.0, 0.0, -9.81 * 1.02], (t.size, 1))  # a 2 % scale error, at rest throughout
    q = np.tile([1.0, 0.0, 0.0, 0.0], (t.size, 1))
    st = Static((0, 300), (1700, 2000))
    assert np.abs(global_acceleration(q, f, 9.81)[:, 2]).max() > 0.19  # normal gravity: 0.2 m/s^2 "up" forever
    g = static_gravity(t, f, st)
    assert np.abs(global_acceleration(q, f, g)).max() < 1e-9


def test_alignment_follows_a_track_whose_speed_is_off_by_metres_per_second():
    # the full-body skier of seed 1202 (issue 39): the inertial track between the still start and finish
    # overestimated the speed along the course by up to 6.7 m/s mid-run (its displacement from gate to gate
    # 30 % too long), the first and the last gate were passed too wide to be detected; every displacement
    # compared on its own, the alignment matched 12 of 28 crossings (some to the neighbouring gate) and the
    # anchored track ended 70-160 m off.  A path's misfits are smooth in time (the drift's rate), so each
    # step is compared with the drift its path has shown so far.
    from sportfusion.gates.alignment import AlignParams, align_with_azimuth

    t0, t1, vmax = 16.0, 61.0, 7.0  # still until t0 and from t1 [s]; the speed error mid-run [m/s]
    along = np.array([1.0, 0.0, 0.2]) / np.hypot(1.0, 0.2)
    for seed in range(4):
        rng = np.random.default_rng(seed)
        survey = _course(rng)
        ssd = survey_sides(survey)
        gates = np.arange(1, 29)
        t = 20.0 + 1.25 * gates + rng.normal(0, 0.05, gates.size)
        drift = vmax * (t1 - t0) / np.pi * (1 - np.cos(np.pi * (t - t0) / (t1 - t0)))  # the speed error's integral
        det = survey[gates] + np.outer(drift, along) + rng.normal(0, 0.3, (gates.size, 3))
        det = rotate_z(det, np.deg2rad(3.0)) + [-400.0, 9.0, -80.0]
        ids, alpha, _ = align_with_azimuth(t, det, ssd[gates], survey, ssd, 0.0)
        assert list(ids) == list(gates), seed
        assert abs(np.rad2deg(alpha) + 3.0) < 0.5
        # the construction is a hard one: without the drift's rate, a handful of crossings are matched
        old = align_crossings(t, rotate_z(det, np.deg2rad(-3.0)), ssd[gates], survey, ssd, AlignParams(drift_gain=0))
        assert (old == gates).sum() < 10
