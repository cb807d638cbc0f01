"""Extended Kalman filter + Rauch-Tung-Striebel smoother (skijump paper eqs 7-21).

This is the one smoother core of the suite (see ``KALMAN_API.md``); models supply
``propagate`` and ``measure`` callables.  Equality constraints (eqs 23-26) are
pseudo-measurements like any other: soft with a small variance ``R``, hard with
``R = 0``.  Parameters are augmented states with zero derivative (eq 22), which
is the model's business, not the core's.

Time-index convention
---------------------
Step ``k`` is sample ``k`` (time ``t[k]``), ``k = 0 .. N-1``.  ``x0, P0`` are the
prior at step 0, *before* any measurement of step 0 (eqs 10-11 give
``x_{0|0}``; here the step-0 measurements, if any, are applied to that prior).
At every step the measurements of that step update ``x_{k|k-1} -> x_{k|k}``
(one stacked Joseph-form update, eqs 14-16); then
``propagate(k, x_{k|k}) -> (x_{k+1|k}, Phi_k, Qd_k)`` with ``Phi_k`` mapping the
error of ``x_k`` onto ``x_{k+1}`` so that
``P_{k+1|k} = Phi_k P_{k|k} Phi_k^T + Qd_k`` (eq 13 with the errata transposes).
The last propagate call is ``k = N-2``.  The backward pass is eqs 17-21.

States on a manifold (error-state / multiplicative form)
--------------------------------------------------------
A state that is not a vector (e.g. a unit quaternion) passes ``boxplus(x, dx)`` and
``boxminus(y, x)`` (``y = x ⊞ (y ⊟ x)``): ``P`` and the Jacobians then refer to the
error ``dx`` (its size is ``P0``'s, which may differ from ``x``'s), the update is
``x ⊞ K r`` and the smoother's eq 20 is ``x_{k|N} = x_{k|k} ⊞ C (x_{k+1|N} ⊟ x_{k+1|k})``.
Without them both are plain ``+`` and ``-``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "Measurement",
    "SmootherResult",
    "CovarianceError",
    "ekf_rts",
    "discretize",
    "rk4_step",
    "symmetrize",
]


@dataclass
class Measurement:
    """One (pseudo-)measurement applied at one step.

    Attributes
    ----------
    residual : array, shape (m,)
        Innovation ``z - h(x_pred)`` in the measurement's unit (the model computes it).
    H : array, shape (m, n)
        Jacobian ``dh/dx`` at ``x_pred``.
    R : array, shape (m, m) or (m,)
        Noise covariance (a vector is its diagonal).  For a constraint its variance;
        0 makes it hard (eq 24 with ``v_c = 0``).
    name : str
        Label; innovations are reported per name in :attr:`SmootherResult.residuals`.
    """

    residual: np.ndarray
    H: np.ndarray
    R: np.ndarray
    name: str = ""


class CovarianceError(ValueError):
    """A covariance stopped being symmetric positive (semi-)definite or became non-finite.

    The message names the step index (and time when known) and the phase.
    """


@dataclass
class SmootherResult:
    """Output of :func:`ekf_rts`.

    Attributes
    ----------
    x_filt, P_filt : arrays (N, n), (N, n, n)
        Forward EKF estimates ``x_{k|k}`` and covariances.
    x_smooth, P_smooth : arrays (N, n), (N, n, n)
        RTS estimates ``x_{k|N}`` and covariances.
    residuals : dict name -> array (N, m)
        Innovation (prior residual) of every measurement name at each step, NaN where absent.
    """

    x_filt: np.ndarray
    P_filt: np.ndarray
    x_smooth: np.ndarray
    P_smooth: np.ndarray
    residuals: dict[str, np.ndarray] = field(default_factory=dict)


def symmetrize(P: np.ndarray) -> np.ndarray:
    """Return ``(P + P^T) / 2`` (over the last two axes)."""
    return 0.5 * (P + np.swapaxes(P, -1, -2))


def _where(k: int, t: Sequence[float] | np.ndarray | None) -> str:
    if t is None:
        return f"step {k}"
    return f"step {k} (t = {float(t[k]):.3f} s)"


def _check_psd(P: np.ndarray, k: int, t, phase: str) -> None:
    """Raise CovarianceError unless P is finite and PSD up to round-off."""
    if not np.all(np.isfinite(P)):
        raise CovarianceError(f"covariance became non-finite at {_where(k, t)} ({phase})")
    d = np.diag(P)
    scale = max(float(np.max(np.abs(d))), 1e-300)
    if np.min(d) < -1e-9 * scale:
        raise CovarianceError(
            f"covariance not positive definite at {_where(k, t)} ({phase}): "
            f"negative variance {np.min(d):.3g} in state {int(np.argmin(d))}"
        )
    try:
        np.linalg.cholesky(P + (1e-9 * scale) * np.eye(P.shape[0]))
    except np.linalg.LinAlgError:
        ev = np.linalg.eigvalsh(P)
        raise CovarianceError(
            f"covariance not positive definite at {_where(k, t)} ({phase}): "
            f"smallest eigenvalue {ev[0]:.3g} (largest {ev[-1]:.3g})"
        ) from None


def _update(x: np.ndarray, P: np.ndarray, meas: list[Measurement], k: int, t, boxplus: Callable | None = None):
    """Stacked Joseph-form update (eqs 14-16); returns x, P and the innovations."""
    import scipy.linalg

    n = P.shape[0]
    rs, Hs, Rs = [], [], []
    for m in meas:
        r = np.atleast_1d(np.asarray(m.residual, dtype=float))
        H = np.asarray(m.H, dtype=float).reshape(r.size, n)
        R = np.asarray(m.R, dtype=float)
        R = np.diag(np.broadcast_to(R, r.shape)) if R.ndim < 2 else R.reshape(r.size, r.size)
        rs.append(r)
        Hs.append(H)
        Rs.append(R)
    r = np.concatenate(rs)
    H = np.vstack(Hs)
    R = scipy.linalg.block_diag(*Rs)
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(H)) and np.all(np.isfinite(R))):
        names = ", ".join(m.name or "?" for m in meas)
        raise CovarianceError(f"non-finite measurement ({names}) at {_where(k, t)}")
    PHt = P @ H.T
    S = symmetrize(H @ PHt + R)
    try:
        cS = scipy.linalg.cho_factor(S, check_finite=False)
    except np.linalg.LinAlgError:
        names = ", ".join(m.name or "?" for m in meas)
        raise CovarianceError(
            f"innovation covariance singular at {_where(k, t)} for ({names}): "
            "a hard constraint redundant with the state's knowledge, or a zero-variance measurement"
        ) from None
    K = scipy.linalg.cho_solve(cS, PHt.T, check_finite=False).T
    x = x + K @ r if boxplus is None else np.asarray(boxplus(x, K @ r), dtype=float)
    IKH = np.eye(n) - K @ H
    P = symmetrize(IKH @ P @ IKH.T + K @ R @ K.T)
    return x, P


def ekf_rts(
    x0: np.ndarray,
    P0: np.ndarray,
    n_steps: int,
    propagate: Callable[[int, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
    measure: Callable[[int, np.ndarray], list[Measurement]],
    *,
    progress: Callable[[int], object] | None = None,
    t: Sequence[float] | np.ndarray | None = None,
    boxplus: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    boxminus: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> SmootherResult:
    """Extended Kalman filter forward + Rauch-Tung-Striebel backward pass.

    Time-index convention: step k is sample k (time t[k]). x0, P0 are the prior at
    step 0 (before any measurement at step 0). For k = 0..N-1: measurements at
    step k update x_{k|k-1} -> x_{k|k} (Joseph form, symmetric P); then
    propagate(k, x_{k|k}) -> (x_{k+1|k}, Phi_k, Qd_k) where Phi_k maps the error
    of x_k to x_{k+1} (so P_{k+1|k} = Phi_k P_{k|k} Phi_k^T + Qd_k). The last
    propagate call is k = N-2.  measure(k, x_pred) -> list[Measurement] (empty
    list when nothing is measured at step k).

    Parameters
    ----------
    x0 : array (n,)
        Prior mean at step 0.
    P0 : array (n, n)
        Prior covariance at step 0 (symmetric PSD); ``n`` is the size of the error state,
        ``x0.size`` unless ``boxplus``/``boxminus`` are given.
    n_steps : int
        Number of steps N (>= 1).
    propagate, measure : callables
        The model, as above.
    progress : callable(k) or None
        Called once per step of the forward pass and of the backward pass
        (forward k = 0..N-1, then backward k = N-2..0).
    t : array (N,) or None
        Step times [s], only used to name the time in error messages.
    boxplus, boxminus : callables or None
        For a state on a manifold (module docstring): ``boxplus(x, dx)`` applies an error
        ``dx`` (n,) to ``x``; ``boxminus(y, x)`` is the error ``dx`` with ``y = x ⊞ dx``.
        Both None (default): ``x + dx`` and ``y - x``.

    Returns
    -------
    SmootherResult

    Raises
    ------
    CovarianceError
        When a covariance becomes non-finite or not positive (semi-)definite, or an
        innovation covariance is singular; the message names the step (and time).
    """
    import scipy.linalg

    if (boxplus is None) != (boxminus is None):
        raise ValueError("boxplus and boxminus go together")
    x0 = np.asarray(x0, dtype=float).copy()
    nx = x0.size
    n = np.asarray(P0).shape[0] if boxplus is not None else nx
    N = int(n_steps)
    if N < 1:
        raise ValueError("n_steps must be >= 1")
    P = symmetrize(np.asarray(P0, dtype=float).reshape(n, n))
    _check_psd(P, 0, t, "prior P0")
    x_filt = np.empty((N, nx))
    P_filt = np.empty((N, n, n))
    x_pred = np.empty((N, nx))
    P_pred = np.empty((N, n, n))
    Phis = np.empty((max(N - 1, 0), n, n))
    residuals: dict[str, np.ndarray] = {}
    x = x0
    for k in range(N):
        x_pred[k] = x
        P_pred[k] = P
        meas = measure(k, x)
        if meas:
            for m in meas:
                r = np.atleast_1d(np.asarray(m.residual, dtype=float))
                arr = residuals.get(m.name)
                if arr is None:
                    arr = residuals[m.name] = np.full((N, r.size), np.nan)
                if arr.shape[1] != r.size:
                    raise ValueError(f"measurement {m.name!r} changed size at step {k}")
                arr[k] = r
            x, P = _update(x, P, meas, k, t, boxplus)
            _check_psd(P, k, t, "after update")
        x_filt[k] = x
        P_filt[k] = P
        if progress is not None:
            progress(k)
        if k < N - 1:
            x, Phi, Qd = propagate(k, x)
            x = np.asarray(x, dtype=float)
            Phi = np.asarray(Phi, dtype=float)
            Phis[k] = Phi
            P = symmetrize(Phi @ P @ Phi.T + np.asarray(Qd, dtype=float))
            if not np.all(np.isfinite(x)):
                raise CovarianceError(f"state became non-finite when propagating from {_where(k, t)}")
            _check_psd(P, k + 1, t, "after prediction")

    x_s = np.empty_like(x_filt)
    P_s = np.empty_like(P_filt)
    x_s[-1] = x_filt[-1]
    P_s[-1] = P_filt[-1]
    for k in range(N - 2, -1, -1):
        Pp = P_pred[k + 1]
        A = Phis[k] @ P_filt[k]  # (P_f Phi^T)^T
        try:
            c = scipy.linalg.cho_factor(Pp, check_finite=False)
            C = scipy.linalg.cho_solve(c, A, check_finite=False).T  # eq 19
        except np.linalg.LinAlgError:
            C = (np.linalg.pinv(Pp, hermitian=True) @ A).T
        if boxplus is None:
            x_s[k] = x_filt[k] + C @ (x_s[k + 1] - x_pred[k + 1])  # eq 20
        else:
            x_s[k] = boxplus(x_filt[k], C @ np.asarray(boxminus(x_s[k + 1], x_pred[k + 1]), dtype=float))
        Pk = P_filt[k] + C @ (P_s[k + 1] - Pp) @ C.T  # eq 21
        P_s[k] = symmetrize(Pk)
        if not np.all(np.isfinite(P_s[k])):
            raise CovarianceError(f"smoothed covariance became non-finite at {_where(k, t)}")
        if progress is not None:
            progress(k)
    return SmootherResult(x_filt=x_filt, P_filt=P_filt, x_smooth=x_s, P_smooth=P_s, residuals=residuals)


def discretize(
    A: np.ndarray, G: np.ndarray, Qc: np.ndarray, dt: float, *, method: str = "van_loan", order: int = 3
) -> tuple[np.ndarray, np.ndarray]:
    """Discretise ``x' = A x + G w`` over ``dt`` (eqs 7-9).

    Parameters
    ----------
    A : array (n, n)
        Continuous system matrix [1/s].
    G : array (n, nw)
        Noise input matrix.
    Qc : array (nw, nw) or (nw,)
        Noise covariance (a vector is its diagonal).  ``method="van_loan"``: power
        spectral density of continuous white noise (unit of w squared times s).
        ``method="series"``: covariance of the noise sample ``w_k`` held over the step
        (eq 13's ``Q``).
    dt : float
        Step [s].
    method : {"van_loan", "series"}
        ``"van_loan"``: exact ``Phi = exp(A dt)`` and
        ``Qd = int_0^dt e^{A s} G Qc G^T e^{A^T s} ds`` by Van Loan's matrix exponential.
        ``"series"``: eqs 7 and 9 truncated after ``order`` terms,
        ``Phi = sum_{i<=order} (A dt)^i / i!``, ``Gamma = sum_{i=1..order} A^{i-1} dt^i / i! G``
        and ``Qd = Gamma Qc Gamma^T`` (eq 13).
    order : int
        Number of series terms for ``"series"``.

    Returns
    -------
    Phi : array (n, n)
    Qd : array (n, n), symmetric
    """
    import scipy.linalg

    A = np.asarray(A, dtype=float)
    G = np.asarray(G, dtype=float)
    Qc = np.asarray(Qc, dtype=float)
    if Qc.ndim < 2:
        Qc = np.diag(np.broadcast_to(Qc, (G.shape[1],)))
    n = A.shape[0]
    if method == "van_loan":
        M = np.zeros((2 * n, 2 * n))
        M[:n, :n] = -A
        M[:n, n:] = G @ Qc @ G.T
        M[n:, n:] = A.T
        E = scipy.linalg.expm(M * dt)
        Phi = E[n:, n:].T
        Qd = Phi @ E[:n, n:]
        return Phi, symmetrize(Qd)
    if method == "series":
        Adt = A * dt
        Phi = np.eye(n)
        term = np.eye(n)
        S = np.eye(n) * dt  # sum A^{i-1} dt^i / i!
        sterm = np.eye(n) * dt
        for i in range(1, order + 1):
            term = term @ Adt / i
            Phi = Phi + term
            if i >= 2:
                sterm = sterm @ Adt / i
                S = S + sterm
        Gam = S @ G
        return Phi, symmetrize(Gam @ Qc @ Gam.T)
    raise ValueError(f"unknown method {method!r}")


def rk4_step(f: Callable, x: np.ndarray, u0: np.ndarray, u1: np.ndarray, dt: float, p=None) -> np.ndarray:
    """One classical RK4 step of ``x' = f(x, u[, p])`` with the input linear from ``u0`` to ``u1`` (eq 12).

    Parameters
    ----------
    f : callable
        ``f(x, u)`` or, when ``p`` is given, ``f(x, u, p)``.
    x : array (n,)
        State at the start of the step.
    u0, u1 : arrays
        Inputs at the start and end of the step (the midpoint input is their mean).
    dt : float
        Step [s].
    p : optional
        Parameters passed through to ``f``.

    Returns
    -------
    array (n,)
        State at the end of the step.
    """
    x = np.asarray(x, dtype=float)
    u0 = np.asarray(u0, dtype=float)
    u1 = np.asarray(u1, dtype=float)
    um = 0.5 * (u0 + u1)
    args = () if p is None else (p,)
    k1 = f(x, u0, *args)
    k2 = f(x + 0.5 * dt * k1, um, *args)
    k3 = f(x + 0.5 * dt * k2, um, *args)
    k4 = f(x + dt * k3, u1, *args)
    return x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
