"""The ski-jump smoother's passes over a session: each IMU segment from its initial state to its final run.

Per segment (the session cut where the IMU stops for more than ``cfg.max_gap`` seconds; each smoothed on its
own), in the order the data flow:

1. the initial state from the rest at the gate (:func:`sportfusion.skijump.smoother_start.initial_state`);
2. runs over the start window that re-linearise it (:func:`_start_passes`): with the in-run alignment's
   attitude one forward run from the rest's end (``cfg.start_pass = "forward"``), else ``cfg.passes - 1``
   smoothed runs, each from the previous one's smoothed first state;
3. the whole segment's smoothed run (:func:`sportfusion.skijump.smoother_engine.run`);
4. the GNSS corrections (:func:`_gnss_corrections`): the latency estimated on the smoothed pass and, with a
   known lever arm, the fixes moved from the antenna to the IMU, each followed by one more run;
5. GNSS outliers (:func:`_screen_gnss`): fixes far from the smoothed track (multipath, wild fixes) skipped,
   and one more run where there were any.

:func:`smooth_inputs` returns every segment's final run as one :class:`Smoothed`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from sportfusion.core import rotations
from sportfusion.core.errors import InputError
from sportfusion.estimators.kalman import CovarianceError
from sportfusion.skijump import model as mdl
from sportfusion.skijump import smoother_engine as engine_
from sportfusion.skijump.alignment import gnss_latency, shift_gnss
from sportfusion.skijump.kinematics import m_bo
from sportfusion.skijump.smoother_engine import Run
from sportfusion.skijump.smoother_inputs import SkiJumpInputs, SmootherConfig, _slice, segments
from sportfusion.skijump.smoother_start import _after_rest, _forward_start, initial_state, start_window


@dataclass
class Smoothed:
    """Smoother output over all IMU steps (either engine).

    ``cov(idx, r0=0, r1=None)`` returns the smoothed covariances (r1 - r0, k, k) over the state
    indices ``idx`` for the steps ``r0 .. r1 - 1`` (default all); ``var()`` their diagonals (n, 22).
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
    gnss_outliers: list[int] = field(default_factory=list)  # GNSS fixes skipped as outliers, per segment


def smooth_inputs(
    inp: SkiJumpInputs,
    cfg: SmootherConfig,
    progress: Callable[[int], object] | None = None,
    engine: str = "auto",
    keep_cov: bool = True,
    keep_filtered: bool = True,
) -> Smoothed:
    """Run the EKF + RTS smoother over the prepared inputs, segment by segment (raises InputError when it diverges).

    Parameters
    ----------
    inp : SkiJumpInputs
        The session on the IMU steps (:func:`sportfusion.skijump.smoother_inputs.session_inputs`).
    cfg : SmootherConfig
    progress : callable(k), optional
        Called once per forward and backward step of every run.
    engine : {"auto", "c", "numpy"}
        ``numpy``: the reference (:func:`sportfusion.estimators.kalman.ekf_rts` with the model callables);
        ``c``: the C loop; ``auto``: C when it is built, else numpy (:mod:`sportfusion.skijump.smoother_engine`).
    keep_cov : bool
        Keep the smoothed covariances for ``Smoothed.cov`` / ``Smoothed.var`` (2 KB per step).  False where
        the C engine's ``std`` rows are all that is wanted: ``cov``/``var`` then raise RuntimeError (the
        numpy engine, which has no ``std`` rows, keeps them regardless).
    keep_filtered : bool
        Keep the filtered states (``Smoothed.x_filt``).  False (with ``keep_cov`` False, the C engine): they
        are not kept (``x_filt`` is then an empty (0, 22) array; 0.2 KB per step less), issue 38.

    The passes over each segment are those of the module text; ``Smoothed.passes`` counts the runs per
    segment, ``Smoothed.gnss_latency`` the latency applied per segment [s].
    """
    use_c = engine_.compiled(engine)
    if use_c:  # each segment's final run writes its rows of the session's arrays: no concatenation
        n_max = max(b - a for a, b in segments(inp.t, cfg.max_gap))
        whole, work = engine_.c_buffers(inp.t.size, n_max, keep_cov, keep_filtered)
    else:
        whole = work = None
    runs, npass, lat, wild = [], [], [], []
    for a, b in segments(inp.t, cfg.max_gap):
        seg = _slice(inp, a, b)
        if b - a < 2 or not np.isfinite(seg.pos[:, 0]).any():
            raise InputError(
                f"the IMU segment {seg.t[0]:.2f}-{seg.t[-1]:.2f} s has no GNSS fix (or a single sample); "
                "expected GNSS during every recorded stretch"
            )
        rows = tuple(None if w is None else w[a:b] for w in whole) if whole is not None else None
        runner = _Runner(seg, cfg, use_c, keep_cov, rows, work, progress)
        try:
            done, n, tau, n_wild = _smooth_segment(seg, cfg, runner)
        except CovarianceError as exc:
            raise InputError(f"the smoother failed: {exc}") from None
        runs.append(done)
        npass.append(n)
        lat.append(tau)
        wild.append(n_wild)
    out = _collect(inp, runs, npass, lat, whole, keep_cov)
    out.gnss_outliers = wild
    return out


