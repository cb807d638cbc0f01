"""Figures that know no sport: styling, the output formats, time series with events and std bands, errors against truth,
and the layout helpers the sports' figures share (legends outside the data, labels placed without collisions,
event lines labelled, a stretched axis for long thin tracks, angles unwrapped).

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
from sportfusion.core.plotlayout import describe_figure, fit_titles, fs, layout, legend_outside, narrow_layout
from sportfusion.core.stats import median

__all__ = [
    "FORMATS",
    "describe_figure",
    "errors_figure",
    "fit_titles",
    "events_of",
    "figure_format",
    "fs",
    "legend_outside",
    "narrow_layout",
    "place_labels",
    "render",
    "series_figure",
    "stretch_factor",
    "unwrap_deg",
]

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


#: Output formats by file suffix.
FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}


def _new_figure(width: float, height: float) -> Figure:
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise InputError("plotting needs matplotlib; install the extra: pip install 'sportfusion[plot]'") from exc
    narrow = layout().width
    if narrow is not None and narrow < width:  # a phone's page: the layout's width, the height kept
        width = narrow
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def figure_format(path: str | Path) -> str:
    """``"png"``, ``"svg"`` or ``"pdf"`` from an output file's suffix; :class:`InputError` otherwise."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise InputError(f"output {path} has suffix {suffix or '(none)'!r}; expected .png, .svg or .pdf")
    return FORMATS[suffix]


def render(fig: Figure, fmt: str, dpi: float = 150.0) -> bytes:
    """The figure as PNG, SVG or PDF bytes (``dpi`` [dots per inch] sets a PNG's pixel size)."""
    fit_titles(fig)
    buf = io.BytesIO()
    metadata = {"png": {"Software": "sportfusion"}, "pdf": {"Creator": "sportfusion"}}.get(fmt)
    fig.savefig(buf, format=fmt, dpi=dpi, metadata=metadata)
    return buf.getvalue()


def _col(table: pa.Table, name: str) -> np.ndarray | None:
    return schema.floats(table, name) if name in table.column_names else None


_AX = "xyz"


_COLOURS = ("tab:blue", "tab:orange", "tab:green")


def events_of(table: pa.Table) -> list[tuple[float, str]]:
    """(t [s], label) of every non-null ``event`` row of a table.

    The label is the event's name, numbered when the name occurs more than once: by the row's value in a
    column named like the event (``event == "gate"`` with a ``gate`` id column gives ``gate 7``; ``?``
    where that value is empty or negative, i.e. unmatched), else by order of occurrence (``grip 1``, ``grip 2`` ...).
    """
    if "event" not in table.column_names:
        return []
    ev = table.column("event").to_pylist()
    t = schema.floats(table, "t")
    rows = [(i, str(e)) for i, e in enumerate(ev) if e]
    counts: dict[str, int] = {}
    for _, name in rows:
        counts[name] = counts.get(name, 0) + 1
    seen: dict[str, int] = {}
    out = []
    for i, name in rows:
        label = name
        if counts[name] > 1:
            seen[name] = seen.get(name, 0) + 1
            if name in table.column_names:
                v = table.column(name)[i].as_py()
                label = f"{name} {v:g}" if isinstance(v, int | float) and np.isfinite(v) and v >= 0 else f"{name} ?"
            else:
                label = f"{name} {seen[name]}"
        out.append((float(t[i]), label))
    return out


