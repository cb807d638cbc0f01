"""Marker calibration table (CSV) and the slope mapping fitted to it (markers.py, calibration.py)."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.core.errors import InputError
from sportfusion.skijump.hillfile import load_hill
from sportfusion.skijump.video.calibration import fit_slope_map
from sportfusion.skijump.video.camera import Camera, Slope
from sportfusion.skijump.video.markers import (
    check_in_frame,
    make_markers,
    markers_path_for,
    read_markers,
    write_markers,
)


@pytest.fixture(scope="module")
def slope() -> Slope:
    return Slope(load_hill("oberstdorf_hs106").profile)


def _camera(slope: Slope, side: float = -1.0, s_cam: float = 92.0) -> Camera:
    pos = slope.point(s_cam, side * 40.0) + np.array([0.0, 0.0, -7.0])
    return Camera.look_at(pos, slope.point(92.0, 0.0), 1300.0, 960, 540)


def _markers(slope: Slope, cam: Camera):
    s = np.arange(70.0, 115.0)
    d = np.concatenate([s, s])
    y = np.concatenate([np.full(s.size, -14.0), np.full(s.size, 14.0)])
    px, depth = cam.project(slope.point(d, y))
    ok = cam.inside(px, 1.0) & (depth > 0)
    return make_markers(d[ok], y[ok], px[ok, 0], px[ok, 1])


def test_csv_round_trip(tmp_path, slope: Slope):
    m = _markers(slope, _camera(slope))
    path = tmp_path / "landing.markers.csv"
    write_markers(path, m)
    back = read_markers(path)
    assert len(back) == len(m)
    assert np.array_equal(back.distance, m.distance) and np.array_equal(back.y, m.y)
    assert np.max(np.abs(back.pixels - m.pixels)) <= 0.005 + 1e-12  # 2 decimals written
    assert markers_path_for("cam/landing.mp4").as_posix() == "cam/landing.markers.csv"


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "empty"),
        ("distance,y,col\n1,2,3\n", "lacks column"),
        ("distance,y,col,row\n85,-14,1,x\n", "expected a number"),
        ("distance,y,col,row\n85,-14,1,2\n86,-14,3,4\n85,14,5,6\n", "at least 4"),
        ("distance,y,col,row\n85,-14,1,2\n86,-14,3,4\n87,-14,5,6\n88,-14,7,8\n", "two lines"),
        ("distance,y,col,row\n85,-14,1,2\n85,-14,3,4\n85,14,5,6\n86,14,7,8\n", "twice"),
    ],
)
def test_bad_marker_files(tmp_path, text: str, match: str):
    path = tmp_path / "m.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=match):
        read_markers(path)


def test_missing_marker_file(tmp_path):
    with pytest.raises(InputError, match="cannot read the marker file"):
        read_markers(tmp_path / "nope.csv")


def test_marker_outside_the_frame_is_named(slope: Slope):
    m = _markers(slope, _camera(slope))
    check_in_frame(m, 960, 540)
    bad = make_markers(m.distance, m.y, np.r_[m.col[:-1], 2000.0], m.row)
    with pytest.raises(InputError, match=r"outside the 960x540 video frame"):
        check_in_frame(bad, 960, 540)


@pytest.mark.parametrize("s_cam", [92.0, 84.0, 100.0])
def test_curved_map_reads_slope_points(slope: Slope, s_cam: float):
    """Exact marker pixels: the curved map reads distance to < 2 cm within +-6 m of its centre.

    The plain slope-plane homography on the same markers is worse across the
    slope (the sagitta of the profile, seen nearly edge-on) -- the reason for
    the curvature terms.
    """
    cam = _camera(slope, s_cam=s_cam)
    m = _markers(slope, cam)
    s = np.linspace(86.0, 98.0, 25)
    y = np.linspace(-3.0, 3.0, 25)
    px, _ = cam.project(slope.point(s, y))
    curved = fit_slope_map(m, 92.0)
    plane = fit_slope_map(m, 92.0, curved=False)
    assert curved.curved and not plane.curved
    s_c, y_c = curved.to_slope(px)
    s_p, y_p = plane.to_slope(px)
    assert np.max(np.abs(s_c - s)) < 0.02
    assert np.max(np.abs(y_c - y)) < 0.06
    assert np.max(np.abs(y_c - y)) < np.max(np.abs(y_p - y)) / 3
    # to_image inverts to_slope
    assert np.max(np.abs(curved.to_image(s_c, y_c) - px)) < 1e-6


@pytest.mark.parametrize(("side", "sign"), [(-1.0, 1.0), (1.0, -1.0)])
def test_away_sign_points_to_the_far_side(slope: Slope, side: float, sign: float):
    m = _markers(slope, _camera(slope, side=side))
    assert fit_slope_map(m, 92.0).away_sign(92.0) == sign


def test_markers_on_one_line_only_are_refused():
    with pytest.raises(InputError, match="two"):
        make_markers([80, 81, 82, 83], [14, 14, 14, 14], [1, 2, 3, 4], [5, 6, 7, 8])
