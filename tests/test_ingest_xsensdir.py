"""Several IMUs on one athlete: a folder of Xsens exports with OpenSense's mapping file -> one session.

The fixture is OpenSense's own example (real MTw exports of 8 sensors of one trial, fixtures/opensense/,
Apache-2.0), cut to 200 samples per sensor, each sensor's window shifted by 5 samples: synchronised by their
shared PacketCounter the same counter value must land on the same row."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, run_cli

from sportfusion.core import io as sfio
from sportfusion.core import schema
from sportfusion.ingest import Options, read_recording
from sportfusion.ingest.xsensdir import read_mapping

FIX = ROOT / "fixtures" / "opensense"
SEGS = {"torso", "pelvis", "tibia_r", "femur_r", "tibia_l", "femur_l", "calcn_r", "calcn_l"}


def _counter(path: Path) -> np.ndarray:
    rows = [ln.split("\t")[0] for ln in path.read_text().splitlines() if ln and not ln.startswith(("/", "Packet"))]
    return np.array([int(r) for r in rows])


def test_mapping_file_is_read_as_opensense_does() -> None:
    m = read_mapping(FIX / "myIMUMappings.xml")
    assert m["prefix"] == "MT_012005D6_009-001" and m["extension"] == ".txt"
    assert m["sensors"]["_00B42279"] == "pelvis" and set(m["sensors"].values()) == SEGS


def test_the_example_trial_is_one_session_synchronised_by_the_packet_counter(tmp_path: Path) -> None:
    out = tmp_path / "s.parquet"
    r = run_cli(["ingest", str(FIX), "-o", str(out)])
    assert r.returncode == 0, r.stderr
    assert b"synchronised by the shared PacketCounter" in r.stderr
    table, meta = sfio.read_table(out)
    # 8 sensors x 200 samples, windows 5 samples apart: 200 + 7 * 5 rows on one 100 Hz clock
    assert table.num_rows == 235
    t = schema.floats(table, "t")
    assert np.allclose(np.diff(t), 0.01, atol=1e-9)
    # the pelvis keeps the plain names; the others are <segment>__<column>, units resolved
    for c in ("acc_x", "dev_q0", "torso__acc_x", "femur_l__acc_z", "calcn_r__dev_q3"):
        assert c in table.column_names, c
    assert schema.unit_of("femur_l__acc_z") == "m/s^2"
    # the same PacketCounter on the same row: the pelvis file starts 5 samples after the torso's
    pel = _counter(FIX / "MT_012005D6_009-001_00B42279.txt")
    tor = _counter(FIX / "MT_012005D6_009-001_00B42268.txt")
    a = schema.floats(table, "acc_x")
    b = schema.floats(table, "torso__acc_x")
    first_pel, first_tor = int(np.argmax(np.isfinite(a))), int(np.argmax(np.isfinite(b)))
    assert first_pel - first_tor == pel[0] - tor[0] == 5
    assert meta["sources"][0]["sync"].startswith("by the shared PacketCounter")
    # the values are the file's: the torso's first Acc_X
    first = (FIX / "MT_012005D6_009-001_00B42268.txt").read_text().splitlines()[6].split("\t")
    assert b[first_tor] == pytest.approx(float([v for v in first if v][1]))


def test_segment_option_instead_of_a_mapping(tmp_path: Path) -> None:
    d = tmp_path / "imus"
    d.mkdir()
    for f in ("MT_012005D6_009-001_00B42279.txt", "MT_012005D6_009-001_00B4227C.txt"):
        shutil.copy(FIX / f, d / f)
    rec = read_recording(d, None, Options(segments={"00B42279": "pelvis", "00B4227C": "femur_r"}))
    cols = {c for s in rec.streams for c in s.columns}
    assert "acc_x" in cols and "femur_r__acc_x" in cols


def _err(args: list[str]) -> str:
    r = run_cli(args)
    assert r.returncode == 1 and r.stdout == b"", r.stderr
    lines = r.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: ingest:"), lines
    return lines[0]


def test_bad_inputs_get_one_clear_line(tmp_path: Path) -> None:
    # a mapping naming a sensor without a file
    d = tmp_path / "missing"
    shutil.copytree(FIX, d)
    (d / "MT_012005D6_009-001_00B421E6.txt").unlink()
    assert "has no file" in _err(["ingest", str(d), "-o", str(tmp_path / "a.parquet")])
    # two files for one segment
    line = _err(
        [
            "ingest",
            str(FIX),
            "--segment",
            "00B42279=pelvis",
            "--segment",
            "00B42268=pelvis",
            "-o",
            str(tmp_path / "b.parquet"),
        ]
    )
    assert "two files for segment 'pelvis'" in line
    # sensors that never overlap in time
    d2 = tmp_path / "apart"
    d2.mkdir()
    src = (FIX / "MT_012005D6_009-001_00B42279.txt").read_text().splitlines()
    shifted = src[:6] + [f"{int(ln.split(chr(9))[0]) + 5000:05d}" + ln[5:] for ln in src[6:]]
    (d2 / "T_00B42279.txt").write_text("\n".join(src) + "\n")
    (d2 / "T_00B4227C.txt").write_text("\n".join(shifted) + "\n")
    line = _err(
        [
            "ingest",
            str(d2),
            "--segment",
            "00B42279=pelvis",
            "--segment",
            "00B4227C=femur_r",
            "-o",
            str(tmp_path / "c.parquet"),
        ]
    )
    assert "never overlap in time" in line
