"""Touch-down as the onset of the landing impact in the specific force (issue 19).

Appendix A puts the touch-down a fixed 0.05 s before the landing peak of ``|a|``.  The time from the
skis' first contact to that peak is not fixed: it depends on how hard and how fast the impact builds up
(the landing pressure, the snow, the legs' bending), and on what else the specific force does meanwhile
(the support of the slope replacing the flight's free fall, the settling onto the slope).  On the
simulated jumps of :mod:`sportfusion.skijump.sim` (impact peaks drawn 35-55 ms after contact, decay
120-180 ms) the peak comes 45-70 ms after the touch-down, so the fixed offset is off by several
milliseconds with a spread of about 5 ms -- at 28 m/s along the slope, about 0.15 m of jump length.

The contact itself is where the specific force *leaves the flight's trend*: before it, the accelerometer
measures only the aerodynamic force, which changes slowly (gusts over about a second); from it, the
force of the snow on the skis builds up.  That build-up is smooth -- the skis, bindings, legs and snow
are compliant, so the force grows from zero with zero slope -- and then saturates into the impact peak.
:func:`impact_onset` fits, to the samples from before the rise up to ``rise_fraction`` of the peak,

    |a|(t) = b0 + b1 (t - t_peak) + A (1 - exp(-((t - t0) / tau)^2))   for t > t0,
    |a|(t) = b0 + b1 (t - t_peak)                                        before,

and returns ``t0``: the flight's trend (a line), plus a step of height ``A`` that starts with zero slope
and rises over ``tau``.  The model needs only that the onset is smooth (quadratic at first) and
monotone up to the fitted level, not the pulse's later shape; it is fitted between the samples, so the
result does not depend on where the contact falls between two of them.  On 30 simulated jumps (seeds
3000-3029, 1 kHz truth sampled at 100 Hz at all ten phases, the paper's accelerometer noise), the
touch-down is found 0.3 ms late on average with a spread of 0.3 ms (largest error 1.2 ms); Appendix A's
peak minus 0.05 s is 3.6 ms late with a spread of 5.4 ms (largest 19 ms).

Where the fit is not credible -- too few samples on the rise (a landing spike of one or two samples),
a rise slower than ``max_rise`` or faster than a quarter sample, an onset outside the rise, a fit that
did not converge -- :func:`impact_onset` returns None and the caller keeps Appendix A's time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sportfusion.core.stats import median


@dataclass(frozen=True)
class OnsetParams:
    """Parameters of :func:`impact_onset`.

    Attributes
    ----------
    trend_window : tuple of float
        The flight's trend is first estimated by a line through the samples from ``trend_window[0]``
        to ``trend_window[1]`` seconds before the landing peak [s] (the initial values of ``b0``, ``b1``).
    rise_fraction : float
        The fit uses the rise up to this fraction of the peak above the trend [-] (0.8: the part where
        the impact model's smooth onset holds; the peak's top is shaped by the decay as well).
    lead : float
        Flight samples before the rise that take part in the fit [s] (they pin the trend at the onset).
    max_rise : float
        Longest plausible time from the onset to the peak [s]; the onset is searched within it.
    min_rise_samples : int
        Fewest samples on the rise for a fit: above 5 % of the peak, up to the first at ``rise_fraction``
        (a one-sample spike is no impact).
    """

    trend_window: tuple[float, float] = (0.30, 0.12)
    rise_fraction: float = 0.8
    lead: float = 0.1
    max_rise: float = 0.2
    min_rise_samples: int = 2


def _onset_model(x: np.ndarray, t: np.ndarray, t_peak: float) -> np.ndarray:
    """Trend plus smooth step (module text); ``x = (t0 [s], ln A [ln m/s^2], ln tau [ln s], b0, b1)``."""
    t0, ln_a, ln_tau, b0, b1 = x
    tau = np.maximum(t - t0, 0.0) / math.exp(ln_tau)
    return b0 + b1 * (t - t_peak) + math.exp(ln_a) * -np.expm1(-(tau * tau))


def impact_onset(t: np.ndarray, a: np.ndarray, k_peak: int, params: OnsetParams | None = None) -> float | None:
    """The time [s] at which the landing impact that peaks at sample ``k_peak`` began (module text).

    Parameters
    ----------
    t : ndarray, shape (n,)
        Sample times [s], increasing.
    a : ndarray, shape (n,)
        Norm of the specific force [m/s^2] (finite around the landing).
    k_peak : int
        Index of the landing peak of ``a``.
    params : OnsetParams, optional

    Returns
    -------
    float or None
        The onset ``t0`` [s] between the samples, or None where the fit is not credible (module text).
    """
    from scipy.optimize import least_squares

    p = params or OnsetParams()
    t = np.asarray(t, float)
    a = np.asarray(a, float)
    if not 0 < k_peak < t.size:
        return None
    t_peak = float(t[k_peak])
    tr = (t >= t_peak - p.trend_window[0]) & (t <= t_peak - p.trend_window[1]) & np.isfinite(a)
    if np.count_nonzero(tr) < 3:
        return None
    b1, b0 = np.polyfit(t[tr] - t_peak, a[tr], 1)
    r = a - (b0 + b1 * (t - t_peak))
    h = float(r[k_peak])
    if not h > 0:
        return None
    first = int(np.searchsorted(t, t_peak - p.max_rise))
    k_hi = k_peak  # the first sample of the rise at or above rise_fraction of the peak
    while k_hi - 1 > first and r[k_hi - 1] >= p.rise_fraction * h:
        k_hi -= 1
    k_lo = k_hi  # the first sample of the rise clearly above the flight (5 % of the peak)
    while k_lo - 1 > first and r[k_lo - 1] >= 0.05 * h:
        k_lo -= 1
    if k_lo - 1 <= first or k_hi - k_lo + 1 < p.min_rise_samples or r[k_lo - 1] >= 0.05 * h:
        return None  # no flight level within max_rise, or a rise of too few samples
    k_hi = max(k_hi, min(k_lo + 2, k_peak))  # at least three rise samples where the peak allows
    t_lo, t_hi = float(t[k_lo - 1]), float(t[k_hi])
    sel = (t >= t_lo - p.lead) & (t <= t_hi) & np.isfinite(a)
    ts, ys = t[sel], a[sel]
    step = float(median(np.diff(t[max(first, 0) : k_peak + 1]))) if k_peak - first > 1 else 0.0
    if not step > 0 or ts.size < 6:
        return None
    x0 = np.array([t_lo, math.log(h), math.log(max(0.5 * (t_hi - t_lo), step)), b0, b1])
    lo = np.array([t_lo - p.lead, math.log(0.1 * h), math.log(0.25 * step), -np.inf, -np.inf])
    hi = np.array([t_hi, math.log(10.0 * h), math.log(p.max_rise), np.inf, np.inf])
    try:
        sol = least_squares(lambda x: _onset_model(x, ts, t_peak) - ys, np.clip(x0, lo, hi), bounds=(lo, hi))
    except (ValueError, np.linalg.LinAlgError):
        return None
    t0, _, ln_tau = sol.x[:3]
    if not sol.success or not (t_lo - 2 * step <= t0 <= float(t[k_lo])):
        return None
    if not (lo[2] < ln_tau < hi[2]):  # the rise time sits on a bound: not this model's onset
        return None
    return float(t0)


def first_impact_peak(t: np.ndarray, a: np.ndarray, k_peak: int, params: OnsetParams | None = None) -> int:
    """The first hump of the landing whose largest sample is ``k_peak`` (an index into ``a``).

    The largest ``|a|`` of a landing is not always the impact's first rise: the body's ringing after it
    (a damped oscillation of the arm and trunk, 8-20 Hz) or the chatter of the skis on the snow can top it
    tens of milliseconds later, and the onset fitted before *that* peak is the start of its own rise, not
    the touch-down (issue 39: 15-30 ms late on the independent simulator).  From ``k_peak`` back, the run of
    samples above the flight's level -- the trend of ``trend_window`` (as :func:`impact_onset`) plus the
    larger of eight robust standard deviations of the flight and a fifth of the peak -- is followed to its
    first sample; the first local maximum after it that reaches half the peak (above the trend) is returned.
    On a single smooth impact that is ``k_peak`` itself.
    """
    p = params or OnsetParams()
    t = np.asarray(t, float)
    a = np.asarray(a, float)
    if not 0 < k_peak < t.size:
        return k_peak
    t_peak = float(t[k_peak])
    first = int(np.searchsorted(t, t_peak - p.max_rise))
    # the flight before the whole landing (the rise may start up to max_rise before the peak)
    fl = (t >= t_peak - p.max_rise - 0.3) & (t <= t_peak - p.max_rise) & np.isfinite(a)
    if np.count_nonzero(fl) < 5:
        return k_peak
    b1, b0 = np.polyfit(t[fl] - t_peak, a[fl], 1)
    r = a - (b0 + b1 * (t - t_peak))
    sig = 1.4826 * float(median(np.abs(r[fl] - median(r[fl]))))
    h = float(r[k_peak])
    if not h > 0:
        return k_peak
    thr = max(8.0 * sig, 0.2 * h)
    k = k_peak
    while k - 1 > first and np.isfinite(r[k - 1]) and r[k - 1] > thr:
        k -= 1
    for j in range(k, k_peak):
        if r[j] >= 0.5 * h and r[j] >= r[j + 1] and (j == 0 or r[j] >= r[j - 1]):
            return j
    return k_peak


def impact_crossing(
    t: np.ndarray, a: np.ndarray, k_first: int, fraction: float = 0.05, k_sigma: float = 5.0
) -> float | None:
    """The time [s] at which the landing's first hump (peak at ``k_first``) rises through ``fraction`` of its
    height above the flight's trend (at least ``k_sigma`` robust standard deviations of the flight), linearly
    interpolated between the samples; None where there is no flight before it.

    A fallback for :func:`impact_onset` (a rise too abrupt or too irregular for its model): late by the time
    the impact takes to build up that fraction (a few milliseconds; on the independent simulator 15 ms with
    a spread of 2 ms, against the onset's 11 ms and 4 ms), but never a whole hump late as the peak minus a
    fixed offset can be.
    """
    t = np.asarray(t, float)
    a = np.asarray(a, float)
    if not 0 < k_first < t.size:
        return None
    tp = float(t[k_first])
    fl = (t >= tp - 0.5) & (t <= tp - 0.2) & np.isfinite(a)
    if np.count_nonzero(fl) < 5:
        return None
    b1, b0 = np.polyfit(t[fl] - tp, a[fl], 1)
    r = a - (b0 + b1 * (t - tp))
    sig = 1.4826 * float(median(np.abs(r[fl] - median(r[fl]))))
    h = float(r[k_first])
    thr = max(k_sigma * sig, fraction * h)
    if not h > thr:
        return None
    first = int(np.searchsorted(t, tp - 0.2))
    k = k_first
    while k - 1 > first and r[k - 1] > thr:
        k -= 1
    if k - 1 <= first or k >= k_first or not r[k] > r[k - 1]:
        return None  # no flight before it, or a rise of one sample (a spike is no impact)
    return float(t[k - 1] + (thr - r[k - 1]) / (r[k] - r[k - 1]) * (t[k] - t[k - 1]))
