"""The transition estimator of the climbing paper (§III-A): one sparse nonlinear least-squares
problem over the whole trial (eq 12), its solution and the velocity covariance (eq 13).

State per IMU sample k (eq 3, as a boxplus manifold, eqs 4-5): the sensor-to-world
rotation ``R_k`` (perturbed on the right, ``R (+) d = R Exp(d)``, the rotation-vector
form of ``q * exp(d/2)``) and the world velocity ``v_k``; the biases ``b_a, b_g, b_m``
are constant over the trial.  The Appendix gives position and biases zero dynamic
covariance, i.e. hard constraints: position appears in no residual of eq 12 and is
integrated afterwards, the biases are one parameter each.

Residuals, whitened by the Appendix covariances (all "per step at the IMU rate"):

* dynamic model ``g(x_k) (-) x_k+1`` for k = 0..n-2 (eqs 6-7; index convention: the
  measurements of sample k carry x_k to x_k+1 over ``dT_k = t_k+1 - t_k``)::

      r_rot = Log(R_k+1^T R_k Exp((w_k - b_g) dT_k))         Sigma_dq = (pi/1800)^2 + (1e-3 |w_k|)^2 + 100 c_k
      r_vel = v_k + dT_k (R_k (a_k - b_a) + g) - v_k+1         Sigma_dv = 4e-4 + (5e-3 |a_k|)^2 + 900 c_k

  with ``c_k = 1`` at a sensor-range violation;
* magnetometer (eq 10) ``R_k^T m_W + b_m - m_k``, Sigma_m = 1e-2 (normalised field; samples
  at or beyond the magnetometer's limit are skipped) plus, beyond the paper, the variance of the
  wall's slowly varying disturbance spread over the samples it spans (``TransitionParams.mag_disturbance``,
  below);
* zero velocity at grips (eq 9) ``v_k``, Sigma_zupt = 0.05^2;
* magnetometer-bias prior (eq 11) ``b_m``, Sigma_bm = 1e-6; plus weak priors on ``b_a``
  (1 m/s^2) and ``b_g`` (0.5 rad/s) that only keep the problem regular.

The normal equations are block tridiagonal in the per-sample states (6 x 6 blocks)
bordered by the 9 bias columns: they are solved exactly by block cyclic reduction
(:mod:`sportfusion.estimators.blocktri`, batched numpy: no loop over the samples, no
``scipy.linalg`` import) and a Schur complement for the biases, inside a
Levenberg-Marquardt loop.  Eq 13's covariance ``(J^T S^-1 J)^-1`` is evaluated only
where it is needed -- the 3 x 3 velocity blocks on its diagonal -- by the
block-tridiagonal selected inversion of the same factorisation plus the rank-9 bias
correction.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sportfusion.climbing import _so3
from sportfusion.climbing._native import native
from sportfusion.climbing.orientation import complementary_filter
from sportfusion.core.errors import InputError
from sportfusion.core.stats import median
from sportfusion.estimators import blocktri

if TYPE_CHECKING:  # imported where used: a command that never calls it does not pay the import
    import scipy.sparse as sp

NX = 6  # tangent dimension per sample: rotation (3), velocity (3)
NB = 9  # biases: accelerometer, gyroscope, magnetometer


@dataclass(frozen=True)
class TransitionParams:
    """Noise model (the paper's Appendix) and solver settings.

    Attributes
    ----------
    sigma_mag : float
        Magnetometer white noise 1-sigma, normalised field (the paper's Sigma_m = 1e-2 I).
    mag_disturbance, mag_correlation_time : float
        1-sigma of the field's slowly varying disturbance (normalised; steel in and behind the wall)
        and its correlation time [s].  Eq 12 treats every magnetometer sample as independent, so at
        100 Hz a disturbance of 0.2-0.6 that lasts a move is counted 100 times a second and the heading
        follows it; here each sample's variance is ``sigma_mag^2 + mag_disturbance^2 tau / dT`` (``dT``
        the median sample interval): the disturbance counts once per correlation time and the
        gyroscope carries the heading within a move (sigma 3.0 at 100 Hz, 2.3 at 60 Hz).  0 gives
        the paper's model.  Chosen on simulated trials (seeds 0-99, 2000-2199, 3000-3099, start-hold
        and per-move figures in :mod:`sportfusion.climbing.particles`): the RMS error of a move's
        displacement fell from 0.19-0.20 to 0.11 m.
    sigma_zupt : float
        Zero-velocity 1-sigma [m/s] (Sigma_zupt = 0.05^2 I).
    sigma_mag_bias : float
        Magnetometer-bias prior 1-sigma, normalised (Sigma_bm = 1e-6 I).
    sigma_rot, rot_scale : float
        Rotation noise per step: ``sigma_rot^2 + (rot_scale |w|)^2`` [rad^2], |w| in rad/s.
    sigma_vel, vel_scale : float
        Velocity noise per step: ``sigma_vel^2 + (vel_scale |a|)^2`` [(m/s)^2], |a| in m/s^2.
    saturated_rot_var, saturated_vel_var : float
        Added at a range violation (100 rad^2, 900 (m/s)^2).
    sigma_acc_bias, sigma_gyr_bias : float
        Weak priors (not in the paper) [m/s^2], [rad/s].
    mag_limit : float
        Magnetometer samples with any axis at or beyond this (normalised) are skipped.
    max_iter : int
        Levenberg-Marquardt iterations at most.
    tol : float
        Stop when the relative cost decrease is below this.
    """

    sigma_mag: float = 0.1
    mag_disturbance: float = 0.3
    mag_correlation_time: float = 1.0
    sigma_zupt: float = 0.05
    sigma_mag_bias: float = 1e-3
    sigma_rot: float = float(np.pi / 1800.0)
    rot_scale: float = 1e-3
    sigma_vel: float = 0.02
    vel_scale: float = 5e-3
    saturated_rot_var: float = 100.0
    saturated_vel_var: float = 900.0
    sigma_acc_bias: float = 1.0
    sigma_gyr_bias: float = 0.5
    mag_limit: float = 1.9
    max_iter: int = 30
    tol: float = 1e-5


@dataclass
class Problem:
    """The data of eq 12 for one trial (n IMU samples)."""

    t: np.ndarray  # (n,) [s]
    acc: np.ndarray  # (n, 3) specific force, sensor frame [m/s^2]
    gyr: np.ndarray  # (n, 3) angular rate, sensor frame [rad/s]
    mag: np.ndarray  # (n, 3) magnetic field, sensor frame, normalised
    grip: np.ndarray  # (n,) bool
    saturated: np.ndarray  # (n,) bool
    m_world: np.ndarray  # (3,) reference field in the map frame, normalised
    g_world: np.ndarray  # (3,) gravity vector in the map frame [m/s^2]
    params: TransitionParams

    def __post_init__(self) -> None:
        p = self.params
        self.dt = np.diff(self.t)
        self.mag_ok = np.isfinite(self.mag).all(axis=1) & (np.abs(np.nan_to_num(self.mag)) < p.mag_limit).all(axis=1)
        w, a, c = np.abs(self.gyr[:-1]), np.abs(self.acc[:-1]), self.saturated[:-1].astype(float)[:, None]
        var_r = p.sigma_rot**2 + (p.rot_scale * w) ** 2 + c * p.saturated_rot_var
        var_v = p.sigma_vel**2 + (p.vel_scale * a) ** 2 + c * p.saturated_vel_var
        self.sig_dyn = np.sqrt(np.hstack([var_r, var_v]))  # (n-1, 6)
        if not (p.mag_disturbance >= 0 and p.mag_correlation_time >= 0):
            raise InputError(
                f"magnetometer disturbance {p.mag_disturbance} over {p.mag_correlation_time} s; "
                "expected a disturbance and a correlation time >= 0"
            )
        dt_med = float(median(self.dt)) if self.dt.size else 1.0
        # per-sample magnetometer 1-sigma: white noise plus the disturbance counted once per correlation time
        self.sig_mag = float(np.sqrt(p.sigma_mag**2 + p.mag_disturbance**2 * p.mag_correlation_time / dt_med))
        self.prior_sig = np.r_[[p.sigma_acc_bias] * 3, [p.sigma_gyr_bias] * 3, [p.sigma_mag_bias] * 3]

    @property
    def n(self) -> int:
        return self.t.size


@dataclass
class State:
    """A point on the manifold: rotations (n, 3, 3) sensor to map, velocities (n, 3) [m/s], biases (9,)."""

    r: np.ndarray
    v: np.ndarray
    b: np.ndarray

    def boxplus(self, dx: np.ndarray, db: np.ndarray) -> State:
        """``x (+) d`` (eq 4): rotations right-multiplied by Exp, vectors added."""
        d = dx.reshape(-1, NX)
        return State(self.r @ _so3.exp(d[:, :3]), self.v + d[:, 3:], self.b + db)


@dataclass
class Linearization:
    """Whitened residuals and their Jacobian blocks at one state."""

    r_dyn: np.ndarray  # (n-1, 6)
    r_mag: np.ndarray  # (n, 3), zero where the magnetometer is not used
    r_zupt: np.ndarray  # (n, 3), zero off the grips
    r_prior: np.ndarray  # (9,)
    ja: np.ndarray | None = None  # (n-1, 6, 6) d r_dyn / d x_k
    jb: np.ndarray | None = None  # (n-1, 6, 6) d r_dyn / d x_k+1
    jc: np.ndarray | None = None  # (n-1, 6, 9) d r_dyn / d b
    jm: np.ndarray | None = None  # (n, 3, 3) d r_mag / d theta_k (d r_mag / d b_m = I / sig_mag)

    @property
    def cost(self) -> float:
        """Half the sum of squared whitened residuals."""
        return 0.5 * float(
            (self.r_dyn**2).sum() + (self.r_mag**2).sum() + (self.r_zupt**2).sum() + self.r_prior @ self.r_prior
        )


def linearize(prob: Problem, st: State, jacobian: bool = True) -> Linearization:
    """Whitened residuals of eq 12 and (optionally) their Jacobian blocks at ``st``.

    Where the C extension is built, the dynamic model's residuals and blocks come from it in one pass over
    the samples (:func:`_linearize_numpy` is the reference, ``tests/test_climbing_native.py``).
    """
    ext = native()
    if ext is None or prob.n < 2:
        return _linearize_numpy(prob, st, jacobian)
    m = prob.n - 1
    r_dyn, ja, jb, jc = np.empty((m, NX)), np.empty((m, NX, NX)), np.empty((m, NX, NX)), np.empty((m, NX, NB))
    c64 = np.ascontiguousarray
    ext.transition_blocks(
        m, c64(prob.dt), c64(prob.gyr), c64(prob.acc), c64(st.r), c64(st.v), c64(st.b), c64(prob.sig_dyn),
        c64(prob.g_world, dtype=np.float64), r_dyn, ja, jb, jc,
    )  # fmt: skip
    lin = _with_sample_terms(prob, st, r_dyn, jacobian)
    if jacobian:
        lin.ja, lin.jb, lin.jc = ja, jb, jc
    return lin


def _with_sample_terms(prob: Problem, st: State, r_dyn: np.ndarray, jacobian: bool) -> Linearization:
    """The linearisation with the per-sample terms both paths form in numpy: the magnetometer (and its
    Jacobian ``jm`` with ``jacobian``), zero velocity and the bias priors, beside the dynamic model's ``r_dyn``."""
    m_pred = np.einsum("nji,j->ni", st.r, prob.m_world)
    r_mag = np.where(prob.mag_ok[:, None], (m_pred + st.b[6:] - np.nan_to_num(prob.mag)) / prob.sig_mag, 0.0)
    r_zupt = np.where(prob.grip[:, None], st.v / prob.params.sigma_zupt, 0.0)
    lin = Linearization(r_dyn, r_mag, r_zupt, st.b / prob.prior_sig)
    if jacobian:
        lin.jm = np.where(prob.mag_ok[:, None, None], _so3.hat(m_pred) / prob.sig_mag, 0.0)
    return lin


