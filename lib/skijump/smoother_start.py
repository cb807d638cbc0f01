"""The smoother's initial state (skijump §4.1), and what re-linearises it over the start window.

The second stage of ``rts-smooth`` (:mod:`sportfusion.skijump.smoother`), from a segment's inputs alone:

* :func:`initial_state`: position and NED velocity of the first GNSS fix, the gyro bias the mean rate over the
  rest at the gate (:func:`_initial_rest`), the attitude from the in-run alignment
  (:func:`sportfusion.skijump.alignment.inrun_attitude`) or QUEST over the rest, ``P0`` from Table 3;
* :func:`start_window`: the steps whose runs re-linearise it (the start, up to the in-run's end);
* :func:`_after_rest` moves that state to the rest's end, where the forward run over the start window begins;
  :func:`_forward_start` carries that run's result back to step 0.  The runs themselves are the engine's
  (:mod:`sportfusion.skijump.smoother_passes` calls both).
"""

from __future__ import annotations

import math

import numpy as np

from sportfusion.core import rotations
from sportfusion.estimators.quest import quest
from sportfusion.skijump import model as mdl
from sportfusion.skijump.alignment import body_to_start, inrun_attitude
from sportfusion.skijump.kinematics import m_bo
from sportfusion.skijump.smoother_inputs import SkiJumpInputs, SmootherConfig


def _initial_rest(inp: SkiJumpInputs, cfg: SmootherConfig) -> np.ndarray:
    """Steps of the rest at the start (mask): at least ``init_window`` s, extended while the sensor is still.

    Still: every gyro and accelerometer sample within ``init_rest_gyr`` [rad/s] and
    ``init_rest_acc`` [m/s^2] of the first ``init_window``'s means, for at most
    ``init_rest_max`` seconds.  Averaging the magnetometer and accelerometer over the
    whole rest gives QUEST a better heading than the first samples alone, and the mean
    rate there is the gyro bias: the smoother then starts in its linear regime.
    """
    t, u = inp.t, inp.u
    first = t <= t[0] + cfg.init_window
    if cfg.init_rest_max <= cfg.init_window:
        return first
    g0, a0 = u[first, 0:3].mean(axis=0), u[first, 3:6].mean(axis=0)
    cand = np.flatnonzero(t <= t[0] + cfg.init_rest_max)
    moving = (np.linalg.norm(u[cand, 0:3] - g0, axis=1) > cfg.init_rest_gyr) | (
        np.linalg.norm(u[cand, 3:6] - a0, axis=1) > cfg.init_rest_acc
    )
    end = int(np.argmax(moving)) if moving.any() else cand.size
    rest = np.zeros(t.size, dtype=bool)
    rest[: max(end, int(first.sum()))] = True
    return rest


def initial_state(
    inp: SkiJumpInputs, cfg: SmootherConfig, with_source: bool = False
) -> tuple[np.ndarray, np.ndarray] | tuple[np.ndarray, np.ndarray, bool, int]:
    """Paper §4.1: first GNSS fix, QUEST attitude from the rest at the start, gyro bias its mean rate; Table 3 P0.

    ``with_source``: also return whether the attitude came from the in-run alignment (True) or the rest, and
    the rest's length [steps] (:func:`_initial_rest`, a run of steps from step 0: where the forward start's
    run begins).
    """
    x0 = np.zeros(mdl.N)
    ip = int(np.flatnonzero(np.isfinite(inp.pos[:, 0]))[0])
    x0[0:3] = inp.pos[ip]
    w = _initial_rest(inp, cfg)
    acc = inp.u[w, 3:6].mean(axis=0)
    if w.sum() > np.count_nonzero(inp.t <= inp.t[0] + cfg.init_window):
        # a rest longer than init_window: the mean rate there is the gyro bias (eq 35, Earth rate neglected)
        x0[mdl.I_BG] = inp.u[w, 0:3].mean(axis=0)
    qa = inrun_attitude(inp.t, inp.u, inp.vel, w, inp.inrun, inp.g0, x0[mdl.I_BG]) if cfg.inrun_align else None
    mags = inp.mag[w & np.isfinite(inp.mag[:, 0])]
    if mags.shape[0] == 0 and np.isfinite(inp.mag[:, 0]).any():
        mags = inp.mag[np.isfinite(inp.mag[:, 0])][:1]
    if qa is not None:  # the in-run alignment: the rest's attitude is not needed
        q = qa
    elif mags.shape[0]:
        body = np.stack([acc, mags.mean(axis=0)])[None]
        ref = np.stack([np.array([0.0, 0.0, -1.0]), inp.m_o])
        q, _ = quest(body, ref, np.array([0.9, 0.1]))
        q = q[0]
    else:  # no magnetometer: level the attitude, heading along the hill axis
        gx, gy, gz = -acc / np.linalg.norm(acc)
        roll, pitch = math.atan2(gy, gz), math.atan2(-gx, math.hypot(gy, gz))
        q = rotations.quat_from_euler(np.array(roll), np.array(pitch), np.array(math.radians(inp.azimuth_deg)))
    x0[6:10] = q
    _start_velocity(inp, x0)
    p = np.concatenate(
        [
            cfg.p0_pos,
            cfg.p0_vel,
            [cfg.p0_quat] * 4,
            [cfg.p0_bias_gyr] * 3,
            [cfg.p0_bias_acc] * 3,
            [cfg.p0_bias_mag] * 3,
            [cfg.p0_scale_mag] * 3,
        ]
    )
    P0 = np.diag(np.asarray(p, float) ** 2)
    return (x0, P0, qa is not None, int(w.sum())) if with_source else (x0, P0)


