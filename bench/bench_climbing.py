"""Climbing (Koller et al., §III-IV): accuracy over 50 simulated trials beside the paper's Table I,
failure cases, and the speed of a 60 s trial at 100 Hz end to end.

For every seed ``simulate boulder`` generates a trial (default settings: 100 Hz, a route of
10-20 holds, magnetic disturbances behind the wall, slaps that clip the accelerometer,
off-centre and wall grips, grip adjustments, a down-climb), ``detect-events --kind grips``
finds the grips and ``pf-holds`` (the same library call, :func:`track_holds`) runs the
transition estimator, the particle filter and the smoother (backward simulation,
with the FFBSm smoother on the same filter beside it, and the previous defaults -- the paper's
noise model: white magnetometer noise, every grip sample counted -- for the before/after).  The filter keeps one stratum of
particles per start hold until their tracks meet on a hold (``PFParams.separate_starts``);
"wrong start hold" compares the smoother's hold at the first detected grip with the
simulated start hold.  Errors are the 3-D
distances to the true sensor position at every IMU sample from the first detected grip to
the end of the trial, pooled over all trials (the paper pools its sparse optical truth).
Transition-only integrates the transition velocities from the true position at the first
grip (as the paper's implementation starts it at the first optical-truth sample).

The seeds (1000-1049) are disjoint from the ones the PF defaults were chosen on (0-23),
the start-hold strata on (0-99, 2000-2199) and the magnetometer-disturbance and grip-count
defaults on (0-99, 2000-2199, 3000-3099).

Model mismatch (issue 39): the simulator is written apart from the estimators (no import of their SO(3)
or hold code; ``tests/test_layout.py``) and ``simulate boulder --variant`` changes one aspect of its world
at a time (a steel wall, big holds, long rests, wall grips, slaps, a poorer unit, a large hand).  Every
variant was held out: the defaults were chosen on the nominal world only (the seeds above); each variant is
scored on its own held-out seeds (4000-40xx), beside the nominal world on the same seeds.

Run: ``python bench/bench_climbing.py [TRIALS] [VARIANT_TRIALS]`` (accuracy on every CPU core; the speed
figure on one core, BLAS limited to one thread).
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import sys  # noqa: E402
import time  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402

import numpy as np  # noqa: E402

PAPER = {  # Table I: 25 % quantile, median, 75 % quantile, RMSE, max [m]
    "Transition-Only": (0.125, 0.266, 0.542, 0.571, 13.013),
    "PF": (0.108, 0.145, 0.320, 0.444, 4.170),
    "PF smoother": (0.101, 0.133, 0.233, 0.413, 4.170),
}
SEED0 = 1000


def _pipeline(seed: int, duration: float | None = None, imu_rate: float = 100.0, variant: str = "nominal") -> tuple:
    from sportfusion.climbing.grips import grip_columns
    from sportfusion.climbing.holds import validate
    from sportfusion.climbing.sim import BoulderConfig, simulate_boulder
    from sportfusion.climbing.track import track_holds
    from sportfusion.core.session import with_columns

    sim = simulate_boulder(BoulderConfig(seed=seed, duration=duration, imu_rate=imu_rate, variant=variant))
    holds = validate(sim.holds, sim.holds_meta)
    t0 = time.perf_counter()
    cols, _ = grip_columns(sim.session)
    t1 = time.perf_counter()
    table = with_columns(sim.session, cols)
    t2 = time.perf_counter()
    tr = track_holds(table, sim.meta, holds)
    t3 = time.perf_counter()
    return sim, cols, tr, (t1 - t0, t3 - t2), (table, holds)


def one(seed: int) -> dict:
    from sportfusion.climbing.particles import PFParams
    from sportfusion.climbing.track import TrackOptions, track_holds
    from sportfusion.climbing.transition import TransitionParams, integrate
    from sportfusion.core import schema

    sim, cols, tr, _, (table, holds) = _pipeline(seed)
    # the same trial and PF seed smoothed by FFBSm (O(M^2), the paper's smoother) for the before/after
    ref = track_holds(table, sim.meta, holds, TrackOptions(pf=PFParams(smoother="ffbsm")))
    # and with the previous defaults (the paper's noise model: white magnetometer noise, every grip sample
    # counted) for the before/after
    prev_opts = TrackOptions(pf=PFParams(grip_count=None), transition=TransitionParams(mag_disturbance=0.0))
    prev = track_holds(table, sim.meta, holds, prev_opts)
    rows = tr.rows
    t = schema.floats(sim.session, "t")[rows]
    p_true = np.column_stack([schema.floats(sim.truth, f"true_{a}") for a in "xyz"])[rows]
    k0 = tr.pf.k0
    p_tr = integrate(t, tr.transition.velocity, p_true[k0], k0)
    p_tr_prev = integrate(t, prev.transition.velocity, p_true[k0], k0)
    err = {
        name: np.linalg.norm(p - p_true, axis=1)[k0:]
        for name, p in (
            ("Transition-Only", p_tr),
            ("PF", tr.pf.pos),
            ("PF smoother", tr.pf.smooth_pos),
            ("FFBSm smoother", ref.pf.smooth_pos),
            ("previous smoother", prev.pf.smooth_pos),
            ("previous transition-only", p_tr_prev),
        )
    }
    true_hold = np.asarray(sim.truth.column("true_hold").fill_null(-2).to_numpy(), dtype=int)[rows][k0:]
    true_grip = sim.truth.column("true_grip").to_numpy(zero_copy_only=False)[rows][k0:]
    meta = sim.truth_meta["climbing"]
    return {
        "seed": seed,
        "err": err,
        "wall": (true_grip & (true_hold == -1)),
        "start_ok": int(tr.pf.smooth_label[k0]) == meta["start_hold"],
        "start_ok_prev": int(prev.pf.smooth_label[prev.pf.k0]) == meta["start_hold"],
        "saturated": bool(cols["imu_saturated"].to_numpy(zero_copy_only=False).any()),
        "wall_grips": meta["wall_grips"],
        "duration": float(t[-1] - t[0]),
    }


VARIANT_SEED0 = 4000


def variant_one(args: tuple[int, str]) -> dict:
    """One held-out trial of a variant: the default pipeline's smoother and transition-only errors."""
    from sportfusion.climbing.transition import integrate
    from sportfusion.core import schema

    seed, variant = args
    sim, cols, tr, _, _ = _pipeline(seed, variant=variant)
    rows = tr.rows
    t = schema.floats(sim.session, "t")[rows]
    p_true = np.column_stack([schema.floats(sim.truth, f"true_{a}") for a in "xyz"])[rows]
    k0 = tr.pf.k0
    p_tr = integrate(t, tr.transition.velocity, p_true[k0], k0)
    return {
        "variant": variant,
        "smoother": np.linalg.norm(tr.pf.smooth_pos - p_true, axis=1)[k0:],
        "transition": np.linalg.norm(p_tr - p_true, axis=1)[k0:],
        "start_ok": int(tr.pf.smooth_label[k0]) == sim.truth_meta["climbing"]["start_hold"],
    }


