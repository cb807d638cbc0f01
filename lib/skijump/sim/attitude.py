"""Attitude of an arm-mounted phone during a simulated ski jump, with its exact angular rate.

The sensor attitude is a chain of three rotations (each as z-y-x Euler angles,
``M = R1(roll) R2(pitch) R3(yaw)`` like skijump eqs 54-56)::

    M_BO = M_BA  M_AJ(t)  M_JO(t)

* ``J`` (jumper frame): x along the direction of travel -- yaw = hill azimuth
  plus the heading of travel, pitch = path or flight-path angle, roll 0;
* ``A`` (upper arm): the arm's attitude relative to ``J`` -- smooth posture
  changes (crouch, extension at take-off, forward lean in flight, telemark
  landing, standing up, turning sideways to brake) plus roll/yaw/pitch
  oscillations;
* ``B`` (phone): a fixed mounting rotation on the arm (screen facing out of the
  right upper arm, phone y axis along the arm) with a small random misalignment.

The body rate follows from the Euler rates of each link exactly::

    omega_BO^B = M_BA (omega_AJ^A + M_AJ omega_JO^J),
    omega = [phi' - psi' sin(theta), theta' cos(phi) + psi' sin(phi) cos(theta),
             -theta' sin(phi) + psi' cos(phi) cos(theta)].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sportfusion.core import rotations
from sportfusion.sim.smooth import Signal


def euler_rates_to_body(
    roll: np.ndarray, pitch: np.ndarray, roll_dot: np.ndarray, pitch_dot: np.ndarray, yaw_dot: np.ndarray
) -> np.ndarray:
    """Body angular rate (n, 3) [rad/s] of ``R1(roll) R2(pitch) R3(yaw)`` from the Euler rates [rad/s]."""
    sr, cr = np.sin(roll), np.cos(roll)
    sp, cp = np.sin(pitch), np.cos(pitch)
    return np.stack(
        (
            roll_dot - yaw_dot * sp,
            pitch_dot * cr + yaw_dot * sr * cp,
            -pitch_dot * sr + yaw_dot * cr * cp,
        ),
        axis=-1,
    )


def dcm_euler(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """``R1(roll) R2(pitch) R3(yaw)`` (n, 3, 3)."""
    return rotations.dcm_from_euler(roll, pitch, yaw)


@dataclass
class ArmMotion:
    """Euler angles of the upper arm relative to the jumper frame, as smooth signals [rad]."""

    roll: Signal
    pitch: Signal
    yaw: Signal


def arm_motion(times: dict[str, float], rng: np.random.Generator) -> ArmMotion:
    """A plausible arm attitude history around the jump's key times.

    Parameters
    ----------
    times : dict
        ``release``, ``takeoff``, ``touchdown``, ``stop`` [s].
    rng : numpy.random.Generator
        Source of the posture amplitudes, oscillation frequencies and phases.
    """
    d = np.radians
    t_rel, t_to, t_td, t_stop = times["release"], times["takeoff"], times["touchdown"], times["stop"]

    def u(lo: float, hi: float) -> float:
        return float(rng.uniform(lo, hi))

    pitch = Signal(base=d(u(15, 25)))
    pitch.step(t_rel, 1.0, d(u(-15, -8)))  # into the crouch
    pitch.step(t_to, 0.35, d(u(20, 30)))  # extension, forward lean into flight
    pitch.step(t_to + 0.5, max(t_td - t_to - 0.6, 0.3), d(u(2, 8)))  # slow drift in flight
    pitch.step(t_td + 0.1, 0.5, d(u(-25, -15)))  # telemark landing, after the impact
    pitch.step(t_td + 1.5, 1.5, d(u(-30, -20)))  # standing up in the out-run
    roll = Signal(base=d(u(-3, 3)))
    roll.step(t_td + 0.1, 0.5, d(u(10, 20)))  # arms open for balance
    roll.step(t_td + 2.0, 1.0, -d(u(8, 18)))
    yaw = Signal(base=d(u(-3, 3)))
    yaw.step(t_stop - 2.5, 1.5, d(u(20, 40)) * float(rng.choice([-1.0, 1.0])))  # turning sideways to brake
    # oscillations: amplitude envelopes per phase
    # (amplitudes [deg] at rest, in-run, flight, out-run; kept moderate and below 1.4 Hz:
    # two-axis oscillations make the coning error of an RK4 / linear-input INS grow as A^2 f^3)
    for sig, amps in (
        (roll, (0.5, 1.5, 2.5, 3.0)),
        (yaw, (0.5, 1.0, 2.0, 3.5)),
        (pitch, (0.3, 1.0, 1.5, 2.5)),
    ):
        a0 = d(amps[0] * u(0.5, 1.0))
        env = Signal().step(0.0, 1.0, a0)  # from rest: no angular acceleration at t = 0
        env.step(t_rel, 1.0, d(amps[1] * u(0.5, 1.0)) - a0)
        env.step(t_to, 0.3, d((amps[2] - amps[1]) * u(0.5, 1.0)))
        env.step(t_td + 0.1, 0.5, d((amps[3] - amps[2]) * u(0.5, 1.0)))
        env.step(t_stop, 1.5, -d(amps[3] * 0.8))
        sig.wave(u(0.5, 1.4), u(0, 2 * np.pi), env)
    return ArmMotion(roll, pitch, yaw)


def mounting(rng: np.random.Generator, misalignment_deg: float = 3.0) -> np.ndarray:
    """Phone-on-arm rotation ``M_BA``: screen facing out of the right upper arm, y along the arm.

    Nominal: phone x = arm x, phone y = arm up (-z), phone z = arm right (+y),
    i.e. roll -90 deg; plus a random misalignment (1-sigma per axis, deg).
    """
    e = np.radians(rng.normal(0.0, misalignment_deg, 3))
    return dcm_euler(np.radians(-90.0) + e[0], e[1], e[2])


def attitude(
    t: np.ndarray,
    azimuth_rad: float,
    pitch_j: np.ndarray,
    pitch_j_rate: np.ndarray,
    heading_j: np.ndarray,
    heading_j_rate: np.ndarray,
    arm: ArmMotion,
    m_ba: np.ndarray,
    jumper: bool = False,
) -> tuple[np.ndarray, ...]:
    """Quaternion ``q_BO`` (n, 4) and body rate ``omega_B`` (n, 3) [rad/s] of the phone.

    With ``jumper``, also the jumper frame's ``M_JO`` (n, 3, 3) and its rate ``omega_JO^J`` (n, 3) [rad/s]
    (where a helmet antenna is fixed).

    Parameters
    ----------
    t : ndarray
        Times [s].
    azimuth_rad : float
        Hill azimuth psi_N [rad].
    pitch_j, pitch_j_rate, heading_j, heading_j_rate : ndarray
        Jumper-frame pitch and heading (relative to the hill axis) [rad] and rates [rad/s].
    arm : ArmMotion
    m_ba : ndarray, shape (3, 3)
        Mounting rotation.
    """
    zero = np.zeros_like(t)
    yaw_j = azimuth_rad + heading_j
    m_jo = dcm_euler(zero, pitch_j, yaw_j)
    w_jo = euler_rates_to_body(zero, pitch_j, zero, pitch_j_rate, heading_j_rate)
    ar, ap, ay = arm.roll.value(t), arm.pitch.value(t), arm.yaw.value(t)
    m_aj = dcm_euler(ar, ap, ay)
    w_aj = euler_rates_to_body(ar, ap, arm.roll.rate(t), arm.pitch.rate(t), arm.yaw.rate(t))
    w_ao = w_aj + np.einsum("nij,nj->ni", m_aj, w_jo)
    w_b = w_ao @ m_ba.T
    m_bo = np.einsum("ij,njk,nkl->nil", m_ba, m_aj, m_jo)
    q = rotations.quat_from_dcm(m_bo)
    # a continuous sign (q and -q are the same attitude)
    flip = np.cumsum(np.concatenate(([0], (np.einsum("ni,ni->n", q[1:], q[:-1]) < 0).astype(int)))) % 2 == 1
    q[flip] *= -1
    return (q, w_b, m_jo, w_jo) if jumper else (q, w_b)
