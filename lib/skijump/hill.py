"""Longitudinal profile of a ski-jumping hill from its certificate parameters.

Geometry: ``docs/hills.md`` (the FIS construction as used by open
implementations; the norm's own text was not available).  Three generations
are supported:

* ``ICR2008`` -- in-run transition a cubic parabola (radius ``r1`` at E2),
  landing circle ``rL`` from P to L, out-run transition a tilted quadratic
  parabola (radius ``r2L`` at L, ``r2`` at U);
* ``ICR1996`` -- circular in-run transition ``r1``, landing circle ``rL``,
  circular out-run transition ``r2`` from L;
* ``ICR1992`` -- circular in-run transition ``r1``, straight landing slope at
  ``betaK`` from ``P = K - l1`` to ``L = K + l2`` (along the slope), circular
  out-run transition ``r2`` from L.  The community game code puts ``L = K``;
  extending the straight by ``l2`` makes the curve length F->L equal HS on
  every ICR1992 data set seen (``l2 = HS - w`` there), and ``l2 = 0``
  reproduces the game's profile.

Frames
------
The public API works in the ski-jumping paper's hill frame (§3.3.1): origin at
the take-off edge T, ``x`` horizontal towards the out-run, ``z`` **down**
[m].  The reference document's formulas use ``Y = -z`` (up); they are
evaluated internally in ``(X, Y)`` and converted in one place.

Curves
------
``part="inrun"`` is the in-run (A .. T, ``x <= 0``), ``part="landing"`` the
landing hill and out-run (F .. U and ``a`` metres of flat out-run beyond U,
``x >= 0``).  Outside its range a part gives NaN, unless ``extend=True``
continues it with straight lines at the end slopes.

Jump length
-----------
The jump length of a touch-down at ``x_TD`` is the curve length of the
landing profile from the knoll base F (``x = 0``) to ``x_TD``
(``docs/hills.md``, "Jump length").
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.stats import unique

__all__ = ["HILL_TYPES", "Certificate", "HillProfile", "Segment", "PARAMETERS"]

#: Profile generations and their community-data type codes.
HILL_TYPES = {"ICR1992": 0, "ICR1996": 1, "ICR2008": 2}

#: Certificate parameters: name -> (unit, meaning).  Lengths [m], angles [deg].
PARAMETERS: dict[str, tuple[str, str]] = {
    "w": ("m", "distance take-off edge -> K point"),
    "hS": ("m", "hill size: distance take-off edge -> L point"),
    "n": ("m", "horizontal distance T -> K"),
    "h": ("m", "vertical distance T -> K"),
    "gamma": ("deg", "in-run straight slope"),
    "alpha": ("deg", "table slope"),
    "e": ("m", "in-run length from the highest start gate to T"),
    "es": ("m", "length between highest and lowest start gate"),
    "t": ("m", "table length"),
    "r1": ("m", "radius of the in-run transition at E2"),
    "s": ("m", "table height above the knoll base F"),
    "beta0": ("deg", "landing-profile slope at F"),
    "betaP": ("deg", "landing-profile slope at P"),
    "betaK": ("deg", "landing-profile slope at K"),
    "betaL": ("deg", "landing-profile slope at L"),
    "rL": ("m", "radius of the landing circle P..L"),
    "r2L": ("m", "out-run transition radius at L"),
    "r2": ("m", "out-run transition radius at U"),
    "a": ("m", "length of the horizontal out-run after U"),
    "l1": ("m", "curve length P -> K"),
    "l2": ("m", "curve length K -> L"),
}

_COMMON = ("w", "hS", "n", "h", "gamma", "alpha", "e", "t", "r1", "s", "beta0", "betaP", "betaK", "a")
_REQUIRED = {
    "ICR1992": (*_COMMON, "l1", "l2", "r2"),
    "ICR1996": (*_COMMON, "betaL", "rL", "r2"),
    "ICR2008": (*_COMMON, "betaL", "rL", "r2L", "r2"),
}
#: Chord |TK| against w: w / 1.005 on every data set seen; refused beyond this relative gap.
_CHORD_TOL = 0.05


@dataclass(frozen=True)
class Certificate:
    """Certificate numbers of one hill (lengths [m], angles [deg]).

    Build it with :meth:`from_mapping`, which checks presence and types;
    :class:`HillProfile` checks the geometry.  Parameters a generation does
    not use are NaN (``betaL`` of an ICR1992 hill, ``r2L`` before ICR2008).
    """

    type: str
    w: float
    hS: float
    n: float
    h: float
    gamma: float
    alpha: float
    e: float
    t: float
    r1: float
    s: float
    beta0: float
    betaP: float
    betaK: float
    a: float
    es: float = 0.0
    betaL: float = math.nan
    rL: float = math.nan
    r2L: float = math.nan
    r2: float = math.nan
    l1: float = math.nan
    l2: float = math.nan
    gates: int | None = None

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], where: str = "certificate") -> Certificate:
        """Certificate from a mapping (a TOML ``[certificate]`` table).

        ``type`` is ``"ICR1992"``, ``"ICR1996"``, ``"ICR2008"`` or the
        community code 0/1/2.  Raises :class:`InputError` naming a missing,
        unknown or non-numeric value.
        """
        d = dict(data)
        typ = d.pop("type", None)
        if isinstance(typ, bool):
            typ = None
        if isinstance(typ, int) and typ in HILL_TYPES.values():
            typ = next(k for k, v in HILL_TYPES.items() if v == typ)
        if isinstance(typ, str):
            typ = typ.strip().upper()
        if typ not in HILL_TYPES:
            raise InputError(f"{where}: 'type' is {data.get('type')!r}, expected one of {', '.join(HILL_TYPES)}")
        gates = d.pop("gates", None)
        if gates is not None and (isinstance(gates, bool) or not isinstance(gates, int) or gates < 1):
            raise InputError(f"{where}: 'gates' is {gates!r}, expected a positive whole number of start gates")
        unknown = sorted(set(d) - set(PARAMETERS))
        if unknown:
            raise InputError(
                f"{where}: unknown parameter(s) {', '.join(unknown)}; expected some of {', '.join(PARAMETERS)}"
            )
        missing = [k for k in _REQUIRED[typ] if k not in d]
        if missing:
            raise InputError(f"{where}: {typ} hill is missing {', '.join(missing)} ([m] or [deg])")
        vals: dict[str, float] = {}
        for k, v in d.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise InputError(f"{where}: '{k}' is {v!r}, expected a finite number [{PARAMETERS[k][0]}]")
            bound = 90.0 if PARAMETERS[k][0] == "deg" else 1e5
            if abs(v) > bound:
                raise InputError(f"{where}: '{k}' is {v!r}, expected -{bound:g} .. {bound:g} {PARAMETERS[k][0]}")
            vals[k] = float(v)
        return cls(type=typ, gates=gates, **vals)

    def as_dict(self) -> dict[str, Any]:
        """The certificate as plain JSON-able values (NaN entries left out)."""
        out: dict[str, Any] = {}
        for k, v in asdict(self).items():
            if v is None or (isinstance(v, float) and math.isnan(v)):
                continue
            out[k] = v
        return out


@dataclass(frozen=True)
class Segment:
    """One piece of a profile in the reference (X, Y up) frame.

    ``f(X)`` returns ``(Y, dY/dX, d2Y/dX2)``; ``length(X0, X1)`` the curve
    length between two abscissae inside ``[x0, x1]``.
    """

    name: str
    x0: float
    x1: float
    f: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]] = field(repr=False)
    length: Callable[[np.ndarray, np.ndarray], np.ndarray] = field(repr=False)


def _line(name: str, x0: float, x1: float, p: np.ndarray, slope: float) -> Segment:
    """Straight line through point ``p`` with ``dY/dX = slope``."""

    def f(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return p[1] + slope * (X - p[0]), np.full_like(X, slope), np.zeros_like(X)

    def length(Xa: np.ndarray, Xb: np.ndarray) -> np.ndarray:
        return (Xb - Xa) * math.hypot(1.0, slope)

    return Segment(name, x0, x1, f, length)


def _circle_below(name: str, x0: float, x1: float, c: np.ndarray, r: float) -> Segment:
    """Lower arc of the circle of centre ``c`` and radius ``r`` (concave up)."""

    def f(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        u = X - c[0]
        root = np.sqrt(np.maximum(r * r - u * u, 0.0))
        return c[1] - root, u / root, r * r / root**3

    def length(Xa: np.ndarray, Xb: np.ndarray) -> np.ndarray:
        return r * (np.arcsin(np.clip((Xb - c[0]) / r, -1, 1)) - np.arcsin(np.clip((Xa - c[0]) / r, -1, 1)))

    return Segment(name, x0, x1, f, length)


# 32-point Gauss-Legendre rule on [-1, 1], the positive half (the rule is symmetric): the values
# numpy.polynomial.legendre.leggauss(32) returns, written out so that building a hill does not import
# numpy.polynomial (~10 ms per command); tests/test_hill.py compares them with leggauss
_GL_NODES = (
    0.048307665687738324, 0.1444719615827965, 0.23928736225213706, 0.33186860228212767,
    0.42135127613063533, 0.5068999089322294, 0.5877157572407623, 0.6630442669302152,
    0.7321821187402897, 0.7944837959679424, 0.84936761373257, 0.8963211557660521,
    0.9349060759377397, 0.9647622555875064, 0.9856115115452684, 0.9972638618494816,
)  # fmt: skip
_GL_WEIGHTS = (
    0.09654008851472766, 0.09563872007927471, 0.09384439908080451, 0.09117387869576378,
    0.08765209300440378, 0.08331192422694671, 0.07819389578707023, 0.07234579410884834,
    0.06582222277636168, 0.058684093478535565, 0.05099805926237609, 0.042835898022226836,
    0.034273862913021765, 0.025392065309262024, 0.016274394730905743, 0.007018610009470506,
)  # fmt: skip


@functools.cache
def _gauss_legendre() -> tuple[np.ndarray, np.ndarray]:
    """32-point Gauss-Legendre nodes (ascending) and weights on [-1, 1]."""
    x, w = np.array(_GL_NODES), np.array(_GL_WEIGHTS)
    return np.concatenate((-x[::-1], x)), np.concatenate((w[::-1], w))


def _quad_length(dydx: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Curve length by 32-point Gauss-Legendre on a smooth segment (exact to ~1e-13 relative)."""

    def length(Xa: np.ndarray, Xb: np.ndarray) -> np.ndarray:
        Xa, Xb = np.broadcast_arrays(np.asarray(Xa, float), np.asarray(Xb, float))
        half = (Xb - Xa)[..., None] / 2
        mid = (Xb + Xa)[..., None] / 2
        nodes, weights = _gauss_legendre()
        X = mid + half * nodes
        return np.sum(half * weights * np.sqrt(1 + dydx(X) ** 2), axis=-1)

    return length


