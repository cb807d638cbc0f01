"""``rts-smooth``: the ski-jump trajectory by the extended RTS smoother with hill constraints (skijump §3-4).

The model is :mod:`sportfusion.models.skijump_ekf` (eqs 22, 35-51); the smoother
is :func:`sportfusion.kalman.ekf_rts`.  Steps are the IMU samples; GNSS and
magnetometer samples update the step they fall on (or the nearest IMU step
within half a step when they were logged at their own times).

Constraint windows (eqs 32-34, 51), per jump of the session:

* ``c_q`` at every step;
* ``c_V,IR`` and ``c_H,IR`` from the start of the in-run to the take-off
  (inclusive).  The in-run starts where the athlete last sat at the gate:
  the run of GNSS speeds below ``rest_speed`` that ends last before the
  take-off (at most ``max_rest`` seconds of it), or the session's (segment's)
  start when there is none;
* ``c_V,LA`` from the touch-down to the end of the first rest after it (or the
  next in-run / the session's end).  The errata's touch-down note: the sensor
  settles onto the slope over ~0.2 s after the detected touch-down, so the
  constraint starts ``la_delay`` seconds after it and its weight (inverse
  variance) ramps linearly from 0 to full over ``la_ramp`` seconds.

Initial state (paper §4.1): position and NED velocity of the first GNSS fix,
attitude by QUEST (:func:`sportfusion.attitude.quest`) from the mean
accelerometer and magnetometer samples of the first ``init_window`` seconds
(gravity up and the reference field), parameters zero; ``P0``, ``Q``, ``R`` are
Tables 3-5 as 1-sigma values in :class:`SmootherConfig`, all overridable from a
TOML file (:func:`load_config`).  The reference field is the hill file's, else
the World Magnetic Model at the take-off edge and the session's date.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from scipy.ndimage import median_filter

from sportfusion import rotations, schema
from sportfusion.attitude import quest
from sportfusion.errors import InputError
from sportfusion.events import gnss_speed
from sportfusion.frames import Frame, gnss_local_columns
from sportfusion.hillfile import Hill
from sportfusion.kalman import CovarianceError, Measurement, ekf_rts
from sportfusion.magfield import reference_field
from sportfusion.meta import epoch_unix
from sportfusion.models import skijump_ekf as mdl
from sportfusion.models.skijump_kinematics import m_bo, m_no
from sportfusion.session import validate_time, with_columns

__all__ = [
    "SmootherConfig",
    "load_config",
    "SkiJumpInputs",
    "ProfileTable",
    "session_inputs",
    "constraint_windows",
    "smooth_inputs",
    "rts_smooth_table",
    "CONSTRAINT_COLUMNS",
    "session_events",
    "segments",
]

IMU_COLUMNS = ("gyr_x", "gyr_y", "gyr_z", "acc_x", "acc_y", "acc_z")
MAG_COLUMNS = ("mag_x", "mag_y", "mag_z")
VEL_COLUMNS = ("vel_n", "vel_e", "vel_d")
CONSTRAINT_COLUMNS = ("c_q", "c_v_ir", "c_h_ir", "c_v_la")


@dataclass
class SmootherConfig:
    """Tuning of the ski-jump smoother; defaults are the paper's Tables 3-5 as 1-sigma values.

    Units: positions [m], velocities [m/s], rates [rad/s], specific force
    [m/s^2], magnetic field [uT], times [s], quaternion and scale errors [1].
    """

    # Table 3: initial 1-sigma
    p0_pos: tuple[float, float, float] = (5.0, 5.0, 15.0)
    p0_vel: tuple[float, float, float] = (1.0, 1.0, 3.0)
    p0_quat: float = 0.1
    p0_bias_gyr: float = 0.0873
    p0_bias_acc: float = 0.2
    p0_bias_mag: float = 5.0
    p0_scale_mag: float = 0.1
    # Table 4: per-sample input noise 1-sigma
    q_gyr: float = 0.0175
    q_acc: float = 0.1
    # Table 5: measurement and constraint 1-sigma
    r_gnss_pos: tuple[float, float, float] = (3.0, 3.0, 5.0)
    r_gnss_vel: tuple[float, float, float] = (0.1, 0.1, 0.3)
    r_mag: float = 5.0
    r_c_q: float = 0.01
    r_c_v_ir: float = 0.1
    r_c_h_ir: float = 0.1
    r_c_v_la: float = 0.1
    # switches
    hill_constraints: bool = True
    use_gnss_vel: bool = True
    use_mag: bool = True
    # windows
    la_delay: float = 0.0
    la_ramp: float = 0.2
    rest_speed: float = 1.0
    max_rest: float = 60.0
    init_window: float = 0.1
    max_gap: float = 1.0
    passes: int = 5
    pass_tol_deg: float = 0.05
    pass_window: float = 120.0


def load_config(path: str | Path | None, base: SmootherConfig | None = None) -> SmootherConfig:
    """Read a TOML file of :class:`SmootherConfig` keys (top level or under ``[rts]``) over ``base``.

    Raises
    ------
    InputError
        Unreadable TOML, an unknown key or a value of the wrong shape.
    """
    cfg = base or SmootherConfig()
    if path is None:
        return cfg
    try:
        doc = tomllib.loads(Path(path).read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"config {path}: {exc}; expected a TOML file of smoother settings") from None
    doc = doc.get("rts", doc)
    known = {f.name: f for f in fields(SmootherConfig)}
    values = asdict(cfg)
    for key, val in doc.items():
        if key not in known:
            raise InputError(f"config {path}: unknown key {key!r}; expected one of {', '.join(known)}")
        old = values[key]
        if isinstance(old, bool):
            if not isinstance(val, bool):
                raise InputError(f"config {path}: {key} must be true or false")
        elif isinstance(old, tuple):
            if not (isinstance(val, list) and len(val) == len(old) and all(isinstance(v, int | float) for v in val)):
                raise InputError(f"config {path}: {key} must be a list of {len(old)} numbers")
            val = tuple(float(v) for v in val)
        elif isinstance(old, int):
            if not isinstance(val, int) or isinstance(val, bool) or val < 1:
                raise InputError(f"config {path}: {key} must be a positive integer")
        elif not isinstance(val, int | float) or isinstance(val, bool) or not math.isfinite(val) or val < 0:
            raise InputError(f"config {path}: {key} must be a non-negative number")
        values[key] = val
    return SmootherConfig(**values)


class ProfileTable:
    """A hill profile part tabulated for fast scalar look-ups: ``z(x)`` and ``dz/dx`` [m, 1].

    Linear interpolation on a ``step`` [m] grid (0.05 m: < 0.1 mm from the
    profile on radii above 10 m), continued by straight lines beyond the part.
    """

    def __init__(self, hill: Hill, part: str, margin: float = 300.0, step: float = 0.05) -> None:
        segs = hill.profile.segments(part)
        lo, hi = float(segs[0].x0), float(segs[-1].x1)
        self.x0 = lo - margin
        self.step = step
        xs = np.arange(self.x0, hi + margin + step, step)
        self.z = np.asarray(hill.profile.z(xs, part, extend=True), dtype=float)
        self.dz = np.asarray(hill.profile.dzdx(xs, part, extend=True), dtype=float)
        self.n = xs.size

    def __call__(self, x: float) -> tuple[float, float]:
        """``(z, dz/dx)`` at ``x`` [m]."""
        f = (x - self.x0) / self.step
        i = min(max(int(f), 0), self.n - 2)
        a = f - i
        return (1 - a) * self.z[i] + a * self.z[i + 1], (1 - a) * self.dz[i] + a * self.dz[i + 1]

    def many(self, x: np.ndarray) -> np.ndarray:
        """``z`` at many ``x`` [m]."""
        return np.interp(x, self.x0 + self.step * np.arange(self.n), self.z)


def profile_tables(hill: Hill) -> tuple[ProfileTable, ProfileTable]:
    """In-run and landing :class:`ProfileTable` of a hill, built once per hill object."""
    tabs = getattr(hill, "_rts_profile_tables", None)
    if tabs is None:
        tabs = (ProfileTable(hill, "inrun"), ProfileTable(hill, "landing"))
        hill._rts_profile_tables = tabs  # type: ignore[attr-defined]
    return tabs


@dataclass
class SkiJumpInputs:
    """Everything the smoother needs, per IMU step (NaN where a sensor did not sample)."""

    t: np.ndarray  # (n,) step times [s]
    rows: np.ndarray  # (n,) table row of each step
    u: np.ndarray  # (n, 6) gyro [rad/s], acc [m/s^2]
    pos: np.ndarray  # (n, 3) GNSS position, hill frame [m]
    vel: np.ndarray  # (n, 3) GNSS velocity NED [m/s]
    mag: np.ndarray  # (n, 3) magnetometer [uT]
    g0: float
    m_o: np.ndarray  # (3,) reference field NED [uT]
    azimuth_deg: float
    jumps: list[tuple[float, float]]  # (takeoff, touchdown) [s]
    inrun: np.ndarray  # (n,) bool: c_V,IR and c_H,IR active
    landing: np.ndarray  # (n,) weight 0..1 of c_V,LA


def _floats(table: pa.Table, names: tuple[str, ...]) -> np.ndarray:
    return np.stack([schema.floats(table, c) for c in names], axis=-1)


def _to_steps(t_rows: np.ndarray, rows_ok: np.ndarray, values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Put row samples onto the nearest IMU step (within half a step); (n, k) with NaN elsewhere."""
    out = np.full((t.size, values.shape[1]), np.nan)
    ts, vs = t_rows[rows_ok], values[rows_ok]
    if ts.size == 0:
        return out
    i = np.clip(np.searchsorted(t, ts), 1, max(t.size - 1, 1))
    i = np.where((i > 0) & (np.abs(t[i - 1] - ts) <= np.abs(t[i] - ts)), i - 1, i)
    i = np.minimum(i, t.size - 1)
    half = 0.5 * np.median(np.diff(t)) if t.size > 1 else 0.0
    keep = np.abs(t[i] - ts) <= half + 1e-9
    out[i[keep]] = vs[keep]
    return out


