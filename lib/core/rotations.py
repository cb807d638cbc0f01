"""Quaternions, direction-cosine matrices and Euler angles (vectorised).

Conventions (``docs/frames.md``)
-------------------------------------------------
* Quaternions are scalar first, ``q = [q0, q1, q2, q3]``, Hamilton product.
* The attitude quaternion ``q_BO`` maps local-level (NED) vectors into the
  body frame exactly as eq 47 of the ski-jumping paper::

      v_B = M_BO(q) v_O,
      M_BO = [[q0²+q1²-q2²-q3², 2(q1q2+q0q3),    2(q1q3-q0q2)],
              [2(q1q2-q0q3),    q0²-q1²+q2²-q3², 2(q2q3+q0q1)],
              [2(q0q2+q1q3),    2(q2q3-q0q1),    q0²-q1²-q2²+q3²]]

  ``M_BO`` is the transpose of the Hamilton rotation matrix of ``q``: the
  quaternion rotates body vectors into NED (``q ⊗ v_B ⊗ q*``).  Chaining
  frames: ``M_CO = M_CB M_BO`` corresponds to ``q_CO = q_BO ⊗ q_CB``.
* Euler angles are z-y-x (yaw ``psi``, pitch ``theta``, roll ``phi``):
  ``M_BO = R1(phi) R2(theta) R3(psi)`` with ``Ri`` the frame rotations, so yaw
  is the azimuth from north of the body x axis (eqs 54-56 of the ski-jumping
  paper, with ``atan2``).  Angles in radians.
* A session's local frame has its x axis along ``azimuth_deg`` (clockwise from
  north), y to the right, z down; :func:`local_to_ned` / :func:`ned_to_local`
  is the one place that rotation is done.

Every function accepts a single item (``(4,)``, ``(3,)``, ``(3, 3)``) or a
stack with leading dimensions (``(..., 4)`` etc.) and broadcasts.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "quat_normalize",
    "quat_multiply",
    "quat_conjugate",
    "dcm_from_quat",
    "dcm_entries",
    "quat_from_dcm",
    "euler_from_quat",
    "quat_from_euler",
    "euler_from_dcm",
    "dcm_from_euler",
    "to_body",
    "to_ned",
    "quat_angle",
    "quat_canonical",
    "quat_from_rotvec",
    "rotvec_from_quat",
    "body_rates",
    "integrate_body_rates",
    "local_to_ned",
    "ned_to_local",
]


def quat_normalize(q: np.ndarray) -> np.ndarray:
    """Unit quaternion(s) ``q / |q|`` (shape ``(..., 4)``)."""
    q = np.asarray(q, dtype=float)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_canonical(q: np.ndarray) -> np.ndarray:
    """The same rotation with a non-negative scalar part (``q`` and ``-q`` are one attitude)."""
    q = np.asarray(q, dtype=float)
    return np.where(q[..., :1] < 0, -q, q)


def quat_multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` of scalar-first quaternions (broadcasts over ``...``)."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    p0, p1, p2, p3 = np.moveaxis(p, -1, 0)
    q0, q1, q2, q3 = np.moveaxis(q, -1, 0)
    return np.stack(
        (
            p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0,
        ),
        axis=-1,
    )


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate ``[q0, -q1, -q2, -q3]`` (the inverse rotation for a unit quaternion)."""
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def dcm_from_quat(q: np.ndarray) -> np.ndarray:
    """``M_BO`` of eq 47 (NED -> body) from ``q_BO``; shape ``(..., 3, 3)``.

    The quaternion need not be exactly unit: it is normalised first.
    """
    q = np.asarray(q, dtype=float)
    if q.shape == (4,):  # one quaternion: Python floats (~30x less overhead), the same operations
        a, b, c, d = q.tolist()
        n = math.sqrt(a * a + b * b + c * c + d * d)
        return dcm_entries(a / n, b / n, c / n, d / n, single=True)
    return dcm_entries(*np.moveaxis(quat_normalize(q), -1, 0))


