"""The ``sportfusion`` schema-metadata key: versioned JSON carried by every table.

Layout (GeoParquet's pattern: one key, JSON value)::

    {"version": 1, "kind": "session",
     "time": {"epoch_utc": "2026-01-01T10:00:00.000000Z" | null},
     "frame": {"name": "hill", "origin": [lat, lon, h], "azimuth_deg": psi,
               "axes": "x forward, y right, z down"},
     "hill": {...}, "events": [...],
     "provenance": [{"tool": ..., "version": ..., "params": {...}}, ...]}

Only ``version``, ``kind`` and ``provenance`` are mandatory; tools add what
they know.  Unknown keys are carried through untouched.
"""

from __future__ import annotations

import copy
import json
import math
import os
from datetime import UTC, datetime
from typing import Any

from sportfusion import __version__
from sportfusion.core.errors import InputError
from sportfusion.core.schema import KINDS

KEY = b"sportfusion"
VERSION = 1


def new_meta(kind: str = "session", epoch_utc: float | str | None = None) -> dict[str, Any]:
    """A fresh metadata dict.

    Parameters
    ----------
    kind : str
        Table kind, one of :data:`sportfusion.core.schema.KINDS`.
    epoch_utc : float or str or None
        Time origin of column ``t``: Unix seconds, an ISO-8601 UTC string, or
        None when the recording has no absolute time.
    """
    if kind not in KINDS:
        raise ValueError(f"unknown table kind {kind!r}")
    return {
        "version": VERSION,
        "kind": kind,
        "time": {"epoch_utc": format_epoch(epoch_utc)},
        "provenance": [],
    }


#: Session times accepted (years, UTC): sensors with a clock, before any far-future nonsense.
MIN_YEAR, MAX_YEAR = 1970, 2099


def format_epoch(epoch: float | str | None) -> str | None:
    """Unix seconds or an ISO string -> canonical ISO-8601 UTC string (microseconds, 'Z')."""
    if epoch is None:
        return None
    if isinstance(epoch, str):
        epoch = parse_epoch(epoch)
    x = float(epoch)
    lo, hi = datetime(MIN_YEAR, 1, 1, tzinfo=UTC).timestamp(), datetime(MAX_YEAR + 1, 1, 1, tzinfo=UTC).timestamp()
    if not (math.isfinite(x) and lo <= x < hi):
        raise InputError(f"session start time {x:g} s (Unix) is not in the years {MIN_YEAR}..{MAX_YEAR}")
    dt = datetime.fromtimestamp(x, tz=UTC)
    return dt.strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def parse_epoch(text: str) -> float:
    """ISO-8601 UTC string -> Unix seconds."""
    try:
        dt = datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError as exc:
        raise InputError(f"metadata key 'time.epoch_utc' is {text!r}, expected an ISO-8601 UTC time") from exc
    if dt.tzinfo is None:
        dt = dt.replace(tzinfo=UTC)
    if not MIN_YEAR <= dt.astimezone(UTC).year <= MAX_YEAR:
        raise InputError(f"metadata key 'time.epoch_utc' is {text!r}, expected a time in {MIN_YEAR}..{MAX_YEAR}")
    return dt.timestamp()


def epoch_unix(meta: dict[str, Any]) -> float | None:
    """The session's time origin in Unix seconds, or None if it has none."""
    text = (meta.get("time") or {}).get("epoch_utc")
    return None if text is None else parse_epoch(text)


def _bad(key: str, why: str) -> InputError:
    return InputError(f"metadata key '{key}' {why}")


def validate_meta(meta: Any) -> dict[str, Any]:
    """Check a decoded metadata object; return it or raise :class:`InputError` naming the key."""
    if not isinstance(meta, dict):
        raise InputError("metadata 'sportfusion' is not a JSON object")
    if "version" not in meta:
        raise _bad("version", "is missing")
    if meta["version"] != VERSION:
        raise _bad("version", f"is {meta['version']!r}; this sportfusion reads version {VERSION}")
    if "kind" not in meta:
        raise _bad("kind", "is missing")
    if meta["kind"] not in KINDS:
        raise _bad("kind", f"is {meta['kind']!r}, expected one of {', '.join(KINDS)}")
    prov = meta.get("provenance")
    if not isinstance(prov, list):
        raise _bad("provenance", "is missing or not a list")
    for i, step in enumerate(prov):
        if not isinstance(step, dict) or not {"tool", "version", "params"} <= set(step):
            raise _bad(f"provenance[{i}]", "must be an object with tool, version and params")
    time = meta.get("time")
    if time is not None:
        if not isinstance(time, dict) or "epoch_utc" not in time:
            raise _bad("time", "must be an object with key epoch_utc")
        if time["epoch_utc"] is not None:
            if not isinstance(time["epoch_utc"], str):
                raise _bad("time.epoch_utc", "must be an ISO-8601 string or null")
            parse_epoch(time["epoch_utc"])
    frame = meta.get("frame")
    if frame is not None:
        if not isinstance(frame, dict):
            raise _bad("frame", "must be an object")
        for k in ("name", "origin", "azimuth_deg"):
            if k not in frame:
                raise _bad(f"frame.{k}", "is missing")
        origin = frame["origin"]
        if (
            not isinstance(origin, list)
            or len(origin) != 3
            or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in origin)
        ):
            raise _bad("frame.origin", "must be [lat_deg, lon_deg, h_m]")
        lat, lon, h = origin
        if not (-90 <= lat <= 90 and -180 <= lon <= 360 and -1000 <= h <= 10000):
            raise _bad("frame.origin", f"is {origin}, expected lat -90..90 deg, lon -180..360 deg, h -1000..10000 m")
        az = frame["azimuth_deg"]
        if isinstance(az, bool) or not isinstance(az, (int, float)) or not -360 <= az <= 360:
            raise _bad("frame.azimuth_deg", f"is {az!r}, expected a number in -360..360 (deg)")
    units = meta.get("units")
    if units is not None and (not isinstance(units, dict) or not all(isinstance(v, str) for v in units.values())):
        raise _bad("units", "must map column names to unit strings")
    events = meta.get("events")
    if events is not None and not isinstance(events, list):
        raise _bad("events", "must be a list")
    return meta


