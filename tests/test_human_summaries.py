"""Human summaries print km/h beside m/s (a coach reads km/h): the batch summary text."""

from __future__ import annotations

from sportfusion.batch import format_summary
from sportfusion.core.describe import ms_to_kmh


def test_ms_to_kmh():
    assert ms_to_kmh(25.0) == 90.0 and ms_to_kmh(1.0) == 3.6


def test_batch_summary_gives_km_h_beside_m_s():
    row = {
        "session": "jump1",
        "sport": "skijump",
        "status": "ok",
        "duration": 25.0,
        "max_speed": 28.0,
        "jump_length": 89.2,
        "video_jump_length": None,
        "takeoff_speed": 25.0,
        "pos_rms": 0.1,
        "vel_rms": 0.03,
    }
    head, _, line = format_summary([row]).splitlines()[:3]
    assert "v_max[m/s]" in head and "v_takeoff[m/s]" in head and head.count("[km/h]") == 2
    # every header is explained under the table
    legend = " ".join(format_summary([row]).splitlines()[3:])
    for name in ("time", "v_max", "jump", "video", "v_takeoff", "[km/h]", "pos_RMS, vel_RMS"):
        assert f"{name}:" in legend, name
    cells = line.split()
    assert cells[cells.index("28.00") + 1] == "100.8" and cells[cells.index("25.00") + 1] == "90.0"
    # a session without a speed prints '-' in both
    text = format_summary([{**row, "max_speed": None, "takeoff_speed": None}])
    assert text.splitlines()[2].split()[4:6] == ["-", "-"]
