"""GNSS error processes that are not white Gaussian noise (simulation toolkit, no sport).

An estimator's usual model of a fix is ``truth + white Gaussian noise``.  A receiver's error is mostly
slow (atmosphere, orbits, the satellites' geometry change over minutes: :func:`gauss_markov`), has
episodes of multipath near structures and slopes that bias it by metres for seconds
(:func:`multipath`), and now and then a wild fix (a wrong ambiguity, a reflection taken for the direct
signal: :func:`outliers`).  Each function draws from the generator it is given and returns an error to
add, so that a simulator can switch one on without changing the others' draws.
"""

from __future__ import annotations

import math

import numpy as np

from sportfusion.sim.smooth import smoothstep


def gauss_markov(rng: np.random.Generator, t: np.ndarray, sigma: float, tau: float) -> np.ndarray:
    """First-order Gauss-Markov process at times ``t`` [s]: stationary 1-sigma ``sigma``, correlation time
    ``tau`` [s] (exact discretisation between the samples)."""
    t = np.asarray(t, dtype=float)
    out = np.empty(t.size)
    if t.size == 0:
        return out
    out[0] = rng.normal(0.0, sigma)
    for k in range(1, t.size):
        phi = math.exp(-(t[k] - t[k - 1]) / tau)
        out[k] = phi * out[k - 1] + rng.normal(0.0, sigma * math.sqrt(1 - phi * phi))
    return out


def multipath(
    rng: np.random.Generator,
    t: np.ndarray,
    rate: float,
    duration: tuple[float, float],
    amplitude: tuple[float, float],
    vertical_share: float = 0.5,
    edge: float = 0.5,
) -> tuple[np.ndarray, np.ndarray]:
    """Multipath bias episodes: offsets (n, 3) [m] in a local frame (x, y horizontal, z down) and the episode
    weight (n,) [0..1].

    Episodes start as a Poisson process of ``rate`` [1/s] over ``t``; each lasts ``duration`` (uniform,
    [s]), ramps in and out over ``edge`` [s] (smoothstep), and pushes the fix by an amplitude uniform in
    ``amplitude`` [m] along a random horizontal direction plus ``vertical_share`` of it vertically (either
    sign).
    """
    t = np.asarray(t, dtype=float)
    out = np.zeros((t.size, 3))
    weight = np.zeros(t.size)
    if t.size == 0 or rate <= 0:
        return out, weight
    start = float(t[0]) - duration[1] * rng.uniform()  # an episode may already be running at the start
    while True:
        start += rng.exponential(1.0 / rate)
        if start > t[-1]:
            break
        dur = rng.uniform(*duration)
        amp = rng.uniform(*amplitude)
        az = rng.uniform(0.0, 2 * math.pi)
        vz = vertical_share * rng.choice([-1.0, 1.0])
        e = min(edge, 0.5 * dur)
        w = smoothstep((t - start) / e)[0] * (1.0 - smoothstep((t - start - dur + e) / e)[0])
        out += amp * w[:, None] * np.array([math.cos(az), math.sin(az), vz])
        weight = np.maximum(weight, w)
    return out, weight


def outliers(
    rng: np.random.Generator, n: int, probability: float, magnitude: tuple[float, float], vertical_share: float = 1.0
) -> np.ndarray:
    """Wild fixes: (n, 3) offsets [m], zero except on a fraction ``probability`` of the fixes, where the
    offset has a magnitude uniform in ``magnitude`` [m] along a random direction (its vertical part scaled by
    ``vertical_share``)."""
    out = np.zeros((n, 3))
    hit = rng.uniform(size=n) < probability
    k = int(hit.sum())
    if k:
        d = rng.normal(size=(k, 3))
        d[:, 2] *= vertical_share
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        out[hit] = d * rng.uniform(magnitude[0], magnitude[1], k)[:, None]
    return out
