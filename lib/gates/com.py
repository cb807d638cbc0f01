"""``gate-anchor`` with a body: the paper's relative anchors from the ski contact points, turn switches from the
ankles and the absolute centre of mass (gates paper, "Body model and relative anchor point estimation",
"Absolute CoM kinematics estimation").

The session carries the columns of ``body-model`` (frame J: x forward, y right of the athlete in the
calibration posture, z down; relative to the lumbar joint centre, LJC): ``ski_r_rel_* ski_l_rel_*``,
``ankle_r_rel_* ankle_l_rel_*``, ``com_rel_*`` and the pelvis segment's ``pelvis__q0..3`` with the pelvis
sensor's alignment and its lever arm to the LJC (``pelvis_lever_m``, pelvis frame) in the metadata.  The
smoother tracks the pelvis sensor (it carries the magnetometer); the LJC is the sensor plus the lever arm
turned by the pelvis' orientation (the paper takes ``p_sacr = p_ljc``: ``body-model --pelvis-lever 0,0,0``).

* Orientation of the pelvis sensor: the body model's (drift-corrected, in J), so the smoother's frame is J.
* Snow plane S_m (eq 6): through the average ski line ``l(t)`` = LJC track + mean of the two ski contact
  points, along its direction over ``t_m +- 0.4 s`` (:func:`snow_planes`: no cross slope); the sacrum's projection onto S_m along its normal (the paper's
  eq 6, ``projection="normal"``) or vertically (``"vertical"``: the |B| peak of a vertical dipole is above
  the magnet); eqs 2-5 as in :func:`sportfusion.gates.anchors.relative_anchors`.
* Turn switches: equal distance from the left and the right ankle to the CoM (Fasel et al. 2016b): the sign
  change of ``|ankle_l - com| - |ankle_r - com|`` between two crossings nearest the middle.
* CoM: the refined track plus the lever arm and the relative CoM (rotated into the survey frame by the
  matching's azimuth), the speed by three-point differentiation, both low-pass filtered (2nd-order Butterworth, 5 Hz,
  zero phase: forward and backward).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from sportfusion.core.errors import InputError

#: 1-sigma of the body model's relative CoM [m] (Fasel et al. 2017: 25.7 +- 6.7 mm against motion capture).
SIGMA_REL_COM = 0.03
#: 1-sigma of the relative CoM's speed [m/s] (our allowance).
SIGMA_REL_VCOM = 0.05
PLANE_HALF_WINDOW = 0.4  # [s], the paper's t_m +- 0.4 s
CUTOFF_HZ = 5.0


@dataclass
class Body:
    """The body columns of a session on the pelvis IMU rows (frame J) relative to the pelvis sensor: the
    body model's points relative to the LJC plus the sensor's lever arm to it [m]."""

    t: np.ndarray
    ski: np.ndarray  # mean of the two contact points (n, 3)
    ankle_r: np.ndarray
    ankle_l: np.ndarray
    com: np.ndarray
    q_sensor: np.ndarray  # pelvis sensor attitude q_BJ (J -> sensor) (n, 4)
    heading: np.ndarray  # the pelvis segment's heading in J, unwrapped [rad]


BODY_COLUMNS = tuple(f"{p}_rel_{a}" for p in ("ski_r", "ski_l", "ankle_r", "ankle_l", "com") for a in "xyz") + tuple(
    f"pelvis__q{i}" for i in range(4)
)


def has_body(names: list[str]) -> bool:
    """Whether a session carries the body-model columns gate-anchor uses."""
    return all(c in names for c in BODY_COLUMNS)


def read_body(table: Any, meta: dict[str, Any], rows: np.ndarray) -> Body:
    """The body columns on ``rows`` (the pelvis IMU rows), and the pelvis sensor's attitude in J."""
    from sportfusion.core import schema
    from sportfusion.core.rotations import dcm_from_quat, quat_from_dcm

    def xyz(p: str) -> np.ndarray:
        return schema.float_columns(table, [f"{p}_rel_{a}" for a in "xyz"])[rows]

    bm = meta.get("body_model") or {}
    a = np.asarray((bm.get("alignment") or {}).get("pelvis", np.eye(3)), float)
    if a.shape != (3, 3):
        raise InputError("body_model metadata: the pelvis alignment is not a 3x3 matrix; rerun body-model")
    q_seg = schema.float_columns(table, [f"pelvis__q{i}" for i in range(4)])[rows]
    ok = np.isfinite(q_seg).all(axis=1)
    if ok.sum() < 100:
        raise InputError(f"{int(ok.sum())} rows with the body model's pelvis orientation; rerun body-model")
    q = np.full((rows.size, 4), np.nan)
    m_seg = dcm_from_quat(q_seg[ok])  # J -> pelvis segment
    q[ok] = quat_from_dcm(np.einsum("ij,njk->nik", a, m_seg))  # J -> sensor = A M_seg
    # the LJC relative to the sensor, in J: the points relative to the LJC become relative to the sensor
    lever_seg = np.asarray(bm.get("pelvis_lever_m") or np.zeros(3), float)
    if lever_seg.shape != (3,) or not np.isfinite(lever_seg).all():
        raise InputError("body_model metadata: pelvis_lever_m is not 3 numbers; rerun body-model")
    lever = np.full((rows.size, 3), np.nan)
    lever[ok] = np.einsum("nji,j->ni", m_seg, lever_seg)  # segment -> J
    ski = 0.5 * (xyz("ski_r") + xyz("ski_l")) + lever
    t = schema.floats(table, "t")[rows]
    heading = np.full(rows.size, np.nan)
    heading[ok] = np.unwrap(np.arctan2(m_seg[:, 0, 1], m_seg[:, 0, 0]))  # the segment's x axis in J
    return Body(t, ski, xyz("ankle_r") + lever, xyz("ankle_l") + lever, xyz("com") + lever, q, heading)


