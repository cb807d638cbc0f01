"""The sensors of a simulated ski jump as they are, not as the smoother models them (issue 39).

The smoother (skijump eqs 35-39) assumes constant biases and white Gaussian noise on IMU samples taken
at the output instants, a magnetometer that sees the Earth's field through a diagonal scale and a bias,
and GNSS fixes of the IMU's own position with white Gaussian errors.  :class:`Realism` describes the
world :func:`sportfusion.skijump.sim.simulate.simulate_skijump` builds instead (``physics="full"``):

* **Continuous truth, sampled as a chip does.**  The motion is computed on a 1 kHz grid (RK4, 1 ms); the
  accelerometer and gyroscope sense it through a sensitivity matrix (scale errors, misalignment), a
  temperature-driven bias, g-sensitivity (gyro), white noise at 1 kHz, clipping at +-16 g / +-2000 deg/s,
  a digital anti-aliasing low-pass (second-order Butterworth at 41 Hz: 5.5 ms of group delay), decimation
  to 100 Hz and 16-bit quantisation (:func:`sportfusion.sim.imu.sense`).
* **Vibration.**  Ski chatter on the in-run track and on the snow of the out-run (random, 15-80 Hz, part of
  it above the 50 Hz Nyquist frequency of the output), a little flutter in flight, and the landing impact's
  ringing (the body -- a damped 8-20 Hz oscillator -- carries the impact to the arm: the sensor's force
  rises with the impact, overshoots and rings), as displacement of the truth and as angular vibration of
  the arm (the gyro sees 10-40 Hz rates) -- :mod:`sportfusion.sim.vibration`.
* **Temperature.**  The phone cools from the jacket to the air (``temp_change`` K, time constant
  ``temp_tau``), and every bias follows with its own coefficient.
* **Magnetometer.**  Hard and soft iron (a full 3x3 soft-iron matrix, not a diagonal scale), a site
  anomaly on top of the World Magnetic Model, steel in the take-off table (magnetic dipoles under the last
  metres of the in-run: tens of uT at the athlete), white noise and 0.15 uT quantisation.
* **GNSS.**  The antenna is on the helmet: fixed in the *jumper's* frame, not the phone's, so the lever arm
  seen from the arm-mounted IMU turns with the arm; the fix stamped ``t`` describes ``t - latency``; the
  receiver's epochs are whole tenths of a second of GNSS time, which the phone's IMU clock does not share
  (a random phase of 1-9 ms); the error is a slow Gauss-Markov drift (horizontal and, larger, vertical),
  white noise, multipath episodes of metres for seconds and occasional wild fixes
  (:mod:`sportfusion.sim.gnss`); the Doppler velocity has its own white noise and a multipath share.

Every effect draws from its own random stream (``numpy.random.default_rng([seed, k])``), so a variant
(:data:`VARIANTS`) that changes one effect leaves the others' draws -- and the jump itself -- unchanged.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np

from sportfusion.core import rotations
from sportfusion.sim.gnss import gauss_markov, multipath, outliers
from sportfusion.sim.imu import TriadErrors, misalignment
from sportfusion.sim.smooth import Signal
from sportfusion.sim.vibration import Envelope, band_noise, body_response

G = 9.80665
DEG = math.pi / 180.0

#: Random streams of the effects: ``default_rng([seed, STREAM[name]])``.
STREAM = {"imu": 11, "noise": 12, "mag": 13, "gnss": 14, "vibration": 15, "temperature": 16, "antenna": 17}


@dataclass(frozen=True)
class Realism:
    """The physics of ``simulate skijump`` beyond the smoother's model (module text; SI units, 1-sigma)."""

    fine_rate: float = 1000.0  # truth grid and the chips' internal rate [Hz]
    antialias: str = "butterworth"  # "butterworth", "boxcar" or "point" (sportfusion.sim.imu.sense)
    cutoff: float = 41.0  # anti-aliasing low-pass [Hz]
    # accelerometer
    acc_noise_density: float = 300e-6 * G  # [m/s^2/sqrt(Hz)] (0.02 m/s^2 at the 100 Hz output)
    acc_bias: float = 0.1  # turn-on bias [m/s^2]
    acc_scale: float = 0.005  # scale-factor error [1]
    acc_misalign: float = 0.5  # axis misalignment [deg]
    acc_tempco: float = 0.5e-3 * G  # bias per kelvin [m/s^2/K]
    acc_range: float = 16 * G  # [m/s^2]
    acc_lsb: float = 32 * G / 65536  # [m/s^2]
    # gyroscope
    gyr_noise_density: float = 0.01 * DEG  # [rad/s/sqrt(Hz)] (0.0012 rad/s at the output)
    gyr_bias: float = 0.02  # [rad/s]
    gyr_scale: float = 0.005  # [1]
    gyr_misalign: float = 0.5  # [deg]
    gyr_tempco: float = 0.02 * DEG  # [rad/s/K]
    gyr_gsens: float = 0.1 * DEG / G  # g-sensitivity [rad/s per m/s^2]
    gyr_range: float = 2000 * DEG  # [rad/s]
    gyr_lsb: float = 4000 * DEG / 65536  # [rad/s]
    # temperature of the phone: from the jacket to the air
    temp_change: float = -6.0  # [K] (drawn +-50 %)
    temp_tau: float = 240.0  # [s]
    # vibration (acceleration RMS [m/s^2], rate RMS [rad/s])
    chatter_inrun: float = 3.0
    chatter_outrun: float = 5.0
    flutter: float = 0.3
    chatter_gyr: float = 0.1
    body_freq: tuple[float, float] = (8.0, 20.0)  # the body's frequency carrying the impact to the arm [Hz]
    body_damping: tuple[float, float] = (0.15, 0.35)  # its damping ratio [1]
    ringing_gyr: float = 0.5  # the arm's angular ringing after the impact, rate peak [rad/s]
    # magnetometer [uT]
    mag_noise: float = 0.4
    mag_lsb: float = 0.15
    mag_bias: float = 5.0
    mag_scale: float = 0.03  # soft iron, diagonal [1]
    mag_cross: float = 0.02  # soft iron, off-diagonal [1]
    mag_anomaly: float = 1.0  # site anomaly per NED axis [uT]
    table_field: float = 20.0  # field of each take-off-table dipole at 1.5 m [uT]
    table_dipoles: int = 3
    table_span: float = 12.0  # the dipoles lie under the last metres of the in-run [m]
    # GNSS
    antenna: tuple[float, float, float] = (0.30, -0.20, -0.40)  # helmet relative to the arm IMU, jumper frame [m]
    head_bob: float = 0.03  # the head's own motion [m]
    latency: float = 0.08  # the fix stamped t describes t - latency [s] (rounded to the 1 ms grid)
    off_grid: bool = True  # GNSS epochs on whole tenths of GNSS time, IMU samples at a random phase
    gm_h: tuple[float, float] = (1.0, 60.0)  # horizontal Gauss-Markov drift: sigma [m], tau [s]
    gm_v: tuple[float, float] = (2.0, 60.0)  # vertical
    white_h: float = 0.3  # [m]
    white_v: float = 0.6  # [m]
    multipath_rate: float = 1 / 40.0  # episodes per second [1/s]
    multipath_amp: tuple[float, float] = (1.5, 4.0)  # [m]
    multipath_dur: tuple[float, float] = (2.0, 6.0)  # [s]
    outlier_prob: float = 0.01  # share of wild fixes [1]
    outlier_amp: tuple[float, float] = (8.0, 25.0)  # [m]
    vel_white: tuple[float, float, float] = (0.05, 0.05, 0.10)  # Doppler velocity NED [m/s]
    vel_multipath: float = 0.2  # velocity error per unit episode weight [m/s]
    sigma_report: tuple[float, float] = (2.5, 4.0)  # what the receiver writes as gnss_sigma_h / _v [m]

    def describe(self) -> dict[str, Any]:
        """The settings as plain JSON values (for the truth's metadata)."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


#: Model-mismatch variants of the nominal :class:`Realism` (name -> changed fields), each one effect made
#: strong.  ``bench/bench_skijump_independent.py`` tunes on :data:`TUNING` and scores on :data:`HELD_OUT`.
VARIANTS: dict[str, dict[str, Any]] = {
    "nominal": {},
    "multipath": {"multipath_rate": 1 / 8.0, "multipath_amp": (3.0, 8.0), "outlier_prob": 0.05},
    "latency": {"latency": 0.2},
    "synced": {"latency": 0.0},
    "lever": {"antenna": (0.5, -0.35, -0.65)},
    "scale": {"acc_scale": 0.02, "gyr_scale": 0.02},
    "misalign": {"acc_misalign": 2.0, "gyr_misalign": 2.0},
    "temperature": {"temp_change": -15.0, "temp_tau": 60.0, "acc_tempco": 1.5e-3 * G, "gyr_tempco": 0.06 * DEG},
    "vibration": {"chatter_inrun": 10.0, "chatter_outrun": 15.0, "chatter_gyr": 0.4, "body_damping": (0.05, 0.12)},
    "magtable": {"table_field": 60.0, "table_dipoles": 6, "table_span": 25.0},
    "height": {"gm_v": (4.0, 30.0), "gm_h": (2.0, 60.0)},
    "boxcar": {"antialias": "boxcar"},
}
TUNING = ("nominal", "multipath", "latency", "synced", "scale", "vibration")
HELD_OUT = ("lever", "misalign", "temperature", "magtable", "height", "boxcar")


def realism(variants: str | list[str] | tuple[str, ...] = ()) -> Realism:
    """The nominal :class:`Realism` with the named :data:`VARIANTS` applied (ValueError for an unknown name)."""
    names = [variants] if isinstance(variants, str) else list(variants)
    out = Realism()
    for name in names:
        if name not in VARIANTS:
            raise ValueError(f"unknown variant {name!r}; expected one of {', '.join(VARIANTS)}")
        out = replace(out, **VARIANTS[name])
    return out


def stream(seed: int, name: str) -> np.random.Generator:
    """The random stream of one effect (module text)."""
    return np.random.default_rng([int(seed), STREAM[name]])


# ----------------------------------------------------------------------------- vibration
def _phase_envelope(times: dict[str, float], inrun: float, flight: float, outrun: float) -> Envelope:
    """Vibration level through the jump: 0 at the gate, ``inrun`` on the track, ``flight`` in the air,
    ``outrun`` on the snow after the landing, fading to 0 at the stop (smooth steps)."""
    t_rel, t_to, t_td, t_stop = times["release"], times["takeoff"], times["touchdown"], times["stop"]
    env = Envelope().step(t_rel, 1.5, inrun)
    env.step(t_to - 0.02, 0.06, flight - inrun)
    env.step(t_td, 0.05, outrun - flight)
    env.step(max(t_stop - 2.0, t_td + 0.5), 1.5, -outrun)
    return env


def translational_vibration(
    t: np.ndarray, a: np.ndarray, times: dict[str, float], r: Realism, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Chatter, flutter and the landing's ringing as hill-frame displacement, velocity, acceleration (n, 3).

    Chatter is mostly normal to the snow (vertical here: weights x 0.4, y 0.6, z 1.0 of the level).  The
    ringing is the body's response (:func:`sportfusion.sim.vibration.body_response`) to the landing's
    acceleration change ``a(t) - a(t_TD)`` (``a`` the truth's hill-frame acceleration [m/s^2]) over the
    first 0.3 s after the touch-down, fading out over the next 0.3 s.
    """
    d, v, acc = (np.zeros((t.size, 3)) for _ in range(3))
    env = _phase_envelope(times, r.chatter_inrun, r.flutter, r.chatter_outrun)
    for j, wgt in enumerate((0.4, 0.6, 1.0)):
        dj, vj, aj = band_noise(t, rng, (15.0, 80.0), wgt, env)
        d[:, j], v[:, j], acc[:, j] = dj, vj, aj
    f = float(rng.uniform(*r.body_freq))
    zeta = float(rng.uniform(*r.body_damping))
    t_td = times["touchdown"]
    k = int(np.searchsorted(t, t_td))
    win = 1.0 - Envelope().step(t_td + 0.3, 0.3, 1.0)(t)[0]
    exc = np.where((t >= t_td)[:, None], (a - a[min(k, t.size - 1)]) * win[:, None], 0.0)
    dr, vr, ar = body_response(t, exc, f, zeta)
    return d + dr, v + vr, acc + ar


