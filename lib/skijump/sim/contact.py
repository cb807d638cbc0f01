"""The contact path of a simulated jump: the certified profile made C2 for a 100 Hz IMU.

:class:`HillGeometry` is the in-run and landing profile of a hill (hill frame: x forward, z down [m]);
:class:`ContactPath` bridges the profile's curvature jumps (E2, P, L, U) by a correction of at most
``max_deviation`` (0.45 mm) vertically that is C2 at the junction and C5 at its ends, and
:func:`curvilinear` / :func:`cartesian` convert motion along the path (arc length [m] and its
derivatives) to and from the hill frame.  Used by :mod:`sportfusion.skijump.sim.motion`; ``ODE_STEP`` is the
fixed step of every phase's integration (:func:`sportfusion.sim.ode.solve_fixed`: RK4 on 1 ms, the same
numbers on every scipy release) and ``STEP_PLAN`` the coarser one of the planning searches.
"""

from __future__ import annotations

import bisect
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sportfusion.sim.smooth import smoothstep5

#: Integration step of the truth [s] (RK4; its error is far below a micrometre, module text of sim.ode).
ODE_STEP = 1e-3
#: Step of the planning searches (lift area, braking) [s]: their answers only need millimetres.
STEP_PLAN = 4e-3


@dataclass
class HillGeometry:
    """What the motion needs from a hill (hill frame, metres, z down).

    Attributes
    ----------
    z_inrun, z_landing : callable
        Profile height z(x) [m] of the in-run and of the landing hill + out-run.
    x_start : float
        Start gate position x [m] (on the in-run straight).
    inrun_junctions, landing_junctions : tuple of float
        x [m] of the profile's piece boundaries (E1, E2; P, K, L, U).
    x_flat : float
        x [m] where the flat out-run begins (U).
    x_end : float
        x [m] of the end of the out-run.
    jump_length : callable
        Jump length [m] of a touch-down at x (curve length of the landing profile from F).
    g : float
        Gravity [m/s^2].
    """

    z_inrun: Callable[[np.ndarray], np.ndarray]
    z_landing: Callable[[np.ndarray], np.ndarray]
    x_start: float
    inrun_junctions: tuple[float, ...]
    landing_junctions: tuple[float, ...]
    x_flat: float
    x_end: float
    jump_length: Callable[[float], float]
    g: float


# ----------------------------------------------------------------------------- profile path
def _one_sided_d2(fun: Callable[[np.ndarray], np.ndarray], x0: float, side: float, h: float = 0.01) -> float:
    """Second derivative of ``fun`` at ``x0`` from one side (+1 right, -1 left), 4th order."""
    xs = x0 + side * h * np.arange(6)
    f = np.asarray(fun(xs), dtype=float)
    return float((45 * f[0] - 154 * f[1] + 214 * f[2] - 156 * f[3] + 61 * f[4] - 10 * f[5]) / (12 * h * h))


