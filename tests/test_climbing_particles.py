"""Hold likelihood (eqs 18-22), resampling, the particle filter and the FFBSm smoother."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from sportfusion.climbing import particles as pf
from sportfusion.climbing.particles import HoldModel, PFParams, grip_log_likelihood, hold_log_likelihood
from sportfusion.core.errors import InputError
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


@pytest.mark.parametrize("grip_count", [None, 2.0])
def test_filter_tracks_and_smoother_resolves_the_start_hold(grip_count):
    t, p, v, cov, grip, route, start = _ladder()
    params = PFParams(particles=200, grip_count=grip_count)
    res = pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=params, seed=1)
    k0 = res.k0
    assert k0 == 0
    # the start holds' strata never meet (the other start is 0.5 m off every later hold); the true one's
    # evidence is larger by about the elsewhere penalty (4.5) per grip sample after the first move (the
    # paper: 2 grips of 50 samples), or per counted grip (tempered: 2 grips counted twice each)
    counted = 2 * 50 if grip_count is None else 2 * grip_count
    assert res.merged_at == -1 and res.start_evidence[0] - res.start_evidence[1] > 0.9 * 4.5 * counted
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


def test_tempered_grip_counts_the_same_whatever_its_length():
    """grip_count c: the weights of one grip's samples sum to c (a grip of 3 samples and one of 300 count
    alike); None: every grip sample weighs 1 (the paper).  Zero outside the grips."""
    grip = np.zeros(400, dtype=bool)
    grip[2:5] = grip[10:310] = grip[399:] = True
    w = pf.grip_weights(grip, 2.0)
    assert w[~grip].sum() == 0.0
    for sl in (slice(2, 5), slice(10, 310), slice(399, 400)):
        assert np.isclose(w[sl].sum(), 2.0) and np.ptp(w[sl]) < 1e-15
    assert np.array_equal(pf.grip_weights(grip, None), grip.astype(float))
    with pytest.raises(InputError):
        pf.grip_weights(grip, 0.0)


def test_tempered_filter_is_the_paper_filter_with_log_likelihoods_scaled():
    """With one grip sample per grip, grip_count=1 is the paper's filter (the weights are the same)."""
    t, p, v, cov, grip, route, start = _ladder()
    single = grip & ~np.concatenate(([False], grip[:-1]))  # only each grip's first sample
    a, b = (
        pf.run_particle_filter(t, v, cov, single, route, start, UP, params=PFParams(grip_count=c), seed=1)
        for c in (None, 1.0)
    )
    assert np.allclose(a.pos, b.pos, equal_nan=True) and np.allclose(a.smooth_pos, b.smooth_pos, equal_nan=True)


def _start(t, v, cov, grip, route, start, params, seed):
    """What both step-by-step references draw first, in the filter's order: the particles at the first grip,
    the process noise of every step, the resampling uniforms, and the grip weights."""
    rng = np.random.default_rng(seed)
    m, n = params.particles, t.size
    k0 = int(np.argmax(grip))
    model = pf._Model(t, v, cov, UP, params.yaw_psd)
    (r_ids, r_pos), (s_ids, s_pos) = route, start
    which = np.arange(m) % s_ids.size
    pos = s_pos[which] + rng.normal(0.0, params.start_sigma, (m, 3))
    psi = rng.normal(0.0, params.start_yaw_sigma, m)
    lab = s_ids[which]
    nk = n - 1 - k0
    add_pos = rng.standard_normal((nk, m, 3)) @ np.swapaxes(model.chol[k0 : n - 1], 1, 2) + model.ustep[k0:, None]
    add_psi = rng.standard_normal((nk, m)) * model.yaw_sigma[k0:, None]
    u_res = rng.random(n)
    horiz = model.step - model.ustep
    temper = pf.grip_weights(grip, params.grip_count)  # 1 per grip sample, or count / samples in the grip
    return m, n, k0, model, r_ids, r_pos, s_ids, which, pos, psi, lab, add_pos, add_psi, u_res, horiz, temper


def _predict(j, k0, pos, psi, add_pos, add_psi, horiz, model):
    """Eq 17 from step j to j + 1 for every particle, with the noise of ``_start``."""
    pos = pos + add_pos[j - k0] + np.outer(np.cos(psi), horiz[j]) + np.outer(np.sin(psi), model.kstep[j])
    return pos, psi + add_psi[j - k0]


