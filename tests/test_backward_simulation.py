"""Backward-simulation smoother (estimators.particles.backward_simulation) against FFBSm and the exact RTS.

A scalar random walk observed in noise: the bootstrap filter (the generic pieces) is run once, then
smoothed by FFBSm (O(m^2), written out here) and by backward simulation with MCMC moves (O(m)).
Both smoothed means must match the exact Kalman/RTS smoother within the Monte-Carlo error, and
each other; with zero moves (ancestors only) the smoother degenerates to the filter's genealogy.
"""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.estimators import particles
from sportfusion.estimators.particles import (
    backward_simulation,
    backward_simulation_gaussian,
    reweight,
    systematic_resample,
)

Q, R, N, M = 0.3**2, 0.5**2, 40, 400


def _problem(seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(0.0, np.sqrt(Q), N))
    return x, x + rng.normal(0.0, np.sqrt(R), N)


def _rts(y: np.ndarray) -> np.ndarray:
    xf, pf, xp, pp = (np.zeros(N) for _ in range(4))
    x, p = 0.0, Q
    for k in range(N):
        if k:
            p += Q
        xp[k], pp[k] = x, p
        g = p / (p + R)
        x, p = x + g * (y[k] - x), (1 - g) * p
        xf[k], pf[k] = x, p
    xs = xf.copy()
    for k in range(N - 2, -1, -1):
        c = pf[k] / pp[k + 1]
        xs[k] = xf[k] + c * (xs[k + 1] - xp[k + 1])
    return xs


def _filter(y: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, np.sqrt(Q), M)
    w = np.full(M, 1.0 / M)
    hx, hw = np.empty((N, M)), np.empty((N, M))
    anc = np.tile(np.arange(M), (N - 1, 1))
    for k in range(N):
        if k:
            x = x + rng.normal(0.0, np.sqrt(Q), M)
        w = reweight(w, -0.5 * (y[k] - x) ** 2 / R)
        hx[k], hw[k] = x, w
        if k < N - 1 and 1.0 / (w @ w) < 0.5 * M:
            idx = systematic_resample(w, rng.random())
            anc[k] = idx
            x, w = x[idx], np.full(M, 1.0 / M)
    return hx, hw, anc


def _ffbsm(hx: np.ndarray, hw: np.ndarray) -> np.ndarray:
    ws = np.empty_like(hw)
    ws[-1] = hw[-1]
    for k in range(N - 2, -1, -1):
        f = np.exp(-0.5 * (hx[k + 1][None, :] - hx[k][:, None]) ** 2 / Q)  # f(j | i), rows i
        den = hw[k] @ f
        ws[k] = hw[k] * (f @ (ws[k + 1] / den))
        ws[k] /= ws[k].sum()
    return ws


def _log_f(hx: np.ndarray):  # noqa: ANN202
    return lambda k, i, j: -0.5 * (hx[k + 1][j] - hx[k][i]) ** 2 / Q


def test_backward_simulation_matches_ffbsm_and_rts() -> None:
    x, y = _problem()
    exact = _rts(y)
    hx, hw, anc = _filter(y, seed=1)
    m_ff = (_ffbsm(hx, hw) * hx).sum(axis=1)
    runs = [
        (backward_simulation(hw, anc, _log_f(hx), np.random.default_rng(s), moves=3) * hx).sum(axis=1) for s in range(8)
    ]
    m_bs = np.mean(runs, axis=0)
    post_sd = 0.3  # smoothed 1-sigma is ~0.25-0.3 here: Monte-Carlo error of m draws is ~sd/sqrt(m)
    assert np.max(np.abs(m_ff - exact)) < 0.12, np.max(np.abs(m_ff - exact))
    assert np.max(np.abs(m_bs - m_ff)) < 0.1, np.max(np.abs(m_bs - m_ff))
    assert np.sqrt(np.mean((m_bs - exact) ** 2)) < 1.5 * np.sqrt(np.mean((m_ff - exact) ** 2)) + post_sd / 10
    # one run's trajectories already agree closely in the mean over time
    assert np.sqrt(np.mean((runs[0] - m_ff) ** 2)) < 0.08
    # smoothing helps: closer to the truth than the filter, as the exact smoother is
    m_filt = (hw * hx).sum(axis=1)
    assert np.mean((m_bs - x) ** 2) < np.mean((m_filt - x) ** 2)


def test_weights_are_trajectory_fractions() -> None:
    _, y = _problem(5)
    hx, hw, anc = _filter(y, seed=2)
    ws = backward_simulation(hw, anc, _log_f(hx), np.random.default_rng(0), k0=4, moves=1)
    assert np.allclose(ws[4:].sum(axis=1), 1.0)
    assert np.all(ws[:4] == 0.0)
    assert np.allclose(ws[4:] * M, np.round(ws[4:] * M))  # counts of M trajectories


