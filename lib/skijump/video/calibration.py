"""Image <-> slope coordinates from the distance markers.

The landing slope is the profile extruded across the hill: a slope point is
``X(s, y) = P(s) + y e_y`` with ``P`` the profile curve.  Expanding ``P``
around a distance ``s0`` (``u = s - s0``) to third order,
``P(s) = P0 + u t + u^2 k n / 2 + u^3 (...)``, so a pinhole camera sees it at
homogeneous pixel ::

    p ~ M [u, y, 1, u^2, u^3]^T          (M: 3 x 5)

-- a homography of the slope's tangent plane (the first three columns)
extended by the curvature terms.  :func:`fit_slope_map` fits ``M`` to the
markers within a window around ``s0`` (linear DLT, then Levenberg-Marquardt
on the reprojection error); with few markers it falls back to the plain
slope-plane homography (``M`` with zero curvature columns).  The window is
refitted around the touch-down once that is known.

Why the curvature terms: the lateral coordinate ``y`` runs nearly along the
line of sight of a side camera, so a few centimetres of sagitta between the
curved slope and its tangent plane (6 m from ``s0`` on a 220 m circle: 8 cm)
move the snow point seen at a pixel by decimetres across the slope.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares

from sportfusion.core.errors import InputError
from sportfusion.core.stats import median
from sportfusion.skijump.video.markers import Markers

#: Scale of ``u`` inside the monomials [m] (conditioning of the fit).
U_SCALE = 10.0


def _monomials(u: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``[u, y, 1, u^2, u^3]`` with ``u`` in units of :data:`U_SCALE`; shape (..., 5)."""
    v = u / U_SCALE
    return np.stack((v, y / U_SCALE, np.ones_like(v), v * v, v * v * v), -1)


