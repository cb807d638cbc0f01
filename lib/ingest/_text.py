"""Shared helpers of the text readers: CSV dialect detection, header parsing, unit factors.

Not a format module (it has no ``sniff``/``read``); phyphox, csvmap, xsens and
bouldering use it.
"""

from __future__ import annotations

import io
import math
import re
import zipfile

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from sportfusion.core.errors import InputError

_HEADER = re.compile(r"^\s*(.*?)\s*(?:[(\[]([^()\[\]]*)[)\]])?\s*$")
_DECIMAL_COMMA = re.compile(r"^\s*\"?[-+]?\d+,\d+(?:[eE][-+]?\d+)?\"?\s*$")

#: Unit spellings -> (canonical unit, factor to it).  Case matters (mG milligauss, mg milligram).
UNITS: dict[str, tuple[str, float]] = {
    # specific force / acceleration
    "m/s^2": ("m/s^2", 1.0),
    "m/s2": ("m/s^2", 1.0),
    "m/s²": ("m/s^2", 1.0),
    "m s^-2": ("m/s^2", 1.0),
    "g": ("m/s^2", 9.80665),
    "mg": ("m/s^2", 9.80665e-3),  # milli-g (accelerometers), never milligram here
    # angular rate
    "rad/s": ("rad/s", 1.0),
    "deg/s": ("rad/s", math.pi / 180.0),
    "°/s": ("rad/s", math.pi / 180.0),
    "dps": ("rad/s", math.pi / 180.0),
    # magnetic field
    "uT": ("uT", 1.0),
    "µT": ("uT", 1.0),  # micro sign U+00B5
    "μT": ("uT", 1.0),  # greek mu U+03BC
    "nT": ("uT", 1e-3),
    "mT": ("uT", 1e3),
    "T": ("uT", 1e6),
    "G": ("uT", 100.0),
    "gauss": ("uT", 100.0),
    "mG": ("uT", 0.1),
    "a.u.": ("1", 1.0),
    "1": ("1", 1.0),
    "": ("1", 1.0),
    # pressure
    "Pa": ("Pa", 1.0),
    "hPa": ("Pa", 100.0),
    "mbar": ("Pa", 100.0),
    "kPa": ("Pa", 1000.0),
    "bar": ("Pa", 1e5),
    # length
    "m": ("m", 1.0),
    "km": ("m", 1000.0),
    "cm": ("m", 0.01),
    "mm": ("m", 1e-3),
    "ft": ("m", 0.3048),
    # speed
    "m/s": ("m/s", 1.0),
    "km/h": ("m/s", 1.0 / 3.6),
    "kn": ("m/s", 1852.0 / 3600.0),
    "kt": ("m/s", 1852.0 / 3600.0),
    "knots": ("m/s", 1852.0 / 3600.0),
    "mph": ("m/s", 0.44704),
    # angles
    "deg": ("deg", 1.0),
    "°": ("deg", 1.0),
    "rad": ("rad", 1.0),
    # time
    "s": ("s", 1.0),
    "ms": ("s", 1e-3),
    "us": ("s", 1e-6),
    "µs": ("s", 1e-6),
    "ns": ("s", 1e-9),
    "min": ("s", 60.0),
    "h": ("s", 3600.0),
}
#: ``0.000244g``, ``4.375e-3 deg/s``, ``0.1*mG``: a scale factor (counts -> unit) before a unit.
_SCALED = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*\*?\s*(\S.*)?$")
#: Angles convert between deg and rad.
_ANGLE = {("deg", "rad"): math.pi / 180.0, ("rad", "deg"): 180.0 / math.pi}


