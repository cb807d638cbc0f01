"""gate-anchor: the sacrum trajectory against the simulator's truth, matching, per-turn figures, bad input."""

from __future__ import annotations

import io

import numpy as np
import pyarrow as pa
import pytest
from conftest import run_cli

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core.schema import floats
from sportfusion.core.session import with_columns
from sportfusion.gates.crossings import detect_gate_table, gate_columns
from sportfusion.gates.eks import EKSParams, run_eks, transition
from sportfusion.gates.pipeline import GateAnchorParams, gate_anchor_table
from sportfusion.gates.sim import GatesConfig, simulate_gates


@pytest.fixture(scope="module")
def sim():
    s = simulate_gates(GatesConfig(seed=21))
    det = detect_gate_table(s.session)
    return s, with_columns(s.session, gate_columns(s.session, det))


def _errors(s, out, run_only=True):
    t = floats(out, "t")
    pos = np.column_stack([floats(out, c) for c in "xyz"])
    vel = np.column_stack([floats(out, c) for c in ("vx", "vy", "vz")])
    tp = np.column_stack([floats(s.truth, f"true_{c}") for c in "xyz"])
    tv = np.column_stack([floats(s.truth, f"true_v{c}") for c in "xyz"])
    run = (t > s.crossings["t"][0] - 2) & (t < s.crossings["t"][-1] + 2)
    e = np.linalg.norm(pos - tp, axis=1)[run]
    se = (np.linalg.norm(vel, axis=1) - np.linalg.norm(tv, axis=1))[run]
    std = np.column_stack([floats(out, f"std_{c}") for c in "xyz"])[run]
    return e, se, np.abs(pos - tp)[run], std


@pytest.mark.slow
def test_cli_pipeline_against_truth(tmp_path, sim):
    s, _ = sim
    (tmp_path / "survey.parquet").write_bytes(sfio.table_to_bytes(s.survey, s.survey_meta))
    data = sfio.table_to_bytes(s.session, s.meta)
    r = run_cli(["detect-events", "--kind", "gates", "-q"], stdin=data)
    assert r.returncode == 0, r.stderr
    r = run_cli(["gate-anchor", "--gates", str(tmp_path / "survey.parquet")], stdin=r.stdout)
    assert r.returncode == 0, r.stderr
    out, meta = sfio.read_table(io.BytesIO(r.stdout))
    e, se, abs_err, std = _errors(s, out)
    # paper Table 1 (CoM vs dGNSS): 0.24 +- 0.09 m, speed 0.00 +- 0.18 m/s; here sacrum vs simulated truth
    assert e.mean() < 0.35 and e.std() < 0.3
    assert abs(se.mean()) < 0.1 and se.std() < 0.2
    assert np.mean(abs_err < 3 * std + 0.05) > 0.8  # the std_ columns are not wildly optimistic
    # every crossing's gate id right (spurious peaks unmatched)
    ev = np.array(out.column("event").to_pylist(), dtype=object)
    rows = np.flatnonzero(ev == "gate")
    gates = out.column("gate").to_numpy(zero_copy_only=False)[rows]
    tc = floats(out, "t")[rows]
    for tt, gid in zip(tc, gates, strict=True):
        j = int(np.argmin(np.abs(s.crossings["t"] - tt)))
        want = j + 1 if abs(s.crossings["t"][j] - tt) < 0.03 else -1
        assert gid == want or gid == -1
    assert np.mean(gates > 0) > 0.85
    # per-turn figures near the truth's (paper Table 2: LoA about +-0.3 m/s, +-0.3 m, path length -0.06..0.16 m)
    turns = meta["gate_anchor"]["turns"]
    assert len(turns) >= 20
    f = s.fine
    for tr in turns[::4]:
        k_in = int(round(tr["t_in"] / 0.001))
        assert abs(tr["v_in"] - np.linalg.norm(f["vel"][k_in])) < 0.4
        g = s.magnets[tr["gate"] - 1]
        assert abs(tr["d_in"] - np.linalg.norm(f["pos"][k_in] - g)) < 0.6
        k0, k1 = int(round(tr["t_in"] / 0.001)), int(round(tr["t_out"] / 0.001))
        true_len = np.sum(np.linalg.norm(np.diff(f["pos"][k0:k1], axis=0), axis=1))
        assert abs(tr["length"] - true_len) < 0.5
    assert 0.2 < np.median([tr["d_cross"] for tr in turns]) < 1.2
    assert meta["provenance"][-1]["tool"] == "gate-anchor"


