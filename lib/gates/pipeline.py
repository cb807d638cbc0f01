"""``gate-anchor``: the paper's Figure 2 pipeline for the sacrum (EKS 1, relative anchors, matching, EKS 2).

1. Orientation: the session's ``q0..q3`` when present, else strap-down with drift correction
   (:mod:`sportfusion.gates.inertial`); gravity-removed acceleration in the global frame.
2. EKS 1 (:func:`sportfusion.gates.eks.run_eks`): acceleration + zero-velocity updates at the static start
   and finish.
3. Relative anchor points at the detected crossings and their matching to the survey.  With the
   magnetometer, each crossing's offset to its magnet comes from a fit of the whole pass's field
   (:func:`~sportfusion.gates.passfit.fit_crossings`: no sacrum height, no lean, any polarity or
   tilt); without it (or where the fit fails) from the peak model (:func:`relative_anchors`, eqs 2-6,
   vertical direction).  Matching: PCA azimuth ``alpha`` (:func:`match_anchors`, eqs 7-9), then the
   crossings aligned with the gates as one sequence by their inertial displacements
   (:mod:`sportfusion.gates.alignment`; the paper's neighbour features mislead after a run of missed
   gates), ``alpha`` refined on the matched pairs, median offset ``o``.
4. EKS 2, first iteration: the matched anchors (surveyed point minus the offset, in the inertial frame
   through ``alpha, o``) as position updates with 1 m sigma; the relative anchors are re-estimated on the
   refined track and aligned again; the passes fitted again with the refined velocity; second iteration
   with each fit's covariance (plus ``sigma_fit``), 0.1 m for the peak model (the paper's), ``sigma_unfitted``
   for a crossing whose fit failed.  ``anchors_every`` keeps only every K-th gate's anchor (the paper's
   simulated downhill: K = 3).
5. The check (:mod:`sportfusion.gates.checks`): the matched share, crossings off every gate on the final
   track, anchors that contradict it; doubtful -> a warning and ``std_`` widened, lost -> refused.

Output in the survey's frame (the session's local frame): the sacrum's x y z, vx vy vz with ``std_``
columns, the matched gate per crossing and the per-turn figures of the paper (Table 2): entrance and exit
speed at the turn switches, distances from the switches and at the crossing to the gate, path length of
the turn.  With one sacrum sensor we output the sacrum (the paper's LJC, ``p_sacr = p_ljc``); on a session
with the columns of ``body-model`` also the paper's output, the absolute CoM, with the peak model's snow
plane from the ski contact points and the turn figures from the CoM (:mod:`sportfusion.gates.com`).

Turn switches: the paper uses equal left/right ankle distances to the CoM (a full-body criterion, used with a
body); with the sacrum alone a switch is the sign change of the course rate (the turning of the horizontal velocity)
between two consecutive crossings, the one nearest the middle of the interval.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.gaps import describe_gaps
from sportfusion.core.rotations import euler_from_quat
from sportfusion.gates.alignment import AlignParams, align_crossings, align_with_azimuth
from sportfusion.gates.anchors import (
    MatchParams,
    match_anchors,
    relative_anchors,
    rotate_z,
    sacrum_height,
    snow_normals,
    survey_sides,
)
from sportfusion.gates.checks import CheckParams, check_matching, widen_std
from sportfusion.gates.com import (
    SIGMA_REL_COM,
    SIGMA_REL_VCOM,
    Body,
    absolute_com,
    ankle_switch_signal,
    body_anchors,
    has_body,
    read_body,
    snow_planes,
    turn_sides,
)
from sportfusion.gates.eks import Anchor, EKSParams, decimate, run_eks
from sportfusion.gates.inertial import global_acceleration, static_gravity, static_windows, strapdown
from sportfusion.gates.passfit import PassFit, PassFitParams, fit_crossings
from sportfusion.gates.turns import turn_figures


@dataclass(frozen=True)
class GateAnchorParams:
    """Options of :func:`gate_anchor_arrays` (units in brackets).

    Attributes
    ----------
    rate : float
        Smoother rate [Hz] (the IMU's acceleration is averaged down to it).
    sigma_first, sigma_second : float
        Anchor 1-sigma of the first and second EKS-2 iteration [m] (paper: 1 and 0.1).
    anchors_every : int
        Use only every K-th gate as an anchor (gates 1, 1+K, ...) [count].
    sacrum_height : float
        Sacrum height above the snow at zero lean [m] (body model: ``h = H0 cos(roll)``).
    burial : float
        Depth of the magnets below the snow [m].
    projection : {"vertical", "normal"}
        Direction from the sacrum down to the magnet's plane: ``"normal"`` is the paper's (eq 6: along the
        snow-plane normal, the crossing taken as the closest approach); ``"vertical"`` (default) follows the
        physics of the detector: the peak of ``|B|`` of a vertical dipole comes when the sensor is above the
        magnet, which on a 12 deg slope is about 0.1 m before the closest approach (measured on the
        simulator: position error 0.16 -> 0.08 m on one run).
    static_height : float
        Sacrum height above the snow in the static upright posture at the start and finish [m], vertically
        above the surveyed mark (used with surveyed static spots only).
    sigma_spot : float
        1-sigma of a surveyed static spot as an anchor of the sacrum [m] (posture and stance on the mark).
    survey_depth : float
        Depth of a magnet's centre below its surveyed point [m]: 0 when the survey gives the magnets
        themselves (the paper's assumption), about 0.1 when it gives the snow above a fully buried 15 cm
        stick; the default takes the middle, so either convention is off by 5 cm at most.
    pass_fit : bool
        Place each anchor by a fit of the whole pass (:mod:`sportfusion.gates.passfit`) when the session has
        the magnetometer; False: from the peak intensity and the body model alone (the paper's eqs 1-6).
    fit : PassFitParams
        The pass fit's settings.
    sigma_fit : float
        Added in quadrature to each axis of a pass fit's covariance in the final iteration [m] (survey noise,
        the magnet model's simplifications).
    sigma_unfitted : float
        1-sigma of a final-iteration anchor whose pass could not be fitted (little signal: a wide or weak
        pass), which only the peak model places [m].
    """

    rate: float = 100.0
    sigma_first: float = 1.0
    sigma_second: float = 0.1
    anchors_every: int = 1
    sacrum_height: float = 0.95
    burial: float = 0.05
    projection: str = "vertical"
    static_height: float = 1.0
    sigma_spot: float = 0.05
    survey_depth: float = 0.05
    pass_fit: bool = True
    fit: PassFitParams = field(default_factory=PassFitParams)
    sigma_fit: float = 0.05
    sigma_unfitted: float = 0.3
    eks: EKSParams = field(default_factory=EKSParams)
    match: MatchParams = field(default_factory=MatchParams)
    align: AlignParams = field(default_factory=AlignParams)
    check: CheckParams = field(default_factory=CheckParams)


@dataclass
class GateAnchorResult:
    """Everything :func:`gate_anchor_arrays` estimates (survey frame unless said otherwise)."""

    t: np.ndarray  # smoother steps [s]
    pos: np.ndarray  # (N, 3) [m]
    vel: np.ndarray  # (N, 3) [m/s]
    std_pos: np.ndarray
    std_vel: np.ndarray
    acc: np.ndarray  # smoothed acceleration (N, 3) [m/s^2]
    pos_inertial: np.ndarray  # EKS 1 (no anchors) in the survey frame through the matching [m]
    vel_inertial: np.ndarray
    ids: np.ndarray  # survey row per crossing, -1 unmatched
    used: np.ndarray  # bool per crossing: used as an anchor in the final pass
    alpha: float
    offset: np.ndarray
    turns: list[dict[str, Any]]
    passes: dict[str, Any]
    fits: list[PassFit] | None = None  # the pass fit of each crossing (with a magnetometer)
    com: np.ndarray | None = None  # absolute CoM (N, 3) [m], with a body
    vcom: np.ndarray | None = None  # its velocity (N, 3) [m/s]


def _interp(tg: np.ndarray, x: np.ndarray, tq: np.ndarray) -> np.ndarray:
    return np.stack([np.interp(tq, tg, x[:, j]) for j in range(x.shape[1])], axis=-1)


def _body_peak_offsets(
    tg: np.ndarray,
    track: np.ndarray,
    vel: np.ndarray,
    cross: dict[str, np.ndarray],
    normal: np.ndarray | None,
    p: GateAnchorParams,
    body: Body | None,
) -> np.ndarray | None:
    """The peak model's sensor -> magnet offsets (M, 3) with a body (eqs 2-6, :mod:`sportfusion.gates.com`):
    the snow plane fitted to the ski contact points (``normal`` replaces its normal where given and finite);
    None without a body (then :func:`relative_anchors` with the sacrum height)."""
    if body is None:
        return None
    pc = _interp(tg, track, cross["t"])
    vc = _interp(tg, vel, cross["t"])
    n, pts = snow_planes(tg, track, body, cross["t"])
    if normal is not None:
        have = np.isfinite(normal).all(axis=1)
        n[have] = normal[have]
    out = relative_anchors(pc, vc, cross["distance"], cross["side"], cross["height"], None, p.burial)
    ok = np.isfinite(pts).all(axis=1)
    if ok.any() and p.projection == "normal":
        out[ok] = relative_anchors(
            pc[ok], vc[ok], cross["distance"][ok], cross["side"][ok], cross["height"][ok], n[ok], p.burial, pts[ok]
        )
    elif ok.any():
        out[ok] = body_anchors(pc[ok], vc[ok], cross["distance"][ok], cross["side"][ok], n[ok], pts[ok], p.burial)
    return out - pc


def _anchor_updates(
    tg: np.ndarray,
    track: np.ndarray,
    vel: np.ndarray,
    cross: dict[str, np.ndarray],
    ids: np.ndarray,
    survey: np.ndarray,
    alpha: float,
    offset: np.ndarray,
    sigma: float,
    p: GateAnchorParams,
    fits: list[PassFit] | None = None,
    final: bool = False,
    body: Body | None = None,
) -> tuple[list[Anchor], np.ndarray]:
    """Anchor updates in the inertial frame: surveyed point (through alpha, offset) minus the sensor -> surveyed
    point offset (a pass fit's where there is one, else the peak model's).  In the ``final`` iteration a
    fitted anchor carries its fit's covariance (plus ``sigma_fit``), an unfitted one ``sigma_unfitted``."""
    pc = _interp(tg, track, cross["t"])
    vc = _interp(tg, vel, cross["t"])
    normal_s, _ = snow_normals(survey, ids)
    normal_j = rotate_z(normal_s, -alpha) if p.projection == "normal" else None
    peak = _body_peak_offsets(tg, track, vel, cross, normal_j, p, body)
    rel = _survey_offsets(pc, vc, cross, normal_j, p, fits, peak)
    used = (ids >= 0) & (np.maximum(ids, 0) % p.anchors_every == 0)
    out = []
    for m in np.flatnonzero(used):
        g_j = rotate_z(survey[ids[m]] - offset, -alpha)
        k = int(np.clip(np.rint((cross["t"][m] - tg[0]) / (tg[1] - tg[0])), 0, tg.size - 1))
        # the crossing time falls between steps: move the measured point along the velocity to step k
        z = g_j - rel[m] + vc[m] * (tg[k] - cross["t"][m])
        if final and fits is not None:
            f = fits[m]
            if f.ok:
                out.append(Anchor(k, z, sigma, cov=f.cov + np.eye(3) * p.sigma_fit**2))
                continue
            out.append(Anchor(k, z, max(sigma, p.sigma_unfitted)))
            continue
        out.append(Anchor(k, z, sigma))
    return out, used


def _survey_offsets(
    pc: np.ndarray,
    vc: np.ndarray,
    cross: dict[str, np.ndarray],
    normal: np.ndarray | None,
    p: GateAnchorParams,
    fits: list[PassFit] | None,
    peak: np.ndarray | None = None,
) -> np.ndarray:
    """Offset (M, 3) from the sensor at each crossing to the magnet's surveyed point, inertial frame (z down):
    the pass fit's magnet centre where it succeeded, else the peak model's (eqs 2-6; ``peak`` when given, a
    body's), raised by ``survey_depth``."""
    if peak is not None:
        rel = np.array(peak, float)
    else:
        rel = relative_anchors(pc, vc, cross["distance"], cross["side"], cross["height"], normal, p.burial) - pc
    if fits is not None:
        for m, f in enumerate(fits):
            if f.ok:
                rel[m] = f.rel
    rel[:, 2] -= p.survey_depth
    return rel


def _spot_anchors(
    tg: np.ndarray,
    windows: dict[str, tuple[float, float]],
    spots: dict[str, np.ndarray],
    survey: np.ndarray,
    alpha: float,
    offset: np.ndarray,
    p: GateAnchorParams,
) -> list[Anchor]:
    """Anchors of the static postures on surveyed spots: the sacrum ``static_height`` vertically above the mark
    (standing still, the body balances its centre of mass over the feet), at the middle step of the static
    window (the zero-velocity updates hold it there)."""
    out = []
    for name, spot in spots.items():
        if name not in windows:
            continue
        a, b = windows[name]
        k = int(np.clip(np.searchsorted(tg, 0.5 * (a + b)), 0, tg.size - 1))
        sacrum = spot - np.array([0.0, 0.0, p.static_height])  # z down
        out.append(Anchor(k, rotate_z(sacrum - offset, -alpha), p.sigma_spot))
    return out


def _detected_anchors(
    tg: np.ndarray,
    track: np.ndarray,
    vel: np.ndarray,
    cross: dict[str, np.ndarray],
    normal: np.ndarray | None,
    p: GateAnchorParams,
    fits: list[PassFit] | None = None,
    body: Body | None = None,
) -> np.ndarray:
    pc = _interp(tg, track, cross["t"])
    vc = _interp(tg, vel, cross["t"])
    peak = _body_peak_offsets(tg, track, vel, cross, normal, p, body)
    return pc + _survey_offsets(pc, vc, cross, normal, p, fits, peak)


def gate_anchor_arrays(
    t: np.ndarray,
    acc: np.ndarray,
    gyr: np.ndarray,
    g: float,
    cross_t: np.ndarray,
    cross_distance: np.ndarray,
    cross_side: np.ndarray,
    survey: np.ndarray,
    survey_side: np.ndarray | None = None,
    gate_numbers: np.ndarray | None = None,
    q_bj: np.ndarray | None = None,
    params: GateAnchorParams | None = None,
    spots: dict[str, np.ndarray] | None = None,
    mag: tuple[np.ndarray, np.ndarray] | None = None,
    body: Body | None = None,
    still: list[tuple[float, float]] | None = None,
) -> GateAnchorResult:
    """The gate-anchor pipeline on arrays (see the module text).

    Parameters
    ----------
    t : ndarray (n,)
        IMU times [s].
    acc, gyr : ndarray (n, 3)
        Specific force [m/s^2] and angular rate [rad/s], body frame.
    g : float
        Gravity [m/s^2].
    cross_t, cross_distance, cross_side : ndarray (M,)
        Detected crossings: time [s], distance to the magnet [m], side (+1 R, -1 L).
    survey : ndarray (N, 3)
        Surveyed magnets in the output frame, in gate order [m].
    survey_side : ndarray (N,), optional
        Turn side per gate (default: from the geometry).
    gate_numbers : ndarray (N,), optional
        Gate numbers of the survey rows (default 1..N).
    q_bj : ndarray (n, 4), optional
        Attitude (global -> body, scalar first); default strap-down with drift correction.
    params : GateAnchorParams, optional
    spots : dict, optional
        Surveyed static spots in the output frame [m]: ``{"start": (3,), "finish": (3,)}``, the snow points
        where the athlete stands for the static postures; each anchors the sacrum during its posture (EKS 2).
    mag : tuple, optional
        Magnetometer times [s] (k,) and field (k, 3), body frame [uT or normalised]: each crossing's offset to
        its magnet then comes from a fit of the whole pass (:func:`fit_crossings`) instead of the peak model.
    body : Body, optional
        The body model's columns (:mod:`sportfusion.gates.com`): the peak model's snow plane from the ski
        contact points, turn switches from the ankles, the absolute CoM; ``q_bj`` is then the body model's
        pelvis sensor attitude.
    still : list of (float, float), optional
        Further still periods [s] (zero-velocity updates), e.g. the body model's.

    Returns
    -------
    GateAnchorResult
    """
    p = params or GateAnchorParams()
    spots = {k: np.asarray(v, float) for k, v in (spots or {}).items()}
    survey = np.asarray(survey, float)
    if survey.shape[0] < 3:
        raise InputError(f"the gate survey has {survey.shape[0]} gate(s); gate-anchor needs at least 3")
    if cross_t.size < 3:
        raise InputError(f"{cross_t.size} gate crossing(s) in the session; gate-anchor needs at least 3")
    gate_numbers = np.arange(1, survey.shape[0] + 1) if gate_numbers is None else np.asarray(gate_numbers)
    static = static_windows(t, acc, gyr)
    q = strapdown(t, acc, gyr, static) if q_bj is None else q_bj
    a_glob = global_acceleration(q, acc, static_gravity(t, acc, static))
    roll = euler_from_quat(q)[0]
    cross = {
        "t": np.asarray(cross_t, float),
        "distance": np.asarray(cross_distance, float),
        "side": np.asarray(cross_side, float),
        "height": sacrum_height(np.interp(cross_t, t, roll), p.sacrum_height),
    }
    tg, ag = decimate(t, a_glob, p.rate)
    wg = decimate(t, np.linalg.norm(gyr, axis=1)[:, None], p.rate)[1][:, 0]
    windows = {
        "start": (float(t[static.start[0]]), float(t[static.start[1] - 1])),
        "finish": (float(t[static.finish[0]]), float(t[static.finish[1] - 1])),
    }
    zupt = np.zeros(tg.size, bool)
    for a, b in list(windows.values()) + list(still or []):
        zupt |= (tg >= a) & (tg <= b)
    # EKS 1: inertial only
    r1 = run_eks(tg, ag, g, zupt, None, p.eks, rot_rate=wg)
    p1, v1 = r1.x_smooth[:, 0:3], r1.x_smooth[:, 3:6]
    fits = None
    if mag is not None:
        guess = _detected_anchors(tg, p1, v1, cross, None, p, None, body) - _interp(tg, p1, cross["t"])
        guess[:, 2] += p.survey_depth
        fits = fit_crossings(t, q, mag[0], mag[1], tg, v1, r1.x_smooth[:, 6:9], cross, guess, p.fit)
    det1 = _detected_anchors(tg, p1, v1, cross, None, p, fits, body)
    m1 = match_anchors(cross["t"], det1, cross["side"], survey, survey_side, p.match)
    ssd = survey_sides(survey) if survey_side is None else np.asarray(survey_side, float)
    ids, alpha, offset = align_with_azimuth(cross["t"], det1, cross["side"], survey, ssd, m1.alpha, p.align)
    if (ids >= 0).sum() < 2:
        raise InputError("fewer than 2 crossings could be matched to the survey; is it the right course?")
    # EKS 2, first iteration (anchor sigma 1 m); relative anchors re-estimated on the refined track (snow
    # plane from the survey) and matched again, already in the survey's azimuth (alpha fixed).  While the
    # re-matching adds matches (a large EKS-1 drift leaves few first matches) the first iteration is repeated
    # (at most 3 times; the paper runs it once).
    ids_first = ids
    track, vel = p1, v1
    normal_s, _ = snow_normals(survey, ids)
    for _ in range(3):
        an1, _ = _anchor_updates(tg, track, vel, cross, ids, survey, alpha, offset, p.sigma_first, p, fits, body=body)
        an1 += _spot_anchors(tg, windows, spots, survey, alpha, offset, p)
        r2 = run_eks(tg, ag, g, zupt, an1, p.eks, rot_rate=wg)
        track, vel = r2.x_smooth[:, 0:3] + r2.x_smooth[:, 9:12], r2.x_smooth[:, 3:6]
        normal_s, _ = snow_normals(survey, ids)
        det2 = _detected_anchors(
            tg, track, vel, cross, rotate_z(normal_s, -alpha) if p.projection == "normal" else None, p, fits, body
        )
        ids2 = align_crossings(cross["t"], rotate_z(det2, alpha) + offset, cross["side"], survey, ssd, p.align)
        grew = (ids2 >= 0).sum() > (ids >= 0).sum() + 1
        if (ids2 >= 0).sum() >= 2:
            ids = ids2
        if not grew:
            break
    track2, v2 = track, vel
    if fits is not None:  # the passes again, with the velocity of the anchored track
        guess = np.array([f.rel if f.ok else g for f, g in zip(fits, guess, strict=True)])
        fits = fit_crossings(t, q, mag[0], mag[1], tg, v2, r2.x_smooth[:, 6:9], cross, guess, p.fit)
    # EKS 2, second iteration (anchor sigma 0.1 m; a pass fit's covariance)
    an2, used = _anchor_updates(tg, track2, v2, cross, ids, survey, alpha, offset, p.sigma_second, p, fits, True, body)
    an2 += _spot_anchors(tg, windows, spots, survey, alpha, offset, p)
    r3 = run_eks(tg, ag, g, zupt, an2, p.eks, rot_rate=wg)
    xs, Ps = r3.x_smooth, r3.P_smooth
    pos_j = xs[:, 0:3] + xs[:, 9:12]
    cov_j = Ps[:, 0:3, 0:3] + Ps[:, 9:12, 9:12] + Ps[:, 0:3, 9:12] + Ps[:, 9:12, 0:3]
    c, s = np.cos(alpha), np.sin(alpha)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    cov_p = R @ cov_j @ R.T
    cov_v = R @ Ps[:, 3:6, 3:6] @ R.T
    pos = rotate_z(pos_j, alpha) + offset
    vel = rotate_z(xs[:, 3:6], alpha)
    # never silently wrong (:mod:`sportfusion.gates.checks`): every crossing's anchor on the final track, the
    # final anchors' post-fit residuals against their sigmas (anchor and track)
    det3 = rotate_z(_detected_anchors(tg, pos_j, xs[:, 3:6], cross, None, p, fits, body), alpha) + offset
    cov_a = [an.cov if an.cov is not None else np.eye(3) * an.sigma**2 for an in an2]
    res_a = [np.linalg.norm(an.z - pos_j[an.k]) for an in an2]
    sig_a = [np.sqrt(np.trace(c + cov_j[an.k])) for an, c in zip(an2, cov_a, strict=True)]
    chk = check_matching(ids, det3, cross["side"], survey, ssd, np.array(res_a), np.array(sig_a), p.check)
    if chk.hopeless:
        raise InputError(
            f"the detected crossings do not fit the gate survey: {chk.message}; an anchored track could be off by "
            "tens of metres (is it the right course, in gate order? are the crossings gate passes? is there motion "
            "other than the run between the static start and finish, e.g. a calibration, that only body-model knows?)"
        )
    accs = rotate_z(xs[:, 6:9], alpha)
    com = vcom = None
    if body is not None:  # the paper's output: the CoM, and the turn figures from it
        com, vcom = absolute_com(tg, pos, alpha, body)
        sig = ankle_switch_signal(tg, body)
        turns = turn_figures(tg, com, vcom, accs, cross["t"], ids, survey, gate_numbers, signal=sig)
    else:
        turns = turn_figures(tg, pos, vel, accs, cross["t"], ids, survey, gate_numbers)
    passes = {
        "rate_hz": p.rate,
        "matched_first": int((ids_first >= 0).sum()),
        "matched_final": int((ids >= 0).sum()),
        "anchors_final": len(an2),
        "static_spots": [k for k in ("start", "finish") if k in spots],
        "alpha_deg": float(np.rad2deg(alpha)),
        "offset_m": [float(v) for v in offset],
        "drift_angles_deg": [float(v) for v in np.rad2deg(xs[-1, 12:15])],
        "anchor_rms_m": float(np.sqrt(np.nanmean(r3.residuals["anchor"] ** 2))) if "anchor" in r3.residuals else None,
    }
    std_pos = np.sqrt(np.maximum(np.diagonal(cov_p, axis1=1, axis2=2), 0))
    std_vel = np.sqrt(np.maximum(np.diagonal(cov_v, axis1=1, axis2=2), 0))
    passes["check"] = {"doubtful": chk.doubtful, "unexplained": chk.n_far, "residual_ratio": chk.ratio}
    if chk.doubtful:  # the anchored or the inertial track may be the right one: std_ covers both
        std_pos = widen_std(std_pos, pos, rotate_z(p1, alpha) + offset)
        std_vel = widen_std(std_vel, vel, rotate_z(v1, alpha))
        passes["warnings"] = [
            f"the matching of crossings to gates is doubtful: {chk.message}; std_ columns widened "
            "to the difference between the anchored and the inertial track"
        ]
    return GateAnchorResult(
        t=tg,
        pos=pos,
        vel=vel,
        std_pos=std_pos,
        std_vel=std_vel,
        acc=accs,
        pos_inertial=rotate_z(p1, alpha) + offset,
        vel_inertial=rotate_z(v1, alpha),
        ids=ids,
        used=used,
        alpha=float(alpha),
        offset=offset,
        turns=turns,
        passes=passes,
        fits=fits,
        com=com,
        vcom=vcom,
    )


# --------------------------------------------------------------------------- tables
def survey_in_frame(survey: Any, survey_meta: dict[str, Any], frame: Any) -> tuple[np.ndarray, Any]:
    """Surveyed magnets as an (N, 3) array in ``frame`` (a :class:`sportfusion.core.frames.Frame` or None).

    A WGS84 survey (``lat lon h``) is converted into ``frame`` (or, without one, into a frame at the first
    gate with azimuth 0, which is returned); a local survey (``x y z``) in another declared frame is
    converted through WGS84; a local survey without a frame is taken to be in ``frame``.
    """
    from sportfusion.core import schema
    from sportfusion.core.frames import Frame

    names = survey.column_names
    sf = Frame.from_meta(survey_meta["frame"]) if survey_meta.get("frame") else None
    if all(c in names for c in ("x", "y", "z")):
        xyz = schema.float_columns(survey, ("x", "y", "z"))
        if frame is not None and sf is not None and (sf.origin != frame.origin or sf.azimuth_deg != frame.azimuth_deg):
            lat, lon, h = sf.to_geodetic(xyz[:, 0], xyz[:, 1], xyz[:, 2])
            xyz = np.column_stack(frame.from_geodetic(lat, lon, h))
        return xyz, frame if frame is not None else sf
    if all(c in names for c in ("lat", "lon", "h")):
        lat, lon, h = (schema.floats(survey, c) for c in ("lat", "lon", "h"))
        if frame is None:
            frame = Frame(float(lat[0]), float(lon[0]), float(h[0]), 0.0, "gates")
        return np.column_stack(frame.from_geodetic(lat, lon, h)), frame
    raise InputError("the gate survey has neither x, y, z nor lat, lon, h columns; expected one of them")


def gate_anchor_table(
    table: Any,
    meta: dict[str, Any],
    survey: Any | None,
    survey_meta: dict[str, Any] | None,
    params: GateAnchorParams | None = None,
) -> tuple[Any, dict[str, Any], str]:
    """:func:`gate_anchor_arrays` on a session table with detected crossings and a ``gates`` survey table.

    Returns the table with ``x y z vx vy vz`` and their ``std_`` columns on every row (interpolated from the
    smoother steps), and at the crossing rows ``gate`` (matched gate number, -1 unmatched),
    ``gate_anchor`` (used as an anchor), ``turn_v_in turn_v_out turn_d_in turn_d_out turn_d_cross
    turn_length``; the metadata gets a ``gate_anchor`` entry (passes, matching, per-turn figures).
    """
    from sportfusion.core import schema
    from sportfusion.core.frames import Frame
    from sportfusion.core.gravity import G_STANDARD, normal_gravity
    from sportfusion.core.rotations import quat_multiply
    from sportfusion.core.session import with_columns
    from sportfusion.gates.crossings import read_crossings

    p = params or GateAnchorParams()
    schema.require_columns(table, ("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"), "gate-anchor")
    cr = read_crossings(table)
    if cr["t"].size == 0:
        raise InputError("no gate crossings in the session (event 'gate'); run detect-events --kind gates first")
    if survey is None:
        raise InputError(f"{cr['t'].size} gate crossings but no gate survey; give --gates FILE (a gates table)")
    from sportfusion.core.io import survey_points

    survey, spot_rows = survey_points(survey)
    if survey.num_rows < 3:
        raise InputError(f"the gate survey has {survey.num_rows} gate(s); gate-anchor needs at least 3")
    frame = Frame.from_meta(meta["frame"]) if meta.get("frame") else None
    xyz, frame = survey_in_frame(survey, survey_meta or {}, frame)
    spots: dict[str, np.ndarray] = {}
    if spot_rows is not None:
        sxyz, _ = survey_in_frame(spot_rows, survey_meta or {}, frame)
        names = [str(v).strip().lower() for v in spot_rows.column("point").to_pylist()]
        spots = dict(zip(names, sxyz, strict=True))
    order = np.argsort(schema.floats(survey, "gate"), kind="stable")
    xyz = xyz[order]
    numbers = np.asarray(schema.floats(survey, "gate"), dtype=int)[order]
    sides = None
    if "turn" in survey.column_names:
        tv = [survey.column("turn").to_pylist()[i] for i in order]
        if all(v in ("L", "R") for v in tv):
            sides = np.array([1.0 if v == "R" else -1.0 for v in tv])
    t = schema.floats(table, "t")
    acc = schema.float_columns(table, ("acc_x", "acc_y", "acc_z"))
    gyr = schema.float_columns(table, ("gyr_x", "gyr_y", "gyr_z"))
    imu = np.isfinite(acc).all(axis=1) & np.isfinite(gyr).all(axis=1)
    if imu.sum() < 100:
        raise InputError(f"{int(imu.sum())} rows with acc_* and gyr_*; expected an IMU recording")
    q = None
    body = None
    still: list[tuple[float, float]] = []
    if has_body(table.column_names):
        body = read_body(table, meta, np.flatnonzero(imu))
        q = body.q_sensor
        if not np.isfinite(q).all():
            raise InputError("the body model's pelvis orientation has gaps on the IMU rows; rerun body-model")
        still = [(float(a), float(b)) for a, b in (meta.get("body_model") or {}).get("still_periods_s", [])]
        cr["turn"] = turn_sides(body, cr["t"])
    elif all(f"q{i}" in table.column_names for i in range(4)):
        qn = schema.float_columns(table, [f"q{i}" for i in range(4)])[imu]
        if np.isfinite(qn).all():
            az = np.deg2rad(frame.azimuth_deg if frame is not None else 0.0)
            qz = np.array([np.cos(-az / 2), 0.0, 0.0, np.sin(-az / 2)])  # NED -> local
            q = quat_multiply(qz, qn)
    g = normal_gravity(frame.lat, frame.h) if frame is not None else G_STANDARD
    dist = np.where(np.isfinite(cr["distance"]), cr["distance"], np.nan)
    mag = None
    if p.pass_fit and all(c in table.column_names for c in ("mag_x", "mag_y", "mag_z")):
        m3 = schema.float_columns(table, ("mag_x", "mag_y", "mag_z"))
        okm = np.isfinite(m3).all(axis=1)
        mag = (t[okm], m3[okm]) if okm.sum() > 10 else None
    from sportfusion.estimators.kalman import CovarianceError

    try:
        res = gate_anchor_arrays(
            t[imu], acc[imu], gyr[imu], g, cr["t"], dist, cr["turn"], xyz, sides, numbers, q, p, spots, mag, body, still
        )
    except CovarianceError as exc:
        raise InputError(f"the smoother failed: {exc}") from exc
    cols: dict[str, Any] = {}
    for i, a in enumerate("xyz"):
        cols[a] = np.interp(t, res.t, res.pos[:, i])
        cols[f"v{a}"] = np.interp(t, res.t, res.vel[:, i])
        cols[f"std_{a}"] = np.interp(t, res.t, res.std_pos[:, i])
        cols[f"std_v{a}"] = np.interp(t, res.t, res.std_vel[:, i])
    if res.com is not None and res.vcom is not None:
        for i, a in enumerate("xyz"):
            cols[f"com_{a}"] = np.interp(t, res.t, res.com[:, i])
            cols[f"com_v{a}"] = np.interp(t, res.t, res.vcom[:, i])
            cols[f"std_com_{a}"] = np.sqrt(cols[f"std_{a}"] ** 2 + SIGMA_REL_COM**2)
            cols[f"std_com_v{a}"] = np.sqrt(cols[f"std_v{a}"] ** 2 + SIGMA_REL_VCOM**2)
    n = t.size
    gate: list[int | None] = [None] * n
    used: list[bool | None] = [None] * n
    figs = {
        k: [None] * n for k in ("turn_v_in", "turn_v_out", "turn_d_in", "turn_d_out", "turn_d_cross", "turn_length")
    }
    by_t = {round(tr["t_cross"], 9): tr for tr in res.turns}
    for m, row in enumerate(cr["row"]):
        gate[row] = int(numbers[res.ids[m]]) if res.ids[m] >= 0 else -1
        used[row] = bool(res.used[m])
        tr = by_t.get(round(float(cr["t"][m]), 9))
        if tr is not None:
            for k, key in (
                ("turn_v_in", "v_in"),
                ("turn_v_out", "v_out"),
                ("turn_d_in", "d_in"),
                ("turn_d_out", "d_out"),
                ("turn_d_cross", "d_cross"),
                ("turn_length", "length"),
            ):
                figs[k][row] = tr[key]
    import pyarrow as pa

    cols["gate"] = pa.array(gate, pa.int32())
    cols["gate_anchor"] = pa.array(used, pa.bool_())
    for k, v in figs.items():
        cols[k] = pa.array(v, pa.float64())
    out = with_columns(table, cols)
    meta = dict(meta)
    if frame is not None and not meta.get("frame"):
        meta["frame"] = frame.to_meta()
    meta["gate_anchor"] = {
        "method": "gates paper Figure 2 (sacrum): strap-down, EKS 1, relative anchors, matching, EKS 2 (1 m, 0.1 m)",
        "attitude": "body model (pelvis)"
        if body is not None
        else "session q0..q3"
        if q is not None
        else "strap-down with drift correction",
        "com": "the sensor's track + its lever arm to the LJC + body model's relative CoM, three-point speed, "
        "Butterworth 2nd order 5 Hz zero phase; turn figures from the CoM, switches from the ankles"
        if body is not None
        else None,
        "anchors": "pass fit (bar magnet) where it converged, else the peak model"
        if res.fits is not None
        else "peak model (eqs 1-6)",
        "pass_fits": None if res.fits is None else int(sum(f.ok for f in res.fits)),
        "survey_depth_m": p.survey_depth,
        "anchors_every": p.anchors_every,
        "static_height_m": p.static_height if spots else None,
        **res.passes,
        "turns": res.turns,
    }
    gap_line = describe_gaps("IMU", t[imu], 0.05)
    meta["gate_anchor"]["warnings"] = ([gap_line] if gap_line else []) + res.passes.pop("warnings", [])
    msg = (
        f"{res.passes['matched_final']} of {cr['t'].size} crossings matched to {xyz.shape[0]} gates, "
        f"{res.passes['anchors_final']} anchors, {len(res.turns)} turns"
        + (f", surveyed static spot(s): {', '.join(res.passes['static_spots'])}" if res.passes["static_spots"] else "")
    )
    return out, meta, msg
