"""Simulated giant-slalom (or downhill) run over a course of magnet gates, with truth (gates paper setup).

Written apart from the estimator (:mod:`sportfusion.gates.magnet`, ``crossings``, ``anchors``, ``eks``):
it imports the core and the simulation toolkit only, and models the physics more fully than the
estimator assumes.  Two parts: the skier's trajectory (here) and the magnetic scene with the worn
unit's sensors (:mod:`sportfusion.gates.sim_sensors`), which any simulated body can reuse.

Course (local course frame: x along the fall-line azimuth, y right, z down, origin on the snow at the
start):

* ``n_gates`` gates (GS: 30, 22-28 m apart, alternating sides 1.5-3.5 m off the centre line; downhill:
  gates three times further apart) on a terrain whose slope varies along the course and whose drop is
  ``drop`` (150 m over about 700 m); a bar magnet buried under each gate (see ``sim_sensors``); the
  survey (a ``gates`` table) gives the snow point above each magnet, with survey noise;
* the sacrum's snow projection follows a C2 spline that swings around each gate on its outside,
  ``pass_offset`` beyond the gate (first/last gate sometimes 1-1.4 m; ``wide_fraction`` of the gates
  passed ``wide_offset`` wide);
* speed: a push-off from the static start with pole plants (surges of the speed, the sacrum bobbing),
  then the course's speed range, a hockey stop after the finish (the body turns sideways and leans
  back against the braking); static postures of ``static`` seconds at start and finish in which the
  body sways like an inverted pendulum (and, with ``fidgets``, shifts its weight now and then);
* body (a balance model, not the estimator's): the legs align with the specific force (gravity and the
  turn's or the braking's acceleration), so the sacrum sits ``L cos(phi)`` above the snow, ``phi`` the
  inclination of the specific force and ``L`` the leg length, which flexes in the turns and varies from
  gate to gate; the pelvis (and the unit on it) inclines less than the legs (hip angulation
  ``angulation``), faces partly down the fall line (counter-rotation) and its trunk flexes;
* the unit sits ``lever`` from the sacrum point on the back of the pelvis; the truth is the unit's
  position (what ``gate-anchor`` estimates) and attitude.

Sensors (``sim_sensors``): IMU at ``imu_rate`` (500 Hz) and magnetometer at ``mag_rate`` (125 Hz, on
IMU instants) with scale, misalignment, bias, temperature drift, noise, quantisation, range and ski
chatter; the magnetometer sees the Earth field, a geological anomaly, the gate magnets, stray iron and
the athlete's equipment.  Earth rotation and Coriolis terms are left out (below 0.01 m/s^2 and 1e-4 rad/s).

Named model-mismatch variants (:data:`VARIANTS`, ``GatesConfig(variant=...)``, ``simulate gates
--variant``) change one aspect of this world at a time.  Everything random comes from ``seed`` (four
independent streams: course and body, magnetic scene, unit, survey).
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass, field, replace

import numpy as np
import pyarrow as pa

from sportfusion.core import meta as sfmeta
from sportfusion.core.frames import local_to_geodetic
from sportfusion.core.gravity import normal_gravity
from sportfusion.core.magfield import reference_field
from sportfusion.core.rotations import (
    euler_from_quat,
    local_to_ned,
    ned_to_local,
    quat_conjugate,
    quat_from_dcm,
    quat_multiply,
    to_body,
    to_ned,
)
from sportfusion.core.session import Stream, merge_streams
from sportfusion.gates.sim_sensors import (
    MagneticScene,
    MagnetSpec,
    StraySpec,
    UnitSpec,
    field_in_body,
    gate_magnets,
    measure_unit,
    stray_sources,
)
from sportfusion.sim.sensors import TriadSpec

FINE_DT = 0.001  # truth grid [s]

#: model-mismatch variants: name -> (what changes, the GatesConfig fields it sets)
VARIANTS: dict[str, tuple[str, dict]] = {
    "nominal": ("the realistic default", {}),
    "stray-iron": (
        "three pylons 4-7 m from the centre line (3-8 uT at 5 m), four debris objects, a buried snow-making "
        "pipe across the course, a groomer at the finish, a 1 uT geological anomaly",
        {
            "stray": StraySpec(
                pylons=3,
                pylon_field=(3.0, 8.0),
                pylon_distance=(4.0, 7.0),
                debris=4,
                pipe=True,
                groomer=True,
                anomaly=1.0,
                start_hut=5.0,
            )
        },
    ),  # fmt: skip
    "tilted": ("magnets tilted 20 deg (1-sigma) from the snow normal", {"magnets": MagnetSpec(tilt_deg=20.0)}),
    "weak": (
        "weak magnets: 0.4 x the moment (four discs), 20 % spread between magnets",
        {"magnets": MagnetSpec(moment=0.4 * MagnetSpec().moment, spread=0.2)},
    ),
    "deep": ("magnets 0.10-0.25 m under the snow (fresh snow)", {"magnets": MagnetSpec(depth=(0.10, 0.25))}),
    "flipped": ("every magnet buried north pole up", {"magnets": MagnetSpec(polarity="up")}),
    "mixed": ("polarity of each magnet at random", {"magnets": MagnetSpec(polarity="mixed")}),
    "two-charge": ("magnets as two charges +-m/L (no disc stack)", {"magnets": MagnetSpec(model="two-charge")}),
    "wide": (
        "a quarter of the gates passed 1.0-2.2 m wide (no detectable peak for many)",
        {"wide_fraction": 0.25, "wide_offset": (1.0, 2.2)},
    ),
    "still": ("30 s standing at start and finish, swaying, with weight shifts", {"static": 30.0, "fidgets": 2}),
    "sensor": (
        "a poorer unit: accelerometer scale 1 %, gyro scale 1.5 %, three times the temperature drift, "
        "a colder day (25 -> -15 deg C)",
        {
            "unit": UnitSpec(
                acc=TriadSpec(
                    bias=0.05,
                    scale=0.01,
                    misalignment=0.007,
                    noise=0.08,
                    temp_bias=0.006,
                    temp_scale=3e-4,
                    resolution=16 * 9.80665 / 32768,
                    range=16 * 9.80665,
                ),
                gyr=TriadSpec(
                    bias=0.02,
                    bias_walk=2e-4,
                    scale=0.015,
                    misalignment=0.007,
                    noise=0.008,
                    temp_bias=6e-4,
                    temp_scale=3e-4,
                    resolution=np.deg2rad(2000.0) / 32768,
                    range=np.deg2rad(2000.0),
                ),
                temperature=(25.0, -15.0),
            )
        },
    ),  # fmt: skip
    "athlete": (
        "a smaller athlete skiing lower: leg length 0.78 m, standing 0.88 m, strong angulation 0.45",
        {"leg_length": 0.78, "stand_height": 0.88, "angulation": 0.45},
    ),
}


@dataclass
class GatesConfig:
    """Parameters of :func:`simulate_gates` (units in brackets); ``variant`` applies one of :data:`VARIANTS`."""

    seed: int = 0
    variant: str = "nominal"
    downhill: bool = False
    n_gates: int = 30
    spacing: tuple[float, float] = (22.0, 28.0)  # gate-to-gate distance [m]
    lateral: tuple[float, float] = (1.5, 3.5)  # gate offset from the centre line [m]
    drop: float = 150.0  # vertical drop start -> finish [m]
    speed: tuple[float, float] = (15.0, 25.0)  # speed range on the course [m/s]
    static: float = 5.0  # static posture at start and at finish [s]
    fidgets: int = 0  # weight shifts in each static posture [count]
    sway: float = 0.01  # amplitude of the standing body's sway at the sacrum [m]
    imu_rate: float = 500.0  # [Hz]
    mag_rate: float = 125.0  # [Hz]
    site: tuple[float, float, float] = (46.8345, 9.2103, 1600.0)  # start: lat [deg], lon [deg], h [m]
    azimuth_deg: float = 20.0  # fall line / course-frame x axis, clockwise from north [deg]
    date: str = "2026-01-20T10:00:00Z"
    moment: float | None = None  # magnet moment [A m^2]; None: the magnets' spec (0: a course without magnets)
    spurious: int | None = None  # debris objects beside the track [count]; None: the stray spec's
    pass_offset: tuple[float, float] = (0.0, 0.5)  # sacrum's snow projection beyond the gate [m]
    wide_fraction: float = 0.0  # gates (besides the first and last) passed wide [fraction]
    wide_offset: tuple[float, float] = (1.0, 1.4)  # how wide [m]
    leg_length: float = 0.92  # sacrum above the ski contact along the legs while skiing [m]
    stand_height: float = 1.0  # sacrum above the snow standing upright [m]
    flexion: float = 0.12  # relative shortening of the legs at the largest lean [1]
    height_spread: float = 0.05  # relative 1-sigma of the leg length at each gate [1]
    angulation: float = 0.25  # the pelvis inclines (1 - angulation) times the legs' inclination [1]
    lever: tuple[float, float, float] = (-0.09, 0.0, -0.02)  # unit from the sacrum point, body axes [m]
    survey_sigma: tuple[float, float] = (0.02, 0.03)  # survey noise, horizontal / vertical [m]
    survey_spots: bool = False  # also survey the snow spots of the static postures (rows point = start/finish)
    magnets: MagnetSpec = field(default_factory=MagnetSpec)
    stray: StraySpec = field(default_factory=StraySpec)
    unit: UnitSpec = field(default_factory=UnitSpec)
    # a full-body skier with seven IMUs (sportfusion.gates.sim_skier; simulate gates --body)
    body: bool = False
    height: float = 1.80  # athlete's height [m]
    body_mass: float = 78.0  # athlete's mass without equipment [kg]
    max_misalignment: float = 30.0  # sensor strap rotation, at most [deg]

    def __post_init__(self) -> None:
        if self.variant not in VARIANTS:
            raise ValueError(f"unknown variant {self.variant!r}; expected one of {', '.join(VARIANTS)}")
        defaults = GatesConfig.__dataclass_fields__
        for k, v in VARIANTS[self.variant][1].items():
            d = defaults[k]
            default = d.default_factory() if d.default_factory is not MISSING else d.default
            if getattr(self, k) == default:
                setattr(self, k, v)
        if self.moment is not None:
            self.magnets = replace(self.magnets, moment=float(self.moment))
        if self.spurious is not None:
            self.stray = replace(self.stray, debris=int(self.spurious))
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
    magnets: np.ndarray = field(repr=False)  # (N, 3) the surveyed points (snow above each magnet), course frame [m]
    crossings: dict = field(repr=False)  # truth per gate: t, distance (to the magnet's centre), turn, fine index
    magnet_centres: np.ndarray = field(default=None, repr=False)  # (N, 3) centre of each magnet [m]
    scene: MagneticScene | None = field(default=None, repr=False)
    body: dict | None = field(default=None, repr=False)  # the skier (--body): sportfusion.gates.sim_skier


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    """Active rotations (n, 3, 3) by ``angle`` [rad] about the body axis ``axis`` (0 x, 1 y, 2 z)."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros((np.size(angle), 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out[:, axis, axis] = 1.0
    out[:, i, i] = out[:, j, j] = c
    out[:, i, j], out[:, j, i] = -s, s
    return out