def session_events(
    table: pa.Table, takeoff: list[float] | None, touchdown: list[float] | None
) -> list[tuple[float, float]]:
    """(take-off, touch-down) pairs [s]: the given lists, else the ``event`` column's rows (validated)."""
    if takeoff is not None or touchdown is not None:
        tos, tds = sorted(takeoff or []), sorted(touchdown or [])
    elif "event" in table.column_names:
        t = schema.floats(table, "t")
        ev = np.asarray(table.column("event").to_pylist(), dtype=object)
        tos = sorted(t[ev == "takeoff"].tolist())
        tds = sorted(t[ev == "touchdown"].tolist())
    else:
        tos, tds = [], []
    if len(tos) != len(tds):
        raise InputError(
            f"{len(tos)} take-off(s) but {len(tds)} touch-down(s); expected one touch-down after each take-off"
        )
    jumps = list(zip(tos, tds, strict=True))
    for k, (a, b) in enumerate(jumps):
        nxt = jumps[k + 1][0] if k + 1 < len(jumps) else math.inf
        if not a < b < nxt:
            raise InputError(
                f"take-off at {a:.3f} s and touch-down at {b:.3f} s do not alternate; "
                "expected each touch-down after its take-off and before the next take-off"
            )
    return jumps


def constraint_windows(
    t: np.ndarray,
    speed_t: np.ndarray,
    speed: np.ndarray,
    jumps: list[tuple[float, float]],
    cfg: SmootherConfig,
) -> tuple[np.ndarray, np.ndarray]:
    """Masks of the hill constraints on the step times ``t`` (see the module text).

    Returns
    -------
    inrun : ndarray bool (n,)
        ``c_V,IR`` and ``c_H,IR`` active.
    landing : ndarray float (n,)
        Weight of ``c_V,LA`` in [0, 1] (0: inactive).
    """
    inrun = np.zeros(t.size, bool)
    landing = np.zeros(t.size, float)
    # a running median over 9 GNSS epochs keeps single noisy velocities from splitting a rest
    slow = median_filter(speed, size=9, mode="nearest") < cfg.rest_speed if speed.size else speed < cfg.rest_speed
    seg_start = t[0]
    for k, (t_to, t_td) in enumerate(jumps):
        # in-run: back from the take-off to the last rest
        before = (speed_t < t_to) & (speed_t >= seg_start)
        idx = np.flatnonzero(before & slow)
        start = seg_start
        if idx.size:
            i = idx[-1]
            while (
                i > 0
                and slow[i - 1]
                and speed_t[i - 1] >= seg_start
                and speed_t[idx[-1]] - speed_t[i - 1] <= cfg.max_rest
                and speed_t[i] - speed_t[i - 1] <= cfg.max_gap
            ):
                i -= 1
            start = max(speed_t[i], seg_start)
        inrun |= (t >= start) & (t <= t_to)
        # landing: from the touch-down to the end of the first rest after it
        nxt = jumps[k + 1][0] if k + 1 < len(jumps) else math.inf
        after = np.flatnonzero((speed_t > t_td + 1.0) & (speed_t < nxt) & slow)
        end = t[-1] if math.isinf(nxt) else nxt
        if after.size:
            i = after[0]
            t_stop = speed_t[i]
            while (
                i + 1 < speed_t.size
                and slow[i + 1]
                and speed_t[i + 1] - t_stop <= cfg.max_rest
                and speed_t[i + 1] - speed_t[i] <= cfg.max_gap
                and speed_t[i + 1] < nxt
            ):
                i += 1
            if i + 1 < speed_t.size and speed_t[i + 1] < nxt:  # moving again, or a gap, before the next jump
                end = speed_t[i]
        t0 = t_td + cfg.la_delay
        w = np.clip((t - t0) / cfg.la_ramp, 0.0, 1.0) if cfg.la_ramp > 0 else (t >= t0).astype(float)
        w[t < t0] = 0.0
        w[t > end] = 0.0
        landing = np.maximum(landing, w)
        seg_start = end
    return inrun, landing


