"""Speed as the user pays it: whole commands (a fresh process each), CPU time beside wall time.

Every figure is the CPU time (user + system, ``os.wait4`` of the child) of one whole command --
interpreter start, imports, numba cache loading, reading, computing, writing -- beside its wall time,
and the peer measured in this same run:

1. ``rts-smooth`` on a training day of 23 simulated jumps (``simulate skijump`` seeds 1-23, logging
   paused between jumps, ~60k IMU steps) and on one 60k-step session (one jump, a long rest after
   it); peer: filterpy's ``ExtendedKalmanFilter`` + ``rts_smoother`` on the same model, per step
   (``bench_rts_speed.time_filterpy`` on a slice, CPU time).  Peak RSS of the command per step.
2. ``spline-smooth`` at 1e5 and 1e6 epochs (linear in N?); peer: csaps' compute alone (the fit of the
   three coordinates, CPU time, in this process).  Beside them the command's I/O floor: a process that
   starts, imports, reads the same table and writes one with the same 25 columns (no spline).
3. ``pf-holds`` on a 35 s climbing trial: times real time.
4. Start-up: every command's ``--help`` and a no-op stage (``inspect`` on a 20-row table) against
   ``python -c "import numpy, pyarrow"`` with one BLAS thread as the commands set it (the floor), best of 3.

rts-smooth and pf-holds are run 5 times each: the minimum is the figure, the median is printed beside it
(identical runs of a ~1 s command spread by up to 1.6x on a shared machine).

Run: ``python bench/bench_commands.py [--quick] [--only rts,spline]`` (``--quick``: 5 jumps, 2e5 epochs, no
filterpy; ``--only``: some of startup, pf, spline, rts).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
BIN = Path(sys.executable).parent
COMMANDS = (
    "ingest inspect video-jumplength gps2hill plot spline-smooth dmc-attitude evaluate simulate "
    "detect-events pf-holds rts-smooth jump-metrics gate-anchor compare-runs"
).split()


# The command is started by a small launcher process: a child forked from this (large) process would
# report this process's memory as its own peak RSS (Linux keeps the high-water mark across exec).
LAUNCHER = """
import os, subprocess, sys, time
t0 = time.perf_counter()
p = subprocess.Popen(sys.argv[2:])
_, status, ru = os.wait4(p.pid, 0)
with open(sys.argv[1], "w") as f:
    f.write(f"{ru.ru_utime + ru.ru_stime} {time.perf_counter() - t0} {ru.ru_maxrss * 1024} {os.waitstatus_to_exitcode(status)}")
"""


#: the start-up floor: ``import numpy, pyarrow`` with one BLAS thread, as every command runs
#: (``tools/__init__.py``): OpenBLAS's threads would otherwise add their start-up to the floor's CPU time
FLOOR = """
import os
for v in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(v, "1")
import numpy, pyarrow
"""


def run(argv: list[str], stdin: Path | None = None, stdout: Path | None = None) -> tuple[float, float, int]:
    """(CPU s, wall s, peak RSS bytes) of one command (its own process only); raises on a non-zero exit."""
    fi = open(stdin, "rb") if stdin else subprocess.DEVNULL  # noqa: SIM115
    fo = open(stdout, "wb") if stdout else subprocess.DEVNULL  # noqa: SIM115
    with tempfile.NamedTemporaryFile("r", suffix=".txt") as rep:
        res = subprocess.run(
            [sys.executable, "-c", LAUNCHER, rep.name, *argv], stdin=fi, stdout=fo, stderr=subprocess.PIPE
        )
        fields = rep.read().split()
    for f in (fi, fo):
        if f is not subprocess.DEVNULL:
            f.close()
    if res.returncode != 0 or len(fields) != 4 or fields[3] != "0":
        raise RuntimeError(f"{' '.join(argv)} failed: {res.stderr.decode()[-400:]}")
    return float(fields[0]), float(fields[1]), int(fields[2])


def best(argv: list[str], repeat: int = 3, **kw: Path | None) -> tuple[float, float, int]:
    """(min CPU s, min wall s, min peak RSS bytes) over ``repeat`` runs."""
    return best_and_median(argv, repeat, **kw)[:3]


#: runs of the rts-smooth and pf-holds cases: on a shared machine identical runs of a ~1 s command spread by
#: up to 1.6x (other work, page faults); the minimum is the figure, the median is printed beside it
REPEAT = 5


def best_and_median(argv: list[str], repeat: int = REPEAT, **kw: Path | None) -> tuple[float, float, int, float]:
    """(min CPU s, min wall s, min peak RSS bytes, median CPU s) over ``repeat`` runs."""
    res = [run(argv, **kw) for _ in range(repeat)]
    cpu = sorted(r[0] for r in res)
    return cpu[0], min(r[1] for r in res), min(r[2] for r in res), cpu[len(cpu) // 2]


def skijump_day(folder: Path, jumps: int) -> tuple[Path, list[float], list[float], int]:
    """The jumps of one day as one session: sessions shifted in time, 60 s of no logging between them."""
    import pyarrow as pa

    from sportfusion.core import io as sfio
    from sportfusion.skijump.hillfile import load_hill
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

    hill = load_hill("oberstdorf_hs106")
    tables, to, td, offset, meta = [], [], [], 0.0, None
    for seed in range(1, jumps + 1):
        sim = simulate_skijump(hill, SkiJumpConfig(seed=seed))
        meta = meta or sim.session_meta
        tt = sim.truth_meta["skijump"]["times"]
        t = sim.session.column("t").to_numpy()
        tables.append(sim.session.set_column(0, "t", pa.array(t + offset)))
        to.append(tt["takeoff"] + offset)
        td.append(tt["touchdown"] + offset)
        offset += float(t[-1]) + 60.0
    day = pa.concat_tables(tables, promote_options="default")
    path = folder / "day.parquet"
    sfio.write_table(day, meta, path)
    return path, to, td, day.num_rows


def skijump_long(folder: Path, rest_after: float) -> tuple[Path, list[float], list[float], int]:
    from sportfusion.core import io as sfio
    from sportfusion.skijump.hillfile import load_hill
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

    hill = load_hill("oberstdorf_hs106")
    sim = simulate_skijump(hill, SkiJumpConfig(seed=0, rest_after=rest_after))
    tt = sim.truth_meta["skijump"]["times"]
    path = folder / "long.parquet"
    sfio.write_table(sim.session, sim.session_meta, path)
    return path, [tt["takeoff"]], [tt["touchdown"]], sim.session.num_rows


def filterpy_us_per_step(slice_steps: int) -> float:
    """filterpy EKF + RTS smoother, CPU us per step on the first steps of the 60k session's model."""
    sys.path.insert(0, str(HERE))
    from bench_rts_speed import build, time_filterpy

    hill, _, inp, cfg, _ = build(98.0)
    c0 = time.process_time()
    time_filterpy(inp, hill, cfg, slice_steps)
    return (time.process_time() - c0) / slice_steps * 1e6


