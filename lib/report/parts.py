"""The pieces every sport's part of a session page is made of (:mod:`sportfusion.report.sports`,
:mod:`sportfusion.report.session`): what a part is given (:class:`Context`) and returns
(:class:`Sections`), figures drawn for a phone with their words read from them, the moving time and speed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.report import html as H
from sportfusion.report.glossary import MOVING_SPEED

#: figures get at most this many rows (every k-th row, events kept): the page stays small enough to mail
MAX_PLOT_ROWS = 600


@dataclass
class Context:
    """What a sport's part of the page is made from."""

    table: pa.Table
    meta: dict[str, Any]
    jumps: pa.Table | None = None
    evaluation: pa.Table | None = None
    evaluation_meta: dict[str, Any] = field(default_factory=dict)
    gates: pa.Table | None = None
    holds: tuple[pa.Table, dict[str, Any]] | None = None

    @property
    def thin(self) -> pa.Table:
        """The rows a figure on a phone can show."""
        return _thin(self.table)


@dataclass
class Sections:
    """A page's parts: ``heads`` (label, value with its unit, the line under it) for the headline boxes;
    ``coach`` HTML blocks in reading order; ``analyst`` blocks folded under "For the analyst"."""

    heads: list[tuple[str, str, str]] = field(default_factory=list)
    coach: list[str] = field(default_factory=list)
    analyst: list[str] = field(default_factory=list)


def col(table: pa.Table, name: str) -> np.ndarray | None:
    """A column as float64 (null -> NaN), or None when the table has none."""
    return schema.floats(table, name) if name in table.column_names else None


def _thin(table: pa.Table, max_rows: int = MAX_PLOT_ROWS) -> pa.Table:
    """Every k-th row and every event row: what a figure on a phone can show."""
    if table.num_rows <= max_rows:
        return table
    keep = np.zeros(table.num_rows, bool)
    keep[:: math.ceil(table.num_rows / max_rows)] = True
    keep[-1] = True
    if "event" in table.column_names:
        keep |= pc.is_valid(table.column("event")).to_numpy(zero_copy_only=False)
    return table.filter(pa.array(keep))


def figure(make: Callable[[], Any]) -> str:
    """A figure drawn for a phone's width with the colour-blind-safe palette, its caption and alt text read
    from it; a figure that cannot be drawn is said in one line, not fatal."""
    try:
        import matplotlib as mpl
        from cycler import cycler
    except ImportError:  # pragma: no cover - the plot extra is part of the install
        return "<p>(figure omitted: matplotlib is not installed)</p>"
    from sportfusion.core.plotlayout import narrow_layout

    with (
        narrow_layout(),
        mpl.rc_context(
            {"axes.prop_cycle": cycler(color=list(H.OKABE_ITO)), "svg.fonttype": "none", "path.simplify_threshold": 0.5}
        ),
    ):
        try:
            fig = make()
        except InputError as exc:
            return f"<p>(figure omitted: {H.esc(exc)})</p>"
        return H.svg_figure(fig)


def duration(table: pa.Table) -> float:
    """First to last row [s]."""
    t = schema.floats(table, "t")
    return float(t[-1] - t[0]) if t.size else float("nan")


def speed_of(table: pa.Table) -> np.ndarray | None:
    """The speed [m/s] per row: the ``speed`` column, else |(vx, vy, vz)|."""
    s = col(table, "speed")
    if s is not None:
        return s
    v = [col(table, f"v{a}") for a in "xyz"]
    return None if any(c is None for c in v) else np.linalg.norm(np.column_stack(v), axis=1)


def moving(t: np.ndarray, speed: np.ndarray, threshold: float = MOVING_SPEED) -> tuple[float, float]:
    """Moving time [s] and the distance travelled while moving [m].

    An interval between two rows counts as moving when the mean of its two speeds [m/s] is at least
    ``threshold`` [m/s]; its distance is that mean times its length (the trapezoid). Intervals with a
    missing speed count as neither.
    """
    dt = np.diff(t)
    mean = 0.5 * (speed[1:] + speed[:-1])
    m = np.isfinite(mean) & (mean >= threshold)
    return float(dt[m].sum()), float((mean[m] * dt[m]).sum())


def moving_heads(table: pa.Table, distance: float | None = None) -> list[tuple[str, str, str]]:
    """Moving time, max speed and moving mean speed (headline boxes) of a session with a speed."""
    s = speed_of(table)
    t = schema.floats(table, "t")
    if s is None or not np.isfinite(s).any():
        return [("Recording", H.number(duration(table), "s", 1), "no speed in the table")]
    t_move, d_move = moving(t, s)
    vmax = float(np.nanmax(s))
    mean = d_move / t_move if t_move > 0 else None
    heads = [
        ("Moving time", H.number(t_move, "s", 1), f"speed ≥ {MOVING_SPEED:g} m/s; recording {duration(table):.1f} s"),
        ("Max speed", H.number(vmax, "m/s"), H.kmh(vmax)),
        ("Moving mean speed", H.number(mean, "m/s"), f"{H.kmh(mean)}: {d_move:.0f} m in {t_move:.1f} s"),
    ]
    if distance is not None:
        heads.insert(1, ("Distance", H.number(distance, "m", 0), "along the smoothed path"))
    return heads
