"""Batch reprocessing: the per-session results of a sessions folder gathered into one summary table.

``pipelines/batch.mk`` runs ``pipelines/session.mk`` for every ``SESSIONS/<name>/config.mk`` into
``OUT/<name>/`` (with ``make -k -j N``: one bad session does not stop the others) and then
``python -m sportfusion.batch OUT`` to write ``OUT/summary.parquet`` (kind ``summary``), a CSV copy,
a readable table listing each failed session with its error line, and ``OUT/index.html`` (the batch's
page for people, linking each session's ``report.html``).
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import schema
from sportfusion.core.describe import ms_to_kmh
from sportfusion.core.errors import InputError

__all__ = [
    "read_config",
    "session_inputs",
    "session_resources",
    "session_row",
    "collect",
    "summary_table",
    "format_summary",
    "main",
]

#: config.mk keys that name a session's input files (RAW may list several).
INPUT_KEYS = ("RAW", "TRUTH", "GATES", "HOLDS", "VIDEO", "MARKERS")

#: Result table of each sport (the pipeline's last stage), relative to the session's OUT folder.
RESULTS = {
    "skijump": "smoothed.parquet",
    "skirace": "attitude.parquet",
    "gates": "anchored.parquet",
    "climbing": "holds.parquet",
}
#: Summary columns in order: (name, arrow type).
COLUMNS: tuple[tuple[str, pa.DataType], ...] = (
    ("session", pa.string()),
    ("sport", pa.string()),
    ("status", pa.string()),
    ("error", pa.string()),
    ("duration", pa.float64()),
    ("max_speed", pa.float64()),
    ("jumps", pa.int64()),
    ("jump_length", pa.float64()),
    ("takeoff_speed", pa.float64()),
    ("video_jump_length", pa.float64()),
    ("pos_rms", pa.float64()),
    ("vel_rms", pa.float64()),
)


def read_config(path: Path) -> dict[str, str]:
    """``KEY = VALUE`` lines of a session's ``config.mk`` (comments and blank lines skipped)."""
    out: dict[str, str] = {}
    for line in path.read_text().splitlines():
        m = re.match(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*[:?]?=\s*(.*?)\s*$", line.split("#", 1)[0])
        if m:
            out[m.group(1)] = m.group(2)
    return out


def session_inputs(session: Path) -> list[str]:
    """The files a session's pipeline reads: its ``config.mk`` and every file the config names.

    Files named by :data:`INPUT_KEYS` that do not exist are left out here (the pipeline itself then fails
    with its own error line for that session, which the batch reports), so one broken session never
    stops the workflow engine from scheduling the others.
    """
    session = Path(session)
    cfg = session / "config.mk"
    files = [str(cfg)]
    if cfg.exists():
        values = read_config(cfg)
        for key in INPUT_KEYS:
            for name in values.get(key, "").split():
                f = session / name
                if f.is_file():
                    files.append(str(f))
    return files


def session_resources(input_files: Any, attempt: int = 1) -> dict[str, int]:
    """Resources to ask a scheduler for one session job: memory [MB] and run time [min].

    Sized by the session's length through the total size of its input files (``S`` MB): the whole
    per-session pipeline peaks below ~8 KB of memory per IMU step and a raw MB holds roughly 10-20 k
    samples, so ``mem_mb = 1000 + 200 S`` (doubled on a retry) and ``runtime = 10 + 2 S`` minutes cover
    every sport with room (a 60 k-step ski-jump day is ~5 MB of raw files: 2 GB, 20 min).

    Parameters
    ----------
    input_files : iterable of str or an object with ``size_mb``
        The session's input files (:func:`session_inputs`), or Snakemake's ``input``.
    attempt : int
        1 for the first try, 2 for the first retry, ...
    """
    size = getattr(input_files, "size_mb", None)
    if size is None:
        size = sum(Path(f).stat().st_size for f in input_files if Path(f).exists()) / 1e6
    mem = int(1000 + 200 * float(size))
    return {"mem_mb": mem * (2 if attempt > 1 else 1), "runtime": int(10 + 2 * float(size))}


def _floats(table: pa.Table, name: str) -> np.ndarray | None:
    return schema.floats(table, name) if name in table.column_names else None


def _rms_3d(summary: pa.Table, names: tuple[str, str, str]) -> float:
    """3-D RMS [m or m/s] from an evaluate summary's ``phase == all, stat == rms`` row."""
    phase, stat = summary.column("phase").to_pylist(), summary.column("stat").to_pylist()
    rows = [i for i, (p, s) in enumerate(zip(phase, stat, strict=True)) if p == "all" and s == "rms"]
    if not rows or not all(n in summary.column_names for n in names):
        return float("nan")
    vals = np.array([summary.column(n)[rows[0]].as_py() or np.nan for n in names], float)
    return float(np.sqrt(np.sum(vals**2)))


def session_row(name: str, config: dict[str, str], out: Path) -> dict[str, Any]:
    """One summary row from a session's output folder.

    Parameters
    ----------
    name : str
        Session name (its folder's name).
    config : dict
        Its ``config.mk`` values (``SPORT`` ...).
    out : Path
        Its output folder: ``error`` (written by batch.mk on failure), the result tables.

    Returns
    -------
    dict
        Column -> value; figures a sport does not produce are NaN (jumps: 0).
    """
    sport = config.get("SPORT", "?")
    row: dict[str, Any] = {c: None for c, _ in COLUMNS}
    row.update(session=name, sport=sport, status="ok", error="", jumps=0)
    err = out / "error"
    result = out / RESULTS.get(sport, "-")
    if err.exists() or not result.exists():
        row["status"] = "failed"
        row["error"] = err.read_text().strip() if err.exists() else f"no result {result.name}"
        return row
    table, _ = sfio.read_table(result)
    t = schema.floats(table, "t")
    row["duration"] = float(t[-1] - t[0])
    v = [_floats(table, f"v{a}") for a in "xyz"]
    speed = _floats(table, "speed")
    if speed is None and all(c is not None for c in v):
        speed = np.linalg.norm(np.column_stack(v), axis=1)
    if speed is not None and np.isfinite(speed).any():
        row["max_speed"] = float(np.nanmax(speed))
    jumps = out / "jumps.parquet"
    if jumps.exists():
        jt, _ = sfio.read_table(jumps, kind="jumps")
        row["jumps"] = jt.num_rows
        if jt.num_rows:
            for col in ("jump_length", "takeoff_speed"):
                if col in jt.column_names:
                    row[col] = float(jt.column(col)[0].as_py())
    video = out / "video.parquet"
    if video.exists():
        vt, _ = sfio.read_table(video, kind="jumps")
        if vt.num_rows and "jump_length" in vt.column_names:
            row["video_jump_length"] = float(vt.column("jump_length")[0].as_py())
    ev = out / "evaluation.parquet"
    if ev.exists():
        st, _ = sfio.read_table(ev, kind="summary")
        row["pos_rms"] = _rms_3d(st, ("x", "y", "z"))
        row["vel_rms"] = _rms_3d(st, ("vx", "vy", "vz") if "vx" in st.column_names else ("vel_n", "vel_e", "vel_d"))
    return row


def collect(sessions: Path, out: Path) -> list[dict[str, Any]]:
    """Summary rows of every ``sessions/<name>/config.mk``, in name order.

    Raises
    ------
    InputError
        No session folder with a ``config.mk``.
    """
    configs = sorted(sessions.glob("*/config.mk"))
    if not configs:
        raise InputError(f"{sessions} has no <session>/config.mk; expected one folder per session")
    rows = []
    for cfg in configs:
        name = cfg.parent.name
        try:
            rows.append(session_row(name, read_config(cfg), out / name))
        except InputError as exc:
            rows.append({**{c: None for c, _ in COLUMNS}, "session": name, "status": "failed", "error": str(exc)})
    return rows


def summary_table(rows: list[dict[str, Any]]) -> pa.Table:
    """The rows as a pyarrow table with :data:`COLUMNS` (missing figures null)."""
    cols = {}
    for name, typ in COLUMNS:
        vals = [r.get(name) for r in rows]
        if pa.types.is_floating(typ):
            vals = [None if v is None or not np.isfinite(v) else float(v) for v in vals]
        cols[name] = pa.array(vals, typ)
    return pa.table(cols)


#: what the summary's text columns mean (printed under the table)
SUMMARY_LEGEND = (
    "time: the recording's length; v_max: the largest estimated speed; jump: jump length along the landing "
    "profile (jump-metrics); video: the same read from the landing video (video-jumplength); v_takeoff: the "
    "speed at take-off; [km/h]: the speed before it in km/h; pos_RMS, vel_RMS: 3-D RMS error of position and "
    "velocity against the simulated truth (evaluate); -: not measured for this session"
)


def format_summary(rows: list[dict[str, Any]]) -> str:
    """A readable table: one line per session (units in brackets in the header), what the columns mean,
    then the failed sessions with their errors."""
    head = (
        f"{'session':<16} {'sport':<9} {'status':<7} {'time[s]':>7} {'v_max[m/s]':>10} {'[km/h]':>7} "
        f"{'jump[m]':>7} {'video[m]':>8} {'v_takeoff[m/s]':>14} {'[km/h]':>7} {'pos_RMS[m]':>10} {'vel_RMS[m/s]':>12}"
    )
    lines = [head, "-" * len(head)]

    def kmh(v: Any) -> float | None:
        return None if v is None else ms_to_kmh(v)

    def f(v: Any, fmt: str) -> str:
        missing = v is None or (isinstance(v, float) and not np.isfinite(v))
        return "-".rjust(int(fmt.split(".")[0])) if missing else format(v, fmt)

    for r in rows:
        lines.append(
            f"{r['session']:<16} {str(r.get('sport')):<9} {r['status']:<7} {f(r.get('duration'), '7.1f')} "
            f"{f(r.get('max_speed'), '10.2f')} {f(kmh(r.get('max_speed')), '7.1f')} {f(r.get('jump_length'), '7.2f')} "
            f"{f(r.get('video_jump_length'), '8.2f')} {f(r.get('takeoff_speed'), '14.2f')} "
            f"{f(kmh(r.get('takeoff_speed')), '7.1f')} {f(r.get('pos_rms'), '10.3f')} {f(r.get('vel_rms'), '12.3f')}"
        )
    import textwrap

    lines += textwrap.wrap(SUMMARY_LEGEND, len(head), initial_indent="", subsequent_indent="  ")
    failed = [r for r in rows if r["status"] != "ok"]
    lines.append(f"\n{len(rows) - len(failed)} of {len(rows)} sessions ok, {len(failed)} failed")
    lines += [f"  FAILED {r['session']}: {r['error']}" for r in failed]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """``python -m sportfusion.batch OUT [--sessions DIR]``: write OUT/summary.{parquet,csv,txt}; exit 1 if any
    session failed."""
    ap = argparse.ArgumentParser(prog="python -m sportfusion.batch", description=main.__doc__)
    ap.add_argument("out", type=Path, help="batch output folder (one sub-folder per session)")
    ap.add_argument("--sessions", type=Path, required=True, help="sessions folder (one sub-folder per session)")
    ap.add_argument("--engine", default="make", help="what ran the sessions, for the provenance (e.g. 'snakemake 9.1')")
    ap.add_argument("--engine-params", default="", help="the engine's settings, for the provenance (free text)")
    args = ap.parse_args(argv)
    try:
        rows = collect(args.sessions, args.out)
    except InputError as exc:
        print(f"Error: batch: {exc}", file=sys.stderr)
        return 1
    table = summary_table(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    meta = sfmeta.add_provenance(
        sfmeta.new_meta("summary"),
        "batch",
        {
            "engine": args.engine,
            "engine_params": args.engine_params,
            "sessions": str(args.sessions),
            "ok": sum(r["status"] == "ok" for r in rows),
            "failed": sum(r["status"] != "ok" for r in rows),
        },
    )
    sfio.write_bytes(sfio.table_to_bytes(table, meta), args.out / "summary.parquet")
    import pyarrow.csv as pacsv

    pacsv.write_csv(table, args.out / "summary.csv")
    text = format_summary(rows)
    (args.out / "summary.txt").write_text(text + "\n")
    from sportfusion.report.batch import batch_index, session_pages

    names = [r["session"] for r in rows]
    index = batch_index(table, session_pages(args.out, names), f"Batch report: {args.sessions.name}")
    sfio.write_bytes(index.encode("utf-8"), args.out / "index.html")
    print(text)
    return 0 if all(r["status"] == "ok" for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