def rts(folder: Path, quick: bool) -> None:
    print("== rts-smooth, whole command (CPU s / wall s; us/step CPU; peak RSS per step)")
    fp = float("nan")
    if not quick:
        try:
            fp = filterpy_us_per_step(2000)
        except ImportError:
            print("  filterpy is not installed (pip install filterpy): ratio skipped")
    cases = [("training day, 23 jumps", skijump_day(folder, 5 if quick else 23))]
    cases.append(("one session", skijump_long(folder, 98.0 if quick else 578.0)))
    run([str(BIN / "rts-smooth"), "--help"])  # warm the page cache
    for label, (path, to, td, n) in cases:
        argv = [str(BIN / "rts-smooth"), str(path), "--hill", "oberstdorf_hs106", "-q"]
        argv += ["--takeoff", ",".join(f"{v:.3f}" for v in to), "--touchdown", ",".join(f"{v:.3f}" for v in td)]
        run(argv, stdout=folder / "warm.parquet")  # numba cache written/loaded once before timing
        cpu, wall, rss, med = best_and_median(argv, stdout=folder / "out.parquet")
        us = cpu / n * 1e6
        print(
            f"  {label:<24} {n:6d} steps: {cpu:6.2f} s CPU (median of {REPEAT}: {med:.2f}) {wall:6.2f} s wall, "
            f"{us:5.1f} us/step "
            f"(filterpy {fp:.0f} us/step: x{fp / us:.0f}; target < 1 s, >= 30x), "
            f"peak RSS {rss / n / 1024:.1f} KB/step (target <= 8)"
        )


# spline-smooth without the spline: start, imports, read, the output's columns (cheap copies), write to stdout
IO_FLOOR = """
import sys
from sportfusion.tools import _cli
sys.meta_path.insert(0, _cli._NoPandas)
import numpy as np
from sportfusion.core import io as sfio
from sportfusion.core.schema import floats
from sportfusion.core.session import with_columns
table, meta = sfio.read_table(sys.argv[1])
x = floats(table, "gnss_x")
names = "x y z vx vy vz ax ay az speed distance course std_x std_y std_z gnss_weight".split()
cols = {n: x * (1.0 + 1e-3 * i) for i, n in enumerate(names)}
cols["spline_filled"] = np.zeros(x.size, bool)
sfio.write_table(with_columns(table, cols), meta, None)
"""


