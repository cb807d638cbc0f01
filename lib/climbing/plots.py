"""Climbing figure: the hand path over the wall's hold map, holds reached marked."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from sportfusion.core.errors import InputError
from sportfusion.core.plots import _col, _new_figure, legend_outside, place_labels

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
    """A climbing hand path over the wall's hold map (front view: horizontal wall axis vs up), each route's
    holds in the colour its name gives (:func:`route_colours`), numbered, labels clear of each other.

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
    names_ = list(dict.fromkeys(routes))
    colours = route_colours(names_)
    path_colour = _distinct(("tab:blue", "tab:cyan", "tab:olive", "tab:pink"), list(colours.values()))
    fig = _new_figure(width, 9.0)
    ax = fig.add_subplot()
    starts = (holds_meta.get("climbing") or {}).get("start_holds") or {}
    hold_no = holds.column("hold").to_pylist() if "hold" in holds.column_names else list(range(holds.num_rows))
    for route in names_:
        sel = np.array([r == route for r in routes])
        face, edge = colours[route], _ink(colours[route])
        ax.plot(hx[sel], hu[sel], "o", ms=9, mfc=face, mec=edge, mew=1.2, alpha=0.8, label=f"holds: {route}")
    label_xy = np.column_stack([hx, hu])
    label_text = [f"{h}{'S' if h in starts.get(r, []) else ''}" for h, r in zip(hold_no, routes, strict=True)]
    label_colour = [_ink(colours[r]) for r in routes]
    avoid = [np.empty((0, 2))]
    if truth is not None:
        tx, tu = _col(truth, f"true_{names[across]}"), _col(truth, f"true_{names[up]}")
        if tx is not None and tu is not None:
            m = np.isfinite(tx) & np.isfinite(tu)
            ax.plot(tx[m], tu[m], "-", lw=0.8, color="0.55", label="true hand path")
            avoid.append(np.column_stack([tx[m], tu[m]]))
    m = np.isfinite(px) & np.isfinite(pu)
    ax.plot(px[m], pu[m], "-", lw=1.1, color=path_colour, label="estimated hand path")
    avoid.append(np.column_stack([px[m], pu[m]]))
    if "grip" in table.column_names:
        g = np.asarray(table.column("grip").to_numpy(zero_copy_only=False), dtype=object)
        g = np.array([bool(v) if v is not None else False for v in g]) & m
        ax.plot(px[g], pu[g], "D", ms=3.5, mfc="white", mec=path_colour, label="grips (estimated path)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"{names[across]} (along the wall) [m]")
    ax.set_ylabel(f"{names[up]} (up) [m]")
    ax.grid(True, lw=0.4, alpha=0.6)
    legend_outside(ax)
    ax.set_title(title or "hand path over the hold map (hold numbers; S: start hold)")
    place_labels(ax, label_xy, label_text, avoid=np.vstack(avoid), colours=label_colour, fontsize=7, marker_pt=5.0)
    return fig


def route_colours(routes: list[str]) -> dict[str, Any]:
    """A colour per route: the route's own name where it names a colour (``black``, ``purple``,
    ``light blue``), else one of the default cycle that no named route uses."""
    from matplotlib import colors as mcolors

    out: dict[str, Any] = {}
    for r in routes:
        key = str(r).lower().replace(" ", "").replace("_", "").replace("-", "")
        if key in mcolors.CSS4_COLORS:
            out[r] = mcolors.CSS4_COLORS[key]
    spare = iter(c for c in (f"C{k}" for k in range(1, 10)) if _distinct((c,), list(out.values()), None) == c)
    for r in routes:
        if r not in out:
            out[r] = next(spare, "0.3")
    return out


def _distinct(candidates: tuple[str, ...], used: list[Any], default: str | None = "tab:blue") -> str | None:
    """The first candidate colour at least 0.35 (RGB distance) from every used one."""
    from matplotlib import colors as mcolors

    rgb = [np.array(mcolors.to_rgb(u)) for u in used]
    for c in candidates:
        if all(np.linalg.norm(np.array(mcolors.to_rgb(c)) - u) >= 0.35 for u in rgb):
            return c
    return default


def _ink(colour: Any) -> Any:
    """The colour itself, or dark grey where it is too light to read on white (a white or yellow route)."""
    from matplotlib import colors as mcolors

    r, g, b = mcolors.to_rgb(colour)
    return colour if 0.299 * r + 0.587 * g + 0.114 * b < 0.75 else "0.3"
