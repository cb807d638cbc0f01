"""Touch-down frame and jump length read from a landing video (skijump paper, Appendix B).

Method
------
1. **Jumper.** Every frame is read once (OpenCV) and kept grey, decimated to
   at most 480 px wide; the background is the per-pixel median of up to 49
   frames spread over the video, the foreground what differs from it by more
   than 6 robust sigmas of the image noise.  Foreground blobs are linked from
   frame to frame (nearest to a constant-velocity prediction, similar area);
   the jumper is the track that travels farthest (a person walking or flags
   waving stay put).
2. **Skis.** In the frames with the jumper, at full resolution (a second read
   of those frames when the video was decimated), the silhouette's lowest
   pixel in each column gives the lower envelope; the skis are the straight
   line along its bottom (the longest edge of its lower convex hull, refitted
   to the points near it) -- the body is above it.  The lower edge is refined
   to where the difference image falls to half its peak (the edge at
   mid-exposure under motion blur); the skis' ends are where the foreground in
   a band along the line ends (the upturned tips included), their middle the
   point half-way.
3. **Calibration.** The slope map of :mod:`~sportfusion.video.calibration` (a
   homography of the slope plane with curvature terms), fitted to the markers
   within +-8 m, maps a pixel to the snow point seen there, ``(s, y)``: a ski
   on the snow maps to its own lateral position, a ski above the snow to a
   point farther from the camera.
4. **Touch-down.** ``Y(f)``, the lowest 20 % of the skis' lower edge mapped to
   ``y`` (signed away from the camera), falls while the skis come down and
   stays level once they lie on the snow.  Under maps fitted every 3 m along
   the track (frames within 7 m of each), :func:`fit_touchdown` fits the hinge
   ``Y = c + d (f - f_td) + a tau + b tau^2`` (``tau = max(f_td - f, 0)``) and
   places ``f_td`` to 0.01 frame; the touch-down with the largest descent
   over noise is kept and refitted under a map centred on it.  The
   touch-down frame is the first frame at or after ``f_td``: both skis on the
   snow (in a side view the two skis overlap; their common lower edge is what
   reaches the snow).
5. **Jump length.** The skis' middle mapped to ``s`` in the frames after the
   touch-down (exact there: the skis lie on the snow) is fitted by a line in
   time and read at ``f_td``.

The uncertainty combines the hinge fit's timing error (at least 0.1 frame)
times the speed along the slope, the scatter of the middle's track, the
calibration residual and 5 cm for the skis' ends (the floors are the residual
systematic errors seen on rendered landings, ``bench/bench_video.py``);
``confidence`` is the probability that the error is within the paper's 0.5 m
reading accuracy under a normal error with that standard deviation.

Limits: markers on both sides of the slope must be in view (one line of
markers does not fix the slope plane); the camera must be fixed, above the
slope, roughly level (image rows ~ up), and see the skis from the side.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from sportfusion.errors import InputError
from sportfusion.video.calibration import SlopeMap, fit_slope_map
from sportfusion.video.markers import Markers, check_in_frame

Progress = Callable[[Iterable[Any], int | None, str], Iterator[Any]]

#: Reading accuracy of the paper's manual video reading [m] (Appendix B).
READING_ACCURACY = 0.5
THUMB_WIDTH = 480
#: Smallest timing and position uncertainty assumed [frames], [m] (systematic errors seen in bench/bench_video.py).
TIMING_FLOOR = 0.1
POSITION_FLOOR = 0.05


def _no_progress(it: Iterable[Any], length: int | None = None, label: str = "") -> Iterator[Any]:
    yield from it


# ----------------------------------------------------------------------------- reading
@dataclass
class VideoInfo:
    """Basic facts of a video file."""

    path: str
    width: int
    height: int
    fps: float
    frames: int


def open_video(path: str | Path) -> tuple[cv2.VideoCapture, VideoInfo]:
    """Open a video with OpenCV; :class:`InputError` if it cannot be decoded."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"video {p} does not exist; expected a video file (e.g. .mp4)")
    cap = cv2.VideoCapture(str(p))
    if not cap.isOpened():
        raise InputError(f"cannot read video {p}; expected a video file OpenCV can decode (e.g. mp4v .mp4)")
    fps = float(cap.get(cv2.CAP_PROP_FPS) or 0.0)
    w = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH) or 0)
    h = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT) or 0)
    n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
    if not (math.isfinite(fps) and fps > 0) or w <= 0 or h <= 0:
        cap.release()
        raise InputError(f"cannot read video {p}: no frame size or frame rate; expected a video file")
    return cap, VideoInfo(str(p), w, h, fps, n)


