"""Relative anchor points and anchor-point matching (gates paper, "Body model and relative anchor point
estimation" and "Anchor point matching").

Equations 2-11 of the paper are images missing from its text; everything below is
implemented from the prose around them, and each function says which equation it stands for.

Relative anchor points (eqs 2-6)
    At a crossing m the sacrum is at ``p`` with velocity ``v``.  The magnet lies in (just below) the snow
    surface S_m with unit normal ``n`` (out of the snow).  The sacrum is ``h`` above S_m along ``n``; its
    projection onto S_m is ``p~ = p - h n`` (eq 6; with a point ``l`` of the plane known,
    ``p~ = p + ((l - p).n) n``).  ``r_m`` (sacrum -> magnet) has the length estimated from the peak
    intensity; its part along the normal is ``d_m = h + b`` (``b``: burial depth of the magnet), and the
    rest ``x_m`` lies in S_m perpendicular to ``v``, on the inside of the turn (eqs 2-5):
    ``|x_m| = sqrt(|r_m|^2 - |d_m|^2)``, direction ``+-(v x n)/|v x n|`` (+ for a right turn).  The anchor
    is ``g_m = p~ + x_m - b n``.  The paper gets ``h`` and S_m from a full-body model (ski contact points);
    with one sacrum sensor we use ``h = H0 cos(lean)`` (``H0`` the sacrum height at zero lean, lean = roll
    of the sacrum sensor) and S_m from the surveyed magnets around the matched gate (vertical before any
    match) -- a departure forced by the single sensor.

Matching (eqs 7-11)
    1. Azimuth ``alpha``: angle between the first principal components of the surveyed and the detected
       anchors projected onto the horizontal plane (each oriented along the course: from the first
       gate/crossing towards the last).
    2. Features of each azimuth-aligned detected anchor and each surveyed anchor (eqs 7-8):
       ``f = [g_{k+1} - g_k, g_k - g_{k-1}, w_side * side, w_turn * turn number]`` (a missing neighbour
       leaves its components out of the distance).  Turn numbers: the first detection is turn 1 and no two
       consecutive turns have the same side, so a repeated side means a missed gate (+2); the time gap
       (in median gate intervals) resolves longer gaps with the right parity.
    3. ``k_m = argmin_n ||f_n - f_m||`` (eq 9; the first detection may not be gate 1 -- the paper says the
       first and last gates are often missed -- so the numbering shift 0-5 with the smallest summed
       distances is taken); matches are removed where two or more detections claim one
       gate; the offset ``o`` is the median position difference of the matched pairs.
    4. Second matching in absolute coordinates (eqs 10-11): ``f = [g, w_side side, w_turn turn number]``
       with the detections azimuth- and offset-corrected, the same minimisation.  Our refinements: of the
       detections claiming one gate only the nearest keeps it (a noise peak next to a detected gate would
       otherwise remove the true match too), a match farther than ``max_distance`` is dropped, matched gate
       numbers must increase with time (the longest increasing run is kept), and each detection is corrected
       not by the one median offset but by the median offset of its ``neighbours`` nearest matched
       detections (from the feature matching, then from the absolute matching, three rounds) (the pass-1 drift is smooth along the run; one global offset leaves the ends
       several metres off).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.stats import median, unique


# --------------------------------------------------------------------------- relative anchors (eqs 2-6)
def sacrum_height(roll: np.ndarray, h0: float = 0.95) -> np.ndarray:
    """Sacrum height above the snow [m] from its lean (roll [rad]): ``H0 cos(roll)`` (our body model)."""
    return h0 * np.cos(np.asarray(roll, dtype=float))


def relative_anchors(
    p: np.ndarray,
    v: np.ndarray,
    distance: np.ndarray,
    side: np.ndarray,
    height: np.ndarray,
    normal: np.ndarray | None = None,
    burial: float = 0.05,
    plane_point: np.ndarray | None = None,
) -> np.ndarray:
    """Anchor (magnet) positions estimated from the sacrum at each crossing (eqs 2-6 from the prose).

    Parameters
    ----------
    p, v : ndarray, shape (M, 3)
        Sacrum position [m] and velocity [m/s] at the crossings (local frame, z down).
    distance : ndarray, shape (M,)
        Sacrum -> magnet distance |r_m| [m] from the peak intensity (NaN: taken as ``height + burial``).
    side : ndarray, shape (M,)
        +1 right turn (magnet on the right of the direction of travel), -1 left turn.
    height : ndarray, shape (M,)
        Sacrum height above the snow along the normal [m] (e.g. :func:`sacrum_height`); ignored where
        ``plane_point`` is given (eq 6 then gives it).
    normal : ndarray, shape (M, 3) or (3,), optional
        Unit normal of the snow surface pointing out of the snow; default vertical ``(0, 0, -1)``.
    burial : float
        Depth of the magnet below the snow [m].
    plane_point : ndarray, shape (M, 3), optional
        A point of each snow plane (eq 6).

    Returns
    -------
    ndarray, shape (M, 3)
        Estimated magnet positions [m].
    """
    p = np.atleast_2d(np.asarray(p, dtype=float))
    v = np.atleast_2d(np.asarray(v, dtype=float))
    n = np.broadcast_to(np.array([0.0, 0.0, -1.0]) if normal is None else np.asarray(normal, float), p.shape)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    if plane_point is not None:
        h = np.sum((p - np.asarray(plane_point, float)) * n, axis=-1)  # eq 6: p~ = p + ((l - p).n) n
    else:
        h = np.broadcast_to(np.asarray(height, float), p.shape[:1])
    p_t = p - h[:, None] * n
    d = h + burial  # |d_m|, the part of r_m along the normal
    r = np.asarray(distance, dtype=float)
    r = np.where(np.isfinite(r), r, d)
    x_len = np.sqrt(np.maximum(r**2 - d**2, 0.0))  # eq 5
    u = np.cross(v, n)  # to the right of the direction of travel
    u /= np.maximum(np.linalg.norm(u, axis=-1, keepdims=True), 1e-9)
    return p_t + (np.asarray(side, float) * x_len)[:, None] * u - burial * n


def snow_normals(survey: np.ndarray, ids: np.ndarray, half: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Snow-plane normals (out of the snow) and plane points from the surveyed magnets around each matched gate.

    A plane is fitted (least squares) to the surveyed magnets ``id-half .. id+half``; unmatched rows
    (``id < 0``) get the vertical and NaN points.
    """
    n_out = np.tile(np.array([0.0, 0.0, -1.0]), (ids.size, 1))
    pts = np.full((ids.size, 3), np.nan)
    for i, g in enumerate(ids):
        if g < 0:
            continue
        lo, hi = max(g - half, 0), min(g + half + 1, survey.shape[0])
        if hi - lo < 3:
            continue
        q = survey[lo:hi]
        c = q.mean(axis=0)
        _, _, vt = np.linalg.svd(q - c)
        nn = vt[-1]
        nn = nn if nn[2] < 0 else -nn
        n_out[i] = nn
        pts[i] = c
    return n_out, pts


