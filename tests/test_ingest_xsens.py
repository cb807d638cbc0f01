"""Xsens MT Manager text exports written here: timing, wraps, quaternion and matrix, UTC."""

from __future__ import annotations

import calendar
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sportfusion.core import io as sfio
from sportfusion.core.errors import InputError
from sportfusion.core.rotations import (
    dcm_from_quat,
    euler_from_dcm,
    quat_canonical,
    quat_from_dcm,
    quat_multiply,
    quat_normalize,
)
from sportfusion.ingest import Options, phyphox, read_recording, xsens

BIN = Path(sys.executable).parent
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
    # converted to q_BO (NED -> sensor): q_BO = q_C (x) q_GS, q_C the rotation from the frame the reader
    # settled on (no Coordinate system line: ENU, unless Acc/Mag fit another) to NED, written out by hand
    q_c = {"ENU": [0.0, 0.5**0.5, 0.5**0.5, 0.0], "NWU": [0.0, 1.0, 0.0, 0.0], "NED": [1.0, 0.0, 0.0, 0.0]}
    q = np.column_stack([vals(rec, f"dev_q{i}") for i in range(4)])
    want = quat_multiply(np.array(q_c[rec.meta["frame"]]), quats(5))
    np.testing.assert_allclose(quat_canonical(q), quat_canonical(want), atol=2e-9)
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


LONG_HEADER = """// General information:
//  MT Manager version: 2022.2.0
//  XDA version: 2022.2.0 build 7381 rev 124627 built on 2023-07-19
// Device information:
//  DeviceId: 00B4D6D1
//  ProductCode: MTW2-3A7G6
//  Firmware Version: 4.6.0
//  Hardware Version: 2.0.0
// Device settings:
//  Filter Profile: human(46.1)
//  Option Flags: Orientation Smoother Disabled, Position/Velocity Smoother Disabled, AHS Disabled, ICC Disabled
// Coordinate system: {frame}
"""
#: G -> NED for each frame MT Manager offers, written out independently of the reader
C_NG = {
    "ENU": np.array([[0.0, 1, 0], [1, 0, 0], [0, 0, -1]]),
    "NWU": np.array([[1.0, 0, 0], [0, -1, 0], [0, 0, -1]]),
    "NED": np.eye(3),
}
M_NED = np.array([20.0, 1.5, 43.0])  # field at the site [uT]: declination ~4 deg east, dip ~65 deg


def truth(n: int = 6):
    """True attitudes q_BO (NED -> sensor) and what a sensor at rest reads: specific force and field."""
    rng = np.random.default_rng(11)
    from sportfusion.core.rotations import quat_from_euler

    q = quat_from_euler(rng.uniform(-0.6, 0.6, n), rng.uniform(-0.6, 0.6, n), rng.uniform(-np.pi, np.pi, n))
    m_bo = dcm_from_quat(q)
    acc = m_bo @ np.array([0.0, 0.0, -9.81])  # at rest the specific force points up
    mag = m_bo @ (M_NED / np.linalg.norm(M_NED))  # MT Manager normalises the field
    return q, m_bo, acc, mag


def mt_file(tmp_path, frame, stated, orientation="quat", imu=True, sep="\t", rate_line=False, name="mt.txt"):
    q, m_bo, acc, mag = truth()
    r_gs = C_NG[frame].T @ np.swapaxes(m_bo, -1, -2)  # sensor -> G
    cols: dict[str, list[str]] = {"PacketCounter": [f"{k:05d}" for k in range(6)], "SampleTimeFine": [""] * 6}
    if imu:
        for k, a in enumerate("XYZ"):
            cols[f"Acc_{a}"] = [f"{v:.9f}" for v in acc[:, k]]
            cols[f"Mag_{a}"] = [f"{v:.9f}" for v in mag[:, k]]
    if orientation == "quat":
        qg = quat_from_dcm(np.swapaxes(r_gs, -1, -2))  # quat_from_dcm(R^T) is the quaternion of R
        for i in range(4):
            cols[f"Quat_q{i}"] = [f"{v:.9f}" for v in qg[:, i]]
    elif orientation == "mat":
        for i in range(3):
            for j in range(3):
                cols[f"Mat[{i + 1}][{j + 1}]"] = [f"{v:.9f}" for v in r_gs[:, i, j]]
    else:
        roll, pitch, yaw = euler_from_dcm(np.swapaxes(r_gs, -1, -2))  # z-y-x angles of R_GS in G
        cols.update(
            {k: [f"{np.degrees(v):.7f}" for v in a] for k, a in (("Roll", roll), ("Pitch", pitch), ("Yaw", yaw))}
        )
    cols["Status"] = ["NaN"] * 6
    head = LONG_HEADER.format(frame=stated) if stated else LONG_HEADER.split("// Coordinate")[0]
    if rate_line:
        head += "//  Update Rate: 100.0Hz\n"
    lines = [sep.join(cols)] + [sep.join(c[r] for c in cols.values()) for r in range(6)]
    p = tmp_path / name
    p.write_text(head + "\n".join(lines) + "\n")
    return p, q


