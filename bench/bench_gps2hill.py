"""gps2hill accuracy and speed: our pyproj pipeline and the paper's eqs 27-29 against pymap3d.

Prints, for points at growing distances from the Oberstdorf HS106 take-off
edge, the difference of each method to pymap3d's geodetic -> NED (an
independent ECEF-based implementation), the round-trip error, and the
conversion time per point.  Run: ``python bench/bench_gps2hill.py``.
"""

from __future__ import annotations

import time

import numpy as np
import pymap3d

from sportfusion.core.frames import geodetic_to_local, local_to_geodetic
from sportfusion.skijump.hillfile import load_hill

hill = load_hill("oberstdorf_hs106")
origin, psi = hill.frame().origin, hill.frame().azimuth_deg
rng = np.random.default_rng(1)


def ring(dist: float, k: int = 2000) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points at horizontal distance ``dist`` [m], random bearing, height +-50 m from the origin."""
    az = rng.uniform(0, 2 * np.pi, k)
    n, e, d = dist * np.cos(az), dist * np.sin(az), rng.uniform(-50, 50, k)
    lat, lon, h = pymap3d.ned2geodetic(n, e, d, *origin)
    return np.asarray(lat), np.asarray(lon), np.asarray(h)


def reference(lat: np.ndarray, lon: np.ndarray, h: np.ndarray) -> np.ndarray:
    n, e, d = pymap3d.geodetic2ned(lat, lon, h, *origin)
    c, s = np.cos(np.radians(psi)), np.sin(np.radians(psi))
    return np.stack([c * n + s * e, -s * n + c * e, d], axis=-1)


print(f"origin {origin}, azimuth {psi} deg; differences to pymap3d [mm] (max over 2000 points)")
print(f"{'distance':>9} {'pyproj 3D':>10} {'round-trip':>10} {'paper 3D':>10} {'paper hor.':>10} {'paper vert.':>11}")
for dist in (100, 300, 1000, 2000, 5000):
    lat, lon, h = ring(dist)
    ref = reference(lat, lon, h)
    ours = np.stack(geodetic_to_local(lat, lon, h, origin, psi), axis=-1)
    paper = np.stack(geodetic_to_local(lat, lon, h, origin, psi, method="paper"), axis=-1)
    back = local_to_geodetic(*ours.T, origin, psi)
    rt = np.stack(geodetic_to_local(*back, origin, psi), axis=-1) - ours
    dp = paper - ref
    print(
        f"{dist:>8}m {1e3 * np.abs(ours - ref).max():10.2e} {1e3 * np.abs(rt).max():10.2e} "
        f"{1e3 * np.linalg.norm(dp, axis=1).max():10.1f} {1e3 * np.linalg.norm(dp[:, :2], axis=1).max():10.2f} "
        f"{1e3 * np.abs(dp[:, 2]).max():11.1f}"
    )

lat, lon, h = ring(300, 100_000)
for name, fn in (
    ("sportfusion pyproj", lambda: geodetic_to_local(lat, lon, h, origin, psi)),
    ("sportfusion paper", lambda: geodetic_to_local(lat, lon, h, origin, psi, method="paper")),
    ("pymap3d geodetic2ned", lambda: pymap3d.geodetic2ned(lat, lon, h, *origin)),
):
    fn()
    t0 = time.perf_counter()
    for _ in range(3):
        fn()
    dt = (time.perf_counter() - t0) / 3 / lat.size
    print(f"{name:>22}: {dt * 1e9:7.1f} ns/point (100k points)")
