"""Domain sampling (§III-B): particle filter over position and yaw error, and its smoother.

Particle (eq 16): position ``p`` [m] in the map frame and yaw error ``psi`` [rad] about the
map's up axis.  Dynamic model (eq 17), with the errata (Sigma_P scales with dT)::

    p_k = p_k-1 + Rot_up(psi) (v*_k-1 + v*_k) / 2 dT + e_p,   e_p ~ N(0, Sigma_v,k-1 dT^2)
    psi_k = psi_k-1 + e_psi,                                 e_psi ~ N(0, yaw_psd dT)

where ``v*`` and ``Sigma_v`` are the transition estimator's velocities and their covariance
(the trapezoid equals eq 6's ``dT v + dT^2 a / 2``).  The position noise is the velocity's
error carried through eq 17's ``dT v``: ``e_p = dT n_v`` with ``n_v ~ N(0, Sigma_v)``, as in
the authors' published implementation (the noise is added to the velocity, then multiplied
by dT).  A variance ``Sigma_v dT`` instead (the Appendix's product read literally) spreads
the particles ``1/dT`` = 100 times wider in variance at 100 Hz; on simulated trials (seeds
0-23, two filter seeds each) that raised the smoother's median error from 0.133 to
0.148-0.187 m and picked the wrong start hold in 11 instead of 3-5 of 48 runs.  The yaw
error keeps the Appendix's random walk, 0.09 rad^2/s times dT.  At every detected grip sample the
weights are multiplied by the grip likelihood (eq 18) ``max(h, c_e)`` with
``h = max_i h_i`` (eq 22) and the ball-plus-Gaussian-tail hold model (eqs 20-21)::

    h_i = N(0; 0, s^2 I)                             if |d| < r
          N((1 - r/|d|) d; 0, s^2 I)                 else,      d = p - p_i

and ``c_e = N(0; 0, s^2 I) exp(-k^2 / 2)`` -- the "elsewhere" level is the tail's value
``k`` standard deviations outside the ball (the paper's implementation parametrises it so).
Maxima, not sums (errata): each particle scores its best explanation.  Every particle
remembers the hold of its best explanation at the last grip (-1: elsewhere); particles
with the same label form a cluster, and the output is the weighted mean of the most
likely cluster.  Systematic resampling when the effective sample size drops below
half the particles.  The PF starts at the first grip, with the particles split evenly
between the route's two start holds.

Start holds (``PFParams.separate_starts``, default): the particles of each start hold form a
stratum that is resampled within itself and keeps its total weight, the filter's estimate of that
hypothesis's evidence.  In one particle set the start holds compete through resampling, and the
first grips decide: a wall grip that the wrong start puts near a hold, or a transition that falls
short of the next hold, can take every particle of the true start before the later grips show it
wrong (simulated seeds 2000-2099: 9 wrong starts; in 6 of them, smoother median errors 0.15-0.83 m,
a filter started on the true start hold alone ends with the larger evidence in each of three seeds).  The strata run until,
at the end of a grip, every stratum's most likely cluster is the same hold -- from there their
tracks are one and later grips cannot tell them apart -- and the stratum with the larger evidence
then takes all particles; the smoother follows that stratum (or, if they never meet, the one with
the larger evidence at the end).  On simulated seeds 0-99 and 2000-2199 (filter seed 0) this cut
the wrong starts from 29 to 18 of 300 (0-99: 12 to 7; 2000-2099: 9 to 4; 2100-2199: 8 to 7); the
rest are trials whose early grips favour the wrong start under the model too (a grip likelihood
per sample, and the yaw random walk absorbing part of a horizontal offset over a long move).
Deciding by the evidence with each grip counted once (its samples' increments over its length)
did no better (7 + 4 wrong on 2000-2199, 15 of 200 runs on 0-99).

Tempered grips (``PFParams.grip_count``, default 2; None = the paper): eq 18 multiplies the weights at
every 100 Hz sample of a grip, so one grip of ``L`` samples counts ``L`` times although its samples are
not independent; with ``grip_count = c`` each sample's log-likelihood is weighted by ``c / L``
(:func:`grip_weights`, the grip lengths taken from the whole detected-grip mask), so that every grip
counts ``c`` times.  With the paper's white magnetometer noise in the transition estimator, c = 2 moved
the wrong starts by a few trials only (18 -> 13 of 300 on tuning seeds 0-99, 2000-2199).  The transition
estimator's heading followed the wall's magnetic disturbances (a move's displacement off by 0.19-0.20 m
RMS while its covariance said a few cm); once its magnetometer noise counts the
disturbance once per second (``TransitionParams.mag_disturbance``) that error falls to 0.11 m and
tempering pays (wrong starts, smoother RMSE -- the RMS over trials of each trial's RMSE -- / max [m];
seeds 0-99 | 2000-2199 | 3000-3099, filter seed 0)::

    paper noise, c = None      7 .366/4.37 | 11 .277/2.88 | 7 .286/1.99   25 of 400
    disturbance, c = None      3 .161/1.22 |  6 .138/2.63 | 1 .198/1.81   10 of 400
    disturbance, c = 2         1 .133/1.16 |  5 .120/1.93 | 0 .115/1.55    6 of 400

Off the default simulation (paper's model -> these defaults, wrong starts and smoother RMSE [m]): 60 Hz
IMU, seeds 0-99: 13 -> 1 of 100, .480 -> .130; panels' disturbances 0-0.01 instead of 0.2-0.6, seeds 0-79:
5 -> 1 of 80, .250 -> .123; 0.5-1.0, seeds 0-79: 10 -> 1 of 80, .304 -> .124.
(also tried with the disturbance model: yaw_psd 0.01 instead of 0.09: 6 of 300 on the first two sets,
with c = 2 as well: 7 of 400; magnetometer 1-sigma 1.0 or 10 instead of 3.0 at 100 Hz: 9 and 10 of 300.)
The trials still wrong have start holds 0.2-0.7 m apart whose tracks both fit the route's holds within
the grips' spread (a few cm to a decimetre).

The smoother (default) is backward simulation (Godsill, Doucet & West) with Metropolis-Hastings
moves from each trajectory's filter ancestor, O(M) per step; the alternative
(``PFParams.smoother = "ffbsm"``) is the forward-filtering backward-smoothing (FFBSm) marginal smoother of
Doucet and Johansen (the paper's [18], as in its implementation): with the filter's
weights ``w_k`` and the Gaussian transition density ``f`` of the model above,
``w_k|N(i) ~ w_k(i) sum_j w_k+1|N(j) f(x_k+1(j) | x_k(i)) / sum_l w_k(l) f(x_k+1(j) | x_k(l))``,
O(M^2) per step, evaluated with one whitened matrix product per step.

Compiled path: where the optional C extension ``_climbing_c`` is built (:mod:`sportfusion.climbing._native`),
the filter runs step by step in C and the backward simulation's paths and the smoothed clusters too, from the
same random draws as the numpy code here (which stays the reference, ``tests/test_climbing_native.py``):
the same outputs to rounding, about 3x faster.  There the filter keeps a block of its history at a time and
the smoother runs it again block by block (:mod:`sportfusion.climbing._pfblocks`): memory that does not grow
with the trial's length, where the numpy path holds the whole history (~26 kB a step with 200 particles).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sportfusion.climbing import _pfblocks
from sportfusion.climbing._native import native
from sportfusion.core.errors import InputError
from sportfusion.core.stats import unique
from sportfusion.estimators.particles import (
    backward_simulation,
    backward_simulation_gaussian,
    systematic_resample,
)

ELSEWHERE = -1


@dataclass(frozen=True)
class HoldModel:
    """Grip likelihood (eqs 18-22).

    Attributes
    ----------
    radius : float
        r, radius of the uniform ball around a hold centre [m].
    sigma : float
        Standard deviation of the Gaussian tails, Sigma_h = sigma^2 I [m].
    elsewhere_sigmas : float
        c_e is the tail's density this many sigmas outside the ball.
    """

    radius: float = 0.10
    sigma: float = 0.05
    elsewhere_sigmas: float = 3.0

    @property
    def log_peak(self) -> float:
        """log N(0; 0, sigma^2 I) in 3-D [log 1/m^3]."""
        return -1.5 * np.log(2 * np.pi * self.sigma**2)

    @property
    def log_elsewhere(self) -> float:
        """log c_e (eq 19)."""
        return self.log_peak - 0.5 * self.elsewhere_sigmas**2


def hold_log_likelihood(p: np.ndarray, centre: np.ndarray, model: HoldModel | None = None) -> np.ndarray:
    """log h_i of eq 20 for positions ``p`` (..., 3) [m] and one hold centre (3,)."""
    m = model or HoldModel()
    d = np.linalg.norm(np.asarray(p, dtype=np.float64) - centre, axis=-1)
    excess = np.maximum(d - m.radius, 0.0)  # |(1 - r/|d|) d| outside the ball
    return m.log_peak - 0.5 * (excess / m.sigma) ** 2


def grip_log_likelihood(
    p: np.ndarray, centres: np.ndarray, ids: np.ndarray, model: HoldModel | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """log of eq 18 (max over holds and elsewhere) and the label of the best explanation.

    Parameters
    ----------
    p : numpy.ndarray, shape (m, 3)
        Particle positions [m].
    centres : numpy.ndarray, shape (h, 3)
        Hold centres [m].
    ids : numpy.ndarray, shape (h,)
        Hold numbers.

    Returns
    -------
    loglik : numpy.ndarray (m,)
    label : numpy.ndarray (m,) of int
        Hold number of the best hold, or -1 where "elsewhere" wins.
    """
    m = model or HoldModel()
    # nearest centre (isotropic Sigma_h: the largest h_i is the nearest hold): argmin |c|^2 - 2 p.c,
    # in pieces of at most 2**16 products: a larger one goes to OpenBLAS's threads, whose waiting costs
    # more CPU time than the product (seen on 2 shared cores: 7 ms instead of 0.5 ms for 20000 x 40)
    ct = -2.0 * centres.T
    score = np.empty((p.shape[0], centres.shape[0]))
    step = max(1, 2**16 // max(1, centres.shape[0]))
    for i in range(0, p.shape[0], step):
        np.matmul(p[i : i + step], ct, out=score[i : i + step])
    score += (centres * centres).sum(axis=1)
    best = np.argmin(score, axis=1)
    d2 = score[np.arange(p.shape[0]), best] + (p * p).sum(axis=1)
    d = np.sqrt(np.maximum(d2, 0.0))
    peak, other = m.log_peak, m.log_elsewhere
    logh = peak - 0.5 * (np.maximum(d - m.radius, 0.0) / m.sigma) ** 2
    at_hold = logh > other
    return np.where(at_hold, logh, other), np.where(at_hold, ids[best], ELSEWHERE)


@dataclass(frozen=True)
class PFParams:
    """Particle filter settings.

    Attributes
    ----------
    particles : int
        M (200 in the paper).
    yaw_psd : float
        Yaw-error random walk [rad^2/s] (Sigma_P's 0.09, times dT).
    start_sigma : float
        1-sigma of the initial positions around the start holds [m].
    start_yaw_sigma : float
        1-sigma of the initial yaw error [rad].
    ess_fraction : float
        Resample when ESS < this fraction of M.
    hold : HoldModel
    smoother : str
        ``"backward"``: backward simulation with MCMC moves, O(M) per step
        (:func:`sportfusion.estimators.particles.backward_simulation`); ``"ffbsm"``: the
        marginal FFBSm smoother, O(M^2) per step (the paper's implementation).
    smoother_moves : int
        Metropolis-Hastings moves per trajectory and step of the backward simulation.
    separate_starts : bool
        Keep one stratum of particles per start hold (resampled within itself, its total weight = the
        hypothesis's evidence) until, at the end of a grip, every stratum's most likely cluster is the
        same hold; the stratum with the larger evidence then takes all particles.  False: one particle
        set from the first grip (the start holds compete through resampling).
    grip_count : float or None
        A number ``c`` (default 2): each sample's log-likelihood is weighted by ``c / L`` (tempered), so
        that a grip of ``L`` samples counts ``c`` times whatever its length.  None: every grip sample
        multiplies the weights by its full likelihood (eq 18 as in the paper, a grip counts ``L`` times).
    """

    particles: int = 200
    yaw_psd: float = 0.09
    start_sigma: float = float(np.sqrt(0.001))
    start_yaw_sigma: float = 0.05
    ess_fraction: float = 0.5
    hold: HoldModel = HoldModel()
    smoother: str = "backward"
    smoother_moves: int = 1
    separate_starts: bool = True
    grip_count: float | None = 2.0


def grip_weights(grip: np.ndarray, count: float | None) -> np.ndarray:
    """Weight of every sample's grip log-likelihood (n,): 1, or ``count`` / (samples in its grip).

    Parameters
    ----------
    grip : numpy.ndarray of bool (n,)
        Detected grips; a grip is a run of consecutive True samples.
    count : float or None
        How many times a whole grip counts; None: every sample counts once (the paper).

    Returns
    -------
    numpy.ndarray (n,)
        Zero outside the grips.
    """
    g = np.asarray(grip, dtype=bool)
    if count is None:
        return g.astype(np.float64)
    if not count > 0:
        raise InputError(f"grip_count {count}; expected a positive number or None")
    start = g & ~np.concatenate(([False], g[:-1]))
    run = np.cumsum(start)  # grip number (1, 2, ...) of every sample
    length = np.bincount(run[g], minlength=int(run[-1]) + 1 if g.size else 1)
    out = np.zeros(g.size)
    out[g] = count / length[run[g]]
    return out


@dataclass
class PFResult:
    """Per-sample outputs of :func:`run_particle_filter` (NaN / -2 before the first grip).

    ``pos`` (n, 3) [m], ``label`` (n,) the most likely cluster's hold (-1 elsewhere),
    ``prob`` (n,) its probability, ``yaw`` (n,) its mean yaw error [rad] -- for the
    filter and (``smooth_*``) the smoother; ``k0`` the first grip sample; ``resamples``;
    ``log_evidence`` (n,) the filter's estimate of the log marginal likelihood of the grips up to
    each step, ``sum_grips log sum_i W_i l_i`` with the normalised weights ``W`` before each grip
    sample and the grip likelihoods ``l`` of eq 18 [sum of log 1/m^3 over the grip samples];
    ``merged_at`` the step where the start holds' strata merged (``k0`` with one stratum, -1 if they never
    did) and ``start_evidence`` (start holds,) each stratum's log evidence up to then (or the end).
    """

    k0: int
    pos: np.ndarray
    label: np.ndarray
    prob: np.ndarray
    yaw: np.ndarray
    smooth_pos: np.ndarray | None
    smooth_label: np.ndarray | None
    smooth_prob: np.ndarray | None
    smooth_yaw: np.ndarray | None
    resamples: int
    log_evidence: np.ndarray | None = None
    merged_at: int = -1
    start_evidence: np.ndarray | None = None


def _strata_sums(lws: np.ndarray, strata: list) -> tuple[np.ndarray, np.ndarray]:
    """Per stratum (particle index array or slice) and row of the log weights ``lws`` (r, m): the log
    of the weights' sum (s, r) and the effective sample size within the stratum (s, r)."""
    lsum = np.empty((len(strata), lws.shape[0]))
    ess = np.empty_like(lsum)
    for h, st in enumerate(strata):
        sub = lws[:, st]
        top = sub.max(axis=1, keepdims=True)
        e = np.exp(sub - top)
        s1 = e.sum(axis=1)
        lsum[h] = top[:, 0] + np.log(s1)
        ess[h] = s1 * s1 / np.einsum("ij,ij->i", e, e)
    return lsum, ess


def _normalised(lw: np.ndarray) -> np.ndarray:
    """Weights from log weights, summing to 1."""
    w = np.exp(lw - lw.max())
    return w / w.sum()


def _same_best_hold(w: np.ndarray, code: np.ndarray, strata: list, codes: int, nowhere: int) -> np.ndarray:
    """Rows (r,) where every stratum's most likely cluster is the same hold (not "elsewhere").

    ``w`` (r, m) weights, ``code`` (r, m) label codes ``0 .. codes-1``; a stratum's clusters are summed over
    its own particles only.
    """
    r = w.shape[0]
    best = np.empty((len(strata), r), dtype=np.int64)
    for h, st in enumerate(strata):
        c, ww = code[:, st], w[:, st]
        sums = np.bincount((c + codes * np.arange(r)[:, None]).ravel(), weights=ww.ravel(), minlength=r * codes)
        best[h] = sums.reshape(r, codes).argmax(axis=1)
    return (best == best[0]).all(axis=0) & (best[0] != nowhere)


def _cluster_rows(
    w: np.ndarray, code: np.ndarray, pos: np.ndarray, psi: np.ndarray, codes: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The most likely cluster of every step: mean position (r, 3) [m], code (r,), probability (r,), mean yaw (r,) [rad].

    ``w`` (r, m) weights, ``code`` (r, m) labels as codes ``0 .. codes-1``, ``pos`` (r, m, 3), ``psi`` (r, m).
    Ties go to the lowest code.
    """
    r = w.shape[0]
    sums = np.bincount((code + codes * np.arange(r)[:, None]).ravel(), weights=w.ravel(), minlength=r * codes)
    sums = sums.reshape(r, codes)
    best = sums.argmax(axis=1)
    prob = sums[np.arange(r), best]
    ws = np.where(code == best[:, None], w, 0.0) / prob[:, None]
    return (ws[:, None, :] @ pos)[:, 0], best, prob, np.einsum("rm,rm->r", ws, psi)


class _Model:
    """Eq 17 per step k -> k+1: the displacement at zero yaw error and the noise factors."""

    def __init__(self, t: np.ndarray, v: np.ndarray, cov_v: np.ndarray, up: np.ndarray, yaw_psd: float) -> None:
        dt = np.diff(t)
        self.step = 0.5 * (v[1:] + v[:-1]) * dt[:, None]  # trapezoid = dT v + dT^2 a / 2 (eq 6)
        self.kstep = np.cross(up, self.step)  # up x step
        self.ustep = (self.step @ up)[:, None] * up  # component along up
        self.horiz = self.step - self.ustep  # component across up (what the yaw error turns)
        self.chol = np.linalg.cholesky(cov_v[:-1] + 1e-12 * np.eye(3)) * dt[:, None, None]  # e_p = dT n_v
        self.yaw_sigma = np.sqrt(yaw_psd * dt)

    def predict(self, k: int, pos: np.ndarray, psi: np.ndarray) -> np.ndarray:
        """Noise-free eq 17 for particles at k: ``pos + Rot_up(psi) step_k``."""
        c, s = np.cos(psi)[:, None], np.sin(psi)[:, None]
        return pos + self.step[k] * c + self.kstep[k] * s + self.ustep[k] * (1.0 - c)


def run_particle_filter(
    t: np.ndarray,
    v: np.ndarray,
    cov_v: np.ndarray,
    grip: np.ndarray,
    route_holds: tuple[np.ndarray, np.ndarray],
    start_holds: tuple[np.ndarray, np.ndarray],
    up: np.ndarray,
    wall_holds: tuple[np.ndarray, np.ndarray] | None = None,
    descent_time: float | None = None,
    params: PFParams | None = None,
    seed: int = 0,
    smooth: bool = True,
) -> PFResult:
    """Particle filter (and smoother) over position and yaw error, driven by transition velocities.

    Parameters
    ----------
    t : numpy.ndarray (n,)
        Sample times [s].
    v, cov_v : numpy.ndarray (n, 3), (n, 3, 3)
        Transition velocities [m/s] and their covariance [(m/s)^2] in the map frame.
    grip : numpy.ndarray of bool (n,)
        Detected grips.
    route_holds, wall_holds : (ids (h,), centres (h, 3) [m])
        Holds used during the ascent / after ``descent_time`` (all holds of the wall).
    start_holds : (ids (2,), centres (2, 3) [m])
    up : numpy.ndarray (3,)
        Map up axis (yaw is about it).
    descent_time : float, optional
        From this time [s] grips are matched against ``wall_holds``.
    params : PFParams, optional
    seed : int
        Seed of the generator for the process noise, the initial spread and the resampling.
    smooth : bool
        Also run the FFBSm smoother.
    """
    p = params or PFParams()
    n = t.size
    if not grip.any():
        raise InputError("no grips in the trial; the particle filter starts at the first grip (detect-events)")
    if p.particles < 2:
        raise InputError(f"{p.particles} particles; expected at least 2")
    rng = np.random.default_rng(seed)
    m = p.particles
    up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    k0 = int(np.argmax(grip))
    model = _Model(t, v, cov_v, up, p.yaw_psd)
    r_ids, r_pos = (np.asarray(a) for a in route_holds)
    w_ids, w_pos = (np.asarray(a) for a in (wall_holds or route_holds))
    s_ids, s_pos = (np.asarray(a) for a in start_holds)
    late = np.zeros(n, dtype=bool) if descent_time is None else t >= descent_time
    # labels are kept as codes 0, 1, ... of the sorted hold numbers (code 0: elsewhere, -1): one bincount
    # then sums the weights of every cluster of many steps at once
    table = unique(np.concatenate(([ELSEWHERE], r_ids, w_ids, s_ids)).astype(np.int64))
    r_code, w_code = np.searchsorted(table, r_ids), np.searchsorted(table, w_ids)
    nowhere = int(np.searchsorted(table, ELSEWHERE))

    which = np.arange(m) % s_ids.size
    pos = s_pos[which] + rng.normal(0.0, p.start_sigma, (m, 3))
    psi = rng.normal(0.0, p.start_yaw_sigma, m)
    lab = np.searchsorted(table, s_ids[which])
    lw = np.zeros(m)  # log weights (equal)
    # start hypotheses: the particles of each start hold form a stratum that is resampled on its own and
    # keeps its total weight (the hypothesis's evidence) until the strata's tracks merge
    split = p.separate_starts and unique(s_ids).size > 1
    strata: list = [np.flatnonzero(which == h) for h in range(s_ids.size)] if split else [slice(None)]
    counts = np.array([m // s_ids.size + (h < m % s_ids.size) for h in range(s_ids.size)]) if split else np.array([m])
    grip_end = grip & ~np.append(grip[1:], False)  # the last sample of every detected grip
    temper = None if p.grip_count is None else grip_weights(grip, p.grip_count)
    merged_at = -1 if split else k0
    start_ev = np.zeros(s_ids.size)
    pf_c = native()
    # the C path with the backward simulation keeps a block of the history at a time (module _pfblocks)
    blocked = pf_c is not None and (not smooth or (p.smoother == "backward" and n - 1 > k0))
    if not blocked:
        hist = np.empty((n, m, 4))  # per step and particle: position [m], yaw error [rad]
        hist_pos, hist_psi = hist[..., :3], hist[..., 3]
        hist_w = np.empty((n + 1, m))[1:]  # (a row in front for the C loop)
        hist_lab = np.empty((n, m), dtype=np.int64)
        anc = np.empty((n, m), dtype=np.int64)[: max(n - 1, 0)]  # anc[k, j]: particle at k that j at k+1 came from
        anc[:] = np.arange(m)
    out_pos = np.full((n, 3), np.nan)
    out_lab = np.full(n, -2, dtype=np.int64)
    out_prob = np.full(n, np.nan)
    out_yaw = np.full(n, np.nan)
    resamples = 0
    log_z = 0.0
    out_ev = np.full(n, np.nan)
    # all process noise up front: one draw, scaled per step, plus the step's along-up part; coordinates
    # first (nk, 3, m), so that the arithmetic below runs along the particles
    nk = max(n - 1 - k0, 0)
    if pf_c is None:
        normal_pos = rng.standard_normal((nk, m, 3))  # e_p = L_k n (plus the step's along-up part) below
        add_psi = rng.standard_normal((nk, m)) * model.yaw_sigma[k0 : n - 1, None]
    else:  # the same numbers, drawn a block of steps at a time when the C loop reaches it
        noise = _pfblocks.NoiseBlocks(rng, nk, m, model.yaw_sigma[k0 : n - 1], _pfblocks.BLOCK)
    u_res = rng.random(n)
    horiz = model.horiz
    grips = np.flatnonzero(grip)
    pos = np.ascontiguousarray(pos.T)
    # The filter runs over blocks of steps at once: eq 17 is a cumulative sum, the weights over a block's
    # grips a cumulative sum of log-likelihoods, up to the first grip whose effective sample size calls
    # for resampling (or where the start hypotheses merge); the block ends there and the next starts from
    # the resampled particles.  A block spans a number of grips: few after a resampling (the next often
    # follows soon), more and more after none.
    if pf_c is not None:  # the same loop, step by step in C (the numpy blocks below are its reference)
        out_code = np.empty(n, dtype=np.int64)
        c64 = np.ascontiguousarray
        lab0 = np.searchsorted(table, s_ids[which]).astype(np.int64)
        head = [
            n, m, k0, table.size, nowhere, len(strata), r_ids.size, w_ids.size,
            p.hold.radius, p.hold.sigma, p.hold.log_peak, p.hold.log_elsewhere, p.ess_fraction,
            c64(horiz) if n > 1 else np.zeros(3), c64(model.kstep) if n > 1 else np.zeros(3),
            noise.normal, c64(model.chol[k0 : n - 1]) if nk else np.zeros(9),
            c64(model.ustep) if n > 1 else np.zeros(3), noise.psi, u_res,
            grip.astype(np.int64), grip_end.astype(np.int64), late.astype(np.int64),
            None if temper is None else c64(temper, dtype=np.float64),
            c64(r_pos, dtype=np.float64), r_code.astype(np.int64),
            c64(w_pos, dtype=np.float64), w_code.astype(np.int64),
            c64(pos.T), c64(psi), lab0, which.astype(np.int64),
        ]  # fmt: skip
        tail = [
            out_pos, out_code, out_prob, out_yaw, out_ev, start_ev if len(strata) > 1 else np.zeros(1),
            np.empty(11 * m + table.size * (len(strata) + 1) + 5 * len(strata)),
            np.empty(6 * m + len(strata), dtype=np.int64),
        ]  # fmt: skip
        full = None if blocked else (hist[k0:], hist_w.base[k0:], hist_lab[k0:], anc.base[k0:])
        fwd = _pfblocks.ForwardC(pf_c, head, tail, noise, n, m, k0, full)
        merged_at, resamples = fwd.record()
        out_lab[k0:] = table[out_code[k0:]]
        if len(strata) > 1 and merged_at >= 0:
            strata = [slice(None)]
    else:
        add_pos = model.chol[k0 : n - 1] @ np.swapaxes(normal_pos, 1, 2)
        add_pos += model.ustep[k0 : n - 1, :, None]
        k, want = k0, 2
        while k < n:
            nxt = np.searchsorted(grips, k) + want - 1  # the block's last grip
            e = min(n, k + 2048, int(grips[nxt]) + 1 if nxt < grips.size else n)
            b0 = k - 1 if k > k0 else k0  # the particles carried in are those of step b0 (after resampling)
            js = slice(b0 - k0, e - 1 - k0)
            psi_rows = np.cumsum(np.concatenate((psi[None], add_psi[js])), axis=0)
            inc = add_pos[js] + horiz[b0 : e - 1, :, None] * np.cos(psi_rows[:-1])[:, None, :]
            inc += model.kstep[b0 : e - 1, :, None] * np.sin(psi_rows[:-1])[:, None, :]
            pos_rows = np.cumsum(np.concatenate((pos[None], inc)), axis=0)
            hist_pos[k:e] = np.swapaxes(pos_rows[k - b0 :], 1, 2)  # steps k..e-1 (those after a resampling are redone)
            hist_psi[k:e] = psi_rows[k - b0 :]
            g = grip[k:e]
            gi = np.flatnonzero(g)
            ll = np.empty((gi.size, m))
            lg = np.empty((gi.size + 1, m), dtype=np.int64)
            lg[0] = lab
            for after, centres, codes in ((False, r_pos, r_code), (True, w_pos, w_code)):
                sel = late[k:e][gi] == after
                if sel.any():
                    lr, cr = grip_log_likelihood(hist_pos[k + gi[sel]].reshape(-1, 3), centres, codes, p.hold)
                    ll[sel] = lr.reshape(-1, m)
                    lg[1:][sel] = np.where(cr == ELSEWHERE, nowhere, cr).reshape(-1, m)
            if temper is not None:
                ll *= temper[k + gi][:, None]
            lws = np.cumsum(np.concatenate((lw[None], ll)), axis=0)  # before the block's grips, after each
            top = lws.max(axis=1, keepdims=True)
            lws -= top
            lsum, ess = _strata_sums(lws, strata)  # per stratum and row
            log_sum = np.logaddexp.reduce(lsum, axis=0)  # of all weights, per row (relative to the row's largest)
            if len(strata) > 1:
                # each hypothesis's log evidence after every row: its weights' total (resampling keeps it)
                hyp_ev = start_ev[:, None] + (lsum + top.T) - (lsum[:, :1] + top[0])
                hyp_p = np.exp(hyp_ev - hyp_ev.max(axis=0))
                hyp_p /= hyp_p.sum(axis=0)
                wsw = np.empty_like(lws)  # normalised within each stratum
                for h, st in enumerate(strata):
                    wsw[:, st] = np.exp(lws[:, st] - lsum[h][:, None])
                ws = wsw * hyp_p.T[:, which]  # between the strata by hyp_p
            else:
                ws = wsw = np.exp(lws - log_sum[:, None])
            low = (ess[:, 1:] < p.ess_fraction * counts[:, None]).any(axis=0)
            stop_row = int(np.argmax(low)) + 1 if low.any() else gi.size + 1  # first row (1 + grip) to act on
            merge = False
            if len(strata) > 1:
                ends = np.flatnonzero(grip_end[k + gi[:stop_row]]) + 1
                same = _same_best_hold(wsw[ends], lg[ends], strata, table.size, nowhere)
                if same.any():
                    stop_row, merge = int(ends[np.argmax(same)]), True
            stop = e if stop_row > gi.size else k + int(gi[stop_row - 1]) + 1  # steps k..stop-1 are final
            rows = slice(k, stop)
            at = np.cumsum(g[: stop - k])  # per step: the block's grips so far = its row of ws, lg
            hist_w[rows], hist_lab[rows] = wsw[at], lg[at]  # split: within the strata (the smoother picks one)
            out_pos[rows], code, out_prob[rows], out_yaw[rows] = _cluster_rows(
                ws[at], hist_lab[rows], hist_pos[rows], hist_psi[rows], table.size
            )
            out_lab[rows] = table[code]
            last, r = stop - 1, int(at[-1])
            tot = top[:, 0] + log_sum
            out_ev[rows] = log_z + tot[at] - tot[0]
            log_z = float(out_ev[last])
            pos, psi, lab, lw = pos_rows[last - b0], hist_psi[last], hist_lab[last], lws[r]
            if len(strata) > 1:
                start_ev = hyp_ev[:, r]
            if merge or stop_row <= gi.size:
                idx = np.arange(m)
                lw = lw.copy()
                if merge:  # one track: the hypothesis with the larger evidence takes all particles
                    best = strata[int(np.argmax(hyp_ev[:, r]))]
                    idx = best[systematic_resample(_normalised(lws[r, best]), u_res[last], m)]
                    strata, counts, lw[:], merged_at = [slice(None)], np.array([m]), 0.0, last
                else:
                    for h, st in enumerate(strata):
                        if ess[h, r] < p.ess_fraction * counts[h]:
                            mem = np.arange(m)[st]
                            idx[mem] = mem[systematic_resample(_normalised(lws[r, mem]), u_res[last])]
                            lw[mem] = lsum[h, r] - np.log(counts[h])  # the stratum keeps its total weight
                if last < n - 1:
                    anc[last] = idx
                pos, psi, lab = pos[:, idx], psi[idx], lab[idx]
                resamples += 1
                want = 2
            else:
                want = min(4 * want, 64)
            k = stop
    normal_pos = add_psi = add_pos = None  # the process noise: the smoother does not need it
    res = PFResult(
        k0, out_pos, out_lab, out_prob, out_yaw, None, None, None, None, resamples, out_ev, merged_at, start_ev
    )
    if smooth:
        # the smoother follows the start hold with the larger evidence (up to the merge): the others' weights 0
        zero = (n if merged_at < 0 else merged_at + 1, which != int(np.argmax(start_ev))) if split else None
        if zero is not None and not blocked:
            hist_w[k0 : zero[0], zero[1]] = 0.0  # the winner's weights sum to 1
        if p.smoother not in ("ffbsm", "backward"):
            raise InputError(f"smoother {p.smoother!r} is not backward or ffbsm")
        sp = np.full((n, 3), np.nan)
        sl = np.full(n, -2, dtype=np.int64)
        sprob = np.full(n, np.nan)
        syaw = np.full(n, np.nan)
        rows = slice(k0, n)
        if blocked:
            # the same draws, tests and clusters in C: the trajectories' particles, then their clusters per step
            code = _pfblocks.smooth_blocks_c(fwd, model, k0, rng, p.smoother_moves, table.size, (sp, sprob, syaw), zero)
        else:
            if p.smoother == "ffbsm":
                ws = _ffbsm(hist_pos, hist_psi, hist_w, model, k0)
            else:
                ws = _backward(hist, hist_w, anc, model, k0, rng, p.smoother_moves)
            sp[rows], code, sprob[rows], syaw[rows] = _cluster_rows(
                ws[rows], hist_lab[rows], hist_pos[rows], hist_psi[rows], table.size
            )
        sl[rows] = table[code]
        res.smooth_pos, res.smooth_label, res.smooth_prob, res.smooth_yaw = sp, sl, sprob, syaw
    return res


def _backward(
    state: np.ndarray,
    w: np.ndarray,
    anc: np.ndarray,
    model: _Model,
    k0: int,
    rng: np.random.Generator,
    moves: int,
) -> np.ndarray:
    """Smoothed weights (n, m) by backward simulation (O(m) per step); rows before ``k0`` are zero.

    ``state`` (n, m, 4): the particles' positions [m] and yaw errors [rad].  The transition density of
    eq 17 in whitened coordinates, prepared for all steps at once:
    ``log f(j | i) = -|B_k(j) - A_k(i)|^2 / 2`` with ``A_k = L_k^-1 predict(x_k)`` and
    ``B_k = L_k^-1 p_k+1`` (position; yaw alike with its 1-sigma).
    """
    n, m = w.shape
    if n - 1 <= k0:
        return backward_simulation(w, anc, lambda k, i, j: np.zeros(i.size), rng, k0, 0)
    steps = np.stack((model.horiz, model.kstep, model.ustep), axis=1)  # (n-1, 3, 3)
    a = np.empty((n, m, 4))  # rows k0..n-2 are set (the others are never read)
    b = np.empty((n, m, 4))
    for c0 in range(k0, n - 1, 1024):  # in blocks of steps: the temporaries stay small
        sl = slice(c0, min(c0 + 1024, n - 1))
        nx = slice(c0 + 1, sl.stop + 1)
        whiten = np.zeros((sl.stop - c0, 4, 4))  # (p, psi) -> (L^-1 p, psi / sigma_psi), as row vectors
        whiten[:, :3, :3] = np.swapaxes(np.linalg.inv(model.chol[sl]), 1, 2)
        whiten[:, 3, 3] = 1.0 / model.yaw_sigma[sl]
        np.matmul(state[nx], whiten, out=b[sl])
        np.matmul(state[sl], whiten, out=a[sl])
        # eq 17 at zero noise adds horiz cos + kstep sin + ustep, whitened: (cos, sin, 1) @ (steps L^-T)
        rot = np.empty((sl.stop - c0, m, 3))
        np.cos(state[sl, :, 3], out=rot[..., 0])
        np.sin(state[sl, :, 3], out=rot[..., 1])
        rot[..., 2] = 1.0
        a[sl] += rot @ (steps[sl] @ whiten[:, :3, :])
    return backward_simulation_gaussian(w, anc, a, b, rng, k0, moves)


def _ffbsm(pos: np.ndarray, psi: np.ndarray, w: np.ndarray, model: _Model, k0: int) -> np.ndarray:
    """Smoothed weights (n, m) by FFBSm; rows before ``k0`` are left undefined.

    Per step the transition density is evaluated in whitened coordinates (centred on the
    particles at k+1, then float32) with one matrix product; buffers are reused.
    """
    n, m = w.shape
    ws = np.empty_like(w)
    ws[-1] = w[-1]
    big = np.empty((m, m), dtype=np.float32)
    col = np.empty(m, dtype=np.float32)
    a = np.empty((m, 4))
    b = np.empty((m, 4))
    for k in range(n - 2, k0 - 1, -1):
        linv = np.linalg.inv(model.chol[k])
        sy = 1.0 / model.yaw_sigma[k]
        centre = pos[k + 1].mean(axis=0)
        a[:, :3] = (model.predict(k, pos[k], psi[k]) - centre) @ linv.T
        b[:, :3] = (pos[k + 1] - centre) @ linv.T
        c_psi = psi[k + 1].mean()
        a[:, 3] = (psi[k] - c_psi) * sy
        b[:, 3] = (psi[k + 1] - c_psi) * sy
        a32, b32 = a.astype(np.float32), b.astype(np.float32)
        with np.errstate(divide="ignore"):
            rowterm = (np.log(w[k]) - 0.5 * (a * a).sum(axis=1)).astype(np.float32)
        np.matmul(a32, b32.T, out=big)  # log f(j | i) + log w_i = a.b - |a|^2/2 - |b|^2/2 + log w_i
        big += rowterm[:, None]
        big -= big.max(axis=0)[None, :]  # the |b|^2 term is constant per column: it cancels here
        np.maximum(big, np.float32(-60.0), out=big)  # exp's underflow path is ~10x slower
        np.exp(big, out=big)  # e_ij = w_i f(j | i) / max_l (w_l f(j | l))
        big.sum(axis=0, out=col)
        new = (big @ (ws[k + 1] / col).astype(np.float32)).astype(np.float64)
        total = new.sum()
        ws[k] = new / total if np.isfinite(total) and total > 0 else w[k]
    return ws
