"""Weighted smoothing splines (skiracing-splines eqs 5-7) against scipy, csaps and dense linear algebra."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline, make_smoothing_spline

from sportfusion.core.errors import InputError
from sportfusion.estimators import spline as sp


def data(n: int = 150, seed: int = 3):
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 30, n))
    y = np.column_stack((np.sin(t / 2), np.cos(t / 3) * t / 10, 0.05 * t)) + 0.05 * rng.standard_normal((n, 3))
    w = rng.uniform(0.3, 3.0, n)
    return t, y, w


def dense_fit(t, y, w, rho):
    """Dense solve of min sum w (y-g)^2 + gamma^T R_rho gamma with gamma = R^{-1} Q^T g (value form)."""
    n = t.size
    h = np.diff(t)
    Q = np.zeros((n, n - 2))
    R = np.zeros((n - 2, n - 2))
    Rr = np.zeros((n - 2, n - 2))
    for j in range(n - 2):
        Q[j, j], Q[j + 1, j], Q[j + 2, j] = 1 / h[j], -1 / h[j] - 1 / h[j + 1], 1 / h[j + 1]
        R[j, j] = (h[j] + h[j + 1]) / 3
        Rr[j, j] = (rho[j] * h[j] + rho[j + 1] * h[j + 1]) / 3
        if j + 1 < n - 2:
            R[j, j + 1] = R[j + 1, j] = h[j + 1] / 6
            Rr[j, j + 1] = Rr[j + 1, j] = rho[j + 1] * h[j + 1] / 6
    Ri = np.linalg.inv(R)
    K = Q @ Ri @ Rr @ Ri @ Q.T
    return np.linalg.solve(np.diag(w) + K, w * y)


@pytest.mark.parametrize("lam", [0.999, 0.9, 0.5, 0.05])
def test_matches_scipy_make_smoothing_spline(lam):
    t, y, w = data()
    fit = sp.smoothing_spline(t, y[:, 0], w, lam)
    ref = make_smoothing_spline(t, y[:, 0], w=w, lam=sp.penalty_from_lambda(lam))
    tq = np.linspace(t[0], t[-1], 2000)
    for nu, tol in ((0, 1e-8), (1, 1e-8), (2, 1e-7)):
        got = fit.spline(tq, nu)[:, 0]
        want = ref(tq, nu)
        assert np.max(np.abs(got - want)) < tol * max(1.0, np.max(np.abs(want))), nu


def test_matches_csaps():
    csaps = pytest.importorskip("csaps")
    t, y, w = data()
    fit = sp.smoothing_spline(t, y, w, 0.7)
    ref = csaps.CubicSmoothingSpline(t, y.T, weights=w, smooth=0.7)
    tq = np.linspace(t[0], t[-1], 500)
    np.testing.assert_allclose(fit.spline(tq), ref(tq).T, atol=1e-9)


def test_lambda_one_interpolates_and_is_natural():
    t, y, w = data()
    fit = sp.smoothing_spline(t, y, w, 1.0)
    np.testing.assert_allclose(fit.spline(t), y, atol=1e-12)
    tq = np.linspace(t[0], t[-1], 999)
    np.testing.assert_allclose(fit.spline(tq), CubicSpline(t, y, bc_type="natural")(tq), atol=1e-10)


def test_lambda_zero_is_weighted_line():
    t, y, w = data()
    fit = sp.smoothing_spline(t, y[:, 0], w, 0.0)
    slope, icpt = np.polyfit(t, y[:, 0], 1, w=np.sqrt(w))
    np.testing.assert_allclose(
        fit.spline(np.array([2.0, 20.0]))[:, 0], icpt + slope * np.array([2.0, 20.0]), atol=1e-10
    )
    assert np.all(fit.spline(t, 2) == 0)


def test_lambda_mapping():
    assert sp.penalty_from_lambda(0.5) == 1.0
    assert sp.penalty_from_lambda(1.0) == 0.0
    assert sp.penalty_from_lambda(0.0) == np.inf
    assert abs(sp.lambda_from_penalty(sp.penalty_from_lambda(0.3)) - 0.3) < 1e-15
    with pytest.raises(InputError):
        sp.penalty_from_lambda(1.5)


def test_per_column_weights_and_shared_weights_agree():
    t, y, w = data()
    a = sp.smoothing_spline(t, y, w, 0.8)
    b = sp.smoothing_spline(t, y, np.column_stack([w, w, w]), 0.8)
    np.testing.assert_allclose(a.spline(t), b.spline(t), atol=1e-12)


def test_per_segment_lambda_is_the_stated_problem():
    t, y, w = data(80)
    segs = [(5.0, 12.0, 0.99), (20.0, 25.0, 0.2)]
    fit = sp.smoothing_spline(t, y[:, 0], w, 0.7, segments=segs)
    rho = sp._interval_penalty(t, segs, 0.7)
    np.testing.assert_allclose(fit.spline(t)[:, 0], dense_fit(t, y[:, 0], w, rho), atol=1e-9)
    # a constant per-segment lambda is the ordinary spline
    same = sp.smoothing_spline(t, y[:, 0], w, 0.7, segments=[(0.0, 100.0, 0.7)])
    np.testing.assert_allclose(same.spline(t), sp.smoothing_spline(t, y[:, 0], w, 0.7).spline(t), atol=1e-9)
    # with lambda None the default outside the segments is the GCV choice, and it is reported
    auto = sp.smoothing_spline(t, y[:, :2], w, None, segments=segs)
    np.testing.assert_allclose(auto.lam, [sp.gcv_lambda(t, y[:, c], w) for c in range(2)], rtol=1e-12)
    np.testing.assert_allclose(auto.penalty, sp.penalty_from_lambda(auto.lam), rtol=1e-12)
    # the segment with lambda 0.99 follows its data more closely than the default
    inside = (t > 5.5) & (t < 11.5)
    base = sp.smoothing_spline(t, y[:, 0], w, 0.7)
    assert (
        np.abs(fit.spline(t[inside])[:, 0] - y[inside, 0]).mean()
        < np.abs(base.spline(t[inside])[:, 0] - y[inside, 0]).mean()
    )


def test_propagated_sigma_matches_dense():
    t, y, w = data(60)
    sig = np.random.default_rng(1).uniform(0.01, 0.2, t.size)
    fit = sp.smoothing_spline(t, y[:, 0], w, 0.8, sigma=sig)
    H = np.column_stack([sp.smoothing_spline(t, e, w, 0.8).spline(t)[:, 0] for e in np.eye(t.size)])
    want = np.sqrt(np.einsum("ij,j,ij->i", H, sig**2, H))
    np.testing.assert_allclose(fit.std[:, 0], want, rtol=1e-8)
    assert np.median(fit.std[:, 0] / sig) < 0.8  # smoothing averages the noise down (weights unrelated to sig here)


def test_gcv_matches_scipy_choice():
    rng = np.random.default_rng(5)
    t = np.sort(rng.uniform(0, 20, 300))
    y = np.sin(t) + 0.1 * rng.standard_normal(t.size)
    lam = sp.gcv_lambda(t, y)
    ref = make_smoothing_spline(t, y)  # lam=None: scipy's GCV
    tq = np.linspace(t[0], t[-1], 1000)
    assert np.max(np.abs(sp.smoothing_spline(t, y, None, lam).spline(tq)[:, 0] - ref(tq))) < 1e-4
    # and it is a minimum of the GCV score
    a = sp.penalty_from_lambda(lam)
    v = sp.gcv_score(t, y, np.ones_like(t), a)[0]
    assert v <= sp.gcv_score(t, y, np.ones_like(t), a * 1.5)[0]
    assert v <= sp.gcv_score(t, y, np.ones_like(t), a / 1.5)[0]


def test_trace_of_hat_matrix():
    t, y, w = data(50)
    a = 0.3
    H = np.column_stack(
        [sp.smoothing_spline(t, e, w, sp.lambda_from_penalty(a)).spline(t)[:, 0] for e in np.eye(t.size)]
    )
    assert abs(sp.gcv_score(t, y[:, 0], w, a)[1] - np.trace(H)) < 1e-8


def test_ambiguity_weights_eq6():
    fix = np.array([4, 4, 4] + [5] * 12 + [4, 4, 4])
    w = sp.ambiguity_weights(fix, w_float=0.5, w_trans=1e-4, no_trans=5, edge_factor=3.0)
    ramp = 1e-4 + (0.5 - 1e-4) * np.arange(5) / 5
    np.testing.assert_allclose(w[3:8], ramp)  # leaving the fixed period
    np.testing.assert_allclose(w[10:15], ramp[::-1])  # approaching the next fixed period
    np.testing.assert_allclose(w[8:10], 0.5)  # float outside the transitions
    np.testing.assert_allclose(w[[2, 15]], 3.0)  # last fixed before / first after, x edge_factor
    np.testing.assert_allclose(w[[0, 1, 16, 17]], 1.0)
    # a float period at the start ramps from its fixed side only
    w2 = sp.ambiguity_weights(np.array([5] * 8 + [4] * 3), no_trans=3)
    np.testing.assert_allclose(w2[:5], 0.5)
    np.testing.assert_allclose(w2[5:8], (1e-4 + (0.5 - 1e-4) * np.arange(3) / 3)[::-1])
    assert np.all(sp.ambiguity_weights(np.full(5, 4)) == 1.0)


def test_epoch_weights_divide_by_sigma():
    w = sp.epoch_weights(np.array([1.0, 0.5, 1.0]), np.array([0.02, 0.2, np.nan]))
    np.testing.assert_allclose(w, [50.0, 2.5, 1.0 / 0.11])  # NaN sigma -> median of the valid ones
    w3 = sp.epoch_weights(np.ones(2), np.array([[0.01, 0.01, 0.02], [0.1, 0.1, 0.2]]))
    np.testing.assert_allclose(w3, [[100, 100, 50], [10, 10, 5]])


def test_derivatives_and_arc_length():
    t = np.linspace(0, 10, 401)
    pos = np.column_stack((20 * np.cos(t / 4), 20 * np.sin(t / 4), 0.5 * t))  # helix: speed sqrt(25 + 0.25)
    fit = sp.smoothing_spline(t, pos, None, 1.0)
    tq = np.linspace(1, 9, 50)
    np.testing.assert_allclose(fit.spline(tq, 1)[:, 0], -5 * np.sin(tq / 4), atol=1e-5)
    np.testing.assert_allclose(fit.spline(tq, 2)[:, 1], -20 / 16 * np.sin(tq / 4), atol=1e-4)
    np.testing.assert_allclose(fit.spline.arc_length(tq), np.sqrt(25.25) * tq, rtol=1e-6)


def test_bad_input():
    with pytest.raises(InputError):
        sp.smoothing_spline(np.array([0.0, 1.0, 1.0]), np.zeros(3))
    with pytest.raises(InputError):
        sp.smoothing_spline(np.array([0.0]), np.zeros(1))
    with pytest.raises(InputError):
        sp.smoothing_spline(np.arange(4.0), np.zeros(4), np.array([1, 0, 1, 1.0]))


def test_extreme_weights_do_not_break_the_factorisation():
    t, y, w = data(200)
    w = w.copy()
    w[50:60] = 1e-9  # huge alpha / w ratio
    fit = sp.smoothing_spline(t, y[:, 0], w, 1e-6)
    assert np.all(np.isfinite(fit.spline(t)))
