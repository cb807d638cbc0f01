"""Geodesy against pymap3d, round trips, the paper's eqs 27-31, sigma rotation, gravity."""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pymap3d
import pytest

from sportfusion.core import meta as sfmeta
from sportfusion.core.errors import InputError
from sportfusion.core.frames import (
    Frame,
    geodetic_to_local,
    geodetic_to_ned,
    gnss_local_columns,
    gnss_to_frame,
    local_to_geodetic,
    local_to_ned,
    m_no,
    ned_to_geodetic,
    ned_to_local,
    normal_gravity,
    rotate_horizontal_sigmas,
)

ORIGIN = (47.4049, 10.2945, 948.0)  # Oberstdorf HS106 take-off edge (approximate)
PSI = 312.6


def eq31(psi_deg: float) -> np.ndarray:
    """M_NO of eq 31, written out."""
    c, s = math.cos(math.radians(psi_deg)), math.sin(math.radians(psi_deg))
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def points_around(origin: tuple[float, float, float], max_dist: float, k: int = 400, seed: int = 3):
    """Geodetic points up to ``max_dist`` [m] horizontally and +-200 m vertically from ``origin`` (via pymap3d)."""
    rng = np.random.default_rng(seed)
    r = max_dist * np.sqrt(rng.uniform(0, 1, k))
    az = rng.uniform(0, 2 * np.pi, k)
    n, e, d = r * np.cos(az), r * np.sin(az), rng.uniform(-200, 200, k)
    lat, lon, h = pymap3d.ned2geodetic(n, e, d, *origin)
    return np.asarray(lat), np.asarray(lon), np.asarray(h)


@pytest.mark.parametrize("origin", [ORIGIN, (-33.9, 151.2, 50.0), (69.6, 18.9, 10.0)])
def test_ned_and_hill_frame_agree_with_pymap3d_within_5km(origin: tuple[float, float, float]) -> None:
    """Exact pipeline vs pymap3d (independent ECEF implementation): < 1 mm within 5 km (observed ~1e-8 m)."""
    lat, lon, h = points_around(origin, 5000.0)
    n, e, d = geodetic_to_ned(lat, lon, h, origin)
    rn, re, rd = pymap3d.geodetic2ned(lat, lon, h, *origin)
    assert np.abs(np.stack([n - rn, e - re, d - rd])).max() < 1e-3
    x, y, z = geodetic_to_local(lat, lon, h, origin, PSI)
    ref = np.stack([rn, re, rd], axis=-1) @ eq31(PSI).T
    assert np.abs(np.stack([x, y, z], axis=-1) - ref).max() < 1e-3


@pytest.mark.parametrize("origin", [ORIGIN, (-33.9, 151.2, 50.0), (69.6, 18.9, 10.0), (0.0, -179.9, -20.0)])
def test_forward_conversion_equals_the_pyproj_pipeline(origin: tuple[float, float, float]) -> None:
    """The numpy geodetic -> NED is pyproj's cart + topocentric computation (to 1e-6 m within 20 km)."""
    from pyproj import Transformer

    lat, lon, h = points_around(origin, 20000.0)
    n, e, d = geodetic_to_ned(lat, lon, h, origin)
    tr = Transformer.from_pipeline(
        "+proj=pipeline +step +proj=cart +ellps=WGS84 "
        f"+step +proj=topocentric +ellps=WGS84 +lat_0={origin[0]!r} +lon_0={origin[1]!r} +h_0={origin[2]!r}"
    )
    pe, pn, pu = tr.transform(lon, lat, h)
    assert np.abs(np.stack([n - pn, e - pe, d + pu])).max() < 1e-6
    assert np.isnan(geodetic_to_ned(np.nan, 10.0, 0.0, origin)[0])


def test_round_trips_below_1mm() -> None:
    lat, lon, h = points_around(ORIGIN, 5000.0)
    x, y, z = geodetic_to_local(lat, lon, h, ORIGIN, PSI)
    lat2, lon2, h2 = local_to_geodetic(x, y, z, ORIGIN, PSI)
    # 1 mm is 9e-9 deg of latitude
    assert np.abs(lat2 - lat).max() < 9e-9 and np.abs(lon2 - lon).max() < 1.3e-8 and np.abs(h2 - h).max() < 1e-3
    x2, y2, z2 = geodetic_to_local(lat2, lon2, h2, ORIGIN, PSI)
    assert np.abs(np.stack([x2 - x, y2 - y, z2 - z])).max() < 1e-3
    n, e, d = geodetic_to_ned(lat, lon, h, ORIGIN)
    back = ned_to_geodetic(n, e, d, ORIGIN)
    assert np.abs(back[2] - h).max() < 1e-3
    # the origin maps to zero
    assert np.allclose(geodetic_to_local(*ORIGIN, ORIGIN, PSI), 0, atol=1e-9)