# --------------------------------------------------------------------------- matching (eqs 7-11)
@dataclass(frozen=True)
class MatchParams:
    """Weights and gates of the anchor matching.

    Attributes
    ----------
    w_side : float
        Weight of the turn side in the feature vectors [m per unit side].
    w_turn : float
        Weight of the turn number [m per turn].
    max_distance : float
        Largest distance between a matched detection and its gate in absolute coordinates [m].
    neighbours : int
        Matched detections (nearest in time) whose median offset corrects each detection in the repeated
        absolute matching [count].
    """

    w_side: float = 2.0
    w_turn: float = 1.0
    max_distance: float = 5.0
    neighbours: int = 6


@dataclass
class MatchResult:
    """Result of :func:`match_anchors`.

    Attributes
    ----------
    ids : ndarray of int, shape (M,)
        Survey row index matched to each detection (input order), -1 when unmatched.
    alpha : float
        Azimuth rotation taking the detections' frame to the survey's [rad].
    offset : ndarray, shape (3,)
        Translation after the rotation [m].
    first_ids : ndarray of int
        The feature matching's ids before the absolute matching (diagnostics).
    """

    ids: np.ndarray
    alpha: float
    offset: np.ndarray
    first_ids: np.ndarray = field(default_factory=lambda: np.zeros(0, int))

    def transform(self, pts: np.ndarray) -> np.ndarray:
        """Apply the rotation then the offset to points (..., 3)."""
        return rotate_z(pts, self.alpha) + self.offset


def rotate_z(pts: np.ndarray, alpha: float) -> np.ndarray:
    """Rotate points (..., 3) about the vertical by ``alpha`` [rad] (from x towards y)."""
    c, s = np.cos(alpha), np.sin(alpha)
    pts = np.asarray(pts, dtype=float)
    out = pts.copy()
    out[..., 0] = c * pts[..., 0] - s * pts[..., 1]
    out[..., 1] = s * pts[..., 0] + c * pts[..., 1]
    return out


def principal_azimuth(points: np.ndarray) -> float:
    """Azimuth [rad] of the first principal component of the horizontal points (ordered along the course),
    oriented from the first point towards the last."""
    xy = np.asarray(points, float)[:, :2]
    c = xy - xy.mean(axis=0)
    _, _, vt = np.linalg.svd(c, full_matrices=False)
    pc = vt[0]
    if np.dot(xy[-1] - xy[0], pc) < 0:
        pc = -pc
    return float(np.arctan2(pc[1], pc[0]))


