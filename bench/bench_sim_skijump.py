"""simulate skijump: is the truth kinematically exact and on the hill, on every shipped hill?

For every shipped hill and a few seeds, ``simulate_skijump`` makes a jump and
the noise-free truth IMU (``true_gyr_* true_acc_*``, 100 Hz) is integrated with
the smoother's own scheme (:func:`sportfusion.skijump.kinematics.propagate`:
RK4 with linearly interpolated inputs, eqs 44-46 with the errata sign) from the
true initial state.  Printed per jump: the largest position drift over the whole
session (gate, in-run, flight, landing, out-run, stop, rest) and attitude drift,
the largest distance of the truth from the in-run profile before the take-off
and from the landing profile once the arm has settled, the arm's height above
the slope at the touch-down and the settling time.

Targets (issue 4): drift < 5 cm over the whole jump; truth on the profiles
< 1 mm.  Hills without a surveyed site get an arbitrary one (the site only sets
gravity, air density and the magnetic field).

Run: ``python bench/bench_sim_skijump.py [--seeds N]`` (default 3 seeds; uses every CPU core).
"""

from __future__ import annotations

import argparse
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

SITE = {"lat": "47.0", "lon": "11.0", "height": "1000", "azimuth_deg": "45"}


def one(job: tuple[str, int]) -> dict:
    from sportfusion.core import rotations, schema
    from sportfusion.skijump import kinematics as kin
    from sportfusion.skijump.hillfile import load_hill
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

    name, seed = job
    hill = load_hill(name)
    if not hill.has_origin:
        hill = load_hill(name, SITE)
    sim = simulate_skijump(
        hill, SkiJumpConfig(seed=seed, physics="paper")
    )  # the paper's world (issue 39: bench_skijump_independent for the full physics)
    tr, meta = sim.truth, sim.truth_meta

    def cols(*names: str) -> np.ndarray:
        return np.stack([schema.floats(tr, n) for n in names], axis=-1)

    t = schema.floats(tr, "t")
    q = cols("true_q0", "true_q1", "true_q2", "true_q3")
    u = cols("true_gyr_x", "true_gyr_y", "true_gyr_z", "true_acc_x", "true_acc_y", "true_acc_z")
    r = cols("true_x", "true_y", "true_z")
    x0 = kin.state_from_nav(r[0], cols("true_vel_n", "true_vel_e", "true_vel_d")[0], q[0])
    x = kin.propagate(x0, t, u, meta["skijump"]["gravity"], math.radians(meta["frame"]["azimuth_deg"]))
    times, prof = meta["skijump"]["times"], hill.profile
    inrun, landed = t <= times["takeoff"], t >= times["settled"]
    k_td = int(round(times["touchdown"] * 100))
    return {
        "hill": name,
        "seed": seed,
        "hs": prof.cert.hS,
        "length": meta["jump_length"],
        "drift": float(np.linalg.norm(x[:, :3] - r, axis=1).max()),
        "att": float(np.degrees(rotations.quat_angle(x[:, 6:], q).max())),
        "inrun": float(np.abs(r[inrun, 2] - prof.z_inrun(r[inrun, 0], extend=True)).max()),
        "landed": float(np.abs(r[landed, 2] - prof.z_landing(r[landed, 0])).max()),
        "clearance": float(schema.floats(tr, "true_clearance")[k_td]),
        "settle": times["settled"] - times["touchdown"],
    }


def main() -> None:
    from sportfusion.skijump.hillfile import shipped_hills

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3, help="seeds per hill [count]")
    args = ap.parse_args()
    jobs = [(h, s) for h in shipped_hills() for s in range(args.seeds)]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        rows = list(pool.map(one, jobs))
    print(f"truth IMU vs truth trajectory, {len(rows)} simulated jumps, {time.perf_counter() - t0:.0f} s")
    print("targets: drift < 5 cm over the session; truth within 1 mm of the in-run / landing profile\n")
    head = f"{'hill':<21}{'seed':>5}{'L [m]':>8}{'drift [cm]':>11}{'att [deg]':>10}"
    head += f"{'in-run [mm]':>12}{'landed [mm]':>12}{'TD height [m]':>14}{'settle [s]':>11}"
    print(head)
    for r in rows:
        print(
            f"{r['hill']:<21}{r['seed']:>5}{r['length']:>8.1f}{100 * r['drift']:>11.2f}{r['att']:>10.4f}"
            f"{1e3 * r['inrun']:>12.3f}{1e3 * r['landed']:>12.3f}{r['clearance']:>14.2f}{r['settle']:>11.2f}"
        )
    d = np.array([r["drift"] for r in rows])
    prof = np.array([max(r["inrun"], r["landed"]) for r in rows])
    print(
        f"\ndrift: median {100 * np.median(d):.2f} cm, max {100 * d.max():.2f} cm (target < 5 cm: "
        f"{'met' if d.max() < 0.05 else 'NOT met'}); profile distance max {1e3 * prof.max():.3f} mm "
        f"(target < 1 mm: {'met' if prof.max() < 1e-3 else 'NOT met'})"
    )


if __name__ == "__main__":
    main()
