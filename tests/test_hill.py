"""Hill profile from certificate parameters: worked numbers, continuity, curvature, jump length, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from sportfusion.core.errors import InputError
from sportfusion.skijump.hill import Certificate, HillProfile
from sportfusion.skijump.hillfile import load_hill, shipped_hills

# Oberstdorf HS106 community numbers (shared/ref/hill-profile.md, "Data")
OBERSTDORF = {
    "type": "ICR2008",
    "w": 95.0,
    "hS": 106.0,
    "h": 44.97893,
    "n": 83.14035,
    "gamma": 35.0,
    "alpha": 11.0,
    "e": 89.0,
    "es": 20.7,
    "t": 6.5,
    "r1": 95.0,
    "beta0": 6.16666651,
    "betaP": 37.0,
    "betaK": 34.5,
    "betaL": 32.0,
    "s": 2.2,
    "l1": 10.0,
    "l2": 11.0,
    "rL": 220.0,
    "r2L": 106.5,
    "r2": 106.5,
    "a": 100.0,
}
# Worked numbers of hill-profile.md as (X, Y up); the hill frame has z = -Y.
WORKED = {
    "E2": (-6.381, 1.240),
    "E1": (-64.702, 30.392),
    "A": (-83.728, 43.715),
    "B": (-66.771, 31.842),
    "F": (0.0, -2.2),
    "P": (75.350, -39.371),
    "K": (83.140, -44.979),
    "L": (91.167, -50.242),
    "U": (143.316, -65.195),
}

HILLS = {name: load_hill(name).profile for name in shipped_hills()}
ICR2008 = [name for name, p in HILLS.items() if p.cert.type == "ICR2008"]
# junctions: (part, left segment index) -> the shared end point
JUNCTIONS = {"inrun": ("E1", "E2"), "landing": ("P", "L", "U")}


def test_shipped_set_covers_sizes_and_generations() -> None:
    types = {p.cert.type for p in HILLS.values()}
    sizes = [p.cert.hS for p in HILLS.values()]
    assert types == {"ICR1992", "ICR1996", "ICR2008"}
    assert len(HILLS) >= 9 and min(sizes) < 50 and max(sizes) > 200
    assert "oberstdorf_hs106" in HILLS


def test_oberstdorf_worked_numbers_to_1mm() -> None:
    p = HillProfile(OBERSTDORF)
    for name, (X, Y) in WORKED.items():
        assert p.points[name] == pytest.approx([X, -Y], abs=1e-3 + 1e-9), name
    assert p.transition_length == pytest.approx(65.774, abs=1e-3)
    assert p.tau == pytest.approx(-0.27925, abs=1e-5)
    assert p.jump_length(p.points["K"][0]) == pytest.approx(94.61, abs=0.005)
    assert p.jump_length(p.points["L"][0]) == pytest.approx(104.21, abs=0.005)


def test_shipped_oberstdorf_is_the_worked_hill() -> None:
    p = HILLS["oberstdorf_hs106"]
    for name, (X, Y) in WORKED.items():
        assert p.points[name] == pytest.approx([X, -Y], abs=1e-3 + 1e-9), name


@pytest.mark.parametrize("name", sorted(HILLS))
def test_slope_and_height_continuous_at_junctions(name: str) -> None:
    """Left and right pieces meet with the same height (1e-9 m) and inclination (< 1e-6 deg)."""
    p = HILLS[name]
    for part, points in JUNCTIONS.items():
        segs = p.segments(part)
        for left, right in zip(segs[:-1], segs[1:], strict=True):
            assert left.x1 == right.x0
            X = np.array([left.x1])
            yl, dl, _ = left.f(X)
            yr, dr, _ = right.f(X)
            assert abs(yl[0] - yr[0]) < 1e-9, (part, left.name)
            assert abs(math.degrees(math.atan(dl[0]) - math.atan(dr[0]))) < 1e-6, (part, left.name)
        ends = {round(s.x1, 9) for s in segs[:-1]}
        for pt in points:
            assert round(float(p.points[pt][0]), 9) in ends, (name, pt)


@pytest.mark.parametrize("name", sorted(HILLS))
def test_inclinations_at_key_points(name: str) -> None:
    p = HILLS[name]
    c = p.cert
    X = p.points
    ang = lambda x, part="landing": float(p.inclination_deg(x, part))  # noqa: E731
    assert ang(X["A"][0] + 1e-9, "inrun") == pytest.approx(c.gamma, abs=1e-9)
    assert ang(X["E1"][0], "inrun") == pytest.approx(c.gamma, abs=1e-6)
    assert ang(X["E2"][0], "inrun") == pytest.approx(c.alpha, abs=1e-6)
    assert ang(0.0, "inrun") == pytest.approx(c.alpha, abs=1e-9)
    assert ang(0.0) == pytest.approx(c.beta0, abs=1e-9)
    assert ang(X["P"][0]) == pytest.approx(c.betaP, abs=1e-6)
    assert ang(X["K"][0]) == pytest.approx(c.betaK, abs=1e-6)
    betaL = c.betaK if c.type == "ICR1992" else c.betaL
    assert ang(X["L"][0]) == pytest.approx(betaL, abs=1e-6)
    assert ang(X["U"][0]) == pytest.approx(0.0, abs=1e-6)
    # z grows downhill all the way from A to T and from F to U
    for part in ("inrun", "landing"):
        _, z = p.sample(part, 0.5)
        assert np.all(np.diff(z) >= -1e-9)


@pytest.mark.parametrize("name", sorted(HILLS))
def test_curvature_radii(name: str) -> None:
    """Radius r1 at E2 and rL on P..L to 1e-6 relative; ICR2008 out-run r2L at L, r2 at U."""
    p = HILLS[name]
    c = p.cert
    r = lambda x, part="landing": 1 / np.abs(p.curvature(x, part))  # noqa: E731
    assert r(p.points["E2"][0] - 1e-12, "inrun") == pytest.approx(c.r1, rel=1e-6)
    if c.type != "ICR1992":
        x = np.linspace(p.points["P"][0] + 1e-9, p.points["L"][0], 25)
        np.testing.assert_allclose(r(x), c.rL, rtol=1e-6)
    if c.type == "ICR2008":
        assert r(p.points["L"][0] + 1e-12) == pytest.approx(c.r2L, rel=1e-6)
        assert r(p.points["U"][0] - 1e-12) == pytest.approx(c.r2, rel=1e-6)
    else:
        x = np.linspace(p.points["L"][0], p.points["U"][0], 9)[1:-1]
        np.testing.assert_allclose(r(x), c.r2, rtol=1e-6)


@pytest.mark.parametrize("name", sorted(HILLS))
def test_derivatives_match_finite_differences(name: str) -> None:
    """dz/dx and curvature against central differences of z and dz/dx (independent of the closed forms)."""
    p = HILLS[name]
    h = 1e-4
    for part in ("inrun", "landing"):
        segs = p.segments(part)
        x = np.concatenate([np.linspace(s.x0, s.x1, 9)[1:-1] for s in segs])
        d_fd = (p.z(x + h, part) - p.z(x - h, part)) / (2 * h)
        np.testing.assert_allclose(p.dzdx(x, part), d_fd, atol=1e-7)
        dd_fd = (p.dzdx(x + h, part) - p.dzdx(x - h, part)) / (2 * h)
        k_fd = dd_fd / (1 + p.dzdx(x, part) ** 2) ** 1.5
        np.testing.assert_allclose(p.curvature(x, part), k_fd, atol=1e-8)


@pytest.mark.parametrize("name", ICR2008)
def test_jump_length_at_k_and_l(name: str) -> None:
    """Jump length at K within 0.5 % of w and at L within 2 % of HS (every shipped ICR2008 hill)."""
    p = HILLS[name]
    assert abs(p.jump_length(p.points["K"][0]) / p.cert.w - 1) < 0.005
    assert abs(p.jump_length(p.points["L"][0]) / p.cert.hS - 1) < 0.02


@pytest.mark.parametrize("name", sorted(HILLS))
def test_jump_length_against_quadrature_and_inverse(name: str) -> None:
    """Curve length F->x equals scipy quad of sqrt(1 + z'^2) (1e-7 m); the inverse returns x to 1e-9 m."""
    p = HILLS[name]
    end = p.points["V"][0]
    x = np.linspace(0, end, 23)
    s = p.jump_length(x)
    breaks = sorted({float(p.points[k][0]) for k in ("P", "L", "U")})
    for xi, si in zip(x[1:], s[1:], strict=True):
        pts = [b for b in breaks if b < xi]
        ref, _ = quad(lambda u: math.sqrt(1 + p.dzdx(u) ** 2), 0, xi, points=pts or None, epsabs=1e-11, limit=200)
        assert si == pytest.approx(ref, abs=1e-7)
    np.testing.assert_allclose(p.x_at_jump_length(s), x, atol=1e-9)
    assert np.all(np.diff(s) > 0)
    assert math.isnan(p.jump_length(-1.0)) and math.isnan(p.x_at_jump_length(s[-1] + 1))
    assert p.x_at_jump_length(s[-1] + 1, extend=True) == pytest.approx(end + 1)


def test_vectorised_and_extend() -> None:
    p = HILLS["oberstdorf_hs106"]
    x = np.array([[-200.0, -10.0], [50.0, 400.0]])
    z_in = p.z_inrun(x)
    assert z_in.shape == (2, 2) and np.isnan(z_in[0, 0]) and np.isnan(z_in[1, 1])
    ext = p.z_inrun(np.array([p.points["A"][0] - 10]), extend=True)[0]
    assert ext == pytest.approx(p.points["A"][1] - 10 * math.tan(math.radians(35)))
    assert p.z_landing(400.0, extend=True) == pytest.approx(p.points["U"][1])
    assert isinstance(p.z_landing(50.0), float)
    assert p.gate(1) == pytest.approx(p.points["B"]) and p.gate(42) == pytest.approx(p.points["A"])


def _bad(**changes: object) -> dict:
    d = dict(OBERSTDORF)
    d.update(changes)
    return {k: v for k, v in d.items() if v is not None}


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"betaP": 33.0}, "beyond K"),
        ({"r1": 150.0}, "in-run transition"),
        ({"rL": None}, "missing rL"),
        ({"type": "ICR2030"}, "'type'"),
        ({"w": "ninety"}, "'w'"),
        ({"rL": -5.0}, "positive length"),
        ({"alpha": 40.0}, "alpha < gamma"),
        ({"n": 60.0}, "inconsistent with w"),
        ({"s": -20.0}, "length >= 0"),
        ({"beta0": 1.0, "s": 30.0}, "knoll"),
        ({"rL": 3000.0}, "before the knoll base"),
        ({"hS": 90.0}, "hS"),
        ({"colour": 3.0}, "unknown parameter"),
    ],
)
def test_inconsistent_certificates_refused(changes: dict, message: str) -> None:
    with pytest.raises(InputError, match=message):
        HillProfile(_bad(**changes))


