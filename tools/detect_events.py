"""``detect-events``: events from the IMU, one kind per run (``--kind``).

Each kind has a runner ``(table, meta, options) -> (table, meta, message)`` in
``RUNNERS`` and its own options, whose help starts with the kind's name.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click
import numpy as np
import pyarrow as pa

from sportfusion.climbing.grips import GripParams, grip_columns
from sportfusion.core.session import with_columns
from sportfusion.gates.crossings import GateParams, detect_gate_table, gate_columns, read_calibration
from sportfusion.skijump.events import TOUCHDOWN_METHODS, JumpParams, detect_jump_events
from sportfusion.tools._cli import Tool, tool


def _grips(table: pa.Table, meta: dict[str, Any], o: dict[str, Any]) -> tuple[pa.Table, dict[str, Any], str]:
    params = GripParams(
        window=o["window"],
        threshold=o["threshold"],
        mean_threshold=o["mean_threshold"],
        acc_threshold=o["acc_threshold"],
        acc_limit=o["acc_limit"],
        gyr_limit=float(np.deg2rad(o["gyr_limit"])),
        world_frame=not o["body_frame"],
    )
    cols, counts = grip_columns(table, params)
    msg = f"{counts['grips']} grips ({counts['grip_samples']} samples), {counts['saturated']} saturated samples"
    return with_columns(table, cols), meta, msg


def _jump(table: pa.Table, meta: dict[str, Any], o: dict[str, Any]) -> tuple[pa.Table, dict[str, Any], str]:
    params = JumpParams(
        min_speed=o["min_speed"],
        min_separation=o["min_separation"],
        touchdown_offset=o["touchdown_offset"],
        max_separation=o["max_separation"],
        min_peak=o["min_peak"],
        max_flight_acc=o["max_flight_acc"],
        max_gnss_gap=o["max_gnss_gap"],
        touchdown_method=o["touchdown_method"],
    )
    table, summary, msg = detect_jump_events(table, params)
    meta = {**meta, "events": [*(meta.get("events") or []), summary]}
    return table, meta, msg


def _gates(table: pa.Table, meta: dict[str, Any], o: dict[str, Any]) -> tuple[pa.Table, dict[str, Any], str]:
    params = GateParams(
        threshold=o["gate_threshold"],
        min_separation=o["gate_separation"],
        background=o["gate_background"],
        turn_window=o["turn_window"],
    )
    cal = read_calibration(o["magnet_calibration"]) if o["magnet_calibration"] else None
    det = detect_gate_table(table, params, cal)
    meta = {**meta, "events": [*(meta.get("events") or []), det.summary(params)]}
    return with_columns(table, gate_columns(table, det)), meta, det.message()


#: kind -> runner; other kinds add their runner here and their options below.
RUNNERS: dict[str, Callable[[pa.Table, dict[str, Any], dict[str, Any]], tuple[pa.Table, dict[str, Any], str]]] = {
    "grips": _grips,
    "jump": _jump,
    "gates": _gates,
}


def kind_from_meta(meta: dict[str, Any]) -> tuple[str, str] | None:
    """The event kind a session's metadata implies, with the reason; None when it names no sport.

    A hill (gps2hill --hill, simulate skijump) -> jump; a climbing trial or hold map -> grips; a gate
    survey -> gates.  Two at once is no answer either.
    """
    found = []
    if meta.get("hill"):
        found.append(("jump", "the session has a hill"))
    if meta.get("climbing") or meta.get("holds"):
        found.append(("grips", "the session is a climbing trial"))
    if meta.get("gates") or meta.get("survey"):
        found.append(("gates", "the session has a gate survey"))
    return found[0] if len(found) == 1 else None


@tool(
    "detect-events",
    cites=(
        "skijump",
        "climbing",
        "gates",
    ),
    example="""
  simulate boulder --seed 1 --holds holds.parquet | detect-events --kind grips > trial.parquet
  detect-events --kind grips --window 17 --threshold 0.5 hand.parquet -o hand_grips.parquet
  simulate skijump --seed 1 | detect-events --kind jump > jump.parquet
  detect-events --kind jump --touchdown-method peak --touchdown-offset 0.08 --min-peak 20 session.parquet -o events.parquet
  simulate gates --seed 1 --gates survey.parquet | detect-events --kind gates > crossings.parquet
  detect-events --kind gates --magnet-calibration magnet.csv --gate-threshold 0.08 run.parquet -o crossings.parquet""",
)
@click.option(
    "--kind",
    type=click.Choice(sorted(RUNNERS)),
    default=None,
    help="Events to detect; default: the kind the session's metadata implies (a hill -> jump, a climbing "
    "trial or hold map -> grips, a gate survey -> gates), else required. grips (low-motion windows of a hand IMU -> columns grip, imu_saturated); "
    "jump (ski-jump take-off and touch-down -> event rows, skijump Appendix A); "
    "gates (magnet gate crossings -> event rows 'gate' with gate_b_peak, gate_distance, turn; gates paper).",
)
@click.option(
    "--window", default=28, show_default=True, type=click.IntRange(2, 100000), help="grips: moving window [samples]."
)
@click.option(
    "--threshold",
    default=GripParams.threshold,
    show_default=True,
    type=click.FloatRange(0, None),
    help="grips: largest summed per-axis standard deviation of the angular rate in a window [rad/s].",
)
@click.option(
    "--mean-threshold",
    default=GripParams.mean_threshold,
    show_default=True,
    type=click.FloatRange(0, None),
    help="grips: largest norm of the window's mean angular rate [rad/s] ('inf' switches it off).",
)
@click.option(
    "--acc-threshold",
    default=GripParams.acc_threshold,
    show_default=True,
    type=click.FloatRange(0, None),
    help="grips: largest summed per-axis standard deviation of the specific force [m/s^2] ('inf': off).",
)
@click.option(
    "--acc-limit",
    default=GripParams.acc_limit,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="grips: accelerometer range; a reading at or beyond it is a range violation [m/s^2].",
)
@click.option(
    "--gyr-limit",
    default=2000.0,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="grips: gyroscope range [deg/s].",
)
@click.option(
    "--body-frame",
    is_flag=True,
    help="grips: use the angular rate in the sensor frame even when dev_q0..3 (sensor to world) is present [flag].",
)
@click.option(
    "--min-speed",
    default=JumpParams.min_speed,
    show_default=True,
    type=click.FloatRange(0, None),
    help="jump: GNSS speed above which a jump is searched [m/s].",
)
@click.option(
    "--min-separation",
    default=JumpParams.min_separation,
    show_default=True,
    type=click.FloatRange(0, None),
    help="jump: the take-off and landing peaks are more than this apart [s].",
)
@click.option(
    "--touchdown-method",
    type=click.Choice(TOUCHDOWN_METHODS),
    default=JumpParams.touchdown_method,
    show_default=True,
    help="jump: onset (the landing impact's onset, fitted between the samples; the peak minus --touchdown-offset "
    "where none is found) or peak (skijump eq A4: the landing peak minus --touchdown-offset).",
)
@click.option(
    "--touchdown-offset",
    default=JumpParams.touchdown_offset,
    show_default=True,
    type=float,
    help="jump: touch-down is this long before the landing peak [s] (--touchdown-method peak, and the fallback "
    "of onset).",
)
@click.option(
    "--max-separation",
    default=JumpParams.max_separation,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="jump: longest flight searched, peak to peak [s].",
)
@click.option(
    "--min-peak",
    default=JumpParams.min_peak,
    show_default=True,
    type=click.FloatRange(0, None),
    help="jump: both peaks reach at least this specific force [m/s^2].",
)
@click.option(
    "--max-flight-acc",
    default=JumpParams.max_flight_acc,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="jump: largest median specific force between the peaks, i.e. in flight [m/s^2] ('inf': off).",
)
@click.option(
    "--max-gnss-gap",
    default=JumpParams.max_gnss_gap,
    show_default=True,
    type=click.FloatRange(0, None),
    help="jump: the GNSS speed is not interpolated across longer gaps [s].",
)
@click.option(
    "--gate-threshold",
    default=GateParams.threshold,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="gates: smallest normalised excess field intensity |B|/background - 1 of a crossing [1].",
)
@click.option(
    "--gate-separation",
    default=GateParams.min_separation,
    show_default=True,
    type=click.FloatRange(0, None),
    help="gates: two crossings are at least this far apart [s].",
)
@click.option(
    "--gate-background",
    default=GateParams.background,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="gates: moving-median window of the background field intensity [s].",
)
@click.option(
    "--turn-window",
    default=GateParams.turn_window,
    show_default=True,
    type=click.FloatRange(0, None),
    help="gates: half-width of the window averaging gyr_z for the turn side [s].",
)
@click.option(
    "--magnet-calibration",
    type=click.Path(dir_okay=False),
    default=None,
    help="gates: the magnet's calibration table, CSV 'distance [m], peak intensity [1]' (or Parquet distance, "
    "gate_b_peak), fitted with the cube law; default: calibrated from the simulator's magnet.",
)
def main(tool: Tool, kind: str | None, **options: Any) -> None:
    """Detect events in a session, one kind per run; without --kind the kind
    comes from the session's metadata (a hill: jump; a climbing trial: grips;
    a gate survey: gates) and a session that names none is refused.  grips: a moving window centred on each IMU
    sample flags a grip when the angular rate (rotated to the world frame with
    the device's own orientation dev_q0..3 when present) and the specific force
    barely vary (climbing paper §III; the first and last window/2 samples are
    never grips); samples at the sensor range are flagged imu_saturated.
    jump: take-off = the earlier of the two largest specific-force peaks more
    than 1.5 s apart while the GNSS speed exceeds 10 m/s (skijump Appendix A),
    per fast stretch, so several jumps are each found; touch-down = the onset of
    the landing impact before the later peak (where the specific force leaves
    the flight's trend, fitted between the samples), or with --touchdown-method
    peak 0.05 s before that peak (eq A4); a stretch without two peaks and a
    flight between them gets no events, with the reason on stderr.
    gates: a gate crossing at each peak of the field intensity |B| normalised by
    its background (moving median), the distance to the magnet from the peak with
    the cube law r = (c/(b-1))^(1/3) (the paper's eq 1 is garbled; c calibrated
    from the simulator's magnet or --magnet-calibration), and the turn side from
    the sign of the angular rate about the trunk's long axis (-z: gyr_z > 0 -> R)."""
    table, meta = tool.read()
    if kind is None:
        implied = kind_from_meta(meta)
        if implied is None:
            raise click.UsageError(
                "no --kind given and the session's metadata names no sport (no hill, climbing trial or gate "
                "survey); pass --kind jump, --kind grips or --kind gates"
            )
        kind = implied[0]
        tool.info(f"--kind {kind}: {implied[1]}")
        tool.params["kind"] = kind
    table, meta, message = RUNNERS[kind](table, meta, options)
    summary = (meta.get("events") or [{}])[-1] or {}
    for w in summary.get("warnings", []):
        tool.warn(w)
    if summary.get("kind") == "jump" and not summary.get("jumps"):
        tool.warn(message)  # no take-off/touch-down: say why even under -q (rts-smooth will need them)
    tool.info(message)
    tool.write(table, meta)