class HillProfile:
    """The in-run and landing profile of one hill, in the hill frame (x forward, z down) [m].

    Parameters
    ----------
    cert : Certificate or mapping
        Certificate numbers; a mapping goes through :meth:`Certificate.from_mapping`.

    Raises
    ------
    InputError
        An inconsistent certificate: missing or non-positive values, angles
        out of order, P beyond K or before F, an in-run transition (radius
        ``r1`` over ``gamma - alpha``) that does not fit the in-run length
        ``e``, a knoll that climbs, K far from ``w``.  (Any positive radius
        gives a valid curve for a given slope change, so radii are otherwise
        not bounded; the ICR2008 out-run parabola cannot fold over because
        ``tau + betaL < 90 deg`` for every ``r2/r2L > 0``.)

    Attributes
    ----------
    cert : Certificate
    points : dict of str -> ndarray (2,)
        Key points ``A B E1 E2 T F P K L U V`` as ``(x, z)`` in the hill frame
        (z down) [m]; V is the end of the flat out-run.
    transition_length : float
        In-run transition length E1 -> E2 [m] (ICR2008: ``d (1 + 0.1 tan²(gamma-alpha))``,
        the construction formula, 35 mm shorter than the exact cubic-parabola arc
        on Oberstdorf HS106; older hills: ``r1 (gamma - alpha)``).
    tau : float
        ICR2008 out-run parabola tilt [rad] (NaN for other generations).
    """

    def __init__(self, cert: Certificate | Mapping[str, Any]) -> None:
        if not isinstance(cert, Certificate):
            cert = Certificate.from_mapping(cert)
        self.cert = cert
        self._check_numbers()
        self._P: dict[str, np.ndarray] = {}
        self._inrun = self._build_inrun()
        self._landing = self._build_landing()
        self._check_geometry()
        self.points = {k: np.array([v[0], -v[1]]) for k, v in self._P.items()}
        # cumulative curve length at each landing segment's start
        starts = [0.0]
        for seg in self._landing[:-1]:
            starts.append(starts[-1] + float(seg.length(np.array(seg.x0), np.array(seg.x1))))
        self._s0 = np.array(starts)
        xs = np.linspace(self._landing[0].x0, self._landing[-1].x1, 4001)
        self._table = (xs, self.jump_length(xs))

    # -- construction ------------------------------------------------------
    def _check_numbers(self) -> None:
        c = self.cert
        positive = ["w", "hS", "n", "h", "e", "t", "r1", "a"]
        positive += {"ICR1992": ["l1", "r2"], "ICR1996": ["rL", "r2"], "ICR2008": ["rL", "r2L", "r2"]}[c.type]
        for k in positive:
            if not getattr(c, k) > 0:
                raise InputError(f"certificate: {k} = {getattr(c, k)} m, expected a positive length")
        for k in ("s", "es") + (("l2",) if c.type == "ICR1992" else ()):
            if getattr(c, k) < 0:
                raise InputError(f"certificate: {k} = {getattr(c, k)} m, expected a length >= 0")
        if not 0 < c.alpha < c.gamma < 90:
            raise InputError(f"certificate: needs 0 < alpha < gamma < 90 deg, got alpha {c.alpha}, gamma {c.gamma}")
        if not 0 <= c.beta0 < c.betaP < 90 or not 0 < c.betaK < 90:
            raise InputError(
                f"certificate: needs 0 <= beta0 < betaP < 90 deg and 0 < betaK < 90 deg, "
                f"got beta0 {c.beta0}, betaP {c.betaP}, betaK {c.betaK}"
            )
        if c.type == "ICR1992" and abs(c.betaP - c.betaK) > 1e-9:
            raise InputError(
                f"certificate: an ICR1992 landing slope is straight from P to L, so betaP ({c.betaP} deg) "
                f"must equal betaK ({c.betaK} deg)"
            )
        if c.type != "ICR1992":
            if c.betaP < c.betaK:
                raise InputError(
                    f"certificate: betaP = {c.betaP} deg < betaK = {c.betaK} deg puts P beyond K; "
                    "expected betaP >= betaK (the landing circle steepens from P to K)"
                )
            if not 0 < c.betaL <= c.betaK:
                raise InputError(f"certificate: betaL = {c.betaL} deg, expected 0 < betaL <= betaK = {c.betaK} deg")
        if c.hS < c.w:
            raise InputError(f"certificate: hS = {c.hS} m is shorter than w = {c.w} m, expected hS >= w")
        chord = math.hypot(c.n, c.h)
        if abs(chord * 1.005 / c.w - 1) > _CHORD_TOL:
            raise InputError(
                f"certificate: n = {c.n} m and h = {c.h} m put K {chord:.2f} m from T, inconsistent with "
                f"w = {c.w} m (expected |TK| about w / 1.005 = {c.w / 1.005:.2f} m)"
            )

    def _build_inrun(self) -> list[Segment]:
        c, P = self.cert, self._P
        ga, al = math.radians(c.gamma), math.radians(c.alpha)
        D = ga - al
        P["T"] = np.array([0.0, 0.0])
        P["E2"] = np.array([-c.t * math.cos(al), c.t * math.sin(al)])
        if c.type == "ICR2008":
            d = 2 * c.r1 * math.sin(D) * math.cos(D) ** 2
            C = math.tan(D) / (3 * d * d)
            f = d * math.tan(D) / 3
            self.transition_length = d * (1 + 0.1 * math.tan(D) ** 2)
            E1 = np.array(
                [
                    -(c.t * math.cos(al) + f * math.sin(ga) + d * math.cos(ga)),
                    c.t * math.sin(al) - f * math.cos(ga) + d * math.sin(ga),
                ]
            )
            sg, cg = math.sin(ga), math.cos(ga)
            p = 1 / (3 * C * math.tan(ga))

            def xi_of(X: np.ndarray) -> np.ndarray:
                # xi^3 + 3 p xi - 2 q = 0 has one real root: 2 sqrt(p) sinh(asinh(q / p^1.5) / 3)
                q = (X - E1[0]) / (2 * C * sg)
                xi = 2 * np.sqrt(p) * np.sinh(np.arcsinh(q / p**1.5) / 3)
                for _ in range(2):  # polish: X(xi) = E1.X + xi cos(gamma) + C xi^3 sin(gamma)
                    xi = xi - (E1[0] + xi * cg + C * xi**3 * sg - X) / (cg + 3 * C * xi**2 * sg)
                return xi

            def f_tr(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
                xi = xi_of(X)
                Y = E1[1] - xi * sg + C * xi**3 * cg
                xx, yx = cg + 3 * C * xi**2 * sg, -sg + 3 * C * xi**2 * cg
                xxx, yxx = 6 * C * xi * sg, 6 * C * xi * cg
                return Y, yx / xx, (yxx * xx - yx * xxx) / xx**3

            def len_tr(Xa: np.ndarray, Xb: np.ndarray) -> np.ndarray:
                return _quad_length(lambda X: f_tr(X)[1])(Xa, Xb)

            trans = Segment("transition", float(E1[0]), float(P["E2"][0]), f_tr, len_tr)
        else:
            C1 = P["E2"] + c.r1 * np.array([math.sin(al), math.cos(al)])
            E1 = C1 - c.r1 * np.array([math.sin(ga), math.cos(ga)])
            self.transition_length = c.r1 * D
            trans = _circle_below("transition", float(E1[0]), float(P["E2"][0]), C1, c.r1)
        P["E1"] = E1
        down = np.array([math.cos(ga), -math.sin(ga)])
        straight = c.e - self.transition_length
        if straight < c.es:
            raise InputError(
                f"certificate: the in-run transition (r1 = {c.r1} m over gamma - alpha = {c.gamma - c.alpha:g} deg) "
                f"takes {self.transition_length:.2f} m of e = {c.e} m, leaving {straight:.2f} m of straight, "
                f"less than es = {c.es} m; expected a longer e or a smaller r1"
            )
        P["A"] = E1 - straight * down
        P["B"] = P["A"] + c.es * down
        return [
            _line("straight", float(P["A"][0]), float(E1[0]), E1, -math.tan(ga)),
            trans,
            _line("table", float(P["E2"][0]), 0.0, P["T"], -math.tan(al)),
        ]

    def _build_landing(self) -> list[Segment]:
        c, P = self.cert, self._P
        bK, bP = math.radians(c.betaK), math.radians(c.betaP)
        b0 = math.radians(c.beta0)
        F = np.array([0.0, -c.s])
        K = np.array([c.n, -c.h])
        P["F"], P["K"] = F, K
        segs: list[Segment] = []
        if c.type == "ICR1992":
            down = np.array([math.cos(bK), -math.sin(bK)])
            Pp, L = K - c.l1 * down, K + c.l2 * down
            bL = bK
        else:
            bL = math.radians(c.betaL)
            CL = K + c.rL * np.array([math.sin(bK), math.cos(bK)])
            Pp = K - c.rL * np.array([math.sin(bP) - math.sin(bK), math.cos(bP) - math.cos(bK)])
            L = K + c.rL * np.array([math.sin(bK) - math.sin(bL), math.cos(bK) - math.cos(bL)])
        P["P"], P["L"] = Pp, L
        if not Pp[0] > 0:
            raise InputError(
                f"certificate: P lies at x = {Pp[0]:.2f} m, at or before the knoll base F; expected P between F and K "
                "(a smaller rL or l1)"
            )
        # knoll F -> P: cubic with slope beta0 at F and betaP at P
        px = float(Pp[0])
        u = (F[1] - Pp[1]) - px * math.tan(b0)
        v = px * (math.tan(bP) - math.tan(b0))
        k2, k3 = 3 * u - v, 2 * u - v
        tb0 = math.tan(b0)

        def f_knoll(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            r = X / px
            Y = F[1] - X * tb0 - k2 * r**2 + k3 * r**3
            return Y, -tb0 - 2 * k2 * r / px + 3 * k3 * r**2 / px, -2 * k2 / px**2 + 6 * k3 * r / px**2

        segs.append(Segment("knoll", 0.0, px, f_knoll, _quad_length(lambda X: f_knoll(X)[1])))
        if c.type == "ICR1992":
            segs.append(_line("landing slope", px, float(L[0]), K, -math.tan(bK)))
        else:
            segs.append(_circle_below("landing circle", px, float(L[0]), CL, c.rL))
        self.tau = math.nan
        if c.type == "ICR2008":
            tau = math.atan((math.cos(bL) - (c.r2 / c.r2L) ** (1 / 3)) / math.sin(bL))
            cc = 1 / (2 * c.r2 * math.cos(tau) ** 3)
            a_ = -math.tan(bL + tau) / (2 * cc)
            b_ = -math.tan(tau) / (2 * cc)
            st, ct = math.sin(tau), math.cos(tau)
            self.tau = tau
            U = L + np.array([cc * st * (a_**2 - b_**2) + ct * (b_ - a_), -cc * ct * (a_**2 - b_**2) + st * (b_ - a_)])

            def xi_of(X: np.ndarray) -> np.ndarray:
                # c sin(tau) xi^2 - cos(tau) xi + k = 0, the root in [a', b'] in its cancellation-free form
                k = X - L[0] - cc * a_**2 * st + a_ * ct
                return 2 * k / (ct + np.sqrt(np.maximum(ct * ct - 4 * cc * st * k, 0.0)))

            def f_out(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
                xi = xi_of(X)
                Y = L[1] - cc * ct * (a_**2 - xi**2) - st * (a_ - xi)
                xx, yx = ct - 2 * cc * xi * st, st + 2 * cc * xi * ct
                xxx, yxx = -2 * cc * st, 2 * cc * ct
                return Y, yx / xx, (yxx * xx - yx * xxx) / xx**3

            def sp(xi: np.ndarray) -> np.ndarray:  # arc length of eta = c xi^2 from its vertex
                return xi * np.sqrt(1 + 4 * cc * cc * xi * xi) / 2 + np.arcsinh(2 * cc * xi) / (4 * cc)

            def len_out(Xa: np.ndarray, Xb: np.ndarray) -> np.ndarray:
                return sp(xi_of(np.asarray(Xb, float))) - sp(xi_of(np.asarray(Xa, float)))

            segs.append(Segment("out-run transition", float(L[0]), float(U[0]), f_out, len_out))
        else:
            C2 = L + c.r2 * np.array([math.sin(bL), math.cos(bL)])
            U = np.array([C2[0], C2[1] - c.r2])
            segs.append(_circle_below("out-run transition", float(L[0]), float(U[0]), C2, c.r2))
        P["U"] = U
        P["V"] = U + np.array([c.a, 0.0])
        segs.append(_line("out-run", float(U[0]), float(P["V"][0]), U, 0.0))
        return segs

    def _check_geometry(self) -> None:
        c, P = self.cert, self._P
        if P["P"][0] > P["K"][0]:
            raise InputError(
                f"certificate: P (x = {P['P'][0]:.2f} m) lies beyond K (x = {P['K'][0]:.2f} m); expected P before K"
            )
        if P["L"][0] < P["K"][0]:
            raise InputError(f"certificate: L (x = {P['L'][0]:.2f} m) lies before K (x = {P['K'][0]:.2f} m)")
        knoll = self._landing[0]
        X = np.linspace(knoll.x0, knoll.x1, 401)
        dY = knoll.f(X)[1]
        if np.any(dY > 1e-12):
            raise InputError(
                f"certificate: the knoll from F to P climbs (s = {c.s} m, beta0 = {c.beta0} deg, P at "
                f"({P['P'][0]:.2f}, {-P['P'][1]:.2f}) m); expected a profile falling all the way from F to P"
            )

    # -- evaluation --------------------------------------------------------
    def segments(self, part: str = "landing") -> list[Segment]:
        """The pieces of a part in order, in the reference (X, Y up) frame (for tests and plots)."""
        return list(self._part(part))

    def _part(self, part: str) -> list[Segment]:
        if part == "inrun":
            return self._inrun
        if part == "landing":
            return self._landing
        raise ValueError(f"part must be 'inrun' or 'landing', got {part!r}")

    def _eval(self, x: np.ndarray | float, part: str, extend: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(Y, dY/dX, d2Y/dX2)`` at ``x`` (reference frame), NaN outside unless ``extend``."""
        segs = self._part(part)
        X = np.asarray(x, dtype=float)
        Y = np.full(X.shape, np.nan)
        dY = np.full(X.shape, np.nan)
        d2Y = np.full(X.shape, np.nan)
        done = np.zeros(X.shape, dtype=bool)
        for seg in segs:
            m = (X >= seg.x0) & (X <= seg.x1) & ~done
            if np.any(m):
                y, d, dd = seg.f(X[m])
                Y[m], dY[m], d2Y[m] = y, d, dd
                done |= m
        if extend:
            first, last = segs[0], segs[-1]
            for seg, end, m in ((first, first.x0, X < first.x0), (last, last.x1, X > last.x1)):
                if np.any(m):
                    y0, d0, _ = seg.f(np.array([end]))
                    Y[m] = y0[0] + d0[0] * (X[m] - end)
                    dY[m] = d0[0]
                    d2Y[m] = 0.0
        return Y, dY, d2Y

    @staticmethod
    def _out(a: np.ndarray, like: np.ndarray | float) -> np.ndarray | float:
        return float(a) if np.ndim(like) == 0 else a

    def z(self, x: np.ndarray | float, part: str = "landing", extend: bool = False) -> np.ndarray | float:
        """Height of the profile at ``x`` [m] in the hill frame (z down, so the profile's z grows downhill).

        Parameters
        ----------
        x : float or array
            Horizontal distance from the take-off edge along the hill axis [m].
        part : {"landing", "inrun"}
            Which curve: the landing hill (``z_LA`` of eq 34) or the in-run (``z_IR`` of eq 32).
        extend : bool
            Continue the part beyond its ends with straight lines at the end slopes (else NaN).
        """
        return self._out(-self._eval(x, part, extend)[0], x)

    def z_inrun(self, x: np.ndarray | float, extend: bool = False) -> np.ndarray | float:
        """``z_IR(x)`` of eq 32 [m]: :meth:`z` of the in-run."""
        return self.z(x, "inrun", extend)

    def z_landing(self, x: np.ndarray | float, extend: bool = False) -> np.ndarray | float:
        """``z_LA(x)`` of eq 34 [m]: :meth:`z` of the landing hill and out-run."""
        return self.z(x, "landing", extend)

    def dzdx(self, x: np.ndarray | float, part: str = "landing", extend: bool = False) -> np.ndarray | float:
        """Slope ``dz/dx`` [1] (positive downhill: ``tan`` of the inclination)."""
        return self._out(-self._eval(x, part, extend)[1], x)

    def inclination_deg(self, x: np.ndarray | float, part: str = "landing", extend: bool = False) -> np.ndarray | float:
        """Inclination of the profile below the horizontal [deg] (gamma on the in-run straight)."""
        return self._out(np.degrees(np.arctan(-self._eval(x, part, extend)[1])), x)

    def curvature(self, x: np.ndarray | float, part: str = "landing", extend: bool = False) -> np.ndarray | float:
        """Signed curvature [1/m] of ``z(x)``: ``z'' / (1 + z'^2)^1.5``.

        Negative where the profile is concave up in the usual (Y up) view (the
        in-run transition, landing circle and out-run transition); its inverse
        magnitude is the radius of curvature [m].
        """
        _, d, dd = self._eval(x, part, extend)
        return self._out(-dd / (1 + d * d) ** 1.5, x)

    # -- jump length -------------------------------------------------------
    def jump_length(self, x: np.ndarray | float, extend: bool = False) -> np.ndarray | float:
        """Curve length of the landing profile from F (x = 0) to ``x`` [m].

        NaN for ``x < 0`` or beyond the end of the flat out-run (unless
        ``extend``, which adds the horizontal distance beyond the end).
        """
        X = np.asarray(x, dtype=float)
        out = np.full(X.shape, np.nan)
        done = np.zeros(X.shape, dtype=bool)
        for seg, s0 in zip(self._landing, self._s0, strict=True):
            m = (X >= seg.x0) & (X <= seg.x1) & ~done
            if np.any(m):
                out[m] = s0 + seg.length(np.full(int(m.sum()), seg.x0), X[m])
                done |= m
        end = self._landing[-1].x1
        if extend:
            m = X > end
            out[m] = self._s0[-1] + (end - self._landing[-1].x0) + (X[m] - end)
        return self._out(out, x)

    def x_at_jump_length(self, length: np.ndarray | float, extend: bool = False) -> np.ndarray | float:
        """Inverse of :meth:`jump_length`: the ``x`` [m] whose curve length from F is ``length`` [m].

        Initial guess from a 4001-point table, then Newton steps on
        ``ds/dx = sqrt(1 + z'^2)``; agrees with :meth:`jump_length` to < 1e-9 m.
        NaN for a negative length or one beyond the profile (unless ``extend``).
        """
        S = np.asarray(length, dtype=float)
        xs, ss = self._table
        X = np.interp(S, ss, xs)
        inside = (S >= 0) & (S <= ss[-1])
        for _ in range(6):
            r = self.jump_length(X) - S
            d = self._eval(X, "landing", False)[1]
            X = np.clip(X - np.where(inside, r / np.sqrt(1 + d * d), 0.0), xs[0], xs[-1])
        X = np.where(inside, X, np.nan)
        if extend:
            X = np.where(S > ss[-1], xs[-1] + (S - ss[-1]), X)
        return self._out(X, length)

    # -- convenience -------------------------------------------------------
    def gate(self, k: int) -> np.ndarray:
        """Start gate ``k`` of ``gates`` (1 = lowest, at B; the highest at A) as ``(x, z)`` [m]."""
        n = self.cert.gates
        if n is None or n < 2:
            raise InputError("the certificate gives no number of start gates (>= 2), so gates cannot be placed")
        if not 1 <= k <= n:
            raise InputError(f"gate {k} does not exist; expected 1 .. {n}")
        return self.points["B"] + (self.points["A"] - self.points["B"]) * (k - 1) / (n - 1)

    def sample(self, part: str = "landing", step: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
        """Points ``(x, z)`` [m] along a part, about ``step`` [m] apart, including every segment end."""
        xs = []
        for seg in self._part(part):
            k = max(2, int(math.ceil((seg.x1 - seg.x0) / step)) + 1)
            xs.append(np.linspace(seg.x0, seg.x1, k))
        x = unique(np.concatenate(xs))
        return x, np.asarray(self.z(x, part))

    def summary(self) -> dict[str, Any]:
        """Certificate and key points as JSON-able values (for the table's ``hill`` metadata)."""
        return {
            "certificate": self.cert.as_dict(),
            "points": {k: [round(float(v[0]), 4) + 0.0, round(float(v[1]), 4) + 0.0] for k, v in self.points.items()},
            "jump_length_K": round(float(self.jump_length(self.points["K"][0])), 4),
            "jump_length_L": round(float(self.jump_length(self.points["L"][0])), 4),
        }