def report_variants(n: int) -> None:
    from sportfusion.climbing.sim import VARIANTS

    tasks = [(VARIANT_SEED0 + i, v) for v in VARIANTS for i in range(n)]
    with ProcessPoolExecutor(max_workers=os.cpu_count()) as ex:
        rows = list(ex.map(variant_one, tasks))
    print(
        f"\nModel-mismatch variants ({n} held-out trials each, seeds {VARIANT_SEED0}-{VARIANT_SEED0 + n - 1}; "
        "defaults chosen on the nominal world only) [m]"
    )
    print(
        f"{'variant':11s} {'smoother median':>15s} {'RMSE':>7s} {'75% Qtl.':>8s} {'transition median':>17s} {'wrong start':>11s}"
    )
    for v in VARIANTS:
        rs = [r for r in rows if r["variant"] == v]
        e = np.concatenate([r["smoother"] for r in rs])
        et = np.concatenate([r["transition"] for r in rs])
        print(
            f"{v:11s} {np.median(e):15.3f} {np.sqrt(np.mean(e**2)):7.3f} {np.percentile(e, 75):8.3f} "
            f"{np.median(et):17.3f} {sum(not r['start_ok'] for r in rs):>8d}/{len(rs)}"
        )
    print(
        f"{'paper':11s} {PAPER['PF smoother'][1]:15.3f} {PAPER['PF smoother'][3]:7.3f} {PAPER['PF smoother'][2]:8.3f} {PAPER['Transition-Only'][1]:17.3f}"
    )


def stats(e: np.ndarray) -> tuple[float, ...]:
    q25, q50, q75 = np.percentile(e, [25, 50, 75])
    return q25, q50, q75, float(np.sqrt(np.mean(e**2))), float(e.max())


