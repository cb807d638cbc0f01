"""A ``jumps`` table (jump-metrics) against the simulated truth: per-jump figure errors.

Errors are estimate minus truth: take-off and touch-down timing [s], jump length [m], take-off speed
[m/s] and flight time [s].  The timing errors follow the one definition of
:mod:`~sportfusion.evaluate.truth` (the detector's exact time against the simulator's), so ``evaluate
jumps.parquet`` and ``evaluate smoothed.parquet`` give the same take-off error for the same jump.  Estimated and true jumps are paired by their take-off times (the nearest
within ``max_event_dt``); a jump without a partner keeps NaN errors.  Jumps are numbered from 1, as
jump-metrics numbers them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.describe import ms_to_kmh
from sportfusion.core.errors import InputError

__all__ = ["JumpFigures", "true_jumps", "compare_jumps", "jumps_table", "jumps_meta", "format_jumps"]

#: (column, label, unit) of the figures compared, in print order.
FIGURES = (
    ("jump_length", "jump length", "m"),
    ("takeoff_speed", "take-off speed", "m/s"),
    ("flight_time", "flight time", "s"),
    ("t_takeoff", "take-off time", "s"),
    ("t_touchdown", "touch-down time", "s"),
)


@dataclass
class JumpFigures:
    """Estimated and true figures per estimated jump (NaN where a side has none)."""

    jump: list[int]
    estimate: dict[str, np.ndarray]
    truth: dict[str, np.ndarray]
    missed: int  # true jumps no estimate was paired with

    def error(self, name: str) -> np.ndarray:
        """Estimate minus truth for one figure (see FIGURES for units)."""
        return self.estimate[name] - self.truth[name]


def true_jumps(truth_meta: dict[str, Any]) -> list[dict[str, float]]:
    """The true jumps of a simulated session from its truth metadata (simulate skijump).

    Returns
    -------
    list of dict with ``t_takeoff``, ``t_touchdown``, ``flight_time`` [s], ``jump_length`` [m] and
    ``takeoff_speed`` [m/s] (NaN when the truth does not give it).
    """
    from sportfusion.evaluate.truth import truth_events

    sk = truth_meta.get("skijump") or {}
    times, figures = sk.get("times") or {}, sk.get("figures") or {}
    events = truth_events(None, truth_meta)  # the one definition of the true event times
    if "takeoff" in times and "touchdown" in times:
        a, b = (next(t for n, t in events if n == name) for name in ("takeoff", "touchdown"))
        return [
            {
                "t_takeoff": a,
                "t_touchdown": b,
                "flight_time": b - a,
                "jump_length": float(figures.get("jump_length", truth_meta.get("jump_length", np.nan))),
                "takeoff_speed": float(figures.get("takeoff_speed", np.nan)),
            }
        ]
    tos = sorted(t for n, t in events if n == "takeoff")
    tds = sorted(t for n, t in events if n == "touchdown")
    lengths = truth_meta.get("jump_length")
    lengths = [] if lengths is None else list(np.atleast_1d(np.asarray(lengths, dtype=float)))
    out = []
    for k, (a, b) in enumerate(zip(tos, tds, strict=False)):
        length = lengths[k] if k < len(lengths) else np.nan
        out.append(
            {"t_takeoff": a, "t_touchdown": b, "flight_time": b - a, "jump_length": length, "takeoff_speed": np.nan}
        )
    if not out:
        raise InputError("the truth holds no jump (no take-off/touch-down); expected simulate skijump's truth")
    return out


def compare_jumps(est: pa.Table, truth_meta: dict[str, Any], max_event_dt: float = 1.0) -> JumpFigures:
    """Pair a jumps table's rows with the true jumps by take-off time and collect both sides' figures."""
    schema.require_columns(est, ["t_takeoff", "jump_length"], "a jumps table (jump-metrics output)")
    if est.num_rows == 0:
        raise InputError("the jumps table has no rows; expected one row per jump (jump-metrics)")
    tj = true_jumps(truth_meta)
    names = [f for f, _, _ in FIGURES]
    e = {n: schema.floats(est, n) if n in est.column_names else np.full(est.num_rows, np.nan) for n in names}
    if np.isnan(e["flight_time"]).all():
        e["flight_time"] = e["t_touchdown"] - e["t_takeoff"]
    tr = {n: np.full(est.num_rows, np.nan) for n in names}
    true_to = np.array([j["t_takeoff"] for j in tj])
    used: set[int] = set()
    for i, a in enumerate(e["t_takeoff"]):
        if not np.isfinite(a):
            continue
        gaps = np.abs(true_to - a)
        k = int(np.argmin(gaps))
        if gaps[k] <= max_event_dt and k not in used:
            used.add(k)
            for n in names:
                tr[n][i] = tj[k][n]
    jump = (
        [int(v) for v in schema.floats(est, "jump")] if "jump" in est.column_names else list(range(1, est.num_rows + 1))
    )
    return JumpFigures(jump=jump, estimate=e, truth=tr, missed=len(tj) - len(used))


def jumps_table(cmp: JumpFigures) -> pa.Table:
    """A ``summary`` table: one row per jump (``phase`` = ``jump N``, ``stat`` = ``error``).

    Columns ``takeoff_dt``, ``touchdown_dt`` [s], ``jump_length_error`` [m], ``takeoff_speed_error``
    [m/s], beside the estimate's ``jump_length`` [m] and ``takeoff_speed`` [m/s].
    """
    n = len(cmp.jump)
    return pa.table(
        {
            "phase": pa.array([f"jump {j}" for j in cmp.jump], pa.string()),
            "stat": pa.array(["error"] * n, pa.string()),
            "samples": pa.array([1] * n, pa.int64()),
            "jump": schema.to_arrow("jump", np.asarray(cmp.jump, dtype=np.int64)),
            "jump_length": schema.to_arrow("jump_length", cmp.estimate["jump_length"]),
            "takeoff_speed": schema.to_arrow("takeoff_speed", cmp.estimate["takeoff_speed"]),
            "takeoff_dt": schema.to_arrow("takeoff_dt", cmp.error("t_takeoff")),
            "touchdown_dt": schema.to_arrow("touchdown_dt", cmp.error("t_touchdown")),
            "jump_length_error": schema.to_arrow("jump_length_error", cmp.error("jump_length")),
            "takeoff_speed_error": schema.to_arrow("takeoff_speed_error", cmp.error("takeoff_speed")),
        }
    )


def _num(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


def jumps_meta(cmp: JumpFigures) -> dict[str, Any]:
    """The comparison as JSON-ready metadata (key ``evaluation``; missing values are null)."""
    rows = []
    for i, j in enumerate(cmp.jump):
        row: dict[str, Any] = {"jump": j}
        for name, _, unit in FIGURES:
            row[name] = {
                "estimate": _num(cmp.estimate[name][i]),
                "truth": _num(cmp.truth[name][i]),
                "error": _num(cmp.error(name)[i]),
                "unit": unit,
            }
        rows.append(row)
    return {"jumps": rows, "missed_true_jumps": cmp.missed}


def format_jumps(cmp: JumpFigures, title: str = "") -> str:
    """Per jump: estimate, truth and error of each figure; speeds in m/s with km/h beside."""
    lines = [title] if title else []
    head = f"{'jump':<6}{'figure':<18}{'estimate':>12}{'truth':>12}{'error':>12}  unit"
    lines += [head, "-" * len(head)]

    def f(v: float, spec: str) -> str:
        return format(v, spec) if np.isfinite(v) else "-"

    for i, j in enumerate(cmp.jump):
        for name, label, unit in FIGURES:
            a, b = cmp.estimate[name][i], cmp.truth[name][i]
            lines.append(f"{j:<6}{label:<18}{f(a, '.3f'):>12}{f(b, '.3f'):>12}{f(a - b, '+.3f'):>12}  {unit}")
            if unit == "m/s":
                ka, kb = (ms_to_kmh(v) if np.isfinite(v) else np.nan for v in (a, b))
                lines.append(f"{'':<6}{'':<18}{f(ka, '.2f'):>12}{f(kb, '.2f'):>12}{f(ka - kb, '+.2f'):>12}  km/h")
    if cmp.missed:
        lines.append(f"{cmp.missed} true jump(s) without an estimated jump within the take-off window")
    return "\n".join(lines) + "\n"
