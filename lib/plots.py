"""Figures (PNG or SVG) for the ``plot`` command: hill profiles and tracks over them.

matplotlib is the optional ``plot`` extra (``pip install 'sportfusion[plot]'``)
and is imported only inside these functions, through its object-oriented API
on the Agg canvas (no pyplot, no global backend change).

All coordinates are in the hill frame (x forward, y right, z down) [m]; side
views show the height ``-z`` [m] so that the hill runs downhill on the page.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from sportfusion import schema
from sportfusion.errors import InputError
from sportfusion.hill import HillProfile

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["FORMATS", "figure_format", "render", "hill_figure", "track_figure", "profile_from_meta", "compare_figure"]

#: Output formats by file suffix.
FORMATS = {".png": "png", ".svg": "svg"}
_POINTS = ("A", "B", "E1", "E2", "T", "F", "P", "K", "L", "U")


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


def _col(table: pa.Table, name: str) -> np.ndarray | None:
    return schema.floats(table, name) if name in table.column_names else None


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


#: Columns of a compare-runs summary that ``compare_figure`` draws: (column, title, unit, smaller is better).
COMPARE_PANELS = (
    ("acc_time_diff", "Accumulated time\ndifference", "s", True),
    ("section_time_diff", "Gate-to-gate time\ndifference", "s", True),
    ("path_distance_diff", "Distance along the path\ndifference", "m", True),
    ("gate_speed_diff", "Speed difference\nat the gate", "m/s", False),
)
COMPARE_COLUMNS = ("run", "gate", "path_distance", *(c for c, _, _, _ in COMPARE_PANELS))


def compare_figure(
    table: pa.Table, meta: dict[str, Any], title: str = "", width: float = 13.0, profile: pa.Table | None = None
) -> Figure:
    """The four-column run comparison of skiracing-splines Figure 9 from a ``compare-runs`` summary.

    One row per gate (course order, top to bottom; the label gives the gate, its
    turn side and the reference's distance along the path from the first gate
    [m]); columns: accumulated time difference [s], gate-to-gate time difference
    [s], difference of the distance along the path [m] and of the speed at the
    gate [m/s], each run minus the reference.  With one compared run the bars
    are green where the run gains (less time, shorter path, more speed) and red
    where it loses; with several, one colour per run.  ``profile`` (``compare-runs
    --profile``: run, path_distance [m], speed_diff [m/s]) adds the speed difference
    along the course to the last column as a line, placed between the gates by the
    reference's distance.

    Raises
    ------
    InputError
        Missing summary columns, or no run besides the reference.
    """
    schema.require_columns(table, COMPARE_COLUMNS, "plot compare (a compare-runs summary table)")
    ref = (meta.get("compare") or {}).get("reference")
    runs = list(dict.fromkeys(table.column("run").to_pylist()))
    if ref is None:
        ref = runs[0] if runs else None
    others = [r for r in runs if r != ref]
    if not others:
        raise InputError("the summary holds no run besides the reference; expected compare-runs output")
    run_col = np.asarray(table.column("run").to_pylist(), dtype=object)
    gates = np.asarray(table.column("gate").to_pylist())
    turn = table.column("turn").to_pylist() if "turn" in table.column_names else [None] * table.num_rows
    refm = run_col == ref
    order = [int(g) for g in gates[refm]]
    dist = dict(zip(order, schema.floats(table, "path_distance")[refm], strict=True))
    sides = dict(zip(order, [s for s, m in zip(turn, refm, strict=True) if m], strict=True))
    ypos = {g: i for i, g in enumerate(order)}
    labels = [f"gate {g}{' ' + sides[g] if sides[g] else ''}  ({dist[g]:.0f} m)" for g in order]

    fig = _new_figure(width, 1.6 + 0.42 * len(order))
    axes = fig.subplots(1, len(COMPARE_PANELS), sharey=True)
    nrun = len(others)
    h = 0.8 / nrun
    colours = ["tab:blue", "tab:orange", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan"]
    for ax, (col, name, unit, smaller_better) in zip(axes, COMPARE_PANELS, strict=True):
        vals = schema.floats(table, col)
        for k, run in enumerate(others):
            m = run_col == run
            y = np.array([ypos[int(g)] for g in gates[m]]) - 0.4 + h * (k + 0.5)
            v = vals[m]
            if nrun == 1:
                good = v < 0 if smaller_better else v > 0
                colour = np.where(good, "tab:green", "tab:red")
            else:
                colour = colours[k % len(colours)]
            ok = np.isfinite(v)
            ax.barh(y[ok], v[ok], height=h * 0.9, color=colour[ok] if nrun == 1 else colour, label=run)
            if nrun == 1:
                digits = 3 if np.nanmax(np.abs(v)) < 0.1 else 2
                for yy, vv in zip(y[ok], v[ok], strict=True):
                    ax.annotate(
                        f"{vv:+.{digits}f}",
                        (vv, yy),
                        textcoords="offset points",
                        xytext=(3 if vv >= 0 else -3, 0),
                        ha="left" if vv >= 0 else "right",
                        va="center",
                        fontsize=7,
                    )
        if profile is not None and col == "gate_speed_diff":
            schema.require_columns(profile, ("run", "path_distance", "speed_diff"), "plot compare --profile")
            prun = np.asarray(profile.column("run").to_pylist(), dtype=object)
            ref_d = np.array([dist[g] for g in order])
            for k, run in enumerate(others):
                m = prun == run
                pd_, sd = schema.floats(profile, "path_distance")[m], schema.floats(profile, "speed_diff")[m]
                ax.plot(
                    sd,
                    np.interp(pd_, ref_d, np.arange(len(order))),
                    lw=1.0,
                    label=f"{run} along the course",
                    color="0.15" if nrun == 1 else colours[k % len(colours)],
                )
                vals = np.concatenate([vals, sd])
            ax.legend(loc="lower right", fontsize=7)
        ax.axvline(0.0, color="0.2", lw=0.8)
        lim = np.nanmax(np.abs(vals)) if np.isfinite(vals).any() else 1.0
        lim = lim if lim > 0 else 1.0
        ax.set_xlim(-1.45 * lim, 1.45 * lim)
        ax.set_title(name, fontsize=10)
        ax.set_xlabel(f"run − reference [{unit}]")
        ax.grid(True, axis="x", lw=0.4, alpha=0.6)
    axes[0].set_yticks(range(len(order)), labels, fontsize=8)
    axes[0].set_ylim(len(order) - 0.5, -0.5)  # first gate on top
    if nrun > 1:
        axes[-1].legend(loc="lower right", fontsize=8, title="run")
    vs = ", ".join(others)
    fig.suptitle(
        title or f"{vs} vs reference {ref} (run minus reference; green: gain, red: loss)"
        if nrun == 1
        else title or f"{vs} vs reference {ref} (run minus reference)"
    )
    return fig
