"""The simulation toolkit (sportfusion.sim: ode, imu, vibration, gnss) against analytic results and scipy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sportfusion.sim.gnss import gauss_markov, multipath, outliers
from sportfusion.sim.imu import TriadErrors, butterworth2, group_delay, lowpass, sense
from sportfusion.sim.ode import EventSpec, bisect_root, solve_fixed
from sportfusion.sim.vibration import Envelope, band_noise, body_response


# -- ode ------------------------------------------------------------------------------------------
def test_rk4_fixed_step_on_a_damped_oscillator_and_its_dense_output():
    # y'' = -w^2 y - 2 z w y', y(0) = 1, y'(0) = 0: analytic solution
    w, z = 2 * math.pi * 1.5, 0.1
    wd = w * math.sqrt(1 - z * z)

    def exact(t):
        return np.exp(-z * w * t) * (np.cos(wd * t) + z * w / wd * np.sin(wd * t))

    sol = solve_fixed(lambda t, y: (y[1], -w * w * y[0] - 2 * z * w * y[1]), (0.0, 3.0), [1.0, 0.0], 1e-3)
    assert sol.status == 0 and sol.t[-1] == pytest.approx(3.0)
    assert np.abs(sol.y[0] - exact(sol.t)).max() < 1e-9  # RK4: O(h^4) ~ (w h)^4 / ... at h = 1 ms
    tq = np.linspace(0.0, 3.0, 777)
    assert np.abs(sol.sol(tq)[0] - exact(tq)).max() < 1e-9  # Hermite between the nodes
    assert np.isclose(sol.sol(1.2345)[0], exact(1.2345), atol=1e-9)  # scalar query -> (n,)


def test_terminal_event_located_between_the_nodes():
    # free fall from 10 m: z = 10 - g t^2 / 2 reaches 0 at sqrt(20 / g)
    g = 9.81
    ev = EventSpec(lambda t, y: y[0], terminal=True, direction=-1.0)
    sol = solve_fixed(lambda t, y: (y[1], -g), (0.0, 5.0), [10.0, 0.0], 0.01, events=[ev])
    assert sol.status == 1
    assert sol.t_events[0][0] == pytest.approx(math.sqrt(20 / g), abs=1e-10)
    assert sol.t[-1] == pytest.approx(sol.t_events[0][0]) and abs(sol.y[0, -1]) < 1e-9
    # a rising-only event is not triggered by the falling crossing
    up = EventSpec(lambda t, y: y[0], terminal=True, direction=1.0)
    assert solve_fixed(lambda t, y: (y[1], -g), (0.0, 2.0), [10.0, 0.0], 0.01, events=[up]).status == 0


def test_bisect_root_and_its_refusal():
    r = bisect_root(lambda x: x**3 - 2.0, 0.0, 2.0, 1e-12)
    assert r == pytest.approx(2 ** (1 / 3), abs=1e-11)
    with pytest.raises(ValueError):
        bisect_root(lambda x: x * x + 1.0, -1.0, 1.0, 1e-9)


# -- imu ------------------------------------------------------------------------------------------
def test_butterworth_matches_scipy_and_its_delay():
    from scipy.signal import butter, lfilter
    from scipy.signal import group_delay as scipy_gd

    b, a = butterworth2(41.0, 1000.0)
    bs, as_ = butter(2, 41.0, fs=1000.0)
    assert np.allclose(b, bs, atol=1e-15) and np.allclose(a, as_, atol=1e-15)
    x = np.random.default_rng(0).normal(size=(4000, 3)) + 3.0
    ref = np.stack([lfilter(b, a, x[:, j] - x[0, j]) + x[0, j] for j in range(3)], -1)  # steady start
    assert np.abs(lowpass(x, 41.0, 1000.0) - ref).max() < 1e-12
    _, gd = scipy_gd((b, a), w=[1.0], fs=1000.0)
    assert group_delay(41.0) == pytest.approx(gd[0] / 1000.0, rel=0.02)  # 5.5 ms


def test_sense_applies_scale_misalignment_bias_and_quantisation():
    fs, dec = 1000.0, 10
    t = np.arange(0, 2.0, 1 / fs)
    truth = np.stack([np.sin(2 * np.pi * 0.5 * t), np.full(t.size, 9.81), 0.2 * t], -1)
    rng = np.random.default_rng(1)
    err = TriadErrors(bias=np.array([0.1, -0.2, 0.3]), scale=np.array([0.02, -0.01, 0.0]))
    err.misalign = np.array([[0, 0.01, 0], [0, 0, 0], [-0.02, 0, 0]])
    y = sense(truth, fs, dec, err, rng, antialias="point")
    expect = truth[::dec] @ (np.eye(3) + np.diag(err.scale) + err.misalign).T + err.bias
    assert np.allclose(y, expect, atol=1e-12)
    # boxcar: the mean of the interval ending at the sample (half an interval late)
    yb = sense(truth, fs, dec, TriadErrors(), rng, antialias="boxcar")
    k = 50
    assert np.allclose(yb[k], truth[k * dec - dec + 1 : k * dec + 1].mean(axis=0), atol=1e-12)
    # quantisation, saturation and the temperature-driven bias
    q = TriadErrors(lsb=0.05, full_scale=5.0, temp_coeff=np.array([0.01, 0.0, 0.0]))
    temp = np.linspace(0.0, -10.0, t.size)
    yq = sense(truth, fs, dec, q, rng, temperature=temp, antialias="point")
    assert np.allclose(yq / 0.05, np.round(yq / 0.05), atol=1e-9)
    assert yq[:, 1].max() <= 5.0 + 1e-9
    assert yq[-1, 0] == pytest.approx(truth[-dec, 0] - 0.1 + 0.0, abs=0.03)  # -10 K x 0.01 per K


def test_sense_noise_density_and_the_filter_passband():
    fs, dec = 1000.0, 10
    n = 200_000
    rng = np.random.default_rng(2)
    y = sense(np.zeros((n, 3)), fs, dec, TriadErrors(noise_density=0.01), rng, cutoff=41.0)
    # white noise of one-sided density d through a 2nd-order Butterworth: sigma^2 = d^2 ENBW, ENBW = pi fc / (4 sin(pi/4))
    enbw = math.pi * 41.0 / (4 * math.sin(math.pi / 4))
    assert y.std() == pytest.approx(0.01 * math.sqrt(enbw), rel=0.05)
    # a 2 Hz signal passes (gain ~1), a 200 Hz one is attenuated by > 20 dB
    t = np.arange(0, 4.0, 1 / fs)
    for f, lo, hi in ((2.0, 0.99, 1.01), (200.0, 0.0, 0.1)):
        s = np.stack([np.sin(2 * np.pi * f * t)] * 3, -1)
        out = sense(s, fs, 1, TriadErrors(), rng)
        assert lo <= out[1000:, 0].std() * math.sqrt(2) <= hi


# -- vibration --------------------------------------------------------------------------------------
def test_vibration_derivatives_are_consistent_and_scaled():
    t = np.arange(0.0, 4.0, 1e-4)
    env = Envelope().step(1.0, 0.5, 1.0).step(3.0, 0.5, -1.0)
    d, v, a = band_noise(t, np.random.default_rng(3), (15.0, 80.0), 3.0, env, tones=16)
    h = t[1] - t[0]
    assert np.abs(np.gradient(d, h) - v).max() < 1e-3 * np.abs(v).max()
    assert np.abs(np.gradient(v, h) - a)[5:-5].max() < 2e-3 * np.abs(a).max()
    on = (t > 1.6) & (t < 2.9)
    assert np.sqrt(np.mean(a[on] ** 2)) == pytest.approx(3.0, rel=0.35)  # RMS of 16 random tones
    assert np.abs(d).max() < 1e-3  # chatter moves the sensor by less than a millimetre
    assert np.all(a[t < 1.0] == 0.0)
    # a body carrying a base's acceleration step (smoothed over 10 ms) to a sensor: relative motion consistent,
    # the sensor's acceleration (base + relative) overshoots and settles on the base's
    e = 30.0 * Envelope().step(2.0, 0.01, 1.0)(t)[0]
    x, v, a = body_response(t, np.stack([e, 0 * e], -1), 12.0, 0.2)
    assert np.abs(np.gradient(x[:, 0], h) - v[:, 0])[5:-5].max() < 1e-3 * np.abs(v[:, 0]).max()
    assert np.abs(np.gradient(v[:, 0], h) - a[:, 0])[5:-5].max() < 1e-3 * np.abs(a[:, 0]).max()
    total = e + a[:, 0]
    assert 1.3 * 30.0 < total.max() < 2.0 * 30.0 and abs(total[-1] - 30.0) < 0.01 and np.all(x[t < 2.0] == 0.0)


# -- gnss ---------------------------------------------------------------------------------------------
def test_gauss_markov_multipath_and_outliers():
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 20000.0, 1.0)
    x = gauss_markov(rng, t, 2.0, 30.0)
    assert x.std() == pytest.approx(2.0, rel=0.1)
    lag = 30
    r = np.corrcoef(x[:-lag], x[lag:])[0, 1]
    assert r == pytest.approx(math.exp(-1.0), abs=0.08)  # correlation e^-1 after one correlation time
    tt = np.arange(0.0, 4000.0, 0.1)
    mp, w = multipath(rng, tt, 1 / 40.0, (2.0, 6.0), (1.5, 4.0))
    share = np.mean(w > 0)
    assert 0.05 < share < 0.2  # ~4 s every 40 s
    h = np.hypot(mp[:, 0], mp[:, 1])
    # episodes add where they overlap (up to 2 x 4 m), and partly cancel now and then
    assert h.max() <= 8.0 + 1e-9 and np.mean(h[w > 0.99] >= 1.5 - 1e-9) > 0.9
    o = outliers(rng, 100_000, 0.01, (8.0, 25.0))
    mag = np.linalg.norm(o, axis=1)
    assert np.mean(mag > 0) == pytest.approx(0.01, abs=0.002)
    assert mag[mag > 0].min() >= 8.0 and mag.max() <= 25.0
