"""Your own venue from a spreadsheet: a gate survey or a hold map as CSV or plain Parquet (no sportfusion
metadata) for --gates / --holds, read into the same tables the tools write (sportfusion.core.venue)."""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import ROOT, run_cli

from sportfusion.climbing.holds import read_holds
from sportfusion.core import io as sfio
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.magfield import reference_field
from sportfusion.core.venue import read_venue

FIX = ROOT / "fixtures"


def _csv(rows: list[list[object]], head: list[str], sep: str = ",", keys: str = "") -> bytes:
    lines = [sep.join(head)] + [sep.join(str(v) for v in r) for r in rows]
    return (keys + "\n".join(lines) + "\n").encode()


@pytest.fixture(scope="module")
def survey() -> tuple[pa.Table, dict]:
    return sfio.read_table(FIX / "gates" / "survey.parquet", kind="gates")


def test_gate_survey_from_csv_with_units_and_from_plain_parquet(tmp_path, survey) -> None:
    table, _ = survey
    g = table.to_pylist()
    # x in metres, y in centimetres, z without a unit (metres); a semicolon sheet with decimal commas
    rows = [[r["gate"], f"{r['x']:.6f}", f"{100 * r['y']:.4f}", f"{r['z']:.6f}", r["turn"]] for r in g]
    (tmp_path / "survey.csv").write_bytes(_csv(rows, ["Gate", "x [m]", "y (cm)", "z", "Turn"]))
    sheet = [[c.replace(".", ",") if isinstance(c, str) and c[:1] in "-0123456789" else c for c in r] for r in rows]
    (tmp_path / "sheet.csv").write_bytes(_csv(sheet, ["gate", "x [m]", "y [cm]", "z [m]", "turn"], sep=";"))
    pq.write_table(pa.table({k: table.column(k) for k in ("gate", "x", "y", "z", "turn")}), tmp_path / "plain.parquet")
    for name in ("survey.csv", "sheet.csv", "plain.parquet"):
        got, meta = read_venue(tmp_path / name, "gates")
        assert meta["kind"] == "gates" and got.column("gate").to_pylist() == table.column("gate").to_pylist()
        for c in ("x", "y", "z"):
            np.testing.assert_allclose(schema.floats(got, c), schema.floats(table, c), atol=1e-6, err_msg=name)
        assert got.column("turn").to_pylist() == table.column("turn").to_pylist()
    # a table a tool wrote is read as it is
    same, meta = read_venue(FIX / "gates" / "survey.parquet", "gates")
    assert same.equals(table) and meta["provenance"]


def test_gate_anchor_with_a_csv_survey_gives_the_parquet_result(tmp_path, survey) -> None:
    table, meta = survey
    frame = meta["frame"]
    keys = f"# site: {', '.join(repr(v) for v in frame['origin'])}\n# azimuth: {frame['azimuth_deg']!r}\n"
    (tmp_path / "survey.csv").write_bytes(
        _csv([[r["gate"], repr(r["x"]), repr(r["y"]), repr(r["z"]), r["turn"]] for r in table.to_pylist()],
             ["gate", "x", "y", "z", "turn"], keys=keys)
    )  # fmt: skip
    assert read_venue(tmp_path / "survey.csv", "gates")[1]["frame"]["origin"] == frame["origin"]
    res = run_cli(["ingest", "-q", str(FIX / "gates" / "raw" / "phyphox.zip")], stdin=None)
    assert res.returncode == 0, res.stderr.decode()
    res = run_cli(["detect-events", "-q", "--kind", "gates"], stdin=res.stdout)
    assert res.returncode == 0, res.stderr.decode()
    out = {}
    for name in ("survey.csv", str(FIX / "gates" / "survey.parquet")):
        r = run_cli(["gate-anchor", "-q", "--gates", str(tmp_path / name)], stdin=res.stdout)
        assert r.returncode == 0, r.stderr.decode()
        out[name] = sfio.table_from_bytes(r.stdout)
    a, b = out.values()
    for c in ("x", "y", "z", "vx"):
        np.testing.assert_allclose(schema.floats(a, c), schema.floats(b, c), atol=1e-9)
    assert a.column("gate").to_pylist() == b.column("gate").to_pylist()