def _bridge(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``phi(u) = u^2/2 (S((u+1)/2) - H(u))`` on [-1, 1] (0 outside) and its second derivative.

    Adding ``jump * L^2 phi(x/L)`` to a profile whose second derivative jumps by
    ``jump`` at x = 0 makes it C2 (phi'' jumps by -1 at 0) and C5 at +-L, so
    that the sensor's acceleration stays C1 across the bridge ends even while
    the sensor is still above the slope after the touch-down (with a C3 bridge
    a height ``d`` over it leaves a jerk jump ``d z'''' v^3``: several mm/s of
    100 Hz integration error when a small hill's landing falls on a bridge).
    """
    u = np.asarray(u, dtype=float)
    s, s1, s2 = smoothstep5((u + 1) / 2)
    s1, s2 = s1 / 2, s2 / 4
    h = (u >= 0).astype(float)
    phi = 0.5 * u**2 * (s - h)
    d2 = s - h + 2 * u * s1 + 0.5 * u**2 * s2
    inside = np.abs(u) < 1
    return np.where(inside, phi, 0.0), np.where(inside, d2, 0.0)


_U = np.linspace(-1, 1, 20001)


BRIDGE_MAX = float(np.max(np.abs(_bridge(_U)[0])))


class ContactPath:
    """A profile z(x) as a quintic spline with its curvature jumps bridged (C2).

    Parameters
    ----------
    zfun : callable
        Profile height z(x) [m] (z down), vectorised.
    x0, x1 : float
        Range [m].
    junctions : sequence of float
        x [m] where the profile's second derivative may jump.
    max_deviation : float
        Largest vertical departure from ``zfun`` allowed for the bridges [m].
    dx : float
        Spline knot spacing [m].
    """

    def __init__(
        self,
        zfun: Callable[[np.ndarray], np.ndarray],
        x0: float,
        x1: float,
        junctions: tuple[float, ...] | list[float] = (),
        max_deviation: float = 4.5e-4,
        dx: float = 0.02,
        max_half_width: float = 4.0,
    ) -> None:
        from scipy.interpolate import PPoly, make_interp_spline

        n = int(np.ceil((x1 - x0) / dx)) + 1
        xs = np.linspace(x0, x1, n)
        z = np.asarray(zfun(xs), dtype=float).copy()
        self.bridges: list[tuple[float, float, float]] = []
        for xj in junctions:
            if not (x0 + 0.2 < xj < x1 - 0.2):
                continue
            jump = _one_sided_d2(zfun, xj, +1.0) - _one_sided_d2(zfun, xj, -1.0)
            if abs(jump) < 1e-7:
                continue
            half = min(max_half_width, np.sqrt(max_deviation / (BRIDGE_MAX * abs(jump))), xj - x0, x1 - xj)
            z += jump * half**2 * _bridge((xs - xj) / half)[0]
            self.bridges.append((float(xj), float(half), float(jump)))
        self.x0, self.x1 = float(x0), float(x1)
        self.spline = make_interp_spline(xs, z, k=5)
        pp = PPoly.from_spline(self.spline)
        keep = np.flatnonzero(np.diff(pp.x) > 0)
        self._bp = pp.x[keep].tolist()
        self._cf = [tuple(c) for c in pp.c[:, keep].T.tolist()]

    def zs(self, x: float) -> tuple[float, float, float]:
        """Height and its first two derivatives at a scalar ``x`` (fast path, same polynomial)."""
        i = min(max(bisect.bisect_right(self._bp, x) - 1, 0), len(self._bp) - 1)
        c0, c1, c2, c3, c4, c5 = self._cf[i]
        h = x - self._bp[i]
        z = ((((c0 * h + c1) * h + c2) * h + c3) * h + c4) * h + c5
        z1 = (((5 * c0 * h + 4 * c1) * h + 3 * c2) * h + 2 * c3) * h + c4
        z2 = ((20 * c0 * h + 12 * c1) * h + 6 * c2) * h + 2 * c3
        return z, z1, z2

    def z(self, x: np.ndarray | float, nu: int = 0) -> np.ndarray:
        """Height or its ``nu``-th derivative w.r.t. x at ``x``."""
        return self.spline(x, nu)

    def foot(self, px: np.ndarray, pz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Foot point x [m] on the path and height above it along the normal [m] of points (px, pz)."""
        px = np.asarray(px, dtype=float)
        pz = np.asarray(pz, dtype=float)
        x = px.copy()
        for _ in range(8):
            z0, z1, z2 = self.spline(x), self.spline(x, 1), self.spline(x, 2)
            g = (px - x) + (pz - z0) * z1
            gp = -1 - z1 * z1 + (pz - z0) * z2
            x = x - g / gp
        z0, z1 = self.spline(x), self.spline(x, 1)
        d = ((px - x) * z1 - (pz - z0)) / np.sqrt(1 + z1 * z1)
        return x, d

    def frame(self, xp: np.ndarray) -> dict[str, np.ndarray]:
        """Point, normal and their derivatives w.r.t. x at ``xp`` (2-D vectors (x, z), last axis)."""
        z0, z1, z2, z3 = (self.spline(xp, k) for k in range(4))
        one, zero = np.ones_like(z0), np.zeros_like(z0)
        u = np.stack((z1, -one), -1)
        du = np.stack((z2, zero), -1)
        ddu = np.stack((z3, zero), -1)
        w = np.sqrt(1 + z1 * z1)[..., None]
        uu = (z1 * z2)[..., None]
        n = u / w
        dn = du / w - u * uu / w**3
        ddn = du * 0 + ddu / w - 2 * du * uu / w**3 - u * ((z2 * z2 + z1 * z3)[..., None] / w**3 - 3 * uu**2 / w**5)
        return {
            "P": np.stack((xp * one, z0), -1),
            "dP": np.stack((one, z1), -1),
            "ddP": np.stack((zero, z2), -1),
            "n": n,
            "dn": dn,
            "ddn": ddn,
        }


def curvilinear(path: ContactPath, p: np.ndarray, pd: np.ndarray, pdd: np.ndarray) -> tuple[np.ndarray, ...]:
    """(x, z) position, velocity, acceleration -> foot point and normal height with their rates.

    Returns ``xp, xpd, xpdd, d, dd, ddd`` (foot point x [m], [m/s], [m/s^2];
    height above the path [m], [m/s], [m/s^2]).
    """
    xp, d = path.foot(p[0], p[1])
    fr = path.frame(np.asarray(xp))
    a = fr["dP"] + d * fr["dn"]
    m = np.array([[a[0], fr["n"][0]], [a[1], fr["n"][1]]])
    xpd, dd = np.linalg.solve(m, pd)
    rhs = pdd - (fr["ddP"] + d * fr["ddn"]) * xpd**2 - 2 * fr["dn"] * xpd * dd
    xpdd, ddd = np.linalg.solve(m, rhs)
    return float(xp), float(xpd), float(xpdd), float(d), float(dd), float(ddd)


def cartesian(path: ContactPath, xp, xpd, xpdd, d, dd, ddd) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # noqa: ANN001
    """Inverse of :func:`curvilinear` for arrays: (x, z) position, velocity, acceleration, shape (n, 2)."""
    fr = path.frame(np.asarray(xp, dtype=float))
    d, dd, ddd = (np.asarray(v, dtype=float)[..., None] for v in (d, dd, ddd))
    xpd, xpdd = np.asarray(xpd, dtype=float)[..., None], np.asarray(xpdd, dtype=float)[..., None]
    a = fr["dP"] + d * fr["dn"]
    p = fr["P"] + d * fr["n"]
    pd = a * xpd + fr["n"] * dd
    pdd = a * xpdd + fr["n"] * ddd + (fr["ddP"] + d * fr["ddn"]) * xpd**2 + 2 * fr["dn"] * xpd * dd
    return p, pd, pdd