def _filter_step_by_step(t, v, cov, grip, route, start, params, seed):
    """The filter one step at a time (as before it ran over blocks): the reference for the block form."""
    from sportfusion.estimators.particles import reweight

    m, n, k0, model, r_ids, r_pos, s_ids, which, pos, psi, lab, add_pos, add_psi, u_res, horiz, temper = _start(
        t, v, cov, grip, route, start, params, seed
    )
    w = np.full(m, 1.0 / m)
    out = np.full((n, 3), np.nan)
    hist_w = np.zeros((n, m))
    for k in range(k0, n):
        if k > k0:
            pos, psi = _predict(k - 1, k0, pos, psi, add_pos, add_psi, horiz, model)
        if grip[k]:
            ll, lab = grip_log_likelihood(pos, r_pos, r_ids, params.hold)
            w = reweight(w, ll * temper[k])
        hist_w[k] = w
        sums = np.bincount(lab + 1, weights=w)
        sel = lab == int(np.argmax(sums)) - 1
        out[k] = w[sel] @ pos[sel] / sums[np.argmax(sums)]
        if grip[k] and 1.0 / (w @ w) < params.ess_fraction * m:
            idx = systematic_resample(w, u_res[k])
            pos, psi, lab, w = pos[idx], psi[idx], lab[idx], np.full(m, 1.0 / m)
    return out, hist_w


@pytest.mark.parametrize("grip_count", [None, 2.0])
def test_block_filter_equals_the_step_by_step_filter(grip_count):
    t, p, v, cov, grip, route, start = _ladder()
    grip = grip.copy()
    grip[:3] = False  # the filter starts at the first grip
    # resampling often: many blocks end early; one particle set (the start holds compete)
    params = PFParams(particles=60, ess_fraction=0.97, separate_starts=False, grip_count=grip_count)
    res = pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=params, seed=2, smooth=False)
    ref, _ = _filter_step_by_step(t, v, cov, grip, route, start, params, seed=2)
    assert res.resamples >= (3 if grip_count is None else 1)  # tempered: the weights drop less
    assert np.allclose(res.pos[3:], ref[3:], rtol=0, atol=1e-9)
    assert np.isnan(res.pos[:3]).all()


def _stratified_step_by_step(t, v, cov, grip, route, start, params, seed):
    """The filter with one stratum per start hold, one step at a time, written from PFParams.separate_starts:
    each stratum is resampled within itself and keeps its total weight; at the end of a grip where every
    stratum's most likely cluster is the same hold, the stratum of the larger total takes all particles."""
    from scipy.special import logsumexp

    m, n, k0, model, r_ids, r_pos, s_ids, which, pos, psi, lab, add_pos, add_psi, u_res, horiz, temper = _start(
        t, v, cov, grip, route, start, params, seed
    )
    lw = np.zeros(m)
    out = np.full((n, 3), np.nan)
    strata = [np.flatnonzero(which == h) for h in range(s_ids.size)]
    merged_at = -1
    for k in range(k0, n):
        if k > k0:
            pos, psi = _predict(k - 1, k0, pos, psi, add_pos, add_psi, horiz, model)
        if grip[k]:
            ll, lab = grip_log_likelihood(pos, r_pos, r_ids, params.hold)
            lw = lw + ll * temper[k]
        ev = np.array([logsumexp(lw[s]) for s in strata])
        within = [np.exp(lw[s] - e) for s, e in zip(strata, ev, strict=True)]  # normalised in each stratum
        w = np.empty(m)
        for s, wi, ph in zip(strata, within, np.exp(ev - logsumexp(ev)), strict=True):
            w[s] = wi * ph
        sums = {h: w[lab == h].sum() for h in np.unique(lab)}
        best = max(sums, key=lambda h: (sums[h], -h))
        sel = lab == best
        out[k] = w[sel] @ pos[sel] / w[sel].sum()
        if not grip[k]:
            continue
        end = k == n - 1 or not grip[k + 1]
        heads = [
            max(np.unique(lab[s]), key=lambda h: (wi[lab[s] == h].sum(), -h))
            for s, wi in zip(strata, within, strict=True)
        ]
        idx = np.arange(m)
        if len(strata) > 1 and end and len(set(heads)) == 1 and heads[0] != -1:
            win = strata[int(np.argmax(ev))]
            idx = win[systematic_resample(within[int(np.argmax(ev))], u_res[k], m)]
            strata, lw, merged_at = [np.arange(m)], np.zeros(m), k
        else:
            for s, wi, e in zip(strata, within, ev, strict=True):
                if 1.0 / (wi @ wi) < params.ess_fraction * s.size:
                    idx[s] = s[systematic_resample(wi, u_res[k])]
                    lw[s] = e - np.log(s.size)
        pos, psi, lab = pos[idx], psi[idx], lab[idx]
    return out, merged_at


