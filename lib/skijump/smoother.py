"""``rts-smooth``: the ski-jump trajectory by the extended RTS smoother with hill constraints (skijump §3-4).

The model is :mod:`sportfusion.skijump.model` (eqs 22, 35-51); the smoother
is :func:`sportfusion.estimators.kalman.ekf_rts`.  Steps are the IMU samples; GNSS and
magnetometer samples update the step they fall on (or the nearest IMU step
within half a step when they were logged at their own times).

Constraint windows (eqs 32-34, 51), per jump of the session:

* ``c_q`` at every step;
* ``c_V,IR`` and ``c_H,IR`` from the start of the in-run to the take-off
  (inclusive).  The in-run starts where the athlete last sat at the gate:
  the run of GNSS speeds below ``rest_speed`` that ends last before the
  take-off (at most ``max_rest`` seconds of it), or the session's (segment's)
  start when there is none;
* ``c_V,LA`` from the touch-down to the end of the first rest after it (or the
  next in-run / the session's end).  The errata's touch-down note: the sensor
  settles onto the slope over ~0.2 s after the detected touch-down, so the
  constraint starts ``la_delay`` seconds after it and its weight (inverse
  variance) ramps linearly from 0 to full over ``la_ramp`` seconds.

Beyond the paper, a zero-velocity update ``v_B = 0`` (1-sigma ``r_zupt`` per step) on the steps where the
athlete stands still (:func:`sportfusion.skijump.smoother_inputs.still_steps`: sitting at the gate,
standing after the stop), so that the rests do not drift between GNSS fixes.

Initial state (paper §4.1): position and NED velocity of the first GNSS fix,
attitude by QUEST (:func:`sportfusion.estimators.quest.quest`) from the mean
accelerometer and magnetometer samples of the rest at the start (at least the
first ``init_window`` seconds, extended while the sensor is still, at most
``init_rest_max``; gravity up and the reference field), the gyro bias the mean
rate over that rest, other parameters zero; ``P0``, ``Q``, ``R`` are
Tables 3-5 as 1-sigma values in :class:`SmootherConfig`, all overridable from a
TOML file (:func:`load_config`).  The reference field is the hill file's, else
the World Magnetic Model at the take-off edge and the session's date.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import rotations, schema
from sportfusion.core.errors import InputError
from sportfusion.core.gaps import describe_gaps
from sportfusion.core.magdisturb import describe as describe_mag
from sportfusion.core.session import with_columns
from sportfusion.estimators.kalman import CovarianceError, Measurement, ekf_rts
from sportfusion.skijump import model as mdl
from sportfusion.skijump.alignment import gnss_latency, shift_gnss
from sportfusion.skijump.hillfile import Hill
from sportfusion.skijump.kinematics import m_bo, m_no
from sportfusion.skijump.saturation import clipped_message, mag_innovation_outliers, step_noise
from sportfusion.skijump.smoother_inputs import (
    SkiJumpInputs,
    SmootherConfig,
    _slice,
    profile_tables,
    segments,
    session_inputs,
)
from sportfusion.skijump.smoother_outputs import (  # noqa: F401  (re-exported: the output columns' helpers)
    _estimate_columns,
    _interp_columns,
    _interp_rows,
    _std_from_cov,
    constraint_residuals,
    euler_jacobian,
    residual_rms,
)
from sportfusion.skijump.smoother_start import (  # noqa: F401  (initial_state re-exported: tests, bench)
    _after_rest,
    _forward_start,
    initial_state,
)


def _model_callables(inp: SkiJumpInputs, cfg: SmootherConfig, hill: Hill | None):
    """propagate/measure for :func:`ekf_rts` (plain numpy, the reference path)."""
    mno = m_no(math.radians(inp.azimuth_deg))
    qd = step_noise(inp, cfg)
    dt = np.diff(inp.t)
    R_pos = np.diag(np.asarray(cfg.r_gnss_pos) ** 2)
    R_vel = np.diag(np.asarray(cfg.r_gnss_vel) ** 2)
    R_mag = np.eye(3) * cfg.r_mag**2
    has_pos = np.isfinite(inp.pos[:, 0])
    has_vel = np.isfinite(inp.vel[:, 0]) & cfg.use_gnss_vel
    has_mag = np.isfinite(inp.mag[:, 0]) & cfg.use_mag
    use_hill = cfg.hill_constraints and hill is not None
    ir, la = profile_tables(hill) if use_hill else (None, None)
    H_pos = np.zeros((3, mdl.N))
    H_pos[:, 0:3] = np.eye(3)
    H_y = np.zeros((1, mdl.N))
    H_y[0, 1] = 1.0
    H_v = np.zeros((3, mdl.N))
    H_v[:, 3:6] = np.eye(3)
    still = inp.still if inp.still is not None else np.zeros(inp.t.size)

    def propagate(k: int, x: np.ndarray):
        u0, u1 = inp.u[k], inp.u[k + 1]
        xn = mdl.rk4_aug(x, u0, u1, dt[k], inp.g0, mno)
        A = mdl.jac_a(x, u0, inp.g0, mno)
        Phi, Qd = mdl.discrete(A, mdl.jac_f(x), qd[k], dt[k])
        return xn, Phi, Qd

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
                z, dz = ir(x[0])
                H = np.zeros((1, mdl.N))
                H[0, 0], H[0, 2] = -dz, 1.0
                out.append(Measurement(np.array([z - x[2]]), H, np.array([[cfg.r_c_v_ir**2]]), "c_v_ir"))
                out.append(Measurement(np.array([-x[1]]), H_y, np.array([[cfg.r_c_h_ir**2]]), "c_h_ir"))
            wl = inp.landing[k]
            if wl > 0:
                z, dz = la(x[0])
                H = np.zeros((1, mdl.N))
                H[0, 0], H[0, 2] = -dz, 1.0
                out.append(Measurement(np.array([z - x[2]]), H, np.array([[cfg.r_c_v_la**2 / wl]]), "c_v_la"))
        if still[k] > 0:  # zero velocity: v_B = 0
            out.append(Measurement(-x[3:6], H_v, np.eye(3) * (cfg.r_zupt**2 / still[k]), "zupt"))
        return out

    return propagate, measure


@dataclass
class Smoothed:
    """Smoother output over all IMU steps (either engine).

    ``cov(idx, r0=0, r1=None)`` returns the smoothed covariances (r1 - r0, k, k) over the state
    indices ``idx`` for the steps ``r0 .. r1 - 1`` (default all).
    """

    x_filt: np.ndarray
    x_smooth: np.ndarray
    cov: Callable[..., np.ndarray]
    var: Callable[[], np.ndarray]
    residuals: dict[str, np.ndarray]
    passes: list[int]
    gnss_latency: list[float | None] = field(default_factory=list)  # per segment [s] (None: not estimated)
    #: (n, 28) smoothed standard deviations from the compiled backward pass: the 22 states, the hill-frame
    #: velocity, roll/pitch/yaw (None from the numpy reference engine: computed from ``cov`` instead)
    std: np.ndarray | None = None


def _fast_engine(prefer_native: bool = True):  # noqa: ANN202
    """The compiled loop: the C extension (:mod:`sportfusion.skijump._ski_native`) when it is built, else
    numba's (:mod:`sportfusion.skijump.smoother_fast`), else None (the numpy reference path)."""
    from sportfusion.skijump import _ski_native

    if prefer_native and _ski_native.native() is not None:
        return _ski_native
    try:
        from sportfusion.skijump import smoother_fast as skijump_fast
    except ImportError:  # numba missing: the numpy reference path
        return None
    return skijump_fast


