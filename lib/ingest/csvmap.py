"""Any delimited text table, read through a column map (``--map t=Time,acc_x=AccX``).

Never sniffed: chosen by ``--format csvmap`` or by giving ``--map``.  The
dialect (separator comma/tab/semicolon, decimal point or comma) is detected
as for phyphox; ``NaN`` and empty cells are nulls.

``Options.column_map`` maps table columns to CSV headers and must map
``t``.  Only mapped columns are read (the others are listed in one
warning).  ``Options.units`` gives the unit of the CSV values of a column
(``acc_x=g``, ``gyr_x=deg/s``, ``mag_x=nT``, ``pressure=hPa``,
``gnss_speed=km/h``, ...); values are converted to the column's registered
unit.  ``mag_x=1`` declares a normalised magnetometer (unit ``1`` recorded in
the metadata's ``units``).  Unregistered target columns pass through as
read (no unit conversion possible).

Time (``Options.time_unit``)
    ``s``, ``ms``, ``us`` or ``ns``: numbers.  Values from 1e9 s on (after
    2001-09-09) are taken as Unix time: the recording's epoch is the first
    sample and ``t`` counts from it.  Smaller values are relative times
    without an absolute clock.  ``iso``: ISO-8601 text such as
    ``2025-03-15T10:00:00.25Z``; times without a zone are UTC.
"""

from __future__ import annotations

import calendar
import datetime as dt
from pathlib import Path

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream
from sportfusion.ingest import Options, Recording
from sportfusion.ingest._text import decode, floats, read_delimited, unit_factor

#: Seconds per unit of a numeric time column.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: Numeric times from this many seconds on are Unix times (2001-09-09).
UNIX_FROM = 1e9


def sniff(path: Path, head: bytes) -> bool:
    """Never: a generic CSV needs a column map (``--map``)."""
    return False


def _iso_seconds(values: list[object], path: Path, header: str) -> tuple[np.ndarray, float]:
    whole = np.zeros(len(values), dtype=np.int64)
    frac = np.zeros(len(values))
    for i, v in enumerate(values):
        if v is None:
            raise InputError(f"{path}: row {i + 2} has no time in column {header!r}; expected a time on every row")
        try:
            t = dt.datetime.fromisoformat(str(v).strip())
        except ValueError as exc:
            raise InputError(
                f"{path}: time {v!r} in row {i + 2} is not ISO-8601; expected e.g. 2025-03-15T10:00:00.25Z "
                "or another --time-unit"
            ) from exc
        if t.tzinfo is not None:
            t = t.astimezone(dt.UTC)
        whole[i] = calendar.timegm(t.timetuple())
        frac[i] = t.microsecond / 1e6
    epoch = float(whole[0]) + float(frac[0])
    return (whole - whole[0]).astype(np.float64) + (frac - frac[0]), epoch


def read(path: Path, opts: Options) -> Recording:
    """Read the mapped columns of a delimited text table (see the module docstring)."""
    cmap = dict(opts.column_map)
    if "t" not in cmap:
        raise InputError("a generic CSV needs the time column mapped: expected --map t=HEADER,acc_x=HEADER,...")
    for col in opts.units:
        if col not in cmap:
            raise InputError(f"--units names column {col!r}, which --map does not map")
    try:
        text = decode(path.read_bytes())
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from exc
    table = read_delimited(text, str(path), numeric=False)
    headers = table.column_names
    missing = [f"{c}={h}" for c, h in cmap.items() if h not in headers]
    if missing:
        raise InputError(f"{path}: --map {', '.join(missing)}: no such header; the file has {', '.join(headers)}")
    warnings: list[str] = []
    unread = [h for h in headers if h not in cmap.values()]
    if unread:
        warnings.append(f"column(s) not mapped and not read: {', '.join(unread)}")
    th = cmap.pop("t")
    epoch = None
    if opts.time_unit == "iso":
        t, epoch = _iso_seconds(table.column(th).to_pylist(), path, th)
    else:
        if opts.time_unit not in TIME_UNITS:
            raise InputError(f"time unit {opts.time_unit!r} unknown; expected s, ms, us, ns or iso")
        raw = _numbers(table, th, path)
        bad = ~np.isfinite(raw)
        if bad.any():
            raise InputError(f"{path}: row {int(np.argmax(bad)) + 2} has no time in column {th!r}")
        t = raw * TIME_UNITS[opts.time_unit]
        if t.size and t.min() >= UNIX_FROM:
            epoch = float(t.min())
            t = t - epoch
    cols: dict[str, object] = {}
    units: dict[str, str] = {}
    for col, header in cmap.items():
        reg = schema.lookup(col)
        given = opts.units.get(col)
        if reg is None:
            if given is not None:
                raise InputError(f"--units {col}={given}: {col!r} is not a registered column, its unit is unknown")
            cols[col] = table.column(header)
            continue
        if pa.types.is_string(reg.type):
            cols[col] = table.column(header).cast(pa.string())
            continue
        v = _numbers(table, header, path)
        if given is not None and reg.name.startswith("mag_") and given == "1":
            units[col] = "1"
        elif given is not None:
            v = v * unit_factor(given, reg.unit, f"--units {col}")
        cols[col] = v
    meta = {"columns": {c: h for c, h in opts.column_map.items()}}
    if units:
        meta["units"] = units
    return Recording(str(path), "csvmap", [Stream(path.stem, t, cols)], epoch, meta, warnings)


def _numbers(table: pa.Table, header: str, path: Path) -> np.ndarray:
    try:
        return floats(table, header)
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError) as exc:
        raise InputError(f"{path}: column {header!r} holds text that is not a number; expected numbers or NaN") from exc
