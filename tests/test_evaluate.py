"""evaluate: a constructed estimate with known errors returns exactly those errors."""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pytest
from conftest import ROOT, run_cli
from scipy.spatial.transform import Rotation

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import rotations, schema
from sportfusion.evaluate import errors, evaluate, format_text, phases, summary_table

FIX = ROOT / "fixtures" / "skijump"
D_POS = {"inrun": (0.1, -0.2, 0.3), "flight": (0.4, 0.0, -0.5), "outrun": (-0.3, 0.25, 0.1)}
D_VEL_HILL = (0.02, -0.01, 0.03)  # constant, hill frame [m/s]
D_ROT = 0.01  # rad, about the body axis D_AXIS
D_AXIS = np.array([0.6, -0.48, 0.64])


@pytest.fixture(scope="module")
def truth():
    return sfio.read_table(FIX / "truth.parquet", kind="truth")


def _truth_phase(truth_table, tmeta):
    t = schema.floats(truth_table, "t")
    times = tmeta["skijump"]["times"]
    return np.where(t <= times["takeoff"], "inrun", np.where(t < times["touchdown"], "flight", "outrun"))


def constructed(truth_table, tmeta, *, events_dt=(0.02, -0.03), length_err=0.7):
    """An estimate = truth + known errors (per-phase position offsets, velocity offset, small rotation)."""
    t = schema.floats(truth_table, "t")
    phase = _truth_phase(truth_table, tmeta)
    cols: dict[str, object] = {"t": pa.array(t)}
    for k, name in enumerate(("x", "y", "z")):
        off = np.array([D_POS[p][k] for p in phase])
        cols[name] = pa.array(schema.floats(truth_table, f"true_{name}") + off)
    for k, name in enumerate(("vx", "vy", "vz")):
        cols[name] = pa.array(schema.floats(truth_table, f"true_{name}") + D_VEL_HILL[k])
    q = np.stack([schema.floats(truth_table, f"true_q{i}") for i in range(4)], -1)
    dq = np.concatenate(([math.cos(D_ROT / 2)], math.sin(D_ROT / 2) * D_AXIS))
    q_est = rotations.quat_multiply(q, dq)  # the body turned by D_ROT about D_AXIS
    for i in range(4):
        cols[f"q{i}"] = pa.array(q_est[:, i])
    times = tmeta["skijump"]["times"]
    ev = [None] * t.size
    ev[int(np.argmin(np.abs(t - times["takeoff"] - events_dt[0])))] = "takeoff"
    ev[int(np.argmin(np.abs(t - times["touchdown"] - events_dt[1])))] = "touchdown"
    cols["event"] = pa.array(ev, pa.string())
    meta = sfmeta.new_meta("session", tmeta["time"]["epoch_utc"])
    meta["frame"] = tmeta["frame"]
    meta["jump_length"] = tmeta["jump_length"] + length_err
    # the exact times beside the rows, as detect-events writes them (the fixture's rows are the IMU's and the
    # receiver's instants: the nearest row is up to 5 ms from a time)
    exact = {"takeoff": times["takeoff"] + events_dt[0], "touchdown": times["touchdown"] + events_dt[1]}
    meta["events"] = [{"kind": "jump", "jumps": [exact]}]
    return pa.table(cols), meta, q, q_est


