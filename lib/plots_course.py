"""Ski-racing and climbing figures: spline vs raw GNSS around float periods, an alpine course with
its gates and anchors (top view), and a climbing hand path over the hold map.

Every function returns a matplotlib :class:`~matplotlib.figure.Figure` on the Agg canvas (see
:mod:`sportfusion.plots`). Coordinates are in the table's local frame [m].
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from sportfusion import schema
from sportfusion.errors import InputError
from sportfusion.events import true_runs
from sportfusion.plots import _col, _new_figure

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["spline_figure", "gates_figure", "holds_figure", "float_spans"]

#: NMEA GGA fix-quality code of an RTK float solution.
FLOAT_FIX = 5


def float_spans(t: np.ndarray, fix: np.ndarray) -> list[tuple[float, float]]:
    """Time spans [s] of consecutive epochs with an RTK float fix (``gnss_fix == 5``).

    Parameters
    ----------
    t : numpy.ndarray
        Epoch times [s] (GNSS rows only).
    fix : numpy.ndarray
        GGA fix-quality codes at those epochs.
    """
    return [(float(t[i0]), float(t[i1 - 1])) for i0, i1 in true_runs(np.asarray(fix) == FLOAT_FIX)]


def _shade(ax: Axes, spans: list[tuple[float, float]]) -> None:
    for k, (a, b) in enumerate(spans):
        ax.axvspan(a, b, color="tab:red", alpha=0.12, lw=0, label="RTK float" if k == 0 else None)


def spline_figure(table: pa.Table, truth: pa.Table | None = None, title: str = "", width: float = 11.0) -> Figure:
    """Raw GNSS against the smoothing spline, float periods shaded (skiracing-splines Figures 5-6).

    Top: plan view (x right, y down the page as in the local frame) of raw ``gnss_x gnss_y`` and the
    spline ``x y``. Bottom: horizontal distance raw - spline [m] (and spline - truth when a truth
    table is given) against time, RTK-float epochs shaded.

    Raises
    ------
    InputError
        No ``gnss_x gnss_y`` or no spline ``x y`` columns.
    """
    gx, gy, x, y = (_col(table, n) for n in ("gnss_x", "gnss_y", "x", "y"))
    if gx is None or gy is None or x is None or y is None:
        raise InputError(
            "missing columns: plot spline needs gnss_x, gnss_y and the spline's x, y; run spline-smooth first"
        )
    t = schema.floats(table, "t")
    fig = _new_figure(width, 8.0)
    top, bottom = fig.subplots(2, 1, height_ratios=[1.4, 1])
    ok = np.isfinite(gx) & np.isfinite(gy)
    fix = (
        np.asarray(table.column("gnss_fix").to_numpy(zero_copy_only=False), float)
        if "gnss_fix" in table.column_names
        else None
    )
    if fix is not None:
        fl = ok & (fix == FLOAT_FIX)
        top.plot(gx[ok & ~fl], gy[ok & ~fl], ".", ms=2.5, color="tab:orange", label="GNSS (fixed)")
        top.plot(gx[fl], gy[fl], ".", ms=3.5, color="tab:red", label="GNSS (float)")
    else:
        top.plot(gx[ok], gy[ok], ".", ms=2.5, color="tab:orange", label="GNSS")
    m = np.isfinite(x) & np.isfinite(y)
    top.plot(x[m], y[m], "-", lw=1.0, color="tab:blue", label="spline")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.invert_yaxis()
    top.set_aspect("equal", adjustable="datalim")
    top.grid(True, lw=0.4, alpha=0.6)
    top.legend(fontsize=8, loc="best")
    d = np.hypot(gx - x, gy - y)
    bottom.plot(t[ok], d[ok], ".", ms=2.5, color="tab:orange", label="|GNSS - spline| horizontal")
    if truth is not None and "true_x" in truth.column_names:
        tt = schema.floats(truth, "t")
        _, ia, ib = np.intersect1d(np.round(t, 6), np.round(tt, 6), return_indices=True)
        e = np.hypot(x[ia] - _col(truth, "true_x")[ib], y[ia] - _col(truth, "true_y")[ib])
        bottom.plot(t[ia], e, "-", lw=0.9, color="tab:blue", label="|spline - truth| horizontal")
    if fix is not None:
        _shade(bottom, float_spans(t[ok], fix[ok]))
    bottom.set_xlabel("t [s]")
    bottom.set_ylabel("horizontal difference [m]")
    bottom.grid(True, lw=0.4, alpha=0.6)
    bottom.legend(fontsize=8, loc="upper right")
    top.set_title(title or "smoothing spline vs raw GNSS (red: RTK float epochs)")
    return fig


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