def test_paper_method_difference_measured() -> None:
    """Eqs 27-29 vs the exact frame: mm at 100 m, ~1 cm at 300 m, metres at 5 km (quadratic growth).

    Measured (bench/bench_gps2hill.py, heights +-50 m): 1.3 mm at 100 m, 11 mm at 300 m, 13 cm at
    1 km, 3.1 m at 5 km.  Printed here with ``pytest -s``.
    """
    worst = {}
    for dist in (100.0, 300.0, 1000.0, 5000.0):
        rng = np.random.default_rng(7)
        az = rng.uniform(0, 2 * np.pi, 500)
        lat, lon, h = pymap3d.ned2geodetic(dist * np.cos(az), dist * np.sin(az), rng.uniform(-50, 50, 500), *ORIGIN)
        exact = np.stack(geodetic_to_local(lat, lon, h, ORIGIN, PSI), axis=-1)
        paper = np.stack(geodetic_to_local(lat, lon, h, ORIGIN, PSI, method="paper"), axis=-1)
        worst[dist] = float(np.linalg.norm(paper - exact, axis=-1).max())
        # the paper's formulas invert exactly
        back = local_to_geodetic(*paper.T, ORIGIN, PSI, method="paper")
        assert np.abs(back[0] - lat).max() < 1e-12 and np.abs(back[2] - h).max() < 1e-9
    print("paper eqs 27-29 minus exact [m]:", {k: round(v, 4) for k, v in worst.items()})
    assert 0.5e-3 < worst[100.0] < 3e-3
    assert 5e-3 < worst[300.0] < 2e-2
    assert 0.08 < worst[1000.0] < 0.2
    assert 2.0 < worst[5000.0] < 4.5
    assert worst[5000.0] / worst[1000.0] == pytest.approx(25, rel=0.1)  # grows with distance squared


@pytest.mark.parametrize("psi", [0.0, 90.0, 312.6, -45.0])
def test_rotation_is_eq31_and_in_one_place(psi: float) -> None:
    np.testing.assert_allclose(m_no(psi), eq31(psi), atol=1e-15)
    v = np.random.default_rng(1).normal(size=(10, 3))
    np.testing.assert_allclose(ned_to_local(v, psi), v @ eq31(psi).T, atol=1e-14)
    np.testing.assert_allclose(local_to_ned(ned_to_local(v, psi), psi), v, atol=1e-14)
    # the hill x axis points to the azimuth: a point 10 m along psi is x = 10
    n, e = 10 * math.cos(math.radians(psi)), 10 * math.sin(math.radians(psi))
    np.testing.assert_allclose(ned_to_local(np.array([n, e, 2.0]), psi), [10, 0, 2], atol=1e-12)


def test_horizontal_sigma_rotation() -> None:
    sx, sy = rotate_horizontal_sigmas(np.array([1.0]), np.array([2.0]), 90.0)
    np.testing.assert_allclose([sx[0], sy[0]], [2.0, 1.0])  # x = east, y = south
    sx, sy = rotate_horizontal_sigmas(np.array([1.5]), np.array([1.5]), PSI)
    np.testing.assert_allclose([sx[0], sy[0]], [1.5, 1.5])  # isotropic is invariant
    # against R Sigma R^T written out, with correlation
    cov = np.array([[1.0, 0.6, 0], [0.6, 4.0, 0], [0, 0, 0]])
    ref = eq31(PSI) @ cov @ eq31(PSI).T
    sx, sy = rotate_horizontal_sigmas(1.0, 2.0, PSI, 0.6)
    np.testing.assert_allclose([sx, sy], np.sqrt([ref[0, 0], ref[1, 1]]), rtol=1e-12)


def test_normal_gravity_check_values() -> None:
    """shared/ref/formats.md: (47.4 deg, 0 m) 9.80836790788, (47.4 deg, 900 m) 9.80559166172."""
    assert normal_gravity(47.4, 0.0) == pytest.approx(9.80836790788, abs=1e-10)
    assert normal_gravity(47.4, 900.0) == pytest.approx(9.80559166172, abs=1e-10)


