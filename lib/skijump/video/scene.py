"""The static scene a landing camera films: slope, distance markers, boards, forest, sky.

The landing slope is the hill's landing profile extruded across the hill
(:class:`~sportfusion.skijump.video.camera.Slope`), textured with snow in slope
coordinates; every metre a small marker plate stands on the snow on both
sides of the slope (``y = +-slope_width / 2``), every 5 m a board with the
distance; advertising boards and a forest stand behind the far side.  The
image is ray-cast once per video (coarse march, then Newton per pixel).
"""

from __future__ import annotations

import cv2
import numpy as np

from sportfusion.skijump.video.camera import Camera, Slope
from sportfusion.skijump.video.markers import Markers


def _rgb(hex_colour: str) -> tuple[int, int, int]:
    """'#rrggbb' -> OpenCV BGR tuple."""
    h = hex_colour.lstrip("#")
    r, g, b = (int(h[i : i + 2], 16) for i in (0, 2, 4))
    return (b, g, r)


# ----------------------------------------------------------------------------- static scene
class Scene:
    """The static scene behind the jumper: slope, markers, boards, forest, sky."""

    def __init__(self, slope: Slope, camera: Camera, slope_width: float, rng: np.random.Generator) -> None:
        self.slope, self.camera = slope, camera
        self.far = 1.0 if camera.position[1] < 0 else -1.0  # sign of y on the far side
        self.half = slope_width / 2
        self.rng = rng
        self.image = self._render()

    # -- ray casting ------------------------------------------------------------
    def _surface_hits(self, dirs: np.ndarray, tmax: float = 400.0) -> np.ndarray:
        """Distance along each ray to the snow surface z = z(x) (inf when none) [m]."""
        cam = self.camera.position
        shape = dirs.shape[:-1]
        d = dirs.reshape(-1, 3)
        sl = self.slope

        def f(t: np.ndarray, idx: np.ndarray | slice = slice(None)) -> np.ndarray:
            dd = d[idx]
            x = cam[0] + t * dd[:, 0]
            return cam[2] + t * dd[:, 2] - sl.z_of_x(x)  # < 0 above the snow

        n = d.shape[0]
        hit = np.full(n, np.inf)
        prev_t = np.zeros(n)
        prev_f = f(prev_t)
        active = prev_f < 0
        t = 0.0
        step = 0.5
        while t < tmax and np.any(active):
            t = t + step
            idx = np.flatnonzero(active)
            ft = f(np.full(idx.size, t), idx)
            crossed = ft >= 0
            if np.any(crossed):
                ci = idx[crossed]
                lo, hi = prev_t[ci], np.full(ci.size, t)
                for _ in range(30):
                    mid = 0.5 * (lo + hi)
                    fm = f(mid, ci)
                    above = fm < 0
                    lo = np.where(above, mid, lo)
                    hi = np.where(above, hi, mid)
                hit[ci] = 0.5 * (lo + hi)
                active[ci] = False
            prev_t[idx[~crossed]] = t
            step = min(step * 1.01, 2.0)
        return hit.reshape(shape)

    def _render(self) -> np.ndarray:
        cam, sl = self.camera, self.slope
        W, H = cam.width, cam.height
        # cast rays on a grid of at most ~240 px wide, refine the surface hit per pixel by Newton
        k = max(1, int(np.ceil(W / 240)))
        cols = np.arange(W, dtype=float)
        rows = np.arange(H, dtype=float)
        cc, rr = np.meshgrid(cols, rows)
        dirs = cam.rays(np.stack((cc, rr), -1))
        coarse = self._surface_hits(dirs[::k, ::k])
        tc = np.where(np.isfinite(coarse), coarse, np.nan)
        t = cv2.resize(np.nan_to_num(tc, nan=-1.0).astype(np.float32), (W, H), interpolation=cv2.INTER_LINEAR)
        t = t.astype(float)
        valid = t > 0
        c = cam.position
        for _ in range(6):
            x = c[0] + t * dirs[..., 0]
            fz = c[2] + t * dirs[..., 2] - sl.z_of_x(x)
            fp = dirs[..., 2] - sl.dz_of_x(x) * dirs[..., 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = np.where(valid & (np.abs(fp) > 1e-6), t - fz / fp, t)
        x = c[0] + t * dirs[..., 0]
        fz = c[2] + t * dirs[..., 2] - sl.z_of_x(x)
        valid &= (np.abs(fz) < 0.05) & (t > 0)
        t_snow = np.where(valid, t, np.inf)

        # vertical walls behind the far side: advertising boards and the forest
        def wall(y_wall: float, top: float) -> np.ndarray:
            dy = dirs[..., 1]
            with np.errstate(divide="ignore", invalid="ignore"):
                tw = (y_wall - c[1]) / dy
            pw = c + tw[..., None] * dirs
            zs = sl.z_of_x(pw[..., 0])
            ok = (tw > 0) & (pw[..., 2] <= zs) & (pw[..., 2] >= zs - top)
            return np.where(ok, tw, np.inf)

        y_board = self.far * (self.half + 2.0)
        y_forest = self.far * (self.half + 9.0)
        t_board = wall(y_board, 1.0)
        t_forest = wall(y_forest, 16.0)
        t_all = np.stack((t_snow, t_board, t_forest), 0)
        which = np.argmin(t_all, 0)
        tmin = np.min(t_all, 0)
        which[~np.isfinite(tmin)] = 3
        img = np.zeros((H, W, 3), np.float32)
        P = c + np.where(np.isfinite(tmin), tmin, 0.0)[..., None] * dirs
        rng = self.rng
        # sky: a vertical gradient
        sky_top, sky_low = np.array(_rgb("#7fa7d9"), np.float32), np.array(_rgb("#dfe9f3"), np.float32)
        g = np.clip(rr / max(H - 1, 1), 0, 1)[..., None]
        img[:] = sky_top * (1 - g) + sky_low * g
        # snow: texture in slope coordinates (s, y), gentle shading, faint haze with distance
        snow = which == 0
        if np.any(snow):
            s = sl.s_of_x(P[..., 0][snow])
            y = P[..., 1][snow]
            tex = self._texture(s, y)
            dz = sl.dz_of_x(P[..., 0][snow])
            shade = 1.0 - 0.06 * (np.arctan(dz) - 0.55)
            base = np.array(_rgb("#eef2f7"), np.float32) * (0.93 + 0.07 * tex[:, None]) * shade[:, None]
            haze = np.clip(tmin[snow] / 600.0, 0, 0.25)[:, None]
            img[snow] = base * (1 - haze) + sky_low * haze
        board = which == 1
        if np.any(board):
            seg = np.floor(P[..., 0][board] / 4.0).astype(int)
            palette = np.array([_rgb(h) for h in ("#0057b8", "#ffd700", "#e10600", "#ffffff", "#00843d")], np.float32)
            img[board] = palette[seg % len(palette)]
        forest = which == 2
        if np.any(forest):
            xw = P[..., 0][forest]
            hz = sl.z_of_x(xw) - P[..., 2][forest]
            trunk = 0.5 + 0.5 * np.sin(xw * 2.3 + np.sin(xw * 0.37) * 3.0)
            dark = np.array(_rgb("#1f3b26"), np.float32)
            light = np.array(_rgb("#3c6b45"), np.float32)
            mix = np.clip(0.35 * trunk + 0.25 * np.sin(hz * 1.7 + xw * 0.9), 0, 1)[:, None]
            col = dark * (1 - mix) + light * mix
            # ragged tree tops
            top = 16.0 - 3.0 * (0.5 + 0.5 * np.sin(xw * 1.3) * np.sin(xw * 0.41))
            sky_like = hz > top
            col[sky_like] = img[forest][sky_like]
            img[forest] = col
        grain = rng.normal(0.0, 1.5, (H, W, 1)).astype(np.float32)
        img = np.clip(img + grain, 0, 255).astype(np.uint8)
        img = cv2.GaussianBlur(img, (0, 0), 0.5)
        self._draw_markers(img)
        return img

    def _texture(self, s: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Snow texture in [0, 1] at slope coordinates (features >= 0.3 m, tiling every 40 m)."""
        if not hasattr(self, "_tex"):
            n = 256
            acc = np.zeros((n, n), np.float32)
            amp = 1.0
            for cells in (8, 16, 32, 64):
                grid = self.rng.random((cells, cells)).astype(np.float32)
                grid = np.concatenate([grid, grid[:1]], 0)
                grid = np.concatenate([grid, grid[:, :1]], 1)
                up = cv2.resize(grid, (n + n // cells, n + n // cells), interpolation=cv2.INTER_CUBIC)[:n, :n]
                acc += amp * up
                amp *= 0.6
            acc -= acc.min()
            acc /= max(float(acc.max()), 1e-6)
            self._tex = acc
        tile = 40.0
        n = self._tex.shape[0]
        u = (np.asarray(s) % tile) / tile * n
        v = (np.asarray(y) % tile) / tile * n
        i0, j0 = np.floor(v).astype(int), np.floor(u).astype(int)
        fv, fu = v - i0, u - j0
        i0, j0 = i0 % n, j0 % n
        i1, j1 = (i0 + 1) % n, (j0 + 1) % n
        tx = self._tex
        top = tx[i0, j0] * (1 - fu) + tx[i0, j1] * fu
        bot = tx[i1, j0] * (1 - fu) + tx[i1, j1] * fu
        return (top * (1 - fv) + bot * fv).astype(float)

    # -- markers ------------------------------------------------------------------
    def marker_positions(self) -> tuple[np.ndarray, np.ndarray]:
        """All whole-metre marker positions ``(s, y)`` [m] on both sides, far side first."""
        s_max = float(self.slope.ss[-1]) - 2.0
        s = np.arange(10.0, np.floor(s_max) + 1.0)
        ys = (self.far * self.half, -self.far * self.half)
        return np.concatenate([s, s]), np.concatenate([np.full(s.size, ys[0]), np.full(s.size, ys[1])])

    def _draw_markers(self, img: np.ndarray) -> None:
        cam, sl = self.camera, self.slope
        s_all, y_all = self.marker_positions()
        foot = sl.point(s_all, y_all)
        px, depth = cam.project(foot)
        show = (depth > 1.0) & cam.inside(px, margin=-40.0)
        up = np.array([0.0, 0.0, -1.0])
        for s, y in zip(s_all[show], y_all[show], strict=True):
            # a board with the distance every 5 m, standing just outside the marker
            if int(round(s)) % 5 == 0:
                out = np.array([0.0, np.sign(y) * 0.7, 0.0])
                a = sl.point(s - 0.8, y) + out
                b = sl.point(s + 0.8, y) + out
                pa_, _ = self.camera.project(np.stack((a, b)))
                if pa_[1, 0] < pa_[0, 0]:  # face the camera: text left to right
                    a, b = b, a
                quad = np.array([a + 0.25 * up, b + 0.25 * up, b + 1.05 * up, a + 1.05 * up])
                self._board(img, quad, f"{int(round(s))}")
            # the metre marker: a small dark-blue plate on the snow
            a = sl.point(s - 0.12, y)
            b = sl.point(s + 0.12, y)
            quad = np.array([a, b, b + 0.35 * up, a + 0.35 * up])
            colour = _rgb("#c1121f") if int(round(s)) % 5 == 0 else _rgb("#1d4e89")
            self._poly(img, quad, colour)

    def _poly(self, img: np.ndarray, quad: np.ndarray, colour: tuple[int, int, int]) -> None:
        px, depth = self.camera.project(quad)
        if np.any(depth <= 0.5) or not np.all(np.isfinite(px)):
            return
        pts = np.round(px * 16).astype(np.int32)
        cv2.fillConvexPoly(img, pts, colour, lineType=cv2.LINE_AA, shift=4)

    def _board(self, img: np.ndarray, quad: np.ndarray, text: str) -> None:
        px, depth = self.camera.project(quad)
        if np.any(depth <= 0.5) or not np.all(np.isfinite(px)):
            return
        span = float(np.max(np.ptp(px, 0)))
        if span < 3:
            return
        tw, th = 160, 80
        tile = np.full((th, tw, 3), 250, np.uint8)
        scale = 2.2 if len(text) < 3 else 1.8
        (w, h), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_DUPLEX, scale, 4)
        cv2.putText(tile, text, ((tw - w) // 2, (th + h) // 2), cv2.FONT_HERSHEY_DUPLEX, scale, (20, 20, 20), 4)
        src = np.float32([[0, th - 1], [tw - 1, th - 1], [tw - 1, 0], [0, 0]])
        M = cv2.getPerspectiveTransform(src, px.astype(np.float32))
        H, W = img.shape[:2]
        warped = cv2.warpPerspective(tile, M, (W, H), flags=cv2.INTER_AREA, borderMode=cv2.BORDER_CONSTANT)
        mask = np.zeros((H, W), np.uint8)
        cv2.fillConvexPoly(mask, np.round(px * 16).astype(np.int32), 255, lineType=cv2.LINE_AA, shift=4)
        m = (mask.astype(np.float32) / 255.0)[..., None]
        np.copyto(img, (img * (1 - m) + warped * m).astype(np.uint8))

    def markers(self, noise: float = 0.0) -> Markers:
        """The markers whose foot is inside the frame, as a user would measure them."""
        s_all, y_all = self.marker_positions()
        px, depth = self.camera.project(self.slope.point(s_all, y_all))
        ok = (depth > 1.0) & self.camera.inside(px, margin=1.0)
        px = px[ok]
        if noise > 0:
            px = px + self.rng.normal(0.0, noise, px.shape)
            W, H = self.camera.width, self.camera.height
            px[:, 0] = np.clip(px[:, 0], 0.0, W - 1.0)
            px[:, 1] = np.clip(px[:, 1], 0.0, H - 1.0)
        return Markers(s_all[ok], y_all[ok], px[:, 0], px[:, 1])
