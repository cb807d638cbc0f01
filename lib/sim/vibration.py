"""Vibration with exact derivatives: ski chatter, flutter, impact ringing (simulation toolkit, no sport).

A vibration is added to a truth *displacement*, so that position, velocity and acceleration stay one
consistent motion: each function returns ``(d, d', d'')`` [m, m/s, m/s^2] on the given times.

* :func:`band_noise`: random vibration in a frequency band -- a sum of ``tones`` sinusoids with random
  frequencies (uniform in the band) and phases, scaled so that the acceleration's RMS is ``rms`` where
  the envelope is 1; the displacement amplitudes follow as ``A / (2 pi f)^2`` (a tenth of a millimetre
  for 3 m/s^2 at 25 Hz).
* :func:`body_response`: how a compliant body carries an impact to a sensor on it -- the sensor's motion
  relative to the base, ``x'' + 2 zeta w x' + w^2 x = -e(t)`` driven by the base's acceleration change
  ``e`` (the transmissibility of a damped oscillator: the sensor's acceleration rises smoothly with the
  impact, overshoots it and rings at the body's frequency).

The envelope of :func:`band_noise` is an :class:`Envelope`: a constant plus smooth steps, with its first
two derivatives, so that switching a vibration on (the in-run) and off (the take-off) keeps the motion
twice differentiable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sportfusion.sim.smooth import smoothstep


@dataclass
class Envelope:
    """``base + sum amp_i S((t - t0_i) / dur_i)`` (septic smoothstep ``S``) with exact derivatives."""

    base: float = 0.0
    steps: list[tuple[float, float, float]] = field(default_factory=list)  # (t0 [s], dur [s], amp)

    def step(self, t0: float, dur: float, amp: float) -> Envelope:
        """Add a smooth step of ``amp`` from ``t0`` [s] over ``dur`` [s]; returns self."""
        self.steps.append((float(t0), float(dur), float(amp)))
        return self

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Value and its first two time derivatives at ``t`` [s]."""
        t = np.asarray(t, dtype=float)
        v, d1, d2 = np.full(t.shape, self.base), np.zeros(t.shape), np.zeros(t.shape)
        for t0, dur, amp in self.steps:
            s, s1, s2 = smoothstep((t - t0) / dur)
            v += amp * s
            d1 += amp * s1 / dur
            d2 += amp * s2 / dur**2
        return v, d1, d2


def band_noise(
    t: np.ndarray,
    rng: np.random.Generator,
    band: tuple[float, float],
    rms: float,
    envelope: Envelope | None = None,
    tones: int = 24,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random vibration in ``band`` [Hz] with acceleration RMS ``rms`` [m/s^2] under a unit envelope.

    Returns displacement [m], velocity [m/s] and acceleration [m/s^2] at ``t`` [s] (module text).
    """
    t = np.asarray(t, dtype=float)
    f = rng.uniform(band[0], band[1], tones)
    ph = rng.uniform(0.0, 2 * math.pi, tones)
    amp_a = rms * math.sqrt(2.0 / tones)  # each tone's acceleration amplitude
    d = np.zeros(t.shape)
    d1 = np.zeros(t.shape)
    d2 = np.zeros(t.shape)
    for fk, pk in zip(f, ph, strict=True):
        w = 2 * math.pi * fk
        a = amp_a / (w * w)
        arg = w * t + pk
        s, c = np.sin(arg), np.cos(arg)
        d += a * s
        d1 += a * w * c
        d2 -= a * w * w * s
    if envelope is None:
        return d, d1, d2
    e, e1, e2 = envelope(t)
    return e * d, e1 * d + e * d1, e2 * d + 2 * e1 * d1 + e * d2


def body_response(
    t: np.ndarray, excitation: np.ndarray, freq: float, damping: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Relative displacement, velocity, acceleration (n, k) of a sensor on a compliant body (module text).

    ``excitation`` (n, k) [m/s^2] is the base's acceleration change on the times ``t`` [s] (uniform
    steps); the ODE ``x'' = -e - 2 zeta w x' - w^2 x`` (``w = 2 pi freq``, ``zeta = damping``) is integrated
    by RK4 from rest with ``e`` linear between the samples; the acceleration is the ODE's right-hand side at
    the samples, so the three stay one motion.
    """
    t = np.asarray(t, dtype=float)
    e = np.asarray(excitation, dtype=float)
    w = 2 * math.pi * freq
    c1, c0 = 2 * damping * w, w * w
    n = t.size
    x = np.zeros(e.shape)
    v = np.zeros(e.shape)
    active = np.flatnonzero(np.any(e != 0.0, axis=1))
    if active.size:
        xk = np.zeros(e.shape[1])
        vk = np.zeros(e.shape[1])
        for k in range(int(active[0]), n - 1):
            h = t[k + 1] - t[k]
            e0, e1 = e[k], e[k + 1]
            em = 0.5 * (e0 + e1)
            a1 = -e0 - c1 * vk - c0 * xk
            x2, v2 = xk + 0.5 * h * vk, vk + 0.5 * h * a1
            a2 = -em - c1 * v2 - c0 * x2
            x3, v3 = xk + 0.5 * h * v2, vk + 0.5 * h * a2
            a3 = -em - c1 * v3 - c0 * x3
            x4, v4 = xk + h * v3, vk + h * a3
            a4 = -e1 - c1 * v4 - c0 * x4
            xk = xk + h / 6 * (vk + 2 * v2 + 2 * v3 + v4)
            vk = vk + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
            x[k + 1], v[k + 1] = xk, vk
    a = -e - c1 * v - c0 * x
    return x, v, a
