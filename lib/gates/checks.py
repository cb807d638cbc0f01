"""Is the anchored track consistent with what was detected?  (gate-anchor's guard against a silent gross error.)

A wrong matching of crossings to gates does not show in the smoother's own figures: the final EKS bends the
track through the anchors it is given (post-fit residuals of a few tenths of a metre against 0.1 m sigmas) and
its ``std_`` columns stay at decimetres while the track is off by tens of metres (the full-body skier of seed
1202 before the alignment followed the track's drift: 12 of 28 crossings matched, some to the neighbouring
gate, the track 70-160 m off with ``std_`` of 1-7 m).  What does show it:

* the **matched share**: every detected crossing is a pass of some magnet or a noise peak, and noise peaks
  are few, so a matching that leaves a large share of the detections unmatched has lost its way;
* the **unexplained crossings**: on a correctly anchored track each detected crossing's anchor (the sensor's
  position plus its offset to the magnet) lies on a surveyed gate, matched or not; a crossing whose anchor
  lies metres from every gate of its side says the track (or the survey) is wrong there;
* the **post-fit residuals** of the final anchors against their sigmas (the track cannot pass through its
  anchors: two of them contradict the inertial track between them).

:func:`check_matching` turns these into a verdict: trusted, doubtful (a warning; the ``std_`` columns widened
by :func:`widen_std` to the disagreement between the anchored and the purely inertial track, so that either
being right is covered), or hopeless (fewer than half of the detections matched, or both a low matched share
and many unexplained crossings: two independent signs that the track is lost; the caller refuses).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CheckParams:
    """Limits of :func:`check_matching` (units in brackets).

    Attributes
    ----------
    min_share : float
        Matched share of the detected crossings below which the matching is doubtful [1].
    refuse_share : float
        Matched share below which nothing is trusted (the caller refuses) [1]; below ``min_share`` with more
        than ``max_far_share`` unexplained crossings is refused too.
    far : float
        Distance from a crossing's anchor to the nearest surveyed gate of its side beyond which the crossing is
        unexplained by the anchored track [m] (a pass fit places a magnet within decimetres, the peak model
        within about a metre).
    max_far_share : float
        Share of unexplained crossings above which the matching is doubtful [1].
    max_ratio : float
        Post-fit anchor residual over its 1-sigma above which the anchors contradict the track [1].
    """

    min_share: float = 0.75
    refuse_share: float = 0.5
    far: float = 3.0
    max_far_share: float = 0.25
    max_ratio: float = 4.0


@dataclass
class MatchCheck:
    """The verdict of :func:`check_matching`."""

    matched: int  # crossings matched to a gate [count]
    detected: int  # crossings detected [count]
    far: np.ndarray  # per crossing: distance of its anchor to the nearest gate of its side [m]
    n_far: int  # crossings farther than ``far`` [count]
    ratio: float  # largest post-fit anchor residual over its sigma [1] (0 without anchors)
    doubtful: bool
    hopeless: bool
    message: str  # one line naming what is wrong ("" when trusted)


def gate_distances(anchors: np.ndarray, side: np.ndarray, survey: np.ndarray, survey_side: np.ndarray) -> np.ndarray:
    """Distance [m] from each anchor (M, 3) to the nearest surveyed gate (N, 3) of its side (any side where
    ``side`` is 0), all in the survey's frame."""
    d = np.linalg.norm(np.asarray(anchors, float)[:, None, :] - np.asarray(survey, float)[None, :, :], axis=-1)
    same = (np.asarray(side)[:, None] == 0) | (np.asarray(side)[:, None] == np.asarray(survey_side)[None, :])
    d = np.where(same, d, np.inf)
    return np.min(d, axis=1) if d.shape[1] else np.full(d.shape[0], np.inf)


def check_matching(
    ids: np.ndarray,
    anchors: np.ndarray,
    side: np.ndarray,
    survey: np.ndarray,
    survey_side: np.ndarray,
    residual: np.ndarray,
    sigma: np.ndarray,
    params: CheckParams | None = None,
) -> MatchCheck:
    """Verdict on a matching of crossings to gates and the track anchored by it (see the module text).

    Parameters
    ----------
    ids : ndarray of int (M,)
        Survey row matched to each detected crossing (-1: none).
    anchors : ndarray (M, 3)
        Each crossing's anchor (magnet position) on the anchored track, survey frame [m].
    side, survey_side : ndarray
        Turn side of each crossing (+1 R, -1 L, 0 unknown) and of each gate.
    survey : ndarray (N, 3)
        Surveyed gates [m].
    residual, sigma : ndarray (K,)
        Post-fit residual [m] of each final anchor (its norm) and its 1-sigma [m] (anchor and track together).
    params : CheckParams, optional

    Returns
    -------
    MatchCheck
    """
    p = params or CheckParams()
    ids = np.asarray(ids)
    m = int(ids.size)
    matched = int((ids >= 0).sum())
    far = gate_distances(anchors, side, survey, survey_side)
    n_far = int(np.sum(~(far <= p.far)))
    res, sig = np.asarray(residual, float), np.asarray(sigma, float)
    ratio = float(np.max(res / np.maximum(sig, 1e-9))) if res.size else 0.0
    share = matched / m if m else 0.0
    low, unexplained = share < p.min_share, n_far > p.max_far_share * m
    hopeless = share < p.refuse_share or (low and unexplained)
    doubtful = hopeless or low or unexplained or ratio > p.max_ratio
    parts = []
    if low:
        parts.append(f"only {matched} of {m} detected crossings matched to a gate")
    if unexplained:
        big = far[np.isfinite(far) & (far > p.far)]
        span = f" ({big.min():.0f}-{big.max():.0f} m)" if big.size else ""
        parts.append(f"{n_far} of {m} crossings lie farther than {p.far:g} m from every gate of their side{span}")
    if ratio > p.max_ratio:
        parts.append(f"the anchors contradict the inertial track (a post-fit residual {ratio:.0f} times its sigma)")
    message = "; ".join(parts)
    return MatchCheck(matched, m, far, n_far, ratio, doubtful, hopeless, message)


def widen_std(std_pos: np.ndarray, pos: np.ndarray, pos_inertial: np.ndarray) -> np.ndarray:
    """``std_`` per axis [m] widened, in quadrature, by the difference between the anchored track and the
    inertial track aligned to the survey (both (N, 3) [m]): when the matching is doubtful either may be the
    right one, and the widened sigma covers both."""
    return np.sqrt(np.asarray(std_pos, float) ** 2 + (np.asarray(pos, float) - np.asarray(pos_inertial, float)) ** 2)
