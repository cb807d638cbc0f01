"""Particle-filter machinery that knows no model: weight updates, effective sample size, resampling.

The climbing filter (:mod:`sportfusion.climbing.particles`) and any other bootstrap filter use these on
arrays of ``m`` particle weights (normalised to sum 1).
"""

from __future__ import annotations

import numpy as np

__all__ = ["reweight", "effective_size", "systematic_resample"]


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
