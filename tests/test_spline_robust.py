"""Robust spline weights: phone/watch GNSS jumps of 50-60 m do not become speeds (issue 15, item 11).

A simulated ski day at 1 Hz (standstill, a run with turns peaking at 16 m/s, standstill) with 2.5 m / 4 m
noise and the receiver's own speed and velocity; 50-60 m jumps are injected at single epochs and as plateaus
of 2-3 epochs, most at a standstill as seen on real phones.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run_cli, session_bytes
from scipy.ndimage import gaussian_filter1d

from sportfusion.core import io as sfio
from sportfusion.core.schema import floats
from sportfusion.estimators.spline import epoch_weights, smoothing_spline
from sportfusion.estimators.spline_robust import robust_weights, tukey
from sportfusion.skirace.track import smooth_track

JUMPS = [(10, (55, 10)), (11, (52, 12)), (20, (-40, 35)), (21, (-42, 33)), (22, (-41, 36)), (60, (45, -30)),
         (130, (0, 58)), (140, (50, 20)), (141, (55, 25))]  # fmt: skip


def watch_track(seed: int, jumps: bool = True):
    rng = np.random.default_rng(seed)
    dt = 0.01
    tf = np.arange(0, 150.0, dt)
    moving = gaussian_filter1d(np.where((tf > 30) & (tf < 120), 1.0, 0.0), 300)
    spd = moving * (13.0 + 3.0 * np.sin(2 * np.pi * tf / 40))
    head = 0.6 * np.sin(2 * np.pi * tf / 4.0) * moving
    vn, ve, vd = spd * np.cos(head), spd * np.sin(head), 0.25 * spd
    fine = np.column_stack([np.cumsum(vn), np.cumsum(ve), np.cumsum(vd)]) * dt
    t = np.arange(0, 150.0, 1.0)
    i = np.round(t / dt).astype(int)
    true = fine[i]
    vel = np.column_stack([vn[i], ve[i], vd[i]])
    pos = true + rng.normal(0, 1, true.shape) * np.array([2.5, 2.5, 4.0])
    if jumps:
        for k, (dx, dy) in JUMPS:
            pos[k] += [dx, dy, 5.0]
    sigma = np.tile([3.0, 3.0, 5.0], (t.size, 1))
    speed = np.abs(np.linalg.norm(vel[:, :2], axis=1) + rng.normal(0, 0.2, t.size))  # receivers report >= 0
    return t, pos, sigma, speed, vel + rng.normal(0, 0.1, vel.shape), true, float(np.max(np.linalg.norm(vel, axis=1)))


def max_speed(res) -> float:
    return float(np.nanmax(res.columns["speed"]))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_jumps_do_not_become_speed(seed):
    t, pos, sigma, speed, vel, true, vmax = watch_track(seed)
    plain = smooth_track(t, pos, None, sigma, lam=0.9, robust=False)
    assert max_speed(plain) > 1.3 * vmax  # the fault: jumps turned into speed
    for kw in ({}, {"speed": speed}, {"vel": vel}):
        res = smooth_track(t, pos, None, sigma, lam=0.9, **kw)
        assert abs(max_speed(res) - vmax) < 0.3 * vmax, kw
        w = res.columns["gnss_weight"]
        bad = np.array([k for k, _ in JUMPS])
        single = np.array([10, 11, 60, 130, 140, 141])  # the leave-one-out screen alone misses the 3-fix plateau
        assert (w[bad if kw else single] < 0.1).all(), w[bad]
        assert np.mean(w[np.setdiff1d(np.arange(t.size), bad)] > 0.5) > 0.97
        assert any("weighted down" in m for m in res.warnings)


@pytest.mark.parametrize("seed", [3, 4])
def test_clean_track_unchanged(seed):
    t, pos, sigma, speed, vel, true, vmax = watch_track(seed, jumps=False)
    plain = smooth_track(t, pos, None, sigma, lam=0.9, robust=False)
    res = smooth_track(t, pos, None, sigma, lam=0.9, vel=vel)

    def rms(r):
        x = np.column_stack([r.columns[a] for a in "xyz"])
        return float(np.sqrt(np.mean(np.sum((x - true) ** 2, axis=1))))

    assert rms(res) < 1.05 * rms(plain)
    assert abs(max_speed(res) - max_speed(plain)) < 0.05 * max_speed(plain)
    assert (res.columns["gnss_weight"] > 0.1).all()


def test_tukey_and_weights_properties():
    assert tukey(np.array([0.0]))[0] == 1.0 and tukey(np.array([10.0]))[0] == pytest.approx(1e-6)
    t = np.arange(40.0)
    y = np.column_stack([t * 3.0, np.zeros(40), np.zeros(40)])
    y[17] += [0.0, 60.0, 0.0]
    w = epoch_weights(np.ones(40), np.full(40, 2.0))
    rw = robust_weights(t, y, np.tile(w[:, None], (1, 3)), 0.9, np.full(40, 2.0))
    assert rw[17] < 0.01 and np.delete(rw, 17).min() > 0.5
    fit = smoothing_spline(t, y, np.tile((w * rw)[:, None], (1, 3)), 0.9)
    assert np.abs(fit.spline(t, 1)[:, 1]).max() < 1.0  # the spike no longer makes a lateral speed


def test_cli_uses_the_receiver_speed_and_writes_weights():
    t, pos, sigma, speed, vel, true, vmax = watch_track(5)
    n = t.size
    cols = {"t": t, **{f"gnss_{a}": pos[:, i] for i, a in enumerate("xyz")}}
    cols |= {"gnss_sigma_h": sigma[:, 0], "gnss_sigma_v": sigma[:, 2], "gnss_speed": speed}
    data = session_bytes(cols, n=n)
    outs = {}
    for flag in ("--robust", "--no-robust"):
        r = run_cli(["spline-smooth", flag], stdin=data)
        assert r.returncode == 0, r.stderr.decode()
        outs[flag] = sfio.table_from_bytes(r.stdout)
    robust = outs["--robust"]
    sp = floats(robust, "speed")
    assert abs(np.nanmax(sp) - vmax) < 0.3 * vmax
    assert np.nanmax(floats(outs["--no-robust"], "speed")) > 1.3 * vmax
    assert "gnss_weight" in robust.column_names and "gnss_weight" not in outs["--no-robust"].column_names
    assert robust.schema.field("gnss_weight").metadata[b"unit"] == b"1"


def test_the_shortcuts_give_the_long_ways_numbers(monkeypatch):
    """What spline-smooth skips on a clean track (issue 40) changes no number: the weights without the medians,
    the screens without the running-median speed, and the final fit taken from the screen's last pass."""
    import sportfusion.skirace.track as track_mod
    from sportfusion.estimators import spline_robust as R

    rng = np.random.default_rng(9)
    n = 2000
    t = np.cumsum(rng.uniform(0.05, 0.15, n))
    clean = np.column_stack((np.sin(t / 3), np.cos(t / 5), 0.01 * t)) + 0.02 * rng.standard_normal((n, 3))
    sig = np.full((n, 3), 0.02)
    # (1) residuals all far below FLAT * floor: weights exactly 1 without the medians; else the full path
    for e in (0.03 * rng.standard_normal((n, 3)), np.r_[0.03 * rng.standard_normal((n - 1, 3)), [[9.0, 0, 0]]]):
        for floor in (1.0, 0.01):
            np.testing.assert_array_equal(R._weights(e, sig, floor, R.TUKEY_C), tukey(R._z(e, sig, floor)))
    # (2) without a receiver speed, the jumps (and the stalls) are those of the running-median speed
    stalled = clean.copy()
    stalled[700:712] = stalled[700]  # a stall, then a catch-up step
    stalled[1500] += [5.0, 0.0, 0.0]  # a spike
    stepped = clean.copy()
    stepped[1200:] += [0.0, 0.1, 0.0]  # a step longer than a standstill allows, but no jump at the speed
    fast = clean * 20.0  # every step longer than a standstill allows: the speed at every epoch at once
    fast[300] += [30.0, 0.0, 0.0]
    for y in (clean, stepped, stalled, fast):
        dist, dt = R._steps(t, y)
        lazy, full = R._jumps(dist, dt, None, sig), R._jumps(dist, dt, R.step_speed(t, y), sig)
        np.testing.assert_array_equal(lazy[2], full[2])
        np.testing.assert_array_equal(R._stalls(dist, dt, *lazy), R._stalls(dist, dt, *full))
        assert (lazy[0] is None) == (y is clean or y is stepped)  # no jump: no speed at every epoch
    dist, dt = R._steps(t, stepped)
    assert (dist > dt + 4 * np.sqrt(2) * 0.02).sum() == 1  # (the speed was taken at that step's ends)
    assert R._jumps(*R._steps(t, stalled), None, sig)[2].size
    np.testing.assert_array_equal(
        R._running_median_at(R._step_speeds(dist, dt), np.array([0, 5, 1000, n - 1]), 15),
        R.step_speed(t, stepped)[[0, 5, 1000, n - 1]],
    )
    # (3) the screen's last fit is the fit with the final weights, to the bit; smooth_track reuses it
    w = 1.0 / sig
    rw, knots = R.robust_fit(t, clean, w, 0.9, sig)
    assert knots is not None and (rw == 1.0).all()
    fit = smoothing_spline(t, clean, w * rw[:, None], 0.9)
    np.testing.assert_array_equal(knots[0], fit.spline.g)
    np.testing.assert_array_equal(knots[1], fit.spline.gamma)
    assert R.robust_fit(t, stalled, w, 0.9, sig)[1] is None  # weights changed after the last fit: no reuse
    fix = np.full(n, 4.0)
    fast = smooth_track(t, clean, fix, sig, lam=0.9)
    monkeypatch.setattr(track_mod, "robust_fit", lambda *a, **k: (R.robust_fit(*a, **k)[0], None))
    slow = smooth_track(t, clean, fix, sig, lam=0.9)
    for name, col in slow.columns.items():
        np.testing.assert_array_equal(np.asarray(fast.columns[name]), np.asarray(col), err_msg=name)