#: Largest ``sportfusion`` metadata JSON read [bytes] (provenance of a long pipeline is a few kB; a table
#: with 80 MB of it took 49 s and 1.4 GB before this limit).  Override: SPORTFUSION_MAX_META_BYTES.
MAX_META_BYTES = 8 * 1024**2
#: Deepest nesting of objects and lists in the metadata (the contract's deepest is 4).
MAX_META_DEPTH = 64
#: Largest integer magnitude in the metadata (a 64-bit integer; Python's own limit is 4300 digits).
MAX_META_INT = 2**63


def max_meta_bytes() -> int:
    """:data:`MAX_META_BYTES`, or ``SPORTFUSION_MAX_META_BYTES`` where set."""
    try:
        return max(int(float(os.environ.get("SPORTFUSION_MAX_META_BYTES", MAX_META_BYTES))), 1024)
    except (ValueError, OverflowError):
        return MAX_META_BYTES


def max_footer_bytes() -> int:
    """Largest Parquet footer read [bytes]: the metadata is in it twice (as JSON and inside the Arrow schema,
    base64), plus the schema and the row groups' statistics."""
    return 3 * max_meta_bytes() + 16 * 1024**2


def _check_shape(obj: Any) -> None:
    """Refuse nesting deeper than :data:`MAX_META_DEPTH` and integers beyond :data:`MAX_META_INT` (iteratively)."""
    stack = [(obj, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, (dict, list)):
            if depth > MAX_META_DEPTH:
                raise InputError(f"metadata 'sportfusion' is nested more than {MAX_META_DEPTH} levels deep; refused")
            stack.extend((v, depth + 1) for v in (item.values() if isinstance(item, dict) else item))
        elif isinstance(item, int) and not isinstance(item, bool) and abs(item) > MAX_META_INT:
            raise InputError(f"metadata 'sportfusion' holds an integer of {len(str(abs(item)))} digits; refused")


def decode(raw: bytes | None) -> dict[str, Any]:
    """Decode and validate the raw metadata value of key ``sportfusion``.

    Bounded: at most :func:`max_meta_bytes` bytes, :data:`MAX_META_DEPTH` levels, integers within
    :data:`MAX_META_INT`; each refused in one line (:class:`InputError`).
    """
    if raw is None:
        raise InputError("the table has no 'sportfusion' metadata; expected a table written by a sportfusion tool")
    cap = max_meta_bytes()
    if len(raw) > cap:
        raise InputError(
            f"metadata 'sportfusion' is {len(raw) / 1024**2:.1f} MiB of JSON; refused above "
            f"{cap / 1024**2:.0f} MiB (SPORTFUSION_MAX_META_BYTES)"
        )
    try:
        meta = json.loads(raw)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"metadata 'sportfusion' is not valid JSON ({exc})") from exc
    except RecursionError as exc:
        raise InputError(f"metadata 'sportfusion' is nested more than {MAX_META_DEPTH} levels deep; refused") from exc
    except ValueError as exc:  # an integer beyond Python's digit limit
        raise InputError(f"metadata 'sportfusion' holds a number that cannot be read ({exc}); refused") from exc
    _check_shape(meta)
    return validate_meta(meta)


def encode(meta: dict[str, Any]) -> bytes:
    """Validate and encode metadata as compact UTF-8 JSON."""
    validate_meta(meta)
    # NaN/inf are not JSON: a parameter that is "inf (off)" or a statistic without a value is null
    clean = _finite(json.loads(json.dumps(meta, default=_jsonable, allow_nan=True)))
    return json.dumps(clean, separators=(",", ":"), allow_nan=False).encode()


def _jsonable(obj: Any) -> Any:
    try:
        import numpy as np

        if isinstance(obj, np.generic):
            return obj.item()
        if isinstance(obj, np.ndarray):
            return obj.tolist()
    except ImportError:  # pragma: no cover
        pass
    if isinstance(obj, (set, tuple)):
        return list(obj)
    return str(obj)


def add_provenance(meta: dict[str, Any], tool: str, params: dict[str, Any]) -> dict[str, Any]:
    """Return a copy of ``meta`` with one provenance step ``{tool, version, params}`` appended."""
    out = copy.deepcopy(meta)
    clean = _finite(json.loads(json.dumps(params, default=_jsonable, allow_nan=True)))
    out.setdefault("provenance", []).append({"tool": tool, "version": __version__, "params": clean})
    return out


def _finite(obj: Any) -> Any:
    """Replace non-finite floats (not valid JSON) by None, recursively."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_finite(v) for v in obj]
    return obj
