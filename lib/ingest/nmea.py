"""NMEA 0183 logs (GPS loggers): GGA, RMC, VTG, GST, GNS and ZDA from any talker.

Sentences are parsed with pynmea2; every sentence must carry a valid ``*hh``
checksum.  Real logs are not pure NMEA (docs/recordings-gnss.md): ``#``
comment lines (receiver test logs) are skipped and counted in the metadata;
a sentence may follow other text on its line (a logger's own time stamp,
binary bytes of an interleaved binary protocol): it is read from its ``$``.
Sentences with a bad or missing checksum, and lines that hold no sentence
(binary junk), are skipped and counted in one warning.  Valid sentences this
reader does not use (GSA, GSV, TXT, proprietary ``$P...`` at any rate, AIS
``!AIVDM``, instrument talkers such as depth or wind) are counted in the
recording's metadata and cost no parsing.

Sniffing
    By the sentences found, not by the first line: among the non-comment
    lines of the first 16 KiB, at least one (three when there are that many
    lines) must be a checksummed sentence, and they must be at least a
    quarter of the lines that are text (lines of binary bytes without a
    sentence do not count), so a CSV or XML file never passes, and a log
    with a comment header, a logger's prefix, or a u-blox ``.ubx`` log with
    NMEA interleaved in its binary messages does.  A file whose
    lines are mostly sentence-shaped (``$GPGGA,...*hh``) with failing
    checksums is claimed too, so the reader can say that the checksums fail.

Epochs
    All sentences with the same UTC time of day form one sample, whichever
    talker (GP, GN, GL, GA, GB, ...) wrote them.  VTG carries no time: it
    belongs to the epoch of the latest timed sentence, or to the next one
    when that epoch already has a VTG (receivers that write VTG before GGA).
    The time of day rolls over at midnight (a step back of more than 12 h
    is a new day).

Date
    From RMC (``ddmmyy``, years < 80 are 20yy) or ZDA.  Epochs without a
    date of their own take it from the nearest dated epoch before them
    (after them at the start of the log), counting midnights in between.
    A log without any RMC/ZDA date (GGA only) needs ``Options.date``
    (``--date YYYY-MM-DD``, the UTC date of the first fix): without it the
    log is refused with one line naming ``--date`` (a time of day alone
    cannot be placed on a clock, and guessing a date would be silent).

Columns (units)
    ``lat``, ``lon`` [deg, signed, from ``ddmm.mmmm`` decimal minutes],
    ``h_msl`` [m] = altitude above mean sea level, ``h`` [m] = altitude +
    geoid separation (WGS84 ellipsoidal); when the separation field is empty
    ``h`` stays null there (``h_msl`` + ``Options.geoid_offset`` when
    ``--geoid-offset`` is given), ``h_msl`` is kept and one warning says how
    many fixes lack it.  ``gnss_fix``: GGA quality as written (0 invalid, 1 GPS,
    2 DGPS, 3 PPS, 4 RTK fixed, 5 RTK float, 6 dead reckoning, 7 manual,
    8 simulator); without GGA, the GNS/RMC mode indicator mapped onto the
    same codes (N 0, A 1, D 2, P 3, R 4, F 5, E 6, M 7, S 8; for GNS the best
    of its per-constellation characters); an RMC without a mode indicator
    gives 0 for status V and 1 (plain GPS, the weakest valid code) for
    status A.  ``gnss_sats``, ``gnss_hdop`` from GGA/GNS (99.99, the
    receivers' "no value" marker, and anything from 99 up: null).
    ``gnss_sigma_n/e/v`` [m] from GST (latitude, longitude, altitude error
    1-sigma), ``gnss_sigma_h`` = sqrt((sigma_n^2 + sigma_e^2) / 2).
    ``gnss_speed`` [m/s] (knots x 1852/3600) and ``gnss_course`` [deg true]
    from RMC, else VTG; ``vel_n`` = speed cos(course), ``vel_e`` = speed
    sin(course) (0 when the speed is 0 and the course empty).  NMEA has no
    vertical velocity: ``vel_d`` is not written.
    Where several sentences of one epoch give a field, GGA wins over GNS,
    GNS over RMC, RMC over VTG; of two sentences of one type the first wins.

Invalid fixes
    Nothing is dropped: an epoch with fix 0 (or RMC status V) is kept with
    exactly what the receiver wrote - usually empty (null) position fields,
    sometimes a stale last position - and ``gnss_fix`` = 0 marks it, so
    downstream tools select on ``gnss_fix`` rather than on missing rows.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pynmea2

from sportfusion.core.errors import InputError
from sportfusion.core.session import Stream
from sportfusion.ingest import Options, Recording

#: An HDOP of this or more is the receivers' "unknown" marker (u-blox writes 99.99 without a fix): null.
HDOP_UNKNOWN = 99.0
#: Metres per second in one knot.
KNOT = 1852.0 / 3600.0
USED = ("GGA", "GNS", "RMC", "VTG", "GST", "ZDA")
#: Source priority per sentence type (lower wins) when several give one field.
_PRIORITY = {"GGA": 0, "GST": 0, "ZDA": 0, "GNS": 1, "RMC": 2, "VTG": 3}
#: NMEA mode indicator (GNS, RMC >= 2.3) -> GGA quality code.
MODE_TO_QUALITY = {"N": 0, "A": 1, "D": 2, "P": 3, "R": 4, "F": 5, "E": 6, "M": 7, "S": 8}
_MODE_RANK = "RFDPAEMSN"  # best first, for GNS's one character per constellation
#: A checksummed sentence (``$`` or ``!`` for AIS encapsulation) anywhere in a line.
_SENTENCE = re.compile(r"[$!]([A-Z0-9]{3,})([,*][^$!*\r\n]*)?\*([0-9A-Fa-f]{2})")
_ADDRESS = re.compile(r"[$!][A-Z0-9]{3,},")
_BINARY = re.compile("[\x00-\x08\x0e-\x1f\x7f\ufffd]")
_SHAPED = re.compile(r"^[$!][A-Z0-9]{3,},[^*]*\*[0-9A-Fa-f]{2}$")
SNIFF_BYTES = 16384
_TIME = re.compile(r"^(\d{2})(\d{2})(\d{2}(?:\.\d*)?)$")
_UNIX_DAY0 = dt.date(1970, 1, 1).toordinal()

FLOAT_COLUMNS = (
    "lat",
    "lon",
    "h",
    "h_msl",
    "gnss_hdop",
    "gnss_sigma_n",
    "gnss_sigma_e",
    "gnss_sigma_v",
    "gnss_sigma_h",
    "gnss_speed",
    "gnss_course",
    "vel_n",
    "vel_e",
)
INT_COLUMNS = ("gnss_fix", "gnss_sats")


def _checksum_ok(sentence: str) -> bool:
    """True when ``$...*hh`` (or ``!...*hh``) carries the XOR checksum of the text between."""
    body, _, cs = sentence[1:].rpartition("*")
    x = 0
    for ch in body.encode("ascii", errors="replace"):
        x ^= ch
    try:
        return x == int(cs[:2], 16)
    except ValueError:
        return False


def find_sentences(line: str) -> list[str]:
    """The checksummed NMEA sentences in a line (each from its ``$``/``!`` to ``*hh``), in order."""
    return [m.group(0) for m in _SENTENCE.finditer(line) if _checksum_ok(m.group(0))]


def sniff(path: Path, head: bytes) -> bool:
    """True when checksummed sentences are a fair share of the first 16 KiB (see the module docstring)."""
    if len(head) < SNIFF_BYTES and path.is_file():
        try:
            with path.open("rb") as fh:
                head = fh.read(SNIFF_BYTES)
        except OSError:
            return False
    text = head.decode("ascii", errors="replace")
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    if len(head) >= SNIFF_BYTES and len(lines) > 1:
        lines = lines[:-1]  # the last line may be cut
    lines = [ln for ln in lines if not ln.startswith("#")]
    if not lines:
        return False
    found = [bool(find_sentences(ln)) for ln in lines]
    valid = sum(found)
    # lines of binary bytes with no sentence (a u-blox .ubx log with NMEA interleaved in its binary messages)
    # are not counted against the share: the file is sniffed by the sentences it holds
    binary = sum(1 for ln, ok in zip(lines, found, strict=True) if not ok and _BINARY.search(ln))
    text_lines = len(lines) - binary
    if valid >= min(3, len(lines)) and valid >= 0.25 * text_lines:
        return True
    # sentence-shaped lines whose checksums all fail: still NMEA, so the reader can say what is wrong
    shaped = sum(bool(_SHAPED.search(ln)) for ln in lines)
    return shaped >= 0.5 * len(lines)


class _Bad(ValueError):
    """A field that is present but not a number/time of the expected form."""


def _num(text: str) -> float | None:
    text = text.strip()
    if not text:
        return None
    try:
        v = float(text)
    except ValueError as exc:
        raise _Bad(text) from exc
    if not math.isfinite(v):
        raise _Bad(text)
    return v


def _int(text: str) -> int | None:
    v = _num(text)
    if v is None:
        return None
    if v != int(v):
        raise _Bad(text)
    return int(v)


def _tod(text: str) -> tuple[int, float] | None:
    """``hhmmss.sss`` -> whole seconds of the UTC day and the fraction (None when empty)."""
    text = text.strip()
    if not text:
        return None
    m = _TIME.match(text)
    if not m:
        raise _Bad(text)
    hh, mm = int(m.group(1)), int(m.group(2))
    whole, _, frac = m.group(3).partition(".")
    ss = int(whole)
    if hh > 23 or mm > 59 or ss > 60:
        raise _Bad(text)
    return hh * 3600 + mm * 60 + ss, float("0." + frac) if frac else 0.0


def dm_to_deg(value: str, hemisphere: str) -> float | None:
    """NMEA ``(d)ddmm.mmmm`` + hemisphere letter -> signed decimal degrees.

    The two digits before the decimal point and the decimals are minutes,
    everything before them degrees: ``4807.038,N`` -> 48 + 7.038/60.
    S and W are negative.  Returns None for an empty field.
    """
    value = value.strip()
    if not value:
        return None
    dot = value.find(".")
    cut = (dot if dot >= 0 else len(value)) - 2
    if cut < 0:
        raise _Bad(value)
    deg = _num(value[:cut]) if cut else 0.0
    minutes = _num(value[cut:])
    if deg is None or minutes is None or deg < 0 or not 0.0 <= minutes < 60.0:
        raise _Bad(value)
    hemi = hemisphere.strip().upper()
    if hemi not in ("N", "S", "E", "W"):
        raise _Bad(hemisphere)
    return (-1.0 if hemi in ("S", "W") else 1.0) * (deg + minutes / 60.0)


def _date_ddmmyy(text: str) -> dt.date | None:
    text = text.strip()
    if not text:
        return None
    if len(text) != 6 or not text.isdigit():
        raise _Bad(text)
    yy = int(text[4:])
    try:
        return dt.date(yy + (2000 if yy < 80 else 1900), int(text[2:4]), int(text[:2]))
    except ValueError as exc:
        raise _Bad(text) from exc


@dataclass
class _Epoch:
    day: int  # midnights counted since the first timed sentence
    sec: int  # whole seconds of the UTC day
    frac: float  # fraction of the second
    date: dt.date | None = None
    values: dict[str, tuple[int, Any]] = field(default_factory=dict)
    has_vtg: bool = False

    def put(self, name: str, value: Any, prio: int) -> None:
        if value is None:
            return
        old = self.values.get(name)
        if old is None or prio < old[0]:
            self.values[name] = (prio, value)

    def get(self, name: str) -> Any:
        item = self.values.get(name)
        return None if item is None else item[1]


@dataclass
class _Log:
    epochs: dict[tuple[int, int, int], _Epoch] = field(default_factory=dict)
    order: list[_Epoch] = field(default_factory=list)
    current: _Epoch | None = None
    pending_vtg: dict[str, Any] | None = None  # a VTG waiting for the next epoch
    day: int = 0
    last_tod: float | None = None
    lines: int = 0
    bad_checksum: int = 0
    bad_types: dict[str, int] = field(default_factory=dict)  # sentence type -> lines failing their checksum
    unparsable: int = 0
    untimed: int = 0
    sentences: dict[str, int] = field(default_factory=dict)
    talkers: set[str] = field(default_factory=set)
    ignored: int = 0
    comments: int = 0
    binary: int = 0
    other_types: dict[str, int] = field(default_factory=dict)

    def epoch_at(self, sec: int, frac: float) -> _Epoch:
        tod = sec + frac
        if self.last_tod is not None:
            if tod < self.last_tod - 43200.0:
                self.day += 1
            elif tod > self.last_tod + 43200.0:
                self.day -= 1
        self.last_tod = tod
        key = (self.day, sec, round(frac * 1e6))
        ep = self.epochs.get(key)
        if ep is None:
            ep = _Epoch(self.day, sec, frac)
            self.epochs[key] = ep
            self.order.append(ep)
        if ep is not self.current:
            self.current = ep
            if self.pending_vtg is not None:
                self._apply_vtg(ep, self.pending_vtg)
                self.pending_vtg = None
        return ep

    def _apply_vtg(self, ep: _Epoch, vtg: dict[str, Any]) -> None:
        ep.has_vtg = True
        for k, v in vtg.items():
            ep.put(k, v, _PRIORITY["VTG"])

    def feed(self, line: str) -> None:
        line = line.strip().lstrip("\ufeff")
        if not line:
            return
        if line.startswith("#"):
            self.comments += 1
            return
        self.lines += 1
        found = find_sentences(line)
        if not found:
            m = _ADDRESS.search(line)
            if m:  # looks like a sentence: its checksum is bad or missing
                self.bad_checksum += 1
                kind = m.group(0)[-4:-1]
                self.bad_types[kind] = self.bad_types.get(kind, 0) + 1
            elif _BINARY.search(line):
                self.binary += 1
            else:
                self.unparsable += 1
            return
        for sentence in found:  # usually one; more where a logger lost a line break
            self._one(sentence)

    def _one(self, line: str) -> None:
        head = line[1:].split(",", 1)[0].split("*", 1)[0]
        kind = head[-3:] if not head.startswith("P") else head
        if line.startswith("!") or kind not in USED:  # valid, but nothing this reader uses
            self.ignored += 1
            key = "!" + head if line.startswith("!") else head[:4] if head.startswith("P") else head[:2] + "/" + kind
            self.other_types[key] = self.other_types.get(key, 0) + 1
            return
        try:
            msg = pynmea2.parse(line, check=True)
        except pynmea2.ChecksumError:
            self.bad_checksum += 1
            self.bad_types[kind] = self.bad_types.get(kind, 0) + 1
            return
        except pynmea2.SentenceTypeError:  # valid line of a type pynmea2 does not know
            self.ignored += 1
            return
        except (pynmea2.ParseError, ValueError, AttributeError, TypeError):
            self.unparsable += 1
            return
        kind = getattr(msg, "sentence_type", "")
        if kind not in USED:
            self.ignored += 1
            return
        try:
            self._sentence(kind, msg)
        except _Bad:
            self.unparsable += 1
            return
        self.sentences[kind] = self.sentences.get(kind, 0) + 1
        self.talkers.add(str(msg.talker))

    def _sentence(self, kind: str, msg: Any) -> None:
        data = list(msg.data)

        def f(name: str) -> str:
            i = msg.name_to_idx[name]
            return data[i] if i < len(data) else ""

        if kind == "VTG":
            course = _num(f("true_track"))
            knots = _num(f("spd_over_grnd_kts"))
            if knots is None:
                kmh = _num(f("spd_over_grnd_kmph"))
                knots = None if kmh is None else kmh / 3.6 / KNOT
            vtg = {"course": course, "knots": knots}
            if self.current is not None and not self.current.has_vtg:
                self._apply_vtg(self.current, vtg)
            elif self.pending_vtg is None:
                self.pending_vtg = vtg
            return
        # parse every field before touching the epoch, so a bad line changes nothing
        tod = _tod(f("timestamp"))
        vals: dict[str, Any] = {}
        date = None
        if kind in ("GGA", "GNS"):
            vals["lat"] = dm_to_deg(f("lat"), f("lat_dir")) if f("lat") else None
            vals["lon"] = dm_to_deg(f("lon"), f("lon_dir")) if f("lon") else None
            alt = _num(f("altitude"))
            sep = _num(f("geo_sep"))
            vals["alt_sep"] = None if alt is None else (alt, sep)
            vals["sats"] = _int(f("num_sats"))
            vals["hdop"] = _num(f("horizontal_dil" if kind == "GGA" else "hdop"))
            if kind == "GGA":
                vals["fix"] = _int(f("gps_qual"))
            else:
                vals["fix"] = _mode_quality(f("mode_indicator"))
        elif kind == "RMC":
            vals["lat"] = dm_to_deg(f("lat"), f("lat_dir")) if f("lat") else None
            vals["lon"] = dm_to_deg(f("lon"), f("lon_dir")) if f("lon") else None
            vals["knots"] = _num(f("spd_over_grnd"))
            vals["course"] = _num(f("true_course"))
            date = _date_ddmmyy(f("datestamp"))
            mode = _mode_quality(f("mode_indicator"))
            status = f("status").strip().upper()
            vals["fix"] = mode if mode is not None else (0 if status == "V" else 1 if status == "A" else None)
        elif kind == "GST":
            vals["sn"] = _num(f("std_dev_latitude"))
            vals["se"] = _num(f("std_dev_longitude"))
            vals["sv"] = _num(f("std_dev_altitude"))
        elif kind == "ZDA":
            day, month, year = _int(f("day")), _int(f("month")), _int(f("year"))
            if None not in (day, month, year):
                try:
                    date = dt.date(year, month, day)  # type: ignore[arg-type]
                except ValueError as exc:
                    raise _Bad(f"{year}-{month}-{day}") from exc
        if tod is None:
            self.untimed += 1
            return
        ep = self.epoch_at(*tod)
        if date is not None and ep.date is None:
            ep.date = date
        prio = _PRIORITY[kind]
        for k, v in vals.items():
            ep.put(k, v, prio)


def _mode_quality(text: str) -> int | None:
    text = text.strip().upper()
    for ch in _MODE_RANK:
        if ch in text:
            return MODE_TO_QUALITY[ch]
    return None


def _days(log: _Log, opts_date: dt.date | None, warnings: list[str]) -> np.ndarray | None:
    """Proleptic ordinal of each epoch's UTC date, or None when no date is known."""
    eps = log.order
    day = np.array([e.day for e in eps], dtype=np.int64)
    known = np.array([e.date is not None for e in eps])
    if not known.any():
        if opts_date is None:
            return None
        return opts_date.toordinal() + day - day[0]
    offset = np.array([e.date.toordinal() if e.date else 0 for e in eps], dtype=np.int64) - day
    idx = np.where(known, np.arange(len(eps)), -1)
    idx = np.maximum.accumulate(idx)
    idx[idx < 0] = int(np.argmax(known))  # leading undated epochs: the first dated one
    ordinal = day + offset[idx]
    if opts_date is not None and opts_date.toordinal() != ordinal[0]:
        first = dt.date.fromordinal(int(ordinal[0]))
        warnings.append(f"the log's own date {first.isoformat()} is used, not the given date {opts_date.isoformat()}")
    return ordinal


