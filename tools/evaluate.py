"""``evaluate``: an estimate against the simulated truth, in the layout of the ski-jump paper's Table 6."""

from __future__ import annotations

import sys
from typing import Any

import click
import pyarrow as pa

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.evaluate import (
    PAPER_READING_ACCURACY,
    check_estimate,
    compare_jump_lengths,
    compare_jumps,
    evaluate,
    format_jump_lengths,
    format_jumps,
    format_text,
    jump_length_meta,
    jump_length_table,
    jumps_meta,
    jumps_table,
    summary_meta,
    summary_table,
)
from sportfusion.tools._cli import Tool, _is_tty, tool


@tool(
    "evaluate",
    cites=("skijump",),
    writes_table=False,
    stdout=True,
    example="""
  simulate skijump --seed 1 --truth truth.parquet | gps2hill --hill oberstdorf_hs106 \\
      | detect-events --kind jump | rts-smooth --hill oberstdorf_hs106 > est.parquet
  evaluate est.parquet --truth truth.parquet --format text
  evaluate est.parquet --truth truth.parquet -o summary.parquet
  jump-metrics est.parquet | evaluate --truth truth.parquet --format text   (jump length, take-off speed)
  gps2hill s.parquet --hill oberstdorf_hs106 | evaluate --truth truth.parquet --gnss --format text
  video-jumplength landing1.mp4 landing2.mp4 > vr.parquet    (L_VR, one row per video)
  evaluate tr.parquet --video vr.parquet --format text        (tr.parquet: jump-metrics output, L_TR)""",
    input_help="Estimate table (Parquet: a session, e.g. rts-smooth output, or a jumps table from "
    "jump-metrics); default: standard input.",
)
@click.option(
    "--truth",
    "truth_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Truth table written by simulate (--truth FILE); required unless --video is given.",
)
@click.option(
    "--video",
    "video_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Compare jump lengths instead (skijump Table 7): a jumps table from video-jumplength (L_VR, the "
    "reference); the input is then a jumps table with jump_length (L_TR, e.g. jump-metrics output), paired by "
    "a 'jump' number column when both have one, else row by row. Prints dL = L_TR - L_VR per jump, its RMS and "
    "the RMS upper bound with --reading-accuracy.",
)
@click.option(
    "--reading-accuracy",
    type=click.FloatRange(min=0.0),
    default=PAPER_READING_ACCURACY,
    show_default=True,
    help="Worst-case error of the --video reading, for the RMS upper bound [m] (paper, Appendix B: 0.5 m).",
)
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["parquet", "text"]),
    default="parquet",
    show_default=True,
    help="parquet: a summary table; text: a readable table (angles in deg).",
)
@click.option(
    "--gnss",
    is_flag=True,
    help="Evaluate the GNSS measurements (gnss_x/y/z [m]; vel_n/e/d [m/s], rotated into the local frame) "
    "instead of the estimate columns.",
)
@click.option(
    "--max-event-dt",
    default=1.0,
    show_default=True,
    type=click.FloatRange(min=0.0),
    help="An estimated event further than this from the true one is not matched [s].",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="Output file (summary table or text), written atomically; default: standard output.",
)
def main(
    tool: Tool,
    truth_path: str | None,
    video_path: str | None,
    reading_accuracy: float,
    fmt: str,
    gnss: bool,
    max_event_dt: float,
    output: str | None,
) -> None:
    """Compare an estimate (x y z and vx vy vz in the hill frame, q0..q3 or
    roll pitch yaw, events) with the truth of a simulated session: RMS, mean and
    maximum absolute error of position [m] and velocity [m/s] (both in the
    session's local frame, named in the table's header), Euler angles and the
    attitude rotation angle, overall and per phase (in-run up to
    the take-off, flight, out-run from the touch-down), like Table 6 of the
    ski-jump paper; take-off/touch-down timing errors and the jump-length error
    when both sides have a jump length. Writes a summary table (angles in rad)
    or, with --format text, a readable table (angles in deg). With --video:
    the jump lengths of a jumps table (L_TR) against a video reading (L_VR),
    Table 7 of the ski-jump paper: per-jump error dL = L_TR - L_VR [m], RMS
    sqrt(mean(dL^2)) and the upper bound sqrt(mean((|dL| + 0.5 m)^2)).  A jumps
    table (jump-metrics) with --truth: per jump the jump length [m], take-off
    speed [m/s, km/h beside], flight time and take-off/touch-down times [s],
    estimate, truth and error; jumps paired by take-off time (--max-event-dt).
    A gate-anchor output with a body (com_x.. against true_com_x..): the gates
    paper's Table 1 (CoM position and speed, accuracy and precision, total and
    in the local skiing frame) and Table 2 (Bland-Altman bias and 95 % limits
    of agreement of the turn figures) beside the paper's, and the relative CoM
    beside Fasel et al. 2017's 25.7 +- 6.7 mm."""
    tool.output = output  # the main output: -o or standard output
    if fmt == "parquet" and output in (None, "-") and _is_tty(sys.stdout):
        raise click.UsageError("standard output is a terminal; redirect it, give -o FILE or use --format text")
    if video_path is not None:
        if truth_path is not None or gnss:
            raise click.UsageError("--video compares jump lengths; it does not go with --truth or --gnss")
        _jump_lengths(tool, video_path, reading_accuracy, fmt, output)
        return
    est, est_meta = tool.read(kind=("session", "jumps"))
    if est_meta["kind"] == "session":
        check_estimate(est, gnss)
    elif gnss:
        raise click.UsageError("--gnss evaluates a session's GNSS columns; the input is a jumps table")
    if truth_path is None:
        raise click.UsageError("--truth FILE is required: the truth table written by simulate --truth")
    truth, truth_meta = sfio.read_table(truth_path, kind="truth", what=f"truth file {truth_path}")
    if est_meta["kind"] == "jumps":
        _jumps_vs_truth(tool, est, est_meta, truth_path, truth_meta, fmt, output, max_event_dt)
        return
    ev = evaluate(est, est_meta, truth, truth_meta, gnss=gnss, max_event_dt=max_event_dt)
    com = None
    if not gnss:
        from sportfusion.evaluate.com import evaluate_com, format_com, has_com

        com = evaluate_com(est, est_meta, truth) if has_com(est, truth) else None
    if fmt == "text":
        what = "GNSS measurements" if gnss else "estimate"
        text = format_text(ev, f"{what} vs truth ({truth_path}); errors = {what} - truth")
        if com is not None:
            text += "\n" + format_com(com)
        tool.write_bytes(text.encode())
        return
    meta = sfmeta.new_meta("summary", (est_meta.get("time") or {}).get("epoch_utc"))
    for key in ("frame", "hill"):
        if key in est_meta:
            meta[key] = est_meta[key]
    meta["evaluation"] = summary_meta(ev)
    if com is not None:
        meta["evaluation"]["com"] = com
    meta["provenance"] = list(est_meta.get("provenance", []))
    tool.output = output
    tool.write(summary_table(ev), meta)


