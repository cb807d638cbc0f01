"""Raw recordings -> one session table on one clock, no sample dropped.

Each format lives in its own module with two functions:

``sniff(path: Path, head: bytes) -> bool``
    True when the file (or folder) looks like this format; ``head`` is the
    first 4 KiB of a file (empty for a folder).
``read(path: Path, opts: Options) -> Recording``
    Parse it into sensor :class:`~sportfusion.core.session.Stream` objects whose
    times are seconds since ``Recording.epoch_utc`` (Unix seconds), or since
    an arbitrary start when the format has no absolute time (``epoch_utc``
    None).

:func:`combine` puts several recordings on one clock (UTC where they have
it, plus per-input offsets) and merges them with
:func:`sportfusion.core.session.merge_streams`, which applies the one
time-ordering policy of every format to each stream
(:func:`sportfusion.core.session.order_by_time`): readers keep absolute times
in file order and neither sort nor refuse out-of-order times themselves.
"""

from __future__ import annotations

import importlib
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow as pa

from sportfusion.core import meta as sfmeta
from sportfusion.core.errors import InputError
from sportfusion.core.io import regular_file
from sportfusion.core.outputs import printable
from sportfusion.core.session import Stream, merge_streams

#: Formats in sniffing order (most specific first); each is a module of this package.
FORMATS = (
    "session",
    "bouldering",
    "xsensdir",
    "phyphox",
    "sensorlogger",
    "rtklib",
    "xsens",
    "fit",
    "tcx",
    "nmea",
    "gpx",
    "csvmap",
)


@dataclass
class Options:
    """Options that readers may use (all optional).

    Attributes
    ----------
    geoid_offset : float or None
        GPX, NMEA, FIT, TCX: geoid separation N [m] added to MSL heights (``<ele>``, a GGA without its
        separation field, FIT/TCX altitude) to get ellipsoidal h.
    no_time : bool
        GPX: accept points without usable times; ``t`` is then the point index [s].
    column_map : dict
        Generic CSV: table column -> CSV header (``--map acc_x=AccX``); ``t`` maps the time column.
    time_unit : str
        Generic CSV: unit of the time column: ``s``, ``ms``, ``us``, ``ns`` or ``iso``.
    units : dict
        Generic CSV: table column -> unit of the CSV values (``g``, ``deg/s``, ``mG``, ``nT``, ...).
    hand : str
        Bouldering dataset: which hand's IMU file to read (``lefthand``/``righthand``); default: the
        trial's only one (a trial with both needs it).
    date : str or None
        NMEA: UTC date ``YYYY-MM-DD`` of a log without RMC/ZDA dates (GGA only).
    hold_map : str or None
        Bouldering dataset: folder of the hold map (``routes/``, ``start_handles.json``); default: searched.
    map_up : str
        Bouldering dataset: the hold map's up axis (``x y z -x -y -z``).
    invalid : dict
        Generic CSV: column, column group (``acc`` for ``acc_x/y/z``) or ``*`` (every mapped column but
        ``t``) -> its invalid markers as written in the file, ``/``-separated (``gnss_speed=-1``,
        ``acc=-999/9999``, ``h=N/A``): cells holding one are read as null.
    rate : float or None
        Sampling rate [Hz] of an input whose file does not state one: Xsens exports
        timed by PacketCounter, generic CSVs whose time column counts ticks.
    mapping : str or None
        A folder of Xsens exports (several IMUs): the OpenSense mapping file (``myIMUMappings.xml``)
        naming each sensor's segment; default: the one in the folder.
    segments : dict
        A folder of Xsens exports: sensor id (or file name) -> segment name, instead of a mapping file.
    base : (lat [deg], lon [deg], h [m]) or None
        RTKLIB e/n/u-baseline solutions: the base station's WGS84 position (ellipsoidal height);
        default: the solution header's ``ref pos`` line.
    """

    geoid_offset: float | None = None
    no_time: bool = False
    column_map: dict[str, str] = field(default_factory=dict)
    time_unit: str = "s"
    units: dict[str, str] = field(default_factory=dict)
    hand: str | None = None
    date: str | None = None
    hold_map: str | None = None
    map_up: str = "z"
    rate: float | None = None
    mapping: str | None = None
    segments: dict[str, str] = field(default_factory=dict)
    base: tuple[float, float, float] | None = None
    invalid: dict[str, str] = field(default_factory=dict)


@dataclass
class Recording:
    """One parsed input: its streams, its time origin and what it says about itself.

    ``meta`` goes into the session's ``sources`` entry, except ``meta["units"]``
    (-> the session's ``units``) and ``meta["session"]`` (keys merged into the
    session metadata, e.g. ``climbing``).  ``tables`` holds side tables a
    reader found (name -> (table, metadata)), e.g. a bouldering hold map.
    """

    source: str
    format: str
    streams: list[Stream]
    epoch_utc: float | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    tables: dict[str, tuple[pa.Table, dict[str, Any]]] = field(default_factory=dict)


def _module(fmt: str) -> Any:
    if fmt not in FORMATS:
        raise InputError(f"unknown input format {fmt!r}, expected one of {', '.join(FORMATS)}")
    return importlib.import_module(f"sportfusion.ingest.{fmt}")


