"""Error budget of the ski-jump smoother on the independent simulator: which error source limits 3-D position.

Runs bench_skijump_independent's pipeline on the nominal world and on worlds with one error source removed
(GNSS drift, all GNSS error, all IMU error), held-out seeds, and prints the median per-axis RMS.
"""

from __future__ import annotations

import math
import os
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import bench_skijump_independent as b  # noqa: E402

from sportfusion.skijump.sim import sensors  # noqa: E402

EXTRA = {
    "no-gnss-drift": {"gm_h": (0.0, 60.0), "gm_v": (0.0, 60.0)},
    "gnss-ideal": {
        "gm_h": (0.0, 60.0),
        "gm_v": (0.0, 60.0),
        "white_h": 0.0,
        "white_v": 0.0,
        "multipath_rate": 0.0,
        "outlier_prob": 0.0,
        "latency": 0.0,
        "vel_white": (0.0, 0.0, 0.0),
    },
    "imu-ideal": {
        "acc_noise_density": 0.0,
        "acc_bias": 0.0,
        "acc_scale": 0.0,
        "acc_misalign": 0.0,
        "acc_tempco": 0.0,
        "gyr_noise_density": 0.0,
        "gyr_bias": 0.0,
        "gyr_scale": 0.0,
        "gyr_misalign": 0.0,
        "gyr_tempco": 0.0,
        "gyr_gsens": 0.0,
        "chatter_inrun": 0.0,
        "chatter_outrun": 0.0,
        "flutter": 0.0,
        "chatter_gyr": 0.0,
    },
    "no-lever": {"antenna": (0.0, 0.0, 0.0), "head_bob": 0.0},
}
sensors.VARIANTS.update(EXTRA)

_orig_errors = None


def one(job):
    from sportfusion import evaluate

    captured = {}
    orig = evaluate.errors

    def spy(*a, **k):
        r = orig(*a, **k)
        captured["e"] = r[2]
        return r

    b.errors = spy  # type: ignore[attr-defined]
    import sportfusion.evaluate as ev

    ev.errors = spy
    r = b.one(job)
    ev.errors = orig
    e = captured["e"]
    for c in "xyz":
        r["rms_" + c] = math.sqrt(float(np.nanmean(e[c] ** 2)))
    return r


def main() -> None:
    names = ["nominal", *EXTRA]
    jobs = [(7000 + i, v) for v in names for i in range(8)]
    with ProcessPoolExecutor(os.cpu_count() or 1) as ex:
        rows = list(ex.map(one, jobs))
    print("variant          3-D [m]  x(along) y(lat)  z(vert) [m]  jump len RMS [m]")
    for v in names:
        rr = [r for r in rows if r["variant"] == v]
        med = {k: float(np.median([r[k] for r in rr])) for k in ("pos3", "rms_x", "rms_y", "rms_z")}
        jl = math.sqrt(float(np.mean([r["jump"] ** 2 for r in rr])))
        print(f"{v:15s} {med['pos3']:7.3f} {med['rms_x']:8.3f} {med['rms_y']:7.3f} {med['rms_z']:7.3f}   {jl:7.3f}")


if __name__ == "__main__":
    main()
