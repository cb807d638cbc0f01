"""Compiled (numba) kernels for the banded smoothing-spline pieces.

Imported lazily by :mod:`sportfusion.estimators.spline`, so that a command that
never needs the std columns or GCV does not pay numba's import.  Compiled once
and cached on disk (``cache=True``); each kernel works for real and complex
arrays (one compiled version per dtype).
"""

from __future__ import annotations

import numpy as np

from sportfusion.core._numba import preload_cython_blas

preload_cython_blas()  # before numba: its BLAS check then skips importing the scipy.linalg package
from numba import njit  # noqa: E402


@njit(cache=True)
def ldl_inverse_bands(a0: np.ndarray, a1: np.ndarray, a2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Central bands of ``B^{-1}`` for a symmetric pentadiagonal ``B``; see ``spline._ldl_inverse_bands``.

    ``a0`` is the diagonal, ``a1[i] = B[i+1, i]``, ``a2[i] = B[i+2, i]`` (all length m).
    """
    m = a0.size
    d = np.zeros(m, a0.dtype)
    l1 = np.zeros(m, a0.dtype)
    l2 = np.zeros(m, a0.dtype)
    for i in range(m):
        di = a0[i]
        if i >= 1:
            di -= l1[i - 1] * l1[i - 1] * d[i - 1]
        if i >= 2:
            di -= l2[i - 2] * l2[i - 2] * d[i - 2]
        d[i] = di
        if i + 1 < m:
            v = a1[i]
            if i >= 1:
                v -= l2[i - 1] * l1[i - 1] * d[i - 1]
            l1[i] = v / di
        if i + 2 < m:
            l2[i] = a2[i] / di
    z0 = np.zeros(m + 2, a0.dtype)
    z1 = np.zeros(m + 2, a0.dtype)
    z2 = np.zeros(m + 2, a0.dtype)
    for i in range(m - 1, -1, -1):
        a = l1[i]
        b = l2[i]
        z2[i] = -a * z1[i + 1] - b * z0[i + 2]
        z1[i] = -a * z0[i + 1] - b * z1[i + 1]
        z0[i] = 1.0 / d[i] - a * z1[i] - b * z2[i]
    return z0[:m].copy(), z1[:m].copy(), z2[:m].copy()


@njit(cache=True)
def _interval(t: np.ndarray, x: float) -> int:
    """Index k of the knot interval [t[k], t[k+1]] holding x (clipped to 0..n-2)."""
    n = t.size
    lo = 0
    hi = n - 1
    # largest k with t[k] <= x (side="right" - 1), clipped
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if t[mid] <= x:
            lo = mid
        else:
            hi = mid
    return min(max(lo, 0), n - 2)


@njit(cache=True)
def spline_eval(
    t: np.ndarray, g: np.ndarray, c: np.ndarray, tq: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Value, first and second derivative of the natural cubic spline (knots t, values g, curvatures c) at tq.

    Same formulas as ``NaturalCubicSpline.evaluate``; straight-line continuation outside the knots.
    """
    m = tq.size
    d = g.shape[1]
    n = t.size
    val = np.empty((m, d))
    d1 = np.empty((m, d))
    d2 = np.empty((m, d))
    k = 0
    for i in range(m):
        x = tq[i]
        # sorted queries walk forward; others fall back to bisection
        if k < n - 2 and t[k] <= x and x < t[k + 1]:
            pass
        elif k + 1 < n - 1 and t[k + 1] <= x and (k + 2 >= n - 1 or x < t[k + 2]):
            k += 1
        else:
            k = _interval(t, x)
        h = t[k + 1] - t[k]
        b = (x - t[k]) / h
        if b < 0.0:
            b = 0.0
        elif b > 1.0:
            b = 1.0
        a = 1.0 - b
        out_lo = x < t[0]
        out_hi = x > t[n - 1]
        for j in range(d):
            g0 = g[k, j]
            g1 = g[k + 1, j]
            c0 = c[k, j]
            c1 = c[k + 1, j]
            s1 = (g1 - g0) / h - (3 * a * a - 1) * h / 6.0 * c0 + (3 * b * b - 1) * h / 6.0 * c1
            d1[i, j] = s1
            if out_lo:
                val[i, j] = g[0, j] + s1 * (x - t[0])
                d2[i, j] = 0.0
            elif out_hi:
                val[i, j] = g[n - 1, j] + s1 * (x - t[n - 1])
                d2[i, j] = 0.0
            else:
                val[i, j] = a * g0 + b * g1 + ((a * a * a - a) * c0 + (b * b * b - b) * c1) * h * h / 6.0
                d2[i, j] = a * c0 + b * c1
    return val, d1, d2


@njit(cache=True)
def _speed(t: np.ndarray, g: np.ndarray, c: np.ndarray, k: int, x: float) -> float:
    """|S'(x)| on knot interval k (x clipped into it, as ``evaluate`` does)."""
    h = t[k + 1] - t[k]
    b = (x - t[k]) / h
    if b < 0.0:
        b = 0.0
    elif b > 1.0:
        b = 1.0
    a = 1.0 - b
    s = 0.0
    for j in range(g.shape[1]):
        v = (g[k + 1, j] - g[k, j]) / h - (3 * a * a - 1) * h / 6.0 * c[k, j] + (3 * b * b - 1) * h / 6.0 * c[k + 1, j]
        s += v * v
    return np.sqrt(s)


@njit(cache=True)
def arc_length(
    t: np.ndarray, g: np.ndarray, c: np.ndarray, tq: np.ndarray, xg: np.ndarray, wg: np.ndarray
) -> np.ndarray:
    """Curvilinear distance from t[0] to each tq: Gauss-Legendre (nodes xg, weights wg) per knot interval."""
    n = t.size
    cum = np.zeros(n)
    for k in range(n - 1):
        mid = 0.5 * (t[k] + t[k + 1])
        half = 0.5 * (t[k + 1] - t[k])
        acc = 0.0
        for q in range(xg.size):
            acc += wg[q] * _speed(t, g, c, k, mid + half * xg[q])
        cum[k + 1] = cum[k] + half * acc
    out = np.empty(tq.size)
    for i in range(tq.size):
        k = _interval(t, tq[i])
        a = t[k]
        if tq[i] == a:  # a row on a knot: the interval's partial integral is zero
            out[i] = cum[k]
            continue
        mid = 0.5 * (a + tq[i])
        half = 0.5 * (tq[i] - a)
        acc = 0.0
        for q in range(xg.size):
            acc += wg[q] * _speed(t, g, c, k, mid + half * xg[q])
        out[i] = cum[k] + half * acc
    return out


@njit(cache=True)
def qzqt_diag(h: np.ndarray, z0: np.ndarray, z1: np.ndarray, z2: np.ndarray) -> np.ndarray:
    """``diag(Q Z Q^T)`` (length n) from the central bands of the symmetric ``Z``; see ``spline._qzqt_diag``."""
    n = h.size + 1
    out = np.zeros(n, z0.dtype)
    for i in range(n):
        # row i couples interior knots j = i+1 (q0 of column i), i (q1 of column i-1), i-1 (q2 of column i-2);
        # interior knot j is row j-1 of Z
        ca = 1.0 / h[i] if i <= n - 3 else 0.0
        cb = -(1.0 / h[i - 1] + 1.0 / h[i]) if 1 <= i <= n - 2 else 0.0
        cc = 1.0 / h[i - 1] if i >= 2 else 0.0
        acc = z0[0] * 0.0
        if ca != 0.0:
            acc += ca * ca * z0[i]
        if cb != 0.0:
            acc += cb * cb * z0[i - 1]
            if ca != 0.0:
                acc += 2 * ca * cb * z1[i - 1]
        if cc != 0.0:
            acc += cc * cc * z0[i - 2]
            if cb != 0.0:
                acc += 2 * cb * cc * z1[i - 2]
            if ca != 0.0:
                acc += 2 * ca * cc * z2[i - 2]
        out[i] = acc
    return out


@njit(cache=True)
def reinsch_bands(h: np.ndarray, winv: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bands of ``B = R + alpha Q^T W^{-1} Q`` (diagonal, first and second sub-diagonal; see ``spline._reinsch_bands``)."""
    m = h.size - 1
    a0 = np.zeros(m, winv.dtype)
    a1 = np.zeros(m, winv.dtype)
    a2 = np.zeros(m, winv.dtype)
    for j in range(m):
        q0 = 1.0 / h[j]
        q2 = 1.0 / h[j + 1]
        q1 = -(q0 + q2)
        a0[j] = (h[j] + h[j + 1]) / 3.0 + alpha * (winv[j] * q0 * q0 + winv[j + 1] * q1 * q1 + winv[j + 2] * q2 * q2)
        if j + 1 < m:
            q0n = 1.0 / h[j + 1]
            q1n = -(q0n + 1.0 / h[j + 2])
            a1[j] = h[j + 1] / 6.0 + alpha * (winv[j + 1] * q1 * q0n + winv[j + 2] * q2 * q1n)
        if j + 2 < m:
            a2[j] = alpha * winv[j + 2] * q2 * (1.0 / h[j + 2])
    return a0, a1, a2


@njit(cache=True)
def minv_diag(h: np.ndarray, winv: np.ndarray, alpha: float) -> np.ndarray:
    """``diag((W + K)^{-1})``, ``K = alpha Q R^{-1} Q^T``, in O(n): bands, LDL^T, inverse bands, ``diag(Q Z Q^T)``."""
    a0, a1, a2 = reinsch_bands(h, winv, alpha)
    z0, z1, z2 = ldl_inverse_bands(a0, a1, a2)
    d = qzqt_diag(h, z0, z1, z2)
    return winv - alpha * winv * winv * d
