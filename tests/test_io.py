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


def _mixed_table(n: int = 500) -> pa.Table:
    rng = np.random.default_rng(3)
    return pa.table(
        {
            "t": np.arange(n) * 0.01,
            "acc_x": pa.array(rng.normal(size=n)).fill_null(0.0),
            "gnss_fix": pa.array(rng.integers(0, 3, n).astype(np.int16)),
            "gate": pa.array(np.arange(n, dtype=np.int32)),
            "name": pa.array([f"p{i % 7}" for i in range(n)]),
            "mag_x": pa.array([None if i % 11 == 0 else float(i) for i in range(n)], pa.float64()),
        }
    )


def _footer(data: bytes) -> list:
    """Per column of the (only) row group: its encodings and compression, as the footer declares them."""
    import pyarrow.parquet as pq

    md = pq.ParquetFile(pa.BufferReader(data)).metadata
    assert md.num_row_groups == 1
    rg = md.row_group(0)
    return [
        (rg.column(i).path_in_schema, rg.column(i).encodings, rg.column(i).compression) for i in range(rg.num_columns)
    ]


def _assert_same_table(got: pa.Table, want: pa.Table) -> None:
    """Same columns, types and metadata (schema and fields); float values equal to a relative 1e-12 (NaN and
    null alike), the other columns equal."""
    assert got.schema.equals(want.schema, check_metadata=True)
    for name in want.column_names:
        a, b = got.column(name), want.column(name)
        assert a.null_count == b.null_count, name
        if pa.types.is_floating(b.type):
            np.testing.assert_allclose(
                a.to_numpy(zero_copy_only=False), b.to_numpy(zero_copy_only=False), rtol=1e-12, atol=0, err_msg=name
            )
        else:
            assert a.to_pylist() == b.to_pylist(), name


def test_compiled_parquet_writer_writes_what_pyarrow_parquet_writes():
    """io writes with pyarrow's compiled writer (no pyarrow.parquet import): same table, metadata, encodings
    (float columns BYTE_STREAM_SPLIT, others dictionary) and zstd as pyarrow.parquet.write_table's."""
    import pyarrow.parquet as pq

    meta = sfmeta.new_meta("session", 1_700_000_000.0)
    table = _mixed_table()
    ours = sfio.table_to_bytes(table, meta)
    final = sfio.finalize(table, meta)
    floats_ = [f.name for f in final.schema if pa.types.is_floating(f.type)]
    others = [f.name for f in final.schema if not pa.types.is_floating(f.type)]
    sink = pa.BufferOutputStream()
    pq.write_table(
        final, sink, compression="zstd", compression_level=-1, use_dictionary=others, use_byte_stream_split=floats_
    )
    ref = sink.getvalue().to_pybytes()
    back, ref_back = sfio.table_from_bytes(ours), pq.read_table(pa.BufferReader(ref))
    _assert_same_table(back, ref_back)
    assert _footer(ours) == _footer(ref)
    enc = dict((name, e) for name, e, _ in _footer(ours))
    assert "BYTE_STREAM_SPLIT" in enc["acc_x"] and "BYTE_STREAM_SPLIT" not in enc["gate"]
    assert any("DICTIONARY" in e for e in enc["name"])
    assert {c for _, _, c in _footer(ours)} == {"ZSTD"}


def test_parquet_falls_back_to_pyarrow_parquet(monkeypatch):
    """Where a pyarrow's compiled reader or writer does not take io's arguments, pyarrow.parquet does the work:
    the same bytes are written and read."""
    from types import SimpleNamespace

    meta = sfmeta.new_meta("session", 1_700_000_000.0)
    table = _mixed_table(50)
    direct = sfio.table_to_bytes(table, meta)

    class Refuses:
        def __init__(self, *_a, **_k):
            raise TypeError("__cinit__() got an unexpected keyword argument")

    calls = []

    def compiled():
        calls.append(1)
        return SimpleNamespace(ParquetWriter=Refuses, ParquetReader=Refuses)

    monkeypatch.setattr(sfio, "_compiled_parquet", compiled)
    fallback = sfio.table_to_bytes(table, meta)
    assert _footer(fallback) == _footer(direct)
    got, got_meta = sfio.read_table(io.BytesIO(fallback))
    want, _ = sfio.read_table(io.BytesIO(direct))
    _assert_same_table(got, want)
    assert got_meta == meta
    assert len(calls) == 3  # the write and both reads tried the compiled module first
    with pytest.raises(InputError, match="not a readable Parquet"):
        sfio.table_from_bytes(b"PAR1garbagegarbagePAR1")


def test_reading_and_writing_a_table_leaves_pyarrow_fs_unimported(tmp_path):
    """A command's read and write import neither pyarrow.parquet nor pyarrow.fs (S3, GCS, Azure, ssl: ~30 ms)."""
    import subprocess
    import sys

    src = tmp_path / "in.parquet"
    sfio.write_table(_mixed_table(20), sfmeta.new_meta("session", 1_700_000_000.0), src)
    prog = (
        "import sys\nfrom sportfusion.core import io\n"
        f"t, m = io.read_table({str(src)!r})\nio.write_table(t, m, {str(tmp_path / 'out.parquet')!r})\n"
        "print(sorted(k for k in ('pyarrow.parquet', 'pyarrow.fs', 'pyarrow._s3fs', 'ssl') if k in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", prog], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
    assert sfio.read_table(tmp_path / "out.parquet")[0].num_rows == 20


