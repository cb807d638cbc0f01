"""``body-model`` over a session: several IMUs on one athlete -> segment orientations, joint centres, CoM.

Reads the sensors of the seven segments (pelvis: plain ``acc_* gyr_*``; the others ``<segment>__acc_*``,
``<segment>__gyr_*``; docs/table-contract.md), puts them on the pelvis sensor's sample times (linear
interpolation of a sensor sampled at other instants), finds the functional calibration
(:mod:`sportfusion.body.calibration`), integrates each segment's orientation with the drift corrections of
:mod:`sportfusion.body.orientation`, and evaluates the body model (:mod:`sportfusion.body.model`, de Leva's
segments of :mod:`sportfusion.body.anthropometry`).

Output columns on the pelvis sensor's rows (null elsewhere and outside the span every sensor covers), in
the body model's frame J (x forward and y right of the athlete in the calibration posture, z down) relative
to the lumbar joint centre (LJC):

* ``<segment>__q0..q3``: the segment's orientation, q mapping J into the segment frame (scalar first);
* ``<point>_rel_x/y/z`` [m] for ``hip_r hip_l knee_r knee_l ankle_r ankle_l sternum head ski_r ski_l``
  (ski_*: the ski-snow contact points, 0.15 m distal of the ankles along the shanks);
* ``com_rel_x/y/z`` [m]: the whole-body centre of mass (boots and skis included);
* ``hip_r_flexion hip_l_flexion knee_r_flexion knee_l_flexion`` [rad].

The metadata's ``body_model.pelvis_lever_m`` is the LJC relative to the pelvis sensor in the pelvis frame
[m] (:func:`sportfusion.body.joints.pelvis_lever`), which ``gate-anchor`` adds to the sensor's track.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sportfusion.body.anthropometry import CONTACT_M, EQUIPMENT_KG, SEGMENTS, body_params
from sportfusion.body.calibration import calibrate
from sportfusion.body.model import body_points, centre_of_mass, joint_rotations, xyz_angles
from sportfusion.body.orientation import quats_from_rot, segment_orientations, static_periods
from sportfusion.core.errors import InputError

SEP = "__"
POINTS = ("hip_r", "hip_l", "knee_r", "knee_l", "ankle_r", "ankle_l", "sternum", "head", "ski_r", "ski_l")
FLEXION = ("hip_r", "hip_l", "knee_r", "knee_l")


@dataclass(frozen=True)
class BodyModelParams:
    """Options of :func:`body_model_table` (units in brackets)."""

    height: float = 1.80  # [m]
    mass: float = 75.0  # [kg]
    sex: str = "male"
    equipment: float = EQUIPMENT_KG  # boots + skis [kg]
    contact: float = CONTACT_M  # ski contact below the ankle [m]
    calibration: tuple[float, float] | None = None  # [s] on the session clock
    lengths: dict[str, float] = field(default_factory=dict)  # measured lengths [m]
    hinge_window: float | None = 4.0  # knee drift correction window [s]; None: off
    # the pelvis sensor's lever arm to the LJC in the pelvis frame [m]: None estimated from the hips
    # (sportfusion.body.joints), zeros: the sensor at the LJC (the gates paper's assumption), or measured
    pelvis_lever: tuple[float, float, float] | None = None


def column(segment: str, name: str) -> str:
    """The session column of sensor column ``name`` for ``segment`` (plain for the pelvis)."""
    return name if segment == "pelvis" else f"{segment}{SEP}{name}"


def sensors_in(names: list[str]) -> dict[str, bool]:
    """Which of the seven segments have ``acc_*`` and ``gyr_*`` columns."""
    cols = set(names)
    return {s: all(column(s, f"{k}_{a}") in cols for k in ("acc", "gyr") for a in "xyz") for s in SEGMENTS}


@dataclass
class BodyResult:
    """Arrays of :func:`body_model_arrays` (on the samples it was given)."""

    rot: dict[str, np.ndarray]
    points: dict[str, np.ndarray]
    com: np.ndarray
    flexion: dict[str, np.ndarray]
    info: dict[str, Any]


def body_model_arrays(
    t: np.ndarray, acc: dict[str, np.ndarray], gyr: dict[str, np.ndarray], p: BodyModelParams
) -> BodyResult:
    """The body model on arrays sampled at the times ``t`` [s] (every segment the same instants)."""
    body = body_params(p.height, p.mass, p.sex, p.equipment, p.lengths, p.contact)
    cal = calibrate(t, acc, gyr, p.calibration)
    statics = static_periods(t, acc, gyr)
    start = int(0.5 * (cal.static[0] + cal.static[1]))
    # the calibration posture counts as a still period (its bias) even when shorter than the default
    if not any(a <= start < b for a, b in statics):
        statics = sorted(statics + [cal.static])
    rot, bias = segment_orientations(t, acc, gyr, cal.alignment, start, statics, p.hinge_window)
    if p.pelvis_lever is None:
        from sportfusion.body.joints import pelvis_lever

        pl = pelvis_lever(
            t, acc, gyr, cal.alignment, {s: body.joint[f"femur_{s}"] for s in "rl"}, body.lengths["thigh"]
        )
        lever, lever_how = (
            pl.lever,
            (
                f"estimated from the hip joint centres (Seel et al. 2012; residual {pl.rms:.2f} m/s^2)"
                if not pl.note
                else f"not estimated ({pl.note}): the sensor taken at the LJC"
            ),
        )
    else:
        lever, lever_how = np.asarray(p.pelvis_lever, float), "given"
    pts = body_points(rot, body)
    com = centre_of_mass(rot, body)
    jr = joint_rotations(rot)
    flex = {
        "hip_r": xyz_angles(jr["femur_r"])[:, 1],
        "hip_l": xyz_angles(jr["femur_l"])[:, 1],
        "knee_r": -xyz_angles(jr["tibia_r"])[:, 1],
        "knee_l": -xyz_angles(jr["tibia_l"])[:, 1],
    }
    info = {
        "calibration_s": [float(t[cal.static[0]]), float(t[cal.squats[1] - 1])],
        "static_upright_s": [float(t[cal.static[0]]), float(t[cal.static[1] - 1])],
        "squats_s": [float(t[cal.squats[0]]), float(t[cal.squats[1] - 1])],
        "squat_tilt_deg": {k: round(v, 1) for k, v in cal.tilt_deg.items()},
        "still_periods_s": [[float(t[a]), float(t[b - 1])] for a, b in statics],
        "alignment": {k: np.round(v, 6).tolist() for k, v in cal.alignment.items()},
        "gyro_bias_start_rad_s": {k: np.round(v[start], 6).tolist() for k, v in bias.items()},
        "segment_mass_kg": {k: round(m, 3) for k, (m, _) in body.com.items()},
        "lengths_m": {k: round(v, 4) for k, v in body.lengths.items()},
        "total_mass_kg": round(body.total_mass, 3),
        "pelvis_lever_m": np.round(lever, 4).tolist(),
        "pelvis_lever": lever_how,
    }
    return BodyResult(rot, pts, com, flex, info)


def _grid(table: Any) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], dict[str, np.ndarray], list[str]]:
    from sportfusion.core import schema

    t_all = schema.floats(table, "t")
    pa_ = schema.float_columns(table, [f"acc_{a}" for a in "xyz"] + [f"gyr_{a}" for a in "xyz"])
    rows = np.flatnonzero(np.isfinite(pa_).all(axis=1))
    if rows.size < 100:
        raise InputError(f"{rows.size} rows with the pelvis sensor's acc_* and gyr_*; expected an IMU recording")
    t = t_all[rows]
    acc: dict[str, np.ndarray] = {"pelvis": pa_[rows, :3]}
    gyr: dict[str, np.ndarray] = {"pelvis": pa_[rows, 3:]}
    notes = []
    for seg in SEGMENTS[1:]:
        v = schema.float_columns(table, [column(seg, f"{k}_{a}") for k in ("acc", "gyr") for a in "xyz"])
        ok = np.isfinite(v).all(axis=1)
        if ok.sum() < 100:
            raise InputError(f"{int(ok.sum())} rows with the {seg} sensor's acc_* and gyr_*; expected its recording")
        ts = t_all[ok]
        if np.array_equal(ok[rows], np.ones(rows.size, bool)) and ok.sum() == rows.size:
            vals = v[rows]
        else:
            vals = np.column_stack([np.interp(t, ts, v[ok, j], left=np.nan, right=np.nan) for j in range(6)])
            notes.append(f"{seg} interpolated onto the pelvis sensor's sample times")
        acc[seg], gyr[seg] = vals[:, :3], vals[:, 3:]
    return rows, t, acc, gyr, notes


def body_model_table(
    table: Any, meta: dict[str, Any], params: BodyModelParams | None = None
) -> tuple[Any, dict[str, Any], str, BodyResult, np.ndarray]:
    """:func:`body_model_arrays` on a session table (module text).

    Returns the table with the body columns, the metadata (``body_model`` entry), a one-line summary, the
    arrays and the table rows they are on.
    """
    import pyarrow as pa

    from sportfusion.core.session import with_columns

    p = params or BodyModelParams()
    have = sensors_in(table.column_names)
    missing = [s for s, ok in have.items() if not ok]
    if missing:
        raise InputError(
            f"no sensor for segment(s) {', '.join(missing)} (columns {column(missing[0], 'acc_x')}, "
            f"{column(missing[0], 'gyr_x')}, ...); body-model needs pelvis, torso, head, femur_r, femur_l, tibia_r, "
            "tibia_l (ingest a folder of exports with its mapping file)"
        )
    rows, t, acc, gyr, notes = _grid(table)
    cover = np.all([np.isfinite(acc[s]).all(axis=1) for s in SEGMENTS], axis=0)
    idx = np.flatnonzero(cover)
    if idx.size < 100:
        raise InputError("the sensors overlap on fewer than 100 of the pelvis sensor's samples; expected one recording")
    i0, i1 = int(idx[0]), int(idx[-1]) + 1
    if not cover[i0:i1].all():
        raise InputError("a sensor has a gap inside the recording; body-model needs every sensor throughout")
    res = body_model_arrays(t[i0:i1], {k: v[i0:i1] for k, v in acc.items()}, {k: v[i0:i1] for k, v in gyr.items()}, p)
    n = table.num_rows
    sel = rows[i0:i1]

    def full(x: np.ndarray) -> np.ndarray:
        out = np.full(n, np.nan)
        out[sel] = x
        return out

    cols: dict[str, Any] = {}
    for seg in SEGMENTS:
        q = quats_from_rot(res.rot[seg])
        for i in range(4):
            cols[f"{seg}{SEP}q{i}"] = full(q[:, i])
    for name in POINTS:
        for i, a in enumerate("xyz"):
            cols[f"{name}_rel_{a}"] = full(res.points[name][:, i])
    for i, a in enumerate("xyz"):
        cols[f"com_rel_{a}"] = full(res.com[:, i])
    for name in FLEXION:
        cols[f"{name}_flexion"] = full(res.flexion[name])
    out = with_columns(table, {k: pa.array(v, pa.float64(), from_pandas=True) for k, v in cols.items()})
    meta = dict(meta)
    meta["body_model"] = {
        "method": "functional calibration (static upright + squats), strap-down with gyro bias from the still "
        "periods, tilt reset at the still periods, knee hinge drift correction; de Leva 1996 segments",
        "frame": "J: x forward, y right of the athlete in the calibration posture, z down; origin the LJC",
        "height_m": p.height,
        "mass_kg": p.mass,
        "sex": p.sex,
        "equipment_kg": p.equipment,
        "contact_m": p.contact,
        "rows": [int(sel[0]), int(sel[-1])],
        "notes": notes,
        **res.info,
    }
    cs = res.info["calibration_s"]
    msg = (
        f"calibration at t = {cs[0]:.1f}-{cs[1]:.1f} s, {len(res.info['still_periods_s'])} still period(s), "
        f"CoM from {len(SEGMENTS)} segments ({res.info['total_mass_kg']:.1f} kg with equipment) on {sel.size} rows"
    )
    return out, meta, msg, res, sel
