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
    att_observe_biased,
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


@pytest.mark.parametrize("direction", [False, True])
def test_biased_observation_jacobian_matches_finite_differences(direction):
    for _ in range(5):
        x = np.concatenate((quat_normalize(RNG.standard_normal(4)), 0.8 * RNG.standard_normal(3)))  # [q, beta]
        r = RNG.standard_normal(3) * (1.0 if direction else 9.8)
        z = to_body(x[:4], 48.0 * r / np.linalg.norm(r) if direction else r) + x[4:] + 0.5 * RNG.standard_normal(3)
        res, H = att_observe_biased(x, z, r, direction)
        v = z - x[4:]
        pred = np.linalg.norm(v) * to_body(x[:4], r / np.linalg.norm(r)) if direction else to_body(x[:4], r)
        np.testing.assert_allclose(res, v - pred, atol=1e-12)

        def plus(d, x=x):  # x ⊞ d on [dtheta, dbeta]
            return np.concatenate((att_boxplus(np.r_[x[:4], 0, 0, 0], np.r_[d[:3], 0, 0, 0])[:4], x[4:] + d[3:]))

        eps = 1e-6
        num = np.empty((3, 6))
        for i in range(6):
            d = np.zeros(6)
            d[i] = eps
            num[:, i] = -(
                att_observe_biased(plus(d), z, r, direction)[0] - att_observe_biased(plus(-d), z, r, direction)[0]
            )
            num[:, i] /= 2 * eps
        np.testing.assert_allclose(H, num, atol=1e-6)


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


BETA = np.array([1.5, -1.0, 2.0])  # hard-iron bias [uT]
BETA_ACC = np.array([0.08, -0.05, 0.06])  # accelerometer bias [m/s^2]


