"""core.stats: median is numpy.median's answer (the independent reference) without importing numpy.ma; finite_rows."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from sportfusion.core.stats import median


@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.int64, np.uint8, bool])
def test_median_equals_numpy(dtype) -> None:
    rng = np.random.default_rng(3)
    for shape in [(1,), (2,), (5,), (6,), (7, 4), (8, 3), (3, 5, 2)]:
        for trial in range(12):
            a = rng.normal(size=shape) * 50 + 100
            if trial % 3 == 0 and np.dtype(dtype).kind == "f":
                a.flat[rng.integers(a.size)] = np.nan  # NaN anywhere: NaN, as numpy
            if trial % 4 == 0:
                a = np.round(a / 20)  # ties
            a = a > 100 if dtype is bool else a.astype(dtype)
            for axis in [None, *range(-a.ndim, a.ndim)]:
                want, got = np.median(a, axis=axis), median(a, axis=axis)
                assert type(got) is type(want)
                assert np.asarray(got).dtype == np.asarray(want).dtype
                np.testing.assert_array_equal(got, want)


def test_median_of_a_list_and_infinities() -> None:
    assert median([3, 1, 2]) == 2.0
    assert median([1.0, np.inf, 2.0, -np.inf]) == 1.5
    assert np.isnan(median([1.0, np.nan]))


def test_median_does_not_import_numpy_ma() -> None:
    code = (
        "import sys, numpy as np; from sportfusion.core.stats import median; "
        "median(np.arange(9.0)); median(np.ones((4, 3)), axis=0); print('numpy.ma' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_unique_equals_numpy() -> None:
    from sportfusion.core.stats import unique

    rng = np.random.default_rng(5)
    for a in (
        rng.integers(0, 7, 50),
        rng.integers(0, 7, (4, 6)),
        np.round(rng.normal(size=40), 1),
        np.array([2.0, np.nan, 1.0, np.nan, 2.0]),
        np.array([np.nan, np.nan]),
        np.array([], float),
        np.array([3]),
    ):
        want, got = np.unique(a), unique(a)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
    assert unique([3, 1, 3]).tolist() == [1, 3]


def test_finite_rows_is_isfinite_all_along_rows() -> None:
    from sportfusion.core.stats import finite_rows

    rng = np.random.default_rng(2)
    a = rng.normal(size=(1000, 6))
    a[rng.random(a.shape) < 0.05] = np.nan
    a[::97, 4] = np.inf
    a[::89, 0] = -np.inf
    for x in (a, np.asfortranarray(a), a[:, 1:2], a[:, ::2], np.empty((5, 0)), a[:0]):
        got = finite_rows(x)
        assert got.dtype == bool
        np.testing.assert_array_equal(got, np.isfinite(x).all(axis=1))
