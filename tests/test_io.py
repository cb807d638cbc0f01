"""Tables on disk and in pipes: read whole, write atomically, metadata and units attached."""

from __future__ import annotations

import io

import numpy as np
import pyarrow as pa
import pytest

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core.errors import InputError


def _table():
    return pa.table({"t": [0.0, 0.01, 0.02], "acc_x": [1.0, None, 3.0], "custom": ["a", "b", "c"]})


def test_round_trip_through_stream_keeps_meta_and_units():
    meta = sfmeta.add_provenance(sfmeta.new_meta("session", 1_700_000_000.25), "test", {"k": 1})
    data = sfio.table_to_bytes(_table(), meta)
    table, back = sfio.read_table(io.BytesIO(data))
    assert back == meta
    assert table.schema.field("acc_x").metadata == {b"unit": b"m/s^2"}
    assert table.schema.field("t").metadata == {b"unit": b"s"}
    assert table.schema.field("custom").metadata is None  # unregistered: no unit invented
    assert table.column("acc_x").to_pylist() == [1.0, None, 3.0]


def test_write_to_file_is_atomic(tmp_path, monkeypatch):
    dest = tmp_path / "out.parquet"
    dest.write_bytes(b"old")

    def boom(*_a, **_k):
        raise OSError("disk full")

    monkeypatch.setattr("os.replace", boom)
    with pytest.raises(InputError, match="disk full"):  # a clean one-line error, not an OSError
        sfio.write_table(_table(), sfmeta.new_meta(), dest)
    assert dest.read_bytes() == b"old"  # untouched
    assert [p.name for p in tmp_path.iterdir()] == ["out.parquet"]  # no temp file left


def test_write_to_file(tmp_path):
    dest = tmp_path / "out.parquet"
    sfio.write_table(_table(), sfmeta.new_meta(), dest)
    table, meta = sfio.read_table(dest)
    assert table.num_rows == 3 and meta["kind"] == "session"


@pytest.mark.parametrize(
    ("data", "needle"),
    [
        (b"", "empty"),
        (b"hello world, not parquet", "not a Parquet"),
        (b"PAR1garbagegarbagePAR1", "not a readable Parquet"),
    ],
)
def test_bad_bytes(data, needle):
    with pytest.raises(InputError, match=needle):
        sfio.table_from_bytes(data)


def test_wrong_kind_refused():
    data = sfio.table_to_bytes(pa.table({"gate": pa.array([1, 2], pa.int32())}), sfmeta.new_meta("gates"))
    with pytest.raises(InputError, match="'gates' table, expected session"):
        sfio.read_table(io.BytesIO(data), kind="session")


def test_known_column_with_wrong_type_named():
    data = sfio.table_to_bytes(pa.table({"t": [0.0, 1.0], "acc_x": ["a", "b"]}), sfmeta.new_meta())
    with pytest.raises(InputError, match="column 'acc_x' has type string, expected double"):
        sfio.read_table(io.BytesIO(data))


@pytest.mark.parametrize(
    ("t", "needle"),
    [
        ([0.0, 1.0, 1.0], "strictly increasing at row 2"),
        ([0.0, 1.0, 1.0], r"row 2: it repeats the time of row 1 \(t = 1.000000 s"),  # duplicates name the rows
        ([0.0, np.nan], "not finite at row 1"),
        ([0.0, None], "null"),
    ],
)
def test_bad_time_named(t, needle):
    data = sfio.table_to_bytes(pa.table({"t": pa.array(t, pa.float64())}), sfmeta.new_meta())
    with pytest.raises(InputError, match=needle):
        sfio.read_table(io.BytesIO(data))


def test_time_must_be_float64():
    data = sfio.table_to_bytes(pa.table({"t": pa.array([0, 1], pa.int64())}), sfmeta.new_meta())
    with pytest.raises(InputError, match="'t' has type int64, expected double"):
        sfio.read_table(io.BytesIO(data))


def test_missing_t_named():
    data = sfio.table_to_bytes(pa.table({"acc_x": [0.0]}), sfmeta.new_meta())
    with pytest.raises(InputError, match="missing column.*t"):
        sfio.read_table(io.BytesIO(data))


def test_session_unit_override_rides_on_the_field():
    meta = sfmeta.new_meta()
    meta["units"] = {"mag_x": "1"}
    data = sfio.table_to_bytes(pa.table({"t": [0.0], "mag_x": [0.9], "mag_y": [0.1]}), meta)
    table, _ = sfio.read_table(io.BytesIO(data))
    assert table.schema.field("mag_x").metadata == {b"unit": b"1"}
    assert table.schema.field("mag_y").metadata == {b"unit": b"uT"}


def test_written_file_has_the_usual_permissions(tmp_path):
    import os
    import stat

    old = os.umask(0o022)
    try:
        sfio.write_bytes(b"PAR1", tmp_path / "out.parquet")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "out.parquet").stat().st_mode) == 0o644


def test_float_columns_side_by_side_nulls_as_nan():
    """schema.float_columns (and schema.floats, one column of it): numeric columns side by side as float64,
    nulls as NaN, over several chunks, float32, int and nullable int columns."""
    from sportfusion.core import schema

    t = pa.table(
        {
            "a": pa.chunked_array([[1.0, None], [3.0, 4.5]]),
            "b": pa.array([1.5, 2.5, None, 4.0], pa.float32()),
            "c": pa.array([1, 2, 3, 4], pa.int16()),
            "d": pa.array([1, None, 3, 4], pa.int32()),
        }
    )
    names = ("a", "b", "c", "d")
    got = schema.float_columns(t, names)
    nan = np.nan
    want = np.array([[1.0, 1.5, 1.0, 1.0], [nan, 2.5, 2.0, nan], [3.0, nan, 3.0, 3.0], [4.5, 4.0, 4.0, 4.0]])
    assert got.dtype == np.float64 and got.flags.writeable
    np.testing.assert_array_equal(got, want)
    for i, n in enumerate(names):
        one = schema.floats(t, n)
        assert one.dtype == np.float64 and one.flags.writeable and one.flags.c_contiguous
        np.testing.assert_array_equal(one, want[:, i])
