"""Several IMUs on one athlete: a folder of Xsens MT Manager exports (one file per sensor) -> one recording.

Which sensor is on which body segment comes from, in this order:

* ``--segment ID=NAME`` (``Options.segments``): ID is the sensor's id as it ends the file name
  (``MT_012005D6_009-001_00B42268.txt`` -> ``00B42268``), the file's name or stem;
* an OpenSim OpenSense mapping file (``myIMUMappings.xml``): given with ``--mapping FILE``
  (``Options.mapping``) or the one ``*.xml`` in the folder holding ``<XsensDataReaderSettings>``.  Its
  ``<trial_prefix>`` and each ``<ExperimentalSensor name="_00B42268">`` name the file
  ``<trial_prefix><name><trial_extension>`` (extension ``.txt`` unless ``<trial_extension>`` says
  otherwise: OpenSim's own rule), and ``<name_in_model>`` the segment (``pelvis_imu`` -> ``pelvis``; the
  ``_imu`` suffix OpenSense puts on its sensor frames is dropped).

Segment names are OpenSim's bodies (``pelvis``, ``torso``, ``head``, ``femur_r``, ``femur_l``,
``tibia_r``, ``tibia_l``, ``calcn_r``, ...; any plain identifier is accepted).  Each file is read by
:mod:`sportfusion.ingest.xsens` (every MT Manager version it reads).

Columns (docs/table-contract.md, "Several IMUs"): the pelvis sensor keeps the plain names (``acc_x``,
``gyr_x``, ``mag_x``, ``dev_q0``, ...), so single-sensor tools (``detect-events --kind gates``,
``gate-anchor``) read it as before; every other sensor's columns are ``<segment>__<column>`` (two
underscores: ``femur_r__acc_x``), plain identifiers that pandas, polars and duckdb read as they are.

Synchronisation (one clock for all sensors), said in the metadata (``sources[].sync``) and on stderr:

1. ``SampleTimeFine`` when every file is timed by it, else ``PacketCounter`` when every file is: the
   exports of one recording share the counter (Awinda's wireless sync), so each file is shifted by its
   first sample's counter time minus the earliest one's (wraps taken modulo the counter's period);
2. else UTC, when every file has valid UTC columns;
3. else start times: every file's first sample at t = 0 (a warning says so).
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream
from sportfusion.ingest import Options, Recording

_IDENT = re.compile(r"^[a-z][a-z0-9_]*$")
#: The segment whose sensor keeps the plain column names (the sacrum / pelvis sensor).
PLAIN_SEGMENT = "pelvis"
SEPARATOR = "__"


def segment_column(segment: str, column: str) -> str:
    """Column name of ``column`` measured by the sensor on ``segment`` (plain for the pelvis)."""
    return column if segment == PLAIN_SEGMENT or column == "t" else f"{segment}{SEPARATOR}{column}"


def check_segment(name: str, where: str) -> str:
    """A segment name in the plain-identifier form (lower case); raises InputError otherwise."""
    seg = name.strip()
    if seg.endswith("_imu"):
        seg = seg[: -len("_imu")]
    if not _IDENT.match(seg) or SEPARATOR in seg:
        raise InputError(
            f"{where}: segment name {name!r} is not a plain identifier (lower-case letters, digits and single "
            "underscores, e.g. pelvis, femur_r)"
        )
    return seg


def _exports(folder: Path) -> list[Path]:
    from sportfusion.ingest import xsens

    out = []
    for p in sorted(folder.iterdir()):
        if not p.is_file() or p.suffix.lower() not in (".txt", ".csv", ".tsv"):
            continue
        with p.open("rb") as fh:
            head = fh.read(4096)
        if head and xsens.sniff(p, head):
            out.append(p)
    return out


def _mapping_files(folder: Path) -> list[Path]:
    out = []
    for p in sorted(folder.glob("*.xml")):
        try:
            if b"XsensDataReaderSettings" in p.read_bytes()[:65536]:
                out.append(p)
        except OSError:
            continue
    return out


def sniff(path: Path, head: bytes) -> bool:
    """A folder holding an OpenSense mapping file, or at least two Xsens exports."""
    if not path.is_dir():
        return False
    return bool(_mapping_files(path)) or len(_exports(path)) >= 2


def read_mapping(path: Path) -> dict[str, Any]:
    """An OpenSense ``XsensDataReaderSettings`` file -> ``{"prefix", "extension", "rate", "sensors": {name: segment}}``."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise InputError(f"{path}: not a readable OpenSense mapping file ({exc})") from exc
    settings = root if root.tag == "XsensDataReaderSettings" else root.find(".//XsensDataReaderSettings")
    if settings is None:  # some files spell it XSensDataReaderSettings
        settings = next((e for e in root.iter() if e.tag.lower() == "xsensdatareadersettings"), None)
    if settings is None:
        raise InputError(f"{path}: no <XsensDataReaderSettings> element; expected an OpenSense myIMUMappings.xml")

    def text(tag: str) -> str | None:
        e = settings.find(tag)
        return e.text.strip() if e is not None and e.text and e.text.strip() else None

    sensors: dict[str, str] = {}
    for e in settings.iter("ExperimentalSensor"):
        name = e.get("name")
        seg = e.findtext("name_in_model")
        if not name or not seg:
            raise InputError(f"{path}: an <ExperimentalSensor> without a name or <name_in_model>")
        sensors[name] = check_segment(seg, str(path))
    if not sensors:
        raise InputError(f"{path}: no <ExperimentalSensor> in the mapping; expected one per sensor file")
    rate = text("sampling_rate")
    return {
        "prefix": text("trial_prefix") or "",
        "extension": text("trial_extension") or ".txt",
        "rate": float(rate) if rate else None,
        "sensors": sensors,
        "file": path.name,
    }