class _Runner:
    """The engine's runs over one segment (or a window of it), all from that segment's ``P0``: the segment's
    smoothed runs write into its rows of the session's arrays (``rows``)."""

    def __init__(
        self,
        seg: SkiJumpInputs,
        cfg: SmootherConfig,
        use_c: bool,
        keep_cov: bool,
        rows: tuple[np.ndarray | None, ...] | None,
        work: tuple[np.ndarray | None, ...] | None,
        progress: Callable[[int], object] | None,
    ) -> None:
        self.seg, self.cfg, self.use_c, self.keep_cov = seg, cfg, use_c, keep_cov
        self.rows, self.work, self.progress = rows, work, progress
        self.P0 = np.empty(0)  # set from the segment's initial state (_smooth_segment)

    def __call__(self, sub: SkiJumpInputs, x0: np.ndarray, smooth: bool = True) -> Run:
        out = self.rows if smooth and sub is self.seg else None
        return engine_.run(sub, self.cfg, x0, self.P0, self.use_c, smooth, self.keep_cov, out, self.work, self.progress)


def _smooth_segment(seg: SkiJumpInputs, cfg: SmootherConfig, run: _Runner) -> tuple[Run, int, float | None, int]:
    """One segment from its initial state to its final run: ``(run, runs made, GNSS latency [s] or None, GNSS fixes
    skipped as outliers)``."""
    x0, P0, aligned, n_rest = initial_state(seg, cfg, with_source=True)
    run.P0 = P0  # every run over the segment starts from the initial covariance (the mean is re-linearised)
    nw = start_window(seg, cfg)
    done, it = _start_passes(seg, cfg, run, x0, nw, aligned, n_rest)
    done, it, tau = _gnss_corrections(seg, cfg, run, done, it)
    n_wild = _screen_gnss(seg, done.x_smooth, cfg) if cfg.gnss_outlier_sigma > 0 else 0
    if n_wild:
        done = run(seg, _unit_quat(done.x_smooth[0]))
        it += 1
    return done, it + 1, tau, n_wild


def _screen_gnss(seg: SkiJumpInputs, xs: np.ndarray, cfg: SmootherConfig) -> int:
    """GNSS fixes far from the smoothed track set to NaN on ``seg`` (new arrays); returns how many (issue 39).

    After the latency and lever-arm corrections the fixes' distance from the smoothed positions is the GNSS
    error itself: mostly slow drift (the median per axis), white noise, and -- what this removes -- multipath
    episodes of metres and wild fixes of tens of metres, which the smoother's Gaussian model (Table 5: 3/3/5 m)
    would otherwise partly follow.  A fix is skipped (position and velocity) where any axis lies more than
    ``cfg.gnss_outlier_sigma`` robust standard deviations (1.4826 MAD, at least ``cfg.gnss_outlier_floor`` m)
    from that axis' median.
    """
    n = xs.shape[0]
    ok = np.flatnonzero(np.isfinite(seg.pos[:n, 0]))
    if ok.size < 10:
        return 0
    r = seg.pos[ok] - xs[ok, 0:3]
    med = np.median(r, axis=0)
    scale = np.maximum(1.4826 * np.median(np.abs(r - med), axis=0), cfg.gnss_outlier_floor)
    bad = ok[np.any(np.abs(r - med) > cfg.gnss_outlier_sigma * scale, axis=1)]
    if bad.size:
        seg.pos, seg.vel = seg.pos.copy(), seg.vel.copy()
        seg.pos[bad] = np.nan
        seg.vel[bad] = np.nan
    return int(bad.size)


