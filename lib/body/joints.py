"""Joint centres from two IMUs on the segments a joint links, and the pelvis sensor's lever arm to the LJC.

Seel, Schauer and Raisch (2012), *Joint axis and position estimation from inertial measurement data by
exploiting kinematic constraints*, IEEE Multi-Conference on Systems and Control, pp. 45-49 (also Seel, Raisch
and Schauer 2014, Sensors 14:6891, eq 9): the joint centre moves with both segments, so its acceleration seen
from either sensor has the same norm.  With ``o1``, ``o2`` the joint centre in each sensor's frame [m], ``f``
the specific force [m/s^2], ``w`` the angular rate [rad/s] and ``dw`` its derivative [rad/s^2]::

    e_k = || f1 + K(w1, dw1) o1 || - || f2 + K(w2, dw2) o2 ||,    K(w, dw) o = w x (w x o) + dw x o

and ``(o1, o2)`` minimises ``sum e_k^2`` (Gauss-Newton).  It needs no orientation (no drift enters it) and
holds for a ball joint: the hip, between the pelvis (sacrum) sensor and a thigh sensor.

The gates paper takes the sacrum sensor to be at the lumbar joint centre (``p_sacr = p_ljc``); a sensor
taped on the sacrum sits about 0.1 m behind it, which moves the CoM by as much.  :func:`pelvis_lever`
estimates the hip joint centres in the pelvis sensor's frame (both thighs), and puts the LJC at their
midpoint plus the body model's offset from the hips to the LJC (:mod:`sportfusion.body.anthropometry`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _k(w: np.ndarray, dw: np.ndarray) -> np.ndarray:
    """``K`` (n, 3, 3) with ``K o = w x (w x o) + dw x o``."""
    n = w.shape[0]
    wx = np.zeros((n, 3, 3))
    wx[:, 0, 1], wx[:, 0, 2], wx[:, 1, 2] = -w[:, 2], w[:, 1], -w[:, 0]
    wx[:, 1, 0], wx[:, 2, 0], wx[:, 2, 1] = w[:, 2], -w[:, 1], w[:, 0]
    dx = np.zeros((n, 3, 3))
    dx[:, 0, 1], dx[:, 0, 2], dx[:, 1, 2] = -dw[:, 2], dw[:, 1], -dw[:, 0]
    dx[:, 1, 0], dx[:, 2, 0], dx[:, 2, 1] = dw[:, 2], -dw[:, 1], dw[:, 0]
    return wx @ wx + dx


@dataclass
class JointFit:
    """Result of :func:`joint_centre`: the joint centre in each sensor's frame [m], the RMS of the
    residual norms [m/s^2] and the number of samples used."""

    o1: np.ndarray
    o2: np.ndarray
    rms: float
    samples: int


def _huber_step(jac: np.ndarray, e: np.ndarray) -> np.ndarray:
    """One Gauss-Newton step with Huber weights (scale from the median absolute deviation of ``e``)."""
    c = 1.345 * max(1.4826 * float(np.median(np.abs(e - np.median(e)))), 1e-3)
    sw = np.sqrt(np.minimum(1.0, c / np.maximum(np.abs(e), 1e-12)))
    step, *_ = np.linalg.lstsq(jac * sw[:, None], -e * sw, rcond=None)
    return step


def _norm_and_grad(f: np.ndarray, k: np.ndarray, o: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``|f + K o|`` (n,) and its gradient with respect to ``o`` (n, 3)."""
    g = f + np.einsum("nij,j->ni", k, o)
    n = np.maximum(np.linalg.norm(g, axis=1), 1e-6)
    return n, np.einsum("ni,nij->nj", g / n[:, None], k)


def joint_centre(
    w1: np.ndarray,
    dw1: np.ndarray,
    f1: np.ndarray,
    w2: np.ndarray,
    dw2: np.ndarray,
    f2: np.ndarray,
    o1: np.ndarray,
    o2: np.ndarray,
    iterations: int = 30,
) -> JointFit:
    """Seel's joint centre (module text) by Gauss-Newton from ``o1``, ``o2`` [m], the residuals weighted by
    Huber's function (scale from their median absolute deviation): a few samples of an angular
    acceleration differentiated across a sharp change of rate do not drag the fit.

    Parameters
    ----------
    w1, dw1, f1, w2, dw2, f2 : ndarray, shape (n, 3)
        Angular rate [rad/s], angular acceleration [rad/s^2] and specific force [m/s^2] of each sensor, in
        its own frame, at the same instants.
    o1, o2 : ndarray, shape (3,)
        Starting guesses of the joint centre in each sensor's frame [m].
    """
    k1, k2 = _k(w1, dw1), _k(w2, dw2)
    x = np.concatenate([o1, o2]).astype(float)
    for _ in range(iterations):
        n1, j1 = _norm_and_grad(f1, k1, x[:3])
        n2, j2 = _norm_and_grad(f2, k2, x[3:])
        step = _huber_step(np.hstack([j1, -j2]), n1 - n2)
        x += step
        if np.linalg.norm(step) < 1e-6:
            break
    e = _norm_and_grad(f1, k1, x[:3])[0] - _norm_and_grad(f2, k2, x[3:])[0]
    return JointFit(x[:3].copy(), x[3:].copy(), float(np.sqrt(np.mean(e * e))), int(e.size))