def _jumps_vs_truth(
    tool: Tool,
    est: pa.Table,
    est_meta: dict[str, Any],
    truth_path: str,
    truth_meta: dict[str, Any],
    fmt: str,
    output: str | None,
    max_event_dt: float,
) -> None:
    """``jump-metrics ... | evaluate --truth``: per-jump figure errors against the simulated truth."""
    cmp = compare_jumps(est, truth_meta, max_event_dt)
    if fmt == "text":
        title = f"jumps (jump-metrics) vs truth ({truth_path}); errors = estimate - truth"
        tool.write_bytes(format_jumps(cmp, title).encode())
        return
    meta = sfmeta.new_meta("summary", (est_meta.get("time") or {}).get("epoch_utc"))
    for key in ("frame", "hill"):
        if key in est_meta:
            meta[key] = est_meta[key]
    meta["evaluation"] = jumps_meta(cmp)
    meta["provenance"] = list(est_meta.get("provenance", []))
    tool.output = output
    tool.write(jumps_table(cmp), meta)


def _jump_lengths(tool: Tool, video_path: str, reading_accuracy: float, fmt: str, output: str | None) -> None:
    """``evaluate --video``: the jumps table on the input against the video reading (Table 7)."""
    est, est_meta = tool.read(kind="jumps")
    ref, _ = sfio.read_table(video_path, kind="jumps", what=f"video jumps file {video_path}")
    cmp = compare_jump_lengths(est, ref, reading_accuracy)
    if fmt == "text":
        title = f"jump length: estimate L_TR vs video L_VR ({video_path}); dL = L_TR - L_VR (skijump Table 7)"
        tool.write_bytes(format_jump_lengths(cmp, title).encode())
        return
    meta = sfmeta.new_meta("summary", (est_meta.get("time") or {}).get("epoch_utc"))
    for key in ("frame", "hill"):
        if key in est_meta:
            meta[key] = est_meta[key]
    meta["evaluation"] = jump_length_meta(cmp)
    meta["provenance"] = list(est_meta.get("provenance", []))
    tool.output = output
    tool.write(jump_length_table(cmp), meta)
