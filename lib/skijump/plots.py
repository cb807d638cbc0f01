"""Ski-jump figures: the hill profile, the jump on the profile coloured by speed, speed against time with a flight zoom,
the magnetometer against the smoother's prediction (skijump paper eq 50, Figure 12).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.plots import _AX, _col, _mark_events, _new_figure, events_of
from sportfusion.skijump.hill import HillProfile

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


_POINTS = ("A", "B", "E1", "E2", "T", "F", "P", "K", "L", "U")


def _draw_profile(ax: Axes, profile: HillProfile, points: bool = True) -> None:
    for part in ("inrun", "landing"):
        x, z = profile.sample(part)
        ax.plot(x, -z, color="0.25", lw=1.4, label="hill profile" if part == "landing" else None)
    x, z = profile.sample("landing")
    ax.fill_between(x, -z, np.nanmin(-z) - 5, color="0.9", zorder=0)
    if points:
        for name in _POINTS:
            px, pz = profile.points[name]
            ax.plot(px, -pz, "o", ms=4, color="tab:red" if name in ("K", "L") else "tab:blue", zorder=5)
            below = name in ("F", "B", "E2")
            ax.annotate(name, (px, -pz), textcoords="offset points", xytext=(4, -12 if below else 4), fontsize=8)


def hill_figure(profile: HillProfile, title: str = "", width: float = 10.0, height: float = 6.0) -> Figure:
    """Side view of a hill: in-run, landing hill and out-run with the key points A .. U.

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
    _draw_profile(ax, profile)
    c = profile.cert
    ax.set_title(
        f"{title}  ({c.type}, K {c.w:g} m, HS {c.hS:g} m; jump length at K "
        f"{profile.jump_length(profile.points['K'][0]):.1f} m, at L {profile.jump_length(profile.points['L'][0]):.1f} m)"
    )
    ax.set_xlabel("x: horizontal distance from the take-off edge [m]")
    ax.set_ylabel("height above the take-off edge, -z [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.6)
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
    fig = _new_figure(width, height)
    side, top = fig.subplots(2, 1, sharex=True, height_ratios=[2, 1])
    if profile is not None:
        _draw_profile(side, profile, points=False)
        for name in ("T", "K", "L"):
            px, pz = profile.points[name]
            side.annotate(name, (px, -pz), textcoords="offset points", xytext=(4, 4), fontsize=8)
        for part in ("inrun", "landing"):
            x, _ = profile.sample(part)
            top.plot(x, np.zeros_like(x), color="0.25", lw=1.0)
    if has_gnss:
        ok = np.isfinite(gx) & np.isfinite(gz)
        side.plot(gx[ok], -gz[ok], ".", ms=3, color="tab:orange", label=f"GNSS ({ok.sum()} fixes)")
        if gy is not None:
            ok2 = ok & np.isfinite(gy)
            top.plot(gx[ok2], gy[ok2], ".", ms=3, color="tab:orange")
    if has_est:
        ok = np.isfinite(ex) & np.isfinite(ez)
        side.plot(ex[ok], -ez[ok], "-", lw=1.2, color="tab:blue", label="estimate")
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
    where = f"frame '{frame.get('name', '?')}', azimuth {frame.get('azimuth_deg', 0):g} deg" if frame else "no frame"
    side.set_title(f"{title}  ({where})" if title else where)
    side.set_ylabel("height, -z [m]")
    side.legend(loc="upper right", fontsize=8)
    side.grid(True, lw=0.4, alpha=0.6)
    top.set_ylabel("y (right) [m]")
    top.invert_yaxis()
    top.set_xlabel("x: along the hill axis [m]")
    top.grid(True, lw=0.4, alpha=0.6)
    return fig


def _velocity(table: pa.Table) -> np.ndarray | None:
    """Velocity (n, 3) [m/s] in the local frame: the estimate vx vy vz, else None."""
    cols = [_col(table, f"v{a}") for a in _AX]
    return None if any(c is None for c in cols) else np.column_stack(cols)


def speed_figure(
    table: pa.Table,
    meta: dict[str, Any],
    profile: HillProfile | None = None,
    title: str = "",
    width: float = 11.0,
    height: float = 6.0,
) -> Figure:
    """Side view of the estimated trajectory coloured by speed (the paper's Figure 7).

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
    x, z = _col(table, "x"), _col(table, "z")
    v = _velocity(table)
    if x is None or z is None or v is None:
        raise InputError(
            "missing columns: plot speed needs an estimate x, z [m] and vx vy vz [m/s]; run rts-smooth or spline-smooth first"
        )
    speed = np.linalg.norm(v, axis=1)
    ok = np.isfinite(x) & np.isfinite(z) & np.isfinite(speed)
    fig = _new_figure(width, height)
    ax = fig.add_subplot()
    if profile is not None:
        _draw_profile(ax, profile, points=False)
    sc = ax.scatter(x[ok], -z[ok], c=speed[ok], s=4, cmap="viridis", zorder=3)
    fig.colorbar(sc, ax=ax, label="speed |v| [m/s]")
    for t_ev, name in events_of(table):
        i = int(np.argmin(np.abs(schema.floats(table, "t") - t_ev)))
        if ok[i]:
            ax.annotate(
                f"{name}\n{speed[i]:.1f} m/s",
                (x[i], -z[i]),
                textcoords="offset points",
                xytext=(6, 6),
                fontsize=8,
                arrowprops={"arrowstyle": "-", "color": "0.4"},
            )
    frame = (meta.get("frame") or {}).get("name", "local")
    ax.set_title(title or f"trajectory coloured by speed ({frame} frame)")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("height, -z [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.6)
    return fig


def mag_figure(table: pa.Table, title: str = "", width: float = 11.0) -> Figure:
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
    fig = _new_figure(width, 7.0)
    axes = fig.subplots(3, 1, sharex=True)
    events = events_of(table)
    for ax, a in zip(axes, _AX, strict=True):
        m, p = _col(table, f"mag_{a}"), _col(table, f"mag_pred_{a}")
        ok = np.isfinite(m)
        ax.plot(t[ok], m[ok], ".", ms=1.5, color="0.55", label=f"measured mag_{a}")
        ok = np.isfinite(p)
        ax.plot(t[ok], p[ok], color="tab:red", lw=1.0, label=f"estimated mag_pred_{a}")
        _mark_events(ax, events)
        ax.set_ylabel(f"mag_{a} [{unit}]")
        ax.grid(True, lw=0.4, alpha=0.6)
        ax.legend(loc="upper right", fontsize=7)
    axes[-1].set_xlabel("t [s]")
    axes[0].set_title(title or "magnetometer: measured vs estimated (body frame)")
    return fig