def _linearize_numpy(prob: Problem, st: State, jacobian: bool = True) -> Linearization:
    """:func:`linearize` in numpy (the reference of the C path)."""
    ba, bg = st.b[:3], st.b[3:6]
    dt = prob.dt[:, None]
    phi = (prob.gyr[:-1] - bg) * dt
    e = _so3.exp(phi)
    rk = st.r[:-1]
    re = np.swapaxes(st.r[1:], 1, 2) @ rk @ e
    r_rot = _so3.log(re)
    f = prob.acc[:-1] - ba
    rf = np.einsum("nij,nj->ni", rk, f)
    r_vel = st.v[:-1] + dt * (rf + prob.g_world) - st.v[1:]
    r_dyn = np.hstack([r_rot, r_vel]) / prob.sig_dyn
    lin = _with_sample_terms(prob, st, r_dyn, jacobian)
    if not jacobian:
        return lin
    m = prob.n - 1
    jinv = _so3.jr_inv(r_rot)
    ja = np.zeros((m, 6, 6))
    jb = np.zeros((m, 6, 6))
    jc = np.zeros((m, 6, NB))
    ja[:, :3, :3] = jinv @ np.swapaxes(e, 1, 2)
    ja[:, 3:, :3] = -dt[:, :, None] * (rk @ _so3.hat(f))
    ja[:, 3:, 3:] = np.eye(3)
    jb[:, :3, :3] = -jinv @ np.swapaxes(re, 1, 2)
    jb[:, 3:, 3:] = -np.eye(3)
    jc[:, :3, 3:6] = -(jinv @ _so3.jr(phi)) * dt[:, :, None]
    jc[:, 3:, 0:3] = -dt[:, :, None] * rk
    w = 1.0 / prob.sig_dyn[:, :, None]
    lin.ja, lin.jb, lin.jc = ja * w, jb * w, jc * w
    return lin


