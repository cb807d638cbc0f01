"""Simulated giant-slalom (or downhill) run over a course of magnet gates, with truth (gates paper setup).

Course (local course frame: x along the fall-line azimuth, y right, z down,
origin on the snow at the start):

* ``n_gates`` gates (GS: 30, 22-28 m apart, alternating sides 1.5-3.5 m off the
  centre line; downhill: gates three times further apart), on a terrain whose
  slope varies along the course and whose total drop is ``drop`` (150 m over
  about 700 m); a magnet buried ``burial`` below the snow at each gate pole,
  its moment vertical (pointing down, so that above it it adds to the Earth
  field); the survey of the magnets (a ``gates`` table) carries a survey noise;
* the snow-projection of the sacrum follows a C2 spline that swings around each
  gate on its outside, ``pass_offset`` 0-0.5 m beyond the pole (first/last gate sometimes 1-1.4 m); the
  sacrum is ``H0 cos(lean)`` above the snow along the snow normal, with
  ``lean = atan(a_lat / g)`` (the inclination that balances the lateral
  acceleration), so it passes 0.2-1.2 m from the magnets; a pass beyond about
  0.8 m is usually not detected (the paper's observation);
* speed: a push-off from the static start, then 15-25 m/s along the course
  (GS; 25-35 m/s downhill), braking to a stop after the finish; static
  postures of ``static`` seconds at start and finish;
* attitude of the sacrum sensor (body axes x forward, y right, z down when
  standing upright): yaw = direction of travel (plus a small pelvis swing),
  roll = the lean, pitch = trunk flexion and slope;
* spurious magnetic disturbances (``spurious`` small buried metal objects
  beside the track between gates) give noise peaks.

Sensors: an IMU at ``imu_rate`` (500 Hz: specific force and angular rate, with
bias, white noise and ski vibration; the gyro bias also walks slowly) and a
magnetometer at ``mag_rate`` (125 Hz, on the same instants as IMU samples) that
measures the Earth field (WMM at the site) plus the dipole fields of all
magnets, with a residual hard-iron bias and noise.  Earth rotation and
Coriolis terms are left out (below 0.01 m/s^2 and 1e-4 rad/s, far under the
sensor errors).

Everything random comes from one ``numpy.random.Generator`` seeded by ``seed``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from sportfusion.core import meta as sfmeta
from sportfusion.core.frames import local_to_geodetic
from sportfusion.core.gravity import normal_gravity
from sportfusion.core.magfield import reference_field
from sportfusion.core.rotations import (
    euler_from_quat,
    local_to_ned,
    quat_conjugate,
    quat_from_euler,
    quat_multiply,
    to_body,
)
from sportfusion.core.session import Stream, merge_streams
from sportfusion.gates.magnet import DEFAULT_MOMENT, dipole_field

FINE_DT = 0.001  # truth grid [s]


@dataclass
class GatesConfig:
    """Parameters of :func:`simulate_gates` (units in brackets)."""

    seed: int = 0
    downhill: bool = False
    n_gates: int = 30
    spacing: tuple[float, float] = (22.0, 28.0)  # gate-to-gate distance [m]
    lateral: tuple[float, float] = (1.5, 3.5)  # gate offset from the centre line [m]
    drop: float = 150.0  # vertical drop start -> finish [m]
    speed: tuple[float, float] = (15.0, 25.0)  # speed range on the course [m/s]
    static: float = 5.0  # static posture at start and at finish [s]
    imu_rate: float = 500.0  # [Hz]
    mag_rate: float = 125.0  # [Hz]
    site: tuple[float, float, float] = (46.8345, 9.2103, 1600.0)  # start: lat [deg], lon [deg], h [m]
    azimuth_deg: float = 20.0  # fall line / course-frame x axis, clockwise from north [deg]
    date: str = "2026-01-20T10:00:00Z"
    moment: float = DEFAULT_MOMENT  # magnet moment [A m^2]
    burial: float = 0.05  # magnet depth below the snow [m]
    pass_offset: tuple[float, float] = (0.0, 0.5)  # sacrum's snow projection beyond the pole [m]
    sacrum_height: float = 0.95  # sacrum height above the snow at zero lean while skiing [m]
    height_spread: float = 0.05  # relative 1-sigma of the sacrum height at each gate
    survey_sigma: tuple[float, float] = (0.02, 0.03)  # survey noise, horizontal / vertical [m]
    survey_spots: bool = False  # also survey the snow spots of the static postures (rows point = start/finish)
    spurious: int = 1  # magnetic disturbances beside the track [count]
    # IMU errors (after the paper's calibration)
    acc_bias: float = 0.03  # [m/s^2] 1-sigma per axis
    acc_noise: float = 0.05  # [m/s^2] per sample
    acc_vibration: float = 0.8  # [m/s^2] per sample while skiing
    gyr_bias: float = 0.01  # [rad/s] 1-sigma per axis (removed at the static start by the estimator)
    gyr_bias_walk: float = 2e-4  # [rad/s/sqrt(s)]
    gyr_noise: float = 0.005  # [rad/s] per sample
    gyr_vibration: float = 0.03  # [rad/s] per sample while skiing
    mag_bias: float = 0.3  # [uT] 1-sigma per axis (residual hard iron)
    mag_noise: float = 0.3  # [uT] per sample
    # a full-body skier with seven IMUs (sportfusion.gates.sim_skier; simulate gates --body)
    body: bool = False
    height: float = 1.80  # athlete's height [m]
    body_mass: float = 78.0  # athlete's mass without equipment [kg]
    max_misalignment: float = 30.0  # sensor strap rotation, at most [deg]

    def __post_init__(self) -> None:
        if self.downhill:
            self.n_gates = 12 if self.n_gates == 30 else self.n_gates
            if self.spacing == (22.0, 28.0):
                self.spacing = (66.0, 84.0)
            if self.lateral == (1.5, 3.5):
                self.lateral = (4.0, 9.0)
            if self.speed == (15.0, 25.0):
                self.speed = (24.0, 32.0)
            if self.drop == 150.0:
                self.drop = 250.0


@dataclass
class GatesSim:
    """Output of :func:`simulate_gates`."""

    session: pa.Table
    truth: pa.Table
    survey: pa.Table
    meta: dict
    truth_meta: dict
    survey_meta: dict
    fine: dict = field(repr=False)
    magnets: np.ndarray = field(repr=False)  # (N, 3) true magnet positions, course frame [m]
    crossings: dict = field(repr=False)  # truth per gate: t, distance, turn, index on the fine grid
    body: dict | None = field(default=None, repr=False)  # the skier (--body): sportfusion.gates.sim_skier


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


class _Terrain:
    """Snow surface z = F(x, y) (z down): slope varying along x, a slight cross slope, flat run-out."""

    def __init__(self, cfg: GatesConfig, rng: np.random.Generator, x_finish: float, x_end: float) -> None:
        from scipy.interpolate import CubicSpline

        self.xg = np.linspace(-20.0, x_end + 50.0, 4000)
        ph = rng.uniform(0, 2 * np.pi, 2)
        shape = (
            1.0 + 0.35 * np.sin(2 * np.pi * self.xg / 230.0 + ph[0]) + 0.2 * np.sin(2 * np.pi * self.xg / 90.0 + ph[1])
        )
        runout = 1.0 - 0.8 * _smoothstep((self.xg - x_finish) / 25.0)
        shape = shape * runout * (self.xg > -5) + 0.2 * (self.xg <= -5)
        # scale so that the drop between x = 0 and the finish is cfg.drop
        grad = np.tan(np.deg2rad(12.0)) * shape
        z = np.concatenate(([0.0], np.cumsum((grad[1:] + grad[:-1]) / 2 * np.diff(self.xg))))
        drop = np.interp(x_finish, self.xg, z) - np.interp(0.0, self.xg, z)
        grad *= cfg.drop / drop
        z = np.concatenate(([0.0], np.cumsum((grad[1:] + grad[:-1]) / 2 * np.diff(self.xg))))
        z -= np.interp(0.0, self.xg, z)
        self.fx = CubicSpline(self.xg, z)
        self.cross = np.tan(np.deg2rad(rng.uniform(-3.0, 3.0)))

    def z(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return self.fx(x) + self.cross * y

    def up_normal(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Unit normal pointing out of the snow (z down frame): ``(F_x, F_y, -1)/norm``."""
        fx = self.fx(x, 1)
        n = np.stack([fx, np.full_like(fx, self.cross), -np.ones_like(fx)], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)


