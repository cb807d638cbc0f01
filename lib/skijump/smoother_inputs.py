"""Inputs of the ski-jump smoother: configuration, constraint windows and the session on the IMU steps.

The first stage of ``rts-smooth`` (:mod:`sportfusion.skijump.smoother`): everything later stages read comes
from here -- the initial state (:mod:`sportfusion.skijump.smoother_start`), the engine
(:mod:`sportfusion.skijump.smoother_engine`) and the output columns (:mod:`sportfusion.skijump.smoother_outputs`)
take a :class:`SkiJumpInputs`, the hill included (its profile's tables), and never the table or the hill.

* :class:`SmootherConfig` -- ``P0``, ``Q``, ``R`` of Tables 3-5 as 1-sigma values, overridable from TOML
  (:func:`load_config`);
* :func:`session_events`, :func:`constraint_windows` -- take-off/touch-down per jump and the windows of
  the constraints (eqs 32-34, 51): ``c_q`` at every step; ``c_V,IR`` and ``c_H,IR`` from the start of the
  in-run (the last rest at the gate, at most ``max_rest`` s of it) to the take-off; ``c_V,LA`` from
  ``la_delay`` s after the touch-down, its weight ramping over ``la_ramp`` s (errata), to the end of the
  first rest after it;
* :func:`still_steps` -- where the athlete stands still (GNSS speed and IMU spread): zero-velocity updates;
* :func:`session_inputs` -- the IMU samples as steps [s], GNSS in the hill frame [m] and NED velocity
  [m/s], magnetometer [uT] on the step they fall on, the profile tables (:class:`ProfileTable`);
* :func:`segments` -- the session cut at IMU gaps longer than ``max_gap`` [s].
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.frames import Frame, gnss_local_columns
from sportfusion.core.magdisturb import mag_disturbed
from sportfusion.core.magfield import reference_field
from sportfusion.core.meta import epoch_unix
from sportfusion.core.session import validate_time
from sportfusion.core.stats import finite_rows, median
from sportfusion.core.windows import window_mean_std
from sportfusion.skijump.events import gnss_speed
from sportfusion.skijump.hillfile import Hill
from sportfusion.skijump.saturation import clipped_steps

IMU_COLUMNS = ("gyr_x", "gyr_y", "gyr_z", "acc_x", "acc_y", "acc_z")


MAG_COLUMNS = ("mag_x", "mag_y", "mag_z")


VEL_COLUMNS = ("vel_n", "vel_e", "vel_d")


CONSTRAINT_COLUMNS = ("c_q", "c_v_ir", "c_h_ir", "c_v_la")


@dataclass
class SmootherConfig:
    """Tuning of the ski-jump smoother; defaults are the paper's Tables 3-5 as 1-sigma values, except the GNSS
    position and the hill constraints (issue 39, below).

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
    # Table 5: measurement and constraint 1-sigma.  GNSS position 5/5/8 m and hill constraints 0.05 m instead of
    # 3/3/5 m and 0.1 m (issue 39): a receiver's error is mostly slow drift, not white noise, so each fix tells
    # less than Table 5 says, and the profile more.  Tuning variants of the independent simulator (seeds
    # 6000-6007): 3-D 0.205 -> 0.188 m, jump length 0.202 -> 0.199 m; the paper's own noise (8 jumps): 3-D 0.089 ->
    # 0.088 m, jump length 0.050 -> 0.034 m
    r_gnss_pos: tuple[float, float, float] = (5.0, 5.0, 8.0)
    r_gnss_vel: tuple[float, float, float] = (0.1, 0.1, 0.3)
    r_mag: float = 5.0
    r_c_q: float = 0.01
    r_c_v_ir: float = 0.05
    r_c_h_ir: float = 0.05
    r_c_v_la: float = 0.05
    r_zupt: float = 0.05  # zero-velocity update while still [m/s], per IMU step
    # switches
    hill_constraints: bool = True
    zupt: bool = True  # zero-velocity updates where the athlete stands still (:func:`still_steps`)
    use_gnss_vel: bool = True
    use_mag: bool = True
    # saturated IMU samples (sportfusion.skijump.saturation): ranges (0: found from the data), inflated noise
    gyr_range: float = 0.0
    acc_range: float = 0.0
    q_gyr_clipped: float = 3.0
    q_acc_clipped: float = 50.0
    clip_margin: float = 0.02
    # windows
    la_delay: float = 0.0
    la_ramp: float = 0.2
    rest_speed: float = 1.0
    max_rest: float = 60.0
    init_window: float = 0.1
    init_rest_max: float = 5.0
    init_rest_gyr: float = 0.15
    init_rest_acc: float = 1.5
    max_gap: float = 1.0
    # still (zero-velocity) detection: GNSS speed (running median of 9 epochs) and the IMU's spread over a window
    zupt_speed: float = 0.5
    zupt_window: float = 0.5
    zupt_acc: float = 0.3
    zupt_gyr: float = 0.2
    zupt_min: float = 1.0
    passes: int = 2
    lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)  # IMU -> GNSS antenna, body frame [m]
    estimate_latency: bool = True  # GNSS time-stamp latency from the first pass (skijump.alignment)
    # a latency estimate is applied where it is at least latency_min [s] and latency_sigmas of its own standard
    # error (skijump.alignment.gnss_latency: 2.5-4 ms on simulated jumps).  Was 0.02 s alone: the estimate also
    # carries the IMU's own anti-aliasing delay and the receiver's clock phase (5-12 ms, issue 39); applied,
    # the 3-D error of the independent simulator's jumps without GNSS latency went from 0.239 to 0.196 m (tuning
    # seeds 6000-6007), the other variants' unchanged; the paper's sensors' spurious 0-7 ms stay below 2 sigma
    latency_min: float = 0.003
    latency_sigmas: float = 2.0
    # GNSS fixes further than this many robust standard deviations (1.4826 MAD per axis, at least
    # gnss_outlier_floor [m]) from the smoothed track are skipped and the segment runs once more (0: never)
    gnss_outlier_sigma: float = 5.0
    gnss_outlier_floor: float = 1.0
    inrun_align: bool = True  # initial attitude from the in-run (skijump.alignment), else QUEST at the rest
    # the run over the start window when the in-run alignment gave the attitude: "forward" (an EKF run; the
    # biases and the gyro-carried attitude at its end start the whole pass) or "smoothed" (a smoothed run)
    start_pass: str = "forward"
    # the forward run starts where the rest at the gate ends (:func:`_initial_rest`; the initial state already
    # holds what the rest tells: the gyro bias, gravity for the alignment), not at the segment's first step
    start_after_rest: bool = True
    pass_tol_deg: float = 0.05
    pass_window: float = 15.0
    pass_after_takeoff: float = 3.0