def _biased(static: bool, n: int = 600, fs: float = 50.0, seed: int = 3):
    """A magnetometer [uT] with a hard-iron bias and an accelerometer [m/s^2] with a bias; the body tumbles about
    all three axes, or stands still."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    if static:
        q = quat_from_euler(np.full(n, 0.1), np.full(n, -0.05), np.full(n, 1.0))
    else:
        q = quat_from_euler(0.6 * np.sin(1.3 * t), 0.4 * np.sin(0.7 * t + 1), 1.5 * np.sin(0.4 * t))
    bias = np.array([0.01, -0.02, 0.015])  # gyro [rad/s]
    gyr = body_rates(t, q) + bias + rng.normal(0, 2e-3, (n, 3))
    ref = np.array([[0.0, 0.0, -9.8], [21.0, 1.5, 43.0]])  # specific force [m/s^2], field [uT]
    f = to_body(q, ref[0]) + BETA_ACC + rng.normal(0, 0.3, (n, 3))
    m = to_body(q, ref[1]) + BETA + rng.normal(0, 0.3, (n, 3))
    sig = np.array([0.3, 0.3 / 48.0])  # [m/s^2], direction [rad]
    kw = {"gyro_noise": 2e-3 / np.sqrt(fs), "bias_walk": 1e-5, "sigma_q0": 0.2, "sigma_bias0": 0.05}
    return t, q, gyr, np.stack((f, m), axis=1), ref, sig, kw


@pytest.mark.slow
def test_hard_iron_bias_batch_equals_ekf_rts_and_is_recovered_under_rotation():
    t, q, gyr, body, ref, sig, kw = _biased(static=False)
    body[:, 0] -= BETA_ACC  # the hard iron alone
    prior = {1: 3.0}  # [uT]
    batch = gyro_vector_smoother(t, gyr, body, ref, sig, q[0], obs_bias=prior, direction=(1,), **kw)
    rts = gyro_vector_smoother(t, gyr, body, ref, sig, q[0], obs_bias=prior, direction=(1,), method="rts", **kw)
    assert batch.converged
    # the same model, two solvers (the batch is the iterated answer, the EKF + RTS linearises once)
    np.testing.assert_allclose(batch.obs_bias[1], rts.obs_bias[1], atol=0.02)
    np.testing.assert_allclose(batch.std_obs_bias[1], rts.std_obs_bias[1], rtol=0.05)
    assert np.degrees(quat_angle(batch.q, rts.q)).max() < 0.05
    # rotations about all axes: the bias comes out to ~0.03 uT (1-sigma) of 1.5-2 uT, within 3 sigma
    print("hard iron", batch.obs_bias[1], "+-", batch.std_obs_bias[1])
    assert np.all(np.abs(batch.obs_bias[1] - BETA) < 3 * batch.std_obs_bias[1])
    assert np.all(batch.std_obs_bias[1] < 0.1)
    err = np.degrees(quat_angle(batch.q, q))
    # without the bias the field is off by up to 3 deg
    plain = body.copy()
    plain[:, 1] /= np.linalg.norm(plain[:, 1], axis=1, keepdims=True)
    unb = gyro_vector_smoother(t, gyr, plain, ref, sig, q[0], **kw)
    err0 = np.degrees(quat_angle(unb.q, q))
    print(f"attitude error median {np.median(err):.3f} deg (bias not estimated: {np.median(err0):.3f} deg)")
    assert np.median(err) < 0.15 < 1.0 < np.median(err0)


@pytest.mark.slow
def test_both_biases_batch_equals_ekf_rts_and_are_recovered():
    t, q, gyr, body, ref, sig, kw = _biased(static=False, seed=4)
    prior = {0: 0.2, 1: 3.0}  # [m/s^2], [uT]
    batch = gyro_vector_smoother(t, gyr, body, ref, sig, q[0], obs_bias=prior, direction=(1,), **kw)
    rts = gyro_vector_smoother(t, gyr, body, ref, sig, q[0], obs_bias=prior, direction=(1,), method="rts", **kw)
    assert batch.converged and batch.cov_obs_bias.shape == (6, 6)
    for i, truth in ((0, BETA_ACC), (1, BETA)):
        np.testing.assert_allclose(batch.obs_bias[i], rts.obs_bias[i], atol=0.2 * batch.std_obs_bias[i].max())
        np.testing.assert_allclose(batch.std_obs_bias[i], rts.std_obs_bias[i], rtol=0.05)
        print(i, batch.obs_bias[i], "+-", batch.std_obs_bias[i])
        assert np.all(np.abs(batch.obs_bias[i] - truth) < 3 * batch.std_obs_bias[i])
    assert np.all(batch.std_obs_bias[0] < 0.03)


def test_a_static_record_leaves_the_hard_iron_bias_at_its_prior():
    """Held still, the bias is a heading or a dip: only its component that changes the dip shows (the
    specific force fixes the tilt), the prior keeps the rest; the estimate stays within its prior."""
    t, q, gyr, body, ref, sig, kw = _biased(static=True, n=300)
    s_prior = 1.0  # [uT]
    res = gyro_vector_smoother(t, gyr, body, ref, sig, q[0], obs_bias={1: s_prior}, direction=(1,), max_iter=20, **kw)
    beta, cov = res.obs_bias[1], res.cov_obs_bias
    ev = np.linalg.eigvalsh(cov)
    print("static: bias", beta, "posterior 1-sigma along the principal axes", np.sqrt(ev))
    assert np.sqrt(ev[1:]).min() > 0.8 * s_prior  # two directions learn (almost) nothing
    assert np.sqrt(ev[0]) < 0.3 * s_prior  # the dip's direction is seen
    assert np.linalg.norm(beta) < 3 * s_prior  # sane: no runaway along the unobservable directions
    # and the attitude is no worse than the prior's: the bias was not used to fit the noise
    assert np.degrees(np.median(quat_angle(res.q, q))) < np.degrees(3 * s_prior / 21.0)


def test_rejects_bad_bias_options():
    t, q, gyr, body, ref, sig, kw = _biased(static=True, n=20)
    with pytest.raises(ValueError, match="positive"):
        gyro_vector_smoother(t, gyr, body, ref, sig, q[0], obs_bias={1: 0.0}, direction=(1,))
    with pytest.raises(ValueError, match="direction"):
        gyro_vector_smoother(t, gyr, body, ref, sig, q[0], direction=(1,))
    with pytest.raises(ValueError, match="indices"):
        gyro_vector_smoother(t, gyr, body, ref, sig, q[0], obs_bias={2: 1.0})


def test_rejects_bad_input():
    t, q, bias, gyr, body, ref, sig = _scenario(n=50)
    with pytest.raises(ValueError, match="strictly increasing"):
        gyro_vector_smoother(t[::-1], gyr, body, ref, sig, q[0])
    with pytest.raises(ValueError, match="unknown method"):
        gyro_vector_smoother(t, gyr, body, ref, sig, q[0], method="ukf")
    with pytest.raises(ValueError, match="positive"):
        gyro_vector_smoother(t, gyr, body, ref, sig, q[0], bias_walk=0.0)
