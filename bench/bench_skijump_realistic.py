"""rts-smooth on jumps with what real recordings have and the paper's simulator lacks (issue 19).

``simulate skijump`` with, on top of the paper's noise (Tables 3-5):

* a GNSS antenna away from the IMU: lever arm (0.1, 0.3, -0.5) m in the body frame (a logger on the
  back or helmet, the phone on the arm);
* a slowly varying GNSS height error: first-order Gauss-Markov, 0.8 m, 30 s;
* GNSS latency: the fix stamped t describes t - 0.1 s;
* wind in flight: 1 m/s headwind with 1.5 m/s sinusoidal gusts (period 0.8-2.5 s).

The simulator's landing already has the sensor (on the arm) decimetres above the snow at the skis'
touch-down and an impact pulse that sets it onto the slope.

Configurations, each on the same jumps:

* ``previous``: main at c35b19f's smoother (rest-QUEST start, 3 re-linearisation passes over the start, no
  latency estimate, the lever arm unknown to the smoother), on today's touch-down detection (the landing
  impact's onset; with the sub-sample peak minus 0.05 s its jump length RMS was 0.331 m, on the sample 0.341 m);
* ``ours``: the default (in-run alignment, GNSS latency estimated from the first pass and removed, a
  second estimate when one was found, zero-velocity updates where the athlete stands still) with the
  lever arm given (``SmootherConfig.lever_arm``);
* ``ours, no ZUPT``: the same without the zero-velocity updates (the default before them);
* ``ours, no lever``: the same without telling the smoother the lever arm.

Figures: 3-D position RMS and velocity RMS per jump against the truth (median over jumps), jump length RMS
over jumps (``jump-metrics``), beside the paper's Table 6 (3-D of its x, y, z medians) and the issue's
targets (3-D <= 0.12 m, jump length <= 0.25 m).  Seeds 4000-4019 are held out: the latency threshold and
search span were set on seeds 3000-3011 (``--seed0 3000 --n 12`` reproduces that run), the zero-velocity
update's noise (``r_zupt``) on seeds 3000-3029.

Run: ``python bench/bench_skijump_realistic.py [--n 20] [--seed0 4000] [--jobs 2]``.
"""

from __future__ import annotations

import argparse
import math
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np

SIM = {"lever_arm": (0.1, 0.3, -0.5), "height_error": (0.8, 30.0), "gnss_latency": 0.1, "wind": (1.0, 1.5)}
PAPER_3D = math.sqrt(0.159**2 + 0.123**2 + 0.109**2)  # Table 6 x, y, z medians as one 3-D figure
TARGET = {"pos3": 0.12, "jump": 0.25}
CONFIGS = ("previous", "ours, no ZUPT", "ours", "ours, no lever")


def one(seed: int) -> dict:
    from sportfusion.core.schema import floats
    from sportfusion.evaluate import errors
    from sportfusion.skijump.events import detect_jump_table
    from sportfusion.skijump.hillfile import load_hill
    from sportfusion.skijump.metrics import jump_metrics
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump
    from sportfusion.skijump.smoother import rts_smooth_table
    from sportfusion.skijump.smoother_inputs import SmootherConfig

    hill = load_hill("oberstdorf_hs106")
    sim = simulate_skijump(hill, SkiJumpConfig(seed=seed, physics="paper", **SIM))  # issue 19's world
    az = sim.session_meta["frame"]["azimuth_deg"]
    det = detect_jump_table(sim.session)
    tt = sim.truth_meta["skijump"]["times"]
    if len(det.jumps) == 1:
        to, td = [det.jumps[0].takeoff], [det.jumps[0].touchdown]
    else:  # the detector missed: the truth's events, so that the smoother is still measured
        to, td = [tt["takeoff"]], [tt["touchdown"]]
    cfgs = {
        "previous": SmootherConfig(inrun_align=False, passes=4, estimate_latency=False, zupt=False),
        "ours, no ZUPT": SmootherConfig(lever_arm=SIM["lever_arm"], zupt=False),
        "ours": SmootherConfig(lever_arm=SIM["lever_arm"]),
        "ours, no lever": SmootherConfig(),
    }
    out: dict = {"seed": seed}
    for name, cfg in cfgs.items():
        est, meta, _ = rts_smooth_table(sim.session, sim.session_meta, hill, cfg, takeoff=to, touchdown=td)
        e = errors(est, sim.truth, az, velocity_frame="ned")[2]
        t = floats(est, "t")
        pos = np.stack([floats(est, c) for c in "xyz"], -1)
        vel = np.stack([floats(est, c) for c in ("vx", "vy", "vz")], -1)
        jl = jump_metrics(t, pos, vel, list(zip(to, td, strict=True)), hill)[0]["jump_length"]
        out[name] = {
            "pos3": math.sqrt(np.nanmean(e["x"] ** 2 + e["y"] ** 2 + e["z"] ** 2)),
            "vel": math.sqrt(np.nanmean(e["vel_n"] ** 2 + e["vel_e"] ** 2 + e["vel_d"] ** 2)),
            "jump": jl - sim.truth_meta["jump_length"],
            "latency": (meta["rts"].get("gnss_latency_s") or [None])[0],
        }
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="jumps [count]")
    ap.add_argument("--seed0", type=int, default=4000, help="first seed (4000..: held out)")
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="worker processes")
    a = ap.parse_args()
    seeds = list(range(a.seed0, a.seed0 + a.n))
    with ProcessPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(one, seeds))
    print(f"rts-smooth on {a.n} realistic-style jumps (seeds {seeds[0]}..{seeds[-1]}), Oberstdorf HS106:")
    print(
        f"  lever arm {SIM['lever_arm']} m, GNSS height Gauss-Markov {SIM['height_error']}, latency {SIM['gnss_latency']} s"
    )
    print(f"  {'':28s} {'3-D pos [m]':>12s} {'vel [m/s]':>10s} {'jump len [m]':>13s}")
    print(f"  {'paper (Table 6; Table 7)':28s} {PAPER_3D:12.3f} {'-':>10s} {'1.0 (video)':>13s}")
    print(f"  {'issue 19 target':28s} {TARGET['pos3']:12.2f} {'-':>10s} {TARGET['jump']:13.2f}")
    for name in CONFIGS:
        p3 = np.median([r[name]["pos3"] for r in rows])
        v = np.median([r[name]["vel"] for r in rows])
        jl = math.sqrt(np.mean([r[name]["jump"] ** 2 for r in rows]))
        print(f"  {name:28s} {p3:12.3f} {v:10.3f} {jl:13.3f}")
    lat = [r["ours"]["latency"] for r in rows if r["ours"]["latency"] is not None]
    if lat:
        print(
            f"  latency found: median {np.median(lat):.3f} s (true {SIM['gnss_latency']} s), "
            f"range {min(lat):.3f}..{max(lat):.3f} s, {len(lat)}/{len(rows)} jumps"
        )
    print("  3-D position and velocity: median over jumps of the per-jump RMS; jump length: RMS over jumps")


if __name__ == "__main__":
    main()
