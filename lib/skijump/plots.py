"""Ski-jump figures: the hill profile, the session over it (side and top view), the trajectory as a line
coloured by speed with a zoom on the flight, the magnetometer against the smoother's prediction (skijump
paper eq 50, Figure 12).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.plots import (
    _AX,
    _col,
    _new_figure,
    events_of,
    finish_time_panels,
    fs,
    layout,
    legend_outside,
    place_labels,
)
from sportfusion.skijump.hill import HillProfile

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


_POINTS = ("A", "B", "E1", "E2", "T", "F", "P", "K", "L", "U")


def _draw_profile(ax: Axes, profile: HillProfile, points: tuple[str, ...] = _POINTS) -> tuple[np.ndarray, np.ndarray]:
    """The profile's line, the landing hill shaded, markers at ``points``; returns the markers' (x, -z) [m]
    and the profile's sampled (x, -z) [m] (what labels should not cover)."""
    line = []
    for part in ("inrun", "landing"):
        x, z = profile.sample(part)
        ax.plot(x, -z, color="0.25", lw=1.4, label="hill profile" if part == "landing" else None)
        line.append(np.column_stack([x, -z]))
    x, z = profile.sample("landing")
    ax.fill_between(x, -z, np.nanmin(-z) - 5, color="0.9", zorder=0)
    xy = np.array([(profile.points[n][0], -profile.points[n][1]) for n in points]).reshape(-1, 2)
    for name, (px, pz) in zip(points, xy, strict=True):
        ax.plot(px, pz, "o", ms=4, color="tab:red" if name in ("K", "L") else "tab:blue", zorder=5)
    return xy, np.vstack(line)


