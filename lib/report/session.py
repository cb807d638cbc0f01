"""One processed session -> one self-contained HTML page for the coach: headline figures, the sport's table,
the trajectory, the time series that matter, how sure we are, the accuracy against a truth; folded at the
end the analyst's part (sensor biases, the full evaluation, the provenance) and "Reading the report".

The sport is read from the table (a ski-jump hill in the metadata, the spline's ``speed``/``distance``,
the gate smoother's anchors, the climbing hold labels); each sport's part is a function registered in
:data:`~sportfusion.report.sports.SPORT_SECTIONS` that fills a :class:`~sportfusion.report.parts.Sections`:
a sport, or a figure for every sport, is added there without touching the page's frame.  The figures on the page are
the numbers of the other tools: ``jump-metrics`` (computed here from the same library function when no
jumps table is given), ``gate-anchor``'s per-turn columns, ``pf-holds``' hold labels, ``evaluate``'s RMS
rows (angles converted from the table's radians to degrees).  Figures are drawn for a phone's width
(:func:`sportfusion.core.plotlayout.narrow_layout`), their captions and alt texts read from the figures.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.report import html as H
from sportfusion.report.glossary import glossary_html
from sportfusion.report.parts import MAX_PLOT_ROWS, Context, Sections, _thin, col, duration, figure
from sportfusion.report.sports import SPORT_SECTIONS

SPORTS = ("skijump", "skirace", "gates", "climbing")
__all__ = ["MAX_PLOT_ROWS", "SPORTS", "Context", "Sections", "certainty", "detect_sport", "session_report", "_thin"]
NAMES = {"skijump": "Ski jump", "skirace": "Ski race", "gates": "Ski race with magnet gates", "climbing": "Climbing"}


def detect_sport(table: pa.Table, meta: dict[str, Any]) -> str:
    """The sport of a processed session, from what the pipelines leave in it."""
    cols = set(table.column_names)
    if "hold_id" in cols:
        return "climbing"
    if "gate_anchor" in cols or "gate_anchor" in meta:
        return "gates"
    if meta.get("hill") and {"x", "y", "z"} <= cols:
        return "skijump"
    if {"speed", "distance"} <= cols:
        return "skirace"
    raise InputError(
        "cannot tell the sport of this table: missing the columns of a processed session (x y z with a hill: "
        "rts-smooth; speed distance: spline-smooth; gate_anchor: gate-anchor; hold_id: pf-holds); give --sport"
    )


def _std_rows(table: pa.Table, names: tuple[str, ...], unit: str) -> list[tuple[str, str, str]]:
    rows = []
    for n in names:
        s = col(table, f"std_{n}")
        if s is not None and np.isfinite(s).any():
            rows.append((n, H.value_in(float(np.nanmedian(s)), unit), H.value_in(float(np.nanmax(s)), unit)))
    return rows


def certainty(table: pa.Table) -> str:
    """The estimator's 1-sigma over the session: median and largest, each with its unit (angles in deg)."""
    rows = _std_rows(table, ("x", "y", "z"), "m") + _std_rows(table, ("vx", "vy", "vz"), "m/s")
    rows += _std_rows(table, ("roll", "pitch", "yaw"), "rad")
    if not rows:
        return ""
    return (
        "<h2>How sure we are</h2><p>The estimator's own 1-sigma uncertainty over the session "
        "(position in metres, velocity in m/s, attitude in degrees).</p>"
        + H.table(["quantity", "median 1-sigma", "largest 1-sigma"], rows, ident="certainty", text_columns=(0,))
    )


#: evaluate's summary columns shown, in order
EVAL_COLUMNS = ("x", "y", "z", "vx", "vy", "vz", "vel_n", "vel_e", "vel_d", "roll", "pitch", "yaw", "rot_angle")


def _unit(table: pa.Table, name: str) -> str:
    md = table.schema.field(name).metadata or {}
    return (md.get(b"unit") or b"").decode() or schema.unit_of(name) or ""


#: how a reader sees evaluate's column names
EVAL_LABELS = {"rot_angle": "attitude angle"}


def evaluation_table(evaluation: pa.Table, meta: dict[str, Any], stat: str = "rms", ident: str = "") -> str:
    """``evaluate``'s rows of one statistic (``rms``, ``mean``, ``max``): a row per quantity, a column per
    phase, each value in its unit (angles converted from the table's radians to degrees), the frame named
    in the caption."""
    names = [c for c in EVAL_COLUMNS if c in evaluation.column_names]
    units = {c: _unit(evaluation, c) for c in names}
    by_phase = {r["phase"]: r for r in evaluation.to_pylist() if r.get("stat") == stat}
    if not by_phase or not names:
        return ""
    phases = list(by_phase)
    rows = [[EVAL_LABELS.get(c, c)] + [H.value_in(by_phase[p].get(c), units[c]) for p in phases] for c in names]
    frame = (meta.get("evaluation") or {}).get("frame") or _frame_words(meta)
    what = {"rms": "RMS", "mean": "mean", "max": "largest absolute"}.get(stat, stat)
    caption = (
        f"{what} of estimate minus truth per phase; position and velocity in the {frame}; "
        "attitude in degrees (the same in any frame)"
    )
    return H.table(["error in", *phases], rows, caption=caption, ident=ident, text_columns=(0,))