def _course(cfg: GatesConfig, rng: np.random.Generator) -> dict:
    """Gate positions (horizontal) and sides, and the sacrum's horizontal path y(x)."""
    from scipy.interpolate import CubicSpline

    n = cfg.n_gates
    side0 = rng.choice([-1.0, 1.0])
    sides = side0 * (-1.0) ** np.arange(n)  # -1: gate left of the centre line (a right turn)
    lat = rng.uniform(*cfg.lateral, n)
    y = sides * lat
    x = np.empty(n)
    x_first = 30.0 if not cfg.downhill else 60.0
    x[0] = x_first
    slope = cfg.drop / 700.0
    for i in range(1, n):
        d = rng.uniform(*cfg.spacing)
        dy = y[i] - y[i - 1]
        x[i] = x[i - 1] + np.sqrt(max(d**2 / (1 + slope**2) - dy**2, 1.0))
    offset = rng.uniform(*cfg.pass_offset, n)
    # first and last gates are often passed wide (the paper: usually those are missed)
    for i in (0, n - 1):
        if rng.random() < 0.4:
            offset[i] = rng.uniform(1.0, 1.4)
    x_finish = x[-1] + 25.0
    x_end = x_finish + (45.0 if not cfg.downhill else 90.0)
    kx = np.concatenate(([0.0, 8.0], x, [x_finish, x_end - 5.0, x_end]))
    yk = y + sides * offset
    ky = np.concatenate(([0.0, 0.0], yk, [0.3 * yk[-1], 0.2 * yk[-1], 0.2 * yk[-1]]))
    path = CubicSpline(kx, ky, bc_type=((1, 0.0), (1, 0.0)))
    return {
        "gx": x,
        "gy": y,
        "sides": sides,
        "offset": offset,
        "path": path,
        "x_finish": x_finish,
        "x_end": x_end,
    }


