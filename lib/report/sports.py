"""Each sport's part of a session page (:mod:`sportfusion.report.session`): its headline figures, its table
and its figures.  A function per sport takes the page's :class:`~sportfusion.report.session.Context` and
returns :class:`~sportfusion.report.session.Sections`; :data:`SPORT_SECTIONS` maps the sport to it.  To add
a figure to every sport (say, the centre of mass), append to the returned sections in one place.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.report import html as H
from sportfusion.report.parts import Context, Sections, col, duration, figure, moving_heads, speed_of


# --------------------------------------------------------------------------- ski jump
def skijump(ctx: Context) -> Sections:
    """Jump length, take-off speed, flight time and max height of every jump (jump-metrics); the trajectory
    coloured by speed with the flight zoomed; side and top view over the profile; the magnetometer
    (analyst)."""
    from sportfusion.skijump.plots import mag_figure, profile_from_meta, speed_figure, track_figure

    jumps = ctx.jumps
    if jumps is None:
        from sportfusion.skijump.hillfile import hill_from_meta
        from sportfusion.skijump.metrics import jump_metrics_table

        jumps, _, _ = jump_metrics_table(ctx.table, ctx.meta, hill_from_meta(ctx.meta))
    rows = jumps.to_pylist()
    out = Sections()
    if rows:
        j = max(rows, key=lambda r: r.get("jump_length") or -1.0)
        out.heads = [
            (
                f"Jump length (jump {j.get('jump', 1)})",
                H.number(j.get("jump_length"), "m"),
                "along the landing profile",
            ),
            ("Take-off speed", H.number(j.get("takeoff_speed"), "m/s"), H.kmh(j.get("takeoff_speed"))),
            ("Flight time", H.number(j.get("flight_time"), "s"), "take-off to touch-down"),
            ("Max height", H.number(j.get("max_height"), "m"), "above the landing slope"),
        ]
    else:
        out.heads = [("Jumps", "0", "no take-off / touch-down in this session")]
    out.coach.append(
        "<h2>Jumps</h2>"
        + H.table(
            ["jump", "take-off at", "take-off speed", "in km/h", "flight time", "jump length", "max height"],
            [
                (
                    f"jump {r.get('jump')}",
                    H.number(r.get("t_takeoff"), "s"),
                    H.number(r.get("takeoff_speed"), "m/s"),
                    H.kmh(r.get("takeoff_speed")),
                    H.number(r.get("flight_time"), "s"),
                    H.number(r.get("jump_length"), "m"),
                    H.number(r.get("max_height"), "m"),
                )
                for r in rows
            ],
            caption="Every jump of the session (jump-metrics); take-off at: time on the session's clock",
            cards=True,
            ident="jumps",
        )
    )
    profile = profile_from_meta(ctx.meta)
    thin = ctx.thin
    out.coach.append("<h2>Trajectory</h2>" + figure(lambda: speed_figure(thin, ctx.meta, profile)))
    out.coach.append("<h2>Side and top view</h2>" + figure(lambda: track_figure(thin, ctx.meta, profile)))
    if all(f"mag_pred_{a}" in ctx.table.column_names for a in "xyz"):
        out.analyst.append("<h3>Magnetometer: measured and predicted</h3>" + figure(lambda: mag_figure(thin)))
    return out


# --------------------------------------------------------------------------- ski racing, GNSS
def skirace(ctx: Context) -> Sections:
    """Moving time, distance, max and moving mean speed; the spline against the raw GNSS."""
    from sportfusion.skirace.plots import spline_figure

    d = col(ctx.table, "distance")
    dist = float(np.nanmax(d)) if d is not None and np.isfinite(d).any() else None
    out = Sections(heads=moving_heads(ctx.table, dist))
    thin = ctx.thin
    out.coach.append("<h2>Track</h2>" + figure(lambda: spline_figure(thin)))
    return out


# --------------------------------------------------------------------------- ski racing, magnet gates
def gate_crossings(table: pa.Table) -> list[tuple[float, int]]:
    """(t [s], matched gate number or -1) of every detected crossing, in time order."""
    if "event" not in table.column_names:
        return []
    t = schema.floats(table, "t")
    ev = table.column("event").to_pylist()
    gate = table.column("gate").to_pylist() if "gate" in table.column_names else [None] * len(ev)
    return [(float(t[i]), -1 if gate[i] is None else int(gate[i])) for i, e in enumerate(ev) if e == "gate"]


def turn_rows(table: pa.Table, surveyed: list[int]) -> list[tuple[Any, ...]]:
    """One row per surveyed gate (and per unmatched crossing): the turn's figures (gate-anchor's turn_*
    columns) or why there are none -- the rules of ``sportfusion.gates.turns.turn_figures``: a turn needs
    a matched crossing with a crossing before and after it and a turn switch in each interval."""
    t = schema.floats(table, "t")
    cross = gate_crossings(table)
    figs: dict[int, dict[str, Any]] = {}
    if "turn_length" in table.column_names and "event" in table.column_names:
        names = [c for c in ("gate", "turn_v_in", "turn_v_out", "turn_length") if c in table.column_names]
        for i, r in enumerate(table.select([*names, "event"]).to_pylist()):
            if r["event"] == "gate" and r.get("turn_length") is not None and r.get("gate") is not None:
                figs[int(r["gate"])] = {**r, "t": float(t[i])}
    at = {g: k for k, (_, g) in enumerate(cross) if g >= 0}
    rows = []
    for g in surveyed:
        if g in figs:
            f = figs[g]
            rows.append(
                (
                    f"gate {g}",
                    H.number(f["t"], "s"),
                    H.speed(f.get("turn_v_in")),
                    H.speed(f.get("turn_v_out")),
                    H.number(f.get("turn_length"), "m"),
                    "",
                )
            )
            continue
        if g not in at:
            why = "not detected: no magnet crossing was matched to this gate"
            rows.append((f"gate {g}", "–", "–", "–", "–", why))
            continue
        k = at[g]
        if k == 0:
            why = "first crossing: no turn switch before it"
        elif k == len(cross) - 1:
            why = "last crossing: no turn switch after it"
        else:
            odd = [f"{cross[j][0]:.2f} s" for j in (k - 1, k + 1) if cross[j][1] < 0]
            why = "no change of turn direction between this crossing and a neighbouring one" + (
                f" (the crossing at {', '.join(odd)} matched no gate)" if odd else ""
            )
        rows.append((f"gate {g}", H.number(cross[k][0], "s"), "–", "–", "–", why))
    for tc, g in cross:
        if g < 0:
            rows.append(("unmatched", H.number(tc, "s"), "–", "–", "–", "a crossing that matched no surveyed gate"))
    return rows


def gates(ctx: Context) -> Sections:
    """Moving time, gates matched (of the survey), speeds; per gate its turn or why it has none; the course."""
    from sportfusion.gates.plots import gates_figure

    cross = gate_crossings(ctx.table)
    matched = sorted({g for _, g in cross if g >= 0})
    if ctx.gates is not None and "gate" in ctx.gates.column_names:
        from sportfusion.core.io import survey_points

        magnets, _ = survey_points(ctx.gates)
        surveyed = sorted({int(v) for v in magnets.column("gate").to_pylist() if v is not None})
    else:
        surveyed = matched
    heads = moving_heads(ctx.table)
    heads.insert(
        1,
        (
            "Gates matched",
            f"{len(matched)} of {len(surveyed)}",
            f"{len(cross)} crossings detected, {len(matched)} matched to the survey",
        ),
    )
    out = Sections(heads=heads)
    rows = turn_rows(ctx.table, surveyed)
    if rows:
        out.coach.append(
            "<h2>Turns</h2>"
            + H.table(
                ["gate", "crossing at", "speed in", "speed out", "path length", "why no turn"],
                rows,
                caption="Per gate (gate-anchor): speeds at the turn switches before and after it, the path between",
                cards=True,
                ident="turns",
                text_columns=(5,),
            )
        )
    if ctx.gates is not None:
        thin = ctx.thin
        out.coach.append("<h2>Course</h2>" + figure(lambda: gates_figure(thin, ctx.gates)))
    if "com_x" in ctx.table.column_names:  # a body (body-model): the paper's own output, the centre of mass
        com = centre_of_mass(ctx)
        out.heads += com.heads
        out.coach += com.coach
        out.analyst += com.analyst
    return out


def com_height(table: pa.Table) -> np.ndarray | None:
    """Height [m] of the centre of mass above the ski line (the mean of the two ski contact points) per row:
    body-model's points relative to the LJC in its frame J, whose z is down."""
    need = ["com_rel_z", "ski_r_rel_z", "ski_l_rel_z"]
    if not all(c in table.column_names for c in need):
        return None
    z = {c: schema.floats(table, c) for c in need}
    return 0.5 * (z["ski_r_rel_z"] + z["ski_l_rel_z"]) - z["com_rel_z"]


