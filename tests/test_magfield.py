"""World Magnetic Model through pygeomag: units (km, decimal year, nT -> uT) and the Oberstdorf check."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.core.errors import InputError
from sportfusion.core.magfield import decimal_year, field_from_angles, inclination_declination, reference_field


def test_oberstdorf_formats_md():
    # formats.md: 47.40 N, 10.29 E, 0.9 km, 2026-01-01: X 21460.6, Y 1477.9, Z 43440.0 nT; I 63.655, D 3.939 deg
    f = reference_field(47.4049, 10.2945, 900.0, "2026-01-01T00:00:00Z")
    np.testing.assert_allclose(f, [21.4606, 1.4779, 43.4400], atol=0.0001)  # uT, to 0.1 nT
    inc, dec = inclination_declination(f)
    assert abs(inc - 63.655) < 0.001
    assert abs(dec - 3.939) < 0.001


def test_height_is_metres_and_matters():
    low = reference_field(47.4049, 10.2945, 0.0, "2026-01-01")
    high = reference_field(47.4049, 10.2945, 900.0, "2026-01-01")
    # about -0.02 nT/m near the ground: 900 m lowers |F| by ~20 nT, not by the ~20000 nT of 900 km
    drop = np.linalg.norm(low) - np.linalg.norm(high)
    assert 0.005 < drop < 0.05


def test_decimal_year():
    assert decimal_year("2026-01-01T00:00:00Z") == 2026.0
    assert abs(decimal_year("2024-07-02T00:00:00Z") - (2024 + 183 / 366)) < 1e-12  # leap year
    assert decimal_year(1767225600.0) == 2026.0  # Unix seconds of 2026-01-01


def test_outside_model_span_and_bad_date():
    with pytest.raises(InputError):
        reference_field(47.4, 10.3, 0.0, "2035-01-01")
    with pytest.raises(InputError):
        reference_field(47.4, 10.3, 0.0, "yesterday")


def test_angles_round_trip():
    f = field_from_angles(63.0, -2.0, 48.0)
    inc, dec = inclination_declination(f)
    assert abs(inc - 63.0) < 1e-12 and abs(dec + 2.0) < 1e-12
    assert abs(np.linalg.norm(f) - 48.0) < 1e-12
