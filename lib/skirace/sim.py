"""Simulated alpine ski run (downhill / giant-slalom like) with truth.

The truth is built on a 1 kHz grid in the course frame (x along the fall-line
azimuth, y right, z down):

* a standing start (low dynamics: small head movements), then the run: the
  speed along the path obeys ``u' = g sin(slope) - mu g cos(slope) - c_d u^2``;
* turns: a sinusoidal lateral acceleration (amplitude ``turn_acc``, period
  ``turn_period``), so the heading swings around the fall line;
* terrain: the slope varies along the run; before each jump it flattens into a
  kicker, the skier flies ballistically (free fall: specific force ~0) and lands
  with a short impact onto a steeper slope;
* attitude of the sensor (helmet): yaw follows the direction of travel plus a
  head swing, pitch follows the path's inclination (with the head's lag), roll
  leans into the turns; the skier straightens before a take-off and the standing
  posture blends into the racing one, so the truth has no step: its angular rate
  and acceleration stay bounded (tests/test_sim_truth_smooth.py).

Sensors (the errors of a MEMS digital magnetic compass and an RTK receiver):

* accelerometer + magnetometer at ``imu_rate`` (30-100 Hz) on the same
  instants: bias, scale-factor error, white noise, ski vibration during the run,
  range saturation; magnetometer hard-iron bias, scale error and noise on the
  WMM field;
* a MEMS gyroscope (``gyro=True``, the default) on the same instants: the truth
  body rate plus the Earth rate, as an integrating (delta-angle) gyro outputs it --
  sample k is the mean rate over the interval ending at it
  (:func:`sportfusion.core.rotations.body_rates`), so integrating the error-free
  samples reproduces the truth attitude -- with a turn-on bias, a bias random
  walk, scale-factor error, white noise, ski vibration and range saturation.  Its
  errors come from their own random stream (a child of ``seed``): the
  accelerometer, magnetometer and GNSS samples are the same with or without it;
* GNSS at ``gnss_rate`` (10-20 Hz): RTK fixed epochs (cm noise) with float
  episodes (a decimetre offset that appears at the fixed->float transition and
  vanishes at float->fixed, plus larger noise, and optimistic reported sigmas)
  and short losses of lock (no epochs, followed by a float re-convergence).

Everything random comes from ``numpy.random.Generator`` s seeded by ``seed`` (the
gyroscope's from ``SeedSequence(seed).spawn(1)[0]``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyarrow as pa

from sportfusion.core import meta as sfmeta
from sportfusion.core.gravity import normal_gravity
from sportfusion.core.magfield import reference_field
from sportfusion.core.rotations import body_rates, euler_from_quat, local_to_ned, quat_from_euler, to_body
from sportfusion.core.session import Stream, merge_streams

FINE_DT = 0.001  # truth grid [s]
AIR_BLEND = 0.3  # the turning fades out before a take-off and back in after the landing over this [s]
HEAD_LAG = 0.25  # the helmet's pitch follows the path's inclination smoothed over this window [s]


@dataclass
class SkiRaceConfig:
    """Parameters of :func:`simulate_skirace` (units in brackets)."""

    seed: int = 0
    duration: float = 60.0  # run length after the start [s]
    static: float = 5.0  # standing in the start gate first [s]
    gnss_rate: float = 10.0  # [Hz], 10-20
    imu_rate: float = 50.0  # [Hz], 30-100
    site: tuple[float, float, float] = (46.4975, 9.8365, 2200.0)  # start: lat [deg], lon [deg], h [m]
    azimuth_deg: float = 160.0  # fall line / course-frame x axis, clockwise from north [deg]
    date: str = "2026-02-10T10:00:00Z"
    slope_deg: float = 20.0  # mean slope [deg]
    turn_period: float = 4.5  # [s] (giant slalom ~2.5-3, downhill ~4-6)
    turn_acc: float = 8.0  # lateral acceleration amplitude [m/s^2]
    rollers: float = 2.5  # slope-angle amplitude of the terrain rollers [deg]
    jumps: int = 2
    float_episodes: int = 3
    lock_losses: int = 2
    # GNSS errors [m]
    sigma_fixed: tuple[float, float] = (0.01, 0.02)  # true noise, horizontal / vertical
    sigma_float: tuple[float, float] = (0.05, 0.08)
    float_offset: tuple[float, float] = (0.3, 0.5)  # 1-sigma of the float offset at its start, horizontal / vertical
    float_converge: float = 3.0  # time constant of the float solution's convergence [s]
    float_duration: tuple[float, float] = (1.0, 3.0)  # range of float-episode lengths [s]
    reported_fixed: tuple[float, float] = (0.015, 0.03)
    reported_float: tuple[float, float] = (0.15, 0.3)
    # DMC errors
    acc_bias: float = 0.05  # [m/s^2] 1-sigma per axis
    acc_scale: float = 0.003  # 1-sigma
    acc_noise: float = 0.03  # [m/s^2] per sample
    acc_vibration: float = 0.4  # [m/s^2] per sample while skiing
    acc_range: float = 16 * 9.80665  # [m/s^2]
    mag_bias: float = 0.3  # [uT] 1-sigma per axis (residual hard iron)
    mag_scale: float = 0.005  # 1-sigma
    mag_noise: float = 0.1  # [uT] per sample
    # gyroscope errors (a consumer MEMS gyro, as in the gates simulator)
    gyro: bool = True  # write gyr_x gyr_y gyr_z [rad/s]
    gyr_bias: float = 0.01  # [rad/s] 1-sigma per axis, turn-on bias
    gyr_bias_walk: float = 2e-4  # [rad/s/sqrt(s)] bias random walk
    gyr_scale: float = 0.003  # 1-sigma
    gyr_noise: float = 0.002  # [rad/s] per sample
    gyr_vibration: float = 0.01  # [rad/s] per sample while skiing
    gyr_range: float = 2000.0 * np.pi / 180.0  # [rad/s]


@dataclass
class SkiRaceSim:
    """Output of :func:`simulate_skirace`: session and truth tables, metadata, and the fine truth."""

    session: pa.Table
    truth: pa.Table
    meta: dict
    truth_meta: dict
    fine: dict
    gnss_status: np.ndarray  # GGA code per GNSS epoch (4/5)
    gnss_t: np.ndarray


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def _lowpass(x: np.ndarray, width: float) -> np.ndarray:
    """Zero-phase moving average with a Hann window ``width`` [s] wide on the fine grid (edges held)."""
    k = max(int(round(width / FINE_DT)) | 1, 3)
    w = np.hanning(k + 2)[1:-1]
    return np.convolve(np.pad(x, k // 2, mode="edge"), w / w.sum(), mode="valid")


def _truth(cfg: SkiRaceConfig, rng: np.random.Generator, g: float) -> dict:
    """Truth trajectory and attitude on the fine grid."""
    T = cfg.static + cfg.duration
    t = np.arange(0.0, T + 1e-9, FINE_DT)
    n = t.size
    run = t >= cfg.static
    tr = t - cfg.static
    # slope profile [rad] along the run, with kickers and landings
    slope = np.deg2rad(cfg.slope_deg + 6.0 * np.sin(2 * np.pi * tr / 23.0) + 3.0 * np.sin(2 * np.pi * tr / 9.0 + 1.0))
    # terrain rollers (a few decimetres high, 1-3 s apart at racing speed)
    slope += (
        np.deg2rad(cfg.rollers)
        * _smoothstep(tr / 5.0)
        * (np.sin(2 * np.pi * tr / 1.9) + 0.6 * np.sin(2 * np.pi * tr / 3.1 + 0.5))
    )
    jump_t = cfg.static + cfg.duration * (np.arange(1, cfg.jumps + 1) / (cfg.jumps + 1)) + rng.uniform(-2, 2, cfg.jumps)
    flight = np.zeros(n, bool)
    flights = []
    for tj in jump_t:
        tau = rng.uniform(0.6, 0.9)
        kick = _smoothstep((t - (tj - 1.2)) / 1.0)  # flatten over 1 s before take-off
        slope = slope * (1 - kick * (t < tj)) + np.deg2rad(3.0) * kick * (t < tj)
        flights.append((tj, tj + tau))
        flight |= (t >= tj) & (t < tj + tau)
    # speed along the path (explicit Euler on the fine grid)
    mu, cd = 0.05, 0.004
    u = np.zeros(n)
    for i in range(1, n):
        if not run[i]:
            continue
        s = slope[i - 1]
        du = -cd * u[i - 1] ** 2 if flight[i - 1] else g * np.sin(s) - mu * g * np.cos(s) - cd * u[i - 1] ** 2
        u[i] = max(u[i - 1] + du * FINE_DT, 0.0)
    # turns: lateral acceleration, ramped in after the start; none in flight, and the skier straightens
    # before the take-off and turns again after the landing over AIR_BLEND (no step in the lean)
    ramp = _smoothstep(tr / 4.0) * run
    steer = np.ones(n)
    for t0, t1 in flights:
        steer = np.minimum(steer, 1.0 - _smoothstep((t - (t0 - AIR_BLEND)) / AIR_BLEND) * (t < t1))
        steer = np.minimum(steer, np.where(t >= t1, _smoothstep((t - t1) / AIR_BLEND), 1.0))
    alat = cfg.turn_acc * ramp * np.sin(2 * np.pi * tr / cfg.turn_period) * steer
    rate = alat / np.maximum(u, 2.0)
    heading = np.cumsum(rate) * FINE_DT
    heading -= np.mean(heading[run]) if run.any() else 0.0
    # the standing start faces the fall line; the run's heading offset at its start is taken up while the
    # turns ramp in (no step in the yaw)
    if run.any():
        heading = (heading - heading[np.argmax(run)] * (1.0 - ramp)) * run
    sh = u * np.cos(slope)  # horizontal speed on the ground
    vz = u * np.sin(slope)
    # in flight: ballistic vertical, horizontal speed kept; landing: blend to the slope in 80 ms
    for t0, t1 in flights:
        i0, i1 = np.searchsorted(t, [t0, t1])
        take_off = slope[i0 - 1]  # the kicker's angle
        sh[i0:i1] = u[i0:i1] * np.cos(take_off)  # horizontal: drag only
        vz[i0:i1] = vz[i0 - 1] + g * (t[i0:i1] - t[i0 - 1])  # ballistic
        land = np.arctan2(vz[i1 - 1], sh[i1 - 1]) + np.deg2rad(4.0)
        i2 = np.searchsorted(t, t1 + 2.0)
        # the slope after landing relaxes from the landing angle to the profile over 2 s
        w = _smoothstep((t[i1:i2] - t1) / 2.0)
        slope[i1:i2] = land * (1 - w) + slope[i1:i2] * w
        # impact: velocity blends from the flight's to the slope's in 80 ms
        b = _smoothstep((t[i1:i2] - t1) / 0.08)
        sh[i1:i2] = sh[i1 - 1] * (1 - b) + u[i1:i2] * np.cos(slope[i1:i2]) * b
        vz[i1:i2] = vz[i1 - 1] * (1 - b) + u[i1:i2] * np.sin(slope[i1:i2]) * b
    vx = sh * np.cos(heading)
    vy = sh * np.sin(heading)
    vel = np.stack((vx, vy, vz), axis=-1)
    pos = np.concatenate((np.zeros((1, 3)), np.cumsum((vel[1:] + vel[:-1]) / 2 * FINE_DT, axis=0)))
    acc = np.gradient(vel, FINE_DT, axis=0)
    # attitude of the helmet in NED; the head follows the path's inclination with a lag (the landing's
    # 80 ms turn of the velocity is smoothed over HEAD_LAG) and the standing posture blends into the
    # racing one over the first second: the angular rate and acceleration stay those of a head
    az = np.deg2rad(cfg.azimuth_deg)
    head = np.deg2rad(3.0) * np.sin(2 * np.pi * t / 2.7) + np.deg2rad(6.0) * np.sin(2 * np.pi * t / 7.3)
    yaw = az + heading + head
    gpath = _lowpass(np.arctan2(vz, np.maximum(sh, 1e-9)), HEAD_LAG)
    lean = np.deg2rad(12.0) * np.sin(2 * np.pi * t / 4.1)
    racing = _smoothstep(tr / 1.0)
    pitch = racing * (-0.6 * gpath + np.deg2rad(8.0)) + (1 - racing) * (np.deg2rad(-5.0) + lean / 3)
    roll = racing * 0.8 * np.arctan2(alat, g) + (1 - racing) * lean / 4 + np.deg2rad(2.0) * np.sin(2 * np.pi * t / 1.9)
    q = quat_from_euler(roll, pitch, yaw)
    return {
        "t": t,
        "pos": pos,
        "vel": vel,
        "acc": acc,
        "q": q,
        "run": run,
        "flight": flight,
        "flights": flights,
    }


def _gnss_status(cfg: SkiRaceConfig, rng: np.random.Generator, tg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """GGA code per epoch (4 fixed, 5 float) and a keep-mask (False: lost lock)."""
    status = np.full(tg.size, 4, np.int16)
    keep = np.ones(tg.size, bool)
    t0, t1 = cfg.static + 3.0, cfg.static + cfg.duration - 4.0
    events = cfg.float_episodes + cfg.lock_losses
    if events == 0 or t1 <= t0:
        return status, keep
    slots = np.linspace(t0, t1, events + 1)
    kinds = np.array([1] * cfg.float_episodes + [0] * cfg.lock_losses)
    rng.shuffle(kinds)
    for k, (a, b) in enumerate(zip(slots[:-1], slots[1:], strict=True)):
        start = rng.uniform(a, a + 0.4 * (b - a))
        if kinds[k] == 1:  # float episode, sometimes after a short loss of lock
            gap = rng.uniform(0.3, 1.0) if rng.random() < 0.5 else 0.0
            dur = rng.uniform(*cfg.float_duration)
        else:  # loss of lock followed by a short float re-convergence
            gap = rng.uniform(0.8, 2.0)
            dur = rng.uniform(1.0, 2.0)
        keep &= ~((tg >= start) & (tg < start + gap))
        status[(tg >= start + gap) & (tg < start + gap + dur)] = 5
    return status, keep


def _geodetic(local: np.ndarray, cfg: SkiRaceConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Course-frame positions -> WGS84 lat, lon [deg], h [m] (pyproj topocentric pipeline)."""
    from pyproj import Transformer

    lat0, lon0, h0 = cfg.site
    ned = local_to_ned(local, cfg.azimuth_deg)
    tr = Transformer.from_pipeline(
        f"+proj=pipeline +step +proj=cart +ellps=WGS84 +step +proj=topocentric +ellps=WGS84 "
        f"+lat_0={lat0} +lon_0={lon0} +h_0={h0}"
    )
    lon, lat, h = tr.transform(ned[:, 1], ned[:, 0], -ned[:, 2], direction="INVERSE")
    return np.asarray(lat), np.asarray(lon), np.asarray(h)


