"""Any delimited text table, read through a column map (``--map t=Time,acc_x=AccX``), or our own CSV.

Chosen by ``--format csvmap``, by giving ``--map``, or sniffed when the
header is the table contract's own column names with ``t`` first (what
``inspect --csv`` writes): then every column is read under its own name,
without ``--map``.  The dialect (separator comma/tab/semicolon/space,
decimal point or comma) is detected as for phyphox; ``NaN`` and empty cells
are nulls.

Column map
    ``Options.column_map`` maps table columns to CSV headers and must map
    ``t``.  A value that is a positive integer and not a header is a 1-based
    column number (``--map t=1,acc_x=2``); a file whose first line is all
    numbers has no header line (logger IMU files) and is read by column
    number only.  Only mapped columns are read (the others are listed in one
    warning).

Units (``Options.units``)
    Per column or per column group (``acc=g`` applies to ``acc_x/y/z``):
    ``g``, ``mg``, ``deg/s``, ``rad/s``, ``mG``, ``nT``, ``hPa``, ``km/h``, ...;
    a leading number is a scale factor for raw counts (``acc=0.000244g``:
    one count is 0.000244 g; ``gyr=0.0175deg/s``; a number alone scales into
    the column's own unit).  Values are converted to the column's registered
    unit.  ``mag_x=1`` (or ``mag=1``) declares a normalised magnetometer (unit
    ``1`` recorded in the metadata's ``units``).  Unregistered target columns
    pass through as read (no unit conversion possible).

Invalid markers (``Options.invalid``, ``--invalid``)
    A generic CSV documents no invalid markers, so none is guessed: the
    values a logger writes for "no value" are declared per column, per
    column group or for every mapped column (``*``), as written in the file
    (before any unit conversion), several joined by ``/``:
    ``--invalid gnss_speed=-1,gnss_course=-1``, ``--invalid acc=-999/9999``,
    ``--invalid '*=N/A'``.  A number matches numerically (``-1`` matches
    ``-1.0``), other text matches the trimmed cell.  Matching cells are read
    as null, counted per column in one warning.  The time column takes
    none (every row needs a time).

Time (``Options.time_unit``, or ``units["t"]`` which wins)
    ``s``, ``ms``, ``us``, ``ns``, a scaled unit (``0.0001s``: ticks of
    100 us) or ``ticks`` (sample counter; ``Options.rate`` [Hz] gives the
    tick length).  Integer times (19-digit nanoseconds) are split from their
    first value in integer arithmetic before they become float64.  Values
    from 1e9 s on (after 2001-09-09) are taken as Unix time: the recording's
    epoch is the first sample and ``t`` counts from it.  Smaller values are
    relative times without an absolute clock.  ``iso``: ISO-8601 text such
    as ``2025-03-15T10:00:00.25Z``; times without a zone are UTC.
"""

from __future__ import annotations

import calendar
import datetime as dt
import re
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream
from sportfusion.core.stats import median
from sportfusion.ingest import Options, Recording
from sportfusion.ingest._text import decode, dialect, exact_seconds, floats, parse_unit, read_delimited, scaled_factor

#: Seconds per unit of a numeric time column.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: Numeric times from this many seconds on are Unix times (2001-09-09).
UNIX_FROM = 1e9


def _contract_headers(head: bytes) -> list[str] | None:
    """The header cells when they are the table contract's column names with ``t`` first, else None."""
    text = decode(head)
    line = text.lstrip("\ufeff").splitlines()[0] if text.strip() else ""
    try:
        sep, _ = dialect(line + "\n")
    except InputError:
        return None
    cells = [c.strip().strip('"') for c in line.split(sep)]
    if len(cells) < 2 or cells[0] != "t":
        return None
    known = sum(schema.lookup(c) is not None for c in cells[1:])
    return cells if known >= 1 and known * 2 >= len(cells) - 1 else None


def sniff(path: Path, head: bytes) -> bool:
    """Our own CSV (``inspect --csv``): header ``t`` then contract column names; other CSVs need ``--map``."""
    return path.is_file() and _contract_headers(head) is not None


_ISO = re.compile(r"^\d{4}-\d{2}-\d{2}[ T]\d{2}:\d{2}")


def _is_value(text: str) -> bool:
    """A data cell rather than a header: a number or an ISO date-time."""
    cell = text.strip().strip('"')
    if _ISO.match(cell):
        return True
    try:
        float(cell)
    except ValueError:
        return False
    return True


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


def _resolve_units(units: dict[str, str], cmap: dict[str, str]) -> dict[str, str]:
    """Per-column units from per-column or per-group (``acc=g``) entries; a column's own entry wins."""
    out: dict[str, str] = {}
    for key, unit in units.items():
        if key in cmap:
            continue
        members = [c for c in cmap if c.startswith(key + "_")]
        if not members:
            raise InputError(f"--units names column {key!r}, which --map does not map (nor any {key}_* column)")
        for c in members:
            out[c] = unit
    out.update({k: v for k, v in units.items() if k in cmap})
    return out


