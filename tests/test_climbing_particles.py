"""Hold likelihood (eqs 18-22), resampling, the particle filter and the FFBSm smoother."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from sportfusion.climbing import particles as pf
from sportfusion.climbing.particles import HoldModel, PFParams, grip_log_likelihood, hold_log_likelihood
from sportfusion.estimators.particles import systematic_resample

MODEL = HoldModel(radius=0.1, sigma=0.05, elsewhere_sigmas=3.0)
UP = np.array([0.0, 0.0, 1.0])


@pytest.mark.parametrize(
    "delta",
    [[0.0, 0.0, 0.0], [0.05, -0.05, 0.05], [0.099, 0.0, 0.0], [0.12, 0.0, 0.0], [0.1, 0.2, -0.1], [0.0, 0.0, 0.4]],
)
def test_hold_likelihood_is_eq_20(delta):
    centre = np.array([1.0, 0.2, 2.5])
    d = np.array(delta)
    gauss = multivariate_normal(np.zeros(3), MODEL.sigma**2 * np.eye(3))
    nd = np.linalg.norm(d)
    expected = gauss.pdf(np.zeros(3)) if nd < MODEL.radius else gauss.pdf((1 - MODEL.radius / nd) * d)
    assert np.isclose(np.exp(hold_log_likelihood(centre + d, centre, MODEL)), expected, rtol=1e-12)


def test_grip_likelihood_takes_the_maximum_over_holds_and_elsewhere():
    centres = np.array([[0.0, 0.0, 1.0], [0.5, 0.0, 1.0], [0.0, 0.0, 2.0]])
    ids = np.array([3, 7, 11])
    p = np.array([[0.44, 0.0, 1.02], [0.0, 0.0, 1.13], [2.0, 0.0, 1.0], [0.25, 0.0, 1.5]])
    ll, lab = grip_log_likelihood(p, centres, ids, MODEL)
    each = np.array([[hold_log_likelihood(q, c, MODEL) for c in centres] for q in p])
    log_ce = np.log(multivariate_normal(np.zeros(3), MODEL.sigma**2 * np.eye(3)).pdf(np.zeros(3))) - 4.5
    assert np.isclose(MODEL.log_elsewhere, log_ce)
    assert np.allclose(ll, np.maximum(each.max(axis=1), log_ce))
    assert lab.tolist() == [7, 3, -1, -1]


def test_systematic_resampling_keeps_the_expected_counts():
    rng = np.random.default_rng(0)
    w = rng.random(50) ** 3
    w /= w.sum()
    for u0 in (0.0, 0.37, 0.999):
        counts = np.bincount(systematic_resample(w, u0), minlength=50)
        assert counts.sum() == 50
        assert (counts >= np.floor(50 * w) - 1e-9).all() and (counts <= np.ceil(50 * w) + 1e-9).all()


def test_ffbsm_matches_the_formula_evaluated_naively():
    rng = np.random.default_rng(3)
    n, m = 6, 5
    t = np.arange(n) * 0.02
    v = rng.normal(0, 0.5, (n, 3))
    cov = np.array([np.diag(rng.uniform(2, 4, 3)) for _ in range(n)])
    model = pf._Model(t, v, cov, UP, 0.09)
    pos = rng.normal(0, 0.4, (n, m, 3))
    psi = rng.normal(0, 0.08, (n, m))
    w = rng.random((n, m))
    w /= w.sum(axis=1, keepdims=True)
    got = pf._ffbsm(pos, psi, w, model, 0)
    ref = np.empty_like(w)
    ref[-1] = w[-1]
    for k in range(n - 2, -1, -1):
        q = np.zeros((4, 4))
        q[:3, :3] = model.chol[k] @ model.chol[k].T
        q[3, 3] = model.yaw_sigma[k] ** 2
        pred = model.predict(k, pos[k], psi[k])
        f = np.array(
            [
                [
                    multivariate_normal(np.r_[pred[i], psi[k, i]], q).pdf(np.r_[pos[k + 1, j], psi[k + 1, j]])
                    for j in range(m)
                ]
                for i in range(m)
            ]
        )
        norm = w[k] @ f
        new = w[k] * (f @ (ref[k + 1] / norm))
        ref[k] = new / new.sum()
    assert np.allclose(got, ref, rtol=2e-4, atol=1e-7)


def _ladder(seed: int = 0):
    """Start holds 0 (x=0) and 1 (x=0.5); the hand starts at 0, climbs to 2 then 3 above hold 0."""
    centres = np.array([[0.0, 0.0, 1.2], [0.5, 0.0, 1.2], [0.05, 0.0, 1.8], [-0.1, 0.0, 2.4]])
    ids = np.array([0, 1, 2, 3])
    dt = 0.02
    knots = [(0, 1.0), (2, 1.0), (3, 1.0)]
    t_list, p_list, g_list = [], [], []
    t0 = 0.0
    for i, (h, dur) in enumerate(knots):
        tg = t0 + np.arange(0, dur, dt)
        t_list.append(tg)
        p_list.append(np.repeat(centres[h][None] + [0, -0.05, 0], tg.size, axis=0))
        g_list.append(np.ones(tg.size, bool))
        t0 = tg[-1] + dt
        if i + 1 < len(knots):
            tm = t0 + np.arange(0, 0.6, dt)
            s = (tm - t0) / 0.6
            sj = s**3 * (10 - 15 * s + 6 * s * s)
            a, b = centres[h], centres[knots[i + 1][0]]
            t_list.append(tm)
            p_list.append(a + [0, -0.05, 0] + sj[:, None] * (b - a))
            g_list.append(np.zeros(tm.size, bool))
            t0 = tm[-1] + dt
    t = np.concatenate(t_list)
    p = np.concatenate(p_list)
    grip = np.concatenate(g_list)
    v = np.gradient(p, t, axis=0)
    cov = np.repeat((0.03**2 * np.eye(3))[None], t.size, axis=0)
    return t, p, v, cov, grip, (ids, centres), (ids[:2], centres[:2])


def test_filter_tracks_and_smoother_resolves_the_start_hold():
    t, p, v, cov, grip, route, start = _ladder()
    res = pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=PFParams(particles=200), seed=1)
    k0 = res.k0
    assert k0 == 0 and res.resamples > 0
    err = np.linalg.norm(res.smooth_pos - p, axis=1)
    assert np.median(err) < 0.1
    last = np.flatnonzero(grip)[-1]
    assert res.label[last] == 3 and res.smooth_label[last] == 3
    # at the start the filter cannot know which start hold; the smoother can
    assert 0.2 < res.prob[0] < 0.8
    assert res.smooth_label[0] == 0 and res.smooth_prob[0] > 0.95
    assert np.linalg.norm(res.smooth_pos[0] - p[0]) < 0.1


def test_same_seed_same_output_and_seed_matters():
    t, p, v, cov, grip, route, start = _ladder()
    a = pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=PFParams(particles=50), seed=4)
    b = pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=PFParams(particles=50), seed=4)
    c = pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=PFParams(particles=50), seed=5)
    assert np.array_equal(a.smooth_pos, b.smooth_pos) and np.array_equal(a.pos, b.pos)
    assert not np.array_equal(a.pos, c.pos)


def test_descent_switches_to_the_wall_holds():
    t, p, v, cov, grip, route, start = _ladder()
    ids, centres = route
    # the route lacks hold 3: before the descent time the last grip is "elsewhere"
    short = (ids[:3], centres[:3])
    res = pf.run_particle_filter(
        t, v, cov, grip, short, start, UP, params=PFParams(particles=100), seed=0, smooth=False
    )
    last = np.flatnonzero(grip)[-1]
    assert res.label[last] == -1
    res = pf.run_particle_filter(
        t, v, cov, grip, short, start, UP, wall_holds=route, descent_time=t[last] - 0.5, seed=0, smooth=False
    )
    assert res.label[last] == 3


def test_position_noise_is_the_velocity_error_times_dt():
    """Eq 17 carries the transition velocity's error n_v ~ N(0, Sigma_v) through dT: the per-step
    position noise is Sigma_v dT^2 (as in the authors' implementation), the yaw noise yaw_psd dT."""
    rng = np.random.default_rng(7)
    n = 50
    t = np.cumsum(rng.uniform(0.008, 0.012, n))
    a = rng.normal(0, 0.1, (n, 3, 3))
    cov = a @ np.swapaxes(a, 1, 2) + 1e-3 * np.eye(3)
    model = pf._Model(t, rng.normal(0, 1, (n, 3)), cov, UP, 0.09)
    dt = np.diff(t)
    np.testing.assert_allclose(model.chol @ np.swapaxes(model.chol, 1, 2), cov[:-1] * dt[:, None, None] ** 2, rtol=1e-9)
    np.testing.assert_allclose(model.yaw_sigma**2, 0.09 * dt, rtol=1e-12)


def test_grip_likelihood_in_pieces_equals_hold_by_hold():
    """Many particles and holds: the product is split into pieces (BLAS threading threshold); same result."""
    rng = np.random.default_rng(4)
    centres = rng.uniform(0.0, 4.0, (40, 3))
    ids = np.arange(100, 140)
    p = rng.uniform(0.0, 4.0, (5000, 3))
    ll, lab = grip_log_likelihood(p, centres, ids, MODEL)
    each = np.array([hold_log_likelihood(p, c, MODEL) for c in centres])  # (40, 5000)
    best = each.max(axis=0)
    assert np.allclose(ll, np.maximum(best, MODEL.log_elsewhere), rtol=0, atol=1e-9)
    at_hold = best > MODEL.log_elsewhere
    assert np.array_equal(lab[at_hold], ids[each.argmax(axis=0)][at_hold]) and (lab[~at_hold] == -1).all()


def _filter_step_by_step(t, v, cov, grip, route, start, params, seed):
    """The filter one step at a time (as before it ran over blocks): the reference for the block form."""
    from sportfusion.estimators.particles import reweight

    rng = np.random.default_rng(seed)
    m, n = params.particles, t.size
    k0 = int(np.argmax(grip))
    model = pf._Model(t, v, cov, UP, params.yaw_psd)
    (r_ids, r_pos), (s_ids, s_pos) = route, start
    which = np.arange(m) % s_ids.size
    pos = s_pos[which] + rng.normal(0.0, params.start_sigma, (m, 3))
    psi = rng.normal(0.0, params.start_yaw_sigma, m)
    lab = s_ids[which]
    w = np.full(m, 1.0 / m)
    nk = n - 1 - k0
    add_pos = rng.standard_normal((nk, m, 3)) @ np.swapaxes(model.chol[k0 : n - 1], 1, 2) + model.ustep[k0:, None]
    add_psi = rng.standard_normal((nk, m)) * model.yaw_sigma[k0:, None]
    u_res = rng.random(n)
    horiz = model.step - model.ustep
    out = np.full((n, 3), np.nan)
    hist_w = np.zeros((n, m))
    for k in range(k0, n):
        if k > k0:
            j = k - 1
            pos = pos + add_pos[j - k0] + np.outer(np.cos(psi), horiz[j]) + np.outer(np.sin(psi), model.kstep[j])
            psi = psi + add_psi[j - k0]
        if grip[k]:
            ll, lab = grip_log_likelihood(pos, r_pos, r_ids, params.hold)
            w = reweight(w, ll)
        hist_w[k] = w
        sums = np.bincount(lab + 1, weights=w)
        sel = lab == int(np.argmax(sums)) - 1
        out[k] = w[sel] @ pos[sel] / sums[np.argmax(sums)]
        if grip[k] and 1.0 / (w @ w) < params.ess_fraction * m:
            idx = systematic_resample(w, u_res[k])
            pos, psi, lab, w = pos[idx], psi[idx], lab[idx], np.full(m, 1.0 / m)
    return out, hist_w


def test_block_filter_equals_the_step_by_step_filter():
    t, p, v, cov, grip, route, start = _ladder()
    grip = grip.copy()
    grip[:3] = False  # the filter starts at the first grip
    params = PFParams(particles=60, ess_fraction=0.97)  # resampling often: many blocks end early
    res = pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=params, seed=2, smooth=False)
    ref, _ = _filter_step_by_step(t, v, cov, grip, route, start, params, seed=2)
    assert res.resamples >= 3
    assert np.allclose(res.pos[3:], ref[3:], rtol=0, atol=1e-9)
    assert np.isnan(res.pos[:3]).all()