def _interp(t: np.ndarray, x: np.ndarray, tq: np.ndarray) -> np.ndarray:
    ok = np.isfinite(x).all(axis=1)
    return np.stack([np.interp(tq, t[ok], x[ok, j]) for j in range(x.shape[1])], axis=-1)


def snow_planes(
    tg: np.ndarray, track: np.ndarray, body: Body, t_cross: np.ndarray, free: bool = True, max_tilt: float = 15.0
) -> tuple[np.ndarray, np.ndarray]:
    """Per crossing, the unit normal of S_m (out of the snow) and a point of it, in J (eq 6).

    As the paper: the plane fitted (least squares) to the average ski line ``l(t) = track + ski`` over
    ``t_m +- 0.4 s``, its point the line's mean.  The line curves through the turn by a metre or two, which
    tilts the plane to the snow's cross slope; where the fit tilts more than ``max_tilt`` [deg] from the
    plane that holds the line's direction and the horizontal perpendicular to it (no cross slope: an almost
    straight line or a poor track, e.g. before any anchor), that plane is used with ``l(t_m)``
    (``free=False``: always).  Measured on the simulator (3 runs, the first anchors' iteration and on):
    CoM error between the gates 0.13 -> 0.12 m, anchors' lateral bias 0.09 -> 0.01 m.
    """
    normals = np.tile(np.array([0.0, 0.0, -1.0]), (t_cross.size, 1))
    points = np.full((t_cross.size, 3), np.nan)
    up = np.array([0.0, 0.0, -1.0])
    for m, tm in enumerate(t_cross):
        w = (tg >= tm - PLANE_HALF_WINDOW) & (tg <= tm + PLANE_HALF_WINDOW)
        if w.sum() < 5:
            continue
        line = track[w] + _interp(body.t, body.ski, tg[w])
        c = line.mean(axis=0)
        _, _, vt = np.linalg.svd(line - c, full_matrices=False)
        d = vt[0]
        n = up - (up @ d) * d
        n /= np.linalg.norm(n)
        normals[m] = n
        points[m] = _interp(tg, track, np.array([tm]))[0] + _interp(body.t, body.ski, np.array([tm]))[0]
        nf = vt[2] if vt[2][2] < 0 else -vt[2]
        if free and nf @ n > np.cos(np.radians(max_tilt)):
            normals[m], points[m] = nf, c
    return normals, points


