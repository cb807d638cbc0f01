"""Pictures for people: annotated frames of a video reading, and a pixel grid for measuring markers.

* :func:`write_debug` -- the frames around the touch-down with the markers,
  the distance lines across the slope, the slope line at the jumper's lateral
  position, the skis' lower edge and middle, and a plot of the skis' lowest
  points over time with the fitted touch-down, so that a coach can check the
  decision;
* :func:`grid_image` -- a frame without the jumper (median of frames) with a
  labelled pixel grid, from which a user reads the marker pixels.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.stats import median
from sportfusion.skijump.video.markers import Markers
from sportfusion.skijump.video.measure import JumpReading
from sportfusion.skijump.video.reader import open_video
from sportfusion.skijump.video.touchdown import _hinge_design

FONT = cv2.FONT_HERSHEY_SIMPLEX


def _text(img: np.ndarray, text: str, org: tuple[int, int], scale: float, colour: tuple[int, int, int]) -> None:
    """Text with a black outline (the glyphs' mask dilated: a thicker putText would be wider and misalign)."""
    th = max(1, int(round(2 * scale)))
    (w, h), base = cv2.getTextSize(text, FONT, scale, th)
    x, y = org
    pad = 3
    x0, y0 = max(0, x - pad), max(0, y - h - pad)
    x1, y1 = min(img.shape[1], x + w + pad), min(img.shape[0], y + base + pad)
    if x1 <= x0 or y1 <= y0:
        return
    mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
    cv2.putText(mask, text, (x - x0, y - y0), FONT, scale, 255, th, cv2.LINE_AA)
    edge = cv2.dilate(mask, np.ones((3, 3), np.uint8)).astype(np.float32)[..., None] / 255.0
    glyph = mask.astype(np.float32)[..., None] / 255.0
    roi = img[y0:y1, x0:x1].astype(np.float32) * (1.0 - edge)
    roi = roi * (1.0 - glyph) + np.asarray(colour, np.float32) * glyph
    img[y0:y1, x0:x1] = np.clip(roi, 0, 255).astype(np.uint8)


def _pt(p: np.ndarray) -> tuple[int, int]:
    return (int(round(float(p[0]) * 16)), int(round(float(p[1]) * 16)))


def annotate_frame(img: np.ndarray, reading: JumpReading, markers: Markers, frame: int) -> np.ndarray:
    """One video frame (BGR) with the reading's evidence drawn over it."""
    out = img.copy()
    det = reading.details
    smap, fit = det["map"], det["fit"]
    scale = max(0.6, out.shape[1] / 1400)
    # markers and the distance lines across the slope near the landing
    for c, r in markers.pixels:
        cv2.circle(out, _pt(np.array([c, r])), int(3 * 16 * scale), (255, 255, 0), 1, cv2.LINE_AA, 4)
    y_lo, y_hi = float(markers.y.min()), float(markers.y.max())
    for s in np.arange(np.floor(reading.jump_length) - 5, np.floor(reading.jump_length) + 7):
        a, b = smap.to_image(np.array([s, s]), np.array([y_lo, y_hi]))
        if np.all(np.isfinite([*a, *b])):
            major = int(s) % 5 == 0
            cv2.line(out, _pt(a), _pt(b), (200, 200, 200) if not major else (0, 200, 255), 1, cv2.LINE_AA, 4)
            if major:
                _text(out, f"{int(s)}", (int(b[0]) + 4, int(b[1])), 0.5 * scale, (0, 200, 255))
    # the slope line at the jumper's lateral position (what "on the snow" means)
    y_j = det["sign"] * fit.c
    ss = np.linspace(reading.jump_length - 8, reading.jump_length + 8, 33)
    line = smap.to_image(ss, np.full(ss.size, y_j))
    ok = np.all(np.isfinite(line), 1)
    if ok.sum() >= 2:
        pts = np.round(line[ok] * 16).astype(np.int32)
        cv2.polylines(out, [pts], False, (0, 220, 0), 1, cv2.LINE_AA, 4)
    obs = det["obs"].get(frame)
    on_snow = frame >= reading.touchdown_frame
    if obs is not None:
        for p in obs.env[:: max(1, len(obs.env) // 60)]:
            cv2.circle(out, _pt(p), int(1.5 * 16 * scale), (0, 0, 255), -1, cv2.LINE_AA, 4)
        m = obs.middle
        cv2.drawMarker(out, (int(round(m[0])), int(round(m[1]))), (0, 255, 255), cv2.MARKER_CROSS, int(14 * scale), 2)
        s_m = float(smap.to_slope(m)[0])
        _text(out, f"{s_m:.1f} m", (int(m[0]) + 6, int(m[1]) + int(24 * scale)), 0.55 * scale, (0, 255, 255))
    head = f"frame {frame}  t = {frame / reading.fps:.3f} s"
    if frame == reading.touchdown_frame:
        head += "  TOUCH-DOWN"
    _text(out, head, (10, int(30 * scale)), 0.8 * scale, (0, 255, 0) if on_snow else (255, 255, 255))
    _text(
        out,
        f"jump length {reading.jump_length:.2f} m +- {reading.std_jump_length:.2f}  (touch-down at frame "
        f"{reading.touchdown_exact:.2f})",
        (10, int(60 * scale)),
        0.6 * scale,
        (255, 255, 255),
    )
    return out


def series_plot(reading: JumpReading, width: int = 900, height: int = 420) -> np.ndarray:
    """Plot of the skis' lowest points (relative to the snow level) per frame with the fitted touch-down."""
    fit = reading.details["fit"]
    f, Y = reading.series["frame"], reading.series["Y"]
    ok = np.isfinite(Y)
    f, Y = f[ok], Y[ok]
    img = np.full((height, width, 3), 255, np.uint8)
    if f.size < 2:
        return img
    m = 50
    lo, hi = float(f.min()) - 0.5, float(f.max()) + 0.5
    yl, yh = float(np.min(Y)), float(np.max(Y))
    yh = yh if yh > yl else yl + 1.0

    def px(fr: np.ndarray, yy: np.ndarray) -> np.ndarray:
        u = m + (fr - lo) / (hi - lo) * (width - 2 * m)
        v = height - m - (yy - yl) / (yh - yl) * (height - 2 * m)
        return np.stack((u, v), -1)

    cv2.rectangle(img, (m, m), (width - m, height - m), (0, 0, 0), 1)
    for k in range(int(np.ceil(lo)), int(hi) + 1, max(1, int((hi - lo) // 15))):
        u = int(px(np.array([k]), np.array([yl]))[0, 0])
        cv2.line(img, (u, height - m), (u, height - m + 5), (0, 0, 0), 1)
        cv2.putText(img, str(k), (u - 8, height - m + 20), FONT, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    for yv in np.linspace(yl, yh, 5):
        v = int(px(np.array([lo]), np.array([yv]))[0, 1])
        cv2.line(img, (m - 5, v), (m, v), (0, 0, 0), 1)
        cv2.putText(img, f"{yv:.2f}", (2, v + 4), FONT, 0.35, (0, 0, 0), 1, cv2.LINE_AA)
    fine = np.linspace(float(f.min()), float(f.max()), 400)
    for p in px(f, Y):
        cv2.circle(img, (int(p[0]), int(p[1])), 3, (200, 80, 0), -1, cv2.LINE_AA)
    # the fitted hinge over its window
    fw = fine[(fine >= fit.f_td - 0.25 * reading.fps) & (fine <= fit.f_td + 0.25 * reading.fps)]
    if fw.size:
        yy = _hinge_design(fw, fit.f_td, 2) @ fit.coef
        pts = np.round(px(fw, yy)).astype(np.int32)
        cv2.polylines(img, [pts], False, (0, 0, 220), 2, cv2.LINE_AA)
    u = int(px(np.array([fit.f_td]), np.array([yl]))[0, 0])
    cv2.line(img, (u, m), (u, height - m), (0, 160, 0), 1, cv2.LINE_AA)
    cv2.putText(img, f"touch-down {fit.f_td:.2f}", (u + 5, m + 15), FONT, 0.5, (0, 160, 0), 1, cv2.LINE_AA)
    label = "lowest points of the skis seen on the slope, away from the camera [m]"
    cv2.putText(img, label, (m, m - 15), FONT, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(img, "frame", (width // 2, height - 10), FONT, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    return img


def write_debug(
    video: str | Path, reading: JumpReading, markers: Markers, folder: str | Path, around: int = 3
) -> list[Path]:
    """Write annotated PNG frames ``touchdown_frame +- around`` and ``series.png`` into ``folder``."""
    out_dir = Path(folder)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create the debug folder {out_dir}: {exc.strerror}; expected a writable path") from exc
    stem = Path(video).stem
    want = set(range(reading.touchdown_frame - around, reading.touchdown_frame + around + 1))
    written: list[Path] = []
    cap, _ = open_video(video)
    try:
        k = 0
        while k <= max(want):
            ok, fr = cap.read()
            if not ok:
                break
            if k in want:
                p = out_dir / f"{stem}_frame{k:05d}.png"
                cv2.imwrite(str(p), annotate_frame(fr, reading, markers, k))
                written.append(p)
            k += 1
    finally:
        cap.release()
    p = out_dir / f"{stem}_series.png"
    cv2.imwrite(str(p), series_plot(reading))
    written.append(p)
    return written


def grid_image(video: str | Path, step: int = 50, most: int = 25) -> np.ndarray:
    """A frame of ``video`` without moving objects (median of up to ``most`` frames) with a pixel grid.

    Lines every ``step`` px, labelled every second line with the column/row.
    """
    cap, info = open_video(video)
    frames: list[np.ndarray] = []
    try:
        n = info.frames if info.frames > 0 else 10**9
        want = set(np.linspace(0, max(n - 1, 0), min(most, n)).round().astype(int).tolist()) if n < 10**9 else None
        k = 0
        while True:
            ok, fr = cap.read()
            if not ok:
                break
            if want is None or k in want:
                frames.append(fr)
            k += 1
    finally:
        cap.release()
    if not frames:
        raise InputError(f"cannot read any frame of video {video}; expected a video OpenCV can decode")
    img = median(np.stack(frames), axis=0).astype(np.uint8)
    h, w = img.shape[:2]
    over = img.copy()
    for x in range(0, w, step):
        cv2.line(over, (x, 0), (x, h - 1), (0, 0, 255) if (x // step) % 2 == 0 else (255, 0, 0), 1)
    for y in range(0, h, step):
        cv2.line(over, (0, y), (w - 1, y), (0, 0, 255) if (y // step) % 2 == 0 else (255, 0, 0), 1)
    img = cv2.addWeighted(over, 0.55, img, 0.45, 0)
    sc = max(0.35, w / 2400)
    for x in range(0, w, 2 * step):
        _text(img, str(x), (x + 2, int(14 * sc / 0.35)), sc, (255, 255, 255))
    for y in range(2 * step, h, 2 * step):
        _text(img, str(y), (2, y - 3), sc, (255, 255, 255))
    return img