def _sensor_id(p: Path) -> str:
    return re.split(r"[_-]", p.stem)[-1]


def _assign(folder: Path, opts: Options) -> tuple[dict[str, Path], str]:
    """Segment -> file, and where the assignment came from."""
    files = _exports(folder)
    segments: dict[str, str] = dict(getattr(opts, "segments", {}) or {})
    out: dict[str, Path] = {}

    def put(seg: str, p: Path, how: str) -> None:
        if seg in out and out[seg] != p:
            raise InputError(
                f"two files for segment {seg!r}: {out[seg].name} and {p.name} ({how}); expected one sensor per segment"
            )
        out[seg] = p

    if segments:
        for key, seg in segments.items():
            hits = [p for p in files if key in (p.name, p.stem, _sensor_id(p))]
            if not hits:
                raise InputError(
                    f"--segment {key}={seg}: no Xsens export in {folder} for sensor {key!r} "
                    f"(files: {', '.join(p.name for p in files) or 'none'})"
                )
            if len(hits) > 1:
                raise InputError(
                    f"--segment {key}={seg}: {len(hits)} files match {key!r}: {', '.join(p.name for p in hits)}"
                )
            put(check_segment(seg, "--segment"), hits[0], "--segment")
        return out, "--segment"
    given = getattr(opts, "mapping", None)
    maps = [Path(given)] if given else _mapping_files(folder)
    if not maps:
        raise InputError(
            f"{folder}: {len(files)} Xsens export(s) but no OpenSense mapping file (myIMUMappings.xml); give "
            "--mapping FILE or --segment ID=NAME for each sensor"
        )
    if len(maps) > 1:
        raise InputError(
            f"{folder}: {len(maps)} mapping files ({', '.join(p.name for p in maps)}); give --mapping FILE"
        )
    m = read_mapping(maps[0])
    for name, seg in m["sensors"].items():
        p = folder / f"{m['prefix']}{name}{m['extension']}"
        if not p.is_file():
            alt = [q for q in files if _sensor_id(q) == name.lstrip("_-")]
            if len(alt) != 1:
                raise InputError(
                    f"{m['file']}: sensor {name!r} ({seg}) has no file {p.name} in {folder}; expected "
                    "<trial_prefix><name><trial_extension> as OpenSense reads it"
                )
            p = alt[0]
        put(seg, p, m["file"])
    return out, m["file"]


def _modular(d: float, wrap: float | None) -> float:
    if not wrap:
        return d
    return (d + wrap / 2) % wrap - wrap / 2