def centre_of_mass(ctx: Context) -> Sections:
    """The centre of mass of a session with a body (gates paper, Figs 3-5, Table 2): how low (the CoM's height
    above the skis at each crossing), how long the line (the CoM path from the first to the last matched gate),
    where the mass was at each gate (the distances of Table 2); the postures at the gates and one turn from
    above; with an evaluation, its CoM figures beside the paper's (analyst)."""
    from sportfusion.gates.plots import body_figure

    table, out = ctx.table, Sections()
    t = schema.floats(table, "t")
    com = schema.float_columns(table, ["com_x", "com_y", "com_z"])
    height = com_height(table)
    turns = (ctx.meta.get("gate_anchor") or {}).get("turns") or []
    cross = [(tc, g) for tc, g in gate_crossings(table) if g >= 0]
    if len(cross) >= 2:
        w = (t >= cross[0][0]) & (t <= cross[-1][0]) & np.isfinite(com).all(axis=1)
        line = float(np.sum(np.linalg.norm(np.diff(com[w], axis=0), axis=1)))
        out.heads.append(
            ("CoM line", H.number(line, "m", 1), f"path of the centre of mass, gate {cross[0][1]} to {cross[-1][1]}")
        )
    if height is not None and cross:
        at = np.interp([tc for tc, _ in cross], t[np.isfinite(height)], height[np.isfinite(height)])
        k = int(np.argmin(at))
        out.heads.append(("Lowest CoM at a gate", H.number(float(at[k]), "m"), f"above the skis, gate {cross[k][1]}"))
    by_gate = {int(tr["gate"]): tr for tr in turns}
    rows = []
    for tc, g in cross:
        tr = by_gate.get(g, {})
        h = None if height is None else float(np.interp(tc, t[np.isfinite(height)], height[np.isfinite(height)]))
        rows.append(
            (
                f"gate {g}",
                H.number(h, "m"),
                H.number(tr.get("d_cross"), "m"),
                H.number(tr.get("d_in"), "m"),
                H.number(tr.get("d_out"), "m"),
                H.number(tr.get("length"), "m"),
            )
        )
    if rows:
        out.coach.append(
            "<h2>Centre of mass at the gates</h2>"
            + H.table(
                ["gate", "CoM height", "CoM to gate", "from switch in", "to switch out", "turn length"],
                rows,
                caption="Per matched gate: the CoM's height above the skis and its distance to the gate's magnet at "
                "the crossing, its distances to the magnet at the turn switches (equal left/right ankle distance to "
                "the CoM) and its path from switch to switch (gates paper, Table 2)",
                cards=True,
                ident="com",
            )
        )
    thin = ctx.thin
    out.coach.append(
        "<h2>Posture at the gates</h2>" + figure(lambda: body_figure(thin, ctx.meta, ctx.gates, max_postures=6))
    )
    res = (ctx.evaluation_meta.get("evaluation") or {}).get("com") if ctx.evaluation_meta else None
    if res:
        from sportfusion.evaluate.com import format_com

        out.analyst.append("<h3>Centre of mass against the truth</h3><pre>" + H.esc(format_com(res)) + "</pre>")
    return out


