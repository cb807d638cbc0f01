"""Magnet-gate figures: the course (the smoothed path over the surveyed gates, crossings numbered) and the body at
the gates (postures at the crossings seen from behind, one turn's CoM path beside the sacrum's)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pyarrow as pa

from sportfusion.core.errors import InputError
from sportfusion.core.plots import _col, _new_figure, legend_outside, place_labels, stretch_factor

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def gates_figure(table: pa.Table, gates: pa.Table, title: str = "", width: float = 9.0) -> Figure:
    """Top view of an alpine course: surveyed gates (numbered, labels placed clear of each other and of the
    path), the trajectory, and the gate crossings (anchors) joined to the gate they were matched to; the
    across-slope axis is stretched by the factor on its label when the course is long and thin.

    Parameters
    ----------
    table : pyarrow.Table
        A session with a trajectory ``x y`` [m] (``gate-anchor`` output) and crossing rows
        (``event == "gate"``, matched ``gate`` id when known).
    gates : pyarrow.Table
        The survey (kind ``gates``: ``gate x y z`` [m], same local frame); rows with ``point`` start/finish
        (surveyed static spots) are drawn as squares.
    """
    x, y = _col(table, "x"), _col(table, "y")
    if x is None or y is None:
        raise InputError("missing columns: plot gates needs a trajectory x, y [m]; run gate-anchor first")
    if not all(n in gates.column_names for n in ("gate", "x", "y")):
        raise InputError("the gates table needs gate, x, y [m] columns (local frame)")
    from sportfusion.core.io import survey_points

    gates, spots = survey_points(gates)
    gid = np.asarray(gates.column("gate").to_numpy(zero_copy_only=False))
    gxy = np.column_stack([_col(gates, "x"), _col(gates, "y")])
    fig = _new_figure(width, 10.0)
    ax = fig.add_subplot()
    m = np.isfinite(x) & np.isfinite(y)
    # plan view with the fall line (x) downwards on the page
    ax.plot(y[m], x[m], "-", lw=1.0, color="tab:blue", label="trajectory")
    ax.plot(gxy[:, 1], gxy[:, 0], "^", ms=7, color="tab:red", label="surveyed gate (magnet), numbered")
    if spots is not None:
        ax.plot(
            _col(spots, "y"), _col(spots, "x"), "s", ms=7, mfc="none", color="tab:orange", label="surveyed static spot"
        )
    avoid = [np.column_stack([y[m], x[m]])]
    if "event" in table.column_names:
        ev = np.array([e == "gate" for e in table.column("event").to_pylist()])
        matched = (
            np.asarray(table.column("gate").to_numpy(zero_copy_only=False), float)
            if "gate" in table.column_names
            else np.full(table.num_rows, np.nan)
        )
        lookup = {int(g): p for g, p in zip(gid, gxy, strict=True)}
        hit = ev & np.array([np.isfinite(v) and int(v) in lookup for v in matched])
        ax.plot(y[hit], x[hit], "o", ms=4, mfc="none", color="k", label="detected crossing, matched")
        for k, i in enumerate(np.flatnonzero(hit)):
            p = lookup[int(matched[i])]
            ax.plot([y[i], p[1]], [x[i], p[0]], "-", lw=0.9, color="tab:green", label="match" if k == 0 else None)
        miss = ev & ~hit
        if miss.any():
            ax.plot(
                y[miss], x[miss], "x", ms=6, mew=1.5, color="tab:purple", label="detected crossing, no gate matched"
            )
        avoid.append(np.column_stack([y[ev], x[ev]]))
    # a course is long and thin: stretch the across-slope axis by a stated factor
    f = stretch_factor(float(np.ptp(x[m])), float(np.ptp(np.r_[y[m], gxy[:, 1]]))) if m.any() else 1
    ax.invert_yaxis()
    ax.set_aspect(1.0 / f, adjustable="datalim")
    ax.set_xlabel(f"y (right of the fall line) [m], stretched ×{f}" if f > 1 else "y (right of the fall line) [m]")
    ax.set_ylabel("x (down the fall line) [m]")
    ax.grid(True, lw=0.4, alpha=0.6)
    legend_outside(ax)
    ax.set_title(title or "course: gates, crossings and trajectory (plan view)")
    place_labels(ax, gxy[:, ::-1], [f"{g}" for g in gid], avoid=np.vstack(avoid), colours=["tab:red"] * len(gid))
    return fig


#: Stick figure of the body seen from behind: point chains drawn as lines (names of ``body-model``'s columns).
_CHAINS = (
    ("ski_l", "ankle_l", "knee_l", "hip_l", "ljc", "hip_r", "knee_r", "ankle_r", "ski_r"),
    ("ljc", "sternum", "head"),
)
_POINTS = ("hip_r", "hip_l", "knee_r", "knee_l", "ankle_r", "ankle_l", "ski_r", "ski_l", "sternum", "head")


def _rz(v: np.ndarray, alpha: float) -> np.ndarray:
    c, s = np.cos(alpha), np.sin(alpha)
    out = v.copy()
    out[..., 0] = c * v[..., 0] - s * v[..., 1]
    out[..., 1] = s * v[..., 0] + c * v[..., 1]
    return out


def body_crossings(table: pa.Table, meta: dict, gates: pa.Table | None = None) -> list[dict]:
    """The body at each matched gate crossing, in the survey frame [m]: the named points of ``body-model``
    (rotated from its frame J by the matching's azimuth), the LJC, the CoM and its horizontal direction of
    travel, and the gate's magnet where known (``gates`` survey, else the turn figures' ``gate_xyz``).

    The points hang from the absolute CoM (``com_x..``): ``p = com + Rz(alpha) (p_rel - com_rel)``.
    """
    need = ["com_x", "com_y", "com_z", "com_vx", "com_vy", "com_rel_x"] + [f"{p}_rel_x" for p in _POINTS]
    missing = [c for c in need if c not in table.column_names]
    if missing:
        raise InputError(
            f"missing columns {', '.join(missing[:4])}{' ...' if len(missing) > 4 else ''}: plot body needs "
            "gate-anchor's output of a session with body-model's columns"
        )
    from sportfusion.core import schema

    t = schema.floats(table, "t")
    com = schema.float_columns(table, ["com_x", "com_y", "com_z"])
    vel = schema.float_columns(table, ["com_vx", "com_vy"])
    rel = {p: schema.float_columns(table, [f"{p}_rel_{a}" for a in "xyz"]) for p in (*_POINTS, "com")}
    alpha = np.deg2rad(float((meta.get("gate_anchor") or {}).get("alpha_deg", 0.0)))
    magnets: dict[int, np.ndarray] = {}
    for tr in (meta.get("gate_anchor") or {}).get("turns") or []:
        if "gate_xyz" in tr:
            magnets[int(tr["gate"])] = np.asarray(tr["gate_xyz"], float)
    if gates is not None and all(c in gates.column_names for c in ("gate", "x", "y", "z")):
        from sportfusion.core.io import survey_points

        g, _ = survey_points(gates)
        for k, xyz in zip(
            np.asarray(g.column("gate").to_numpy(zero_copy_only=False), int),
            schema.float_columns(g, ["x", "y", "z"]),
            strict=True,
        ):
            magnets[int(k)] = xyz
    if "event" not in table.column_names or "gate" not in table.column_names:
        raise InputError("no gate crossings (event 'gate' with a matched 'gate'): run detect-events and gate-anchor")
    ev = table.column("event").to_pylist()
    gate = table.column("gate").to_pylist()
    out = []
    for i, (e, g) in enumerate(zip(ev, gate, strict=True)):
        if e != "gate" or g is None or g < 0:
            continue
        if not (np.isfinite(com[i]).all() and np.isfinite(rel["com"][i]).all()):
            continue
        pts = {p: com[i] + _rz(rel[p][i] - rel["com"][i], alpha) for p in _POINTS}
        pts["ljc"] = com[i] - _rz(rel["com"][i], alpha)
        pts["com"] = com[i]
        h = vel[i] / max(float(np.hypot(*vel[i])), 1e-9)
        out.append({"t": float(t[i]), "gate": int(g), "points": pts, "forward": h, "magnet": magnets.get(int(g))})
    if not out:
        raise InputError("no matched gate crossing with a CoM: run gate-anchor on a session with body-model's columns")
    return out


def _behind(c: dict, p: np.ndarray) -> tuple[float, float]:
    """A point seen from behind the athlete at crossing ``c``: (right of travel, up) from the LJC [m]."""
    d = p - c["points"]["ljc"]
    f = c["forward"]
    return float(-f[1] * d[0] + f[0] * d[1]), float(-d[2])


def body_figure(
    table: pa.Table, meta: dict, gates: pa.Table | None = None, gate: int | None = None, title: str = "",
    width: float = 10.0, max_postures: int = 12,
) -> Figure:  # fmt: skip
    """The body at the gates (gates paper Figs 3 and 5): the posture at each matched crossing seen from
    behind (joint centres, ski contact points, CoM and the magnet, right of travel and up from the LJC [m]; at
    most ``max_postures``, evenly spread), and one turn in plan view (``gate``, default the middle one with
    turn figures): the CoM path beside the sacrum's and the ski line, the turn switches and the distances
    d_in, d_out from them to the gate.
    """
    cr = body_crossings(table, meta, gates)
    if len(cr) > max_postures:
        keep = np.unique(np.round(np.linspace(0, len(cr) - 1, max_postures)).astype(int))
        shown = [cr[k] for k in keep]
    else:
        shown = cr
    from sportfusion.core.plotlayout import fs, layout

    narrow = layout().width is not None and layout().width < 8.0
    width = min(width, layout().width or width)
    nrow = int(np.ceil(len(shown) / (3 if narrow else 6)))
    ncol = int(np.ceil(len(shown) / nrow))
    uv_all = np.array(
        [
            _behind(c, p)
            for c in shown
            for p in [*c["points"].values()] + ([c["magnet"]] if c["magnet"] is not None else [])
        ]
    )
    lo, hi = uv_all.min(axis=0) - 0.1, uv_all.max(axis=0) + 0.1
    row_h = (width / ncol) * (hi[1] - lo[1]) / (hi[0] - lo[0]) + 0.45
    plan_h = 4.2 if narrow else 3.6
    fig = _new_figure(width, row_h * nrow + 1.0 + plan_h)
    gs = fig.add_gridspec(nrow + 1, ncol, height_ratios=[row_h] * nrow + [plan_h])
    axs = [fig.add_subplot(gs[i // ncol, i % ncol]) for i in range(len(shown))]
    for i, (ax, c) in enumerate(zip(axs, shown, strict=True)):
        for chain in _CHAINS:
            uv = np.array([_behind(c, c["points"][p]) for p in chain])
            ax.plot(uv[:, 0], uv[:, 1], "-o", lw=1.6, ms=2.5, color="0.3")
        sk = np.array([_behind(c, c["points"][p]) for p in ("ski_l", "ski_r")])
        ax.plot(sk[:, 0], sk[:, 1], "-", lw=3, color="tab:cyan", alpha=0.6)
        cu = _behind(c, c["points"]["com"])
        ax.plot(*cu, "o", ms=7, mfc="gold", mec="k", zorder=5)
        txt = f"gate {c['gate']}"
        if c["magnet"] is not None:
            mu = _behind(c, c["magnet"])
            ax.plot(*mu, "^", ms=7, color="tab:red", zorder=5)
            ax.plot([cu[0], mu[0]], [cu[1], mu[1]], ":", lw=0.8, color="tab:red")
            txt += f": {np.linalg.norm(c['points']['com'] - c['magnet']):.2f} m"
        ax.set_title(txt, fontsize=fs(8))
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal", adjustable="box")
        ax.grid(True, lw=0.3, alpha=0.5)
        ax.tick_params(labelsize=fs(7))
        if i // ncol == nrow - 1 or i + ncol >= len(shown):
            ax.set_xlabel("right of travel [m]", fontsize=fs(8))
        else:
            ax.tick_params(labelbottom=False)
        if i % ncol == 0:
            ax.set_ylabel("up from the LJC [m]", fontsize=fs(8))
        else:
            ax.tick_params(labelleft=False)
    from matplotlib.lines import Line2D

    handles = [
        Line2D([], [], color="0.3", marker="o", ms=3, label="joint centres (LJC, hips, knees, ankles, sternum, head)"),
        Line2D([], [], color="tab:cyan", lw=3, alpha=0.6, label="ski contact points"),
        Line2D([], [], ls="", marker="o", ms=7, mfc="gold", mec="k", label="centre of mass"),
        Line2D([], [], ls="", marker="^", ms=7, color="tab:red", label="gate magnet"),
    ]
    fig.legend(
        handles=handles,
        loc="outside upper center",
        ncol=2 if narrow else 4,
        fontsize=fs(8),
        title=f"posture at the gate crossings, seen from behind ({len(shown)} of {len(cr)} crossings); "
        "in each title the gate and the CoM's distance to its magnet",
        title_fontsize=fs(9),
    )
    _turn_plan(fig.add_subplot(gs[nrow, :]), table, meta, cr, gate)
    if title:
        fig.suptitle(title)
    return fig


def _turn_plan(ax, table: pa.Table, meta: dict, cr: list[dict], gate: int | None) -> None:  # noqa: ANN001
    from sportfusion.core import schema
    from sportfusion.core.plotlayout import fs

    turns = [tr for tr in (meta.get("gate_anchor") or {}).get("turns") or [] if "gate_xyz" in tr]
    if gate is not None:
        turns = [tr for tr in turns if int(tr["gate"]) == gate]
        if not turns:
            raise InputError(
                f"--gate {gate}: no turn figures for that gate (matched, with a crossing before and after)"
            )
    if not turns:
        ax.set_axis_off()
        ax.set_title("no turn with figures (needs a matched crossing before and after)", fontsize=9)
        return
    tr = turns[len(turns) // 2]
    t = schema.floats(table, "t")
    pad = 0.15 * (tr["t_out"] - tr["t_in"])
    w = (t >= tr["t_in"] - pad) & (t <= tr["t_out"] + pad)
    com = schema.float_columns(table, ["com_x", "com_y"])
    sac = schema.float_columns(table, ["x", "y"])
    alpha = np.deg2rad(float((meta.get("gate_anchor") or {}).get("alpha_deg", 0.0)))
    ski = 0.5 * (
        schema.float_columns(table, ["ski_r_rel_x", "ski_r_rel_y", "ski_r_rel_z"])
        + schema.float_columns(table, ["ski_l_rel_x", "ski_l_rel_y", "ski_l_rel_z"])
    ) - schema.float_columns(table, ["com_rel_x", "com_rel_y", "com_rel_z"])
    skixy = com + _rz(ski, alpha)[:, :2]
    g = np.asarray(tr["gate_xyz"], float)
    ax.plot(sac[w, 0], sac[w, 1], "-", lw=1.2, color="tab:blue", label="sacrum (x, y)")
    ax.plot(com[w, 0], com[w, 1], "-", lw=1.8, color="goldenrod", label="centre of mass (com_x, com_y)")
    ax.plot(skixy[w, 0], skixy[w, 1], "-", lw=0.8, color="tab:cyan", label="ski line (mean contact point)")
    ax.plot(g[0], g[1], "^", ms=9, color="tab:red", label=f"gate {tr['gate']} magnet")
    for key, dkey, mk in (("t_in", "d_in", "s"), ("t_out", "d_out", "D")):
        p = np.array([np.interp(tr[key], t, com[:, j]) for j in range(2)])
        ax.plot(*p, mk, ms=7, mfc="none", mec="k", label=f"turn switch ({key[2:]})")
        ax.plot([p[0], g[0]], [p[1], g[1]], "--", lw=0.8, color="0.4")
        ax.annotate(f"{dkey} {tr[dkey]:.2f} m", 0.5 * (p + g[:2]), fontsize=fs(8), color="0.3")
    ax.invert_yaxis()  # y to the right of the fall line, seen from above with x down the page's width
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (down the fall line) [m]")
    ax.set_ylabel("y (right of the fall line) [m]")
    ax.grid(True, lw=0.4, alpha=0.6)
    legend_outside(ax)
    ax.set_title(
        f"turn at gate {tr['gate']} seen from above: length {tr['length']:.2f} m, v_in {tr['v_in']:.2f} m/s, "
        f"v_out {tr['v_out']:.2f} m/s, CoM-magnet at the crossing {tr['d_cross']:.2f} m",
        fontsize=fs(9),
    )
