"""rts-smooth accuracy over simulated jumps, beside the ski-jumping paper's Table 6.

For each seed ``simulate skijump`` (Oberstdorf HS106, the paper's noise of
Tables 3-5: biases drawn from the priors, white noise of Tables 4-5) makes a
jump; ``detect_jump_table`` (what ``detect-events --kind jump`` runs) finds the
take-off and touch-down; the smoother runs (a) as the paper (hill constraints)
and (b) without hill constraints; GNSS alone is the raw measurement.  Per jump
the RMS error over all samples (estimate minus truth; velocity in NED, Euler
angles wrapped) is computed; the table prints the median over the jumps, and
the jump length (``jump-metrics``: foot of the normal at the detected touch-down)
as RMS over the jumps against the simulator's truth (target 0.5 m).

``--variants`` also compares how the landing constraint starts (errata: the
arm-mounted sensor settles onto the slope ~0.2 s after the touch-down):
full strength at the detected touch-down, a 0.2 s ramp (default), a 0.1 s delay.

Run: ``python bench/bench_rts_accuracy.py [--n 20] [--quick] [--variants] [--jobs 2]``.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

PAPER = {  # Table 6
    "x": 0.159,
    "y": 0.123,
    "z": 0.109,
    "vel_n": 0.021,
    "vel_e": 0.026,
    "vel_d": 0.023,
    "roll": 0.584,
    "pitch": 0.319,
    "yaw": 0.759,
}
VARS = ("x", "y", "z", "vel_n", "vel_e", "vel_d", "roll", "pitch", "yaw", "rot_angle")
ANG = ("roll", "pitch", "yaw", "rot_angle")


def _rms(e: np.ndarray) -> float:
    return float(np.sqrt(np.nanmean(np.asarray(e) ** 2)))


def one(job: tuple[int, tuple[str, ...]]) -> dict:
    import pyarrow as pa

    from sportfusion.core.frames import gnss_local_columns
    from sportfusion.core.schema import floats
    from sportfusion.evaluate import errors
    from sportfusion.skijump.events import detect_jump_table
    from sportfusion.skijump.hillfile import load_hill
    from sportfusion.skijump.metrics import jump_metrics
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump
    from sportfusion.skijump.smoother import rts_smooth_table
    from sportfusion.skijump.smoother_inputs import SmootherConfig

    seed, variants = job
    hill = load_hill("oberstdorf_hs106")
    sim = simulate_skijump(
        hill, SkiJumpConfig(seed=seed, physics="paper")
    )  # the paper's world (issue 39: bench_skijump_independent for the full physics)
    az = sim.session_meta["frame"]["azimuth_deg"]
    det = detect_jump_table(sim.session)
    times = sim.truth_meta["skijump"]["times"]
    if len(det.jumps) == 1:
        to, td = [det.jumps[0].takeoff], [det.jumps[0].touchdown]
    else:  # the detector missed: use the truth so that the smoother is still measured
        to, td = [times["takeoff"]], [times["touchdown"]]
    out = {"seed": seed, "detected": len(det.jumps) == 1, "dt_td": td[0] - times["touchdown"]}
    configs = {"rts": SmootherConfig(), "nohill": SmootherConfig(hill_constraints=False)}
    if "init" in variants:  # the start: the previous default (no in-run alignment, 3 passes over the start's
        # window + the whole) vs the in-run alignment with fewer passes
        configs["prev_c35b19f"] = SmootherConfig(inrun_align=False, passes=4)
        configs["passes3"] = SmootherConfig(passes=3)
        configs["one_pass"] = SmootherConfig(passes=1)
        configs["from_gate"] = SmootherConfig(start_after_rest=False)  # the forward start's run from step 0
    if "variants" in variants:
        configs["la_full"] = SmootherConfig(la_ramp=0.0)
        configs["la_delay"] = SmootherConfig(la_ramp=0.0, la_delay=0.1)
        configs["la_ramp_delay"] = SmootherConfig(la_ramp=0.2, la_delay=0.05)
    for name, cfg in configs.items():
        t0 = time.perf_counter()
        est, _, _ = rts_smooth_table(sim.session, sim.session_meta, hill, cfg, takeoff=to, touchdown=td)
        out[f"{name}_time"] = time.perf_counter() - t0
        err = errors(est, sim.truth, az, velocity_frame="ned")[2]  # Table 6: v_O in NED
        out[name] = {k: _rms(v) * (180 / math.pi if k in ANG else 1.0) for k, v in err.items()}
        t = floats(est, "t")
        pos = np.stack([floats(est, c) for c in ("x", "y", "z")], -1)
        vel = np.stack([floats(est, c) for c in ("vx", "vy", "vz")], -1)
        jl = jump_metrics(t, pos, vel, list(zip(to, td, strict=True)), hill)[0]["jump_length"]
        out[name]["jump_length"] = jl - sim.truth_meta["jump_length"]
    g = gnss_local_columns(sim.session, hill.frame())
    tab = sim.session
    for c in ("gnss_x", "gnss_y", "gnss_z"):
        tab = tab.append_column(c, pa.array(g[c]))
    gerr = errors(tab, sim.truth, az, gnss=True, velocity_frame="ned")[2]
    out["gnss"] = {k: _rms(v) for k, v in gerr.items()}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="number of simulated jumps (seeds 0..n-1)")
    ap.add_argument("--quick", action="store_true", help="5 jumps")
    ap.add_argument("--variants", action="store_true", help="also compare landing-constraint start variants")
    ap.add_argument(
        "--init",
        action="store_true",
        help="also run the previous start (rest QUEST heading, 3 re-linearisation passes over the in-run window "
        "then the whole segment), 3 passes, a single pass and the forward start's run from the segment's first "
        "step instead of the rest's end, beside the default (in-run alignment, passes=2)",
    )
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="worker processes")
    a = ap.parse_args()
    n = 5 if a.quick else a.n
    t0 = time.perf_counter()
    flags = (("variants",) if a.variants else ()) + (("init",) if a.init else ())
    jobs = [(s, flags) for s in range(n)]
    if a.jobs > 1:
        with ProcessPoolExecutor(a.jobs) as ex:
            rows = list(ex.map(one, jobs))
    else:
        rows = [one(j) for j in jobs]
    wall = time.perf_counter() - t0
    names = ["rts", "nohill"] + (["prev_c35b19f", "passes3", "one_pass", "from_gate"] if a.init else [])
    names += ["la_full", "la_delay", "la_ramp_delay"] if a.variants else []
    print(f"rts-smooth accuracy: {n} simulated jumps on Oberstdorf HS106, paper noise (Tables 3-5)")
    print(
        f"touch-down detected in {sum(r['detected'] for r in rows)}/{n} jumps; "
        f"detected minus true touch-down: median {np.median([r['dt_td'] for r in rows]):+.3f} s"
    )
    head = f"{'median RMS':<14}{'paper T6':>9}{'GNSS':>9}" + "".join(f"{k:>14}" for k in names)
    print(head)
    for v in VARS:
        unit = "deg" if v in ANG else ("m/s" if v.startswith("vel") else "m")
        paper = f"{PAPER[v]:9.3f}" if v in PAPER else f"{'-':>9}"
        gn = [r["gnss"].get(v, np.nan) for r in rows]
        gtxt = f"{np.median(gn):9.3f}" if np.isfinite(gn).any() else f"{'-':>9}"
        cells = "".join(f"{np.median([r[k][v] for r in rows]):14.3f}" for k in names)
        print(f"{v + ' [' + unit + ']':<14}{paper}{gtxt}{cells}")
    cells = "".join(f"{math.sqrt(np.mean([r[k]['jump_length'] ** 2 for r in rows])):14.3f}" for k in names)
    print(f"{'jump len RMS':<14}{'0.5*':>9}{'-':>9}{cells}")
    cells = "".join(f"{np.median([r[k + '_time'] for r in rows]):14.2f}" for k in names)
    print(f"{'time/jump [s]':<14}{'':>9}{'':>9}{cells}")
    print("* issue target (the paper's Table 7 reports 1.0 m RMS against video on real jumps)")
    better = [v for v in PAPER if np.median([r["rts"][v] for r in rows]) <= PAPER[v]]
    print(f"at or below Table 6: {len(better)}/9 ({', '.join(better)}); wall {wall:.1f} s with {a.jobs} process(es)")


if __name__ == "__main__":
    sys.exit(main())
