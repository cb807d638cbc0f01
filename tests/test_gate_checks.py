"""gate-anchor's guard against a silent gross error (sportfusion.gates.checks): the matched share, crossings
that no gate explains, anchors that contradict the track; the verdicts and the widened std_."""

from __future__ import annotations

import numpy as np

from sportfusion.gates.anchors import survey_sides
from sportfusion.gates.checks import check_matching, gate_distances, widen_std


def _course(n=20):
    x = 30.0 + 25.0 * np.arange(n)
    y = 3.0 * (-1.0) ** np.arange(n)
    return np.stack([x, y, 0.2 * x], -1)


def test_a_correct_matching_is_trusted_even_with_missed_gates_and_a_noise_peak():
    survey = _course()
    ssd = survey_sides(survey)
    gates = np.array([1, 2, 3, 5, 6, 7, 8, 10, 11, 12, 13, 14, 15, 16, 17, 18])  # gates 1, 5, 9, 20 missed
    rng = np.random.default_rng(0)
    anchors = survey[gates] + rng.normal(0, 0.2, (gates.size, 3))
    ids = gates.copy()
    side = ssd[gates].copy()
    # a noise peak between two gates: unmatched and far from any gate, one of 17
    anchors = np.vstack([anchors, survey[4] + [12.0, 0.0, 2.4]])
    ids, side = np.r_[ids, -1], np.r_[side, 1.0]
    chk = check_matching(ids, anchors, side, survey, ssd, np.full(16, 0.05), np.full(16, 0.12))
    assert not chk.doubtful and not chk.hopeless and chk.message == ""
    assert chk.n_far == 1 and chk.far[-1] > 10


def test_a_lost_matching_is_refused_and_a_doubtful_one_named():
    survey = _course()
    ssd = survey_sides(survey)
    rng = np.random.default_rng(1)
    # the track 30 % too long: the crossings' anchors drift off their gates, most left unmatched
    gates = np.arange(1, 19)
    anchors = survey[1] + (survey[gates] - survey[1]) * 1.3 + rng.normal(0, 0.2, (gates.size, 3))
    ids = np.where(np.arange(gates.size) < 6, gates, -1)
    chk = check_matching(ids, anchors, ssd[gates], survey, ssd, np.full(6, 0.3), np.full(6, 0.12))
    assert chk.hopeless and chk.doubtful
    assert "only 6 of 18" in chk.message and "farther than 3 m" in chk.message
    # every crossing matched and on its gate, but an anchor the track cannot pass through: doubtful only
    anchors = survey[gates] + rng.normal(0, 0.2, (gates.size, 3))
    res = np.full(18, 0.05)
    res[7] = 1.5
    chk = check_matching(gates, anchors, ssd[gates], survey, ssd, res, np.full(18, 0.12))
    assert chk.doubtful and not chk.hopeless and "12 times its sigma" in chk.message
    # the same side only: a crossing beside a gate of the other side is unexplained
    d = gate_distances(survey[[2]] + [0.0, 0.0, 0.0], np.array([-ssd[2]]), survey, ssd)
    assert d[0] > 20


def test_widened_std_covers_either_track():
    rng = np.random.default_rng(2)
    pos = rng.normal(0, 30, (50, 3))
    other = pos + rng.normal(0, 20, (50, 3))
    std = np.full((50, 3), 0.1)
    w = widen_std(std, pos, other)
    assert np.all(np.abs(pos - other) <= w) and np.all(w >= std)
    assert np.allclose(widen_std(std, pos, pos), std)