def _smooth(x: np.ndarray, width: int) -> np.ndarray:
    """Hann-window moving average of ``width`` samples (odd) along axis 0, edges held."""
    ker = np.hanning(width + 2)[1:-1]
    ker /= ker.sum()
    half = width // 2
    pad = [(half, half)] + [(0, 0)] * (x.ndim - 1)
    xp = np.pad(x, pad, mode="edge")
    if x.ndim == 1:
        return np.convolve(xp, ker, mode="valid")
    return np.stack([np.convolve(xp[:, j], ker, mode="valid") for j in range(x.shape[1])], axis=-1)


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
    # first and last gates are often passed wide (the paper: usually those are missed), others now and then
    for i in (0, n - 1):
        if rng.random() < 0.4:
            offset[i] = rng.uniform(1.0, 1.4)
    wide = rng.random(n) < cfg.wide_fraction
    offset[wide] = rng.uniform(*cfg.wide_offset, int(wide.sum()))
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


def _timing(cfg: GatesConfig, rng: np.random.Generator, s_of_x: np.ndarray, s_fin: float) -> tuple[np.ndarray, int]:
    """Distance along the path s [m] on the fine grid of the run (push-off to stop) and the stop index."""
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
    brake = rng.uniform(6.0, 8.0)
    s_end = s_of_x[-1]
    s_stop = s_fin + 0.8 * (s_end - s_fin)
    u_s = np.minimum(base, np.sqrt(2 * push * (s_of_x + 0.02)))
    u_s = np.minimum(u_s, np.sqrt(2 * brake * np.maximum(s_stop - s_of_x, 0.0)))
    n_run = int(400.0 / FINE_DT)
    s = np.zeros(n_run)
    k_stop = n_run - 1
    u_prev = 0.0
    for i in range(1, n_run):
        u = np.interp(s[i - 1], s_of_x, u_s)
        if u < 0.05 and s[i - 1] > s_fin:
            k_stop = i
            s[i:] = s[i - 1]
            break
        if s[i - 1] < s_fin:  # the push-off's acceleration builds up over 0.6 s
            u = min(u, u_prev + push * float(_smoothstep(np.array(i * FINE_DT / 0.6))) * FINE_DT)
        u_prev = max(u, 1e-3)
        s[i] = s[i - 1] + u_prev * FINE_DT
    s = s[: k_stop + 1]
    # pole plants in the push-off: speed surges of +-0.25 m/s at 1.1-1.5 Hz over the first 2-3 s
    tr = np.arange(s.size) * FINE_DT
    fp = rng.uniform(1.1, 1.5)
    env = _smoothstep(tr / 0.4) * (1 - _smoothstep((tr - rng.uniform(2.0, 3.0)) / 0.6))
    du = 0.25 * env * (1 - np.cos(2 * np.pi * fp * tr))
    s = s + np.cumsum(du) * FINE_DT
    s[-1:] = s[-2]
    return s, k_stop


