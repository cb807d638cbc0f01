"""Sensor error models for simulators: a three-axis sensor (accelerometer, gyroscope, magnetometer) as a
chip measures, with the errors a calibration leaves or does not touch.

Knows no sport and no estimator.  A :class:`TriadSpec` holds the 1-sigma sizes of the errors; its
:meth:`TriadSpec.draw` makes one sensor (a :class:`Triad`: the errors of one chip on one day), whose
:meth:`Triad.measure` turns true values into readings::

    y = Q( clip( (I + S(T)) (I + A) x + b0 + b_T (T - T0) + w(t) + n ) )

* ``S(T)`` -- per-axis scale-factor error, changing with temperature ``T`` [K] (``temp_scale`` per K);
* ``A`` -- axis misalignment / non-orthogonality (a general small matrix, zero diagonal);
* ``b0`` -- constant bias; ``b_T`` -- bias temperature coefficient; ``w`` -- bias random walk;
* ``n`` -- white noise; ``clip`` -- the range; ``Q`` -- quantisation to the resolution (the LSB).

Temperatures come from :func:`temperature_profile` (a sensor worn under a race suit: warm from the
start house, cooling towards the air temperature in the wind of the run).  Vibration is motion, not a
sensor error: :func:`band_noise` makes band-limited random signals for the simulators to add to the
true motion (ski chatter, a slapped hand).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TriadSpec:
    """1-sigma sizes of a three-axis sensor's errors (units of the measured quantity, ``u``).

    Attributes
    ----------
    bias : float
        Constant bias per axis [u].
    bias_walk : float
        Bias random walk [u / sqrt(s)].
    scale : float
        Scale-factor error per axis [1].
    misalignment : float
        Off-diagonal coupling between axes [rad].
    noise : float
        White noise per sample [u].
    temp_bias : float
        Bias temperature coefficient per axis [u / K].
    temp_scale : float
        Scale-factor temperature coefficient per axis [1 / K].
    resolution : float
        Quantisation step (one LSB) [u]; 0: none.
    range : float
        Measurement range, readings clip at +-range [u].
    """

    bias: float = 0.0
    bias_walk: float = 0.0
    scale: float = 0.0
    misalignment: float = 0.0
    noise: float = 0.0
    temp_bias: float = 0.0
    temp_scale: float = 0.0
    resolution: float = 0.0
    range: float = float("inf")

    def draw(self, rng: np.random.Generator) -> Triad:
        """One sensor: the constant errors drawn from the 1-sigma sizes."""
        a = rng.normal(0.0, self.misalignment, (3, 3))
        np.fill_diagonal(a, 0.0)
        return Triad(
            spec=self,
            scale=rng.normal(0.0, self.scale, 3),
            misalignment=a,
            bias=rng.normal(0.0, self.bias, 3),
            temp_bias=rng.normal(0.0, self.temp_bias, 3),
            temp_scale=rng.normal(0.0, self.temp_scale, 3),
        )


@dataclass(frozen=True)
class Triad:
    """One drawn sensor (see :class:`TriadSpec`): scale (3,), misalignment (3, 3), bias (3,) [u],
    temperature coefficients (3,) [u/K] and (3,) [1/K]."""

    spec: TriadSpec
    scale: np.ndarray
    misalignment: np.ndarray
    bias: np.ndarray
    temp_bias: np.ndarray
    temp_scale: np.ndarray

    def measure(
        self,
        t: np.ndarray,
        x: np.ndarray,
        rng: np.random.Generator,
        temperature: np.ndarray | None = None,
        t_ref: float = 0.0,
    ) -> np.ndarray:
        """Readings (n, 3) of the true values ``x`` (n, 3) at times ``t`` (n,) [s].

        ``temperature`` (n,) [deg C] drives the temperature terms relative to ``t_ref`` [deg C] (the
        temperature of the sensor's calibration); ``None``: constant at ``t_ref``.
        """
        s = self.spec
        x = np.asarray(x, dtype=float)
        dT = np.zeros(x.shape[0]) if temperature is None else np.asarray(temperature, float) - t_ref
        gain = 1.0 + self.scale[None, :] + dT[:, None] * self.temp_scale[None, :]
        y = np.einsum("ij,nj->ni", np.eye(3) + self.misalignment, x) * gain
        y = y + self.bias + dT[:, None] * self.temp_bias[None, :]
        if s.bias_walk > 0 and x.shape[0] > 1:
            dt = np.diff(t, prepend=t[0])
            y = y + np.cumsum(rng.normal(0.0, 1.0, x.shape) * (s.bias_walk * np.sqrt(dt))[:, None], axis=0)
        if s.noise > 0:
            y = y + rng.normal(0.0, s.noise, x.shape)
        y = np.clip(y, -s.range, s.range)
        if s.resolution > 0:
            y = np.round(y / s.resolution) * s.resolution
        return y


def temperature_profile(
    t: np.ndarray, t_start: float, t_end: float, start: float, air: float, tau: float = 90.0
) -> np.ndarray:
    """Sensor temperature [deg C] at times ``t`` [s]: ``start`` until ``t_start``, then relaxing towards
    ``air`` with the time constant ``tau`` [s] while the athlete moves (wind chill), and held after
    ``t_end`` (standing still at the finish)."""
    run = np.clip(np.asarray(t, float), t_start, t_end) - t_start
    return air + (start - air) * np.exp(-run / tau)


def band_noise(
    rng: np.random.Generator, n: int, rate: float, band: tuple[float, float], rms: float, dims: int = 3
) -> np.ndarray:
    """Band-limited Gaussian noise (n, dims) of the given ``rms`` with its power flat in ``band`` [Hz]
    (``rate`` [Hz] the sampling rate): vibrations such as ski chatter."""
    if n == 0 or rms == 0:
        return np.zeros((n, dims))
    spec = rng.normal(size=(n // 2 + 1, dims)) + 1j * rng.normal(size=(n // 2 + 1, dims))
    f = np.fft.rfftfreq(n, 1.0 / rate)
    spec[(f < band[0]) | (f > band[1])] = 0.0
    x = np.fft.irfft(spec, n=n, axis=0)
    sd = x.std(axis=0)
    return x * (rms / np.where(sd > 0, sd, 1.0))