def _gray(frame: np.ndarray) -> np.ndarray:
    return frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)


def read_thumbnails(path: str | Path, progress: Progress = _no_progress) -> tuple[VideoInfo, list[np.ndarray], int]:
    """Read every frame once, keep it grey and decimated by an integer factor to at most 480 px wide.

    Returns
    -------
    info : VideoInfo
        With ``frames`` the number of frames actually decoded.
    thumbs : list of ndarray
        Grey thumbnails (uint8).
    factor : int
        Shrink factor (1: the thumbnails are the frames).
    """
    cap, info = open_video(path)
    k = max(1, math.ceil(info.width / THUMB_WIDTH))
    size = (info.width // k, info.height // k)
    thumbs: list[np.ndarray] = []

    def frames() -> Iterator[np.ndarray]:
        while True:
            ok, fr = cap.read()
            if not ok:
                return
            yield fr

    try:
        for fr in progress(frames(), info.frames or None, "reading"):
            if k > 1:  # decimate first: the grey conversion then costs 1/k^2
                fr = np.ascontiguousarray(fr[: size[1] * k : k, : size[0] * k : k])
            thumbs.append(_gray(fr))
    finally:
        cap.release()
    if not thumbs:
        raise InputError(f"cannot read any frame of video {info.path}; expected a video OpenCV can decode")
    info.frames = len(thumbs)
    return info, thumbs, k


def median_background(frames: list[np.ndarray], most: int = 49) -> np.ndarray:
    """Per-pixel median of up to ``most`` frames spread evenly over the list."""
    idx = np.unique(np.linspace(0, len(frames) - 1, min(most, len(frames))).round().astype(int))
    return np.median(np.stack([frames[i] for i in idx]), axis=0).astype(np.uint8)


def noise_threshold(frames: list[np.ndarray], background: np.ndarray) -> float:
    """Foreground threshold [grey levels]: 6 robust sigmas of frame - background, at least 14."""
    idx = np.linspace(0, len(frames) - 1, min(8, len(frames))).round().astype(int)
    d = np.concatenate([cv2.absdiff(frames[i], background).ravel()[::7] for i in idx]).astype(float)
    sigma = 1.4826 * float(np.median(d)) / 0.6745 if d.size else 0.0  # |N(0,s)| has median 0.6745 s
    return max(14.0, 6.0 * sigma)


# ----------------------------------------------------------------------------- the jumper's track
@dataclass
class Track:
    """A blob followed from frame to frame (thumbnail pixels)."""

    frames: list[int] = field(default_factory=list)
    centroids: list[np.ndarray] = field(default_factory=list)
    boxes: list[tuple[int, int, int, int]] = field(default_factory=list)  # x, y, w, h

    def predict(self) -> np.ndarray:
        if len(self.centroids) >= 2:
            return 2 * self.centroids[-1] - self.centroids[-2]
        return self.centroids[-1]

    @property
    def travel(self) -> float:
        return float(np.linalg.norm(self.centroids[-1] - self.centroids[0])) if self.centroids else 0.0


def find_jumper(thumbs: list[np.ndarray], background: np.ndarray, threshold: float) -> Track:
    """The foreground track that travels farthest across the image (the jumper).

    Blobs are linked to tracks by the smallest distance to the track's
    constant-velocity prediction, within a gate of 1.5 times the last step plus
    1.5 blob sizes, and only between blobs of similar area (ratio < 3), so a
    flag or a person the jumper passes does not take over its track.

    Raises
    ------
    InputError
        No moving blob crosses a tenth of the frame in at least 4 frames.
    """
    h, w = background.shape
    min_area = max(8, int(1.5e-4 * w * h))
    merge = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7))
    tracks: list[Track] = []
    active: list[Track] = []
    areas: dict[int, float] = {}
    for f, th in enumerate(thumbs):
        mask = (cv2.absdiff(th, background) > threshold).astype(np.uint8)
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((2, 2), np.uint8))
        mask = cv2.dilate(mask, merge)
        n, _, stats, cents = cv2.connectedComponentsWithStats(mask, connectivity=8)
        blobs = [(cents[i], tuple(int(v) for v in stats[i, :4]), float(stats[i, 4])) for i in range(1, n)]
        blobs = [b for b in blobs if b[2] >= min_area]
        pairs = []
        for ti, tr in enumerate(active):
            if tr.frames[-1] != f - 1:
                continue
            pred = tr.predict()
            step = float(np.linalg.norm(tr.centroids[-1] - tr.centroids[-2])) if len(tr.centroids) > 1 else 0.0
            a_prev = areas[id(tr)]
            gate = 1.5 * step + 1.5 * math.sqrt(a_prev) + 4.0
            for bi, (c, _, a) in enumerate(blobs):
                d = float(np.linalg.norm(c - pred))
                if d < gate and 1 / 3 < a / a_prev < 3:
                    pairs.append((d / gate, ti, bi))
        pairs.sort()
        t_used: set[int] = set()
        b_used: set[int] = set()
        still: list[Track] = []
        for _, ti, bi in pairs:
            if ti in t_used or bi in b_used:
                continue
            t_used.add(ti)
            b_used.add(bi)
            tr = active[ti]
            c, box, a = blobs[bi]
            tr.frames.append(f)
            tr.centroids.append(np.asarray(c, float))
            tr.boxes.append(box)  # type: ignore[arg-type]
            areas[id(tr)] = a
            still.append(tr)
        for bi, (c, box, a) in enumerate(blobs):
            if bi not in b_used:
                tr = Track([f], [np.asarray(c, float)], [box])  # type: ignore[list-item]
                areas[id(tr)] = a
                tracks.append(tr)
                still.append(tr)
        active = still
    good = [t for t in tracks if len(t.frames) >= 4 and t.travel >= 0.1 * w]
    if not good:
        raise InputError(
            "no jumper found: nothing moves across the landing slope; expected a video of a jumper landing "
            "filmed by a fixed camera"
        )
    return max(good, key=lambda t: t.travel)


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


