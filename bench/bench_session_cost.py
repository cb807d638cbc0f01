"""Cost of one session by sport: CPU time and peak memory of its whole pipeline (pipelines/session.mk).

Each fixture session (fixtures/<sport>) runs from its raw files to its results (target ``results``) in a
fresh output folder; the CPU time (user + system) and the largest resident set of the child processes
come from ``getrusage(RUSAGE_CHILDREN)``, so the figure is what a batch pays per session, independent of
how loaded the machine is. Then the projection for 10,000 sessions on N cores (labelled as such).

Run: ``python bench/bench_session_cost.py [--repeat 2]``.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPORTS = ("skijump", "skirace", "gates", "climbing")


def measure(sport: str, out: Path) -> tuple[float, float, float]:
    """(CPU seconds, wall seconds, peak RSS MB) of one session's pipeline, in a fresh process (the peak
    resident set of the children is a maximum over a process's life)."""
    res = subprocess.run([sys.executable, __file__, "--one", sport, str(out)], capture_output=True, text=True)
    if res.returncode:
        raise SystemExit(res.stderr[-500:])
    cpu, wall, rss = (float(v) for v in res.stdout.split())
    return cpu, wall, rss


def _measure_here(sport: str, out: Path) -> tuple[float, float, float]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    res = subprocess.run(
        [
            "make",
            "--no-print-directory",
            "-f",
            str(ROOT / "pipelines" / "session.mk"),
            f"SESSION={ROOT / 'fixtures' / sport}",
            f"OUT={out}",
            f"BIN={Path(sys.executable).parent}/",
            "results",
        ],
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - start
    if res.returncode:
        raise SystemExit(f"{sport}: pipeline failed: {res.stderr[-500:]}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall, after.ru_maxrss / 1024.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=2, help="runs per sport; the fastest counts [count]")
    ap.add_argument("--one", nargs=2, metavar=("SPORT", "OUT"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(*_measure_here(args.one[0], Path(args.one[1])))
        return
    rows = []
    with tempfile.TemporaryDirectory(prefix="sf-cost-") as tmp:
        for sport in SPORTS:
            runs = [measure(sport, Path(tmp) / f"{sport}{k}") for k in range(args.repeat)]
            rows.append((sport, *min(runs)))
    print(
        f"{'sport':<10} {'CPU [s]':>8} {'wall [s]':>9} {'peak RSS [MB]':>14}   (one fixture session, raw files -> results)"
    )
    for sport, cpu, wall, rss in rows:
        print(f"{sport:<10} {cpu:8.2f} {wall:9.2f} {rss:14.0f}")
    mean_cpu = sum(r[1] for r in rows) / len(rows)
    print(f"\nPROJECTION (not measured): 10,000 sessions of this mix at {mean_cpu:.2f} CPU s each")
    for cores in (2, 16, 64, 256):
        hours = 10_000 * mean_cpu / cores / 3600
        print(f"  {cores:>4} cores: {hours:6.2f} h of CPU-bound work (+ scheduler and file-system overhead)")


if __name__ == "__main__":
    main()
