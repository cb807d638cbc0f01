"""Smooth building blocks for simulated truth: steps, pulses, oscillations with exact derivatives.

A truth IMU sampled at 100 Hz is integrated by the smoother with RK4 and
linearly interpolated inputs, i.e. (for the quadrature part) the trapezoidal
rule.  Its error is governed by the jumps of the *odd* derivatives of the
signal at the junctions of its pieces (Euler-Maclaurin).  The shapes here are
chosen for that: the septic smoothstep has zero first to third derivatives at
both ends, and the Gaussian-based pulses are even functions at their start,
so all their odd derivatives vanish there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


def smoothstep(u: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Septic smoothstep ``S(u) = 35u^4 - 84u^5 + 70u^6 - 20u^7`` on [0, 1], constant outside.

    Returns
    -------
    S, dS/du, d2S/du2 : ndarray
        Value and first two derivatives (zero outside [0, 1]); S is C3 at 0 and 1.
    """
    u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    s = u**4 * (35 - 84 * u + 70 * u**2 - 20 * u**3)
    d1 = 140 * u**3 * (1 - u) ** 3
    d2 = 420 * u**2 * (1 - u) ** 2 * (1 - 2 * u)
    return s, d1, d2


def smoothstep5(u: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """C5 smoothstep ``S(u) = 2772 int_0^u s^5 (1 - s)^5 ds`` (degree 11) on [0, 1], constant outside.

    Returns
    -------
    S, dS/du, d2S/du2 : ndarray
        Value and first two derivatives; the first to fifth derivatives vanish at 0 and 1.
    """
    u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    s = u**6 * (462 + u * (-1980 + u * (3465 + u * (-3080 + u * (1386 - 252 * u)))))
    d1 = 2772 * u**5 * (1 - u) ** 5
    d2 = 13860 * u**4 * (1 - u) ** 4 * (1 - 2 * u)
    return s, d1, d2


def pulse_shape(tau: np.ndarray | float, tau_r: float, tau_d: float) -> np.ndarray:
    """Unit-peak pulse ``(1 - exp(-(tau/tau_r)^2)) exp(-(tau/tau_d)^2)``, zero for ``tau < 0``.

    Rises over ``tau_r`` [s], decays over ``tau_d`` [s]; even in ``tau`` at 0.
    The peak, at ``tau_r sqrt(ln(1 + k^2))`` with ``k = tau_d / tau_r``, is scaled to 1.
    """
    tau = np.asarray(tau, dtype=float)
    k2 = (tau_d / tau_r) ** 2
    a = np.log1p(k2)
    peak = (1 - np.exp(-a)) * np.exp(-a / k2)
    out = (1 - np.exp(-((tau / tau_r) ** 2))) * np.exp(-((tau / tau_d) ** 2)) / peak
    return np.where(tau >= 0, out, 0.0)


def pulse_peak_time(tau_r: float, tau_d: float) -> float:
    """Time [s] of the maximum of :func:`pulse_shape`."""
    return float(tau_r * np.sqrt(np.log1p((tau_d / tau_r) ** 2)))


def pulse_rise_for_peak(t_peak: float, tau_d: float) -> float:
    """The ``tau_r`` [s] that puts the peak of :func:`pulse_shape` at ``t_peak`` [s] for a given ``tau_d``."""
    lo, hi = 1e-6, t_peak
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if pulse_peak_time(mid, tau_d) < t_peak:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@dataclass
class Signal:
    """A smooth scalar function of time: a constant plus septic steps plus modulated sines.

    ``value(t) = base + sum amp_i S((t - t0_i) / dur_i) + sum A_j(t) sin(2 pi f_j t + phi_j)``
    where each envelope ``A_j`` is itself a :class:`Signal`.  :meth:`rate` is
    the exact time derivative.
    """

    base: float = 0.0
    steps: list[tuple[float, float, float]] = field(default_factory=list)  # (t0 [s], dur [s], amp)
    waves: list[tuple[float, float, Signal]] = field(default_factory=list)  # (f [Hz], phase [rad], envelope)

    def step(self, t0: float, dur: float, amp: float) -> Signal:
        """Add a smooth step of ``amp`` from ``t0`` over ``dur`` seconds; returns self."""
        self.steps.append((float(t0), float(dur), float(amp)))
        return self

    def wave(self, freq: float, phase: float, envelope: Signal) -> Signal:
        """Add ``envelope(t) sin(2 pi freq t + phase)``; returns self."""
        self.waves.append((float(freq), float(phase), envelope))
        return self

    def value(self, t: np.ndarray) -> np.ndarray:
        """Value at times ``t`` [s]."""
        t = np.asarray(t, dtype=float)
        out = np.full(t.shape, self.base)
        for t0, dur, amp in self.steps:
            out += amp * smoothstep((t - t0) / dur)[0]
        for f, ph, env in self.waves:
            out += env.value(t) * np.sin(2 * np.pi * f * t + ph)
        return out

    def rate(self, t: np.ndarray) -> np.ndarray:
        """Exact derivative d value / dt at ``t`` [1/s]."""
        t = np.asarray(t, dtype=float)
        out = np.zeros(t.shape)
        for t0, dur, amp in self.steps:
            out += amp * smoothstep((t - t0) / dur)[1] / dur
        for f, ph, env in self.waves:
            w = 2 * np.pi * f
            out += env.rate(t) * np.sin(w * t + ph) + env.value(t) * w * np.cos(w * t + ph)
        return out


def smoothstep_s(u: float) -> float:
    """Scalar :func:`smoothstep` value (fast path for ODE right-hand sides)."""
    if u <= 0.0:
        return 0.0
    if u >= 1.0:
        return 1.0
    return u**4 * (35 - 84 * u + 70 * u * u - 20 * u**3)


def pulse_s(tau: float, tau_r: float, tau_d: float) -> float:
    """Scalar :func:`pulse_shape` (fast path)."""
    if tau < 0.0:
        return 0.0
    k2 = (tau_d / tau_r) ** 2
    a = math.log1p(k2)
    peak = (1 - math.exp(-a)) * math.exp(-a / k2)
    return (1 - math.exp(-((tau / tau_r) ** 2))) * math.exp(-((tau / tau_d) ** 2)) / peak
