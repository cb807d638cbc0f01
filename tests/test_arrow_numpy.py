"""Arrow float and bool columns read into numpy without pyarrow.compute: nulls, offsets, chunks, float32."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest

from sportfusion.core.schema import flags, float_values
from sportfusion.core.session import drop_impossible, nonfinite_to_null


@pytest.mark.parametrize("typ", [pa.float64(), pa.float32()])
def test_float_values_nulls_offsets_and_chunks(typ: pa.DataType) -> None:
    raw = [1.0, None, 3.0, float("nan"), 5.0, None, 7.0, 8.0, 9.0, None]
    arr = pa.array(raw, type=typ)
    for col in (arr, arr.slice(3, 6), pa.chunked_array([arr.slice(0, 4), arr.slice(4)])):
        want = col.to_pylist()
        vals, valid = float_values(col)
        assert vals.dtype == typ.to_pandas_dtype() and vals.size == len(want)
        assert valid is not None and valid.tolist() == [v is not None for v in want]
        for v, ok, w in zip(vals, valid, want, strict=True):
            assert not ok or (np.isnan(v) and np.isnan(w)) or v == w
    vals, valid = float_values(pa.chunked_array([pa.array([1.0, 2.0])]))
    assert valid is None and vals.tolist() == [1.0, 2.0]


def test_flags_nulls_as_false_with_offsets_and_chunks() -> None:
    raw = [True, None, False, True, True, None, False, True, True, True, None]
    arr = pa.array(raw, type=pa.bool_())
    for col in (
        arr,
        arr.slice(3, 7),
        pa.chunked_array([arr.slice(0, 5), arr.slice(5)]),
        pa.chunked_array([arr.slice(1, 9)]),
        pa.array([True, False] * 9),
        pa.array([], type=pa.bool_()),
    ):
        want = [bool(v) for v in col.to_pylist()]  # None -> False
        got = flags(pa.table({"grip": col}), "grip")
        assert got.dtype == bool and got.tolist() == want
    with pytest.raises(TypeError):
        flags(pa.table({"grip": [1.0]}), "grip")


def test_drop_impossible_counts_new_nulls_only_and_keeps_old_ones() -> None:
    acc = pa.chunked_array([pa.array([1.0, None, 1e9]), pa.array([float("inf"), 2.0, float("nan")])])
    table = pa.table({"t": np.arange(6.0), "acc_x": acc, "lat": [0.0, 91.0, None, 45.0, -90.0, 90.0]})
    out, counts = drop_impossible(table)
    assert counts == {"acc_x": 3, "lat": 1}
    assert out.column("acc_x").to_pylist() == [1.0, None, None, None, 2.0, None]
    assert out.column("lat").to_pylist() == [0.0, None, None, 45.0, -90.0, 90.0]
    assert out.column("t").to_pylist() == list(range(6))
    same, none = drop_impossible(out)
    assert none == {} and same.equals(out)


def test_nonfinite_to_null_in_estimates_only() -> None:
    table = pa.table({"x": [1.0, float("nan"), None, float("-inf")], "acc_x": [float("nan")] * 4})
    out, counts = nonfinite_to_null(table)
    assert counts == {"x": 2}
    assert out.column("x").to_pylist() == [1.0, None, None, None]
    assert np.isnan(out.column("acc_x").to_pylist()).all()  # a raw sensor column is left as it is
