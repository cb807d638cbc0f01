"""Simulated bouldering trial: one hand's IMU + magnetometer on a wall with a hold map.

The wall (4-5 m high, 4 m wide, overhanging by 0-15 deg) carries three routes of
10-20 holds; the first is the route climbed, the others are the wall's other
holds (used on the way down).  Map frame: x right along the wall, y into the
wall (horizontal), z up; the metadata says so.

One hand (the sensor sits on its back, 6 cm along the hand and 3 cm out from the grip point):

* starts gripping one of the route's two start holds, climbs a subset of the
  route's holds to the top hold, then down-climbs 2-4 moves on any holds of the wall;
* grips are off-centre sometimes (6-12 cm from the hold centre), sometimes on the
  wall between holds (at least 0.3 m from every route hold), and sometimes contain
  a grip adjustment (a 2-5 cm re-grip of 0.25 s);
* transitions last 0.3-2 s (minimum-jerk path bulging away from the wall, a
  rotation with a wobble); some arrivals slap the hold, ringing at 30 Hz with
  accelerations beyond the sensor range (clipped at 160 m/s^2);
* while gripping, the hand rolls slowly about the grip point as the body moves
  (up to 0.35 rad per grip, min-jerk) and sways by a few degrees, so the sensor
  on the back of the hand (6.7 cm from the grip point) moves by a few
  centimetres at a few cm/s -- what a zero-velocity update cannot see.

Sensors at ``imu_rate`` (60-100 Hz), the strapdown-integrated outputs of an
Xsens-like unit: the gyroscope gives the mean rate ``Log(R_k^T R_k+1) / dT`` and
the accelerometer the velocity increment in the frame at the start of the
interval, ``R_k^T ((v_k+1 - v_k) / dT - g)``, so the paper's dynamic model (eq 6)
is exact up to the sensor errors: white noise, constant biases, scale-factor and
axis-misalignment errors, range clipping.
Where the instantaneous specific force exceeds the range (a slap), the sample
is the clipped instantaneous value instead -- a range violation whose reading
no longer fits the model.
The magnetometer is normalised to the undisturbed field (unit "1") and sees the
wall's disturbances -- a dipole 1.5-3 m behind the wall (0.1-0.35 of the field
over the whole wall: a heading bias of several degrees) and one or two dipoles
0.2-0.4 m behind the panels (0.2-0.6 at the nearest wall point) -- plus a bias and noise.
``dev_q0..3`` is the unit's own orientation estimate (sensor to world, scalar
first, as the Xsens export gives it) with a slowly varying error of a few degrees.

Written apart from the estimators it scores (:mod:`sportfusion.climbing.transition`, ``particles``,
``holds``): it imports the core and the simulation toolkit only (rotations from ``core.rotations``; the
hold map written in the documented table format here, and read back by the estimator's validator in the
tests).  Besides the errors above, the unit's biases drift with its temperature (the hand warms up by
``temp_rise`` over a minute) and the gyro bias walks; the sensor sits a little differently on every
hand (``lever_spread`` around ``LEVER``).  Named model-mismatch variants (:data:`VARIANTS`,
``BoulderConfig(variant=...)``, ``simulate boulder --variant``) change one aspect of this world at a time.

Everything random comes from ``seed``: the trial's plan from one generator, the unit's extra errors
(lever spread, temperature, bias walk) from a second, so the plan is the same whatever those are.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from sportfusion.core import meta as sfmeta
from sportfusion.core import schema
from sportfusion.core.magfield import field_from_angles
from sportfusion.core.rotations import dcm_from_quat, quat_from_dcm, quat_from_rotvec, rotvec_from_quat, skew
from sportfusion.sim.sensors import temperature_profile

ROUTE_NAMES = ("yellow", "blue", "green", "red", "purple", "black")
LEVER = np.array([-0.06, 0.0, 0.03])  # sensor on the back of the hand, from the grip point (fingers) [m]
DATE = "2026-03-02T15:00:00Z"


def _exp(phi: np.ndarray) -> np.ndarray:
    """Rotation matrices (sensor -> map, Hamilton) of rotation vectors ``phi`` [rad] (..., 3)."""
    return np.swapaxes(dcm_from_quat(quat_from_rotvec(np.asarray(phi, dtype=float))), -1, -2)


def _log(r: np.ndarray) -> np.ndarray:
    """Rotation vectors [rad] of rotation matrices (..., 3, 3)."""
    return rotvec_from_quat(quat_from_dcm(np.swapaxes(np.asarray(r, dtype=float), -1, -2)))


def _quat(r: np.ndarray) -> np.ndarray:
    """Scalar-first quaternions of rotation matrices (the Hamilton ``R(q)``)."""
    return quat_from_dcm(np.swapaxes(np.asarray(r, dtype=float), -1, -2))


#: model-mismatch variants: name -> (what changes, the BoulderConfig fields it sets)
VARIANTS: dict[str, tuple[str, dict]] = {
    "nominal": ("the realistic default", {}),
    "steel-wall": (
        "a steel frame close behind the panels: disturbances 0.6-1.2 of the field near the wall, 0.3-0.5 over it",
        {"disturbance": (0.6, 1.2), "disturbance_far": (0.3, 0.5)},
    ),
    "volumes": (
        "big holds and volumes: most grips 10-25 cm from the hold's centre",
        {"p_off_centre": 0.7, "off_centre": (0.10, 0.25)},
    ),
    "rests": ("long rests: every grip three times as long (the hand rolling and swaying)", {"grip_scale": 3.0}),
    "wall-grips": ("the wall gripped between holds on a third of the moves", {"p_wall_grip": 0.35}),
    "slaps": ("dynamic climbing: half the arrivals slap the hold beyond the accelerometer's range", {"p_impact": 0.5}),
    "sensor": (
        "a poorer unit: scale 3 %, misalignment 1.5 deg, gyro bias walk 1e-3 rad/s/sqrt(s), three times the "
        "temperature drift",
        {"acc_scale": 0.03, "gyr_scale": 0.03, "misalignment": 0.026, "gyr_bias_walk": 1e-3, "temp_rise": 24.0},
    ),
    "big-hand": (
        "a large hand: the sensor 9 cm along the hand and 4.5 cm out from the grip point, 2 cm spread",
        {"lever": (-0.09, 0.0, 0.045), "lever_spread": 0.02},
    ),
}


@dataclass
class BoulderConfig:
    """Parameters of :func:`simulate_boulder` (units in brackets)."""

    seed: int = 0
    imu_rate: float = 100.0  # [Hz], 60-100
    route_holds: int | None = None  # holds on the climbed route, 10-20 (None: drawn)
    duration: float | None = None  # stretch the grips so the trial lasts this long [s]
    wall_width: float = 4.0  # [m]
    p_off_centre: float = 0.2  # probability that a grip is 6-12 cm off the hold centre
    p_wall_grip: float = 0.12  # probability of a wall grip between two holds (per move)
    p_adjust: float = 0.15  # probability of a grip adjustment (per grip longer than 1.2 s)
    p_impact: float = 0.15  # probability that an arrival slaps the hold (per grip)
    grip_roll: float = 0.35  # largest roll of the hand about the grip point during a grip [rad]
    descent_moves: tuple[int, int] = (2, 4)  # down-climbing moves after the top [count]
    gravity: float = 9.81  # [m/s^2]
    inclination_deg: float = 67.5  # local field (Bremen-like)
    declination_deg: float = 2.5
    gyr_noise: float = 0.005  # [rad/s] per sample
    gyr_bias: float = 0.01  # [rad/s] 1-sigma per axis
    acc_noise: float = 0.05  # [m/s^2] per sample
    acc_bias: float = 0.05  # [m/s^2] 1-sigma per axis
    acc_scale: float = 0.01  # scale-factor error, 1-sigma per axis
    gyr_scale: float = 0.01  # scale-factor error, 1-sigma per axis
    misalignment: float = 0.005  # axis misalignment, 1-sigma [rad]
    acc_range: float = 160.0  # [m/s^2]
    gyr_range: float = float(np.deg2rad(2000.0))  # [rad/s]
    mag_noise: float = 0.005  # normalised, per sample
    mag_bias: float = 0.01  # normalised, 1-sigma per axis
    disturbance: tuple[float, float] = (0.2, 0.6)  # disturbance at the nearest wall point (normalised)
    disturbance_far: tuple[float, float] = (0.1, 0.35)  # the frame far behind the wall, over the wall (normalised)
    site: tuple[float, float, float] = (53.1065, 8.8520, 10.0)  # gym: lat [deg], lon [deg], h [m]
    variant: str = "nominal"
    off_centre: tuple[float, float] = (0.06, 0.12)  # distance of an off-centre grip from the hold centre [m]
    grip_scale: float = 1.0  # grip durations times this [1]
    lever: tuple[float, float, float] = tuple(LEVER)  # sensor from the grip point, hand frame [m]
    lever_spread: float = 0.01  # 1-sigma per axis of the sensor's place on this hand [m]
    gyr_bias_walk: float = 2e-4  # [rad/s/sqrt(s)]
    temp_rise: float = 8.0  # the unit warms by this much over the trial [K]
    acc_temp: float = 0.003  # accelerometer bias temperature coefficient, 1-sigma per axis [m/s^2/K]
    gyr_temp: float = 3e-4  # gyro bias temperature coefficient, 1-sigma per axis [rad/s/K]

    def __post_init__(self) -> None:
        if self.variant not in VARIANTS:
            raise ValueError(f"unknown variant {self.variant!r}; expected one of {', '.join(VARIANTS)}")
        fields = BoulderConfig.__dataclass_fields__
        for k, v in VARIANTS[self.variant][1].items():
            if getattr(self, k) == fields[k].default:  # a field set explicitly wins over the variant
                setattr(self, k, v)


@dataclass
class Segment:
    """One piece of the hand's motion: a grip (c0 == c1, R0 == R1) or a move."""

    t0: float
    t1: float
    kind: str  # "grip" or "move"
    c0: np.ndarray
    c1: np.ndarray
    r0: np.ndarray
    r1: np.ndarray
    hold: int = -1  # grips: hold number, -1 on the wall
    bulge: np.ndarray = field(default_factory=lambda: np.zeros(3))  # moves: peak offset from the line [m]
    wobble: np.ndarray = field(default_factory=lambda: np.zeros(3))  # moves: peak extra rotation [rad]
    impact: float = 0.0  # grips: slap amplitude [m] at the start
    adjust: bool = False  # moves: a grip adjustment on the same hold


