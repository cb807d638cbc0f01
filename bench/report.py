"""Run every ``bench/bench_*.py`` and write one markdown report of what they print.

Each benchmark prints our figure beside the paper's (accuracy) or the peer library's (speed), measured
in one process so the ratio is fair. This script runs them one after another (one at a time, so the
timings don't compete), echoes their output, and writes ``bench-report.md`` (or ``-o FILE``) with one
section per benchmark, its wall time and exit status, and the machine it ran on.

Run: ``make bench`` or ``python bench/report.py [-o FILE] [--only NAME ...] [--timeout S]``.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", type=Path, default=Path("bench-report.md"), help="report file (markdown)")
    ap.add_argument("--only", nargs="*", default=None, help="run only these benchmarks (name without bench_/.py)")
    ap.add_argument("--timeout", type=float, default=1800.0, help="per-benchmark limit [s]")
    args = ap.parse_args()
    scripts = sorted(HERE.glob("bench_*.py"))
    if args.only:
        scripts = [s for s in scripts if s.stem.removeprefix("bench_") in args.only]
    now = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    parts = [
        "# sportfusion benchmark report",
        "",
        f"{now}; Python {platform.python_version()} on {platform.machine()}, {os.cpu_count()} CPU(s), "
        f"{platform.platform()}. Each section is one benchmark script's output: our figures beside the "
        "papers' and the peer libraries', measured in one process.",
        "",
    ]
    failed = []
    for script in scripts:
        print(f"== {script.name}", flush=True)
        start = time.perf_counter()
        try:
            res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=args.timeout)
            out, code = res.stdout + (("\n" + res.stderr) if res.returncode else ""), res.returncode
        except subprocess.TimeoutExpired as exc:
            out, code = (exc.stdout or b"").decode() if isinstance(exc.stdout, bytes) else (exc.stdout or ""), "timeout"
        wall = time.perf_counter() - start
        print(out, flush=True)
        if code != 0:
            failed.append(script.name)
        parts += [
            f"## {script.stem.removeprefix('bench_')}",
            "",
            f"`{script.name}`: {wall:.0f} s, exit {code}",
            "",
            "```",
            out.rstrip(),
            "```",
            "",
        ]
    args.output.write_text("\n".join(parts))
    print(f"wrote {args.output}" + (f"; FAILED: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