def _frame_words(meta: dict[str, Any]) -> str:
    from sportfusion.evaluate.truth import frame_label

    return frame_label(meta)


def evaluation_section(ctx: Context) -> tuple[str, str]:
    """(coach part, analyst part) of the evaluation: the RMS rows, and the mean/max rows folded."""
    ev = ctx.evaluation
    if ev is None or "phase" not in ev.column_names:
        return "", ""
    meta = ctx.evaluation_meta or {}
    if not meta.get("frame") and ctx.meta.get("frame"):
        meta = {**meta, "frame": ctx.meta["frame"]}
    coach = "<h2>Against the truth</h2><p>RMS error of the estimate against the reference (evaluate).</p>"
    coach += evaluation_table(ev, meta, "rms", ident="against-truth")
    analyst = (
        "<h3>Errors: mean and largest</h3>" + evaluation_table(ev, meta, "mean") + evaluation_table(ev, meta, "max")
    )
    return coach, analyst


def series_section(ctx: Context) -> tuple[str, str]:
    """(coach part, analyst part): position, velocity and attitude against time; the sensor biases."""
    from sportfusion.core.plots import series_figure

    thin = ctx.thin
    coach = "<h2>Time series</h2>" + figure(
        lambda: series_figure(thin, ctx.meta, panels=("position", "velocity", "attitude"))
    )
    analyst = ""
    if any(c in ctx.table.column_names for c in ("bias_gyr_x", "bias_acc_x")):
        analyst = "<h3>Estimated sensor biases</h3>" + figure(
            lambda: series_figure(thin, ctx.meta, panels=("gyro bias", "acc bias"), title="estimated sensor biases")
        )
    return coach, analyst


def session_report(
    table: pa.Table,
    meta: dict[str, Any],
    *,
    sport: str | None = None,
    title: str | None = None,
    jumps: pa.Table | None = None,
    evaluation: pa.Table | tuple[pa.Table, dict[str, Any]] | None = None,
    gates: pa.Table | None = None,
    holds: tuple[pa.Table, dict[str, Any]] | None = None,
) -> tuple[str, dict[str, Any]]:
    """The HTML page of one processed session and its headline figures.

    Parameters
    ----------
    table, meta : pyarrow.Table, dict
        A processed session (rts-smooth, spline-smooth/dmc-attitude, gate-anchor or pf-holds output).
    sport : str, optional
        One of :data:`SPORTS`; detected from the table when not given.
    title : str, optional
        Page title (default: the sport and the session's start time).
    jumps : pyarrow.Table, optional
        ``jump-metrics`` output (ski jump); computed from the session when not given.
    evaluation : pyarrow.Table or (table, metadata), optional
        ``evaluate`` output against a truth or reference: an RMS table is added (its metadata names the frame).
    gates, holds : optional
        The gate survey (gates) / the hold map and its metadata (climbing) for the venue figure.

    Returns
    -------
    page : str
        The whole HTML document (UTF-8 text, self-contained).
    figures : dict
        The headline figures as shown: label -> value text.
    """
    sport = sport or detect_sport(table, meta)
    if sport not in SPORTS:
        raise InputError(f"unknown sport {sport!r}; expected one of {', '.join(SPORTS)}")
    ev_table, ev_meta = evaluation if isinstance(evaluation, tuple) else (evaluation, {})
    ctx = Context(table, meta, jumps, ev_table, ev_meta or {}, gates, holds)
    parts = SPORT_SECTIONS[sport](ctx)
    series_coach, series_analyst = series_section(ctx)
    ev_coach, ev_analyst = evaluation_section(ctx)
    body = "<h2>Headline</h2>" + H.headline(parts.heads) + "".join(parts.coach)
    body += series_coach + certainty(table) + ev_coach
    analyst = series_analyst + "".join(parts.analyst) + ev_analyst + H.provenance(meta)
    body += H.folded("For the analyst: sensor biases, full errors, processing steps", analyst, "analyst")
    body += H.folded(
        "Reading the report: what each figure and word means",
        glossary_html() + "<p class='note'>The same text: docs/reading-the-report.md in sportfusion.</p>",
        "reading",
    )
    start = (meta.get("time") or {}).get("epoch_utc")
    start = f"{str(start)[:16].replace('T', ' ')} UTC" if start else "relative time (no clock)"
    page = H.page(
        title or f"{NAMES[sport]} session",
        f"{NAMES[sport]}; recording start {start}; {duration(table):.1f} s recorded",
        body,
        nav=(("Reading the report", "#reading"), ("For the analyst", "#analyst")),
    )
    return page, {label: value for label, value, _ in parts.heads}
