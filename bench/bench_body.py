"""The gates paper's CoM output (Fasel et al. 2018, Tables 1-2) on the independent full-body skier.

For every seed ``simulate gates --body --raw`` writes a 30-gate GS run as Xsens exports with OpenSense's
mapping file, and the chain ``ingest RAWDIR | body-model --height H --mass M | detect-events --kind gates |
gate-anchor --gates survey.parquet`` estimates the CoM (the same commands, by their console scripts).
Printed: Table 1 (mean over runs (sd over runs) of the per-run accuracy and precision, total and in the local
skiing frame) and Table 2 (Bland-Altman bias and 95 % limits of agreement of the six turn figures over all
turns) beside the paper's, the CoM path length per gate-to-gate segment (bias, LoA), and the relative CoM
beside Fasel et al. 2017 (25.7 +- 6.7 mm).  The paper's figures are against a differential GNSS reference,
ours against simulated truth.

Run: ``python bench/bench_body.py [--n 5] [--jobs 2]``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

BIN = Path(sys.executable).parent
SEED0 = 1100


def _run(cmd: str, cwd: Path) -> None:
    subprocess.run(["bash", "-o", "pipefail", "-c", cmd], cwd=cwd, check=True, capture_output=True)


def _one(seed: int) -> dict:
    from sportfusion.core import io as sfio
    from sportfusion.core import schema
    from sportfusion.evaluate.com import evaluate_com

    with tempfile.TemporaryDirectory() as d:
        dd = Path(d)
        b = f"{BIN}/"
        _run(f"{b}simulate gates -q --seed {seed} --body --raw raw --truth truth.parquet -o /dev/null", dd)
        _run(
            f"{b}ingest -q raw | {b}body-model -q --height 1.8 --mass 78 | {b}detect-events -q --kind gates"
            f" | {b}gate-anchor -q --gates raw/survey.parquet -o run.parquet",
            dd,
        )
        est, meta = sfio.read_table(dd / "run.parquet")
        truth, _ = sfio.read_table(dd / "truth.parquet")
        res = evaluate_com(est, meta, truth)
        # path length per gate-to-gate segment (between consecutive true crossings)
        t, tt = schema.floats(est, "t"), schema.floats(truth, "t")
        com = schema.float_columns(est, ["com_x", "com_y", "com_z"])
        tcom = schema.float_columns(truth, ["true_com_x", "true_com_y", "true_com_z"])
        ev = truth.column("true_event").to_pylist()
        tg = np.array([tt[i] for i, e in enumerate(ev) if e == "gate"])
        seg = []
        for a, c in zip(tg[:-1], tg[1:], strict=True):
            w, wt = (t >= a) & (t <= c), (tt >= a) & (tt <= c)
            le = np.sum(np.linalg.norm(np.diff(com[w], axis=0), axis=1))
            lt = np.sum(np.linalg.norm(np.diff(tcom[wt], axis=0), axis=1))
            if np.isfinite(le):
                seg.append(le - lt)
        res["segments"] = seg
        res["turn_errors"] = res["table2"]
        return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=5, help="runs [count]")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes")
    a = ap.parse_args()
    from sportfusion.evaluate.com import FASEL_2017_MM, PAPER_T1

    with ProcessPoolExecutor(a.jobs) as ex:
        runs = list(ex.map(_one, [SEED0 + i for i in range(a.n)]))
    print(f"CoM over {a.n} simulated GS runs with the full-body skier (seeds {SEED0}..{SEED0 + a.n - 1})")
    print("Table 1: mean over runs (sd over runs) of the per-run accuracy (mean) and precision (sd)")
    print(f"{'':22s} {'accuracy':>13s} {'paper':>13s} {'precision':>13s} {'paper':>13s}")
    for q in ("position [m]", "speed [m/s]"):
        for i, ax in enumerate(("total", "x", "y", "z")):
            acc = np.array([r["table1"][q][i][0] for r in runs])
            prec = np.array([r["table1"][q][i][1] for r in runs])
            (pa_, pas), (pp, pps) = PAPER_T1[q][i]
            print(
                f"{q + ' ' + ax:22s} {acc.mean():6.2f} ({acc.std():.2f}) {pa_:6.2f} ({pas:.2f})"
                f" {prec.mean():6.2f} ({prec.std():.2f}) {pp:6.2f} ({pps:.2f})"
            )
    print("\nTable 2 (per-run Bland-Altman, mean over runs of bias and LoA):")
    from sportfusion.evaluate.com import FIGURES, PAPER_T2

    for k in FIGURES:
        vals = [r["table2"][k] for r in runs if r["table2"].get(k)]
        bias = np.mean([v["bias"] for v in vals])
        lo, hi = np.mean([v["loa"][0] for v in vals]), np.mean([v["loa"][1] for v in vals])
        pm, pu = PAPER_T2[k]
        print(f"  {k:8s} bias {bias:7.3f}  LoA [{lo:7.3f}, {hi:7.3f}] | paper bias {pm}, upper LoA {pu}")
    seg = np.concatenate([r["segments"] for r in runs])
    print(
        f"\nCoM path length per gate-to-gate segment ({seg.size}): bias {seg.mean():.3f} m, LoA "
        f"[{seg.mean() - 1.96 * seg.std():.3f}, {seg.mean() + 1.96 * seg.std():.3f}] m (paper, per turn: -0.06..0.16 m)"
    )
    rel = np.array([r["relative"]["mean_mm"] for r in runs if r["relative"]])
    print(f"relative CoM: {rel.mean():.1f} mm mean error (Fasel 2017: {FASEL_2017_MM[0]} +- {FASEL_2017_MM[1]} mm)")


if __name__ == "__main__":
    main()
