"""The ski-jump smoother's engine: one EKF + RTS run over a segment of IMU steps (skijump §3, eqs 10-21).

Third stage of ``rts-smooth`` (inputs -> initial state -> this engine -> output columns): :func:`run` takes a
segment's inputs (:class:`~sportfusion.skijump.smoother_inputs.SkiJumpInputs`), the configuration and the
initial state ``(x0, P0)`` and returns the filtered and smoothed states, the covariances, the innovations and
(from the C loop) the smoothed standard deviations, as a :class:`Run`.  Two implementations of the same
equations stand behind it:

* **the numpy reference**: :func:`sportfusion.estimators.kalman.ekf_rts` driven by :func:`model_callables`
  -- the model of :mod:`sportfusion.skijump.model` (eqs 22, 35-51), the measurements of a step stacked into
  one update, full covariances.  The readable statement of the algorithm, and the tests' oracle.
* **the C loop** (``_ski_c.c`` through :func:`sportfusion.skijump._ski_native.ski_ekf_rts`), the fast path.
  The same equations arranged for speed: a step's measurements (all with a diagonal ``R``) applied one
  scalar at a time, each residual and Jacobian evaluated at the prior and corrected for the rows applied
  before it (algebraically the stacked update), each in the Joseph form with the optimal gain (a symmetric
  rank-1 downdate); covariances stored packed (253 numbers); the backward pass forms ``Phi`` and
  ``P_{k+1|k}`` again (or reads the forward pass's) and solves only for the 10 kinematic rows of the RTS
  gain (the parameters' rows are ``[0 I]``: no process noise, eq 22); positive definiteness checked after
  every update and prediction and by the Cholesky factor of every ``P_{k+1|k}``; the output's standard
  deviations formed from each smoothed covariance as it is made (the formulas of
  :func:`sportfusion.skijump.smoother_outputs._std_from_cov`).  Tested against the numpy reference
  (``tests/test_rts_smooth.py``: states to 1e-9, covariances to 1e-10).

:func:`compiled` says which one runs: C when the extension is built (``engine="auto"``), else the numpy
reference -- about 100-200x slower, said once on stderr (:mod:`sportfusion.core.native`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.native import BUILD
from sportfusion.estimators.kalman import CovarianceError, Measurement, ekf_rts
from sportfusion.skijump import _ski_native
from sportfusion.skijump import model as mdl
from sportfusion.skijump.kinematics import m_no
from sportfusion.skijump.saturation import step_noise
from sportfusion.skijump.smoother_inputs import SkiJumpInputs, SmootherConfig

#: the ``engine`` choices: C where it is built, else numpy; the C loop (an error where it is not built);
#: the numpy reference
ENGINES = ("auto", "c", "numpy")


class Run(NamedTuple):
    """One run of the engine over ``n`` steps."""

    x_filt: np.ndarray  #: (n, 22) filtered states
    x_smooth: np.ndarray  #: (n, 22) smoothed states (the filtered ones after a forward run)
    #: covariances: (n, 22, 22) from the numpy reference; packed (n, 253) upper triangles from the C loop, or
    #: (0, 253) where it kept none
    cov: np.ndarray
    residuals: dict[str, np.ndarray]  #: innovations by update, (n, width) each, NaN where absent
    std: np.ndarray | None  #: (n, 28) smoothed standard deviations from the C loop (None from numpy)


def compiled(engine: str = "auto") -> bool:
    """Whether ``engine`` ({"auto", "c", "numpy"}) runs the C loop (raises InputError for "c" without it)."""
    if engine not in ENGINES:
        raise InputError(f"engine {engine!r}; expected one of {', '.join(ENGINES)}")
    if engine == "numpy":
        return False
    built = _ski_native.native() is not None
    if engine == "c" and not built:
        raise InputError(f"engine c requested but the C extension is not built; to build it, {BUILD}")
    return built


def run(
    seg: SkiJumpInputs,
    cfg: SmootherConfig,
    x0: np.ndarray,
    P0: np.ndarray,
    use_c: bool,
    smooth: bool = True,
    keep_cov: bool = True,
    out: tuple[np.ndarray | None, ...] | None = None,
    work: tuple[np.ndarray | None, ...] | None = None,
    progress: Callable[[int], object] | None = None,
) -> Run:
    """One EKF (and with ``smooth`` RTS) run over ``seg`` from ``(x0, P0)``; raises CovarianceError.

    Parameters
    ----------
    seg : SkiJumpInputs
        The steps (one IMU segment, or a window of it).
    cfg : SmootherConfig
        ``Q`` and ``R`` (Tables 4-5), the switches (hill constraints, GNSS velocity, magnetometer).
    x0, P0 : (22,), (22, 22)
        The initial state and covariance at ``seg``'s first step.
    use_c : bool
        The C loop (:func:`compiled`), else the numpy reference.
    smooth : bool
        False: a forward run for its states alone (``x_smooth`` is then ``x_filt``; the C loop keeps no
        covariances for it).
    keep_cov : bool
        False: the C loop's backward pass does not write the smoothed covariances back (only ``std`` is
        wanted).  The numpy reference always keeps them.
    out, work : tuple of arrays, optional
        The C loop's arrays to write the states, residuals and std rows into and its reused scratch
        (:func:`sportfusion.skijump._ski_native.ski_ekf_rts`).
    progress : callable(k), optional
        Called once per forward and backward step.
    """
    if not use_c:
        propagate, measure = model_callables(seg, cfg)
        r = ekf_rts(x0, P0, seg.t.size, propagate, measure, progress=progress, t=seg.t)
        return Run(r.x_filt, r.x_smooth if smooth else r.x_filt, r.P_smooth, r.residuals, None)
    res = _run_c(seg, cfg, x0, P0, smooth, keep_cov, out, work)
    if progress is not None:
        for k in range(2 * seg.t.size - 1):
            progress(k)
    return res


def model_callables(inp: SkiJumpInputs, cfg: SmootherConfig) -> tuple[Callable, Callable]:
    """``propagate`` and ``measure`` of :func:`sportfusion.estimators.kalman.ekf_rts`: the numpy reference.

    ``propagate(k, x)``: the RK4 prediction of eq 22's kinematics over step k, ``Phi`` and ``Qd``
    (eqs 7, 9, 13).  ``measure(k, x)``: the updates at step k -- ``c_q`` (eq 51), GNSS position and
    velocity (eqs 47-49), the magnetometer (eq 50), the hill constraints ``c_V,IR``, ``c_H,IR``,
    ``c_V,LA`` (eqs 32-34, 51; the landing's weight ramping) and the zero-velocity update ``v_B = 0``.
    """
    mno = m_no(math.radians(inp.azimuth_deg))
    qd = step_noise(inp, cfg)
    dt = np.diff(inp.t)
    R_pos = np.diag(np.asarray(cfg.r_gnss_pos) ** 2)
    R_vel = np.diag(np.asarray(cfg.r_gnss_vel) ** 2)
    R_mag = np.eye(3) * cfg.r_mag**2
    has_pos = np.isfinite(inp.pos[:, 0])
    has_vel = np.isfinite(inp.vel[:, 0]) & cfg.use_gnss_vel
    has_mag = np.isfinite(inp.mag[:, 0]) & cfg.use_mag
    use_hill = cfg.hill_constraints and inp.profile is not None
    ir, la = inp.profile if use_hill else (None, None)
    H_pos = np.zeros((3, mdl.N))
    H_pos[:, 0:3] = np.eye(3)
    H_y = np.zeros((1, mdl.N))
    H_y[0, 1] = 1.0
    H_v = np.zeros((3, mdl.N))
    H_v[:, 3:6] = np.eye(3)
    still = inp.still if inp.still is not None else np.zeros(inp.t.size)

    def propagate(k: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        u0, u1 = inp.u[k], inp.u[k + 1]
        xn = mdl.rk4_aug(x, u0, u1, dt[k], inp.g0, mno)
        A = mdl.jac_a(x, u0, inp.g0, mno)
        Phi, Qd = mdl.discrete(A, mdl.jac_f(x), qd[k], dt[k])
        return xn, Phi, Qd

    def profile_row(z: float, dz: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A profile constraint ``z(x) - x_2`` (in-run or landing): its residual and Jacobian row."""
        H = np.zeros((1, mdl.N))
        H[0, 0], H[0, 2] = -dz, 1.0
        return np.array([z - x[2]]), H

    def measure(k: int, x: np.ndarray) -> list[Measurement]:
        out = [Measurement(np.array([-mdl.c_q(x)]), mdl.C_q(x), np.array([[cfg.r_c_q**2]]), "c_q")]
        if has_pos[k]:
            out.append(Measurement(inp.pos[k] - x[0:3], H_pos, R_pos, "gnss_pos"))
        if has_vel[k]:
            out.append(Measurement(inp.vel[k] - mdl.h_vel(x), mdl.H_vel(x), R_vel, "gnss_vel"))
        if has_mag[k]:
            out.append(Measurement(inp.mag[k] - mdl.h_mag(x, inp.m_o), mdl.H_mag(x, inp.m_o), R_mag, "mag"))
        if use_hill:
            if inp.inrun[k]:
                r, H = profile_row(*ir(x[0]), x)
                out.append(Measurement(r, H, np.array([[cfg.r_c_v_ir**2]]), "c_v_ir"))
                out.append(Measurement(np.array([-x[1]]), H_y, np.array([[cfg.r_c_h_ir**2]]), "c_h_ir"))
            wl = inp.landing[k]
            if wl > 0:
                r, H = profile_row(*la(x[0]), x)
                out.append(Measurement(r, H, np.array([[cfg.r_c_v_la**2 / wl]]), "c_v_la"))
        if still[k] > 0:  # zero velocity: v_B = 0
            out.append(Measurement(-x[3:6], H_v, np.eye(3) * (cfg.r_zupt**2 / still[k]), "zupt"))
        return out

    return propagate, measure


def _run_c(
    seg: SkiJumpInputs,
    cfg: SmootherConfig,
    x0: np.ndarray,
    P0: np.ndarray,
    smooth: bool,
    keep_cov: bool,
    out: tuple[np.ndarray | None, ...] | None,
    work: tuple[np.ndarray | None, ...] | None,
) -> Run:
    """:func:`run` in C: the model's arrays and ``R`` as the loop takes them; its failure as CovarianceError."""
    use_hill = cfg.hill_constraints and seg.profile is not None
    ir, la = seg.profile if use_hill else (None, None)
    empty = np.zeros(2)
    # covariances nobody reads are skipped: a forward run keeps no filtered ones, a smoothed run without
    # keep_cov writes no smoothed ones back
    options = {"smoothed_cov": keep_cov, "out": out, "work": work} if smooth else {"filtered_cov": False}
    try:
        xf, xs, Pp, resid, fail, phase, std = _ski_native.ski_ekf_rts(
            seg.t,
            seg.u,
            seg.pos,
            seg.vel,
            seg.mag,
            seg.inrun,
            seg.landing,
            seg.still if seg.still is not None else np.zeros(seg.t.size),
            x0,
            P0,
            float(seg.g0),
            m_no(math.radians(seg.azimuth_deg)),
            seg.m_o,
            step_noise(seg, cfg),
            np.asarray(cfg.r_gnss_pos, float) ** 2,
            np.asarray(cfg.r_gnss_vel, float) ** 2,
            float(cfg.r_mag**2),
            float(cfg.r_c_q**2),
            float(cfg.r_c_v_ir**2),
            float(cfg.r_c_h_ir**2),
            float(cfg.r_c_v_la**2),
            float(cfg.r_zupt**2),
            ir.x0 if ir else 0.0,
            ir.step if ir else 1.0,
            ir.z if ir else empty,
            ir.dz if ir else empty,
            la.x0 if la else 0.0,
            la.step if la else 1.0,
            la.z if la else empty,
            la.dz if la else empty,
            use_hill,
            bool(cfg.use_gnss_vel),
            bool(cfg.use_mag),
            bool(smooth),
            **options,
        )
    except np.linalg.LinAlgError:
        raise CovarianceError("a predicted covariance is not positive definite (backward pass)") from None
    if fail >= 0:
        what = ("update", "prediction", "backward pass")[phase]
        raise CovarianceError(f"covariance not positive definite at step {fail} (t = {seg.t[fail]:.3f} s) ({what})")
    return Run(xf, xs, Pp, residual_blocks(resid), std)


def c_buffers(
    n_all: int, n_max: int, keep_cov: bool, keep_filtered: bool = True
) -> tuple[tuple[np.ndarray | None, ...], tuple[np.ndarray | None, ...] | None]:
    """The C loop's session-wide outputs and reused scratch for a session of ``n_all`` steps whose longest
    segment has ``n_max``: ``(out, work)`` of :func:`run` (a segment's rows of ``out`` are its ``out``).

    ``out``: filtered states, smoothed states and std rows column by column (each of the table's columns
    without a copy: :func:`sportfusion.skijump._ski_native.column_outputs`), residuals.  ``work`` (None with
    ``keep_cov``): the predictions and covariances of the longest segment, or of a block of
    ``_ski_native.BLOCK_STEPS`` steps where it is longer (the backward pass then runs each block's forward pass
    again from a checkpoint: memory that does not grow with the session), which every run reuses; on a
    session of many short segments (a multi-jump day) also the forward pass's predictions for the backward
    pass (on a single long segment they gain nothing for their memory: ``_ski_native.PRED_MAX_STEPS``).
    Without ``keep_filtered`` (and ``keep_cov``) ``out`` has None for the filtered states, and ``work`` a
    fourth array: their scratch, of the longest segment or one block (0.2 KB/step less on a long session).
    """
    x_s, std = _ski_native.column_outputs(n_all)
    keep_filtered = keep_filtered or keep_cov
    x_f = np.empty((n_all, mdl.N)) if keep_filtered else None
    out = (x_f, x_s, np.empty((n_all, _ski_native.NRES)), std)
    if keep_cov:
        return out, None
    rows = min(n_max, _ski_native.BLOCK_STEPS)  # a longer run keeps one block at a time (same results)
    work: tuple[np.ndarray | None, ...] = (np.empty((rows + 1, mdl.N)), np.empty((rows, _ski_native.NP)))
    pred = n_max <= _ski_native.PRED_MAX_STEPS and 3 * n_max <= n_all
    work += (np.empty((rows, _ski_native.NPRED)) if pred else None,)
    if not keep_filtered:
        work += (np.empty((rows, mdl.N)),)
    return out, work


def residual_blocks(resid: np.ndarray) -> dict[str, np.ndarray]:
    """The C loop's (n, 16) innovations as the numpy reference names them: views of ``resid``'s columns."""
    res, i = {}, 0
    for name, w in _ski_native.RESIDUALS:
        res[name] = resid[:, i : i + w]
        i += w
    return res


def cov_rows(P: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Rows of a run's covariances (either engine's layout) over the state indices ``idx``: (m, k, k)."""
    if P.ndim == 3:
        return P[:, idx][:, :, idx]
    return _ski_native.unpack_many(P, idx)


def variances(P: np.ndarray) -> np.ndarray:
    """The diagonals (m, 22) of a run's covariances (either engine's layout), read without unpacking."""
    if P.ndim == 3:
        return np.diagonal(P, axis1=1, axis2=2)
    iu = np.triu_indices(mdl.N)
    return P[:, np.flatnonzero(iu[0] == iu[1])]  # packed (upper, row-major) positions of the diagonal