def test_hold_map_from_csv_with_start_holds_and_the_field_from_the_site() -> None:
    table, meta = sfio.read_table(FIX / "climbing" / "holds.parquet", kind="holds")
    starts = {(r, h) for r, hs in meta["climbing"]["start_holds"].items() for h in hs}
    rows = [[r["route"], r["hold"], r["x"], r["y"], r["z"], "yes" if (r["route"], r["hold"]) in starts else ""]
            for r in table.to_pylist()]  # fmt: skip
    keys = "# a hold map typed into a spreadsheet\n# site: 53.1065, 8.8520, 10\n# azimuth: 90\n# date: 2026-03-02\n"
    hm = read_holds_bytes(_csv(rows, ["route", "hold", "x", "y", "z", "start"], keys=keys))
    assert hm.start_holds == meta["climbing"]["start_holds"]
    np.testing.assert_allclose(hm.pos, schema.float_columns(table, ("x", "y", "z")), atol=1e-9)
    np.testing.assert_allclose(hm.up, [0, 0, 1])
    # the map's x points east (azimuth 90), y into the wall (north), z up: the WMM field (n, e, d) normalised
    n, e, d = reference_field(53.1065, 8.8520, 10.0, "2026-03-02")
    np.testing.assert_allclose(hm.magnetic_field, np.array([e, n, -d]) / math.hypot(n, e, d), atol=1e-12)
    assert hm.meta["frame"]["azimuth_deg"] == 90.0
    # azimuth 0: x north, y west (into a wall facing ... west), the same field turned
    hm0 = read_holds_bytes(_csv(rows, ["route", "hold", "x", "y", "z", "start"], keys=keys.replace("90", "0")))
    np.testing.assert_allclose(hm0.magnetic_field, np.array([n, -e, -d]) / math.hypot(n, e, d), atol=1e-12)


def read_holds_bytes(data: bytes):  # noqa: ANN201
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "holds.csv"
        p.write_bytes(data)
        return read_holds(str(p))


def test_plot_holds_takes_a_csv_hold_map(tmp_path) -> None:
    table, _ = sfio.read_table(FIX / "climbing" / "holds.parquet", kind="holds")
    rows = [[r["route"], r["hold"], r["x"], r["y"], r["z"]] for r in table.to_pylist()]
    (tmp_path / "holds.csv").write_bytes(_csv(rows, ["route", "hold", "x [m]", "y [m]", "z [m]"]))
    truth, tmeta = sfio.read_table(FIX / "climbing" / "truth.parquet", kind="truth")
    path = truth.select(["t"])
    for c in "xyz":
        path = path.append_column(c, truth.column(f"true_{c}"))
    res = run_cli(
        ["plot", "holds", "--holds", str(tmp_path / "holds.csv"), "-o", str(tmp_path / "p.png")],
        stdin=sfio.table_to_bytes(path, dict(tmeta, kind="session")),
    )
    assert res.returncode == 0, res.stderr.decode()
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("gate,x,y\n1,2,3\n", "no column"),
        ("gate,x,y,z\n1,2,three,4\n", "row 1, column y: 'three' is not a number"),
        ("gate,x,y,z\n1.5,2,3,4\n", "expected a whole number"),
        ("gate,x [ft],y,z\n1,2,3,4\n", "expected m, cm, mm or km"),
        ("gate,x,y,z,turn\n1,2,3,4,up\n", "column turn holds ['UP']"),
        ("gate,x,y,z\n1,2,3\n", "row 1 has 3 cells, the header 4"),
        ("", "is empty"),
    ],
)
def test_a_bad_sheet_is_refused_in_one_line(tmp_path, text: str, message: str) -> None:
    p = tmp_path / "s.csv"
    p.write_text(text)
    with pytest.raises(InputError, match=message.replace("[", r"\[").replace("]", r"\]").replace("(", r"\(")):
        read_venue(p, "gates")
    res = run_cli(["gate-anchor", "--gates", str(p)], stdin=sfio.table_to_bytes(*_tiny_session()))
    assert res.returncode == 1 and res.stdout == b""
    lines = res.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: gate-anchor:"), lines


def _tiny_session() -> tuple[pa.Table, dict]:
    from sportfusion.core import meta as sfmeta

    t = np.arange(0.0, 1.0, 0.01)
    return pa.table({"t": t, "acc_x": np.zeros_like(t)}), sfmeta.new_meta("session", 1.7e9)


def test_hold_map_without_start_holds_says_how_to_mark_them(tmp_path) -> None:
    (tmp_path / "h.csv").write_bytes(_csv([["red", 1, 0, 0, 1], ["red", 2, 1, 0, 2]], ["route", "hold", "x", "y", "z"]))
    with pytest.raises(InputError, match="start"):
        read_holds(str(tmp_path / "h.csv"))