def test_known_errors_are_returned(truth):
    table, tmeta = truth
    est, meta, q, q_est = constructed(table, tmeta)
    ev = evaluate(est, meta, table, tmeta)
    phase = _truth_phase(table, tmeta)
    n = {p: int((phase == p).sum()) for p in D_POS}
    for ph, off in D_POS.items():
        s = ev.stats[ph]
        assert s["n"] == n[ph]
        for k, name in enumerate(("x", "y", "z")):
            assert s["rms"][name] == pytest.approx(abs(off[k]), abs=1e-12)
            assert s["mean"][name] == pytest.approx(off[k], abs=1e-12)
            assert s["max"][name] == pytest.approx(abs(off[k]), abs=1e-12)
    # overall RMS = sample-weighted quadratic mean of the phases
    for k, name in enumerate(("x", "y", "z")):
        expect = math.sqrt(sum(n[p] * D_POS[p][k] ** 2 for p in D_POS) / sum(n.values()))
        assert ev.stats["all"]["rms"][name] == pytest.approx(expect, abs=1e-12)
    # velocity: in the position's frame (the hill frame), the constructed error exactly
    for name, val in zip(("vx", "vy", "vz"), D_VEL_HILL, strict=True):
        assert ev.stats["all"]["mean"][name] == pytest.approx(val, abs=1e-12)
        assert ev.stats["all"]["rms"][name] == pytest.approx(abs(val), abs=1e-12)
    assert not {"vel_n", "vel_e", "vel_d"} & set(ev.variables)
    assert ev.frame == f"hill frame ({tmeta['frame']['axes']}; x at azimuth 312.6 deg)"
    # the paper's Table 6 velocity (NED, v_O) on request: the same error rotated by the azimuth
    az = math.radians(tmeta["frame"]["azimuth_deg"])
    dn = D_VEL_HILL[0] * math.cos(az) - D_VEL_HILL[1] * math.sin(az)
    de = D_VEL_HILL[0] * math.sin(az) + D_VEL_HILL[1] * math.cos(az)
    _, _, err = errors(est, table, tmeta["frame"]["azimuth_deg"], velocity_frame="ned")
    for name, val in (("vel_n", dn), ("vel_e", de), ("vel_d", D_VEL_HILL[2])):
        np.testing.assert_allclose(err[name], val, atol=1e-12)
    # attitude: rotation angle exactly D_ROT; Euler errors as scipy computes them (z-y-x)
    assert ev.stats["all"]["max"]["rot_angle"] == pytest.approx(D_ROT, abs=1e-12)
    assert ev.stats["all"]["rms"]["rot_angle"] == pytest.approx(D_ROT, abs=1e-12)
    # scipy: q_BO as an active rotation takes body vectors into NED, R = Rz(yaw) Ry(pitch) Rx(roll)
    e_true = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_euler("ZYX")
    e_est = Rotation.from_quat(q_est[:, [1, 2, 3, 0]]).as_euler("ZYX")
    d = (e_est - e_true + np.pi) % (2 * np.pi) - np.pi  # yaw, pitch, roll
    for k, name in ((2, "roll"), (1, "pitch"), (0, "yaw")):
        assert ev.stats["all"]["rms"][name] == pytest.approx(math.sqrt(np.mean(d[:, k] ** 2)), abs=1e-10)
        assert ev.stats["all"]["mean"][name] == pytest.approx(np.mean(d[:, k]), abs=1e-10)
    # events and jump length
    (jump,) = ev.jumps
    assert jump["takeoff_dt"] == pytest.approx(0.02, abs=1e-9)
    assert jump["touchdown_dt"] == pytest.approx(-0.03, abs=1e-9)
    assert jump["jump_length_error"] == pytest.approx(0.7, abs=1e-12)
    assert ev.false_events == {"takeoff": 0, "touchdown": 0}


def test_yaw_error_wraps_and_euler_columns_work(truth):
    table, tmeta = truth
    t = schema.floats(table, "t")
    roll, pitch, yaw = (schema.floats(table, f"true_{n}") for n in ("roll", "pitch", "yaw"))
    yaw_est = np.angle(np.exp(1j * (yaw + 0.01)))  # wrapped to (-pi, pi]
    est = pa.table({"t": t, "roll": roll - 0.02, "pitch": pitch, "yaw": yaw_est})
    meta = sfmeta.new_meta("session")
    ev = evaluate(est, meta, table, tmeta)
    assert ev.stats["all"]["max"]["yaw"] == pytest.approx(0.01, abs=1e-9)
    assert ev.stats["all"]["mean"]["roll"] == pytest.approx(-0.02, abs=1e-9)
    assert set(ev.variables) == {"roll", "pitch", "yaw", "rot_angle"}


