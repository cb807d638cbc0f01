"""Estimate versus truth: error statistics in the layout of the ski-jumping paper's Table 6.

Errors are estimate minus truth (skijump eqs 52-53, 57):

* position ``x y z`` in the session's local (hill) frame [m];
* velocity in NED ``vel_n vel_e vel_d`` [m/s] (the paper's ``v_O``): the
  estimate's ``vx vy vz`` are in the local frame and are rotated by the frame
  azimuth of the metadata;
* Euler angles ``roll pitch yaw`` (z-y-x, eqs 54-56) [rad], wrapped to
  (-pi, pi];
* ``rot_angle``: the rotation angle between the estimated and the true
  attitude quaternion [rad], free of the Euler singularity at pitch +-90 deg.

Statistics per variable: RMS, mean and maximum absolute error, overall and per
phase.  The phases come from the truth's events: ``inrun`` up to and including
the take-off instant (``t <= t_TO``, as the paper's in-run constraint),
``flight`` strictly between take-off and touch-down, ``outrun`` from the
touch-down on.  In a session of several jumps the time between a touch-down
and the next take-off is split at its midpoint (out-run, then in-run).

Event timing errors pair every true ``takeoff``/``touchdown`` with the nearest
estimated event of the same name within ``max_event_dt``; the jump-length error
is reported when both sides carry a jump length (metadata key ``jump_length``,
or a ``jump_length`` column).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import rotations, schema
from sportfusion.core.errors import InputError

#: Error variables in Table 6 order: (column, unit, label for text output).
VARIABLES: tuple[tuple[str, str, str], ...] = (
    ("x", "m", "dx [m]"),
    ("y", "m", "dy [m]"),
    ("z", "m", "dz [m]"),
    ("vel_n", "m/s", "dv_n [m/s]"),
    ("vel_e", "m/s", "dv_e [m/s]"),
    ("vel_d", "m/s", "dv_d [m/s]"),
    ("roll", "rad", "droll [deg]"),
    ("pitch", "rad", "dpitch [deg]"),
    ("yaw", "rad", "dyaw [deg]"),
    ("rot_angle", "rad", "angle [deg]"),
)


ANGLES = ("roll", "pitch", "yaw", "rot_angle")


PHASES = ("all", "inrun", "flight", "outrun")


STATS = ("rms", "mean", "max")


EVENT_NAMES = ("takeoff", "touchdown")


@dataclass
class Evaluation:
    """Result of :func:`evaluate`.

    Attributes
    ----------
    stats : dict
        ``stats[phase][stat][variable]`` -> float (NaN where no sample),
        ``stats[phase]["n"]`` -> rows of that phase where the estimate has a value.
    jumps : list of dict
        Per true jump: ``takeoff``/``touchdown`` true times [s], their timing
        errors ``takeoff_dt``/``touchdown_dt`` [s] (NaN when missed) and
        ``jump_length_error`` [m] (NaN when a side has no length).
    false_events : dict
        Estimated take-off/touch-down events matched to no true event, per name.
    variables : list of str
        The variables the estimate provided.
    phases : tuple of str
        The phases reported: all four of :data:`PHASES` when the truth has a take-off, else only
        ``all`` (a ski race or a climbing trial has no in-run, flight or out-run).
    """

    stats: dict[str, dict[str, Any]]
    jumps: list[dict[str, float]] = field(default_factory=list)
    false_events: dict[str, int] = field(default_factory=dict)
    variables: list[str] = field(default_factory=list)
    phases: tuple[str, ...] = PHASES


def _wrap(a: np.ndarray) -> np.ndarray:
    """Angles [rad] wrapped to (-pi, pi]."""
    return -((-a + np.pi) % (2 * np.pi) - np.pi)


def _col(table: pa.Table, name: str) -> np.ndarray | None:
    return schema.floats(table, name) if name in table.column_names else None


def _azimuth(meta: dict[str, Any]) -> float | None:
    frame = meta.get("frame")
    return None if not frame else float(frame["azimuth_deg"])


def _check_frames(est_meta: dict[str, Any], truth_meta: dict[str, Any]) -> float:
    """The frame azimuth [deg] both sides agree on (0 when neither declares a frame)."""
    fe, ft = est_meta.get("frame"), truth_meta.get("frame")
    if fe and ft:
        if abs(float(fe["azimuth_deg"]) - float(ft["azimuth_deg"])) > 1e-9 or not np.allclose(
            fe["origin"], ft["origin"], rtol=0, atol=1e-9
        ):
            raise InputError(
                f"the estimate's frame (origin {fe['origin']}, azimuth {fe['azimuth_deg']} deg) differs from the "
                f"truth's (origin {ft['origin']}, azimuth {ft['azimuth_deg']} deg); expected the same local frame"
            )
    az = _azimuth(est_meta)
    if az is None:
        az = _azimuth(truth_meta)
    return 0.0 if az is None else az


def match_rows(t_est: np.ndarray, t_true: np.ndarray, tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Indices ``(i_est, i_true)`` of rows whose times agree within ``tol`` [s]."""
    if t_true.size == 0 or t_est.size == 0:
        return np.empty(0, int), np.empty(0, int)
    hi = np.clip(np.searchsorted(t_true, t_est), 0, t_true.size - 1)
    lo = np.clip(hi - 1, 0, t_true.size - 1)
    j0 = np.where(np.abs(t_true[lo] - t_est) < np.abs(t_true[hi] - t_est), lo, hi)
    ok = np.abs(t_true[j0] - t_est) <= tol
    return np.flatnonzero(ok), j0[ok]