def angular_vibration(arm: Any, times: dict[str, float], r: Realism, rng: np.random.Generator) -> None:
    """Add the arm's angular chatter (10-40 Hz; rate RMS ``chatter_gyr`` on the snow of the out-run, 60 % of it
    on the in-run track, 5 % in flight) and the landing's angular ringing to the arm's Euler-angle signals
    (``ArmMotion``; exact rates via :class:`Signal`)."""
    t_rel, t_to, t_td, t_stop = times["release"], times["takeoff"], times["touchdown"], times["stop"]
    tones = 8
    levels = (0.6, 0.05, 1.0)  # in-run, flight, out-run (shares of chatter_gyr)
    for sig in (arm.roll, arm.pitch, arm.yaw):
        for _ in range(tones):
            f = float(rng.uniform(10.0, 40.0))
            amp = r.chatter_gyr * math.sqrt(2.0 / (3 * tones)) / (2 * math.pi * f)  # angle amplitude [rad]
            env = Signal().step(t_rel, 1.5, amp * levels[0])
            env.step(t_to - 0.02, 0.06, amp * (levels[1] - levels[0]))
            env.step(t_td, 0.05, amp * (levels[2] - levels[1]))
            env.step(max(t_stop - 2.0, t_td + 0.5), 1.5, -amp * levels[2])
            sig.wave(f, float(rng.uniform(0, 2 * math.pi)), env)
        f = float(rng.uniform(8.0, 20.0))
        amp = r.ringing_gyr * float(rng.uniform(0.3, 1.0)) / (2 * math.pi * f)
        env = Signal().step(t_td, 0.015, amp).step(t_td + 0.015, 0.2, -amp)
        sig.wave(f, float(rng.uniform(0, 2 * math.pi)), env)


