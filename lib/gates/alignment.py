"""Crossings matched to the surveyed gates as one sequence alignment (robust to many missed gates).

The paper's matching (eqs 7-11, :func:`sportfusion.gates.anchors.match_anchors`) compares each detection's
neighbour offsets with the survey's; where several gates in a row are passed too wide to be detected, the
neighbours are the wrong ones and the features mislead (on the simulator with a quarter of the gates
passed 1-2.2 m wide, half the runs ended with a third of their crossings matched and the rest of the
track drifting tens of metres).  The order of the gates and the inertial track between two crossings
are better evidence:

* detections and gates both come in course order, so a matching is a monotone alignment of the two
  sequences, with gates skipped (missed: a wide pass) and detections skipped (noise peaks);
* the displacement between two matched detections, from the inertial track (azimuth-aligned), must
  equal the displacement between their gates, within an error that grows with the time between them
  (the track's drift) and with the displacement's length (the azimuth's error), after the drift that the
  path has shown so far is taken out: the inertial track's velocity error changes slowly, so the misfit of
  one step, divided by its time, predicts the next one's (a path's drift rate, an exponential average of
  its steps' misfit rates).  Without it a track whose speed is off by a few m/s mid-run (its gate-to-gate
  displacements 20-30 % too long: the full-body skier of seed 1202, 6.7 m/s between a still start and
  finish) matched 12 of 28 crossings, some to the neighbouring gate;
* the detected turn side must be the gate's.

The alignment with the least cost (squared displacement misfits over their sigmas, plus a cost per
skipped gate, per skipped detection and per side mismatch) is found by dynamic programming over
(detection, gate) pairs (Viterbi), the previous matched detection at most ``max_noise + 1`` back and the
previous gate at most ``max_skip + 1`` back.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sportfusion.gates.anchors import rotate_z


@dataclass(frozen=True)
class AlignParams:
    """Costs and error model of :func:`align_crossings` (units in brackets).

    Attributes
    ----------
    sigma0, sigma_rate, sigma_frac : float
        Displacement sigma ``sigma0 + sigma_rate dt + sigma_frac |d|`` [m, m/s, 1].
    miss_cost : float
        Cost of a gate without a detection [1] (a wide pass; common).
    noise_cost : float
        Cost of a detection without a gate [1] (a noise peak).
    side_cost : float
        Cost of a detected turn side that differs from the gate's [1].
    max_skip, max_noise : int
        Most gates and most detections skipped between two matches [count].
    drift_gain : float
        Share of the drift rate of a path that predicts its next misfit [1] (0: every displacement must
        match on its own, the track's velocity error taken as zero; 1: the error a path has shown so far is
        expected to go on).
    drift_smooth : float
        Weight of the latest misfit rate in a path's drift-rate estimate [1] (an exponential average over
        its matched steps).
    """

    sigma0: float = 0.5
    sigma_rate: float = 0.4
    sigma_frac: float = 0.02
    miss_cost: float = 2.0
    noise_cost: float = 6.0
    side_cost: float = 6.0
    max_skip: int = 6
    max_noise: int = 2
    drift_gain: float = 1.0
    drift_smooth: float = 0.5


def align_crossings(
    t: np.ndarray,
    detected: np.ndarray,
    side: np.ndarray,
    survey: np.ndarray,
    survey_side: np.ndarray,
    params: AlignParams | None = None,
    with_cost: bool = False,
) -> np.ndarray | tuple[np.ndarray, float]:
    """Survey row matched to each detection (-1: none), by the sequence alignment of the module text.

    Parameters
    ----------
    t : ndarray (M,)
        Crossing times [s].
    detected : ndarray (M, 3)
        Detected anchors, already in the survey's azimuth (a common offset does not matter) [m].
    side : ndarray (M,)
        Detected turn side (+1 R, -1 L, 0 unknown).
    survey : ndarray (N, 3)
        Surveyed gates in course order [m].
    survey_side : ndarray (N,)
        Turn side of each gate.
    params : AlignParams, optional
    with_cost : bool
        Also return the alignment's cost [1].

    Returns
    -------
    ndarray of int (M,)
        In the input order (and the cost, with ``with_cost``).
    """
    p = params or AlignParams()
    order = np.argsort(t, kind="stable")
    tt, det, sd = np.asarray(t, float)[order], np.asarray(detected, float)[order], np.asarray(side, float)[order]
    m, n = det.shape[0], survey.shape[0]
    side_pen = np.where((sd[:, None] != 0) & (sd[:, None] != survey_side[None, :]), p.side_cost, 0.0)
    inf = np.inf
    sdiff = survey[:, None, :] - survey[None, :, :]  # (g, g')
    gap = np.arange(n)[:, None] - np.arange(n)[None, :]  # g - g'
    allowed = (gap >= 1) & (gap <= p.max_skip + 1)
    skip_cost = p.miss_cost * np.maximum(gap - 1, 0)
    cost = np.full((m, n), inf)
    back = np.full((m, n, 2), -1, dtype=int)
    drift = np.zeros((m, n, 3))  # the drift rate [m/s] of the best path ending at (detection, gate)
    for i in range(m):
        # as the first match: the detections before are noise, the gates before missed
        cost[i] = p.noise_cost * i + p.miss_cost * np.arange(n) + side_pen[i]
        for di in range(1, p.max_noise + 2):
            j = i - di
            if j < 0:
                break
            dt = tt[i] - tt[j]
            dd = det[i] - det[j]
            sig = p.sigma0 + p.sigma_rate * dt + p.sigma_frac * float(np.linalg.norm(dd))
            # every (gate g for detection i, gate g' < g for detection j) pair at once
            mis = sdiff - dd  # (n, n, 3): survey[g] - survey[g'] - dd
            r = mis - p.drift_gain * drift[j][None, :, :] * dt  # less the drift its path predicts
            c = cost[j][None, :] + np.sum(r * r, axis=-1) / sig**2 + skip_cost
            c = np.where(allowed, c, inf)
            k = np.argmin(c, axis=1)
            total = c[np.arange(n), k] + p.noise_cost * (di - 1) + side_pen[i]
            better = total < cost[i]
            cost[i, better] = total[better]
            back[i, better, 0] = j
            back[i, better, 1] = k[better]
            rate = mis[np.arange(n), k] / dt
            drift[i, better] = drift[j, k[better]] + p.drift_smooth * (rate[better] - drift[j, k[better]])
    final = cost + p.noise_cost * (m - 1 - np.arange(m))[:, None] + p.miss_cost * (n - 1 - np.arange(n))[None, :]
    ids = np.full(m, -1, dtype=int)
    if not np.isfinite(final).any():
        return (ids, np.inf) if with_cost else ids
    best = float(np.min(final))
    i, g = np.unravel_index(int(np.argmin(final)), final.shape)
    while i >= 0:
        ids[i] = g
        i, g = back[i, g]
    out = np.empty(m, dtype=int)
    out[order] = ids
    return (out, best) if with_cost else out


def align_with_azimuth(
    t: np.ndarray,
    det: np.ndarray,
    side: np.ndarray,
    survey: np.ndarray,
    survey_side: np.ndarray,
    alpha: float,
    params: AlignParams | None = None,
) -> tuple[np.ndarray, float, np.ndarray]:
    """Ids, azimuth [rad] and offset [m] of detections ``det`` in an inertial frame: aligned (:func:`align_crossings`)
    after rotating them by the first guess ``alpha`` (e.g. the principal-component azimuth) or by the azimuth
    within +-30 deg of it (2 deg steps) whose alignment costs least -- a drifting inertial track bends the
    principal component by degrees, and a poor unit's by more --, the azimuth refined from the matched pairs
    (a 2-D Procrustes fit of their horizontal positions), aligned again; the offset is the median of survey
    minus rotated detection over the matched pairs (``rotate_z(det, alpha) + offset`` lands on the survey)."""
    best = None
    for da in np.deg2rad(np.arange(-30.0, 30.1, 2.0)):
        ids_a, cost = align_crossings(t, rotate_z(det, alpha + da), side, survey, survey_side, params, with_cost=True)
        if best is None or cost < best[0]:
            best = (cost, alpha + da, ids_a)
    assert best is not None
    _, alpha, ids = best
    for _ in range(2):
        ok = ids >= 0
        if ok.sum() < 3:
            break
        a = rotate_z(det[ok], alpha)[:, :2]
        b = survey[ids[ok]][:, :2]
        a, b = a - a.mean(axis=0), b - b.mean(axis=0)
        alpha += float(np.arctan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), np.sum(a * b)))
        ids = align_crossings(t, rotate_z(det, alpha), side, survey, survey_side, params)
    ok = ids >= 0
    offset = np.median(survey[ids[ok]] - rotate_z(det[ok], alpha), axis=0) if ok.any() else np.zeros(3)
    return ids, alpha, offset
