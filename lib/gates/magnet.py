"""The buried gate magnet: dipole field and the distance-from-intensity model.

The paper's eq 1 (a piecewise fit of ``||r||`` against ``||B||``) is garbled in
the text.  It is replaced by the physical model
the paper itself names (Furlani 2001): the magnet's contribution decays with
the cube of the distance, so with the field normalised to 1 far from the magnet
(``b = ||B|| / ||B_earth||``)::

    b_peak - 1 = c / r^3          <=>       r = (c / (b_peak - 1))^(1/3)

with one constant ``c`` [m^3] calibrated from a table of (distance, peak
intensity) pairs -- a user's measurements, or passes simulated with the
simulator's magnet (:func:`simulated_calibration_table`, the default).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.stats import median

MU0_4PI = 1e-7  # mu_0 / (4 pi) [T m / A]

#: Default magnet of the simulator: 10 stacked N42 discs (20 x 10 mm), vertical moment [A m^2].
DEFAULT_MOMENT = 30.0
#: Default Earth field used for the calibration passes (Swiss Alps, NED) [uT].
DEFAULT_EARTH_NED = (21.5, 0.6, 42.5)


def dipole_field(rel: np.ndarray, moment: np.ndarray) -> np.ndarray:
    """Field of a point dipole at displacement(s) ``rel`` from the magnet [uT].

    Parameters
    ----------
    rel : ndarray, shape (..., 3)
        Sensor position minus magnet position [m] (any Cartesian frame).
    moment : ndarray, shape (3,) or (..., 3)
        Magnetic moment in the same frame [A m^2].

    Returns
    -------
    ndarray, shape (..., 3)
        ``mu0/(4 pi) (3 (m.r^) r^ - m) / |r|^3`` in microtesla.
    """
    rel = np.asarray(rel, dtype=float)
    m = np.asarray(moment, dtype=float)
    r = np.linalg.norm(rel, axis=-1, keepdims=True)
    r = np.maximum(r, 1e-3)
    u = rel / r
    mu = np.sum(m * u, axis=-1, keepdims=True)
    return MU0_4PI * (3.0 * mu * u - m) / r**3 * 1e6


def peak_vertex(b: np.ndarray, k: int) -> tuple[float, float]:
    """Sub-sample peak of the normalised intensity near sample ``k``: a parabola through ``log(b - 1)`` at k-1,
    k, k+1; returns (offset from ``k`` [samples], within +-0.5; peak value).  ``(0, b[k])`` when a neighbour is
    missing or not above 1.

    At 125 Hz and 20 m/s the sensor moves 0.16 m per sample: the sampled maximum underestimates the peak (the
    paper's own limitation) and its time is up to half a sample off (+-0.08 m along the track); the parabola
    on the logarithm of the excess recovers most of both (the excess falls off as a power of the distance, its
    logarithm is near a parabola around the peak)."""
    if k <= 0 or k >= b.size - 1:
        return 0.0, float(b[k])
    e = b[k - 1 : k + 2] - 1.0
    if not (e > 0).all() or not np.isfinite(e).all():
        return 0.0, float(b[k])
    y0, y1, y2 = np.log(e)
    den = y0 - 2 * y1 + y2
    if den >= 0:
        return 0.0, float(b[k])
    d = float(np.clip(0.5 * (y0 - y2) / den, -0.5, 0.5))
    return d, float(1.0 + np.exp(y1 - 0.25 * (y0 - y2) * d))


def refine_peak(b: np.ndarray, k: int) -> float:
    """Peak of the normalised intensity near sample ``k`` (:func:`peak_vertex`'s value)."""
    return peak_vertex(b, k)[1]


@dataclass(frozen=True)
class MagnetCalibration:
    """Distance from the peak intensity: ``r = (c / (b_peak - 1))^(1/3)``.

    Attributes
    ----------
    c : float
        Calibration constant [m^3] (normalised excess intensity times distance cubed).
    source : str
        Where ``c`` came from (for the metadata).
    """

    c: float
    source: str = "table"

    def distance(self, b_peak: np.ndarray | float) -> np.ndarray:
        """Distance sensor -> magnet [m] for normalised peak intensities (NaN where ``b_peak <= 1``)."""
        e = np.asarray(b_peak, dtype=float) - 1.0
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(e > 0, np.cbrt(self.c / e), np.nan)

    def peak(self, distance: np.ndarray | float) -> np.ndarray:
        """Normalised peak intensity expected at a distance [m] (the inverse of :meth:`distance`)."""
        return 1.0 + self.c / np.asarray(distance, dtype=float) ** 3


def fit_calibration(distance: np.ndarray, b_peak: np.ndarray, source: str = "table") -> MagnetCalibration:
    """Fit ``c`` of the cube law to (distance [m], normalised peak intensity) pairs.

    Least squares on ``log(b - 1) = log c - 3 log r``; pairs with ``b <= 1`` or
    a non-positive distance are ignored.  Fewer than 2 usable pairs is an error.
    """
    d = np.asarray(distance, dtype=float)
    b = np.asarray(b_peak, dtype=float)
    ok = np.isfinite(d) & np.isfinite(b) & (d > 0) & (b > 1)
    if ok.sum() < 2:
        raise InputError(
            f"the magnet calibration table has {int(ok.sum())} usable (distance > 0, peak intensity > 1) rows; "
            "expected at least 2"
        )
    logc = float(np.mean(np.log(b[ok] - 1.0) + 3.0 * np.log(d[ok])))
    return MagnetCalibration(float(np.exp(logc)), source)


def simulated_calibration_table(
    moment: float = DEFAULT_MOMENT,
    earth_ned: tuple[float, float, float] = DEFAULT_EARTH_NED,
    rate: float = 125.0,
    speed: float = 20.0,
    n: int = 400,
    seed: int = 12345,
) -> tuple[np.ndarray, np.ndarray]:
    """(distance [m], sampled peak intensity) of straight passes over the simulator's magnet.

    The sensor moves at ``speed`` [m/s] along a horizontal line whose closest
    point is at distance ``r`` (0.2-1.2 m) from a vertical dipole of
    ``moment`` [A m^2], at an elevation of 35-90 deg above the magnet (a leaning
    skier's sacrum is above and outside the buried magnet); the intensity
    ``|B_earth + B_magnet| / |B_earth|`` is sampled at ``rate`` [Hz] with a random
    phase and its peak refined with :func:`refine_peak`, as the detector does.
    """
    rng = np.random.default_rng(seed)
    earth = np.asarray(earth_ned, dtype=float)
    be = np.linalg.norm(earth)
    r = rng.uniform(0.2, 1.2, n)
    elev = np.deg2rad(rng.uniform(35.0, 90.0, n))
    heading = rng.uniform(0, 2 * np.pi, n)
    m = np.array([0.0, 0.0, moment])  # pointing down (NED z down): on its axis it adds to the Earth field
    dt = 1.0 / rate
    peaks = np.empty(n)
    for i in range(n):
        side = np.array([-np.sin(heading[i]), np.cos(heading[i]), 0.0])
        fwd = np.array([np.cos(heading[i]), np.sin(heading[i]), 0.0])
        closest = r[i] * (np.cos(elev[i]) * side + np.sin(elev[i]) * np.array([0, 0, -1.0]))
        tt = (np.arange(-40, 41) + rng.uniform(-0.5, 0.5)) * dt
        pos = closest + speed * tt[:, None] * fwd
        b = np.linalg.norm(earth + dipole_field(pos, m), axis=1) / be
        peaks[i] = refine_peak(b, int(np.argmax(b)))
    return r, peaks


@functools.lru_cache(maxsize=4)
def default_calibration(moment: float = DEFAULT_MOMENT) -> MagnetCalibration:
    """The cube law calibrated from :func:`simulated_calibration_table` (the simulator's magnet)."""
    d, b = simulated_calibration_table(moment)
    return fit_calibration(d, b, source=f"simulated magnet, moment {moment:g} A m^2")


def _direction_features(u: np.ndarray) -> np.ndarray:
    """Constant, linear and quadratic terms of the field direction ``u`` (n, 3) -> (n, 9)."""
    x, y, z = u[:, 0], u[:, 1], u[:, 2]
    return np.column_stack([np.ones_like(x), x, y, z, x * x, y * y, x * y, x * z, y * z])


def self_calibrated_norm(mag: np.ndarray, iterations: int = 4, tukey_c: float = 4.685) -> tuple[np.ndarray, float]:
    """``|B|`` divided by the norm a miscalibrated magnetometer shows in the same direction.

    A magnetometer with scale (soft-iron) errors of a few per cent and an
    offset (hard iron) of a few uT reports a field norm that changes with the
    sensor's orientation: a uniform field of norm ``F`` measured as
    ``m = S R^T b + o`` has ``|m| ~ F (1 + u^T (S - I) u) + u^T o`` to first
    order, a quadratic function of the measured direction ``u = m / |m|``.
    That function is fitted to the recording itself (least squares on the
    constant, linear and quadratic terms of ``u``, iteratively reweighted with
    Tukey's biweight on the residual over 1.4826 MAD, so the short magnet
    peaks -- a few per cent of the samples -- do not pull it), and ``|m|`` is
    divided by it.  On a well calibrated sensor the fit is flat and the
    result is ``|m| / median|m|``; without any magnet it is ~1 everywhere,
    whatever the orientation.  Across outlying samples (weight 0) the
    expected norm is interpolated from the neighbouring inliers, so a magnet
    pass is measured against the field just before and after it, not
    against the model at the direction the magnet bent the field into.
    Orientations the recording never visits are
    never evaluated, so a poorly conditioned fit (little motion) does no harm
    (a small ridge term keeps it solvable).

    Parameters
    ----------
    mag : ndarray, shape (n, 3)
        Magnetic field samples, body frame [uT or normalised].
    iterations : int
        Reweighting passes.
    tukey_c : float
        Tukey biweight constant [robust sigmas].

    Returns
    -------
    b : ndarray, shape (n,)
        Field norm over the orientation-dependent expected norm [1].
    spread : float
        Relative 1-sigma (1.4826 MAD) of the orientation-dependent norm before
        the correction, ``|m|/median - 1`` [1] (how far the sensor was from a
        calibrated one).
    """
    n = np.linalg.norm(mag, axis=1)
    med = float(median(n)) if n.size else 1.0
    if not np.isfinite(med) or med <= 0:
        return np.ones_like(n), 0.0
    y = n / med
    u = mag / np.maximum(n, 1e-12)[:, None]
    feats = _direction_features(u)
    w = np.ones_like(y)
    ridge = 1e-6 * max(1, y.size)
    fit = np.ones_like(y)
    for _ in range(iterations):
        a = feats * w[:, None]
        lhs = feats.T @ a + ridge * np.eye(feats.shape[1])
        rhs = a.T @ y
        coef = np.linalg.solve(lhs, rhs)
        fit = feats @ coef
        r = y - fit
        s = 1.4826 * float(median(np.abs(r - median(r))))
        if not np.isfinite(s) or s <= 0:
            break
        z = r / (tukey_c * s)
        w = np.where(np.abs(z) < 1, (1 - z * z) ** 2, 0.0)
    # Where a sample is an outlier (a magnet pass bends the measured direction too), the expected norm is
    # interpolated from the neighbouring inliers instead of being evaluated at the bent direction.
    out = w <= 0.0
    if out.any() and (~out).sum() >= 2:
        idx = np.arange(y.size)
        fit = fit.copy()
        fit[out] = np.interp(idx[out], idx[~out], fit[~out])
    spread = 1.4826 * float(median(np.abs(fit - median(fit))))
    return y / np.where(fit > 0.2, fit, 1.0), spread