# ----------------------------------------------------------------------------- the result
@dataclass
class JumpReading:
    """A jump read from a video.

    Attributes
    ----------
    video : str
    fps : float
        Frame rate [1/s].
    frames : int
        Frames decoded.
    touchdown_frame : int
        First frame (0-based) with both skis on the snow.
    touchdown_exact : float
        Touch-down instant in frame units (sub-frame, from the hinge fit).
    jump_length : float
        Distance of the skis' middle at the touch-down along the profile from F [m].
    std_jump_length : float
        Its estimated standard deviation [m].
    confidence : float
        Probability that the jump length is within 0.5 m [1].
    touchdown_y : float
        Lateral position of the skis' lower edge at the touch-down [m] (marker y units).
    speed : float
        Speed of the skis' middle along the slope at the touch-down [m/s].
    calibration_rms : float
        RMS reprojection error of the markers used [px].
    """

    video: str
    fps: float
    frames: int
    touchdown_frame: int
    touchdown_exact: float
    jump_length: float
    std_jump_length: float
    confidence: float
    touchdown_y: float
    speed: float
    calibration_rms: float
    series: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    details: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def touchdown_time(self) -> float:
        """Touch-down time after the first frame [s]."""
        return self.touchdown_exact / self.fps


# ----------------------------------------------------------------------------- the reading
class _Frames:
    """Full-resolution grey crops of the frames with the jumper, and their background."""

    def __init__(self, band: tuple[int, int, int, int], crops: dict[int, np.ndarray], background: np.ndarray):
        self.band = band  # x0, y0, x1, y1 (full-resolution pixels)
        self.crops = crops
        self.background = background


