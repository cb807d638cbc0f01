"""Particle-filter machinery that knows no model: weight updates, effective sample size, resampling.

The climbing filter (:mod:`sportfusion.climbing.particles`) and any other bootstrap filter use these on
arrays of ``m`` particle weights (normalised to sum 1).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["reweight", "effective_size", "systematic_resample", "backward_simulation"]


def reweight(w: np.ndarray, log_likelihood: np.ndarray) -> np.ndarray:
    """Weights times likelihoods, renormalised, computed in logs (no underflow for far-off particles).

    Parameters
    ----------
    w : ndarray (m,)
        Current weights (sum 1; zeros allowed).
    log_likelihood : ndarray (m,)
        Log-likelihood of the new measurement per particle (``-inf`` allowed).
    """
    with np.errstate(divide="ignore"):
        lw = np.log(w) + log_likelihood
    out = np.exp(lw - lw.max())
    return out / out.sum()


def effective_size(w: np.ndarray) -> float:
    """Kish's effective sample size ``1 / sum w_i^2`` of normalised weights (between 1 and m)."""
    return float(1.0 / (w @ w))


def systematic_resample(w: np.ndarray, u0: float) -> np.ndarray:
    """Indices of the particles kept by systematic resampling.

    Parameters
    ----------
    w : ndarray (m,)
        Normalised weights.
    u0 : float
        One uniform draw in [0, 1): the offset of the ``m`` evenly spaced pointers.

    Returns
    -------
    ndarray of int (m,)
        Particle ``i`` appears about ``m w_i`` times (never less than ``floor(m w_i)``).
    """
    m = w.size
    u = (u0 + np.arange(m)) / m
    c = np.cumsum(w)
    c[-1] = 1.0
    return np.minimum(np.searchsorted(c, u), m - 1)


def backward_simulation(
    w: np.ndarray,
    ancestors: np.ndarray,
    log_transition: Callable[[int, np.ndarray, np.ndarray], np.ndarray],
    rng: np.random.Generator,
    k0: int = 0,
    moves: int = 2,
) -> np.ndarray:
    """Marginal smoothing weights by backward simulation with MCMC moves: O(m) per step.

    Draws ``m`` trajectories backwards (Godsill, Doucet & West 2004) from the backward kernel
    ``P(x_k = i | x_k+1 = j) ~ w_k(i) f(x_k+1(j) | x_k(i))``.  Instead of the exact O(m) draw per
    trajectory (O(m^2) per step), each trajectory starts from its filter ancestor and takes
    ``moves`` independent Metropolis-Hastings steps with the filter weights as proposal
    (Bunch & Godsill 2013; Dau & Chopin 2023): a proposal ``i'`` is accepted with probability
    ``min(1, f(j | i') / f(j | i))``, which leaves the backward kernel invariant.  The smoothed
    weight of particle ``i`` at step ``k`` is the fraction of trajectories through it.

    Parameters
    ----------
    w : ndarray (n, m)
        The filter's normalised weights per step (rows before ``k0`` are ignored).
    ancestors : ndarray of int (n - 1, m)
        ``ancestors[k, j]``: the particle at step ``k`` that particle ``j`` at step ``k+1`` was
        propagated from (the identity between resampling steps).
    log_transition : callable ``(k, i, j) -> ndarray``
        ``log f(x_k+1(j) | x_k(i))`` up to a constant per step, for index arrays ``i``, ``j`` of equal size.
    rng : numpy.random.Generator
    k0 : int
        First step smoothed.
    moves : int
        Metropolis-Hastings steps per trajectory and step.

    Returns
    -------
    ndarray (n, m)
        Smoothed weights (rows ``k0..n-1``; earlier rows are zero).
    """
    n, m = w.shape
    ws = np.zeros_like(w, dtype=np.float64)
    if n == 0 or k0 >= n:
        return ws
    b = systematic_resample(w[n - 1], float(rng.random()))
    ws[n - 1] = np.bincount(b, minlength=m) / m
    steps = max(n - 1 - k0, 0)
    # everything random and every proposal cumsum up front: the loop is a few array ops per move
    cum = np.cumsum(w[k0 : n - 1], axis=1)
    cum /= cum[:, -1:]
    # proposals for every step and move in one search: row r of the cumsums shifted by r (one sorted array)
    cum += np.arange(steps)[:, None]
    cum[:, -1] = np.arange(1, steps + 1)  # exact row ends
    u = rng.random((steps, moves, m)) + np.arange(steps)[:, None, None]
    props = np.minimum(
        cum.ravel().searchsorted(u.ravel(), side="right").reshape(u.shape),
        np.arange(1, steps + 1)[:, None, None] * m - 1,
    )
    props -= (np.arange(steps) * m)[:, None, None]
    with np.errstate(divide="ignore"):
        log_u = np.log(rng.random((steps, moves, m)))
    for k in range(n - 2, k0 - 1, -1):
        r = k - k0
        cur = ancestors[k, b]
        if moves > 0:
            lcur = log_transition(k, cur, b)
            for mv in range(moves):
                prop = props[r, mv]
                lprop = log_transition(k, prop, b)
                acc = log_u[r, mv] < lprop - lcur
                cur = np.where(acc, prop, cur)
                lcur = np.where(acc, lprop, lcur)
        b = cur
        ws[k] = np.bincount(b, minlength=m)
    ws[k0 : n - 1] /= m
    return ws
