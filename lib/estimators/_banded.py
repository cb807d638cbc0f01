"""The smoothing spline's compiled kernels: :mod:`sportfusion.estimators._banded_c` (C), when it is built.

The C extension (built by ``setup.py`` as an optional extension) imports in about a millisecond.  The
functions here allocate the outputs and call it; each returns None where it is not built (no C compiler
at install time, or ``SPORTFUSION_NATIVE=0`` in the environment), and the caller in
:mod:`sportfusion.estimators.spline` (or :mod:`~sportfusion.estimators.spline_robust`) then runs its numpy
reference (``_ldl_inverse_bands_py``, ``_minv_diag_py``, ``NaturalCubicSpline.evaluate``'s numpy formulas,
scipy's banded solve, ``_running_median_py``): the same results to rounding, slower (docs/speed.md).
"""

from __future__ import annotations

from types import ModuleType

import numpy as np

from sportfusion.core.native import load_extension

_UNSET = object()
_NATIVE: ModuleType | None | object = _UNSET


def native() -> ModuleType | None:
    """The C extension module, or None when it is not built or ``SPORTFUSION_NATIVE=0``."""
    global _NATIVE
    if _NATIVE is _UNSET:
        _NATIVE = load_extension("sportfusion.estimators._banded_c")
    return _NATIVE  # type: ignore[return-value]


def _f64(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def reinsch(
    h: np.ndarray, winv: np.ndarray, alpha: float, y: np.ndarray, diag: bool = False
) -> tuple[np.ndarray, ...] | None:
    """Knot values and second derivatives ``(g, gamma)`` (each (n, d)) of the constant-penalty spline, in C.

    Parameters
    ----------
    h : (n-1,) knot spacings [s], n >= 3.
    winv : (n,) inverse weights [1/weight unit].
    alpha : penalty (finite, >= 0).
    y : (n, d) observations (e.g. [m]).
    diag : also return ``diag((W + K)^{-1})`` (n,) from the same factorization (GCV's trace).

    Returns
    -------
    (g, gamma) or (g, gamma, mdiag) or None
        None when the C extension is not available or the banded system lost positive
        definiteness (the caller then takes scipy's solve or the KKT system).
    """
    mod = native()
    if mod is None:
        return None
    y = _f64(y)
    g = np.empty_like(y)
    gam = np.empty_like(y)
    m = np.empty(y.shape[0]) if diag else None
    if not mod.reinsch(_f64(h), _f64(winv), float(alpha), y, g, gam, m):
        return None
    return (g, gam, m) if diag else (g, gam)


def minv_diag(h: np.ndarray, winv: np.ndarray, alpha: float) -> np.ndarray | None:
    """``diag((W + K)^{-1})`` for ``W = diag(1/winv)`` (float or complex), ``K = alpha Q R^{-1} Q^T``; O(n).

    ``h`` (n-1,) knot spacings [s]; the result has ``winv``'s dtype (complex for the complex step).  None
    without the C extension or with fewer than 3 knots (the caller's numpy reference then runs).
    """
    mod = native()
    cplx = np.iscomplexobj(winv)
    if mod is None or np.size(winv) < 3:
        return None
    winv = np.ascontiguousarray(winv, dtype=np.complex128 if cplx else np.float64)
    out = np.empty_like(winv)
    mod.minv_diag(cplx, _f64(h), winv, float(alpha), out)
    return out


def inverse_bands(a0: np.ndarray, a1: np.ndarray, a2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Central bands ``Z[i, i], Z[i, i+1], Z[i, i+2]`` of ``B^{-1}`` for a symmetric pentadiagonal ``B``.

    ``a0`` is the diagonal, ``a1[i] = B[i+1, i]``, ``a2[i] = B[i+2, i]`` (all length m; real or
    complex symmetric, no conjugation).  LDL^T without pivoting, then the Hutchinson-de Hoog recursion.
    None without the C extension.
    """
    mod = native()
    if mod is None:
        return None
    cplx = any(np.iscomplexobj(a) for a in (a0, a1, a2))
    dt = np.complex128 if cplx else np.float64
    a0, a1, a2 = (np.ascontiguousarray(a, dtype=dt) for a in (a0, a1, a2))
    m = a0.size
    z = [np.empty(m + 2, dt) for _ in range(3)]
    mod.inverse_bands(cplx, a0, a1, a2, *z)
    return z[0][:m], z[1][:m], z[2][:m]


def evaluate(t: np.ndarray, g: np.ndarray, c: np.ndarray, tq: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Value, first and second derivative ((m, d) each) of the natural cubic spline at ``tq`` [s] (n >= 2 knots).

    The arrays are column-major (Fortran order): each coordinate is contiguous, so a column goes into an
    Arrow table without a copy.  Call only where :func:`native` is not None.
    """
    mod = native()
    g, c, tq = _f64(g), _f64(c), _f64(tq)
    shape = (g.shape[1], tq.size)
    val, d1, d2 = np.empty(shape), np.empty(shape), np.empty(shape)
    mod.evaluate(_f64(t), g, c, tq, val, d1, d2, True)
    return val.T, d1.T, d2.T


def arc_length(
    t: np.ndarray, g: np.ndarray, c: np.ndarray, tq: np.ndarray, xg: np.ndarray, wg: np.ndarray
) -> np.ndarray:
    """Distance [m] along the spline from ``t[0]`` to each ``tq`` (Gauss-Legendre nodes ``xg``, weights ``wg``).

    Call only where :func:`native` is not None."""
    mod = native()
    g, c, tq = _f64(g), _f64(c), _f64(tq)
    out = np.empty(tq.size)
    mod.arc_length(_f64(t), g, c, tq, _f64(xg), _f64(wg), out)
    return out


def running_median(v: np.ndarray, half: int) -> np.ndarray | None:
    """The median of the non-NaN ``v[j]`` with ``|j - i| <= half`` for each ``i`` (the window shrinks at the ends;
    NaN where it holds no value); None without the C extension."""
    mod = native()
    if mod is None:
        return None
    v = _f64(v)
    out = np.empty(v.size)
    mod.running_median(v, int(half), out)
    return out
