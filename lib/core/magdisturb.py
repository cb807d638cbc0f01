"""Magnetic disturbances: magnetometer samples that do not measure the Earth's (reference) field.

Near steel (a lift pylon, a climbing wall's frame, a car), a magnet or an
electric current, the magnetometer adds a local field to the Earth's.  Used as a
heading reference, such samples turn the estimated attitude.  Two checks
against the reference field (the World Magnetic Model of
:mod:`sportfusion.core.magfield`, a hill file's, a hold map's):

* **norm**: ``| |m| / |m_ref| - 1 | > norm_tol`` (0.2): the Earth's field has
  one strength at a place; a disturbance changes it;
* **dip**: where the accelerometer measures gravity alone (quasi-static:
  ``| |a| - g | < static_tol`` and, when given, ``|w| < static_rate``), the angle
  between the field and the vertical must equal the reference's (90 deg minus
  the inclination) within ``dip_tol_deg`` (15 deg: a calibrated consumer
  magnetometer keeps its dip within about 12 deg during motion).

Runs of fewer than ``min_run`` failing samples are ignored (noise); the
others are widened by ``margin`` seconds on both sides (a disturbance
fades in and out).  Estimators skip them or down-weight the magnetometer there
(policy: ``docs/faults.md``).
"""

from __future__ import annotations

import numpy as np

from sportfusion.core.stats import median


def mag_disturbed(
    t: np.ndarray,
    mag: np.ndarray,
    ref_norm: float | None = None,
    acc: np.ndarray | None = None,
    ref_dip_deg: float | None = None,
    g: float = 9.80665,
    gyr: np.ndarray | None = None,
    norm_tol: float = 0.2,
    dip_tol_deg: float = 15.0,
    static_tol: float = 0.5,
    static_rate: float = 0.5,
    margin: float = 0.25,
    min_run: int = 5,
) -> np.ndarray:
    """(n,) True where the magnetometer is disturbed (see the module text); NaN samples are False.

    Parameters
    ----------
    t : ndarray (n,)
        Sample times [s].
    mag : ndarray (n, 3)
        Magnetometer (any unit, sensor frame).
    ref_norm : float, optional
        Reference field strength (same unit); default the median ``|m|`` of the recording.
    acc : ndarray (n, 3), optional
        Specific force [m/s^2], sensor frame, for the dip check.
    ref_dip_deg : float, optional
        Reference angle between the field and the downward vertical [deg]
        (``90 - inclination``); the dip check runs only when it and ``acc`` are given.
    g : float
        Gravity [m/s^2].
    gyr : ndarray (n, 3), optional
        Angular rate [rad/s]; the dip check needs ``|w| < static_rate`` when given.
    norm_tol, dip_tol_deg, static_tol, static_rate, margin : float
        Tolerances (relative; deg; m/s^2; rad/s) and the widening [s].
    min_run : int
        Fewest consecutive failing samples that count (isolated outliers are noise, not a disturbance).
    """
    m = np.asarray(mag, dtype=float)
    n = np.linalg.norm(m, axis=1)
    ok = np.isfinite(n) & (n > 0)
    bad = np.zeros(m.shape[0], dtype=bool)
    if not ok.any():
        return bad
    ref = float(median(n[ok])) if ref_norm is None else float(ref_norm)
    bad[ok] = np.abs(n[ok] / ref - 1.0) > norm_tol
    if acc is not None and ref_dip_deg is not None:
        a = np.asarray(acc, dtype=float)
        an = np.linalg.norm(a, axis=1)
        static = ok & np.isfinite(an) & (np.abs(an - g) < static_tol)
        if gyr is not None:
            w = np.linalg.norm(np.asarray(gyr, dtype=float), axis=1)
            static &= np.isfinite(w) & (w < static_rate)
        if static.any():
            # specific force at rest points up: the downward vertical is -a/|a|
            cosang = -np.sum(m[static] * a[static], axis=1) / (n[static] * an[static])
            ang = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
            bad[static] |= np.abs(ang - ref_dip_deg) > dip_tol_deg
    if min_run > 1 and bad.any():
        d = np.diff(np.concatenate(([0], bad.astype(np.int8), [0])))
        for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True):
            if b - a < min_run:
                bad[a:b] = False
    if margin > 0 and bad.any():
        tb = np.asarray(t, dtype=float)[bad]
        tt = np.asarray(t, dtype=float)
        j = np.clip(np.searchsorted(tb, tt), 1, tb.size)
        near = (np.abs(tt - tb[j - 1]) <= margin) | (np.abs(tt - tb[np.minimum(j, tb.size - 1)]) <= margin)
        bad = near & ok
    return bad


def dip_angle_deg(field_ned: np.ndarray) -> float:
    """Angle between a reference field (NED or any frame with z down) and the downward vertical [deg]."""
    f = np.asarray(field_ned, dtype=float)
    return float(np.degrees(np.arccos(np.clip(f[2] / np.linalg.norm(f), -1.0, 1.0))))


def describe(n_disturbed: int, t: np.ndarray, mask: np.ndarray) -> str:
    """One line naming the fault, e.g. ``"magnetometer disturbed in 812 sample(s) (12.3-20.1 s): skipped"``."""
    tt = np.asarray(t)[np.asarray(mask, bool)]
    span = f" ({tt.min():.1f}-{tt.max():.1f} s)" if tt.size else ""
    return f"magnetometer disturbed (field norm or dip off the reference) in {n_disturbed} sample(s){span}"