def _full_res_band(
    path: str,
    info: VideoInfo,
    thumbs: list[np.ndarray],
    bg_thumb: np.ndarray,
    k: int,
    track: Track,
    progress: Progress,
) -> _Frames:
    """Crops of the band the jumper crosses, at full resolution, for the tracked frames."""
    xs = [b[0] for b in track.boxes] + [b[0] + b[2] for b in track.boxes]
    ys = [b[1] for b in track.boxes] + [b[1] + b[3] for b in track.boxes]
    pad = 8
    x0 = max(0, (min(xs) - pad) * k)
    y0 = max(0, (min(ys) - pad) * k)
    x1 = min(info.width, (max(xs) + pad) * k)
    y1 = min(info.height, (max(ys) + pad) * k)
    f0, f1 = track.frames[0], track.frames[-1]
    if k == 1:
        crops = {f: thumbs[f][y0:y1, x0:x1] for f in range(f0, f1 + 1)}
        return _Frames((x0, y0, x1, y1), crops, bg_thumb[y0:y1, x0:x1])
    # a second read at full resolution, frames f0 - 12 .. f1 + 12 (extra frames for the background)
    a, b = max(0, f0 - 12), min(info.frames - 1, f1 + 12)
    cap, _ = open_video(path)
    crops: dict[int, np.ndarray] = {}
    extra: list[np.ndarray] = []
    try:
        for f in progress(range(b + 1), b + 1, "measuring"):
            if f < a:
                if not cap.grab():
                    break
                continue
            ok, fr = cap.read()
            if not ok:
                break
            g = _gray(fr)[y0:y1, x0:x1].copy()
            if f0 <= f <= f1:
                crops[f] = g
            else:
                extra.append(g)
    finally:
        cap.release()
    stack = list(crops.values()) + extra
    if not stack:
        raise InputError(f"cannot re-read the frames with the jumper from {path}; expected a seekable video")
    return _Frames((x0, y0, x1, y1), crops, median_background(stack, most=21))


def _observe(
    fr: _Frames, track: Track, k: int, threshold: float, px_per_m: float, width: int, height: int
) -> list[SkiObs]:
    """Skis in every tracked frame."""
    x0, y0, x1, y1 = fr.band
    out: list[SkiObs] = []
    min_area = max(4, int(0.002 * px_per_m * px_per_m))
    tol = max(1.5, 0.06 * px_per_m)
    gap = max(3.0, 0.25 * px_per_m)
    for f, box in zip(track.frames, track.boxes, strict=True):
        crop = fr.crops.get(f)
        if crop is None:
            continue
        bx, by, bw, bh = box
        cx0 = max(0, (bx - 4) * k - x0)
        cy0 = max(0, (by - 4) * k - y0)
        cx1 = min(x1 - x0, (bx + bw + 4) * k - x0)
        cy1 = min(y1 - y0, (by + bh + 4) * k - y0)
        diff = cv2.absdiff(crop[cy0:cy1, cx0:cx1], fr.background[cy0:cy1, cx0:cx1])
        mask = (diff > threshold).astype(np.uint8)
        n, lab, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        keep = np.zeros(n, bool)
        keep[1:] = stats[1:, 4] >= min_area
        mask = keep[lab]
        if mask.sum() < 10:
            continue
        cols, rows = lower_envelope(mask)
        found = ski_line(cols, rows, tol, gap)
        if found is None:
            continue
        run, (a, b) = found
        gx, gy = cx0 + x0, cy0 + y0
        edge = half_max_edge(diff, cols[run].astype(int), rows[run].astype(int), depth=max(3, int(0.15 * px_per_m)))
        env = np.stack((cols[run] + gx, edge + gy), -1)
        # line in full-frame pixels: row = a + gy + b (col - gx)
        line = (a + gy - b * gx, b)
        lo, hi = ski_ends(mask, cols[run], (a, b), up=tol + 0.12 * px_per_m, down=tol, gap=gap)
        ends = (lo + gx, hi + gx)
        border = bool(ends[0] <= 2 or ends[1] >= width - 3 or env[:, 1].max() >= height - 2)
        out.append(SkiObs(f, env, line, ends, border))
    return out


@dataclass
class _Fit:
    f_td: float  # touch-down [frame units]
    c: float  # level of Y on the snow at f_td [m]
    u_frames: float  # standard uncertainty of f_td [frames]
    sigma: float  # noise of Y [m]
    coarse: int  # first frame on the final level
    z: float  # drop of the flight part over the fit window / residual noise [1]
    coef: np.ndarray  # hinge coefficients (c, drift, a, b), see _hinge_design


