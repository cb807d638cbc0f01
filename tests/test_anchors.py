"""Relative anchor points and anchor matching (gates paper eqs 2-11 from the prose)."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.core.errors import InputError
from sportfusion.gates.anchors import (
    match_anchors,
    principal_azimuth,
    relative_anchors,
    rotate_z,
    survey_sides,
    turn_numbers,
)


def _course(rng, n=30):
    """A GS-like gate course: 21-27 m apart, alternating 1.5-3.5 m off the centre line, 12 deg slope."""
    sides = rng.choice([-1.0, 1.0]) * (-1.0) ** np.arange(n)
    y = sides * rng.uniform(1.5, 3.5, n)
    x = np.cumsum(np.r_[30.0, rng.uniform(21, 27, n - 1)])
    z = x * np.tan(np.deg2rad(12)) + rng.normal(0, 0.5, n)
    return np.stack([x, y, z], -1), np.where(y < 0, 1.0, -1.0)


def _detections(rng, g, turn, drift=5.0, nmiss=2, nspur=2):
    """Detected anchors: survey + 0.15 m noise + a smooth pass-1 drift (bridge up to `drift` m, 0.5 % scale),
    `nmiss` gates missed, `nspur` noise peaks between gates, then rotated, shifted and permuted."""
    n = g.shape[0]
    t = np.cumsum(np.r_[2.0, np.linalg.norm(np.diff(g, axis=0), axis=1) / rng.uniform(17, 23, n - 1)])
    det = g + rng.normal(0, 0.15, g.shape)
    s = (t - t[0]) / (t[-1] - t[0])
    dirn = rng.normal(0, 1, 3) * [1, 1, 0.2]
    dirn /= np.linalg.norm(dirn)
    det += (rng.uniform(0, drift) * np.sin(np.pi * s))[:, None] * dirn + rng.uniform(-0.005, 0.005) * (det - det[0])
    truth = np.arange(n)
    keep = np.ones(n, bool)
    keep[rng.choice(n, nmiss, replace=False)] = False
    det, t2, sd, truth = det[keep], t[keep], turn[keep].copy(), truth[keep]
    for _ in range(nspur):
        i = rng.integers(0, n - 1)
        f = rng.uniform(0.3, 0.7)
        pt = g[i] * (1 - f) + g[i + 1] * f + rng.normal(0, 1.0, 3) * [1, 1, 0.1]
        det = np.vstack([det, pt])
        t2 = np.r_[t2, t[i] * (1 - f) + t[i + 1] * f]
        sd = np.r_[sd, rng.choice([-1.0, 1.0])]
        truth = np.r_[truth, -1]
    alpha = rng.uniform(-np.pi, np.pi)
    det = rotate_z(det, alpha) + rng.uniform(-200, 200, 3)
    perm = rng.permutation(t2.size)
    return t2[perm], det[perm], sd[perm], truth[perm], alpha


def test_matching_success_rate_over_50_runs():
    rng = np.random.default_rng(2024)
    ok = 0
    for _ in range(50):
        g, turn = _course(rng)
        t, det, sd, truth, _ = _detections(rng, g, turn)
        res = match_anchors(t, det, sd, g)
        ok += np.array_equal(res.ids, truth)  # every gate right, both noise peaks and nothing else unmatched
    assert ok >= 48  # >= 95 % of the runs fully correct (issue 7)


def test_matching_recovers_rotation_and_offset():
    rng = np.random.default_rng(7)
    g, turn = _course(rng)
    t, det, sd, truth, alpha = _detections(rng, g, turn, drift=0.0, nmiss=0, nspur=0)
    res = match_anchors(t, det, sd, g)
    assert np.array_equal(res.ids, truth)
    ang = np.angle(np.exp(1j * (res.alpha + alpha)))
    assert abs(ang) < np.deg2rad(3.0)  # PCA azimuth within a few degrees
    assert np.median(np.linalg.norm(res.transform(det) - g[truth], axis=1)) < 3.0


def test_survey_sides_and_turn_numbers():
    rng = np.random.default_rng(3)
    g, turn = _course(rng)
    assert np.array_equal(survey_sides(g), turn)
    t = np.array([0.0, 1.2, 2.4, 4.8, 6.0, 6.5, 7.2])  # gate 4 missed (same side twice), a noise peak at 6.5 s
    side = np.array([1, -1, 1, 1, -1, 1, 1])
    n = turn_numbers(t, side)
    assert list(n[:5]) == [1, 2, 3, 5, 6] and n[6] == pytest.approx(7.0, abs=0.05)
    assert principal_azimuth(np.c_[np.arange(5.0), np.arange(5.0), np.zeros(5)]) == pytest.approx(np.pi / 4)


def test_relative_anchors_of_a_known_geometry():
    # the peak model (eqs 2-6) inverts its own geometry exactly: sensor 0.6 m above the snow, magnet 0.05 m
    # under it and 0.4 m to the right of the direction of travel
    p = np.array([[10.0, 2.0, -0.6]])
    v = np.array([[15.0, 0.0, 0.0]])
    magnet = np.array([10.0, 2.4, 0.05])
    r = np.linalg.norm(magnet - p[0])
    est = relative_anchors(p, v, [r], [1.0], [0.6], None, burial=0.05)
    assert np.allclose(est[0], magnet, atol=1e-9)
    left = relative_anchors(p, v, [r], [-1.0], [0.6], None, burial=0.05)
    assert np.allclose(left[0], [10.0, 1.6, 0.05], atol=1e-9)


def test_bad_surveys():
    g = np.zeros((2, 3))
    with pytest.raises(InputError, match="at least 3"):
        match_anchors(np.arange(4.0), np.zeros((4, 3)), np.ones(4), g)
    with pytest.raises(InputError, match="crossing"):
        match_anchors(np.arange(2.0), np.zeros((2, 3)), np.ones(2), np.eye(3) * 20)