def report(rows: list[dict]) -> None:
    print(f"\nAccuracy over {len(rows)} simulated trials (errors [m], every IMU sample after the first grip)")
    print(f"{'':18s}{'25% Qtl.':>10s}{'Median':>10s}{'75% Qtl.':>10s}{'RMSE':>10s}{'Max':>10s}")
    meds, rmses = {}, {}
    for name, paper in PAPER.items():
        e = np.concatenate([r["err"][name] for r in rows])
        s = stats(e)
        meds[name], rmses[name] = s[1], s[3]
        print(f"{name + ' (ours)':18s}" + "".join(f"{v:10.3f}" for v in s))
        print(f"{name + ' (paper)':18s}" + "".join(f"{v:10.3f}" for v in paper))
    e = np.concatenate([r["err"]["FFBSm smoother"] for r in rows])
    print(f"{'FFBSm smoother':18s}" + "".join(f"{v:10.3f}" for v in stats(e)) + "   (O(M^2) reference, same PF)")
    per_trial = [(np.median(r["err"]["PF smoother"]), np.median(r["err"]["FFBSm smoother"])) for r in rows]
    bs, ff = np.array(per_trial).T
    print(
        f"PF smoother = backward simulation (O(M)); per-trial medians: backward {np.median(bs):.3f} m, "
        f"FFBSm {np.median(ff):.3f} m (median of trial medians), backward better in {int(np.sum(bs < ff))}/{len(rows)}"
    )
    names = ("Transition-Only", "PF", "PF smoother")
    order = meds[names[0]] > meds[names[1]] > meds[names[2]]
    order_rmse = rmses[names[0]] > rmses[names[1]] > rmses[names[2]]
    print(
        f"\nordering transition-only > PF > PF smoother: medians {'yes' if order else 'NO'}, "
        f"RMSE {'yes' if order_rmse else 'NO'}; PF smoother median {meds['PF smoother']:.3f} m (target <= 0.133)\n"
        "  (transition-only starts from the true position at the first grip, which a user does not have; with the\n"
        "  magnetometer disturbance modelled its local error can be below the PF's, whose positions at a grip spread\n"
        "  within the hold model's 0.10 m ball)"
    )
    # failure cases
    bad_start = [r for r in rows if not r["start_ok"]]
    print("\nFailure cases (PF smoother):")
    e_bad = np.concatenate([r["err"]["PF smoother"] for r in bad_start]) if bad_start else np.zeros(1)
    e_good = np.concatenate([r["err"]["PF smoother"] for r in rows if r["start_ok"]])
    print(
        f"  wrong start hold: {len(bad_start)}/{len(rows)} trials, median {np.median(e_bad):.3f} m "
        f"(right start: median {np.median(e_good):.3f} m)"
    )
    e_prev = np.concatenate([r["err"]["previous smoother"] for r in rows])
    e_prev_tr = np.concatenate([r["err"]["previous transition-only"] for r in rows])
    print(
        f"  previous defaults (the paper's noise model: white magnetometer noise, every grip sample counted; "
        f"same trials and seed): wrong start hold {sum(not r['start_ok_prev'] for r in rows)}/{len(rows)} "
        f"(issue 19 target: <= 1/50), smoother median {np.median(e_prev):.3f} m, "
        f"RMSE {np.sqrt(np.mean(e_prev**2)):.3f} m, max {e_prev.max():.3f} m; transition-only median "
        f"{np.median(e_prev_tr):.3f} m, RMSE {np.sqrt(np.mean(e_prev_tr**2)):.3f} m"
    )
    wall = np.concatenate([r["err"]["PF smoother"][r["wall"]] for r in rows])
    hold = np.concatenate([r["err"]["PF smoother"][~r["wall"]] for r in rows])
    n_wall = sum(1 for r in rows if r["wall_grips"])
    print(
        f"  wall grips: {n_wall} trials with {sum(r['wall_grips'] for r in rows)} wall grips; error at wall-grip "
        f"samples median {np.median(wall) if wall.size else float('nan'):.3f} m vs elsewhere {np.median(hold):.3f} m"
    )
    for label, sel in (("with", True), ("without", False)):
        es = [r["err"]["PF smoother"] for r in rows if r["saturated"] == sel]
        if es:
            s = stats(np.concatenate(es))
            print(f"  trials {label} range violations ({len(es)}): median {s[1]:.3f} m, RMSE {s[3]:.3f} m")
    lost = [r for r in rows if np.median(r["err"]["Transition-Only"]) > 1.0]
    print(
        f"  transition estimate lost (transition-only median > 1 m): {len(lost)}/{len(rows)} trials"
        + (": seeds " + ", ".join(str(r["seed"]) for r in lost) if lost else "")
    )
    worst = sorted(rows, key=lambda r: -np.median(r["err"]["PF smoother"]))[:5]
    print(
        "  worst trials (seed: smoother median [m], start ok, wall grips): "
        + ", ".join(
            f"{r['seed']}: {np.median(r['err']['PF smoother']):.2f} {'y' if r['start_ok'] else 'n'} {r['wall_grips']}"
            for r in worst
        )
    )