def _mark_events(ax: Axes, events: list[tuple[float, str]], label: bool = False, fontsize: float = 7.0) -> None:
    """Dashed vertical lines at the events; with ``label``, their names above the axes, in as many rows as it
    takes for no two labels to overlap."""
    fontsize = fs(fontsize)
    for t, _ in events:
        ax.axvline(t, color="0.4", lw=0.8, ls="--", zorder=1)
    if not label or not events:
        return
    lo, hi = ax.get_xlim()
    width_pt = ax.figure.get_figwidth() * 72.0 * 0.62  # the axes' width, on the short side of an estimate
    row_end: list[float] = []
    for t, name in sorted(events):
        f = (t - lo) / (hi - lo) if hi > lo else 0.0
        w = (0.62 * fontsize * len(name) + 8.0) / width_pt
        row = next((r for r, end in enumerate(row_end) if f > end), len(row_end))
        if row == len(row_end):
            row_end.append(f + w)
        row_end[row] = f + w
        ax.annotate(
            name,
            (t, 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(1.5, 2.0 + row * (fontsize + 2.5)),
            textcoords="offset points",
            ha="left",
            va="bottom",
            fontsize=fontsize,
            color="0.3",
            annotation_clip=False,
        )


def unwrap_deg(angle: np.ndarray) -> np.ndarray:
    """An angle [deg] made continuous: a step of more than 180 deg between finite samples is taken as a
    wrap at +-180 deg and removed (NaN gaps are bridged); the result is shifted by whole turns so that its
    median lies in [-180, 180].
    """
    a = np.array(angle, dtype=float)
    ok = np.isfinite(a)
    if ok.sum() > 1:
        a[ok] = np.unwrap(a[ok], period=360.0)
        a -= 360.0 * np.round(median(a[ok]) / 360.0)
    return a


def finish_time_panels(
    fig: Figure, axes: Any, events: list[tuple[float, str]], title: str | None, default_title: str
) -> None:
    """Close a stack of panels against time: events marked on every panel (labelled on the top one), the
    time axis [s] labelled on the bottom one, the title (``default_title`` with ``{}`` where the note on the
    dashed event lines goes, when there are events)."""
    for k, ax in enumerate(axes):
        _mark_events(ax, events, label=k == 0)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(title or default_title.format("; dashed lines: events" if events else ""))


def stretch_factor(long_span: float, short_span: float, min_share: float = 0.25) -> int:
    """How much to stretch the short axis of a plan view of a long thin track [1].

    With a forced equal aspect an 800 m run 30 m wide is a flat line. The factor is the smallest of
    1, 2, 5, 10, 20, 50, 100 that makes ``short_span`` [m] at least ``min_share`` of ``long_span`` [m] on
    the page; the caller states it on the stretched axis' label.
    """
    if not (np.isfinite(long_span) and np.isfinite(short_span)) or short_span <= 0 or long_span <= 0:
        return 1
    for f in (1, 2, 5, 10, 20, 50):
        if f * short_span >= min_share * long_span:
            return f
    return 100


def place_labels(
    ax: Axes,
    xy: np.ndarray,
    texts: list[str],
    avoid: np.ndarray | None = None,
    colours: list[Any] | None = None,
    fontsize: float = 8.0,
    marker_pt: float = 4.0,
) -> list[Any]:
    """Label points [data] so that no two labels overlap and as few ``avoid`` points [data] as can be are
    covered.

    Each label (``fontsize`` [pt], at least the layout's minimum) tries offsets around its point (eight
    directions, 5 to 40 pt away, a thin leader line beyond
    the nearest ring) and keeps the first best: no overlap with a placed label or a labelled point's marker
    (a square ``marker_pt`` [pt] either side), inside the axes, nearer its own point than any other
    labelled point, fewest covered ``avoid`` points. The figure is laid out first (one draw); labels kept
    inside the axes do not change that layout, so the boxes checked are the boxes drawn. Call it after
    everything else is on the figure.
    """
    from matplotlib.text import Text
    from matplotlib.transforms import Bbox, IdentityTransform

    fontsize = fs(fontsize)
    fig = ax.figure
    fig.canvas.draw()  # lays the figure out: labels inside the axes leave that layout as it is
    renderer = fig.canvas.get_renderer()
    px = fig.dpi / 72.0
    pts = ax.transData.transform(np.asarray(xy, float).reshape(-1, 2))
    obst = np.empty((0, 2)) if avoid is None or len(avoid) == 0 else ax.transData.transform(np.asarray(avoid, float))
    obst = obst[np.all(np.isfinite(obst), axis=1)]
    axbox = ax.get_window_extent(renderer)
    r0 = marker_pt * px
    marks = [Bbox.from_extents(p[0] - r0, p[1] - r0, p[0] + r0, p[1] + r0) for p in pts]
    dirs = ((1, 1), (1, -1), (-1, 1), (-1, -1), (1, 0), (-1, 0), (0, 1), (0, -1))
    radii = tuple(marker_pt + d for d in (2.0, 7.0, 13.0, 21.0, 30.0, 40.0))
    placed: list[Bbox] = []
    out = []
    for i, text in enumerate(texts):
        best: tuple[float, tuple[float, float], str, str, float, Bbox] | None = None
        for r in radii:
            for k, (dx, dy) in enumerate(dirs):
                ha = "left" if dx > 0 else "right" if dx < 0 else "center"
                va = "bottom" if dy > 0 else "top" if dy < 0 else "center"
                off = (dx * r * (0.8 if dy else 1.0), dy * r * (0.8 if dx else 1.0))
                x0, y0 = pts[i] + np.array(off) * px
                probe = Text(x0, y0, text, fontsize=fontsize, ha=ha, va=va, transform=IdentityTransform())
                probe.set_figure(fig)
                bb = probe.get_window_extent(renderer)
                gap = bb.padded(1.5 * px)  # neighbouring labels keep a gap, so "E2" "T" never read "E2T"
                hard = sum(gap.overlaps(b) for b in placed) + sum(bb.overlaps(m) for m in marks)
                outside = not (bb.x0 >= axbox.x0 and bb.x1 <= axbox.x1 and bb.y0 >= axbox.y0 and bb.y1 <= axbox.y1)
                inside = (
                    int(
                        np.count_nonzero(
                            (obst[:, 0] >= bb.x0)
                            & (obst[:, 0] <= bb.x1)
                            & (obst[:, 1] >= bb.y0)
                            & (obst[:, 1] <= bb.y1)
                        )
                    )
                    if obst.size
                    else 0
                )
                # a label nearer another labelled point than its own would be read as that point's
                centre = np.array([(bb.x0 + bb.x1) / 2, (bb.y0 + bb.y1) / 2])
                dist = np.hypot(*(pts - centre).T)
                ambiguous = len(pts) > 1 and float(np.min(np.delete(dist, i))) < dist[i]
                score = 1000.0 * hard + 500.0 * outside + 200.0 * ambiguous + inside + 0.01 * r + 0.001 * k
                if best is None or score < best[0]:
                    best = (score, off, ha, va, r, bb)
            if best is not None and best[0] < 1.0:
                break
        assert best is not None
        _, off, ha, va, r, bb = best
        colour = colours[i] if colours is not None else "0.1"
        ann = ax.annotate(
            text,
            tuple(np.asarray(xy, float).reshape(-1, 2)[i]),
            xytext=off,
            textcoords="offset points",
            ha=ha,
            va=va,
            fontsize=fontsize,
            color=colour,
            zorder=6,
            arrowprops=None
            if r <= radii[0]
            else {"arrowstyle": "-", "color": "0.5", "lw": 0.5, "shrinkA": 0, "shrinkB": 2},
        )
        placed.append(bb)
        out.append(ann)
    return out


def _band(ax: Axes, t: np.ndarray, y: np.ndarray, s: np.ndarray | None, colour: str, label: str) -> None:
    ok = np.isfinite(y)
    ax.plot(t[ok], y[ok], color=colour, lw=1.0, label=label)
    if s is not None:
        m = ok & np.isfinite(s)
        ax.fill_between(t[m], y[m] - s[m], y[m] + s[m], color=colour, alpha=0.2, lw=0)


#: The panels :func:`series_figure` can draw, in order.
SERIES_PANELS = ("position", "velocity", "attitude", "gyro bias", "acc bias")


def series_figure(
    table: pa.Table,
    meta: dict[str, Any],
    title: str = "",
    width: float = 12.0,
    panels: tuple[str, ...] = SERIES_PANELS,
) -> Figure:
    """Position, velocity, attitude (and sensor biases when estimated) against time with the GNSS
    measurements and the events (the paper's Figures 8-11).

    Rows drawn (those of ``panels`` whose columns the table has): ``position`` ``x y z`` [m] with
    ``gnss_x..`` dots; ``velocity`` ``vx vy vz`` [m/s]; ``attitude`` ``roll pitch yaw`` [deg]; ``gyro bias``
    ``bias_gyr_*`` [deg/s] and ``acc bias`` ``bias_acc_*`` [m/s^2]. Each estimate with its ``std_`` 1-sigma
    band.

    Raises
    ------
    InputError
        None of those columns is present.
    """
    t = schema.floats(table, "t")
    rows: list[tuple[str, list[str], list[str | None], float, str]] = []  # label, columns, GNSS columns, scale, kind
    want = set(panels)
    if "position" in want and any(n in table.column_names for n in ("x", "gnss_x")):
        rows.append(("position [m]", list(_AX), [f"gnss_{a}" for a in _AX], 1.0, "pos"))
    if "velocity" in want and "vx" in table.column_names:
        rows.append(("velocity [m/s]", [f"v{a}" for a in _AX], [None] * 3, 1.0, "vel"))
    if "attitude" in want and "roll" in table.column_names:
        rows.append(("attitude [deg]", ["roll", "pitch", "yaw"], [None] * 3, 180 / np.pi, "att"))
    if "gyro bias" in want and "bias_gyr_x" in table.column_names:
        rows.append(("gyro bias [deg/s]", [f"bias_gyr_{a}" for a in _AX], [None] * 3, 180 / np.pi, "bg"))
    if "acc bias" in want and "bias_acc_x" in table.column_names:
        rows.append(("acc. bias [m/s^2]", [f"bias_acc_{a}" for a in _AX], [None] * 3, 1.0, "ba"))
    if not rows:
        raise InputError(
            f"missing columns: the series figure ({', '.join(panels)}) needs estimates (x.., vx.., roll.., "
            "bias_gyr_.., bias_acc_..) or gnss_x..; run gps2hill or a smoother first"
        )
    fig = _new_figure(width, (2.2 + (0.6 if layout().legend == "below" else 0.0)) * len(rows) + 1.0)
    axes = np.atleast_1d(fig.subplots(len(rows), 1, sharex=True))
    events = events_of(table)
    for ax, (label, names, meas, scale, kind) in zip(axes, rows, strict=True):
        for name, mname, colour in zip(names, meas, _COLOURS, strict=True):
            y = _col(table, name)
            if y is not None:
                y = y * scale
                s = _col(table, f"std_{name}")
                if kind == "att":  # no full-height jumps where an angle crosses +-180 deg
                    y = unwrap_deg(y)
                    name = f"{name} (unwrapped)" if name == "yaw" else name
                _band(ax, t, y, None if s is None else s * scale, colour, name)
            m = _col(table, mname) if mname else None
            if m is not None:
                ok = np.isfinite(m)
                ax.plot(t[ok], m[ok], ".", ms=2.5, color=colour, alpha=0.6, label=f"{mname} (GNSS)")
        ax.set_ylabel(label)
        ax.grid(True, lw=0.4, alpha=0.6)
        legend_outside(ax, fontsize=7)
    frame = (meta.get("frame") or {}).get("name", "local")
    finish_time_panels(fig, axes, events, title, f"estimates against time ({frame} frame{{}}; bands: 1-sigma)")
    return fig


def errors_figure(table: pa.Table, truth: pa.Table, title: str = "", width: float = 12.0) -> Figure:
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
    events = events_of(truth) or events_of(table)
    for ax, (label, got) in zip(axes, rows, strict=False):
        unit = label[label.index("[") + 1 : label.index("]")]
        for (name, p), colour in zip(got, _COLOURS, strict=True):
            if p is None:
                continue
            err = p[0] - p[1]
            s = _col(table, f"std_{name}")
            rms = float(np.sqrt(np.nanmean(err**2)))
            ok = np.isfinite(err)
            ax.plot(ts[ok], err[ok], color=colour, lw=0.9, label=f"{name}: RMS {rms:.3f} {unit}")
            if s is not None:
                s = s[ia]
                m = np.isfinite(s)
                ax.fill_between(ts[m], -s[m], s[m], color=colour, alpha=0.15, lw=0)
        ax.axhline(0, color="0.3", lw=0.6)
        ax.set_ylabel(label)
        ax.grid(True, lw=0.4, alpha=0.6)
        legend_outside(ax, fontsize=7)
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
        ax.set_ylabel("attitude error [deg]")
        ax.grid(True, lw=0.4, alpha=0.6)
        legend_outside(ax, fontsize=7)
    finish_time_panels(fig, axes, events, title, "estimate minus truth (bands: estimated 1-sigma{})")
    return fig
