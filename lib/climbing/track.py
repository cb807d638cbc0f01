"""``pf-holds`` as one library call: session + hold map -> positions, hold per grip, cluster probability.

Pipeline (the climbing paper's methodology, Fig. 3): grips from ``detect-events
--kind grips`` -> transition estimator (:mod:`.transition`) -> particle filter and
smoother over the hold map (:mod:`.particles`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.climbing._so3 import axis_rotation
from sportfusion.climbing.grips import GripParams, range_violations
from sportfusion.climbing.holds import HoldMap
from sportfusion.climbing.particles import PFParams, PFResult, run_particle_filter
from sportfusion.climbing.transition import TransitionParams, TransitionResult, estimate_transitions
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.magdisturb import describe as describe_mag
from sportfusion.core.magdisturb import mag_disturbed
from sportfusion.core.stats import median

IMU = tuple(f"{s}_{a}" for s in ("acc", "gyr", "mag") for a in "xyz")


@dataclass(frozen=True)
class TrackOptions:
    """Options of :func:`track_holds`.

    Attributes
    ----------
    route : str or None
        Route climbed; default: the session's ``climbing.route`` metadata, else the map's only route.
    descent_after : float or None
        From this time [s] grips are matched against all holds of the wall; default: the
        session's ``climbing.descent_time``; None there too: the route only.
    seed : int
        Seed of the particle filter.
    smooth : bool
        Output the smoother (True) or the filter.
    pf, transition
        Parameters of the two stages.
    saturation_margin : float
        Samples within this time [s] of a saturated (clipped) sample are treated as saturated too (default 0:
        a wider mask changed which start hold the filter settles on in clean simulated trials)
        (the rest of the impact burst; policy in docs/faults.md).
    """

    route: str | None = None
    descent_after: float | None = None
    seed: int = 0
    smooth: bool = True
    pf: PFParams = field(default_factory=PFParams)
    transition: TransitionParams = field(default_factory=TransitionParams)
    saturation_margin: float = 0.0


@dataclass
class Track:
    """What :func:`track_holds` found: new columns (full table length) and the stages' results."""

    columns: dict[str, pa.Array]
    route: str
    descent_time: float | None
    transition: TransitionResult
    pf: PFResult
    rows: np.ndarray  # boolean mask of the IMU rows the estimate lives on
    warnings: list[str]


def _normalised_mag(table: pa.Table, meta: dict[str, Any], rows: np.ndarray) -> np.ndarray:
    mag = schema.float_columns(table, [f"mag_{a}" for a in "xyz"])[rows]
    unit = (meta.get("units") or {}).get("mag_x", schema.unit_of("mag_x"))
    if unit == "1":
        return mag
    norm = np.linalg.norm(mag, axis=1)
    ok = np.isfinite(norm) & (norm > 0)
    if not ok.any():
        raise InputError("the magnetometer has no valid samples on the IMU rows; expected mag_x, mag_y, mag_z")
    return mag / median(norm[ok])


