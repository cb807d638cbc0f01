"""Venue tables from a spreadsheet: a gate survey (``--gates``) or a hold map (``--holds``) as CSV or as a
plain Parquet file without sportfusion metadata, besides the ``gates`` / ``holds`` tables the tools write.

The columns (names case-insensitive; a unit in brackets after a name, ``x [m]`` or ``x (cm)``, is read and
converted; without one the unit below is taken):

``gates`` (one row per gate magnet, docs/table-contract.md)
    ``gate`` (integer, the gate's number along the course); the position either ``x y z`` [m] in the
    session's local frame (gps2hill's; z down) or ``lat lon`` [deg] and ``h`` [m, WGS84 ellipsoidal];
    optional ``turn`` (``L``/``R``: the side the skier passes) and ``point`` (``start``/``finish``:
    the surveyed snow spot of a static posture instead of a magnet).
``holds`` (one row per hold of a route)
    ``route`` (name), ``hold`` (integer, the physical hold: a hold shared by two routes has one number),
    ``x y z`` [m] in the wall's map frame (x right along the wall, y into the wall, z up); optional
    ``start`` (1/yes/true/x marks the route's two start holds) and ``top`` (its top hold).

What a row cannot say comes on ``# key: value`` lines before the header of a CSV (a plain Parquet file
takes the defaults): for a hold map ``up`` (the map's up axis, default ``z``), ``site`` (the wall's
``lat, lon, h`` [deg, deg, m]), ``azimuth`` (the map's x axis, clockwise from north [deg]) and ``date``
(ISO, for the World Magnetic Model; default 2025-07-01), from which the reference magnetic field in the
map frame is computed, or that field directly as ``magnetic_field: mx, my, mz`` (any scale); for a gate
survey in ``x y z``, optionally the frame they are in: ``site`` (its origin ``lat, lon, h``) and ``azimuth``
(its x axis), else they are taken to be in the session's frame.  Commas, semicolons or tabs separate the
cells; with semicolons a decimal comma is read.

A table a sportfusion tool wrote (with its ``sportfusion`` metadata) is read as it is.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from typing import Any, BinaryIO

import numpy as np
import pyarrow as pa

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import schema
from sportfusion.core.errors import InputError

__all__ = ["KINDS", "read_venue", "venue_table"]

#: kind -> (required columns, position column sets (one of them), optional columns)
KINDS: dict[str, tuple[tuple[str, ...], tuple[tuple[str, ...], ...], tuple[str, ...]]] = {
    "gates": (("gate",), (("x", "y", "z"), ("lat", "lon", "h")), ("turn", "point")),
    "holds": (("route", "hold"), (("x", "y", "z"),), ("start", "top")),
}
#: units a header may give -> factor to the column's SI unit
LENGTH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "km": 1000.0}
ANGLE_UNITS = {"deg": 1.0, "°": 1.0, "degree": 1.0, "degrees": 1.0}
#: the World Magnetic Model's date when a hold map's CSV names none (the field's direction moves ~0.1 deg a year)
DEFAULT_DATE = "2025-07-01"
_YES = {"1", "yes", "y", "true", "x", "s", "start", "top"}
_HEAD = re.compile(r"^\s*([^\[\(]+?)\s*(?:[\[\(]\s*([^\]\)]*?)\s*[\]\)])?\s*$")
_AXES = "x right along the wall, y into the wall, z up"


def _header(name: str, what: str) -> tuple[str, float]:
    """``"X [cm]"`` -> ``("x", 0.01)``: the column name and the factor to its SI unit."""
    m = _HEAD.match(str(name))
    col = (m.group(1) if m else str(name)).strip().lower()
    unit = (m.group(2) or "").strip().lower() if m else ""
    if not unit:
        return col, 1.0
    if col in ("x", "y", "z", "h"):
        if unit not in LENGTH_UNITS:
            raise InputError(f"{what}: column {name!r} in {unit!r}; expected m, cm, mm or km")
        return col, LENGTH_UNITS[unit]
    if col in ("lat", "lon"):
        if unit not in ANGLE_UNITS:
            raise InputError(f"{what}: column {name!r} in {unit!r}; expected degrees (deg)")
        return col, 1.0
    return col, 1.0


def _read_csv(data: bytes, what: str) -> tuple[dict[str, str], list[str], list[list[str]]]:
    """``# key: value`` lines, the header and the rows of a CSV (comma, semicolon or tab separated)."""
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    keys: dict[str, str] = {}
    lines = []
    for line in text.splitlines():
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            k, sep, v = s[1:].partition(":")
            if sep and k.strip():
                keys[k.strip().lower()] = v.strip()
            continue
        lines.append(line)
    if not lines:
        raise InputError(f"{what} holds no table; expected a header line and one row per point")
    head = lines[0]
    delim = max((";", "\t", ","), key=head.count) if any(d in head for d in ";\t,") else ","
    rows = list(csv.reader(lines, delimiter=delim))
    cells = [[c.strip() for c in r] for r in rows[1:] if any(c.strip() for c in r)]
    if delim == ";":  # a spreadsheet with a decimal comma
        cells = [[re.sub(r"^(-?\d+),(\d+)$", r"\1.\2", c) for c in r] for r in cells]
    return keys, [c.strip() for c in rows[0]], cells