def _hill_frame(table: pa.Table, meta: dict[str, Any], hill: Hill) -> tuple[Frame, np.ndarray]:
    """The hill frame and the GNSS positions in it (from lat/lon/h, else gnss_x.. in the table's frame)."""
    names = set(table.column_names)
    frame = hill.frame() if hill.has_origin else (Frame.from_meta(meta["frame"]) if meta.get("frame") else None)
    if {"lat", "lon", "h"} <= names and frame is not None:
        cols = gnss_local_columns(table, frame)
        return frame, np.stack([cols[c] for c in ("gnss_x", "gnss_y", "gnss_z")], axis=-1)
    if {"gnss_x", "gnss_y", "gnss_z"} <= names:
        if not meta.get("frame"):
            raise InputError("the table has gnss_x/y/z but no frame in its metadata; expected gps2hill output")
        own = Frame.from_meta(meta["frame"])
        if frame is not None and (
            abs(own.azimuth_deg - frame.azimuth_deg) > 1e-6
            or max(abs(a - b) for a, b in zip(own.origin[:2], frame.origin[:2], strict=True)) > 1e-7
            or abs(own.h - frame.h) > 1e-3
        ):
            raise InputError(
                f"gnss_x/y/z are in frame origin {list(own.origin)}, azimuth {own.azimuth_deg:g} deg, not the hill's "
                f"{list(frame.origin)}, {frame.azimuth_deg:g} deg; expected gps2hill with the same --hill"
            )
        return own, _floats(table, ("gnss_x", "gnss_y", "gnss_z"))
    if frame is None:
        raise InputError("the hill has no take-off edge position and the table no frame; expected gps2hill output")
    raise InputError(
        "missing column(s) gnss_x, gnss_y, gnss_z (or lat, lon, h); expected GNSS positions (ingest + gps2hill)"
    )


