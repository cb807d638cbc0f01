"""rts-smooth + jump-metrics on a world the smoother does not model (issue 39): the independent simulator.

``simulate skijump`` (``physics="full"``, :mod:`sportfusion.skijump.sim.sensors`) builds each jump on a
1 kHz grid and senses it as the hardware does: scale errors, misalignment, temperature-driven biases,
g-sensitivity, a 41 Hz anti-aliasing filter, quantisation, ski chatter and landing ringing; a magnetometer
with soft iron, a site anomaly and steel in the take-off table; a helmet antenna whose lever arm turns with
the arm, 0.08 s of GNSS latency, GNSS epochs off the IMU's clock, slow Gauss-Markov drift, multipath
episodes and wild fixes.  None of it is in the smoother's model (skijump eqs 35-39).  Each variant makes one
effect strong (:data:`sportfusion.skijump.sim.sensors.VARIANTS`).

Per variant and seed: ``detect_jump_table`` (detect-events --kind jump), ``rts_smooth_table`` with the
defaults (rts-smooth: nothing about the simulated hardware is given to it), ``jump_metrics`` (jump-metrics).
Printed per variant: the 3-D position RMS and velocity RMS per jump (median over jumps), the jump length
RMS over jumps, the touch-down time error RMS [ms], jumps detected; beside the paper's Table 6 (3-D of its
x, y, z figures; velocity 3-D of its NED figures), Table 7 and the issue's targets (3-D <= 0.12 m, jump
length <= 0.25 m).

Tuning and scoring are kept apart: the defaults that issue 39 changed were chosen on the tuning variants
(:data:`sportfusion.skijump.sim.sensors.TUNING`) and seeds 6000-6007; the figures that count are the
held-out variants (:data:`HELD_OUT`) and all variants on seeds 7000-7007 (``--set held-out``, the
default).  ``--set tuning`` reproduces the tuning runs.

Run: ``python bench/bench_skijump_independent.py [--set held-out|tuning] [--n 8] [--variants a,b]
[--jobs 2]`` (about 20 s per jump and process).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

PAPER_3D = math.sqrt(0.159**2 + 0.123**2 + 0.109**2)  # Table 6 x, y, z as one 3-D figure [m]
PAPER_V3D = math.sqrt(0.021**2 + 0.026**2 + 0.023**2)  # Table 6 NED velocity as one 3-D figure [m/s]
TARGET = {"pos3": 0.12, "jump": 0.25}
SEEDS = {"tuning": 6000, "held-out": 7000}


def one(job: tuple[int, str]) -> dict:
    from sportfusion.core.schema import floats
    from sportfusion.evaluate import errors
    from sportfusion.skijump.events import detect_jump_table
    from sportfusion.skijump.hillfile import load_hill
    from sportfusion.skijump.metrics import jump_metrics
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump
    from sportfusion.skijump.smoother import rts_smooth_table

    seed, variant = job
    hill = load_hill("oberstdorf_hs106")
    sim = simulate_skijump(hill, SkiJumpConfig(seed=seed, variants=(variant,) if variant != "nominal" else ()))
    az = sim.session_meta["frame"]["azimuth_deg"]
    times = sim.truth_meta["skijump"]["times"]
    det = detect_jump_table(sim.session)
    found = len(det.jumps) == 1
    if found:
        to, td = [det.jumps[0].takeoff], [det.jumps[0].touchdown]
    else:  # missed: the truth's events, so that the smoother is still measured (and the miss counted)
        to, td = [times["takeoff"]], [times["touchdown"]]
    est, meta, _ = rts_smooth_table(sim.session, sim.session_meta, hill, takeoff=to, touchdown=td)
    e = errors(est, sim.truth, az)[2]
    t = floats(est, "t")
    pos = np.stack([floats(est, c) for c in "xyz"], -1)
    vel = np.stack([floats(est, c) for c in ("vx", "vy", "vz")], -1)
    jl = jump_metrics(t, pos, vel, list(zip(to, td, strict=True)), hill)[0]["jump_length"]
    return {
        "seed": seed,
        "variant": variant,
        "found": found,
        "pos3": math.sqrt(np.nanmean(e["x"] ** 2 + e["y"] ** 2 + e["z"] ** 2)),
        "vel": math.sqrt(np.nanmean(e["vx"] ** 2 + e["vy"] ** 2 + e["vz"] ** 2)),
        "jump": jl - sim.truth_meta["jump_length"],
        "td": td[0] - times["touchdown"],
    }


def summarise(rows: list[dict]) -> dict[str, float]:
    """Median 3-D position and velocity RMS, jump length RMS, touch-down RMS [s], detections."""
    return {
        "pos3": float(np.median([r["pos3"] for r in rows])),
        "vel": float(np.median([r["vel"] for r in rows])),
        "jump": math.sqrt(float(np.mean([r["jump"] ** 2 for r in rows]))),
        "td": math.sqrt(float(np.mean([r["td"] ** 2 for r in rows]))),
        "found": sum(r["found"] for r in rows),
        "n": len(rows),
    }


def main() -> None:
    from sportfusion.skijump.sim.sensors import HELD_OUT, TUNING, VARIANTS

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=tuple(SEEDS), default="held-out", help="seed set (and its variants' label)")
    ap.add_argument("--n", type=int, default=8, help="jumps per variant [count]")
    ap.add_argument("--seed0", type=int, default=None, help="first seed (default 7000 held-out, 6000 tuning)")
    ap.add_argument("--variants", default=None, help="comma-separated variant names (default: all)")
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="worker processes")
    a = ap.parse_args()
    n = a.n
    seed0 = a.seed0 if a.seed0 is not None else SEEDS[a.set]
    names = a.variants.split(",") if a.variants else list(VARIANTS)
    for v in names:
        if v not in VARIANTS:
            sys.exit(f"unknown variant {v!r}; expected one of {', '.join(VARIANTS)}")
    seeds = list(range(seed0, seed0 + n))
    jobs = [(s, v) for v in names for s in seeds]
    with ProcessPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(one, jobs))
    print(
        f"rts-smooth + jump-metrics on the independent simulator: {n} jumps per variant, seeds "
        f"{seeds[0]}..{seeds[-1]} ({a.set} seeds), Oberstdorf HS106, smoother defaults"
    )
    print(
        f"  {'variant':12s} {'role':9s} {'3-D pos [m]':>11s} {'vel [m/s]':>10s} {'jump len [m]':>12s} "
        f"{'TD [ms]':>8s} {'found':>6s}"
    )
    print(f"  {'paper T6/T7':22s} {PAPER_3D:11.3f} {PAPER_V3D:10.3f} {'1.0 (video)':>12s}")
    print(f"  {'issue target':22s} {TARGET['pos3']:11.2f} {'-':>10s} {TARGET['jump']:12.2f}")
    total: list[dict] = []
    for v in names:
        rr = [r for r in rows if r["variant"] == v]
        total += rr
        s = summarise(rr)
        role = "tuning" if v in TUNING else ("held-out" if v in HELD_OUT else "-")
        print(
            f"  {v:12s} {role:9s} {s['pos3']:11.3f} {s['vel']:10.3f} {s['jump']:12.3f} "
            f"{1e3 * s['td']:8.1f} {s['found']:3d}/{s['n']}"
        )
    s = summarise(total)
    print(
        f"  {'all':12s} {'':9s} {s['pos3']:11.3f} {s['vel']:10.3f} {s['jump']:12.3f} {1e3 * s['td']:8.1f} "
        f"{s['found']:3d}/{s['n']}"
    )
    print(
        "  3-D position and velocity: median over jumps of the per-jump RMS; jump length and touch-down: "
        "RMS over jumps; role: whether the variant took part in tuning the defaults (tuning seeds 6000-6007)"
    )


if __name__ == "__main__":
    main()
