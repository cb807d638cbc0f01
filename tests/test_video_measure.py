"""Rendering a small landing clip and reading it back (render.py, measure.py, video-jumplength).

Truth comes from the renderer: the touch-down frame (first frame at or after
the skis touch) and the jump length of the skis' middle at that instant.
Tolerances are the issue's: touch-down frame within +-1, jump length within
0.5 m (the paper's manual reading accuracy).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from conftest import run_cli

from sportfusion.core import io as sfio
from sportfusion.core.errors import InputError
from sportfusion.skijump.hillfile import load_hill
from sportfusion.skijump.video.markers import make_markers, read_markers, write_markers
from sportfusion.skijump.video.measure import measure_video, read_jump, read_skis
from sportfusion.skijump.video.render import RenderOptions, parabolic_landing, render_landing
from sportfusion.skijump.video.skis import half_max_edge
from sportfusion.skijump.video.touchdown import fit_touchdown
from sportfusion.tools import video_jumplength as vj


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    """A 320x180, 50 fps, 1.3 s landing with a person and flags in the background."""
    folder = tmp_path_factory.mktemp("video")
    profile = load_hill("oberstdorf_hs106").profile
    traj = parabolic_landing(profile, 91.4, lateral=1.0)
    opts = RenderOptions(
        width=320,
        height=180,
        fps=50,
        before=0.8,
        after=0.5,
        field=22.0,
        clock=0.013,
        marker_noise=0.3,
        person=True,
        flags=True,
        seed=2,
    )
    path = folder / "landing.mp4"
    res = render_landing(path, traj, profile, opts)
    write_markers(folder / "landing.markers.csv", res.markers)
    return path, res


def test_rendered_clip_is_frame_exact(clip):
    path, res = clip
    cap = cv2.VideoCapture(str(path))
    assert cap.get(cv2.CAP_PROP_FPS) == pytest.approx(50.0)
    n = 0
    while cap.read()[0]:
        n += 1
    assert n == res.n_frames
    # the truth: the touch-down falls between frames (clock offset), jump length as asked
    assert res.touchdown_frame == math.ceil(res.touchdown_frame_exact)
    assert res.jump_length == pytest.approx(91.4, abs=1e-6)


def test_measure_reads_touchdown_and_length(clip):
    path, res = clip
    reading = measure_video(path, read_markers(path.with_name("landing.markers.csv")))
    assert abs(reading.touchdown_frame - res.touchdown_frame) <= 1
    assert abs(reading.touchdown_exact - res.touchdown_frame_exact) < 0.5
    assert abs(reading.jump_length - res.jump_length) < 0.5
    assert 0 < reading.std_jump_length < 0.5 and reading.confidence > 0.5
    # speed along the slope: the trajectory slides at 26 m/s cos(4.5 deg)
    assert reading.speed == pytest.approx(26.0 * math.cos(math.radians(4.5)), rel=0.05)


def test_cli_writes_a_jumps_row(clip, tmp_path):
    path, res = clip
    out = tmp_path / "jumps.parquet"
    r = run_cli(["video-jumplength", str(path), "-o", str(out), "--debug", str(tmp_path / "dbg"), "-q"])
    assert r.returncode == 0, r.stderr
    table, meta = sfio.read_table(out, kind="jumps")
    row = table.to_pylist()[0]
    assert row["video"] == str(path)
    assert abs(row["touchdown_frame"] - res.touchdown_frame) <= 1
    assert abs(row["jump_length"] - res.jump_length) < 0.5
    assert row["touchdown_time"] == pytest.approx(res.touchdown_frame_exact / 50.0, abs=0.5 / 50)
    assert row["video_fps"] == 50.0
    units = {f.name: (f.metadata or {}).get(b"unit") for f in pq.read_schema(out)}
    assert units["jump_length"] == b"m" and units["touchdown_time"] == b"s" and units["std_jump_length"] == b"m"
    assert meta["provenance"][-1]["tool"] == "video-jumplength"
    pngs = sorted(p.name for p in (tmp_path / "dbg").iterdir())
    assert "landing_series.png" in pngs and len(pngs) == 8


def test_calibrate_writes_a_grid_frame(clip, tmp_path):
    path, _ = clip
    out = tmp_path / "grid.png"
    r = CliRunner().invoke(vj.main, ["calibrate", str(path), "-o", str(out), "--step", "20"])
    assert r.exit_code == 0, r.stderr
    img = cv2.imread(str(out))
    assert img.shape == (180, 320, 3)


def _one_error(args: list[str]) -> str:
    """Run video-jumplength in-process: exit 1, nothing on stdout, one ``Error:`` line on stderr."""
    r = CliRunner().invoke(vj.main, args)
    assert r.exit_code == 1, (r.exit_code, r.stderr, r.exception)
    assert r.stdout_bytes == b""
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: video-jumplength: "), lines
    assert "internal error" not in lines[0]
    return lines[0]


def test_unreadable_video(tmp_path):
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"this is not a video\n" * 50)
    write_markers(
        tmp_path / "bad.markers.csv", make_markers([80, 81, 80, 81], [-14, -14, 14, 14], [1, 2, 3, 4], [5, 6, 7, 8])
    )
    assert "cannot read" in _one_error([str(bad), "-o", str(tmp_path / "o.parquet")])
    assert not (tmp_path / "o.parquet").exists()
    assert "does not exist" in _one_error([str(tmp_path / "none.mp4")])


def test_markers_outside_the_frame(clip, tmp_path):
    path, _ = clip
    m = read_markers(path.with_name("landing.markers.csv"))
    bad = make_markers(m.distance, m.y, np.r_[m.col[:-1], 400.0], m.row)
    write_markers(tmp_path / "m.csv", bad)
    line = _one_error([str(path), "--markers", str(tmp_path / "m.csv")])
    assert "outside the 320x180 video frame" in line


def test_missing_marker_file(clip, tmp_path):
    path, _ = clip
    assert "no marker file" in _one_error([str(path), "--markers", str(tmp_path / "x.csv")])


def test_no_jumper(clip, tmp_path):
    """A video of the empty slope: nothing crosses it."""
    path, _ = clip
    cap = cv2.VideoCapture(str(path))
    ok, frame = cap.read()
    assert ok
    empty = tmp_path / "empty.mp4"
    w = cv2.VideoWriter(str(empty), cv2.VideoWriter_fourcc(*"mp4v"), 50.0, (320, 180))
    rng = np.random.default_rng(0)
    for _ in range(30):
        noisy = np.clip(frame.astype(int) + rng.normal(0, 2, frame.shape), 0, 255).astype(np.uint8)
        w.write(noisy)
    w.release()
    markers = str(path.with_name("landing.markers.csv"))
    assert "no jumper found" in _one_error([str(empty), "--markers", markers])


def test_fit_touchdown_recovers_a_hinge():
    """Synthetic lowest-point series: a quadratic descent onto a drifting level at 30.37, noise 1 cm."""
    rng = np.random.default_rng(3)
    f = np.arange(10.0, 50.0)
    f_td = 30.37
    tau = np.maximum(f_td - f, 0)
    Y = -0.4 + 0.002 * (f - f_td) + 0.3 * tau + 0.004 * tau**2 + rng.normal(0, 0.01, f.size)
    fit = fit_touchdown(f, Y, 50.0, 0.01)
    assert fit.f_td == pytest.approx(f_td, abs=0.1)
    assert fit.c == pytest.approx(-0.4, abs=0.02)
    assert 0 < fit.u_frames < 0.2


def test_fit_touchdown_refuses_a_level_without_descent():
    rng = np.random.default_rng(4)
    f = np.arange(0.0, 30.0)
    with pytest.raises(InputError):
        fit_touchdown(f, 0.01 * rng.normal(size=f.size), 50.0, 0.01)
    with pytest.raises(InputError):  # descending all along: never lands
        fit_touchdown(f, 5.0 - 0.2 * f + 0.01 * rng.normal(size=f.size), 50.0, 0.01)


@pytest.mark.parametrize("edge", [10.0, 10.3, 10.75])
def test_half_max_edge_is_sub_pixel(edge: float):
    """A dark bar above snow, its lower edge at `edge` [px], blurred by a box of 3 px: the half-maximum row."""
    rows = np.arange(30, dtype=float)
    fine = np.linspace(-0.5, 29.5, 3001)
    cover = ((fine <= edge) & (fine >= 4.0)).astype(float)
    blur = np.convolve(cover, np.ones(301) / 301, mode="same")  # 3 px box
    img = np.array([blur[(fine >= r - 0.5) & (fine < r + 0.5)].mean() for r in rows]) * 150
    diff = np.tile(img[:, None], (1, 3)).astype(np.uint8)
    low = int(np.max(np.flatnonzero(diff[:, 0] > 10)))
    got = half_max_edge(diff, np.array([1]), np.array([low]), depth=6)
    assert got[0] == pytest.approx(edge, abs=0.15)


def test_too_few_frames_of_the_landing(clip):
    """A landing seen in only 6 frames (a narrow view at 25 /s): a clear message, not 'no touch-down'."""
    path, _ = clip
    markers = read_markers(path.with_name("landing.markers.csv"))
    info, obs = read_skis(path, markers)
    assert len(obs) >= 8
    with pytest.raises(InputError, match="too few frames around the landing"):
        read_jump(obs[:6], markers, info.fps)