def _truth(cfg: GatesConfig, rng: np.random.Generator, g: float) -> dict:
    """Course, terrain and the sacrum's truth on the fine grid."""
    from scipy.interpolate import CubicSpline

    c = _course(cfg, rng)
    ter = _Terrain(cfg, rng, c["x_finish"], c["x_end"])
    path = c["path"]
    # arc length of the snow-projection path (3-D) on a dense x grid
    xs = np.linspace(0.0, c["x_end"], int(c["x_end"] / 0.05) + 1)
    ys = path(xs)
    zs = ter.z(xs, ys)
    seg = np.linalg.norm(np.diff(np.stack([xs, ys, zs], axis=-1), axis=0), axis=1)
    s_of_x = np.concatenate(([0.0], np.cumsum(seg)))
    x_of_s = CubicSpline(s_of_x[::4], xs[::4])
    s_end = s_of_x[-1]
    s_fin = float(np.interp(c["x_finish"], xs, s_of_x))
    # speed profile along the path: push-off, smooth random variations in the range, braking after the finish
    lo, hi = cfg.speed
    mid, amp = (lo + hi) / 2, (hi - lo) / 2
    ph = rng.uniform(0, 2 * np.pi, 3)
    base = (
        mid
        + 0.6 * amp * np.sin(2 * np.pi * s_of_x / 310.0 + ph[0])
        + 0.3 * amp * np.sin(2 * np.pi * s_of_x / 95.0 + ph[1])
    )
    base = np.clip(base, lo + 0.5, hi - 0.5)
    push = 6.0 if not cfg.downhill else 7.0
    brake = 7.0
    s_stop = s_fin + 0.8 * (s_end - s_fin)
    u_s = np.minimum(base, np.sqrt(2 * push * (s_of_x + 0.02)))
    u_s = np.minimum(u_s, np.sqrt(2 * brake * np.maximum(s_stop - s_of_x, 0.0)))
    # time integration of ds/dt = u(s)
    n_run = int(400.0 / FINE_DT)
    s = np.zeros(n_run)
    k_stop = n_run - 1
    for i in range(1, n_run):
        u = np.interp(s[i - 1], s_of_x, u_s)
        if u < 0.05 and s[i - 1] > s_fin:
            k_stop = i
            s[i:] = s[i - 1]
            break
        s[i] = s[i - 1] + max(u, 0.05) * FINE_DT
    n_static = int(round(cfg.static / FINE_DT))
    s_run = s[: k_stop + 1]
    s_all = np.concatenate((np.zeros(n_static), s_run, np.full(n_static, s_run[-1])))
    # smooth the 1 kHz s(t) slightly (removes the Euler kinks, keeps it monotone)
    ker = np.hanning(41)
    ker /= ker.sum()
    s_all = np.convolve(np.pad(s_all, 20, mode="edge"), ker, mode="valid")
    t = np.arange(s_all.size) * FINE_DT
    x = x_of_s(s_all)
    x = np.maximum.accumulate(x)
    y = path(x)
    snow = np.stack([x, y, ter.z(x, y)], axis=-1)
    nup = ter.up_normal(x, y)
    # horizontal kinematics of the snow point -> lateral acceleration -> lean -> sacrum height
    vs = np.gradient(snow, FINE_DT, axis=0)
    as_ = np.gradient(vs, FINE_DT, axis=0)
    vh = vs[:, :2]
    sp = np.linalg.norm(vh, axis=1)
    right = np.stack([-vh[:, 1], vh[:, 0]], axis=-1) / np.maximum(sp, 0.3)[:, None]
    alat = np.sum(as_[:, :2] * right, axis=1)
    moving = sp > 0.5
    lean = np.arctan2(alat, g) * moving
    lean = np.convolve(np.pad(lean, 50, mode="edge"), np.hanning(101) / np.hanning(101).sum(), mode="valid")
    tr = t - cfg.static
    t_run_end = k_stop * FINE_DT
    skiing = _smoothstep(tr / 1.5) * (1 - _smoothstep((tr - t_run_end + 1.5) / 1.5))
    h0 = 1.0 + (cfg.sacrum_height - 1.0) * skiing  # upright at start/finish, crouched while skiing
    # per-gate variation of the height (posture) around the model, smooth in time
    gate_s = np.interp(c["gx"], xs, s_of_x)
    hv = rng.normal(0, cfg.height_spread, c["gx"].size)
    hv_s = CubicSpline(np.concatenate(([0.0], gate_s, [s_end])), np.concatenate(([0.0], hv, [0.0])))
    hfac = 1.0 + hv_s(s_all) * skiing
    height = h0 * np.cos(lean) * hfac
    # standing still the body balances its centre of mass over the feet (vertically above the snow point);
    # gliding, the slope's acceleration tilts the effective gravity onto the snow normal
    up = (1.0 - skiing)[:, None] * np.array([0.0, 0.0, -1.0]) + skiing[:, None] * nup
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    pos = snow + height[:, None] * up
    vel = np.gradient(pos, FINE_DT, axis=0)
    acc = np.gradient(vel, FINE_DT, axis=0)
    # attitude of the sacrum sensor in the course frame -> NED
    heading = np.unwrap(np.arctan2(vh[:, 1], vh[:, 0]))
    heading = np.where(moving, heading, np.nan)
    idx = np.flatnonzero(np.isfinite(heading))
    heading = np.interp(np.arange(t.size), idx, heading[idx])
    heading = np.convolve(np.pad(heading, 50, mode="edge"), np.hanning(101) / np.hanning(101).sum(), mode="valid")
    pelvis = np.deg2rad(1.0) * np.sin(2 * np.pi * t / 1.3) * skiing
    sway = np.deg2rad(1.0) * np.sin(2 * np.pi * t / 3.7)
    yaw = np.deg2rad(cfg.azimuth_deg) + heading + pelvis
    # the trunk follows the slope as the skier gets going (weighted by the smooth skiing ramp, not switched
    # on when the speed passes a threshold: no step in the pitch)
    slope_along = np.arctan2(vs[:, 2], np.maximum(sp, 1e-3)) * skiing
    pitch = np.deg2rad(15.0) * skiing - 0.5 * slope_along + sway
    roll = lean + 0.5 * sway
    q = quat_from_euler(roll, pitch, yaw)
    return {
        "t": t,
        "pos": pos,
        "vel": vel,
        "acc": acc,
        "q": q,
        "roll": roll,
        "height": height,
        "skiing": skiing,
        "course": c,
        "terrain": ter,
        "snow": snow,
        "t_run": (cfg.static, cfg.static + t_run_end),
    }