def speed() -> None:
    from sportfusion.climbing.grips import grip_columns
    from sportfusion.climbing.holds import validate
    from sportfusion.climbing.particles import PFParams, run_particle_filter
    from sportfusion.climbing.transition import estimate_transitions
    from sportfusion.core import schema

    sim, cols, tr, (t_grip, t_track), _ = _pipeline(SEED0 + 7, duration=60.0, imu_rate=100.0)
    n = int(tr.rows.sum())
    # the stages one by one: transition estimator, PF alone, PF + smoother
    hm = validate(sim.holds, sim.holds_meta)
    s = sim.session

    def xyz(p: str) -> np.ndarray:
        return np.column_stack([schema.floats(s, f"{p}_{a}") for a in "xyz"])

    cols, _ = grip_columns(s)
    grip = cols["grip"].to_numpy(zero_copy_only=False)
    sat = cols["imu_saturated"].to_numpy(zero_copy_only=False)
    a = time.perf_counter()
    res = estimate_transitions(
        schema.floats(s, "t"), xyz("acc"), xyz("gyr"), xyz("mag"), grip, hm.magnetic_field, -hm.gravity * hm.up, sat
    )
    b = time.perf_counter()
    args = (
        schema.floats(s, "t"),
        res.velocity,
        res.velocity_cov,
        grip,
        hm.route_holds(tr.route),
        hm.start_positions(tr.route),
        hm.up,
        hm.wall_holds(),
        tr.descent_time,
    )
    run_particle_filter(*args, smooth=False)
    c = time.perf_counter()
    run_particle_filter(*args, smooth=True)
    d = time.perf_counter()
    # the smoothers alone, CPU time, 200 and 800 particles: backward simulation vs FFBSm, same run
    smoother_cpu = {}
    for m in (200, 800):
        for name in ("backward", "ffbsm"):
            pp = PFParams(particles=m, smoother=name)
            c0 = time.process_time()
            run_particle_filter(*args, params=pp, smooth=False)
            c1 = time.process_time()
            run_particle_filter(*args, params=pp, smooth=True)
            c2 = time.process_time()
            smoother_cpu[m, name] = ((c2 - c1) - (c1 - c0)) / n * 1e6
    print(f"\nSpeed: one trial of {n / 100:.0f} s at 100 Hz ({n} samples), one core")
    print(f"  grip detection          {t_grip:6.2f} s")
    print(f"  transition estimator    {b - a:6.2f} s  ({res.iterations} iterations)")
    print(f"  particle filter (200)   {c - b:6.2f} s  ({(c - b) / n * 1e6:.0f} us/step; DESIGN: ~69 us/step numpy)")
    smooth = (d - c) - (c - b)
    print(f"  PF + smoother           {d - c:6.2f} s  (smoother {smooth / n * 1e6:.0f} us/step wall)")
    for m in (200, 800):
        bw, ff = smoother_cpu[m, "backward"], smoother_cpu[m, "ffbsm"]
        print(
            f"  smoother CPU, {m} particles: backward simulation {bw:.0f} us/step, FFBSm {ff:.0f} us/step "
            f"(x{ff / bw:.1f}; target backward <= 150 us/step at 200)"
        )
    print(f"  end to end (grips + estimator + PF + smoother) {t_grip + t_track:6.2f} s  (issue: < 10 s)")


def main() -> None:
    trials = int(sys.argv[1]) if len(sys.argv) > 1 else 50
    n_variant = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    seeds = list(range(SEED0, SEED0 + trials))
    t0 = time.time()
    with ProcessPoolExecutor(max_workers=os.cpu_count()) as ex:
        rows = list(ex.map(one, seeds))
    print(f"{trials} trials in {time.time() - t0:.0f} s on {os.cpu_count()} cores")
    report(rows)
    report_variants(n_variant)
    speed()


if __name__ == "__main__":
    main()