def _parse_date(text: str | None) -> dt.date | None:
    if text is None:
        return None
    try:
        return dt.date.fromisoformat(str(text).strip())
    except ValueError as exc:
        raise InputError(f"date {text!r} is not a valid date, expected YYYY-MM-DD (UTC)") from exc


def read(path: Path, opts: Options) -> Recording:
    """Read an NMEA 0183 log into one ``nmea`` stream (see the module docstring)."""
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from exc
    log = _Log()
    for line in raw.decode("ascii", errors="replace").splitlines():
        log.feed(line)
    warnings: list[str] = []
    skipped = log.bad_checksum + log.unparsable + log.untimed + log.binary
    if not log.order:
        raise InputError(
            f"{path}: no timed GGA, GNS, RMC, GST or ZDA sentence with a valid checksum in {log.lines} line(s) "
            f"({log.bad_checksum} with a bad or missing checksum, {log.unparsable} unparsable, {log.binary} binary); "
            "expected an NMEA 0183 log"
        )
    if skipped:
        parts = [
            f"{n} {what}"
            for n, what in (
                (log.bad_checksum, "with a bad or missing checksum"),
                (log.unparsable, "unparsable"),
                (log.binary, "binary (bytes that are not text)"),
                (log.untimed, "without a UTC time"),
            )
            if n
        ]
        warnings.append(f"skipped {skipped} of {log.lines} NMEA line(s): {', '.join(parts)}")

    days = _days(log, _parse_date(opts.date), warnings)
    sec = np.array([e.sec for e in log.order], dtype=np.int64)
    frac = np.array([e.frac for e in log.order])
    if days is None:
        first = log.order[0]
        hms = f"{first.sec // 3600:02d}:{first.sec // 60 % 60:02d}:{first.sec % 60:02d}"
        dated = {k: v for k, v in log.bad_types.items() if k in ("RMC", "ZDA")}
        why = (
            " and ".join(f"{v} {k} sentence(s)" for k, v in sorted(dated.items())) + " failed their checksum"
            if dated
            else "no RMC or ZDA sentence"
        )
        raise InputError(
            f"{path}: the log has times of day but no date ({why}; first fix at {hms} UTC); "
            "give --date YYYY-MM-DD, the UTC date of the first fix"
        )
    whole = (days - _UNIX_DAY0) * 86400 + sec
    epoch = float(whole.min())
    t = (whole - epoch).astype(np.float64) + frac

    cols, no_sep = _columns(log.order)
    if no_sep and opts.geoid_offset is not None:
        h, msl = np.asarray(cols["h"]), np.asarray(cols["h_msl"])
        cols["h"] = np.where(np.isfinite(h), h, msl + float(opts.geoid_offset))
    elif no_sep:
        warnings.append(
            f"{no_sep} fix(es) have no geoid separation in GGA/GNS: ellipsoidal h is left null there and the "
            "altitude above mean sea level is kept in h_msl (give --geoid-offset M, here or to gps2hill)"
        )
    meta = {
        "talkers": sorted(log.talkers),
        "sentences": dict(sorted(log.sentences.items())),
        "ignored_sentences": log.ignored,
        "ignored_types": dict(sorted(log.other_types.items())),
        "comment_lines": log.comments,
    }
    return Recording(str(path), "nmea", [Stream("nmea", t, cols)], epoch, meta, warnings)


