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
    lo, hi = np.asarray(lo), np.asarray(hi)
    mean, var = np.empty((lo.size, x.shape[1])), np.empty((lo.size, x.shape[1]))
    # window by window in blocks of rows: the gathered sums are small temporaries that the allocator reuses
    # (whole-length ones would be fresh pages each: 20 MB instead of 9 on a 60k x 6 record)
    for r0 in range(0, lo.size, _BLOCK):
        r = slice(r0, r0 + _BLOCK)
        cnt = (hi[r] - lo[r])[:, None]
        m, v = mean[r], var[r]
        np.subtract(c1[hi[r]], c1[lo[r]], out=m)
        m /= cnt
        np.subtract(c2[hi[r]], c2[lo[r]], out=v)
        v /= cnt
        v -= m * m
        np.maximum(v, 0.0, out=v)
        np.sqrt(v, out=v)
        m += off
    return mean, var


#: rows of windows per block in window_mean_std
_BLOCK = 4096
