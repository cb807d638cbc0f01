"""Xsens MT Manager text exports written here: timing, wraps, quaternion and matrix, UTC."""

from __future__ import annotations

import calendar
from pathlib import Path

import numpy as np
import pytest

from sportfusion.core.errors import InputError
from sportfusion.core.rotations import dcm_from_quat, quat_canonical, quat_normalize
from sportfusion.ingest import Options, phyphox, read_recording, xsens

HEADER = """// Start Time: Unknown
// Update Rate: 100.0Hz
// Filter Profile: human (46.1)
// Option Flags: AHS Disabled ICC Disabled
// Firmware Version: 4.0.2
"""


def quats(n: int) -> np.ndarray:
    rng = np.random.default_rng(3)
    return quat_canonical(quat_normalize(rng.normal(size=(n, 4))))


def export(tmp_path: Path, orientation: str = "quat", time: str = "fine", sep: str = "\t", utc: bool = False) -> Path:
    n = 5
    q = quats(n)
    cols = {"PacketCounter": (65533 + np.arange(n)) % 65536}  # wraps after 2 samples
    if time == "fine":
        cols["SampleTimeFine"] = (2**32 - 200 + 100 * np.arange(n)) % 2**32  # 10 ms steps, wraps
    if utc:
        cols.update(
            {
                "UTC_Nano": np.array([250_000_000] * n),
                "UTC_Year": np.full(n, 2025),
                "UTC_Month": np.full(n, 3),
                "UTC_Day": np.full(n, 15),
                "UTC_Hour": np.full(n, 10),
                "UTC_Minute": np.zeros(n, int),
                "UTC_Second": np.array([0, 0, 0, 0, 0]),
                "UTC_Valid": np.array([0, 0, 7, 7, 7]),  # valid from the third sample on
            }
        )
    for k, s in enumerate("XYZ"):
        cols[f"Acc_{s}"] = np.arange(n) + 0.5 * k
        cols[f"Gyr_{s}"] = 0.01 * np.arange(n) - k
        cols[f"Mag_{s}"] = 0.1 * k + np.zeros(n)
    cols["FreeAcc_E"] = np.zeros(n)
    if orientation == "quat":
        for i in range(4):
            cols[f"Quat_q{i}"] = q[:, i]
    else:
        r = np.swapaxes(dcm_from_quat(q), -1, -2)  # R(q): sensor -> global
        for j in range(3):  # column-wise, as MT Manager writes it
            for i in range(3):
                cols[f"Mat[{i + 1}][{j + 1}]"] = r[:, i, j]
    lines = [sep.join(cols) + sep]
    for r_ in range(n):
        lines.append(
            sep.join(f"{cols[c][r_]:.9f}" if "Quat" in c or "Mat" in c else str(cols[c][r_]) for c in cols) + sep
        )
    p = tmp_path / f"MT_{orientation}_{time}.txt"
    p.write_text(HEADER + "\n".join(lines) + "\n")
    return p


def vals(rec, col):
    return np.asarray(rec.streams[0].columns[col], dtype=float)


@pytest.mark.parametrize("orientation", ["quat", "mat"])
def test_columns_orientation_and_sample_time_fine_wrap(tmp_path, orientation):
    p = export(tmp_path, orientation)
    head = p.read_bytes()[:4096]
    assert xsens.sniff(p, head) and not phyphox.sniff(p, head)
    rec = read_recording(p)
    assert rec.format == "xsens"
    np.testing.assert_allclose(rec.streams[0].t, [0.0, 0.01, 0.02, 0.03, 0.04], atol=1e-12)
    np.testing.assert_allclose(vals(rec, "acc_y"), np.arange(5) + 0.5)
    np.testing.assert_allclose(vals(rec, "gyr_z"), 0.01 * np.arange(5) - 2)
    np.testing.assert_allclose(vals(rec, "mag_z"), 0.2)
    q = np.column_stack([vals(rec, f"dev_q{i}") for i in range(4)])
    np.testing.assert_allclose(quat_canonical(q), quats(5), atol=2e-9)
    assert rec.meta["units"] == {"mag_x": "1", "mag_y": "1", "mag_z": "1"}
    assert rec.meta["header"]["Update Rate"] == "100.0Hz"
    assert "FreeAcc_E" in rec.meta["ignored_columns"]
    assert rec.epoch_utc is None and any("no absolute time" in w for w in rec.warnings)


def test_packet_counter_with_update_rate_and_utc_epoch(tmp_path):
    rec = xsens.read(export(tmp_path, time="counter", utc=True, sep=";"), Options())
    np.testing.assert_allclose(rec.streams[0].t, [0.0, 0.01, 0.02, 0.03, 0.04], atol=1e-12)  # 16-bit wrap
    utc = calendar.timegm((2025, 3, 15, 10, 0, 0)) + 0.25
    assert rec.epoch_utc == pytest.approx(utc - 0.02)  # third sample (t = 0.02 s) is the first valid UTC


def test_no_timing_column_is_an_error(tmp_path):
    p = tmp_path / "x.txt"
    p.write_text("// Firmware Version: 4.0.2\nAcc_X\tAcc_Y\n1\t2\n")
    with pytest.raises(InputError, match="neither SampleTimeFine nor PacketCounter, no Update Rate header"):
        xsens.read(p, Options())


def test_empty_sample_time_fine_and_utc_cells_fall_back_to_the_packet_counter(tmp_path):
    """As in MT Manager exports of Awinda data: SampleTimeFine and UTC columns present but empty."""
    head = "PacketCounter\tSampleTimeFine\tUTC_Nano\tUTC_Year\tUTC_Valid\tAcc_X\tMat[1][1]\n"
    rows = "".join(f"{n:05d}\t\t\t\t\t{a}\t1.0\n" for n, a in ((3583, 3.03), (3584, 3.04), (3586, 3.05)))
    p = tmp_path / "awinda.txt"
    p.write_text("// Update Rate: 60.0Hz\n" + head + rows)
    rec = read_recording(p)
    np.testing.assert_allclose(rec.streams[0].t, [0.0, 1 / 60, 3 / 60])  # a lost packet leaves its gap
    assert vals(rec, "acc_x").tolist() == [3.03, 3.04, 3.05]
    assert rec.meta["time_from"] == "PacketCounter" and rec.epoch_utc is None
    p.write_text(head + rows)
    with pytest.raises(InputError, match="SampleTimeFine and PacketCounter with empty cells, no Update Rate"):
        xsens.read(p, Options())