def start_window(seg: SkiJumpInputs, cfg: SmootherConfig) -> int:
    """Steps [0, nw) of the start window that needs re-linearising: the start up to the in-run's end (the first
    take-off in the segment plus ``cfg.pass_after_takeoff`` [s]), at least ``cfg.pass_window`` [s] and 2 steps,
    at most the segment."""
    t_end = seg.t[0] + cfg.pass_window
    tos = [a for a, _ in seg.jumps if seg.t[0] <= a <= seg.t[-1]]
    if tos:
        t_end = max(t_end, min(tos) + cfg.pass_after_takeoff)
    nw = int(np.searchsorted(seg.t, t_end, side="right"))
    return max(min(nw, seg.t.size), 2)


def _start_velocity(inp: SkiJumpInputs, x0: np.ndarray) -> None:
    """``x0``'s body-frame velocity: the first GNSS velocity rotated by ``x0``'s attitude (in place)."""
    iv = np.flatnonzero(np.isfinite(inp.vel[:, 0]))
    if iv.size:
        x0[3:6] = m_bo(x0[6:10]) @ inp.vel[iv[0]]


def _forward_start(seg: SkiJumpInputs, x_end: np.ndarray, k: int, x0: np.ndarray) -> np.ndarray:
    """The initial state re-linearised from a forward (EKF) run over the start window ending at step ``k``.

    The parameters (biases, magnetometer scale) have no process noise (eq 22): their smoothed value at step 0
    is the filtered one at the window's end (``x_end``, 22).  The attitude at step 0 is the filtered attitude
    there carried back by the gyro (bias-corrected by that estimate, :func:`body_to_start`): once the in-run
    has pinned the heading, this is what the smoothed pass over the window returns, at the cost of the
    forward run alone.  Position stays the first fix; the velocity is re-rotated.
    """
    x = x0.copy()
    x[10:] = x_end[10:]
    x[6:10] = _gyro_carried(seg, x_end[6:10], x_end[mdl.I_BG], k, back=True)
    _start_velocity(seg, x)
    return x


def _after_rest(seg: SkiJumpInputs, x0: np.ndarray, r: int) -> np.ndarray:
    """``x0`` (step 0) at step ``r`` of the rest at the gate: the attitude turned by the bias-corrected gyro."""
    x = x0.copy()
    x[6:10] = _gyro_carried(seg, x0[6:10], x0[mdl.I_BG], r, back=False)
    return x


def _gyro_carried(seg: SkiJumpInputs, q: np.ndarray, bias: np.ndarray, k: int, back: bool) -> np.ndarray:
    """Attitude ``q`` (q_BO) at step ``k`` carried to step 0 (``back``), or at step 0 carried to step ``k``, by
    the gyro less ``bias`` [rad/s] (:func:`body_to_start`); scalar part >= 0."""
    c = body_to_start(seg.t[: k + 1], seg.u[: k + 1, 0:3], bias, last_only=True)[-1]  # body k -> body 0
    m = m_bo(q / np.linalg.norm(q))
    out = rotations.quat_from_dcm(c @ m if back else c.T @ m)
    return out if out[0] >= 0 else -out