# ----------------------------------------------------------------------------- IMU
def imu_errors(rng: np.random.Generator, r: Realism) -> tuple[TriadErrors, TriadErrors]:
    """Accelerometer and gyroscope errors drawn from the :class:`Realism` sigmas."""
    acc = TriadErrors(
        bias=rng.normal(0.0, r.acc_bias, 3),
        scale=rng.normal(0.0, r.acc_scale, 3),
        misalign=misalignment(rng, r.acc_misalign * DEG),
        temp_coeff=rng.normal(0.0, r.acc_tempco, 3),
        noise_density=r.acc_noise_density,
        lsb=r.acc_lsb,
        full_scale=r.acc_range,
    )
    gyr = TriadErrors(
        bias=rng.normal(0.0, r.gyr_bias, 3),
        scale=rng.normal(0.0, r.gyr_scale, 3),
        misalign=misalignment(rng, r.gyr_misalign * DEG),
        temp_coeff=rng.normal(0.0, r.gyr_tempco, 3),
        noise_density=r.gyr_noise_density,
        lsb=r.gyr_lsb,
        full_scale=r.gyr_range,
        cross=rng.normal(0.0, r.gyr_gsens, (3, 3)),
    )
    return acc, gyr


def temperature(t: np.ndarray, r: Realism, rng: np.random.Generator) -> np.ndarray:
    """Phone temperature relative to its start [K]: ``dT (1 - exp(-t / tau))``, ``dT`` drawn within +-50 %."""
    dt = r.temp_change * float(rng.uniform(0.5, 1.5))
    return dt * (1.0 - np.exp(-np.asarray(t, dtype=float) / r.temp_tau))