def _columns(epochs: list[_Epoch]) -> tuple[dict[str, object], int]:
    n = len(epochs)
    out = {k: np.full(n, np.nan) for k in FLOAT_COLUMNS}
    ints: dict[str, list[int | None]] = {k: [None] * n for k in INT_COLUMNS}
    has_alt = False
    no_sep = 0
    for i, e in enumerate(epochs):
        for src, dst in (("lat", "lat"), ("lon", "lon"), ("hdop", "gnss_hdop"), ("course", "gnss_course")):
            v = e.get(src)
            if v is not None and not (src == "hdop" and v >= HDOP_UNKNOWN):
                out[dst][i] = v
        alt_sep = e.get("alt_sep")
        if alt_sep is not None:
            has_alt = True
            alt, sep = alt_sep
            out["h_msl"][i] = alt
            if sep is None:
                no_sep += 1
            else:
                out["h"][i] = alt + sep
        sn, se, sv = e.get("sn"), e.get("se"), e.get("sv")
        if sn is not None:
            out["gnss_sigma_n"][i] = sn
        if se is not None:
            out["gnss_sigma_e"][i] = se
        if sv is not None:
            out["gnss_sigma_v"][i] = sv
        if sn is not None and se is not None:
            out["gnss_sigma_h"][i] = math.sqrt((sn * sn + se * se) / 2.0)
        knots, course = e.get("knots"), e.get("course")
        if knots is not None:
            speed = knots * KNOT
            out["gnss_speed"][i] = speed
            if course is not None:
                out["vel_n"][i] = speed * math.cos(math.radians(course))
                out["vel_e"][i] = speed * math.sin(math.radians(course))
            elif speed == 0.0:
                out["vel_n"][i] = out["vel_e"][i] = 0.0
        ints["gnss_fix"][i] = e.get("fix")
        ints["gnss_sats"][i] = e.get("sats")
    cols: dict[str, object] = {}
    for k in FLOAT_COLUMNS:
        if (k == "h" and has_alt) or not np.isnan(out[k]).all():
            cols[k] = out[k]
    for k in INT_COLUMNS:
        if any(v is not None for v in ints[k]):
            cols[k] = pa.array(ints[k], type=pa.int16())
    return cols, no_sep
