"""Figures that know no sport: styling, the output formats, time series with events and std bands, errors against truth.

matplotlib is imported by the callers' plot functions only (the ``plot`` command), never at library import.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from sportfusion.core import rotations, schema
from sportfusion.core.errors import InputError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


#: Output formats by file suffix.
FORMATS = {".png": "png", ".svg": "svg"}


def _new_figure(width: float, height: float) -> Figure:
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise InputError("plotting needs matplotlib; install the extra: pip install 'sportfusion[plot]'") from exc
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def figure_format(path: str | Path) -> str:
    """``"png"`` or ``"svg"`` from an output file's suffix; :class:`InputError` otherwise."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise InputError(f"output {path} has suffix {suffix or '(none)'!r}; expected .png or .svg")
    return FORMATS[suffix]


def render(fig: Figure, fmt: str, dpi: float = 150.0) -> bytes:
    """The figure as PNG or SVG bytes (``dpi`` [dots per inch] sets a PNG's pixel size)."""
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, dpi=dpi, metadata={"Software": "sportfusion"} if fmt == "png" else None)
    return buf.getvalue()


def _col(table: pa.Table, name: str) -> np.ndarray | None:
    return schema.floats(table, name) if name in table.column_names else None


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