def _start_passes(
    seg: SkiJumpInputs, cfg: SmootherConfig, run: _Runner, x0: np.ndarray, nw: int, aligned: bool, n_rest: int
) -> tuple[Run, int]:
    """Runs over the start window (its first ``nw`` steps) that re-linearise the initial state, then the whole
    segment: ``(the whole segment's run, the index of the last run)``.

    With the in-run alignment's attitude (``aligned``) and ``cfg.start_pass = "forward"``, one forward run over
    the window is enough (:func:`_forward_start`), from the rest's end (``n_rest`` steps) with
    ``cfg.start_after_rest``: at rest the filter can only pull the heading towards the (hard-iron biased)
    magnetometer's (20 paper-noise jumps: yaw 0.315 -> 0.256 deg, docs/speed.md); a third less run.  Else
    ``cfg.passes - 1`` smoothed runs over the window (all ``cfg.passes`` over the whole segment where the
    window is all of it), each from the previous one's smoothed first state (mean only, the same ``P0``),
    stopping early when the initial attitude changes by less than ``cfg.pass_tol_deg`` [deg].
    """
    win = seg if nw == seg.t.size or cfg.passes <= 1 else _slice(seg, 0, nw)
    n_win = max(cfg.passes, 1) if win is seg else cfg.passes - 1
    done, it = None, 0
    if win is not seg and aligned and cfg.start_pass == "forward":
        r = n_rest - 1 if cfg.start_after_rest else 0
        r = r if 0 < r < nw - 2 else 0
        xw = run(_slice(seg, r, nw) if r else win, _after_rest(seg, x0, r) if r else x0, smooth=False).x_filt
        x0 = _forward_start(seg, xw[-1], nw - 1, x0)
        n_win = 0
    for it in range(n_win):
        done = run(win, x0)
        q_old = x0[6:10] / np.linalg.norm(x0[6:10])
        x0 = _unit_quat(done.x_smooth[0])
        change = float(np.degrees(rotations.quat_angle(q_old, x0[6:10])))
        if it > 0 and change < cfg.pass_tol_deg:
            break
    if win is not seg:
        done = run(seg, x0)
        it += 1
    assert done is not None
    return done, it


def _gnss_corrections(
    seg: SkiJumpInputs, cfg: SmootherConfig, run: _Runner, done: Run, it: int
) -> tuple[Run, int, float | None]:
    """The GNSS latency and the lever arm taken off the segment's fixes, each followed by one more run:
    ``(the last run, the index of the last run, the latency applied [s] or None)``.

    The latency is estimated on the smoothed pass; where one is applied, that pass had absorbed part of it:
    what is left is estimated on the corrected pass and the segment runs once more (only sessions with a
    latency pay for these runs).  The antenna is not at the IMU (``cfg.lever_arm``): the lever arm comes off
    the fixes with the smoothed attitude and rates of a pass (the measurement model linearised about it), with
    the first latency correction, so that what is left is estimated on velocities without the antenna's
    rotation (o x l: on 12 realistic tuning jumps 3-D 0.118 -> 0.092 m, latency error -0.003 -> -0.001 s), and
    again at the end from the logged fixes moved by the whole latency, with the last pass's attitude.
    """
    lever = np.asarray(cfg.lever_arm, float) if any(cfg.lever_arm) else None
    ant_pos, ant_vel = seg.pos, seg.vel  # the fixes as logged: at the antenna, with their latency
    tos = [a for a, _ in seg.jumps if seg.t[0] <= a <= seg.t[-1]]
    tau, applied = None, False
    if cfg.estimate_latency and cfg.passes > 1 and tos:
        tau, applied = _correct_latency(seg, done.x_smooth, min(tos), seg.t[-1], cfg.latency_min, cfg.latency_sigmas)
        if applied:
            if lever is not None:
                _remove_lever_arm(seg, done.x_smooth, lever)
            done = run(seg, _unit_quat(done.x_smooth[0]))
            it += 1
            more, _ = _correct_latency(seg, done.x_smooth, min(tos), seg.t[-1], 0.0, 0.0)
            if more is not None:
                tau += more
                done = run(seg, _unit_quat(done.x_smooth[0]))
                it += 1
    if lever is not None:
        seg.pos, seg.vel = ant_pos, ant_vel
        if applied and tau is not None:
            vel_hill = rotations.ned_to_local(seg.vel, seg.azimuth_deg)
            seg.pos, seg.vel = shift_gnss(seg.t, seg.pos, vel_hill, seg.vel, tau)
        _remove_lever_arm(seg, done.x_smooth, lever)
        done = run(seg, _unit_quat(done.x_smooth[0]))
        it += 1
    return done, it, tau


