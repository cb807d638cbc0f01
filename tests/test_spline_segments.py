"""``spline-smooth`` splits a track at gaps the data cannot bridge (issue 36, item 1) and stays linear in
rows and gaps on long sessions with IMU rows (issue 38, item 6).

A watch whose record clock jumps 20 days mid-file and a ski week with overnight gaps must not turn the
spline's swing across a gap into travelled distance: each segment is smoothed alone, rows inside a gap are
null, distance carries over the gap, and a warning names it.
"""

from __future__ import annotations

import numpy as np
from conftest import run_cli, session_bytes

from sportfusion.core import io as sfio
from sportfusion.core.schema import floats
from sportfusion.estimators.spline import smoothing_spline
from sportfusion.estimators.spline_gaps import MAX_WINDOWS, bridge_error_profile, gap_std
from sportfusion.skirace.track import smooth_track


def _run(t0: float, n: int, speed: float, start: np.ndarray, heading: float) -> tuple[np.ndarray, np.ndarray]:
    t = t0 + np.arange(n, dtype=float)
    d = speed * (t - t0)
    return t, start + np.column_stack([d * np.cos(heading), d * np.sin(heading), -0.2 * d])


def multi_day(seed: int = 0):
    """Three 10-minute runs at 5 m/s on three days (overnight gaps), 1 Hz, 0.5 m noise; true length 3 x 2996 m."""
    rng = np.random.default_rng(seed)
    parts = [_run(day * 86400.0, 600, 5.0, np.array([day * 3000.0, 0.0, 0.0]), 0.3 * day) for day in range(3)]
    t = np.concatenate([p[0] for p in parts])
    pos = np.concatenate([p[1] for p in parts]) + rng.normal(0, 0.5, (t.size, 3))
    true_len = 3 * 599 * 5.0 * np.sqrt(1 + 0.04)
    return t, pos, true_len


def test_overnight_gaps_add_no_distance():
    t, pos, true_len = multi_day()
    res = smooth_track(t, pos, None, np.full((t.size, 3), 0.5), lam=0.9, epoch_utc=1.7e9)
    d = res.columns["distance"]
    # the whole track's distance is the three runs' (the spline's swing across the nights would add ~6 km)
    assert abs(d[-1] - true_len) < 0.01 * true_len, d[-1]
    # distance carries over: the first fix after a night continues where the evening's last ended
    for j in (599, 1199):
        assert 0 <= d[j + 1] - d[j] < 1.0
    seg = res.columns["spline_segment"].to_numpy(zero_copy_only=False)
    assert list(seg[[0, 599, 600, 1199, 1200, 1799]]) == [0, 0, 1, 1, 2, 2]
    assert res.info["segments"] == 3 and len(res.info["breaks"]) == 2
    line = next(w for w in res.warnings if "split" in w)
    assert "2 GNSS gap(s)" in line and "23.8 h" in line and "UTC" in line and "carries over" in line


def test_clock_jump_of_twenty_days_with_imu_rows_between():
    """A 20-day clock jump, IMU rows at 100 Hz on both sides: rows in the jump are null, no speed invented."""
    rng = np.random.default_rng(1)
    t1, p1 = _run(0.0, 300, 3.0, np.zeros(3), 0.0)
    t2, p2 = _run(300.0 + 20 * 86400.0, 300, 3.0, np.array([2000.0, 500.0, 0.0]), 1.0)
    tg = np.r_[t1, t2]
    pg = np.r_[p1, p2] + rng.normal(0, 0.3, (tg.size, 3))
    ti = np.r_[np.arange(0.0, 360.0, 0.01), np.arange(t2[0] - 30, t2[-1], 0.01)]
    t = np.union1d(tg, ti)
    pos = np.full((t.size, 3), np.nan)
    pos[np.searchsorted(t, tg)] = pg
    res = smooth_track(t, pos, None, None, lam=0.9)
    x = res.columns["x"]
    between = (t > t1[-1]) & (t < t2[0])
    assert np.isnan(x[between]).all() and np.isnan(res.columns["speed"][between]).all()
    assert np.isfinite(x[~between & (t >= tg[0]) & (t <= tg[-1])]).all()
    assert np.nanmax(res.columns["speed"]) < 4.5  # 3 m/s with 0.3 m noise; a spline across the jump: km/s
    assert abs(np.nanmax(res.columns["distance"]) - 2 * 299 * 3.0 * np.sqrt(1.04)) < 20.0  # 1829.5 m
    assert res.info["breaks"] == [[float(t1[-1]), float(t2[0])]]


def test_short_gaps_are_still_bridged_and_isolated_fixes_are_null():
    t = np.r_[np.arange(0.0, 100.0), np.arange(105.0, 200.0), [400.0], np.arange(600.0, 700.0)]
    pos = np.column_stack([2.0 * t, np.zeros(t.size), np.zeros(t.size)])
    res = smooth_track(t, pos, None, None, lam=0.9)
    assert res.info["segments"] == 2  # 99-105 s (6 s) is bridged; 199-400-600 splits, 400 s is alone
    assert np.isnan(res.columns["x"][t == 400.0]).all()
    assert any("isolated" in w for w in res.warnings)
    assert np.isnan(res.columns["gnss_weight"][t == 400.0]).all()


def test_cli_writes_segments_and_names_the_gap():
    t, pos, true_len = multi_day(2)
    cols = {"t": t, **{f"gnss_{a}": pos[:, i] for i, a in enumerate("xyz")}}
    res = run_cli(["spline-smooth"], stdin=session_bytes(cols, n=t.size))
    assert res.returncode == 0, res.stderr.decode()
    out = sfio.table_from_bytes(res.stdout)
    assert out.schema.field("spline_segment").metadata[b"unit"] == b"1"
    assert abs(np.nanmax(floats(out, "distance")) - true_len) < 0.01 * true_len
    err = res.stderr.decode()
    assert "track split into 3 segment(s)" in err and "UTC" in err


def test_bridge_profile_is_bounded_and_matches_the_full_scan():
    """The thinned profile (at most MAX_WINDOWS windows) equals the full scan where the scan is small,
    and the work for many gaps on a long track stays bounded (linear, issue 38)."""
    rng = np.random.default_rng(3)
    tk = np.arange(0.0, 3000.0, 1.0)
    y = np.column_stack([np.cumsum(rng.normal(0, 1, tk.size)), np.sin(tk / 7.0) * 20.0])
    fit = smoothing_spline(tk, y, None, 0.9)
    full = bridge_error_profile(fit.spline, tk, 6.0, [], max_windows=10**9)
    thin = bridge_error_profile(fit.spline, tk, 6.0, [])
    np.testing.assert_allclose(thin, full, rtol=0.15)  # 2000 of 2000 windows here: the same RMS
    calls = []

    class Counting:
        def __init__(self, s):
            self.s = s

        def evaluate(self, tq):
            calls.append(np.size(tq))
            return self.s.evaluate(tq)

    gaps = [(float(a), float(a) + 2.0 + (i % 50) * 0.1) for i, a in enumerate(np.arange(10.0, 2900.0, 7.0))]
    tq = np.arange(0.0, 3000.0, 0.01)
    std = gap_std(Counting(fit.spline), tk, gaps, tq, np.ones((tq.size, 2)))
    assert np.isfinite(std[(tq > gaps[0][0]) & (tq < gaps[0][1])]).all()
    assert sum(calls) < 30 * MAX_WINDOWS * 25  # at most MAX_LENGTHS profiles of MAX_WINDOWS windows x 23 points