def _gyro(cfg: SkiRaceConfig, ti: np.ndarray, q_i: np.ndarray, running: np.ndarray, lat_deg: float) -> np.ndarray:
    """Gyroscope samples [rad/s] at the IMU instants ``ti`` from the truth attitude ``q_i`` there.

    Truth: the mean body rate over each sample interval (:func:`body_rates`) plus the Earth rate in the
    body frame; errors from their own random stream (a child of ``cfg.seed``), so the other sensors'
    samples do not depend on whether the gyroscope is simulated.
    """
    from sportfusion.skirace.attitude import OMEGA_EARTH

    rng = np.random.default_rng(np.random.SeedSequence(cfg.seed).spawn(1)[0])
    phi = np.deg2rad(lat_deg)
    w_ie = OMEGA_EARTH * np.array([np.cos(phi), 0.0, -np.sin(phi)])  # NED
    w_b = body_rates(ti, q_i) + to_body(q_i, np.broadcast_to(w_ie, q_i[:, 1:].shape))
    dt = 1.0 / cfg.imu_rate
    walk = np.cumsum(rng.normal(0, cfg.gyr_bias_walk * np.sqrt(dt), w_b.shape), axis=0)
    gyr = (
        w_b * (1 + rng.normal(0, cfg.gyr_scale, 3))
        + rng.normal(0, cfg.gyr_bias, 3)
        + walk
        + rng.normal(0, cfg.gyr_noise, w_b.shape)
        + rng.normal(0, cfg.gyr_vibration, w_b.shape) * running[:, None]
    )
    return np.clip(gyr, -cfg.gyr_range, cfg.gyr_range)