def _run_fast(  # noqa: ANN202
    fast,  # noqa: ANN001
    seg: SkiJumpInputs,
    cfg: SmootherConfig,
    hill: Hill | None,
    x0: np.ndarray,
    P0: np.ndarray,
    smooth: bool = True,
    keep_cov: bool = True,
    out: tuple[np.ndarray, ...] | None = None,
    work: tuple[np.ndarray, np.ndarray] | None = None,
):
    """One run of the compiled loop over ``seg``: ``(x_filt, x_smooth, P_packed, residuals, std)``.

    Without ``smooth`` (a forward run for its states), the C engine keeps no filtered covariances: its
    ``P_packed`` is then empty (numba's holds them); so too without ``keep_cov`` (only ``std`` wanted: the C
    backward pass does not write the smoothed covariances back).  ``out``, ``work``: the C engine's arrays to
    write the states, residuals and std rows into and its reused scratch
    (:func:`sportfusion.skijump._ski_native.ski_ekf_rts`).
    """
    use_hill = cfg.hill_constraints and hill is not None
    ir, la = profile_tables(hill) if use_hill else (None, None)
    empty = np.zeros(2)
    try:
        out = fast.ski_ekf_rts(
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
            **({} if fast.__name__.endswith("smoother_fast") else _c_options(smooth, keep_cov, out, work)),
        )
    except np.linalg.LinAlgError:
        raise CovarianceError("a predicted covariance is not positive definite (backward pass)") from None
    xf, xs, Pp, resid, fail, phase, std = out
    if fail >= 0:
        what = ("update", "prediction", "backward pass")[phase]
        raise CovarianceError(f"covariance not positive definite at step {fail} (t = {seg.t[fail]:.3f} s) ({what})")
    res, i = {}, 0
    for name, w in fast.RESIDUALS:
        res[name] = resid[:, i : i + w]
        i += w
    return xf, xs, Pp, res, std