def residual_vector(prob: Problem, lin: Linearization) -> np.ndarray:
    """All whitened residuals in the row order of :func:`sparse_jacobian`."""
    return np.concatenate(
        [lin.r_dyn.ravel(), lin.r_mag[prob.mag_ok].ravel(), lin.r_zupt[prob.grip].ravel(), lin.r_prior]
    )


def sparse_jacobian(prob: Problem, lin: Linearization) -> sp.csr_matrix:
    """The whitened Jacobian of eq 15 as a sparse matrix.

    Columns: the tangent of sample k at ``6k .. 6k+5`` (rotation, velocity), then the
    biases (acc, gyr, mag) at ``6n .. 6n+8``.  Rows: dynamic model (6 per step),
    magnetometer (3 per used sample), zero velocity (3 per grip sample), bias priors (9).
    """
    import scipy.sparse as sp

    n, m = prob.n, prob.n - 1
    rows, cols, vals = [], [], []
    k = np.arange(m)
    r0 = 6 * k[:, None, None] + np.arange(6)[None, :, None]
    for blk, c0 in ((lin.ja, 6 * k), (lin.jb, 6 * (k + 1))):
        rows.append(np.broadcast_to(r0, blk.shape).ravel())
        cols.append(np.broadcast_to(c0[:, None, None] + np.arange(6)[None, None, :], blk.shape).ravel())
        vals.append(blk.ravel())
    rows.append(np.broadcast_to(r0, lin.jc.shape).ravel())
    cols.append(np.broadcast_to(6 * n + np.arange(NB)[None, None, :], lin.jc.shape).ravel())
    vals.append(lin.jc.ravel())
    base = 6 * m
    km = np.flatnonzero(prob.mag_ok)
    rm = base + 3 * np.arange(km.size)[:, None, None] + np.arange(3)[None, :, None]
    rows.append(np.broadcast_to(rm, (km.size, 3, 3)).ravel())
    cols.append(np.broadcast_to(6 * km[:, None, None] + np.arange(3)[None, None, :], (km.size, 3, 3)).ravel())
    vals.append(lin.jm[km].ravel())
    rows.append((base + np.arange(3 * km.size)).ravel())
    cols.append(np.tile(6 * n + 6 + np.arange(3), km.size))
    vals.append(np.full(3 * km.size, 1.0 / prob.sig_mag))
    base += 3 * km.size
    kz = np.flatnonzero(prob.grip)
    rows.append(base + np.arange(3 * kz.size))
    cols.append((6 * kz[:, None] + 3 + np.arange(3)[None, :]).ravel())
    vals.append(np.full(3 * kz.size, 1.0 / prob.params.sigma_zupt))
    base += 3 * kz.size
    rows.append(base + np.arange(NB))
    cols.append(6 * n + np.arange(NB))
    vals.append(1.0 / prob.prior_sig)
    shape = (base + NB, 6 * n + NB)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=shape)


