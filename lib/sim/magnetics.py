"""Magnetic sources for simulators, from magnetic charges: finite bar magnets, iron, background anomalies.

Knows no sport and no estimator: everything is built from one physical primitive, the magnetic point
charge (Furlani 2001, §3.2: the "charge model" of a permanent magnet).  A uniformly magnetised body
with magnetisation ``M`` [A/m] carries the surface charge ``sigma = M . n`` on its faces; its field
outside the body is the Coulomb-like field of that charge::

    B(p) = mu0 / (4 pi) * sum_j q_j (p - p_j) / |p - p_j|^3            (q_j in A m, B in T)

A cylinder magnetised along its axis is two charged discs (``+- M pi a^2``); each disc is integrated
with a degree-5 quadrature (its centre and six points at ``sqrt(2/3)`` of the radius), so near the
magnet the field keeps the disc's shape and far away it tends to the point dipole of moment
``m = M V`` -- the estimator's model, which this module never imports.

Sources here:

* :class:`Charges` -- a set of point charges and its field (and, for tests, its potential);
* :func:`bar_magnet` -- a stack of axially magnetised discs (the gates paper's magnet: 10 discs
  20 x 10 mm, 5 mm apart, on a 15 cm stick), any axis direction (tilt, polarity), any moment;
* :func:`two_charge_magnet` -- the textbook bar magnet: ``+-m/L`` at the two ends;
* :func:`iron_rod` -- a long ferromagnetic body (a lift pylon, a snow-making pipe) magnetised along
  its axis by the ambient field: charges of opposite sign spread over its two ends;
* :func:`point_dipole_charges` -- a small magnetised object as a tight +-q pair;
* :class:`Anomaly` -- a smooth spatially varying background (geological anomaly: deep charge pairs).

Units: positions [m], charges [A m], moments [A m^2], fields [uT] (the suite's magnetometer unit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MU0_4PI = 1e-7  # mu_0 / (4 pi) [T m / A]
#: magnetisation of sintered NdFeB, grade N42 (remanence about 1.3 T): Br / mu0 [A/m]
M_N42 = 1.03e6

# degree-5 quadrature of the unit disc (area-normalised weights): the centre and a hexagon at sqrt(2/3)
_DISC_R = np.sqrt(2.0 / 3.0)
_DISC_ANG = np.arange(6) * np.pi / 3.0
_DISC_W = np.concatenate(([0.25], np.full(6, 0.125)))


@dataclass(frozen=True)
class Charges:
    """Magnetic point charges: positions ``pos`` (K, 3) [m] and strengths ``q`` (K,) [A m]."""

    pos: np.ndarray
    q: np.ndarray

    def __add__(self, other: Charges) -> Charges:
        return Charges(np.vstack([self.pos, other.pos]), np.concatenate([self.q, other.q]))

    @property
    def moment(self) -> np.ndarray:
        """Dipole moment ``sum q_j p_j`` [A m^2] (origin-independent when the charges sum to zero)."""
        return (self.q[:, None] * self.pos).sum(axis=0)

    @property
    def centre(self) -> np.ndarray:
        """Mean charge position [m]."""
        return self.pos.mean(axis=0)

    def field(self, p: np.ndarray, chunk: int = 4096) -> np.ndarray:
        """Field [uT] at points ``p`` (..., 3) [m]: ``mu0/(4 pi) sum q_j r_j / |r_j|^3``.

        Points closer than 1 mm to a charge are held at 1 mm (inside a magnet the charge model does not
        apply; no simulated sensor goes there).
        """
        p = np.asarray(p, dtype=float)
        flat = p.reshape(-1, 3)
        out = np.empty_like(flat)
        for a in range(0, flat.shape[0], chunk):
            r = flat[a : a + chunk, None, :] - self.pos[None, :, :]
            d = np.maximum(np.linalg.norm(r, axis=-1), 1e-3)
            out[a : a + chunk] = np.einsum("nk,nkj->nj", self.q[None, :] / d**3, r)
        return (MU0_4PI * 1e6) * out.reshape(p.shape)

    def potential(self, p: np.ndarray) -> np.ndarray:
        """Scalar potential ``phi`` [uT m] with ``B = -grad phi``: ``mu0/(4 pi) sum q_j / |r_j|`` (for tests)."""
        p = np.asarray(p, dtype=float)
        r = p[..., None, :] - self.pos
        d = np.maximum(np.linalg.norm(r, axis=-1), 1e-3)
        return (MU0_4PI * 1e6) * (self.q / d).sum(axis=-1)

    def near(self, p: np.ndarray, radius: float) -> np.ndarray:
        """Mask of the points ``p`` (n, 3) within ``radius`` [m] of any charge (to evaluate sources locally)."""
        lo = self.pos.min(axis=0) - radius
        hi = self.pos.max(axis=0) + radius
        return np.all((p >= lo) & (p <= hi), axis=-1)


def _disc(centre: np.ndarray, axis: np.ndarray, radius: float, q: float) -> Charges:
    """A uniformly charged disc (total charge ``q``) as its seven quadrature points."""
    a = axis / np.linalg.norm(axis)
    e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    ring = radius * _DISC_R * (np.cos(_DISC_ANG)[:, None] * e1 + np.sin(_DISC_ANG)[:, None] * e2)
    pos = np.vstack([centre, centre + ring])
    return Charges(pos, q * _DISC_W)


def bar_magnet(
    centre: np.ndarray,
    axis: np.ndarray,
    moment: float,
    discs: int = 10,
    thickness: float = 0.010,
    radius: float = 0.010,
    gap: float = 0.005,
) -> Charges:
    """A stack of ``discs`` axially magnetised cylinders on one axis (the gates paper's buried magnet).

    Parameters
    ----------
    centre : ndarray (3,)
        Centre of the stack [m].
    axis : ndarray (3,)
        Direction of the magnetisation (north pole side) [any length]; tilt and polarity live here.
    moment : float
        Total moment of the stack [A m^2]; each disc carries ``moment / discs``.
    discs : int
        Number of discs [count].
    thickness, radius, gap : float
        Disc thickness, disc radius and the spacing between discs [m] (paper: S-20-10-N discs,
        20 mm diameter, 10 mm thick, 5 mm apart: a 14.5 cm stack).

    Returns
    -------
    Charges
        ``2 * discs * 7`` charges; their dipole moment is ``moment * axis / |axis|``.
    """
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    c = np.asarray(centre, dtype=float)
    q = moment / discs / thickness  # face charge M * pi a^2 = (m_disc / V) * area = m_disc / thickness
    pitch = thickness + gap
    length = discs * thickness + (discs - 1) * gap
    out: Charges | None = None
    for i in range(discs):
        mid = c + a * (-length / 2 + thickness / 2 + i * pitch)
        pair = _disc(mid + a * thickness / 2, a, radius, q) + _disc(mid - a * thickness / 2, a, radius, -q)
        out = pair if out is None else out + pair
    assert out is not None
    return out


def two_charge_magnet(centre: np.ndarray, axis: np.ndarray, moment: float, length: float) -> Charges:
    """The textbook bar magnet: charges ``+-moment/length`` [A m] at its two ends (``length`` [m] apart)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    c = np.asarray(centre, dtype=float)
    q = moment / length
    return Charges(np.stack([c + a * length / 2, c - a * length / 2]), np.array([q, -q]))


def point_dipole_charges(centre: np.ndarray, moment: np.ndarray, size: float = 0.02) -> Charges:
    """A small magnetised object (a lost binding screw, a ski pole tip): a +-q pair ``size`` [m] apart
    along the moment ``moment`` [A m^2 vector]."""
    m = np.asarray(moment, dtype=float)
    mag = float(np.linalg.norm(m))
    if mag == 0:
        return Charges(np.zeros((0, 3)), np.zeros(0))
    return two_charge_magnet(centre, m / mag, mag, size)


def iron_rod(
    a: np.ndarray,
    b: np.ndarray,
    pole: float,
    spread: float = 0.3,
    points: int = 5,
    rng: np.random.Generator | None = None,
) -> Charges:
    """A long ferromagnetic body (pylon, pipe) magnetised along its axis from end ``a`` to end ``b``.

    Induced magnetisation in a long rod concentrates the magnetic charge at its ends: ``+pole`` [A m]
    near ``b``, ``-pole`` near ``a``, each spread over ``points`` charges within ``spread`` [m] of the
    end (a remanent patchiness when ``rng`` is given).  The sign of ``pole`` follows the ambient field:
    positive when it points from ``a`` to ``b``.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    u = (b - a) / np.linalg.norm(b - a)
    s = np.linspace(0.0, spread, points)
    w = np.full(points, pole / points)
    if rng is not None:
        w = w * rng.uniform(0.6, 1.4, points)
        w *= pole / w.sum()
    pos = np.vstack([b - s[:, None] * u, a + s[:, None] * u])
    return Charges(pos, np.concatenate([w, -w]))


def rod_pole_for_field(field_ut: float, distance: float) -> float:
    """The end charge [A m] whose field is ``field_ut`` [uT] at ``distance`` [m] (to size a source by
    the anomaly it makes, the quantity surveys report)."""
    return field_ut * 1e-6 * distance**2 / MU0_4PI


@dataclass(frozen=True)
class Anomaly:
    """A smooth background anomaly: charge pairs buried ``depth`` [m] deep (geology, old foundations).

    Its field varies over distances of the order of the depth: over a 700 m course a few hundred nT to
    a few uT, a slowly changing background -- not a peak.
    """

    charges: Charges

    @classmethod
    def random(
        cls,
        rng: np.random.Generator,
        extent: tuple[np.ndarray, np.ndarray],
        level: float,
        depth: tuple[float, float] = (20.0, 80.0),
        count: int = 6,
    ) -> Anomaly:
        """``count`` deep dipoles over the box ``extent`` (lower, upper corner [m], z down) whose field
        is about ``level`` [uT] at the surface above each."""
        lo, hi = (np.asarray(v, float) for v in extent)
        out = Charges(np.zeros((0, 3)), np.zeros(0))
        for _ in range(count):
            d = rng.uniform(*depth)
            c = np.array([rng.uniform(lo[0], hi[0]), rng.uniform(lo[1], hi[1]), hi[2] + d])
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            m = level * 1e-6 * d**3 / (2 * MU0_4PI) * rng.uniform(0.5, 1.5)
            out = out + two_charge_magnet(c, u, m, 0.2 * d)
        return cls(out)

    def field(self, p: np.ndarray) -> np.ndarray:
        """Field [uT] at ``p`` (..., 3) [m]."""
        return self.charges.field(p)
