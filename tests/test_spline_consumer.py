"""Consumer tracks through ``spline-smooth`` (issue 36, item 5): a watch's catch-up step after a stall, the
fixes' stated accuracy and HDOP as weights, and a height that wiggles from fix to fix but adds no distance."""

from __future__ import annotations

import numpy as np
from conftest import run_cli, session_bytes
from scipy.ndimage import gaussian_filter1d

from sportfusion.core import io as sfio
from sportfusion.core.schema import floats
from sportfusion.estimators.spline_robust import stall_fixes, step_speed
from sportfusion.skirace.track import smooth_track


def jog(seed: int, n: int = 600, v: float = 4.6):
    rng = np.random.default_rng(seed)
    t = np.arange(float(n))
    head = 0.4 * np.sin(2 * np.pi * t / 90)
    true = np.column_stack([np.cumsum(v * np.cos(head)), np.cumsum(v * np.sin(head)), -0.05 * v * t])
    noise = np.column_stack(
        [gaussian_filter1d(rng.normal(0, 1, n), 2) * 2.0, gaussian_filter1d(rng.normal(0, 1, n), 2) * 2.0,
         rng.normal(0, 2.5, n)]  # the height wiggles from fix to fix (1 Hz, 2.5 m)
    )  # fmt: skip
    return t, true, true + noise, np.full(n, v) + rng.normal(0, 0.1, n)


def with_stall(pos: np.ndarray, start: int, length: int) -> np.ndarray:
    """Frozen fixes for ``length`` s from ``start``, then the catch-up step (the next fix is right again)."""
    out = pos.copy()
    out[start + 1 : start + length + 1] = out[start]
    return out


def test_catch_up_step_makes_no_speed_peak():
    t, true, pos, speed = jog(1)
    bad = with_stall(pos, 200, 13)  # 13 s frozen, then 60 m in one second
    assert np.linalg.norm(bad[214, :2] - bad[213, :2]) > 55
    flagged = stall_fixes(t, bad, speed, np.full(t.size, 3.0))
    assert flagged[201:214].all() and flagged.sum() <= 14
    for kw in ({"speed": speed}, {}):  # with the watch's speed, and from the fixes' own running median
        res = smooth_track(t, bad, None, np.full((t.size, 3), 3.0), lam=0.9, **kw)
        sp = res.columns["speed"]
        assert np.nanmax(sp[190:230]) < 4.6 * 1.35, kw  # the spline through the stall: 13 m/s before
        assert (res.columns["gnss_weight"][202:214] < 0.01).all()
    plain = smooth_track(t, bad, None, np.full((t.size, 3), 3.0), lam=0.9, robust=False)
    assert np.nanmax(plain.columns["speed"][190:230]) > 8.0  # the fault it fixes


def test_a_real_stop_is_not_a_stall():
    t, true, pos, speed = jog(2)
    stop = pos.copy()
    stop[300:320] = stop[300]  # standing still 20 s, then walking on from there (no catch-up step)
    stop[320:] -= stop[320] - stop[300]
    sp = speed.copy()
    sp[300:320] = 0.0
    assert not stall_fixes(t, stop, sp, np.full(t.size, 3.0)).any()
    est = step_speed(t, stop)
    assert not stall_fixes(t, stop, est, np.full(t.size, 3.0)).any()


def test_height_wiggle_adds_no_distance():
    t, true, pos, _ = jog(3)
    true_len = np.sum(np.linalg.norm(np.diff(true, axis=0), axis=1))
    sig = np.tile([3.0, 3.0, 5.0], (t.size, 1))
    for lam in (0.9, None):
        res = smooth_track(t, pos, None, sig, lam=lam)
        d = res.columns["distance"][-1]
        assert abs(d / true_len - 1) < 0.02, (lam, d / true_len)  # 9 % (22 % with GCV) before
    # an RTK track keeps the spline's own 3-D arc length
    rtk = smooth_track(t, true, np.full(t.size, 4.0), np.full((t.size, 3), 0.02), lam=0.9)
    assert abs(rtk.columns["distance"][-1] / true_len - 1) < 1e-3


def test_hdop_weights_the_fixes():
    """Fixes with a large HDOP (and no stated sigma) weigh less: where a third of the fixes have HDOP 5 and
    12 m of extra noise, the spline weighted by HDOP is closer to the truth than the unweighted one."""
    t, true, pos, _ = jog(4, n=400)
    rng = np.random.default_rng(5)
    poor = rng.random(t.size) < 0.33
    hdop = np.where(poor, 5.0, 0.8)
    pos = pos.copy()
    pos[poor, :2] += rng.normal(0, 12.0, (int(poor.sum()), 2))
    cols = {"t": t, **{f"gnss_{a}": pos[:, i] for i, a in enumerate("xyz")}}
    err = []
    for extra in ({"gnss_hdop": hdop}, {}):
        r = run_cli(["spline-smooth", "--no-robust"], stdin=session_bytes({**cols, **extra}, n=t.size))
        assert r.returncode == 0, r.stderr.decode()
        out = sfio.table_from_bytes(r.stdout)
        xy = np.column_stack([floats(out, "x"), floats(out, "y")])
        err.append(float(np.sqrt(np.mean(np.sum((xy - true[:, :2]) ** 2, axis=1)))))
    assert err[0] < 0.75 * err[1], err


def test_step_speed_is_the_running_median_of_the_step_speeds():
    """The running median (C where built, else scipy inside and the shrinking windows at the ends) equals its
    definition: the median of the finite step speeds within ``window // 2`` epochs either side; a missing fix
    is skipped."""
    from numpy.lib.stride_tricks import sliding_window_view

    rng = np.random.default_rng(5)
    for n in (3, 4, 17, 31, 32, 200):
        t = np.cumsum(rng.uniform(0.5, 1.5, n))
        y = np.cumsum(rng.normal(0, 3, (n, 2)), axis=0)
        v = np.linalg.norm(np.diff(y, axis=0), axis=1) / np.diff(t)
        v = np.r_[v[0], v]
        pad = np.r_[np.full(15, np.nan), v, np.full(15, np.nan)]
        ref = np.nanmedian(sliding_window_view(pad, 31), axis=1)
        np.testing.assert_allclose(step_speed(t, y), ref, rtol=0, atol=1e-12, err_msg=str(n))
    y[50] = np.nan  # a missing fix: its two steps are left out of the medians around it
    est = step_speed(t, y)
    assert np.isfinite(est).all() and abs(est[50] - np.nanmedian(v[35:66])) < 2.0