@dataclass
class Boulder:
    """Output of :func:`simulate_boulder`."""

    session: pa.Table
    truth: pa.Table
    holds: pa.Table
    meta: dict
    truth_meta: dict
    holds_meta: dict
    segments: list[Segment]
    route: str
    start_hold: int
    descent_time: float


@dataclass
class Wall:
    height: float
    width: float
    overhang: float  # [rad]

    @property
    def normal(self) -> np.ndarray:
        """Outward unit normal (towards the climber)."""
        return np.array([0.0, -np.cos(self.overhang), -np.sin(self.overhang)])

    @property
    def up_tangent(self) -> np.ndarray:
        v = np.array([0.0, -np.tan(self.overhang), 1.0])
        return v / np.linalg.norm(v)

    def surface(self, x: float, z: float) -> np.ndarray:
        return np.array([x, -z * np.tan(self.overhang), z])


def _map_field(cfg: BoulderConfig, azimuth_deg: float) -> np.ndarray:
    """Normalised reference field in the map frame (x at ``azimuth_deg``, z up, y = z x x)."""
    n, e, d = field_from_angles(cfg.inclination_deg, cfg.declination_deg)
    a = np.deg2rad(azimuth_deg)
    return np.array([n * np.cos(a) + e * np.sin(a), n * np.sin(a) - e * np.cos(a), -d])


