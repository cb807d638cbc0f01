"""Session tables: one row per instant, the union of all sensors' sample times.

A sensor's columns are null where that sensor did not sample.  Nothing is
resampled or dropped: :func:`merge_streams` places every sample of every
stream on the union of their times.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.stats import unique


def time_step_problem(t: np.ndarray) -> str | None:
    """Where times ``t`` [s] first fail to increase strictly, naming the rows (index and t); None if they do."""
    t = np.asarray(t, dtype=np.float64)
    if t.size < 2:
        return None
    step = np.diff(t)
    bad = ~(step > 0)
    if not bad.any():
        return None
    i = int(np.argmax(bad))
    what = "repeats the time of" if step[i] == 0 else "is not later than"
    return (
        f"row {i + 1}: it {what} row {i} (t = {t[i]:.6f} s then {t[i + 1]:.6f} s; {int(bad.sum())} such step(s) in all)"
    )


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
    problem = time_step_problem(t)
    if problem is not None:
        raise InputError(f"column 't' is not strictly increasing at {problem}, expected strictly increasing times")
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
class TimeOrder:
    """What :func:`order_by_time` did to one stream (the one time-ordering policy of ``ingest``).

    Attributes
    ----------
    samples : int
        Samples in the stream as the reader gave them.
    backward_steps : int
        Places where the time stepped back in the reader's order.
    reordered : int
        Samples that are not at their input position after the stable sort.
    no_time : int
        Samples without a finite time, dropped (a row needs a time).
    duplicates : int
        Exact duplicates dropped: same time and the same value in every column.
    merged : int
        Samples at the time of an earlier one whose values complete it without
        contradicting it (each column non-null in at most one of them, or equal):
        folded into that row, nothing lost.
    conflicts : int
        Samples at the time of an earlier one with a different value in some
        column: the earlier sample (file order) wins those columns, the later
        one only fills the columns the earlier left null.
    conflict_rows : list of (int, float)
        Input index (0-based, the reader's order) and time [s] of the first
        conflicting samples (at most 5), for messages.
    no_time_rows : list of int
        Input index of the first samples without a time (at most 5).
    """

    samples: int = 0
    backward_steps: int = 0
    reordered: int = 0
    no_time: int = 0
    duplicates: int = 0
    merged: int = 0
    conflicts: int = 0
    conflict_rows: list[tuple[int, float]] = field(default_factory=list)
    no_time_rows: list[int] = field(default_factory=list)

    def counts(self) -> dict[str, int]:
        """The counts as a plain dict (for provenance and metadata)."""
        return {
            "samples": self.samples,
            "backward_steps": self.backward_steps,
            "reordered": self.reordered,
            "no_time_dropped": self.no_time,
            "duplicates_dropped": self.duplicates,
            "same_time_merged": self.merged,
            "same_time_conflicts": self.conflicts,
        }

    def describe(self) -> str:
        """One short phrase of what was done, empty when the stream was already in order."""
        parts = []
        if self.backward_steps:
            parts.append(f"{self.backward_steps} backward time step(s), {self.reordered} sample(s) reordered")
        if self.no_time:
            parts.append(f"{self.no_time} sample(s) without a time dropped")
        if self.duplicates:
            parts.append(f"{self.duplicates} exact duplicate(s) dropped")
        if self.merged:
            parts.append(f"{self.merged} same-time sample(s) merged")
        if self.conflicts:
            parts.append(f"{self.conflicts} same-time conflict(s): first in file order kept")
        return ", ".join(parts)


def order_by_time(stream: Stream) -> tuple[Stream, TimeOrder]:
    """Apply the time-ordering policy to one stream: sort, fold same-time samples, count.

    The policy, for every format ``ingest`` reads:

    1. Time stays absolute (nothing is re-stamped or shifted).
    2. Samples are sorted by time with a *stable* sort, so samples at one
       instant keep the reader's (file) order.
    3. Samples at the same time become one row: an exact duplicate is dropped;
       a sample that only completes the first (fills columns it left null,
       agrees where both have a value) is merged into it; where they disagree,
       the first in file order wins and the later sample's other values still
       fill the nulls.  Every case is counted in the returned :class:`TimeOrder`
       (conflicts with their input index and time).
    4. Samples without a finite time cannot be placed on a row: they are
       dropped and counted, never silently.

    Parameters
    ----------
    stream : Stream
        One sensor's samples in the reader's order, times [s].

    Returns
    -------
    stream : Stream
        Strictly increasing times, columns as Arrow arrays of their registered types.
    report : TimeOrder
    """
    t_in = np.asarray(stream.t, dtype=np.float64)
    rep = TimeOrder(samples=int(t_in.size))
    cols_in = {k: _nan_as_null(schema.to_arrow(k, v)) for k, v in stream.columns.items()}
    finite = np.isfinite(t_in)
    idx_in = np.flatnonzero(finite)
    rep.no_time = int(t_in.size - idx_in.size)
    rep.no_time_rows = [int(i) for i in np.flatnonzero(~finite)[:5]]
    t_ok = t_in[idx_in]
    rep.backward_steps = int((np.diff(t_ok) < 0).sum()) if t_ok.size > 1 else 0
    order = idx_in[np.argsort(t_ok, kind="stable")]
    rep.reordered = int((order != idx_in).sum())
    t = t_in[order]
    moved = rep.reordered or rep.no_time
    cols = {k: c.take(pa.array(order)) for k, c in cols_in.items()} if moved else cols_in
    if t.size < 2 or not (np.diff(t) == 0).any():
        return Stream(stream.name, t, cols), rep
    n = t.size
    new_instant = np.r_[True, np.diff(t) != 0]
    start = np.flatnonzero(new_instant)  # first row of each instant
    size = np.diff(np.r_[start, n])
    first = np.repeat(start, size)  # first row of each row's instant
    later = np.flatnonzero(first != np.arange(n))  # rows folded into an earlier one
    # only the rows of instants with several samples need looking at
    multi = np.flatnonzero(size > 1)
    rows_m = np.flatnonzero(np.repeat(size > 1, size))
    seg_m = np.r_[0, np.cumsum(size[multi])[:-1]]  # where each such instant starts in rows_m
    exact = np.ones(later.size, dtype=bool)
    clash = np.zeros(later.size, dtype=bool)
    out: dict[str, pa.Array] = {}
    import pyarrow.compute as pc  # lazy: a command's --help does not pay for it

    for k, c in cols.items():
        a, b = c.take(pa.array(later)), c.take(pa.array(first[later]))
        va, vb = _valid(a), _valid(b)
        same = np.asarray(pc.fill_null(pc.equal(a, b), False).to_numpy(zero_copy_only=False), dtype=bool)
        exact &= (va & vb & same) | (~va & ~vb)
        clash |= va & vb & ~same
        # per instant, the first non-null value in file order (the first sample's own where it has one)
        cand = np.where(_valid(c.take(pa.array(rows_m))), rows_m, n)
        first_valid = np.minimum.reduceat(cand, seg_m) if rows_m.size else np.zeros(0, dtype=np.int64)
        pick = start.copy()
        pick[multi] = np.where(first_valid < n, first_valid, start[multi])
        out[k] = c.take(pa.array(pick))
    rep.duplicates = int(exact.sum())
    rep.conflicts = int(clash.sum())
    rep.merged = int(later.size - rep.duplicates - rep.conflicts)
    rep.conflict_rows = [(int(order[i]), float(t[i])) for i in later[clash][:5]]
    return Stream(stream.name, t[start], out), rep


def _valid(arr: pa.Array) -> np.ndarray:
    """Boolean numpy mask of the non-null entries."""
    return ~np.asarray(arr.is_null().to_numpy(zero_copy_only=False), dtype=bool)


def _nan_as_null(arr: pa.Array) -> pa.Array:
    """NaN in a float array -> null (the table's 'did not sample'), so equal rows compare equal."""
    import pyarrow.compute as pc

    if pa.types.is_floating(arr.type) and len(arr) and pc.any(pc.is_nan(arr)).as_py():
        return pc.if_else(pc.is_nan(arr), pa.scalar(None, arr.type), arr)
    return arr


@dataclass
class MergeReport:
    """What :func:`merge_streams` did: rows per stream, duplicates folded, time order per stream."""

    rows: dict[str, int] = field(default_factory=dict)
    duplicates: dict[str, int] = field(default_factory=dict)
    order: dict[str, TimeOrder] = field(default_factory=dict)


def _ordered(stream: Stream, report: MergeReport) -> Stream:
    clean, rep = order_by_time(stream)
    report.order[stream.name] = rep
    if rep.duplicates:
        report.duplicates[stream.name] = rep.duplicates
    return clean


def merge_streams(streams: Sequence[Stream]) -> tuple[pa.Table, MergeReport]:
    """Merge sensor streams into one session table on the union of their times.

    Samples of different streams at exactly the same time share a row.  Two
    streams may not both provide a column at the same instant.  Each stream
    first goes through :func:`order_by_time` (sorted, same-time samples folded
    by its documented rule, everything counted in ``report.order``).

    Returns
    -------
    table : pyarrow.Table
        Column ``t`` first, then every stream's columns in first-seen order.
    report : MergeReport
    """
    report = MergeReport()
    clean = [_ordered(s, report) for s in streams if len(s.t)]
    if not any(len(s.t) for s in clean):
        lost = sum(r.no_time for r in report.order.values())
        why = f" ({lost} sample(s) without a finite time)" if lost else ""
        raise InputError(f"no samples found in the input(s){why}; expected samples with times")
    t_all = unique(np.concatenate([s.t for s in clean]))
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
                row = int(rows[idx_all[rows] >= 0][0])
                raise InputError(
                    f"column '{name}' comes from two inputs at row {row} (t = {t_all[row]:.6f} s); "
                    "rename one or shift it with --offset"
                )
            idx_all[rows] = offset + np.arange(s.t.size)
            chunks.append(s.columns[name].cast(typ))  # type: ignore[union-attr]
            offset += s.t.size
        values = pa.concat_arrays(chunks) if len(chunks) > 1 else chunks[0]
        out[name] = values.take(schema.numeric_array(idx_all, idx_all < 0))
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
    """Whether ``name`` is a measured sensor column (see :data:`RAW_PREFIXES`; a segment's sensor
    ``femur_r__acc_x`` counts as its ``acc_x``)."""
    name = schema.sensor_column(name)
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
    counts: dict[str, int] = {}
    for i, name in enumerate(table.column_names):
        col = table.column(i)
        if name in keep or is_raw(name) or not pa.types.is_floating(col.type):
            continue
        table, n = _null_where(table, i, lambda v: ~np.isfinite(v))
        if n:
            counts[name] = n
    return table, counts


def _null_where(table: pa.Table, i: int, bad_of: Callable[[np.ndarray], np.ndarray]) -> tuple[pa.Table, int]:
    """Null the values of float column ``i`` where ``bad_of(values)`` is True (numpy, no pyarrow.compute:
    its import alone costs a command 0.1 s); returns the table and how many values were made null.
    Existing nulls stay null and are not counted."""
    col = table.column(i)
    vals, valid = schema.float_values(col)
    with np.errstate(invalid="ignore"):
        bad = bad_of(vals)
    if valid is not None:
        bad &= valid
    n = int(np.count_nonzero(bad))
    if n:
        mask = bad if valid is None else bad | ~valid
        arr = schema.numeric_array(vals, mask)  # vals has the column's float dtype: no cast (pyarrow.compute)
        if arr.type != col.type:
            arr = pa.array(vals, type=col.type, mask=mask)
        table = table.set_column(i, table.field(i), arr)
    return table, n


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
    counts: dict[str, int] = {}
    for i, name in enumerate(table.column_names):
        col = table.column(i)
        if not pa.types.is_floating(col.type):
            continue
        if name in _POSSIBLE_RANGE:
            lo, hi = _POSSIBLE_RANGE[name]
        else:
            base = schema.sensor_column(name)
            bound = next((v for k, v in POSSIBLE.items() if base.startswith(k)), None)
            if bound is None:
                continue
            lo, hi = -bound, bound
        table, n = _null_where(table, i, lambda v, lo=lo, hi=hi: ~((v >= lo) & (v <= hi)))  # NaN, inf fail too
        if n:
            counts[name] = n
    return table, counts