def session_inputs(
    table: pa.Table,
    meta: dict[str, Any],
    hill: Hill,
    cfg: SmootherConfig,
    takeoff: list[float] | None = None,
    touchdown: list[float] | None = None,
) -> tuple[SkiJumpInputs, Frame]:
    """Gather IMU, GNSS, magnetometer, events and constraint windows of a session (raises InputError)."""
    t_rows = validate_time(table)
    missing = [c for c in IMU_COLUMNS if c not in table.column_names]
    if missing:
        raise InputError(f"missing column(s) {', '.join(missing)}; expected IMU data (gyroscope and accelerometer)")
    imu = _floats(table, IMU_COLUMNS)
    ok = np.isfinite(imu).all(axis=1)
    if ok.sum() < 10:
        raise InputError("the IMU columns hold fewer than 10 complete samples; expected a recorded IMU")
    rows = np.flatnonzero(ok)
    t = t_rows[rows]
    u = imu[rows]
    frame, pos_rows = _hill_frame(table, meta, hill)
    pos_ok = np.isfinite(pos_rows).all(axis=1)
    if not pos_ok.any():
        raise InputError("no GNSS position in the session; expected GNSS fixes (gnss_x/y/z or lat/lon/h)")
    _check_hill_near(pos_rows[pos_ok], hill)
    pos = _to_steps(t_rows, pos_ok, pos_rows, t)
    if np.isfinite(pos[:, 0]).sum() == 0:
        raise InputError("no GNSS fix falls within the IMU recording; expected overlapping GNSS and IMU data")
    if set(VEL_COLUMNS) <= set(table.column_names):
        v_rows = _floats(table, VEL_COLUMNS)
        vel = _to_steps(t_rows, np.isfinite(v_rows).all(axis=1), v_rows, t)
    else:
        vel = np.full((t.size, 3), np.nan)
    if set(MAG_COLUMNS) <= set(table.column_names):
        m_rows = _floats(table, MAG_COLUMNS)
        mag = _to_steps(t_rows, np.isfinite(m_rows).all(axis=1), m_rows, t)
    else:
        mag = np.full((t.size, 3), np.nan)
    jumps = session_events(table, takeoff, touchdown)
    for a, b in jumps:
        for name, te in (("take-off", a), ("touch-down", b)):
            if not t[0] <= te <= t[-1]:
                raise InputError(
                    f"{name} at {te:.3f} s is outside the IMU data ({t[0]:.3f}-{t[-1]:.3f} s); "
                    "expected events within the session"
                )
    field = hill.mag_field()
    if field is None:
        epoch = epoch_unix(meta)
        field = reference_field(frame.lat, frame.lon, frame.h, (epoch or 0.0) + float(t[0]))
    try:
        st, sv = gnss_speed(table)
    except InputError:
        st, sv = np.zeros(0), np.zeros(0)
    inrun, landing = constraint_windows(t, st, sv, jumps, cfg)
    inp = SkiJumpInputs(
        t=t,
        rows=rows,
        u=u,
        pos=pos,
        vel=vel,
        mag=mag,
        g0=hill.gravity(),
        m_o=np.asarray(field, dtype=float),
        azimuth_deg=frame.azimuth_deg,
        jumps=jumps,
        inrun=inrun,
        landing=landing,
    )
    return inp, frame


def _check_hill_near(pos: np.ndarray, hill: Hill, limit: float = 1000.0) -> None:
    """InputError when no GNSS fix is within ``limit`` [m] of the hill's profile (x range, |y|)."""
    segs = hill.profile.segments("inrun") + hill.profile.segments("landing")
    lo, hi = min(s.x0 for s in segs), max(s.x1 for s in segs)
    dx = np.maximum(np.maximum(lo - pos[:, 0], pos[:, 0] - hi), 0.0)
    d = np.hypot(dx, pos[:, 1])
    if d.min() > limit:
        raise InputError(
            f"the GNSS track is {d.min() / 1000:.1f} km from the hill {hill.name!r} (nearest fix); "
            "expected a session recorded on that hill (check --hill and the hill's site)"
        )


def initial_state(inp: SkiJumpInputs, cfg: SmootherConfig) -> tuple[np.ndarray, np.ndarray]:
    """Paper §4.1: first GNSS fix, QUEST attitude from the first samples, zero parameters; Table 3 P0."""
    x0 = np.zeros(mdl.N)
    ip = int(np.flatnonzero(np.isfinite(inp.pos[:, 0]))[0])
    x0[0:3] = inp.pos[ip]
    w = inp.t <= inp.t[0] + cfg.init_window
    acc = inp.u[w, 3:6].mean(axis=0)
    mags = inp.mag[w & np.isfinite(inp.mag[:, 0])]
    if mags.shape[0] == 0 and np.isfinite(inp.mag[:, 0]).any():
        mags = inp.mag[np.isfinite(inp.mag[:, 0])][:1]
    if mags.shape[0]:
        body = np.stack([acc, mags.mean(axis=0)])[None]
        ref = np.stack([np.array([0.0, 0.0, -1.0]), inp.m_o])
        q, _ = quest(body, ref, np.array([0.9, 0.1]))
        q = q[0]
    else:  # no magnetometer: level the attitude, heading along the hill axis
        gx, gy, gz = -acc / np.linalg.norm(acc)
        roll, pitch = math.atan2(gy, gz), math.atan2(-gx, math.hypot(gy, gz))
        q = rotations.quat_from_euler(np.array(roll), np.array(pitch), np.array(math.radians(inp.azimuth_deg)))
    x0[6:10] = q
    iv = np.flatnonzero(np.isfinite(inp.vel[:, 0]))
    if iv.size:
        x0[3:6] = m_bo(q) @ inp.vel[iv[0]]
    p = np.concatenate(
        [
            cfg.p0_pos,
            cfg.p0_vel,
            [cfg.p0_quat] * 4,
            [cfg.p0_bias_gyr] * 3,
            [cfg.p0_bias_acc] * 3,
            [cfg.p0_bias_mag] * 3,
            [cfg.p0_scale_mag] * 3,
        ]
    )
    return x0, np.diag(np.asarray(p, float) ** 2)


