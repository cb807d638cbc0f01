"""A MEMS sensor triad as it is built, not as an estimator models it (simulation toolkit, no sport).

An estimator usually assumes ``measured = true + constant bias + white noise``, sampled at the output
instants.  A real accelerometer, gyroscope or magnetometer chip:

1. senses the true quantity through a sensitivity matrix ``(I + diag(scale) + misalign)``: per-axis scale
   errors and the axes' non-orthogonality and mounting misalignment (small off-diagonal angles [rad]);
2. adds a bias that is not constant: a turn-on value, plus a temperature coefficient times the
   temperature's change, plus a slow random walk (bias instability);
3. samples internally at a high rate (here the truth's fine grid, 1 kHz), clips at its range (an ADC
   saturates before any filtering), adds its white noise there (a noise density [unit/sqrt(Hz)]);
4. low-pass filters digitally against aliasing (a second-order Butterworth section at ``cutoff`` [Hz],
   causal: a group delay of ``sqrt(2) / (2 pi cutoff)`` at low frequencies, 5.5 ms at 41 Hz) -- or,
   with ``antialias = "boxcar"``, averages the fine samples over each output interval (a delta-v
   integrator's output divided by the interval, half an interval late), or, ``"point"``, takes the fine
   sample at the output instant (what a simulator that copies the estimator's model does);
5. decimates to the output rate and quantises to its least significant bit.

:func:`sense` does all of that on a fine-grid truth signal; every random draw is made by the caller
(:class:`TriadErrors`), so a simulator can switch one effect off and keep the other draws.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

ANTIALIAS = ("butterworth", "boxcar", "point")


@dataclass
class TriadErrors:
    """Errors of one three-axis sensor (units of the sensed quantity ``u``: m/s^2, rad/s, uT).

    Attributes
    ----------
    bias : (3,) turn-on bias [u]
    scale : (3,) scale-factor errors [1]
    misalign : (3, 3) off-diagonal sensitivity (non-orthogonality + mounting) [rad]; diagonal ignored
    temp_coeff : (3,) bias change per kelvin [u/K]
    bias_walk : bias random-walk density [u/sqrt(s)] (bias instability)
    noise_density : white-noise density [u/sqrt(Hz)], added at the internal rate
    lsb : output quantisation step [u] (0: none)
    full_scale : saturation of the raw samples [u] (0: none)
    cross : (3, 3) extra input-to-output coupling from a second quantity (gyro g-sensitivity [rad/s per
        m/s^2]); applied by :func:`sense` when ``other`` is given
    """

    bias: np.ndarray = field(default_factory=lambda: np.zeros(3))
    scale: np.ndarray = field(default_factory=lambda: np.zeros(3))
    misalign: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    temp_coeff: np.ndarray = field(default_factory=lambda: np.zeros(3))
    bias_walk: float = 0.0
    noise_density: float = 0.0
    lsb: float = 0.0
    full_scale: float = 0.0
    cross: np.ndarray | None = None

    def sensitivity(self) -> np.ndarray:
        """``I + diag(scale) + misalign`` (off-diagonal part only) (3, 3)."""
        m = np.array(self.misalign, dtype=float) * (1.0 - np.eye(3))
        return np.eye(3) + np.diag(self.scale) + m


def butterworth2(cutoff: float, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients ``(b, a)`` of a second-order Butterworth low-pass at ``cutoff`` [Hz] for rate ``fs`` [Hz].

    The bilinear transform with pre-warping, written out (no filter-design library involved):
    ``K = tan(pi fc / fs)``, ``b = K^2 (1, 2, 1) / d``, ``a = (1, 2 (K^2 - 1) / d, (1 - sqrt2 K + K^2) / d)``
    with ``d = 1 + sqrt2 K + K^2``; unit gain at 0 Hz, -3 dB at ``cutoff``.
    """
    k = math.tan(math.pi * cutoff / fs)
    r2 = math.sqrt(2.0)
    d = 1.0 + r2 * k + k * k
    b = np.array([k * k, 2 * k * k, k * k]) / d
    a = np.array([1.0, 2.0 * (k * k - 1.0) / d, (1.0 - r2 * k + k * k) / d])
    return b, a


