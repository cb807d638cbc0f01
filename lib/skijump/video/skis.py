"""The skis in one frame: the silhouette's lower envelope, the ski line and the skis' ends.

Step 2 ("Skis") of :mod:`sportfusion.skijump.video.measure`: the silhouette's lowest pixel in each column
gives the lower envelope; the skis are the straight line along its bottom (the longest edge of its lower
convex hull, refitted to the points near it) -- the body is above it.  The lower edge is refined to where
the difference image falls to half its peak (the edge at mid-exposure under motion blur); the skis' ends
are where the foreground in a band along the line ends (the upturned tips included), their middle the
point half-way.  All in image pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


# ----------------------------------------------------------------------------- skis in one frame
@dataclass
class SkiObs:
    """The skis in one frame (full-resolution pixels)."""

    frame: int
    env: np.ndarray  # (n, 2) lower-edge points on the ski line (col, row)
    line: tuple[float, float]  # row = a + b * col
    ends: tuple[float, float]  # columns of the skis' two ends
    touches_border: bool

    @property
    def middle(self) -> np.ndarray:
        c = 0.5 * (self.ends[0] + self.ends[1])
        return np.array([c, self.line[0] + self.line[1] * c])


def lower_envelope(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns with foreground and the row of their lowest foreground pixel."""
    has = mask.any(axis=0)
    cols = np.flatnonzero(has)
    flipped = mask[::-1, cols]
    rows = mask.shape[0] - 1 - np.argmax(flipped, axis=0)
    return cols.astype(float), rows.astype(float)


def half_max_edge(diff: np.ndarray, cols: np.ndarray, rows: np.ndarray, depth: int) -> np.ndarray:
    """Sub-pixel lower edge: where the difference image falls to half its peak below the object.

    For each column, the peak of ``diff`` over the ``depth`` rows up to the
    lowest foreground pixel ``rows``; the edge is the row (interpolated
    linearly between pixel centres) at which ``diff`` drops below half that
    peak going down.  With motion blur this is the object's edge at mid-exposure.
    """
    h = diff.shape[0]
    d = diff.astype(np.float32)
    offs = np.arange(-depth, 3)
    rr = np.clip(rows[:, None] + offs[None, :], 0, h - 1)
    prof = d[rr, cols[:, None]]
    peak = prof[:, : depth + 1].max(axis=1)
    half = 0.5 * peak
    above = prof >= half[:, None]
    # last index (going down) at or above half the peak
    last = above.shape[1] - 1 - np.argmax(above[:, ::-1], axis=1)
    last = np.minimum(last, prof.shape[1] - 2)
    v0 = prof[np.arange(len(cols)), last]
    v1 = prof[np.arange(len(cols)), last + 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(v0 > v1, (v0 - half) / (v0 - v1), 0.0)
    return rows + offs[last] + np.clip(frac, 0.0, 1.0)


def ski_ends(
    mask: np.ndarray, run_cols: np.ndarray, line: tuple[float, float], up: float, down: float, gap: float
) -> tuple[float, float]:
    """Columns of the skis' two ends: the foreground in a band along the ski line, grown out from the run.

    The band reaches ``up`` px above and ``down`` px below the line ``row = a + b col``
    (the upturned tips rise above the soles); columns with foreground in the band
    extend the run outwards across gaps of at most ``gap`` px.
    """
    a, b = line
    h, w = mask.shape
    rows = np.arange(h)[:, None]
    cols = np.arange(w)[None, :]
    r_line = a + b * cols
    band = mask & (rows >= r_line - up) & (rows <= r_line + down)
    has = np.flatnonzero(band.any(axis=0))
    lo, hi = float(run_cols.min()), float(run_cols.max())
    if has.size == 0:
        return lo, hi
    right = has[has >= hi]
    for c in right:
        if c - hi > gap:
            break
        hi = float(c)
    left = has[has <= lo][::-1]
    for c in left:
        if lo - c > gap:
            break
        lo = float(c)
    return lo, hi


def _lower_hull(c: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Indices of the lower (largest-row) convex hull of points sorted by column."""
    hull: list[int] = []
    for i in range(c.size):
        while len(hull) >= 2:
            i1, i2 = hull[-2], hull[-1]
            cross = (c[i2] - c[i1]) * (r[i] - r[i1]) - (r[i2] - r[i1]) * (c[i] - c[i1])
            if cross >= 0:  # i2 lies above the chord i1 -> i (rows grow downwards)
                hull.pop()
            else:
                break
        hull.append(i)
    return np.array(hull, int)


def ski_line(
    cols: np.ndarray, rows: np.ndarray, tol: float, gap: float
) -> tuple[np.ndarray, tuple[float, float]] | None:
    """The skis as the straight bottom of a lower envelope.

    Parameters
    ----------
    cols, rows : ndarray
        Lower-envelope points (sorted by column) [px].
    tol : float
        Distance from the line within which a point belongs to the skis [px].
    gap : float
        Largest gap in columns inside the skis [px].

    Returns
    -------
    inliers : ndarray of int
        Indices of the ski points (one contiguous run of columns).
    line : (a, b)
        ``row = a + b col``.
    None if no line is found.
    """
    if cols.size < 6:
        return None
    hull = _lower_hull(cols, rows)
    if hull.size < 2:
        return None
    spans = np.diff(cols[hull])
    k = int(np.argmax(spans))
    i1, i2 = hull[k], hull[k + 1]
    b = (rows[i2] - rows[i1]) / (cols[i2] - cols[i1])
    a = rows[i1] - b * cols[i1]
    inl = np.zeros(cols.size, bool)
    for _ in range(3):
        res = rows - (a + b * cols)
        inl = np.abs(res) <= tol
        if inl.sum() < 4:
            return None
        b, a = np.polyfit(cols[inl], rows[inl], 1)
    # the longest run of inliers with gaps no wider than `gap`
    idx = np.flatnonzero(inl)
    breaks = np.flatnonzero(np.diff(cols[idx]) > gap)
    runs = np.split(idx, breaks + 1)
    run = max(runs, key=lambda r: cols[r[-1]] - cols[r[0]])
    if run.size < 4:
        return None
    b, a = np.polyfit(cols[run], rows[run], 1)
    return run, (float(a), float(b))