@pytest.mark.slow
def test_session_attitude_every_third_gate_and_drift(sim):
    s, sess = sim
    # the session's q0..q3 (here the truth's) replace the strap-down
    for i in range(4):
        sess = sess.append_column(f"q{i}", pa.array(floats(s.truth, f"true_q{i}")))
    params = GateAnchorParams(rate=25.0, anchors_every=3)
    out, meta, msg = gate_anchor_table(sess, s.meta, s.survey, s.survey_meta, params)
    assert meta["gate_anchor"]["attitude"] == "session q0..q3"
    e, se, _, _ = _errors(s, out)
    used = out.column("gate_anchor").drop_null().to_numpy(zero_copy_only=False)
    assert 8 <= used.sum() <= 11  # every third gate (paper's simulated downhill)
    assert e.mean() < 0.6  # paper: 0.34 m with every third anchor
    assert abs(meta["gate_anchor"]["alpha_deg"]) < 3.0  # q0..q3 are in the local frame already


def test_eks_without_anchors_drifts_and_zupts_hold():
    # constant acceleration measurements with a 0.05 m/s^2 bias and no anchors: position drifts, ZUPTs at the
    # ends pull the velocity to zero there
    t = np.arange(0, 20, 0.05)
    acc = np.zeros((t.size, 3))
    acc[:, 0] = 0.05
    zupt = (t < 2) | (t > 18)
    r = run_eks(t, acc, 9.81, zupt, None, EKSParams())
    v = r.x_smooth[:, 3:6]
    assert np.abs(v[zupt]).max() < 0.1
    Phi, Q = transition(0.05, EKSParams())
    assert np.allclose(Phi[0, 6], 0.05**2 / 2) and np.all(np.linalg.eigvalsh(Q) > -1e-12)


def test_bad_inputs(tmp_path, sim):
    s, sess = sim
    data = sfio.table_to_bytes(sess, s.meta)
    r = run_cli(["gate-anchor"], stdin=data)  # crossings but no survey
    assert r.returncode == 1 and r.stdout == b""
    assert len(r.stderr.decode().strip().splitlines()) == 1 and "no gate survey" in r.stderr.decode()
    small = s.survey.slice(0, 2)
    (tmp_path / "g2.parquet").write_bytes(sfio.table_to_bytes(small, s.survey_meta))
    r = run_cli(["gate-anchor", "--gates", str(tmp_path / "g2.parquet")], stdin=data)
    assert r.returncode == 1 and "at least 3" in r.stderr.decode()
    (tmp_path / "g.parquet").write_bytes(sfio.table_to_bytes(s.survey, s.survey_meta))
    r = run_cli(["gate-anchor", "--gates", str(tmp_path / "g.parquet")], stdin=sfio.table_to_bytes(s.session, s.meta))
    assert r.returncode == 1 and "detect-events --kind gates" in r.stderr.decode()
    no_mag = sfio.table_to_bytes(s.session.drop(["mag_x", "mag_y", "mag_z"]), sfmeta.new_meta("session", 0.0))
    r = run_cli(["detect-events", "--kind", "gates"], stdin=no_mag)
    assert r.returncode == 1 and "no magnetometer" in r.stderr.decode()


