"""Magnet gates as anchor points (Fasel et al. 2018) on independent physics: accuracy per model-mismatch
variant beside the nominal world and the paper's Table 1, with defaults chosen on tuning seeds and scored on
held-out seeds (issue 39).

``simulate gates`` is written apart from the estimator (its magnets are stacks of charged discs, not the
estimator's dipole; its athlete angulates and flexes, its unit has scale, misalignment and temperature
drift; stray iron, a geological anomaly...; ``lib/gates/sim.py``), and ``--variant`` changes one aspect of
that world at a time.  For every run ``detect-events --kind gates`` finds the crossings and ``gate-anchor``
(the same library calls) estimates the sacrum unit's track with the gates only (no surveyed start/finish
spots).  Figures per run, averaged over the runs of a variant:

* detected: passes within 0.5 m of a magnet (centre) found within 50 ms [%] (issue 39 target >= 95 %);
* moving: mean 3-D position error while the true speed is above 1 m/s [m] (paper Table 1: 0.24 m, the CoM
  against dGNSS; ours the sacrum unit against simulated truth);
* standing: mean 3-D error while the athlete stands at the start and at the finish [m] (target <= 0.15 m);
* silent: runs with any instant whose error exceeds 1 m and 3 times the std_ columns' norm (target 0);
* wrong ids: crossings given another gate than their own [count over the runs].

Tuning: the defaults that were chosen on this simulator (the pass fit's ``sigma_fit``, the EKS's ``q_rot``,
the alignment's costs) were chosen on seeds 1-8 of the variants nominal, wide and stray-iron
(``--tune`` prints that grid); the report below uses seeds 101-1xx (nominal, Table 1) and 401-4xx (every
variant), none of which was looked at while choosing.  Seeds 201-203 and 301-303 of the variants were
looked at once each (the standing error; a poorer unit's 1-3 % accelerometer scale error breaking the
first matching, fixed by reading gravity from the static postures) and are no longer reported.  The
variants tilted, weak, deep, flipped, mixed, two-charge, still, sensor and athlete were not used for
tuning.

Run: ``python bench/bench_gates.py [--n 12] [--n-variant 4] [--rate 50] [--quick] [--tune]``.
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import time  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402

import numpy as np  # noqa: E402

TUNE_SEEDS = range(1, 9)
TUNE_VARIANTS = ("nominal", "wide", "stray-iron")
TABLE_SEED0 = 101
VARIANT_SEED0 = 401
# Table 1 of the paper: total position and speed, accuracy (sd over runs) and precision (sd over runs)
PAPER = {
    "GS": {"position": (0.24, 0.09), "speed": (0.00, 0.18)},
    "DH": {"position": (0.34, 0.19), "speed": (0.01, 0.31)},
}
PREVIOUS = {  # the table: this suite before issue 39 on an independent simulator
    "standing": "0.54-0.68 m",
    "detected": "88 %",
    "wide": "1 of 2 runs silently off by more than 1 m",
}


def _run(args: tuple) -> dict:
    seed, variant, rate, overrides = args
    from sportfusion.core.io import survey_points
    from sportfusion.core.schema import floats
    from sportfusion.core.session import with_columns
    from sportfusion.gates.crossings import detect_gate_table, gate_columns
    from sportfusion.gates.eks import EKSParams
    from sportfusion.gates.pipeline import GateAnchorParams, gate_anchor_table
    from sportfusion.gates.sim import GatesConfig, simulate_gates

    cfg = GatesConfig(seed=seed, variant=variant, survey_spots=bool(overrides.get("spots")), **overrides.get("cfg", {}))
    s = simulate_gates(cfg)  # the spot rows are drawn after the gates' survey noise: the same run either way
    gates_only, _ = survey_points(s.survey)
    t0 = time.perf_counter()
    det = detect_gate_table(s.session)
    sess = with_columns(s.session, gate_columns(s.session, det))
    t1 = time.perf_counter()
    c = s.crossings
    ct = np.array([x.t for x in det.crossings])
    found = np.array([ct.size > 0 and bool(np.any(np.abs(ct - tc) < 0.05)) for tc in c["t"]])
    out: dict = {
        "seed": seed,
        "variant": variant,
        "near": int((c["distance"] <= 0.5).sum()),
        "near_found": int((found & (c["distance"] <= 0.5)).sum()),
        "passes": int(c["t"].size),
        "found": int(found.sum()),
        "detect_s": t1 - t0,
    }
    runs = {"gs": 1, "dh": 3, "spots": 1} if overrides.get("spots") else {"gs": 1}
    for name, every in runs.items():
        eks = EKSParams(**{k: v for k, v in overrides.items() if k in ("q_rot", "sigma_acc", "q_eps")})
        extra = {k: v for k, v in overrides.items() if k in ("sigma_fit", "survey_depth", "pass_fit")}
        p = GateAnchorParams(rate=rate, anchors_every=every, eks=eks, **extra)
        t2 = time.perf_counter()
        try:
            srv = s.survey if name == "spots" else gates_only
            tab, meta, _ = gate_anchor_table(sess, s.meta, srv, s.survey_meta, p)
        except Exception as exc:  # a refusal is a result too (counted, not a crash of the bench)
            out[name] = {"error": str(exc)}
            continue
        t3 = time.perf_counter()
        t = floats(tab, "t")
        pos = np.column_stack([floats(tab, k) for k in "xyz"])
        vel = np.column_stack([floats(tab, f"v{k}") for k in "xyz"])
        std = np.linalg.norm(np.column_stack([floats(tab, f"std_{k}") for k in "xyz"]), axis=1)
        tp = np.column_stack([floats(s.truth, f"true_{k}") for k in "xyz"])
        tv = np.column_stack([floats(s.truth, f"true_v{k}") for k in "xyz"])
        err = np.linalg.norm(pos - tp, axis=1)
        spd = np.linalg.norm(vel, axis=1) - np.linalg.norm(tv, axis=1)
        moving = np.linalg.norm(tv, axis=1) > 1.0
        first, last = t < c["t"][0], t > c["t"][-1]
        ids = tab.column("gate").drop_null().to_numpy(zero_copy_only=False)
        want = [int(np.argmin(np.abs(c["t"] - x))) + 1 if np.min(np.abs(c["t"] - x)) < 0.05 else -1 for x in ct]
        # the lever of the standing error: distance from the standing athlete to the nearest anchored gate
        used = tab.column("gate_anchor").drop_null().to_numpy(zero_copy_only=False)
        ta = ct[used] if used.size == ct.size else ct
        lever = [np.nan, np.nan]
        if ta.size:
            k0, k1 = (int(np.argmin(np.abs(t - x))) for x in (ta[0], ta[-1]))
            lever = [float(np.linalg.norm(tp[k0] - tp[0])), float(np.linalg.norm(tp[k1] - tp[-1]))]
        out[name] = {
            "lever": lever,
            "moving": (float(err[moving].mean()), float(err[moving].std())),
            "speed": (float(spd[moving].mean()), float(spd[moving].std())),
            "standing": (float(err[~moving & first].mean()), float(err[~moving & last].mean())),
            "standing_z": float(
                max(np.max(err[~moving & h] / np.maximum(std[~moving & h], 1e-9)) for h in (first, last))
            ),
            "silent": bool(np.any((err > 1.0) & (err > 3.0 * std))),
            "max": float(err.max()),
            "wrong": int(sum(g not in (-1, w) for g, w in zip(ids, want, strict=True))),
            "fits": meta["gate_anchor"].get("pass_fits"),
            "time_s": t3 - t2,
        }
    return out


def _pool(jobs: int, tasks: list[tuple]) -> list[dict]:
    with ProcessPoolExecutor(jobs) as ex:
        return list(ex.map(_run, tasks))


def _summary(rows: list[dict], key: str = "gs") -> dict:
    ok = [r[key] for r in rows if "error" not in r[key]]
    near = sum(r["near"] for r in rows)
    st = np.array([o["standing"] for o in ok]) if ok else np.full((1, 2), np.nan)
    return {
        "runs": len(rows),
        "refused": len(rows) - len(ok),
        "detected": 100.0 * sum(r["near_found"] for r in rows) / max(near, 1),
        "near": near,
        "found_all": 100.0 * sum(r["found"] for r in rows) / max(sum(r["passes"] for r in rows), 1),
        "moving": float(np.mean([o["moving"][0] for o in ok])) if ok else np.nan,
        "moving_sd": float(np.mean([o["moving"][1] for o in ok])) if ok else np.nan,
        "start": float(st[:, 0].mean()),
        "finish": float(st[:, 1].mean()),
        "standing_worst": float(st.max()),
        "standing_z": float(np.max([o["standing_z"] for o in ok])) if ok else np.nan,
        "lever": float(np.nanmean([o["lever"] for o in ok])) if ok else np.nan,
        "implied_deg": float(np.rad2deg(np.nanmedian(st / np.array([o["lever"] for o in ok])))) if ok else np.nan,
        "silent": sum(o["silent"] for o in ok),
        "wrong": sum(o["wrong"] for o in ok),
        "max": float(np.max([o["max"] for o in ok])) if ok else np.nan,
    }


def tune(jobs: int, rate: float) -> None:
    grid = [
        {"q_rot": 0.0},
        {"q_rot": 2e-5},
        {"q_rot": 2e-5, "sigma_fit": 0.03},
        {"q_rot": 2e-5, "sigma_fit": 0.1},
    ]
    print(f"tuning grid on seeds {TUNE_SEEDS.start}-{TUNE_SEEDS.stop - 1} x {', '.join(TUNE_VARIANTS)} ({rate:g} Hz)")
    print(f"{'setting':34s} {'moving':>7s} {'start':>6s} {'finish':>6s} {'worst':>6s} {'silent':>6s} {'wrong':>5s}")
    for ov in grid:
        rows = _pool(jobs, [(s, v, rate, ov) for v in TUNE_VARIANTS for s in TUNE_SEEDS])
        m = _summary(rows)
        print(
            f"{str(ov):34s} {m['moving']:7.3f} {m['start']:6.2f} {m['finish']:6.2f} {m['standing_worst']:6.2f} "
            f"{m['silent']:6d} {m['wrong']:5d}"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=12, help="held-out nominal runs for Table 1 [count]")
    ap.add_argument("--n-variant", type=int, default=4, help="held-out runs per variant [count]")
    ap.add_argument("--rate", type=float, default=50.0, help="smoother rate [Hz]")
    ap.add_argument("--quick", action="store_true", help="4 nominal runs, 2 per variant")
    ap.add_argument("--tune", action="store_true", help="print the tuning grid (seeds 1-8) instead")
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="worker processes")
    a = ap.parse_args()
    if a.tune:
        tune(a.jobs, a.rate)
        return
    if a.quick:
        a.n, a.n_variant = 4, 2
    from sportfusion.gates.sim import VARIANTS

    t0 = time.perf_counter()
    table = _pool(a.jobs, [(TABLE_SEED0 + i, "nominal", a.rate, {"spots": True}) for i in range(a.n)])
    var_rows = _pool(
        a.jobs, [(VARIANT_SEED0 + i, v, a.rate, {}) for v in VARIANTS if v != "nominal" for i in range(a.n_variant)]
    )
    # a diagnostic, not a world: the nominal held-out runs with a gyro free of scale and misalignment errors
    from dataclasses import replace

    from sportfusion.gates.sim_sensors import UnitSpec

    clean_gyr = UnitSpec(gyr=replace(UnitSpec().gyr, scale=0.0, misalignment=0.0))
    diag = _pool(
        a.jobs, [(TABLE_SEED0 + i, "nominal", a.rate, {"cfg": {"unit": clean_gyr}}) for i in range(a.n_variant)]
    )
    wall = time.perf_counter() - t0

    print(f"gate-anchor on the independent gates simulator, smoother at {a.rate:g} Hz, gates only (no surveyed spots)")
    print(
        f"defaults chosen on seeds {TUNE_SEEDS.start}-{TUNE_SEEDS.stop - 1} of {', '.join(TUNE_VARIANTS)}; "
        f"reported on held-out seeds {TABLE_SEED0}-{TABLE_SEED0 + a.n - 1} (nominal) and "
        f"{VARIANT_SEED0}-{VARIANT_SEED0 + a.n_variant - 1} (each variant)"
    )
    print("\nTable 1 layout (total error; mean over runs (sd over runs) of the per-run mean and sd), nominal world")
    print(f"{'':22s} {'ours GS':>13s} {'paper GS':>13s} | {'ours DH':>13s} {'paper DH':>13s}")
    for q, unit in (("moving", "position [m]"), ("speed", "speed [m/s]")):
        cells = []
        for var, paper in (("gs", PAPER["GS"]), ("dh", PAPER["DH"])):
            ok = [r[var] for r in table if "error" not in r[var]]
            acc = np.array([o[q][0] for o in ok])
            prec = np.array([o[q][1] for o in ok])
            pq = paper["position" if q == "moving" else "speed"]
            cells += [
                f"{acc.mean():5.2f} ({acc.std():.2f})",
                f"{pq[0]:5.2f}",
                f"{prec.mean():5.2f} ({prec.std():.2f})",
                f"{pq[1]:5.2f}",
            ]
        print(f"{'accuracy ' + unit:22s} {cells[0]:>13s} {cells[1]:>13s} | {cells[4]:>13s} {cells[5]:>13s}")
        print(f"{'precision ' + unit:22s} {cells[2]:>13s} {cells[3]:>13s} | {cells[6]:>13s} {cells[7]:>13s}")

    print("\nper variant (held-out seeds): detection, accuracy, standing still, silent gross errors")
    hdr = (
        f"{'variant':11s} {'runs':>4s} {'det<=0.5m':>9s} {'det all':>7s} {'moving':>7s} {'start':>6s} {'finish':>6s} "
        f"{'worst':>6s} {'z':>5s} {'silent':>6s} {'wrong':>5s}"
    )
    print(hdr + "   (det: %; errors: m; z: worst standing error / its std)")
    rows_by = {"nominal": table}
    for v in VARIANTS:
        if v != "nominal":
            rows_by[v] = [r for r in var_rows if r["variant"] == v]
    for v, rows in rows_by.items():
        m = _summary(rows)
        tag = " (tuning variant)" if v in TUNE_VARIANTS else ""
        print(
            f"{v:11s} {m['runs']:4d} {m['detected']:9.1f} {m['found_all']:7.1f} {m['moving']:7.3f} {m['start']:6.2f} "
            f"{m['finish']:6.2f} {m['standing_worst']:6.2f} {m['standing_z']:5.1f} {m['silent']:6d} {m['wrong']:5d}{tag}"
        )
    sp = _summary(table, "spots")
    print(
        f"nominal with the start and finish spots surveyed too (simulate gates --survey-spots): standing start "
        f"{sp['start']:.2f} m, finish {sp['finish']:.2f} m (worst {sp['standing_worst']:.2f} m), moving {sp['moving']:.3f} m"
    )
    nm, dg = _summary(table), _summary(diag)
    print(
        f"why standing still is off (nominal): the standing athlete is {nm['lever']:.0f} m on average from the nearest "
        f"anchored gate (the push-off, the braking), a lever on the heading: the standing error is "
        f"{nm['implied_deg']:.2f} deg of heading times that distance (median) -- the strap-down heading's error "
        f"relative to the anchored part of the run; with a gyro free of scale and misalignment errors (a "
        f"diagnostic, {dg['runs']} runs) start {dg['start']:.2f} m, finish {dg['finish']:.2f} m "
        f"({dg['implied_deg']:.2f} deg)"
    )
    allm = _summary(table + var_rows)
    print(
        f"\ntargets (issue 39): detected {allm['detected']:.1f} % of {allm['near']} passes within 0.5 m (>= 95 %; "
        f"before: {PREVIOUS['detected']}); standing mean start {allm['start']:.2f} m, finish {allm['finish']:.2f} m "
        f"(<= 0.15 m; before: {PREVIOUS['standing']}); runs silently off by more than 1 m: {allm['silent']} of "
        f"{allm['runs']} (0; before: {PREVIOUS['wide']})"
    )
    tg = np.array([r["gs"]["time_s"] for r in table if "error" not in r["gs"]])
    td = np.array([r["detect_s"] for r in table])
    print(
        f"speed: detect-events {td.mean():.1f} s, gate-anchor {tg.mean():.1f} s per ~55 s run at {a.rate:g} Hz; "
        f"bench wall {wall:.0f} s on {a.jobs} processes (shared machine: noisy)"
    )


if __name__ == "__main__":
    main()