def _quat(table: pa.Table, prefix: str) -> np.ndarray | None:
    names = [f"{prefix}q{i}" for i in range(4)]
    if all(n in table.column_names for n in names):
        return schema.float_columns(table, names)
    names = [f"{prefix}{a}" for a in ("roll", "pitch", "yaw")]
    if all(n in table.column_names for n in names):
        r, p, y = (schema.floats(table, n) for n in names)
        return rotations.quat_from_euler(r, p, y)
    return None


def _truth_velocity_ned(truth: pa.Table, azimuth: float) -> np.ndarray | None:
    names = ("true_vel_n", "true_vel_e", "true_vel_d")
    if all(n in truth.column_names for n in names):
        return schema.float_columns(truth, names)
    names = ("true_vx", "true_vy", "true_vz")
    if all(n in truth.column_names for n in names):
        return rotations.local_to_ned(schema.float_columns(truth, names), azimuth)
    return None


def check_estimate(est: pa.Table, gnss: bool = False) -> None:
    """Raise :class:`InputError` unless the table has at least one group of estimate columns."""
    names = set(est.column_names)
    if gnss:
        groups = [("gnss_x", "gnss_y", "gnss_z"), ("vel_n", "vel_e", "vel_d")]
    else:
        groups = [("x", "y", "z"), ("vx", "vy", "vz"), ("q0", "q1", "q2", "q3"), ("roll", "pitch", "yaw")]
    if not any(set(g) <= names for g in groups):
        raise InputError(
            f"missing column(s): the input has none of {'; '.join(' '.join(g) for g in groups)}; "
            f"expected {'GNSS measurements in the local frame (gps2hill)' if gnss else 'an estimate such as rts-smooth output'}"
        )


