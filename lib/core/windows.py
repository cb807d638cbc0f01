"""Statistics over sliding windows of samples, by running sums (linear in the number of samples)."""

from __future__ import annotations

import numpy as np


def window_mean_std(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-column mean and standard deviation of ``x[lo[i]:hi[i]]`` for every window ``i``.

    Parameters
    ----------
    x : numpy.ndarray, shape (n, d)
        Samples (any unit, finite).
    lo, hi : numpy.ndarray of int, shape (m,)
        Window bounds, ``0 <= lo < hi <= n``.

    Returns
    -------
    mean, std : numpy.ndarray, shape (m, d)
        In the unit of ``x``; std is the population standard deviation (divisor: window length).
        The running sums are taken about the columns' means, so long records lose no precision.
    """
    x = np.asarray(x, dtype=np.float64)
    off = x.mean(axis=0)
    xc = x - off
    zero = np.zeros((1, x.shape[1]))
    c1 = np.concatenate((zero, np.cumsum(xc, axis=0)))
    c2 = np.concatenate((zero, np.cumsum(xc * xc, axis=0)))
    cnt = (np.asarray(hi) - np.asarray(lo))[:, None]
    mean = (c1[hi] - c1[lo]) / cnt
    var = np.maximum((c2[hi] - c2[lo]) / cnt - mean * mean, 0.0)
    return mean + off, np.sqrt(var)
