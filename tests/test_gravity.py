"""WGS84 normal gravity: the check values of shared/ref/formats.md and the defining constants."""

from __future__ import annotations

import numpy as np

from sportfusion.core.gravity import normal_gravity


def test_formats_md_check_values():
    assert abs(normal_gravity(47.4, 0.0) - 9.80836790788) < 1e-8
    assert abs(normal_gravity(47.4, 900.0) - 9.80559166172) < 1e-8


def test_equator_pole_and_free_air_gradient():
    assert abs(normal_gravity(0.0) - 9.7803253359) < 1e-10  # gamma_e
    assert abs(normal_gravity(90.0) - 9.8321849378) < 1e-9  # gamma_p of WGS84
    # free-air gradient near the surface ~ -3.086e-6 1/s^2
    grad = (normal_gravity(45.0, 100.0) - normal_gravity(45.0, 0.0)) / 100.0
    assert abs(grad + 3.086e-6) < 0.01e-6


def test_vectorised():
    lat = np.array([0.0, 47.4, 47.4])
    h = np.array([0.0, 0.0, 900.0])
    np.testing.assert_allclose(normal_gravity(lat, h), [9.7803253359, 9.80836790788, 9.80559166172], atol=1e-8)