def turn_numbers(t: np.ndarray, side: np.ndarray) -> np.ndarray:
    """Turn number of each detection (sorted by time): the first is 1, consecutive turns alternate sides.

    The step to the next detection is the time gap in median gaps, rounded to the nearest count with the
    parity the sides require (odd when the side changes, even when it repeats: a missed gate), at least 1.
    A gap shorter than 0.7 median gaps (a noise peak between two gates, or the gate after it) counts as
    its fraction, so a noise peak does not shift the numbers of the turns after it.
    """
    n = np.ones(t.size)
    if t.size < 2:
        return n
    dt = np.diff(t)
    med = float(median(dt))
    for i in range(1, t.size):
        k = dt[i - 1] / med if med > 0 else 1.0
        if k < 0.7:
            n[i] = n[i - 1] + k
            continue
        want_even = side[i] == side[i - 1] and side[i] != 0
        cand = [c for c in range(1, int(k) + 3) if (c % 2 == 0) == want_even] or [1]
        n[i] = n[i - 1] + min(cand, key=lambda c: abs(c - k))
    return n


def _features(points: np.ndarray, side: np.ndarray, number: np.ndarray, p: MatchParams) -> np.ndarray:
    """Eqs 7-8: neighbour offsets (NaN where a neighbour is missing), weighted side and turn number."""
    m = points.shape[0]
    nxt = np.full((m, 3), np.nan)
    prv = np.full((m, 3), np.nan)
    if m > 1:
        nxt[:-1] = points[1:] - points[:-1]
        prv[1:] = points[1:] - points[:-1]
    return np.column_stack([nxt, prv, p.w_side * side, p.w_turn * number])


def _nan_dist(fm: np.ndarray, fn: np.ndarray) -> np.ndarray:
    """Distances between feature rows with NaN components left out (rescaled to the full length)."""
    d = fm[:, None, :] - fn[None, :, :]
    ok = np.isfinite(d)
    s = np.where(ok, d * d, 0.0).sum(axis=-1)
    cnt = ok.sum(axis=-1)
    return np.sqrt(s * fm.shape[1] / np.maximum(cnt, 1))


def _argmin_unique(dist: np.ndarray) -> np.ndarray:
    """Eq 9 for each row, then drop every match whose gate is claimed by two or more rows."""
    k = np.argmin(dist, axis=1)
    ids, counts = np.unique(k, return_counts=True)
    dup = set(ids[counts > 1].tolist())
    return np.array([-1 if kk in dup else kk for kk in k], dtype=int)


def _argmin_mutual(dist: np.ndarray) -> np.ndarray:
    """Eq 9 for each row; where two or more rows claim one gate, only the row nearest to that gate keeps it."""
    k = np.argmin(dist, axis=1)
    out = k.copy()
    for g in unique(k):
        rows = np.flatnonzero(k == g)
        if rows.size > 1:
            best = rows[np.argmin(dist[rows, g])]
            out[rows[rows != best]] = -1
    return out


def _local_offsets(g_hat: np.ndarray, survey: np.ndarray, ids: np.ndarray, k: int) -> np.ndarray:
    """Per detection, the median offset (survey - detection) of the ``k`` matched detections nearest in time
    order: the pass-1 drift is smooth along the run, so a local offset follows it where one global offset
    cannot."""
    idx = np.flatnonzero(ids >= 0)
    diff = survey[ids[idx]] - g_hat[idx]
    out = np.empty_like(g_hat)
    for i in range(g_hat.shape[0]):
        near = np.argsort(np.abs(idx - i), kind="stable")[:k]
        out[i] = median(diff[near], axis=0)
    return out


def _increasing(ids: np.ndarray) -> np.ndarray:
    """Keep the longest strictly increasing subsequence of the matched ids (others -> -1)."""
    idx = np.flatnonzero(ids >= 0)
    if idx.size < 2:
        return ids
    vals = ids[idx]
    n = vals.size
    best = np.ones(n, int)
    prev = np.full(n, -1)
    for i in range(n):
        for j in range(i):
            if vals[j] < vals[i] and best[j] + 1 > best[i]:
                best[i], prev[i] = best[j] + 1, j
    keep = set()
    i = int(np.argmax(best))
    while i >= 0:
        keep.add(i)
        i = int(prev[i])
    out = ids.copy()
    for j, r in enumerate(idx):
        if j not in keep:
            out[r] = -1
    return out


