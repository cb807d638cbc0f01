"""Pinhole camera beside the landing slope, the slope surface, and the slope-plane homography.

Frames
------
World coordinates are the ski-jumping hill frame (origin at the take-off edge,
``x`` forward along the hill axis, ``y`` to the right looking downhill, ``z``
down) [m].  The camera frame is OpenCV's: ``x`` right, ``y`` down, ``z``
along the optical axis.  Pixel coordinates are ``(col, row)`` with the centre
of the top-left pixel at ``(0, 0)`` [px].

Slope coordinates
-----------------
A point on the landing slope is ``(s, y)``: ``s`` the curve length of the
landing profile from the knoll base F (the jump length of a touch-down there)
[m], ``y`` the lateral position [m].  The slope is the profile ``z(x)``
extruded along ``y`` (flat across), so every line of constant ``s`` is a
straight 3-D line and its image is a straight line.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from sportfusion.core.errors import InputError

#: Width of the 35-mm film frame [mm] used for 35-mm equivalent focal lengths.
FILM_WIDTH_MM = 36.0


class Profile(Protocol):
    """What the video code needs from a hill (:class:`sportfusion.skijump.hill.HillProfile` provides it)."""

    def z(self, x: np.ndarray | float) -> np.ndarray | float: ...

    def dzdx(self, x: np.ndarray | float) -> np.ndarray | float: ...

    def jump_length(self, x: np.ndarray | float) -> np.ndarray | float: ...

    def x_at_jump_length(self, length: np.ndarray | float) -> np.ndarray | float: ...


class Slope:
    """The landing slope as a surface: slope coordinates ``(s, y)`` <-> hill frame.

    Tabulates the landing profile once (``step`` [m]) so that the per-pixel
    work of the renderer is a table look-up; exact profile calls are used for
    single points.

    Parameters
    ----------
    profile : Profile
        Landing profile ``z(x)`` [m, z down] with its curve length from F.
    x_min, x_max : float
        Range of the table along the hill axis [m].
    step : float
        Table spacing [m].
    """

    def __init__(self, profile: Profile, x_min: float = 0.0, x_max: float = 140.0, step: float = 0.05) -> None:
        self.profile = profile
        xs = np.arange(x_min, x_max + step / 2, step)
        zs = np.asarray(profile.z(xs), dtype=float)
        ok = np.isfinite(zs)
        if ok.sum() < 10:
            raise InputError("the hill has no landing profile between x = 0 and 140 m; expected a landing hill")
        self.xs = xs[ok]
        self.zs = zs[ok]
        self.dzs = np.asarray(profile.dzdx(self.xs), dtype=float)
        self.ss = np.asarray(profile.jump_length(self.xs), dtype=float)

    # -- tabulated (vectorised, for rendering) -----------------------------
    def z_of_x(self, x: np.ndarray) -> np.ndarray:
        """Profile height z [m] (z down) at ``x`` [m], linear in the table, straight beyond its ends."""
        x = np.asarray(x, dtype=float)
        z = np.interp(x, self.xs, self.zs)
        lo, hi = x < self.xs[0], x > self.xs[-1]
        z = np.where(lo, self.zs[0] + (x - self.xs[0]) * self.dzs[0], z)
        return np.where(hi, self.zs[-1] + (x - self.xs[-1]) * self.dzs[-1], z)

    def dz_of_x(self, x: np.ndarray) -> np.ndarray:
        """Profile slope dz/dx [1] at ``x`` [m] (table)."""
        return np.interp(np.asarray(x, dtype=float), self.xs, self.dzs)

    def s_of_x(self, x: np.ndarray) -> np.ndarray:
        """Curve length from F [m] at ``x`` [m] (table)."""
        return np.interp(np.asarray(x, dtype=float), self.xs, self.ss)

    def x_of_s(self, s: np.ndarray) -> np.ndarray:
        """``x`` [m] at curve length ``s`` [m] from F (table)."""
        return np.interp(np.asarray(s, dtype=float), self.ss, self.xs)

    def point_fast(self, s: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Hill-frame point(s) ``(..., 3)`` [m] of slope coordinates ``(s, y)`` [m] from the tables."""
        s, y = np.broadcast_arrays(np.asarray(s, dtype=float), np.asarray(y, dtype=float))
        x = self.x_of_s(s)
        return np.stack((x, y, self.z_of_x(x)), -1)

    # -- exact points ----------------------------------------------------------
    def point(self, s: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Hill-frame point(s) ``(..., 3)`` [m] of slope coordinates ``(s, y)`` [m]."""
        s, y = np.broadcast_arrays(np.asarray(s, dtype=float), np.asarray(y, dtype=float))
        x = np.asarray(self.profile.x_at_jump_length(s), dtype=float)
        z = np.asarray(self.profile.z(x), dtype=float)
        return np.stack((x, y, z), -1)

    def axes(self, x: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Unit downhill tangent and upward normal ``(..., 3)`` of the profile at ``x`` [m]."""
        d = np.asarray(self.profile.dzdx(x), dtype=float)
        w = np.sqrt(1 + d * d)
        zero = np.zeros_like(d)
        tangent = np.stack((1 / w, zero, d / w), -1)
        normal = np.stack((d / w, zero, -1 / w), -1)
        return tangent, normal

    def axes_fast(self, x: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`axes` from the tables."""
        d = self.dz_of_x(x)
        w = np.sqrt(1 + d * d)
        zero = np.zeros_like(d)
        return np.stack((1 / w, zero, d / w), -1), np.stack((d / w, zero, -1 / w), -1)

    def foot(self, x: np.ndarray, z: np.ndarray, iterations: int = 8) -> tuple[np.ndarray, np.ndarray]:
        """Normal projection of hill-frame points onto the profile.

        Parameters
        ----------
        x, z : ndarray
            Points in the vertical plane of the hill axis [m] (z down).

        Returns
        -------
        xp : ndarray
            ``x`` of the foot point on the profile [m].
        d : ndarray
            Height above the profile along its upward normal [m] (negative below).
        """
        x = np.asarray(x, dtype=float)
        z = np.asarray(z, dtype=float)
        xp = x.copy()
        for _ in range(iterations):
            zp = np.asarray(self.profile.z(xp), dtype=float)
            d1 = np.asarray(self.profile.dzdx(xp), dtype=float)
            # f(xp) = (x - xp) + (z - zp) d1 = 0 ; f' ~ -(1 + d1^2)
            f = (x - xp) + (z - zp) * d1
            xp = xp + f / (1 + d1 * d1)
        zp = np.asarray(self.profile.z(xp), dtype=float)
        d1 = np.asarray(self.profile.dzdx(xp), dtype=float)
        d = ((x - xp) * d1 - (z - zp)) / np.sqrt(1 + d1 * d1)
        return xp, d


def focal_px(focal_35mm: float, width: int) -> float:
    """Focal length [px] of a 35-mm equivalent focal length [mm] on an image ``width`` pixels wide."""
    return float(focal_35mm) / FILM_WIDTH_MM * float(width)


@dataclass(frozen=True)
class Camera:
    """An ideal pinhole camera (no lens distortion, square pixels).

    Attributes
    ----------
    position : ndarray (3,)
        Projection centre in the hill frame [m].
    rotation : ndarray (3, 3)
        Rotation hill frame -> camera frame (rows are the camera axes in the hill frame).
    focal : float
        Focal length [px].
    width, height : int
        Image size [px].
    """

    position: np.ndarray
    rotation: np.ndarray
    focal: float
    width: int
    height: int

    @classmethod
    def look_at(cls, position: np.ndarray, target: np.ndarray, focal: float, width: int, height: int) -> Camera:
        """A camera at ``position`` [m] aimed at ``target`` [m] with a level horizon.

        Parameters
        ----------
        position, target : array (3,)
            Hill-frame points [m]; the optical axis runs from ``position`` to ``target``.
        focal : float
            Focal length [px].
        width, height : int
            Image size [px].
        """
        c = np.asarray(position, dtype=float)
        fwd = np.asarray(target, dtype=float) - c
        n = np.linalg.norm(fwd)
        if not np.isfinite(n) or n == 0:
            raise InputError("the camera target coincides with the camera position; expected distinct points")
        fwd = fwd / n
        down = np.array([0.0, 0.0, 1.0])
        right = np.cross(down, fwd)
        if np.linalg.norm(right) < 1e-6:
            raise InputError("the camera looks straight up or down; expected a camera aimed across the slope")
        right /= np.linalg.norm(right)
        cam_down = np.cross(fwd, right)
        if width < 16 or height < 16 or focal <= 0:
            raise InputError(f"camera {width}x{height} px with focal length {focal} px; expected a real image size")
        return cls(c, np.stack((right, cam_down, fwd)), float(focal), int(width), int(height))

    @property
    def K(self) -> np.ndarray:
        """Intrinsic matrix (3, 3) [px]; principal point at the image centre."""
        return np.array(
            [[self.focal, 0.0, (self.width - 1) / 2], [0.0, self.focal, (self.height - 1) / 2], [0.0, 0.0, 1.0]]
        )

    @property
    def P(self) -> np.ndarray:
        """Projection matrix (3, 4): hill-frame homogeneous points -> homogeneous pixels."""
        return self.K @ np.hstack((self.rotation, -(self.rotation @ self.position)[:, None]))

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """Hill-frame points ``(..., 3)`` [m] -> camera-frame points ``(..., 3)`` [m]."""
        return (np.asarray(points, dtype=float) - self.position) @ self.rotation.T

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project hill-frame points ``(..., 3)`` [m].

        Returns
        -------
        pixels : ndarray (..., 2)
            ``(col, row)`` [px]; NaN behind the camera.
        depth : ndarray (...)
            Distance along the optical axis [m] (<= 0 behind the camera).
        """
        pc = self.to_camera(points)
        depth = pc[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(depth > 1e-6, 1.0 / depth, np.nan)
        col = self.focal * pc[..., 0] * inv + (self.width - 1) / 2
        row = self.focal * pc[..., 1] * inv + (self.height - 1) / 2
        return np.stack((col, row), -1), depth

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """Unit viewing directions ``(..., 3)`` in the hill frame of pixels ``(..., 2)`` ``(col, row)``."""
        px = np.asarray(pixels, dtype=float)
        d = np.stack(
            (
                (px[..., 0] - (self.width - 1) / 2) / self.focal,
                (px[..., 1] - (self.height - 1) / 2) / self.focal,
                np.ones(px.shape[:-1]),
            ),
            -1,
        )
        d = d @ self.rotation  # camera -> hill frame (R^T d)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def inside(self, pixels: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """True where pixels ``(..., 2)`` lie inside the image (at least ``margin`` px from its edge)."""
        px = np.asarray(pixels, dtype=float)
        c, r = px[..., 0], px[..., 1]
        with np.errstate(invalid="ignore"):
            return (
                (c >= -0.5 + margin)
                & (c <= self.width - 0.5 - margin)
                & (r >= -0.5 + margin)
                & (r <= self.height - 0.5 - margin)
            )

    def slope_homography(self, slope: Slope, s0: float) -> np.ndarray:
        """Homography (3, 3) of the slope's tangent plane at ``s0`` [m].

        Maps ``(s - s0, y, 1)`` [m] to homogeneous pixels: exact for points of the
        tangent plane, and for the curved slope within the sagitta
        ``(s - s0)^2 / (2 R)`` of the profile's radius of curvature ``R``.
        """
        p0 = slope.point(s0, 0.0)
        t, _ = slope.axes(p0[0])
        cols = np.stack((t, np.array([0.0, 1.0, 0.0]), p0 - self.position), -1)
        return self.K @ self.rotation @ cols


def apply_homography(H: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Apply a homography to points ``(..., 2)``; NaN where the point maps to infinity."""
    p = np.asarray(pts, dtype=float)
    h = p @ H[:, :2].T + H[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(np.abs(h[..., 2]) > 1e-12, h[..., 2], np.nan)
        return h[..., :2] / w[..., None]
