"""Weighted smoothing cubic splines by a direct banded (Reinsch) solve.

The spline ``S`` minimises (skiracing-splines eq 5)::

    sum_i w_i (y_i - S(t_i))^2 + alpha * integral S''(t)^2 dt

with the paper's smoothing factor ``lambda`` in [0, 1] mapped to the penalty
as ``alpha = (1 - lambda) / lambda`` (the convention of de Boor's / MATLAB's
``csaps``): ``lambda = 1`` is the natural interpolating spline, ``lambda = 0``
the weighted least-squares straight line.  Like the paper's lambda, ``alpha``
depends on the units: time in seconds, weights in 1/m (eq 6), so a given
lambda smooths more when the weights are smaller or the epochs sparser.

The minimiser is a natural cubic spline with knots at the data times,
represented here by its values ``g`` and second derivatives ``gamma`` at the
knots.  With ``h_i = t_{i+1} - t_i``, the tridiagonal ``R`` (``(h_{i-1} +
h_i)/3`` on the diagonal, ``h_i/6`` beside it) and the second-difference
matrix ``Q`` (``Q^T g`` = slope differences), Reinsch's equations are::

    (R + alpha Q^T W^{-1} Q) gamma = Q^T y,     g = y - alpha W^{-1} Q gamma

a symmetric positive-definite pentadiagonal system solved by a banded
Cholesky factorisation: O(N) time and memory.  A penalty that varies per knot
interval (per-segment lambda) is solved through the banded KKT system of the
same problem (:func:`_solve_kkt`).

The generalised cross-validation score (Wahba) and the 1-sigma propagated
from the input sigmas use the central bands of ``B^{-1}``, computed in O(N)
by the Hutchinson-de Hoog recursion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.session import time_step_problem
from sportfusion.core.stats import median
from sportfusion.estimators import _banded

__all__ = [
    "NaturalCubicSpline",
    "SplineFit",
    "penalty_from_lambda",
    "lambda_from_penalty",
    "smoothing_spline",
    "gcv_score",
    "gcv_lambda",
    "ambiguity_weights",
    "epoch_weights",
]

#: GGA fix-quality codes (formats.md)
FIX_RTK_FIXED = 4
FIX_RTK_FLOAT = 5


def penalty_from_lambda(lam: float | np.ndarray) -> float | np.ndarray:
    """The paper's smoothing factor ``lambda`` in [0, 1] -> penalty ``alpha = (1 - lambda)/lambda`` (inf at 0)."""
    lam = np.asarray(lam, dtype=float)
    if np.any((lam < 0) | (lam > 1)) or np.any(~np.isfinite(lam)):
        raise InputError(f"smoothing factor lambda {lam} is outside [0, 1]")
    with np.errstate(divide="ignore"):
        out = (1.0 - lam) / lam
    return float(out) if out.ndim == 0 else out


def lambda_from_penalty(alpha: float | np.ndarray) -> float | np.ndarray:
    """Penalty ``alpha`` >= 0 -> the paper's ``lambda = 1 / (1 + alpha)``."""
    out = 1.0 / (1.0 + np.asarray(alpha, dtype=float))
    return float(out) if np.ndim(out) == 0 else out


