"""Gyro + vector-observation attitude smoother: Jacobians vs finite differences, the batch solver vs the
EKF + RTS (kalman.ekf_rts with its manifold hooks), and accuracy against a known rotation history."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.core.rotations import body_rates, quat_angle, quat_from_euler, quat_normalize, to_body
from sportfusion.estimators.attitude_ekf import (
    att_boxminus,
    att_boxplus,
    att_observe,
    att_propagate,
    gyro_vector_smoother,
    process_residuals,
)

RNG = np.random.default_rng(11)
W_IE = 7.292115e-5 * np.array([np.cos(0.8), 0.0, -np.sin(0.8)])  # Earth rate in NED at 46 deg [rad/s]


def _state() -> np.ndarray:
    return np.concatenate((quat_normalize(RNG.standard_normal(4)), 0.02 * RNG.standard_normal(3)))


@pytest.mark.parametrize("w_ie", [None, W_IE])
def test_propagation_jacobian_matches_finite_differences(w_ie):
    for _ in range(5):
        x = _state()
        gyr = RNG.standard_normal(3) * 3.0  # [rad/s], up to landing-impact rates
        dt = 0.02
        xn, Phi = att_propagate(x, gyr, dt, w_ie)
        eps = 1e-6
        num = np.empty((6, 6))
        for i in range(6):
            d = np.zeros(6)
            d[i] = eps
            plus = att_boxminus(att_propagate(att_boxplus(x, d), gyr, dt, w_ie)[0], xn)
            minus = att_boxminus(att_propagate(att_boxplus(x, -d), gyr, dt, w_ie)[0], xn)
            num[:, i] = (plus - minus) / (2 * eps)
        np.testing.assert_allclose(Phi, num, atol=1e-8)


def test_observation_jacobian_matches_finite_differences():
    for _ in range(5):
        x = _state()
        r = RNG.standard_normal(3) * 9.8
        h, H = att_observe(x, r)
        np.testing.assert_allclose(h, to_body(x[:4], r), atol=1e-12)
        eps = 1e-6
        num = np.empty((3, 6))
        for i in range(6):
            d = np.zeros(6)
            d[i] = eps
            num[:, i] = (att_observe(att_boxplus(x, d), r)[0] - att_observe(att_boxplus(x, -d), r)[0]) / (2 * eps)
        np.testing.assert_allclose(H, num, atol=1e-7)


def test_boxplus_boxminus_round_trip():
    x = _state()
    d = np.r_[0.3 * RNG.standard_normal(3), 0.01 * RNG.standard_normal(3)]
    np.testing.assert_allclose(att_boxminus(att_boxplus(x, d), x), d, atol=1e-12)


def test_batch_process_residuals_agree_with_the_step_model():
    n = 20
    t = np.cumsum(np.r_[0.0, np.full(n - 1, 0.02)])
    q = quat_normalize(RNG.standard_normal((n, 4)))
    b = 0.01 * RNG.standard_normal((n, 3))
    gyr = RNG.standard_normal((n, 3))
    res, Phi = process_residuals(q, b, t, gyr, W_IE)
    for k in range(n - 1):
        xn, Ph = att_propagate(np.r_[q[k], b[k]], gyr[k + 1], 0.02, W_IE)
        np.testing.assert_allclose(res[k], att_boxminus(np.r_[q[k + 1], b[k + 1]], xn), atol=1e-12)
        np.testing.assert_allclose(Phi[k], Ph, atol=1e-12)


def _scenario(n: int = 600, fs: float = 50.0, seed: int = 2):
    """Tumbling body (up to ~2 rad/s), constant gyro bias, noisy gyro, two noisy vector observations."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    q = quat_from_euler(0.6 * np.sin(1.3 * t), 0.4 * np.sin(0.7 * t + 1), 1.5 * np.sin(0.4 * t))
    bias = np.array([0.01, -0.02, 0.015])  # [rad/s]
    gyr = body_rates(t, q) + bias + rng.normal(0, 2e-3, (n, 3))
    ref = np.array([[0.0, 0.0, -9.8], [21.0, 1.5, 43.0]])
    ref[1] /= np.linalg.norm(ref[1])
    sig = np.array([0.3, 0.01])
    body = np.stack([to_body(q, r) for r in ref], axis=1) + rng.normal(0, 1, (n, 2, 3)) * sig[None, :, None]
    body[100:160, 0] = np.nan  # a stretch without the first vector
    return t, q, bias, gyr, body, ref, sig


def test_batch_equals_ekf_rts_and_recovers_attitude_and_bias():
    t, q, bias, gyr, body, ref, sig = _scenario()
    q0 = quat_normalize(q[0] + np.r_[0.0, 0.03, -0.02, 0.01])  # a start ~4 deg off
    kw = {"gyro_noise": 2e-3 / np.sqrt(50.0), "bias_walk": 1e-5, "sigma_q0": 0.2, "sigma_bias0": 0.05}
    batch = gyro_vector_smoother(t, gyr, body, ref, sig, q0, **kw)
    rts = gyro_vector_smoother(t, gyr, body, ref, sig, q0, method="rts", **kw)
    assert batch.converged and batch.iterations <= 10
    # the same model, two solvers: at convergence the batch MAP is the (iterated) RTS answer
    assert np.degrees(quat_angle(batch.q, rts.q)).max() < 0.02
    np.testing.assert_allclose(batch.bias, rts.bias, atol=2e-4)
    np.testing.assert_allclose(batch.std_theta, rts.std_theta, rtol=0.05)
    # against the truth: well inside the observations' own accuracy (0.3/9.8 rad, 0.01 rad per sample)
    err = np.degrees(quat_angle(batch.q, q))
    print(f"smoothed attitude error: median {np.median(err):.3f} deg, max {err.max():.3f} deg")
    assert np.median(err) < 0.3 and err.max() < 0.5
    np.testing.assert_allclose(batch.bias[300], bias, atol=2e-3)
    # the reported 1-sigma matches the errors (within a factor 2)
    e_rad = np.radians(np.median(err))
    ratio = e_rad / np.median(np.linalg.norm(batch.std_theta, axis=1))
    print(f"median error / median reported 1-sigma: {ratio:.2f}")
    assert 0.5 < ratio < 2.0
    # residuals: NaN where the observation was absent
    assert np.isnan(batch.residuals["obs0"][120]).all() and np.isfinite(batch.residuals["obs1"][120]).all()
    # the forward filter alone is causal and worse, but close
    assert np.median(np.degrees(quat_angle(rts.q_filt, q))) < 3 * np.median(err) + 0.1


def test_rejects_bad_input():
    t, q, bias, gyr, body, ref, sig = _scenario(n=50)
    with pytest.raises(ValueError, match="strictly increasing"):
        gyro_vector_smoother(t[::-1], gyr, body, ref, sig, q[0])
    with pytest.raises(ValueError, match="unknown method"):
        gyro_vector_smoother(t, gyr, body, ref, sig, q[0], method="ukf")
    with pytest.raises(ValueError, match="positive"):
        gyro_vector_smoother(t, gyr, body, ref, sig, q[0], bias_walk=0.0)
