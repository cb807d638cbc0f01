"""Attitude from a gyroscope and vector observations: a smoother over the whole record.

The model knows no sport: body-frame rates drive the attitude ``q_BO``; vector observations
(a specific force, a magnetic field, ...) measured in the body frame against their reference
directions in NED correct it.  Two solvers of the same model (:func:`gyro_vector_smoother`):

* ``"batch"`` (default): the maximum a-posteriori trajectory by Gauss-Newton over all steps at
  once.  The normal equations are block tridiagonal (6 x 6 blocks: each step couples only to its
  neighbours through the propagation), built with batched numpy and solved by cyclic reduction
  (:mod:`sportfusion.estimators.blocktri`), which also gives the smoothed covariances.  At
  convergence this is the iterated RTS smoother's answer; it costs a few array operations per
  iteration instead of a Python-level step per sample.
* ``"rts"``: the multiplicative EKF forward and the RTS backward pass of
  :func:`sportfusion.estimators.kalman.ekf_rts` with its manifold hooks (the step-by-step
  reference, ~1 ms per step in numpy).

State and error state
---------------------
``x = [q0 q1 q2 q3, b_x b_y b_z]``: ``q_BO`` (scalar first, NED -> body, ``docs/frames.md``) and
the gyro bias ``b`` [rad/s].  The error is ``dx = [dtheta, db]`` with the attitude error in the
body frame on the right, ``q_true = q ⊗ Exp(dtheta)`` (so ``M_BO,true = M(Exp(dtheta)) M_BO``)
and ``b_true = b + db``.

Time-index convention
---------------------
Step ``k`` is sample ``k`` (time ``t[k]``); ``gyr[k]`` is the mean body rate over the interval
*ending* at ``t[k]`` (a delta-angle / integrating gyro, :func:`sportfusion.core.rotations.body_rates`),
so the propagation from step ``k`` to ``k + 1`` uses ``gyr[k + 1]``::

    w_k   = gyr[k+1] - b_k - M_BO(q_k) w_ie            (body rate relative to NED) [rad/s]
    q_k+1 = q_k ⊗ Exp(w_k dt_k),   b_k+1 = b_k          (bias: random walk)

and ``Phi_k`` maps ``dx_k`` onto ``dx_{k+1}``::

    dtheta_k+1 = M(Exp(w_k dt)) dtheta_k - Jr(w_k dt) dt ([M_BO w_ie]x dtheta_k + db_k)
    db_k+1     = db_k

with ``M(.)`` the frame rotation (:func:`~sportfusion.core.rotations.dcm_from_quat`) and ``Jr`` the
right Jacobian of SO(3).  Process noise: ``Q_theta = N_g^2 dt I`` (gyro white noise density
``N_g`` [rad/s/sqrt(Hz)]) and ``Q_b = N_b^2 dt I`` (bias random walk ``N_b`` [rad/s/sqrt(s)]).

A vector observation ``z = M_BO(q) r + v`` (body ``z``, NED reference ``r``, isotropic noise of
1-sigma ``s`` in the vectors' unit) has the residual ``z - M_BO(q) r`` and the Jacobian
``[M_BO(q) r]x`` on ``dtheta`` (zero on ``db``).

Constant sensor biases (``obs_bias``)
-------------------------------------
An observation may carry a constant additive bias ``beta`` (3, body frame, in its vector's unit: an
accelerometer's bias, a magnetometer's residual hard iron).  ``beta`` is three more unknowns shared
by all steps, with a Gaussian prior (``obs_bias0``, 1-sigma ``obs_bias[i]``) and no process noise:

* a vector observation: ``z - beta = M_BO(q) r + v``; residual ``z - beta - M_BO(q) r``, Jacobian
  (the "H" of the prediction, as above) ``[M_BO r]x`` on ``dtheta`` and ``I`` on ``dbeta``;
* a direction observation (``direction``): only the direction of ``z - beta`` is compared,
  ``u = (z - beta)/|z - beta| = M_BO(q) r^`` (``r^ = r/|r|``, 1-sigma ``s`` in rad).  The noise is the
  sensor's, in its unit: the residual is ``v - |v| M_BO(q) r^`` (``v = z - beta``; ``|v|`` times the
  direction residual) with 1-sigma ``s * rho`` (``rho`` the median ``|z|``), Jacobian
  ``|v| [M_BO r^]x`` on ``dtheta`` and ``I - M_BO r^ u^T`` on ``dbeta``.  (Weighting the direction
  residual ``u - M_BO r^`` by ``1/s^2`` alone would let ``beta`` grow along the field: a longer
  ``z - beta`` shrinks the noise's angle, a spurious gain.)

:func:`att_observe_biased` gives both.  A body-frame bias is observable through rotations: it turns
with the body against the reference, which the gyro and the other vector see; held still it is
indistinguishable from a tilt or heading (the prior keeps it).  In the batch solver each bias adds
3 columns that border every step: the normal equations are block tridiagonal plus a dense border,
solved by a Schur complement on the border (:func:`sportfusion.estimators.blocktri.factor_bordered`),
still linear in the number of steps.  The EKF + RTS reference carries the biases as augmented states
(error state ``[dtheta, db, dbeta_1, ...]``, ``Phi`` the identity and no process noise on them).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass, field

import numpy as np

from sportfusion.core.rotations import (
    dcm_from_quat,
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
    quat_normalize,
    rotvec_from_quat,
    skew,
)
from sportfusion.core.stats import median
from sportfusion.estimators import blocktri
from sportfusion.estimators.kalman import Measurement, ekf_rts

#: Rows of the per-sample terms of the batch smoother's normal equations formed at a time (bounds the
#: temporaries: ~1 kB a row each; the result does not depend on it).
CHUNK = 1 << 14

__all__ = [
    "GyroAttitudeResult",
    "gyro_vector_smoother",
    "att_boxplus",
    "att_boxminus",
    "att_propagate",
    "att_observe",
    "att_observe_biased",
    "right_jacobian",
    "process_residuals",
]


def _qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product of two single quaternions (the loop's fast path of ``quat_multiply``)."""
    p0, p1, p2, p3 = p
    q0, q1, q2, q3 = q
    return np.array(
        (
            p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0,
        )
    )


