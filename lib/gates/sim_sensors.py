"""The sensor side of the magnet-gate simulator: the course's magnetic scene and a body-worn unit's readings.

Separate from the skier's trajectory (:mod:`sportfusion.gates.sim`), so that any simulated body -- the
sacrum unit alone or a full body of units -- is measured in the same scene.  Built on the simulation
toolkit only (:mod:`sportfusion.sim.magnetics`, :mod:`sportfusion.sim.sensors`), never on the
estimator's magnet model: the physics here is fuller than what the estimator assumes.

The scene (local course frame: x along the fall line, y right, z down; fields in uT):

* the Earth's main field at the site (World Magnetic Model) plus a smooth geological anomaly
  (deep charge pairs: a few hundred nT over the course);
* at every gate a buried magnet: a stack of ten axially magnetised discs (the paper's 10 x S-20-10-N on
  a 15 cm stick) whose top lies ``depth`` below the snow, tilted from the snow normal by a few degrees,
  with a moment spread between magnets and a polarity (down: it adds to the Earth's downward field
  above it); the survey gives the snow point above the stick's top;
* stray iron: lift pylons beside the course (vertical steel rods magnetised by the Earth field), small
  buried metal objects beside the track (debris), optionally a buried snow-making pipe crossing the
  course (a line of induced dipoles) and a parked snow groomer near the finish (a large dipole).

The unit (:func:`measure_unit`): accelerometer, gyroscope and magnetometer as
:class:`sportfusion.sim.sensors.Triad` chips with scale, misalignment, bias, temperature drift,
noise, quantisation and range; ski chatter (band-limited vibration growing with speed) on the
accelerometer and gyroscope; the athlete's own equipment (binding and boot steel about a metre below
the sacrum) as a field fixed to the body that changes with the lean.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sportfusion.core.rotations import local_to_ned, to_body
from sportfusion.sim.magnetics import (
    M_N42,
    Anomaly,
    Charges,
    bar_magnet,
    iron_rod,
    point_dipole_charges,
    rod_pole_for_field,
    two_charge_magnet,
)
from sportfusion.sim.sensors import TriadSpec, band_noise, temperature_profile

#: the paper's magnet: ten N42 discs of 20 x 10 mm -> moment [A m^2]
STACK_MOMENT = 10 * M_N42 * np.pi * 0.010**2 * 0.010
STACK_LENGTH = 10 * 0.010 + 9 * 0.005  # [m]


@dataclass(frozen=True)
class MagnetSpec:
    """The buried gate magnets (units in brackets).

    Attributes
    ----------
    moment : float
        Nominal moment of one magnet [A m^2] (the paper's stack: about 32).
    spread : float
        Relative 1-sigma of the moment between magnets (grade, temperature, chipped discs) [1].
    tilt_deg : float
        1-sigma tilt of the stick from the snow normal [deg].
    polarity : str
        ``"down"`` (north pole down: adds to the Earth's downward field above it), ``"up"``, ``"mixed"``.
    depth : tuple
        Range of the depth of the stick's top below the snow [m].
    model : str
        ``"stack"`` (ten charged disc pairs) or ``"two-charge"`` (``+-m/L`` at the stick's ends).
    """

    moment: float = float(STACK_MOMENT)
    spread: float = 0.05
    tilt_deg: float = 4.0
    polarity: str = "down"
    depth: tuple[float, float] = (0.02, 0.06)
    model: str = "stack"


@dataclass(frozen=True)
class StraySpec:
    """Stray iron and background (units in brackets).

    Attributes
    ----------
    pylons : int
        Lift pylons beside the course [count].
    pylon_field : tuple
        Range of a pylon's anomaly 5 m from its base [uT].
    pylon_distance : tuple
        Range of the pylons' distance from the course centre line [m].
    debris : int
        Small buried metal objects beside the track, between gates [count].
    debris_moment : tuple
        Range of a debris object's moment [A m^2].
    pipe : bool
        A buried snow-making pipe crossing the course.
    groomer : bool
        A snow groomer parked near the finish.
    anomaly : float
        Size of the geological anomaly at the surface [uT].
    start_hut : float
        Anomaly of the start hut's steel where the athlete stands [uT].
    """

    pylons: int = 1
    pylon_field: tuple[float, float] = (0.5, 2.0)
    pylon_distance: tuple[float, float] = (8.0, 15.0)
    debris: int = 1
    debris_moment: tuple[float, float] = (15.0, 25.0)
    pipe: bool = False
    groomer: bool = False
    anomaly: float = 0.3
    start_hut: float = 2.0


@dataclass(frozen=True)
class UnitSpec:
    """The body-worn unit: three chips, vibration, temperature, equipment (units in brackets).

    Attributes
    ----------
    acc, gyr, mag : TriadSpec
        Error sizes of the accelerometer [m/s^2], gyroscope [rad/s] and magnetometer [uT].
    acc_vibration : float
        RMS of the ski chatter on the accelerometer at 20 m/s (band 8-60 Hz, growing with speed) [m/s^2].
    gyr_vibration : float
        RMS of the chatter on the gyroscope at 20 m/s (band 5-40 Hz) [rad/s].
    temperature : tuple
        Sensor temperature at the start (warm under the suit) and the air temperature [deg C].
    cooling : float
        Time constant of the cooling in the wind of the run [s].
    calibrated_at : float
        Temperature of the sensor's calibration [deg C].
    equipment : float
        Field of the athlete's steel (bindings, boots) at the sensor, changing with the lean [uT].
    """

    acc: TriadSpec = field(
        default_factory=lambda: TriadSpec(
            bias=0.03, scale=0.003, misalignment=0.0035, noise=0.05, temp_bias=0.002,
            temp_scale=1e-4, resolution=16 * 9.80665 / 32768, range=16 * 9.80665,
        )
    )  # fmt: skip
    gyr: TriadSpec = field(
        default_factory=lambda: TriadSpec(
            bias=0.01, bias_walk=1e-4, scale=0.005, misalignment=0.0035, noise=0.005, temp_bias=2e-4,
            temp_scale=1e-4, resolution=np.deg2rad(2000.0) / 32768, range=np.deg2rad(2000.0),
        )
    )  # fmt: skip
    mag: TriadSpec = field(
        default_factory=lambda: TriadSpec(
            bias=0.3, scale=0.005, misalignment=0.005, noise=0.3, temp_bias=0.03, resolution=0.1, range=800.0,
        )
    )  # fmt: skip
    acc_vibration: float = 1.5
    gyr_vibration: float = 0.05
    temperature: tuple[float, float] = (20.0, -5.0)
    cooling: float = 120.0
    calibrated_at: float = 20.0
    equipment: float = 0.5


@dataclass
class MagneticScene:
    """Sources of the course (local frame) and the Earth field (NED) [uT]."""

    earth_ned: np.ndarray
    azimuth_deg: float
    magnets: list[Charges]
    stray: list[Charges]
    anomaly: Anomaly | None = None
    reach: float = 6.0  # a gate magnet's field is evaluated within this distance [m]

    def field_local(self, p: np.ndarray) -> np.ndarray:
        """Field of every source but the Earth's main field at points ``p`` (n, 3) [m], local frame [uT]."""
        p = np.asarray(p, dtype=float)
        out = np.zeros_like(p)
        for src in self.magnets:
            near = src.near(p, self.reach)
            if near.any():
                out[near] += src.field(p[near])
        for src in self.stray:
            out += src.field(p)
        if self.anomaly is not None:
            out += self.anomaly.field(p)
        return out

    def field_ned(self, p: np.ndarray) -> np.ndarray:
        """Total field at ``p`` (n, 3) [m] in NED [uT]."""
        return self.earth_ned + local_to_ned(self.field_local(p), self.azimuth_deg)


def _tilted(normal: np.ndarray, tilt: float, rng: np.random.Generator) -> np.ndarray:
    """A unit vector ``tilt`` [rad] from ``normal`` in a random direction."""
    a = rng.normal(size=3)
    a -= a.dot(normal) * normal
    a /= np.linalg.norm(a)
    return np.cos(tilt) * normal + np.sin(tilt) * a


def gate_magnets(
    spec: MagnetSpec, rng: np.random.Generator, snow: np.ndarray, up: np.ndarray
) -> tuple[list[Charges], np.ndarray, np.ndarray]:
    """One magnet per gate under the snow points ``snow`` (N, 3) with out-of-snow normals ``up`` (N, 3).

    Returns
    -------
    magnets : list of Charges
    centres : ndarray (N, 3)
        Centre of each stick [m].
    tops : ndarray (N, 3)
        Top of each stick [m] (its snow point is the surveyed point).
    """
    n = snow.shape[0]
    depth = rng.uniform(*spec.depth, n)
    moment = spec.moment * np.maximum(1.0 + spec.spread * rng.normal(size=n), 0.05)
    tilt = np.abs(rng.normal(0.0, np.deg2rad(spec.tilt_deg), n))
    pol = {"down": -np.ones(n), "up": np.ones(n), "mixed": rng.choice([-1.0, 1.0], n)}[spec.polarity]
    mags, centres, tops = [], np.empty((n, 3)), np.empty((n, 3))
    for i in range(n):
        axis = _tilted(up[i], tilt[i], rng)  # along the stick, pointing out of the snow
        top = snow[i] - depth[i] * up[i]
        centre = top - axis * STACK_LENGTH / 2
        m_dir = pol[i] * axis  # "down": the moment points into the snow (north pole down)
        if spec.model == "two-charge":
            mags.append(two_charge_magnet(centre, m_dir, moment[i], STACK_LENGTH))
        else:
            mags.append(bar_magnet(centre, m_dir, moment[i]))
        centres[i], tops[i] = centre, top
    return mags, centres, tops


def stray_sources(
    spec: StraySpec,
    rng: np.random.Generator,
    track: np.ndarray,
    gates_x: np.ndarray,
    earth_local: np.ndarray,
    snow_z,  # noqa: ANN001 - callable z(x, y) of the snow surface [m]
) -> tuple[list[Charges], Anomaly | None]:
    """Stray iron along the course and the geological anomaly.

    ``track`` (n, 3) is the sacrum's path (to place debris beside it), ``gates_x`` the gates' x [m],
    ``earth_local`` the Earth field in the local frame [uT] (iron magnetises along it), ``snow_z`` the
    snow surface.
    """
    out: list[Charges] = []
    e_hat = earth_local / np.linalg.norm(earth_local)
    x_lo, x_hi = float(track[:, 0].min()), float(track[:, 0].max())
    for _ in range(spec.pylons):
        x = rng.uniform(x_lo + 20.0, x_hi - 20.0)
        y = rng.choice([-1.0, 1.0]) * rng.uniform(*spec.pylon_distance)
        base = np.array([x, y, float(snow_z(x, y))])
        top = base - np.array([0.0, 0.0, rng.uniform(8.0, 14.0)])
        pole = rod_pole_for_field(rng.uniform(*spec.pylon_field), 5.0)
        # the vertical field component (down) magnetises the rod top -> base: + charge at the base
        out.append(iron_rod(top, base, pole * np.sign(e_hat[2]), rng=rng))
    for _ in range(spec.debris):
        i = int(rng.integers(1, max(gates_x.size - 1, 2)))
        xm = (gates_x[min(i, gates_x.size - 1)] + gates_x[i - 1]) / 2 + rng.uniform(-3, 3)
        k = int(np.argmin(np.abs(track[:, 0] - xm)))
        p = track[k].copy()
        p[1] += rng.uniform(-0.3, 0.3)
        p[2] = float(snow_z(p[0], p[1])) + rng.uniform(0.0, 0.15)
        mom = rng.normal(size=3)
        out.append(point_dipole_charges(p, mom / np.linalg.norm(mom) * rng.uniform(*spec.debris_moment)))
    if spec.pipe:  # a steel pipe 0.5 m under the snow, crossing the course obliquely
        xc = rng.uniform(x_lo + 0.3 * (x_hi - x_lo), x_hi - 0.3 * (x_hi - x_lo))
        ang = rng.uniform(np.deg2rad(50), np.deg2rad(130))
        u = np.array([np.cos(ang), np.sin(ang), 0.0])
        for s in np.arange(-15.0, 15.01, 0.5):
            q = np.array([xc, 0.0, 0.0]) + s * u
            q[2] = float(snow_z(q[0], q[1])) + 0.5
            m = (e_hat - e_hat.dot(u) * u) * 2.0 * rng.uniform(0.7, 1.3)  # induced across the pipe [A m^2]
            out.append(point_dipole_charges(q, m, 0.1))
    if spec.groomer:
        x = x_hi - rng.uniform(5.0, 20.0)
        p = np.array([x, rng.choice([-1.0, 1.0]) * rng.uniform(8.0, 12.0), 0.0])
        p[2] = float(snow_z(p[0], p[1])) - 1.0
        out.append(two_charge_magnet(p, e_hat, rng.uniform(2e3, 6e3), 3.0))
    if spec.start_hut > 0:  # steel of the start hut, a few metres behind and beside the start
        p = track[0] + np.array([-3.0, rng.choice([-1.0, 1.0]) * 2.5, -1.0])
        out.append(two_charge_magnet(p, e_hat, spec.start_hut * 1e-6 * 3.5**3 / (2 * 1e-7), 1.0))
    anomaly = None
    if spec.anomaly > 0:
        lo = np.array([x_lo - 100.0, -150.0, float(track[:, 2].min())])
        hi = np.array([x_hi + 100.0, 150.0, float(track[:, 2].max())])
        anomaly = Anomaly.random(rng, (lo, hi), spec.anomaly)
    return out, anomaly


def measure_unit(
    spec: UnitSpec,
    rng: np.random.Generator,
    t_imu: np.ndarray,
    f_body: np.ndarray,
    w_body: np.ndarray,
    speed: np.ndarray,
    t_mag: np.ndarray,
    b_body: np.ndarray,
    lean_mag: np.ndarray,
    t_move: tuple[float, float],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Readings of one unit: accelerometer, gyroscope (at ``t_imu``) and magnetometer (at ``t_mag``).

    Parameters
    ----------
    t_imu : ndarray (n,)
        IMU sample times [s].
    f_body, w_body : ndarray (n, 3)
        True specific force [m/s^2] and angular rate [rad/s] in the unit's frame.
    speed : ndarray (n,)
        Speed over the snow [m/s] (drives the chatter).
    t_mag : ndarray (k,)
        Magnetometer sample times [s].
    b_body : ndarray (k, 3)
        True field at the unit in its frame [uT].
    lean_mag : ndarray (k,)
        The athlete's lean at the magnetometer samples [rad] (moves the equipment's steel).
    t_move : tuple
        Start and end of the motion [s] (the wind cools the sensor in between).

    Returns
    -------
    acc, gyr, mag : ndarray
    """
    rate = 1.0 / float(np.median(np.diff(t_imu)))
    temp_i = temperature_profile(t_imu, *t_move, *spec.temperature, tau=spec.cooling)
    temp_m = temperature_profile(t_mag, *t_move, *spec.temperature, tau=spec.cooling)
    chatter = np.clip(speed / 20.0, 0.0, 1.6)[:, None]
    f = f_body + chatter * band_noise(rng, t_imu.size, rate, (8.0, 60.0), spec.acc_vibration)
    w = w_body + chatter * band_noise(rng, t_imu.size, rate, (5.0, 40.0), spec.gyr_vibration)
    acc = spec.acc.draw(rng).measure(t_imu, f, rng, temp_i, spec.calibrated_at)
    gyr = spec.gyr.draw(rng).measure(t_imu, w, rng, temp_i, spec.calibrated_at)
    eq_dir = rng.normal(size=(2, 3))
    eq_dir /= np.linalg.norm(eq_dir, axis=1, keepdims=True)
    equip = spec.equipment * (eq_dir[0][None, :] + np.sin(lean_mag)[:, None] * eq_dir[1][None, :])
    mag = spec.mag.draw(rng).measure(t_mag, b_body + equip, rng, temp_m, spec.calibrated_at)
    return acc, gyr, mag


def field_in_body(scene: MagneticScene, pos: np.ndarray, q: np.ndarray) -> np.ndarray:
    """True field [uT] in the unit's frame at local positions ``pos`` (k, 3) [m], attitudes ``q_BO`` (k, 4)."""
    return to_body(q, scene.field_ned(pos))
