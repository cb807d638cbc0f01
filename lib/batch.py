"""Batch reprocessing: the per-session results of a sessions folder gathered into one summary table.

``pipelines/batch.mk`` runs ``pipelines/session.mk`` for every ``SESSIONS/<name>/config.mk`` into
``OUT/<name>/`` (with ``make -k -j N``: one bad session does not stop the others) and then
``python -m sportfusion.batch OUT`` to write ``OUT/summary.parquet`` (kind ``summary``), a CSV copy,
a readable table listing each failed session with its error line, and ``OUT/index.html`` (the batch's
page for people, linking each session's ``report.html``). A session is ok only when every file its
target declares (``session.mk ... outputs``) exists and it left no ``error``.

The same module serves ``make cluster-batch`` (``pipelines/Snakefile``): the resources of a session job,
the scheduler's own error line of a job that SLURM refused or ended, and ``python -m sportfusion.batch
check-profile PROFILE``, which checks a SLURM profile against the cluster before anything is submitted.
"""

from __future__ import annotations

import argparse
import getpass
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
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
    "declared_outputs",
    "scheduler_error_line",
    "check_slurm_profile",
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
    samples, so ``mem_mb = 1000 + 200 S`` and ``runtime = 10 + 2 S`` minutes cover every sport with room
    (a 60 k-step ski-jump day is ~5 MB of raw files: 2 GB, 20 min). Each retry doubles both: on SLURM a
    retry is a new job, so one killed for memory (OUT_OF_MEMORY) or time (TIMEOUT) gets twice as much.

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
    factor = 2 ** max(int(attempt) - 1, 0)
    return {"mem_mb": int(1000 + 200 * float(size)) * factor, "runtime": int(10 + 2 * float(size)) * factor}