def test_zero_moves_follows_the_genealogy() -> None:
    _, y = _problem(7)
    hx, hw, anc = _filter(y, seed=4)
    ws = backward_simulation(hw, anc, _log_f(hx), np.random.default_rng(0), moves=0)
    # without moves each trajectory is its ancestor line: support at k is inside the ancestors of k+1's support
    for k in range(N - 1):
        assert set(np.flatnonzero(ws[k])) <= set(anc[k][np.flatnonzero(ws[k + 1])])


def _whitened(hx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The random walk's transition in whitened coordinates: a[k] = x_k / sqrt(Q), b[k] = x_k+1 / sqrt(Q)."""
    a = np.empty((N, M, 1))
    b = np.empty((N, M, 1))
    a[:-1, :, 0] = hx[:-1] / np.sqrt(Q)
    b[:-1, :, 0] = hx[1:] / np.sqrt(Q)
    return a, b


@pytest.mark.parametrize("moves", [0, 1, 3])
def test_gaussian_form_draws_the_same_trajectories(moves: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """backward_simulation_gaussian = backward_simulation with log f = -|b - a|^2 / 2, draw for draw, both ways
    (one step at a time, and many steps per array operation for one move)."""
    _, y = _problem(11)
    hx, hw, anc = _filter(y, seed=6)
    a, b = _whitened(hx)
    ref = backward_simulation(hw, anc, _log_f(hx), np.random.default_rng(5), k0=2, moves=moves)
    for stepwise in (False, True):
        monkeypatch.setattr(particles, "_STEPWISE", stepwise)
        got = backward_simulation_gaussian(hw, anc, a, b, np.random.default_rng(5), k0=2, moves=moves)
        assert np.array_equal(got, ref)


def test_gaussian_form_matches_ffbsm_statistically() -> None:
    """The O(M)-per-step smoother's marginal means against FFBSm's (O(M^2)) within the Monte-Carlo error."""
    _, y = _problem()
    hx, hw, anc = _filter(y, seed=1)
    a, b = _whitened(hx)
    m_ff = (_ffbsm(hx, hw) * hx).sum(axis=1)
    runs = [
        (backward_simulation_gaussian(hw, anc, a, b, np.random.default_rng(s), moves=1) * hx).sum(axis=1)
        for s in range(8)
    ]
    assert np.max(np.abs(np.mean(runs, axis=0) - m_ff)) < 0.1
    assert np.sqrt(np.mean((runs[0] - m_ff) ** 2)) < 0.08


def test_blocks_agree_with_steps_when_proposals_are_often_accepted(monkeypatch: pytest.MonkeyPatch) -> None:
    """Many accepted moves per trajectory and block (wide transition noise): the block form redoes them all."""
    rng = np.random.default_rng(2)
    n, m = 60, 30
    w = rng.random((n, m)) + 0.1
    w /= w.sum(axis=1, keepdims=True)
    anc = np.tile(np.arange(m), (n - 1, 1))
    for k in (7, 30, 31, 50):  # resamplings, two in a row
        anc[k] = np.sort(rng.integers(0, m, m))
    a = rng.normal(0.0, 0.3, (n, m, 2))
    b = rng.normal(0.0, 0.3, (n, m, 2))
    monkeypatch.setattr(particles, "_STEPWISE", True)
    ref = backward_simulation_gaussian(w, anc, a, b, np.random.default_rng(9), k0=3, moves=1)
    monkeypatch.setattr(particles, "_STEPWISE", False)
    got = backward_simulation_gaussian(w, anc, a, b, np.random.default_rng(9), k0=3, moves=1)
    assert np.array_equal(got, ref)


@pytest.mark.parametrize("kind", [np.random.PCG64, np.random.Philox])
def test_backward_draws_in_blocks_are_the_same_numbers(kind: type) -> None:
    """BackwardDraws (the draws a block of steps at a time; PCG64 jumps ahead) gives backward_draws' numbers
    and leaves the generator where backward_draws does."""
    rng = np.random.default_rng(2)
    w = rng.random((40, 6))
    w /= w.sum(axis=1, keepdims=True)
    whole_rng, block_rng = np.random.Generator(kind(9)), np.random.Generator(kind(9))
    end, cum, u, log_u = particles.backward_draws(w, whole_rng, 3, 2)
    draws = particles.BackwardDraws(w[-1], 40 - 1 - 3, block_rng, 2)
    assert np.array_equal(draws.end, end)
    assert whole_rng.random() == block_rng.random()
    for r0, r1 in ((30, 36), (0, 1), (5, 30)):
        c, uu, lu = draws.rows(r0, r1, w[3 + r0 : 3 + r1])
        assert np.array_equal(c, cum[r0:r1]) and np.array_equal(uu, u[r0:r1]) and np.array_equal(lu, log_u[r0:r1])