def _correct_latency(
    seg: SkiJumpInputs, xs: np.ndarray, t_takeoff: float, t_end: float, least: float, sigmas: float
) -> tuple[float | None, bool]:
    """Estimate the GNSS latency from a smoothed pass over the in-run and take-off, and move the segment's
    GNSS fixes to the time they describe (in place: new arrays on ``seg``) when it is at least ``least``
    [s] and ``sigmas`` of its standard error (smaller estimates are within the estimate's own noise).
    Returns the estimate [s] (None where the data do not show one) and whether the fixes were moved."""
    n = xs.shape[0]
    span = (max(seg.t[0], t_takeoff - 6.0), min(t_end, t_takeoff + 4.0))
    tau, std = gnss_latency(seg.t[:n], seg.u[:n], xs, seg.vel[:n], seg.g0, span, with_std=True)
    if tau is None or abs(tau) < least or abs(tau) < sigmas * std:
        return tau, False
    vel_hill = rotations.ned_to_local(seg.vel, seg.azimuth_deg)
    seg.pos, seg.vel = shift_gnss(seg.t, seg.pos, vel_hill, seg.vel, tau)
    return tau, True


def _unit_quat(x: np.ndarray) -> np.ndarray:
    """A copy of the state ``x`` with its quaternion normalised (a run's smoothed first state, to start the next)."""
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


def _collect(
    inp: SkiJumpInputs,
    runs: list[Run],
    npass: list[int],
    lat: list[float | None],
    whole: tuple[np.ndarray | None, ...] | None,
    keep_cov: bool,
) -> Smoothed:
    """The segments' final runs as one :class:`Smoothed` over the session's steps."""
    # 2 KB per step: the covariances are only kept where asked for (the numpy engine has no std rows: always)
    covs = [r.cov if keep_cov or r.std is None else None for r in runs]

    def kept() -> list[np.ndarray]:
        if any(P is None for P in covs):
            raise RuntimeError("the smoothed covariances were not kept (smooth_inputs(keep_cov=False))")
        return covs  # type: ignore[return-value]

    def cov(idx: np.ndarray, r0: int = 0, r1: int | None = None) -> np.ndarray:
        idx = np.asarray(idx)
        r1 = inp.t.size if r1 is None else min(r1, inp.t.size)
        out = np.empty((r1 - r0, idx.size, idx.size))  # filled segment by segment: no list + concatenate
        i = 0
        for P in kept():
            a, b = max(r0, i), min(r1, i + P.shape[0])  # the rows of this segment inside [r0, r1)
            if a < b:
                out[a - r0 : b - r0] = engine_.cov_rows(P[a - i : b - i], idx)
            i += P.shape[0]
        return out

    def var() -> np.ndarray:
        """Smoothed variances (n, 22): the covariances' diagonals, read without unpacking."""
        out = np.empty((inp.t.size, mdl.N))
        i = 0
        for P in kept():
            out[i : i + P.shape[0]] = engine_.variances(P)
            i += P.shape[0]
        return out

    if whole is not None:  # every segment's last run wrote its rows (C engine; the filtered states: where kept)
        x_f, x_s, resid, std = whole
        assert x_s is not None and resid is not None
        x_f = np.empty((0, mdl.N)) if x_f is None else x_f
        return Smoothed(x_f, x_s, cov, var, engine_.residual_blocks(resid), npass, lat, std)
    if len(runs) == 1:  # one segment: its arrays as they are (a copy of 60k steps costs ~10 ms per 10 MB)
        r = runs[0]
        return Smoothed(r.x_filt, r.x_smooth, cov, var, r.residuals, npass, lat, r.std)
    names = {k: v.shape[1] for r in runs for k, v in r.residuals.items()}
    res = {k: np.full((inp.t.size, m), np.nan) for k, m in names.items()}
    i = 0
    for r in runs:
        for k, v in r.residuals.items():
            res[k][i : i + r.x_filt.shape[0]] = v
        i += r.x_filt.shape[0]
    std = None if any(r.std is None for r in runs) else np.concatenate([r.std for r in runs])
    xf = np.concatenate([r.x_filt for r in runs])
    return Smoothed(xf, np.concatenate([r.x_smooth for r in runs]), cov, var, res, npass, lat, std)