@dataclass
class Normal:
    """Normal equations ``H d = -g`` in block form."""

    hd: np.ndarray  # (n, 6, 6) diagonal blocks
    ho: np.ndarray  # (n-1, 6, 6) blocks (k, k+1)
    hxb: np.ndarray  # (n, 6, 9)
    hbb: np.ndarray  # (9, 9)
    gx: np.ndarray  # (n, 6)
    gb: np.ndarray  # (9,)


def normal_equations(prob: Problem, lin: Linearization) -> Normal:
    """``J^T J`` and ``J^T r`` of the whitened problem, assembled block by block (the dynamic model's blocks
    in C where the extension is built)."""
    n = prob.n
    ja, jb, jc, r = lin.ja, lin.jb, lin.jc, lin.r_dyn
    ext = native()
    if ext is not None and n >= 2:
        hd, ho, hxb = np.empty((n, NX, NX)), np.empty((n - 1, NX, NX)), np.empty((n, NX, NB))
        hbb, gx, gb = np.empty((NB, NB)), np.empty((n, NX)), np.empty(NB)
        c64 = np.ascontiguousarray
        ext.normal_blocks(n - 1, c64(ja), c64(jb), c64(jc), c64(r), hd, ho, hxb, hbb, gx, gb)
    else:
        at = np.swapaxes(ja, 1, 2)
        bt = np.swapaxes(jb, 1, 2)
        hd = np.zeros((n, 6, 6))
        hd[:-1] += at @ ja
        hd[1:] += bt @ jb
        ho = at @ jb
        hxb = np.zeros((n, 6, NB))
        hxb[:-1] += at @ jc
        hxb[1:] += bt @ jc
        jc2 = jc.reshape(-1, NB)
        hbb = jc2.T @ jc2  # (BLAS syrk)
        gx = np.zeros((n, 6))
        gx[:-1] += np.einsum("kri,kr->ki", ja, r)
        gx[1:] += np.einsum("kri,kr->ki", jb, r)
        gb = jc2.T @ r.ravel()
    # magnetometer
    s = 1.0 / prob.sig_mag
    jmt = np.swapaxes(lin.jm, 1, 2)
    hd[:, :3, :3] += jmt @ lin.jm
    hxb[:, :3, 6:9] += jmt * s
    hbb[6:9, 6:9] += np.eye(3) * s * s * prob.mag_ok.sum()
    gx[:, :3] += np.einsum("kri,kr->ki", lin.jm, lin.r_mag)
    gb[6:9] += s * lin.r_mag.sum(axis=0)
    # zero velocity at grips
    z = 1.0 / prob.params.sigma_zupt
    idx = np.arange(3, 6)
    hd[:, idx, idx] += np.where(prob.grip[:, None], z * z, 0.0)
    gx[:, 3:] += z * lin.r_zupt
    # bias priors
    hbb += np.diag(1.0 / prob.prior_sig**2)
    gb += lin.r_prior / prob.prior_sig
    return Normal(hd, ho, hxb, hbb, gx, gb)