def _resolve_invalid(invalid: dict[str, str], cmap: dict[str, str]) -> dict[str, list[str]]:
    """Per mapped column, its declared invalid markers (from a column, a group such as ``acc``, or ``*``)."""
    out: dict[str, list[str]] = {}
    for key, spec in invalid.items():
        markers = [m.strip() for m in spec.split("/") if m.strip()]
        if key == "t":
            raise InputError("--invalid t=...: the time column takes no invalid markers (every row needs a time)")
        members = [c for c in cmap if c != "t"] if key == "*" else [key] if key in cmap else []
        if not members:
            members = [c for c in cmap if c.startswith(key + "_")]
        if not members:
            raise InputError(f"--invalid names column {key!r}, which --map does not map (nor any {key}_* column)")
        for c in members:
            out.setdefault(c, [])
            out[c] += [m for m in markers if m not in out[c]]
    return out


def _marker_number(text: str) -> float | None:
    try:
        x = float(text)
    except ValueError:
        return None
    return x if np.isfinite(x) else None


def _null_markers(
    table: pa.Table, cmap: dict[str, str], markers: dict[str, list[str]], warnings: list[str]
) -> pa.Table:
    """Null the cells holding a declared invalid marker (numbers numerically, text as written), counted."""
    counts: list[str] = []
    for c, ms in markers.items():
        header = cmap[c]
        col = table.column(header)
        nums = [x for m in ms if (x := _marker_number(m)) is not None]
        texts = [m for m in ms if _marker_number(m) is None]
        if pa.types.is_integer(col.type) or pa.types.is_floating(col.type):
            v = np.asarray(col.cast(pa.float64(), safe=False).fill_null(np.nan).to_numpy(), dtype=np.float64)
            hit = np.isin(v, nums) if nums else np.zeros(len(v), dtype=bool)
        else:
            cells = col.cast(pa.string()).to_pylist()
            hit = np.array(
                [
                    x is not None and (x.strip() in texts or (bool(nums) and _marker_number(x.strip()) in nums))
                    for x in cells
                ],
                dtype=bool,
            )
        n = int(hit.sum())
        if n:
            kept = pc.if_else(pa.array(hit), pa.nulls(len(hit), col.type), col.combine_chunks())
            table = table.set_column(table.column_names.index(header), header, kept)
            counts.append(f"{n} {c} ({'/'.join(ms)})")
    if counts:
        warnings.append(f"invalid markers (declared by --invalid) read as null: {', '.join(counts)}")
    return table


def _time_seconds(spec: str, rate: float | None) -> float:
    """Seconds per unit of a numeric time column: ``ms``, ``0.0001s``, ``ticks`` (with a rate), ..."""
    if spec in TIME_UNITS:
        return TIME_UNITS[spec]
    if spec in ("ticks", "tick", "counts", "samples"):
        if not rate or rate <= 0:
            raise InputError(f"time unit {spec!r} needs the sampling rate: expected --rate HZ")
        return 1.0 / rate
    scale, unit = parse_unit(spec)
    if unit == "=":
        return scale
    if unit in ("ticks", "tick"):
        return scale * _time_seconds(unit, rate)
    return scaled_factor(spec, "s", "time unit")