def test_wgs84_survey_lands_in_the_session_frame():
    from sportfusion.core.frames import Frame
    from sportfusion.gates.pipeline import survey_in_frame

    loc = simulate_gates(GatesConfig(seed=8, n_gates=5))
    geo = simulate_gates(GatesConfig(seed=8, n_gates=5), survey_wgs84=True)
    frame = Frame.from_meta(loc.meta["frame"])
    a, _ = survey_in_frame(loc.survey, loc.survey_meta, frame)
    b, _ = survey_in_frame(geo.survey, geo.survey_meta, frame)
    assert np.abs(a - b).max() < 1e-6 and np.abs(a - loc.magnets).max() < 0.15  # same seed: same survey noise
    # a session in another frame (shifted origin, rotated azimuth): the survey follows it
    other = Frame(frame.lat + 0.001, frame.lon, frame.h, frame.azimuth_deg + 30.0)
    c, _ = survey_in_frame(loc.survey, loc.survey_meta, other)
    assert np.allclose(
        np.linalg.norm(np.diff(c, axis=0), axis=1), np.linalg.norm(np.diff(a, axis=0), axis=1), atol=1e-6
    )
    assert np.abs(c - a).max() > 50


def _standing_errors(s, out):
    """Mean 3-D error [m] while the true speed is below 1 m/s, at the start and at the finish."""
    t = floats(out, "t")
    pos = np.column_stack([floats(out, c) for c in "xyz"])
    tp = np.column_stack([floats(s.truth, f"true_{c}") for c in "xyz"])
    tv = np.column_stack([floats(s.truth, f"true_v{c}") for c in "xyz"])
    still = np.linalg.norm(tv, axis=1) < 1.0
    first = t < s.crossings["t"][0]
    last = t > s.crossings["t"][-1]
    e = np.linalg.norm(pos - tp, axis=1)
    return float(e[still & first].mean()), float(e[still & last].mean())


@pytest.mark.slow
def test_surveyed_static_spots_anchor_the_standing_athlete():
    # seed 23 is not a bench seed; without the spots the standing sacrum is off by the drift from the nearest gate
    s = simulate_gates(GatesConfig(seed=23, survey_spots=True))
    det = detect_gate_table(s.session)
    sess = with_columns(s.session, gate_columns(s.session, det))
    out, meta, msg = gate_anchor_table(sess, s.meta, s.survey, s.survey_meta)
    assert "static spot(s): start, finish" in msg
    assert meta["gate_anchor"]["static_spots"] == ["start", "finish"]
    start, finish = _standing_errors(s, out)
    assert start < 0.15 and finish < 0.15, (start, finish)  # issue 19: standing error <= 0.15 m
    e, _, _, _ = _errors(s, out)
    assert e.mean() < 0.2
    # the same survey without the spot rows: the gates alone leave the standing athlete further off
    from sportfusion.core.io import survey_points

    gates_only, spots = survey_points(s.survey)
    assert spots is not None and spots.num_rows == 2 and gates_only.num_rows == s.magnets.shape[0]
    out0, meta0, _ = gate_anchor_table(sess, s.meta, gates_only, s.survey_meta)
    assert meta0["gate_anchor"]["static_spots"] == []
    assert max(_standing_errors(s, out0)) > max(start, finish)
    # the same survey in WGS84 (lat lon h): the spots are converted into the session's frame like the gates
    geo = simulate_gates(GatesConfig(seed=23, survey_spots=True), survey_wgs84=True)
    outg, _, msg = gate_anchor_table(sess, s.meta, geo.survey, geo.survey_meta)
    assert "start, finish" in msg
    assert max(_standing_errors(s, outg)) < 0.15


def test_survey_points_split_and_refusals():
    from sportfusion.core.errors import InputError
    from sportfusion.core.io import survey_points

    t = pa.table({"gate": [1, 2, 3, None], "x": [0.0, 1, 2, 3], "y": [0.0] * 4, "z": [0.0] * 4})
    g, sp = survey_points(t)
    assert g is t and sp is None  # no point column: every row a magnet
    t2 = t.append_column("point", pa.array(["gate", None, "", "Finish"]))
    g, sp = survey_points(t2)
    assert g.num_rows == 3 and sp.column("point").to_pylist() == ["Finish"]
    with pytest.raises(InputError, match="point holds"):
        survey_points(t.append_column("point", pa.array(["gate", "gate", "gate", "middle"])))
    with pytest.raises(InputError, match="surveyed 2 times"):
        survey_points(t.append_column("point", pa.array(["gate", "gate", "start", "start"])))


