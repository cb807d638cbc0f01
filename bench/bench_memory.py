"""Peak memory and CPU of every command on long recordings: 1 h and 2 h of 100 Hz sensors.

Each sport's session is a simulated one (``simulate``) repeated end to end with its clock shifted (the
simulators make minutes; a day's recording is many such stretches).  Every command then runs once on the
1 h and once on the 2 h session, as a process of its own (forked by a small launcher, see :data:`LAUNCHER`);
its CPU time (user + system) and its peak resident set come from ``wait4``'s resource usage, so the figures
are the command's own, however loaded the machine is.

Printed per command: the input table's size in memory [MiB] (Arrow buffers), the peak RSS [MiB] and CPU
[s] at 1 h and 2 h, the memory the command needs per hour of recording (the 2 h peak less the 1 h peak
[MiB/h]) and that over the table's own size per hour ("x table": the issue-38 goal is about 2), and the
CPU and memory growth 2 h / 1 h (linear cost: CPU about 2.0, memory below 2.0 since the fixed start-up
share does not grow).

Run: ``python bench/bench_memory.py [--hours 1 2] [--only dmc-attitude,detect-events] [--keep DIR]``.
The sessions of one sport are built once per run (a few minutes); the whole table takes ~20-40 min of CPU.
Not here: ``simulate`` (its output is at most 600 s), ``compare-runs`` and ``gate-anchor`` (a run of one course,
minutes: a tiled course repeats its gates, which gate-anchor refuses) and ``video-jumplength`` (a video).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
HILL = "oberstdorf_hs106"


@dataclass
class Run:
    rc: int
    cpu: float
    rss: float
    wall: float
    err: str


#: A small launcher process between this one and the command: a process's peak RSS as ``wait4`` reports it
#: includes the RSS of the process it was forked from (Linux keeps the largest resident set across fork and
#: exec), and this script holds the tiled tables in memory; the launcher is ~10 MB.
LAUNCHER = """
import os, sys
pid = os.fork()
if pid == 0:
    os.execv(sys.argv[1], sys.argv[1:])