def _dcm(q: np.ndarray) -> np.ndarray:
    """``M_BO`` of one unit quaternion (the loop's fast path of ``dcm_from_quat``, no normalisation)."""
    q0, q1, q2, q3 = q
    return np.array(
        (
            (q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3, 2 * (q1 * q2 + q0 * q3), 2 * (q1 * q3 - q0 * q2)),
            (2 * (q1 * q2 - q0 * q3), q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3, 2 * (q2 * q3 + q0 * q1)),
            (2 * (q0 * q2 + q1 * q3), 2 * (q2 * q3 - q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3),
        )
    )


def _exp(phi: np.ndarray) -> np.ndarray:
    """``Exp(phi)`` of one rotation vector (fast path of ``quat_from_rotvec``)."""
    a = math.sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2])
    k = 0.5 - a * a / 48.0 if a < 1e-4 else math.sin(0.5 * a) / a
    return np.array((math.cos(0.5 * a), k * phi[0], k * phi[1], k * phi[2]))


def _skew3(v: np.ndarray) -> np.ndarray:
    return np.array(((0.0, -v[2], v[1]), (v[2], 0.0, -v[0]), (-v[1], v[0], 0.0)))


def _unit4(q: np.ndarray) -> np.ndarray:
    return q / math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])


def right_jacobian(phi: np.ndarray) -> np.ndarray:
    """Right Jacobian of SO(3) for a rotation vector ``phi`` [rad] (3,): ``Exp(phi + d) ~ Exp(phi) Exp(Jr d)``.

    ``Jr = I - (1 - cos a)/a^2 [phi]x + (a - sin a)/a^3 [phi]x^2`` with ``a = |phi|`` (series below 1e-5 rad).
    """
    phi = np.asarray(phi, dtype=float)
    a = math.sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2])
    K = _skew3(phi)
    if a < 1e-5:
        c1, c2 = 0.5, 1.0 / 6.0
    else:
        c1, c2 = (1.0 - np.cos(a)) / a**2, (a - np.sin(a)) / a**3
    return np.eye(3) - c1 * K + c2 * (K @ K)


