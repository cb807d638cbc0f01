"""Speed as the user pays it: whole commands (a fresh process each), CPU time beside wall time.

Every figure is the CPU time (user + system, ``os.wait4`` of the child) of one whole command --
interpreter start, imports, loading the C extensions, reading, computing, writing -- beside its wall time,
and the peer measured in this same run:

1. ``rts-smooth`` on a training day of 23 simulated jumps (``simulate skijump`` seeds 1-23, logging
   paused between jumps, ~60k IMU steps) and on one 60k-step session (one jump, a long rest after
   it); peer: filterpy's ``ExtendedKalmanFilter`` + ``rts_smoother`` on the same model, per step
   (``bench_rts_speed.time_filterpy`` on a slice, CPU time).  Peak RSS of the command per step.
2. ``spline-smooth`` at 1e5 and 1e6 epochs (linear in N?); peer: a whole script doing the same job
   (:data:`PEER_SPLINE`: read the table with pyarrow, csaps' smoothing splines of x, y, z with their first
   and second derivatives and the speed, write a Parquet table of those columns; the ratio is to csaps'
   one fit of all three coordinates, and the script fitting each coordinate on its own is printed beside
   it), CPU time of its process, runs alternating with ours.  Beside them the command's I/O floor: a process that starts, imports, reads
   the same table and writes one with the same 25 columns (no spline).
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
        run(argv, stdout=folder / "warm.parquet")  # the page cache warmed once before timing
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

#: the peer's whole script for the same job: read the table with pyarrow, csaps' smoothing splines of x, y, z
#: with their first and second derivatives and the speed, write a Parquet table of those columns.  The same fit
#: as ours: csaps' p is the paper's lambda and its weights are eq 6's 1/sigma [1/m] (on the bench's track the
#: two agree to 1e-5 m; ours also screens outliers and writes 1-sigma, distance and course).  ``joint``: one
#: csaps fit of the (3, n) array with x's sigmas (csaps at its best; the bench's sigmas are the same for x, y,
#: z); ``each``: one fit per coordinate, as a script written column by column would do
PEER_SPLINE = """
import sys
import csaps
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
names = ["gnss_x", "gnss_y", "gnss_z", "std_gnss_x", "std_gnss_y", "std_gnss_z"]
table = pq.read_table(sys.argv[1], columns=["t", *names])
t = table.column("t").to_numpy()
xyz, sig = np.vstack([table.column(c).to_numpy() for c in names]).reshape(2, 3, -1)
if sys.argv[4] == "joint":
    sp = csaps.CubicSmoothingSpline(t, xyz, weights=1.0 / sig[0], smooth=float(sys.argv[3]))
    val, d1, d2 = sp(t), sp(t, nu=1), sp(t, nu=2)
else:
    fits = [csaps.CubicSmoothingSpline(t, y, weights=1.0 / s, smooth=float(sys.argv[3])) for y, s in zip(xyz, sig)]
    val, d1, d2 = (np.vstack([sp(t, nu=k) for sp in fits]) for k in (0, 1, 2))
cols = {"t": t}
for i, a in enumerate("xyz"):
    cols[a], cols["v" + a], cols["a" + a] = val[i], d1[i], d2[i]
cols["speed"] = np.sqrt(d1[0] ** 2 + d1[1] ** 2 + d1[2] ** 2)
pq.write_table(pa.table(cols), sys.argv[2])
"""

#: spline-smooth's target against the peer's whole script at 1e6 epochs (issue 40)
SPLINE_TARGET = 3.0


def spline(folder: Path, quick: bool) -> None:
    import pyarrow as pa

    from sportfusion.core import io as sfio
    from sportfusion.core.meta import new_meta
    from sportfusion.core.schema import floats

    print(
        "== spline-smooth, whole command vs the peer's whole script (read with pyarrow, csaps x, y, z with 1st and "
        "2nd derivatives and speed, write Parquet), lambda 0.9, CPU s min of 3 alternating runs"
    )
    try:
        import csaps  # noqa: F401

        peer_ok = True
    except ImportError:
        print("  csaps is not installed (pip install -e '.[bench]'): the peer is skipped")
        peer_ok = False
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
        peer_argv = [sys.executable, "-c", PEER_SPLINE, str(path), str(folder / "peer.parquet"), "0.9"]
        run(argv, stdout=folder / "warm.parquet")
        ours, peer, each = [], [], []
        for _ in range(3):  # alternating: all see the same moments of a shared machine
            ours.append(run(argv, stdout=folder / "out.parquet"))
            if peer_ok:
                peer.append(run([*peer_argv, "joint"]))
                each.append(run([*peer_argv, "each"]))
        cpu, wall = min(r[0] for r in ours), min(r[1] for r in ours)
        pcpu = min(r[0] for r in peer) if peer else float("nan")
        pmed = sorted(r[0] for r in peer)[1] if peer else float("nan")
        ecpu = min(r[0] for r in each) if each else float("nan")
        med = sorted(r[0] for r in ours)[1]
        floor = best([sys.executable, "-c", IO_FLOOR, str(path)], 2, stdout=folder / "floor.parquet")[0]
        rows.append((n, cpu))
        same = ""
        if peer_ok:  # the same job: the same positions
            import pyarrow.parquet as pq

            ours_t, peer_t = sfio.read_table(folder / "out.parquet")[0], pq.read_table(folder / "peer.parquet")
            d = max(float(np.max(np.abs(floats(ours_t, c) - floats(peer_t, c)))) for c in "xyz")
            same = f"; positions equal to the peer's within {d:.0e} m"
        target = f" (target >= {SPLINE_TARGET:g} at 1e6)" if n == 1_000_000 else ""
        print(
            f"  {n:>9,} epochs: ours {cpu:5.2f} s CPU (median {med:.2f}) {wall:5.2f} s wall ({cpu / n * 1e6:.2f} "
            f"us/epoch) | peer's script {pcpu:5.2f} s CPU (median {pmed:.2f}) | x{pcpu / cpu:.2f}{target}; "
            f"the peer fitting each coordinate on its own {ecpu:5.2f} s: x{ecpu / cpu:.2f}; "
            f"I/O floor {floor:.2f} s CPU (start, read, write; our compute {cpu - floor:.2f} s){same}"
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