def _c_options(
    smooth: bool, keep_cov: bool, out: tuple[np.ndarray, ...] | None, work: tuple[np.ndarray, np.ndarray] | None
) -> dict[str, Any]:
    """The C engine's options: covariances nobody reads skipped, the arrays to write into, the scratch."""
    return {"smoothed_cov": keep_cov, "out": out, "work": work} if smooth else {"filtered_cov": False}


def _correct_latency(seg: SkiJumpInputs, xs: np.ndarray, t_takeoff: float, t_end: float, least: float) -> float | None:
    """Estimate the GNSS latency from a smoothed pass over the in-run and take-off, and move the segment's
    GNSS fixes to the time they describe (in place: new arrays on ``seg``) when it is at least ``least``
    [s] (smaller estimates are within the estimate's own noise: about 0.01 s on simulated jumps).
    Returns the estimate [s] (None where the data do not show one)."""
    n = xs.shape[0]
    span = (max(seg.t[0], t_takeoff - 6.0), min(t_end, t_takeoff + 4.0))
    tau = gnss_latency(seg.t[:n], seg.u[:n], xs, seg.vel[:n], seg.g0, span)
    if tau is None or abs(tau) < least:
        return tau
    vel_hill = rotations.ned_to_local(seg.vel, seg.azimuth_deg)
    seg.pos, seg.vel = shift_gnss(seg.t, seg.pos, vel_hill, seg.vel, tau)
    return tau


def _unit_quat(x: np.ndarray) -> np.ndarray:
    x = x.copy()
    x[6:10] /= np.linalg.norm(x[6:10])
    return x


def _remove_lever_arm(seg: SkiJumpInputs, xs: np.ndarray, lever: np.ndarray) -> None:
    """GNSS fixes moved from the antenna to the IMU: ``r_IMU = r_ant - M_BO^T l`` (hill frame) and
    ``v_IMU = v_ant - M_BO^T (omega x l)`` (NED) with the smoothed attitude and bias-corrected rate of
    ``xs`` (the lever arm ``l`` [m] in the body frame, IMU -> antenna).  New arrays on ``seg``."""
    m = m_bo(xs[:, 6:10])  # NED -> body, per step
    arm_ned = np.einsum("nji,j->ni", m, lever)
    omega = seg.u[:, 0:3] - xs[:, mdl.I_BG]
    rot_ned = np.einsum("nji,nj->ni", m, np.cross(omega, lever))
    seg.pos = seg.pos - rotations.ned_to_local(arm_ned, seg.azimuth_deg)
    seg.vel = seg.vel - rot_ned