@pytest.mark.parametrize("grip_count", [None, 2.0])
@pytest.mark.parametrize("second_start_x", [0.5, 0.12])
def test_block_filter_with_start_strata_equals_the_step_by_step_filter(second_start_x, grip_count):
    """The strata's bookkeeping in blocks (evidence, resampling within a stratum, the merge) against the
    plain per-step form; 0.5: the strata never meet, 0.12: they meet at hold 2 and merge."""
    t, p, v, cov, grip, (ids, centres), _ = _ladder()
    centres = centres.copy()
    centres[1, 0] = second_start_x
    route, start = (ids, centres), (ids[:2], centres[:2])
    grip = grip.copy()
    grip[:3] = False
    params = PFParams(particles=60, ess_fraction=0.97, grip_count=grip_count)  # resampling often
    res = pf.run_particle_filter(t, v, cov, grip, route, start, UP, params=params, seed=2, smooth=False)
    ref, merged_at = _stratified_step_by_step(t, v, cov, grip, route, start, params, seed=2)
    assert (
        res.resamples >= (2 if grip_count is None else 1)
        and res.merged_at == merged_at
        and (merged_at > 0) == (second_start_x < 0.3)
    )
    assert np.allclose(res.pos[3:], ref[3:], rtol=0, atol=1e-9)


@pytest.mark.slow
def test_start_strata_find_the_start_hold_that_one_particle_set_loses():
    """Simulated trial 2018 (a tuning seed, not a bench seed): the hand starts on hold 0, then grips the
    wall 0.5 m from every hold; from the other start hold (0.52 m to the right) the integrated transition
    puts that wall grip 0.21 m from hold 2, which the grip likelihood prefers, so one particle set loses
    every particle of the true start before the next grips (hold 2, then 6 and 7) show it wrong.  Kept as
    a stratum, the true start's evidence is the larger when the strata meet.  Under the paper's noise model
    (every grip sample counted, white magnetometer noise), where this trial showed it."""
    from sportfusion.climbing.grips import grip_columns
    from sportfusion.climbing.holds import validate
    from sportfusion.climbing.sim import BoulderConfig, simulate_boulder
    from sportfusion.climbing.track import TrackOptions, track_holds
    from sportfusion.climbing.transition import TransitionParams
    from sportfusion.core import schema
    from sportfusion.core.session import with_columns

    sim = simulate_boulder(BoulderConfig(seed=2018))
    holds = validate(sim.holds, sim.holds_meta)
    table = with_columns(sim.session, grip_columns(sim.session)[0])
    start = sim.truth_meta["climbing"]["start_hold"]
    truth = np.column_stack([schema.floats(sim.truth, f"true_{a}") for a in "xyz"])
    for separate, ok, median in ((False, False, (0.4, 0.7)), (True, True, (0.05, 0.2))):
        paper = TrackOptions(
            pf=PFParams(separate_starts=separate, grip_count=None), transition=TransitionParams(mag_disturbance=0.0)
        )
        tr = track_holds(table, sim.meta, holds, paper)
        k0 = tr.pf.k0
        err = np.linalg.norm(tr.pf.smooth_pos - truth[tr.rows], axis=1)[k0:]
        assert (tr.pf.smooth_label[k0] == start) == ok
        assert median[0] < np.median(err) < median[1]
    ids = list(holds.start_positions(tr.route)[0])
    i = ids.index(start)
    # the strata meet on one hold only late in the ascent (about 21 s), by when the true one leads clearly
    assert tr.pf.merged_at > k0 + 1000
    assert tr.pf.start_evidence[i] - tr.pf.start_evidence[1 - i] > 1000