def att_boxplus(x: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """``x ⊞ dx``: ``q ⊗ Exp(dtheta)`` and ``b + db`` for ``x = [q (4), b (3)]``, ``dx = [dtheta, db]`` [rad, rad/s]."""
    q = _unit4(_qmul(x[:4], _exp(dx[:3])))
    return np.concatenate((q, x[4:] + dx[3:]))


def att_boxminus(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``y ⊟ x``: the error ``[Log(q_x* ⊗ q_y), b_y - b_x]`` with ``y = x ⊞ (y ⊟ x)``."""
    d = quat_multiply(x[:4] * np.array([1.0, -1.0, -1.0, -1.0]), y[:4])
    return np.concatenate((rotvec_from_quat(d), y[4:] - x[4:]))


def att_propagate(
    x: np.ndarray, gyr_next: np.ndarray, dt: float, w_ie_ned: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """One propagation step (module docstring): returns ``x_{k+1}`` and ``Phi_k`` (6, 6).

    Parameters
    ----------
    x : (7,) state ``[q_BO, b]`` at step k [1, rad/s].
    gyr_next : (3,) gyro sample closing the interval (mean rate over it) [rad/s].
    dt : step [s].
    w_ie_ned : (3,) Earth rate in NED [rad/s] removed from the gyro, or None.
    """
    q, b = x[:4], x[4:]
    w = gyr_next - b
    e = None
    if w_ie_ned is not None:
        e = _dcm(q) @ w_ie_ned
        w = w - e
    phi = w * dt
    dq = _exp(phi)
    xn = np.concatenate((_unit4(_qmul(q, dq)), b))
    Jr = right_jacobian(phi)
    Phi = np.eye(6)
    Phi[:3, :3] = _dcm(dq)
    if e is not None:
        Phi[:3, :3] -= Jr @ _skew3(e) * dt
    Phi[:3, 3:] = -Jr * dt
    return xn, Phi


def att_observe(x: np.ndarray, ref_ned: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Predicted body vector ``M_BO(q) r`` and its Jacobian (3, 6) ``[[M_BO r]x, 0]`` on the error state."""
    h = _dcm(_unit4(x[:4])) @ ref_ned
    H = np.zeros((3, 6))
    H[:, :3] = _skew3(h)
    return h, H


def att_observe_biased(
    x: np.ndarray, z: np.ndarray, ref_ned: np.ndarray, direction: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """A vector observation with a constant bias (module docstring): its residual and Jacobian.

    Parameters
    ----------
    x : (7,) ``[q_BO, beta]`` [1, unit of ``z``].
    z : (3,) measured body vector (a specific force [m/s^2], a magnetometer sample [any unit]).
    ref_ned : (3,) reference vector in NED [unit of ``z``; any unit when ``direction``].
    direction : compare the direction of ``z - beta`` only.

    Returns
    -------
    residual : (3,) ``z - beta - M_BO(q) r`` or, for a direction, ``v - |v| M_BO(q) r^`` with
        ``v = z - beta`` [unit of ``z``].
    H : (3, 6) minus the residual's Jacobian on ``[dtheta, dbeta]``: ``[M_BO r]x``, ``I`` or, for a
        direction, ``|v| [M_BO r^]x``, ``I - M_BO r^ u^T`` (``u = v/|v|``).
    """
    v = z - x[4:7]
    M = _dcm(_unit4(x[:4]))
    H = np.empty((3, 6))
    if not direction:
        h = M @ ref_ned
        H[:, :3] = _skew3(h)
        H[:, 3:] = np.eye(3)
        return v - h, H
    n = math.sqrt(v @ v)
    h = M @ (ref_ned / math.sqrt(ref_ned @ ref_ned))
    H[:, :3] = n * _skew3(h)
    H[:, 3:] = np.eye(3) - np.outer(h, v / n)
    return v - n * h, H


@dataclass
class GyroAttitudeResult:
    """Output of :func:`gyro_vector_smoother`.

    Attributes
    ----------
    q : (N, 4) smoothed ``q_BO`` (scalar first, ``q0 >= 0``).
    bias : (N, 3) smoothed gyro bias [rad/s].
    std_theta : (N, 3) smoothed 1-sigma of the body-frame attitude error [rad].
    cov_theta : (N, 3, 3) its covariance [rad^2].
    std_bias : (N, 3) smoothed 1-sigma of the bias [rad/s].
    q_filt : (N, 4) forward-filter ``q_BO`` (causal; ``"rts"`` only, else None).
    residuals : dict name -> (N, 3) innovations of each observation (NaN where absent or unused);
        ``"batch"``: the residuals at the solution.
    iterations : Gauss-Newton iterations (``"batch"``), 1 for ``"rts"``.
    converged : the last Gauss-Newton attitude step was below ``tol`` (always True for ``"rts"``).
    obs_bias : observation index -> (3,) its estimated constant bias [its unit] (empty without).
    std_obs_bias : observation index -> (3,) its 1-sigma [its unit].
    cov_obs_bias : (3k, 3k) covariance of the k biases, in increasing index order [their units^2], or None.
    """

    q: np.ndarray
    bias: np.ndarray
    std_theta: np.ndarray
    cov_theta: np.ndarray
    std_bias: np.ndarray
    q_filt: np.ndarray | None
    residuals: dict[str, np.ndarray]
    iterations: int = 1
    converged: bool = True
    obs_bias: dict[int, np.ndarray] = field(default_factory=dict)
    std_obs_bias: dict[int, np.ndarray] = field(default_factory=dict)
    cov_obs_bias: np.ndarray | None = None


def _jr_batch(phi: np.ndarray) -> np.ndarray:
    """Right Jacobians (N, 3, 3) of rotation vectors ``phi`` (N, 3) [rad] (see :func:`right_jacobian`)."""
    a = np.linalg.norm(phi, axis=-1)
    small = a < 1e-5
    aa = np.where(small, 1.0, a)
    c1 = np.where(small, 0.5, (1.0 - np.cos(aa)) / aa**2)
    c2 = np.where(small, 1.0 / 6.0, (aa - np.sin(aa)) / aa**3)
    K = skew(phi)
    return np.eye(3) - c1[:, None, None] * K + c2[:, None, None] * (K @ K)


def process_residuals(
    q: np.ndarray, b: np.ndarray, t: np.ndarray, gyr: np.ndarray, w_ie_ned: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Propagation residuals of a whole trajectory and their Jacobians on the earlier step.

    For k = 0 .. N-2, with ``q^_{k+1} = q_k ⊗ Exp(w_k dt_k)`` (module docstring): the residual
    ``[Log(q^_{k+1}* ⊗ q_{k+1}) [rad], b_{k+1} - b_k [rad/s]]`` (N-1, 6), zero for a trajectory the
    gyro explains exactly; its Jacobian on ``dx_{k+1}`` is the identity (to first order in the
    residual) and on ``dx_k`` it is ``-Phi_k`` (N-1, 6, 6).

    Parameters
    ----------
    q : (N, 4) ``q_BO``; b : (N, 3) gyro bias [rad/s]; t : (N,) [s]; gyr : (N, 3) [rad/s] (row k: mean
        rate over the interval ending at ``t[k]``); w_ie_ned : (3,) Earth rate [rad/s] or None.

    Returns
    -------
    res : (N-1, 6); Phi : (N-1, 6, 6).
    """
    dt = np.diff(t)[:, None]
    w = gyr[1:] - b[:-1]
    e = None
    if w_ie_ned is not None:
        e = dcm_from_quat(q[:-1]) @ np.asarray(w_ie_ned, float)
        w = w - e
    phi = w * dt
    dq = quat_from_rotvec(phi)
    pred = quat_multiply(q[:-1], dq)
    rho = rotvec_from_quat(quat_multiply(quat_conjugate(pred), q[1:]))
    res = np.concatenate((rho, b[1:] - b[:-1]), axis=1)
    Jr = _jr_batch(phi)
    Phi = np.zeros((phi.shape[0], 6, 6))
    Phi[:, :3, :3] = dcm_from_quat(dq)
    if e is not None:
        Phi[:, :3, :3] -= Jr @ skew(e) * dt[:, :, None]
    Phi[:, :3, 3:] = -Jr * dt[:, :, None]
    Phi[:, 3:, 3:] = np.eye(3)
    return res, Phi


def _batch(
    t: np.ndarray,
    gyr: np.ndarray,
    body: np.ndarray,
    ref: np.ndarray,
    var: np.ndarray,
    use: np.ndarray,
    x0: np.ndarray,
    P0: np.ndarray,
    q_init: np.ndarray,
    qn: float,
    bn: float,
    w_ie_ned: np.ndarray | None,
    max_iter: int,
    tol: float,
    biased: tuple[int, ...] = (),
    direction: tuple[int, ...] = (),
    beta0: np.ndarray | None = None,
    Pb: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, bool, np.ndarray | None, np.ndarray | None]:
    """Gauss-Newton on the whole trajectory (module docstring); returns q, b, covariance blocks (at the
    last linearisation), the iterations, whether the last attitude step was below ``tol``, and the
    constant biases of the observations ``biased`` (k, 3) with their covariance (3k, 3k) (None, None
    without).  ``beta0`` (k, 3) and ``Pb`` (3k, 3k) are their prior; ``ref[:, i]`` of a ``direction``
    observation must be unit vectors."""
    N = body.shape[0]
    dt = np.diff(t)
    P0i = np.linalg.inv(P0)
    winv = np.where(use, 1.0 / np.where(use, var, 1.0), 0.0)  # (N, m) inverse variances, 0 when unused
    q = quat_normalize(q_init)
    b = np.broadcast_to(x0[4:], (N, 3)).copy()
    nb = len(biased)
    if nb:
        assert beta0 is not None and Pb is not None
        Pbi = np.linalg.inv(Pb)
        beta = np.array(beta0, dtype=float, copy=True)
        raw = np.where(use[:, biased, None], body[:, biased], 0.0)  # (N, k, 3)
        wb = winv[:, biased].copy()
        winv[:, biased] = 0.0  # the biased observations are added below
    # A long record's memory is the normal equations' blocks and their factorisation (~1.5 kB a sample at
    # the peak): the last iteration's factorisation is dropped before the next system is built, the system's
    # blocks once they are factorised, and the per-sample terms are formed CHUNK rows at a time
    f: blocktri.CyclicReduction | blocktri.BlockCholesky | blocktri.Bordered | None = None
    iterations, converged = 0, False
    while iterations < max_iter and not converged:
        iterations += 1
        f = None
        D = np.zeros((N, 6, 6))
        E = np.empty((max(N - 1, 0), 6, 6))
        g = np.zeros((N, 6))  # right-hand side -J^T W r
        border = np.zeros((N, 6, 3 * nb)) if nb else None
        # prior on step 0
        r0 = att_boxminus(np.concatenate((q[0], b[0])), x0)
        D[0] += P0i
        g[0] -= P0i @ r0
        # propagation, steps s..e-1 of each chunk (rows s..e)
        for s in range(0, N - 1, CHUNK):
            e = min(s + CHUNK, N - 1)
            res, Phi = process_residuals(q[s : e + 1], b[s : e + 1], t[s : e + 1], gyr[s : e + 1], w_ie_ned)
            Wp = np.zeros((e - s, 6, 6))  # inverse process noise per step
            Wp[:, :3, :3] = np.eye(3) / (qn * dt[s:e])[:, None, None]
            Wp[:, 3:, 3:] = np.eye(3) / (bn * dt[s:e])[:, None, None]
            PtW = np.swapaxes(Phi, 1, 2) @ Wp
            D[s:e] += PtW @ Phi
            D[s + 1 : e + 1] += Wp
            np.negative(PtW, out=E[s:e])
            g[s:e] += np.einsum("nij,nj->ni", PtW, res)
            g[s + 1 : e + 1] -= np.einsum("nij,nj->ni", Wp, res)
        corner = Pbi.copy() if nb else None
        gc = -Pbi @ (beta - beta0).ravel() if nb else None
        for s in range(0, N, CHUNK):
            e = min(s + CHUNK, N)
            # vector observations: r = z - M r_ref, H = [[M r_ref]x, 0]
            M = dcm_from_quat(q[s:e])
            h = np.einsum("nij,nkj->nki", M, ref[s:e])  # (n, m, 3)
            r = np.where(use[s:e, :, None], body[s:e] - h, 0.0)
            hh = np.einsum("nki,nki->nk", h, h)
            wi = winv[s:e]
            # H^T H = [h]x^T [h]x = |h|^2 I - h h^T ; H^T r = [h]x^T r = r x h
            D[s:e, :3, :3] += np.einsum("nk,ij->nij", wi * hh, np.eye(3)) - np.einsum("nk,nki,nkj->nij", wi, h, h)
            g[s:e, :3] += np.einsum("nk,nki->ni", wi, np.cross(r, h))
            if not nb:
                continue
            # each bias: H = [H_theta, H_beta] (att_observe_biased), its 3 columns border every step
            eye = np.broadcast_to(np.eye(3), (e - s, 3, 3))
            for j, i in enumerate(biased):
                v = raw[s:e, j] - beta[j]
                hj = h[:, i]
                if i in direction:
                    rho = np.linalg.norm(v, axis=1)
                    u = v / np.where(rho > 0, rho, 1.0)[:, None]
                    rb = v - rho[:, None] * hj
                    Ht = rho[:, None, None] * skew(hj)
                    Hb = eye - np.einsum("ni,nj->nij", hj, u)
                else:
                    rb = v - hj
                    Ht = skew(hj)
                    Hb = eye
                w = wb[s:e, j]
                HtW = np.swapaxes(Ht, 1, 2) * w[:, None, None]
                D[s:e, :3, :3] += HtW @ Ht
                g[s:e, :3] += np.einsum("nij,nj->ni", HtW, rb)
                c = slice(3 * j, 3 * j + 3)
                border[s:e, :3, c] = HtW @ Hb  # type: ignore[index]
                corner[c, c] += np.einsum("n,nki,nkj->ij", w, Hb, Hb)  # type: ignore[index]
                gc[c] += np.einsum("n,nki,nk->i", w, Hb, rb)  # type: ignore[index]
        tri = blocktri.factor(D, E, overwrite=True)  # (its factors in D and E's memory, where built in C)
        del D, E
        if not nb:
            f = tri
            dx = blocktri.solve(f, g)
        else:
            f = blocktri.bordered(tri, border, corner)  # type: ignore[arg-type]
            del border
            dx, dbeta = blocktri.solve_bordered(f, g, gc)  # type: ignore[arg-type]
            beta = beta + dbeta.reshape(nb, 3)
        del tri, g
        q = quat_normalize(quat_multiply(q, quat_from_rotvec(dx[:, :3])))
        b = b + dx[:, 3:]
        converged = float(np.max(np.abs(dx[:, :3]))) < tol
    q = np.where(q[:, :1] < 0, -q, q)
    if not nb:
        return q, b, blocktri.diagonal_of_inverse(f), iterations, converged, None, None  # type: ignore[arg-type]
    cov, cov_beta, _ = blocktri.diagonal_of_inverse_bordered(f, border=False)  # type: ignore[arg-type]
    return q, b, cov, iterations, converged, beta, cov_beta


def gyro_vector_smoother(
    t: np.ndarray,
    gyr: np.ndarray,
    body: np.ndarray,
    ref: np.ndarray,
    sigma: np.ndarray,
    q0: np.ndarray,
    *,
    sigma_q0: float = 0.1,
    bias0: np.ndarray | None = None,
    sigma_bias0: float = 0.02,
    gyro_noise: float = 3e-4,
    bias_walk: float = 2e-4,
    w_ie_ned: np.ndarray | None = None,
    names: tuple[str, ...] | None = None,
    method: str = "batch",
    q_init: np.ndarray | None = None,
    max_iter: int = 10,
    tol: float = 1e-7,
    progress: Callable[[int], object] | None = None,
    obs_bias: Mapping[int, float] | None = None,
    obs_bias0: Mapping[int, np.ndarray] | None = None,
    direction: Collection[int] = (),
) -> GyroAttitudeResult:
    """Smoothed attitude and gyro bias from body rates and vector observations (EKF + RTS).

    Parameters
    ----------
    t : (N,) step times [s], strictly increasing.
    gyr : (N, 3) gyro [rad/s], row k the mean rate over ``(t[k-1], t[k]]`` (row 0 unused).
    body : (N, m, 3) observed vectors in the body frame (any unit per vector).
    ref : (N, m, 3) or (m, 3) the same vectors in NED, in the same unit.
    sigma : (N, m) or (m,) isotropic 1-sigma of each observation [its unit]; a non-finite value, or a
        NaN in ``body``/``ref``, leaves that observation out at that step.
    q0 : (4,) prior ``q_BO`` at ``t[0]``; ``sigma_q0`` its 1-sigma per axis [rad].
    bias0 : (3,) prior gyro bias [rad/s] (default 0); ``sigma_bias0`` its 1-sigma [rad/s].
    gyro_noise : gyro white-noise density [rad/s/sqrt(Hz)].
    bias_walk : bias random walk [rad/s/sqrt(s)].
    w_ie_ned : (3,) Earth rate in NED [rad/s] to remove from the gyro, or None.
    names : observation names for :attr:`GyroAttitudeResult.residuals` (default ``obs0``, ...).
    method : ``"batch"`` (Gauss-Newton over the record, block-tridiagonal solve) or ``"rts"``
        (EKF + RTS step by step); module docstring.
    q_init : (N, 4) starting trajectory of ``"batch"`` (e.g. per-sample QUEST solutions with gaps
        bridged by the gyro); default: the gyro integrated from ``q0`` with the bias ``bias0``.
        Within some degrees of the answer it converges in a few iterations.
    max_iter, tol : Gauss-Newton iterations at most, and the largest attitude step [rad] that ends them.
    progress : callable(k) per step of each pass of ``"rts"``, or None.
    obs_bias : observation index -> prior 1-sigma per axis [its unit] of a constant additive bias of that
        observation in the body frame, estimated along (module docstring); None or empty: none.
    obs_bias0 : observation index -> (3,) prior mean of its bias [its unit] (default 0).
    direction : indices of biased observations compared by their direction only (``body[:, i]`` raw, in
        any unit; ``ref[:, i]`` any length; ``sigma[:, i]`` [rad]).

    Returns
    -------
    GyroAttitudeResult
    """
    t = np.asarray(t, dtype=float)
    gyr = np.asarray(gyr, dtype=float)
    body = np.asarray(body, dtype=float)
    N, m = body.shape[0], body.shape[1]
    ref = np.broadcast_to(np.asarray(ref, dtype=float), body.shape)
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), (N, m))
    names = tuple(names) if names is not None else tuple(f"obs{i}" for i in range(m))
    use = np.isfinite(sigma) & (sigma > 0) & np.all(np.isfinite(body), axis=-1) & np.all(np.isfinite(ref), axis=-1)
    qn = float(gyro_noise) ** 2
    bn = float(bias_walk) ** 2
    if N < 2:
        raise ValueError("the smoother needs at least two steps")
    if not (np.all(np.isfinite(gyr[1:])) and np.all(np.diff(t) > 0)):
        raise ValueError("gyro samples must be finite and times strictly increasing")
    if gyro_noise <= 0 or bias_walk <= 0:
        raise ValueError("gyro_noise and bias_walk must be positive")
    x0 = np.concatenate((quat_normalize(q0), np.zeros(3) if bias0 is None else np.asarray(bias0, float)))
    P0 = np.diag([sigma_q0**2] * 3 + [sigma_bias0**2] * 3)
    biased = tuple(sorted(obs_bias or {}))
    direction = tuple(sorted(direction))
    nb = len(biased)
    beta0, Pb = None, None
    if any(not 0 <= i < m for i in biased):
        raise ValueError(f"obs_bias {biased}: not observation indices (0..{m - 1})")
    if not set(direction) <= set(biased):
        raise ValueError(f"direction {direction}: a direction observation must be in obs_bias")
    if nb:
        s_b = np.array([float(obs_bias[i]) for i in biased])  # type: ignore[index]
        if not np.all(np.isfinite(s_b) & (s_b > 0)):
            raise ValueError("obs_bias: the prior 1-sigmas must be positive")
        beta0 = np.array(
            [np.zeros(3) if i not in (obs_bias0 or {}) else np.asarray(obs_bias0[i], float) for i in biased]
        )  # type: ignore[index]
        Pb = np.diag(np.repeat(s_b, 3) ** 2)
    if direction:
        sigma, ref = sigma.copy(), ref.copy()
        for i in direction:
            rho = np.linalg.norm(body[:, i], axis=-1)
            use[:, i] &= rho > 0
            if use[:, i].any():  # the direction's 1-sigma [rad] as the sensor's [its unit] at its median length
                sigma[:, i] *= float(median(rho[use[:, i]]))
            with np.errstate(invalid="ignore", divide="ignore"):
                ref[:, i] /= np.linalg.norm(ref[:, i], axis=-1, keepdims=True)
            use[:, i] &= np.isfinite(ref[:, i]).all(axis=-1)
    if method == "batch":
        if q_init is None:
            from sportfusion.core.rotations import integrate_body_rates

            w = gyr - x0[4:]
            if w_ie_ned is not None:
                w = w - np.asarray(w_ie_ned, float) @ dcm_from_quat(x0[:4]).T  # first-step Earth rate
            q_init = integrate_body_rates(x0[:4], t, w)
        var = np.where(use, sigma, 1.0) ** 2
        q, b, cov, it, ok, beta, cov_beta = _batch(
            t, gyr, body, ref, var, use, x0, P0, q_init, qn, bn, w_ie_ned, max_iter, tol, biased, direction, beta0, Pb
        )
        d = np.sqrt(np.maximum(np.diagonal(cov, axis1=1, axis2=2), 0.0))
        h = np.einsum("nij,nkj->nki", dcm_from_quat(q), ref)
        obs = body
        if nb and beta is not None:
            obs = body.copy()
            for j, i in enumerate(biased):
                obs[:, i] = body[:, i] - beta[j]
                if i in direction:  # residual of the direction [1 ~ rad]
                    with np.errstate(invalid="ignore", divide="ignore"):
                        obs[:, i] /= np.linalg.norm(obs[:, i], axis=-1, keepdims=True)
        res = {names[i]: np.where(use[:, i, None], obs[:, i] - h[:, i], np.nan) for i in range(m)}
        cov_theta = np.ascontiguousarray(cov[:, :3, :3])  # not a view: the (N, 6, 6) blocks go
        del cov
        out = GyroAttitudeResult(q, b, d[:, :3], cov_theta, d[:, 3:], None, res, it, ok)
        if beta is not None and cov_beta is not None:
            sb = np.sqrt(np.maximum(np.diag(cov_beta), 0.0))
            out.obs_bias = {i: beta[j] for j, i in enumerate(biased)}
            out.std_obs_bias = {i: sb[3 * j : 3 * j + 3] for j, i in enumerate(biased)}
            out.cov_obs_bias = cov_beta
        return out
    if method != "rts":
        raise ValueError(f"unknown method {method!r}: expected 'batch' or 'rts'")
    dt = np.diff(t)
    ne = 6 + 3 * nb  # error-state size: [dtheta, db] (+ dbeta_j, constant)
    if beta0 is not None and Pb is not None:
        x0 = np.concatenate((x0, beta0.ravel()))
        P0 = np.block([[P0, np.zeros((6, 3 * nb))], [np.zeros((3 * nb, 6)), Pb]])
    slot = {i: 7 + 3 * j for j, i in enumerate(biased)}  # where bias i sits in x (its error at slot - 1)

    def propagate(k: int, x: np.ndarray):
        xn, Phi6 = att_propagate(x[:7], gyr[k + 1], dt[k], w_ie_ned)
        Phi = np.eye(ne)
        Phi[:6, :6] = Phi6
        Qd = np.zeros((ne, ne))
        Qd[:3, :3] = np.eye(3) * (qn * dt[k])
        Qd[3:6, 3:6] = np.eye(3) * (bn * dt[k])
        return np.concatenate((xn, x[7:])), Phi, Qd

    R_all = np.where(use, sigma, 1.0) ** 2  # an unused observation: zero rows (no effect), unit variance

    def measure(k: int, x: np.ndarray) -> list[Measurement]:
        # one stacked measurement of every observation (fewer small matrices per step)
        if not use[k].any():
            return []
        M = _dcm(_unit4(x[:4]))
        h = ref[k] @ M.T  # (m, 3) predicted body vectors
        r = np.where(use[k][:, None], body[k] - h, 0.0)
        H = np.zeros((3 * m, ne))
        for i in range(m):
            if use[k, i]:
                if i in slot:
                    c = slot[i]
                    r[i], Hi = att_observe_biased(
                        np.concatenate((x[:4], x[c : c + 3])), body[k, i], ref[k, i], i in direction
                    )
                    H[3 * i : 3 * i + 3, :3] = Hi[:, :3]
                    H[3 * i : 3 * i + 3, c - 1 : c + 2] = Hi[:, 3:]
                else:
                    H[3 * i : 3 * i + 3, :3] = _skew3(h[i])
        return [Measurement(r.ravel(), H, np.repeat(R_all[k], 3), "vectors")]

    r = ekf_rts(x0, P0, N, propagate, measure, progress=progress, t=t, boxplus=att_boxplus, boxminus=att_boxminus)
    q = r.x_smooth[:, :4]
    q = np.where(q[:, :1] < 0, -q, q)
    qf = r.x_filt[:, :4]
    qf = np.where(qf[:, :1] < 0, -qf, qf)
    d = np.sqrt(np.maximum(np.diagonal(r.P_smooth, axis1=1, axis2=2), 0.0))
    res = {}
    if "vectors" in r.residuals:
        v = r.residuals["vectors"].reshape(N, m, 3)
        for i in range(m):
            res[names[i]] = np.where(use[:, i, None], v[:, i], np.nan)
    out = GyroAttitudeResult(q, r.x_smooth[:, 4:7], d[:, :3], r.P_smooth[:, :3, :3], d[:, 3:6], qf, res)
    if nb:
        # a constant's smoothed estimate is the same at every step: report step 0's
        out.obs_bias = {i: r.x_smooth[0, c : c + 3] for i, c in slot.items()}
        out.std_obs_bias = {i: d[0, c - 1 : c + 2] for i, c in slot.items()}
        out.cov_obs_bias = r.P_smooth[0, 6:, 6:]
    return out
