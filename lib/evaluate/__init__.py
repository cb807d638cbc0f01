"""Estimates against the truth or a reference (cross-cutting: any sport's session).

* :mod:`~sportfusion.evaluate.truth` -- errors against a simulated truth by phase, in the layout of the
  skijump paper's Table 6 (position [m] and velocity [m/s] in the session's one local frame, attitude
  [deg]), event timing [s];
* :mod:`~sportfusion.evaluate.jump_length` -- jump lengths against the video reference (Table 7) [m];
* :mod:`~sportfusion.evaluate.jumps` -- a jumps table (jump-metrics) against the truth: length, take-off
  speed, timing errors.
"""

from sportfusion.evaluate.jump_length import (
    PAPER_READING_ACCURACY,
    JumpLengthComparison,
    compare_jump_lengths,
    format_jump_lengths,
    jump_length_meta,
    jump_length_table,
)
from sportfusion.evaluate.jumps import JumpFigures, compare_jumps, format_jumps, jumps_meta, jumps_table
from sportfusion.evaluate.truth import (
    ANGLES,
    EVENT_NAMES,
    PAPER_TABLE7_RMS,
    PAPER_TABLE7_RMS_UB,
    PHASES,
    STATS,
    Evaluation,
    check_estimate,
    errors,
    estimate_event_times,
    evaluate,
    event_errors,
    format_text,
    frame_label,
    match_rows,
    phases,
    summary_meta,
    summary_table,
    table_events,
    truth_events,
)

__all__ = [
    "ANGLES",
    "EVENT_NAMES",
    "PAPER_READING_ACCURACY",
    "PAPER_TABLE7_RMS",
    "PAPER_TABLE7_RMS_UB",
    "PHASES",
    "STATS",
    "Evaluation",
    "JumpFigures",
    "JumpLengthComparison",
    "check_estimate",
    "compare_jump_lengths",
    "compare_jumps",
    "errors",
    "estimate_event_times",
    "evaluate",
    "event_errors",
    "format_jump_lengths",
    "format_jumps",
    "format_text",
    "frame_label",
    "jump_length_meta",
    "jump_length_table",
    "jumps_meta",
    "jumps_table",
    "match_rows",
    "phases",
    "summary_meta",
    "summary_table",
    "table_events",
    "truth_events",
]