@dataclass(frozen=True)
class SlopeMap:
    """The mapping slope coordinates -> pixels near one distance.

    Attributes
    ----------
    M : ndarray (3, 5)
        ``[u, y, 1, u^2, u^3]`` (``u = s - s0``, both divided by 10 m) -> homogeneous pixel.
    s0 : float
        Distance the expansion is taken at [m].
    rms_px : float
        RMS reprojection error of the markers used [px].
    used : int
        Number of markers used.
    s_range : tuple of float
        Distances of the markers used, min and max [m].
    curved : bool
        False for the plain slope-plane homography.
    side : float
        Sign of the homogeneous scale of ``H^-1 p`` for pixels that see the slope.
    """

    M: np.ndarray
    s0: float
    rms_px: float
    used: int
    s_range: tuple[float, float]
    curved: bool
    side: float = 1.0

    @property
    def H(self) -> np.ndarray:
        """The slope-plane part (3, 3): ``((s - s0)/10, y/10, 1)`` -> homogeneous pixel."""
        return self.M[:, :3]

    def to_image(self, s: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Slope coordinates [m] -> pixels ``(..., 2)`` ``(col, row)``."""
        s, y = np.broadcast_arrays(np.asarray(s, dtype=float), np.asarray(y, dtype=float))
        h = _monomials(s - self.s0, y) @ self.M.T
        with np.errstate(divide="ignore", invalid="ignore"):
            return h[..., :2] / h[..., 2:3]

    def to_slope(self, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixels ``(..., 2)`` -> slope coordinates ``(s, y)`` [m] of the snow point seen there.

        Inverts :meth:`to_image` by Newton steps from the slope-plane homography.
        """
        p = np.asarray(pixels, dtype=float)
        shape = p.shape[:-1]
        p = p.reshape(-1, 2)
        Hinv = np.linalg.inv(self.H)
        q = np.c_[p, np.ones(len(p))] @ Hinv.T
        with np.errstate(divide="ignore", invalid="ignore"):
            u = q[:, 0] / q[:, 2] * U_SCALE
            y = q[:, 1] / q[:, 2] * U_SCALE
        if self.curved:
            eps = 1e-4
            for _ in range(8):
                f0 = self.to_image(u + self.s0, y) - p
                fu = (self.to_image(u + eps + self.s0, y) - p - f0) / eps
                fy = (self.to_image(u + self.s0, y + eps) - p - f0) / eps
                det = fu[:, 0] * fy[:, 1] - fu[:, 1] * fy[:, 0]
                with np.errstate(divide="ignore", invalid="ignore"):
                    du = (f0[:, 0] * fy[:, 1] - f0[:, 1] * fy[:, 0]) / det
                    dy = (fu[:, 0] * f0[:, 1] - fu[:, 1] * f0[:, 0]) / det
                u, y = u - du, y - dy
                if np.all(np.abs(du) < 1e-7) and np.all(np.abs(dy) < 1e-7):
                    break
        return (u + self.s0).reshape(shape), y.reshape(shape)

    def in_front(self, pixels: np.ndarray) -> np.ndarray:
        """True for pixels below the slope plane's horizon (they see the snow in front of the camera)."""
        p = np.asarray(pixels, dtype=float)
        w = (np.c_[p.reshape(-1, 2), np.ones(p.reshape(-1, 2).shape[0])] @ np.linalg.inv(self.H).T)[:, 2]
        return (np.sign(w) == self.side).reshape(p.shape[:-1])

    def jacobian(self, s: float, y: float) -> np.ndarray:
        """``d(col, row) / d(s, y)`` [px/m] at a slope point, shape (2, 2) (columns: d/ds, d/dy)."""
        h = 1e-3
        p = self.to_image(np.array([s, s + h, s]), np.array([y, y, y + h]))
        return np.stack(((p[1] - p[0]) / h, (p[2] - p[0]) / h), -1)

    def away_sign(self, s: float, y: float = 0.0) -> float:
        """+1 if points above the snow are seen in line with snow points at larger ``y``, else -1.

        A point raised above the snow moves up in the image (a level camera);
        the snow point seen at the pixel just above ``(s, y)`` in the same
        column tells on which side the ray meets the snow.
        """
        p = self.to_image(s, y)
        _, y_up = self.to_slope(p - np.array([0.0, 1.0]))
        return 1.0 if float(y_up) > y else -1.0


def _select(markers: Markers, s_center: float | None, half_window: float, need: int) -> np.ndarray:
    if s_center is None:
        return np.ones(len(markers), dtype=bool)
    w = half_window
    while True:
        sel = np.abs(markers.distance - s_center) <= w
        counts = [int(np.sum(sel & (markers.y == v))) for v in markers.lines()]
        if sum(c >= need for c in counts) >= 2 or w > 1e4:
            return sel
        w *= 1.5


def _dlt(A: np.ndarray, pix: np.ndarray) -> np.ndarray:
    """Linear fit of M (3 x n) with p ~ M a, pixels normalised inside."""
    mu = pix.mean(0)
    sc = np.sqrt(2) / max(float(np.mean(np.linalg.norm(pix - mu, axis=1))), 1e-9)
    T = np.array([[sc, 0, -sc * mu[0]], [0, sc, -sc * mu[1]], [0, 0, 1]])
    q = (pix - mu) * sc
    n = A.shape[1]
    rows = []
    zero = np.zeros(n)
    for a, (x, y) in zip(A, q, strict=True):
        rows.append(np.concatenate((a, zero, -x * a)))
        rows.append(np.concatenate((zero, a, -y * a)))
    _, _, vt = np.linalg.svd(np.array(rows))
    Mn = vt[-1].reshape(3, n)
    return np.linalg.inv(T) @ Mn


def fit_slope_map(
    markers: Markers, s_center: float | None = None, half_window: float = 8.0, curved: bool = True
) -> SlopeMap:
    """Fit the slope mapping to the markers near ``s_center``.

    Parameters
    ----------
    markers : Markers
    s_center : float, optional
        Distance around which to fit [m]; None: all markers.
    half_window : float
        Markers within ``s_center +- half_window`` [m] are used; the window is
        widened until two marker lines hold enough markers (6 each for the
        curved model, else 3 for the plane).
    curved : bool
        Fit the curvature terms (falls back to the plane with too few markers).

    Raises
    ------
    InputError
        The markers do not determine the mapping (all on one line, collinear).
    """
    sel = _select(markers, s_center, half_window, 6 if curved else 3)
    m = markers.subset(sel)
    counts = [int(np.sum(m.y == v)) for v in m.lines()]
    curved = curved and sum(c >= 6 for c in counts) >= 2
    if len(m) < 4:
        raise InputError("fewer than 4 markers near the landing; expected markers on both sides of the slope")
    s0 = float(s_center) if s_center is not None else float(np.mean(m.distance))
    A = _monomials(m.distance - s0, m.y)
    pix = m.pixels.astype(float)
    H, _ = cv2.findHomography(A[:, :2].astype(np.float64), pix.astype(np.float64), 0)
    if H is None or not np.all(np.isfinite(H)) or abs(np.linalg.det(H)) < 1e-12:
        raise InputError(
            "the markers do not determine the slope plane (collinear or on one line); expected markers on "
            "both sides of the landing slope"
        )
    M = np.hstack((H, np.zeros((3, 2))))
    if curved:
        M = _dlt(A, pix)
        if M[2] @ A.mean(0) < 0:
            M = -M

        def resid(x: np.ndarray) -> np.ndarray:
            Mx = x.reshape(3, 5)
            h = A @ Mx.T
            return (h[:, :2] / h[:, 2:3] - pix).ravel()

        x0 = (M / np.linalg.norm(M)).ravel()
        sol = least_squares(resid, x0, method="lm", x_scale="jac")
        M = sol.x.reshape(3, 5)
    M = M / np.linalg.norm(M)
    h = A @ M.T
    with np.errstate(divide="ignore", invalid="ignore"):
        proj = h[:, :2] / h[:, 2:3]
    rms = float(np.sqrt(np.mean(np.sum((proj - pix) ** 2, -1))))
    if not np.isfinite(rms):
        raise InputError("the markers map to infinity in the fitted homography; expected markers seen from one side")
    w = np.c_[pix, np.ones(len(pix))] @ np.linalg.inv(M[:, :3]).T
    side = 1.0 if median(w[:, 2]) > 0 else -1.0
    return SlopeMap(M, s0, rms, len(m), (float(m.distance.min()), float(m.distance.max())), curved, side)
