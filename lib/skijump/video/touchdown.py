"""The touch-down frame from the skis' height series: a hinge fit placing ``f_td`` to 0.01 frame.

Step 4 ("Touch-down") of :mod:`sportfusion.skijump.video.measure`: ``Y(f)`` [m], the skis' lower edge
mapped to the slope's lateral coordinate, falls while the skis come down and stays level once they lie on
the snow; :func:`fit_touchdown` fits ``Y = c + d (f - f_td) + a tau + b tau^2`` with
``tau = max(f_td - f, 0)`` [frames] and returns ``f_td`` with its timing uncertainty.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.stats import median


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
    return 1.4826 * float(median(np.abs(d2 - median(d2)))) / math.sqrt(6.0)


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