def body_rates(q: np.ndarray, dt: float) -> np.ndarray:
    """Body angular rate [rad/s] from attitude quaternions ``q_BO`` sampled every ``dt`` [s].

    ``q`` rotates body vectors into NED (Hamilton), so ``q' = q ⊗ [0, w_B] / 2``;
    the rate at sample k is the rotation vector of ``q_{k-1}* ⊗ q_{k+1}`` over 2 dt.
    """
    d = quat_multiply(quat_conjugate(q[:-2]), q[2:])
    d = d * np.sign(d[:, :1] + 1e-300)
    vn = np.linalg.norm(d[:, 1:], axis=1)
    ang = 2 * np.arctan2(vn, d[:, 0])
    axis = d[:, 1:] / np.maximum(vn, 1e-300)[:, None]
    w = axis * (ang / (2 * dt))[:, None]
    return np.concatenate((w[:1], w, w[-1:]))


def _crossings(tru: dict, magnets: np.ndarray, sides: np.ndarray) -> dict:
    """Truth per gate: the instant of closest approach of the sacrum to the magnet, distance, turn side."""
    pos = tru["pos"]
    t = tru["t"]
    out = {"t": [], "distance": [], "turn": [], "k": []}
    for m, sd in zip(magnets, sides, strict=True):
        # search near the closest approach in x first (cheap), then exactly
        kx = int(np.argmin(np.abs(pos[:, 0] - m[0])))
        lo, hi = max(kx - 1500, 0), min(kx + 1500, t.size)
        d = np.linalg.norm(pos[lo:hi] - m, axis=1)
        k = lo + int(np.argmin(d))
        out["t"].append(t[k])
        out["distance"].append(float(d[k - lo]))
        out["turn"].append("R" if sd < 0 else "L")
        out["k"].append(k)
    return {k: np.asarray(v) for k, v in out.items()}