def test_missed_and_false_events(truth):
    table, tmeta = truth
    est, meta, _, _ = constructed(table, tmeta, events_dt=(2.5, 0.0))  # take-off 2.5 s late: not matched
    ev = evaluate(est, meta, table, tmeta)
    assert math.isnan(ev.jumps[0]["takeoff_dt"]) and ev.false_events["takeoff"] == 1
    assert "take-off missed" in format_text(ev)


def test_phases_of_two_jumps():
    t = np.arange(0, 40.0, 1.0)
    ev = [("takeoff", 5.0), ("touchdown", 8.0), ("takeoff", 25.0), ("touchdown", 28.0)]
    ph = phases(t, ev)
    assert list(ph[[5, 6, 8, 15, 17, 25, 26, 30]]) == [
        "inrun", "flight", "outrun", "outrun", "inrun", "inrun", "flight", "outrun"
    ]  # fmt: skip


def test_summary_table_layout(truth):
    table, tmeta = truth
    est, meta, _, _ = constructed(table, tmeta)
    out = summary_table(evaluate(est, meta, table, tmeta))
    assert out.num_rows == 4 * 3 + 1
    assert out.column_names[:3] == ["phase", "stat", "samples"]
    assert out.column("phase").to_pylist()[:3] == ["all", "all", "all"]
    assert out.column("stat").to_pylist()[-1] == "error"
    assert schema.floats(out, "jump_length_error")[-1] == pytest.approx(0.7)


def _write(table, meta, path):
    sfio.write_table(table, meta, path)
    return path


def test_cli(tmp_path, truth):
    table, tmeta = truth
    est, meta, _, _ = constructed(table, tmeta)
    est_path = _write(est, meta, tmp_path / "est.parquet")
    res = run_cli(["evaluate", str(est_path), "--truth", str(FIX / "truth.parquet")])
    assert res.returncode == 0, res.stderr
    out, ometa = sfio.read_table(__import__("io").BytesIO(res.stdout), kind="summary")
    assert ometa["provenance"][-1]["tool"] == "evaluate"
    assert ometa["evaluation"]["jumps"][0]["jump_length_error"] == pytest.approx(0.7)
    assert schema.floats(out, "x")[0] == pytest.approx(ometa["evaluation"]["stats"]["all"]["rms"]["x"])
    res = run_cli(["evaluate", str(est_path), "--truth", str(FIX / "truth.parquet"), "--format", "text"])
    text = res.stdout.decode()
    assert res.returncode == 0 and "inrun" in text and "jump 1: take-off +0.020 s" in text
    # the frames must agree
    meta2 = dict(meta, frame=dict(meta["frame"], azimuth_deg=10.0))
    bad = _write(est, meta2, tmp_path / "bad.parquet")
    res = run_cli(["evaluate", str(bad), "--truth", str(FIX / "truth.parquet")])
    assert res.returncode == 1 and res.stdout == b""
    assert res.stderr.decode().startswith("Error: evaluate: the estimate's frame")
    # --truth is required; a session table is not a truth
    assert run_cli(["evaluate", str(est_path)]).returncode == 2
    res = run_cli(["evaluate", str(est_path), "--truth", str(FIX / "session.parquet")])
    assert res.returncode == 1 and "expected truth" in res.stderr.decode()


