"""Segment orientations by strap-down integration with drift correction (gates paper, "Data processing
overview": Fasel et al. 2017d, 2018).

Global frame J of the body model: x forward and y to the right of the athlete in the calibration's static
upright posture, z down (the gates paper's frame with its Y up renamed), origin at the lumbar joint centre.

1. **Gyroscope bias from the static moments**: the mean angular rate of every still period of at least
   ``min_static`` s (the calibration posture, the start and finish postures, any stop); linear in time
   between their centres, constant before the first and after the last.
2. **Strap-down**: each segment's angular rate ``w_seg = A^T (w_s - b)`` (A the calibration's alignment)
   integrated from the identity at the calibration posture (all segments upright and facing forward there).
3. **Tilt reset at the static moments**: in each later still period the strap-down "down" direction is
   compared with the measured specific force; the rotation (about a horizontal axis) that closes the gap is
   applied, growing linearly in time from the previous still period (the heading is left as it is).
4. **Joint drift correction** (the knee as a hinge): the knee's ab/adduction and axial rotation, the two
   degrees of freedom a hinge does not have, should average zero over a few turns; their slowly varying
   part (a centred moving mean over ``hinge_window`` s) is taken as drift of the shank's orientation relative
   to the thigh and removed from the shank (the joint constraint behind the joint drift correction of Fasel
   et al. 2017d, PLoS One 12:e0181446, applied here to the knees).
"""

from __future__ import annotations

import numpy as np

from sportfusion.body.calibration import quiet_mask, runs
from sportfusion.core.rotations import (
    dcm_from_quat,
    integrate_body_rates,
    interval_mean_rates,
    quat_from_dcm,
    quat_from_rotvec,
    rotvec_from_quat,
)

KNEES = (("femur_r", "tibia_r"), ("femur_l", "tibia_l"))


def static_periods(
    t: np.ndarray, acc: dict[str, np.ndarray], gyr: dict[str, np.ndarray], min_static: float = 1.0
) -> list[tuple[int, int]]:
    """Still periods of every sensor at once (sample ranges, end exclusive), at least ``min_static`` s long."""
    fs = 1.0 / float(np.median(np.diff(t)))
    w = int(round(0.25 * fs))
    out = []
    for a, b in runs(quiet_mask(fs, acc, gyr), int(min_static * fs)):
        if b - a > 2 * w + 2:
            out.append((a + w, b - w))  # the edges of a moving window see the motion late
    return out


def gyro_bias(t: np.ndarray, gyr: np.ndarray, statics: list[tuple[int, int]]) -> np.ndarray:
    """Bias per sample [rad/s] (n, 3): mean rate of each still period, linear between their centres."""
    if not statics:
        return np.zeros_like(gyr)
    tc = np.array([t[a:b].mean() for a, b in statics])
    bc = np.array([gyr[a:b].mean(axis=0) for a, b in statics])
    return np.column_stack([np.interp(t, tc, bc[:, j]) for j in range(3)])


def _rot(q: np.ndarray) -> np.ndarray:
    """Segment -> J rotation matrices from q_BJ (J -> segment)."""
    return np.swapaxes(dcm_from_quat(q), -1, -2)


def tilt_errors(c: np.ndarray, acc_seg: np.ndarray, statics: list[tuple[int, int]]) -> list[np.ndarray]:
    """Per still period, the rotation vector [rad] in J taking the strap-down down direction onto the measured one."""
    out = []
    for a, b in statics:
        f = acc_seg[a:b].mean(axis=0)
        d_meas = np.einsum("nij,j->ni", c[a:b], -f / np.linalg.norm(f)).mean(axis=0)  # measured down, in J
        d_meas /= np.linalg.norm(d_meas)
        ax = np.cross(d_meas, np.array([0.0, 0.0, 1.0]))
        s = np.linalg.norm(ax)
        out.append(np.zeros(3) if s < 1e-12 else ax / s * np.arctan2(s, d_meas[2]))
    return out