def test_icr1992_requires_straight_landing_slope() -> None:
    d = {k: v for k, v in OBERSTDORF.items() if k not in ("betaL", "rL", "r2L")}
    d.update(type="ICR1992", betaP=34.5)
    p = HillProfile(d)
    assert p.points["L"][0] > p.points["K"][0]
    d["betaP"] = 36.0
    with pytest.raises(InputError, match="must equal betaK"):
        HillProfile(d)


def test_certificate_accepts_community_type_codes() -> None:
    c = Certificate.from_mapping({**OBERSTDORF, "type": 2})
    assert c.type == "ICR2008"
    assert "r2L" in c.as_dict() and "gates" not in c.as_dict()


def test_gauss_legendre_rule_is_numpys() -> None:
    """The 32-point rule written out in hill.py is numpy's leggauss(32) (to rounding, whatever the numpy
    release) and integrates polynomials up to degree 63 exactly."""
    from numpy.polynomial.legendre import leggauss

    from sportfusion.skijump.hill import _gauss_legendre

    x, w = _gauss_legendre()
    xr, wr = leggauss(32)
    np.testing.assert_allclose(x, xr, rtol=0, atol=1e-15)
    np.testing.assert_allclose(w, wr, rtol=0, atol=1e-15)
    for deg in (0, 2, 30, 62):
        assert np.sum(w * x**deg) == pytest.approx(2.0 / (deg + 1), rel=1e-13)
    assert abs(np.sum(w * x**63)) < 1e-15