# ----------------------------------------------------------------------------- magnetometer
def table_dipoles(rng: np.random.Generator, r: Realism, z_inrun: Any) -> list[tuple[np.ndarray, np.ndarray]]:
    """Steel under the take-off table: ``table_dipoles`` dipoles (hill-frame position [m], moment [A m^2])
    1-2.5 m under the in-run's last ``table_span`` metres, random directions, each giving
    ``table_field`` [uT] (+-50 %) on its axis at 1.5 m."""
    out = []
    for _ in range(r.table_dipoles):
        x = -float(rng.uniform(0.5, r.table_span))
        pos = np.array([x, float(rng.uniform(-2.5, 2.5)), float(z_inrun(x)) + float(rng.uniform(1.0, 2.5))])
        b = r.table_field * float(rng.uniform(0.5, 1.5)) * 1e-6
        m = b * 1.5**3 / (2 * 1e-7)  # on-axis field 2 (mu0 / 4 pi) m / r^3
        d = rng.normal(size=3)
        out.append((pos, m * d / np.linalg.norm(d)))
    return out


def dipole_sum(points: np.ndarray, dipoles: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """Field [uT] (n, 3) of point dipoles at ``points`` (n, 3) [m], in the frame of the positions:
    ``B = (mu0 / 4 pi) (3 (m . u) u - m) / |r|^3``."""
    out = np.zeros_like(points, dtype=float)
    for pos, m in dipoles:
        d = points - pos
        dist = np.maximum(np.linalg.norm(d, axis=1), 0.3)  # no closer than 0.3 m (the table's surface)
        u = d / dist[:, None]
        out += 1e-7 * (3 * (u @ m)[:, None] * u - m) / dist[:, None] ** 3 * 1e6
    return out


# ----------------------------------------------------------------------------- GNSS
def antenna_state(
    t: np.ndarray,
    r_imu: np.ndarray,
    v_imu: np.ndarray,
    m_jo: np.ndarray,
    w_jo: np.ndarray,
    az: float,
    r: Realism,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """Helmet antenna position (hill frame) [m] and velocity (NED) [m/s] on the fine grid.

    ``r_ant = r_imu + M_OJ l_J(t)`` with ``l_J`` the nominal :attr:`Realism.antenna` plus the head's own
    slow motion (``head_bob``, 0.3-1.2 Hz); ``v_ant = v_imu + M_OJ (omega_J x l_J + l_J')``.
    """
    l0 = np.asarray(r.antenna, dtype=float)
    bob = [
        Signal().wave(float(rng.uniform(0.3, 1.2)), float(rng.uniform(0, 6.3)), Signal(base=r.head_bob))
        for _ in range(3)
    ]
    lj = l0 + np.stack([b.value(t) for b in bob], -1)
    lj_rate = np.stack([b.rate(t) for b in bob], -1)
    m_oj = np.transpose(m_jo, (0, 2, 1))
    arm_ned = np.einsum("nij,nj->ni", m_oj, lj)
    rate_ned = np.einsum("nij,nj->ni", m_oj, np.cross(w_jo, lj) + lj_rate)
    r_ant = r_imu + rotations.ned_to_local(arm_ned, az)
    v_ant = rotations.local_to_ned(v_imu, az) + rate_ned
    return r_ant, v_ant


def gnss_errors(t: np.ndarray, r: Realism, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Position errors (hill-frame axes, n x 3) [m] and velocity errors (NED, n x 3) [m/s] of the fixes at ``t``.

    Components (returned separately too): Gauss-Markov drift, white noise, multipath episodes, wild fixes.
    """
    n = t.size
    drift = np.stack([gauss_markov(rng, t, *r.gm_h), gauss_markov(rng, t, *r.gm_h), gauss_markov(rng, t, *r.gm_v)], -1)
    white = rng.normal(size=(n, 3)) * np.array([r.white_h, r.white_h, r.white_v])
    mp, weight = multipath(rng, t, r.multipath_rate, r.multipath_dur, r.multipath_amp)
    wild = outliers(rng, n, r.outlier_prob, r.outlier_amp)
    vel = rng.normal(size=(n, 3)) * np.asarray(r.vel_white) + r.vel_multipath * weight[:, None] * rng.normal(
        size=(n, 3)
    )
    return {"pos": drift + white + mp + wild, "vel": vel, "drift": drift, "multipath": mp, "outliers": wild}


def realism_fields() -> tuple[str, ...]:
    """Names of the :class:`Realism` settings."""
    return tuple(f.name for f in fields(Realism))
