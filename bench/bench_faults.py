"""Fault injection: realistic recording faults through each sport's pipeline, beside the clean run.

For a few seeds per sport the simulator makes a session; :mod:`sportfusion.sim.faults` injects one
fault per variant; the sport's pipeline (the library calls the README pipeline's commands make)
runs on the clean and on the faulty session, and the estimate is compared with the simulated truth:

* ski jump (``detect-events --kind jump | rts-smooth | jump-metrics``): IMU saturation (+-16 g,
  +-2000 deg/s, impact bursts at take-off, touch-down and 3 random instants), a GNSS outage of
  5-20 s over the jump and one of 20 s from the start gate to the stop, a magnetic disturbance (+50 % of the field for 6 s); position RMS [m] and
  jump length error [m];
* ski racing (``spline-smooth``): an 8 s GNSS outage (bridged: spline-smooth bridges up to 10 s); position RMS [m] and, inside the gap, the
  share of rows whose truth lies within +-2 std (``cov2``);
* gates (``detect-events --kind gates | gate-anchor``): 2 % IMU samples dropped plus two 0.1-0.3 s
  gaps; position RMS [m] while moving;
* climbing (``detect-events --kind grips | pf-holds``): IMU saturation (bursts), a magnetic
  disturbance (+50 % of the field for 8 s); position RMS of the PF smoother [m];
* every sport: three duplicated time stamps (must be refused by name).

A run is **ok** when its error stays within 3x the clean run's (ski jump: jump length within 3 m),
**flagged** when it failed with one clear line or warned naming the fault, and **SILENT** otherwise
(gross and not warned about, or refused with a line that does not name the fault); the benchmark's
acceptance is no SILENT run.  ``nan`` counts estimate
rows with NaN where the clean run has a value.

Run: ``python bench/bench_faults.py [--seeds 3] [--only skijump ...] [--jobs 2]``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

SPORTS = ("skijump", "skirace", "gates", "climbing")
SEED0 = {"skijump": 100, "skirace": 200, "gates": 300, "climbing": 400}


def _rms3(err: dict) -> float:
    e = np.stack([err[k] for k in ("x", "y", "z")], axis=-1)
    ok = np.isfinite(e).all(axis=1)
    return float(np.sqrt(np.mean(np.sum(e[ok] ** 2, axis=1)))) if ok.any() else float("nan")


def _nan_rows(table, names=("x", "y", "z")) -> np.ndarray:
    from sportfusion.core.schema import floats

    return ~np.isfinite(np.stack([floats(table, c) for c in names], axis=-1)).all(axis=1)


# ----------------------------------------------------------------------------------------- ski jump
def _skijump_variants(seed: int) -> tuple:
    from sportfusion.sim import faults
    from sportfusion.skijump.hillfile import load_hill
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

    hill = load_hill("oberstdorf_hs106")
    sim = simulate_skijump(
        hill, SkiJumpConfig(seed=seed, physics="paper")
    )  # the paper's world (issue 39: bench_skijump_independent for the full physics)
    times = sim.truth_meta["skijump"]["times"]
    rng = np.random.default_rng(seed)
    t_end = times["end"]
    bursts = [times["takeoff"], times["touchdown"], *rng.uniform(1.0, t_end - 1.0, 3).tolist()]
    dur = float(rng.uniform(5.0, 20.0))
    start = float(np.clip(times["takeoff"] - rng.uniform(1.0, max(dur - 4.5, 1.5)), 0.5, t_end - dur - 0.5))
    variants = {
        "clean": sim.session,
        "saturation": faults.saturate_imu(sim.session, bursts, seed=seed),
        f"gnss-out {dur:.0f}s": faults.gnss_outage(sim.session, start, dur),
        "gnss-out-20s": faults.gnss_outage(sim.session, 3.0, 20.0),
        "mag-disturb 6s": faults.mag_disturbance(
            sim.session, float(rng.uniform(2.0, t_end - 8.0)), 6.0, 0.5, seed=seed
        ),
        "dup-times": faults.duplicate_times(sim.session, 3, seed=seed),
    }
    return hill, sim, variants


def _skijump_run(hill, sim, table) -> dict:
    from sportfusion.core.schema import floats
    from sportfusion.evaluate import errors
    from sportfusion.skijump.events import detect_jump_events
    from sportfusion.skijump.metrics import jump_metrics
    from sportfusion.skijump.smoother import rts_smooth_table

    notes = []
    ev, summary, msg = detect_jump_events(table)
    notes += list(summary.get("warnings", []))
    if not summary["jumps"]:
        raise _Refused(f"detect-events: {msg}")
    est, meta, msg = rts_smooth_table(ev, sim.session_meta, hill)
    notes += list(meta.get("rts", {}).get("warnings", []))
    az = meta["frame"]["azimuth_deg"]
    err = errors(est, sim.truth, az)[2]
    t = floats(est, "t")
    pos = np.stack([floats(est, c) for c in ("x", "y", "z")], -1)
    vel = np.stack([floats(est, c) for c in ("vx", "vy", "vz")], -1)
    jumps = [(j["takeoff"], j["touchdown"]) for j in meta["rts"]["jumps"]]
    jl = jump_metrics(t, pos, vel, jumps, hill)[0]["jump_length"] if jumps else float("nan")
    return {
        "err": _rms3(err),
        "jl": jl - sim.truth_meta["jump_length"],
        "nan": int(_nan_rows(est).sum()),
        "notes": notes,
    }


# --------------------------------------------------------------------------------------- ski racing
def _skirace_variants(seed: int) -> tuple:
    from sportfusion.core.schema import floats
    from sportfusion.sim import faults
    from sportfusion.skirace.sim import SkiRaceConfig, simulate_skirace

    sim = simulate_skirace(SkiRaceConfig(seed=seed))
    t = floats(sim.session, "t")
    rng = np.random.default_rng(seed)
    start = float(rng.uniform(t[0] + 0.3 * (t[-1] - t[0]), t[0] + 0.6 * (t[-1] - t[0])))
    return (
        None,
        sim,
        {
            "clean": sim.session,
            "gnss-out 8s": faults.gnss_outage(sim.session, start, 8.0),
            "dup-times": faults.duplicate_times(sim.session, 3, seed=seed),
        },
    )


def _skirace_run(_, sim, table) -> dict:
    import pyarrow as pa

    from sportfusion.core.schema import floats
    from sportfusion.core.session import validate_time, with_columns
    from sportfusion.evaluate import errors
    from sportfusion.skirace.track import smooth_session

    validate_time(table)  # spline-smooth reads the table through core.io, which checks t
    res = smooth_session(table, sim.meta)
    cols = {k: (v if isinstance(v, pa.Array) else np.asarray(v)) for k, v in res.columns.items()}
    est = with_columns(table, cols)
    az = sim.meta["frame"]["azimuth_deg"]
    _, i_est, err = errors(est, sim.truth, az)
    out = {"err": _rms3(err), "nan": int(_nan_rows(est).sum()), "notes": list(res.warnings)}
    filled = np.asarray(est.column("spline_filled").fill_null(False).to_numpy(zero_copy_only=False), bool)[i_est]
    if filled.any():
        e = np.stack([err[a] for a in "xyz"], -1)[filled]
        out["gap_err"] = float(np.sqrt(np.mean(np.sum(e**2, axis=1))))
    if filled.any() and "std_x" in est.column_names:
        std = np.stack([floats(est, f"std_{a}") for a in "xyz"], -1)[i_est][filled]
        e = np.stack([err[a] for a in "xyz"], -1)[filled]
        out["cov2"] = float(np.mean(np.abs(e) <= 2 * std))
    return out


# -------------------------------------------------------------------------------------------- gates
def _gates_variants(seed: int) -> tuple:
    from sportfusion.gates.sim import GatesConfig, simulate_gates
    from sportfusion.sim import faults

    sim = simulate_gates(GatesConfig(seed=seed))
    rng = np.random.default_rng(seed)
    t0, t1 = float(sim.crossings["t"][0]), float(sim.crossings["t"][-1])
    gaps = [(float(rng.uniform(t0, t1)), float(rng.uniform(0.1, 0.3))) for _ in range(2)]
    return (
        None,
        sim,
        {
            "clean": sim.session,
            "drop 2%+gaps": faults.drop_imu_samples(sim.session, 0.02, gaps, seed=seed),
            "dup-times": faults.duplicate_times(sim.session, 3, seed=seed),
        },
    )


def _gates_run(_, sim, table) -> dict:
    from sportfusion.core.session import validate_time, with_columns
    from sportfusion.evaluate import errors
    from sportfusion.gates.crossings import detect_gate_table, gate_columns
    from sportfusion.gates.pipeline import gate_anchor_table

    validate_time(table)
    det = detect_gate_table(table)
    tab = with_columns(table, gate_columns(table, det))
    est, meta, msg = gate_anchor_table(tab, sim.meta, sim.survey, sim.survey_meta)
    _, _, err = errors(est, sim.truth, 0.0)
    return {
        "err": _rms3(err),
        "nan": int(_nan_rows(est).sum()),
        "notes": list(meta.get("gate_anchor", {}).get("warnings", [])),
    }


# ----------------------------------------------------------------------------------------- climbing
def _climbing_variants(seed: int) -> tuple:
    from sportfusion.climbing.sim import BoulderConfig, simulate_boulder
    from sportfusion.core.schema import floats
    from sportfusion.sim import faults

    sim = simulate_boulder(BoulderConfig(seed=seed))
    t = floats(sim.session, "t")
    rng = np.random.default_rng(seed)
    bursts = rng.uniform(t[0] + 2, t[-1] - 2, 4).tolist()
    md = float(rng.uniform(t[0] + 2, max(t[-1] - 10, t[0] + 3)))
    return (
        None,
        sim,
        {
            "clean": sim.session,
            "saturation": faults.saturate_imu(
                sim.session, bursts, acc_range=160.0, burst_acc=300.0, burst_duration=0.03, seed=seed
            ),
            "mag-disturb 8s": faults.mag_disturbance(sim.session, md, 8.0, 0.5, seed=seed),
            "dup-times": faults.duplicate_times(sim.session, 3, seed=seed),
        },
    )


def _climbing_run(_, sim, table) -> dict:
    from sportfusion.climbing.grips import grip_columns
    from sportfusion.climbing.holds import validate
    from sportfusion.climbing.track import track_holds
    from sportfusion.core import schema
    from sportfusion.core.session import validate_time, with_columns

    validate_time(table)
    holds = validate(sim.holds, sim.holds_meta)
    cols, _ = grip_columns(table)
    tr = track_holds(with_columns(table, cols), sim.meta, holds)
    t_est = schema.floats(table, "t")[tr.rows]
    t_true = schema.floats(sim.truth, "t")
    j = np.searchsorted(t_true, t_est)
    j = np.clip(j, 0, t_true.size - 1)
    p_true = np.column_stack([schema.floats(sim.truth, f"true_{a}") for a in "xyz"])[j]
    k0 = tr.pf.k0
    e = np.linalg.norm(tr.pf.smooth_pos - p_true, axis=1)[k0:]
    return {
        "err": float(np.sqrt(np.nanmean(e**2))),
        "nan": int((~np.isfinite(tr.pf.smooth_pos[k0:]).all(axis=1)).sum()),
        "notes": list(getattr(tr, "warnings", []) or []),
    }


class _Refused(Exception):
    pass


def one(job: tuple[str, int]) -> list[dict]:
    from sportfusion.core.errors import InputError

    sport, seed = job
    make = globals()[f"_{sport}_variants"]
    run = globals()[f"_{sport}_run"]
    ctx, sim, variants = make(seed)
    rows = []
    for name, table in variants.items():
        t0 = time.perf_counter()
        row = {"sport": sport, "seed": seed, "variant": name}
        try:
            row.update(run(ctx, sim, table))
            row["status"] = "ran"
        except (InputError, _Refused) as exc:
            row.update(status="refused", line=str(exc))
        except Exception as exc:  # noqa: BLE001 - a crash is a finding of this benchmark
            row.update(status="CRASH", line=f"{type(exc).__name__}: {exc}")
        row["time"] = time.perf_counter() - t0
        rows.append(row)
    return rows


FAULT_WORDS = (
    "satur",
    "clip",
    "gnss",
    "gap",
    "outage",
    "magnet",
    "disturb",
    "duplicat",
    "repeats the time",
    "missing",
    "dropped",
)


def verdict(row: dict, clean: dict | None) -> str:
    """ok / flagged / SILENT for one faulty run against its clean run."""
    if row["status"] == "refused":
        return "flagged" if any(w in row["line"].lower() for w in FAULT_WORDS) else "SILENT"
    if row["status"] == "CRASH":
        return "SILENT"
    if clean is None or clean.get("status") != "ran":
        return "ok"
    gross = row["err"] > 3 * clean["err"] or not np.isfinite(row["err"])
    if "jl" in row:
        gross |= not abs(row["jl"] - clean["jl"]) <= 3.0
    if not gross:
        return "ok"
    warned = any(any(w in n.lower() for w in FAULT_WORDS) for n in row.get("notes", []))
    return "flagged" if warned else "SILENT"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3, help="seeds per sport")
    ap.add_argument("--only", nargs="*", default=list(SPORTS), choices=SPORTS)
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("-v", "--verbose", action="store_true", help="print every run")
    a = ap.parse_args()
    jobs = [(s, SEED0[s] + k) for s in a.only for k in range(a.seeds)]
    t0 = time.perf_counter()
    if a.jobs > 1:
        with ProcessPoolExecutor(a.jobs) as ex:
            res = list(ex.map(one, jobs))
    else:
        res = [one(j) for j in jobs]
    wall = time.perf_counter() - t0
    print(f"fault injection: {a.seeds} seed(s) per sport, each fault beside the clean run of the same seed")
    print("error: position RMS [m] (ski jump: also jump length error [m]); ok = within 3x clean (jump length 3 m)")
    silent = 0
    for sport in a.only:
        runs = [r for rs in res for r in rs if r["sport"] == sport]
        names = list(dict.fromkeys(r["variant"].split(" ")[0] for r in runs))
        print(f"\n{sport}")
        print(
            f"  {'variant':14s} {'runs':>4s} {'refused':>7s} {'NaN rows':>8s} {'error med (max)':>18s} "
            f"{'x clean med (max)':>18s} {'ok':>3s} {'flag':>4s} {'SILENT':>6s}"
            + ("  jump length err med (max)" if sport == "skijump" else "")
        )
        for name in names:
            rows = [r for r in runs if r["variant"].split(" ")[0] == name]
            verdicts, growth = [], []
            for r in rows:
                clean = next(c for c in runs if c["seed"] == r["seed"] and c["variant"] == "clean")
                v = "ok" if name == "clean" else verdict(r, clean)
                r["verdict"] = v
                verdicts.append(v)
                if r["status"] == "ran" and clean.get("status") == "ran":
                    growth.append(r["err"] / clean["err"])
            ran = [r for r in rows if r["status"] == "ran"]
            errs = [r["err"] for r in ran]
            e_txt = f"{np.median(errs):7.2f} ({max(errs):7.2f})" if errs else "-"
            g_txt = f"{np.median(growth):7.1f} ({max(growth):7.1f})" if growth else "-"
            line = (
                f"  {rows[0]['variant']:14s} {len(rows):4d} {sum(r['status'] != 'ran' for r in rows):7d} "
                f"{sum(r.get('nan', 0) for r in ran):8d} {e_txt:>18s} {g_txt:>18s} "
                f"{verdicts.count('ok'):3d} {verdicts.count('flagged'):4d} {verdicts.count('SILENT'):6d}"
            )
            if sport == "skijump":
                jls = [abs(r["jl"]) for r in ran if np.isfinite(r["jl"])]
                line += f"  {np.median(jls):6.2f} ({max(jls):6.2f})" if jls else "  -"
            ge = [r["gap_err"] for r in ran if "gap_err" in r and name != "clean"]
            if ge:
                cv = [r["cov2"] for r in ran if "cov2" in r]
                line += (
                    f"  in the gap: RMS {np.median(ge):.2f} m, truth within +-2 std {np.median(cv) if cv else 0:.0%}"
                )
            print(line)
            silent += verdicts.count("SILENT")
        for r in runs:
            if a.verbose or r.get("verdict") == "SILENT" or r["status"] != "ran":
                what = r.get("line") or f"err {r['err']:.2f}" + (f", jl {r['jl']:+.2f}" if "jl" in r else "")
                print(f"    seed {r['seed']} {r['variant']}: {r['status']} {r.get('verdict', '')}: {what[:160]}")
    print(f"\nSILENT gross errors: {silent} (acceptance: 0); wall {wall:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