def strapdown_segment(
    t: np.ndarray, gyr_seg: np.ndarray, acc_seg: np.ndarray, statics: list[tuple[int, int]], start: int
) -> np.ndarray:
    """Segment -> J rotations (n, 3, 3): strap-down from the identity at sample ``start`` (backwards before it),
    then the tilt reset at each still period after it (steps 2-3 of the module text)."""
    n = t.size
    q = np.empty((n, 4))
    fwd = integrate_body_rates(np.array([1.0, 0.0, 0.0, 0.0]), t[start:], interval_mean_rates(gyr_seg[start:]))
    q[start:] = fwd
    if start > 0:
        # backwards: the rates reversed in time, negated
        tb = -t[: start + 1][::-1]
        wb = -gyr_seg[: start + 1][::-1]
        qb = integrate_body_rates(np.array([1.0, 0.0, 0.0, 0.0]), tb, interval_mean_rates(wb))
        q[: start + 1] = qb[::-1]
    c = _rot(q)
    later = [(a, b) for a, b in statics if a > start]
    if not later:
        return c
    errs = tilt_errors(c, acc_seg, later)
    tk = [t[start]] + [t[a:b].mean() for a, b in later]
    ek = [np.zeros(3)]
    for e in errs:
        ek.append(e)
    # cumulative: each reset is applied on top of the previous ones
    ecum = np.cumsum(np.array(ek), axis=0)
    corr = np.column_stack([np.interp(t, tk, ecum[:, j]) for j in range(3)])
    corr[t < tk[0]] = 0.0
    r = _rot(quat_from_rotvec(corr).reshape(-1, 4))
    return np.einsum("nij,njk->nik", r, c)


def _moving_mean(x: np.ndarray, w: int) -> np.ndarray:
    w = max(1, int(w))
    k = np.ones(w) / w
    pad = np.pad(x, ((w // 2, w - 1 - w // 2), (0, 0)), mode="edge")
    return np.column_stack([np.convolve(pad[:, j], k, mode="valid") for j in range(x.shape[1])])


def hinge_correction(c_thigh: np.ndarray, c_shank: np.ndarray, fs: float, window: float = 4.0) -> np.ndarray:
    """The shank's orientation with the knee's slow ab/adduction and axial rotation removed (step 4).

    Returns the corrected shank -> J rotations (n, 3, 3).
    """
    r = np.einsum("nji,njk->nik", c_thigh, c_shank)  # shank -> thigh
    y = r[:, :, 1]  # the shank's hinge axis in the thigh frame
    # the rotation vector taking the shank's axis onto the thigh's y: about y_s x y_t (in the thigh frame)
    e = np.cross(y, np.array([0.0, 1.0, 0.0]))
    s = np.linalg.norm(e, axis=1, keepdims=True)
    ang = np.arctan2(s[:, 0], y[:, 1])
    e = np.where(s > 1e-12, e / np.maximum(s, 1e-12), 0.0) * ang[:, None]
    slow = _moving_mean(e, int(round(window * fs)))
    slow[:, 1] = 0.0
    fix = _rot(quat_from_rotvec(slow))
    return np.einsum("nij,njk,nkl->nil", c_thigh, fix, r)


def segment_orientations(
    t: np.ndarray,
    acc: dict[str, np.ndarray],
    gyr: dict[str, np.ndarray],
    alignment: dict[str, np.ndarray],
    start: int,
    statics: list[tuple[int, int]],
    hinge_window: float | None = 4.0,
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Segment -> J rotations (n, 3, 3) of every sensed segment (module text), and each sensor's gyro bias
    [rad/s] (n, 3)."""
    fs = 1.0 / float(np.median(np.diff(t)))
    rot: dict[str, np.ndarray] = {}
    bias: dict[str, np.ndarray] = {}
    for seg, a in alignment.items():
        b = gyro_bias(t, gyr[seg], statics)
        bias[seg] = b
        w_seg = (gyr[seg] - b) @ a  # A^T (w - b), row vectors
        f_seg = acc[seg] @ a
        rot[seg] = strapdown_segment(t, w_seg, f_seg, statics, start)
    if hinge_window:
        for thigh, shank in KNEES:
            if thigh in rot and shank in rot:
                rot[shank] = hinge_correction(rot[thigh], rot[shank], fs, hinge_window)
    return rot, bias


def quats_from_rot(c: np.ndarray) -> np.ndarray:
    """q_BJ (J -> segment, scalar first, the suite's convention) from segment -> J rotations."""
    q = quat_from_dcm(np.swapaxes(c, -1, -2))
    return q * np.where(q[:, :1] < 0, -1.0, 1.0)


def rotation_angle(c: np.ndarray) -> np.ndarray:
    """Rotation angle [rad] of each matrix (n, 3, 3)."""
    return np.linalg.norm(rotvec_from_quat(quat_from_dcm(c)), axis=-1)
