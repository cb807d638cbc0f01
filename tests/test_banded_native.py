"""The C kernels of the smoothing spline (``estimators._banded_c``) prove their numbers (never a timing).

* the selected inverse (Hutchinson-de Hoog bands of ``B^-1``) against a dense numpy inverse, real and
  complex symmetric, on small systems;
* ``diag((W + K)^-1)`` and its complex step against dense matrices built from ``Q`` and ``R``;
* the Reinsch solve against the dense smoother ``g = (W + K)^-1 W y``, and a lost positive definiteness
  handed to the KKT solve;
* whole fits (values, curvatures, 1-sigma, GCV's lambda) equal with and without the extension;
* the buffer checks of the entry points.
"""

from __future__ import annotations

import os
import shutil

import numpy as np
import pytest

from sportfusion.estimators import _banded, spline_gaps
from sportfusion.estimators import spline as S

C = _banded.native()
needs_c = pytest.mark.skipif(C is None, reason="the C extension is not built (no compiler at install time)")


def _qr(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Dense Q (n, n-2) and R (n-2, n-2) of Reinsch's equations."""
    n = h.size + 1
    Q = np.zeros((n, n - 2))
    R = np.zeros((n - 2, n - 2))
    for j in range(n - 2):
        Q[j, j], Q[j + 1, j], Q[j + 2, j] = 1 / h[j], -(1 / h[j] + 1 / h[j + 1]), 1 / h[j + 1]
        R[j, j] = (h[j] + h[j + 1]) / 3
        if j + 1 < n - 2:
            R[j, j + 1] = R[j + 1, j] = h[j + 1] / 6
    return Q, R


def _dense_penta(a0: np.ndarray, a1: np.ndarray, a2: np.ndarray) -> np.ndarray:
    m = a0.size
    B = np.diag(a0).astype(a0.dtype)
    for k, a in ((1, a1), (2, a2)):
        idx = np.arange(m - k)
        B[idx + k, idx] = a[: m - k]
        B[idx, idx + k] = a[: m - k]
    return B


def test_the_extension_is_built_where_a_compiler_is() -> None:
    # setup.py builds it as optional: a broken build would silently fall back to the numpy path
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler here")
    if os.environ.get("SPORTFUSION_NATIVE") == "0":
        pytest.skip("SPORTFUSION_NATIVE=0: the fallback is asked for")
    assert C is not None, "sportfusion.estimators._banded_c is not built: pip install -e . (make .venv/.installed)"


@needs_c
@pytest.mark.parametrize("m", [1, 2, 3, 4, 7, 40])
@pytest.mark.parametrize("complex_", [False, True])
def test_inverse_bands_match_a_dense_inverse(m: int, complex_: bool) -> None:
    rng = np.random.default_rng(m)
    a0 = rng.uniform(4.0, 6.0, m)
    a1 = rng.uniform(-1.0, 1.0, m)
    a2 = rng.uniform(-1.0, 1.0, m)
    a1[-1:] = 0.0
    a2[max(m - 2, 0) :] = 0.0
    if complex_:  # complex symmetric (no conjugation), as the complex step makes it
        a0 = a0 + 1j * rng.uniform(-1e-3, 1e-3, m)
        a1 = a1 + 1j * rng.uniform(-1e-3, 1e-3, m)
    Z = np.linalg.inv(_dense_penta(a0, a1, a2))
    z0, z1, z2 = _banded.inverse_bands(a0, a1, a2)
    assert z0.dtype == (np.complex128 if complex_ else np.float64)
    i = np.arange(m)
    assert np.allclose(z0, Z[i, i], rtol=1e-12, atol=1e-14)
    assert np.allclose(z1[: m - 1], Z[i[:-1], i[:-1] + 1], rtol=1e-12, atol=1e-14)
    assert np.allclose(z2[: max(m - 2, 0)], Z[i[: m - 2], i[: m - 2] + 2], rtol=1e-12, atol=1e-14)
    ref = S._ldl_inverse_bands_py(np.stack((a0, a1, a2)))
    for a, b in zip((z0, z1, z2), ref, strict=True):
        assert np.allclose(a, b, rtol=1e-13, atol=1e-15)


@needs_c
def test_inverse_bands_say_when_a_pivot_is_zero() -> None:
    a0 = np.array([1.0, 1.0, 1.0])
    a1 = np.array([1.0, 0.0, 0.0])  # B[1, 1] - B[1, 0]^2 / B[0, 0] = 0
    z = [np.empty(5) for _ in range(3)]
    assert C.inverse_bands(False, a0, a1, np.zeros(3), *z) is False
    assert C.inverse_bands(False, np.array([4.0, 4.0, 4.0]), a1, np.zeros(3), *z) is True


@needs_c
@pytest.mark.parametrize("n", [3, 4, 6, 25, 120])
def test_minv_diag_and_its_complex_step_match_dense_matrices(n: int) -> None:
    rng = np.random.default_rng(n)
    h = rng.uniform(0.05, 0.3, n - 1)
    w = rng.uniform(0.5, 50.0, n)
    alpha = 0.7
    Q, R = _qr(h)
    M = np.diag(w) + alpha * Q @ np.linalg.solve(R, Q.T)
    Minv = np.linalg.inv(M)
    got = S._minv_diag(h, w, alpha)
    assert got.dtype == np.float64
    assert np.allclose(got, np.diag(Minv), rtol=1e-10, atol=0)
    # the complex step gives diag(M^-1 P M^-1), the derivative for a weight perturbation -P
    p = rng.uniform(0.1, 2.0, n)
    step = 1e-20
    dm = S._minv_diag(h, w - 1j * step * p, alpha).imag / step
    assert np.allclose(dm, np.einsum("ij,j,ji->i", Minv, p, Minv), rtol=1e-9, atol=0)
    assert np.array_equal(got, S._minv_diag(h, w, alpha))  # deterministic


@needs_c
@pytest.mark.parametrize("n", [3, 4, 5, 60])
@pytest.mark.parametrize("d", [1, 3])
def test_reinsch_solve_matches_the_dense_smoother(n: int, d: int) -> None:
    rng = np.random.default_rng(10 * n + d)
    h = rng.uniform(0.05, 0.3, n - 1)
    t = np.concatenate(([0.0], np.cumsum(h)))
    y = np.column_stack([np.sin(t * (k + 1)) for k in range(d)]) + 0.05 * rng.standard_normal((n, d))
    w = rng.uniform(0.5, 20.0, n)
    alpha = 0.3
    Q, R = _qr(h)
    M = np.diag(w) + alpha * Q @ np.linalg.solve(R, Q.T)
    g_ref = np.linalg.solve(M, w[:, None] * y)
    gam_ref = np.zeros((n, d))
    gam_ref[1:-1] = np.linalg.solve(R, Q.T @ g_ref)  # the spline condition Q^T g = R gamma
    g, gam = _banded.reinsch(h, 1.0 / w, alpha, y)
    assert np.allclose(g, g_ref, rtol=1e-10, atol=1e-12)
    assert np.allclose(gam, gam_ref, rtol=1e-8, atol=1e-9 * np.abs(gam_ref).max())
    assert np.all(gam[[0, -1]] == 0.0)
    # the diagonal of (W + K)^-1 from the same factorization (GCV's trace) is the one minv_diag gives
    g2, gam2, mdiag = _banded.reinsch(h, 1.0 / w, alpha, y, diag=True)
    assert np.array_equal(g2, g) and np.array_equal(gam2, gam)
    assert np.array_equal(mdiag, S._minv_diag(h, w, alpha))
    assert np.allclose(mdiag, np.diag(np.linalg.inv(M)), rtol=1e-10, atol=0)


@needs_c
def test_a_lost_positive_definiteness_goes_to_the_kkt_solve() -> None:
    h = np.array([0.1, 0.1, 0.1])
    y = np.arange(8.0).reshape(4, 2)
    winv = np.array([1.0, -1e6, 1.0, 1.0])  # a negative weight: B is not positive definite
    assert _banded.reinsch(h, winv, 1.0, y) is None
    g, gam = S._reinsch(h, y, 1.0 / winv, 1.0)  # what smoothing_spline calls: the KKT system answers
    ref = S._solve_kkt(h, y, 1.0 / winv, np.full(3, 1.0))
    assert np.allclose(g, ref[0]) and np.allclose(gam, ref[1])


def _fits(monkeypatch: pytest.MonkeyPatch, engine: str, *args: object, **kw: object) -> S.SplineFit:
    if engine == "reference":
        monkeypatch.setattr(_banded, "_NATIVE", None)  # scipy's banded Cholesky and the numpy references
    try:
        return S.smoothing_spline(*args, **kw)  # type: ignore[arg-type]
    finally:
        monkeypatch.setattr(_banded, "_NATIVE", C)


@needs_c
def test_whole_fits_are_equal_with_and_without_the_extension(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(7)
    n = 3000
    t = np.cumsum(rng.uniform(0.05, 0.15, n))
    y = np.column_stack((np.sin(t / 3), np.cos(t / 5), 0.01 * t)) + 0.02 * rng.standard_normal((n, 3))
    sigma = np.column_stack((np.full(n, 0.02), np.full(n, 0.02), rng.uniform(0.03, 0.05, n)))
    w = 1.0 / sigma
    w[500:520] *= 0.01  # a float period
    for lam in (0.9, 0.999):
        a, b = (_fits(monkeypatch, e, t, y, w, lam, sigma=sigma) for e in ("c", "reference"))
        for x, r in ((a.spline.g, b.spline.g), (a.spline.gamma, b.spline.gamma), (a.std, b.std)):
            assert np.max(np.abs(x - r)) <= 1e-9 * np.max(np.abs(r))
    # GCV: the same lambda (to the search's tolerance, 1e-4 in log10 alpha) on well-conditioned columns
    a, b = (_fits(monkeypatch, e, t[:800], y[:800, :2], w[:800, :2], None) for e in ("c", "reference"))
    assert np.allclose(np.log10(a.penalty), np.log10(b.penalty), atol=1e-4)
    assert np.allclose(a.spline.g, b.spline.g, rtol=1e-6, atol=1e-6)


@needs_c
def test_entry_points_refuse_wrong_buffers() -> None:
    h = np.full(4, 0.1)
    with pytest.raises(ValueError):
        C.minv_diag(False, h, np.ones(4), 1.0, np.empty(5))  # winv one short
    with pytest.raises(ValueError):
        C.reinsch(h, np.ones(5), 1.0, np.ones((5, 2)), np.empty((5, 2)), np.empty((5, 1)), None)
    with pytest.raises(ValueError):
        C.reinsch(h, np.ones(5), 1.0, np.ones((5, 2)), np.empty((5, 2)), np.empty((5, 2)), np.empty(4))
    with pytest.raises(TypeError):  # float32 queries
        C.evaluate(np.arange(3.0), np.ones((3, 1)), np.ones((3, 1)), np.ones(4, np.float32), *[np.empty(4)] * 3, False)
    with pytest.raises((ValueError, TypeError, BufferError)):
        C.evaluate(np.arange(3.0), np.ones((3, 1)), np.ones((3, 1)), np.ones(4), *[np.empty(8)[::2]] * 3, False)
    with pytest.raises(TypeError):  # int64 items have float64's size but are no floats
        C.minv_diag(False, h, np.ones(5, np.int64), 1.0, np.empty(5))


@needs_c
def test_running_median_matches_its_numpy_reference() -> None:
    """``_banded_c.running_median`` = ``spline_robust._running_median_py``: scipy's running median with the
    ends by hand on finite values, the padded nanmedian where a value is NaN or infinite; ties, shrinking ends."""
    from sportfusion.estimators.spline_robust import _running_median_py

    rng = np.random.default_rng(11)
    for n in (1, 2, 3, 17, 31, 32, 200):
        for half in (1, 3, 15):
            v = rng.integers(0, 6, n) + np.where(rng.random(n) < 0.5, 0.0, rng.random(n))  # many ties
            np.testing.assert_array_equal(_banded.running_median(v, half), _running_median_py(v, half))
            v[rng.random(n) < 0.1] = np.inf
            v[rng.random(n) < 0.2] = np.nan
            v[0] = 1.0  # (every window holds a value: nanmedian warns on an empty one)
            v[-1] = 2.0
            if n > 2 * half + 1:
                v[np.arange(half, n - half, 2 * half + 1)] = 1.5
            np.testing.assert_array_equal(_banded.running_median(v, half), _running_median_py(v, half))
    assert np.isnan(_banded.running_median(np.array([np.nan, np.nan, 1.0, np.nan, np.nan, np.nan]), 1)[-1])


@needs_c
@pytest.mark.parametrize("same", [True, False])
def test_loo_fit_in_c_matches_the_reference(monkeypatch: pytest.MonkeyPatch, same: bool) -> None:
    """The robust screen's fit and leave-one-out residuals from one factorization per weight vector (C) equal
    the reference (smoothing_spline and _minv_diag), and its knots are smoothing_spline's to the bit."""
    from sportfusion.estimators import spline_robust as R

    rng = np.random.default_rng(12)
    n = 1500
    t = np.cumsum(rng.uniform(0.5, 1.5, n))
    y = np.cumsum(rng.normal(0, 2, (n, 3)), axis=0)
    w = np.tile(rng.uniform(0.2, 0.5, (n, 1)), (1, 3))
    if not same:
        w[:, 2] *= 0.5
    a = R._loo_fit(t, y, w, 0.9)
    fit = S.smoothing_spline(t, y, w, 0.9)
    np.testing.assert_array_equal(a[1], fit.spline.g)
    np.testing.assert_array_equal(a[2], fit.spline.gamma)
    monkeypatch.setattr(_banded, "_NATIVE", None)
    b = R._loo_fit(t, y, w, 0.9)
    for x, r in zip(a, b, strict=True):
        assert np.max(np.abs(x - r)) <= 1e-9 * np.max(np.abs(r))


def test_gap_rows_are_found_by_bisection_as_by_mask() -> None:
    rng = np.random.default_rng(3)
    tk = np.sort(rng.uniform(0, 100, 400))
    tk = np.concatenate((tk[tk < 40], tk[tk > 48]))  # an 8 s gap
    y = np.column_stack((np.sin(tk), np.cos(tk / 2)))
    sp = S.smoothing_spline(tk, y, None, 0.95).spline
    gaps = [(float(a), float(b)) for a, b in zip(tk[:-1], tk[1:], strict=True) if b - a > 1.0]
    tq = np.sort(np.concatenate((tk, rng.uniform(0, 100, 300), [gaps[0][0], gaps[0][1]])))
    edge = np.full((tq.size, 2), 0.1)
    got = spline_gaps.gap_std(sp, tk, gaps, tq, edge)
    shuffled = rng.permutation(tq.size)  # unsorted rows take the mask path
    ref = spline_gaps.gap_std(sp, tk, gaps, tq[shuffled], edge[shuffled])
    assert np.array_equal(got[shuffled], ref, equal_nan=True)
    inside = (tq > gaps[0][0]) & (tq < gaps[0][1])
    assert np.isfinite(got[inside]).all() and np.isnan(got[np.isin(tq, tk)]).all()


def test_std_at_rows_is_numpy_interp() -> None:
    from sportfusion.skirace.track import _at_rows

    rng = np.random.default_rng(5)
    tk = np.cumsum(rng.uniform(0.5, 1.5, 50))
    t = np.sort(np.concatenate((tk, rng.uniform(tk[0], tk[-1], 80))))
    has = np.isin(t, tk)
    values = rng.uniform(0.01, 0.1, (tk.size, 3))
    rows = np.flatnonzero((t >= tk[0]) & (t <= tk[-1]))
    got = _at_rows(values, tk, t, rows, has)
    ref = np.column_stack([np.interp(t[rows], tk, values[:, c]) for c in range(3)])
    assert np.array_equal(got, ref)
    assert np.array_equal(_at_rows(values, tk, t, slice(rows[0], rows[-1] + 1), has), ref)  # rows as a slice
    assert _at_rows(values, tk, tk, np.arange(tk.size), np.ones(tk.size, bool)) is values  # epochs only: no work
    assert _at_rows(values, tk, tk, slice(0, tk.size), np.ones(tk.size, bool)) is values