def hill_figure(profile: HillProfile, title: str = "", width: float = 10.0, height: float = 6.0) -> Figure:
    """Side view of a hill: in-run, landing hill and out-run with the key points A .. U, labelled so that
    no two labels collide (leader lines where points crowd, as E2 T F at the take-off edge).

    Parameters
    ----------
    profile : HillProfile
    title : str
        Figure title (the hill's name).
    width, height : float
        Figure size [inch].
    """
    fig = _new_figure(width, height)
    ax = fig.add_subplot()
    xy, line = _draw_profile(ax, profile)
    c = profile.cert
    ax.set_title(
        f"{title}  ({c.type}, K {c.w:g} m, HS {c.hS:g} m; jump length at K "
        f"{profile.jump_length(profile.points['K'][0]):.1f} m, at L {profile.jump_length(profile.points['L'][0]):.1f} m)"
    )
    ax.set_xlabel("x: horizontal distance from the take-off edge [m]")
    ax.set_ylabel("height above the take-off edge, -z [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.6)
    place_labels(ax, xy, list(_POINTS), avoid=line)
    return fig


def profile_from_meta(meta: dict[str, Any]) -> HillProfile | None:
    """The hill profile recorded in a table's ``hill`` metadata (by ``gps2hill --hill``), or None."""
    cert = (meta.get("hill") or {}).get("certificate")
    return None if not cert else HillProfile(cert)


def track_figure(
    table: pa.Table,
    meta: dict[str, Any],
    profile: HillProfile | None = None,
    title: str = "",
    width: float = 10.0,
    height: float = 8.0,
) -> Figure:
    """Side and top view of a session in its local frame, over the hill profile when known.

    Draws the GNSS points ``gnss_x gnss_y gnss_z`` and, when present, the
    estimate ``x y z`` with a 1-sigma band from ``std_z`` (side) and
    ``std_y`` (top).

    Raises
    ------
    InputError
        Neither ``gnss_x/gnss_z`` nor ``x/z`` columns (run gps2hill first).
    """
    gx, gy, gz = (_col(table, f"gnss_{a}") for a in "xyz")
    ex, ey, ez = (_col(table, a) for a in "xyz")
    has_gnss = gx is not None and gz is not None
    has_est = ex is not None and ez is not None
    if not has_gnss and not has_est:
        raise InputError("no gnss_x/gnss_z or x/z columns to draw; expected a session after gps2hill")
    fig = _new_figure(width, height if layout().legend != "below" else 0.75 * height)
    side, top = fig.subplots(2, 1, sharex=True, height_ratios=[2, 1])
    marks: np.ndarray | None = None
    avoid = [np.empty((0, 2))]
    if profile is not None:
        marks, line = _draw_profile(side, profile, points=("T", "K", "L"))
        avoid.append(line)
        for part in ("inrun", "landing"):
            x, _ = profile.sample(part)
            top.plot(x, np.zeros_like(x), color="0.25", lw=1.0)
    if has_gnss:
        ok = np.isfinite(gx) & np.isfinite(gz)
        side.plot(gx[ok], -gz[ok], ".", ms=3, color="tab:orange", label=f"GNSS ({ok.sum()} fixes)")
        avoid.append(np.column_stack([gx[ok], -gz[ok]]))
        if gy is not None:
            ok2 = ok & np.isfinite(gy)
            top.plot(gx[ok2], gy[ok2], ".", ms=3, color="tab:orange")
    if has_est:
        ok = np.isfinite(ex) & np.isfinite(ez)
        side.plot(ex[ok], -ez[ok], "-", lw=1.2, color="tab:blue", label="estimate")
        avoid.append(np.column_stack([ex[ok], -ez[ok]]))
        sz = _col(table, "std_z")
        if sz is not None:
            m = ok & np.isfinite(sz)
            side.fill_between(
                ex[m], -ez[m] - sz[m], -ez[m] + sz[m], color="tab:blue", alpha=0.25, lw=0, label="estimate ±1σ"
            )
        if ey is not None:
            m = ok & np.isfinite(ey)
            top.plot(ex[m], ey[m], "-", lw=1.2, color="tab:blue")
            sy = _col(table, "std_y")
            if sy is not None:
                m2 = m & np.isfinite(sy)
                top.fill_between(ex[m2], ey[m2] - sy[m2], ey[m2] + sy[m2], color="tab:blue", alpha=0.25, lw=0)
    frame = meta.get("frame") or {}
    where = f"{frame.get('name', '?')} frame, azimuth {frame.get('azimuth_deg', 0):.1f} deg" if frame else "no frame"
    side.set_title(f"{title}: side view ({where})" if title else f"side view ({where})")
    side.set_ylabel("height, -z [m]")
    side.grid(True, lw=0.4, alpha=0.6)
    top.set_ylabel("y (right) [m]")
    top.invert_yaxis()
    top.set_xlabel("x: along the hill axis [m]")
    top.grid(True, lw=0.4, alpha=0.6)
    top.set_title("top view (y not to scale)", fontsize=fs(9))
    legend_outside(side)
    if marks is not None:
        place_labels(side, marks, ["T", "K", "L"], avoid=np.vstack(avoid))
    return fig


def _velocity(table: pa.Table) -> np.ndarray | None:
    """Velocity (n, 3) [m/s] in the local frame: the estimate vx vy vz, else None."""
    cols = [_col(table, f"v{a}") for a in _AX]
    return None if any(c is None for c in cols) else np.column_stack(cols)


def _flight(table: pa.Table) -> tuple[float, float] | None:
    """(t take-off, t touch-down) [s] of the first jump in the events, or None."""
    if "event" not in table.column_names:
        return None
    t = schema.floats(table, "t")
    ev = np.array([e or "" for e in table.column("event").to_pylist()], dtype=object)
    to = t[ev == "takeoff"]
    if to.size == 0:
        return None
    td = t[(ev == "touchdown") & (t > to[0])]
    return None if td.size == 0 else (float(to[0]), float(td[0]))


def speed_figure(
    table: pa.Table,
    meta: dict[str, Any],
    profile: HillProfile | None = None,
    title: str = "",
    width: float = 11.0,
    height: float = 9.0,
) -> Figure:
    """Side view of the estimated trajectory as a line coloured by speed (the paper's Figure 7), the whole run
    on top and, when the session has take-off and touch-down events, a zoom on the flight below (to scale,
    with its own colour scale).  A line, not dots: a thinned table (the report draws at most a few hundred
    rows) and the full one look the same.

    Parameters
    ----------
    table : pyarrow.Table
        A smoothed session with ``x z`` [m] and ``vx vy vz`` [m/s] (e.g. from ``rts-smooth`` or
        ``spline-smooth``); the speed is ``|v|`` [m/s].
    meta : dict
        The table's metadata (frame name in the title).
    profile : HillProfile, optional
        Hill profile drawn under the track.

    Raises
    ------
    InputError
        No ``x z`` or no ``vx vy vz`` columns.
    """
    from matplotlib.collections import LineCollection
    from matplotlib.colors import Normalize

    x, z = _col(table, "x"), _col(table, "z")
    v = _velocity(table)
    if x is None or z is None or v is None:
        raise InputError(
            "missing columns: plot speed needs an estimate x, z [m] and vx vy vz [m/s]; run rts-smooth or spline-smooth first"
        )
    t = schema.floats(table, "t")
    speed = np.linalg.norm(v, axis=1)
    ok = np.isfinite(x) & np.isfinite(z) & np.isfinite(speed)
    if not ok.any():
        raise InputError("no row has an estimate x, z [m] and vx vy vz [m/s] to draw")
    flight = _flight(table)
    if flight is not None and not (ok & (t >= flight[0]) & (t <= flight[1])).any():
        flight = None  # no estimate in the air to zoom on
    # the panels' heights follow their data (to scale): the whole run, then the flight's box
    xs, ys = [x[ok]], [-z[ok]]
    if profile is not None:
        line_xz = _draw_line(profile)
        xs.append(line_xz[:, 0])
        ys.append(line_xz[:, 1])
    spans = [max(np.ptp(np.concatenate(ys)), 1.0) / max(np.ptp(np.concatenate(xs)), 1.0)]
    if flight:
        m = ok & (t >= flight[0]) & (t <= flight[1])
        spans.append((np.ptp(-z[m]) + 8.0) / (np.ptp(x[m]) + 20.0))
    narrow = layout().legend == "below"
    fig = _new_figure(width, height)
    plot_w = fig.get_figwidth() - (0.9 if narrow else 2.2)  # less the colour bar (beside it on a wide page)
    fig.set_figheight(min(max(plot_w * sum(spans) + (2.2 if narrow else 1.6) * len(spans), 3.0), 2 * height))
    axes = list(fig.subplots(2, 1, height_ratios=spans)) if flight else [fig.add_subplot()]
    norm = Normalize(float(np.nanmin(speed[ok])), float(np.nanmax(speed[ok])))
    track = np.column_stack([x[ok], -z[ok]])
    labelled = []
    for t_ev, name in events_of(table):
        i = int(np.argmin(np.abs(t - t_ev)))
        if ok[i]:
            labelled.append((x[i], -z[i], f"{name}\n{speed[i]:.1f} m/s"))
    frame = (meta.get("frame") or {}).get("name", "local")
    for k, ax in enumerate(axes):
        if profile is not None:
            _draw_profile(ax, profile, points=())
        sel = ok.copy()
        if k == 1 and flight:  # the flight with its own colour scale, to show the speed's change in the air
            m = ok & (t >= flight[0]) & (t <= flight[1])
            x0, x1 = float(np.min(x[m])) - 8.0, float(np.max(x[m])) + 12.0
            sel = ok & (x >= x0) & (x <= x1)
            y0, y1 = float(np.min(-z[sel])) - 4.0, float(np.max(-z[sel])) + 4.0
            ax.set_xlim(x0, x1)
            ax.set_ylim(y0, y1)
            norm = Normalize(float(np.min(speed[sel])), float(np.max(speed[sel])))
        i = np.flatnonzero(sel)
        pair = i[:-1][np.diff(i) == 1]  # consecutive rows with an estimate: one segment each
        segs = np.stack([np.column_stack([x[pair], -z[pair]]), np.column_stack([x[pair + 1], -z[pair + 1]])], axis=1)
        line = LineCollection(segs, cmap="viridis", norm=norm, linewidths=2.0 if k == 0 else 3.0, zorder=3)
        line.set_array(0.5 * (speed[pair] + speed[pair + 1]))
        ax.add_collection(line)
        ax.autoscale_view()
        ax.plot(*np.array([p[:2] for p in labelled]).T.reshape(2, -1), "o", ms=5, mfc="none", mec="k", zorder=4)
        fig.colorbar(
            line,
            ax=ax,
            label="speed |v| [m/s]" if k == 0 else "speed in the zoom |v| [m/s]",
            location="bottom" if narrow else "right",
            shrink=0.8 if narrow else 1.0,
        )
        ax.set_xlabel("x [m]")
        ax.set_ylabel("height, -z [m]")
        ax.set_aspect("equal", adjustable="box")
        ax.grid(True, lw=0.4, alpha=0.6)
    axes[0].set_title(
        title or f"trajectory, line coloured by speed ({frame} frame{'; circles: events' if labelled else ''})"
    )
    if flight:
        i0, i1 = (int(np.argmin(np.abs(t - f))) for f in flight)
        axes[1].set_title(
            f"flight (zoom): {flight[1] - flight[0]:.2f} s in the air, {x[i1] - x[i0]:.1f} m horizontally",
            fontsize=fs(10),
        )
        axes[0].indicate_inset_zoom(axes[1], edgecolor="0.3")
    for ax in axes:
        if labelled:
            xl, yl = ax.get_xlim(), ax.get_ylim()
            inside = [p for p in labelled if xl[0] <= p[0] <= xl[1] and min(yl) <= p[1] <= max(yl)]
            if inside:
                place_labels(
                    ax,
                    np.array([p[:2] for p in inside]),
                    [p[2] for p in inside],
                    avoid=np.vstack([track, *([] if profile is None else [_draw_line(profile)])]),
                )
    return fig


def _draw_line(profile: HillProfile) -> np.ndarray:
    """The profile's sampled (x, -z) [m]."""
    return np.vstack([np.column_stack([p[0], -p[1]]) for p in (profile.sample("inrun"), profile.sample("landing"))])


def mag_figure(table: pa.Table, title: str = "", width: float = 12.0) -> Figure:
    """Measured magnetometer ``mag_*`` against the smoother's prediction ``mag_pred_*`` (Figure 12).

    Raises
    ------
    InputError
        No ``mag_*`` or no ``mag_pred_*`` columns (``rts-smooth`` writes the prediction).
    """
    t = schema.floats(table, "t")
    have = all(f"mag_{a}" in table.column_names and f"mag_pred_{a}" in table.column_names for a in _AX)
    if not have:
        raise InputError(
            "missing columns: plot mag needs mag_x.. and the smoother's mag_pred_x.. columns; run rts-smooth first"
        )
    unit = schema.unit_of("mag_x") or "uT"
    fig = _new_figure(width, 7.5)
    axes = fig.subplots(3, 1, sharex=True)
    events = events_of(table)
    for ax, a in zip(axes, _AX, strict=True):
        m, p = _col(table, f"mag_{a}"), _col(table, f"mag_pred_{a}")
        ok = np.isfinite(m)
        ax.plot(t[ok], m[ok], ".", ms=1.5, color="0.55", label=f"measured mag_{a}")
        ok = np.isfinite(p)
        ax.plot(t[ok], p[ok], color="tab:red", lw=1.0, label=f"estimated mag_pred_{a}")
        ax.set_ylabel(f"mag_{a} [{unit}]")
        ax.grid(True, lw=0.4, alpha=0.6)
        legend_outside(ax, fontsize=7)
    finish_time_panels(fig, axes, events, title, "magnetometer: measured vs estimated (body frame{})")
    return fig