def solve_step(ne: Normal, lam: float) -> tuple[np.ndarray, np.ndarray, tuple]:
    """Solve ``(H + lam I) d = -g``: cyclic reduction of the block-tridiagonal state block, Schur complement
    for the biases.

    Returns the state step (n, 6), the bias step (9,) and the factors reused for the covariance:
    ``A^-1 H_xb`` (6n, 9), the biases' Schur complement (9, 9) and the factorised state block ``A``.
    """
    n = ne.hd.shape[0]
    try:
        # the factors over the shifted diagonal and a copy of the couplings: no third pair of (n, 6, 6) arrays
        cr = blocktri.factor(ne.hd + lam * np.eye(NX), ne.ho.copy(), overwrite=True)
    except np.linalg.LinAlgError as exc:
        raise InputError(
            "the transition estimate is singular (too few grips or magnetometer samples); "
            "expected zero-velocity grips in the trial"
        ) from exc
    x = blocktri.solve(cr, np.concatenate((ne.gx[:, :, None], ne.hxb), axis=2))  # (n, 6, 1 + 9)
    xg, xb = x[:, :, 0], x[:, :, 1:]
    xbf = xb.reshape(-1, NB)  # (a copy, once: the columns 1.. of x are not contiguous)
    hxb = ne.hxb.reshape(-1, NB)
    # H_xb^T A^-1 H_xb by einsum, not BLAS: a (9 x 6n) (6n x 9) product goes to OpenBLAS's threads,
    # whose waiting costs more CPU time than the product (7 vs 1.6 ms on the loaded 2-core machine)
    s = ne.hbb + lam * np.eye(NB) - np.einsum("kia,kib->ab", ne.hxb, xb)
    db = np.linalg.solve(s, -ne.gb + hxb.T @ xg.ravel())
    dx = -xg - (xbf @ db).reshape(n, NX)
    return dx, db, (xbf, s, cr)