def dcm_entries(q0, q1, q2, q3, single: bool = False) -> np.ndarray:  # noqa: ANN001
    """Eq 47's ``M_BO`` as printed from the quaternion's components (not normalised here).

    Parameters
    ----------
    q0, q1, q2, q3 : float or array
        The components (scalar first), arrays of one shape ``S``.
    single : bool
        The components are Python floats: one (3, 3) matrix built from them.

    Returns
    -------
    array, shape S + (3, 3)
    """
    e = (
        (q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3, 2 * (q1 * q2 + q0 * q3), 2 * (q1 * q3 - q0 * q2)),
        (2 * (q1 * q2 - q0 * q3), q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3, 2 * (q2 * q3 + q0 * q1)),
        (2 * (q0 * q2 + q1 * q3), 2 * (q2 * q3 - q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3),
    )
    if single:
        return np.array(e)
    m = np.empty(np.shape(q0) + (3, 3))
    for i in range(3):
        for j in range(3):
            m[..., i, j] = e[i][j]
    return m


def quat_from_dcm(m: np.ndarray) -> np.ndarray:
    """``q_BO`` (scalar part >= 0) from ``M_BO`` (NED -> body), Shepperd's method.

    Shepperd's method picks, per matrix, the largest of the four squared
    components to divide by, so it is accurate for every rotation.
    """
    m = np.asarray(m, dtype=float)
    if m.shape == (3, 3) and (q := _quat_from_dcm_one(m)) is not None:
        return q
    # M_BO is the transpose of the Hamilton rotation matrix R(q): work on R.
    r = np.swapaxes(m, -1, -2)
    tr = r[..., 0, 0] + r[..., 1, 1] + r[..., 2, 2]
    cand = np.stack((tr, r[..., 0, 0], r[..., 1, 1], r[..., 2, 2]), axis=-1)
    k = np.argmax(cand, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):  # the unused cases may divide by ~0
        # case 0: q0 largest
        s = np.sqrt(np.maximum(1.0 + tr, 0.0)) * 2
        c0 = np.stack(
            (
                0.25 * s,
                (r[..., 2, 1] - r[..., 1, 2]) / s,
                (r[..., 0, 2] - r[..., 2, 0]) / s,
                (r[..., 1, 0] - r[..., 0, 1]) / s,
            ),
            axis=-1,
        )
        s1 = np.sqrt(np.maximum(1.0 + r[..., 0, 0] - r[..., 1, 1] - r[..., 2, 2], 0.0)) * 2
        c1 = np.stack(
            (
                (r[..., 2, 1] - r[..., 1, 2]) / s1,
                0.25 * s1,
                (r[..., 0, 1] + r[..., 1, 0]) / s1,
                (r[..., 0, 2] + r[..., 2, 0]) / s1,
            ),
            axis=-1,
        )
        s2 = np.sqrt(np.maximum(1.0 + r[..., 1, 1] - r[..., 0, 0] - r[..., 2, 2], 0.0)) * 2
        c2 = np.stack(
            (
                (r[..., 0, 2] - r[..., 2, 0]) / s2,
                (r[..., 0, 1] + r[..., 1, 0]) / s2,
                0.25 * s2,
                (r[..., 1, 2] + r[..., 2, 1]) / s2,
            ),
            axis=-1,
        )
        s3 = np.sqrt(np.maximum(1.0 + r[..., 2, 2] - r[..., 0, 0] - r[..., 1, 1], 0.0)) * 2
        c3 = np.stack(
            (
                (r[..., 1, 0] - r[..., 0, 1]) / s3,
                (r[..., 0, 2] + r[..., 2, 0]) / s3,
                (r[..., 1, 2] + r[..., 2, 1]) / s3,
                0.25 * s3,
            ),
            axis=-1,
        )
        q = np.where((k == 0)[..., None], c0, np.where((k == 1)[..., None], c1, np.where((k == 2)[..., None], c2, c3)))
    return quat_canonical(quat_normalize(q))


def _quat_from_dcm_one(m: np.ndarray) -> np.ndarray | None:
    """:func:`quat_from_dcm` of one matrix on Python floats: the same case and the same operations (the same
    result to the last bit, ~30x less overhead).  None where it would divide by zero or meets NaN (the general
    path then gives numpy's answer)."""
    (r00, r10, r20), (r01, r11, r21), (r02, r12, r22) = m.tolist()  # R = M_BO^T
    tr = r00 + r11 + r22
    cand = (tr, r00, r11, r22)
    if not all(math.isfinite(v) for v in cand):
        return None
    k = cand.index(max(cand))  # the first largest, as np.argmax
    if k == 0:
        s = math.sqrt(max(1.0 + tr, 0.0)) * 2
        q = (0.25 * s, r21 - r12, r02 - r20, r10 - r01)
    elif k == 1:
        s = math.sqrt(max(1.0 + r00 - r11 - r22, 0.0)) * 2
        q = (r21 - r12, 0.25 * s, r01 + r10, r02 + r20)
    elif k == 2:
        s = math.sqrt(max(1.0 + r11 - r00 - r22, 0.0)) * 2
        q = (r02 - r20, r01 + r10, 0.25 * s, r12 + r21)
    else:
        s = math.sqrt(max(1.0 + r22 - r00 - r11, 0.0)) * 2
        q = (r10 - r01, r02 + r20, r12 + r21, 0.25 * s)
    if s == 0.0 or not all(math.isfinite(v) for v in q):
        return None
    q = tuple(v if i == k else v / s for i, v in enumerate(q))
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    sign = -1.0 if q[0] / n < 0 else 1.0
    return np.array([sign * (v / n) for v in q])


def euler_from_dcm(m: np.ndarray, scale: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(roll, pitch, yaw) [rad] from ``M_BO`` (z-y-x; eqs 54-56 with ``atan2``).

    Roll and yaw are in (-pi, pi], pitch in [-pi/2, pi/2].  ``scale``: the matrix is ``scale`` times a
    rotation, optional (``|q|^2`` for the matrix of a quaternion that is not unit: roll and yaw are ratios of its
    entries, pitch's sine is ``-m02 / scale``).
    """
    m = np.asarray(m, dtype=float)
    roll = np.arctan2(m[..., 1, 2], m[..., 2, 2])
    sp = -m[..., 0, 2] if scale is None else -m[..., 0, 2] / scale
    pitch = np.arcsin(np.clip(sp, -1.0, 1.0))
    yaw = np.arctan2(m[..., 0, 1], m[..., 0, 0])
    return roll, pitch, yaw


def euler_from_quat(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(roll, pitch, yaw) [rad] of ``q_BO``; yaw is the azimuth from north."""
    return euler_from_dcm(dcm_from_quat(q))


def dcm_from_euler(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """``M_BO = R1(roll) R2(pitch) R3(yaw)`` [angles in rad]; shape ``(..., 3, 3)``."""
    return dcm_from_quat(quat_from_euler(roll, pitch, yaw))


def quat_from_euler(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """``q_BO`` from z-y-x Euler angles [rad] (the inverse of :func:`euler_from_quat`)."""
    roll, pitch, yaw = np.broadcast_arrays(
        np.asarray(roll, dtype=float), np.asarray(pitch, dtype=float), np.asarray(yaw, dtype=float)
    )
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    q = np.stack(
        (
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ),
        axis=-1,
    )
    return quat_canonical(q)


def to_body(q: np.ndarray, v_ned: np.ndarray) -> np.ndarray:
    """Rotate NED vector(s) into the body frame: ``M_BO(q) v`` (shapes ``(...,4)``, ``(...,3)``)."""
    return np.einsum("...ij,...j->...i", dcm_from_quat(q), np.asarray(v_ned, dtype=float))


def to_ned(q: np.ndarray, v_body: np.ndarray) -> np.ndarray:
    """Rotate body vector(s) into NED: ``M_BO(q)^T v``."""
    return np.einsum("...ji,...j->...i", dcm_from_quat(q), np.asarray(v_body, dtype=float))


def skew(v: np.ndarray) -> np.ndarray:
    """Skew-symmetric (cross-product) matrices ``[v]x`` of vectors ``v`` (..., 3) -> (..., 3, 3):
    ``skew(a) @ b == cross(a, b)``."""
    v = np.asarray(v, dtype=np.float64)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def quat_angle(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Rotation angle [rad] between two attitudes, in [0, pi] (sign of ``q`` ignored).

    Computed as ``2 atan2(|vec(d)|, |d0|)`` with ``d = q1* ⊗ q2``, accurate for
    small angles too.
    """
    d = quat_multiply(quat_conjugate(quat_normalize(q1)), quat_normalize(q2))
    return 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))


def quat_from_rotvec(phi: np.ndarray) -> np.ndarray:
    """Unit quaternion(s) ``Exp(phi) = [cos(|phi|/2), sin(|phi|/2) phi/|phi|]`` of rotation vector(s) ``phi`` [rad].

    Shapes ``(..., 3) -> (..., 4)``; exact for every angle, with the series of ``sin(x/2)/x`` for tiny
    angles.  As a body-frame increment, ``q_BO ⊗ Exp(phi)`` is the attitude after the body turned by
    ``phi`` (its own axes; ``M_BO`` then becomes ``M(Exp(phi)) M_BO``, the frame rotation).
    """
    phi = np.asarray(phi, dtype=float)
    th = np.linalg.norm(phi, axis=-1)
    small = th < 1e-4
    k = np.where(small, 0.5 - th * th / 48.0, np.sin(0.5 * th) / np.where(small, 1.0, th))
    return np.concatenate((np.cos(0.5 * th)[..., None], k[..., None] * phi), axis=-1)


def rotvec_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation vector(s) ``Log(q)`` [rad] of quaternion(s) ``(..., 4) -> (..., 3)``, angle in [0, pi].

    The inverse of :func:`quat_from_rotvec` (``q`` and ``-q`` give the same vector); the angle is
    ``2 atan2(|vec q|, |q0|)``, accurate near 0 and pi.
    """
    q = quat_canonical(quat_normalize(q))
    v = q[..., 1:]
    sv = np.linalg.norm(v, axis=-1)
    th = 2.0 * np.arctan2(sv, q[..., 0])
    tiny = sv < 1e-12
    k = np.where(tiny, 2.0 / np.maximum(q[..., 0], 1e-300), th / np.where(tiny, 1.0, sv))
    return k[..., None] * v


def body_rates(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Mean body angular rate [rad/s] over each sample interval of an attitude history ``q_BO``.

    Row ``k`` is ``Log(q_{k-1}* ⊗ q_k) / (t_k - t_{k-1})``, the body-frame rate (body relative to NED)
    averaged over the interval that *ends* at ``t_k`` -- what an integrating (delta-angle) gyroscope
    outputs; row 0 repeats row 1.  :func:`integrate_body_rates` inverts it exactly.

    Parameters
    ----------
    t : (N,) sample times [s], strictly increasing, N >= 2.
    q : (N, 4) ``q_BO`` (scalar first).

    Returns
    -------
    (N, 3) body rates [rad/s].
    """
    t = np.asarray(t, dtype=float)
    q = quat_normalize(q)
    d = quat_multiply(quat_conjugate(q[:-1]), q[1:])
    w = rotvec_from_quat(d) / np.diff(t)[:, None]
    return np.concatenate((w[:1], w))


def interval_mean_rates(w: np.ndarray) -> np.ndarray:
    """Instantaneous gyro samples (N, 3) [rad/s] -> the mean rate over each interval ending at the sample.

    Row ``k`` is ``(w_{k-1} + w_k) / 2`` (the trapezoid; exact for a rate linear in time over the
    interval), row 0 unchanged: the convention :func:`integrate_body_rates` expects.  For gyroscopes
    that sample the rate (phones, most MEMS loggers) rather than integrate it (delta-angle output).
    """
    w = np.asarray(w, dtype=float)
    out = w.copy()
    out[1:] = 0.5 * (w[1:] + w[:-1])
    return out


def integrate_body_rates(q0: np.ndarray, t: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Strap-down attitude ``q_k = q_{k-1} ⊗ Exp(w_k (t_k - t_{k-1}))`` from ``q_BO`` at ``t[0]``.

    ``w[k]`` is the mean body rate [rad/s] over the interval ending at ``t[k]`` (the convention of
    :func:`body_rates`; ``w[0]`` is unused).  Returns ``(N, 4)`` ``q_BO``, scalar part >= 0.
    """
    t = np.asarray(t, dtype=float)
    dq = quat_from_rotvec(np.asarray(w, dtype=float)[1:] * np.diff(t)[:, None])
    out = np.empty((t.size, 4))
    a = quat_normalize(q0)
    out[0] = a
    for k in range(1, t.size):
        a = quat_multiply(a, dq[k - 1])
        out[k] = a
    return quat_canonical(quat_normalize(out))


def _rot_z(azimuth_deg: float) -> np.ndarray:
    a = np.deg2rad(azimuth_deg)
    c, s = np.cos(a), np.sin(a)
    # NED components of the local axes: x along the azimuth, y to its right, z down
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def local_to_ned(v_local: np.ndarray, azimuth_deg: float) -> np.ndarray:
    """Local-frame vector(s) ``(..., 3)`` -> NED, for a frame whose x axis points to ``azimuth_deg``.

    ``n = x cos(az) - y sin(az)``, ``e = x sin(az) + y cos(az)``, ``d = z``.
    Attitude angles follow: roll and pitch are the same in both frames, and
    the yaw w.r.t. north is the local yaw plus the azimuth.
    """
    return np.asarray(v_local, dtype=float) @ _rot_z(azimuth_deg).T


def ned_to_local(v_ned: np.ndarray, azimuth_deg: float, out: np.ndarray | None = None) -> np.ndarray:
    """NED vector(s) ``(..., 3)`` -> local frame whose x axis points to ``azimuth_deg`` (inverse of :func:`local_to_ned`).

    ``out``: an array of the result's shape (any strides, e.g. the ``.T`` of a (3, n) array) to write into.
    """
    return np.matmul(np.asarray(v_ned, dtype=float), _rot_z(azimuth_deg), out=out)