@dataclass
class NaturalCubicSpline:
    """A natural cubic spline from its knot values and second derivatives.

    Attributes
    ----------
    t : numpy.ndarray, shape (n,)
        Knots [s], strictly increasing.
    g : numpy.ndarray, shape (n, d)
        Values at the knots (e.g. [m]).
    gamma : numpy.ndarray, shape (n, d)
        Second derivatives at the knots (e.g. [m/s^2]); zero at both ends.
    """

    t: np.ndarray
    g: np.ndarray
    gamma: np.ndarray

    def evaluate(self, tq: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Value, first and second derivative at times ``tq`` [s]; each ``(m, d)``.

        Outside ``[t[0], t[-1]]`` the natural spline continues as a straight line.
        """
        t, g, c = self.t, self.g, self.gamma
        tq = np.asarray(tq, dtype=float)
        n = t.size
        if n > 1 and tq.ndim == 1 and _banded.native() is not None:
            return _banded.evaluate(t, g, c, tq)
        if n == 1:
            z = np.zeros((tq.size, g.shape[1]))
            return np.broadcast_to(g[0], z.shape).copy(), z, z.copy()
        k = np.clip(np.searchsorted(t, tq, side="right") - 1, 0, n - 2)
        h = (t[k + 1] - t[k])[:, None]
        g0, g1, c0, c1 = g[k], g[k + 1], c[k], c[k + 1]
        b = np.clip((tq[:, None] - t[k][:, None]) / h, 0.0, 1.0)
        a = 1.0 - b
        val = a * g0 + b * g1 + ((a**3 - a) * c0 + (b**3 - b) * c1) * h**2 / 6.0
        d1 = (g1 - g0) / h - (3 * a**2 - 1) * h / 6.0 * c0 + (3 * b**2 - 1) * h / 6.0 * c1
        d2 = a * c0 + b * c1
        # linear continuation beyond the ends (S'' = 0 there)
        out = (tq < t[0]) | (tq > t[-1])
        if out.any():
            edge = np.where(tq[out] < t[0], 0, n - 1)
            dt = (tq[out] - t[edge])[:, None]
            val[out] = g[edge] + d1[out] * dt  # d1 was evaluated at the clipped end
            d2[out] = 0.0
        return val, d1, d2

    def __call__(self, tq: np.ndarray, nu: int = 0) -> np.ndarray:
        """Value (``nu=0``) or derivative ``nu`` in {1, 2} at times ``tq``."""
        return self.evaluate(tq)[nu]

    def arc_length(self, tq: np.ndarray) -> np.ndarray:
        """Curvilinear distance [m] along the curve from ``t[0]`` to each ``tq`` (d >= 2 columns).

        The speed ``|S'|`` is integrated by 5-point Gauss-Legendre on every
        knot interval (and on the partial interval up to ``tq``).
        """
        t = self.t
        xg, wg = np.polynomial.legendre.leggauss(5)
        tq = np.asarray(tq, dtype=float)
        if t.size > 1 and tq.ndim == 1 and _banded.native() is not None:
            return _banded.arc_length(t, self.g, self.gamma, tq, xg, wg)

        def integral(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            mid, half = (a + b) / 2, (b - a) / 2
            pts = mid[:, None] + half[:, None] * xg[None, :]
            sp = np.linalg.norm(self.evaluate(pts.ravel())[1], axis=1).reshape(pts.shape)
            return half * (sp @ wg)

        cum = np.concatenate(([0.0], np.cumsum(integral(t[:-1], t[1:]))))
        tq = np.asarray(tq, dtype=float)
        k = np.clip(np.searchsorted(t, tq, side="right") - 1, 0, t.size - 2)
        return cum[k] + integral(t[k], tq)


@dataclass
class SplineFit:
    """Result of :func:`smoothing_spline`.

    Attributes
    ----------
    spline : NaturalCubicSpline
    lam : numpy.ndarray, shape (d,)
        The paper's lambda used per column (with ``segments``: outside the segments,
        given or chosen by GCV).
    penalty : numpy.ndarray, shape (d,)
        ``alpha`` per column (with ``segments``: outside the segments).
    std : numpy.ndarray or None, shape (n, d)
        1-sigma of the fitted values at the knots, the input sigmas propagated
        through the smoother (noise only; the smoothing bias is not included).
    """

    spline: NaturalCubicSpline
    lam: np.ndarray
    penalty: np.ndarray
    std: np.ndarray | None


# -- the banded pieces ---------------------------------------------------


def _qcoef(h: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Entries of column j of Q (interior knot j+1): rows j, j+1, j+2."""
    return 1.0 / h[:-1], -(1.0 / h[:-1] + 1.0 / h[1:]), 1.0 / h[1:]


