"""Ski-racing figures: the smoothing spline against the raw GNSS with the float periods shaded, and the gate-by-gate
comparison of runs (skiracing-splines paper, Figure 9).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.events import true_runs
from sportfusion.core.plots import _col, _new_figure, fs, legend_outside, stretch_factor

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


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
                        f"{vv:+.{digits}f} {unit}" if round(vv, digits) != 0 else f"0 {unit}",
                        (vv, yy),
                        textcoords="offset points",
                        xytext=(3 if vv >= 0 else -3, 0),
                        ha="left" if vv >= 0 else "right",
                        va="center",
                        fontsize=fs(7),
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
        ax.axvline(0.0, color="0.2", lw=0.8)
        lim = np.nanmax(np.abs(vals)) if np.isfinite(vals).any() else 1.0
        lim = lim if lim > 0 else 1.0
        ax.set_xlim(-1.7 * lim, 1.7 * lim)
        ax.set_title(name, fontsize=fs(10))
        ax.set_xlabel(f"run − reference [{unit}]")
        ax.grid(True, axis="x", lw=0.4, alpha=0.6)
    axes[0].set_yticks(range(len(order)), labels, fontsize=fs(8))
    axes[0].set_ylim(len(order) - 0.5, -0.5)  # first gate on top
    if nrun == 1:
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch

        handles = [
            Patch(color="tab:green", label=f"{others[0]} gains"),
            Patch(color="tab:red", label=f"{others[0]} loses"),
        ]
        handles += [h for h in axes[-1].get_legend_handles_labels()[0] if isinstance(h, Line2D)]
        legend_outside(axes[-1], handles=handles)
    else:
        legend_outside(axes[-1], title="run")
    vs = ", ".join(others)
    fig.suptitle(
        title or f"{vs} vs reference {ref} (run minus reference; green: gain, red: loss)"
        if nrun == 1
        else title or f"{vs} vs reference {ref} (run minus reference)"
    )
    return fig


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


def spline_figure(table: pa.Table, truth: pa.Table | None = None, title: str = "", width: float = 12.0) -> Figure:
    """Raw GNSS against the smoothing spline, float periods shaded (skiracing-splines Figures 5-6).

    Top: plan view (x right, y down the page as in the local frame) of raw ``gnss_x gnss_y`` and the
    spline ``x y``, y stretched by the factor on its label where the run is long and thin
    (:func:`sportfusion.core.plots.stretch_factor`). Bottom: horizontal distance raw - spline [m] (and spline - truth when a truth
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
    # a run is long and thin: stretch y by a stated factor rather than draw a flat line at equal aspect
    f = stretch_factor(float(np.ptp(x[m])), float(np.ptp(y[m]))) if m.any() else 1
    top.set_xlabel("x [m]")
    top.set_ylabel(f"y [m], stretched ×{f}" if f > 1 else "y [m]")
    top.invert_yaxis()
    top.set_aspect(f, adjustable="datalim")
    top.grid(True, lw=0.4, alpha=0.6)
    legend_outside(top)
    d = np.hypot(gx - x, gy - y)
    rms = float(np.sqrt(np.nanmean(d[ok] ** 2))) if ok.any() else float("nan")
    bottom.plot(t[ok], d[ok], ".", ms=2.5, color="tab:orange", label=f"|GNSS - spline|: RMS {rms:.3f} m")
    if truth is not None and "true_x" in truth.column_names:
        tt = schema.floats(truth, "t")
        _, ia, ib = np.intersect1d(np.round(t, 6), np.round(tt, 6), return_indices=True)
        e = np.hypot(x[ia] - _col(truth, "true_x")[ib], y[ia] - _col(truth, "true_y")[ib])
        rms_t = float(np.sqrt(np.nanmean(e**2))) if e.size else float("nan")
        bottom.plot(t[ia], e, "-", lw=0.9, color="tab:blue", label=f"|spline - truth|: RMS {rms_t:.3f} m")
    if fix is not None:
        _shade(bottom, float_spans(t[ok], fix[ok]))
    bottom.set_xlabel("t [s]")
    bottom.set_ylabel("horizontal difference [m]")
    bottom.grid(True, lw=0.4, alpha=0.6)
    legend_outside(bottom)
    top.set_title(title or "smoothing spline vs raw GNSS, plan view (red: RTK float epochs)")
    return fig