def _standing(cfg: GatesConfig, rng: np.random.Generator, t: np.ndarray, still: np.ndarray) -> np.ndarray:
    """Horizontal displacement (n, 2) [m] of the standing body's sacrum: sway (a few sines, 0.15-0.6 Hz) and
    weight shifts (``fidgets`` per posture: 3-6 cm over 0.8 s, held 1.5-3 s, back), zero while skiing."""
    d = np.zeros((t.size, 2))
    for j in range(2):
        for _ in range(3):
            f = rng.uniform(0.15, 0.6)
            d[:, j] += cfg.sway / 2 * rng.uniform(0.5, 1.0) * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
    runs = np.flatnonzero(np.diff(np.concatenate(([0], still.astype(int), [0]))))
    for a, b in zip(runs[::2], runs[1::2], strict=True):
        ta, tb = t[a], t[b - 1]
        for _ in range(cfg.fidgets):
            t0 = rng.uniform(ta + 1.0, max(tb - 6.0, ta + 1.5))
            hold = rng.uniform(1.5, 3.0)
            shift = rng.normal(size=2)
            shift *= rng.uniform(0.03, 0.06) / np.linalg.norm(shift)
            bump = _smoothstep((t - t0) / 0.8) * (1 - _smoothstep((t - t0 - 0.8 - hold) / 0.8))
            d += bump[:, None] * shift
    return d


