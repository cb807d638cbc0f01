"""``simulate skijump``: a ski jump with known truth and the paper's sensor error models.

The truth motion (gate, in-run, take-off impulse, flight with lift and drag,
touch-down with the landing impact, out-run, braking, stop) and the arm-mounted
phone's attitude are built by :mod:`sportfusion.skijump.sim.motion` and
:mod:`sportfusion.skijump.sim.attitude` so that they obey the INS kinematics of
skijump eqs 44-46 (with the errata sign in eq 45): the noise-free truth IMU,
integrated with RK4 and linearly interpolated inputs, reproduces the
trajectory.

Sensors (skijump §3.3.4 and Tables 3-5)::

    gyro  omega_B,gyro = omega_B + d_omega + w_gyro                (35)
    acc   a_B,acc      = a_B + d_a + w_acc                         (36)
    mag   m_B,mag      = (1 + diag(dS_m)) M_BO m_O + d_m + v_mag   (37)
    GNSS  r_N,GPS      = r_N + v_pos, v_O,GPS = v_O + v_vel        (38, 39)

Constant biases and scale errors are drawn once from the Table 3 priors
(gyro 0.0873 rad/s, accelerometer 0.2 m/s^2, magnetometer 5 uT and 0.1), the
white noises have the Table 4-5 sigmas (gyro 0.0175 rad/s, accelerometer
0.1 m/s^2, magnetometer 5 uT, GNSS position 3/3/5 m in the hill frame,
velocity 0.1/0.1/0.3 m/s in NED).  IMU and magnetometer sample at 100 Hz, the
GNSS at 10 Hz on every tenth IMU instant.  Options: a slowly varying GNSS
height error (first-order Gauss-Markov), GNSS outages, a lever arm from the
IMU to the GNSS antenna (body frame), a GNSS latency (the fix stamped t describes t - latency), a headwind with gusts in flight.  The magnetic reference field comes from
the World Magnetic Model at the take-off edge and the start date (or the hill
file's field), gravity from the hill file's g0 (or WGS84 normal gravity).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import meta as sfmeta
from sportfusion.core import rotations, schema
from sportfusion.core.errors import InputError
from sportfusion.core.magfield import reference_field
from sportfusion.sim.ode import bisect_root
from sportfusion.skijump.sim import DEFAULT_START
from sportfusion.skijump.sim.attitude import arm_motion, attitude, mounting
from sportfusion.skijump.sim.contact import ODE_STEP, STEP_PLAN, HillGeometry
from sportfusion.skijump.sim.motion import JumpMotion, MotionParams, MotionTruth
from sportfusion.skijump.sim.sensors import VARIANTS, Realism
from sportfusion.skijump.sim.venue import INRUN_JUNCTIONS, LANDING_JUNCTIONS, SimHill, as_sim_hill

IMU_RATE = 100.0  # [Hz]
GNSS_EVERY = 10  # GNSS on every tenth IMU sample: 10 Hz
#: The sensor models: the independent full physics (default) or the paper's eqs 35-39.
PHYSICS = ("full", "paper")
#: Published ranges used for the flight's lift area [m^2] when the distance is solved for.
LIFT_RANGE = (0.3, 1.2)


@dataclass
class SkiJumpConfig:
    """Options of :func:`simulate_skijump` (units in the comments)."""

    seed: int = 0
    distance: float | None = None  # wanted jump length [m]; default: drawn near the K point
    gate: int | None = None  # start gate (1 = lowest); default: chosen for the distance
    start: str = DEFAULT_START  # UTC time of t = 0
    rest_before: float = 5.0  # standing at the gate [s]
    rest_after: float = 3.0  # standing after the stop [s]
    # white noise, Tables 4-5
    sigma_gyr: float = 0.0175  # [rad/s]
    sigma_acc: float = 0.1  # [m/s^2]
    sigma_mag: float = 5.0  # [uT]
    sigma_pos: tuple[float, float, float] = (3.0, 3.0, 5.0)  # hill frame x, y, z [m]
    sigma_vel: tuple[float, float, float] = (0.1, 0.1, 0.3)  # NED [m/s]
    # constant errors drawn from the Table 3 priors (1-sigma)
    prior_bias_gyr: float = 0.0873  # [rad/s]
    prior_bias_acc: float = 0.2  # [m/s^2]
    prior_bias_mag: float = 5.0  # [uT]
    prior_scale_mag: float = 0.1  # [-]
    # GNSS extras
    height_error: tuple[float, float] | None = None  # Gauss-Markov (sigma [m], correlation time [s])
    outages: list[tuple[float, float]] = field(default_factory=list)  # (start [s], end [s])
    lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)  # IMU -> antenna, body frame [m]
    gnss_latency: float = 0.0  # GNSS time stamps late by this much [s] (the fix describes t - latency)
    wind: tuple[float, float] | None = None  # headwind [m/s] and gust amplitude [m/s] in flight
    geoid_separation: float = 47.9  # written into the NMEA log [m]
    noise: bool = True  # False: sensors without biases and noise (truth values)
    # "full": the physics of sportfusion.skijump.sim.sensors (independent of the smoother's model; the
    # sigmas above and lever_arm/gnss_latency/height_error then give way to the Realism settings, the three
    # options still overriding where set); "paper": eqs 35-39 with the Table 3-5 sigmas above
    physics: str = "full"
    variants: tuple[str, ...] = ()  # sportfusion.skijump.sim.sensors.VARIANTS applied to the full physics
    realism: Realism | None = None  # explicit full-physics settings (variants are applied on top)


@dataclass
class SkiJump:
    """A simulated jump: the session and truth tables with their metadata."""

    session: pa.Table
    session_meta: dict[str, Any]
    truth: pa.Table
    truth_meta: dict[str, Any]
    raw: dict[str, Any]


def hill_geometry(hill: SimHill, x_start: float) -> HillGeometry:
    """The motion's view of a hill, starting at ``x_start`` [m] on the in-run."""
    pts = hill.points
    return HillGeometry(
        z_inrun=hill.z_inrun,  # type: ignore[arg-type]
        z_landing=hill.z_landing,  # type: ignore[arg-type]
        x_start=float(x_start),
        inrun_junctions=tuple(float(pts[k][0]) for k in INRUN_JUNCTIONS if k in pts),
        landing_junctions=tuple(float(pts[k][0]) for k in LANDING_JUNCTIONS if k in pts),
        x_flat=float(pts["U"][0]),
        x_end=float(pts["V"][0]),
        jump_length=hill.jump_length,
        g=hill.g,
    )