def declared_outputs(session: Path, out: Path, session_mk: Path, target: str = "all") -> list[Path] | None:
    """The files ``session.mk`` declares for a session's ``target`` (its ``outputs`` target).

    Parameters
    ----------
    session, out : Path
        The session's folder (with ``config.mk``) and its output folder.
    session_mk : Path
        ``pipelines/session.mk``.
    target : str
        ``all`` or one or more of ``results plots evaluation report`` (space-separated).

    Returns
    -------
    list of Path or None
        None when make cannot read the session's configuration (that session fails on its own).
    """
    cmd = ["make", "-s", "--no-print-directory", "-f", str(session_mk), f"SESSION={session}", f"OUT={out}"]
    try:
        run = subprocess.run([*cmd, f"TARGET={target}", "outputs"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return None
    if run.returncode != 0:
        return None
    return [Path(line) for line in run.stdout.splitlines() if line.strip()]


def scheduler_error_line(msg: str | None, log: str | None = None) -> str | None:
    """One line from a Snakemake executor's job-error message: what the scheduler said or did.

    ``sbatch: error: ...`` lines of a refused submission; ``SLURM job 123 ended CANCELLED`` (TIMEOUT,
    OUT_OF_MEMORY, NODE_FAIL, ...) for a job that the scheduler ended; the job's SLURM log when ``log``
    names one. None for an empty message (a local job: its own ``error`` file says why).
    """
    if not msg or not msg.strip():
        return None
    msg = msg.split("For further error details", 1)[0]
    logs = re.findall(r"[^\s'\",\[\]]*slurm_logs[^\s'\",\[\]]*", log or "")
    where = f" (its log: {logs[0]})" if logs else ""
    if "sbatch failed" in msg or "submission failed" in msg:
        m = re.search(r"The error message was '(.*?)'\.?\s*(?:\n\s*sbatch|$)", msg, re.S)
        lines = [ln.strip() for ln in (m.group(1) if m else msg).splitlines() if ln.strip()]
        errors = [ln for ln in lines if "error" in ln.lower()] or lines[:1]
        return "sbatch refused the job: " + "; ".join(dict.fromkeys(errors))
    m = re.search(r"SLURM-job '([^']+)' failed.*?SLURM status is: '([^']+)'", msg, re.S)
    if m:
        return f"SLURM job {m.group(1)} ended {m.group(2)}{where}"
    return " ".join(msg.split())[:300] + where


def _profile_resources(profile: dict[str, Any]) -> dict[str, str]:
    res = profile.get("default-resources") or {}
    if isinstance(res, list | tuple):
        res = dict(str(r).split("=", 1) for r in res if "=" in str(r))
    return {str(k): str(v).strip().strip("'\"") for k, v in dict(res).items()}


def _run(cmd: list[str]) -> tuple[int, str]:
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=30)
    except subprocess.TimeoutExpired:
        return 124, f"{cmd[0]} did not answer in 30 s (is slurmctld up?)"
    except OSError as exc:
        return 127, f"{cmd[0]}: {exc.strerror}"
    if r.returncode == 0:
        return 0, r.stdout
    lines = (r.stderr.strip() or r.stdout.strip()).splitlines()
    return r.returncode, lines[-1] if lines else f"exit status {r.returncode}"


#: The SLURM executor plugin checks a running job again at most this long after the last check [s].
MAX_STATUS_INTERVAL = 180


def check_slurm_profile(
    profile: dict[str, Any], where: str = "the profile", run: Callable[[list[str]], tuple[int, str]] = _run
) -> tuple[list[str], list[str]]:
    """What would make every job of a Snakemake SLURM profile fail or hang, found before submitting.

    Checked with the cluster's own commands: the partition exists (``sinfo``), the account is one of the
    user's (``sacctmgr``; skipped where the cluster keeps no accounts), the partition does not cancel
    pre-empted jobs, and with ``slurm-status-command: squeue`` that ``MinJobAge`` (how long slurmctld
    remembers a finished job) outlasts the plugin's longest pause between status checks
    (:data:`MAX_STATUS_INTERVAL`) -- else a finished job is never seen to finish.

    Parameters
    ----------
    profile : dict
        The profile's ``config.yaml`` as read by a YAML parser.
    where : str
        How to name the profile in messages.
    run : callable
        ``run(argv) -> (exit status, stdout or the last stderr line)``; the default runs the command.

    Returns
    -------
    problems, notes : list of str
        Problems (each one line: the run would fail or hang) and notes (worth knowing, not fatal).
    """
    problems: list[str] = []
    notes: list[str] = []
    if profile.get("executor") != "slurm":
        return problems, notes
    if shutil.which("sinfo") is None and run is _run:
        return [f"{where} submits to SLURM, but sinfo is not on PATH: run it on the cluster's login node"], notes
    res = _profile_resources(profile)
    partition, account = res.get("slurm_partition", ""), res.get("slurm_account", "")
    rc, out = run(["sinfo", "-h", "-o", "%R"])
    if rc != 0:
        return [f"sinfo failed: {out}"], notes
    partitions = sorted({p.strip() for p in out.split()})
    if partition and partition not in partitions:
        problems.append(
            f"partition '{partition}' (slurm_partition in {where}) is not on this cluster; "
            f"its partitions: {', '.join(partitions) or 'none'}"
        )
    user = getpass.getuser()
    rc, out = run(["sacctmgr", "-n", "-P", "show", "associations", "where", f"user={user}", "format=account"])
    if rc == 0:
        accounts = sorted({a.strip() for a in out.split()})
        if account and account not in accounts:
            problems.append(
                f"account '{account}' (slurm_account in {where}) is not one of {user}'s SLURM accounts: "
                f"{', '.join(accounts) or 'none'}"
            )
    else:
        notes.append(f"the account is not checked: sacctmgr says {out}")
    if partition and partition in partitions:
        rc, out = run(["scontrol", "-o", "show", "partition", partition])
        mode = re.search(r"PreemptMode=(\S+)", out) if rc == 0 else None
        if mode and "CANCEL" in mode.group(1).upper():
            problems.append(
                f"partition '{partition}' cancels pre-empted jobs (PreemptMode={mode.group(1)}): the engine "
                "would wait for such a job forever; use a partition that requeues them or none that pre-empts"
            )
    status = str(profile.get("slurm-status-command") or "")
    if status == "squeue":
        rc, out = run(["scontrol", "show", "config"])
        age = re.search(r"^MinJobAge\s*=\s*(\d+)", out, re.M) if rc == 0 else None
        if age and int(age.group(1)) <= MAX_STATUS_INTERVAL + 20:
            problems.append(
                f"MinJobAge is {age.group(1)} s on this cluster: squeue forgets a finished job before the "
                f"engine's next status check (up to {MAX_STATUS_INTERVAL} s apart); ask for MinJobAge >= 300 s, "
                f"or set slurm-status-command: sacct in {where} (then a cancelled job is not noticed)"
            )
    else:
        how = f"slurm-status-command: {status}" if status else "no slurm-status-command (the plugin then uses sacct)"
        notes.append(
            f"{where} has {how}; the SLURM plugin does not take sacct's 'CANCELLED by <uid>' for a failure, "
            "so a cancelled job would keep the run waiting: slurm-status-command: squeue notices it"
        )
    return problems, notes


def _check_profile_cli(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m sportfusion.batch check-profile",
        description="Check a Snakemake SLURM profile against this cluster (partition, account, polling) before "
        "submitting; exit 2 with one line naming the first problem.",
    )
    ap.add_argument("profile", type=Path, help="profile folder (with config.yaml) or the YAML file")
    args = ap.parse_args(argv)
    path = args.profile / "config.yaml" if args.profile.is_dir() else args.profile
    try:
        import yaml

        profile = yaml.safe_load(path.read_text()) or {}
    except (OSError, ImportError, ValueError, yaml.YAMLError) as exc:
        print(f"Error: cluster-batch: cannot read the profile {path}: {exc}", file=sys.stderr)
        return 2
    problems, notes = check_slurm_profile(profile if isinstance(profile, dict) else {}, where=str(path))
    for note in notes:
        print(f"cluster-batch: note: {note}", file=sys.stderr)
    if problems:
        print(f"Error: cluster-batch: {problems[0]}", file=sys.stderr)
        return 2
    return 0


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


def session_row(name: str, config: dict[str, str], out: Path, outputs: list[Path] | None = None) -> dict[str, Any]:
    """One summary row from a session's output folder.

    Parameters
    ----------
    name : str
        Session name (its folder's name).
    config : dict
        Its ``config.mk`` values (``SPORT`` ...).
    out : Path
        Its output folder: ``error`` (written by batch.mk on failure), the result tables.
    outputs : list of Path, optional
        The files its target declares (:func:`declared_outputs`): the session is ok only when all exist.
        Without them, only the sport's result table is looked for.

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
    missing = [p for p in (outputs or [result]) if not p.exists()]
    if err.exists() or missing or not result.exists():
        row["status"] = "failed"
        if err.exists():
            row["error"] = err.read_text().strip()
        elif not result.exists():
            row["error"] = f"no result {result.name}"
        else:
            names = [str(p.relative_to(out)) if p.is_relative_to(out) else str(p) for p in missing]
            more = f" and {len(names) - 3} more" if len(names) > 3 else ""
            row["error"] = f"incomplete (an interrupted run?): no {', '.join(names[:3])}{more}"
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


def collect(
    sessions: Path, out: Path, session_mk: Path | None = None, target: str = "all", done_marker: str | None = None
) -> list[dict[str, Any]]:
    """Summary rows of every ``sessions/<name>/config.mk``, in name order.

    With ``session_mk`` (``pipelines/session.mk``) a session is ok only when every file ``target``
    declares exists (:func:`declared_outputs`); without it, when its sport's result table exists. With
    ``done_marker`` (the Snakefile's ``.done``, which the engine removes before it reruns a session) a
    session without ``out/<name>/<done_marker>`` is not finished: a run that stopped left old files there.

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
            declared = declared_outputs(cfg.parent, out / name, session_mk, target) if session_mk else None
            row = session_row(name, read_config(cfg), out / name, declared)
            if done_marker and row["status"] == "ok" and not (out / name / done_marker).exists():
                row = {**{c: None for c, _ in COLUMNS}, "session": name, "sport": row["sport"], "jumps": 0}
                row.update(status="failed", error="not finished: the run stopped before this session ended")
            rows.append(row)
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
    """``python -m sportfusion.batch OUT --sessions DIR``: write OUT/summary.{parquet,csv,txt}; exit 1 if any
    session failed. ``python -m sportfusion.batch check-profile PROFILE``: check a SLURM profile."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["check-profile"]:
        return _check_profile_cli(argv[1:])
    ap = argparse.ArgumentParser(prog="python -m sportfusion.batch", description=main.__doc__)
    ap.add_argument("out", type=Path, help="batch output folder (one sub-folder per session)")
    ap.add_argument("--sessions", type=Path, required=True, help="sessions folder (one sub-folder per session)")
    ap.add_argument("--engine", default="make", help="what ran the sessions, for the provenance (e.g. 'snakemake 9.1')")
    ap.add_argument("--engine-params", default="", help="the engine's settings, for the provenance (free text)")
    ap.add_argument(
        "--session-mk", type=Path, help="pipelines/session.mk: a session is ok only when all files of --target exist"
    )
    ap.add_argument("--target", default="all", help="the session.mk target(s) the sessions were run to (default all)")
    ap.add_argument("--done-marker", help="a session is finished only when OUT/<name>/DONE_MARKER exists (.done)")
    args = ap.parse_args(argv)
    try:
        rows = collect(args.sessions, args.out, args.session_mk, args.target, args.done_marker)
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