_, status, u = os.wait4(pid, 0)
print(os.waitstatus_to_exitcode(status), u.ru_utime + u.ru_stime, u.ru_maxrss / 1024.0, file=sys.stderr)
"""


def run(argv: list[str], stdin: Path | None = None, stdout: Path | None = None) -> Run:
    """One command as a grandchild process: exit code, CPU [s] (user + system), peak RSS [MiB], wall [s]."""
    fin = open(stdin, "rb") if stdin else subprocess.DEVNULL  # noqa: SIM115
    fout = open(stdout, "wb") if stdout else subprocess.DEVNULL  # noqa: SIM115
    start = time.perf_counter()
    exe = [sys.executable, "-c", LAUNCHER, str(BIN / argv[0]), *argv[1:]]
    p = subprocess.run(exe, stdin=fin, stdout=fout, stderr=subprocess.PIPE)
    for fh in (fin, fout):
        if hasattr(fh, "close"):
            fh.close()
    lines = p.stderr.decode(errors="replace").splitlines()
    rc, cpu, rss = lines[-1].split()
    return Run(int(rc), float(cpu), float(rss), time.perf_counter() - start, "\n".join(lines[:-1]))


def must(argv: list[str], stdin: Path | None = None, stdout: Path | None = None) -> Run:
    r = run(argv, stdin, stdout)
    if r.rc:
        raise SystemExit(f"{' '.join(argv)} failed: {r.err.strip()[-400:]}")
    return r


def tile(src: Path, dst: Path, seconds: float) -> tuple[int, float]:
    """``src`` repeated end to end (t shifted by its span) until it covers ``seconds``; (rows, MiB in memory)."""
    import numpy as np
    import pyarrow as pa

    from sportfusion.core import io as sfio

    table, meta = sfio.read_table(src, kind=None)
    t = table.column("t").to_numpy()
    span = float(t[-1] - t[0]) + float(np.median(np.diff(t)))
    n = max(1, int(np.ceil(seconds / span)))
    parts = [table.set_column(0, "t", pa.array(t + k * span)) for k in range(n)]
    big = pa.concat_tables(parts).combine_chunks()
    meta = dict(meta)
    meta.pop("events", None)  # events of the stretch would name instants of the first copy only
    sfio.write_table(big, meta, dst)
    return big.num_rows, big.nbytes / 2**20


def table_mib(path: Path) -> float:
    from sportfusion.core import io as sfio

    return sfio.read_table(path, kind=None)[0].nbytes / 2**20


# -- what each sport's commands read -------------------------------------------------------------------------------


def skirace(d: Path, hours: float) -> dict[str, tuple[list[str], Path | None]]:
    base = d / "skirace_600s.parquet"
    if not base.exists():
        must(["simulate", "skirace", "--seed", "1", "--duration", "600", "--imu-rate", "100", "-q", "-o", str(base)])
    s = d / f"skirace_{hours:g}h.parquet"
    tile(base, s, hours * 3600)
    csv = d / f"skirace_{hours:g}h.csv"
    must(["inspect", str(s), "--csv"], stdout=csv)
    smooth = d / f"skirace_{hours:g}h.smooth.parquet"
    must(["spline-smooth", str(s), "-q", "-o", str(smooth)])
    return {
        "ingest (CSV)": (["ingest", str(csv), "-q"], None),
        "inspect": (["inspect", str(s)], None),
        "gps2hill": (["gps2hill", str(s), "--origin", "auto", "-q"], None),
        "spline-smooth": (["spline-smooth", str(s), "-q"], None),
        "dmc-attitude": (["dmc-attitude", str(smooth), "-q"], None),
        "report (skirace)": (["report", str(smooth), "--sport", "skirace", "-q", "-o", str(d / "r.html")], None),
        "plot series": (["plot", "series", str(smooth), "-q", "-o", str(d / "series.png")], None),
    }


def skijump(d: Path, hours: float) -> dict[str, tuple[list[str], Path | None]]:
    base, truth = d / "skijump_one.parquet", d / "skijump_one.truth.parquet"
    if not base.exists():
        must(["simulate", "skijump", "--seed", "1", "-q", "--truth", str(truth), "-o", str(base)])
    s, t = d / f"skijump_{hours:g}h.parquet", d / f"skijump_{hours:g}h.truth.parquet"
    tile(base, s, hours * 3600)
    tile(truth, t, hours * 3600)
    local = d / f"skijump_{hours:g}h.local.parquet"
    must(["gps2hill", str(s), "--hill", HILL, "-q", "-o", str(local)])
    events = d / f"skijump_{hours:g}h.events.parquet"
    must(["detect-events", str(local), "--kind", "jump", "-q", "-o", str(events)])
    est = d / f"skijump_{hours:g}h.rts.parquet"
    must(["rts-smooth", str(events), "--hill", HILL, "-q", "-o", str(est)])
    return {
        "detect-events --kind jump": (["detect-events", str(local), "--kind", "jump", "-q"], None),
        "rts-smooth": (["rts-smooth", str(events), "--hill", HILL, "-q"], None),
        "jump-metrics": (["jump-metrics", str(est), "-q"], None),
        "evaluate": (["evaluate", str(est), "--truth", str(t), "-q"], None),
    }


def climbing(d: Path, hours: float) -> dict[str, tuple[list[str], Path | None]]:
    base, holds = d / "boulder_one.parquet", d / "boulder_holds.parquet"
    if not base.exists():
        must(["simulate", "boulder", "--seed", "1", "-q", "--holds", str(holds), "-o", str(base)])
    s = d / f"boulder_{hours:g}h.parquet"
    tile(base, s, hours * 3600)
    grips = d / f"boulder_{hours:g}h.grips.parquet"
    must(["detect-events", str(s), "--kind", "grips", "-q", "-o", str(grips)])
    return {
        "detect-events --kind grips": (["detect-events", str(s), "--kind", "grips", "-q"], None),
        "pf-holds": (["pf-holds", str(grips), "--holds", str(holds), "-q"], None),
    }


def gates(d: Path, hours: float) -> dict[str, tuple[list[str], Path | None]]:
    base, survey = d / "gates_one.parquet", d / "gates_survey.parquet"
    if not base.exists():
        must(["simulate", "gates", "--seed", "1", "-q", "--gates", str(survey), "-o", str(base)])
    s = d / f"gates_{hours:g}h.parquet"
    tile(base, s, hours * 3600)
    return {"detect-events --kind gates": (["detect-events", str(s), "--kind", "gates", "-q"], None)}


SPORTS: dict[str, Callable[[Path, float], dict[str, tuple[list[str], Path | None]]]] = {
    "skirace": skirace,
    "skijump": skijump,
    "climbing": climbing,
    "gates": gates,
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, nargs=2, default=(1.0, 2.0), help="the two lengths [h]")
    ap.add_argument("--only", default="", help="comma-separated commands (names as printed) to run")
    ap.add_argument("--sports", default=",".join(SPORTS), help="comma-separated sports")
    ap.add_argument("--keep", type=Path, default=None, help="build the sessions in this folder and keep them")
    args = ap.parse_args()
    only = {s.strip() for s in args.only.split(",") if s.strip()}
    with tempfile.TemporaryDirectory(prefix="sf-mem-") as tmp:
        d = args.keep or Path(tmp)
        d.mkdir(parents=True, exist_ok=True)
        results: dict[str, list[tuple[float, Run, float]]] = {}
        for sport in args.sports.split(","):
            for hours in args.hours:
                cmds = SPORTS[sport](d, hours)
                for name, (argv, stdin) in cmds.items():
                    if only and name not in only:
                        continue
                    paths = [Path(a) for a in argv[1:] if a.endswith((".parquet", ".csv")) and Path(a).exists()]
                    src = paths[0].with_suffix(".parquet") if paths else None  # a CSV: the session it was made from
                    mib = table_mib(src) if src is not None and src.exists() else float("nan")
                    r = run(argv, stdin)
                    if r.rc:
                        print(f"# {name} at {hours:g} h failed: {r.err.strip()[-300:]}", file=sys.stderr)
                    results.setdefault(name, []).append((hours, r, mib))
                    print(f"# {name:28s} {hours:g} h: {r.cpu:7.1f} s CPU, {r.rss:7.0f} MiB peak", file=sys.stderr)
        h1, h2 = args.hours
        print(
            f"Peak memory and CPU of each command at {h1:g} h and {h2:g} h of recording (100 Hz sensors; gates: 500 Hz IMU)"
        )
        print(
            f"{'command':28s} {'table MiB':>9s} {'RSS ' + f'{h1:g}h':>8s} {'RSS ' + f'{h2:g}h':>8s} {'MiB/h':>7s} "
            f"{'x table':>7s} {'CPU ' + f'{h1:g}h':>8s} {'CPU ' + f'{h2:g}h':>8s} {'CPU x':>6s} {'RSS x':>6s}"
        )
        for name, rows in results.items():
            if len(rows) != 2:
                continue
            (_, a, ma), (_, b, mb) = rows
            per_h = (b.rss - a.rss) / (h2 - h1)
            table_h = (mb - ma) / (h2 - h1)
            ratio = per_h / table_h if table_h > 0 else float("nan")
            print(
                f"{name:28s} {mb:9.0f} {a.rss:8.0f} {b.rss:8.0f} {per_h:7.0f} {ratio:7.1f} {a.cpu:8.1f} {b.cpu:8.1f} "
                f"{b.cpu / max(a.cpu, 1e-9):6.2f} {b.rss / max(a.rss, 1e-9):6.2f}"
            )
        print("(table MiB: the input at the longer length; MiB/h: peak RSS growth per hour of recording; x table: that")
        print(" over the table's own growth per hour; CPU x / RSS x: the longer run over the shorter, 2.0 = linear)")


if __name__ == "__main__":
    main()