def spline(folder: Path, quick: bool) -> None:
    import pyarrow as pa

    from sportfusion.core import io as sfio
    from sportfusion.core.meta import new_meta

    print("== spline-smooth, whole command vs csaps' compute alone (3 coordinates, lambda 0.9)")
    rows = []
    for n in (100_000, 200_000) if quick else (100_000, 1_000_000):
        rng = np.random.default_rng(0)
        t = np.cumsum(rng.uniform(0.05, 0.15, n))
        y = np.column_stack((np.sin(t / 3), np.cos(t / 5), 0.01 * t)) + 0.02 * rng.standard_normal((n, 3))
        table = pa.table(
            {
                "t": t,
                **{f"gnss_{a}": y[:, i] for i, a in enumerate("xyz")},
                "gnss_fix": pa.array(np.full(n, 4, np.int16)),
                **{f"std_gnss_{a}": np.full(n, 0.02) for a in "xyz"},
            }
        )
        path = folder / f"track{n}.parquet"
        sfio.write_table(table, new_meta(), path)
        argv = [str(BIN / "spline-smooth"), str(path), "--lambda", "0.9", "-q"]
        run(argv, stdout=folder / "warm.parquet")
        cpu, wall, _ = best(argv, 2, stdout=folder / "out.parquet")
        peer = float("nan")
        try:
            import csaps

            c0 = time.process_time()
            csaps.CubicSmoothingSpline(t, y.T, smooth=0.9)
            peer = time.process_time() - c0
        except ImportError:
            pass
        floor = best([sys.executable, "-c", IO_FLOOR, str(path)], 2, stdout=folder / "floor.parquet")[0]
        rows.append((n, cpu))
        print(
            f"  {n:>9,} epochs: {cpu:6.2f} s CPU {wall:6.2f} s wall ({cpu / n * 1e6:.2f} us/epoch); "
            f"csaps compute alone {peer:.2f} s CPU: x{peer / cpu:.2f} (target >= 2 at 1e6, ours with I/O); "
            f"I/O floor {floor:.2f} s CPU (start, read, write; compute {cpu - floor:.2f} s)"
        )
    (n1, c1), (n2, c2) = rows
    print(f"  growth: x{c2 / c1:.1f} CPU for x{n2 / n1:.0f} epochs (linear: at most x{n2 / n1:.0f})")


def pf(folder: Path) -> None:
    print("== pf-holds, whole command on a 35 s trial")
    holds = folder / "holds.parquet"
    raw = folder / "boulder.parquet"
    with open(raw, "wb") as fo:
        subprocess.run(
            [str(BIN / "simulate"), "boulder", "--seed", "5", "--duration", "35", "--holds", str(holds)],
            stdout=fo,
            stderr=subprocess.DEVNULL,
            check=True,
        )
    trial = folder / "trial.parquet"
    run([str(BIN / "detect-events"), str(raw), "--kind", "grips", "-q"], stdout=trial)
    from sportfusion.core import io as sfio
    from sportfusion.core.schema import floats

    tt = floats(sfio.read_table(str(trial))[0], "t")
    dur = float(tt[-1] - tt[0])
    argv = [str(BIN / "pf-holds"), str(trial), "--holds", str(holds), "-q"]
    cpu, wall, _, med = best_and_median(argv, stdout=folder / "out.parquet")
    print(
        f"  {dur:.1f} s trial: {cpu:.2f} s CPU (median of {REPEAT}: {med:.2f}) {wall:.2f} s wall: "
        f"x{dur / cpu:.0f} real time (CPU; target >= 60)"
    )


def startup(folder: Path) -> None:
    import pyarrow as pa

    from sportfusion.core import io as sfio
    from sportfusion.core.meta import new_meta

    print("== start-up: --help of every command and a no-op stage vs `python -c 'import numpy, pyarrow'` (best of 3)")
    floor = best([sys.executable, "-c", FLOOR])
    print(f"  {'floor':<22} {floor[0]:.3f} s CPU {floor[1]:.3f} s wall")
    worst = 0.0
    for c in COMMANDS:
        cpu, wall, _ = best([str(BIN / c), "--help"])
        worst = max(worst, cpu / floor[0])
        print(f"  {c + ' --help':<22} {cpu:.3f} s CPU {wall:.3f} s wall  x{cpu / floor[0]:.2f}")
    small = folder / "small.parquet"
    sfio.write_table(pa.table({"t": np.arange(20) * 0.01, "acc_x": np.zeros(20)}), new_meta(), small)
    cpu, wall, _ = best([str(BIN / "inspect"), str(small)])
    print(f"  {'inspect (20 rows)':<22} {cpu:.3f} s CPU {wall:.3f} s wall  x{cpu / floor[0]:.2f}")
    print(f"  worst --help: x{worst:.2f} the floor (target <= 1.5)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller inputs, no filterpy")
    parts = ("startup", "pf", "spline", "rts")
    ap.add_argument("--only", default=",".join(parts), help=f"comma-separated parts to run, of {', '.join(parts)}")
    a = ap.parse_args()
    only = {p.strip() for p in a.only.split(",") if p.strip()}
    if not only <= set(parts):
        ap.error(f"--only: unknown part(s) {', '.join(sorted(only - set(parts)))}; expected {', '.join(parts)}")
    print(f"{os.cpu_count()} CPU(s); CPU time = user + system of the command's process (os.wait4)")
    # bytecode written once, as an install or a first run does (where PYTHONDONTWRITEBYTECODE is set, every
    # run would otherwise compile the package's modules again: 0.15-0.2 s that no user pays twice)
    root = HERE.parent
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(root / "lib"), str(root / "tools")], check=False)
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        if "startup" in only:
            startup(folder)
        if "pf" in only:
            pf(folder)
        if "spline" in only:
            spline(folder, a.quick)
        if "rts" in only:
            rts(folder, a.quick)
    print("timings on a shared machine are noisy: CPU time is the figure to compare")


if __name__ == "__main__":
    sys.exit(main())