def survey_sides(survey: np.ndarray) -> np.ndarray:
    """Turn side of each surveyed gate from the course geometry (+1 R, -1 L).

    A gate lying to the left of the line joining its neighbours is passed on its outside (further left) and
    the skier turns right around it (the magnet on the right at the crossing): a right turn, and vice versa.
    """
    n = survey.shape[0]
    out = np.zeros(n)
    for i in range(1, n - 1):
        d = survey[i + 1] - survey[i - 1]
        rel = survey[i] - survey[i - 1]
        cross = d[0] * rel[1] - d[1] * rel[0]  # > 0: the gate is to the right of its neighbours' line (z down)
        out[i] = -1.0 if cross > 0 else 1.0
    if n >= 3:  # the end gates alternate with their neighbours
        out[0], out[-1] = -out[1], -out[-2]
    return out


def match_anchors(
    t: np.ndarray,
    detected: np.ndarray,
    side: np.ndarray,
    survey: np.ndarray,
    survey_side: np.ndarray | None = None,
    params: MatchParams | None = None,
    alpha: float | None = None,
) -> MatchResult:
    """Match detected anchor points to surveyed gates (eqs 7-11 from the prose; see the module text).

    Parameters
    ----------
    t : ndarray, shape (M,)
        Crossing times [s] (any order; sorted inside, results in input order).
    detected : ndarray, shape (M, 3)
        Estimated anchors in the inertial frame (azimuth and position unknown) [m].
    side : ndarray, shape (M,)
        +1 right turn, -1 left turn, 0 unknown.
    survey : ndarray, shape (N, 3)
        Surveyed magnets in gate order [m].
    survey_side : ndarray, shape (N,), optional
        Turn side of each gate; default from the geometry (:func:`survey_sides`).
    params : MatchParams, optional
    alpha : float, optional
        Known azimuth rotation [rad] (skip the principal-component step; used once the detections are
        already in the survey frame).

    Returns
    -------
    MatchResult
    """
    p = params or MatchParams()
    survey = np.asarray(survey, float)
    if survey.shape[0] < 3:
        raise InputError(f"the gate survey has {survey.shape[0]} gate(s); anchor matching needs at least 3")
    t = np.asarray(t, float)
    order = np.argsort(t, kind="stable")
    det = np.asarray(detected, float)[order]
    sd = np.asarray(side, float)[order]
    m = det.shape[0]
    if m < 3:
        raise InputError(f"{m} gate crossing(s) detected; anchor matching needs at least 3")
    ssd = survey_sides(survey) if survey_side is None else np.asarray(survey_side, float)
    n_num = np.arange(1, survey.shape[0] + 1, dtype=float)
    m_num = turn_numbers(t[order], sd)
    # 1. azimuth from the principal components
    if alpha is None:
        alpha = principal_azimuth(survey) - principal_azimuth(det)
    g_hat = rotate_z(det, alpha)
    # 2-3. features of neighbours, eq 9, duplicates removed, offset = median difference
    fn = _features(survey, ssd, n_num, p)
    # the first detection need not be gate 1: the shift of the numbering with the smallest summed eq-9
    # distances is used
    best = None
    for shift in range(0, min(6, survey.shape[0])):
        dist = _nan_dist(_features(g_hat, sd, m_num + shift, p), fn)
        cost = float(np.sum(np.min(dist, axis=1)))
        if best is None or cost < best[0]:
            best = (cost, shift, dist)
    _, shift, dist = best
    m_num = m_num + shift
    first = _argmin_unique(dist)
    ok = first >= 0
    if not ok.any():
        raise InputError("anchor matching found no unambiguous pair between the crossings and the survey")
    offset = median(survey[first[ok]] - g_hat[ok], axis=0)
    # 4. absolute coordinates (eqs 10-11); the offset is re-estimated from the absolute matches once
    fs = np.column_stack([survey, p.w_side * ssd, p.w_turn * n_num])
    local = (
        _local_offsets(g_hat, survey, first, p.neighbours) if ok.sum() >= 3 else np.broadcast_to(offset, g_hat.shape)
    )
    for _ in range(3):
        g_abs = g_hat + local
        fa = np.column_stack([g_abs, p.w_side * sd, p.w_turn * m_num])
        ids = _argmin_mutual(_nan_dist(fa, fs))
        far = (ids >= 0) & (np.linalg.norm(g_abs - survey[np.maximum(ids, 0)], axis=1) > p.max_distance)
        ids[far] = -1
        ids = _increasing(ids)
        if (ids >= 0).sum() < 3:
            break
        offset = median(survey[ids[ids >= 0]] - g_hat[ids >= 0], axis=0)
        local = _local_offsets(g_hat, survey, ids, p.neighbours)
    inv = np.empty_like(order)
    inv[order] = np.arange(order.size)
    return MatchResult(ids=ids[inv], alpha=float(alpha), offset=offset, first_ids=first[inv])