def q_of(rec, prefix):
    return np.column_stack([vals(rec, f"{prefix}{i}") for i in range(4)])


@pytest.mark.parametrize("frame", ["ENU", "NWU", "NED"])
@pytest.mark.parametrize("sep", ["\t", ",", ";", " "], ids=["tab", "comma", "semicolon", "space"])
def test_stated_frame_converted_to_q_bo_and_checked_against_the_field(tmp_path, frame, sep):
    p, q_true = mt_file(tmp_path, frame, frame, sep=sep)
    assert xsens.sniff(p, p.read_bytes()[:4096])
    rec = read_recording(p, opts=Options(rate=100.0))
    assert rec.format == "xsens" and rec.meta["frame"] == frame
    np.testing.assert_allclose(rec.streams[0].t, np.arange(6) / 100.0)  # PacketCounter at --rate
    np.testing.assert_allclose(quat_canonical(q_of(rec, "dev_q")), quat_canonical(q_true), atol=1e-8)
    check = rec.meta["frame_check"][frame]
    assert check["passes"] and abs(check["north_deg"] - np.degrees(np.arctan2(1.5, 20.0))) < 1e-3
    assert not any("fits" in w for w in rec.warnings)
    assert "Status" in rec.meta["ignored_columns"]


def test_a_mislabelled_frame_is_caught_by_the_magnetometer(tmp_path):
    p, q_true = mt_file(tmp_path, "ENU", "NWU")  # data in ENU, header says NWU
    rec = xsens.read(p, Options(rate=100.0))
    assert rec.meta["frame"] == "ENU"
    np.testing.assert_allclose(quat_canonical(q_of(rec, "dev_q")), quat_canonical(q_true), atol=1e-8)
    w = next(w for w in rec.warnings if "fits" in w)
    assert "stated NWU puts magnetic north at -86 deg" in w and "ENU fits" in w


@pytest.mark.parametrize("orientation", ["quat", "mat", "euler"])
def test_orientation_only_export_gives_q0_q3_and_needs_a_rate(tmp_path, orientation):
    p, q_true = mt_file(tmp_path, "ENU", "ENU", orientation=orientation, imu=False, sep=";")
    assert xsens.sniff(p, p.read_bytes()[:4096])
    with pytest.raises(InputError, match=r"--rate HZ"):
        read_recording(p)  # long header, no Update Rate, SampleTimeFine empty
    rec = read_recording(p, opts=Options(rate=60.0))
    np.testing.assert_allclose(rec.streams[0].t, np.arange(6) / 60.0)
    assert not any(k.startswith(("acc", "dev_q")) for k in rec.streams[0].columns)
    np.testing.assert_allclose(quat_canonical(q_of(rec, "q")), quat_canonical(q_true), atol=1e-7)
    assert rec.meta["time_from"] == "PacketCounter"


def test_rate_from_a_long_header_and_the_command_line(tmp_path):
    p, _ = mt_file(tmp_path, "NED", "NED", rate_line=True)
    rec = read_recording(p)
    np.testing.assert_allclose(rec.streams[0].t, np.arange(6) / 100.0)
    out = tmp_path / "s.parquet"
    p2, _ = mt_file(tmp_path, "ENU", "ENU", imu=False, name="ori.txt")
    cmd = [str(BIN / "ingest"), str(p2), "--rate", "50", "-o", str(out)]
    proc = subprocess.run(cmd, capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr.decode()
    table, _ = sfio.read_table(out, kind="session")
    assert table.column_names[:5] == ["t", "q0", "q1", "q2", "q3"]
    np.testing.assert_allclose(table.column("t").to_numpy(), np.arange(6) / 50.0)


def test_zero_quaternion_and_empty_cells_are_null(tmp_path):
    """An orientation that is no rotation (MT Manager's zero quaternion before the filter has a solution) and
    empty cells read as null, counted; the other rows convert as usual."""
    p = export(tmp_path)
    lines = p.read_text().splitlines()
    head = lines[len(HEADER.splitlines())].split("\t")
    row = lines[len(HEADER.splitlines()) + 2].split("\t")
    for i in range(4):
        row[head.index(f"Quat_q{i}")] = "0.000000000"
    row[head.index("Acc_X")] = ""  # a packet without this value
    lines[len(HEADER.splitlines()) + 2] = "\t".join(row)
    p.write_text("\n".join(lines) + "\n")
    rec = xsens.read(p, Options())
    q = np.column_stack([vals(rec, f"dev_q{i}") for i in range(4)])
    assert np.isnan(q[1]).all() and np.isfinite(np.delete(q, 1, axis=0)).all()
    np.testing.assert_allclose(np.linalg.norm(np.delete(q, 1, axis=0), axis=1), 1.0, atol=1e-9)
    acc_x = vals(rec, "acc_x")
    assert np.isnan(acc_x[1]) and np.isfinite(np.delete(acc_x, 1)).all()
    (line,) = [w for w in rec.warnings if "invalid markers" in w]
    assert "1 orientation(s) that are no rotation" in line