def _min_jerk(s: np.ndarray) -> np.ndarray:
    return s**3 * (10 - 15 * s + 6 * s * s)


def _bump(s: np.ndarray) -> np.ndarray:
    return 16 * s * s * (1 - s) ** 2


def _routes(rng: np.random.Generator, wall: Wall, n_route: int) -> tuple[list[dict], np.ndarray]:
    """Three routes: dicts with name, holds (numbers), pos, start, top."""
    names = [str(v) for v in rng.permutation(ROUTE_NAMES)[:3]]
    centres = rng.permutation([0.9, 2.0, 3.1]) + rng.uniform(-0.15, 0.15, 3)
    taken: list[np.ndarray] = []
    routes = []
    number = 0

    def free(p: np.ndarray, d: float) -> bool:
        return all(np.linalg.norm(p - q) >= d for q in taken)

    def put(x: float, z: float) -> np.ndarray:
        x = float(np.clip(x, 0.2, wall.width - 0.2))
        return wall.surface(x, z) + 0.03 * wall.normal

    for r, (name, xc) in enumerate(zip(names, centres, strict=True)):
        n = n_route if r == 0 else int(rng.integers(10, 17))
        pos = []
        z0 = rng.uniform(1.1, 1.5)
        dx = rng.uniform(0.15, 0.3)
        for sgn in (-1, 1):
            for _ in range(50):
                p = put(xc + sgn * dx + rng.normal(0, 0.03), z0 + rng.uniform(-0.15, 0.15))
                if free(p, 0.22):
                    break
            pos.append(p)
            taken.append(p)
        z_top = wall.height - rng.uniform(0.2, 0.4)
        levels = np.linspace(z0 + 0.45, z_top - 0.35, n - 3)
        side = 1.0
        for z in levels:
            for _ in range(80):
                p = put(xc + side * rng.uniform(0.05, 0.6), z + rng.uniform(-0.1, 0.1))
                if free(p, 0.25):
                    break
            side = -side if rng.random() < 0.75 else side
            pos.append(p)
            taken.append(p)
        for _ in range(50):
            p = put(xc + rng.uniform(-0.4, 0.4), z_top)
            if free(p, 0.25):
                break
        pos.append(p)
        taken.append(p)
        ids = np.arange(number, number + n)
        number += n
        routes.append({"name": name, "holds": ids, "pos": np.array(pos), "start": [int(ids[0]), int(ids[1])]})
        routes[-1]["top"] = int(ids[-1])
    return routes, np.vstack([r["pos"] for r in routes])


