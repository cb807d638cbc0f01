"""Functional calibration: each sensor's rotation onto its segment's anatomical frame (sensor-to-segment).

The protocol (gates paper "Experimental setup", after Fasel et al. 2017d, PLoS One 12:e0181446): the athlete
stands **upright and still** for at least 1 s (the segments' long axes vertical, all facing forward), then
does **a few squats** (knees and hips flex, the trunk leans forward), before the run.

* vertical axis (z, down the segment): the mean specific force in the static upright posture, ``z = -f/|f|``;
* medio-lateral axis (y, to the athlete's right): the principal axis of the angular rate during the squats,
  made orthogonal to z; its sign from the tilt the squat gives each segment: the thighs' distal ends go
  forward, the shanks', the pelvis', the torso's and the head's upper ends go forward -- the down direction
  seen by the sensor at the deepest point leans backward for a thigh and forward for the others;
* anterior axis: ``x = y cross z``.

The calibration window (static upright + squats) is found automatically: the first still period of at least
``min_static`` seconds within the first ``search`` seconds, then the movement until the next still period
(at most ``max_squats`` seconds); or it is given (``window``: t0, t1 containing both).  A segment whose squat
tilt is below ``min_tilt`` has no usable axis: calibration then fails with one line naming it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sportfusion.core.errors import InputError

#: Segments whose distal end goes forward in a squat (the down direction leans backward in their frame).
DISTAL_FORWARD = ("femur_r", "femur_l")


@dataclass
class Calibration:
    """Result of :func:`calibrate`.

    Attributes
    ----------
    static : tuple of int
        Sample range (end exclusive) of the static upright posture.
    squats : tuple of int
        Sample range of the squats.
    alignment : dict
        Segment -> A (3, 3): columns are the segment's x, y, z axes in the sensor frame (``v_s = A v_seg``).
    tilt_deg : dict
        Segment -> largest tilt during the squats [deg].
    """

    static: tuple[int, int]
    squats: tuple[int, int]
    alignment: dict[str, np.ndarray]
    tilt_deg: dict[str, float]


def moving_std(x: np.ndarray, w: int) -> np.ndarray:
    """Centred moving standard deviation of ``x`` over ``w`` samples (edges: the nearest full window)."""
    w = max(3, int(w))
    k = np.ones(w) / w
    c1 = np.convolve(x, k, mode="same")
    c2 = np.convolve(x * x, k, mode="same")
    s = np.sqrt(np.maximum(c2 - c1 * c1, 0.0))
    h = w // 2
    if s.size > 2 * h + 1:
        s[:h] = s[h]
        s[-h:] = s[-h - 1]
    return s


def quiet_mask(
    fs: float, acc: dict[str, np.ndarray], gyr: dict[str, np.ndarray], acc_std: float = 0.5, gyr_std: float = 0.12
) -> np.ndarray:
    """Samples where every sensor is still: moving std (0.5 s) of |acc| [m/s^2] and |gyr| [rad/s] below limits,
    and |gyr| itself below 0.3 rad/s."""
    w = int(round(0.5 * fs))
    q = None
    for seg in acc:
        m = (moving_std(np.linalg.norm(acc[seg], axis=1), w) < acc_std) & (
            moving_std(np.linalg.norm(gyr[seg], axis=1), w) < gyr_std
        )
        m &= np.convolve(np.linalg.norm(gyr[seg], axis=1), np.ones(w) / w, mode="same") < 0.3
        q = m if q is None else q & m
    assert q is not None
    return q


def runs(mask: np.ndarray, min_len: int) -> list[tuple[int, int]]:
    """Runs of True at least ``min_len`` samples long, as (start, end exclusive)."""
    d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    a, b = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    return [(int(i), int(j)) for i, j in zip(a, b, strict=True) if j - i >= min_len]


def _lowpass(x: np.ndarray, fs: float, fc: float = 2.0) -> np.ndarray:
    from scipy.signal import butter, filtfilt

    if x.shape[0] < 20:
        return x
    b, a = butter(2, min(fc / (fs / 2), 0.9))
    return filtfilt(b, a, x, axis=0)


def calibrate(
    t: np.ndarray,
    acc: dict[str, np.ndarray],
    gyr: dict[str, np.ndarray],
    window: tuple[float, float] | None = None,
    min_static: float = 1.0,
    search: float = 60.0,
    max_squats: float = 20.0,
    min_tilt: float = 5.0,
) -> Calibration:
    """Find the calibration (or take ``window`` [s]) and compute each sensor's alignment (module text).

    Parameters
    ----------
    t : ndarray (n,)
        Sample times [s] shared by all sensors.
    acc, gyr : dict
        Segment -> specific force [m/s^2] and angular rate [rad/s], sensor frame, shape (n, 3).
    window : tuple, optional
        (t0, t1) [s] containing the static upright posture followed by the squats.

    Raises
    ------
    InputError
        No static upright posture, no squats, or a segment the squats did not tilt.
    """
    fs = 1.0 / float(np.median(np.diff(t)))
    quiet = quiet_mask(fs, acc, gyr)
    lo, hi = 0, t.size
    if window is not None:
        lo, hi = int(np.searchsorted(t, window[0])), int(np.searchsorted(t, window[1], side="right"))
        if hi - lo < int(2 * min_static * fs):
            raise InputError(
                f"--calibration {window[0]:g},{window[1]:g}: {max(hi - lo, 0)} samples in the window; expected the "
                "static upright posture and the squats inside it"
            )
    else:
        hi = int(np.searchsorted(t, t[0] + search))
    still = [r for r in runs(quiet[lo:hi], int(min_static * fs))]
    if not still:
        raise InputError(
            f"no calibration posture found: no still period of {min_static:g} s "
            + ("in the --calibration window" if window else f"in the first {search:g} s")
            + " (expected a static upright posture, then a few squats; give --calibration T0,T1)"
        )
    s0, s1 = (lo + still[0][0], lo + still[0][1])
    # squats: from the end of the static posture to the next still period (or the window's end)
    end = hi if window is not None else min(t.size, int(np.searchsorted(t, t[s1 - 1] + max_squats)))
    nxt = [r for r in runs(quiet[s1:end], int(0.5 * fs))]
    q0, q1 = s1, (s1 + nxt[0][0] if nxt else end)
    if q1 - q0 < int(1.0 * fs):
        raise InputError(
            f"no calibration posture found: {(q1 - q0) / fs:.1f} s of movement after the static posture at "
            f"t = {t[s0]:.1f}-{t[s1 - 1]:.1f} s (expected a few squats; give --calibration T0,T1)"
        )
    align: dict[str, np.ndarray] = {}
    tilts: dict[str, float] = {}
    for seg in acc:
        f0 = acc[seg][s0:s1].mean(axis=0)
        z = -f0 / np.linalg.norm(f0)
        down = -_lowpass(acc[seg][q0:q1], fs)
        down /= np.maximum(np.linalg.norm(down, axis=1, keepdims=True), 1e-9)
        ang = np.arccos(np.clip(down @ z, -1.0, 1.0))
        k = int(np.argmax(ang))
        tilts[seg] = float(np.degrees(ang[k]))
        if tilts[seg] < min_tilt:
            raise InputError(
                f"no calibration posture found for {seg}: the squats tilt it by {tilts[seg]:.1f} deg only (expected "
                f"at least {min_tilt:g} deg: knees and hips flexed, trunk leaning forward; give --calibration T0,T1)"
            )
        # the tilt's axis: y from z x d_b (sign: see the module text)
        ax = np.cross(z, down[k])
        ax /= np.linalg.norm(ax)
        y_grav = -ax if seg in DISTAL_FORWARD else ax
        w = gyr[seg][q0:q1]
        w = w - w.mean(axis=0)
        _, _, vt = np.linalg.svd(w, full_matrices=False)
        e = vt[0] - (vt[0] @ z) * z
        y = y_grav
        if np.linalg.norm(e) > 0.5:
            e /= np.linalg.norm(e)
            e = e if e @ y_grav > 0 else -e
            if e @ y_grav > np.cos(np.radians(30.0)):  # the gyro's axis, sharper than one tilt sample
                y = e
        y = y - (y @ z) * z
        y /= np.linalg.norm(y)
        x = np.cross(y, z)
        align[seg] = np.column_stack([x, y, z])
    return Calibration((s0, s1), (q0, q1), align, tilts)