def read(path: Path, opts: Options) -> Recording:
    """Read the mapped columns of a delimited text table (see the module docstring)."""
    try:
        raw_bytes = path.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from exc
    warnings: list[str] = []
    cmap = dict(opts.column_map)
    contract = False
    if not cmap:
        cells = _contract_headers(raw_bytes[:4096])
        if cells is None:
            raise InputError(
                "a generic CSV needs the time column mapped: expected --map t=HEADER,acc_x=HEADER,... "
                "(or t=1,acc_x=2,... by column number)"
            )
        cmap = {c: c for c in cells}
        contract = True
    if "t" not in cmap:
        raise InputError("a generic CSV needs the time column mapped: expected --map t=HEADER,acc_x=HEADER,...")
    units = _resolve_units(dict(opts.units), cmap)
    text = decode(raw_bytes).lstrip("\ufeff")
    lines = text.splitlines()
    skip = 0
    while skip < len(lines) and (not lines[skip].strip() or lines[skip].lstrip().startswith(("#", "//", "%"))):
        skip += 1  # comment lines some loggers write before the table
    if skip:
        text = "\n".join(lines[skip:])
        warnings.append(f"{skip} leading comment line(s) skipped")
    first = text.splitlines()[0].split(dialect(text)[0]) if text.strip() else []
    headerless = bool(first) and all(_is_value(c) for c in first if c.strip())
    table = read_delimited(text, str(path), numeric=False, header=not headerless)
    headers = table.column_names
    for c, h in list(cmap.items()):  # column numbers (1-based) -> names
        if h not in headers and h.isdigit():
            k = int(h)
            if not 1 <= k <= len(headers):
                raise InputError(
                    f"{path}: --map {c}={h}: the file has {len(headers)} column(s); expected 1..{len(headers)}"
                )
            cmap[c] = headers[k - 1]
    missing = [f"{c}={h}" for c, h in cmap.items() if h not in headers]
    if missing:
        raise InputError(f"{path}: --map {', '.join(missing)}: no such header; the file has {', '.join(headers)}")
    unread = [h for h in headers if h not in cmap.values()]
    if unread:
        what = "column number(s)" if headerless else "column(s)"
        warnings.append(f"{what} not mapped and not read: {', '.join(unread)}")
    if opts.invalid:
        table = _null_markers(table, cmap, _resolve_invalid(dict(opts.invalid), cmap), warnings)
    th = cmap.pop("t")
    t_spec = units.pop("t", opts.time_unit)
    epoch = None
    if t_spec == "iso":
        t, epoch = _iso_seconds(table.column(th).to_pylist(), path, th)
    else:
        if (
            t_spec not in TIME_UNITS
            and t_spec not in ("ticks", "tick", "counts", "samples")
            and not _valid_unit(t_spec)
        ):
            raise InputError(
                f"time unit {t_spec!r} unknown; expected s, ms, us, ns, ticks (with --rate), iso or e.g. 0.0001s"
            )
        unit_s = _time_seconds(t_spec, opts.rate)
        col = table.column(th)
        if pa.types.is_integer(col.type) or pa.types.is_string(col.type):
            try:
                t, origin = exact_seconds(col, unit_s, f"{path}: column {th!r}")
            except InputError as exc:
                raise InputError(f"{exc}; expected a number on every row of the time column") from exc
        else:
            raw = _numbers(table, th, path)
            bad = ~np.isfinite(raw)
            if bad.any():
                raise InputError(f"{path}: row {int(np.argmax(bad)) + 2} has no time in column {th!r}")
            t, origin = raw * unit_s, 0.0
        if t.size and origin + t.min() >= UNIX_FROM:
            lo = float(t.min())
            epoch = origin + lo
            t = t - lo
        else:
            t = t + origin
    cols: dict[str, object] = {}
    units_meta: dict[str, str] = {}
    for col_name, header in cmap.items():
        reg = schema.lookup(col_name)
        given = units.get(col_name)
        if reg is None:
            if given is not None:
                raise InputError(
                    f"--units {col_name}={given}: {col_name!r} is not a registered column, its unit is unknown"
                )
            cols[col_name] = table.column(header)
            continue
        if not pa.types.is_floating(reg.type):
            try:
                cols[col_name] = table.column(header).cast(reg.type)
            except (pa.ArrowInvalid, pa.ArrowNotImplementedError) as exc:
                raise InputError(f"{path}: column {header!r} is not {reg.type} ({reg.meaning})") from exc
            continue
        v = _numbers(table, header, path)
        if given is not None and reg.name.startswith("mag_") and given == "1":
            units_meta[col_name] = "1"
        elif given is not None:
            v = v * scaled_factor(given, reg.unit, f"--units {col_name}")
        cols[col_name] = v
    if contract:
        _normalised_mag(cols, units_meta, warnings)
    meta: dict[str, object] = {"columns": dict(opts.column_map) if not contract else "contract names"}
    if headerless:
        meta["header"] = "none (columns by number)"
    if units_meta:
        meta["units"] = units_meta
    if contract and epoch is None:
        warnings.append("t is relative (a CSV carries no epoch): no absolute time; align it by --offset NAME=SECONDS")
    return Recording(str(path), "csvmap", [Stream(path.stem, t, cols)], epoch, meta, warnings)


#: Largest median field magnitude [uT] of a magnetometer taken as normalised (the Earth's field is 22-67 uT).
NORMALISED_BELOW = 5.0


def _normalised_mag(cols: dict[str, object], units: dict[str, str], warnings: list[str]) -> None:
    """Our own CSV loses the unit ``1`` of a normalised magnetometer: restore it from the field's size."""
    names = [c for c in ("mag_x", "mag_y", "mag_z") if c in cols]
    if not names:
        return
    m = np.column_stack([np.asarray(cols[c], dtype=np.float64) for c in names])
    good = np.isfinite(m).all(axis=1)
    if not good.any():
        return
    size = float(median(np.linalg.norm(m[good], axis=1)))
    if size < NORMALISED_BELOW:
        units.update({c: "1" for c in names})
        warnings.append(f"{'/'.join(names)} read as normalised (unit 1): median |m| = {size:.3g}, no Earth field in uT")


def _valid_unit(spec: str) -> bool:
    try:
        _time_seconds(spec, 1.0)
    except InputError:
        return False
    return True


def _numbers(table: pa.Table, header: str, path: Path) -> np.ndarray:
    try:
        return floats(table, header)
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError) as exc:
        raise InputError(f"{path}: column {header!r} holds text that is not a number; expected numbers or NaN") from exc
