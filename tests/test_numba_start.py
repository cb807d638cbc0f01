"""The kernels' start-up: numba's BLAS check is served without importing the scipy.linalg package."""

from __future__ import annotations

import subprocess
import sys

PROG = """
import sys
import numpy as np
from sportfusion.estimators._quest_kernel import quest_batch
q, loss = quest_batch(np.array([[[0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]]), np.array([[[0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]]),
                      np.array([0.5, 0.5]), 4)
assert np.allclose(np.abs(q[0]), [1.0, 0.0, 0.0, 0.0]), q
print("linalg" if "scipy.linalg" in sys.modules else "no-linalg")
import scipy.linalg
from scipy.linalg import cython_blas
assert cython_blas is sys.modules["scipy.linalg.cython_blas"]
assert np.allclose(scipy.linalg.solve(np.eye(2) * 2.0, np.ones(2)), 0.5)
print("ok")
"""


def test_kernel_runs_without_the_scipy_linalg_package_and_scipy_linalg_still_imports() -> None:
    out = subprocess.run([sys.executable, "-c", PROG], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["no-linalg", "ok"], out


def test_optional_extensions_are_loaded_unless_asked_not_to(monkeypatch) -> None:  # noqa: ANN001
    from sportfusion.core.native import load_extension

    assert load_extension("sportfusion.skijump._no_such_extension") is None  # not built: the fallback
    monkeypatch.setenv("SPORTFUSION_NATIVE", "0")
    assert load_extension("sportfusion.core.rotations") is None  # asked for the fallback
    monkeypatch.setenv("SPORTFUSION_NATIVE", "1")
    assert load_extension("sportfusion.core.rotations") is not None
