"""Compare two output trees (e.g. two `make demo` runs) table by table, within a stated tolerance.

    python bench/compare_outputs.py demo-before demo-after [--rtol 1e-9] [--atol 1e-9]

Every ``*.parquet`` under the first tree must exist under the second with the same columns, types and
row count; numeric columns must agree within ``atol + rtol * |a|`` (nulls in the same places), other
columns exactly; the ``sportfusion`` metadata must agree (numbers within the tolerance) except the provenance's per-run
fields.  Text outputs (``*.txt``, ``*.csv``) must agree once numbers are compared within the tolerance and
the trees' own paths are masked.  Prints one line per difference and exits 1
if there is any; used to show that a refactoring changed no output.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

#: provenance fields that legitimately differ between two runs of the same pipeline
VOLATILE = {"time", "started", "duration_s", "host", "input", "inputs", "output", "path", "paths", "wall_s", "cpu_s"}


def _scrub(obj: object) -> object:
    if isinstance(obj, dict):
        return {k: _scrub(v) for k, v in obj.items() if k not in VOLATILE}
    if isinstance(obj, list):
        return [_scrub(v) for v in obj]
    return obj


_NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def _close(a: object, b: object, rtol: float, atol: float) -> bool:
    """Nested JSON-like values equal, numbers within ``atol + rtol * |a|``."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k], rtol, atol) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y, rtol, atol) for x, y in zip(a, b, strict=True))
    if isinstance(a, float | int) and isinstance(b, float | int) and not isinstance(a, bool):
        return abs(a - b) <= atol + rtol * abs(a)
    return a == b


def _text_close(a: str, b: str, rtol: float, atol: float) -> bool:
    """Two texts equal once their numbers are compared within the tolerance."""
    if _NUMBER.sub("#", a) != _NUMBER.sub("#", b):
        return False
    na = [float(x) for x in _NUMBER.findall(a)]
    nb = [float(x) for x in _NUMBER.findall(b)]
    return _close(na, nb, rtol, atol)


def _meta(table: pa.Table) -> object:
    raw = (table.schema.metadata or {}).get(b"sportfusion")
    return _scrub(json.loads(raw)) if raw else None


def compare_tables(a: pa.Table, b: pa.Table, rtol: float, atol: float) -> list[str]:
    """Differences between two tables, one line each (empty when they agree)."""
    out: list[str] = []
    if a.column_names != b.column_names:
        return [f"columns differ: {sorted(set(a.column_names) ^ set(b.column_names))}"]
    if a.num_rows != b.num_rows:
        return [f"rows differ: {a.num_rows} vs {b.num_rows}"]
    for name in a.column_names:
        ca, cb = a.column(name), b.column(name)
        if ca.type != cb.type:
            out.append(f"{name}: type {ca.type} vs {cb.type}")
            continue
        if pa.types.is_floating(ca.type) or pa.types.is_integer(ca.type):
            va = ca.to_numpy(zero_copy_only=False).astype(float)
            vb = cb.to_numpy(zero_copy_only=False).astype(float)
            na, nb = ~np.isfinite(va), ~np.isfinite(vb)
            if not np.array_equal(na, nb):
                out.append(f"{name}: nulls/non-finite in different rows")
                continue
            d = np.abs(va[~na] - vb[~na])
            lim = atol + rtol * np.abs(va[~na])
            if d.size and np.any(d > lim):
                out.append(f"{name}: max difference {d.max():.3g} (tolerance {atol:g} + {rtol:g} |a|)")
        elif ca.to_pylist() != cb.to_pylist():
            out.append(f"{name}: values differ")
    if not _close(_meta(a), _meta(b), rtol, atol):
        out.append("metadata differs (provenance run fields ignored)")
    return out


def compare_trees(a: Path, b: Path, rtol: float, atol: float) -> list[str]:
    """Differences between every table and text output of tree ``a`` and its counterpart in ``b``."""
    out: list[str] = []
    for pa_path in sorted(a.rglob("*.parquet")):
        rel = pa_path.relative_to(a)
        other = b / rel
        if not other.exists():
            out.append(f"{rel}: missing in {b}")
            continue
        ta, tb = pq.read_table(pa_path, use_threads=False), pq.read_table(other, use_threads=False)
        out += [f"{rel}: {line}" for line in compare_tables(ta, tb, rtol, atol)]
    for txt in sorted([*a.rglob("*.txt"), *a.rglob("*.csv")]):
        rel = txt.relative_to(a)
        other = b / rel
        if not other.exists():
            out.append(f"{rel}: missing in {b}")
        elif not _text_close(
            txt.read_text().replace(str(a), "<tree>"), other.read_text().replace(str(b), "<tree>"), rtol, atol
        ):
            out.append(f"{rel}: text differs")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--rtol", type=float, default=1e-9, help="relative tolerance [1]")
    ap.add_argument("--atol", type=float, default=1e-9, help="absolute tolerance [column unit]")
    args = ap.parse_args(argv)
    diffs = compare_trees(args.before, args.after, args.rtol, args.atol)
    n = len(list(args.before.rglob("*.parquet")))
    for line in diffs:
        print(line)
    print(f"{n} tables compared: {'identical within tolerance' if not diffs else f'{len(diffs)} differences'}")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())