#: allowed values of the text settings
CHOICES = {"start_pass": ("forward", "smoothed")}


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
    except UnicodeDecodeError:
        raise InputError(
            f"config {path}: not UTF-8 text (a binary file?); expected a TOML file of smoother settings"
        ) from None
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"config {path}: {exc}; expected a TOML file of smoother settings") from None
    doc = doc.get("rts", doc)
    known = {f.name: f for f in fields(SmootherConfig)}
    values = asdict(cfg)
    for key, val in doc.items():
        if key not in known:
            raise InputError(f"config {path}: unknown key {key!r}; expected one of {', '.join(known)}")
        old = values[key]
        if isinstance(old, str):
            if val not in CHOICES.get(key, ()):
                raise InputError(f"config {path}: {key} must be one of {', '.join(CHOICES[key])}")
        elif isinstance(old, bool):
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
    clipped: np.ndarray | None = None  # (n, 6) bool: gyro and accelerometer axes clipped (sensor range)
    still: np.ndarray | None = None  # (n,) weight 0..1 of the zero-velocity update (0: moving)
    mag_disturbed: np.ndarray | None = None  # (n,) bool: magnetometer samples skipped as disturbed
    #: the hill's in-run and landing profiles tabulated for the constraints (:func:`profile_tables`); None: no hill
    profile: tuple[ProfileTable, ProfileTable] | None = None