def unit_factor(given: str, target: str, what: str) -> float:
    """Factor that turns values in unit ``given`` into unit ``target``.

    Raises :class:`InputError` naming ``what`` when the units do not convert.
    """
    given = given.strip()
    if given == target:
        return 1.0
    if given not in UNITS:
        raise InputError(
            f"{what}: unknown unit {given!r}; expected a unit convertible to {target!r} "
            f"(known: {', '.join(sorted(k for k, v in UNITS.items() if k and v[0] == UNITS.get(target, (target,))[0]))})"
        )
    canon, factor = UNITS[given]
    tcanon, tfactor = UNITS.get(target, (target, 1.0))
    if canon == tcanon:
        return factor / tfactor
    if (canon, tcanon) in _ANGLE:
        return factor * _ANGLE[(canon, tcanon)] / tfactor
    raise InputError(f"{what}: unit {given!r} does not convert to {target!r}")


def parse_unit(text: str) -> tuple[float, str]:
    """``"0.000244g"`` -> ``(0.000244, "g")``; ``"deg/s"`` -> ``(1.0, "deg/s")``.

    A leading number is a scale factor: one count of the raw value is that
    many of the unit (``acc_x=0.000244g`` for a +-8 g 16-bit accelerometer).
    A number alone (``0.01``) scales into the column's own unit.
    """
    m = _SCALED.match(text)
    if m and text.strip() not in UNITS:
        return float(m.group(1)), (m.group(2) or "").strip() or "="
    return 1.0, text.strip()


def scaled_factor(given: str, target: str, what: str) -> float:
    """Factor from raw values in ``given`` (``[scale][*]unit``, see :func:`parse_unit`) to ``target``."""
    scale, unit = parse_unit(given)
    if unit == "=":
        return scale
    return scale * unit_factor(unit, target, what)


def split_header(header: str) -> tuple[str, str]:
    """``"Acceleration x (m/s^2)"`` -> ``("acceleration x", "m/s^2")``: name normalised, unit as written."""
    m = _HEADER.match(header.strip().strip('"'))
    name, unit = (m.group(1), m.group(2) or "") if m else (header, "")
    name = re.sub(r"[\s_]+", " ", name.replace("\ufeff", "")).strip().lower()
    return name, unit.strip()