def test_gnss_baseline(truth):
    session, smeta = sfio.read_table(FIX / "session.parquet")
    table, tmeta = truth
    from sportfusion.core.frames import Frame

    frame = Frame.from_meta(smeta["frame"])
    g = ~np.isnan(schema.floats(session, "lat"))
    xyz = [np.full(session.num_rows, np.nan) for _ in range(3)]
    x, y, z = frame.from_geodetic(*(schema.floats(session, c)[g] for c in ("lat", "lon", "h")))
    for arr, vals in zip(xyz, (x, y, z), strict=True):
        arr[g] = vals
    est = session.append_column("gnss_x", pa.array(xyz[0])).append_column("gnss_y", pa.array(xyz[1]))
    est = est.append_column("gnss_z", pa.array(xyz[2]))
    ev = evaluate(est, smeta, table, tmeta, gnss=True)
    rms = ev.stats["all"]["rms"]
    assert ev.stats["all"]["n"] == int(g.sum())  # the GNSS epochs, not every row
    # against the IMU's truth the fixes carry the full physics' helmet lever arm (0.54 m), 0.08 s of latency
    # (2 m at 25 m/s), slow drift, multipath and wild fixes: metres, and the exact figures are the errors
    # themselves, computed here independently
    t = schema.floats(session, "t")
    fix = np.stack((x, y, z), -1)
    for k, name in enumerate(("x", "y", "z")):
        true = np.interp(t[g], schema.floats(table, "t"), schema.floats(table, f"true_{name}"))
        assert rms[name] == pytest.approx(float(np.sqrt(np.mean((fix[:, k] - true) ** 2))), rel=1e-9)
        assert 0.5 < rms[name] < 6.0


def test_gnss_without_vertical_velocity(truth):
    # an NMEA log has no vel_d: the horizontal components are still evaluated, exactly
    table, tmeta = truth
    t = schema.floats(table, "t")[::10]
    sel = pa.array(np.isin(schema.floats(table, "t"), t))
    tr = table.filter(sel)
    est = pa.table(
        {
            "t": t,
            "gnss_x": schema.floats(tr, "true_x") + 1.5,
            "gnss_y": schema.floats(tr, "true_y"),
            "gnss_z": schema.floats(tr, "true_z"),
            "vel_n": schema.floats(tr, "true_vel_n") - 0.04,
            "vel_e": schema.floats(tr, "true_vel_e") + 0.03,
        }
    )
    meta = sfmeta.new_meta("session", tmeta["time"]["epoch_utc"])
    meta["frame"] = tmeta["frame"]
    ev = evaluate(est, meta, table, tmeta, gnss=True)
    # in the local (hill) frame like the position: the NED error (-0.04, +0.03) rotated by the azimuth
    assert "vz" not in ev.variables and {"vx", "vy"} <= set(ev.variables)
    az = math.radians(tmeta["frame"]["azimuth_deg"])
    dx, dy = -0.04 * math.cos(az) + 0.03 * math.sin(az), 0.04 * math.sin(az) + 0.03 * math.cos(az)
    assert ev.stats["all"]["mean"]["vx"] == pytest.approx(dx, abs=1e-12)
    assert ev.stats["all"]["rms"]["vy"] == pytest.approx(abs(dy), abs=1e-12)
    assert ev.stats["all"]["max"]["x"] == pytest.approx(1.5, abs=1e-9)
    assert ev.stats["all"]["n"] == t.size


def test_session_without_a_jump_reports_only_the_whole_session():
    t = np.arange(0.0, 5.0, 0.01)
    meta = sfmeta.new_meta("truth", 1.7e9)
    truth_t = pa.table({"t": t, "true_x": t, "true_y": 0 * t, "true_z": 0 * t})
    est = pa.table({"t": t, "x": t + 0.1, "y": 0 * t - 0.2, "z": 0 * t})
    ev = evaluate(est, sfmeta.new_meta("session", 1.7e9), truth_t, meta)
    assert ev.phases == ("all",)
    table = summary_table(ev)
    assert set(table.column("phase").to_pylist()) == {"all"}
    rms = {r["stat"]: r for r in table.to_pylist()}["rms"]
    assert rms["x"] == pytest.approx(0.1) and rms["y"] == pytest.approx(0.2) and rms["z"] == 0.0
    assert "inrun" not in format_text(ev)
