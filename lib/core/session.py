"""Session tables: one row per instant, the union of all sensors' sample times.

A sensor's columns are null where that sensor did not sample.  Nothing is
resampled or dropped: :func:`merge_streams` places every sample of every
stream on the union of their times.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError


def validate_time(table: pa.Table) -> np.ndarray:
    """Check column ``t``: float64, no nulls, finite, strictly increasing. Return it."""
    schema.require_columns(table, ("t",), "a session table")
    col = table.column("t")
    if col.type != pa.float64():
        raise InputError(f"column 't' has type {col.type}, expected float64 seconds")
    if col.null_count:
        raise InputError(f"column 't' has {col.null_count} null value(s), expected a time on every row")
    t = col.to_numpy()
    bad = ~np.isfinite(t)
    if bad.any():
        raise InputError(f"column 't' is not finite at row {int(np.argmax(bad))}, expected finite seconds")
    if t.size > 1:
        step = np.diff(t)
        if (step <= 0).any():
            i = int(np.argmax(step <= 0))
            raise InputError(
                f"column 't' is not strictly increasing at row {i + 1} "
                f"({t[i]:.6f} s then {t[i + 1]:.6f} s), expected strictly increasing times"
            )
    return t


@dataclass
class Stream:
    """One sensor's samples on its own time base.

    Attributes
    ----------
    name : str
        Sensor name used in messages (``"accelerometer"``, ``"nmea"``).
    t : numpy.ndarray
        Sample times [s] on the session clock.
    columns : dict
        Column name -> values (numpy array, list or pyarrow array), one per sample.
    """

    name: str
    t: np.ndarray
    columns: dict[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=np.float64)
        for k, v in self.columns.items():
            if len(v) != len(self.t):  # type: ignore[arg-type]
                raise InputError(f"{self.name}: column '{k}' has {len(v)} values for {len(self.t)} times")  # type: ignore[arg-type]


@dataclass
class MergeReport:
    """What :func:`merge_streams` did: rows per stream and duplicates folded."""

    rows: dict[str, int] = field(default_factory=dict)
    duplicates: dict[str, int] = field(default_factory=dict)


def _dedupe(stream: Stream, report: MergeReport) -> Stream:
    """Sort a stream by time and fold rows with identical time and identical values.

    Two different samples at one instant cannot both live on one row; that is
    an error, not something to drop silently.
    """
    t = stream.t
    if not np.isfinite(t).all():
        raise InputError(f"{stream.name}: {int((~np.isfinite(t)).sum())} sample(s) without a valid time")
    order = np.argsort(t, kind="stable")
    cols = {k: schema.to_arrow(k, v).take(pa.array(order)) for k, v in stream.columns.items()}
    t = t[order]
    dup = np.flatnonzero(np.diff(t) == 0) + 1
    if dup.size:
        keep = np.ones(t.size, bool)
        for i in dup:
            same = all(c[int(i)].equals(c[int(i) - 1]) for c in cols.values())
            if not same:
                raise InputError(
                    f"{stream.name}: two different samples at t = {t[i]:.6f} s; "
                    "expected one sample per instant per sensor"
                )
            keep[i] = False
        report.duplicates[stream.name] = int(dup.size)
        idx = pa.array(np.flatnonzero(keep))
        cols = {k: c.take(idx) for k, c in cols.items()}
        t = t[keep]
    return Stream(stream.name, t, cols)


def merge_streams(streams: Sequence[Stream]) -> tuple[pa.Table, MergeReport]:
    """Merge sensor streams into one session table on the union of their times.

    Samples of different streams at exactly the same time share a row.  Two
    streams may not both provide a column at the same instant.  Repeated
    identical samples within a stream (GPS loggers repeat fixes) are folded and
    counted in the report; conflicting repeats are an error.

    Returns
    -------
    table : pyarrow.Table
        Column ``t`` first, then every stream's columns in first-seen order.
    report : MergeReport
    """
    report = MergeReport()
    clean = [_dedupe(s, report) for s in streams if len(s.t)]
    if not clean:
        raise InputError("no samples found in the input(s)")
    t_all = np.unique(np.concatenate([s.t for s in clean]))
    n = t_all.size
    names: list[str] = []
    for s in clean:
        names += [k for k in s.columns if k not in names and k != "t"]
    out: dict[str, pa.Array] = {"t": pa.array(t_all, type=pa.float64())}
    for name in names:
        owners = [s for s in clean if name in s.columns]
        typ = schema.lookup(name).type if schema.lookup(name) else owners[0].columns[name].type  # type: ignore[union-attr]
        idx_all = np.full(n, -1, dtype=np.int64)
        chunks = []
        offset = 0
        for s in owners:
            rows = np.searchsorted(t_all, s.t)
            if (idx_all[rows] >= 0).any():
                clash = t_all[rows[idx_all[rows] >= 0][0]]
                raise InputError(
                    f"column '{name}' comes from two inputs at t = {clash:.6f} s; rename one or shift it with --offset"
                )
            idx_all[rows] = offset + np.arange(s.t.size)
            chunks.append(s.columns[name].cast(typ))  # type: ignore[union-attr]
            offset += s.t.size
        values = pa.concat_arrays(chunks) if len(chunks) > 1 else chunks[0]
        out[name] = values.take(pa.array(idx_all, mask=idx_all < 0))
    for s in clean:
        report.rows[s.name] = int(s.t.size)
    return pa.table(out), report


def with_columns(table: pa.Table, columns: Mapping[str, object]) -> pa.Table:
    """Add or replace columns (registered types applied), keeping every other column."""
    for name, values in columns.items():
        arr = schema.to_arrow(name, values)
        if name in table.column_names:
            table = table.set_column(table.column_names.index(name), name, arr)
        else:
            table = table.append_column(name, arr)
    return table


#: Measured (raw sensor) columns: a reader may keep what the file said there, so they are never
#: rewritten by :func:`nonfinite_to_null`; everything else a tool writes is an estimate or derived.
RAW_PREFIXES = ("acc_", "gyr_", "mag_", "vel_", "dev_q", "true_", "gnss_sigma", "gnss_sd")
RAW_NAMES = frozenset({"t", "lat", "lon", "h", "h_msl", "pressure", "gnss_hdop", "gnss_speed", "gnss_course"})


def is_raw(name: str) -> bool:
    """Whether ``name`` is a measured sensor column (see :data:`RAW_PREFIXES`)."""
    return (
        name in RAW_NAMES
        or name.startswith(RAW_PREFIXES)
        or name.startswith("gnss_")
        and name[5:]
        in (
            "age",
            "ratio",
        )
    )


def nonfinite_to_null(
    table: pa.Table, keep: set[str] | frozenset[str] = frozenset()
) -> tuple[pa.Table, dict[str, int]]:
    """Replace NaN and +-inf by null in the floating-point estimate columns of ``table``.

    A command never writes NaN/inf into an estimate: where there is none the value is null.
    Raw sensor columns (:func:`is_raw`) and the columns named in ``keep`` (passed through
    unchanged from the input) are left as they are.

    Returns
    -------
    table : pyarrow.Table
    counts : dict
        Column name -> number of values made null (only columns that had some).
    """
    import pyarrow.compute as pc

    counts: dict[str, int] = {}
    for i, name in enumerate(table.column_names):
        col = table.column(i)
        if name in keep or is_raw(name) or not pa.types.is_floating(col.type):
            continue
        bad = pc.invert(pc.is_finite(col))  # null stays null; NaN and inf are True
        n = pc.sum(bad).as_py() or 0
        if n:
            counts[name] = int(n)
            table = table.set_column(i, table.field(i), pc.if_else(bad, pa.scalar(None, col.type), col))
    return table, counts


#: Physically possible magnitudes of raw sensor values [column unit]; beyond them (or NaN/inf) a
#: value is a corrupt sample, dropped to null when a table is read (the reader says how many).
POSSIBLE: dict[str, float] = {
    "acc_": 2000.0,  # m/s^2 (about 200 g; consumer IMUs clip at 16-32 g)
    "gyr_": 200.0,  # rad/s (about 11,000 deg/s)
    "mag_": 10000.0,  # uT (Earth ~25-65 uT; a magnet at the sensor a few mT)
    "vel_": 1000.0,  # m/s
    "gnss_sigma": 1e6,  # m
    "gnss_sd": 1e6,  # m
}
_POSSIBLE_RANGE = {"lat": (-90.0, 90.0), "lon": (-180.0, 360.0), "h": (-1000.0, 100000.0), "h_msl": (-1000.0, 100000.0)}


def drop_impossible(table: pa.Table) -> tuple[pa.Table, dict[str, int]]:
    """Null the raw sensor values that are NaN, inf or physically impossible (see :data:`POSSIBLE`).

    Returns the cleaned table and column name -> number of values dropped (columns with any).
    """
    import pyarrow.compute as pc

    counts: dict[str, int] = {}
    for i, name in enumerate(table.column_names):
        col = table.column(i)
        if not pa.types.is_floating(col.type):
            continue
        if name in _POSSIBLE_RANGE:
            lo, hi = _POSSIBLE_RANGE[name]
        else:
            bound = next((v for k, v in POSSIBLE.items() if name.startswith(k)), None)
            if bound is None:
                continue
            lo, hi = -bound, bound
        ok = pc.and_(pc.is_finite(col), pc.and_(pc.greater_equal(col, lo), pc.less_equal(col, hi)))
        bad = pc.invert(ok)
        n = pc.sum(bad).as_py() or 0
        if n:
            counts[name] = int(n)
            table = table.set_column(i, table.field(i), pc.if_else(bad, pa.scalar(None, col.type), col))
    return table, counts