def body_anchors(
    pc: np.ndarray,
    vc: np.ndarray,
    distance: np.ndarray,
    side: np.ndarray,
    normals: np.ndarray,
    points: np.ndarray,
    burial: float,
) -> np.ndarray:
    """Magnets (M, 3) [m] from the sacrum at the crossings ``pc`` (velocity ``vc``) with the snow plane
    (unit ``normals`` out of the snow, ``points`` on it), projecting vertically (eqs 2-5 with the |B| peak of
    a vertical dipole above the magnet): the snow point ``h`` below the sacrum, the magnet ``burial`` below the
    snow, and ``x = sqrt(|r|^2 - (h + burial)^2)`` to the turn's inside (``side`` +1 right) along the
    horizontal perpendicular to the velocity, moved along the plane (a cross slope puts a magnet on the
    uphill side higher than the snow under the sacrum)."""
    ez = np.array([0.0, 0.0, 1.0])
    nz = np.minimum(normals[:, 2], -1e-3)
    h = -np.sum((pc - points) * normals, axis=1) / nz  # vertical distance down to the plane
    d = h + burial
    r = np.where(np.isfinite(distance), distance, d)
    x_len = np.sqrt(np.maximum(r**2 - d**2, 0.0))
    u = np.cross(vc, -ez)  # right of the direction of travel, horizontal (z down: v x up)
    u[:, 2] = 0.0
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-9)
    u[:, 2] = -np.sum(normals[:, :2] * u[:, :2], axis=1) / nz  # stay in the plane
    return pc + d[:, None] * ez + (np.asarray(side, float) * x_len)[:, None] * u


def ankle_switch_signal(tg: np.ndarray, body: Body) -> np.ndarray:
    """``|ankle_l - com| - |ankle_r - com|`` [m] on the grid: its sign changes at the turn switches."""
    dl = np.linalg.norm(body.ankle_l - body.com, axis=1)
    dr = np.linalg.norm(body.ankle_r - body.com, axis=1)
    ok = np.isfinite(dl) & np.isfinite(dr)
    return np.interp(tg, body.t[ok], (dl - dr)[ok])


def absolute_com(
    tg: np.ndarray, pos: np.ndarray, alpha: float, body: Body, cutoff: float = CUTOFF_HZ
) -> tuple[np.ndarray, np.ndarray]:
    """Absolute CoM [m] and its velocity [m/s] on the grid ``tg``: the LJC track (survey frame) plus the
    relative CoM rotated by ``alpha`` [rad]; three-point derivative; both Butterworth-filtered (2nd order,
    ``cutoff`` Hz, zero phase)."""
    from scipy.signal import butter, filtfilt

    from sportfusion.gates.anchors import rotate_z

    com = pos + rotate_z(_interp(body.t, body.com, tg), alpha)
    vel = np.gradient(com, tg, axis=0)  # central differences: the three-point derivative
    fs = 1.0 / float(np.median(np.diff(tg)))
    if tg.size > 15 and cutoff < 0.45 * fs:
        b, a = butter(2, cutoff / (fs / 2))
        com = filtfilt(b, a, com, axis=0)
        vel = filtfilt(b, a, vel, axis=0)
    return com, vel


def turn_sides(body: Body, t_cross: np.ndarray, half: float = 0.3) -> np.ndarray:
    """Turn side at each crossing from the pelvis segment's heading in J (+1 right, -1 left): the sign of the
    heading's change over ``t +- half`` s (z down: a right turn increases it).  Unlike the sensor's own z
    rate (the detector's) it does not depend on how the sensor is strapped."""
    ok = np.isfinite(body.heading)
    out = np.zeros(t_cross.size)
    for i, tc in enumerate(t_cross):
        d = np.interp(tc + half, body.t[ok], body.heading[ok]) - np.interp(tc - half, body.t[ok], body.heading[ok])
        out[i] = 1.0 if d > 0 else -1.0
    return out