def errors(
    est: pa.Table, truth: pa.Table, azimuth_deg: float, gnss: bool = False
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Per-row errors (estimate minus truth) on the rows both tables share.

    Parameters
    ----------
    est, truth : pyarrow.Table
        Estimate (``x y z``, ``vx vy vz``, ``q0..q3`` or ``roll pitch yaw``) and
        truth (``true_`` columns) with column ``t`` [s].
    azimuth_deg : float
        Azimuth of the local frame's x axis [deg], for the NED velocity.
    gnss : bool
        Evaluate the GNSS measurements instead of an estimate: ``gnss_x
        gnss_y gnss_z`` [m] and ``vel_n vel_e vel_d`` [m/s].

    Returns
    -------
    t : ndarray
        Times of the matched rows [s].
    i_est : ndarray
        Row indices into ``est``.
    err : dict
        Variable -> error per matched row (NaN where either side is null).
    """
    t_est, t_true = schema.floats(est, "t"), schema.floats(truth, "t")
    i_est, i_true = match_rows(t_est, t_true)
    if i_est.size == 0:
        raise InputError(
            f"the estimate's times ({t_est[0]:.3f}-{t_est[-1]:.3f} s) share no row with the truth's; "
            "expected the estimate of the simulated session the truth belongs to"
            if t_est.size and t_true.size
            else "the estimate or the truth has no rows; expected both tables of one simulated session"
        )
    err: dict[str, np.ndarray] = {}
    pos = ("gnss_x", "gnss_y", "gnss_z") if gnss else ("x", "y", "z")
    lacking = [(f"true_{n}", c) for n, c in zip("xyz", pos, strict=True) if c in est.column_names]
    lacking = [(n, c) for n, c in lacking if n not in truth.column_names]
    if lacking:  # an error left out of the table without a word would read as "no error"
        raise InputError(
            f"the truth lacks {', '.join(n for n, _ in lacking)} (the estimate has {', '.join(c for _, c in lacking)}); "
            "expected the truth table written by simulate --truth"
        )
    for name, col in zip(("x", "y", "z"), pos, strict=True):
        e, tr = _col(est, col), _col(truth, f"true_{name}")
        if e is not None and tr is not None:
            err[name] = e[i_est] - tr[i_true]
    v_true = _truth_velocity_ned(truth, azimuth_deg)
    if gnss:
        # GNSS velocity is NED already; each component stands alone (an NMEA log has no vel_d)
        v_est = None
        for k, name in enumerate(("vel_n", "vel_e", "vel_d")):
            e = _col(est, name)
            if e is not None and v_true is not None:
                err[name] = e[i_est] - v_true[i_true, k]
    else:
        names = ("vx", "vy", "vz")
        v_est = (
            rotations.local_to_ned(schema.float_columns(est, names), azimuth_deg)
            if all(n in est.column_names for n in names)
            else None
        )
    if v_est is not None and v_true is not None:
        d = v_est[i_est] - v_true[i_true]
        for k, name in enumerate(("vel_n", "vel_e", "vel_d")):
            err[name] = d[:, k]
    q_est, q_true = (None, None) if gnss else (_quat(est, ""), _quat(truth, "true_"))
    if q_est is not None and q_true is not None:
        qe, qt = q_est[i_est], q_true[i_true]
        ok = np.isfinite(qe).all(axis=1) & np.isfinite(qt).all(axis=1)
        e_eul = np.full((qe.shape[0], 3), np.nan)
        ang = np.full(qe.shape[0], np.nan)
        if ok.any():
            re, pe, ye = rotations.euler_from_quat(qe[ok])
            rt, pt, yt = rotations.euler_from_quat(qt[ok])
            e_eul[ok] = np.stack((_wrap(re - rt), pe - pt, _wrap(ye - yt)), axis=-1)
            ang[ok] = rotations.quat_angle(qe[ok], qt[ok])
        err["roll"], err["pitch"], err["yaw"], err["rot_angle"] = e_eul[:, 0], e_eul[:, 1], e_eul[:, 2], ang
    if not err:
        what = "gnss_x gnss_y gnss_z or vel_n vel_e vel_d" if gnss else "x y z, vx vy vz, q0..q3 or roll pitch yaw"
        raise InputError(
            f"missing column(s): the input has none of {what} with matching true_ columns in the truth; "
            "expected an estimate such as rts-smooth's output"
        )
    return t_true[i_true], i_est, err


def truth_events(truth: pa.Table, meta: dict[str, Any]) -> list[tuple[str, float]]:
    """(name, t) of the truth's events, from its ``event`` column or else its metadata ``events``."""
    return table_events(truth) if "event" in truth.column_names else _meta_events(meta)


def _meta_events(meta: dict[str, Any]) -> list[tuple[str, float]]:
    out = []
    for ev in meta.get("events") or []:
        if isinstance(ev, dict) and "name" in ev and "t" in ev:
            out.append((str(ev["name"]), float(ev["t"])))
    return sorted(out, key=lambda e: e[1])


def table_events(table: pa.Table) -> list[tuple[str, float]]:
    """(name, t) for every non-null row of the ``event`` column."""
    if "event" not in table.column_names:
        return []
    names = table.column("event").to_pylist()
    t = schema.floats(table, "t")
    return [(n, float(t[i])) for i, n in enumerate(names) if n is not None]


def phases(t: np.ndarray, events: list[tuple[str, float]]) -> np.ndarray:
    """Phase label per time: ``inrun`` (t <= take-off), ``flight``, ``outrun`` (t >= touch-down).

    Without a take-off every row is ``inrun``.  Between a touch-down and the
    next take-off the boundary out-run/in-run is the midpoint.
    """
    label = np.full(t.shape, "inrun", dtype=object)
    tos = [e[1] for e in events if e[0] == "takeoff"]
    tds = [e[1] for e in events if e[0] == "touchdown"]
    for k, t_to in enumerate(tos):
        later = [x for x in tds if x > t_to]
        t_td = later[0] if later else np.inf
        label[(t > t_to) & (t < t_td)] = "flight"
        if np.isfinite(t_td):
            nxt = [x for x in tos[k + 1 :] if x > t_td]
            end = 0.5 * (t_td + nxt[0]) if nxt else np.inf
            label[(t >= t_td) & (t < end)] = "outrun"
    return label


def _stats(e: np.ndarray) -> dict[str, float]:
    e = e[np.isfinite(e)]
    if e.size == 0:
        return {"rms": np.nan, "mean": np.nan, "max": np.nan}
    return {"rms": float(np.sqrt(np.mean(e**2))), "mean": float(np.mean(e)), "max": float(np.max(np.abs(e)))}


def _lengths(meta: dict[str, Any], table: pa.Table | None = None) -> list[float]:
    v = meta.get("jump_length")
    if v is None and table is not None and "jump_length" in table.column_names:
        col = schema.floats(table, "jump_length")
        return [float(x) for x in col[np.isfinite(col)]]
    if v is None:
        return []
    return [float(x) for x in (v if isinstance(v, list) else [v])]


def event_errors(
    true_events: list[tuple[str, float]], est_events: list[tuple[str, float]], max_dt: float
) -> tuple[list[dict[str, float]], dict[str, int]]:
    """Timing errors of estimated take-off/touch-down events (estimate minus truth) [s].

    Each true event is paired with the nearest unused estimated event of the same
    name within ``max_dt`` [s]; unpaired true events give NaN, unpaired
    estimated events are counted as false events.
    """
    jumps: list[dict[str, float]] = []
    false: dict[str, int] = {}
    for name in EVENT_NAMES:
        est_t = [t for n, t in est_events if n == name]
        used = [False] * len(est_t)
        k = 0
        for n, t_true in true_events:
            if n != name:
                continue
            best, best_i = np.inf, -1
            for i, te in enumerate(est_t):
                if not used[i] and abs(te - t_true) < abs(best):
                    best, best_i = te - t_true, i
            while len(jumps) <= k:
                jumps.append({})
            jumps[k][name] = t_true
            if best_i >= 0 and abs(best) <= max_dt:
                used[best_i] = True
                jumps[k][f"{name}_dt"] = float(best)
            else:
                jumps[k][f"{name}_dt"] = float("nan")
            k += 1
        false[name] = used.count(False)
    return jumps, false


def evaluate(
    est: pa.Table,
    est_meta: dict[str, Any],
    truth: pa.Table,
    truth_meta: dict[str, Any],
    *,
    gnss: bool = False,
    max_event_dt: float = 1.0,
) -> Evaluation:
    """Compare an estimate with the simulated truth.

    Parameters
    ----------
    est, est_meta : pyarrow.Table, dict
        Estimate table and its metadata.
    truth, truth_meta : pyarrow.Table, dict
        Truth table (``true_`` columns, ``event``) and its metadata (``jump_length`` [m]).
    gnss : bool
        Evaluate the GNSS measurements (``gnss_x..``, ``vel_n..``) instead of an estimate.
    max_event_dt : float
        Largest timing difference [s] for an estimated event to count as the true one.

    Returns
    -------
    Evaluation
    """
    az = _check_frames(est_meta, truth_meta)
    t, _, err = errors(est, truth, az, gnss=gnss)
    tev = truth_events(truth, truth_meta)
    label = phases(t, tev)
    stats: dict[str, dict[str, Any]] = {}
    any_value = np.any([np.isfinite(e) for e in err.values()], axis=0)
    used = PHASES if any(name == "takeoff" for name, _ in tev) else ("all",)
    for ph in used:
        sel = any_value & (True if ph == "all" else label == ph)
        per = {name: _stats(e[sel]) for name, e in err.items()}
        stats[ph] = {s: {name: per[name][s] for name in err} for s in STATS}
        stats[ph]["n"] = int(sel.sum())
    jumps, false = event_errors(tev, table_events(est), max_event_dt)
    l_true, l_est = _lengths(truth_meta, truth), _lengths(est_meta, est)
    n_jumps = max(len(jumps), len(l_true))
    while len(jumps) < n_jumps:
        jumps.append({})
    for k in range(n_jumps):
        if k < len(l_true) and k < len(l_est):
            jumps[k]["jump_length_error"] = l_est[k] - l_true[k]
    return Evaluation(stats=stats, jumps=jumps, false_events=false, variables=list(err), phases=used)


def summary_table(ev: Evaluation) -> pa.Table:
    """The evaluation as a ``summary`` table (Table 6 layout: one column per variable).

    Rows ``(phase, stat)`` for phase in all/inrun/flight/outrun and stat in
    rms/mean/max, with ``samples`` the matched rows; then one row per jump
    (``phase`` = ``jump 1``.., ``stat`` = ``error``) holding ``takeoff_dt``,
    ``touchdown_dt`` [s] and ``jump_length_error`` [m].
    """
    rows: dict[str, list[Any]] = {"phase": [], "stat": [], "samples": []}
    for name, _, _ in VARIABLES:
        rows[name] = []
    extra = ("takeoff_dt", "touchdown_dt", "jump_length_error")
    for name in extra:
        rows[name] = []
    for ph in ev.phases:
        for s in STATS:
            rows["phase"].append(ph)
            rows["stat"].append(s)
            rows["samples"].append(ev.stats[ph]["n"])
            for name, _, _ in VARIABLES:
                rows[name].append(ev.stats[ph][s].get(name, np.nan))
            for name in extra:
                rows[name].append(np.nan)
    for k, j in enumerate(ev.jumps):
        rows["phase"].append(f"jump {k + 1}")
        rows["stat"].append("error")
        rows["samples"].append(0)
        for name, _, _ in VARIABLES:
            rows[name].append(np.nan)
        for name in extra:
            rows[name].append(j.get(name, np.nan))
    cols = {}
    for name, values in rows.items():
        if name in ("phase", "stat"):
            cols[name] = pa.array(values, pa.string())
        elif name == "samples":
            cols[name] = pa.array(values, pa.int64())
        else:
            cols[name] = schema.to_arrow(name, np.asarray(values, dtype=float))
    keep = [n for n in cols if n in ("phase", "stat", "samples", *extra) or n in ev.variables]
    return pa.table({n: cols[n] for n in keep})


def _json_ready(obj: Any) -> Any:
    """Non-finite floats -> None (JSON has no NaN), recursively."""
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _json_ready(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_json_ready(v) for v in obj]
    return obj


def summary_meta(ev: Evaluation) -> dict[str, Any]:
    """The evaluation as JSON-ready metadata (key ``evaluation``; missing values are null)."""
    return _json_ready(
        {
            "stats": ev.stats,
            "jumps": ev.jumps,
            "false_events": ev.false_events,
            "variables": ev.variables,
            "units": {name: unit for name, unit, _ in VARIABLES if name in ev.variables},
        }
    )


def format_text(ev: Evaluation, title: str = "") -> str:
    """A readable table of the evaluation (angles in degrees), Table 6 layout."""
    cols = [(n, u, lab) for n, u, lab in VARIABLES if n in ev.variables]
    head = f"{'phase':<8}{'stat':<6}{'samples':>8}" + "".join(f"{lab:>13}" for _, _, lab in cols)
    lines = [title] if title else []
    lines += [head, "-" * len(head)]
    for ph in ev.phases:
        for s in STATS:
            vals = []
            for name, _, _ in cols:
                v = ev.stats[ph][s].get(name, np.nan)
                if name in ANGLES:
                    v = np.degrees(v)
                vals.append(f"{v:13.3f}" if np.isfinite(v) else f"{'-':>13}")
            lines.append(f"{ph:<8}{s:<6}{ev.stats[ph]['n']:>8d}" + "".join(vals))
    for k, j in enumerate(ev.jumps):
        parts = []
        for name, label, unit in (
            ("takeoff_dt", "take-off", "s"),
            ("touchdown_dt", "touch-down", "s"),
            ("jump_length_error", "jump length", "m"),
        ):
            if name in j:
                v = j[name]
                parts.append(f"{label} {v:+.3f} {unit}" if np.isfinite(v) else f"{label} missed")
        if parts:
            lines.append(f"jump {k + 1}: " + ", ".join(parts))
    false = {k: v for k, v in ev.false_events.items() if v}
    if false:
        lines.append("false events: " + ", ".join(f"{k} {v}" for k, v in false.items()))
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- jump length vs a reference (Table 7)
#: The ski-jump paper's Table 7 figures: RMS of L_TR - L_VR and its upper bound with a 0.5 m reading error [m].
PAPER_TABLE7_RMS = 1.0


PAPER_TABLE7_RMS_UB = 1.5