def _smooth_rates(t: np.ndarray, x: np.ndarray, fc: float) -> np.ndarray:
    from scipy.signal import butter, filtfilt

    fs = 1.0 / float(np.median(np.diff(t)))
    if fc >= 0.45 * fs or x.shape[0] < 30:
        return x
    b, a = butter(2, fc / (fs / 2))
    return filtfilt(b, a, x, axis=0)


@dataclass
class PelvisLever:
    """The pelvis sensor's lever arm: the LJC in the pelvis segment's frame relative to the sensor [m]
    (``lever``; zeros when not estimated), the hip joint centres in the sensor's frame [m], the fit's
    residual RMS [m/s^2] and why it was not used (``note``)."""

    lever: np.ndarray
    hips: dict[str, np.ndarray]
    rms: float
    note: str


def pelvis_lever(
    t: np.ndarray,
    acc: dict[str, np.ndarray],
    gyr: dict[str, np.ndarray],
    alignment: dict[str, np.ndarray],
    hip_offset: dict[str, np.ndarray],
    thigh_length: float,
    cutoff: float = 8.0,
    step: int = 2,
    iterations: int = 30,
) -> PelvisLever:
    """The LJC relative to the pelvis sensor from the hips (module text).

    Parameters
    ----------
    t : ndarray (n,)
        Sample times [s].
    acc, gyr : dict
        Segment -> specific force [m/s^2] and angular rate [rad/s] in the sensor frame (n, 3); ``pelvis``,
        ``femur_r``, ``femur_l`` are used, low-pass filtered at ``cutoff`` [Hz] and taken every ``step``-th
        sample.
    alignment : dict
        Segment -> A (3, 3), ``v_sensor = A v_segment`` (:func:`sportfusion.body.calibration.calibrate`).
    hip_offset : dict
        ``"r"``/``"l"`` -> the hip joint centre relative to the LJC in the pelvis segment frame [m].
    thigh_length : float
        Hip to knee [m] (the thigh sensor's starting guess: halfway down the thigh).

    Both hips are fitted at once, symmetric about the pelvis' sagittal plane at the model's distance apart:
    the unknowns are their midpoint relative to the sensor (3) and each hip in its thigh sensor's frame
    (2 x 3).  The estimate is refused (lever zero, ``note`` says why) when the LJC comes out more than 0.3 m
    from the sensor.
    """
    sel = slice(None, None, step)
    rates = {s: _smooth_rates(t, gyr[s], cutoff) for s in ("pelvis", "femur_r", "femur_l")}
    force = {s: _smooth_rates(t, acc[s], cutoff)[sel] for s in rates}
    kk = {s: _k(rates[s][sel], np.gradient(rates[s], t, axis=0)[sel]) for s in rates}
    a_p = alignment["pelvis"]
    mid_seg = 0.5 * (hip_offset["r"] + hip_offset["l"])  # the hips' midpoint relative to the LJC, segment frame
    half = {side: hip_offset[side] - mid_seg for side in ("r", "l")}  # the model's half hip width
    # unknowns: the hips' midpoint in the pelvis segment frame relative to the sensor, each thigh sensor's hip
    x = np.concatenate(
        [mid_seg + np.array([0.10, 0.0, 0.0])]  # a sacrum sensor ~0.1 m behind the LJC
        + [alignment[f"femur_{side}"] @ np.array([0.0, 0.0, -0.5 * thigh_length]) for side in ("r", "l")]
    )
    for _ in range(iterations):
        rows, res = [], []
        for i, side in enumerate(("r", "l")):
            thigh = f"femur_{side}"
            n1, j1 = _norm_and_grad(force["pelvis"], kk["pelvis"], a_p @ (x[:3] + half[side]))
            n2, j2 = _norm_and_grad(force[thigh], kk[thigh], x[3 + 3 * i : 6 + 3 * i])
            jac = np.zeros((n1.size, 9))
            jac[:, :3] = j1 @ a_p
            jac[:, 3 + 3 * i : 6 + 3 * i] = -j2
            rows.append(jac)
            res.append(n1 - n2)
        dx = _huber_step(np.vstack(rows), np.concatenate(res))
        x += dx
        if np.linalg.norm(dx) < 1e-6:
            break
    e = np.concatenate(res)
    lever = x[:3] - mid_seg  # sensor -> LJC, segment frame
    hips = {side: a_p @ (x[:3] + half[side]) for side in ("r", "l")}
    rms = float(np.sqrt(np.mean(e * e)))
    note = ""
    if np.linalg.norm(lever) > 0.3:
        note = f"LJC {np.linalg.norm(lever):.2f} m from the sensor"
    if note:
        lever = np.zeros(3)
    return PelvisLever(lever, hips, rms, note)