def _model_callables(inp: SkiJumpInputs, cfg: SmootherConfig, hill: Hill | None):
    """propagate/measure for :func:`ekf_rts` (plain numpy, the reference path)."""
    mno = m_no(math.radians(inp.azimuth_deg))
    qd = np.array([cfg.q_gyr] * 3 + [cfg.q_acc] * 3) ** 2
    dt = np.diff(inp.t)
    R_pos = np.diag(np.asarray(cfg.r_gnss_pos) ** 2)
    R_vel = np.diag(np.asarray(cfg.r_gnss_vel) ** 2)
    R_mag = np.eye(3) * cfg.r_mag**2
    has_pos = np.isfinite(inp.pos[:, 0])
    has_vel = np.isfinite(inp.vel[:, 0]) & cfg.use_gnss_vel
    has_mag = np.isfinite(inp.mag[:, 0]) & cfg.use_mag
    use_hill = cfg.hill_constraints and hill is not None
    ir, la = profile_tables(hill) if use_hill else (None, None)
    H_pos = np.zeros((3, mdl.N))
    H_pos[:, 0:3] = np.eye(3)
    H_y = np.zeros((1, mdl.N))
    H_y[0, 1] = 1.0

    def propagate(k: int, x: np.ndarray):
        u0, u1 = inp.u[k], inp.u[k + 1]
        xn = mdl.rk4_aug(x, u0, u1, dt[k], inp.g0, mno)
        A = mdl.jac_a(x, u0, inp.g0, mno)
        Phi, Qd = mdl.discrete(A, mdl.jac_f(x), qd, dt[k])
        return xn, Phi, Qd

    def measure(k: int, x: np.ndarray) -> list[Measurement]:
        out = [Measurement(np.array([-mdl.c_q(x)]), mdl.C_q(x), np.array([[cfg.r_c_q**2]]), "c_q")]
        if has_pos[k]:
            out.append(Measurement(inp.pos[k] - x[0:3], H_pos, R_pos, "gnss_pos"))
        if has_vel[k]:
            out.append(Measurement(inp.vel[k] - mdl.h_vel(x), mdl.H_vel(x), R_vel, "gnss_vel"))
        if has_mag[k]:
            out.append(Measurement(inp.mag[k] - mdl.h_mag(x, inp.m_o), mdl.H_mag(x, inp.m_o), R_mag, "mag"))
        if use_hill:
            if inp.inrun[k]:
                z, dz = ir(x[0])
                H = np.zeros((1, mdl.N))
                H[0, 0], H[0, 2] = -dz, 1.0
                out.append(Measurement(np.array([z - x[2]]), H, np.array([[cfg.r_c_v_ir**2]]), "c_v_ir"))
                out.append(Measurement(np.array([-x[1]]), H_y, np.array([[cfg.r_c_h_ir**2]]), "c_h_ir"))
            wl = inp.landing[k]
            if wl > 0:
                z, dz = la(x[0])
                H = np.zeros((1, mdl.N))
                H[0, 0], H[0, 2] = -dz, 1.0
                out.append(Measurement(np.array([z - x[2]]), H, np.array([[cfg.r_c_v_la**2 / wl]]), "c_v_la"))
        return out

    return propagate, measure