def _to_steps(t_rows: np.ndarray, rows_ok: np.ndarray, values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Put row samples onto the nearest IMU step (within half a step); (n, k) with NaN elsewhere.

    Where every row is an IMU step, ``values`` itself is returned with NaN written into its rows that are not
    ``rows_ok`` (the callers' arrays are their own: no copy of the session's rows).
    """
    if t.size == t_rows.size:  # every row is an IMU step (t is t_rows, strictly increasing): row k is step k
        if not rows_ok.all():
            values[~rows_ok] = np.nan
        return values
    out = np.full((t.size, values.shape[1]), np.nan)
    ts, vs = t_rows[rows_ok], values[rows_ok]
    if ts.size == 0:
        return out
    i = np.clip(np.searchsorted(t, ts), 1, max(t.size - 1, 1))
    i = np.where((i > 0) & (np.abs(t[i - 1] - ts) <= np.abs(t[i] - ts)), i - 1, i)
    i = np.minimum(i, t.size - 1)
    half = 0.5 * median(np.diff(t)) if t.size > 1 else 0.0
    keep = np.abs(t[i] - ts) <= half + 1e-9
    out[i[keep]] = vs[keep]
    return out


def _exact_times(rows: list[float], name: str, meta: dict[str, Any] | None, tol: float) -> list[float]:
    """Event-row times replaced by the detector's exact times from the metadata's ``events`` list, where
    one lies within ``tol`` [s] of the row (the row is the nearest sample to it)."""
    exact = [
        float(j[name])
        for e in (meta or {}).get("events") or []
        if isinstance(e, dict) and e.get("kind") == "jump"
        for j in e.get("jumps") or []
        if isinstance(j, dict) and isinstance(j.get(name), int | float)
    ]
    if not exact:
        return rows
    ex = np.asarray(exact)
    out = []
    for r in rows:
        i = int(np.argmin(np.abs(ex - r)))
        out.append(float(ex[i]) if abs(ex[i] - r) <= tol else r)
    return out


def session_events(
    table: pa.Table,
    takeoff: list[float] | None,
    touchdown: list[float] | None,
    meta: dict[str, Any] | None = None,
) -> list[tuple[float, float]]:
    """(take-off, touch-down) pairs [s]: the given lists, else the ``event`` column's rows (validated).

    Event rows sit on samples; where the metadata carries the detector's exact time of an event (its
    ``events`` list, within half a sample step of the row), that time is used.
    """
    if takeoff is not None or touchdown is not None:
        tos, tds = sorted(takeoff or []), sorted(touchdown or [])
    elif "event" in table.column_names:
        t = schema.floats(table, "t")
        ev = np.asarray(table.column("event").to_pylist(), dtype=object)
        step = float(median(np.diff(t))) if t.size > 1 else 0.0
        tol = 0.5 * step + 1e-9
        tos = sorted(_exact_times(t[ev == "takeoff"].tolist(), "takeoff", meta, tol))
        tds = sorted(_exact_times(t[ev == "touchdown"].tolist(), "touchdown", meta, tol))
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


def running_median(x: np.ndarray, size: int) -> np.ndarray:
    """Centred running median over ``size`` (odd) samples, edges padded with the end values.

    The same as ``scipy.ndimage.median_filter(x, size, mode="nearest")`` without importing scipy.ndimage.
    """
    x = np.asarray(x, float)
    if x.size == 0:
        return x.copy()
    h = size // 2
    return median(np.lib.stride_tricks.sliding_window_view(np.pad(x, h, mode="edge"), size), axis=1)


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
    slow = running_median(speed, 9) < cfg.rest_speed
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
        # the steps inside each window found by bisection: the masks are written over those steps only (a
        # training day has dozens of jumps over tens of thousands of steps)
        inrun[np.searchsorted(t, start, "left") : np.searchsorted(t, t_to, "right")] = True
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
        sl = slice(np.searchsorted(t, t0, "left"), np.searchsorted(t, end, "right"))  # t0 <= t <= end
        w = np.clip((t[sl] - t0) / cfg.la_ramp, 0.0, 1.0) if cfg.la_ramp > 0 else np.ones(t[sl].size)
        np.maximum(landing[sl], w, out=landing[sl])
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
        return own, schema.float_columns(table, ("gnss_x", "gnss_y", "gnss_z"))
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
    imu = schema.float_columns(table, IMU_COLUMNS)
    ok = finite_rows(imu)
    if ok.sum() < 10:
        raise InputError("the IMU columns hold fewer than 10 complete samples; expected a recorded IMU")
    rows = np.flatnonzero(ok)
    t = t_rows[rows]
    u = imu if rows.size == imu.shape[0] else imu[rows]
    frame, pos_rows = _hill_frame(table, meta, hill)
    pos, vel, mag = _gnss_and_mag_on_steps(table, t_rows, t, pos_rows, hill, frame.azimuth_deg)
    disturbed = _skip_disturbed_mag(t, mag, cfg.max_gap)
    jumps = session_events(table, takeoff, touchdown, meta)
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
        clipped=clipped_steps(t, u, cfg),
        mag_disturbed=disturbed,
        still=still_steps(t, u, st, sv, cfg) if cfg.zupt else None,
        profile=profile_tables(hill),
    )
    return inp, frame


def _gnss_and_mag_on_steps(
    table: pa.Table, t_rows: np.ndarray, t: np.ndarray, pos_rows: np.ndarray, hill: Hill, azimuth_deg: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """GNSS positions (hill frame [m], from ``pos_rows``) and NED velocities [m/s], magnetometer [uT]: each (n, 3)
    on the IMU steps ``t`` (the nearest within half a step), NaN where a sensor did not sample.

    A receiver's epochs are not the IMU's samples (each has its own clock): a fix taken up to half a step away
    from its step is carried there along the GNSS velocity (and the velocity along the fixes' change of velocity,
    :func:`_carry_to_steps`) -- 5 ms is 0.13 m at 25 m/s, which the smoother would otherwise take as a position
    error (issue 39).  ``azimuth_deg`` turns the NED velocity into the hill frame."""
    pos_ok = finite_rows(pos_rows)
    if not pos_ok.any():
        raise InputError("no GNSS position in the session; expected GNSS fixes (gnss_x/y/z or lat/lon/h)")
    _check_hill_near(pos_rows[pos_ok], hill)
    vel_rows = schema.float_columns(table, VEL_COLUMNS) if set(VEL_COLUMNS) <= set(table.column_names) else None
    if vel_rows is not None and t.size != t_rows.size:
        pos_rows, vel_rows = _carry_to_steps(t_rows, t, pos_rows, vel_rows, azimuth_deg)
    pos = _to_steps(t_rows, pos_ok, pos_rows, t)
    if np.isfinite(pos[:, 0]).sum() == 0:
        raise InputError("no GNSS fix falls within the IMU recording; expected overlapping GNSS and IMU data")
    out = [pos]
    for names, rows in ((VEL_COLUMNS, vel_rows), (MAG_COLUMNS, None)):
        if rows is None and set(names) <= set(table.column_names):
            rows = schema.float_columns(table, names)
        out.append(np.full((t.size, 3), np.nan) if rows is None else _to_steps(t_rows, finite_rows(rows), rows, t))
    return out[0], out[1], out[2]


def _carry_to_steps(
    t_rows: np.ndarray, t: np.ndarray, pos_rows: np.ndarray, vel_rows: np.ndarray, azimuth_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """GNSS rows moved to the time of their nearest IMU step ``t``: position + velocity x dt (the NED velocity
    turned into the hill frame), velocity + (its central difference between the fixes) x dt, with ``dt`` the
    step's time minus the fix's; rows without a velocity keep their position.  New arrays."""
    from sportfusion.core.rotations import ned_to_local

    pos_rows, vel_rows = pos_rows.copy(), vel_rows.copy()
    g = np.flatnonzero(finite_rows(vel_rows))
    if g.size == 0 or t.size < 2:
        return pos_rows, vel_rows
    tg = t_rows[g]
    i = np.clip(np.searchsorted(t, tg), 1, t.size - 1)
    i = np.where(np.abs(t[i - 1] - tg) <= np.abs(t[i] - tg), i - 1, i)
    dt = t[i] - tg
    dt[np.abs(dt) > 0.5 * float(median(np.diff(t))) + 1e-9] = 0.0  # not put on a step anyway
    acc = np.gradient(vel_rows[g], tg, axis=0) if g.size > 1 else np.zeros((1, 3))
    pos_rows[g] += ned_to_local(vel_rows[g], azimuth_deg) * dt[:, None]
    vel_rows[g] += acc * dt[:, None]
    return pos_rows, vel_rows


def _skip_disturbed_mag(t: np.ndarray, mag: np.ndarray, max_gap: float) -> np.ndarray:
    """Magnetic disturbances (:mod:`sportfusion.core.magdisturb`) set to NaN in ``mag`` (in place); returns their
    mask (n,).  The raw magnetometer is not calibrated (the smoother estimates its bias and scale), so the
    reference strength is the median of each IMU segment (between logging pauses; a phone may recalibrate its
    magnetometer between two recordings), not the model's."""
    disturbed = np.zeros(t.size, dtype=bool)
    okm = finite_rows(mag)
    for a, b in segments(t, max_gap):
        sel = np.flatnonzero(okm[a:b]) + a
        if sel.size > 10:
            disturbed[sel] = mag_disturbed(t[sel], mag[sel], None)
    mag[disturbed] = np.nan
    return disturbed


