"""A phone/watch GPX from ingest to a smoothed track, with no ellipsoidal height and no surveyed origin
(issue 15 item 2): the distances against gpxpy's own lengths of the file (an independent reader)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import gpxpy
import numpy as np
import pytest

from sportfusion.core import io as sfio

BIN = Path(sys.executable).parent


def _gpx(path: Path, with_ele: bool) -> Path:
    """A 5 min ski descent at 1 Hz, 8-15 m/s on a winding line, 0.3 m of position noise, times in order."""
    rng = np.random.default_rng(3)
    pts = []
    for i in range(300):
        lat = 47.40 + 9e-5 * i + rng.normal(0, 3e-6)
        lon = 10.29 + 1.5e-4 * np.sin(i / 25.0) + rng.normal(0, 4e-6)
        ele = f"<ele>{2100.0 - 0.8 * i + rng.normal(0, 0.3):.2f}</ele>" if with_ele else ""
        pts.append(
            f'<trkpt lat="{lat:.8f}" lon="{lon:.8f}">{ele}<time>2026-02-01T10:{i // 60:02d}:{i % 60:02d}Z</time></trkpt>'
        )
    path.write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n<gpx version="1.1" creator="watch" '
        'xmlns="http://www.topografix.com/GPX/1/1"><trk><name>Downhill</name><trkseg>'
        + "\n".join(pts)
        + "</trkseg></trk></gpx>\n"
    )
    return path


def _pipeline(track: Path, out: Path) -> tuple[subprocess.CompletedProcess, ...]:
    a = subprocess.run([str(BIN / "ingest"), str(track), "-o", str(out) + ".1"], capture_output=True, timeout=120)
    b = subprocess.run([str(BIN / "gps2hill"), str(out) + ".1", "--origin", "auto", "-o", str(out) + ".2"], capture_output=True, timeout=120)  # fmt: skip
    c = subprocess.run([str(BIN / "spline-smooth"), str(out) + ".2", "-o", str(out)], capture_output=True, timeout=120)
    return a, b, c


@pytest.mark.parametrize("with_ele", [True, False], ids=["msl-ele", "no-height"])
def test_watch_track_reaches_a_smoothed_local_track(tmp_path, with_ele):
    track = _gpx(tmp_path / "w.gpx", with_ele)
    out = tmp_path / "s.parquet"
    for proc in _pipeline(track, out):
        assert proc.returncode == 0, proc.stderr.decode()
    table, meta = sfio.read_table(out)
    doc = gpxpy.parse(track.read_text())
    dist = table.column("distance").to_numpy()[-1]
    if with_ele:
        assert meta["frame"]["height_ref"] == "msl" and table.column("z").null_count == 0
        assert dist == pytest.approx(doc.length_3d(), rel=0.015)
    else:
        assert meta["frame"]["height_ref"] == "none" and table.column("z").null_count == table.num_rows
        assert dist == pytest.approx(doc.length_2d(), rel=0.015)
    assert table.column("label").to_pylist() == ["Downhill"] * 300