def velocity_covariance(
    ne: Normal | None,
    xb: np.ndarray,
    s: np.ndarray,
    factored: blocktri.CyclicReduction | blocktri.BlockCholesky | None = None,
) -> np.ndarray:
    """3 x 3 velocity blocks on the diagonal of ``H^-1`` (eq 13), shape (n, 3, 3) [(m/s)^2].

    The diagonal blocks of the state block's inverse by selected inversion
    (:func:`sportfusion.estimators.blocktri.diagonal_of_inverse`; ``factored``: the state block
    already factorised, e.g. by :func:`solve_step`), plus the bias term ``X_k S_b^-1 X_k^T`` of the
    bordered inverse (``xb`` = ``A^-1 H_xb``, ``s`` the biases' Schur complement).  ``ne``, the normal
    equations, is read only where ``factored`` is None (so a caller may drop them once factorised).
    """
    n = xb.shape[0] // NX
    if factored is None and ne is None:
        raise ValueError("velocity_covariance needs the normal equations or their factorisation")
    cr = factored if factored is not None else blocktri.factor(ne.hd, ne.ho)  # type: ignore[union-attr]
    out = blocktri.diagonal_of_inverse(cr)[:, 3:, 3:]
    xv = xb.reshape(n, NX, NB)[:, 3:, :]
    out = out + xv @ np.linalg.inv(s) @ np.swapaxes(xv, 1, 2)
    return 0.5 * (out + np.swapaxes(out, 1, 2))


@dataclass
class TransitionResult:
    """Output of :func:`estimate_transitions`.

    Attributes
    ----------
    t : numpy.ndarray (n,)
    rotation : numpy.ndarray (n, 3, 3)
        Sensor-to-map rotation.
    velocity : numpy.ndarray (n, 3)
        Transition velocity v* in the map frame [m/s].
    velocity_cov : numpy.ndarray (n, 3, 3)
        Its covariance (eq 13) [(m/s)^2].
    bias_acc, bias_gyr, bias_mag : numpy.ndarray (3,)
        [m/s^2], [rad/s], normalised.
    cost : float
        Final value of eq 12 (half the sum of squared whitened residuals).
    iterations : int
    """

    t: np.ndarray
    rotation: np.ndarray
    velocity: np.ndarray
    velocity_cov: np.ndarray
    bias_acc: np.ndarray
    bias_gyr: np.ndarray
    bias_mag: np.ndarray
    cost: float
    iterations: int

    @property
    def quaternion(self) -> np.ndarray:
        """Sensor-to-map rotation as scalar-first quaternions (n, 4)."""
        return _so3.quat_from_matrix(self.rotation)


def initial_state(prob: Problem) -> State:
    """§III-A initial guess: complementary-filter orientations, v = 0 at grips, propagated between."""
    up = -prob.g_world / np.linalg.norm(prob.g_world)
    g = float(np.linalg.norm(prob.g_world))
    bg = median(prob.gyr[prob.grip], axis=0) if prob.grip.sum() >= 10 else np.zeros(3)
    mag = np.where(prob.mag_ok[:, None], prob.mag, np.nan)
    r = complementary_filter(prob.t, prob.acc, prob.gyr, mag, prob.m_world, up, g, bg)
    a_w = np.einsum("nij,nj->ni", r, prob.acc) + prob.g_world
    # v_k+1 = v_k + dT a_k, restarted from 0 at every grip sample: cumulative sums per run
    inc = np.vstack([np.zeros((1, 3)), prob.dt[:, None] * a_w[:-1]])
    inc[prob.grip] = 0.0
    c = np.cumsum(inc, axis=0)
    last = np.maximum.accumulate(np.where(prob.grip, np.arange(prob.n), 0))
    v = c - c[last]
    return State(r, v, np.r_[np.zeros(3), bg, np.zeros(3)])


