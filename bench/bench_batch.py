"""Batch reprocessing: N simulated sessions through ``pipelines/batch.mk`` with ``make -j 1`` and
``make -j 2``; wall times, speed-up, and the per-session report (issue: batch reprocessing).

One session is corrupted on purpose (its raw file is not a recording): it must be listed with its
error while the other N-1 complete. Sessions are climbing trials (``simulate boulder``, a new seed
each) taken through detect-events -> pf-holds -> evaluate (target ``results evaluation``, no plots).

Run: ``python bench/bench_batch.py [--n 100] [--keep DIR]``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def make_sessions(root: Path, n: int) -> None:
    from sportfusion.tools.simulate import main as simulate

    for k in range(n):
        d = root / f"trial{k:03d}"
        d.mkdir(parents=True)
        here = os.getcwd()
        os.chdir(d)
        try:
            simulate.main(
                args=[
                    "boulder",
                    "--seed",
                    str(k),
                    "--truth",
                    "truth.parquet",
                    "--holds",
                    "holds.parquet",
                    "-q",
                    "-o",
                    "session.parquet",
                ],
                prog_name="simulate",
                standalone_mode=False,
            )
        finally:
            os.chdir(here)
        (d / "config.mk").write_text(
            "SPORT = climbing\nRAW = session.parquet\nHOLDS = holds.parquet\nTRUTH = truth.parquet\n"
        )
    (root / "trial000" / "session.parquet").write_bytes(b"this is not a recording\n")  # the corrupt one


def _spin(n: int) -> int:
    s = 0
    for i in range(n):
        s += i
    return s


def cpu_ceiling(n: int = 30_000_000) -> float:
    """Speed-up of two pure-Python CPU-bound processes over running them one after the other: what this
    machine gives a perfectly parallel job (no start-up, I/O or page faults)."""
    import multiprocessing as mp

    start = time.perf_counter()
    _spin(n)
    _spin(n)
    serial = time.perf_counter() - start
    start = time.perf_counter()
    with mp.Pool(2) as pool:
        pool.map(_spin, [n, n])
    return serial / (time.perf_counter() - start)


def run(sessions: Path, out: Path, jobs: int) -> tuple[float, str]:
    shutil.rmtree(out, ignore_errors=True)
    start = time.perf_counter()
    res = subprocess.run(
        [
            "make",
            "--no-print-directory",
            "-j",
            str(jobs),
            "-f",
            str(ROOT / "pipelines" / "batch.mk"),
            f"SESSIONS={sessions}",
            f"OUT={out}",
            "TARGET=results evaluation",
            f"BIN={Path(sys.executable).parent}/",
        ],
        capture_output=True,
        text=True,
    )
    return time.perf_counter() - start, res.stdout


def run_snakemake(sessions: Path, out: Path, jobs: int) -> tuple[float, str]:
    """The same batch through pipelines/Snakefile (Snakemake, local executor, ``jobs`` cores)."""
    shutil.rmtree(out, ignore_errors=True)
    bindir = Path(sys.executable).parent
    start = time.perf_counter()
    res = subprocess.run(
        [
            str(bindir / "snakemake"),
            "-s",
            str(ROOT / "pipelines" / "Snakefile"),
            "-d",
            str(out),
            "--cores",
            str(jobs),
            "--keep-going",
            "--quiet",
            "all",
            "--config",
            f"sessions={sessions}",
            f"out={out}",
            f"bin={bindir}/",
            "target=results evaluation",
        ],
        capture_output=True,
        text=True,
    )
    return time.perf_counter() - start, (out / "summary.txt").read_text() if (
        out / "summary.txt"
    ).exists() else res.stderr


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=100, help="sessions [count]")
    ap.add_argument("--keep", type=Path, default=None, help="keep the sessions and outputs in this folder")
    ap.add_argument("--no-j1", action="store_true", help="skip the make -j 1 run (engines side by side only)")
    args = ap.parse_args()
    tmp = Path(args.keep or tempfile.mkdtemp(prefix="sf-batch-"))
    sessions = tmp / "sessions"
    shutil.rmtree(sessions, ignore_errors=True)
    t0 = time.perf_counter()
    make_sessions(sessions, args.n)
    print(f"{args.n} simulated climbing sessions written in {time.perf_counter() - t0:.0f} s (one corrupt)")
    t1 = float("nan") if args.no_j1 else run(sessions, tmp / "out-j1", 1)[0]
    t2, report = run(sessions, tmp / "out-j2", 2)
    have_snakemake = (Path(sys.executable).parent / "snakemake").exists()
    ts, sreport = run_snakemake(sessions, tmp / "out-sm2", 2) if have_snakemake else (float("nan"), "")
    summary = report[report.find("session ") :] if "session " in report else report
    tail = [ln for ln in summary.splitlines() if "sessions ok" in ln or "FAILED " in ln]
    print("\n".join(tail))
    print(f"\n{'jobs':>5} {'wall [s]':>9} {'per session [s]':>16}")
    print(f"{1:>5} {t1:9.1f} {t1 / args.n:16.2f}")
    print(f"{2:>5} {t2:9.1f} {t2 / args.n:16.2f}")
    print(f"{'2 sm':>5} {ts:9.1f} {ts / args.n:16.2f}   (Snakemake, pipelines/Snakefile, --cores 2)")
    print(f"speed-up make -j 2 vs -j 1: {t1 / t2:.2f}x (ideal 2.00x on {os.cpu_count()} cores)")
    if have_snakemake:
        ok = [ln for ln in sreport.splitlines() if "sessions ok" in ln]
        print(
            f"Snakemake --cores 2 vs make -j 2: {ts / t2:.2f}x the time (target <= 1.10); {ok[0] if ok else sreport[-200:]}"
        )
    else:
        print("Snakemake: not installed (pip install -e '.[cluster]')")
    print(f"this machine's ceiling, two pure-Python CPU-bound processes: {cpu_ceiling():.2f}x")
    if args.keep is None:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
