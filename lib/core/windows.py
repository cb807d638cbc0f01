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
    # the running sums with a leading zero row, formed in place: few temporaries (on a 60k x 6 record each
    # fresh array costs its page faults, more than the arithmetic), the same operations and values
    c1 = np.empty((x.shape[0] + 1, x.shape[1]))
    c2 = np.empty_like(c1)
    c1[0] = c2[0] = 0.0
    np.subtract(x, off, out=c1[1:])
    np.multiply(c1[1:], c1[1:], out=c2[1:])
    np.cumsum(c1[1:], axis=0, out=c1[1:])
    np.cumsum(c2[1:], axis=0, out=c2[1:])
    cnt = (np.asarray(hi) - np.asarray(lo))[:, None]
    mean = c1[hi]
    mean -= c1[lo]
    mean /= cnt
    var = c2[hi]
    var -= c2[lo]
    var /= cnt
    var -= mean * mean
    np.maximum(var, 0.0, out=var)
    np.sqrt(var, out=var)
    mean += off
    return mean, var
