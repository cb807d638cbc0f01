"""Magnet-gate course figure: the smoothed path over the surveyed gates, crossings numbered."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pyarrow as pa

from sportfusion.core.errors import InputError
from sportfusion.core.plots import _col, _new_figure, legend_outside, place_labels, stretch_factor

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def gates_figure(table: pa.Table, gates: pa.Table, title: str = "", width: float = 9.0) -> Figure:
    """Top view of an alpine course: surveyed gates (numbered, labels placed clear of each other and of the
    path), the trajectory, and the gate crossings (anchors) joined to the gate they were matched to; the
    across-slope axis is stretched by the factor on its label when the course is long and thin.

    Parameters
    ----------
    table : pyarrow.Table
        A session with a trajectory ``x y`` [m] (``gate-anchor`` output) and crossing rows
        (``event == "gate"``, matched ``gate`` id when known).
    gates : pyarrow.Table
        The survey (kind ``gates``: ``gate x y z`` [m], same local frame); rows with ``point`` start/finish
        (surveyed static spots) are drawn as squares.
    """
    x, y = _col(table, "x"), _col(table, "y")
    if x is None or y is None:
        raise InputError("missing columns: plot gates needs a trajectory x, y [m]; run gate-anchor first")
    if not all(n in gates.column_names for n in ("gate", "x", "y")):
        raise InputError("the gates table needs gate, x, y [m] columns (local frame)")
    from sportfusion.core.io import survey_points

    gates, spots = survey_points(gates)
    gid = np.asarray(gates.column("gate").to_numpy(zero_copy_only=False))
    gxy = np.column_stack([_col(gates, "x"), _col(gates, "y")])
    fig = _new_figure(width, 10.0)
    ax = fig.add_subplot()
    m = np.isfinite(x) & np.isfinite(y)
    # plan view with the fall line (x) downwards on the page
    ax.plot(y[m], x[m], "-", lw=1.0, color="tab:blue", label="trajectory")
    ax.plot(gxy[:, 1], gxy[:, 0], "^", ms=7, color="tab:red", label="surveyed gate (magnet), numbered")
    if spots is not None:
        ax.plot(
            _col(spots, "y"), _col(spots, "x"), "s", ms=7, mfc="none", color="tab:orange", label="surveyed static spot"
        )
    avoid = [np.column_stack([y[m], x[m]])]
    if "event" in table.column_names:
        ev = np.array([e == "gate" for e in table.column("event").to_pylist()])
        matched = (
            np.asarray(table.column("gate").to_numpy(zero_copy_only=False), float)
            if "gate" in table.column_names
            else np.full(table.num_rows, np.nan)
        )
        lookup = {int(g): p for g, p in zip(gid, gxy, strict=True)}
        hit = ev & np.array([np.isfinite(v) and int(v) in lookup for v in matched])
        ax.plot(y[hit], x[hit], "o", ms=4, mfc="none", color="k", label="detected crossing, matched")
        for k, i in enumerate(np.flatnonzero(hit)):
            p = lookup[int(matched[i])]
            ax.plot([y[i], p[1]], [x[i], p[0]], "-", lw=0.9, color="tab:green", label="match" if k == 0 else None)
        miss = ev & ~hit
        if miss.any():
            ax.plot(
                y[miss], x[miss], "x", ms=6, mew=1.5, color="tab:purple", label="detected crossing, no gate matched"
            )
        avoid.append(np.column_stack([y[ev], x[ev]]))
    # a course is long and thin: stretch the across-slope axis by a stated factor
    f = stretch_factor(float(np.ptp(x[m])), float(np.ptp(np.r_[y[m], gxy[:, 1]]))) if m.any() else 1
    ax.invert_yaxis()
    ax.set_aspect(1.0 / f, adjustable="datalim")
    ax.set_xlabel(f"y (right of the fall line) [m], stretched ×{f}" if f > 1 else "y (right of the fall line) [m]")
    ax.set_ylabel("x (down the fall line) [m]")
    ax.grid(True, lw=0.4, alpha=0.6)
    legend_outside(ax)
    ax.set_title(title or "course: gates, crossings and trajectory (plan view)")
    place_labels(ax, gxy[:, ::-1], [f"{g}" for g in gid], avoid=np.vstack(avoid), colours=["tab:red"] * len(gid))
    return fig
