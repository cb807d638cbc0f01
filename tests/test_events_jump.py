"""Take-off / touch-down detection (skijump Appendix A) on simulated jumps and on constructed signals."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from conftest import ROOT

from sportfusion.core import io as sfio
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.events import set_events
from sportfusion.skijump.events import JUMP_EVENTS, JumpParams, detect_jump_table, detect_jumps, jump_events, speed_at

FIX = ROOT / "fixtures" / "skijump"
# The fixture is the full physics (issue 39): the take-off peak (eq A3) comes 25-45 ms after the edge (the push
# peaks 22-26 ms after it, the 41 Hz anti-aliasing filter adds 5.5 ms, the 50 ms average over the in-run's chatter
# moves the peak of this asymmetric pulse by ~10 ms): 40.6 ms here.  The landing impact reaches the arm through
# the body (a damped 8-20 Hz response) and the filter: its onset shows 4-17 ms after the skis' contact on the
# tuning jumps, 13.7 ms here.  (On the paper's sensors: within 30 ms and 2 ms.)
TO_TOL, TD_TOL = 0.05, 0.02


@pytest.fixture(scope="module")
def jump():
    session, meta = sfio.read_table(FIX / "session.parquet")
    truth, tmeta = sfio.read_table(FIX / "truth.parquet", kind="truth")
    return session, meta, truth, tmeta


def _shifted(table: pa.Table, dt: float) -> pa.Table:
    return table.set_column(0, "t", pa.array(schema.floats(table, "t") + dt))


def test_simulated_jump_within_30_ms(jump):
    session, _, _, tmeta = jump
    det = detect_jump_table(session)
    assert len(det.jumps) == 1, det.message()
    j = det.jumps[0]
    times = tmeta["skijump"]["times"]
    assert abs(j.takeoff - times["takeoff"]) <= TO_TOL
    assert abs(j.touchdown - times["touchdown"]) <= TD_TOL  # the impact's onset (issue 19)
    assert j.touchdown_method == "onset" and j.touchdown < j.t_peak_landing
    assert j.flight_acc < 9.81 < j.peak_takeoff
    (a4,) = detect_jump_table(session, JumpParams(touchdown_method="peak")).jumps
    assert a4.touchdown == pytest.approx(a4.t_peak_landing - 0.05) and a4.touchdown_method == "peak"  # eq A4
    assert abs(a4.touchdown - times["touchdown"]) <= 0.04
    with pytest.raises(ValueError, match="touchdown_method"):
        JumpParams(touchdown_method="guess")


def test_several_jumps_are_each_found(jump):
    session, _, _, tmeta = jump
    span = float(schema.floats(session, "t")[-1]) + 60.0
    both = pa.concat_tables([session, _shifted(session, span)])
    det = detect_jump_table(both)
    assert len(det.jumps) == 2 and det.windows == 2
    times = tmeta["skijump"]["times"]
    for k, j in enumerate(det.jumps):
        assert abs(j.takeoff - (times["takeoff"] + k * span)) <= TO_TOL
        assert abs(j.touchdown - (times["touchdown"] + k * span)) <= TD_TOL


def test_back_to_back_jumps_in_one_continuous_recording(jump):
    # no time gap: the second jump's rest at the gate follows the first's stop sample by sample, so only
    # the GNSS speed dropping below 10 m/s between them separates the jumps
    session, _, _, tmeta = jump
    t = schema.floats(session, "t")
    ti = t[np.isfinite(schema.floats(session, "acc_x"))]  # the IMU's samples (the receiver has its own rows)
    inside = pa.array((t >= ti[0]) & (t <= ti[-1]))
    session = session.filter(inside)
    span = float(ti[-1] + (ti[1] - ti[0]) - ti[0])
    both = pa.concat_tables([session, _shifted(session, span)])
    tb = schema.floats(both, "t")
    assert np.allclose(np.diff(tb[np.isfinite(schema.floats(both, "acc_x"))]), ti[1] - ti[0])
    det = detect_jump_table(both)
    assert len(det.jumps) == 2 and det.windows == 2, det.message()
    times = tmeta["skijump"]["times"]
    for k, j in enumerate(det.jumps):
        assert abs(j.takeoff - (times["takeoff"] + k * span)) <= TO_TOL
        assert abs(j.touchdown - (times["touchdown"] + k * span)) <= TD_TOL
    out = set_events(both, jump_events(det), replace=JUMP_EVENTS)
    assert [n for n in out.column("event").to_pylist() if n] == ["takeoff", "touchdown"] * 2


def test_fast_run_without_a_jump_gets_no_events():
    # a giant-slalom-like run: fast for 20 s, turns up to 8 m/s^2 and terrain rollers, but never airborne
    from sportfusion.skijump.events import detect_jump_events
    from sportfusion.skirace.sim import SkiRaceConfig, simulate_skirace

    sim = simulate_skirace(SkiRaceConfig(seed=3, jumps=0, duration=20.0))
    out, summary, message = detect_jump_events(sim.session)
    assert summary["speed_windows"] == 1 and summary["jumps"] == []
    assert message.startswith("no jump found in 1 fast window") and "no flight between the peaks" in message
    assert out.equals(sim.session)  # no event column invented


def test_no_jump_gives_no_events(jump):
    session, _, _, tmeta = jump
    t = schema.floats(session, "t")
    # the in-run alone: fast, but only one acceleration peak region -> no invented jump
    inrun = session.filter(pa.array(t < tmeta["skijump"]["times"]["takeoff"] - 0.5))
    det = detect_jump_table(inrun)
    assert det.jumps == [] and det.windows == 1
    assert "no jump found" in det.message()
    # standing still: never fast
    rest = session.filter(pa.array(t < 4.0))
    det = detect_jump_table(rest)
    assert det.jumps == [] and det.windows == 0
    assert "never exceeds" in det.message()


def test_appendix_a_on_a_constructed_signal():
    t = np.arange(0, 20, 0.01)
    speed = np.where((t > 3) & (t < 17), 25.0, 2.0)
    a = np.full(t.size, 9.8)
    a[(t > 8) & (t < 11)] = 5.0  # flight: aerodynamic force only
    a[np.argmin(np.abs(t - 8.0))] = 25.0  # take-off peak
    a[np.argmin(np.abs(t - 11.0))] = 40.0  # landing peak (the largest)
    a[np.argmin(np.abs(t - 10.0))] = 30.0  # within 1.5 s of the landing peak: not the second peak (errata A2)
    det = detect_jumps(t, a, speed)
    (j,) = det.jumps
    assert j.takeoff == pytest.approx(8.0, abs=0.005) and j.touchdown == pytest.approx(
        10.95, abs=0.005
    )  # between samples
    # parameters are options: offset and separation
    det = detect_jumps(t, a, speed, JumpParams(touchdown_offset=0.1))
    assert det.jumps[0].touchdown == pytest.approx(10.9, abs=0.005)
    det = detect_jumps(t, a, speed, JumpParams(min_separation=0.5))
    assert det.jumps[0].takeoff == pytest.approx(10.0, abs=0.005)  # now the 30 m/s^2 bump wins, as A2 then says
    # too slow: nothing analysed
    assert detect_jumps(t, a, speed, JumpParams(min_speed=30.0)).windows == 0


def test_two_bumps_without_flight_are_rejected():
    t = np.arange(0, 20, 0.01)
    speed = np.full(t.size, 20.0)
    a = np.full(t.size, 9.5)
    a[np.argmin(np.abs(t - 6.0))] = 25.0
    a[np.argmin(np.abs(t - 9.0))] = 30.0
    det = detect_jumps(t, a, speed)
    assert det.jumps == [] and "no flight" in det.rejected[0]["reason"]
    a[(t > 6.2) & (t < 8.8)] = 4.0
    assert len(detect_jumps(t, a, speed).jumps) == 1
    det = detect_jumps(t, a, speed, JumpParams(min_peak=26.0))
    assert det.jumps == [] and "min_peak" in det.rejected[0]["reason"]


def test_speed_interpolation_respects_gaps():
    tg = np.array([0.0, 0.1, 0.2, 5.0, 5.1])
    vg = np.array([10.0, 12.0, 14.0, 20.0, 22.0])
    t = np.array([0.05, 0.2, 1.0, 5.05, 6.0])
    v = speed_at(t, tg, vg, max_gap=2.0)
    assert v[0] == pytest.approx(11.0) and v[1] == 14.0 and np.isnan(v[2])
    assert v[3] == pytest.approx(21.0) and np.isnan(v[4])


def test_events_written_and_replaced(jump):
    session, _, _, _ = jump
    det = detect_jump_table(session)
    out = set_events(session, jump_events(det), replace=JUMP_EVENTS)
    names = [n for n in out.column("event").to_pylist() if n]
    assert names == ["takeoff", "touchdown"]
    t = schema.floats(out, "t")
    ev = {n: t[i] for i, n in enumerate(out.column("event").to_pylist()) if n}
    assert ev["takeoff"] == pytest.approx(det.jumps[0].takeoff, abs=0.005 + 1e-9)  # the nearest row
    # a re-run replaces the jump events but keeps others
    col = out.column("event").to_pylist()
    col[5] = "gate"
    out = out.set_column(out.column_names.index("event"), "event", pa.array(col, pa.string()))
    again = set_events(out, [("takeoff", 1.0)], replace=JUMP_EVENTS)
    assert [n for n in again.column("event").to_pylist() if n] == ["gate", "takeoff"]
    with pytest.raises(InputError, match="falls on the row"):
        set_events(again, [("touchdown", float(t[5]))], replace=())


def test_missing_columns_are_input_errors(jump):
    session, _, _, _ = jump
    with pytest.raises(InputError, match="acc_x"):
        detect_jump_table(session.drop(["acc_x"]))
    with pytest.raises(InputError, match="vel_n"):
        detect_jump_table(session.drop(["vel_n", "vel_e", "vel_d"]))


def test_table_level_detection(jump):
    from sportfusion.skijump.events import detect_jump_events

    session, _, _, _ = jump
    out, summary, message = detect_jump_events(session)
    assert [n for n in out.column("event").to_pylist() if n] == ["takeoff", "touchdown"]
    assert summary["kind"] == "jump" and len(summary["jumps"]) == 1 and message.startswith("1 jump(s)")
    still = session.filter(pa.array(schema.floats(session, "t") < 4.0))
    out, summary, message = detect_jump_events(still)
    assert out.equals(still) and summary["jumps"] == [] and "no jump found" in message


def test_cli_kind_jump(tmp_path, jump):
    import io as _io

    from conftest import run_cli

    session, meta, _, tmeta = jump
    res = run_cli(["detect-events", "--kind", "jump", str(FIX / "session.parquet")])
    assert res.returncode == 0, res.stderr
    out, ometa = sfio.read_table(_io.BytesIO(res.stdout))
    ev = {n: t for n, t in zip(out.column("event").to_pylist(), schema.floats(out, "t"), strict=True) if n}
    times = tmeta["skijump"]["times"]
    assert abs(ev["takeoff"] - times["takeoff"]) <= TO_TOL + 0.005  # the nearest row (IMU rows 10 ms apart)
    assert abs(ev["touchdown"] - times["touchdown"]) <= TD_TOL + 0.005
    assert ometa["events"][-1]["kind"] == "jump" and ometa["provenance"][-1]["tool"] == "detect-events"
    assert out.drop(["event"]).equals(session)  # every other column passes through
    # an option changes the result as documented
    peak = ["detect-events", "--kind", "jump", "--touchdown-method", "peak", str(FIX / "session.parquet")]
    res = run_cli(peak)
    out1, meta1 = sfio.read_table(_io.BytesIO(res.stdout))
    (j1,) = meta1["events"][-1]["jumps"]
    assert j1["touchdown_method"] == "peak" and j1["touchdown"] == pytest.approx(j1["t_peak_landing"] - 0.05)
    res = run_cli([*peak, "--touchdown-offset", "0.1"])
    out2, meta2 = sfio.read_table(_io.BytesIO(res.stdout))
    assert meta2["events"][-1]["jumps"][0]["touchdown"] == pytest.approx(j1["touchdown"] - 0.05)
    (default,) = ometa["events"][-1]["jumps"]
    assert default["touchdown_method"] == "onset" and abs(default["touchdown"] - times["touchdown"]) <= TD_TOL
    # no jump: a clear message, no event column invented
    still = session.filter(pa.array(schema.floats(session, "t") < 4.0))
    sfio.write_table(still, meta, tmp_path / "still.parquet")
    res = run_cli(["detect-events", "--kind", "jump", str(tmp_path / "still.parquet")])
    assert res.returncode == 0 and "no jump found" in res.stderr.decode()
    out3, _ = sfio.read_table(_io.BytesIO(res.stdout))
    assert "event" not in out3.column_names