def read(path: Path, opts: Options) -> Recording:
    """Read every sensor's export in the folder ``path`` into one recording on one clock (module text)."""
    from sportfusion.ingest import xsens

    folder = Path(path)
    assign, how = _assign(folder, opts)
    if not assign:
        raise InputError(f"{folder}: no sensor assigned to a segment")
    recs = {seg: xsens.read(p, replace(opts, column_map={}, units={})) for seg, p in assign.items()}
    kinds = {r.meta.get("time_from") for r in recs.values()}
    warnings: list[str] = []
    starts: dict[str, float] = {}
    if len(kinds) == 1 and kinds <= {"SampleTimeFine", "PacketCounter"}:
        sync = kinds.pop()
        ref_seg = min(recs, key=lambda s: recs[s].meta["counter"]["start_s"])
        ref = recs[ref_seg].meta["counter"]
        for seg, r in recs.items():
            c = r.meta["counter"]
            starts[seg] = _modular(c["start_s"] - ref["start_s"], c.get("wrap_s"))
        starts = {k: v - min(starts.values()) for k, v in starts.items()}
        epoch = None
        with_utc = [r.epoch_utc for r in recs.values() if r.epoch_utc is not None]
        if with_utc:  # absolute time from the earliest file that has it
            seg0 = next(s for s, r in recs.items() if r.epoch_utc is not None)
            epoch = recs[seg0].epoch_utc - starts[seg0]
        sync_line = f"by the shared {sync}"
    elif all(r.epoch_utc is not None for r in recs.values()):
        e0 = min(r.epoch_utc for r in recs.values())  # type: ignore[type-var]
        starts = {s: float(r.epoch_utc - e0) for s, r in recs.items()}  # type: ignore[operator]
        epoch = e0
        sync_line = "by UTC"
    else:
        starts = {s: 0.0 for s in recs}
        epoch = None
        sync_line = "by start times (no shared counter or UTC): every file's first sample at t = 0"
        warnings.append(f"sensors synchronised {sync_line}; check with --offset if they did not start together")
    spans = {s: (starts[s] + r.streams[0].t[0], starts[s] + r.streams[0].t[-1]) for s, r in recs.items()}
    lo, hi = max(a for a, _ in spans.values()), min(b for _, b in spans.values())
    if lo >= hi:
        a = min(spans, key=lambda s: spans[s][1])
        b = max(spans, key=lambda s: spans[s][0])
        raise InputError(
            f"the sensors never overlap in time: {a} ends at {spans[a][1]:.2f} s, {b} starts at {spans[b][0]:.2f} s "
            f"(synchronised {sync_line}); expected one recording of all sensors"
        )
    streams = []
    units: dict[str, str] = {}
    sensors_meta = {}
    for seg, r in recs.items():
        s = r.streams[0]
        cols = {segment_column(seg, k): v for k, v in s.columns.items()}
        ts = np.asarray(s.t, float) + starts[seg]
        step = r.meta["counter"].get("step_s") if sync_line.startswith("by the shared") else None
        if step:  # on the counter's grid: the same instant of two sensors is the same float (one row)
            ts = np.round(ts / step) * step
        streams.append(Stream(seg, ts, cols))
        units.update({segment_column(seg, k): v for k, v in r.meta.get("units", {}).items()})
        warnings += [f"{Path(r.source).name}: {w}" for w in r.warnings if "no absolute time" not in w]
        sensors_meta[seg] = {
            "file": Path(r.source).name,
            "shift_s": starts[seg],
            "time_from": r.meta.get("time_from"),
            "columns": sorted(cols),
        }
    if PLAIN_SEGMENT not in recs:
        warnings.append(
            f"no {PLAIN_SEGMENT} sensor: every column carries its segment's prefix (single-sensor tools read the "
            f"{PLAIN_SEGMENT} sensor's plain acc_*, gyr_*, mag_*)"
        )
    meta: dict[str, Any] = {
        "sync": sync_line,
        "mapping": how,
        "sensors": sensors_meta,
        "overlap_s": [float(lo), float(hi)],
        "session": {
            "body_sensors": {seg: sorted(c for c in st.columns) for seg, st in zip(recs, streams, strict=True)}
        },
    }
    if units:
        meta["units"] = units
    meta["summary"] = f"{len(recs)} sensors ({', '.join(sorted(recs))}) synchronised {sync_line} (segments from {how})"
    return Recording(str(folder), "xsensdir", streams, epoch, meta, warnings)


def segment_recording(rec: Recording, segment: str) -> Recording:
    """A single-sensor recording (any reader, e.g. a CSV read with ``--map``) put on ``segment``: its
    columns renamed ``<segment>__<column>`` (plain for the pelvis), as a folder of exports would name them."""
    seg = check_segment(segment, f"--segment for {Path(rec.source).name}")
    streams = [Stream(s.name, s.t, {segment_column(seg, k): v for k, v in s.columns.items()}) for s in rec.streams]
    meta = dict(rec.meta)
    if "units" in meta:
        meta["units"] = {segment_column(seg, k): v for k, v in meta["units"].items()}
    meta["segment"] = seg
    return replace(rec, streams=streams, meta=meta)