def start_position(hill: SimHill, gate: float) -> float:
    """x [m] of a start position: gate ``gate`` (1 = lowest, at B; may be fractional) of the hill's gates.

    A hill without a number of gates is treated as having two, at B and A.
    """
    n = hill.gates
    if not 1 <= gate <= n:
        raise InputError(f"gate {gate:g} does not exist on {hill.name}; expected 1 .. {n}")
    a, b = hill.points["A"], hill.points["B"]
    return float(b[0] + (a[0] - b[0]) * (gate - 1) / max(n - 1, 1))


def draw_motion(rng: np.random.Generator, rest_before: float, rest_after: float, rho: float) -> MotionParams:
    """Jumper, air and landing parameters drawn in plausible (published) ranges."""
    u = rng.uniform
    return MotionParams(
        mass=u(58.0, 72.0),
        rho=rho,
        mu=u(0.015, 0.03),
        cda_inrun=u(0.18, 0.24),
        cda_flight=u(0.50, 0.65),
        cla_flight=u(0.55, 0.80),
        cda_outrun=u(0.35, 0.50),
        rest_before=rest_before,
        release_time=u(0.8, 1.2),
        rest_after=rest_after,
        push=u(20.0, 28.0),
        push_peak=u(0.022, 0.026),
        push_decay=u(0.10, 0.14),
        support_decay=u(0.04, 0.06),
        side_acc=u(-0.3, 0.3),
        side_period=u(2.0, 4.0),
        side_phase=u(0.0, 2 * np.pi),
        impact_peak=u(0.035, 0.055),
        impact_decay=u(0.12, 0.18),
        settle_time=u(0.25, 0.35),
        lateral_shift=u(-2.0, 2.0),
        stop_fraction=u(0.7, 0.9),
    )


def air_density(h: float) -> float:
    """ISA air density [kg/m^3] at height ``h`` [m] (troposphere)."""
    return float(1.225 * (1 - 2.25577e-5 * h) ** 4.2559)


