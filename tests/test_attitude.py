"""QUEST against Davenport's q-method (brute-force eigenvectors), DMC references (eq 9) and helpers."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.core import rotations as R
from sportfusion.estimators import quest as Q
from sportfusion.skirace import attitude as A

RNG = np.random.default_rng(11)
REF2 = np.array([[0.0, 0.0, -9.8], [21.5, 1.4, 43.4]])  # -g and the field (NED)


def observe(q, ref, noise=0.0):
    body = np.stack([R.to_body(q, r) for r in ref], axis=1)
    return body + noise * RNG.standard_normal(body.shape) * np.linalg.norm(ref, axis=1)[None, :, None]


def test_quest_equals_davenport_eigenvector():
    q = R.quat_normalize(RNG.standard_normal((20000, 4)))
    body = observe(q, REF2, noise=0.02)
    for w in ([1.0, 1.0], [3.0, 1.0], [0.2, 1.0]):
        qq, loss = Q.quest(body, REF2, np.array(w))
        qd, ld = Q.davenport(body, REF2, np.array(w))
        assert np.max(np.abs(qq - qd)) < 1e-9
        assert np.max(np.abs(loss - ld)) < 1e-12


def test_quest_three_vectors_and_per_sample_references():
    q = R.quat_normalize(RNG.standard_normal((3000, 4)))
    ref = np.array([[0.0, 0, -1], [0.44, 0.03, 0.89], [1.0, 0, 0]])
    body = observe(q, ref, noise=0.05)
    refs = np.broadcast_to(ref, body.shape) + 0.01 * RNG.standard_normal(body.shape)
    qq, loss = Q.quest(body, refs, np.array([1.0, 2.0, 3.0]))
    qd, ld = Q.davenport(body, refs, np.array([1.0, 2.0, 3.0]))
    assert np.max(np.abs(qq - qd)) < 1e-9
    assert np.max(np.abs(loss - ld)) < 1e-12


@pytest.mark.parametrize("n", [1, 7])
def test_quest_many_vectors_matches_davenport(n: int) -> None:
    """More than four vectors (the in-run alignment: hundreds for one sample) take the contracted path."""
    ref = RNG.standard_normal((40, 3))
    q = R.quat_normalize(RNG.standard_normal((n, 4)))
    body = observe(q, ref, noise=0.03)
    w = RNG.uniform(0.5, 2.0, 40)
    for r in (ref, np.broadcast_to(ref, body.shape) + 0.01 * RNG.standard_normal(body.shape)):
        qq, loss = Q.quest(body, r, w)
        qd, ld = Q.davenport(body, r, w)
        assert np.max(np.abs(qq - qd)) < 1e-9
        assert np.max(np.abs(loss - ld)) < 1e-12


@pytest.mark.parametrize("k", [2, 3, 4, 40])
def test_single_sample_path_equals_the_batched_one(k: int) -> None:
    """One sample (the alignments) runs on Python floats: the same numbers as the array path, half turns
    (the adjugate's other column) and NaN/zero vectors included."""
    ref = RNG.standard_normal((k, 3))
    w = RNG.uniform(0.5, 2.0, k)
    qs = [*R.quat_normalize(RNG.standard_normal((30, 4))), [0, 1, 0, 0], [0, 0, 0.6, 0.8], [1e-12, 0.6, 0, 0.8]]
    for i, q in enumerate(qs):
        body = observe(np.asarray(q, float)[None], ref, noise=0.0 if i % 2 else 0.05)
        q1, l1 = Q.quest(body, ref, w)
        qb, lb = Q._quest_block(body, ref, w / w.sum(), 8)
        assert q1.shape == (1, 4) and l1.shape == (1,)
        # q and -q are one rotation: at a half turn (q0 ~ 1e-17) either sign may come out of the rounding
        sign = 1.0 if abs(qb[0, 0]) > 1e-9 else np.sign(q1[0] @ qb[0])
        np.testing.assert_allclose(q1, sign * qb, rtol=0, atol=1e-12)
        np.testing.assert_allclose(l1, lb, rtol=0, atol=1e-12)
        assert q1[0, 0] >= 0
    body = observe(np.array([[1.0, 0, 0, 0]]), ref)
    for bad in (0.0, np.nan):
        b = body.copy()
        b[0, 0] = bad
        q1, l1 = Q.quest(b, ref, w)
        assert np.isnan(q1).all() and np.isnan(l1).all()


def test_exact_observations_and_half_turns():
    q = R.quat_normalize(
        np.vstack([RNG.standard_normal((500, 4)), [[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [1e-12, 0.6, 0, 0.8]]])
    )
    qq, loss = Q.quest(observe(q, REF2), REF2, np.array([1.0, 1.0]))
    assert np.max(R.quat_angle(qq, q)) < 1e-7
    assert np.max(np.abs(loss)) < 1e-12
    assert np.all(qq[:, 0] >= 0)


def test_loss_of_two_inconsistent_vectors():
    # equal weights: loss = 1 - cos(delta/2), delta the mismatch of the angle between the two vectors
    delta = 0.1
    ref = np.array([[0.0, 0, 1], [1.0, 0, 0]])
    body = np.array([[[0.0, 0, 1], [np.cos(delta), 0, np.sin(delta)]]])
    _, loss = Q.quest(body, ref, np.array([1.0, 1.0]))
    assert abs(loss[0] - (1 - np.cos(delta / 2))) < 1e-14


def test_reference_specific_force_and_coriolis():
    f = A.reference_specific_force(None, 9.8, n=3)
    np.testing.assert_allclose(f, np.tile([0, 0, -9.8], (3, 1)))
    a = np.array([[1.0, 2.0, 3.0]])
    np.testing.assert_allclose(A.reference_specific_force(a, 9.8), [[1.0, 2.0, 3.0 - 9.8]])
    # northward velocity at latitude phi: Coriolis 2 w_ie x v = (0, -2 w v sin phi, 0); transport adds the
    # centripetal v^2 / (R_M + h) downwards (the navigation equation's v_D' = f_D - v_N^2/(R_M+h) + ... + g)
    v = np.array([[30.0, 0.0, 0.0]])
    phi = np.radians(46.5)
    c = A.coriolis_ned(v, 46.5, 2000.0)
    rm = 6378137.0 * (1 - 0.00669437999013) / (1 - 0.00669437999013 * np.sin(phi) ** 2) ** 1.5
    np.testing.assert_allclose(c[0], [0.0, -2 * A.OMEGA_EARTH * 30 * np.sin(phi), 30.0**2 / (rm + 2000.0)], atol=1e-12)


def test_dmc_attitude_recovers_truth_and_flags_free_fall():
    q = R.quat_from_euler(RNG.uniform(-0.5, 0.5, 100), RNG.uniform(-0.5, 0.5, 100), RNG.uniform(-3, 3, 100))
    a_ned = RNG.normal(0, 5, (100, 3))
    a_ned[:5] = [0, 0, 9.8]  # free fall
    f_ref = A.reference_specific_force(a_ned, 9.8)
    m_ref = np.array([21.5, 1.4, 43.4])
    res = A.dmc_attitude(R.to_body(q, f_ref), R.to_body(q, np.broadcast_to(m_ref, (100, 3))), f_ref, m_ref, 9.8)
    ok = ~res.singular
    assert res.singular[:5].all() and ok[5:].sum() >= 90
    assert np.max(R.quat_angle(res.q[ok], q[ok])) < 1e-7
    np.testing.assert_allclose(res.acc_kin_ned[ok], a_ned[ok], atol=1e-6)
    np.testing.assert_allclose(
        np.column_stack((res.roll, res.pitch, res.yaw))[ok], np.column_stack(R.euler_from_quat(q))[ok], atol=1e-7
    )


def test_dip_from_quiet_samples():
    n = 500
    q = R.quat_from_euler(0.05 * np.sin(np.arange(n) / 50), 0.1, np.arange(n) / 100)
    m_ref = np.array([21.46, 1.48, 43.44])
    f = R.to_body(q, np.tile([0, 0, -9.81], (n, 1))) + RNG.normal(0, 0.02, (n, 3))
    m = R.to_body(q, np.tile(m_ref, (n, 1))) + RNG.normal(0, 0.1, (n, 3))
    inc, count = A.dip_from_quiet(f, m, 9.81, 50.0)
    assert count > 400
    assert abs(inc - np.degrees(np.arctan2(43.44, np.hypot(21.46, 1.48)))) < 0.3
    # a moving sensor has no quiet samples
    shaken = f + RNG.normal(0, 3.0, f.shape)
    assert A.dip_from_quiet(shaken, m, 9.81, 50.0)[1] < 20


def test_lowpass():
    fs = 50.0
    t = np.arange(1000) / fs
    x = np.column_stack((np.sin(2 * np.pi * 0.5 * t) + np.sin(2 * np.pi * 15 * t),))
    x[100, 0] = np.nan
    y = A.lowpass(x, fs, 5.0)
    core = slice(200, 800)
    assert np.isnan(y[100, 0])
    np.testing.assert_allclose(y[core, 0], np.sin(2 * np.pi * 0.5 * t[core]), atol=0.01)
    np.testing.assert_array_equal(A.lowpass(x, fs, 0.0), x)


@pytest.mark.parametrize("n", [1, 7])
def test_small_batches(n):
    q = R.quat_normalize(RNG.standard_normal((n, 4)))
    qq, _ = Q.quest(observe(q, REF2), REF2, np.array([1.0, 1.0]))
    assert qq.shape == (n, 4)
    assert np.max(R.quat_angle(qq, q)) < 1e-7