def track_holds(table: pa.Table, meta: dict[str, Any], holds: HoldMap, opts: TrackOptions | None = None) -> Track:
    """Positions of one hand on a climbing wall from its IMU, magnetometer and grips.

    Parameters
    ----------
    table : pyarrow.Table
        Session with ``acc_* gyr_* mag_*`` (sensor frame; magnetometer in uT or normalised,
        unit "1") and ``grip`` (from ``detect-events --kind grips``); ``imu_saturated``
        is used when present, else computed with the default sensor ranges.
    meta : dict
        The session's metadata (``climbing.route``, ``climbing.descent_time`` are used).
    holds : HoldMap
        The validated hold map; it must declare the reference magnetic field.
    opts : TrackOptions, optional

    Returns
    -------
    Track
        ``columns``: ``x y z`` [m] (map frame), ``vx vy vz`` [m/s] (transition velocity
        rotated by the output's yaw error), ``hold_id`` (int32: the most likely cluster's
        hold at grip samples, -1 elsewhere, null off the grips), ``cluster_prob`` -- null on
        rows without an IMU sample and before the first grip.
    """
    o = opts or TrackOptions()
    schema.require_columns(table, (*IMU, "grip"), "hold tracking (run `detect-events --kind grips` first)")
    acc = schema.float_columns(table, [f"acc_{a}" for a in "xyz"])
    gyr = schema.float_columns(table, [f"gyr_{a}" for a in "xyz"])
    rows = np.isfinite(acc).all(axis=1) & np.isfinite(gyr).all(axis=1)
    if rows.sum() < 3:
        raise InputError(f"only {int(rows.sum())} IMU samples; expected a trial of many samples")
    t = schema.floats(table, "t")[rows]
    grip = schema.flags(table, "grip")[rows]
    if "imu_saturated" in table.column_names:
        sat = schema.flags(table, "imu_saturated")[rows]
    else:
        sat = range_violations(acc[rows], gyr[rows], GripParams())
    mag = _normalised_mag(table, meta, rows)
    if holds.magnetic_field is None:
        raise InputError(
            "the hold map declares no reference magnetic field (metadata climbing.magnetic_field); "
            "expected the field direction in the map frame"
        )
    cl = meta.get("climbing") or {}
    route = o.route or cl.get("route")
    if route is None:
        if len(holds.routes) != 1:
            raise InputError(
                f"the hold map has {len(holds.routes)} routes and the session names none; "
                f"expected --route (one of {', '.join(holds.routes)})"
            )
        route = holds.routes[0]
    route = str(route)
    descent = o.descent_after if o.descent_after is not None else cl.get("descent_time")
    descent = None if descent is None else float(descent)
    warnings = []
    frame = meta.get("frame")
    hframe = holds.meta.get("frame")
    if (
        frame
        and hframe
        and (frame.get("name"), frame.get("azimuth_deg")) != (hframe.get("name"), hframe.get("azimuth_deg"))
    ):
        warnings.append("the session's frame differs from the hold map's; x y z are in the hold map's frame")

    # magnetic disturbances (core.magdisturb): disturbed samples are skipped by the orientation filter
    f_ref = np.asarray(holds.magnetic_field, dtype=float)
    up = np.asarray(holds.up, dtype=float)
    dip = float(np.degrees(np.arccos(np.clip(-f_ref @ up / (np.linalg.norm(f_ref) * np.linalg.norm(up)), -1, 1))))
    dist = mag_disturbed(t, mag, None, acc[rows], dip, float(holds.gravity), gyr[rows])
    if dist.any():
        mag = mag.copy()
        mag[dist] = np.nan
        warnings.append(describe_mag(int(dist.sum()), t, dist) + ": those samples are skipped")
    if sat.any() and o.saturation_margin > 0:
        # an impact that clips also disturbs the samples around it (the rest of the burst): widen the mask
        ts = t[sat]
        j = np.clip(np.searchsorted(ts, t), 1, ts.size)
        m = o.saturation_margin
        sat = (np.abs(t - ts[j - 1]) <= m) | (np.abs(t - ts[np.minimum(j, ts.size - 1)]) <= m)
    if sat.any():
        warnings.append(
            f"IMU saturated (clipped at the sensor range) in {int(sat.sum())} sample(s): "
            "their transitions get inflated noise"
        )
    tr = estimate_transitions(
        t, acc[rows], gyr[rows], mag, grip, holds.magnetic_field, -holds.gravity * holds.up, sat, o.transition
    )
    pf = run_particle_filter(
        t,
        tr.velocity,
        tr.velocity_cov,
        grip,
        holds.route_holds(route),
        holds.start_positions(route),
        holds.up,
        holds.wall_holds(),
        descent,
        o.pf,
        seed=o.seed,
        smooth=o.smooth,
    )
    pos, lab, prob, yaw = (
        (pf.smooth_pos, pf.smooth_label, pf.smooth_prob, pf.smooth_yaw)
        if o.smooth
        else (pf.pos, pf.label, pf.prob, pf.yaw)
    )
    vel = np.full_like(tr.velocity, np.nan)
    ok = np.isfinite(yaw)
    vel[ok] = axis_rotation(holds.up, yaw[ok], tr.velocity[ok])
    n = table.num_rows
    cols: dict[str, pa.Array] = {}
    for i, a in enumerate("xyz"):
        full = np.full(n, np.nan)
        full[rows] = pos[:, i]
        cols[a] = schema.to_arrow(a, full)
    for i, a in enumerate("xyz"):
        full = np.full(n, np.nan)
        full[rows] = vel[:, i]
        cols[f"v{a}"] = schema.to_arrow(f"v{a}", full)
    hid = np.zeros(n, dtype=np.int32)
    hmask = np.ones(n, dtype=bool)
    on = grip & (lab > -2)
    idx = np.flatnonzero(rows)
    hid[idx[on]] = lab[on]
    hmask[idx[on]] = False
    cols["hold_id"] = schema.numeric_array(hid.astype(np.int32), hmask)
    full = np.full(n, np.nan)
    full[rows] = prob
    cols["cluster_prob"] = schema.to_arrow("cluster_prob", full)
    return Track(cols, route, descent, tr, pf, rows, warnings)