def lowpass(x: np.ndarray, cutoff: float, fs: float) -> np.ndarray:
    """:func:`butterworth2` applied causally along axis 0 (direct form II transposed), started in steady
    state on the first sample; written out in Python floats (no filtering library's version involved)."""
    b, a = butterworth2(cutoff, fs)
    b0, b1, b2 = (float(v) for v in b)
    _, a1, a2 = (float(v) for v in a)
    x = np.asarray(x, dtype=float)
    out = np.empty_like(x)
    for j in range(x.shape[1]):
        col = x[:, j].tolist()
        x0 = col[0] if col else 0.0
        # steady state for a constant input x0 (unit DC gain): y = x0
        z1 = x0 - b0 * x0
        z2 = b2 * x0 - a2 * x0
        res = [0.0] * len(col)
        for i, xi in enumerate(col):
            y = b0 * xi + z1
            z1 = b1 * xi - a1 * y + z2
            z2 = b2 * xi - a2 * y
            res[i] = y
        out[:, j] = res
    return out


def group_delay(cutoff: float) -> float:
    """Low-frequency group delay [s] of :func:`butterworth2` (analogue prototype): ``sqrt(2) / (2 pi fc)``."""
    return math.sqrt(2.0) / (2.0 * math.pi * cutoff)


def sense(
    truth: np.ndarray,
    fs: float,
    decimate: int,
    err: TriadErrors,
    rng_noise: np.random.Generator,
    temperature: np.ndarray | None = None,
    antialias: str = "butterworth",
    cutoff: float = 41.0,
    other: np.ndarray | None = None,
) -> np.ndarray:
    """What the chip outputs: the fine-grid ``truth`` (N, 3) [u] at rate ``fs`` [Hz] -> (N // decimate, 3).

    Output sample ``k`` is the filter's output at fine sample ``k * decimate`` (``"point"``: that fine
    sample; ``"boxcar"``: the mean of the ``decimate`` fine samples ending there).  ``temperature`` (N,)
    [K, any origin] drives ``temp_coeff`` relative to its first value; ``other`` (N, 3) is the quantity
    ``cross`` couples in (the specific force for a gyroscope).  Noise and the bias walk are drawn from
    ``rng_noise``.
    """
    if antialias not in ANTIALIAS:
        raise ValueError(f"antialias {antialias!r}; expected one of {ANTIALIAS}")
    x = np.asarray(truth, dtype=float) @ err.sensitivity().T
    if err.cross is not None and other is not None:
        x = x + np.asarray(other, dtype=float) @ np.asarray(err.cross, dtype=float).T
    n = x.shape[0]
    dt = 1.0 / fs
    bias = np.broadcast_to(np.asarray(err.bias, dtype=float), (n, 3)).copy()
    if temperature is not None:
        bias += (np.asarray(temperature, dtype=float) - float(temperature[0]))[:, None] * np.asarray(err.temp_coeff)
    if err.bias_walk > 0:
        bias += np.cumsum(rng_noise.normal(0.0, err.bias_walk * math.sqrt(dt), (n, 3)), axis=0)
    x = x + bias
    if err.noise_density > 0:
        x = x + rng_noise.normal(0.0, err.noise_density * math.sqrt(fs / 2.0), (n, 3))
    if err.full_scale > 0:
        x = np.clip(x, -err.full_scale, err.full_scale)
    idx = np.arange(0, n, decimate)
    if antialias == "butterworth":
        y = lowpass(x, cutoff, fs)[idx]
    elif antialias == "boxcar":
        c = np.vstack([np.zeros((1, 3)), np.cumsum(x, axis=0)])
        lo = np.maximum(idx + 1 - decimate, 0)
        y = (c[idx + 1] - c[lo]) / (idx + 1 - lo)[:, None]
    else:
        y = x[idx]
    if err.lsb > 0:
        y = np.round(y / err.lsb) * err.lsb
    return y


def misalignment(rng: np.random.Generator, sigma: float) -> np.ndarray:
    """A (3, 3) off-diagonal sensitivity matrix with independent N(0, ``sigma``) entries [rad]."""
    return rng.normal(0.0, sigma, (3, 3)) * (1.0 - np.eye(3))