def smooth_inputs(
    inp: SkiJumpInputs,
    hill: Hill | None,
    cfg: SmootherConfig,
    progress: Callable[[int], object] | None = None,
    engine: str = "auto",
    keep_cov: bool = True,
) -> Smoothed:
    """Run the EKF + RTS smoother over the prepared inputs (raises InputError when it diverges).

    Parameters
    ----------
    keep_cov : bool
        Keep the smoothed covariances for ``Smoothed.cov`` / ``Smoothed.var`` (2 KB per step).  False where
        the compiled engine's ``std`` rows are all that is wanted: ``cov``/``var`` then raise RuntimeError
        (the numpy engine, which has no ``std`` rows, keeps them regardless).
    engine : {"auto", "c", "numba", "numpy"}
        ``numpy``: :func:`sportfusion.estimators.kalman.ekf_rts` with the model callables (the
        reference); ``numba``: the compiled loop of
        :mod:`sportfusion.skijump.smoother_fast` (same equations, packed
        covariances); ``c``: the same loop as a C extension (:mod:`sportfusion.skijump._ski_native`);
        ``auto``: C when it is built, else numba when it is installed.

    A session whose IMU stops for more than ``cfg.max_gap`` seconds is smoothed in
    independent segments (each initialised from its own first samples); the
    results are concatenated.  The initial state comes from the rest at the start
    (:func:`initial_state`: the gyro bias from its mean rate; the attitude from the
    in-run alignment of :mod:`sportfusion.skijump.alignment`, else QUEST over the rest).
    ``cfg.passes`` runs cover the start of each segment, the last of them the whole
    segment; the earlier ones cover ``cfg.pass_window`` seconds, extended to
    ``cfg.pass_after_takeoff`` seconds after the segment's first take-off (the in-run
    is what pins the heading), each started from the previous run's smoothed initial
    state (mean only, same ``P0``), stopping early when the initial attitude changes by
    less than ``cfg.pass_tol_deg`` [deg]: this re-linearises the start, where an attitude
    error of degrees leaves the EKF's linear regime (``bench/bench_rts_accuracy.py --init``).
    When the in-run alignment gave the attitude and ``cfg.start_pass`` is ``"forward"`` (the
    default), one forward EKF run over that window replaces the smoothed ones
    (:func:`_forward_start`), from the rest's end with ``cfg.start_after_rest`` (:func:`_after_rest`).
    Then the GNSS latency is estimated on the whole segment's smoothed pass and, with a known lever
    arm, the fixes are moved to the IMU; each correction costs one more run.
    """
    fast = _fast_engine(prefer_native=engine in ("auto", "c")) if engine in ("auto", "numba", "c") else None
    if engine == "numba" and (fast is None or not fast.__name__.endswith("smoother_fast")):
        raise InputError("engine numba requested but numba is not installed; expected pip install numba")
    if engine == "c" and (fast is None or fast.__name__.endswith("smoother_fast")):
        raise InputError("engine c requested but the C extension is not built; expected pip install -e . with gcc")
    xfs, xss, covs, resids, npass, lat, stds = [], [], [], [], [], [], []
    whole = work = None  # the C engine writes each segment's final run into its rows of these (no concatenation)
    if fast is not None and not fast.__name__.endswith("smoother_fast"):
        n_all = inp.t.size
        x_s, std = fast.column_outputs(n_all)  # column by column: the table's columns without copies
        whole = (np.empty((n_all, mdl.N)), x_s, np.empty((n_all, fast.NRES)), std)
        if not keep_cov:  # the predictions and covariances of the longest segment, reused by every run
            n_max = max(b - a for a, b in segments(inp.t, cfg.max_gap))
            work = (np.empty((n_max, mdl.N)), np.empty((n_max, fast.NP)))
            if n_max <= fast.PRED_MAX_STEPS and 3 * n_max <= n_all:
                # many short segments (a multi-jump day): the forward pass keeps its predictions for the backward
                # pass in a scratch that every run reuses (on a single long segment it gains nothing for its
                # memory: _ski_native.PRED_MAX_STEPS)
                work += (np.empty((n_max, fast.NPRED)),)
    for a, b in segments(inp.t, cfg.max_gap):
        lat.append(None)
        seg = _slice(inp, a, b)
        if b - a < 2 or not np.isfinite(seg.pos[:, 0]).any():
            raise InputError(
                f"the IMU segment {seg.t[0]:.2f}-{seg.t[-1]:.2f} s has no GNSS fix (or a single sample); "
                "expected GNSS during every recorded stretch"
            )
        x0, P0, aligned, n_rest = initial_state(seg, cfg, with_source=True)
        # the window that needs re-linearising: the start up to the in-run's end (the first take-off in
        # the segment plus pass_after_takeoff), at least pass_window seconds
        t_end = seg.t[0] + cfg.pass_window
        tos = [a for a, _ in seg.jumps if seg.t[0] <= a <= seg.t[-1]]
        if tos:
            t_end = max(t_end, min(tos) + cfg.pass_after_takeoff)
        nw = int(np.searchsorted(seg.t, t_end, side="right"))
        nw = max(min(nw, seg.t.size), 2)

        seg_rows = tuple(w[a:b] for w in whole) if whole is not None else None

        def run(  # noqa: ANN202
            sub: SkiJumpInputs,
            x0: np.ndarray,
            P0: np.ndarray = P0,
            smooth: bool = True,
            seg: SkiJumpInputs = seg,
            seg_rows: tuple[np.ndarray, ...] | None = seg_rows,
        ):
            if fast is None:
                propagate, measure = _model_callables(sub, cfg, hill)
                r = ekf_rts(x0, P0, sub.t.size, propagate, measure, progress=progress, t=sub.t)
                return r.x_filt, r.x_smooth if smooth else r.x_filt, r.P_smooth, r.residuals, None
            rows = seg_rows if smooth and sub is seg else None
            out = _run_fast(fast, sub, cfg, hill, x0, P0, smooth, keep_cov, rows, work)
            if progress is not None:
                for k in range(2 * sub.t.size - 1):
                    progress(k)
            return out

        try:
            # runs over the start (the window up to the in-run's end) that re-linearise it, then the whole
            # segment; with the in-run alignment one forward run over the window is enough (_forward_start)
            win = seg if nw == seg.t.size or cfg.passes <= 1 else _slice(seg, 0, nw)
            n_win = max(cfg.passes, 1) if win is seg else cfg.passes - 1
            done, it, change = None, 0, math.inf
            if win is not seg and aligned and cfg.start_pass == "forward":
                # from the rest's end: at rest the filter can only pull the heading towards the (hard-iron biased)
                # magnetometer's.  20 paper-noise jumps: yaw 0.315 -> 0.256 deg (docs/speed.md); a third less run
                r = n_rest - 1 if cfg.start_after_rest else 0
                r = r if 0 < r < nw - 2 else 0
                xw = run(_slice(seg, r, nw) if r else win, _after_rest(seg, x0, r) if r else x0, smooth=False)[0]
                x0 = _forward_start(seg, xw[-1], nw - 1, x0)
                n_win, it = 0, 0
            for it in range(n_win):
                done = run(win, x0)
                q_old = x0[6:10] / np.linalg.norm(x0[6:10])
                x0 = done[1][0].copy()
                x0[6:10] /= np.linalg.norm(x0[6:10])
                change = float(np.degrees(rotations.quat_angle(q_old, x0[6:10])))
                if it > 0 and change < cfg.pass_tol_deg:
                    break
            if win is not seg:
                done = run(seg, x0)
                it += 1
            # the antenna is not at the IMU (cfg.lever_arm): the lever arm comes off the fixes with the smoothed
            # attitude and rates of a pass (the measurement model linearised about it) before the next run
            lever = np.asarray(cfg.lever_arm, float) if any(cfg.lever_arm) else None
            ant_pos, ant_vel = seg.pos, seg.vel  # the fixes as logged: at the antenna, with their latency
            if cfg.estimate_latency and cfg.passes > 1 and tos:
                # the GNSS latency from the smoothed pass; where one is applied, that pass had absorbed part of
                # it: estimate what is left on the corrected pass and run once more (only sessions with a
                # latency pay for these runs).  The lever arm comes off with the first correction, so that
                # what is left is estimated on velocities without the antenna's rotation (o x l): on 12
                # realistic tuning jumps 3-D 0.118 -> 0.092 m, latency error -0.003 -> -0.001 s
                lat[-1] = _correct_latency(seg, done[1], min(tos), seg.t[-1], cfg.latency_min)
                if lat[-1] is not None and abs(lat[-1]) >= cfg.latency_min:
                    if lever is not None:
                        _remove_lever_arm(seg, done[1], lever)
                    done = run(seg, _unit_quat(done[1][0]))
                    it += 1
                    more = _correct_latency(seg, done[1], min(tos), seg.t[-1], 0.0)
                    if more is not None:
                        lat[-1] += more
                        done = run(seg, _unit_quat(done[1][0]))
                        it += 1
            if lever is not None:
                # (again) from the logged fixes moved by the whole latency, with the last pass's attitude
                seg.pos, seg.vel = ant_pos, ant_vel
                if lat[-1] is not None and abs(lat[-1]) >= cfg.latency_min:
                    vel_hill = rotations.ned_to_local(seg.vel, seg.azimuth_deg)
                    seg.pos, seg.vel = shift_gnss(seg.t, seg.pos, vel_hill, seg.vel, lat[-1])
                _remove_lever_arm(seg, done[1], lever)
                done = run(seg, _unit_quat(done[1][0]))
                it += 1
            xf, xs, P, res, sd = done
        except CovarianceError as exc:
            raise InputError(f"the smoother failed: {exc}") from None
        xfs.append(xf)
        xss.append(xs)
        covs.append(P if keep_cov or sd is None else None)  # 2 KB per step: only kept where asked for
        stds.append(sd)
        resids.append(res)
        npass.append(it + 1)

    def kept() -> list[np.ndarray]:
        if any(P is None for P in covs):
            raise RuntimeError("the smoothed covariances were not kept (smooth_inputs(keep_cov=False))")
        return covs

    def cov(idx: np.ndarray, r0: int = 0, r1: int | None = None) -> np.ndarray:
        idx = np.asarray(idx)
        r1 = inp.t.size if r1 is None else min(r1, inp.t.size)
        out = np.empty((r1 - r0, idx.size, idx.size))  # filled segment by segment: no list + concatenate
        i = 0
        for P in kept():
            a, b = max(r0, i), min(r1, i + P.shape[0])  # the rows of this segment inside [r0, r1)
            if a < b:
                Ps = P[a - i : b - i]
                out[a - r0 : b - r0] = Ps[:, idx][:, :, idx] if fast is None else fast.unpack_many(Ps, idx)
            i += P.shape[0]
        return out

    def var() -> np.ndarray:
        """Smoothed variances (n, 22): the covariances' diagonals, read without unpacking."""
        iu = np.triu_indices(mdl.N)
        diag = np.flatnonzero(iu[0] == iu[1])  # packed (upper, row-major) positions of the diagonal
        out = np.empty((inp.t.size, mdl.N))
        i = 0
        for P in kept():
            out[i : i + P.shape[0]] = np.diagonal(P, axis1=1, axis2=2) if fast is None else P[:, diag]
            i += P.shape[0]
        return out

    if whole is not None:  # every segment's last run wrote its rows (C engine)
        res, i = {}, 0
        for name, w in fast.RESIDUALS:
            res[name] = whole[2][:, i : i + w]
            i += w
        return Smoothed(whole[0], whole[1], cov, var, res, npass, lat, whole[3])
    if len(xfs) == 1:  # one segment: its arrays as they are (a copy of 60k steps costs ~10 ms per 10 MB)
        std = stds[0]
        return Smoothed(xfs[0], xss[0], cov, var, resids[0], npass, lat, std)
    names = {k: v.shape[1] for r in resids for k, v in r.items()}
    out = {k: np.full((inp.t.size, m), np.nan) for k, m in names.items()}
    i = 0
    for xf, r in zip(xfs, resids, strict=True):
        for k, v in r.items():
            out[k][i : i + xf.shape[0]] = v
        i += xf.shape[0]
    std = None if any(v is None for v in stds) else np.concatenate(stds)
    return Smoothed(np.concatenate(xfs), np.concatenate(xss), cov, var, out, npass, lat, std)


