"""Batched SO(3) helpers for the climbing estimators (rotation matrices and rotation vectors).

Exp/Log go through unit quaternions (Shepperd's method from the matrix, ``atan2`` for
the angle: robust near 0 and pi; numpy only, no scipy import);
the right Jacobians are the closed forms of Barfoot's *State Estimation for
Robotics* (eqs 7.77 and 7.80), with series expansions for small angles.
Quaternions in this package are scalar first; a "rotation matrix" here is the Hamilton
``R(q)`` (scipy's ``as_matrix``), the transpose of core.rotations' ``M_BO``.
"""

from __future__ import annotations

import numpy as np

from sportfusion.core.rotations import dcm_from_quat, quat_from_dcm, quat_from_rotvec
from sportfusion.core.rotations import skew as hat

_SMALL = 1e-5  # rad: below this the Jacobians use their series expansions


def exp(phi: np.ndarray) -> np.ndarray:
    """Rotation matrices from rotation vectors ``phi`` [rad] (..., 3) -> (..., 3, 3)."""
    phi = np.asarray(phi, dtype=np.float64)
    return matrix_from_quat(quat_from_rotvec(phi))


def log(r: np.ndarray) -> np.ndarray:
    """Rotation vectors [rad] of rotation matrices ``r`` (..., 3, 3) -> (..., 3), angle in [0, pi]."""
    q = quat_from_matrix(r)
    v = q[..., 1:]
    sv = np.linalg.norm(v, axis=-1)
    th = 2.0 * np.arctan2(sv, q[..., 0])
    # th / sin(th/2), with its series for tiny angles (w ~ 1)
    k = np.where(sv < 1e-8, 2.0 / np.maximum(q[..., 0], 1e-300), th / np.where(sv < 1e-8, 1.0, sv))
    return k[..., None] * v


def _coeffs(phi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    th = np.linalg.norm(phi, axis=-1)
    small = th < _SMALL
    ts = np.where(small, 1.0, th)
    return th, small, ts, hat(phi)


def jr(phi: np.ndarray) -> np.ndarray:
    """Right Jacobian of SO(3): ``Exp(phi + d) ~ Exp(phi) Exp(Jr(phi) d)``."""
    th, small, ts, k = _coeffs(np.asarray(phi, dtype=np.float64))
    a = np.where(small, 0.5, (1.0 - np.cos(ts)) / ts**2)
    b = np.where(small, 1.0 / 6.0, (ts - np.sin(ts)) / ts**3)
    return np.eye(3) - a[..., None, None] * k + b[..., None, None] * (k @ k)


def jr_inv(phi: np.ndarray) -> np.ndarray:
    """Inverse right Jacobian: ``Log(Exp(phi) Exp(d)) ~ phi + Jr^-1(phi) d``."""
    th, small, ts, k = _coeffs(np.asarray(phi, dtype=np.float64))
    c = np.where(small, 1.0 / 12.0, 1.0 / ts**2 - (1.0 + np.cos(ts)) / (2.0 * ts * np.sin(np.where(small, 1.0, ts))))
    return np.eye(3) + 0.5 * k + c[..., None, None] * (k @ k)


def quat_from_matrix(r: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternions (w >= 0) of rotation matrices (..., 3, 3) -> (..., 4)."""
    r = np.asarray(r, dtype=np.float64)
    return quat_from_dcm(np.swapaxes(r, -1, -2))


def matrix_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation matrices of scalar-first quaternions (..., 4) -> (..., 3, 3)."""
    return np.swapaxes(dcm_from_quat(np.asarray(q, dtype=np.float64)), -1, -2)


def axis_rotation(axis: np.ndarray, angle: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v`` ((3,) or (..., 3)) about the unit ``axis`` (3,) by ``angle`` [rad] (...) (Rodrigues)."""
    angle = np.asarray(angle, dtype=np.float64)[..., None]
    c, s = np.cos(angle), np.sin(angle)
    v = np.asarray(v, dtype=np.float64)
    kv = v @ hat(axis).T  # axis x v
    return v * c + kv * s + (v @ axis)[..., None] * axis * (1.0 - c)
