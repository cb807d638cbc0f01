"""Merging multi-rate sensor streams keeps every sample on one strictly increasing clock."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream, merge_streams, order_by_time, validate_time, with_columns


def test_shared_instants_share_a_row():
    a = Stream("imu", [0.0, 0.1, 0.2], {"acc_x": [1.0, 2.0, 3.0]})
    g = Stream("gps", [0.1, 0.25], {"lat": [47.0, 47.1]})
    table, rep = merge_streams([a, g])
    assert table.column("t").to_pylist() == [0.0, 0.1, 0.2, 0.25]
    assert table.column("acc_x").to_pylist() == [1.0, 2.0, 3.0, None]
    assert table.column("lat").to_pylist() == [None, 47.0, None, 47.1]
    assert rep.rows == {"imu": 3, "gps": 2}


def test_identical_repeats_folded_and_counted_conflicts_resolved_first_wins():
    g = Stream("gps", [0.0, 1.0, 1.0, 2.0], {"lat": [1.0, 2.0, 2.0, 3.0]})
    table, rep = merge_streams([g])
    assert table.num_rows == 3 and rep.duplicates == {"gps": 1}
    # issue 15/17: two different samples at one time are no longer refused: the first (file order) wins
    bad = Stream("gps", [0.0, 1.0, 1.0], {"lat": [1.0, 2.0, 2.5]})
    table, rep = merge_streams([bad])
    assert table.column("lat").to_pylist() == [1.0, 2.0]
    assert rep.order["gps"].conflicts == 1 and rep.order["gps"].conflict_rows == [(2, 1.0)]


def test_same_column_from_two_inputs_at_one_instant_refused():
    with pytest.raises(InputError, match="column 'lat' comes from two inputs"):
        merge_streams([Stream("a", [0.0, 1.0], {"lat": [1.0, 2.0]}), Stream("b", [1.0], {"lat": [3.0]})])


def test_unsorted_stream_is_sorted_with_its_values():
    table, _ = merge_streams([Stream("a", [2.0, 0.0, 1.0], {"acc_x": [20.0, 0.0, 10.0]})])
    assert table.column("acc_x").to_pylist() == [0.0, 10.0, 20.0]


def test_registered_types_applied():
    table, _ = merge_streams([Stream("g", [0.0], {"gnss_fix": np.array([4]), "lat": [np.nan]})])
    assert table.schema.field("gnss_fix").type == pa.int16()
    assert table.column("lat").null_count == 1  # NaN means "did not sample"


def test_with_columns_adds_and_replaces():
    table = pa.table({"t": [0.0, 1.0], "x": [1.0, 2.0], "keep": ["a", "b"]})
    out = with_columns(table, {"x": np.array([5.0, 6.0]), "y": np.array([7.0, np.nan])})
    assert out.column_names == ["t", "x", "keep", "y"]
    assert out.column("x").to_pylist() == [5.0, 6.0]
    assert out.column("y").to_pylist() == [7.0, None]


rates = st.lists(
    st.tuples(st.integers(1, 60), st.sampled_from([0.001, 0.01, 0.1, 0.0125, 1 / 3]), st.floats(-5, 5)),
    min_size=1,
    max_size=4,
)


@settings(max_examples=80, deadline=None)
@given(rates)
def test_merge_of_random_multirate_streams_loses_nothing(spec):
    cols = ["acc_x", "gyr_x", "mag_x", "lat"]
    streams = []
    for i, (n, dt, t0) in enumerate(spec):
        t = t0 + dt * np.arange(n)
        streams.append(Stream(f"s{i}", t, {cols[i]: np.arange(n, dtype=float) + 1000 * i}))
    table, rep = merge_streams(streams)
    t = validate_time(table)
    assert np.all(np.diff(t) > 0)
    for i, s in enumerate(streams):
        col = table.column(cols[i])
        assert len(col) - col.null_count == len(s.t)  # every sample kept
        vals = np.array(col.to_pylist(), dtype=object)
        present = np.array([v is not None for v in vals])
        np.testing.assert_array_equal(t[present], np.sort(s.t))
        np.testing.assert_array_equal(vals[present].astype(float), np.arange(len(s.t)) + 1000 * i)
    assert sum(rep.rows.values()) == sum(len(s.t) for s in streams)


def test_time_error_names_the_rows():
    table = pa.table({"t": [0.0, 1.0, 2.0, 2.0, 1.5]})
    with pytest.raises(
        InputError, match=r"at row 3: it repeats the time of row 2 \(t = 2.000000 s then 2.000000 s; 2 such"
    ):
        validate_time(table)


samples = st.lists(
    st.tuples(st.integers(0, 15), st.sampled_from([1.0, 2.0, None]), st.sampled_from([10, 20])), min_size=1, max_size=40
)


@settings(max_examples=150, deadline=None)
@given(samples)
def test_time_order_policy_properties(rows):
    """Any order, repeats and gaps: strictly increasing output, one row per instant, every sample accounted for,
    the first sample in file order wins each column it has, the later ones only fill its nulls."""
    t = np.array([r[0] for r in rows], dtype=float)
    lat = np.array([np.nan if r[1] is None else r[1] for r in rows])
    fix = [r[2] for r in rows]
    out, rep = order_by_time(Stream("g", t, {"lat": lat, "gnss_fix": np.array(fix)}))
    assert np.all(np.diff(out.t) > 0)
    np.testing.assert_array_equal(out.t, np.unique(t))
    assert out.t.size + rep.duplicates + rep.merged + rep.conflicts + rep.no_time == len(rows)
    assert rep.backward_steps == int((np.diff(t) < 0).sum())
    for k, tk in enumerate(out.t):
        idx = [i for i in range(len(rows)) if t[i] == tk]  # file order
        have = [lat[i] for i in idx if np.isfinite(lat[i])]
        assert out.columns["lat"][k].as_py() == (have[0] if have else None)
        assert out.columns["gnss_fix"][k].as_py() == fix[idx[0]]
    # an exactly repeated row never counts as a conflict, and sorting an already ordered stream moves nothing
    again, rep2 = order_by_time(
        Stream("g", np.repeat(out.t, 2), {"gnss_fix": np.repeat(out.columns["gnss_fix"].to_numpy(), 2)})
    )
    assert rep2.duplicates == out.t.size and rep2.conflicts == 0 and rep2.reordered == 0


def test_to_arrow_float_columns_nulls_views_and_byte_order() -> None:
    """NaN -> null; a strided view (a state column), float32 and big-endian input keep their values; the
    float path builds its buffers without importing numpy.ma."""
    import subprocess
    import sys

    from sportfusion.core import schema

    x = np.arange(40.0).reshape(10, 4)
    x[3, 1] = np.nan
    col = schema.to_arrow("x", x[:, 1])
    col.validate(full=True)
    assert col.type == pa.float64() and col.null_count == 1
    assert col.to_pylist() == [v if not np.isnan(v) else None for v in x[:, 1]]
    for a in (np.array([1.5, 2.5], ">f8"), np.array([1.5, np.nan], np.float32), np.zeros(0)):
        got = schema.to_arrow("x", a)
        got.validate(full=True)
        assert got.to_pylist() == [None if np.isnan(v) else float(v) for v in a]
    code = (
        "import sys, numpy as np; from sportfusion.core import schema; "
        "schema.to_arrow('x', np.array([1.0, np.nan])); schema.to_arrow('x', np.ones(5)); "
        "print('numpy.ma' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_numeric_array_integers_with_nulls() -> None:
    from sportfusion.core import schema

    hid = np.array([3, -1, 7, -1], dtype=np.int64)
    arr = schema.numeric_array(hid.astype(np.int32), hid < 0)
    arr.validate(full=True)
    assert arr.type == pa.int32() and arr.to_pylist() == [3, None, 7, None]
    assert schema.numeric_array(np.arange(3)[::-1]).to_pylist() == [2, 1, 0]
    flags = np.array([True, False, True, True, False, False, True, False, True])  # over one byte: bit-packed
    null = np.zeros(9, bool)
    null[[1, 8]] = True
    got = schema.numeric_array(flags, null)
    got.validate(full=True)
    assert got.type == pa.bool_()
    assert got.to_pylist() == [None if n else bool(f) for f, n in zip(flags, null, strict=True)]
    assert schema.numeric_array(flags[::2]).to_pylist() == flags[::2].tolist()


def test_nulling_nan_estimates_keeps_pyarrow_compute_out() -> None:
    """nonfinite_to_null (every command's write) nulls NaN in float64 and float32 columns without importing
    pyarrow.compute (0.1 s of a command's CPU): no cast of the rebuilt column.  Run as a console script
    runs (pandas kept out: pyarrow would import it, and it imports pyarrow.compute)."""
    import subprocess
    import sys

    code = (
        "import sys; from sportfusion.tools import _cli; sys.meta_path.insert(0, _cli._NoPandas); "
        "import numpy as np, pyarrow as pa; from sportfusion.core.session import nonfinite_to_null; "
        "t = pa.table({'x': np.array([1.0, np.nan, np.inf]), 'y': np.array([np.nan, 2.0, 3.0], np.float32)}); "
        "out, n = nonfinite_to_null(t); "
        "print(out.column('x').to_pylist(), out.column('y').to_pylist(), out.schema.types, n, "
        "'pyarrow.compute' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[1.0, None, None] [None, 2.0, 3.0] [DataType(double), DataType(float)] {'x': 2, 'y': 1} False"