def _grip_rotation(rng: np.random.Generator, wall: Wall) -> np.ndarray:
    """Hand frame at a grip: x along the fingers (up the wall), z out of the back of the hand."""
    z = wall.normal
    x = wall.up_tangent
    base = np.column_stack([x, np.cross(z, x), z])
    roll = rng.uniform(-0.7, 0.7)
    tilt = rng.uniform(-0.35, 0.35)
    return base @ _exp(np.array([0.0, tilt, roll]))


def _contact(
    rng: np.random.Generator, wall: Wall, centre: np.ndarray, p_off: float, off: tuple[float, float] = (0.06, 0.12)
) -> np.ndarray:
    """Grip point for a hold centre: a little out of the wall, centred or off-centre."""
    e1 = np.array([1.0, 0.0, 0.0])
    e2 = wall.up_tangent
    if rng.random() < p_off:
        ang = rng.uniform(0, 2 * np.pi)
        d = rng.uniform(*off) * (np.cos(ang) * e1 + np.sin(ang) * e2)
    else:
        d = rng.normal(0, 0.02, 2) @ np.vstack([e1, e2])
    return centre + d + rng.uniform(0.01, 0.03) * wall.normal


def _wall_point(
    rng: np.random.Generator, wall: Wall, a: np.ndarray, b: np.ndarray, holds: np.ndarray
) -> np.ndarray | None:
    """A point on the wall beside the move a -> b, at least 0.3 m from every route hold."""
    mid = 0.5 * (a + b)
    for _ in range(40):
        x = mid[0] + rng.choice([-1, 1]) * rng.uniform(0.25, 0.5)
        z = mid[2] + rng.uniform(-0.2, 0.2)
        if not (0.2 < x < wall.width - 0.2 and 0.8 < z < wall.height - 0.2):
            continue
        p = wall.surface(x, z) + 0.01 * wall.normal
        if np.min(np.linalg.norm(holds - p, axis=1)) >= 0.3:
            return p
    return None