def simulate_gates(cfg: GatesConfig | None = None, survey_wgs84: bool = False) -> GatesSim:
    """Simulate one run over a magnet-gate course: session, truth and survey tables.

    Parameters
    ----------
    cfg : GatesConfig, optional
    survey_wgs84 : bool
        Write the survey as ``lat lon h`` (WGS84) instead of ``x y z`` in the course frame.

    Returns
    -------
    GatesSim
        ``session`` (kind session): ``acc_* gyr_*`` at 500 Hz, ``mag_*`` [uT] at
        125 Hz on the same instants (null elsewhere); ``truth`` (kind truth) at
        every session row: ``true_x.. true_vx.. true_ax.. true_q0..3 true_roll
        true_pitch true_yaw true_speed`` and, at the row nearest each gate's
        closest approach, ``true_event = "gate"``, ``true_gate``,
        ``true_gate_distance``, ``true_turn``; ``survey`` (kind gates): ``gate``,
        ``x y z`` [m] or ``lat lon h``, ``turn`` (L/R, the side the course turns
        around the gate).  All three carry the course frame (origin on the snow
        at the start, x along the fall-line azimuth, z down).
    """
    cfg = cfg or GatesConfig()
    rng = np.random.default_rng(cfg.seed)
    lat0, lon0, h0 = cfg.site
    g = normal_gravity(lat0, h0)
    tru = _truth(cfg, rng, g)
    body = None
    if cfg.body:  # the skier's posture and seven sensors (sportfusion.gates.sim_skier), calibration first
        from sportfusion.gates.sim_skier import attach_body

        tru, body = attach_body(tru, cfg, FINE_DT)
    c, ter = tru["course"], tru["terrain"]
    tf = tru["t"]
    gx, gy = c["gx"], c["gy"]
    burial = cfg.burial * (1 + 0.2 * rng.uniform(-1, 1, gx.size))
    magnets = np.stack([gx, gy, ter.z(gx, gy)], axis=-1) - burial[:, None] * ter.up_normal(gx, gy)
    moment_local = np.array([0.0, 0.0, cfg.moment])
    # spurious disturbances: small buried metal objects beside the track, between gates
    spur = []
    for _ in range(cfg.spurious):
        i = rng.integers(1, gx.size - 1)
        k = int(np.argmin(np.abs(tru["pos"][:, 0] - (gx[i] + gx[i + 1]) / 2 + rng.uniform(-3, 3))))
        p = tru["pos"][k].copy()
        p[2] += 0.5 + rng.uniform(0.0, 0.2)
        p[1] += rng.uniform(-0.3, 0.3)
        spur.append((p, rng.uniform(0.5, 0.8) * cfg.moment))
    cross = _crossings(tru, magnets, c["sides"])

    def at(x: np.ndarray, times: np.ndarray) -> np.ndarray:
        idx = np.clip(np.rint(times / FINE_DT).astype(int), 0, tf.size - 1)
        return x[idx]

    T = tf[-1]
    ti = np.round(np.arange(0.0, T, 1.0 / cfg.imu_rate) / FINE_DT) * FINE_DT
    q_i = at(tru["q"], ti)
    a_ned = local_to_ned(at(tru["acc"], ti), cfg.azimuth_deg)
    f_ned = a_ned.copy()
    f_ned[:, 2] -= g
    f_b = to_body(q_i, f_ned)
    skiing = at(tru["skiing"], ti) > 0.5
    acc = (
        f_b
        + rng.normal(0, cfg.acc_bias, 3)
        + rng.normal(0, cfg.acc_noise, f_b.shape)
        + rng.normal(0, cfg.acc_vibration, f_b.shape) * skiing[:, None]
    )
    w_b = at(body_rates(tru["q"], FINE_DT), ti)
    walk = np.cumsum(rng.normal(0, cfg.gyr_bias_walk * np.sqrt(1.0 / cfg.imu_rate), w_b.shape), axis=0)
    gyr = (
        w_b
        + rng.normal(0, cfg.gyr_bias, 3)
        + walk
        + rng.normal(0, cfg.gyr_noise, w_b.shape)
        + rng.normal(0, cfg.gyr_vibration, w_b.shape) * skiing[:, None]
    )
    # magnetometer on every (imu_rate / mag_rate)-th IMU instant
    step = int(round(cfg.imu_rate / cfg.mag_rate))
    tm = ti[::step]
    pos_m = at(tru["pos"], tm)
    b_loc = np.zeros_like(pos_m)
    for m in magnets:
        near = np.abs(pos_m[:, 0] - m[0]) < 15.0
        b_loc[near] += dipole_field(pos_m[near] - m, moment_local)
    for p, mom in spur:
        near = np.abs(pos_m[:, 0] - p[0]) < 15.0
        b_loc[near] += dipole_field(pos_m[near] - p, np.array([0.0, 0.0, mom]))
    earth = reference_field(lat0, lon0, h0, cfg.date)
    b_ned = earth + local_to_ned(b_loc, cfg.azimuth_deg)
    mag = to_body(at(tru["q"], tm), b_ned) + rng.normal(0, cfg.mag_bias, 3) + rng.normal(0, cfg.mag_noise, b_loc.shape)

    imu = Stream(
        "imu",
        ti,
        {
            "acc_x": acc[:, 0],
            "acc_y": acc[:, 1],
            "acc_z": acc[:, 2],
            "gyr_x": gyr[:, 0],
            "gyr_y": gyr[:, 1],
            "gyr_z": gyr[:, 2],
        },
    )
    magn = Stream("magnetometer", tm, {"mag_x": mag[:, 0], "mag_y": mag[:, 1], "mag_z": mag[:, 2]})
    streams = [imu, magn]
    if body is not None:
        from sportfusion.gates.sim_skier import body_streams

        body["skiing_at"] = lambda times: at(tru["skiing"], times) > 0.5
        streams += body_streams(body, ti, cfg, rng, g, body_rates)
    session, _ = merge_streams(streams)
    frame = {
        "name": "course",
        "origin": [float(lat0), float(lon0), float(h0)],
        "azimuth_deg": float(cfg.azimuth_deg),
        "axes": "x forward (fall line), y right, z down",
    }
    meta = sfmeta.new_meta("session", cfg.date)
    meta["frame"] = dict(frame)
    meta["sensor"] = {"placement": "sacrum", "body_axes": "x forward, y right, z down (trunk long axis = -z)"}

    # --- truth at every session row ---------------------------------------
    ts = session.column("t").to_numpy()
    qs = at(tru["q"], ts)
    roll, pitch, yaw = euler_from_quat(qs)
    vs = at(tru["vel"], ts)
    cols: dict[str, object] = {"t": ts}
    ps, acs = at(tru["pos"], ts), at(tru["acc"], ts)
    for i, a in enumerate("xyz"):
        cols[f"true_{a}"] = ps[:, i]
        cols[f"true_v{a}"] = vs[:, i]
        cols[f"true_a{a}"] = acs[:, i]
    for i in range(4):
        cols[f"true_q{i}"] = qs[:, i]
    cols.update({"true_roll": roll, "true_pitch": pitch, "true_yaw": yaw, "true_speed": np.linalg.norm(vs, axis=1)})
    ev: list[str | None] = [None] * ts.size
    gid: list[int | None] = [None] * ts.size
    gdist: list[float | None] = [None] * ts.size
    gturn: list[str | None] = [None] * ts.size
    for j in range(magnets.shape[0]):
        r = int(np.argmin(np.abs(ts - cross["t"][j])))
        ev[r], gid[r], gdist[r], gturn[r] = "gate", j + 1, float(cross["distance"][j]), str(cross["turn"][j])
    cols["true_event"] = pa.array(ev, pa.string())
    cols["true_gate"] = pa.array(gid, pa.int32())
    cols["true_gate_distance"] = pa.array(gdist, pa.float64())
    cols["true_turn"] = pa.array(gturn, pa.string())
    if body is not None:
        from sportfusion.gates.sim_skier import body_truth_columns

        cols.update(body_truth_columns(body, ts))
    truth = pa.table(cols)
    truth_meta = sfmeta.new_meta("truth", cfg.date)
    truth_meta["frame"] = dict(frame)

    # --- survey of the magnets ---------------------------------------------
    sh, sv = cfg.survey_sigma
    surveyed = magnets + rng.normal(0, 1, magnets.shape) * np.array([sh, sh, sv])
    gate_no: list[int | None] = list(range(1, magnets.shape[0] + 1))
    turns: list[str | None] = [str(v) for v in cross["turn"]]
    if cfg.survey_spots:  # the snow points under the feet in the static postures, surveyed like the magnets
        spots = np.stack([tru["snow"][0], tru["snow"][-1]])
        surveyed = np.vstack([surveyed, spots + rng.normal(0, 1, spots.shape) * np.array([sh, sh, sv])])
        gate_no += [None, None]
        turns += [None, None]
    scol: dict[str, object] = {"gate": pa.array(gate_no, pa.int32())}
    if survey_wgs84:
        la, lo, hh = local_to_geodetic(surveyed[:, 0], surveyed[:, 1], surveyed[:, 2], cfg.site, cfg.azimuth_deg)
        scol.update({"lat": np.asarray(la), "lon": np.asarray(lo), "h": np.asarray(hh)})
    else:
        scol.update({"x": surveyed[:, 0], "y": surveyed[:, 1], "z": surveyed[:, 2]})
    scol["turn"] = pa.array(turns, pa.string())
    if cfg.survey_spots:
        scol["point"] = pa.array(["gate"] * magnets.shape[0] + ["start", "finish"], pa.string())
    survey = pa.table(scol)
    survey_meta = sfmeta.new_meta("gates", cfg.date)
    survey_meta["frame"] = dict(frame)
    survey_meta["survey"] = {
        "sigma_h": sh,
        "sigma_v": sv,
        "what": "buried magnet positions" + (", static start and finish spots" if cfg.survey_spots else ""),
        "coordinates": "WGS84" if survey_wgs84 else "course frame",
    }
    return GatesSim(session, truth, survey, meta, truth_meta, survey_meta, tru, magnets, cross, body)