def segments(t: np.ndarray, max_gap: float) -> list[tuple[int, int]]:
    """Index ranges ``[a, b)`` of the IMU steps split where the sampling stops for more than ``max_gap`` [s]."""
    cut = np.flatnonzero(np.diff(t) > max_gap) + 1
    edges = [0, *cut.tolist(), t.size]
    return [(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def _slice(inp: SkiJumpInputs, a: int, b: int) -> SkiJumpInputs:
    sl = slice(a, b)
    return SkiJumpInputs(
        t=inp.t[sl],
        rows=inp.rows[sl],
        u=inp.u[sl],
        pos=inp.pos[sl],
        vel=inp.vel[sl],
        mag=inp.mag[sl],
        g0=inp.g0,
        m_o=inp.m_o,
        azimuth_deg=inp.azimuth_deg,
        jumps=inp.jumps,
        inrun=inp.inrun[sl],
        landing=inp.landing[sl],
    )


@dataclass
class Smoothed:
    """Smoother output over all IMU steps (either engine).

    ``cov(idx)`` returns the smoothed covariances (n, k, k) over the state indices ``idx``.
    """

    x_filt: np.ndarray
    x_smooth: np.ndarray
    cov: Callable[[np.ndarray], np.ndarray]
    residuals: dict[str, np.ndarray]
    passes: list[int]


def _fast_engine():  # noqa: ANN202
    try:
        from sportfusion.kalman import skijump_fast
    except ImportError:  # numba missing: the numpy reference path
        return None
    return skijump_fast


def _run_fast(fast, seg: SkiJumpInputs, cfg: SmootherConfig, hill: Hill | None, x0: np.ndarray, P0: np.ndarray):  # noqa: ANN001, ANN202
    use_hill = cfg.hill_constraints and hill is not None
    ir, la = profile_tables(hill) if use_hill else (None, None)
    empty = np.zeros(2)
    try:
        out = fast.ski_ekf_rts(
            seg.t,
            seg.u,
            seg.pos,
            seg.vel,
            seg.mag,
            seg.inrun,
            seg.landing,
            x0,
            P0,
            float(seg.g0),
            m_no(math.radians(seg.azimuth_deg)),
            seg.m_o,
            np.array([cfg.q_gyr] * 3 + [cfg.q_acc] * 3) ** 2,
            np.asarray(cfg.r_gnss_pos, float) ** 2,
            np.asarray(cfg.r_gnss_vel, float) ** 2,
            float(cfg.r_mag**2),
            float(cfg.r_c_q**2),
            float(cfg.r_c_v_ir**2),
            float(cfg.r_c_h_ir**2),
            float(cfg.r_c_v_la**2),
            ir.x0 if ir else 0.0,
            ir.step if ir else 1.0,
            ir.z if ir else empty,
            ir.dz if ir else empty,
            la.x0 if la else 0.0,
            la.step if la else 1.0,
            la.z if la else empty,
            la.dz if la else empty,
            use_hill,
            bool(cfg.use_gnss_vel),
            bool(cfg.use_mag),
        )
    except np.linalg.LinAlgError:
        raise CovarianceError("a predicted covariance is not positive definite (backward pass)") from None
    xf, xs, Pp, resid, fail, phase = out
    if fail >= 0:
        what = ("update", "prediction", "backward pass")[phase]
        raise CovarianceError(f"covariance not positive definite at step {fail} (t = {seg.t[fail]:.3f} s) ({what})")
    res, i = {}, 0
    for name, w in fast.RESIDUALS:
        res[name] = resid[:, i : i + w]
        i += w
    return xf, xs, Pp, res


def smooth_inputs(
    inp: SkiJumpInputs,
    hill: Hill | None,
    cfg: SmootherConfig,
    progress: Callable[[int], object] | None = None,
    engine: str = "auto",
) -> Smoothed:
    """Run the EKF + RTS smoother over the prepared inputs (raises InputError when it diverges).

    Parameters
    ----------
    engine : {"auto", "numba", "numpy"}
        ``numpy``: :func:`sportfusion.kalman.ekf_rts` with the model callables (the
        reference); ``numba``: the compiled loop of
        :mod:`sportfusion.kalman.skijump_fast` (same equations, packed
        covariances); ``auto``: numba when it is installed.

    A session whose IMU stops for more than ``cfg.max_gap`` seconds is smoothed in
    independent segments (each initialised from its own first samples); the
    results are concatenated.  With ``cfg.passes > 1`` the smoother is re-run from
    the smoothed initial state (mean only, same ``P0``) until the initial attitude
    changes by less than ``cfg.pass_tol_deg`` [deg] or ``passes`` runs are done: this
    re-linearises the start, where an attitude error of tens of degrees (gyro
    biases of the Table 3 prior over a rest of seconds) leaves the EKF's linear
    regime.  These passes cover the first ``cfg.pass_window`` seconds; one final
    pass then covers the whole segment (a single pass when the window covers it).
    """
    fast = _fast_engine() if engine in ("auto", "numba") else None
    if engine == "numba" and fast is None:
        raise InputError("engine numba requested but numba is not installed; expected pip install numba")
    xfs, xss, covs, resids, npass = [], [], [], [], []
    for a, b in segments(inp.t, cfg.max_gap):
        seg = _slice(inp, a, b)
        if b - a < 2 or not np.isfinite(seg.pos[:, 0]).any():
            raise InputError(
                f"the IMU segment {seg.t[0]:.2f}-{seg.t[-1]:.2f} s has no GNSS fix (or a single sample); "
                "expected GNSS during every recorded stretch"
            )
        x0, P0 = initial_state(seg, cfg)
        nw = int(np.searchsorted(seg.t, seg.t[0] + cfg.pass_window, side="right"))
        nw = max(min(nw, seg.t.size), 2)

        def run(sub: SkiJumpInputs, x0: np.ndarray, P0: np.ndarray = P0):  # noqa: ANN202
            if fast is None:
                propagate, measure = _model_callables(sub, cfg, hill)
                r = ekf_rts(x0, P0, sub.t.size, propagate, measure, progress=progress, t=sub.t)
                return r.x_filt, r.x_smooth, r.P_smooth, r.residuals
            out = _run_fast(fast, sub, cfg, hill, x0, P0)
            if progress is not None:
                for k in range(2 * sub.t.size - 1):
                    progress(k)
            return out

        try:
            # re-linearisation passes over the first pass_window seconds, then the whole segment
            win = seg if nw == seg.t.size else _slice(seg, 0, nw)
            done, it, change = None, 0, math.inf
            for it in range(max(cfg.passes, 1)):
                done = run(win, x0)
                q_old = x0[6:10] / np.linalg.norm(x0[6:10])
                x0 = done[1][0].copy()
                x0[6:10] /= np.linalg.norm(x0[6:10])
                change = float(np.degrees(rotations.quat_angle(q_old, x0[6:10])))
                if it > 0 and change < cfg.pass_tol_deg:
                    break
            if win is not seg:
                done = run(seg, x0)
                it += 1
            xf, xs, P, res = done
        except CovarianceError as exc:
            raise InputError(f"the smoother failed: {exc}") from None
        xfs.append(xf)
        xss.append(xs)
        covs.append(P)
        resids.append(res)
        npass.append(it + 1)

    def cov(idx: np.ndarray) -> np.ndarray:
        idx = np.asarray(idx)
        if fast is None:
            return np.concatenate([P[:, idx][:, :, idx] for P in covs])
        return np.concatenate([fast.unpack_many(P, idx) for P in covs])

    names = {k: v.shape[1] for r in resids for k, v in r.items()}
    out = {k: np.full((inp.t.size, m), np.nan) for k, m in names.items()}
    i = 0
    for xf, r in zip(xfs, resids, strict=True):
        for k, v in r.items():
            out[k][i : i + xf.shape[0]] = v
        i += xf.shape[0]
    return Smoothed(np.concatenate(xfs), np.concatenate(xss), cov, out, npass)


def _interp_rows(t_rows: np.ndarray, t: np.ndarray, values: np.ndarray, max_gap: float) -> np.ndarray:
    """Values at the steps -> every table row (linear in time; NaN outside the IMU segments)."""
    out = np.full((t_rows.size, values.shape[1]), np.nan)
    for a, b in segments(t, max_gap):
        inside = (t_rows >= t[a]) & (t_rows <= t[b - 1])
        for j in range(values.shape[1]):
            out[inside, j] = np.interp(t_rows[inside], t[a:b], values[a:b, j])
    return out


def _estimate_columns(
    x: np.ndarray, cov: Callable[[np.ndarray], np.ndarray] | None, inp: SkiJumpInputs, prefix: str = ""
) -> dict[str, np.ndarray]:
    """Named estimate columns (at the steps) from states (n, 22) and covariances (n, 22, 22)."""
    mno = m_no(math.radians(inp.azimuth_deg))
    q = x[:, 6:10]
    qn = q / np.linalg.norm(q, axis=1, keepdims=True)
    M = m_bo(q)
    v_o = np.einsum("nji,nj->ni", M, x[:, 3:6])
    v_n = rotations.ned_to_local(v_o, inp.azimuth_deg)  # the one NED -> hill-frame rotation
    roll, pitch, yaw = rotations.euler_from_quat(qn)
    cols: dict[str, np.ndarray] = {}
    for k, a in enumerate("xyz"):
        cols[prefix + a] = x[:, k]
    for k, a in enumerate("xyz"):
        cols[f"{prefix}v{a}"] = v_n[:, k]
    for k in range(4):
        cols[f"{prefix}q{k}"] = qn[:, k]
    cols[prefix + "roll"], cols[prefix + "pitch"], cols[prefix + "yaw"] = roll, pitch, yaw
    if prefix:
        return cols
    for name, sl in (("bias_gyr", mdl.I_BG), ("bias_acc", mdl.I_BA), ("bias_mag", mdl.I_BM), ("scale_mag", mdl.I_SM)):
        for k, a in enumerate("xyz"):
            cols[f"{name}_{a}"] = x[:, sl][:, k]
    # eq 50: the magnetometer the estimate predicts (the paper's Figure 12 sets it beside the measurement)
    mag = (1.0 + x[:, mdl.I_SM]) * (M @ inp.m_o) + x[:, mdl.I_BM]
    for k, a in enumerate("xyz"):
        cols[f"mag_pred_{a}"] = mag[:, k]
    if cov is None:
        return cols
    d = np.sqrt(np.maximum(np.stack([cov(np.array([i]))[:, 0, 0] for i in range(mdl.N)], axis=-1), 0.0))
    P = np.zeros((x.shape[0], 10, 10))
    P[:, 3:10, 3:10] = cov(np.arange(3, 10))
    for k, a in enumerate("xyz"):
        cols[f"std_{a}"] = d[:, k]
    # hill-frame velocity: J = M_NO [M^T, d(M^T v)/dq] over (v_B, q)
    dm = mdl.dm_dq(q)  # (n, 4, 3, 3)
    Jv = np.einsum("ij,nkj->nik", mno, M)  # (n,3,3)  M_NO M^T
    Jq = np.einsum("ab,nkib,ni->nak", mno, dm, x[:, 3:6])  # (n,3,4)  M_NO dM_k^T v
    J = np.concatenate([Jv, Jq], axis=2)
    Cv = np.einsum("nij,njk,nlk->nil", J, P[:, 3:10, 3:10], J)
    sv = np.sqrt(np.maximum(np.diagonal(Cv, axis1=1, axis2=2), 0.0))
    for k, a in enumerate("xyz"):
        cols[f"std_v{a}"] = sv[:, k]
    for k in range(4):
        cols[f"std_q{k}"] = d[:, 6 + k]
    # Euler angles: numerical Jacobian w.r.t. q (of the normalised quaternion)
    eps = 1e-7
    e0 = np.stack((roll, pitch, yaw), axis=-1)
    Je = np.empty((q.shape[0], 3, 4))
    for k in range(4):
        qp = q.copy()
        qp[:, k] += eps
        qp /= np.linalg.norm(qp, axis=1, keepdims=True)
        e = np.stack(rotations.euler_from_quat(qp), axis=-1)
        de = e - e0
        de = (de + np.pi) % (2 * np.pi) - np.pi
        Je[:, :, k] = de / eps
    Ce = np.einsum("nij,njk,nlk->nil", Je, P[:, 6:10, 6:10], Je)
    se = np.sqrt(np.maximum(np.diagonal(Ce, axis1=1, axis2=2), 0.0))
    for k, a in enumerate(("roll", "pitch", "yaw")):
        cols[f"std_{a}"] = se[:, k]
    for name, sl in (("bias_gyr", mdl.I_BG), ("bias_acc", mdl.I_BA), ("bias_mag", mdl.I_BM), ("scale_mag", mdl.I_SM)):
        for k, a in enumerate("xyz"):
            cols[f"std_{name}_{a}"] = d[:, sl][:, k]
    return cols


def constraint_residuals(x: np.ndarray, inp: SkiJumpInputs, hill: Hill | None) -> dict[str, np.ndarray]:
    """Constraint values (eq 51) at the states ``x`` (n, 22): NaN where a hill constraint is inactive."""
    out = {"c_q": np.linalg.norm(x[:, 6:10], axis=1) - 1.0}
    nan = np.full(x.shape[0], np.nan)
    if hill is None:
        out.update(c_v_ir=nan, c_h_ir=nan.copy(), c_v_la=nan.copy())
        return out
    ir, la = profile_tables(hill)
    out["c_v_ir"] = np.where(inp.inrun, x[:, 2] - ir.many(x[:, 0]), np.nan)
    out["c_h_ir"] = np.where(inp.inrun, x[:, 1], np.nan)
    out["c_v_la"] = np.where(inp.landing > 0, x[:, 2] - la.many(x[:, 0]), np.nan)
    return out


def rts_smooth_table(
    table: pa.Table,
    meta: dict[str, Any],
    hill: Hill,
    cfg: SmootherConfig | None = None,
    *,
    takeoff: list[float] | None = None,
    touchdown: list[float] | None = None,
    filtered: bool = False,
    progress: Callable[[int], object] | None = None,
    on_start: Callable[[int], object] | None = None,
    engine: str = "auto",
) -> tuple[pa.Table, dict[str, Any], str]:
    """``rts-smooth`` on a session table: every input column plus the estimate columns.

    Parameters
    ----------
    table, meta : session and its metadata
    hill : the hill (profile for the constraints, take-off edge for the frame)
    cfg : SmootherConfig, optional
    takeoff, touchdown : lists of times [s], optional
        Events; default the ``event`` column's ``takeoff``/``touchdown`` rows.
    filtered : bool
        Also write the forward-only (EKF) estimates as ``filt_`` columns.
    progress : callable(k), optional
        Called once per forward and backward step.
    on_start : callable(total), optional
        Called with the number of progress calls to expect.

    Returns
    -------
    table, meta, message
    """
    cfg = cfg or SmootherConfig()
    inp, frame = session_inputs(table, meta, hill, cfg, takeoff, touchdown)
    if on_start is not None:
        on_start((2 * inp.t.size - 1) * max(cfg.passes, 1))
    res = smooth_inputs(inp, hill, cfg, progress, engine)
    t_rows = schema.floats(table, "t")
    cols = _estimate_columns(res.x_smooth, res.cov, inp)
    cols.update(constraint_residuals(res.x_smooth, inp, hill if cfg.hill_constraints else None))
    if filtered:
        cols.update(_estimate_columns(res.x_filt, None, inp, prefix="filt_"))
    names = list(cols)
    vals = _interp_rows(t_rows, inp.t, np.stack([cols[n] for n in names], axis=-1), cfg.max_gap)
    out_cols = {n: vals[:, j] for j, n in enumerate(names)}
    # quaternions interpolated linearly: renormalise
    for pre in ("", "filt_") if filtered else ("",):
        qs = np.stack([out_cols[f"{pre}q{k}"] for k in range(4)], axis=-1)
        qs /= np.linalg.norm(qs, axis=1, keepdims=True)
        for k in range(4):
            out_cols[f"{pre}q{k}"] = qs[:, k]
    out = with_columns(table, out_cols)
    new_meta = dict(meta)
    new_meta["frame"] = frame.to_meta()
    new_meta["hill"] = hill.meta()
    new_meta["rts"] = {
        "config": {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(cfg).items()},
        "jumps": [{"takeoff": a, "touchdown": b} for a, b in inp.jumps],
        "gravity": inp.g0,
        "passes": res.passes,
        "mag_field_ned": inp.m_o.tolist(),
        "residual_rms": {k: float(np.sqrt(np.nanmean(v**2))) for k, v in res.residuals.items() if np.isfinite(v).any()},
    }
    msg = (
        f"{inp.t.size} IMU steps, {int(np.isfinite(inp.pos[:, 0]).sum())} GNSS fixes, {len(inp.jumps)} jump(s); "
        f"hill constraints {'on' if cfg.hill_constraints else 'off'}"
    )
    return out, new_meta, msg