def plan_jump(hill: SimHill, p: MotionParams, distance: float, gate: int | None) -> tuple[float, JumpMotion]:
    """Start gate and lift area for a jump of ``distance`` [m]; returns (gate, motion ready to run).

    Without ``gate``, the gate is chosen (bisection) so that the drawn lift
    area gives about the distance; the lift area is then solved within
    :data:`LIFT_RANGE`.
    """
    n = hill.gates

    def motion(g: float, step: float = STEP_PLAN) -> JumpMotion:
        return JumpMotion(hill_geometry(hill, start_position(hill, g)), p, step)

    if gate is None:  # the candidates' in-runs on the planning step, the chosen one's on the truth's
        lo, hi = 1.0, float(n)
        if motion(lo).length_for_lift(p.cla_flight) >= distance:
            g_sel = lo
        elif motion(hi).length_for_lift(p.cla_flight) <= distance:
            g_sel = hi
        else:
            while hi - lo > 1.0:
                mid = float(round(0.5 * (lo + hi)))
                if mid in (lo, hi):
                    break
                if motion(mid).length_for_lift(p.cla_flight) < distance:
                    lo = mid
                else:
                    hi = mid
            g_sel = hi
    else:
        g_sel = float(gate)
    m = motion(g_sel, ODE_STEP)
    lengths = [m.length_for_lift(c) for c in LIFT_RANGE]
    if not lengths[0] <= distance <= lengths[1]:
        raise InputError(
            f"a jump of {distance:g} m is out of reach from gate {g_sel:g} of {hill.name}: "
            f"{lengths[0]:.1f} .. {lengths[1]:.1f} m with lift areas {LIFT_RANGE[0]}-{LIFT_RANGE[1]} m^2; "
            "choose another --distance or --gate"
        )
    p.cla_flight = float(bisect_root(lambda c: m.length_for_lift(c) - distance, *LIFT_RANGE, xtol=1e-6))
    return g_sel, m


def _gauss_markov(rng: np.random.Generator, t: np.ndarray, sigma: float, tau: float) -> np.ndarray:
    """First-order Gauss-Markov process (stationary, 1-sigma ``sigma``, correlation time ``tau`` [s])."""
    out = np.empty(t.size)
    out[0] = rng.normal(0.0, sigma)
    for k in range(1, t.size):
        phi = math.exp(-(t[k] - t[k - 1]) / tau)
        out[k] = phi * out[k - 1] + rng.normal(0.0, sigma * math.sqrt(1 - phi * phi))
    return out