def _noise(y: np.ndarray) -> float:
    if y.size < 5:
        return float(np.std(y)) if y.size else 0.0
    d2 = np.diff(y, 2)
    return 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6.0)


def _hinge_design(f: np.ndarray, ft: float, order: int) -> np.ndarray:
    """Columns ``1, f - ft, tau, tau^2 (, tau^3)`` with ``tau = max(ft - f, 0)``."""
    tau = np.maximum(ft - f, 0.0)
    cols = [np.ones_like(f), f - ft] + [tau**k for k in range(1, order + 1)]
    return np.stack(cols, -1)


def _hinge_sse(f: np.ndarray, Y: np.ndarray, ft: float, order: int) -> tuple[float, np.ndarray]:
    A = _hinge_design(f, ft, order)
    coef, *_ = np.linalg.lstsq(A, Y, rcond=None)
    r = Y - A @ coef
    return float(r @ r), coef


def fit_touchdown(f: np.ndarray, Y: np.ndarray, fps: float, floor: float) -> _Fit:
    """Sub-frame touch-down from the lowest-point series ``Y(f)`` (see the module text).

    Model: ``Y = c + d (f - f_td) + a tau + b tau^2`` with ``tau = max(f_td - f, 0)``:
    the skis come down (``a > 0``) until ``f_td``, then stay on a level that
    may drift slowly (``d``, the calibration's error along the track).  A
    coarse search over all frames (cubic flight part) finds the kink, a fit on
    the 0.2 s either side of it (quadratic flight part) places it to 0.01 frame.

    Parameters
    ----------
    f : ndarray
        Frame numbers (increasing).
    Y : ndarray
        Lowest points of the skis mapped to the slope, signed away from the camera [m]; inf: far above.
    fps : float
        Frame rate [1/s].
    floor : float
        Smallest noise level of ``Y`` assumed [m].

    Raises
    ------
    InputError
        No descent onto a level with at least three frames before and after it.
    """
    ok = np.isfinite(Y)
    f, Y = f[ok], Y[ok]
    if f.size < 8:
        raise InputError("the skis were measured in fewer than 8 frames; expected the landing in view")
    sigma = max(_noise(Y), floor / 4)
    # coarse: the kink over all frames
    grid = np.arange(f[2], f[-4] + 1e-9, 0.25)
    if grid.size == 0:
        raise InputError("too few frames around the touch-down; expected the landing in view")
    costs = [_hinge_sse(f, Y, g, 3)[0] for g in grid]
    j = float(grid[int(np.argmin(costs))])
    # fine: +-0.2 s around it
    K = max(4, int(round(0.2 * fps)))
    M = max(4, int(round(0.2 * fps)))
    win = (f >= j - K - 1) & (f <= j + M)
    fw, yw = f[win], Y[win]

    def best(fw: np.ndarray, yw: np.ndarray) -> float:
        grid = np.arange(j - 1.5, j + 1.5 + 1e-9, 0.05)
        g0 = float(grid[int(np.argmin([_hinge_sse(fw, yw, g, 2)[0] for g in grid]))])
        grid = np.arange(g0 - 0.05, g0 + 0.05 + 1e-9, 0.005)
        return float(grid[int(np.argmin([_hinge_sse(fw, yw, g, 2)[0] for g in grid]))])

    ft = best(fw, yw)
    _, coef = _hinge_sse(fw, yw, ft, 2)
    res = yw - _hinge_design(fw, ft, 2) @ coef
    keep = np.abs(res) <= max(5 * sigma, floor)
    if keep.sum() >= 7 and not keep.all():
        fw, yw = fw[keep], yw[keep]
        ft = best(fw, yw)
    cost, coef = _hinge_sse(fw, yw, ft, 2)
    n_before, n_after = int(np.sum(fw < ft)), int(np.sum(fw >= ft))
    if n_before < 3 or n_after < 3:
        raise InputError(
            "the skis do not settle on the snow while in view; expected the touch-down in view with at least "
            "three frames before and after it"
        )
    c, d, a, b = (float(v) for v in coef)
    span = max(ft - float(fw.min()), 1.0)
    drop = a * span + b * span * span
    rate = drop / span  # mean descent per frame over the flight part
    if not (a > 0 and drop > 0 and abs(d) < 0.5 * rate):
        raise InputError(
            "no touch-down found: the skis' lowest points never stop coming down onto a level; expected a landing"
        )
    dof = max(fw.size - 5, 1)
    s2 = max(cost / dof, sigma * sigma)
    h = 0.05
    curv = (_hinge_sse(fw, yw, ft + h, 2)[0] - 2 * cost + _hinge_sse(fw, yw, ft - h, 2)[0]) / (h * h)
    u = math.sqrt(2 * s2 / curv) if curv > 0 else 1.0
    return _Fit(ft, c, min(u, 1.0), math.sqrt(s2), int(math.ceil(j)), drop / math.sqrt(s2), coef)