def _plan(
    rng: np.random.Generator, cfg: BoulderConfig, wall: Wall, routes: list[dict], all_pos: np.ndarray
) -> tuple[list[Segment], int, float]:
    """The hand's segments, its start hold and the descent time (arrival at the top hold)."""
    route = routes[0]
    ids, pos = route["holds"], route["pos"]
    start = int(rng.choice(route["start"]))
    middle = [i for i in range(2, len(ids) - 1)]
    middle.sort(key=lambda i: pos[i, 2])
    seq = [int(np.flatnonzero(ids == start)[0])]
    for i in middle:
        last = pos[seq[-1]]
        if np.linalg.norm(pos[i] - last) < 0.2:
            continue
        if rng.random() < 0.6:
            seq.append(i)
    seq.append(len(ids) - 1)
    # fill in skipped holds where a move would be longer than 1.3 m
    full = [seq[0]]
    for j in seq[1:]:
        while np.linalg.norm(pos[j] - pos[full[-1]]) > 1.3:
            cand = [i for i in middle if pos[full[-1], 2] < pos[i, 2] < pos[j, 2] and i not in full]
            if not cand:
                break
            full.append(min(cand, key=lambda i: np.linalg.norm(pos[i] - pos[full[-1]])))
        full.append(j)
    stops: list[tuple[np.ndarray, int, float]] = []  # (hold centre or wall point, hold id, grip time)
    for k, i in enumerate(full):
        dur = rng.uniform(2.0, 3.0) if k == 0 else rng.uniform(0.6, 3.0)
        if k == len(full) - 1:
            dur = rng.uniform(1.5, 3.0)
        if k > 0 and rng.random() < cfg.p_wall_grip:
            w = _wall_point(rng, wall, pos[full[k - 1]], pos[i], pos)
            if w is not None:
                stops.append((w, -1, rng.uniform(0.6, 1.5)))
        stops.append((pos[i], int(ids[i]), dur))
    n_top = len(stops) - 1
    # descent on any holds of the wall
    wall_ids = np.arange(all_pos.shape[0])
    here = pos[-1]
    for _ in range(int(rng.integers(cfg.descent_moves[0], cfg.descent_moves[1] + 1))):
        d = np.linalg.norm(all_pos - here, axis=1)
        drop = here[2] - all_pos[:, 2]
        cand = np.flatnonzero((drop > 0.3) & (drop < 0.9) & (d < 1.0))
        if cand.size == 0:
            break
        j = int(rng.choice(cand))
        stops.append((all_pos[j], int(wall_ids[j]), rng.uniform(0.6, 2.0)))
        here = all_pos[j]
    stops[-1] = (stops[-1][0], stops[-1][1], max(stops[-1][2], 1.2))
    # durations of the moves, then the grips stretched to the requested length
    contacts = [_contact(rng, wall, c, cfg.p_off_centre, cfg.off_centre) if h >= 0 else c for c, h, _ in stops]
    moves = []
    for a, b in zip(contacts[:-1], contacts[1:], strict=True):
        dist = float(np.linalg.norm(b - a))
        moves.append(float(np.clip(0.3 + 0.8 * dist + rng.normal(0, 0.15), 0.3, 2.0)))
    grips = np.array([s[2] for s in stops]) * cfg.grip_scale
    if cfg.duration is not None:
        room = cfg.duration - sum(moves)
        if room > 0.5 * len(grips):
            grips = grips * room / grips.sum()
    segs: list[Segment] = []
    t = 0.0
    rot = _grip_rotation(rng, wall)
    descent = 0.0
    for k, ((_, hold, _), c) in enumerate(zip(stops, contacts, strict=True)):
        if k > 0:
            prev = segs[-1]
            dur = moves[k - 1]
            nxt = _grip_rotation(rng, wall)
            dist = np.linalg.norm(c - prev.c1)
            bulge = wall.normal * rng.uniform(0.03, 0.15) * min(1.0, dist / 0.3)
            axis = rng.normal(size=3)
            wob = axis / np.linalg.norm(axis) * rng.uniform(0.3, 0.8)
            segs.append(Segment(t, t + dur, "move", prev.c1, c, prev.r1, nxt, bulge=bulge, wobble=wob))
            t += dur
            rot = nxt
        if k == n_top:
            descent = t
        g = float(grips[k])
        impact = rng.uniform(0.004, 0.009) if (k > 0 and rng.random() < cfg.p_impact) else 0.0

        def roll(r: np.ndarray) -> np.ndarray:
            axis = rng.normal(size=3)
            return r @ _exp(axis / np.linalg.norm(axis) * rng.uniform(0.0, cfg.grip_roll))

        if hold >= 0 and g > 1.2 and rng.random() < cfg.p_adjust:
            t_a = rng.uniform(0.4, g - 0.65)
            r1 = roll(rot)
            segs.append(Segment(t, t + t_a, "grip", c, c, rot, r1, hold=hold, impact=impact))
            t += t_a
            off = rng.normal(size=2)
            off = off / np.linalg.norm(off) * rng.uniform(0.02, 0.05)
            c2 = c + off[0] * np.array([1.0, 0, 0]) + off[1] * wall.up_tangent
            r2 = r1 @ _exp(rng.uniform(-0.25, 0.25, 3))
            segs.append(Segment(t, t + 0.25, "move", c, c2, r1, r2, hold=hold, adjust=True))
            t += 0.25
            r3 = roll(r2)
            segs.append(Segment(t, t + g - t_a - 0.25, "grip", c2, c2, r2, r3, hold=hold))
            t += g - t_a - 0.25
            c, rot = c2, r3
        else:
            r1 = roll(rot)
            segs.append(Segment(t, t + g, "grip", c, c, rot, r1, hold=hold, impact=impact))
            rot = r1
            t += g
    return segs, start, descent