def test_frame_meta_round_trip_and_validation() -> None:
    f = Frame(*ORIGIN, PSI, "hill")
    m = f.to_meta()
    assert m == {
        "name": "hill",
        "origin": list(ORIGIN),
        "azimuth_deg": PSI,
        "axes": "x forward, y right, z down",
        "height_ref": "ellipsoidal",  # issue 15: the frame says what its heights rest on
    }
    assert Frame.from_meta(m) == f
    x, y, z = f.from_geodetic(*f.to_geodetic(12.0, -3.0, 40.0))
    assert (x, y, z) == pytest.approx((12.0, -3.0, 40.0), abs=1e-6)
    with pytest.raises(InputError):
        Frame(147.0, 10.0, 0.0)
    with pytest.raises(InputError, match="method"):
        geodetic_to_local(47.0, 10.0, 0.0, ORIGIN, 0.0, method="flat")


def _gnss_table(n: int = 6, **extra: object) -> pa.Table:
    lat = np.full(n, ORIGIN[0] + 1e-4)
    lon = np.full(n, ORIGIN[1])
    h = np.full(n, ORIGIN[2] - 10)
    mask = np.array([False, True] * (n // 2))
    cols = {
        "t": np.arange(n) * 0.1,
        "lat": pa.array(lat, mask=mask),
        "lon": pa.array(lon, mask=mask),
        "h": pa.array(h, mask=mask),
    }
    cols.update(extra)
    return pa.table(cols)


def test_gnss_columns_nulls_and_sigmas() -> None:
    f = Frame(*ORIGIN, 90.0)
    t = _gnss_table(gnss_sigma_n=np.full(6, 1.0), gnss_sigma_e=np.full(6, 2.0), gnss_sigma_v=np.full(6, 3.0))
    out = gnss_local_columns(t, f)
    assert np.isnan(out["gnss_x"][1::2]).all() and np.isfinite(out["gnss_x"][::2]).all()
    n, e, d = pymap3d.geodetic2ned(ORIGIN[0] + 1e-4, ORIGIN[1], ORIGIN[2] - 10, *ORIGIN)
    assert out["gnss_x"][0] == pytest.approx(e, abs=1e-6)  # azimuth 90: x = east
    assert out["gnss_y"][0] == pytest.approx(-n, abs=1e-6)  # y = south
    assert out["gnss_z"][0] == pytest.approx(d, abs=1e-6)
    np.testing.assert_allclose(out["std_gnss_x"], 2.0)
    np.testing.assert_allclose(out["std_gnss_y"], 1.0)
    np.testing.assert_allclose(out["std_gnss_z"], 3.0)
    only_h = gnss_local_columns(_gnss_table(gnss_sigma_h=np.full(6, 0.7)), f)
    np.testing.assert_allclose(only_h["std_gnss_x"], 0.7)
    assert "std_gnss_z" not in only_h
    assert "std_gnss_x" not in gnss_local_columns(_gnss_table(), f)


def test_gnss_columns_bad_input() -> None:
    f = Frame(*ORIGIN, PSI)
    with pytest.raises(InputError, match="missing column"):
        gnss_local_columns(pa.table({"t": [0.0], "lat": [47.0]}), f)
    empty = pa.table({"t": [0.0], "lat": pa.nulls(1, pa.float64()), "lon": [1.0], "h": [2.0]})
    with pytest.raises(InputError, match="no row"):
        gnss_local_columns(empty, f)


def test_gnss_to_frame_meta_and_frame_conflict() -> None:
    f = Frame(*ORIGIN, PSI, "hill")
    meta = sfmeta.new_meta("session", 1.7e9)
    t = _gnss_table(vel_n=np.arange(6.0))
    out, m = gnss_to_frame(t, meta, f, hill_meta={"name": "X"})
    assert {k: m["frame"][k] for k in f.to_meta()} == f.to_meta() and m["hill"] == {"name": "X"}
    assert m["frame"]["gnss_z_ref"] == "ellipsoidal" and "geoid_offset_m" not in m["frame"]
    assert out.column("vel_n").to_pylist() == t.column("vel_n").to_pylist()
    assert out.column_names[: t.num_columns] == t.column_names
    est = t.append_column("x", pa.array(np.zeros(6)))
    other = Frame(*ORIGIN, 0.0)
    with pytest.raises(InputError, match="mix frames"):
        gnss_to_frame(est, m, other)
    gnss_to_frame(est, m, f)  # the same frame is fine