def simulate_skijump(hill: Any, cfg: SkiJumpConfig) -> SkiJump:
    """Simulate one jump on ``hill`` (a :class:`SimHill`, or a loaded hill file: its venue data); see the
    module text.

    Returns
    -------
    SkiJump
        ``session`` (IMU 100 Hz, GNSS 10 Hz), ``truth`` (``true_`` columns and
        ``event``) with their metadata, and ``raw`` (what :func:`write_raw` needs).
    """
    hill = as_sim_hill(hill)
    frame = hill.frame
    epoch = sfmeta.parse_epoch(cfg.start)
    rng = np.random.default_rng(cfg.seed)
    p = draw_motion(rng, cfg.rest_before, cfg.rest_after, air_density(frame.h))
    if cfg.wind is not None:  # its own generator: the other draws of the seed stay as they are
        wr = np.random.default_rng([cfg.seed, 7])
        p.wind, p.gust = float(cfg.wind[0]), float(cfg.wind[1])
        p.gust_period, p.gust_phase = float(wr.uniform(0.8, 2.5)), float(wr.uniform(0.0, 2 * np.pi))
    w = hill.w
    distance = float(cfg.distance) if cfg.distance is not None else float(w * rng.uniform(0.9, 1.04))
    gate, motion = plan_jump(hill, p, distance, cfg.gate)
    if cfg.physics not in PHYSICS:
        raise InputError(f"physics {cfg.physics!r}; expected one of {', '.join(PHYSICS)}")
    if cfg.physics == "full":
        return _full(hill, cfg, rng, p, motion, gate, distance, epoch)
    mt = motion.run()
    arm = arm_motion(mt.times, rng)
    m_ba = mounting(rng)
    az = frame.azimuth_deg
    q, w_b = attitude(mt.t, math.radians(az), mt.pitch, mt.pitch_rate, mt.heading, mt.heading_rate, arm, m_ba)
    g = hill.g
    f_o = rotations.local_to_ned(mt.a - np.array([0.0, 0.0, g]), az)
    acc_true = rotations.to_body(q, f_o)
    field_o = np.asarray(hill.mag_field or reference_field(frame.lat, frame.lon, frame.h, epoch), dtype=float)
    mag_true = rotations.to_body(q, np.broadcast_to(field_o, (mt.t.size, 3)))
    v_o = rotations.local_to_ned(mt.v, az)
    # constant sensor errors (Table 3 priors), then white noise (Tables 4-5)
    errs = {
        "bias_gyr": rng.normal(0.0, cfg.prior_bias_gyr, 3),
        "bias_acc": rng.normal(0.0, cfg.prior_bias_acc, 3),
        "bias_mag": rng.normal(0.0, cfg.prior_bias_mag, 3),
        "scale_mag": rng.normal(0.0, cfg.prior_scale_mag, 3),
    }
    n = mt.t.size
    noise = {
        "gyr": rng.normal(0.0, cfg.sigma_gyr, (n, 3)),
        "acc": rng.normal(0.0, cfg.sigma_acc, (n, 3)),
        "mag": rng.normal(0.0, cfg.sigma_mag, (n, 3)),
    }
    ig = np.arange(0, n, GNSS_EVERY)
    noise["pos"] = rng.normal(0.0, 1.0, (ig.size, 3)) * np.asarray(cfg.sigma_pos)
    noise["vel"] = rng.normal(0.0, 1.0, (ig.size, 3)) * np.asarray(cfg.sigma_vel)
    height = _gauss_markov(rng, mt.t[ig], *cfg.height_error) if cfg.height_error is not None else np.zeros(ig.size)
    if not cfg.noise:
        errs = {k: np.zeros(3) for k in errs}
        noise = {k: np.zeros_like(v) for k, v in noise.items()}
        height = np.zeros(ig.size)
    gyr = w_b + errs["bias_gyr"] + noise["gyr"]
    acc = acc_true + errs["bias_acc"] + noise["acc"]
    mag = (1 + errs["scale_mag"]) * mag_true + errs["bias_mag"] + noise["mag"]
    # GNSS antenna (lever arm in the body frame), eqs 38-39
    lever = np.asarray(cfg.lever_arm, dtype=float)
    r_ant = mt.r[ig] + rotations.ned_to_local(rotations.to_ned(q[ig], np.broadcast_to(lever, (ig.size, 3))), az)
    v_ant = v_o[ig] + rotations.to_ned(q[ig], np.cross(w_b[ig], lever))
    if cfg.gnss_latency:  # the receiver stamps at t what the antenna did at t - latency
        r_all = mt.r + rotations.ned_to_local(rotations.to_ned(q, np.broadcast_to(lever, (n, 3))), az)
        v_all = v_o + rotations.to_ned(q, np.cross(w_b, lever))
        tl = mt.t[ig] - cfg.gnss_latency
        r_ant = np.column_stack([np.interp(tl, mt.t, r_all[:, j]) for j in range(3)])
        v_ant = np.column_stack([np.interp(tl, mt.t, v_all[:, j]) for j in range(3)])
    pos = r_ant + noise["pos"]
    pos[:, 2] += height
    vel = v_ant + noise["vel"]
    keep = np.ones(ig.size, bool)
    for t0, t1 in cfg.outages:
        keep &= ~((mt.t[ig] >= t0) & (mt.t[ig] <= t1))
    ig, pos, vel = ig[keep], pos[keep], vel[keep]
    lat, lon, h = frame.to_geodetic(pos[:, 0], pos[:, 1], pos[:, 2])
    session = _session_table(mt.t, gyr, acc, mag, ig, lat, lon, h, vel, cfg)
    events = [{"name": "takeoff", "t": mt.times["takeoff"]}, {"name": "touchdown", "t": mt.times["touchdown"]}]
    hill_meta = hill.meta
    base = {"frame": frame.to_meta(), "hill": hill_meta}
    session_meta = {**sfmeta.new_meta("session", epoch), **base}
    truth_meta = {**sfmeta.new_meta("truth", epoch), **base}
    truth_meta["jump_length"] = mt.figures["jump_length"]
    truth_meta["events"] = events
    truth_meta["skijump"] = {
        "physics": "paper",
        "times": mt.times,
        "figures": mt.figures,
        "gate": gate,
        "distance_target": distance,
        "gravity": g,
        "mag_field_ned": field_o.tolist(),
        "sensor_errors": {k: v.tolist() for k, v in errs.items()},
        "mounting_dcm": m_ba.tolist(),
        "motion": asdict(p),
        "config": {k: v for k, v in asdict(cfg).items() if k not in ("outages", "realism")} | {"outages": cfg.outages},
    }
    truth = _truth_table(mt, q, w_b, acc_true, mag_true, v_o, errs)
    raw = {"epoch": epoch, "t": mt.t, "gyr": gyr, "acc": acc, "mag": mag, "t_gnss": mt.t[ig]}
    raw.update(lat=lat, lon=lon, h=h, vel=vel, sigma_pos=cfg.sigma_pos, geoid=cfg.geoid_separation)
    return SkiJump(session, session_meta, truth, truth_meta, raw)


