"""The column registry: name -> Arrow type, unit and meaning.

Every column that flows between the tools is described here once.  The write
helper in :mod:`sportfusion.core.io` attaches ``{"unit": ...}`` to each field from
this registry, and :func:`check_types` refuses a table whose known columns
carry the wrong type.  Columns a user adds that are not registered pass
through untouched.

Two prefixes are resolved automatically: ``std_<name>`` (1-sigma of
``<name>``, same unit) and ``true_<name>`` (truth from ``simulate``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyarrow as pa

from sportfusion.core.errors import InputError

F64 = pa.float64()
I16 = pa.int16()
I32 = pa.int32()
I64 = pa.int64()
STR = pa.string()
BOOL = pa.bool_()


@dataclass(frozen=True)
class Column:
    """One registered column.

    Attributes
    ----------
    name : str
        Column name as it appears in the table.
    type : pyarrow.DataType
        Arrow type the column must have.
    unit : str
        SI unit (``"1"`` for dimensionless, ``""`` for text/flags).
    meaning : str
        One line describing the column.
    """

    name: str
    type: pa.DataType
    unit: str
    meaning: str


COLUMNS: dict[str, Column] = {}


def register(name: str, type_: pa.DataType, unit: str, meaning: str) -> Column:
    """Add (or replace) a column in the registry and return it."""
    col = Column(name, type_, unit, meaning)
    COLUMNS[name] = col
    return col


def _xyz(prefix: str, unit: str, meaning: str, axes: str = "xyz") -> None:
    for a in axes:
        register(f"{prefix}_{a}" if prefix else a, F64, unit, f"{meaning}, {a} axis")


register("t", F64, "s", "time since time.epoch_utc")
# IMU, body frame
_xyz("acc", "m/s^2", "specific force in the body (sensor) frame")
_xyz("gyr", "rad/s", "angular rate in the body (sensor) frame")
_xyz("mag", "uT", "magnetic field in the body frame (unit '1' when normalised)")
register("pressure", F64, "Pa", "barometric pressure")
for _i in range(4):
    register(f"dev_q{_i}", F64, "1", f"device's own orientation quaternion, component {_i} (scalar first)")
# GNSS
register("lat", F64, "deg", "WGS84 latitude")
register("lon", F64, "deg", "WGS84 longitude")
register("h", F64, "m", "WGS84 ellipsoidal height")
register("h_msl", F64, "m", "height above mean sea level as reported by the receiver")
for _a, _m in (("n", "north"), ("e", "east"), ("d", "down")):
    register(f"vel_{_a}", F64, "m/s", f"GNSS velocity, {_m} (NED)")
register("gnss_fix", I16, "1", "fix quality, NMEA GGA codes (0 invalid, 1 GPS, 2 DGPS, 4 RTK fixed, 5 RTK float, 6 DR)")
register("gnss_sats", I16, "1", "number of satellites used")
register("gnss_hdop", F64, "1", "horizontal dilution of precision")
register("gnss_sigma_h", F64, "m", "horizontal position 1-sigma (per axis)")
register("gnss_sigma_v", F64, "m", "vertical position 1-sigma")
register("gnss_sigma_n", F64, "m", "north position 1-sigma")
register("gnss_sigma_e", F64, "m", "east position 1-sigma")
for _a in ("ne", "eu", "un"):
    register(f"gnss_sd{_a}", F64, "m", f"signed square root of the {_a} position covariance (RTKLIB sd{_a})")
register("gnss_speed", F64, "m/s", "speed over ground as reported by the receiver")
register("gnss_course", F64, "deg", "course over ground, clockwise from true north")
register("label", STR, "", "per-row label written by the recording app (a GPX track name: Lift, Downhill, Hold)")
register("gnss_age", F64, "s", "age of differential corrections")
register("gnss_ratio", F64, "1", "ambiguity ratio-test value")
register("rtk_q", I16, "1", "RTKLIB solution quality Q (1 fix, 2 float, 3 sbas, 4 dgps, 5 single, 6 ppp, 7 dr)")
_xyz("gnss", "m", "GNSS position in the local frame")
# watches and bike computers (FIT/TCX), robust GNSS smoothing, magnetometer plausibility (issue 15)
register("heart_rate", F64, "1/min", "heart rate")
register("cadence", F64, "1/min", "cadence (steps, strides or crank revolutions per minute, as the device reports)")
register("power", F64, "W", "mechanical power (power meter)")
register("temperature", F64, "degC", "temperature reported by the device")
register("gnss_weight", F64, "1", "robust weight of the GNSS fix in spline-smooth (1 = trusted, 0 = rejected outlier)")
register("mag_implausible", BOOL, "", "magnetometer sample inconsistent with the magnetic model (norm or dip)")
# estimates
_xyz("", "m", "position in the local frame")
_xyz("v", "m/s", "velocity in the local frame")
_xyz("a", "m/s^2", "kinematic acceleration in the local frame")
for _i in range(4):
    register(f"q{_i}", F64, "1", f"attitude quaternion q_BO, component {_i} (scalar first)")
register("roll", F64, "rad", "roll angle")
register("pitch", F64, "rad", "pitch angle")
register("yaw", F64, "rad", "yaw angle (azimuth from north)")
register("speed", F64, "m/s", "speed")
register("distance", F64, "m", "curvilinear distance along the path")
for _s in ("gyr", "acc", "mag"):
    _xyz(f"bias_{_s}", COLUMNS[f"{_s}_x"].unit, f"estimated {_s} bias")
_xyz("scale_mag", "1", "estimated magnetometer scale error")
# events
register("event", STR, "", "event name at its instant (takeoff, touchdown, gate, ...), else null")
register("grip", BOOL, "", "hand is gripping (low-motion window)")
register("imu_saturated", BOOL, "", "IMU sample exceeded the sensor range")
register("gate_b_peak", F64, "1", "peak magnetic intensity at a gate crossing (normalised)")
register("gate_distance", F64, "m", "distance to the gate magnet at the crossing")
register("gate_t_peak", F64, "s", "time of the field peak at a gate crossing, between samples")
register("turn", STR, "", "turn direction at a gate (L or R)")
# other table kinds
register("route", STR, "", "route (track) identifier")
register("hold", I32, "1", "hold index on the route")
register("route_hold", I32, "1", "the hold's own index in its route file (bouldering dataset hold maps)")
# climbing (pf-holds)
register("hold_id", I32, "1", "hold number of the most likely particle cluster at a grip (-1: elsewhere)")
register("cluster_prob", F64, "1", "probability of the most likely particle cluster (pf-holds)")
register("gate", I32, "1", "gate number along the course")
# ski racing from GNSS (spline-smooth, dmc-attitude)
register(
    "course", F64, "rad", "azimuth of the horizontal velocity (spline tangent), clockwise from north, in (-pi, pi]"
)
register("spline_filled", BOOL, "", "position bridged by the spline across a GNSS data gap (no measured position near)")
register(
    "spline_segment", I32, "1", "track segment of the spline (0, 1, ...: split at GNSS gaps the data cannot bridge)"
)
register(
    "quest_loss", F64, "1", "Wahba loss of the DMC attitude at its optimum, 1 - lambda_max (0 = consistent vectors)"
)
register("dmc_singular", BOOL, "", "DMC attitude unreliable: specific force near free fall or parallel to the field")
for _a in "xyz":  # DESIGN names vx vy vz / ax ay az (the _xyz helper above registers v_x, a_x)
    register(f"v{_a}", F64, "m/s", f"velocity in the local frame, {_a} axis")
    register(f"a{_a}", F64, "m/s^2", f"kinematic acceleration in the local frame, {_a} axis")
    register(
        f"a{_a}_dmc", F64, "m/s^2", f"kinematic acceleration from the DMC attitude and specific force, local {_a} axis"
    )
# ski-jump truth/evaluation (simulate skijump, evaluate)
register("jump_length", F64, "m", "jump length along the landing profile from the knoll base F")
register("takeoff_speed_error", F64, "m/s", "take-off speed error, estimate minus truth")
register("phase", STR, "", "motion phase (inrun, flight, outrun, all) or a jump label in a summary")
register("stat", STR, "", "statistic of a summary row (rms, mean, max, error)")
register("samples", I64, "1", "number of samples behind a summary row")
register("rot_angle", F64, "rad", "rotation angle between estimated and true attitude")
register("takeoff_dt", F64, "s", "take-off timing error, estimate minus truth")
register("touchdown_dt", F64, "s", "touch-down timing error, estimate minus truth")
register("jump_length_error", F64, "m", "jump length error, estimate minus truth")
register("clearance", F64, "m", "height of the sensor above the hill profile, along the profile normal")
# video reference for the jump length (video-jumplength)
register("video", STR, "", "video file the row was read from")
register("video_fps", F64, "1/s", "frame rate of the video")
register("touchdown_frame", I32, "1", "first video frame (0-based) with both skis on the snow")
register("touchdown_time", F64, "s", "touch-down time after the video's first frame (sub-frame)")
register("touchdown_speed", F64, "m/s", "speed of the skis along the landing slope at the touch-down")
register("confidence", F64, "1", "probability that the video jump length is within 0.5 m (paper's reading accuracy)")
for _a in "xyz":
    register(
        f"mag_pred_{_a}",
        F64,
        "uT",
        f"magnetometer predicted by the smoother's estimate (skijump eq 50), body {_a} axis",
    )
# batch summary (python -m sportfusion.batch)
register("session", STR, "", "session name (its folder in a sessions folder)")
register("sport", STR, "", "sport of a session: skijump, skirace, gates, climbing")
register("status", STR, "", "outcome of a session's pipeline: ok or failed")
register("error", STR, "", "the error line of a failed session")
register("duration", F64, "s", "time span of a session's result table")
register("max_speed", F64, "m/s", "largest estimated speed in a session")
register("jumps", I64, "1", "number of jumps found in a session")
register("video_jump_length", F64, "m", "jump length read from the landing video (video-jumplength)")
register("pos_rms", F64, "m", "3-D RMS position error against the truth")
register("vel_rms", F64, "m/s", "3-D RMS velocity error against the truth")

# alpine racing with magnet gates (gate-anchor)
register("gate_anchor", BOOL, "", "the gate crossing was used as an anchor point (position update)")
register("turn_v_in", F64, "m/s", "speed at the turn switch before the gate (turn entrance)")
register("turn_v_out", F64, "m/s", "speed at the turn switch after the gate (turn exit)")
register("turn_d_in", F64, "m", "distance from the turn-entrance switch position to the gate")
register("turn_d_out", F64, "m", "distance from the turn-exit switch position to the gate")
register("turn_d_cross", F64, "m", "distance from the estimated position at the crossing to the gate")
register("turn_length", F64, "m", "3-D path length of the turn, switch to switch")
# run-vs-run comparison (compare-runs; skiracing-splines Figure 9), one row per run and common gate
register("run", STR, "", "run label (the first run of a comparison is the reference)")
register("crossing_t", F64, "s", "gate crossing time on the run's own clock (its t)")
register("crossing_source", STR, "", "how the crossing was found: event (gate event row) or closest (closest approach)")
register("acc_time", F64, "s", "time since the first common gate")
register("section_time", F64, "s", "time from the previous common gate (gate-to-gate)")
register("path_distance", F64, "m", "distance integrated along the trajectory since the first common gate")
register("section_distance", F64, "m", "distance along the trajectory from the previous common gate")
register("gate_speed", F64, "m/s", "instantaneous speed at the gate crossing")
register("turn_entry_speed", F64, "m/s", "speed at the turn switch before the gate (start of the turn)")
register("turn_exit_speed", F64, "m/s", "speed at the turn switch after the gate (end of the turn)")
register("turn_length", F64, "m", "path length of the turn, from switch to switch")
for _c in (
    "acc_time",
    "section_time",
    "path_distance",
    "section_distance",
    "gate_speed",
    "turn_entry_speed",
    "turn_exit_speed",
    "turn_length",
):
    register(f"{_c}_diff", F64, COLUMNS[_c].unit, f"{COLUMNS[_c].meaning}: this run minus the reference")
register("speed_diff", F64, "m/s", "speed at the same place along the course: this run minus the reference")
register("ref_jump_length", F64, "m", "reference jump length (e.g. read from a video, L_VR of skijump Table 7)")

#: Table kinds and the columns each must have.
REQUIRED: dict[str, tuple[str, ...]] = {
    "session": ("t",),
    "truth": ("t",),
    "jumps": (),
    "holds": ("route", "hold", "x", "y", "z"),
    "gates": ("gate",),
    "summary": (),
}
KINDS = tuple(REQUIRED)


#: Several IMUs on one athlete: the columns of the sensor on a body segment are ``<segment>__<column>``.
SEGMENT_SEPARATOR = "__"


def sensor_column(name: str) -> str:
    """The per-sensor column a (possibly segment-prefixed) name stands for: ``femur_r__acc_x`` -> ``acc_x``."""
    seg, sep, base = name.partition(SEGMENT_SEPARATOR)
    return base if sep and seg and base else name


def lookup(name: str) -> Column | None:
    """Return the registered column for ``name``, resolving ``std_``/``true_`` prefixes."""
    if name in COLUMNS:
        return COLUMNS[name]
    seg, sep, base_name = name.partition(SEGMENT_SEPARATOR)
    if sep and seg and base_name:  # a sensor on a body segment: femur_r__acc_x (docs/table-contract.md)
        base = lookup(base_name)
        if base is not None:
            return Column(name, base.type, base.unit, f"{seg} sensor: {base.meaning}")
    for prefix in ("true_", "std_"):
        if name.startswith(prefix):
            base = lookup(name[len(prefix) :])
            if base is not None:
                return Column(name, base.type, base.unit, f"{prefix[:-1]} of {base.name}")
    return None


def unit_of(name: str) -> str | None:
    """Unit of a column, or None for an unregistered column."""
    col = lookup(name)
    return None if col is None else col.unit


def check_types(table: pa.Table) -> None:
    """Raise :class:`InputError` naming the first known column whose type is wrong."""
    for field in table.schema:
        col = lookup(field.name)
        if col is None:
            continue
        ok = field.type == col.type
        if not ok and pa.types.is_integer(col.type) and pa.types.is_integer(field.type):
            ok = True  # any integer width is accepted for counters and codes
        if not ok:
            raise InputError(f"column '{field.name}' has type {field.type}, expected {col.type} ({col.meaning})")


def require_columns(table: pa.Table, names: tuple[str, ...] | list[str], what: str = "") -> None:
    """Raise :class:`InputError` listing the required columns that are missing."""
    missing = [n for n in names if n not in table.column_names]
    if missing:
        need = f" for {what}" if what else ""
        raise InputError(
            f"missing column(s) {', '.join(missing)}{need}; the table has {', '.join(table.column_names) or 'no columns'}"
        )


def to_arrow(name: str, values: object) -> pa.Array:
    """Build an Arrow array for a column, cast to its registered type.

    NaN in a float column becomes null (a sensor that did not sample).
    Unregistered names keep the type Arrow infers.
    """
    col = lookup(name)
    if isinstance(values, pa.ChunkedArray):
        values = values.combine_chunks()
    if isinstance(values, pa.Array):
        arr = values
    else:
        a = np.asarray(values)
        if a.dtype.kind == "f":
            arr = numeric_array(a, np.isnan(a))
        elif a.dtype.kind in "biu":
            arr = numeric_array(a)
        elif a.dtype.kind == "O":
            arr = pa.array(list(a), from_pandas=True)
        else:
            arr = pa.array(a)
    if col is not None and arr.type != col.type:
        if pa.types.is_floating(col.type) and arr.type == pa.null():
            arr = pa.nulls(len(arr), col.type)
        arr = arr.cast(col.type)
    return arr


def numeric_array(a: np.ndarray, null: np.ndarray | None = None) -> pa.Array:
    """An Arrow array over a 1-D bool, int, uint or float numpy array's buffer -- not copied where it is
    contiguous in native byte order (bools are bit-packed) -- with nulls where ``null`` is True.

    The buffers are built directly: ``pa.array`` on a numpy array imports numpy.ma (~15 ms of a command's
    CPU), with an all-False mask also costs ~4 ms per 60k values, and on a strided view (a state column
    ``x[:, k]``) is 40x slower than a contiguous copy.
    """
    a = np.asarray(a)
    if a.ndim != 1 or a.dtype.kind not in "biuf":
        return pa.array(a, mask=null)
    n_null = 0 if null is None else int(np.count_nonzero(null))
    valid = pa.py_buffer(np.packbits(~np.asarray(null, bool), bitorder="little")) if n_null else None
    if a.dtype.kind == "b":
        values = pa.py_buffer(np.packbits(a, bitorder="little"))
        return pa.Array.from_buffers(pa.bool_(), a.size, [valid, values], n_null)
    a = np.ascontiguousarray(a, dtype=a.dtype.newbyteorder("="))
    return pa.Array.from_buffers(pa.from_numpy_dtype(a.dtype), a.size, [valid, pa.py_buffer(a)], n_null)


def float_values(col: pa.ChunkedArray | pa.Array) -> tuple[np.ndarray, np.ndarray | None]:
    """A floating-point column as numpy without pyarrow.compute: ``(values, valid)``.

    ``values`` has the column's float dtype (NaN where null; read-only and not copied where the column
    is one chunk without nulls); ``valid`` is the validity mask, or None when there are no nulls.
    """
    arr = col if isinstance(col, pa.Array) else (col.chunk(0) if col.num_chunks == 1 else col.combine_chunks())
    if arr.null_count == 0:
        return arr.to_numpy(zero_copy_only=False), None
    if not pa.types.is_floating(arr.type):
        raise TypeError(f"float_values: {arr.type} with nulls")
    bits = np.unpackbits(np.frombuffer(arr.buffers()[0], np.uint8), bitorder="little")
    valid = bits[arr.offset : arr.offset + len(arr)].astype(bool)
    return arr.to_numpy(zero_copy_only=False), valid


def floats(table: pa.Table, name: str) -> np.ndarray:
    """A numeric column as a float64 numpy array (a writable copy), nulls as NaN."""
    return float_columns(table, (name,))[:, 0]


def float_columns(table: pa.Table, names: tuple[str, ...] | list[str]) -> np.ndarray:
    """Numeric columns side by side as a float64 (rows, len(names)) numpy array (writable), nulls as NaN.

    Each column is written once into the result (stacking per-column copies would copy twice: on 60k rows
    each copy is half a megabyte of fresh pages).
    """
    out = np.empty((table.num_rows, len(names)))
    for i, name in enumerate(names):
        col = table.column(name)
        if pa.types.is_floating(col.type) or (pa.types.is_integer(col.type) and col.null_count == 0):
            vals, valid = float_values(col)  # numpy only: no pyarrow.compute import (0.1 s of a command's start)
            out[:, i] = vals
            if valid is not None:
                out[~valid, i] = np.nan
        else:
            out[:, i] = np.asarray(col.cast(F64).fill_null(np.nan).to_numpy(), dtype=np.float64)
    return out


def flags(table: pa.Table, name: str) -> np.ndarray:
    """A boolean column as a numpy bool array (a copy), nulls as False, without pyarrow.compute.

    ``fill_null(False)`` would import pyarrow.compute, about 0.05-0.1 s of a short command's CPU time.
    """
    col = table.column(name)
    if not pa.types.is_boolean(col.type):
        raise TypeError(f"flags: column {name!r} is {col.type}, expected bool")
    arr = col.chunk(0) if col.num_chunks == 1 else col.combine_chunks()
    n = len(arr)
    if n == 0:
        return np.zeros(0, dtype=bool)
    validity, data = arr.buffers()[0], arr.buffers()[1]

    def bits(buf: pa.Buffer) -> np.ndarray:
        return np.unpackbits(np.frombuffer(buf, np.uint8), bitorder="little")[arr.offset : arr.offset + n].astype(bool)

    out = bits(data)
    if arr.null_count and validity is not None:
        out &= bits(validity)
    return out


# rts-smooth (skijump ERTS smoother): constraint residuals at the smoothed state, forward-only estimates
register("c_q", F64, "1", "quaternion norm constraint |q| - 1 at the smoothed state (skijump eq 51)")
register(
    "c_v_ir", F64, "m", "in-run vertical constraint z - z_IR(x) at the smoothed state (eq 32), null where inactive"
)
register("c_h_ir", F64, "m", "in-run lateral constraint y at the smoothed state (eq 33), null where inactive")
register(
    "c_v_la",
    F64,
    "m",
    "landing-area vertical constraint z - z_LA(x) at the smoothed state (eq 34), null where inactive",
)
for _n in ("x", "y", "z", "vx", "vy", "vz", "q0", "q1", "q2", "q3", "roll", "pitch", "yaw"):
    register(f"filt_{_n}", F64, COLUMNS[_n].unit, f"forward-only (EKF) estimate: {COLUMNS[_n].meaning}")
# jump-metrics (jumps table, one row per jump)
register("jump", I32, "1", "jump number in the session, from 1")
register("t_takeoff", F64, "s", "take-off time on the session clock")
register("t_touchdown", F64, "s", "touch-down time on the session clock")
register("takeoff_speed", F64, "m/s", "estimated speed at the take-off")
register("flight_time", F64, "s", "touch-down minus take-off time")
_xyz("touchdown", "m", "estimated sensor position at the touch-down, hill frame")
register("max_height", F64, "m", "largest vertical height of the sensor above the landing profile in flight")

# several IMUs on one athlete (body-model; docs/table-contract.md "Several IMUs"), frame J relative to the LJC
for _seg in ("pelvis", "torso", "head", "femur_r", "femur_l", "tibia_r", "tibia_l"):
    for _i in range(4):
        register(
            f"{_seg}__q{_i}",
            F64,
            "1",
            f"{_seg} segment orientation, q mapping the body frame J into it, component {_i}",
        )
for _p, _m in (
    ("com", "whole-body centre of mass"),
    ("hip_r", "right hip joint centre"),
    ("hip_l", "left hip joint centre"),
    ("knee_r", "right knee joint centre"),
    ("knee_l", "left knee joint centre"),
    ("ankle_r", "right ankle joint centre"),
    ("ankle_l", "left ankle joint centre"),
    ("sternum", "suprasternale (top of the sternum, cervical joint centre)"),
    ("head", "head centre of mass"),
    ("ski_r", "right ski-snow contact point (0.15 m distal of the ankle along the shank)"),
    ("ski_l", "left ski-snow contact point (0.15 m distal of the ankle along the shank)"),
    ("ljc", "lumbar joint centre"),
):
    _xyz(f"{_p}_rel", "m", f"{_m} relative to the lumbar joint centre, body frame J")
for _j in ("hip_r", "hip_l", "knee_r", "knee_l"):
    register(f"{_j}_flexion", F64, "rad", f"{_j.replace('_', ' ')} flexion angle (body model)")
_xyz("com", "m", "centre of mass in the local frame")
_xyz("ljc", "m", "lumbar joint centre in the local frame")
for _a in "xyz":
    register(f"com_v{_a}", F64, "m/s", f"centre-of-mass velocity in the local frame, {_a} axis")
