"""Estimate versus truth: error statistics in the layout of the ski-jumping paper's Table 6.

Errors are estimate minus truth (skijump eqs 52-53, 57), all in one frame, the session's local (hill,
course, wall) frame that its metadata declares (:func:`frame_label` names it in every table header):

* position ``x y z`` [m];
* velocity ``vx vy vz`` [m/s] in the same frame (the paper's Table 6 gives the velocity in NED, ``v_O``,
  beside a hill-frame position; ``errors(..., velocity_frame="ned")`` returns ``vel_n vel_e vel_d`` for
  that comparison); GNSS velocities (NED, ``--gnss``) are rotated into the local frame by its azimuth;
* Euler angles ``roll pitch yaw`` (z-y-x, eqs 54-56) [rad], wrapped to
  (-pi, pi]; their errors are the same whether the yaw is counted from north or from the frame's x
  axis (the two differ by the constant azimuth);
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
or a ``jump_length`` column).  The times compared are the same whichever table
is evaluated (a smoothed session here, a ``jump-metrics`` table in
:mod:`~sportfusion.evaluate.jumps`): the estimate's event at the detector's exact
time (:func:`estimate_event_times`: the metadata's time where it lies within half
a sample of the event row, as ``jump-metrics`` takes it), the truth's at the
simulator's exact time (:func:`truth_events`: its metadata before its rows).
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
    ("vx", "m/s", "dvx [m/s]"),
    ("vy", "m/s", "dvy [m/s]"),
    ("vz", "m/s", "dvz [m/s]"),
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
    frame: str = "local frame"


def frame_label(meta: dict[str, Any]) -> str:
    """The frame every error of a table is in, in words: ``"hill frame (x along azimuth 312.6 deg, y right, z
    down)"``; ``"local frame"`` when the metadata declares none."""
    frame = meta.get("frame") or {}
    if not frame:
        return "local frame"
    name = str(frame.get("name") or "local")
    az = frame.get("azimuth_deg")
    axes = str(frame.get("axes") or "x forward, y right, z down")
    return f"{name} frame ({axes}; x at azimuth {float(az):.1f} deg)" if az is not None else f"{name} frame ({axes})"


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
    est: pa.Table, truth: pa.Table, azimuth_deg: float, gnss: bool = False, velocity_frame: str = "local"
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Per-row errors (estimate minus truth) on the rows both tables share.

    Parameters
    ----------
    est, truth : pyarrow.Table
        Estimate (``x y z``, ``vx vy vz``, ``q0..q3`` or ``roll pitch yaw``) and
        truth (``true_`` columns) with column ``t`` [s].
    azimuth_deg : float
        Azimuth of the local frame's x axis [deg], between NED and the local frame.
    gnss : bool
        Evaluate the GNSS measurements instead of an estimate: ``gnss_x
        gnss_y gnss_z`` [m] and ``vel_n vel_e vel_d`` [m/s].
    velocity_frame : ``"local"`` or ``"ned"``
        The velocity errors as ``vx vy vz`` in the local frame (the position's frame: one frame per
        table), or as ``vel_n vel_e vel_d`` in NED (the ski-jump paper's Table 6, ``v_O``).

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
    if velocity_frame not in ("local", "ned"):
        raise ValueError(f"velocity_frame {velocity_frame!r}; expected 'local' or 'ned'")
    v_true = _truth_velocity_ned(truth, azimuth_deg)
    ned_names, local_names = ("vel_n", "vel_e", "vel_d"), ("vx", "vy", "vz")
    if gnss and v_true is not None:
        # GNSS velocity is NED; each component stands alone (an NMEA log has no vel_d): the horizontal pair
        # rotates into the local frame, the vertical is the same in both
        d = {n: _col(est, n) for n in ned_names}
        d = {n: None if v is None else v[i_est] - v_true[i_true, k] for k, (n, v) in enumerate(d.items())}
        if velocity_frame == "ned":
            err.update({n: v for n, v in d.items() if v is not None})
        else:
            if d["vel_n"] is not None and d["vel_e"] is not None:
                hz = rotations.ned_to_local(
                    np.column_stack([d["vel_n"], d["vel_e"], np.zeros_like(d["vel_n"])]), azimuth_deg
                )
                err["vx"], err["vy"] = hz[:, 0], hz[:, 1]
            if d["vel_d"] is not None:
                err["vz"] = d["vel_d"]
    elif not gnss and v_true is not None and all(n in est.column_names for n in local_names):
        v_est = schema.float_columns(est, local_names)[i_est]
        if velocity_frame == "ned":
            dv, names = rotations.local_to_ned(v_est, azimuth_deg) - v_true[i_true], ned_names
        else:
            dv, names = v_est - rotations.ned_to_local(v_true[i_true], azimuth_deg), local_names
        for k, name in enumerate(names):
            err[name] = dv[:, k]
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


def truth_events(truth: pa.Table | None, meta: dict[str, Any]) -> list[tuple[str, float]]:
    """(name, t [s]) of the truth's events at the simulator's exact instants: its metadata's
    ``skijump.times`` (take-off, touch-down), else its metadata ``events``, else its ``event`` column's rows
    (a row sits on a sample; the metadata's time is the event's own)."""
    times = (meta.get("skijump") or {}).get("times") or {}
    if "takeoff" in times and "touchdown" in times:
        return sorted(((n, float(times[n])) for n in EVENT_NAMES), key=lambda e: e[1])
    found = _meta_events(meta)
    if found or truth is None:
        return found
    return table_events(truth)


def estimate_event_times(table: pa.Table, meta: dict[str, Any]) -> list[tuple[str, float]]:
    """(name, t [s]) of an estimate's events: the ``event`` column's rows, each at the detector's exact time
    where the metadata's ``events`` list holds one within half a sample step of the row (what
    ``jump-metrics`` reports as ``t_takeoff``), else at the row's time.  One definition of an event's time
    for every table ``evaluate`` compares."""
    rows = table_events(table)
    exact: dict[str, list[float]] = {}
    for e in meta.get("events") or []:
        for j in (e.get("jumps") or []) if isinstance(e, dict) else []:
            for name in EVENT_NAMES:
                if isinstance(j, dict) and isinstance(j.get(name), int | float):
                    exact.setdefault(name, []).append(float(j[name]))
    if not rows or not exact:
        return rows
    t = schema.floats(table, "t")
    tol = 0.5 * float(np.median(np.diff(t))) + 1e-9 if t.size > 1 else 1e-9
    out = []
    for name, tr in rows:
        cand = np.asarray(exact.get(name, []))
        k = int(np.argmin(np.abs(cand - tr))) if cand.size else -1
        out.append((name, float(cand[k]) if k >= 0 and abs(cand[k] - tr) <= tol else tr))
    return out


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
    jumps, false = event_errors(tev, estimate_event_times(est, est_meta), max_event_dt)
    l_true, l_est = _lengths(truth_meta, truth), _lengths(est_meta, est)
    n_jumps = max(len(jumps), len(l_true))
    while len(jumps) < n_jumps:
        jumps.append({})
    for k in range(n_jumps):
        if k < len(l_true) and k < len(l_est):
            jumps[k]["jump_length_error"] = l_est[k] - l_true[k]
    return Evaluation(
        stats=stats,
        jumps=jumps,
        false_events=false,
        variables=list(err),
        phases=used,
        frame=frame_label(est_meta if est_meta.get("frame") else truth_meta),
    )


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
            "frame": ev.frame,
        }
    )


def format_text(ev: Evaluation, title: str = "") -> str:
    """A readable table of the evaluation (angles in degrees), Table 6 layout; its header names the one
    frame of every position and velocity error."""
    cols = [(n, u, lab) for n, u, lab in VARIABLES if n in ev.variables]
    head = f"{'phase':<8}{'stat':<6}{'samples':>8}" + "".join(f"{lab:>13}" for _, _, lab in cols)
    lines = [title] if title else []
    what = []
    if any(n in ev.variables for n in ("x", "y", "z", "vx", "vy", "vz")):
        what.append(f"position and velocity errors in the {ev.frame}")
    if any(n in ev.variables for n in ANGLES):
        what.append("attitude errors (the same in any frame) in deg")
    if what:
        lines.append("; ".join(what))
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
