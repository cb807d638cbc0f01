"""The hill as the simulator sees it: venue data, not the estimator's profile code.

The simulator gets the hill as numbers -- its frame, gravity, field, start gates, key points and the
in-run and landing profiles as surveyed points ``(x, z)`` -- and builds its own geometry from them:
the profile between the points by a cubic spline through them, one per piece between the key points
where its curvature may jump (continued by a straight line beyond the
ends), the jump length as the spline's curve length from F (x = 0) by Gauss-Legendre quadrature.  So
the simulated truth does not share :mod:`sportfusion.skijump.hill`'s construction of the certificate's
circles and curves with the smoother it scores: a construction error there would show as an error in
the benchmarks instead of cancelling out.  :meth:`sportfusion.skijump.hillfile.Hill.venue_data`
writes the numbers (a hill's profile points about 5 cm apart).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.interpolate import make_interp_spline

from sportfusion.core.frames import Frame

_GL_X, _GL_W = np.polynomial.legendre.leggauss(5)
#: key points where a profile's curvature may jump (the ends of its circles, straights and curves)
INRUN_JUNCTIONS = ("E1", "E2")
LANDING_JUNCTIONS = ("P", "K", "L", "U")


class _Profile:
    """z(x) [m] through surveyed points: a cubic spline per piece between the profile's junctions (where its
    curvature may jump: a spline across one would smear the jump), the end tangents outside."""

    def __init__(self, x: np.ndarray, z: np.ndarray, breaks: tuple[float, ...] = ()) -> None:
        x, z = np.asarray(x, float), np.asarray(z, float)
        if x.ndim != 1 or x.shape != z.shape or x.size < 4 or np.any(np.diff(x) <= 0):
            raise ValueError("a profile needs at least 4 points with increasing x")
        self.x0, self.x1 = float(x[0]), float(x[-1])
        inner = sorted(float(b) for b in breaks if self.x0 < b < self.x1)
        self.breaks = np.array([self.x0, *inner, self.x1])
        self.pieces = []
        for a, b in zip(self.breaks[:-1], self.breaks[1:], strict=True):
            m = (x >= a - 1e-9) & (x <= b + 1e-9)
            k = min(3, int(m.sum()) - 1)
            self.pieces.append(make_interp_spline(x[m], z[m], k=k))
        self.ends = [(self.x0, float(z[0]), self._d(self.x0, 0)), (self.x1, float(z[-1]), self._d(self.x1, -1))]
        # curve length from x[0] at each point: 5-point Gauss-Legendre on every interval
        self.knots = x
        self.s = np.concatenate([[0.0], np.cumsum(self._length(x[:-1], x[1:]))])

    def _piece(self, X: np.ndarray) -> np.ndarray:
        return np.clip(np.searchsorted(self.breaks, X, side="right") - 1, 0, len(self.pieces) - 1)

    def _d(self, x: float, k: int) -> float:
        return float(self.pieces[k].derivative()(x))

    def _eval(self, X: np.ndarray, nu: int = 0) -> np.ndarray:
        out = np.empty(X.shape)
        idx = self._piece(X)
        for k, sp in enumerate(self.pieces):
            m = idx == k
            if np.any(m):
                out[m] = sp(X[m], nu)
        return out

    def _length(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        h = 0.5 * (b - a)
        xs = 0.5 * (a + b)[..., None] + h[..., None] * _GL_X
        return h * np.sum(_GL_W * np.sqrt(1.0 + self._eval(xs, 1) ** 2), axis=-1)

    def z(self, x: np.ndarray | float) -> np.ndarray | float:
        X = np.asarray(x, float)
        out = self._eval(np.clip(X, self.x0, self.x1))
        for x_end, z_end, d_end, m in ((*self.ends[0], X < self.x0), (*self.ends[1], X > self.x1)):
            out = np.where(m, z_end + d_end * (X - x_end), out)
        return float(out) if np.ndim(x) == 0 else out

    def length_from_start(self, x: float) -> float:
        """Curve length [m] from the first point to ``x`` (beyond the last point, the horizontal distance)."""
        if x >= self.x1:
            return float(self.s[-1] + (x - self.x1))
        k = int(np.clip(np.searchsorted(self.knots, x, side="right") - 1, 0, self.knots.size - 2))
        return float(self.s[k] + self._length(np.array([self.knots[k]]), np.array([x]))[0])


@dataclass
class SimHill:
    """A hill as data (hill frame: x forward from the take-off edge, z down [m]).

    Attributes
    ----------
    name : the hill's name.
    frame : the local hill frame (origin, azimuth).
    g : gravity at the site [m/s^2].
    mag_field : the hill file's Earth field NED [uT], or None (the World Magnetic Model is used).
    meta : the tables' ``hill`` metadata, passed through.
    gates : number of start gates (1 = lowest at B, the highest at A).
    w : certificate distance take-off edge -> K [m].
    points : key points ``name -> (x, z)`` [m] (A, B, E1, E2, T, F, P, K, L, U, V ...).
    inrun_x, inrun_z, landing_x, landing_z : the profiles' surveyed points [m].
    """

    name: str
    frame: Frame
    g: float
    mag_field: tuple[float, float, float] | None
    meta: dict[str, Any]
    gates: int
    w: float
    points: dict[str, tuple[float, float]]
    inrun_x: np.ndarray
    inrun_z: np.ndarray
    landing_x: np.ndarray
    landing_z: np.ndarray
    _inrun: _Profile = field(init=False, repr=False)
    _landing: _Profile = field(init=False, repr=False)

    def __post_init__(self) -> None:
        pts = self.points
        self._inrun = _Profile(self.inrun_x, self.inrun_z, tuple(pts[k][0] for k in INRUN_JUNCTIONS if k in pts))
        self._landing = _Profile(
            self.landing_x, self.landing_z, tuple(pts[k][0] for k in LANDING_JUNCTIONS if k in pts)
        )

    @classmethod
    def from_data(cls, d: Mapping[str, Any]) -> SimHill:
        """From :meth:`sportfusion.skijump.hillfile.Hill.venue_data`'s mapping (plain numbers and arrays)."""
        return cls(**{k: d[k] for k in cls.__dataclass_fields__ if not k.startswith("_")})

    def z_inrun(self, x: np.ndarray | float) -> np.ndarray | float:
        """In-run profile height z(x) [m] (straight beyond its ends)."""
        return self._inrun.z(x)

    def z_landing(self, x: np.ndarray | float) -> np.ndarray | float:
        """Landing hill + out-run height z(x) [m] (straight beyond its ends)."""
        return self._landing.z(x)

    def jump_length(self, x: float) -> float:
        """Curve length [m] of the landing profile from F (x = 0) to ``x`` (beyond its end, + horizontal)."""
        return self._landing.length_from_start(float(x)) - self._landing.length_from_start(0.0)


def as_sim_hill(hill: Any) -> SimHill:
    """``hill`` as a :class:`SimHill`: itself, or the venue data of an object that gives them (``venue_data()``,
    as a loaded hill file does)."""
    return hill if isinstance(hill, SimHill) else SimHill.from_data(hill.venue_data())
