"""Climbing figure: the hand path over the wall's hold map, holds reached marked."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from sportfusion.core.errors import InputError
from sportfusion.core.plots import _col, _new_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def holds_figure(
    table: pa.Table,
    holds: pa.Table,
    holds_meta: dict[str, Any],
    truth: pa.Table | None = None,
    title: str = "",
    width: float = 8.0,
) -> Figure:
    """A climbing hand path over the wall's hold map (front view: horizontal wall axis vs up).

    Parameters
    ----------
    table : pyarrow.Table
        ``pf-holds`` output: ``x y z`` [m] per sample, ``grip`` and ``hold_id`` at grips.
    holds : pyarrow.Table
        Hold map (kind ``holds``: route, hold, x, y, z [m]).
    holds_meta : dict
        Its metadata (``climbing.up`` names the up axis, ``start_holds``).
    truth : pyarrow.Table, optional
        ``true_x..`` of the same session, drawn for comparison.
    """
    from sportfusion.climbing.holds import AXES

    up_name = str((holds_meta.get("climbing") or {}).get("up", "z")).lstrip("-")
    up = AXES.get(up_name, 2)
    across = 0 if up != 0 else 1
    names = "xyz"
    hx, hu = _col(holds, names[across]), _col(holds, names[up])
    if hx is None or hu is None:
        raise InputError("the hold map needs x, y, z [m] columns")
    px, pu = _col(table, names[across]), _col(table, names[up])
    if px is None or pu is None:
        raise InputError("missing columns: plot holds needs the hand path x, y, z [m]; run pf-holds first")
    routes = holds.column("route").to_pylist() if "route" in holds.column_names else ["route"] * holds.num_rows
    fig = _new_figure(width, 9.0)
    ax = fig.add_subplot()
    starts = (holds_meta.get("climbing") or {}).get("start_holds") or {}
    hold_no = holds.column("hold").to_pylist() if "hold" in holds.column_names else list(range(holds.num_rows))
    for k, route in enumerate(dict.fromkeys(routes)):
        sel = np.array([r == route for r in routes])
        ax.plot(hx[sel], hu[sel], "o", ms=9, mfc="none", mew=1.5, color=f"C{k}", label=f"holds: {route}")
        for i in np.flatnonzero(sel):
            start = hold_no[i] in starts.get(route, [])
            ax.annotate(
                f"{hold_no[i]}{'S' if start else ''}",
                (hx[i], hu[i]),
                textcoords="offset points",
                xytext=(6, -3),
                fontsize=7,
                color=f"C{k}",
            )
    if truth is not None:
        tx, tu = _col(truth, f"true_{names[across]}"), _col(truth, f"true_{names[up]}")
        if tx is not None and tu is not None:
            m = np.isfinite(tx) & np.isfinite(tu)
            ax.plot(tx[m], tu[m], "-", lw=0.8, color="0.55", label="true hand path")
    m = np.isfinite(px) & np.isfinite(pu)
    ax.plot(px[m], pu[m], "-", lw=1.1, color="tab:blue", label="estimated hand path")
    if "grip" in table.column_names:
        g = np.asarray(table.column("grip").to_numpy(zero_copy_only=False), dtype=object)
        g = np.array([bool(v) if v is not None else False for v in g]) & m
        ax.plot(px[g], pu[g], ".", ms=3, color="k", label="grips")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"{names[across]} (along the wall) [m]")
    ax.set_ylabel(f"{names[up]} (up) [m]")
    ax.grid(True, lw=0.4, alpha=0.6)
    ax.legend(fontsize=8, loc="best")
    ax.set_title(title or "hand path over the hold map (S: start hold)")
    return fig
