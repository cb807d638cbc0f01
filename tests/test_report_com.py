"""report on gate-anchor's output with a body: the centre-of-mass section (gates paper Figs 3-5, Table 2) shows
the tools' numbers -- the CoM line from the first to the last matched gate, the CoM's height above the skis and
the turn figures at each gate -- and the posture figure.  Input: the full-body fixture's truth dressed as the
estimate (the numbers are checked against the table the page was made from)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pyarrow as pa
from conftest import ROOT, run_cli

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import schema
from sportfusion.report.sports import com_height

FIX = ROOT / "fixtures" / "gates_body"


def _session(path: Path) -> pa.Table:
    truth, _ = sfio.read_table(FIX / "truth.parquet", kind="truth")
    survey, _ = sfio.read_table(FIX / "raw" / "survey.parquet", kind="gates")
    cols: dict[str, object] = {"t": truth.column("t")}
    for n in ("x", "y", "z", "vx", "vy", "vz", "com_x", "com_y", "com_z", "com_vx", "com_vy", "com_vz"):
        cols[n] = truth.column(f"true_{n}")
    cols.update({c[5:]: truth.column(c) for c in truth.column_names if c.endswith(("_rel_x", "_rel_y", "_rel_z"))})
    ev = truth.column("true_event").to_pylist()
    cols["event"] = pa.array(ev, pa.string())
    gate = truth.column("true_gate").to_pylist()
    cols["gate"] = pa.array([g if e == "gate" else None for e, g in zip(ev, gate, strict=True)], pa.int32())
    t = schema.floats(truth, "t")
    tc = [float(t[i]) for i, e in enumerate(ev) if e == "gate"]
    g_xyz = schema.float_columns(survey, ["x", "y", "z"])
    turns = [
        {"gate": k + 1, "gate_xyz": g_xyz[k].tolist(), "t_cross": tc[k], "t_in": 0.5 * (tc[k - 1] + tc[k]),
         "t_out": 0.5 * (tc[k] + tc[k + 1]), "v_in": 20.0 + k, "v_out": 20.5 + k, "d_in": 12.0 + 0.1 * k,
         "d_out": 12.5, "d_cross": 0.6, "length": 24.0 + 0.01 * k}
        for k in range(1, len(tc) - 1)
    ]  # fmt: skip
    meta = sfmeta.new_meta("session", 1.7e9)
    meta["gate_anchor"] = {"alpha_deg": 0.0, "turns": turns}
    table = pa.table(cols)
    path.write_bytes(sfio.table_to_bytes(table, meta))
    return table


def test_centre_of_mass_section_shows_the_tables_numbers(tmp_path: Path) -> None:
    table = _session(tmp_path / "run.parquet")
    out = tmp_path / "report.html"
    r = run_cli(["report", "-q", str(tmp_path / "run.parquet"), "--gates", str(FIX / "raw" / "survey.parquet"),
                 "-o", str(out)])  # fmt: skip
    assert r.returncode == 0, r.stderr
    text = re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", out.read_text(encoding="utf-8")))
    t = schema.floats(table, "t")
    ev = table.column("event").to_pylist()
    tc = [float(t[i]) for i, e in enumerate(ev) if e == "gate"]
    com = schema.float_columns(table, ["com_x", "com_y", "com_z"])
    w = (t >= tc[0]) & (t <= tc[-1])
    line = float(np.sum(np.linalg.norm(np.diff(com[w], axis=0), axis=1)))
    assert re.search(rf"CoM line {line:.1f} m path of the centre of mass, gate 1 to {len(tc)}", text), text[:600]
    h = np.interp(tc, t, com_height(table))
    k = int(np.argmin(h))
    assert f"Lowest CoM at a gate {h[k]:.2f} m above the skis, gate {k + 1}" in text
    assert 0.2 < h.min() and h.max() < 1.2  # the CoM of a skier in a turn, above the ski line
    assert "Centre of mass at the gates" in text and "Posture at the gates" in text
    # gate 2's row: its height and turn figures (d_cross, d_in, d_out, length)
    assert f"gate 2 {h[1]:.2f} m 0.60 m 12.10 m 12.50 m 24.01 m" in text
