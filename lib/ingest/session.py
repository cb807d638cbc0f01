"""A sportfusion session table (Parquet) as one more input of ``ingest``.

So a session made earlier (or by another tool) merges with new raw files in
one ``ingest`` call: e.g. an IMU session plus a receiver's ``.pos``.  Sniffed
by the Parquet magic ``PAR1`` and the ``sportfusion`` metadata (a session
table).  Its columns keep their names, types and units; rows are split into
one stream per group of columns sampled together (same non-null rows), so
the merge places each sensor's samples on the union of times as for any raw
input.  The session's epoch is the recording's; its ``units``, frame, hill
and other metadata keys are carried into the new session, its provenance
steps are counted in the source entry.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import io as sfio
from sportfusion.core.meta import epoch_unix
from sportfusion.core.session import Stream
from sportfusion.ingest import Options, Recording

_OWN_KEYS = ("version", "kind", "time", "provenance", "sources", "units")


def sniff(path: Path, head: bytes) -> bool:
    """A Parquet file (magic ``PAR1``); :func:`read` checks it is a sportfusion session."""
    return path.is_file() and head.startswith(b"PAR1")


def read(path: Path, opts: Options) -> Recording:
    """Read a session table into streams of columns sampled together (see the module docstring)."""
    table, meta = sfio.read_table(path, kind="session", what=str(path))
    t = table.column("t").to_numpy()
    groups: dict[bytes, list[str]] = {}
    empty: list[str] = []
    for name in table.column_names:
        if name == "t":
            continue
        valid = np.asarray(table.column(name).is_valid().to_numpy(zero_copy_only=False), dtype=bool)
        if not valid.any():
            empty.append(name)
            continue
        groups.setdefault(valid.tobytes(), []).append(name)
    streams: list[Stream] = []
    seen: dict[str, int] = {}
    for key, names in groups.items():
        mask = np.frombuffer(key, dtype=bool)
        idx = pa.array(np.flatnonzero(mask))
        base = names[0].split("_")[0]
        seen[base] = seen.get(base, 0) + 1
        label = base if seen[base] == 1 else f"{base}{seen[base]}"
        streams.append(Stream(label, t[mask], {n: table.column(n).take(idx) for n in names}))
    warnings = [f"column(s) {', '.join(empty)} hold no value and are not carried"] if empty else []
    extra: dict[str, Any] = {
        "provenance_steps": len(meta.get("provenance", [])),
        "session": {k: v for k, v in meta.items() if k not in _OWN_KEYS},
    }
    if meta.get("units"):
        extra["units"] = dict(meta["units"])
    return Recording(str(path), "session", streams, epoch_unix(meta), extra, warnings)