def _truth(cfg: GatesConfig, rng: np.random.Generator, g: float) -> dict:
    """Course, terrain and the unit's truth on the fine grid (see the module text)."""
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
    s_run, k_stop = _timing(cfg, rng, s_of_x, s_fin)
    n_static = int(round(cfg.static / FINE_DT))
    s_all = np.concatenate((np.zeros(n_static), s_run, np.full(n_static, s_run[-1])))
    s_all = np.maximum.accumulate(_smooth(s_all, 41))  # removes the Euler kinks, keeps it monotone
    t = np.arange(s_all.size) * FINE_DT
    x = np.maximum.accumulate(x_of_s(s_all))
    y = path(x)
    snow = np.stack([x, y, ter.z(x, y)], axis=-1)
    nup = ter.up_normal(x, y)
    tr = t - cfg.static
    t_run_end = k_stop * FINE_DT
    skiing = _smoothstep(tr / 1.5) * (1 - _smoothstep((tr - t_run_end + 1.5) / 1.5))
    still = (tr < 0) | (tr > t_run_end)
    # horizontal kinematics of the snow point
    vs = np.gradient(snow, FINE_DT, axis=0)
    a_h = _smooth(np.gradient(vs[:, :2], FINE_DT, axis=0), 301)
    vh = vs[:, :2]
    sp = np.linalg.norm(vh, axis=1)
    moving = sp > 0.5
    heading = np.unwrap(np.arctan2(vh[:, 1], vh[:, 0]))
    heading = np.where(moving, heading, np.nan)
    idx = np.flatnonzero(np.isfinite(heading))
    heading = _smooth(np.interp(np.arange(t.size), idx, heading[idx]), 101)
    # the pelvis twists against the turn (counter-rotation: it faces towards the course direction); a hockey
    # stop turns it sideways
    course_dir = _smooth(heading, 3001)
    k_brake = int(np.argmax((x > c["x_finish"]) & (np.gradient(sp, FINE_DT) < -2.0)))
    hs = rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 1.4)
    twist = -0.3 * (heading - course_dir) + hs * _smoothstep((t - t[k_brake]) / 0.6)
    fwd = np.stack([np.cos(heading), np.sin(heading)], axis=-1)
    right = np.stack([-np.sin(heading), np.cos(heading)], axis=-1)
    a_fwd, a_right = np.sum(a_h * fwd, axis=1), np.sum(a_h * right, axis=1)
    # legs along the specific force: inclination phi; the pelvis inclines less (angulation)
    phi = np.arctan(np.linalg.norm(a_h, axis=1) / g)
    gate_s = np.interp(c["gx"], xs, s_of_x)
    hv = rng.normal(0, cfg.height_spread, c["gx"].size)
    hv_s = CubicSpline(np.concatenate(([0.0], gate_s, [s_end])), np.concatenate(([0.0], hv, [0.0])))
    phi_late = np.interp(t - 0.2, t, phi)  # the legs flex most just after the largest lean
    bob = 0.03 * np.sin(2 * np.pi * 1.3 * tr) * _smoothstep(tr / 0.4) * (1 - _smoothstep((tr - 2.5) / 0.6))
    leg = cfg.leg_length * (1 - cfg.flexion * np.tanh(phi_late**2 / 0.5)) * (1 + hv_s(s_all)) + bob
    stand = _standing(cfg, rng, t, still)
    height = (cfg.stand_height * (1 - skiing) + leg * skiing) * np.cos(phi)
    up = (1.0 - skiing)[:, None] * np.array([0.0, 0.0, -1.0]) + skiing[:, None] * nup
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    sacrum = snow + height[:, None] * up
    sacrum[:, :2] += stand * (1.0 - skiing)[:, None]
    # attitude of the pelvis (body axes x forward, y right, z down): inclined along the specific force in the
    # travel frame (by 1 - angulation of the legs' inclination; standing, by the sway), then twisted about its
    # long axis and flexed forward
    stand = stand * (1.0 - skiing)[:, None]
    sway_fwd, sway_right = np.sum(stand * fwd, axis=1), np.sum(stand * right, axis=1)
    flex = skiing * (0.35 + 0.1 * np.tanh(phi**2)) + 8.0 * bob
    lean_r = (1 - cfg.angulation) * np.arctan(a_right / g) + sway_right / cfg.stand_height
    lean_f = (1 - cfg.angulation) * np.arctan(a_fwd / g) + sway_fwd / cfg.stand_height
    c_bn = _rot(2, np.deg2rad(cfg.azimuth_deg) + heading) @ _rot(0, lean_r) @ _rot(1, -lean_f)
    c_bn = c_bn @ _rot(2, twist) @ _rot(1, -flex)
    q = quat_from_dcm(np.swapaxes(c_bn, 1, 2))
    roll = euler_from_quat(q)[0]
    lever = ned_to_local(to_ned(q, np.broadcast_to(np.asarray(cfg.lever, float), (t.size, 3))), cfg.azimuth_deg)
    pos = sacrum + lever
    vel = np.gradient(pos, FINE_DT, axis=0)
    acc = np.gradient(vel, FINE_DT, axis=0)
    return {
        "t": t,
        "pos": pos,
        "vel": vel,
        "acc": acc,
        "q": q,
        "roll": roll,
        "lean": phi,
        "height": height,
        "skiing": skiing,
        "course": c,
        "terrain": ter,
        "snow": snow,
        "speed": sp,
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
    """Truth per gate: the instant of closest approach of the unit to the magnet's centre, distance, turn side."""
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
        every session row: the unit's ``true_x.. true_vx.. true_ax.. true_q0..3 true_roll
        true_pitch true_yaw true_speed`` and, at the row nearest each gate's
        closest approach, ``true_event = "gate"``, ``true_gate``,
        ``true_gate_distance`` (to the magnet's centre), ``true_turn``; ``survey`` (kind gates): ``gate``,
        ``x y z`` [m] or ``lat lon h`` (the snow point above each magnet), ``turn`` (L/R, the side the
        course turns around the gate).  All three carry the course frame (origin on the snow
        at the start, x along the fall-line azimuth, z down).
    """
    cfg = cfg or GatesConfig()
    rng_body, rng_scene, rng_unit, rng_survey = (
        np.random.default_rng(s) for s in np.random.SeedSequence(cfg.seed).spawn(4)
    )
    lat0, lon0, h0 = cfg.site
    g = normal_gravity(lat0, h0)
    tru = _truth(cfg, rng_body, g)
    body = None
    if cfg.body:  # the skier's posture and seven sensors (sportfusion.gates.sim_skier), calibration first
        from sportfusion.gates.sim_skier import attach_body

        tru, body = attach_body(tru, cfg, FINE_DT)
    c, ter = tru["course"], tru["terrain"]
    tf = tru["t"]
    gx, gy = c["gx"], c["gy"]
    snow_g = np.stack([gx, gy, ter.z(gx, gy)], axis=-1)
    magnets, centres, _ = gate_magnets(cfg.magnets, rng_scene, snow_g, ter.up_normal(gx, gy))
    earth = reference_field(lat0, lon0, h0, cfg.date)
    stray, anomaly = stray_sources(
        cfg.stray, rng_scene, tru["pos"][::50], gx, ned_to_local(earth, cfg.azimuth_deg), ter.z
    )
    scene = MagneticScene(earth, cfg.azimuth_deg, magnets, stray, anomaly)
    cross = _crossings(tru, centres, c["sides"])

    def at(x: np.ndarray, times: np.ndarray) -> np.ndarray:
        idx = np.clip(np.rint(times / FINE_DT).astype(int), 0, tf.size - 1)
        return x[idx]

    T = tf[-1]
    ti = np.round(np.arange(0.0, T, 1.0 / cfg.imu_rate) / FINE_DT) * FINE_DT
    q_i = at(tru["q"], ti)
    f_ned = local_to_ned(at(tru["acc"], ti), cfg.azimuth_deg) - np.array([0.0, 0.0, g])
    step = int(round(cfg.imu_rate / cfg.mag_rate))
    tm = ti[::step]
    b_body = field_in_body(scene, at(tru["pos"], tm), at(tru["q"], tm))
    acc, gyr, mag = measure_unit(
        cfg.unit,
        rng_unit,
        ti,
        to_body(q_i, f_ned),
        at(body_rates(tru["q"], FINE_DT), ti),
        at(tru["speed"], ti),
        tm,
        b_body,
        at(tru["lean"], tm),
        tru["t_run"],
    )

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

        rng_skin = np.random.default_rng(np.random.SeedSequence(cfg.seed).spawn(5)[4])  # the six other units
        streams += body_streams(body, ti, cfg, rng_skin, g, body_rates, at(tru["speed"], ti), tru["t_run"])
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
    for j in range(snow_g.shape[0]):
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
    surveyed = snow_g + rng_survey.normal(0, 1, snow_g.shape) * np.array([sh, sh, sv])
    gate_no: list[int | None] = list(range(1, snow_g.shape[0] + 1))
    turns: list[str | None] = [str(v) for v in cross["turn"]]
    if cfg.survey_spots:  # the snow points under the feet in the static postures, surveyed like the magnets
        spots = np.stack([tru["snow"][0], tru["snow"][-1]])
        surveyed = np.vstack([surveyed, spots + rng_survey.normal(0, 1, spots.shape) * np.array([sh, sh, sv])])
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
        scol["point"] = pa.array(["gate"] * snow_g.shape[0] + ["start", "finish"], pa.string())
    survey = pa.table(scol)
    survey_meta = sfmeta.new_meta("gates", cfg.date)
    survey_meta["frame"] = dict(frame)
    survey_meta["survey"] = {
        "sigma_h": sh,
        "sigma_v": sv,
        "what": "snow points above the buried magnets"
        + (", static start and finish spots" if cfg.survey_spots else ""),
        "coordinates": "WGS84" if survey_wgs84 else "course frame",
    }
    return GatesSim(session, truth, survey, meta, truth_meta, survey_meta, tru, snow_g, cross, centres, scene, body)