def full_realism(cfg: SkiJumpConfig) -> Realism:
    """The full physics of ``cfg``: ``cfg.realism`` (or the nominal), the variants, then the GNSS options
    that were set (``gnss_latency``, ``height_error``)."""
    from dataclasses import replace

    r = cfg.realism or Realism()
    for name in cfg.variants:
        if name not in VARIANTS:
            raise InputError(f"unknown variant {name!r}; expected one of {', '.join(VARIANTS)}")
        r = replace(r, **VARIANTS[name])
    if cfg.gnss_latency:
        r = replace(r, latency=float(cfg.gnss_latency))
    if cfg.height_error is not None:
        r = replace(r, gm_v=(float(cfg.height_error[0]), float(cfg.height_error[1])))
    return r


def _full(
    hill: SimHill, cfg: SkiJumpConfig, rng, p: MotionParams, motion: JumpMotion, gate, distance, epoch
) -> SkiJump:  # noqa: ANN001
    """``physics="full"``: :func:`sportfusion.skijump.sim.full.simulate_full` and the tables' metadata."""
    from sportfusion.skijump.sim.full import simulate_full

    frame = hill.frame
    field_o = np.asarray(hill.mag_field or reference_field(frame.lat, frame.lon, frame.h, epoch), dtype=float)
    r = full_realism(cfg)
    lever = tuple(float(v) for v in cfg.lever_arm) if any(cfg.lever_arm) else None
    out = simulate_full(hill, cfg.seed, rng, motion, field_o, r, cfg.outages, lever, cfg.noise)  # type: ignore[arg-type]
    times, figures = out["times"], out["figures"]
    events = [{"name": "takeoff", "t": times["takeoff"]}, {"name": "touchdown", "t": times["touchdown"]}]
    base = {"frame": frame.to_meta(), "hill": hill.meta}
    session_meta = {**sfmeta.new_meta("session", epoch), **base}
    truth_meta = {**sfmeta.new_meta("truth", epoch), **base}
    truth_meta["jump_length"] = figures["jump_length"]
    truth_meta["events"] = events
    truth_meta["skijump"] = {
        "physics": "full",
        "variants": list(cfg.variants),
        "times": times,
        "figures": figures,
        "gate": gate,
        "distance_target": distance,
        "gravity": hill.g,
        "mag_field_ned": field_o.tolist(),
        "mounting_dcm": out["mounting"].tolist(),
        "motion": asdict(p),
        "realism": r.describe(),
        **out["meta"],
        "config": {k: v for k, v in asdict(cfg).items() if k not in ("outages", "realism")}
        | {"outages": cfg.outages, "variants": list(cfg.variants)},
    }
    raw = {"epoch": epoch, **out["raw"], "geoid": cfg.geoid_separation}
    return SkiJump(out["session"], session_meta, out["truth"], truth_meta, raw)


def _column(name: str, values: np.ndarray) -> pa.Array:
    return schema.to_arrow(name, values)


