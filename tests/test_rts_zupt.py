"""rts-smooth's zero-velocity updates: where the athlete stands still (still_steps) and what they give."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.core import io as sfio
from sportfusion.core import schema
from sportfusion.core.windows import window_mean_std
from sportfusion.evaluate import errors
from sportfusion.skijump.hillfile import load_hill
from sportfusion.skijump.smoother import rts_smooth_table
from sportfusion.skijump.smoother_inputs import SmootherConfig, still_steps

FIX = "fixtures/skijump/"


def _imu(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    u = np.zeros((t.size, 6))
    u[:, 0:3] = 0.05 + rng.normal(0.0, 0.02, (t.size, 3))  # gyro: a bias (does not count) and noise
    u[:, 3:6] = [0.3, -0.2, 9.8] + rng.normal(0.0, 0.1, (t.size, 3))
    return u


def test_window_mean_std_matches_numpy_windows() -> None:
    """Against numpy on each window, also far from zero (the running sums are centred)."""
    rng = np.random.default_rng(1)
    x = rng.normal(size=(40, 2)) + [1e6, 9.81]
    lo = np.array([0, 0, 7, 36])
    hi = np.array([4, 6, 14, 40])
    mean, std = window_mean_std(x, lo, hi)
    for i in range(lo.size):
        np.testing.assert_allclose(mean[i], x[lo[i] : hi[i]].mean(axis=0), rtol=0, atol=1e-9)
        np.testing.assert_allclose(std[i], x[lo[i] : hi[i]].std(axis=0), rtol=0, atol=1e-9)
    # more windows than one block of rows (windows.py's _BLOCK): every block's windows
    x = rng.normal(size=(9000, 3)) + [5.0, -2.0, 9.81]
    lo = rng.integers(0, 8990, 9000)
    hi = lo + rng.integers(1, 10, 9000)
    mean, std = window_mean_std(x, lo, hi)
    for i in (0, 4095, 4096, 4097, 8191, 8192, 8999):
        np.testing.assert_allclose(mean[i], x[lo[i] : hi[i]].mean(axis=0), rtol=0, atol=1e-9)
        np.testing.assert_allclose(std[i], x[lo[i] : hi[i]].std(axis=0), rtol=0, atol=1e-9)


def test_still_ends_where_the_motion_starts() -> None:
    """At rest until 4 s, then sliding off: still steps end within the half window before 4 s, none after."""
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 10.0, 0.01)
    u = _imu(t, rng)
    moving = t >= 4.0
    u[moving, 3] += 5.0 * np.minimum((t[moving] - 4.0) / 0.2, 1.0)  # specific force along the slope
    ts = np.arange(0.0, 10.0, 0.1)
    speed = np.where(ts >= 4.0, 5.0 * (ts - 4.0), 0.0) + np.abs(rng.normal(0.0, 0.15, ts.size))
    w = still_steps(t, u, ts, speed, SmootherConfig())
    assert set(np.unique(w)) <= {0.0, 1.0}
    assert w[t < 3.7].min() == 1.0
    assert w[t >= 4.0].max() == 0.0


def test_arm_swinging_or_slow_sliding_or_no_gnss_is_not_still() -> None:
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 6.0, 0.01)
    ts = np.arange(0.0, 6.0, 0.1)
    cfg = SmootherConfig()
    slow = np.full(ts.size, 0.1)
    # the athlete stands (GNSS slow) and swings the arm the sensor is on
    u = _imu(t, rng)
    u[:, 1] += 1.0 * np.sin(2 * np.pi * 1.0 * t)
    u[:, 3] += 2.0 * np.sin(2 * np.pi * 1.0 * t)
    assert still_steps(t, u, ts, slow, cfg).max() == 0.0
    # a quiet IMU while the GNSS says 1 m/s: sliding, not standing
    assert still_steps(t, _imu(t, rng), ts, np.full(ts.size, 1.0), cfg).max() == 0.0
    # no GNSS speed at all: nothing is declared still
    assert still_steps(t, _imu(t, rng), np.zeros(0), np.zeros(0), cfg).max() == 0.0
    # a still stretch shorter than zupt_min is dropped
    u = _imu(t, rng)
    u[t > 0.8, 3] += 3.0 * np.sin(2 * np.pi * 2.0 * t[t > 0.8])
    assert still_steps(t, u, ts, slow, cfg).max() == 0.0
    # and the same data is still with a shorter minimum
    assert still_steps(t, u, ts, slow, SmootherConfig(zupt_min=0.3)).max() == 1.0


@pytest.fixture(scope="module")
def runs():
    tab, meta = sfio.read_table(FIX + "session.parquet")
    truth, tmeta = sfio.read_table(FIX + "truth.parquet", kind="truth")
    times = tmeta["skijump"]["times"]
    hill = load_hill("oberstdorf_hs106")
    ev = {"takeoff": [times["takeoff"]], "touchdown": [times["touchdown"]]}
    out = {z: rts_smooth_table(tab, meta, hill, SmootherConfig(zupt=z), **ev) for z in (True, False)}
    return truth, times, meta, out


def test_zupt_pins_the_rests_and_reports_its_residuals(runs) -> None:
    """On the simulated jump (sitting at the gate, standing after the stop): with the updates the velocity
    at the rests is ~zero and the position error there smaller; the whole-run 3-D error not worse."""
    truth, times, meta, out = runs
    az = meta["frame"]["azimuth_deg"]
    res = {}
    for z, (est, ometa, _) in out.items():
        t, _, e = errors(est, truth, az, velocity_frame="ned")
        rest = (t < times["release"] - 0.3) | (t > times["stop"] + 0.5)
        v = np.sqrt(e["vel_n"] ** 2 + e["vel_e"] ** 2 + e["vel_d"] ** 2)
        p = np.sqrt(e["x"] ** 2 + e["y"] ** 2 + e["z"] ** 2)
        res[z] = (np.sqrt(np.nanmean(v[rest] ** 2)), np.sqrt(np.nanmean(p[rest] ** 2)), np.sqrt(np.nanmean(p**2)))
        assert ("zupt" in ometa["rts"]["residual_rms"]) == z
    assert res[True][0] < 0.01 < res[False][0], res
    assert res[True][1] < res[False][1], res
    assert res[True][2] <= res[False][2] * 1.02, res
    est = out[True][0]
    v = np.stack([schema.floats(est, c) for c in ("vx", "vy", "vz")], -1)
    t = schema.floats(est, "t")
    assert np.abs(v[(t > 1.0) & (t < times["release"] - 0.3)]).max() < 0.01
