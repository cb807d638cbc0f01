"""Magnet-gate course figure: the smoothed path over the surveyed gates, crossings numbered."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pyarrow as pa

from sportfusion.core.errors import InputError
from sportfusion.core.plots import _col, _new_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def gates_figure(table: pa.Table, gates: pa.Table, title: str = "", width: float = 8.0) -> Figure:
    """Top view of an alpine course: surveyed gates, the trajectory, and the gate crossings (anchors)
    joined to the gate they were matched to.

    Parameters
    ----------
    table : pyarrow.Table
        A session with a trajectory ``x y`` [m] (``gate-anchor`` output) and crossing rows
        (``event == "gate"``, matched ``gate`` id when known).
    gates : pyarrow.Table
        The survey (kind ``gates``: ``gate x y z`` [m], same local frame).
    """
    x, y = _col(table, "x"), _col(table, "y")
    if x is None or y is None:
        raise InputError("missing columns: plot gates needs a trajectory x, y [m]; run gate-anchor first")
    if not all(n in gates.column_names for n in ("gate", "x", "y")):
        raise InputError("the gates table needs gate, x, y [m] columns (local frame)")
    gid = np.asarray(gates.column("gate").to_numpy(zero_copy_only=False))
    gxy = np.column_stack([_col(gates, "x"), _col(gates, "y")])
    fig = _new_figure(width, 10.0)
    ax = fig.add_subplot()
    m = np.isfinite(x) & np.isfinite(y)
    # plan view with the fall line (x) downwards on the page
    ax.plot(y[m], x[m], "-", lw=1.0, color="tab:blue", label="trajectory")
    ax.plot(gxy[:, 1], gxy[:, 0], "^", ms=7, color="tab:red", label="surveyed gate (magnet)")
    for g, (gxv, gyv) in zip(gid, gxy, strict=True):
        ax.annotate(str(g), (gyv, gxv), textcoords="offset points", xytext=(5, 0), fontsize=7)
    if "event" in table.column_names:
        ev = np.array([e == "gate" for e in table.column("event").to_pylist()])
        ax.plot(y[ev], x[ev], "o", ms=4, mfc="none", color="k", label="detected crossing")
        if "gate" in table.column_names:
            matched = np.asarray(table.column("gate").to_numpy(zero_copy_only=False), float)
            lookup = {int(g): p for g, p in zip(gid, gxy, strict=True)}
            for i in np.flatnonzero(ev):
                if np.isfinite(matched[i]) and int(matched[i]) in lookup:
                    p = lookup[int(matched[i])]
                    ax.plot([y[i], p[1]], [x[i], p[0]], "-", lw=0.7, color="tab:green")
    ax.invert_yaxis()
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("y (right of the fall line) [m]")
    ax.set_ylabel("x (down the fall line) [m]")
    ax.grid(True, lw=0.4, alpha=0.6)
    ax.legend(fontsize=8, loc="best")
    ax.set_title(title or "course: gates, crossings (green: matched anchor) and trajectory")
    return fig