def simulate_skirace(cfg: SkiRaceConfig | None = None) -> SkiRaceSim:
    """Simulate one run: session table (sensors), truth table and metadata.

    Returns
    -------
    SkiRaceSim
        ``session`` (kind session): ``acc_* mag_*`` (and ``gyr_*`` [rad/s]
        unless ``cfg.gyro`` is False) at the IMU instants,
        ``lat lon h vel_* gnss_fix gnss_sats gnss_sigma_h gnss_sigma_v`` and the
        local ``gnss_x gnss_y gnss_z std_gnss_*`` (as gps2hill writes them in
        the course frame) at the GNSS epochs; ``truth`` (kind truth) at every
        session row: ``true_x.. true_vx.. true_ax.. true_q0..3 true_roll
        true_pitch true_yaw true_speed``.  The metadata carries the course
        frame (origin = start, azimuth = fall line) and the session's epoch.
    """
    cfg = cfg or SkiRaceConfig()
    if not 10.0 <= cfg.gnss_rate <= 20.0 or not 30.0 <= cfg.imu_rate <= 100.0:
        raise ValueError("gnss_rate must be in [10, 20] Hz and imu_rate in [30, 100] Hz")
    rng = np.random.default_rng(cfg.seed)
    lat0, lon0, h0 = cfg.site
    g = normal_gravity(lat0, h0)
    tru = _truth(cfg, rng, g)
    tf = tru["t"]
    T = tf[-1]

    def at(x: np.ndarray, times: np.ndarray) -> np.ndarray:
        idx = np.clip(np.rint(times / FINE_DT).astype(int), 0, tf.size - 1)
        return x[idx]

    # --- DMC at imu_rate ------------------------------------------------
    ti = np.arange(0.0, T, 1.0 / cfg.imu_rate)
    ti = np.round(ti / FINE_DT) * FINE_DT
    q_i = at(tru["q"], ti)
    a_ned = local_to_ned(at(tru["acc"], ti), cfg.azimuth_deg)
    v_ned = local_to_ned(at(tru["vel"], ti), cfg.azimuth_deg)
    from sportfusion.skirace.attitude import coriolis_ned

    f_ned = a_ned + coriolis_ned(v_ned, lat0, h0)
    f_ned[:, 2] -= g
    f_b = to_body(q_i, f_ned)
    running = at(tru["run"] & ~tru["flight"], ti)  # skis on the snow: vibration
    acc = (
        f_b * (1 + rng.normal(0, cfg.acc_scale, 3))
        + rng.normal(0, cfg.acc_bias, 3)
        + rng.normal(0, cfg.acc_noise, f_b.shape)
        + rng.normal(0, cfg.acc_vibration, f_b.shape) * running[:, None]
    )
    acc = np.clip(acc, -cfg.acc_range, cfg.acc_range)
    m_ned = reference_field(lat0, lon0, h0, cfg.date)
    m_b = to_body(q_i, np.broadcast_to(m_ned, f_ned.shape))
    mag = (
        m_b * (1 + rng.normal(0, cfg.mag_scale, 3))
        + rng.normal(0, cfg.mag_bias, 3)
        + rng.normal(0, cfg.mag_noise, m_b.shape)
    )

    gyr = _gyro(cfg, ti, q_i, running, lat0) if cfg.gyro else None

    # --- GNSS at gnss_rate (offset 3 ms from the IMU grid) --------------
    tg = np.round((np.arange(0.0, T, 1.0 / cfg.gnss_rate) + 0.003) / FINE_DT) * FINE_DT
    status, keep = _gnss_status(cfg, rng, tg)
    pos_true = at(tru["pos"], tg)
    noise_fx = rng.normal(0, 1, (tg.size, 3)) * np.array([cfg.sigma_fixed[0]] * 2 + [cfg.sigma_fixed[1]])
    noise_fl = rng.normal(0, 1, (tg.size, 3)) * np.array([cfg.sigma_float[0]] * 2 + [cfg.sigma_float[1]])
    err = np.where((status == 4)[:, None], noise_fx, noise_fl)
    # one offset per float episode, appearing at fixed->float, converging with time
    # constant float_converge, plus a slow random walk (5 cm/sqrt(s)); it vanishes at float->fixed
    fl = status == 5
    starts = np.flatnonzero(fl & ~np.r_[False, fl[:-1]])
    for s in starts:
        e = s
        while e < tg.size and fl[e]:
            e += 1
        off = rng.normal(0, 1, 3) * np.array([cfg.float_offset[0]] * 2 + [cfg.float_offset[1]])
        walk = np.cumsum(rng.normal(0, 0.05 * np.sqrt(1.0 / cfg.gnss_rate), (e - s, 3)), axis=0)
        decay = np.exp(-(tg[s:e] - tg[s]) / cfg.float_converge)[:, None]
        err[s:e] += off * decay + walk
    meas = pos_true + err
    rep_h = np.where(status == 4, cfg.reported_fixed[0], cfg.reported_float[0])
    rep_v = np.where(status == 4, cfg.reported_fixed[1], cfg.reported_float[1])
    lat, lon, h = _geodetic(meas, cfg)
    vel_ned = local_to_ned(at(tru["vel"], tg), cfg.azimuth_deg) + rng.normal(0, 0.03, (tg.size, 3))
    k = keep
    gnss = Stream(
        "gnss",
        tg[k],
        {
            "lat": lat[k],
            "lon": lon[k],
            "h": h[k],
            "vel_n": vel_ned[k, 0],
            "vel_e": vel_ned[k, 1],
            "vel_d": vel_ned[k, 2],
            "gnss_fix": status[k],
            "gnss_sats": np.where(status[k] == 4, 9, 5).astype(np.int16),
            "gnss_sigma_h": rep_h[k],
            "gnss_sigma_v": rep_v[k],
            "gnss_x": meas[k, 0],
            "gnss_y": meas[k, 1],
            "gnss_z": meas[k, 2],
            "std_gnss_x": rep_h[k],
            "std_gnss_y": rep_h[k],
            "std_gnss_z": rep_v[k],
        },
    )
    dmc = Stream(
        "dmc",
        ti,
        {
            "acc_x": acc[:, 0],
            "acc_y": acc[:, 1],
            "acc_z": acc[:, 2],
            "mag_x": mag[:, 0],
            "mag_y": mag[:, 1],
            "mag_z": mag[:, 2],
            **({f"gyr_{a}": gyr[:, i] for i, a in enumerate("xyz")} if gyr is not None else {}),
        },
    )
    session, _ = merge_streams([dmc, gnss])
    meta = sfmeta.new_meta("session", cfg.date)
    meta["frame"] = {
        "name": "course",
        "origin": [float(lat0), float(lon0), float(h0)],
        "azimuth_deg": float(cfg.azimuth_deg),
        "axes": "x forward (fall line), y right, z down",
    }
    # --- truth at every session row --------------------------------------
    ts = session.column("t").to_numpy()
    qs = at(tru["q"], ts)
    roll, pitch, yaw = euler_from_quat(qs)
    vs = at(tru["vel"], ts)
    cols = {"t": ts}
    for i, a in enumerate("xyz"):
        cols[f"true_{a}"] = at(tru["pos"], ts)[:, i]
        cols[f"true_v{a}"] = vs[:, i]
        cols[f"true_a{a}"] = at(tru["acc"], ts)[:, i]
    for i in range(4):
        cols[f"true_q{i}"] = qs[:, i]
    cols.update({"true_roll": roll, "true_pitch": pitch, "true_yaw": yaw, "true_speed": np.linalg.norm(vs, axis=1)})
    truth = pa.table(cols)
    truth_meta = sfmeta.new_meta("truth", cfg.date)
    truth_meta["frame"] = dict(meta["frame"])
    return SkiRaceSim(session, truth, meta, truth_meta, tru, status[k], tg[k])