def _reinsch_bands(h: np.ndarray, winv: np.ndarray, alpha: float) -> np.ndarray:
    """Lower bands (3, n-2) of ``B = R + alpha Q^T W^{-1} Q`` (LAPACK lower storage)."""
    q0, q1, q2 = _qcoef(h)
    m = h.size - 1
    ab = np.zeros((3, m), dtype=np.result_type(winv, float))
    ab[0] = (h[:-1] + h[1:]) / 3.0 + alpha * (winv[:-2] * q0**2 + winv[1:-1] * q1**2 + winv[2:] * q2**2)
    ab[1, :-1] = h[1:-1] / 6.0 + alpha * (winv[1:-2] * q1[:-1] * q0[1:] + winv[2:-1] * q2[:-1] * q1[1:])
    ab[2, :-2] = alpha * winv[2:-2] * q2[:-2] * q0[2:]
    return ab


def _qt(h: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``Q^T y`` (slope differences), shape (n-2, d)."""
    s = np.diff(y, axis=0) / h[:, None]
    return np.diff(s, axis=0)


def _q_times(h: np.ndarray, gam: np.ndarray) -> np.ndarray:
    """``Q gamma`` for full-length gamma (zeros at both ends), shape (n, d)."""
    s = np.diff(gam, axis=0) / h[:, None]
    out = np.zeros_like(gam)
    out[:-1] += s
    out[1:] -= s
    return out


def _line_fit(t: np.ndarray, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weighted least-squares straight line through (t, y), values at t; shape (n, d)."""
    tm = np.sum(w * t) / np.sum(w)
    dt = t - tm
    ym = (w[:, None] * y).sum(0) / np.sum(w)
    sxx = np.sum(w * dt * dt)
    slope = (w[:, None] * dt[:, None] * (y - ym)).sum(0) / sxx if sxx > 0 else np.zeros(y.shape[1])
    return ym + dt[:, None] * slope


def _ldl_inverse_bands(ab: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Central bands of ``B^{-1}`` (see :func:`_ldl_inverse_bands_py`), in C where it is built: O(m)."""
    z = _banded.inverse_bands(ab[0], ab[1], ab[2])
    return z if z is not None else _ldl_inverse_bands_py(ab)


def _ldl_inverse_bands_py(ab: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Central bands of ``B^{-1}`` for a symmetric pentadiagonal ``B`` (lower storage ``ab``).

    LDL^T without pivoting, then the Hutchinson-de Hoog (Takahashi) recursion
    ``Z[i, j] = delta_ij / d_i - sum_k L[k, i] Z[k, j]``.  Works for complex
    symmetric ``B`` (no conjugation), as the complex-step 1-sigma needs.

    Returns
    -------
    z0, z1, z2 : arrays (m,)
        ``Z[i, i]``, ``Z[i, i+1]``, ``Z[i, i+2]`` (zero-padded at the end).
    """
    a0, a1, a2 = (ab[k].tolist() for k in range(3))
    m = len(a0)
    d = [0.0] * m
    l1 = [0.0] * m
    l2 = [0.0] * m
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
    z0 = [0.0] * (m + 2)
    z1 = [0.0] * (m + 2)
    z2 = [0.0] * (m + 2)
    for i in range(m - 1, -1, -1):
        a, b = l1[i], l2[i]
        z2[i] = -a * z1[i + 1] - b * z0[i + 2]
        z1[i] = -a * z0[i + 1] - b * z1[i + 1]
        z0[i] = 1.0 / d[i] - a * z1[i] - b * z2[i]
    return np.array(z0[:m]), np.array(z1[:m]), np.array(z2[:m])


def _qzqt_diag_py(h: np.ndarray, z0: np.ndarray, z1: np.ndarray, z2: np.ndarray) -> np.ndarray:
    """``diag(Q Z Q^T)`` (length n) from the central bands of the symmetric ``Z`` (n-2 interior knots)."""
    n = h.size + 1
    q0, q1, q2 = _qcoef(h)
    # full-index padding: interior knot j (1..n-2) is row j-1 of Z
    dt = z0.dtype
    Zd = np.zeros(n + 2, dt)
    Z1 = np.zeros(n + 2, dt)
    Z2 = np.zeros(n + 2, dt)
    Zd[2:n] = z0
    Z1[2:n] = z1
    Z2[2:n] = z2
    # coefficient of row i on interior knot j: c_{i, j} with j = i+1 (q0), i (q1), i-1 (q2)
    ca = np.zeros(n, dt)  # j = i+1
    cb = np.zeros(n, dt)  # j = i
    cc = np.zeros(n, dt)  # j = i-1
    ca[: n - 2] = q0
    cb[1 : n - 1] = q1
    cc[2:n] = q2
    i = np.arange(n)
    # Z entries (padded index p = j + 1): Zd[p], Z1[p] = Z[j, j+1], Z2[p] = Z[j, j+2]
    zaa = Zd[i + 2]
    zbb = Zd[i + 1]
    zcc = Zd[i]
    zab = Z1[i + 1]
    zbc = Z1[i]
    zac = Z2[i]
    return ca * ca * zaa + cb * cb * zbb + cc * cc * zcc + 2 * (ca * cb * zab + cb * cc * zbc + ca * cc * zac)


def _minv_diag(h: np.ndarray, w: np.ndarray, alpha: float) -> np.ndarray:
    """``diag((W + K)^{-1})`` with ``K = alpha Q R^{-1} Q^T`` (complex ``w`` allowed); in C where it is built, O(n)."""
    m = _banded.minv_diag(h, 1.0 / w, alpha)
    return m if m is not None else _minv_diag_py(h, w, alpha)


def _minv_diag_py(h: np.ndarray, w: np.ndarray, alpha: float) -> np.ndarray:
    """Reference (numpy + the Python recursion) for :func:`_minv_diag`."""
    winv = 1.0 / w
    z = _ldl_inverse_bands_py(_reinsch_bands(h, winv, alpha))
    return winv - alpha * winv**2 * _qzqt_diag_py(h, *z)


def gcv_score(t: np.ndarray, y: np.ndarray, w: np.ndarray, alpha: float) -> tuple[float, float]:
    """Weighted generalised cross-validation score and ``tr(H)`` for one column.

    ``V(alpha) = (1/n) sum_i w_i r_i^2 / (1 - tr(H)/n)^2`` with residuals
    ``r = y - S(t)`` and the hat matrix ``H`` (Wahba 1990, eq 4.3.1).
    """
    t = np.asarray(t, float)
    y = np.asarray(y, float).reshape(-1, 1)
    w = np.asarray(w, float)
    h = np.diff(t)
    n = t.size
    # tr(H) = tr(M^{-1} W) = sum_i w_i diag(M^{-1})_i  (= n - alpha sum diag(Q Z Q^T) / w), O(n) compiled;
    # in C the fit and diag(M^{-1}) share one factorization
    both = _banded.reinsch(h, 1.0 / w, alpha, y, diag=True) if n > 2 and np.isfinite(alpha) else None
    if both is not None:
        g, _, mdiag = both
    else:
        g, _ = _reinsch(h, y, w, alpha)
        mdiag = _minv_diag(h, w, alpha)
    r = y[:, 0] - g[:, 0]
    tr = float(np.sum(w * mdiag))
    return float(np.sum(w * r * r) / n / (1.0 - tr / n) ** 2), tr


def _reinsch(h: np.ndarray, y: np.ndarray, w: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Knot values g and second derivatives gamma (both (n, d)) for a constant penalty.

    Solved in C (:func:`sportfusion.estimators._banded.reinsch`, banded LDL^T) where the extension is
    built, else by scipy's banded Cholesky; a system that lost positive definiteness goes to the KKT solve.
    """
    n = h.size + 1
    d = y.shape[1]
    if n == 2 or not np.isfinite(alpha):
        t = np.concatenate(([0.0], np.cumsum(h)))
        return _line_fit(t, y, w), np.zeros((n, d))
    if _banded.native() is not None:
        res = _banded.reinsch(h, 1.0 / w, alpha, y)
        return res if res is not None else _solve_kkt(h, y, w, np.full(n - 1, alpha))
    from scipy.linalg import solveh_banded

    ab = _reinsch_bands(h, 1.0 / w, alpha)
    try:
        inner = solveh_banded(ab, _qt(h, y), lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        # rounding lost positive definiteness (huge alpha / w ratios): pivoted LU on the KKT system
        return _solve_kkt(h, y, w, np.full(n - 1, alpha))
    gam = np.zeros((n, d))
    gam[1:-1] = inner
    g = y - alpha * _q_times(h, gam) / w[:, None]
    return g, gam


def _interval_penalty(t: np.ndarray, segments: list[tuple[float, float, float]], default: float) -> np.ndarray:
    """Penalty per knot interval: intervals whose midpoint is in [t0, t1) take that segment's lambda."""
    mid = (t[:-1] + t[1:]) / 2
    lam = np.full(mid.size, default)
    for t0, t1, value in segments:
        if not 0.0 < value <= 1.0:
            raise InputError(f"segment lambda {value} is outside (0, 1]")
        lam[(mid >= t0) & (mid < t1)] = value
    if np.any(lam <= 0):
        raise InputError("a per-segment fit needs lambda > 0 everywhere (lambda 0 is a straight line)")
    return penalty_from_lambda(lam)


def _solve_kkt(h: np.ndarray, y: np.ndarray, w: np.ndarray, rho: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Knot values and second derivatives for a penalty ``rho_k`` per knot interval.

    Minimises ``sum w_i (y_i - g_i)^2 + gamma^T R_rho gamma`` subject to the
    spline condition ``Q^T g = R gamma``, through its symmetric KKT system in
    the unknowns ``(g_i, gamma_i, mu_i)`` interleaved per knot (bandwidth 5),
    solved by banded LU with partial pivoting::

        [ W    0     Q ] [g    ]   [W y]
        [ 0  R_rho  -R ] [gamma] = [ 0 ]
        [ Q^T -R     0 ] [mu   ]   [ 0 ]

    ``R_rho`` weights interval k's contribution to ``integral S''^2`` by
    ``rho_k``; with a constant ``rho`` it reduces to Reinsch's system.
    """
    from scipy.linalg import solve_banded

    n = h.size + 1
    N = 3 * n
    lu = 5
    ab = np.zeros((2 * lu + 1, N))

    def put(i: np.ndarray, j: np.ndarray, v: np.ndarray) -> None:
        np.add.at(ab, (lu + i - j, j), v)
        off = i != j
        np.add.at(ab, (lu + j[off] - i[off], i[off]), v[off])

    k = np.arange(n)
    G, C, M = 3 * k, 3 * k + 1, 3 * k + 2
    put(G, G, w.astype(float))
    inner = np.arange(1, n - 1)
    q0, q1, q2 = _qcoef(h)
    # Q: rows (knots) j-1, j, j+1 against multiplier mu_j of interior knot j
    put(G[inner - 1], M[inner], q0)
    put(G[inner], M[inner], q1)
    put(G[inner + 1], M[inner], q2)
    # R (standard) and R_rho on interior knots
    r_diag = (h[:-1] + h[1:]) / 3.0
    r_off = h[1:-1] / 6.0
    rho_diag = (rho[:-1] * h[:-1] + rho[1:] * h[1:]) / 3.0
    rho_off = rho[1:-1] * h[1:-1] / 6.0
    put(C[inner], C[inner], rho_diag)
    put(C[inner[:-1]], C[inner[1:]], rho_off)
    put(C[inner], M[inner], -r_diag)
    put(C[inner[:-1]], M[inner[1:]], -r_off)
    put(C[inner[1:]], M[inner[:-1]], -r_off)
    # end knots: gamma = mu = 0
    for e in (0, n - 1):
        put(np.array([C[e], M[e]]), np.array([C[e], M[e]]), np.ones(2))
    rhs = np.zeros((N, y.shape[1]))
    rhs[G] = w[:, None] * y
    sol = solve_banded((lu, lu), ab, rhs, check_finite=False)
    return sol[G], sol[C]


# -- public API ------------------------------------------------------------


def smoothing_spline(
    t: np.ndarray,
    y: np.ndarray,
    w: np.ndarray | None = None,
    lam: float | None = 0.5,
    *,
    segments: list[tuple[float, float, float]] | None = None,
    sigma: np.ndarray | None = None,
    knots: tuple[np.ndarray, np.ndarray] | None = None,
) -> SplineFit:
    """Fit the weighted smoothing cubic spline of eq 5, column by column.

    Parameters
    ----------
    t : array (n,)
        Epoch times [s], strictly increasing.
    y : array (n,) or (n, d)
        Observations (e.g. positions [m]); each column is an independent spline.
    w : array (n,) or (n, d), optional
        Positive weights (default 1), e.g. from :func:`epoch_weights`.
    lam : float or None
        The paper's smoothing factor in [0, 1] (1 interpolates, 0 is the
        straight line); ``None`` chooses it per column by generalised
        cross-validation.
    segments : list of (t0 [s], t1 [s], lambda), optional
        Per-segment smoothing: knot intervals whose midpoint lies in
        ``[t0, t1)`` use that lambda in (0, 1], the others ``lam`` (which is
        chosen by GCV first when None).  Solved through the KKT system.
    sigma : array (n,) or (n, d), optional
        Input 1-sigma [same unit as y]; when given, :attr:`SplineFit.std`
        holds the propagated 1-sigma at the knots (not with ``segments``).
    knots : (g, gamma), each (n, d), optional
        The knot values and second derivatives of this very fit (same ``t``, ``y``, ``w`` and ``lam``, no
        ``segments``) where the caller has already solved it (the robust screen's last pass,
        :func:`sportfusion.estimators.spline_robust.robust_fit`): taken as they are, only the 1-sigma is
        computed.

    Returns
    -------
    SplineFit
    """
    t, y2, h, W = _validated(t, y, w)
    n, d = y2.shape
    S = None if sigma is None else np.broadcast_to(np.asarray(sigma, float).reshape(n, -1), (n, d))
    g = np.empty((n, d))
    gam = np.empty((n, d))
    lams = np.empty(d)
    if knots is not None and lam is not None and not segments:
        g, gam = knots
        lams[:] = float(lam)
    elif lam is not None and not segments and np.all(W == W[:, :1]):
        # one weight vector for all columns: one factorisation, d right-hand sides
        g, gam = _reinsch(h, y2, W[:, 0], penalty_from_lambda(float(lam)))
        lams[:] = float(lam)
    else:
        for c in range(d):
            wc = W[:, c]
            lams[c] = gcv_lambda(t, y2[:, c], wc) if lam is None else float(lam)
            if segments:
                gc, cc = _solve_kkt(h, y2[:, c : c + 1], wc, _interval_penalty(t, segments, lams[c]))
            else:
                gc, cc = _reinsch(h, y2[:, c : c + 1], wc, penalty_from_lambda(lams[c]))
            g[:, c], gam[:, c] = gc[:, 0], cc[:, 0]
    alphas = np.array([penalty_from_lambda(v) for v in lams])
    std = None
    if S is not None and not segments:
        # columns with the same weights, sigmas and penalty (x and y, typically) share one computation
        cols: list[np.ndarray] = []
        for c in range(d):
            same = next(
                (
                    j
                    for j in range(c)
                    if alphas[j] == alphas[c] and np.array_equal(W[:, j], W[:, c]) and np.array_equal(S[:, j], S[:, c])
                ),
                None,
            )
            cols.append(cols[same] if same is not None else _propagated_std(h, W[:, c], alphas[c], S[:, c]))
        std = np.empty((n, d), order="F")  # (each column contiguous, as the output table takes it)
        for c, col in enumerate(cols):
            std[:, c] = col
    return SplineFit(NaturalCubicSpline(t, g, gam), lams, alphas, std)


def _validated(
    t: np.ndarray, y: np.ndarray, w: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(t, y, h, W)`` of :func:`smoothing_spline`'s arguments as float arrays (``y`` and ``W`` (n, d)), or
    InputError: times not strictly increasing, positions not finite, weights not positive and finite."""
    t = np.asarray(t, dtype=float)
    y2 = np.asarray(y, dtype=float)
    y2 = y2.reshape(-1, 1) if y2.ndim == 1 else y2
    n, d = y2.shape
    if t.shape != (n,):
        raise InputError(f"{t.size} times for {n} observations")
    if n < 2:
        raise InputError(f"a smoothing spline needs at least 2 epochs with a position, got {n}")
    h = np.diff(t)
    if not np.all(h > 0) or not np.all(np.isfinite(y2)):
        problem = time_step_problem(t) or "a position that is not finite"
        raise InputError(f"epoch times must be strictly increasing and positions finite: {problem}")
    W = np.ones((n, d)) if w is None else np.broadcast_to(np.asarray(w, float).reshape(n, -1), (n, d))
    if not np.all(W > 0) or not np.all(np.isfinite(W)):
        raise InputError("spline weights must be positive and finite")
    return t, y2, h, W


def _propagated_std(h: np.ndarray, w: np.ndarray, alpha: float, sigma: np.ndarray) -> np.ndarray:
    """1-sigma of the fitted knot values for input noise ``sigma``: ``sqrt(diag(H Sigma H^T))``.

    With ``M = W + K`` and ``H = M^{-1} W``, ``H Sigma H^T = M^{-1} P M^{-1}``
    where ``P = diag(w^2 sigma^2)`` is a weight perturbation:
    ``d/de diag((M - eP)^{-1}) = diag(M^{-1} P M^{-1})``.  The derivative is
    taken by a complex step (exact to rounding), each evaluation costing one
    O(n) banded factorisation and inverse-band recursion.
    """
    n = w.size
    if n == 2 or not np.isfinite(alpha):
        # straight line: H is the weighted LS projector, small n or no smoothing
        t = np.concatenate(([0.0], np.cumsum(h)))
        X = np.stack((np.ones(n), t - t.mean()), axis=1)
        A = X @ np.linalg.solve(X.T @ (w[:, None] * X), (X * w[:, None]).T)
        return np.sqrt(np.einsum("ij,j,ij->i", A, sigma**2, A))
    p = w**2 * sigma**2
    step = 1e-20 / max(float(np.max(p / w)), 1e-300)
    # w - i step p, and then its inverse, in one complex array (16 MB at 1e6 knots: fresh memory costs as much
    # as the arithmetic); the same numbers as _minv_diag(h, w - 1j * step * p, alpha)
    wc = np.empty(n, complex)
    wc.real = w
    np.multiply(p, -step, out=wc.imag)
    if _banded.native() is None:
        m = _minv_diag_py(h, wc, alpha)
    else:
        m = _banded.minv_diag(h, np.divide(1.0, wc, out=wc), alpha)
    var = m.imag / step
    return np.sqrt(np.maximum(var, 0.0, out=var), out=var)


def gcv_lambda(t: np.ndarray, y: np.ndarray, w: np.ndarray | None = None) -> float:
    """The paper's lambda minimising the weighted GCV score for one column.

    Searched on ``log10(alpha)`` over a coarse grid spanning the data's time
    scales, then refined by a bounded Brent search around the best grid point.
    """
    from scipy.optimize import minimize_scalar

    t = np.asarray(t, float)
    y = np.asarray(y, float)
    w = np.ones_like(t) if w is None else np.asarray(w, float)
    n = t.size
    if n < 4:
        return 1.0
    h = np.diff(t)
    # alpha ~ (time scale)^3 * weight density: bracket generously around the data's spacing
    scale = np.log10(median(h) ** 3 * median(w))
    grid = np.linspace(scale - 6, scale + 12, 37)

    def score(e: float) -> float:
        try:
            v = gcv_score(t, y, w, 10.0**e)[0]
        except (np.linalg.LinAlgError, ZeroDivisionError, FloatingPointError):
            return np.inf
        return v if np.isfinite(v) else np.inf

    vals = [score(e) for e in grid]
    i = int(np.argmin(vals))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    res = minimize_scalar(score, bounds=(lo, hi), method="bounded", options={"xatol": 1e-4})
    best = res.x if res.fun <= vals[i] else grid[i]
    return float(lambda_from_penalty(10.0**best))


def ambiguity_weights(
    fix: np.ndarray,
    *,
    w_float: float = 0.5,
    w_trans: float = 1e-4,
    no_trans: int = 5,
    edge_factor: float = 2.0,
) -> np.ndarray:
    """``w_amb.status`` of eq 6 / Figure 2 per positioned epoch.

    Parameters
    ----------
    fix : int array (n,)
        GGA fix quality of consecutive positioned epochs; 4 (RTK fixed) is
        "fixed", every other code counts as not fixed ("float").
    w_float : float
        Weight of float epochs outside the transitions (fixed = 1).
    w_trans : float
        Weight of a float epoch next to a fixed epoch.
    no_trans : int
        Transition length [epochs]: the float epoch at distance ``d`` (1 =
        adjacent) from the nearest fixed epoch gets
        ``w_trans + (w_float - w_trans) (d - 1) / no_trans`` for ``d <= no_trans``.
        Distance is counted only towards fixed neighbours (a float period at the
        start or end of the data ramps from its fixed side only).
    edge_factor : float
        Multiplier (paper: 2-3) for the last fixed epoch before and the first
        fixed epoch after a float period.

    Returns
    -------
    numpy.ndarray (n,)
        Dimensionless weights; divide by sigma_pos for eq 6 (:func:`epoch_weights`).
    """
    fix = np.asarray(fix)
    n = fix.size
    fixed = fix == FIX_RTK_FIXED
    w = np.where(fixed, 1.0, w_float)
    if fixed.all() or not fixed.any():
        return w
    idx = np.arange(n)
    # distance to the previous / next fixed epoch
    last = np.maximum.accumulate(np.where(fixed, idx, -1))
    nxt = np.minimum.accumulate(np.where(fixed, idx, n)[::-1])[::-1]
    big = n + no_trans + 1
    d_prev = np.where(last >= 0, idx - last, big)
    d_next = np.where(nxt < n, nxt - idx, big)
    dist = np.minimum(d_prev, d_next)
    ramp = ~fixed & (dist <= no_trans)
    if no_trans > 0:
        w[ramp] = w_trans + (w_float - w_trans) * (dist[ramp] - 1) / no_trans
    # fixed epochs bordering a float period
    edge = fixed & (np.r_[False, ~fixed[:-1]] | np.r_[~fixed[1:], False])
    w[edge] *= edge_factor
    return w


def epoch_weights(w_amb: np.ndarray, sigma_pos: np.ndarray | None) -> np.ndarray:
    """Eq 6: ``w(i) = w_amb(i) / sigma_pos(i)`` (sigma in m; ``None`` -> w_amb).

    ``sigma_pos`` may be ``(n,)`` or ``(n, d)`` (per axis); missing (NaN or
    non-positive) sigmas take the median of the valid ones.
    """
    w_amb = np.asarray(w_amb, float)
    if sigma_pos is None:
        return w_amb
    s = np.asarray(sigma_pos, dtype=float)
    ok = np.isfinite(s) & (s > 0)
    if not ok.any():
        return w_amb
    if ok.all():  # nothing to fill
        return (w_amb[:, None] / s) if s.ndim == 2 else w_amb / s
    s = s.copy()
    s2 = s.reshape(s.shape[0], -1)
    ok2 = ok.reshape(s2.shape)
    for c in range(s2.shape[1]):
        if ok2[:, c].all():  # nothing to fill (and the median of 1e6 sigmas costs 10-30 ms)
            continue
        fill = median(s2[ok2[:, c], c]) if ok2[:, c].any() else median(s[ok])
        s2[~ok2[:, c], c] = fill
    s = s2.reshape(s.shape)
    return (w_amb[:, None] / s) if s.ndim == 2 else w_amb / s