def _number(v: Any, col: str, row: int, what: str) -> float:
    if v is None or (isinstance(v, str) and not v.strip()):
        return math.nan
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{what}: row {row + 1}, column {col}: {v!r} is not a number") from None
    return x


def _integer(v: Any, col: str, row: int, what: str) -> int:
    x = _number(v, col, row, what)
    if not math.isfinite(x) or x != round(x):
        raise InputError(f"{what}: row {row + 1}, column {col}: {v!r}; expected a whole number")
    return int(round(x))


def venue_table(
    kind: str, columns: dict[str, list[Any]], keys: dict[str, str] | None = None, what: str = "venue table"
) -> tuple[pa.Table, dict[str, Any]]:
    """A ``gates`` or ``holds`` table and its metadata from plain columns (see the module text).

    Parameters
    ----------
    kind : ``"gates"`` or ``"holds"``
    columns : dict
        Header (a unit in brackets allowed) -> the column's values, one per row.
    keys : dict, optional
        The ``# key: value`` lines of a CSV (lower-case keys).
    what : str
        How to name the input in error messages.

    Raises
    ------
    InputError
        A required column is missing, a cell is not a number where one is needed, a position is missing.
    """
    if kind not in KINDS:
        raise ValueError(f"kind {kind!r}; expected one of {', '.join(KINDS)}")
    keys = keys or {}
    required, positions, optional = KINDS[kind]
    cols: dict[str, tuple[list[Any], float]] = {}
    for name, values in columns.items():
        col, factor = _header(name, what)
        if col in cols:
            raise InputError(f"{what}: column {col!r} appears twice")
        cols[col] = (list(values), factor)
    pos = next((p for p in positions if all(c in cols for c in p)), None)
    missing = [c for c in required if c not in cols]
    if missing or pos is None:
        want = " or ".join(" ".join(p) for p in positions)
        raise InputError(
            f"{what}: no column {', '.join(missing) or want} (it has {', '.join(cols) or 'none'}); "
            f"expected {' '.join(required)} and {want} (docs/table-contract.md, 'Your own venue')"
        )
    n = len(next(iter(cols.values()))[0])
    out: dict[str, pa.Array] = {}
    for c in required + pos:
        values, factor = cols[c]
        if c == "route":
            names = ["" if v is None else str(v).strip() for v in values]
            if any(not v for v in names):
                raise InputError(f"{what}: row {names.index('') + 1} has no route name")
            out[c] = schema.to_arrow(c, np.asarray(names, dtype=object))
        elif c in ("gate", "hold"):
            out[c] = schema.to_arrow(c, np.array([_integer(v, c, i, what) for i, v in enumerate(values)], np.int32))
        else:
            x = np.array([_number(v, c, i, what) for i, v in enumerate(values)], float) * factor
            bad = ~np.isfinite(x)
            if bad.any():
                raise InputError(f"{what}: row {int(np.argmax(bad)) + 1} has no {c}; expected a number in every row")
            out[c] = schema.to_arrow(c, x)
    for c in optional:
        if c not in cols:
            continue
        values = ["" if v is None else str(v).strip() for v in cols[c][0]]
        if c == "turn":
            up = [v.upper() for v in values]
            bad = sorted({v for v in up if v not in ("L", "R", "")})
            if bad:
                raise InputError(f"{what}: column turn holds {bad}; expected L or R")
            out[c] = pa.array([v or None for v in up], pa.string())
        elif c == "point":
            out[c] = pa.array([v.lower() or None for v in values], pa.string())
    table = pa.table(out)
    if table.num_rows == 0 or n == 0:
        raise InputError(f"{what} has no rows; expected one row per {'gate' if kind == 'gates' else 'hold'}")
    meta = sfmeta.new_meta(kind)
    if kind == "holds":
        meta.update(_holds_meta(table, cols, keys, what))
    elif "site" in keys and pos == ("x", "y", "z"):
        lat, lon, h = _numbers(keys["site"], 3, "site", what)
        az = _numbers(keys.get("azimuth", "0"), 1, "azimuth", what)[0]
        meta["frame"] = {
            "name": "course",
            "origin": [lat, lon, h],
            "azimuth_deg": az,
            "axes": "x forward, y right, z down",
        }
    sfio.check_positions(table, what)
    schema.check_types(table)
    return table, meta


