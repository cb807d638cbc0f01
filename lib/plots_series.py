"""Ski-jump figures of the paper: speed along the track (Figure 7), time series (Figures 8-11),
estimated vs measured magnetometer (Figure 12) and errors against truth (Figure 6).

Every function returns a matplotlib :class:`~matplotlib.figure.Figure` built on the Agg canvas
(see :mod:`sportfusion.plots`); :func:`sportfusion.plots.render` turns it into PNG/SVG bytes.
Positions are in the session's local (hill) frame (x forward, y right, z down) [m]; heights are
drawn as ``-z`` [m]; angles in degrees on the axes, radians in the tables.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from sportfusion import rotations, schema
from sportfusion.errors import InputError
from sportfusion.hill import HillProfile
from sportfusion.plots import _col, _draw_profile, _new_figure

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["speed_figure", "series_figure", "errors_figure", "mag_figure", "events_of"]

_AX = "xyz"
_COLOURS = ("tab:blue", "tab:orange", "tab:green")


def events_of(table: pa.Table) -> list[tuple[float, str]]:
    """(t [s], name) of every non-null ``event`` row of a table."""
    if "event" not in table.column_names:
        return []
    ev = table.column("event").to_pylist()
    t = schema.floats(table, "t")
    return [(float(t[i]), str(e)) for i, e in enumerate(ev) if e]


def _mark_events(ax: Axes, events: list[tuple[float, str]], label: bool = False) -> None:
    for t, name in events:
        ax.axvline(t, color="0.4", lw=0.8, ls="--", zorder=1)
        if label:
            ax.annotate(
                name,
                (t, 1.0),
                xycoords=("data", "axes fraction"),
                xytext=(2, -10),
                textcoords="offset points",
                fontsize=7,
                color="0.3",
            )


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


def _band(ax: Axes, t: np.ndarray, y: np.ndarray, s: np.ndarray | None, colour: str, label: str) -> None:
    ok = np.isfinite(y)
    ax.plot(t[ok], y[ok], color=colour, lw=1.0, label=label)
    if s is not None:
        m = ok & np.isfinite(s)
        ax.fill_between(t[m], y[m] - s[m], y[m] + s[m], color=colour, alpha=0.2, lw=0)


def series_figure(table: pa.Table, meta: dict[str, Any], title: str = "", width: float = 11.0) -> Figure:
    """Position, velocity, attitude (and sensor biases when estimated) against time with the GNSS
    measurements and the events (the paper's Figures 8-11).

    Rows drawn: position ``x y z`` [m] with ``gnss_x..`` dots; velocity ``vx vy vz`` [m/s]; attitude
    ``roll pitch yaw`` [deg]; gyroscope and accelerometer biases ``bias_gyr_*`` [deg/s] and
    ``bias_acc_*`` [m/s^2]. Each estimate with its ``std_`` 1-sigma band; missing rows are skipped.

    Raises
    ------
    InputError
        None of those columns is present.
    """
    t = schema.floats(table, "t")
    rows: list[tuple[str, list[str], list[str | None], float, str]] = []
    if any(n in table.column_names for n in ("x", "gnss_x")):
        rows.append(("position [m]", list(_AX), [f"gnss_{a}" for a in _AX], 1.0, "pos"))
    if "vx" in table.column_names:
        rows.append(("velocity [m/s]", [f"v{a}" for a in _AX], [None] * 3, 1.0, "vel"))
    if "roll" in table.column_names:
        rows.append(("attitude [deg]", ["roll", "pitch", "yaw"], [None] * 3, 180 / np.pi, "att"))
    if "bias_gyr_x" in table.column_names:
        rows.append(("gyro bias [deg/s]", [f"bias_gyr_{a}" for a in _AX], [None] * 3, 180 / np.pi, "bg"))
    if "bias_acc_x" in table.column_names:
        rows.append(("acc. bias [m/s^2]", [f"bias_acc_{a}" for a in _AX], [None] * 3, 1.0, "ba"))
    if not rows:
        raise InputError(
            "plot series: missing columns; needs estimates (x.., vx.., roll..) or gnss_x..; run gps2hill or a smoother first"
        )
    fig = _new_figure(width, 2.2 * len(rows) + 0.8)
    axes = np.atleast_1d(fig.subplots(len(rows), 1, sharex=True))
    events = events_of(table)
    for k, (ax, (label, names, meas, scale, kind)) in enumerate(zip(axes, rows, strict=True)):
        for name, mname, colour in zip(names, meas, _COLOURS, strict=True):
            y = _col(table, name)
            if y is not None:
                s = _col(table, f"std_{name}")
                _band(ax, t, y * scale, None if s is None else s * scale, colour, name)
            m = _col(table, mname) if mname else None
            if m is not None:
                ok = np.isfinite(m)
                ax.plot(t[ok], m[ok], ".", ms=2.5, color=colour, alpha=0.6, label=f"{mname} (GNSS)")
        if kind == "att":
            ax.set_ylim(-185, 185)
        _mark_events(ax, events, label=k == 0)
        ax.set_ylabel(label)
        ax.grid(True, lw=0.4, alpha=0.6)
        ax.legend(loc="upper right", fontsize=7, ncols=3)
    axes[-1].set_xlabel("t [s]")
    frame = (meta.get("frame") or {}).get("name", "local")
    axes[0].set_title(title or f"estimates against time ({frame} frame; dashed lines: events)")
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


def errors_figure(table: pa.Table, truth: pa.Table, title: str = "", width: float = 11.0) -> Figure:
    """Estimate minus truth against time with the estimate's 1-sigma band (the paper's Figure 6).

    Rows: position error [m] (x y z), velocity error [m/s] (vx vy vz), attitude error as the rotation
    angle between estimated and true quaternions [deg] — each where both tables have the columns.
    Tables are joined on ``t`` (the truth from ``simulate --truth`` has the session's rows).

    Raises
    ------
    InputError
        The tables share no time stamps or no estimate/truth column pair.
    """
    t = schema.floats(table, "t")
    tt = schema.floats(truth, "t")
    _, ia, ib = np.intersect1d(np.round(t, 6), np.round(tt, 6), return_indices=True)
    if ia.size == 0:
        raise InputError("the estimate and the truth share no time stamps; expected the truth of this session")

    def pair(name: str) -> tuple[np.ndarray, np.ndarray] | None:
        e, r = _col(table, name), _col(truth, f"true_{name}")
        return None if e is None or r is None else (e[ia], r[ib])

    rows = []
    for label, names in (("position error [m]", list(_AX)), ("velocity error [m/s]", [f"v{a}" for a in _AX])):
        got = [(n, pair(n)) for n in names]
        if any(p is not None for _, p in got):
            rows.append((label, got))
    q = [pair(f"q{i}") for i in range(4)]
    if not rows and any(p is None for p in q):
        raise InputError("no estimate column has a true_ counterpart in the truth table")
    n_rows = len(rows) + (0 if any(p is None for p in q) else 1)
    fig = _new_figure(width, 2.4 * n_rows + 0.8)
    axes = np.atleast_1d(fig.subplots(n_rows, 1, sharex=True))
    ts = t[ia]
    events = events_of(truth)
    for ax, (label, got) in zip(axes, rows, strict=False):
        for (name, p), colour in zip(got, _COLOURS, strict=True):
            if p is None:
                continue
            err = p[0] - p[1]
            s = _col(table, f"std_{name}")
            rms = float(np.sqrt(np.nanmean(err**2)))
            ok = np.isfinite(err)
            ax.plot(ts[ok], err[ok], color=colour, lw=0.9, label=f"{name}: RMS {rms:.3f}")
            if s is not None:
                s = s[ia]
                m = np.isfinite(s)
                ax.fill_between(ts[m], -s[m], s[m], color=colour, alpha=0.15, lw=0)
        ax.axhline(0, color="0.3", lw=0.6)
        _mark_events(ax, events)
        ax.set_ylabel(label)
        ax.grid(True, lw=0.4, alpha=0.6)
        ax.legend(loc="upper right", fontsize=7, ncols=3)
    if n_rows > len(rows):
        ax = axes[-1]
        qe = np.column_stack([p[0] for p in q])
        qt = np.column_stack([p[1] for p in q])
        ang = np.degrees(rotations.quat_angle(qe, qt))
        ok = np.isfinite(ang)
        ax.plot(
            ts[ok],
            ang[ok],
            color="tab:purple",
            lw=0.9,
            label=f"rotation angle: RMS {np.sqrt(np.mean(ang[ok] ** 2)):.3f} deg",
        )
        _mark_events(ax, events)
        ax.set_ylabel("attitude error [deg]")
        ax.grid(True, lw=0.4, alpha=0.6)
        ax.legend(loc="upper right", fontsize=7)
    axes[-1].set_xlabel("t [s]")
    axes[0].set_title(title or "estimate minus truth (bands: estimated 1-sigma)")
    return fig