@pytest.mark.parametrize("variant", ["nominal", "wide"])
def test_independent_physics_short_course(variant):
    # a 10-gate course of the independent simulator (bar magnets, stray iron, a unit with scale, misalignment
    # and temperature drift, an angulating athlete); seed 61 is no bench seed
    s = simulate_gates(GatesConfig(seed=61, variant=variant, n_gates=10, static=3.0))
    det = detect_gate_table(s.session)
    c = s.crossings
    ct = np.array([x.t for x in det.crossings])
    found = np.array([np.any(np.abs(ct - tc) < 0.05) for tc in c["t"]])
    assert found[c["distance"] <= 0.5].all()  # issue 39: every pass within 0.5 m of a magnet detected
    sess = with_columns(s.session, gate_columns(s.session, det))
    out, meta, msg = gate_anchor_table(sess, s.meta, s.survey, s.survey_meta, GateAnchorParams(rate=50.0))
    ga = meta["gate_anchor"]
    assert ga["pass_fits"] >= found.sum() - 1 and ga["anchors"].startswith("pass fit")
    t = floats(out, "t")
    pos = np.column_stack([floats(out, k) for k in "xyz"])
    std = np.column_stack([floats(out, f"std_{k}") for k in "xyz"])
    tp = np.column_stack([floats(s.truth, f"true_{k}") for k in "xyz"])
    tv = np.column_stack([floats(s.truth, f"true_v{k}") for k in "xyz"])
    err = np.linalg.norm(pos - tp, axis=1)
    moving = np.linalg.norm(tv, axis=1) > 1.0
    on_course = moving & (t > c["t"][0]) & (t < c["t"][-1])
    assert err[on_course].mean() < 0.2  # between the first and the last gate (paper: 0.24 m for the CoM)
    # never silently wrong: where the error passes 0.3 m, the std_ columns say so (error within 3 sigma)
    big = err > 0.3
    assert np.all(err[big] < 3.0 * np.linalg.norm(std[big], axis=1) + 0.1)
    ids = out.column("gate").drop_null().to_numpy(zero_copy_only=False)
    truth_ids = [int(np.argmin(np.abs(c["t"] - x))) + 1 for x in ct]
    assert all(g in (-1, want) for g, want in zip(ids, truth_ids, strict=True))


def test_a_survey_that_does_not_fit_is_refused_not_silently_anchored(tmp_path, sim):
    # the survey of another course (this one stretched by 30 % along the hill): before issue 39's check,
    # gate-anchor matched 2 of 29 crossings, said so in an info line and wrote a track tens of metres off
    s, sess = sim
    x = floats(s.survey, "x")
    stretched = s.survey.set_column(s.survey.column_names.index("x"), "x", pa.array(x[0] + (x - x[0]) * 1.3))
    (tmp_path / "g.parquet").write_bytes(sfio.table_to_bytes(stretched, s.survey_meta))
    r = run_cli(["gate-anchor", "--gates", str(tmp_path / "g.parquet")], stdin=sfio.table_to_bytes(sess, s.meta))
    err = r.stderr.decode().strip()
    assert r.returncode == 1 and r.stdout == b"", err
    assert len(err.splitlines()) == 1 and err.startswith("Error: gate-anchor: the detected crossings do not fit")


def test_a_doubtful_matching_warns_and_widens_std(sim):
    from sportfusion.gates.checks import CheckParams

    s, sess = sim
    # every anchor taken as contradicting the track (a zero limit): the warning and the widened std_ columns
    p = GateAnchorParams(rate=50.0, check=CheckParams(max_ratio=0.0))
    out, meta, _ = gate_anchor_table(sess, s.meta, s.survey, s.survey_meta, p)
    ga = meta["gate_anchor"]
    assert ga["check"]["doubtful"] and any("doubtful" in w and "std_ columns widened" in w for w in ga["warnings"])
    e, _, abs_err, std = _errors(s, out)
    # widened to the difference between the anchored and the inertial track: metres, not decimetres
    assert np.median(np.linalg.norm(std, axis=1)) > 1.0 and np.all(abs_err <= 3 * std + 0.05)