def detect_format(path: Path) -> str:
    """Name of the format of ``path`` by sniffing its content (and name)."""
    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    head = b""
    if path.is_file():
        with path.open("rb") as fh:
            head = fh.read(4096)
        if not head:
            raise InputError(f"{path}: file is empty; expected a raw recording")
    for fmt in FORMATS:
        if _module(fmt).sniff(path, head):
            return fmt
    raise InputError(
        f"{path}: format not recognised; expected phyphox or Sensor Logger (ZIP/folder), NMEA, GPX, FIT, TCX, "
        "RTKLIB .pos, Xsens export (or a folder of them with a mapping), a bouldering trial folder, a session Parquet, or a CSV with --map (or give --format)"
    )


def read_recording(path: str | Path, fmt: str | None = None, opts: Options | None = None) -> Recording:
    """Parse one raw input (format sniffed unless given).

    A pipe (``ingest <(cat file)``), a FIFO or a device is buffered into a temporary file first
    (:func:`sportfusion.core.io.regular_file`), so it is sniffed and read like the file it carries.  A
    damaged ZIP archive (a flipped bit: a CRC or decompression error) is an :class:`InputError`.
    """
    p = Path(path)
    with regular_file(p) as q:
        fmt = fmt or detect_format(q)
        try:
            rec = _module(fmt).read(q, opts or Options())
        except (zipfile.BadZipFile, zipfile.LargeZipFile, zlib.error, EOFError) as exc:
            raise InputError(
                f"{printable(str(p))}: a damaged ZIP archive ({printable(str(exc))}); expected an intact export"
            ) from exc
    if q != p:
        rec.source = str(p)
    if not any(len(s.t) for s in rec.streams):
        raise InputError(f"{p}: no samples found in this {fmt} input")
    return rec


def combine(
    recordings: list[Recording], offsets: dict[str, float] | None = None
) -> tuple[pa.Table, dict[str, Any], list[str]]:
    """Put recordings on one clock and merge them into a session table.

    The session's time origin is the earliest ``epoch_utc`` among the
    recordings that have one.  A recording with UTC is shifted by its epoch's
    difference to that origin; one without UTC starts at session t = 0.  Then
    ``offsets[source]`` [s] (keyed by the input's path or file name) is added.

    Returns
    -------
    table : pyarrow.Table
        The session table.
    meta : dict
        Fresh session metadata with ``sources`` (file, format, samples per
        stream) and ``units`` where a reader declared a non-default unit
        (``Recording.meta["units"]``, e.g. ``{"mag_x": "1"}``).
    warnings : list of str
    """
    offsets = dict(offsets or {})
    warnings: list[str] = []
    epochs = [r.epoch_utc for r in recordings if r.epoch_utc is not None]
    origin = min(epochs) if epochs else None
    streams: list[Stream] = []
    sources = []
    units: dict[str, str] = {}
    session: dict[str, Any] = {}
    for rec in recordings:
        key = next((k for k in (rec.source, Path(rec.source).name) if k in offsets), None)
        off = offsets.pop(key, 0.0) if key else 0.0
        shift = off + (rec.epoch_utc - origin if (rec.epoch_utc is not None and origin is not None) else 0.0)
        if rec.epoch_utc is None and len(recordings) > 1 and key is None:
            warnings.append(
                f"{rec.source} has no absolute time; it starts at session t = 0 (give --offset {Path(rec.source).name}=SECONDS)"
            )
        warnings += [f"{rec.source}: {w}" for w in rec.warnings]
        for s in rec.streams:
            streams.append(Stream(f"{Path(rec.source).name}:{s.name}", s.t + shift, s.columns))
        extra = dict(rec.meta)
        units.update(extra.pop("units", {}))
        session.update(extra.pop("session", {}))
        sources.append({"file": Path(rec.source).name, "format": rec.format, "shift_s": shift, **extra})
    if offsets:
        raise InputError(f"--offset names {', '.join(offsets)}, which is not one of the inputs")
    table, report = merge_streams(streams)
    for name, order in report.order.items():  # the time-ordering policy: core.session.order_by_time
        if order.conflicts:
            rows = ", ".join(f"index {i} at t = {t:.3f} s" for i, t in order.conflict_rows)
            warnings.append(
                f"{name}: {order.conflicts} sample(s) share a time with an earlier, different sample "
                f"(first: {rows}); the earlier one (file order) is kept, the later only fills its empty columns"
            )
        if order.no_time:
            first = ", ".join(str(i) for i in order.no_time_rows)
            warnings.append(f"{name}: {order.no_time} sample(s) without a finite time dropped (first index: {first})")
    meta = sfmeta.new_meta("session", origin)
    meta.update({k: v for k, v in session.items() if k not in meta})
    for src in sources:
        prefix = src["file"] + ":"
        src["samples"] = {k[len(prefix) :]: v for k, v in report.rows.items() if k.startswith(prefix)}
        src["time_order"] = {k[len(prefix) :]: v.counts() for k, v in report.order.items() if k.startswith(prefix)}
    meta["sources"] = sources
    if units:
        meta["units"] = units
    return table, meta, warnings


def time_order_totals(meta: dict[str, Any]) -> dict[str, int]:
    """Counts of the time-ordering policy summed over every stream of every source (``meta["sources"]``)."""
    total: dict[str, int] = {}
    for src in meta.get("sources", []):
        for counts in (src.get("time_order") or {}).values():
            for k, v in counts.items():
                total[k] = total.get(k, 0) + int(v)
    return total
