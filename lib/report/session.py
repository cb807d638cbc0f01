"""One processed session -> one self-contained HTML page for the coach: headline figures, the trajectory,
the time series that matter, how sure we are, and the provenance.

The sport is read from the table (a ski-jump hill in the metadata, the spline's ``speed``/``distance``,
the gate smoother's anchors, the climbing hold labels); each sport has its sections.  The figures on the
page are the numbers of the other tools: ``jump-metrics`` (computed here from the same library function
when no jumps table is given), ``gate-anchor``'s per-turn columns, ``pf-holds``' hold labels,
``evaluate``'s RMS rows.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.report import html as H

SPORTS = ("skijump", "skirace", "gates", "climbing")
#: figures get at most this many rows (every k-th row, events kept): the page stays small enough to mail
MAX_PLOT_ROWS = 600


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


def _col(table: pa.Table, name: str) -> np.ndarray | None:
    return schema.floats(table, name) if name in table.column_names else None


def _thin(table: pa.Table, max_rows: int = MAX_PLOT_ROWS) -> pa.Table:
    """Every k-th row and every event row: what a figure on a phone can show."""
    if table.num_rows <= max_rows:
        return table
    keep = np.zeros(table.num_rows, bool)
    keep[:: math.ceil(table.num_rows / max_rows)] = True
    keep[-1] = True
    if "event" in table.column_names:
        keep |= pc.is_valid(table.column("event")).to_numpy(zero_copy_only=False)
    return table.filter(pa.array(keep))


def _figure(make: Callable[[], Any], alt: str, caption: str) -> str:
    """Render a figure with the colour-blind-safe palette; a figure that cannot be drawn is said, not fatal."""
    try:
        import matplotlib as mpl
        from cycler import cycler
    except ImportError:  # pragma: no cover - the plot extra is part of the install
        return f"<p>(figure omitted: matplotlib is not installed) {H.esc(caption)}</p>"
    with mpl.rc_context(
        {"axes.prop_cycle": cycler(color=list(H.OKABE_ITO)), "svg.fonttype": "none", "path.simplify_threshold": 0.5}
    ):
        try:
            fig = make()
        except InputError as exc:
            return f"<p>(figure omitted: {H.esc(exc)})</p>"
        return H.svg_figure(fig, alt, caption)


def _duration(table: pa.Table) -> float:
    t = schema.floats(table, "t")
    return float(t[-1] - t[0]) if t.size else float("nan")


def _speed(table: pa.Table) -> np.ndarray | None:
    s = _col(table, "speed")
    if s is not None:
        return s
    v = [_col(table, f"v{a}") for a in "xyz"]
    return None if any(c is None for c in v) else np.linalg.norm(np.column_stack(v), axis=1)


def _std_rows(table: pa.Table, names: tuple[str, ...], unit: str) -> list[tuple[str, str, str]]:
    rows = []
    for n in names:
        s = _col(table, f"std_{n}")
        if s is not None and np.isfinite(s).any():
            rows.append((n, H.number(float(np.nanmedian(s)), unit, 3), H.number(float(np.nanmax(s)), unit, 3)))
    return rows


def _certainty(table: pa.Table) -> str:
    rows = _std_rows(table, ("x", "y", "z"), "m") + _std_rows(table, ("vx", "vy", "vz"), "m/s")
    rows += [(n, a.replace(" rad", ""), b) for n, a, b in _std_rows(table, ("roll", "pitch", "yaw"), "rad")]
    if not rows:
        return ""
    return "<h2>How sure we are</h2><p>The estimator's 1-sigma uncertainty over the session.</p>" + H.table(
        ["quantity", "median 1-sigma", "largest 1-sigma"], rows
    )


def _evaluation(evaluation: pa.Table | None) -> str:
    if evaluation is None or "phase" not in evaluation.column_names:
        return ""
    units = {"x": "m", "y": "m", "z": "m", "vel_n": "m/s", "vel_e": "m/s", "vel_d": "m/s"}
    units.update({a: "deg" for a in ("roll", "pitch", "yaw", "rot_angle")})
    rows = []
    for r in evaluation.to_pylist():
        if r.get("stat") != "rms":
            continue
        cells = [r["phase"]] + [H.number(r.get(c), u, 3) for c, u in units.items() if c in r]
        rows.append(cells)
    heads = ["phase"] + [c for c in units if c in evaluation.column_names]
    return "<h2>Against the truth</h2><p>RMS error of the estimate against the reference (evaluate).</p>" + H.table(
        heads, rows
    )


# --------------------------------------------------------------------------- per sport
def _skijump(table: pa.Table, meta: dict[str, Any], jumps: pa.Table | None) -> tuple[list, str]:
    from sportfusion.skijump.plots import profile_from_meta, speed_figure, track_figure

    if jumps is None:
        from sportfusion.skijump.hillfile import hill_from_meta
        from sportfusion.skijump.metrics import jump_metrics_table

        jumps, _, _ = jump_metrics_table(table, meta, hill_from_meta(meta))
    rows = jumps.to_pylist()
    heads = []
    if rows:
        j = max(rows, key=lambda r: r.get("jump_length") or -1.0)
        heads = [
            (f"Jump length (jump {j.get('jump', 1)})", H.number(j.get("jump_length"), "m"), "along the hill profile"),
            (
                "Take-off speed",
                H.number(j.get("takeoff_speed"), "m/s"),
                f"{3.6 * (j.get('takeoff_speed') or 0):.1f} km/h",
            ),
            ("Flight time", H.number(j.get("flight_time"), "s"), "take-off to touch-down"),
        ]
    else:
        heads = [("Jumps", "0", "no take-off / touch-down in this session")]
    body = H.table(
        ["jump", "take-off [s]", "take-off speed", "flight time", "jump length", "max height"],
        [
            (
                r.get("jump"),
                H.number(r.get("t_takeoff"), "", 2),
                H.speed(r.get("takeoff_speed")),
                H.number(r.get("flight_time"), "s"),
                H.number(r.get("jump_length"), "m"),
                H.number(r.get("max_height"), "m"),
            )
            for r in rows
        ],
        caption="Every jump of the session (jump-metrics)",
    )
    hill = (meta.get("hill") or {}).get("name") or (meta.get("hill") or {}).get("spec") or "the hill"
    thin = _thin(table)
    profile = profile_from_meta(meta)
    body += "<h2>Trajectory</h2>" + _figure(
        lambda: track_figure(thin, meta, profile),
        f"Side view of the jump over the profile of {hill}, coloured by speed",
        f"The estimated path over {hill}'s profile (hill frame, metres), coloured by speed.",
    )
    body += "<h2>Speed</h2>" + _figure(
        lambda: speed_figure(thin, meta, profile),
        "Speed against time with take-off and touch-down marked",
        "Speed [m/s] against time [s]; take-off and touch-down marked.",
    )
    return heads, body


def _skirace(table: pa.Table, meta: dict[str, Any]) -> tuple[list, str]:
    from sportfusion.skirace.plots import spline_figure

    s, d = _speed(table), _col(table, "distance")
    vmax = float(np.nanmax(s)) if s is not None and np.isfinite(s).any() else None
    dist = float(np.nanmax(d)) if d is not None and np.isfinite(d).any() else None
    dur = _duration(table)
    heads = [
        ("Run time", H.number(dur, "s", 1), "first to last sample"),
        ("Distance", H.number(dist, "m", 0), "along the smoothed path"),
        ("Max speed", H.number(vmax, "m/s"), f"{3.6 * (vmax or 0):.1f} km/h"),
        ("Mean speed", H.number(dist / dur if dist and dur else None, "m/s"), "distance / run time"),
    ]
    body = "<h2>Track</h2>" + _figure(
        lambda: spline_figure(_thin(table)),
        "The smoothed GNSS track and its speed, float periods shaded",
        "The smoothing spline against the raw GNSS fixes; periods without an RTK fix shaded.",
    )
    return heads, body


def _gates(table: pa.Table, meta: dict[str, Any], gates: pa.Table | None) -> tuple[list, str]:
    from sportfusion.gates.plots import gates_figure

    s = _speed(table)
    vmax = float(np.nanmax(s)) if s is not None and np.isfinite(s).any() else None
    ev = table.column("event").to_pylist() if "event" in table.column_names else []
    n_gates = sum(e == "gate" for e in ev)
    heads = [
        ("Run time", H.number(_duration(table), "s", 1), "first to last sample"),
        ("Gates passed", str(n_gates), "magnet crossings detected"),
        ("Max speed", H.number(vmax, "m/s"), f"{3.6 * (vmax or 0):.1f} km/h"),
    ]
    turns = []
    if "turn_length" in table.column_names:
        t = schema.floats(table, "t")
        for i, r in enumerate(
            table.select([c for c in table.column_names if c.startswith("turn_") or c == "gate"]).to_pylist()
        ):
            if r.get("turn_length") is not None:
                turns.append(
                    (
                        r.get("gate"),
                        H.number(float(t[i]), "s"),
                        H.speed(r.get("turn_v_in")),
                        H.speed(r.get("turn_v_out")),
                        H.number(r.get("turn_length"), "m"),
                    )
                )
    body = ""
    if turns:
        body += "<h2>Turns</h2>" + H.table(
            ["gate", "time", "speed in", "speed out", "path length"], turns, caption="Per turn (gate-anchor)"
        )
    if gates is not None:
        body += "<h2>Course</h2>" + _figure(
            lambda: gates_figure(_thin(table), gates),
            "The smoothed path through the surveyed gates, seen from above",
            "The path through the gates (course frame, metres); anchored gates marked.",
        )
    return heads, body


def _climbing(table: pa.Table, meta: dict[str, Any], holds: tuple[pa.Table, dict] | None) -> tuple[list, str]:
    from sportfusion.climbing.plots import holds_figure

    ids = table.column("hold_id").to_pylist()
    t = schema.floats(table, "t")
    seq: list[tuple[int, float]] = []
    for i, h in enumerate(ids):
        if h is not None and h >= 0 and (not seq or seq[-1][0] != h):
            seq.append((int(h), float(t[i])))
    prob = _col(table, "cluster_prob")
    heads = [
        ("Holds reached", str(len({h for h, _ in seq})), f"{len(seq)} grips on holds"),
        ("Climb time", H.number(_duration(table), "s", 1), "first to last sample"),
        (
            "Mean hold probability",
            H.number(float(np.nanmean(prob)) if prob is not None else None, "", 2),
            "particle filter",
        ),
    ]
    body = H.table(
        ["order", "hold", "reached at"],
        [(k + 1, h, H.number(tt, "s")) for k, (h, tt) in enumerate(seq)],
        caption="Holds in the order they were gripped (pf-holds)",
    )
    if holds is not None:
        body += "<h2>Path on the wall</h2>" + _figure(
            lambda: holds_figure(_thin(table), holds[0], holds[1]),
            "The hand's path over the wall's hold map",
            "The estimated hand path over the hold map (map frame, metres).",
        )
    return heads, body


def session_report(
    table: pa.Table,
    meta: dict[str, Any],
    *,
    sport: str | None = None,
    title: str | None = None,
    jumps: pa.Table | None = None,
    evaluation: pa.Table | None = None,
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
    evaluation : pyarrow.Table, optional
        ``evaluate`` output against a truth or reference: an RMS table is added.
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
    if sport == "skijump":
        heads, body = _skijump(table, meta, jumps)
    elif sport == "skirace":
        heads, body = _skirace(table, meta)
    elif sport == "gates":
        heads, body = _gates(table, meta, gates)
    else:
        heads, body = _climbing(table, meta, holds)
    from sportfusion.core.plots import series_figure

    body = "<h2>Headline</h2>" + H.headline(heads) + body
    body += "<h2>Time series</h2>" + _figure(
        lambda: series_figure(_thin(table), meta),
        "Position, velocity and attitude estimates against time with their uncertainty bands",
        "Estimates against time with ±1-sigma bands; events marked.",
    )
    body += _certainty(table) + _evaluation(evaluation) + H.provenance(meta)
    start = (meta.get("time") or {}).get("epoch_utc")
    start = f"{str(start)[:16].replace('T', ' ')} UTC" if start else "relative time (no clock)"
    names = {
        "skijump": "Ski jump",
        "skirace": "Ski race",
        "gates": "Ski race with magnet gates",
        "climbing": "Climbing",
    }
    page = H.page(title or f"{names[sport]} session", f"{names[sport]}; recording start {start}", body)
    return page, {label: value for label, value, _ in heads}