def _session_table(t, gyr, acc, mag, ig, lat, lon, h, vel, cfg: SkiJumpConfig) -> pa.Table:  # noqa: ANN001
    n = t.size
    cols: dict[str, pa.Array] = {"t": pa.array(t, pa.float64())}
    for name, data in (("acc", acc), ("gyr", gyr), ("mag", mag)):
        for k, ax in enumerate("xyz"):
            cols[f"{name}_{ax}"] = _column(f"{name}_{ax}", data[:, k])

    def sparse(values: np.ndarray) -> np.ndarray:
        out = np.full(n, np.nan)
        out[ig] = values
        return out

    for name, values in (("lat", lat), ("lon", lon), ("h", h)):
        cols[name] = _column(name, sparse(values))
    for k, name in enumerate(("vel_n", "vel_e", "vel_d")):
        cols[name] = _column(name, sparse(vel[:, k]))
    mask = np.ones(n, bool)
    mask[ig] = False
    cols["gnss_fix"] = schema.numeric_array(np.ones(n, np.int16), mask)
    cols["gnss_sats"] = schema.numeric_array(np.full(n, 9, np.int16), mask)
    cols["gnss_sigma_h"] = _column("gnss_sigma_h", sparse(np.full(ig.size, cfg.sigma_pos[0])))
    cols["gnss_sigma_v"] = _column("gnss_sigma_v", sparse(np.full(ig.size, cfg.sigma_pos[2])))
    return pa.table(cols)


def _truth_table(mt: MotionTruth, q, w_b, acc, mag, v_o, errs) -> pa.Table:  # noqa: ANN001
    n = mt.t.size
    cols: dict[str, Any] = {"t": pa.array(mt.t, pa.float64())}
    blocks = {
        ("x", "y", "z"): mt.r,
        ("vx", "vy", "vz"): mt.v,
        ("vel_n", "vel_e", "vel_d"): v_o,
        ("ax", "ay", "az"): mt.a,
        ("q0", "q1", "q2", "q3"): q,
        ("acc_x", "acc_y", "acc_z"): acc,
        ("gyr_x", "gyr_y", "gyr_z"): w_b,
        ("mag_x", "mag_y", "mag_z"): mag,
    }
    roll, pitch, yaw = rotations.euler_from_quat(q)
    blocks[("roll", "pitch", "yaw")] = np.stack((roll, pitch, yaw), -1)
    for key, vals in errs.items():
        blocks[tuple(f"{key}_{a}" for a in "xyz")] = np.broadcast_to(vals, (n, 3))
    for names, data in blocks.items():
        for k, name in enumerate(names):
            cols[f"true_{name}"] = _column(f"true_{name}", np.ascontiguousarray(data[:, k]))
    cols["true_clearance"] = _column("true_clearance", mt.clearance)
    event = [None] * n
    for name in ("takeoff", "touchdown"):
        event[int(round(mt.times[name] * IMU_RATE))] = name
    cols["event"] = pa.array(event, pa.string())
    return pa.table(cols)


def write_raw(sim: SkiJump, folder: str | Path) -> list[Path]:
    """Write what a user would ingest: ``phyphox.zip`` (IMU, magnetometer) and ``gnss.nmea`` (GGA/RMC/GST).

    The phyphox experiment starts at t = 0 of the session; the NMEA log's UTC
    times are the session epoch plus t.  NMEA carries the height above mean sea
    level (ellipsoidal height minus the configured geoid separation) and the
    horizontal speed and course; it has no vertical velocity.
    """
    from sportfusion.sim.rawfiles import write_nmea, write_phyphox_zip

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    r = sim.raw
    write_phyphox_zip(
        out / "phyphox.zip",
        r["epoch"],
        {"Accelerometer": (r["t"], r["acc"]), "Gyroscope": (r["t"], r["gyr"]), "Magnetometer": (r["t"], r["mag"])},
        device="sportfusion simulated phone (simulate skijump)",
    )
    vel = r["vel"]
    ones = np.ones(r["t_gnss"].size)
    sx, _, sz = r["sigma_pos"]
    write_nmea(
        out / "gnss.nmea",
        r["epoch"],
        r["t_gnss"],
        r["lat"],
        r["lon"],
        r["h"] - r["geoid"],
        r["geoid"],
        np.hypot(vel[:, 0], vel[:, 1]),
        np.degrees(np.arctan2(vel[:, 1], vel[:, 0])) % 360.0,
        sx * ones,
        sx * ones,
        sz * ones,
    )
    return [out / "phyphox.zip", out / "gnss.nmea"]