def rts_smooth_table(
    table: pa.Table,
    meta: dict[str, Any],
    hill: Hill,
    cfg: SmootherConfig | None = None,
    *,
    takeoff: list[float] | None = None,
    touchdown: list[float] | None = None,
    filtered: bool = False,
    progress: Callable[[int], object] | None = None,
    on_start: Callable[[int], object] | None = None,
    engine: str = "auto",
) -> tuple[pa.Table, dict[str, Any], str]:
    """``rts-smooth`` on a session table: every input column plus the estimate columns.

    Parameters
    ----------
    table, meta : session and its metadata
    hill : the hill (profile for the constraints, take-off edge for the frame)
    cfg : SmootherConfig, optional
    takeoff, touchdown : lists of times [s], optional
        Events; default the ``event`` column's ``takeoff``/``touchdown`` rows.
    filtered : bool
        Also write the forward-only (EKF) estimates as ``filt_`` columns.
    progress : callable(k), optional
        Called once per forward and backward step.
    on_start : callable(total), optional
        Called with the number of progress calls to expect.

    Returns
    -------
    table, meta, message
    """
    cfg = cfg or SmootherConfig()
    inp, frame = session_inputs(table, meta, hill, cfg, takeoff, touchdown)
    if cfg.hill_constraints and not inp.jumps:
        # without events the in-run/landing windows are guessed from speed alone: errors several times
        # larger (roll 1.8 deg instead of 0.15 on the fixture), so refuse rather than answer wrongly
        raise InputError(
            "no take-off/touch-down events in the session; expected detect-events --kind jump before "
            "rts-smooth, or --takeoff/--touchdown [s], or --no-hill-constraints"
        )
    if on_start is not None:
        on_start((2 * inp.t.size - 1) * max(cfg.passes, 1))
    res = smooth_inputs(inp, hill, cfg, progress, engine, keep_cov=False)
    if cfg.use_mag:
        # a disturbance that keeps the field's strength shows in the innovations: skip those samples, run again
        bad = mag_innovation_outliers(res.residuals.get("mag"), inp.t, cfg.r_mag)
        if bad.any():
            raw = inp.mag.copy()
            inp.mag[bad] = np.nan
            res = smooth_inputs(inp, hill, cfg, progress, engine, keep_cov=False)
            # the flagged stretch may outlast the disturbance (the filter's heading was off for a while): give back
            # the samples that agree with the smoothed attitude, then run once more
            idx = np.flatnonzero(bad)
            pred = np.array([mdl.h_mag(res.x_smooth[k], inp.m_o) for k in idx])
            agree = np.linalg.norm(raw[idx] - pred, axis=1) < 2.0 * math.sqrt(3.0) * cfg.r_mag
            if agree.any():
                bad[idx[agree]] = False
                inp.mag[idx[agree]] = raw[idx[agree]]
                res = smooth_inputs(inp, hill, cfg, progress, engine, keep_cov=False)
            inp.mag_disturbed = bad if inp.mag_disturbed is None else inp.mag_disturbed | bad
    t_rows = schema.floats(table, "t")
    cols = _estimate_columns(res.x_smooth, res.cov, inp, var=res.var, std=res.std)
    cols.update(constraint_residuals(res.x_smooth, inp, hill if cfg.hill_constraints else None))
    if filtered:
        cols.update(_estimate_columns(res.x_filt, None, inp, prefix="filt_"))
    if t_rows.size == inp.t.size and np.array_equal(t_rows, inp.t):
        out_cols = cols  # every row is an IMU step: nothing to interpolate (the quaternions are unit)
    else:
        out_cols = _interp_columns(t_rows, inp.t, cols, cfg.max_gap)
        # quaternions interpolated linearly: renormalise
        for pre in ("", "filt_") if filtered else ("",):
            qs = [out_cols[f"{pre}q{k}"] for k in range(4)]
            nq = np.sqrt(qs[0] * qs[0] + qs[1] * qs[1] + qs[2] * qs[2] + qs[3] * qs[3])
            for k in range(4):
                out_cols[f"{pre}q{k}"] = qs[k] / nq
    out = with_columns(table, out_cols)
    new_meta = dict(meta)
    new_meta["frame"] = frame.to_meta()
    new_meta["hill"] = hill.meta()
    new_meta["rts"] = {
        "config": {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(cfg).items()},
        "jumps": [{"takeoff": a, "touchdown": b} for a, b in inp.jumps],
        "gravity": inp.g0,
        "passes": res.passes,
        "gnss_latency_s": res.gnss_latency,
        "mag_field_ned": inp.m_o.tolist(),
        "residual_rms": residual_rms(res.residuals),
    }
    # the IMU's own stops (logging paused between jumps: independent segments) are not GNSS gaps
    pauses = [(inp.t[a - 1], inp.t[a]) for a, _ in segments(inp.t, cfg.max_gap)[1:]]
    warn = [clipped_message(inp), describe_gaps("GNSS", inp.t[np.isfinite(inp.pos[:, 0])], 2.0, pauses)]
    if inp.mag_disturbed is not None and inp.mag_disturbed.any():
        md = inp.mag_disturbed
        warn.append(describe_mag(int(md.sum()), inp.t, md) + ": those samples are skipped")
    new_meta["rts"]["warnings"] = [w for w in warn if w]
    msg = (
        f"{inp.t.size} IMU steps, {int(np.isfinite(inp.pos[:, 0]).sum())} GNSS fixes, {len(inp.jumps)} jump(s); "
        f"hill constraints {'on' if cfg.hill_constraints else 'off'}"
    )
    return out, new_meta, msg
