"""The pass fit (sportfusion.gates.passfit): a magnet placed from the whole pass's vector field, against
synthetic passes (written here with the simulation toolkit's charge model, not the estimator's) and against
the independent gates simulator."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.gates.passfit import PassFitParams, bar_field, fit_pass
from sportfusion.sim.magnetics import MU0_4PI, bar_magnet

EARTH = np.array([21.5, 0.6, 42.5])  # NED [uT]


def synthetic_pass(rel, moment, speed=20.0, rate=125.0, noise=0.3, seed=0, tilt=(0.0, 0.0)):
    """A straight pass at ``speed`` along x whose closest point is the origin; the paper's stack at ``rel``
    (moment [A m^2], positive: north pole down), sampled at ``rate`` with white noise [uT]."""
    rng = np.random.default_rng(seed)
    t = np.arange(-1.2, 1.2, 1.0 / rate) + rng.uniform(0, 1.0 / rate)
    p = np.column_stack([speed * t, np.zeros_like(t), np.zeros_like(t)])
    axis = np.array([tilt[0], tilt[1], 1.0])
    src = bar_magnet(np.asarray(rel, float), axis * np.sign(moment), abs(moment))
    b = EARTH + src.field(p) + rng.normal(0, noise, p.shape)
    return t, b


@pytest.mark.parametrize(
    "rel,moment,tilt",
    [
        ((0.0, 0.4, 0.5), 32.0, (0.0, 0.0)),  # beside and below, the paper's magnet
        ((0.1, -0.2, 0.6), -32.0, (0.0, 0.0)),  # north pole up
        ((0.0, 0.5, 0.4), 32.0, (0.35, -0.2)),  # tilted 23 deg
        ((0.0, 0.05, 0.55), 12.0, (0.0, 0.0)),  # weak, almost straight under the sensor
    ],
)
def test_fit_recovers_the_magnet(rel, moment, tilt):
    t, b = synthetic_pass(rel, moment, tilt=tilt)
    guess = np.array([0.0, 0.3 * np.sign(rel[1] + 1e-9), 0.5])  # a rough guess on the right side
    f = fit_pass(t, b, 0.0, np.array([20.0, 0.0, 0.0]), np.zeros(3), guess)
    assert f.ok, f.why
    err = f.rel - np.asarray(rel)
    # the fit's bar (two charges) is not the stack of discs: a few mm to 2 cm
    assert np.linalg.norm(err) < 0.03, err
    assert np.all(np.abs(err) < 4 * np.sqrt(np.diag(f.cov)) + 0.02)  # the covariance is not wildly optimistic
    assert np.linalg.norm(f.moment) == pytest.approx(abs(moment), rel=0.1)
    assert np.sign(f.moment[2]) == np.sign(moment)


def test_the_mirror_image_above_is_not_taken():
    t, b = synthetic_pass((0.0, -0.3, 0.5), 32.0)
    guess = np.array([0.0, 0.3, -0.5])  # the mirror image above the sensor
    f = fit_pass(t, b, 0.0, np.array([20.0, 0.0, 0.0]), np.zeros(3), guess)
    assert f.ok and f.rel[2] > 0 and np.linalg.norm(f.rel - [0.0, -0.3, 0.5]) < 0.03


def test_a_wide_pass_is_refused_or_uncertain():
    t, b = synthetic_pass((0.0, 2.0, 0.6), 32.0, noise=0.3)  # 2.1 m: 1-2 uT in 0.3 uT noise
    f = fit_pass(t, b, 0.0, np.array([20.0, 0.0, 0.0]), np.zeros(3), np.array([0.0, 1.0, 0.5]))
    assert (not f.ok) or np.sqrt(np.trace(f.cov)) > 0.05
    t, b = synthetic_pass((0.0, 3.5, 0.6), 32.0)  # nothing above the noise
    f = fit_pass(t, b, 0.0, np.array([20.0, 0.0, 0.0]), np.zeros(3), np.array([0.0, 1.0, 0.5]))
    assert not f.ok and "noise" in f.why


def test_bar_field_is_the_dipole_far_away_and_scaled_in_microtesla():
    r = np.array([[0.0, 0.0, 5.0]])
    m = np.array([0.0, 0.0, 30.0])
    on_axis = 2 * MU0_4PI * 30.0 / 5.0**3 * 1e6  # uT
    assert np.allclose(bar_field(r, np.zeros(3), m, 0.0), [[0, 0, on_axis]])
    assert np.allclose(bar_field(r, np.zeros(3), m, 0.145), [[0, 0, on_axis]], rtol=2e-3)


def test_fit_on_the_independent_simulator():
    # truth attitude and velocity, the simulator's unit errors, its stack magnets, stray iron: the fit places
    # each magnet's centre within a few centimetres, where the peak model (eqs 1-6 with the body model
    # h = H0 cos(roll)) is off by a decimetre or more: the simulator's athlete angulates and flexes
    from sportfusion.core.rotations import euler_from_quat, local_to_ned, to_ned
    from sportfusion.core.schema import floats
    from sportfusion.gates.anchors import relative_anchors, sacrum_height
    from sportfusion.gates.sim import GatesConfig, simulate_gates

    sim = simulate_gates(GatesConfig(seed=31, n_gates=8, static=2.0))
    s, f = sim.session, sim.fine
    rows = np.isfinite(floats(s, "mag_x"))
    tm = floats(s, "t")[rows]
    mag = np.column_stack([floats(s, c)[rows] for c in ("mag_x", "mag_y", "mag_z")])
    q = np.column_stack([floats(sim.truth, f"true_q{i}")[rows] for i in range(4)])
    b_ned = to_ned(q, mag)
    az = sim.meta["frame"]["azimuth_deg"]
    fit_err, peak_err = [], []
    for j, (tc, k) in enumerate(zip(sim.crossings["t"], sim.crossings["k"], strict=True)):
        if sim.crossings["distance"][j] > 1.0:
            continue
        v, a = local_to_ned(f["vel"][k], az), local_to_ned(f["acc"][k], az)
        true_rel = local_to_ned(sim.magnet_centres[j] - f["pos"][k], az)
        w = np.abs(tm - tc) < 1.5
        res = fit_pass(tm[w], b_ned[w], tc, v, a, np.array([0.0, 0.0, 0.5]), PassFitParams())
        assert res.ok, res.why
        fit_err.append(np.linalg.norm(res.rel - true_rel))
        side = 1.0 if sim.crossings["turn"][j] == "R" else -1.0
        roll = euler_from_quat(f["q"][k])[0]
        peak = relative_anchors(
            f["pos"][k][None], f["vel"][k][None], [sim.crossings["distance"][j]], [side], sacrum_height(roll)
        )[0]
        peak_err.append(np.linalg.norm(peak - sim.magnet_centres[j]))
    assert len(fit_err) >= 5
    assert np.median(fit_err) < 0.04 and max(fit_err) < 0.1
    assert np.median(fit_err) < 0.3 * np.median(peak_err)
