"""Human-readable summaries of a table, for ``inspect``."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.stats import median

#: Sensor groups: name -> a column whose non-null rows mark that sensor's samples.
SENSORS = {
    "accelerometer": "acc_x",
    "gyroscope": "gyr_x",
    "magnetometer": "mag_x",
    "barometer": "pressure",
    "gnss": "lat",
    "gnss (local)": "gnss_x",
    "estimate": "x",
}


def ms_to_kmh(v: float) -> float:
    """A speed [m/s] in km/h, for human summaries that print both."""
    return float(v) * 3.6


def sensor_rates(table: pa.Table) -> list[dict[str, Any]]:
    """Per-sensor sample count, time span [s] and median rate [Hz].

    Returns
    -------
    list of dict
        Keys ``sensor``, ``column``, ``samples``, ``t_first``, ``t_last``, ``rate_hz``.
    """
    if "t" not in table.column_names:
        return []
    t = schema.floats(table, "t")
    out = []
    for sensor, col in SENSORS.items():
        if col not in table.column_names:
            continue
        valid = table.column(col).is_valid().to_numpy(zero_copy_only=False)
        ts = t[valid]
        if ts.size == 0:
            continue
        rate = float(1.0 / median(np.diff(ts))) if ts.size > 1 else float("nan")
        out.append(
            {
                "sensor": sensor,
                "column": col,
                "samples": int(ts.size),
                "t_first": float(ts[0]),
                "t_last": float(ts[-1]),
                "rate_hz": rate,
            }
        )
    return out


def column_rows(table: pa.Table) -> list[tuple[str, str, str, int, str]]:
    """(name, type, unit, null count, meaning) per column."""
    rows = []
    for field in table.schema:
        md = field.metadata or {}
        unit = md.get(b"unit", b"").decode() or (schema.unit_of(field.name) or "")
        col = schema.lookup(field.name)
        rows.append(
            (field.name, str(field.type), unit, table.column(field.name).null_count, col.meaning if col else "")
        )
    return rows


#: Decimals printed for a column's values in the head/tail rows, by unit (None: 6 significant digits).
#: Degrees of latitude/longitude need 8 (1e-8 deg ~ 1 mm; 6 significant digits would be ~10 m).
DECIMALS = {"deg": 8, "m": 3, "s": 3}


def _fmt(v: Any, decimals: int | None = None) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        if decimals is not None and np.isfinite(v) and abs(v) < 1e9:
            return f"{v:.{decimals}f}"
        return f"{v:.6g}"
    return str(v)


def describe_json(table: pa.Table, meta: dict[str, Any]) -> dict[str, Any]:
    """What ``inspect --json`` prints: the metadata, every column with its unit, the sensors' rates.

    Returns
    -------
    dict with keys ``metadata`` (the table's sportfusion metadata), ``rows``, ``columns`` (a list of
    ``{"name", "type", "unit", "nulls", "meaning"}``; unit ``""`` for text and flags) and ``sensors``
    (see :func:`sensor_rates`: samples, time span [s], median rate [Hz]).
    """
    cols = [
        {"name": n, "type": typ, "unit": unit, "nulls": nulls, "meaning": meaning}
        for n, typ, unit, nulls, meaning in column_rows(table)
    ]
    return {"metadata": meta, "rows": table.num_rows, "columns": cols, "sensors": sensor_rates(table)}


def render(table: pa.Table, meta: dict[str, Any], rows: int = 5) -> str:
    """The full terminal view: columns, sensors, metadata, provenance, head and tail."""
    lines = [f"kind: {meta.get('kind')}   rows: {table.num_rows}   columns: {table.num_columns}"]
    epoch = (meta.get("time") or {}).get("epoch_utc")
    lines.append(f"time origin (t = 0): {epoch or 'none (relative times)'}")
    if "t" in table.column_names and table.num_rows:
        import pyarrow.compute as pc  # lazy: the commands that only need ms_to_kmh do not pay for it

        t = table.column("t")
        lo, hi = pc.min(t).as_py(), pc.max(t).as_py()
        lines.append(f"time span: {lo:.3f} .. {hi:.3f} s ({hi - lo:.3f} s)")
    lines.append("")
    lines.append("columns:")
    width = max([len(r[0]) for r in column_rows(table)] + [4])
    for name, typ, unit, nulls, meaning in column_rows(table):
        lines.append(f"  {name:<{width}}  {typ:<8} {('[' + unit + ']') if unit else '':<10} nulls {nulls:<8} {meaning}")
    rates = sensor_rates(table)
    if rates:
        lines.append("")
        lines.append("sensors:")
        for r in rates:
            lines.append(
                f"  {r['sensor']:<14} {r['samples']:>8} samples  {r['t_first']:.3f} .. {r['t_last']:.3f} s  {r['rate_hz']:.3g} Hz"
            )
    for key in ("frame", "hill", "events"):
        if meta.get(key):
            lines.append("")
            lines.append(f"{key}: {json.dumps(meta[key], indent=None)}")
    other = {
        k: v for k, v in meta.items() if k not in ("version", "kind", "time", "frame", "hill", "events", "provenance")
    }
    for k, v in other.items():
        lines.append(f"{k}: {json.dumps(v)}")
    lines.append("")
    lines.append("provenance:")
    for i, step in enumerate(meta.get("provenance", [])):
        params = ", ".join(f"{k}={v}" for k, v in step.get("params", {}).items() if v not in (None, (), [], False))
        lines.append(f"  {i + 1}. {step['tool']} {step['version']}  {params}")
    if not meta.get("provenance"):
        lines.append("  (none)")
    if rows and table.num_rows:
        lines.append("")
        lines += _rows_block("head", table.slice(0, rows))
        if table.num_rows > rows:
            lines += _rows_block("tail", table.slice(max(table.num_rows - rows, rows), rows))
    return "\n".join(lines) + "\n"


def _rows_block(title: str, part: pa.Table) -> list[str]:
    names = part.column_names
    units = {name: unit for name, _, unit, _, _ in column_rows(part)}
    data = [[_fmt(v, DECIMALS.get(units.get(n, ""))) for v in part.column(n).to_pylist()] for n in names]
    widths = [max([len(n)] + [len(x) for x in col]) for n, col in zip(names, data, strict=True)]
    out = [f"{title}:", "  " + " ".join(n.rjust(w) for n, w in zip(names, widths, strict=True))]
    for i in range(part.num_rows):
        out.append("  " + " ".join(col[i].rjust(w) for col, w in zip(data, widths, strict=True)))
    return out
