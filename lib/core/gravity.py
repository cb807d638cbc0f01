"""WGS84 normal gravity (Somigliana) with the free-air height correction.

Formula and check values: ``docs/frames.md`` ("Gravity and the magnetic field").
"""

from __future__ import annotations

import numpy as np

#: WGS84 constants
A = 6378137.0  # semi-major axis [m]
F = 1.0 / 298.257223563  # flattening
GAMMA_E = 9.7803253359  # normal gravity at the equator [m/s^2]
K = 0.00193185265241  # Somigliana constant
E2 = 0.00669437999013  # first eccentricity squared
M = 0.00344978650684  # omega^2 a^2 b / GM
#: Standard gravity [m/s^2], used only where no site is known.
G_STANDARD = 9.80665


def normal_gravity(lat_deg: np.ndarray | float, h: np.ndarray | float = 0.0) -> np.ndarray | float:
    """Normal gravity magnitude of WGS84 at a latitude and ellipsoidal height.

    Parameters
    ----------
    lat_deg : float or array
        Geodetic latitude [deg].
    h : float or array
        Ellipsoidal height [m].

    Returns
    -------
    float or array
        Normal gravity [m/s^2]:
        ``gamma(phi) = gamma_e (1 + k sin²phi) / sqrt(1 - e² sin²phi)`` times
        ``1 - (2/a)(1 + f + m - 2 f sin²phi) h + 3 h²/a²``.
    """
    s2 = np.sin(np.deg2rad(lat_deg)) ** 2
    g0 = GAMMA_E * (1 + K * s2) / np.sqrt(1 - E2 * s2)
    h = np.asarray(h, dtype=float)
    out = g0 * (1 - (2 / A) * (1 + F + M - 2 * F * s2) * h + 3 * h**2 / A**2)
    return float(out) if np.ndim(out) == 0 else out
