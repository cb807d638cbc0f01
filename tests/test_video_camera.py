"""Pinhole camera, slope surface and slope-plane homography (lib/skijump/video/camera.py)."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.core.errors import InputError
from sportfusion.skijump.hillfile import load_hill
from sportfusion.skijump.video.camera import Camera, Slope, apply_homography, focal_px


@pytest.fixture(scope="module")
def slope() -> Slope:
    return Slope(load_hill("oberstdorf_hs106").profile)


@pytest.fixture(scope="module")
def camera(slope: Slope) -> Camera:
    target = slope.point(92.0, 0.0)
    pos = slope.point(92.0, -40.0) + np.array([0.0, 0.0, -8.0])
    return Camera.look_at(pos, target, 900.0, 640, 360)


def test_focal_from_35mm_equivalent():
    assert focal_px(36.0, 1000) == pytest.approx(1000.0)
    assert focal_px(50.0, 1920) == pytest.approx(50 / 36 * 1920)


def test_target_on_the_optical_axis_and_level_horizon(camera: Camera, slope: Slope):
    px, depth = camera.project(slope.point(92.0, 0.0))
    assert px == pytest.approx([(640 - 1) / 2, (360 - 1) / 2], abs=1e-9)
    assert depth > 0
    # a level camera: the image x axis is horizontal (no z component in the hill frame)
    assert abs(camera.rotation[0, 2]) < 1e-12
    assert np.allclose(camera.rotation @ camera.rotation.T, np.eye(3), atol=1e-12)


def test_projection_ray_round_trip(camera: Camera):
    rng = np.random.default_rng(1)
    pts = camera.position + rng.normal(0, 1, (200, 3)) * [15, 5, 5] + camera.rotation[2] * 45
    px, depth = camera.project(pts)
    assert np.all(depth > 0)
    rays = camera.rays(px)
    want = (pts - camera.position) / np.linalg.norm(pts - camera.position, axis=1, keepdims=True)
    assert np.max(np.abs(rays - want)) < 1e-12
    # and the projection matrix agrees with project()
    h = np.c_[pts, np.ones(len(pts))] @ camera.P.T
    assert np.max(np.abs(h[:, :2] / h[:, 2:] - px)) < 1e-9


def test_points_behind_the_camera_are_nan(camera: Camera):
    px, depth = camera.project(camera.position - 10 * camera.rotation[2])
    assert depth < 0 and np.all(np.isnan(px))


def test_slope_homography_exact_on_the_tangent_plane(camera: Camera, slope: Slope):
    s0 = 90.0
    H = camera.slope_homography(slope, s0)
    p0 = slope.point(s0, 0.0)
    t, _ = slope.axes(p0[0])
    u = np.linspace(-6, 6, 13)
    y = np.linspace(-14, 14, 13)
    uu, yy = np.meshgrid(u, y)
    plane = p0 + uu[..., None] * t + yy[..., None] * np.array([0.0, 1.0, 0.0])
    px, _ = camera.project(plane)
    via_h = apply_homography(H, np.stack((uu, yy), -1))
    assert np.max(np.abs(via_h - px)) < 1e-8


def test_slope_tables_match_the_profile(slope: Slope):
    prof = slope.profile
    x = np.linspace(5, 130, 57)
    assert np.max(np.abs(slope.s_of_x(x) - prof.jump_length(x))) < 1e-3
    s = np.linspace(10, 110, 41)
    assert np.max(np.abs(slope.x_of_s(s) - prof.x_at_jump_length(s))) < 1e-3
    assert np.max(np.abs(slope.z_of_x(x) - prof.z(x))) < 2e-4


def test_foot_point_inverts_a_normal_offset(slope: Slope):
    x = np.linspace(40, 120, 9)
    d = np.linspace(-0.5, 3.0, 9)
    _, n = slope.axes(x)
    p = np.stack((x, np.zeros_like(x), slope.profile.z(x)), -1) + d[:, None] * n
    xp, dd = slope.foot(p[:, 0], p[:, 2])
    assert np.max(np.abs(xp - x)) < 1e-9
    assert np.max(np.abs(dd - d)) < 1e-9


def test_degenerate_camera_is_refused(slope: Slope):
    p = slope.point(90.0, -40.0)
    with pytest.raises(InputError, match="target"):
        Camera.look_at(p, p, 900.0, 640, 360)
    with pytest.raises(InputError, match="straight"):
        Camera.look_at(p, p + [0, 0, 10.0], 900.0, 640, 360)
