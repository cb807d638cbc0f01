"""Reading a landing video: grey thumbnails, the median background and the jumper's track.

Step 1 ("Jumper") of :mod:`sportfusion.skijump.video.measure`: every frame is read once (OpenCV) and kept
grey, decimated to at most 480 px wide; the background is the per-pixel median of up to 49 frames spread
over the video, the foreground what differs from it by more than 6 robust sigmas of the image noise.
Foreground blobs are linked from frame to frame (nearest to a constant-velocity prediction, similar area);
the jumper is the track that travels farthest (a person walking or flags waving stay put).  Pixels are
image pixels, times frame numbers.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.stats import median, unique

THUMB_WIDTH = 480


#: a progress wrapper: (iterable, length, label) -> iterable
Progress = Callable[[Iterable[Any], int | None, str], Iterator[Any]]


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
    if w > MAX_SIDE or h > MAX_SIDE or w * h > MAX_FRAME_PIXELS or fps > 10000:
        cap.release()
        raise InputError(
            f"video {p} declares {w}x{h} px frames at {fps:g} fps; refused (limits: {MAX_SIDE} px a side, "
            f"{MAX_FRAME_PIXELS / 1e6:g} Mpx a frame, 10000 fps)"
        )
    if n > 0 and n * thumb_bytes(w, h) > _max_video_bytes():
        cap.release()
        raise InputError(
            f"video {p} declares {n} frames of {w}x{h} px, ~{n * thumb_bytes(w, h) / 1024**2:.0f} MiB of "
            f"thumbnails; refused (limit {_max_video_bytes() / 1024**2:.0f} MiB, SPORTFUSION_MAX_VIDEO_BYTES)"
        )
    return cap, VideoInfo(str(p), w, h, fps, n)


#: Limits on what a video may declare (a hostile file must not exhaust memory): frame side [px],
#: frame area [px], and the grey thumbnails kept in memory [bytes] (SPORTFUSION_MAX_VIDEO_BYTES).
MAX_SIDE = 16384
MAX_FRAME_PIXELS = 40_000_000
MAX_VIDEO_BYTES = 2 * 1024**3


def _max_video_bytes() -> float:
    import os

    try:
        value = float(os.environ.get("SPORTFUSION_MAX_VIDEO_BYTES", MAX_VIDEO_BYTES))
    except ValueError:
        return MAX_VIDEO_BYTES
    return value if math.isfinite(value) and value > 0 else MAX_VIDEO_BYTES


def thumb_bytes(width: int, height: int) -> int:
    """Bytes of one grey thumbnail of a ``width`` x ``height`` frame (see :func:`read_thumbnails`)."""
    k = max(1, math.ceil(width / THUMB_WIDTH))
    return (width // k) * (height // k)


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

    budget, used = _max_video_bytes(), 0
    try:
        for fr in progress(frames(), info.frames or None, "reading"):
            used += size[0] * size[1]
            if used > budget:
                raise InputError(
                    f"video {info.path} has more frames than fit the limit of {budget / 1024**2:.0f} MiB of "
                    "thumbnails (SPORTFUSION_MAX_VIDEO_BYTES); refused"
                )
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
    idx = unique(np.linspace(0, len(frames) - 1, min(most, len(frames))).round().astype(int))
    return median(np.stack([frames[i] for i in idx]), axis=0).astype(np.uint8)


def noise_threshold(frames: list[np.ndarray], background: np.ndarray) -> float:
    """Foreground threshold [grey levels]: 6 robust sigmas of frame - background, at least 14."""
    idx = np.linspace(0, len(frames) - 1, min(8, len(frames))).round().astype(int)
    d = np.concatenate([cv2.absdiff(frames[i], background).ravel()[::7] for i in idx]).astype(float)
    sigma = 1.4826 * float(median(d)) / 0.6745 if d.size else 0.0  # |N(0,s)| has median 0.6745 s
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
