"""The smoother core against an independent dense batch least-squares solution, and its properties."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.estimators.kalman import CovarianceError, Measurement, discretize, ekf_rts, rk4_step


def _problem(seed: int = 0, N: int = 30, n: int = 3):
    """A small time-varying linear Gaussian problem with missing and multi-rate measurements."""
    rng = np.random.default_rng(seed)
    Phis = [np.eye(n) + 0.2 * rng.standard_normal((n, n)) for _ in range(N - 1)]
    Qs = []
    for _ in range(N - 1):
        L = 0.3 * rng.standard_normal((n, n))
        Qs.append(L @ L.T + 0.05 * np.eye(n))
    meas = {}
    for k in range(N):
        items = []
        if k % 3 != 1:  # missing at some steps
            H = rng.standard_normal((2, n))
            Lr = 0.5 * rng.standard_normal((2, 2))
            R = Lr @ Lr.T + 0.1 * np.eye(2)
            items.append((H, R, rng.standard_normal(2), "a"))
        if k % 4 == 0:  # a second, slower sensor at the same steps
            H = rng.standard_normal((1, n))
            items.append((H, np.array([[0.2]]), rng.standard_normal(1), "b"))
        meas[k] = items
    x0 = rng.standard_normal(n)
    L0 = rng.standard_normal((n, n))
    P0 = L0 @ L0.T + np.eye(n)
    return x0, P0, Phis, Qs, meas


def _batch(x0, P0, Phis, Qs, meas):
    """Dense batch (information-form) least squares over all states: mean and full covariance."""
    n = x0.size
    N = len(Phis) + 1
    J = np.zeros((N * n, N * n))
    b = np.zeros(N * n)
    W0 = np.linalg.inv(P0)
    J[:n, :n] += W0
    b[:n] += W0 @ x0
    for k in range(N - 1):
        W = np.linalg.inv(Qs[k])
        D = np.zeros((n, N * n))  # x_{k+1} - Phi x_k
        D[:, (k + 1) * n : (k + 2) * n] = np.eye(n)
        D[:, k * n : (k + 1) * n] = -Phis[k]
        J += D.T @ W @ D
    for k, items in meas.items():
        for H, R, z, _ in items:
            E = np.zeros((H.shape[0], N * n))
            E[:, k * n : (k + 1) * n] = H
            W = np.linalg.inv(R)
            J += E.T @ W @ E
            b += E.T @ W @ z
    C = np.linalg.inv(J)
    return (C @ b).reshape(N, n), C


def _run(x0, P0, Phis, Qs, meas, **kw):
    N = len(Phis) + 1

    def propagate(k, x):
        return Phis[k] @ x, Phis[k], Qs[k]

    def measure(k, x):
        return [Measurement(z - H @ x, H, R, name) for H, R, z, name in meas[k]]

    return ekf_rts(x0, P0, N, propagate, measure, **kw)


def test_matches_dense_batch_least_squares():
    x0, P0, Phis, Qs, meas = _problem()
    res = _run(x0, P0, Phis, Qs, meas)
    xb, C = _batch(x0, P0, Phis, Qs, meas)
    n = x0.size
    np.testing.assert_allclose(res.x_smooth, xb, rtol=0, atol=1e-9)
    for k in range(len(xb)):
        np.testing.assert_allclose(res.P_smooth[k], C[k * n : (k + 1) * n, k * n : (k + 1) * n], rtol=0, atol=1e-9)
    # the last filtered estimate equals the last smoothed one (eqs 17-18), and the filter at step k
    # equals the batch solution over the data up to step k
    np.testing.assert_allclose(res.x_filt[-1], res.x_smooth[-1])
    k = 11
    sub = {j: meas[j] for j in range(k + 1)}
    xk, Ck = _batch(x0, P0, Phis[:k], Qs[:k], sub)
    np.testing.assert_allclose(res.x_filt[k], xk[-1], atol=1e-9)
    np.testing.assert_allclose(res.P_filt[k], Ck[-n:, -n:], atol=1e-9)


def test_covariances_symmetric_positive_definite_throughout():
    x0, P0, Phis, Qs, meas = _problem(seed=3, N=40, n=4)
    res = _run(x0, P0, Phis, Qs, meas)
    for P in (res.P_filt, res.P_smooth):
        assert np.array_equal(P, np.swapaxes(P, 1, 2))
        assert np.linalg.eigvalsh(P).min() > 0
    # smoothing never increases the variance
    assert np.all(np.diagonal(res.P_smooth, axis1=1, axis2=2) <= np.diagonal(res.P_filt, axis1=1, axis2=2) + 1e-12)


def test_residuals_reported_per_name_with_nan_where_absent():
    x0, P0, Phis, Qs, meas = _problem()
    seen = []
    res = _run(x0, P0, Phis, Qs, meas, progress=seen.append)
    assert set(res.residuals) == {"a", "b"}
    assert res.residuals["a"].shape == (30, 2) and res.residuals["b"].shape == (30, 1)
    assert np.all(np.isnan(res.residuals["a"][1::3]))
    assert np.all(np.isfinite(res.residuals["a"][0::3]))
    assert np.all(np.isnan(res.residuals["b"][1::4]))
    assert len(seen) == 30 + 29


@pytest.mark.parametrize("hard", [False, True])
def test_constraint_residual_shrinks_with_variance(hard):
    """A pseudo-measurement x0 + x1 = 1 at every step: smaller variance -> smaller violation."""
    x0, P0, Phis, Qs, meas = _problem(seed=1)
    h = np.array([[1.0, 1.0, 0.0]])
    N = len(Phis) + 1

    def violation(var):
        def propagate(k, x):
            return Phis[k] @ x, Phis[k], Qs[k]

        def measure(k, x):
            items = [Measurement(z - H @ x, H, R, name) for H, R, z, name in meas[k]]
            return [*items, Measurement(np.array([1.0]) - h @ x, h, np.array([[var]]), "c")]

        res = ekf_rts(x0, P0, N, propagate, measure)
        return np.sqrt(np.mean((1.0 - res.x_smooth @ h[0]) ** 2)), res

    vs = [violation(v)[0] for v in (1.0, 1e-2, 1e-4, 1e-6)]
    assert all(b < 0.5 * a for a, b in zip(vs[:-1], vs[1:], strict=True)), vs
    if hard:
        v0, res = violation(0.0)
        assert v0 < 1e-9
        # the constrained direction has (numerically) zero smoothed variance
        assert np.max(np.abs(np.einsum("i,kij,j->k", h[0], res.P_smooth, h[0]))) < 1e-9


def test_non_positive_definite_covariance_raises_with_step():
    x0, P0, Phis, Qs, meas = _problem()
    bad = [q.copy() for q in Qs]
    bad[7] = -5.0 * np.eye(3)
    with pytest.raises(CovarianceError, match=r"step 8 \(t = 0\.800 s\)"):
        _run(x0, P0, Phis, bad, meas, t=np.arange(30) * 0.1)
    nan_phi = [p.copy() for p in Phis]
    nan_phi[3][0, 0] = np.nan
    with pytest.raises(CovarianceError, match="step"):
        _run(x0, P0, nan_phi, Qs, meas)


def test_redundant_hard_constraints_raise_clearly():
    def propagate(k, x):
        return x, np.eye(1), np.zeros((1, 1))

    def measure(k, x):
        return [Measurement(np.array([0.0]) - x, np.eye(1), np.zeros((1, 1)), "hard")]

    with pytest.raises(CovarianceError, match="singular at step 1.*hard"):
        ekf_rts(np.zeros(1), np.eye(1), 3, propagate, measure)


def test_discretize_double_integrator_exact():
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    G = np.array([[0.0], [1.0]])
    q, dt = 0.7, 0.3
    Phi, Qd = discretize(A, G, np.array([[q]]), dt)
    np.testing.assert_allclose(Phi, [[1, dt], [0, 1]], atol=1e-14)
    np.testing.assert_allclose(Qd, q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]), atol=1e-14)
    # eqs 7 and 9 as truncated series: exact for a nilpotent A once order >= 2
    Phi2, Qd2 = discretize(A, G, [q], dt, method="series", order=3)
    gam = np.array([[dt**2 / 2], [dt]])
    np.testing.assert_allclose(Phi2, Phi, atol=1e-14)
    np.testing.assert_allclose(Qd2, q * gam @ gam.T, atol=1e-14)


def test_discretize_series_converges_to_expm():
    rng = np.random.default_rng(5)
    A = rng.standard_normal((4, 4))
    G = rng.standard_normal((4, 2))
    Phi, _ = discretize(A, G, np.eye(2), 0.01)
    Phi_s, _ = discretize(A, G, np.eye(2), 0.01, method="series", order=6)
    np.testing.assert_allclose(Phi_s, Phi, atol=1e-13)
    Phi_1, _ = discretize(A, G, np.eye(2), 0.01, method="series", order=1)
    assert np.max(np.abs(Phi_1 - Phi)) > 1e-6  # first order is visibly truncated


def test_rk4_step_interpolates_input_linearly():
    # x' = u with u linear in time: the exact integral is the trapezoid
    x1 = rk4_step(lambda x, u: u, np.zeros(2), np.array([1.0, -2.0]), np.array([3.0, 4.0]), 0.5)
    np.testing.assert_allclose(x1, 0.5 * np.array([2.0, 1.0]), atol=1e-15)
    # x' = p x: fourth-order accurate
    x = rk4_step(lambda x, u, p: p * x, np.array([1.0]), 0.0, 0.0, 0.1, p=-2.0)
    assert abs(x[0] - np.exp(-0.2)) < 0.2**5 / 120 * 1.1
