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
3. **Calibration.** The slope map of :mod:`~sportfusion.skijump.video.calibration` (a
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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.stats import median
from sportfusion.skijump.video.calibration import SlopeMap, fit_slope_map
from sportfusion.skijump.video.markers import Markers, check_in_frame
from sportfusion.skijump.video.reader import (
    Progress,
    Track,
    VideoInfo,
    _gray,
    _no_progress,
    find_jumper,
    median_background,
    noise_threshold,
    open_video,
    read_thumbnails,
)
from sportfusion.skijump.video.skis import SkiObs, half_max_edge, lower_envelope, ski_ends, ski_line
from sportfusion.skijump.video.touchdown import fit_touchdown

#: Reading accuracy of the paper's manual video reading [m] (Appendix B).
READING_ACCURACY = 0.5


#: Smallest timing and position uncertainty assumed [frames], [m] (systematic errors seen in bench/bench_video.py).
TIMING_FLOOR = 0.1


POSITION_FLOOR = 0.05


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
        obs = [o for o, n in zip(obs, lengths, strict=True) if n >= 0.6 * median(lengths)]
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