def solve(prob: Problem, st: State) -> tuple[State, float, tuple, int]:
    """Levenberg-Marquardt from ``st``; returns the optimum, its cost (eq 12), the factors of :func:`solve_step` at
    the optimum (for the covariance) and the iterations.

    Memory: one linearization or one system of normal equations is held besides the step's solve at a time
    (~1.2 kB a sample each): the optimum's system is freed once factorised.
    """
    p = prob.params
    lin = linearize(prob, st)
    cost = lin.cost
    lam = 1e-6
    it = 0
    for it in range(1, p.max_iter + 1):  # noqa: B007 - the count is returned
        ne = None  # the last iteration's system, freed before the next is formed
        ne = normal_equations(prob, lin)
        lin = lin_c = None  # memory: formed again below in the rare case that the last candidate is refused
        while True:
            lin_c = None
            dx, db = solve_step(ne, lam)[:2]  # its factors freed before the candidate's linearization
            cand = st.boxplus(dx, db)
            lin_c = linearize(prob, cand)  # with the Jacobian: it is the next linearization when accepted
            if lin_c.cost <= cost or lam > 1e8:
                break
            lam *= 10.0
        if lin_c.cost > cost:
            break
        decrease = (cost - lin_c.cost) / max(cost, 1e-300)
        st, cost, lin = cand, lin_c.cost, lin_c
        lam = max(lam / 10.0, 1e-9)
        if decrease < p.tol or np.abs(dx).max() < 1e-10:
            break
    ne = lin_c = None  # the last iteration's system and candidate: freed before the final system is formed
    if lin is None:  # the last candidate was refused: the optimum's linearization again (the same numbers)
        lin = linearize(prob, st)
    ne = normal_equations(prob, lin)
    cost = lin.cost
    del lin
    return st, cost, solve_step(ne, 1e-12)[2], it


def estimate_transitions(
    t: np.ndarray,
    acc: np.ndarray,
    gyr: np.ndarray,
    mag: np.ndarray,
    grip: np.ndarray,
    m_world: np.ndarray,
    g_world: np.ndarray,
    saturated: np.ndarray | None = None,
    params: TransitionParams | None = None,
) -> TransitionResult:
    """Transition velocities and their covariance for a whole trial (eqs 3-15).

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        IMU sample times [s], strictly increasing.
    acc, gyr : numpy.ndarray, shape (n, 3)
        Specific force [m/s^2] and angular rate [rad/s], sensor frame.
    mag : numpy.ndarray, shape (n, 3)
        Magnetic field in the sensor frame, normalised to the undisturbed field (NaN: no sample).
    grip : numpy.ndarray of bool, shape (n,)
        Zero-velocity samples (detected grips).
    m_world : numpy.ndarray, shape (3,)
        Reference field in the map frame (normalised).
    g_world : numpy.ndarray, shape (3,)
        Gravity in the map frame [m/s^2] (``-g`` times the up axis).
    saturated : numpy.ndarray of bool, shape (n,), optional
        Sensor-range violations (the Appendix's c_k).
    params : TransitionParams, optional
    """
    t = np.asarray(t, dtype=np.float64)
    n = t.size
    if n < 3:
        raise InputError(f"only {n} IMU samples; expected a trial of many samples")
    grip = np.asarray(grip, dtype=bool)
    if not grip.any():
        raise InputError("no grips in the trial; the transition estimator needs zero-velocity grips (detect-events)")
    for name, a in (("accelerometer", acc), ("gyroscope", gyr)):
        if not np.isfinite(a).all():
            raise InputError(f"the {name} has missing samples on IMU rows; expected complete IMU samples")
    prob = Problem(
        t,
        np.asarray(acc, dtype=np.float64),
        np.asarray(gyr, dtype=np.float64),
        np.asarray(mag, dtype=np.float64),
        grip,
        np.zeros(n, dtype=bool) if saturated is None else np.asarray(saturated, dtype=bool),
        np.asarray(m_world, dtype=np.float64) / np.linalg.norm(m_world),
        np.asarray(g_world, dtype=np.float64),
        params or TransitionParams(),
    )
    st0 = initial_state(prob)
    st, cost, (xb, s, factored), it = solve(prob, st0)
    cov = velocity_covariance(None, xb, s, factored)  # the factors only: the system was dropped
    return TransitionResult(t, st.r, st.v, cov, st.b[:3], st.b[3:6], st.b[6:], cost, it)


def integrate(t: np.ndarray, v: np.ndarray, p0: np.ndarray, k0: int = 0) -> np.ndarray:
    """Positions from velocities by the dynamic model (trapezoid, eq 6), ``p[k0] = p0``; NaN before ``k0``."""
    dt = np.diff(t)[:, None]
    steps = 0.5 * (v[1:] + v[:-1]) * dt
    p = np.full_like(v, np.nan)
    p[k0] = p0
    p[k0 + 1 :] = p0 + np.cumsum(steps[k0:], axis=0)
    return p
