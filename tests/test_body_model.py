"""body-model: de Leva's segments, the functional calibration and the body model against the independent
full-body skier of ``simulate gates --body`` (Dempster's segments, its own kinematics), and gate-anchor's
CoM from it.  Tolerances: measured values (commit message of issue 35) with margin."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run_cli

from sportfusion.body.anthropometry import body_params
from sportfusion.core import io as sfio
from sportfusion.core import schema


def test_de_leva_segments_scale_with_height_and_mass() -> None:
    b = body_params(1.741, 73.0, "male", equipment=0.0)
    assert b.total_mass == pytest.approx(73.0, rel=1e-9)  # the seven segments carry all of de Leva's mass
    assert b.lengths["thigh"] == pytest.approx(0.4222, abs=1e-4)  # Table 4, HJC-KJC 422.2 mm
    assert b.lengths["shank"] == pytest.approx(0.4403, abs=1e-4)
    assert b.com["femur_r"][0] == pytest.approx(0.1416 * 73.0)  # Table 4, 14.16 %
    assert b.com["femur_r"][1][2] == pytest.approx(0.4095 * 0.4222, abs=1e-4)
    b2 = body_params(1.741, 73.0, "male", equipment=12.0)
    assert b2.total_mass == pytest.approx(85.0)
    f = body_params(1.735, 61.9, "female", equipment=0.0)
    assert f.total_mass == pytest.approx(61.9, rel=2e-4) and f.lengths["thigh"] == pytest.approx(0.3685, abs=1e-4)
    assert f.lengths["shank"] == pytest.approx(0.4386, abs=1e-4)  # Table 4, KJC-AJC 438.6 mm
    # Table 4's segments (arms and legs twice) make up the whole body: 100 % within its rounding
    from sportfusion.body.anthropometry import MASS_PCT

    for sex, m in MASS_PCT.items():
        limbs = ("upper_arm", "forearm", "hand", "thigh", "shank", "foot")
        assert sum(m.values()) + sum(m[k] for k in limbs) == pytest.approx(100.0, abs=0.05), sex


@pytest.fixture(scope="module")
def skier(tmp_path_factory):
    d = tmp_path_factory.mktemp("skier")
    r = run_cli(
        ["simulate", "gates", "--seed", "2", "--n-gates", "10", "--body", "--raw", str(d / "raw"), "--truth",
         str(d / "truth.parquet"), "-q", "-o", str(d / "sim.parquet")]
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    ing = run_cli(["ingest", "-q", str(d / "raw")])
    assert ing.returncode == 0, ing.stderr
    body = run_cli(["body-model", "-q", "--height", "1.8", "--mass", "78", "--opensense", str(d / "o.sto")], ing.stdout)
    assert body.returncode == 0, body.stderr
    (d / "body.parquet").write_bytes(body.stdout)
    return d


def _xyz(table, prefix):
    return schema.float_columns(table, [f"{prefix}{a}" for a in "xyz"])


def test_joint_centres_and_relative_com_against_the_independent_skier(skier) -> None:
    est, meta = sfio.read_table(skier / "body.parquet")
    truth, _ = sfio.read_table(skier / "truth.parquet")
    assert meta["body_model"]["calibration_s"][0] < 1.0  # found at the start
    t, tt = schema.floats(est, "t"), schema.floats(truth, "t")
    ok = np.isfinite(schema.floats(est, "com_rel_x"))
    assert ok.mean() > 0.99
    # (measured on seed 2: relative CoM 43 mm, hips 13 mm, knees 15 mm, ankles 60 mm, skis 90 mm)
    for name, tol in (("com", 0.07), ("hip_r", 0.04), ("knee_l", 0.05), ("ankle_r", 0.12), ("ski_l", 0.15)):
        e = _xyz(est, f"{name}_rel_")[ok]
        tr = np.column_stack([np.interp(t[ok], tt, c) for c in _xyz(truth, f"true_{name}_rel_").T])
        err = np.linalg.norm(e - tr, axis=1)
        assert err.mean() < tol, (name, err.mean())
    assert (skier / "o.sto").read_text().startswith("sportfusion body-model\nDataRate=")


@pytest.mark.slow
def test_gate_anchor_com_against_the_independent_skier(skier) -> None:
    det = run_cli(["detect-events", "-q", "--kind", "gates", str(skier / "body.parquet")])
    assert det.returncode == 0, det.stderr
    ga = run_cli(["gate-anchor", "-q", "--gates", str(skier / "raw" / "survey.parquet")], det.stdout)
    assert ga.returncode == 0, ga.stderr
    (skier / "run.parquet").write_bytes(ga.stdout)
    ev = run_cli(["evaluate", str(skier / "run.parquet"), "--truth", str(skier / "truth.parquet"), "--format", "text"])
    assert ev.returncode == 0 and b"Table 2 layout" in ev.stdout, ev.stderr
    from sportfusion.evaluate.com import table1

    est, _ = sfio.read_table(skier / "run.parquet")
    truth, _ = sfio.read_table(skier / "truth.parquet")
    t1 = table1(est, truth)
    # a 10-gate course (27 deg average slope); measured: 0.3-0.4 m, speed sd 0.08 m/s (30 gates: 0.19 m, 0.07 m/s)
    assert t1["position [m]"][0][0] < 0.6
    assert t1["speed [m/s]"][0][1] < 0.2
    assert "std_com_x" in est.column_names


def _one_error(args, stdin=b""):
    r = run_cli(args, stdin)
    assert r.returncode == 1 and r.stdout == b"", r.stderr
    lines = r.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: body-model:"), lines
    return lines[0]


def test_bad_input_one_line(skier) -> None:
    data = (skier / "body.parquet").read_bytes()
    assert "out of the human range" in _one_error(["body-model", "--height", "3.1", "--mass", "78"], data)
    assert "out of the human range" in _one_error(["body-model", "--height", "1.8", "--mass", "400"], data)
    # still from start to end: no squats
    assert "no calibration posture found" in _one_error(
        ["body-model", "--height", "1.8", "--mass", "78", "--calibration", "0.2,2.5"], data
    )
    # a session without the other segments' sensors
    import pyarrow as pa

    table, meta = sfio.read_table(skier / "body.parquet")
    keep = [c for c in table.column_names if not c.startswith("head__")]
    bad = sfio.table_to_bytes(pa.table({c: table.column(c) for c in keep}), meta)
    assert "no sensor for segment(s) head" in _one_error(["body-model", "--height", "1.8", "--mass", "78"], bad)