def still_steps(
    t: np.ndarray, u: np.ndarray, speed_t: np.ndarray, speed: np.ndarray, cfg: SmootherConfig
) -> np.ndarray:
    """Weight (n,) of the zero-velocity update per IMU step: 1 where the athlete stands still, else 0.

    Still: the GNSS speed's running median over 9 epochs (linearly interpolated to the step, within
    ``max_gap``) below ``zupt_speed`` [m/s], and over the centred ``zupt_window`` [s] every axis's
    standard deviation below ``zupt_acc`` [m/s^2] (accelerometer) and ``zupt_gyr`` [rad/s] (gyroscope) --
    biases do not enter, only the spread; runs shorter than ``zupt_min`` [s] are dropped.  Sitting at the
    gate and standing after the stop qualify; sliding slowly does not (GNSS speed), nor does an arm
    swinging while the athlete stands (IMU spread).  Without GNSS speeds nothing is still.

    Parameters
    ----------
    t : ndarray (n,)
        IMU step times [s].
    u : ndarray (n, 6)
        Gyro [rad/s] and accelerometer [m/s^2] samples.
    speed_t, speed : ndarray (m,)
        GNSS epochs [s] and speed [m/s] (:func:`sportfusion.skijump.events.gnss_speed`).
    cfg : SmootherConfig
    """
    out = np.zeros(t.size)
    if speed.size < 2 or t.size < 3:
        return out
    slow = running_median(speed, 9) < cfg.zupt_speed
    j = np.clip(np.searchsorted(speed_t, t), 1, speed_t.size - 1)
    near = np.maximum(np.abs(t - speed_t[j - 1]), np.abs(speed_t[j] - t)) <= cfg.max_gap
    inside = (t >= speed_t[0]) & (t <= speed_t[-1]) & near & (speed_t[j] - speed_t[j - 1] <= cfg.max_gap)
    still = inside & slow[j - 1] & slow[j]
    for a, b in segments(t, cfg.max_gap):
        if b - a < 3:
            still[a:b] = False
            continue
        k = np.flatnonzero(still[a:b])  # the IMU spread only where the GNSS speed says still (the gate, the stop)
        if k.size == 0:
            continue
        half = max(1, int(round(0.5 * cfg.zupt_window / median(np.diff(t[a:b])))))
        sd = window_mean_std(u[a:b], np.maximum(k - half, 0), np.minimum(k + half + 1, b - a))[1]  # centred
        still[a + k] = (sd[:, 0:3].max(axis=1) < cfg.zupt_gyr) & (sd[:, 3:6].max(axis=1) < cfg.zupt_acc)
    # drop runs shorter than zupt_min
    edges = np.flatnonzero(np.diff(np.concatenate(([0], still.astype(np.int8), [0]))))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if t[b - 1] - t[a] >= cfg.zupt_min:
            out[a:b] = 1.0
    return out


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


def segments(t: np.ndarray, max_gap: float) -> list[tuple[int, int]]:
    """Index ranges ``[a, b)`` of the IMU steps split where the sampling stops for more than ``max_gap`` [s]."""
    cut = np.flatnonzero(np.diff(t) > max_gap) + 1
    edges = [0, *cut.tolist(), t.size]
    return [(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def _slice(inp: SkiJumpInputs, a: int, b: int) -> SkiJumpInputs:
    """Steps ``a .. b - 1`` of ``inp`` (views; ``mag_disturbed`` is the session's alone)."""
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
        clipped=None if inp.clipped is None else inp.clipped[sl],
        still=None if inp.still is None else inp.still[sl],
        profile=inp.profile,
    )
