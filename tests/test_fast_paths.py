"""Fast paths agree with their references numerically (never a timing).

* the C kernels' banded inverse / diag((W+K)^-1) / spline evaluation / arc length against the Python and
  numpy references of ``estimators.spline`` on the same inputs (more in ``test_banded_native.py``);
* ``smoother_outputs.euler_jacobian`` (analytic) against central differences of ``euler_from_quat``;
* ``smoother_outputs.interp_columns`` (column by column) against ``_interp_rows``.
"""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.core.rotations import euler_from_quat
from sportfusion.estimators import _banded
from sportfusion.estimators import spline as S
from sportfusion.skijump import smoother_outputs as R

needs_c = pytest.mark.skipif(_banded.native() is None, reason="the C extension is not built")


@needs_c
@pytest.mark.parametrize("n", [4, 5, 9, 300, 4000])
def test_compiled_banded_inverse_matches_python(n: int) -> None:
    rng = np.random.default_rng(n)
    h = rng.uniform(0.05, 0.15, n - 1)
    w = rng.uniform(0.5, 2.0, n)
    for ww in (w, w - 1j * 1e-20 * w):  # real and the complex step of the 1-sigma
        ab = S._reinsch_bands(h, 1.0 / ww, 2.0)
        got, ref = S._ldl_inverse_bands(ab), S._ldl_inverse_bands_py(ab)
        for a, b in zip(got, ref, strict=True):
            assert a.dtype == b.dtype
            assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b))
        m, mref = S._minv_diag(h, ww, 2.0), S._minv_diag_py(h, ww, 2.0)
        assert np.max(np.abs(m.real - mref.real)) <= 1e-9 * np.max(np.abs(mref.real))
        if np.iscomplexobj(ww):
            assert np.max(np.abs(m.imag - mref.imag)) <= 1e-8 * np.max(np.abs(mref.imag))


@needs_c
def test_compiled_spline_evaluation_matches_numpy(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.05, 0.15, 3000))
    y = np.column_stack((np.sin(t / 3), np.cos(t / 5), 0.01 * t)) + 0.02 * rng.standard_normal((t.size, 3))
    sp = S.smoothing_spline(t, y, None, 0.9).spline
    tq = np.concatenate(([t[0] - 1.0], rng.uniform(t[0] - 2, t[-1] + 2, 5000), t[::7], [t[-1] + 3.0]))
    fast = sp.evaluate(tq), sp.arc_length(tq)
    monkeypatch.setattr(_banded, "_NATIVE", None)  # the numpy reference
    ref = sp.evaluate(tq), sp.arc_length(tq)
    for a, b in zip(fast[0], ref[0], strict=True):
        assert np.allclose(a, b, rtol=1e-12, atol=1e-12)
    assert np.allclose(fast[1], ref[1], rtol=1e-11, atol=1e-9)
    assert fast[1][-2] > 0 and np.all(np.diff(fast[1][tq.argsort()]) >= -1e-9)


def test_gcv_trace_is_the_same_either_way() -> None:
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.uniform(0.05, 0.15, 500))
    y = np.sin(t) + 0.05 * rng.standard_normal(t.size)
    w = rng.uniform(0.5, 2.0, t.size)
    h = np.diff(t)
    _, tr = S.gcv_score(t, y, w, 0.3)
    ref = t.size - 0.3 * np.sum(S._qzqt_diag_py(h, *S._ldl_inverse_bands_py(S._reinsch_bands(h, 1 / w, 0.3))) / w)
    assert tr == pytest.approx(ref, rel=1e-10)
    assert 2.0 < tr < t.size


def test_euler_jacobian_matches_central_differences() -> None:
    rng = np.random.default_rng(0)
    q = rng.normal(size=(200, 4)) * rng.uniform(0.5, 2.0, (200, 1))  # not unit: the angles normalise
    J = R.euler_jacobian(q)
    eps = 1e-6
    num = np.empty_like(J)
    for k in range(4):
        dq = np.zeros(4)
        dq[k] = eps
        ep = np.stack(euler_from_quat(q + dq), -1)
        em = np.stack(euler_from_quat(q - dq), -1)
        d = (ep - em + np.pi) % (2 * np.pi) - np.pi
        num[:, :, k] = d / (2 * eps)
    ok = np.abs(np.stack(euler_from_quat(q), -1)[:, 1]) < 1.4  # away from gimbal lock
    assert np.allclose(J[ok], num[ok], rtol=1e-5, atol=1e-6)


def test_interp_columns_matches_interp_rows() -> None:
    t = np.concatenate((np.arange(0, 5, 0.01), 10 + np.arange(0, 3, 0.01)))  # two segments (gap 5 s)
    rows = np.sort(np.concatenate((t, np.arange(-1, 14, 0.037))))
    rng = np.random.default_rng(1)
    cols = {f"c{i}": rng.normal(size=t.size) for i in range(3)}
    got = R.interp_columns(rows, t, cols, 1.0)
    ref = R._interp_rows(rows, t, np.stack(list(cols.values()), -1), 1.0)
    for j, name in enumerate(cols):
        assert np.array_equal(np.isnan(got[name]), np.isnan(ref[:, j]))
        assert np.allclose(got[name], ref[:, j], equal_nan=True)
    # consume=True (rts-smooth, issue 38): the same columns in the same order, taken out of the input as it goes
    taken = R.interp_columns(rows, t, dict(cols), 1.0, consume=True)
    assert list(taken) == list(got)
    for name in cols:
        np.testing.assert_array_equal(taken[name], got[name])
    left = dict(cols)
    R.interp_columns(rows, t, left, 1.0, consume=True)
    assert left == {}