# --------------------------------------------------------------------------- climbing
def hold_sequence(table: pa.Table) -> list[tuple[int, float]]:
    """(hold, t [s]) of every grip on a hold, in order (pf-holds' hold_id; a hold held on is one grip)."""
    ids = table.column("hold_id").to_pylist()
    t = schema.floats(table, "t")
    seq: list[tuple[int, float]] = []
    for i, h in enumerate(ids):
        if h is not None and h >= 0 and (not seq or seq[-1][0] != h):
            seq.append((int(h), float(t[i])))
    return seq


def hold_certainty(table: pa.Table) -> float | None:
    """Mean over the grip rows of the probability of the most likely hold (pf-holds' cluster_prob)."""
    prob = col(table, "cluster_prob")
    if prob is None:
        return None
    on = np.array([h is not None for h in table.column("hold_id").to_pylist()], bool)
    v = prob[on & np.isfinite(prob)]
    return float(v.mean()) if v.size else None


def _percent(p: float | None) -> str:
    return "–" if p is None or not np.isfinite(p) else f"{100.0 * p:.0f} %"


def climbing(ctx: Context) -> Sections:
    """Holds reached, grips, climb time, hold certainty; the holds in order; the hand's path on the wall."""
    from sportfusion.climbing.plots import holds_figure

    seq = hold_sequence(ctx.table)
    heads = [
        ("Holds reached", str(len({h for h, _ in seq})), "different holds gripped"),
        ("Grips on holds", str(len(seq)), "in the order of the table below"),
        ("Climb time", H.number(duration(ctx.table), "s", 1), "first to last sample"),
        ("Hold certainty", _percent(hold_certainty(ctx.table)), "mean probability of the chosen hold at the grips"),
    ]
    out = Sections(heads=heads)
    out.coach.append(
        "<h2>Holds</h2>"
        + H.table(
            ["order", "hold", "reached at"],
            [(k + 1, h, H.number(tt, "s")) for k, (h, tt) in enumerate(seq)],
            caption="Holds in the order they were gripped (pf-holds); reached at: time on the session's clock",
            ident="holds",
        )
    )
    if ctx.holds is not None:
        thin = ctx.thin
        hold_table, hold_meta = ctx.holds
        out.coach.append("<h2>Path on the wall</h2>" + figure(lambda: holds_figure(thin, hold_table, hold_meta)))
    return out


SPORT_SECTIONS: dict[str, Callable[[Context], Sections]] = {
    "skijump": skijump,
    "skirace": skirace,
    "gates": gates,
    "climbing": climbing,
}

__all__ = [
    "SPORT_SECTIONS",
    "centre_of_mass",
    "com_height",
    "gate_crossings",
    "hold_certainty",
    "hold_sequence",
    "turn_rows",
    "speed_of",
]
