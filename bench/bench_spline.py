"""Benchmark spline-smooth's banded Reinsch solve against csaps and scipy, plus its accuracy figures.

Prints, in one process:
1. speed on 1e6 epochs (one coordinate, and three) against csaps and scipy's
   ``make_smoothing_spline`` with the same penalised problem (lambda mapped),
   the largest difference between the results, and DESIGN.md's figures;
2. eq-6 weighting vs one uniform weight around float periods on simulated runs;
3. Table 1 of the paper: interpolating splines through 2 / 1 / 0.5 Hz subsets.

Peers (``pip install csaps``) that are missing are reported and skipped.
"""

from __future__ import annotations

import time

import numpy as np

from sportfusion.core.schema import floats
from sportfusion.estimators.spline import ambiguity_weights, epoch_weights, penalty_from_lambda, smoothing_spline
from sportfusion.skirace.sim import SkiRaceConfig, simulate_skirace

N = 1_000_000
LAM = 0.9


def best(fn, repeat: int = 3) -> tuple[float, object]:
    out, times = None, []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def speed() -> None:
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.05, 0.15, N))
    y = np.column_stack((np.sin(t / 3), np.cos(t / 5), 0.01 * t)) + 0.02 * rng.standard_normal((N, 3))
    w = rng.uniform(0.5, 2.0, N)
    print(f"== speed: N = {N:,} epochs, lambda = {LAM} (penalty {penalty_from_lambda(LAM):.4g}), random weights")
    ours1, fit1 = best(lambda: smoothing_spline(t, y[:, 0], w, LAM))
    ours3, fit3 = best(lambda: smoothing_spline(t, y, w, LAM))
    g1 = fit1.spline.g[:, 0]
    rows = [("sportfusion (banded Reinsch)", ours1, ours3, 0.0, "0.23 (DESIGN)")]
    try:
        import csaps

        c1, s1 = best(lambda: csaps.CubicSmoothingSpline(t, y[:, 0], weights=w, smooth=LAM), 2)
        c3, s3 = best(lambda: csaps.CubicSmoothingSpline(t, y.T, weights=w, smooth=LAM), 2)
        diff = float(np.max(np.abs(s1(t) - g1)))
        rows.append(("csaps", c1, c3, diff, "1.4 (DESIGN)"))
    except ImportError:
        print("  csaps is not installed (pip install csaps): row skipped")
    try:
        from scipy.interpolate import make_smoothing_spline

        sc1, ss = best(lambda: make_smoothing_spline(t, y[:, 0], w=w, lam=penalty_from_lambda(LAM)), 1)
        rows.append(
            ("scipy make_smoothing_spline", sc1, float("nan"), float(np.max(np.abs(ss(t) - g1))), "10 (DESIGN)")
        )
    except ImportError:
        print("  scipy.interpolate.make_smoothing_spline is missing: row skipped")
    print(
        f"  {'method':<30} {'1 coord [us/pt]':>16} {'3 coords [us/pt]':>17} {'x ours':>8} {'max |diff| [m]':>15}  reference"
    )
    for name, a, b, d, ref in rows:
        print(f"  {name:<30} {a / N * 1e6:16.3f} {b / N * 1e6:17.3f} {a / ours1:8.1f} {d:15.2e}  {ref} us/pt")


def weighting() -> None:
    print("== eq-6 weighting vs one uniform weight (lambda 0.9), simulated runs with float episodes [m RMS]")
    print(
        f"  {'seed':>4} {'around float: eq6':>18} {'uniform':>8} {'gain':>6} {'in float: eq6':>14} {'uniform':>8} {'gain':>6}"
    )
    for seed in range(1, 6):
        s = simulate_skirace(SkiRaceConfig(seed=seed))
        T, tr = s.session, s.truth
        has = np.isfinite(floats(T, "gnss_x"))
        t = floats(T, "t")[has]
        y = np.column_stack([floats(T, f"gnss_{a}")[has] for a in "xyz"])
        sig = np.column_stack([floats(T, f"std_gnss_{a}")[has] for a in "xyz"])
        fix = floats(T, "gnss_fix")[has].astype(int)
        truth = np.column_stack([floats(tr, f"true_{a}")[has] for a in "xyz"])
        near = np.zeros(t.size, bool)
        for tf in t[fix != 4]:
            near |= np.abs(t - tf) <= 1.0
        res = []
        for w in (
            epoch_weights(ambiguity_weights(fix), sig),
            np.broadcast_to(1 / np.median(sig[fix == 4], axis=0), sig.shape),
        ):
            e = np.linalg.norm(smoothing_spline(t, y, w, LAM).spline(t) - truth, axis=1)
            res.append((np.sqrt(np.mean(e[near & (fix == 4)] ** 2)), np.sqrt(np.mean(e[fix != 4] ** 2))))
        (a6, i6), (au, iu) = res
        print(f"  {seed:4d} {a6:18.3f} {au:8.3f} {1 - a6 / au:6.0%} {i6:14.3f} {iu:8.3f} {1 - i6 / iu:6.0%}")
    print("  (around = fixed epochs within 1 s of a float epoch; required: >= 30 % lower)")


def table1() -> None:
    paper = {2: (0.02, 0.02, 0.03, 0.03), 1: (0.09, 0.09, 0.12, 0.13), 0.5: (0.73, 0.65, 0.42, 0.38)}
    print("== Table 1: interpolating splines through decimated 10 Hz tracks (mean, 1-sigma) [m], 3 runs")
    acc = {r: [] for r in paper}
    for seed in (3, 4, 5):
        s = simulate_skirace(SkiRaceConfig(seed=seed, float_episodes=0, lock_losses=0, jumps=0))
        T = s.session
        has = np.isfinite(floats(T, "gnss_x"))
        t = floats(T, "t")[has]
        y = np.column_stack([floats(T, f"gnss_{a}")[has] for a in "xyz"])
        run = t > 7.0
        t, y = t[run], y[run]
        for rate, step in ((2, 5), (1, 10), (0.5, 20)):
            keep = np.arange(0, t.size, step)
            f = smoothing_spline(t[keep], y[keep], None, 1.0)
            m = (t > t[keep[0]]) & (t < t[keep[-1]])
            m[keep] = False
            d = f.spline(t[m]) - y[m]
            dh, dv = np.hypot(d[:, 0], d[:, 1]), np.abs(d[:, 2])
            acc[rate].append((dh.mean(), dh.std(), dv.mean(), dv.std()))
    print(f"  {'rate':>6}  {'horiz mean':>10} {'1-sigma':>8} {'vert mean':>10} {'1-sigma':>8}   paper")
    for rate, vals in acc.items():
        v = np.mean(vals, axis=0)
        p = paper[rate]
        print(
            f"  {rate:>4} Hz {v[0]:10.3f} {v[1]:8.3f} {v[2]:10.3f} {v[3]:8.3f}   {p[0]:.2f} {p[1]:.2f} {p[2]:.2f} {p[3]:.2f}"
        )


if __name__ == "__main__":
    speed()
    weighting()
    table1()
