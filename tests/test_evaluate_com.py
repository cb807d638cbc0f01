"""evaluate's CoM figures (gates paper Tables 1-2, gate-to-gate path length) on synthetic truth: an estimate
equal to the truth has no error whatever its sample times; a shifted one has the shift; the turn figures at
shared switch times see the trajectory's error only."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest

from sportfusion.evaluate.com import segment_lengths, table1, table2


def _truth(dt: float = 0.01) -> pa.Table:
    t = np.arange(0.0, 12.0, dt)
    x, y, z = 20.0 * t, 3.0 * np.sin(2 * np.pi * t / 2.0), 0.2 * t
    v = np.column_stack([np.full_like(t, 20.0), 3.0 * np.pi * np.cos(2 * np.pi * t / 2.0), np.full_like(t, 0.2)])
    ev = [None] * t.size
    gates = [None] * t.size
    for k, tg in enumerate(np.arange(1.5, 11.0, 1.0)):  # a gate every second, at the turns' apexes
        i = int(np.argmin(np.abs(t - tg)))
        ev[i], gates[i] = "gate", k + 1
    lift = 0.1 * np.sin(2 * np.pi * t / 2.0)  # the legs take turns to be the longer: switches at whole seconds
    cols = {"t": t, "true_com_x": x, "true_com_y": y, "true_com_z": z}
    cols.update({f"true_com_v{a}": v[:, i] for i, a in enumerate("xyz")})
    cols.update({f"true_com_rel_{a}": np.zeros_like(t) for a in "xyz"})
    for side, sgn in (("l", -1.0), ("r", 1.0)):
        cols.update({f"true_ankle_{side}_rel_x": np.zeros_like(t), f"true_ankle_{side}_rel_y": np.full_like(t, 0.1 * sgn),
                     f"true_ankle_{side}_rel_z": 0.9 + sgn * lift})  # fmt: skip
    cols["true_event"] = pa.array(ev, pa.string())
    cols["true_gate"] = pa.array(gates, pa.int32())
    return pa.table(cols)


def _estimate(truth: pa.Table, t: np.ndarray, shift: np.ndarray) -> pa.Table:
    tt = truth.column("t").to_numpy()
    cols = {"t": t}
    for a, s in zip("xyz", shift, strict=True):
        cols[f"com_{a}"] = np.interp(t, tt, truth.column(f"true_com_{a}").to_numpy()) + s
        cols[f"com_v{a}"] = np.interp(t, tt, truth.column(f"true_com_v{a}").to_numpy())
    return pa.table(cols)


def test_path_length_per_segment_independent_of_the_sample_times() -> None:
    truth = _truth()
    t = np.arange(0.0005, 12.0, 0.02)  # another clock, offset by half a millisecond
    res = segment_lengths(_estimate(truth, t, np.array([0.3, -0.2, 0.1])), truth, filtered=False)
    assert res is not None and len(res["segments"]) == 9
    # a 0.02 s polyline against a 0.01 s one of the same sine: at most a few millimetres shorter
    assert abs(res["bias"]) < 0.005 and max(np.abs(res["segments"])) < 0.01


def test_table1_sees_a_constant_offset() -> None:
    truth = _truth()
    t = truth.column("t").to_numpy()
    t1 = table1(_estimate(truth, t, np.array([0.0, 0.0, -0.1])), truth)  # 0.1 m too high (z down)
    assert t1["position [m]"][0][0] == pytest.approx(0.1, abs=0.01)  # the norm
    assert abs(t1["speed [m/s]"][0][0]) < 0.01


def test_table2_at_shared_switches_sees_the_trajectory_only() -> None:
    truth = _truth()
    tt = truth.column("t").to_numpy()
    com = np.column_stack([truth.column(f"true_com_{a}").to_numpy() for a in "xyz"])
    turns = []
    for g in range(2, 9):
        tg = 1.5 + (g - 1)
        t_in, t_out = tg - 0.48, tg + 0.53  # the estimate's switches, 20-30 ms off the true ones (tg -+ 0.5 s)
        turns.append({"gate": g, "gate_xyz": [float(np.interp(tg, tt, com[:, j])) + o for j, o in enumerate((0.0, 0.5, 0.6))],
                      "t_in": t_in, "t_out": t_out, "t_cross": tg, "v_in": 0, "v_out": 0, "d_in": 0, "d_out": 0,
                      "d_cross": 0, "length": 0})  # fmt: skip
    # figures computed from the truth itself at the estimate's switches: zero error when shared
    for tr in turns:
        p = {k: np.array([np.interp(tr[k], tt, com[:, j]) for j in range(3)]) for k in ("t_in", "t_out")}
        tr["d_in"] = float(np.linalg.norm(p["t_in"] - np.asarray(tr["gate_xyz"])))
    meta = {"gate_anchor": {"turns": turns}}
    shared = table2(meta, truth)
    assert shared["turns"] == 7 and abs(shared["d_in"]["bias"]) < 0.02
    own = table2(meta, truth, shared_switches=False)
    assert abs(own["d_in"]["bias"]) > 0.1  # 20 ms at 20 m/s