def _flags(cols: dict[str, tuple[list[Any], float]], name: str) -> np.ndarray | None:
    if name not in cols:
        return None
    return np.array([str(v).strip().lower() in _YES for v in cols[name][0]], bool)


def _numbers(text: str, k: int, key: str, what: str) -> list[float]:
    parts = [p for p in re.split(r"[,\s;]+", text.strip()) if p]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        vals = []
    if len(vals) != k or not all(math.isfinite(v) for v in vals):
        raise InputError(f"{what}: '# {key}: {text}'; expected {k} numbers")
    return vals


def _holds_meta(
    table: pa.Table, cols: dict[str, tuple[list[Any], float]], keys: dict[str, str], what: str
) -> dict[str, Any]:
    """The ``climbing`` (and ``frame``) metadata of a hold map read from plain columns."""
    route = [str(v) for v in table.column("route").to_pylist()]
    hold = [int(v) for v in table.column("hold").to_pylist()]
    cl: dict[str, Any] = {"up": keys.get("up", "z")}
    start, top = _flags(cols, "start"), _flags(cols, "top")
    if start is not None:
        cl["start_holds"] = {
            r: sorted({h for h, rr, s in zip(hold, route, start, strict=True) if rr == r and s})
            for r in dict.fromkeys(route)
        }
    if top is not None:
        tops = {rr: h for h, rr, s in zip(hold, route, top, strict=True) if s}
        if tops:
            cl["top_holds"] = tops
    out: dict[str, Any] = {}
    if "magnetic_field" in keys:
        cl["magnetic_field"] = _numbers(keys["magnetic_field"], 3, "magnetic_field", what)
    if "site" in keys:
        lat, lon, h = _numbers(keys["site"], 3, "site", what)
        az = _numbers(keys.get("azimuth", "0"), 1, "azimuth", what)[0]
        out["frame"] = {"name": "wall", "origin": [lat, lon, h], "azimuth_deg": az, "axes": _AXES}
        if "magnetic_field" not in cl:
            from sportfusion.core.magfield import reference_field

            n, e, d = reference_field(lat, lon, h, keys.get("date", DEFAULT_DATE))
            a = math.radians(az)  # map x at azimuth a, y (into the wall) at a - 90 deg, z up
            f = np.array([n * math.cos(a) + e * math.sin(a), n * math.sin(a) - e * math.cos(a), -d])
            cl["magnetic_field"] = [float(v) for v in f / np.linalg.norm(f)]
    out["climbing"] = cl
    return out


def read_venue(
    source: str | os.PathLike[str] | BinaryIO, kind: str, what: str | None = None
) -> tuple[pa.Table, dict[str, Any]]:
    """A gate survey or a hold map from a sportfusion table, a plain Parquet file or a CSV (module text).

    Parameters
    ----------
    source : path or binary stream
    kind : ``"gates"`` or ``"holds"``
    what : str, optional
        How to name the input in error messages (default: the path).

    Returns
    -------
    table, meta : the table (SI units) and its metadata, as :func:`sportfusion.core.io.read_table` gives them.
    """
    name = what or str(source)
    data = sfio.read_bytes(source)
    if data[:4] == sfio.PARQUET_MAGIC:
        table = sfio.table_from_bytes(data, what=name)
        if table.schema.metadata and b"sportfusion" in table.schema.metadata:
            return sfio.read_table(io.BytesIO(data), kind=kind, what=name)
        return venue_table(kind, table.to_pydict(), {}, name)
    if not data.strip():
        raise InputError(f"{name} is empty; expected a {kind} table (Parquet) or a CSV with a header line")
    if b"\x00" in data[:4096]:
        raise InputError(f"{name} is neither Parquet nor CSV text; expected a {kind} table or a CSV")
    keys, head, rows = _read_csv(data, name)
    short = [i for i, r in enumerate(rows) if len(r) != len(head)]
    if short:
        raise InputError(f"{name}: row {short[0] + 1} has {len(rows[short[0]])} cells, the header {len(head)}")
    columns = {h: [r[k] for r in rows] for k, h in enumerate(head)}
    return venue_table(kind, columns, keys, name)