def _series(obs: list[SkiObs], smap: SlopeMap, sign: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frame numbers, lowest-point series Y [m] and the skis' middle distance s [m] under one map."""
    f, Y, S = [], [], []
    for o in obs:
        _, y = smap.to_slope(o.env)
        # a ski seen above the slope's horizon maps behind the camera: far above the snow
        y = np.where(smap.in_front(o.env), sign * y, np.inf)
        Y.append(float(np.quantile(y, 0.2, method="lower")))
        S.append(float(smap.to_slope(o.middle)[0]))
        f.append(o.frame)
    return np.array(f, float), np.array(Y), np.array(S)


def _floor(smap: SlopeMap, s: float) -> float:
    """0.6 px expressed as a lateral distance [m] at ``(s, 0)``."""
    jac = smap.jacobian(s, 0.0)
    return 0.6 / max(float(np.hypot(*jac[:, 1])), 1e-6)


def read_skis(path: str | Path, markers: Markers, progress: Progress = _no_progress) -> tuple[VideoInfo, list[SkiObs]]:
    """Steps 1-2 of the module text: the jumper's skis in every frame they are fully in view.

    Raises
    ------
    InputError
        Unreadable video, markers outside the frame, no jumper, skis seen in fewer than 6 frames.
    """
    info, thumbs, k = read_thumbnails(path, progress)
    check_in_frame(markers, info.width, info.height, where=f"markers for {Path(path).name}")
    whole = fit_slope_map(markers)
    bg = median_background(thumbs)
    thr = noise_threshold(thumbs, bg)
    track = find_jumper(thumbs, bg, thr)
    frames = _full_res_band(str(path), info, thumbs, bg, k, track, progress)
    del thumbs
    thr_full = thr if k == 1 else noise_threshold(list(frames.crops.values()), frames.background)
    # pixels per metre along the slope where the jumper is
    boxes = np.array(track.boxes, float)
    mid_px = np.array([np.mean(boxes[:, 0] + boxes[:, 2] / 2), np.mean(boxes[:, 1] + boxes[:, 3])]) * k
    s_guess, _ = whole.to_slope(mid_px)
    px_per_m = float(np.linalg.norm(whole.jacobian(float(s_guess), 0.0)[:, 0]))
    if not (np.isfinite(px_per_m) and px_per_m > 0):
        px_per_m = info.width / 30.0
    obs = _observe(frames, track, k, thr_full, px_per_m, info.width, info.height)
    obs = [o for o in obs if not o.touches_border]
    if obs:
        lengths = np.array([o.ends[1] - o.ends[0] for o in obs])
        obs = [o for o, n in zip(obs, lengths, strict=True) if n >= 0.6 * np.median(lengths)]
    if len(obs) < 6:
        raise InputError(
            f"the skis were found in only {len(obs)} frame(s); expected the jumper's skis fully in view in at least 6"
        )
    return info, obs


def read_jump(obs: list[SkiObs], markers: Markers, fps: float, half_window: float = 7.0) -> dict[str, Any]:
    """Steps 3-5 of the module text: touch-down and jump length from the skis' observations.

    Slope maps are fitted around distances 3 m apart along the skis' track;
    under each, the frames within ``half_window`` [m] are searched for a
    touch-down, and the one found nearest its map's centre is refined with a
    map centred on it.

    Raises
    ------
    InputError
        No touch-down: the skis never settle onto the snow while in view.
    """
    whole = fit_slope_map(markers)
    s_whole = np.array([float(whole.to_slope(o.middle)[0]) for o in obs])
    s_mid = float(np.nanmedian(s_whole))
    sign = fit_slope_map(markers, s_mid).away_sign(s_mid)
    found = []
    last_error = None
    for sc in np.arange(np.floor(np.nanmin(s_whole)), np.nanmax(s_whole) + 3.0, 3.0):
        sel = np.abs(s_whole - sc) <= half_window
        if sel.sum() < 8:
            continue
        smap = fit_slope_map(markers, float(sc))
        sub = [o for o, m in zip(obs, sel, strict=True) if m]
        f, Y, S = _series(sub, smap, sign)
        try:
            fit = fit_touchdown(f, Y, fps, _floor(smap, float(sc)))
        except InputError as exc:
            last_error = exc
            continue
        s_td = float(np.interp(fit.f_td, f, S))
        if abs(s_td - sc) <= 0.65 * half_window and np.isfinite(fit.z):
            found.append((fit.z, s_td))
    if not found:
        if last_error is None:  # no stretch of the track had 8 frames to fit
            raise InputError(
                f"the skis were measured in too few frames around the landing ({len(obs)} in all); expected the "
                "landing in view for at least 8 frames (a wider view or a higher frame rate)"
            )
        raise last_error
    s_td = max(found)[1]
    smap = fit_slope_map(markers, s_td)
    sel = np.abs(s_whole - s_td) <= half_window
    sub = [o for o, m in zip(obs, sel, strict=True) if m]
    f, Y, S = _series(sub, smap, sign)
    fit = fit_touchdown(f, Y, fps, _floor(smap, s_td))
    # the skis' middle in the frames after the touch-down (on the snow): a line in time, read at f_td
    post = (f >= math.ceil(fit.f_td - 1e-9)) & (f <= math.ceil(fit.f_td) + max(3, int(round(0.12 * fps))))
    if post.sum() < 2:
        post = np.abs(f - fit.f_td) <= 3
    beta, alpha = np.polyfit(f[post] - fit.f_td, S[post], 1)
    resid = S[post] - (alpha + beta * (f[post] - fit.f_td))
    u_track = float(np.sqrt(np.sum(resid**2) / max(int(post.sum()) - 2, 1)) / math.sqrt(post.sum()))
    length = float(alpha)
    px_m = float(np.linalg.norm(smap.jacobian(length, 0.0)[:, 0]))
    u_cal = smap.rms_px / max(px_m, 1e-6) / math.sqrt(max(smap.used / 4, 1.0))
    # floors: the residual systematic errors of the bench (0.1 frame in timing, 5 cm in position)
    u = math.sqrt((beta * max(fit.u_frames, TIMING_FLOOR)) ** 2 + u_track**2 + u_cal**2 + POSITION_FLOOR**2)
    return {
        "fit": fit,
        "length": length,
        "std": u,
        "speed": abs(float(beta)) * fps,
        "y": sign * fit.c,
        "map": smap,
        "series": {"frame": f, "Y": Y, "s_mid": S},
        "details": {"obs": {o.frame: o for o in sub}, "map": smap, "fit": fit, "sign": sign, "line": (alpha, beta)},
    }


def measure_video(
    path: str | Path,
    markers: Markers,
    progress: Progress = _no_progress,
) -> JumpReading:
    """Read the touch-down frame and the jump length from a landing video.

    Parameters
    ----------
    path : str or Path
        The video (any format OpenCV decodes).
    markers : Markers
        Marker calibration for this camera placement.
    progress : callable, optional
        ``progress(iterable, length, label)`` wrapping the frame loops.

    Raises
    ------
    InputError
        Unreadable video, markers outside the frame, no jumper, no touch-down in view.
    """
    info, obs = read_skis(path, markers, progress)
    r = read_jump(obs, markers, info.fps)
    fit, u = r["fit"], r["std"]
    conf = math.erf(READING_ACCURACY / (math.sqrt(2) * u)) if u > 0 else 1.0
    return JumpReading(
        video=str(path),
        fps=info.fps,
        frames=info.frames,
        touchdown_frame=int(math.ceil(fit.f_td - 1e-6)),
        touchdown_exact=fit.f_td,
        jump_length=r["length"],
        std_jump_length=u,
        confidence=conf,
        touchdown_y=r["y"],
        speed=r["speed"],
        calibration_rms=r["map"].rms_px,
        series=r["series"],
        details=r["details"],
    )