def _sway(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    amp = rng.uniform(0.01, 0.03, (3, 3))
    freq = rng.uniform(0.2, 0.8, (3, 3))
    phase = rng.uniform(0, 2 * np.pi, (3, 3))
    return amp, freq, phase


def _pose(
    t: np.ndarray, segs: list[Segment], wall: Wall, sway: tuple, lever: np.ndarray = LEVER
) -> tuple[np.ndarray, np.ndarray]:
    """Sensor position (n, 3) [m] and sensor-to-map rotation (n, 3, 3) at times ``t`` [s]."""
    t = np.clip(t, segs[0].t0, None)
    n = t.size
    c = np.zeros((n, 3))
    r0 = np.zeros((n, 3, 3))
    ring = np.zeros(n)
    for s in segs:
        m = (t >= s.t0) & (t < s.t1) if s is not segs[-1] else (t >= s.t0)
        if not m.any():
            continue
        if s.kind == "grip":
            c[m] = s.c0
            u = np.clip((t[m] - s.t0) / (s.t1 - s.t0), 0.0, 1.0)
            r0[m] = s.r0 @ _exp(_min_jerk(u)[:, None] * _log(s.r0.T @ s.r1))
            if s.impact > 0:
                tau = t[m] - s.t0
                ring[m] = s.impact * np.exp(-tau / 0.012) * np.sin(2 * np.pi * 30.0 * tau)
        else:
            u = np.clip((t[m] - s.t0) / (s.t1 - s.t0), 0.0, 1.0)
            sj, b = _min_jerk(u), _bump(u)
            c[m] = s.c0 + sj[:, None] * (s.c1 - s.c0) + b[:, None] * s.bulge
            d = _log(s.r0.T @ s.r1)
            r0[m] = s.r0 @ _exp(sj[:, None] * d) @ _exp(b[:, None] * s.wobble)
    amp, freq, phase = sway
    sw = (amp[None] * np.sin(2 * np.pi * freq[None] * t[:, None, None] + phase[None])).sum(axis=2)
    sw = sw + ring[:, None] * np.array([8.0, 5.0, 0.0])  # the slap also rings the hand (about 0.04 rad)
    rot = r0 @ _exp(sw)
    p = c + rot @ lever - ring[:, None] * wall.normal
    return p, rot


def _dipoles(rng: np.random.Generator, cfg: BoulderConfig, wall: Wall) -> list[tuple[np.ndarray, np.ndarray]]:
    """Magnetic sources behind the wall: the steel of the wall's frame far behind it (a field
    offset over the whole climbing area) and one or two local pieces close behind the panels."""
    out = []
    depths = [rng.uniform(1.5, 3.0)] + [rng.uniform(0.2, 0.4) for _ in range(int(rng.integers(1, 3)))]
    levels = [rng.uniform(*cfg.disturbance_far)] + [rng.uniform(*cfg.disturbance) for _ in depths[1:]]
    for depth, level in zip(depths, levels, strict=True):
        x, z = rng.uniform(0.5, wall.width - 0.5), rng.uniform(1.0, wall.height - 0.5)
        where = wall.surface(x, z) - depth * wall.normal
        m = rng.normal(size=3)
        out.append((where, level * depth**3 * m / np.linalg.norm(m)))
    return out


def disturbance_field(p: np.ndarray, dipoles: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """Local magnetic disturbance (normalised) at positions ``p`` (n, 3) from point dipoles."""
    out = np.zeros_like(p)
    for where, m in dipoles:
        r = p - where
        d = np.linalg.norm(r, axis=1)[:, None]
        rh = r / d
        out += (3 * (rh @ m)[:, None] * rh - m) / d**3
    return out


def _hold_map(
    routes: list[dict], all_pos: np.ndarray, field: np.ndarray, cfg: BoulderConfig, azimuth: float
) -> tuple[pa.Table, dict]:
    """The wall's hold map in the ``holds`` table format (docs/table-contract.md): one row per hold and
    route, the start and top holds, the up axis, the reference field and gravity in the metadata."""
    table = pa.table(
        {
            "route": schema.to_arrow("route", np.array([r["name"] for r in routes for _ in r["holds"]], dtype=object)),
            "hold": schema.to_arrow("hold", np.concatenate([r["holds"] for r in routes]).astype(np.int32)),
            "x": schema.to_arrow("x", all_pos[:, 0]),
            "y": schema.to_arrow("y", all_pos[:, 1]),
            "z": schema.to_arrow("z", all_pos[:, 2]),
        }
    )
    meta = sfmeta.new_meta("holds")
    meta["frame"] = {
        "name": "wall",
        "origin": [float(v) for v in cfg.site],
        "azimuth_deg": float(azimuth),
        "axes": "x right along the wall, y into the wall, z up",
    }
    meta["climbing"] = {
        "up": "z",
        "start_holds": {r["name"]: [int(v) for v in r["start"]] for r in routes},
        "top_holds": {r["name"]: int(r["top"]) for r in routes},
        "magnetic_field": [float(v) for v in field],
        "gravity": float(cfg.gravity),
    }
    return table, meta


def simulate_boulder(cfg: BoulderConfig | None = None) -> Boulder:
    """Simulate one trial: the session (IMU + magnetometer), the truth and the hold map.

    Returns
    -------
    Boulder
        ``session`` (kind session): ``acc_* gyr_* mag_*`` (magnetometer unit "1")
        and ``dev_q0..3`` at the IMU instants; metadata ``climbing`` = {route,
        descent_time [s], hand}.  ``truth`` (kind truth) at every row:
        ``true_x.. true_vx.. true_q0..3`` (map -> sensor, scalar first),
        ``true_grip`` (the hand is still on a hold or the wall) and ``true_hold``
        (hold number, -1 on the wall, null while moving).  ``holds``: the wall's
        hold map (see :mod:`sportfusion.climbing.holds`).
    """
    cfg = cfg or BoulderConfig()
    if not 60.0 <= cfg.imu_rate <= 100.0:
        raise ValueError("imu_rate must be in [60, 100] Hz")
    rng = np.random.default_rng(cfg.seed)
    wall = Wall(rng.uniform(4.0, 5.0), cfg.wall_width, np.deg2rad(rng.uniform(0.0, 15.0)))
    n_route = int(cfg.route_holds if cfg.route_holds is not None else rng.integers(10, 21))
    if not 10 <= n_route <= 20:
        raise ValueError("route_holds must be in [10, 20]")
    routes, all_pos = _routes(rng, wall, n_route)
    segs, start_hold, descent = _plan(rng, cfg, wall, routes, all_pos)
    sway = _sway(rng)
    azimuth = float(rng.uniform(0, 360))
    m_w = _map_field(cfg, azimuth)
    dipoles = _dipoles(rng, cfg, wall)
    rng2 = np.random.default_rng(np.random.SeedSequence([cfg.seed, 39]))  # the unit's extra errors
    lever = np.asarray(cfg.lever, float) + rng2.normal(0.0, cfg.lever_spread, 3)

    dt = 1.0 / cfg.imu_rate
    n = int(np.floor(segs[-1].t1 / dt))
    t = np.arange(n + 1) * dt
    h = 1e-5
    p, rot = _pose(t, segs, wall, sway, lever)
    v = (_pose(t + h, segs, wall, sway, lever)[0] - _pose(t - h, segs, wall, sway, lever)[0]) / (2 * h)
    g_w = np.array([0.0, 0.0, -cfg.gravity])
    gyr_true = _log(np.swapaxes(rot[:-1], 1, 2) @ rot[1:]) / dt
    acc_true = np.einsum("nji,nj->ni", rot[:-1], (v[1:] - v[:-1]) / dt - g_w)
    t, p, v, rot = t[:-1], p[:-1], v[:-1], rot[:-1]
    # a slap drives the instantaneous specific force beyond the range: the unit then
    # reports the clipped instantaneous value instead of a valid increment
    hh = 1e-4
    a_inst = (_pose(t + hh, segs, wall, sway, lever)[0] - 2 * p + _pose(t - hh, segs, wall, sway, lever)[0]) / hh**2
    f_inst = np.einsum("nji,nj->ni", rot, a_inst - g_w)
    over = (np.abs(f_inst) >= cfg.acc_range).any(axis=1)
    acc_true[over] = f_inst[over]
    m_gyr = np.diag(1 + rng.normal(0, cfg.gyr_scale, 3)) + skew(rng.normal(0, cfg.misalignment, 3))
    m_acc = np.diag(1 + rng.normal(0, cfg.acc_scale, 3)) + skew(rng.normal(0, cfg.misalignment, 3))
    gyr = gyr_true @ m_gyr.T + rng.normal(0, cfg.gyr_bias, 3) + rng.normal(0, cfg.gyr_noise, gyr_true.shape)
    acc = acc_true @ m_acc.T + rng.normal(0, cfg.acc_bias, 3) + rng.normal(0, cfg.acc_noise, acc_true.shape)
    # the unit warms on the hand (biases follow its temperature) and the gyro bias walks
    dtemp = temperature_profile(t, 0.0, t[-1], 0.0, cfg.temp_rise, tau=60.0)
    acc = acc + dtemp[:, None] * rng2.normal(0.0, cfg.acc_temp, 3)
    gyr = gyr + dtemp[:, None] * rng2.normal(0.0, cfg.gyr_temp, 3)
    if cfg.gyr_bias_walk > 0:
        gyr = gyr + np.cumsum(rng2.normal(0.0, cfg.gyr_bias_walk * np.sqrt(dt), gyr.shape), axis=0)
    acc = np.clip(acc, -cfg.acc_range, cfg.acc_range)
    gyr = np.clip(gyr, -cfg.gyr_range, cfg.gyr_range)
    m_true = np.einsum("nji,nj->ni", rot, m_w + disturbance_field(p, dipoles))
    mag = m_true + rng.normal(0, cfg.mag_bias, 3) + rng.normal(0, cfg.mag_noise, m_true.shape)
    # the unit's own orientation: the truth with a slowly varying error of a few degrees
    e_amp = rng.uniform(0.01, 0.04, 3)
    e_f = rng.uniform(0.02, 0.1, 3)
    err = e_amp * np.sin(2 * np.pi * e_f * t[:, None] + rng.uniform(0, 2 * np.pi, 3))
    q_dev = _quat(_exp(err) @ rot)

    # truth labels
    grip = np.zeros(t.size, dtype=bool)
    hold = np.full(t.size, -1, dtype=np.int32)
    on = np.zeros(t.size, dtype=bool)
    for s in segs:
        m = (t >= s.t0) & (t < s.t1)
        if s.kind == "grip":
            grip[m] = True
            hold[m] = s.hold
            on[m] = True
        elif s.adjust:
            hold[m] = s.hold
            on[m] = True

    cols = {"t": t}
    for i, a in enumerate("xyz"):
        cols[f"acc_{a}"] = acc[:, i]
    for i, a in enumerate("xyz"):
        cols[f"gyr_{a}"] = gyr[:, i]
    for i, a in enumerate("xyz"):
        cols[f"mag_{a}"] = mag[:, i]
    for i in range(4):
        cols[f"dev_q{i}"] = q_dev[:, i]
    session = pa.table({k: schema.to_arrow(k, v_) for k, v_ in cols.items()})
    route = routes[0]["name"]
    frame = {
        "name": "wall",
        "origin": [float(v_) for v_ in cfg.site],
        "azimuth_deg": azimuth,
        "axes": "x right along the wall, y into the wall, z up",
    }
    meta = sfmeta.new_meta("session", DATE)
    meta["frame"] = dict(frame)
    meta["units"] = {"mag_x": "1", "mag_y": "1", "mag_z": "1"}
    meta["climbing"] = {"route": route, "descent_time": float(descent), "hand": "right", "up": "z"}

    q_bo = _quat(np.swapaxes(rot, 1, 2))
    tcols = {"t": t}
    for i, a in enumerate("xyz"):
        tcols[f"true_{a}"] = p[:, i]
    for i, a in enumerate("xyz"):
        tcols[f"true_v{a}"] = v[:, i]
    for i in range(4):
        tcols[f"true_q{i}"] = q_bo[:, i]
    truth = pa.table({k: schema.to_arrow(k, v_) for k, v_ in tcols.items()})
    truth = truth.append_column("true_grip", pa.array(grip))
    truth = truth.append_column("true_hold", schema.numeric_array(np.asarray(hold, np.int32), ~on))
    truth_meta = sfmeta.new_meta("truth", DATE)
    truth_meta["frame"] = dict(frame)
    truth_meta["climbing"] = {
        "route": route,
        "start_hold": start_hold,
        "descent_time": float(descent),
        "wall_grips": int(sum(1 for s in segs if s.kind == "grip" and s.hold < 0)),
        "adjustments": int(sum(1 for s in segs if s.adjust)),
        "impacts": int(sum(1 for s in segs if s.impact > 0)),
    }

    holds, holds_meta = _hold_map(routes, all_pos, m_w, cfg, azimuth)
    return Boulder(session, truth, holds, meta, truth_meta, holds_meta, segs, route, start_hold, float(descent))
