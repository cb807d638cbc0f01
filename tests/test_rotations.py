"""Quaternion / DCM / Euler conventions (skijump eqs 47, 54-56), against scipy's Rotation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sportfusion.core import rotations as R

RNG = np.random.default_rng(7)
Q = R.quat_normalize(RNG.standard_normal((500, 4)))


def eq47(q: np.ndarray) -> np.ndarray:
    """M_BO written out exactly as printed in the ski-jumping paper (eq 47)."""
    q0, q1, q2, q3 = q
    return np.array(
        [
            [q0**2 + q1**2 - q2**2 - q3**2, 2 * (q1 * q2 + q0 * q3), 2 * (q1 * q3 - q0 * q2)],
            [2 * (q1 * q2 - q0 * q3), q0**2 - q1**2 + q2**2 - q3**2, 2 * (q2 * q3 + q0 * q1)],
            [2 * (q0 * q2 + q1 * q3), 2 * (q2 * q3 - q0 * q1), q0**2 - q1**2 - q2**2 + q3**2],
        ]
    )


def test_dcm_is_eq47_and_scipy_transpose():
    m = R.dcm_from_quat(Q)
    for i in range(20):
        np.testing.assert_allclose(m[i], eq47(Q[i]), atol=1e-14)
    # scipy (scalar last) gives the active body->NED rotation; M_BO is its transpose
    ref = Rotation.from_quat(Q[:, [1, 2, 3, 0]]).as_matrix()
    np.testing.assert_allclose(m, np.swapaxes(ref, 1, 2), atol=1e-14)


def test_dcm_quat_round_trip_including_half_turns():
    special = np.array([[0.0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [1e-9, 0.6, 0.8, 0], [0.0, 0.5, 0.5, np.sqrt(0.5)]])
    q = np.vstack([Q, R.quat_normalize(special)])
    back = R.quat_from_dcm(R.dcm_from_quat(q))
    np.testing.assert_allclose(back, R.quat_canonical(q), atol=1e-12)


def test_one_item_is_the_stack_to_the_bit():
    """dcm_from_quat, quat_from_dcm and m_bo on one item (Python floats) give the stacked path's numbers (the
    same operations; a last-bit tolerance in case numpy's summation order changes): every Shepperd case, half
    turns, ties between the candidates, matrices that are no rotation (the same case picked), NaN."""
    from sportfusion.skijump.kinematics import m_bo

    raw = np.vstack(
        [RNG.standard_normal((300, 4)), np.eye(4), [[0.0, 0.5, 0.5, 0.5]], 1e-3 * RNG.standard_normal((5, 4))]
    )
    for f in (R.dcm_from_quat, m_bo):
        stack = f(raw)
        np.testing.assert_allclose(np.array([f(q) for q in raw]), stack, rtol=1e-15, atol=1e-15)
    mats = np.concatenate(
        [
            R.dcm_from_quat(raw),
            RNG.standard_normal((300, 3, 3)),
            np.diag([1.0, 1.0, 1.0])[None],
            np.diag([-1.0, -1.0, 1.0])[None],
            np.diag([1.0, -1.0, -1.0])[None],
            np.diag([-1.0, 1.0, -1.0])[None],
            np.diag([-1.0, -1.0, -1.0])[None],  # no rotation: a tie between three candidates
            np.zeros((1, 3, 3)),
            np.full((1, 3, 3), np.nan),
        ]
    )
    stack = R.quat_from_dcm(mats)
    one = np.array([R.quat_from_dcm(m) for m in mats])
    np.testing.assert_allclose(one, stack, rtol=1e-14, atol=1e-15)  # NaN where NaN
    assert np.isnan(one[-1]).all()


def test_euler_matches_eqs_54_56_and_scipy_zyx():
    roll, pitch, yaw = R.euler_from_quat(Q)
    q0, q1, q2, q3 = Q.T
    np.testing.assert_allclose(roll, np.arctan2(2 * (q2 * q3 + q0 * q1), q0**2 - q1**2 - q2**2 + q3**2), atol=1e-12)
    np.testing.assert_allclose(pitch, np.arcsin(-2 * (q1 * q3 - q0 * q2)), atol=1e-12)
    np.testing.assert_allclose(yaw, np.arctan2(2 * (q1 * q2 + q0 * q3), q0**2 + q1**2 - q2**2 - q3**2), atol=1e-12)
    ypr = Rotation.from_quat(Q[:, [1, 2, 3, 0]]).as_euler("ZYX")
    np.testing.assert_allclose(np.column_stack((yaw, pitch, roll)), ypr, atol=1e-10)


def test_euler_round_trip_and_yaw_is_azimuth():
    roll = RNG.uniform(-np.pi, np.pi, 200)
    pitch = RNG.uniform(-1.5, 1.5, 200)
    yaw = RNG.uniform(-np.pi, np.pi, 200)
    q = R.quat_from_euler(roll, pitch, yaw)
    np.testing.assert_allclose(np.column_stack(R.euler_from_quat(q)), np.column_stack((roll, pitch, yaw)), atol=1e-10)
    # a level body with yaw psi: its x axis points to azimuth psi, i.e. north = (cos psi, -sin psi, 0) in the body
    psi = 0.7
    north_b = R.to_body(R.quat_from_euler(0.0, 0.0, psi), [1.0, 0.0, 0.0])
    np.testing.assert_allclose(north_b, [np.cos(psi), -np.sin(psi), 0.0], atol=1e-15)
    # positive pitch raises the nose: gravity (down) has a negative body-x component... of -sin(theta)*(-g)
    g_b = R.to_body(R.quat_from_euler(0.0, 0.3, 0.0), [0.0, 0.0, 9.81])
    np.testing.assert_allclose(g_b, [-9.81 * np.sin(0.3), 0.0, 9.81 * np.cos(0.3)], atol=1e-12)


def test_multiply_composes_frames():
    p, q = Q[:100], Q[100:200]
    # q_CO = q_BO ⊗ q_CB  <=>  M_CO = M_CB M_BO
    lhs = R.dcm_from_quat(R.quat_multiply(p, q))
    rhs = R.dcm_from_quat(q) @ R.dcm_from_quat(p)
    np.testing.assert_allclose(lhs, rhs, atol=1e-13)
    r = Q[200:300]
    np.testing.assert_allclose(
        R.quat_multiply(R.quat_multiply(p, q), r), R.quat_multiply(p, R.quat_multiply(q, r)), atol=1e-14
    )
    ident = R.quat_multiply(p, R.quat_conjugate(p))
    np.testing.assert_allclose(ident, np.tile([1.0, 0, 0, 0], (100, 1)), atol=1e-14)


def test_rotate_round_trip_and_broadcast():
    v = RNG.standard_normal((500, 3))
    np.testing.assert_allclose(R.to_ned(Q, R.to_body(Q, v)), v, atol=1e-13)
    one = R.to_body(Q, np.array([0.0, 0.0, 1.0]))  # one vector, many attitudes
    assert one.shape == (500, 3)
    np.testing.assert_allclose(np.linalg.norm(one, axis=1), 1.0, atol=1e-14)


def test_quat_angle():
    axis = np.array([0.0, 0.6, 0.8])
    for ang in (1e-7, 0.01, 1.0, 3.0):
        dq = np.r_[np.cos(ang / 2), np.sin(ang / 2) * axis]
        q2 = R.quat_multiply(Q[:50], dq)
        np.testing.assert_allclose(R.quat_angle(Q[:50], q2), ang, rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(R.quat_angle(Q[:50], -q2), ang, rtol=1e-9, atol=1e-15)  # sign ignored


@pytest.mark.parametrize("az", [0.0, 90.0, 160.0, -35.0])
def test_local_ned_frame(az):
    x_local = np.array([1.0, 0.0, 0.0])
    ned = R.local_to_ned(x_local, az)
    np.testing.assert_allclose(ned, [np.cos(np.radians(az)), np.sin(np.radians(az)), 0.0], atol=1e-15)
    y_ned = R.local_to_ned([0.0, 1.0, 0.0], az)  # y is to the right: azimuth + 90
    np.testing.assert_allclose(y_ned, [np.cos(np.radians(az + 90)), np.sin(np.radians(az + 90)), 0.0], atol=1e-15)
    v = RNG.standard_normal((10, 3))
    np.testing.assert_allclose(R.ned_to_local(R.local_to_ned(v, az), az), v, atol=1e-14)


def test_skew_is_the_cross_product():
    from sportfusion.core.rotations import skew

    rng = np.random.default_rng(5)
    a, b = rng.normal(size=(7, 3)), rng.normal(size=(7, 3))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", skew(a), b), np.cross(a, b), atol=1e-14)
    np.testing.assert_allclose(skew(a[0]) @ b[0], np.cross(a[0], b[0]), atol=1e-14)


def test_rotvec_exp_log_against_scipy():
    phi = RNG.standard_normal((200, 3)) * np.array([[1.0], [1e-6], [3.0], [1e-9]]).repeat(50, axis=0)
    q = R.quat_from_rotvec(phi)
    ref = Rotation.from_rotvec(phi).as_quat()[:, [3, 0, 1, 2]]  # scipy: scalar last, same Hamilton rotation
    np.testing.assert_allclose(R.quat_canonical(q), R.quat_canonical(ref), atol=1e-14)
    small = np.linalg.norm(phi, axis=1) < np.pi
    np.testing.assert_allclose(R.rotvec_from_quat(q)[small], phi[small], atol=1e-12)
    # a body-frame increment: q ⊗ Exp(phi) turns M_BO by the frame rotation M(Exp(phi))
    m = R.dcm_from_quat(R.quat_multiply(Q[:200], q))
    np.testing.assert_allclose(m, R.dcm_from_quat(q) @ R.dcm_from_quat(Q[:200]), atol=1e-13)


def test_body_rates_and_integration_are_inverse():
    t = np.cumsum(np.r_[0.0, 0.01 + 0.01 * RNG.random(299)])  # uneven steps [s]
    roll, pitch, yaw = 0.5 * np.sin(2 * t), 0.3 * np.cos(3 * t), 2.0 * t  # [rad]
    q = R.quat_from_euler(roll, pitch, yaw)
    w = R.body_rates(t, q)
    back = R.integrate_body_rates(q[0], t, w)
    np.testing.assert_allclose(R.quat_angle(back, q), 0.0, atol=1e-10)
    # the mean rate over an interval is the instantaneous one at its middle, to second order
    tm = (t[1:] + t[:-1]) / 2
    eul = np.array(R.euler_from_quat(q))
    dot = np.gradient(np.unwrap(eul, axis=1), t, axis=1)  # Euler rates
    wx = dot[0] - dot[2] * np.sin(eul[1])  # body rates from Euler rates (z-y-x)
    assert np.median(np.abs(w[1:, 0] - np.interp(tm, t, wx))) < 1e-3


def test_interval_mean_rates_exact_for_a_linear_rate():
    """Instantaneous samples of a rate linear in time -> the exact mean over each interval (trapezoid)."""
    from sportfusion.core.rotations import interval_mean_rates

    t = np.cumsum(np.r_[0.0, np.full(9, 0.02)])
    w_at = np.outer(t, [1.0, -2.0, 0.5]) + [0.1, 0.0, -0.3]  # w(t) sampled at the instants
    got = interval_mean_rates(w_at)
    mid = 0.5 * (t[1:] + t[:-1])
    np.testing.assert_allclose(got[1:], np.outer(mid, [1.0, -2.0, 0.5]) + [0.1, 0.0, -0.3], atol=1e-15)
    np.testing.assert_array_equal(got[0], w_at[0])


def test_euler_of_a_scaled_matrix_and_ned_to_local_into_columns():
    """euler_from_dcm(scale=|q|^2) on the matrix of a quaternion that is not unit gives the unit quaternion's
    angles; ned_to_local(out=) writes the same numbers into (3, n) rows as it returns without out."""
    from sportfusion.skijump.kinematics import m_bo

    rng = np.random.default_rng(5)
    q = rng.normal(size=(200, 4)) * rng.uniform(0.5, 2.0, size=(200, 1))
    n2 = (q * q).sum(axis=1)
    got = R.euler_from_dcm(m_bo(q), scale=n2)
    want = R.euler_from_quat(q / np.sqrt(n2)[:, None])
    for g, w in zip(got, want, strict=True):
        np.testing.assert_allclose(g, w, rtol=0, atol=1e-12)
    v = rng.normal(size=(200, 3))
    rows = np.empty((3, 200))
    R.ned_to_local(v, 37.0, out=rows.T)
    np.testing.assert_allclose(rows.T, R.ned_to_local(v, 37.0), rtol=0, atol=1e-15)