def decode(data: bytes) -> str:
    """Text of a file: UTF-8 (with or without BOM), else Latin-1."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def dialect(text: str) -> tuple[str, str]:
    """Separator and decimal mark of a delimited text table (header line first).

    The separator is the character after the first quoted header when headers
    are quoted (phyphox), else the most frequent of tab, semicolon and comma in
    the header line.  The decimal mark is a comma only when the separator is
    not a comma and a data cell looks like ``9,81`` (or ``9,810000000E0``).
    """
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines:
        raise InputError("the file has no header line")
    head = lines[0].lstrip("\ufeff")
    sep = None
    if head.startswith('"'):
        end = head.find('"', 1)
        if 0 < end < len(head) - 1 and head[end + 1] in ",;\t":
            sep = head[end + 1]
    if sep is None:
        counts = {c: head.count(c) for c in ("\t", ";", ",")}
        if any(counts.values()):
            sep = max(counts, key=lambda c: counts[c])
        else:  # space-separated (MT Manager's "space" delimiter) or a single column
            sep = " " if " " in head.strip() else ","
    dec = "."
    if sep != ",":
        for line in lines[1:50]:
            if any(_DECIMAL_COMMA.match(cell) for cell in line.split(sep)):
                dec = ","
                break
    return sep, dec


def read_delimited(
    text: str,
    what: str,
    numeric: bool = True,
    dropped: list[str] | None = None,
    header: bool = True,
) -> pa.Table:
    """Parse a delimited text table whose first line is the header (dialect detected).

    Cells ``NaN``/empty become null.  With ``numeric`` every column is float64,
    except integer columns too large for float64 (19-digit nanosecond times),
    which stay int64 so that :func:`exact_seconds` can split them exactly.
    A column holding text is an error, or, when ``dropped`` is a list, is left
    out and its name appended there (the caller warns once).  Column names are
    the headers as written (quotes removed); without ``header`` they are
    ``"1"``, ``"2"``, ... (1-based column numbers).
    """
    sep, dec = dialect(text)
    lines = [ln.rstrip("\r") for ln in text.splitlines() if ln.strip()]
    if sep == " ":  # columns aligned by runs of spaces: one separator each
        if any("  " in ln.strip() for ln in lines[:1]):
            lines = [re.sub(r" +", " ", ln.strip()) for ln in lines]
    if lines and lines[0].endswith(sep):  # every line ends with a separator (MT Manager): drop that empty column
        lines = [ln[:-1] if ln.endswith(sep) else ln for ln in lines]
    body = "\n".join(lines)
    data = body.lstrip("\ufeff").encode("utf-8")
    ncol = len(lines[0].split(sep)) if lines else 0
    try:
        table = pacsv.read_csv(
            io.BytesIO(data),
            parse_options=pacsv.ParseOptions(delimiter=sep, quote_char='"'),
            convert_options=pacsv.ConvertOptions(decimal_point=dec, strings_can_be_null=True),
            read_options=pacsv.ReadOptions(
                autogenerate_column_names=False,
                column_names=None if header else [str(i + 1) for i in range(ncol)],
            ),
        )
    except (pa.ArrowInvalid, pa.ArrowTypeError) as exc:
        msg = str(exc).splitlines()[0]
        raise InputError(f"{what}: not a readable table ({msg}); expected a header line and delimited rows") from exc
    if numeric:
        cols = {}
        for name in table.column_names:
            col = table.column(name)
            if pa.types.is_null(col.type):
                col = pa.nulls(len(col), pa.float64())
            if pa.types.is_integer(col.type) and not _fits_float(col):
                cols[name] = col.cast(pa.int64())
                continue
            try:
                cols[name] = col.cast(pa.float64())
            except (pa.ArrowInvalid, pa.ArrowNotImplementedError) as exc:
                if dropped is not None:
                    dropped.append(name)
                    continue
                raise InputError(
                    f"{what}: column {name!r} holds text that is not a number (decimal mark {dec!r}, separator "
                    f"{sep!r}); expected numbers or NaN"
                ) from exc
        table = pa.table(cols) if cols else table.select([])
    return table


def _fits_float(col: pa.ChunkedArray) -> bool:
    """True when every value of an integer column is exact in float64 (|v| <= 2**53)."""
    v = col.cast(pa.int64()).fill_null(0).to_numpy()
    return bool(v.size == 0 or np.abs(v).max() <= 2**53)


def exact_seconds(col: pa.ChunkedArray | pa.Array, unit_s: float, what: str) -> tuple[np.ndarray, float]:
    """Times of a column as seconds since its first value, and that first value [s].

    Integer columns (19-digit nanoseconds since the Unix epoch) are split in
    integer arithmetic before anything becomes float64, so that a relative
    time keeps its nanoseconds; decimal text is split exactly as well.
    ``unit_s`` is the seconds per unit of the column (1e-9 for ns).

    Returns
    -------
    t : numpy.ndarray
        Seconds since the first value (float64).
    origin : float
        The first value in seconds (float64; Unix time when the column is one).
    """
    if isinstance(col, pa.ChunkedArray):
        col = col.combine_chunks()
    if col.null_count:
        i = int(np.argmax(~np.asarray(col.is_valid().to_numpy(zero_copy_only=False))))
        raise InputError(f"{what}: row {i + 2} has no time; expected a time on every row")
    if pa.types.is_integer(col.type):
        v = col.cast(pa.int64()).to_numpy()
        base = int(v[0])
        rel = (v - base).astype(np.float64) * unit_s
        return rel, _int_seconds(base, unit_s)
    if pa.types.is_string(col.type) or pa.types.is_large_string(col.type):
        import decimal

        try:
            vals = [decimal.Decimal(str(x).strip()) for x in col.to_pylist()]
        except decimal.InvalidOperation as exc:
            raise InputError(f"{what}: a time is not a number; expected numbers") from exc
        base = vals[0]
        unit = decimal.Decimal(repr(unit_s))
        rel = np.array([float((x - base) * unit) for x in vals], dtype=np.float64)
        return rel, float(base * unit)
    v = np.asarray(col.cast(pa.float64()).to_numpy(zero_copy_only=False), dtype=np.float64)
    return (v - v[0]) * unit_s, float(v[0]) * unit_s


def _int_seconds(value: int, unit_s: float) -> float:
    """An integer count of ``unit_s`` as seconds, whole seconds split off first (exact for ns, us, ms)."""
    per = round(1.0 / unit_s) if unit_s < 1 else 0
    if per and abs(per * unit_s - 1.0) < 1e-12:
        whole, frac = divmod(value, per)
        return float(whole) + frac / per
    return value * unit_s


def floats(table: pa.Table, name: str) -> np.ndarray:
    """Column as a float64 numpy array, nulls as NaN."""
    col = table.column(name).cast(pa.float64(), safe=False)
    return np.asarray(col.fill_null(np.nan).to_numpy(), dtype=np.float64)


#: Decompression limits for ZIP exports (a "zip bomb" is refused before it is inflated):
#: the total uncompressed size of the members read [bytes] and each member's compression ratio.
#: Override with the environment variables SPORTFUSION_MAX_UNZIPPED (bytes) and SPORTFUSION_MAX_ZIP_RATIO.
MAX_UNZIPPED = 2 * 1024**3
MAX_ZIP_RATIO = 200.0


def _limit(env: str, default: float) -> float:
    import os

    try:
        value = float(os.environ.get(env, default))
    except ValueError:
        return default
    return value if math.isfinite(value) and value > 0 else default


def read_zip_members(zf: zipfile.ZipFile, names: list[str], where: str) -> dict[str, bytes]:
    """Bytes of the named members of an open ZIP, refusing decompression bombs.

    The declared sizes are checked first (total at most :data:`MAX_UNZIPPED` bytes, each member's
    ratio uncompressed/compressed at most :data:`MAX_ZIP_RATIO`); the members are then inflated
    in chunks with the running total capped, so a member that lies about its size is stopped too.
    Member names are only used as keys: nothing is ever written to disk.
    """
    cap = _limit("SPORTFUSION_MAX_UNZIPPED", MAX_UNZIPPED)
    ratio = _limit("SPORTFUSION_MAX_ZIP_RATIO", MAX_ZIP_RATIO)
    infos = [zf.getinfo(n) for n in names]
    total = sum(i.file_size for i in infos)
    if total > cap:
        raise InputError(
            f"{where}: the ZIP declares {total / 1024**2:.0f} MiB uncompressed, over the limit of "
            f"{cap / 1024**2:.0f} MiB (SPORTFUSION_MAX_UNZIPPED); refused as a possible decompression bomb"
        )
    for i in infos:
        if i.file_size > 1024**2 and i.file_size > ratio * max(i.compress_size, 1):
            raise InputError(
                f"{where}: ZIP member {i.filename!r} inflates {i.file_size / max(i.compress_size, 1):.0f}-fold, over "
                f"the limit of {ratio:g} (SPORTFUSION_MAX_ZIP_RATIO); refused as a possible decompression bomb"
            )
    out: dict[str, bytes] = {}
    used = 0
    for i in infos:
        chunks, got = [], 0
        with zf.open(i) as fh:
            while chunk := fh.read(1 << 20):
                used, got = used + len(chunk), got + len(chunk)
                if used > cap or got > i.file_size:
                    raise InputError(
                        f"{where}: ZIP member {i.filename!r} inflates beyond its declared size or the limit of "
                        f"{cap / 1024**2:.0f} MiB; refused as a possible decompression bomb"
                    )
                chunks.append(chunk)
        out[i.filename] = b"".join(chunks)
    return out
