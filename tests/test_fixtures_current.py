"""The shipped demo sessions are what `make fixtures` makes today: each simulator's output for the
fixture's seed equals the shipped truth (same rows, columns and values within a tolerance that allows
another numpy/scipy release), so a change to a simulator that forgets to regenerate its fixture fails here.

(fixtures/skijump is checked by test_sim_skijump.py::test_fixture_regenerates_within_tolerance.)
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from conftest import ROOT

from sportfusion.core import io as sfio
from sportfusion.core import schema

FIX = ROOT / "fixtures"
REL = 1e-4  # of each column's span: loose for another library release, far below a stale fixture's change


def _make_sessions():
    spec = importlib.util.spec_from_file_location("make_sessions", FIX / "make_sessions.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _assert_close(shipped: Path, made: Path) -> None:
    a, _ = sfio.read_table(shipped)
    b, _ = sfio.read_table(made)
    assert a.column_names == b.column_names, shipped
    assert a.num_rows == b.num_rows, f"{shipped}: {a.num_rows} rows shipped, {b.num_rows} made"
    for name in a.column_names:
        ca = a.column(name)
        if pa.types.is_floating(ca.type) or pa.types.is_integer(ca.type):
            x, y = schema.floats(a, name), schema.floats(b, name)
            assert np.array_equal(np.isnan(x), np.isnan(y)), f"{shipped}: {name}"
            ok = ~np.isnan(x)
            span = float(np.ptp(x[ok])) if ok.any() else 0.0
            np.testing.assert_allclose(y[ok], x[ok], rtol=0, atol=1e-9 + REL * span, err_msg=f"{shipped}: {name}")
        else:
            assert ca.equals(b.column(name)), f"{shipped}: {name}"


@pytest.mark.parametrize(
    ("sport", "tables"),
    [
        ("gates", ["truth.parquet", "survey.parquet"]),
        ("gates_body", ["truth.parquet", "raw/survey.parquet"]),
        ("climbing", ["truth.parquet", "holds.parquet", "session.parquet"]),
        ("skirace", ["truth.parquet"]),
    ],
)
def test_shipped_fixture_is_what_its_simulator_makes(sport: str, tables: list[str], tmp_path: Path) -> None:
    getattr(_make_sessions(), f"make_{sport}")(tmp_path)
    for name in tables:
        _assert_close(FIX / sport / name, tmp_path / sport / name)
