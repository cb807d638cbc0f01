"""Event columns that know no sport: set instants in the ``event`` column, runs of a boolean mask.

The ``event`` column (string) is null except at an instant (``takeoff``, ``touchdown``, ``gate``, ...); the
events are also listed in the metadata's ``events``.  Each detector chooses which names it replaces.
"""

from __future__ import annotations

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Start and end (exclusive) indices of the runs of True."""
    d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def set_events(table: pa.Table, events: list[tuple[str, float]], replace: tuple[str, ...]) -> pa.Table:
    """Write events into the ``event`` column at the rows nearest their times.

    Existing events named in ``replace`` are cleared first (a re-run replaces
    its own events); other existing events are kept.  Two events that land on
    one row are an error.
    """
    t = schema.floats(table, "t")
    col = table.column("event").to_pylist() if "event" in table.column_names else [None] * table.num_rows
    col = [None if v in replace else v for v in col]
    for name, te in events:
        i = int(np.clip(np.searchsorted(t, te), 1, max(t.size - 1, 1)))
        i = i - 1 if t.size > 1 and abs(t[i - 1] - te) <= abs(t[i] - te) else i
        i = min(i, t.size - 1)
        if col[i] is not None:
            raise InputError(f"event '{name}' at t = {te:.3f} s falls on the row of event '{col[i]}'")
        col[i] = name
    arr = pa.array(col, pa.string())
    if "event" in table.column_names:
        return table.set_column(table.column_names.index("event"), "event", arr)
    return table.append_column("event", arr)