def test_write_table_streams_the_same_table_to_a_stream_a_path_and_stdout(tmp_path, capsysbinary):
    """write_table encodes into its destination page by page: each reads back as table_to_bytes' table, with
    the same footer (encodings, compression) and metadata."""
    meta = sfmeta.new_meta("session", 1_700_000_000.0)
    table = _mixed_table(3000)
    want = sfio.table_to_bytes(table, meta)
    stream = io.BytesIO()
    sfio.write_table(table, meta, stream)
    sfio.write_table(table, meta, tmp_path / "out.parquet")
    sfio.write_table(table, meta, None)
    outs = {"stream": stream.getvalue(), "path": (tmp_path / "out.parquet").read_bytes()}
    outs["stdout"] = capsysbinary.readouterr().out
    ref, ref_meta = sfio.read_table(io.BytesIO(want))
    for where, data in outs.items():
        assert _footer(data) == _footer(want), where
        got, got_meta = sfio.read_table(io.BytesIO(data))
        _assert_same_table(got, ref)
        assert got_meta == ref_meta == meta, where


def test_a_failure_while_encoding_leaves_the_output_file_untouched(tmp_path, monkeypatch):
    dest = tmp_path / "out.parquet"
    old_meta = sfmeta.new_meta("session", 1_600_000_000.0)
    sfio.write_table(_mixed_table(40), old_meta, dest)  # the previous run's output
    old, _ = sfio.read_table(dest)

    def half(table, meta, sink):
        sink.write(b"PAR1 half a file")
        raise MemoryError("while encoding")

    monkeypatch.setattr(sfio, "encode_table", half)
    with pytest.raises(MemoryError):
        sfio.write_table(_table(), sfmeta.new_meta(), dest)
    kept, kept_meta = sfio.read_table(dest)  # still the previous output, whole
    _assert_same_table(kept, old)
    assert kept_meta == old_meta
    assert [p.name for p in tmp_path.iterdir()] == ["out.parquet"]  # no temp file left


def test_a_reader_that_stops_early_is_a_broken_pipe_for_the_writer():
    """The encoder writes into stdout as it goes: a downstream reader that exits early (``| head``) raises
    BrokenPipeError in the writer (what the commands catch: exit 1, no traceback), not an Arrow error."""
    import subprocess
    import sys

    prog = (
        "import sys, numpy as np, pyarrow as pa\n"
        "from sportfusion.core import io, meta\n"
        "t = pa.table({'t': np.arange(200000) * 0.01, 'acc_x': np.random.default_rng(1).normal(size=200000)})\n"
        "try:\n"
        "    io.write_table(t, meta.new_meta('session', 1.7e9), None)\n"
        "except BaseException as exc:\n"
        "    print(type(exc).__name__, file=sys.stderr)\n"
    )
    p = subprocess.Popen([sys.executable, "-c", prog], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert p.stdout.read(4) == b"PAR1"
    p.stdout.close()
    err = p.stderr.read().decode()
    p.wait(timeout=60)
    assert err.strip().splitlines()[0] == "BrokenPipeError", err


@pytest.mark.parametrize("engine", ["compiled", "pyarrow.parquet"])
def test_an_interrupted_write_leaves_no_footer(engine, monkeypatch, capfd):
    """Ctrl-C (or any failure) while the encoder writes into stdout: what reached the stream so far is not
    closed with a Parquet footer, so the next stage refuses it instead of reading part of a table."""
    import gc
    from types import SimpleNamespace

    if engine == "pyarrow.parquet":

        class Refuses:
            def __init__(self, *_a, **_k):
                raise TypeError("unexpected keyword argument")

        monkeypatch.setattr(sfio, "_compiled_parquet", lambda: SimpleNamespace(ParquetWriter=Refuses))

    class Interrupted(io.BytesIO):
        calls = 0

        def write(self, data):
            self.calls += 1
            if self.calls == 3:
                raise KeyboardInterrupt
            return super().write(data)

    n = 300_000
    rng = np.random.default_rng(0)
    table = pa.table({"t": np.arange(n) * 0.01, "acc_x": rng.normal(size=n), "acc_y": rng.normal(size=n)})
    sink = Interrupted()
    with pytest.raises(KeyboardInterrupt):
        sfio.write_table(table, sfmeta.new_meta("session", 1.7e9), sink)
    gc.collect()  # the writer's destructor has run
    written = sink.getvalue()
    assert 0 < len(written) < 100_000 and written[-4:] != b"PAR1"
    with pytest.raises(InputError, match="not a Parquet"):
        sfio.table_from_bytes(written)
    assert "Exception ignored" not in capfd.readouterr().err
