"""The marker calibration table: distance markers on the landing slope and their pixels.

A user measures it once per camera placement, from any frame without the
jumper (``video-jumplength calibrate`` writes one with a pixel grid): for each
distance marker visible along the two sides of the landing slope, the point
where the marker meets the snow.

CSV layout (``landing.mp4`` -> ``landing.markers.csv``), ``#`` lines are comments::

    distance,y,col,row
    85,-12.5,312.4,201.7
    85,12.5,347.0,96.2

* ``distance`` [m]: distance of the marker along the landing profile from the
  knoll base F (the jump length it marks);
* ``y`` [m]: lateral position of the marker line across the slope (hill frame,
  positive to the right looking downhill); only its distinctness matters for
  the distance reading, metric values make the reported lateral position metric;
* ``col``, ``row`` [px]: pixel of the marker's foot, centre of the top-left
  pixel at (0, 0), columns to the right, rows down.

Markers on at least two lines across the slope are needed (e.g. both sides of
the hill): one line alone does not fix a homography of the slope plane.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sportfusion.core.errors import InputError
from sportfusion.core.stats import unique

COLUMNS = ("distance", "y", "col", "row")
HEADER = (
    "# sportfusion landing markers: distance along the landing profile from F [m], lateral position y [m],\n"
    "# pixel column and row of the marker's foot on the snow [px] (top-left pixel centre = 0,0)\n"
)


@dataclass(frozen=True)
class Markers:
    """Marker calibration points (arrays of equal length).

    Attributes
    ----------
    distance : ndarray
        Distance along the landing profile from F [m].
    y : ndarray
        Lateral position of the marker [m].
    col, row : ndarray
        Pixel coordinates of the marker's foot [px].
    """

    distance: np.ndarray
    y: np.ndarray
    col: np.ndarray
    row: np.ndarray

    def __len__(self) -> int:
        return int(self.distance.size)

    @property
    def pixels(self) -> np.ndarray:
        """``(n, 2)`` array of ``(col, row)`` [px]."""
        return np.stack((self.col, self.row), -1)

    @property
    def slope(self) -> np.ndarray:
        """``(n, 2)`` array of ``(distance, y)`` [m]."""
        return np.stack((self.distance, self.y), -1)

    def lines(self) -> np.ndarray:
        """The distinct lateral positions ``y`` [m] of the marker lines, sorted."""
        return unique(self.y)

    def subset(self, mask: np.ndarray) -> Markers:
        """The markers where ``mask`` is true."""
        return Markers(self.distance[mask], self.y[mask], self.col[mask], self.row[mask])


def make_markers(distance: object, y: object, col: object, row: object, where: str = "markers") -> Markers:
    """Build and validate a :class:`Markers` from four sequences.

    Raises
    ------
    InputError
        Non-finite values, fewer than 4 markers, fewer than two marker lines
        (distinct ``y``) with at least 2 markers each, or a repeated marker.
    """
    arrs = [np.asarray(v, dtype=float).ravel() for v in (distance, y, col, row)]
    n = arrs[0].size
    if any(a.size != n for a in arrs):
        raise InputError(f"{where}: columns of different lengths; expected one value per marker in each column")
    for name, a in zip(COLUMNS, arrs, strict=True):
        if not np.all(np.isfinite(a)):
            raise InputError(f"{where}: column '{name}' has a missing or non-finite value; expected numbers")
    m = Markers(*arrs)
    if n < 4:
        raise InputError(f"{where}: {n} marker(s); expected at least 4, on both sides of the landing slope")
    counts = [int(np.sum(m.y == v)) for v in m.lines()]
    if sum(c >= 2 for c in counts) < 2:
        raise InputError(
            f"{where}: markers on {len(counts)} line(s) across the slope (distinct y); expected at least two "
            "lines (e.g. both sides of the hill) with 2 or more markers each"
        )
    keys = np.stack((m.distance, m.y), -1)
    if np.unique(keys, axis=0).shape[0] != n:
        raise InputError(f"{where}: a marker (distance, y) appears twice; expected each marker once")
    return m


def check_order(m: Markers, where: str = "markers") -> None:
    """Refuse distances that run backwards along a marker line in the image.

    A homography keeps the order of points along a line, so a line's markers sorted by distance must
    advance one way in the image (projected on the chord from its first to its last marker), and every
    line the same way down the slope.  A swapped or reversed distance would otherwise be fitted.
    """
    chords = []
    for v in m.lines():
        on = np.flatnonzero(m.y == v)
        if on.size < 2:
            continue
        k = on[np.argsort(m.distance[on], kind="stable")]
        px = np.stack((m.col[k], m.row[k]), -1)
        chord = px[-1] - px[0]
        along = (px - px[0]) @ chord
        bad = np.flatnonzero(np.diff(along) <= 0)
        if bad.size:
            a, b = m.distance[k[bad[0]]], m.distance[k[bad[0] + 1]]
            raise InputError(
                f"{where}: on the marker line y = {v:g} m the distances run backwards in the image ({a:g} m and "
                f"{b:g} m are out of order); expected each line's distances to increase one way along it"
            )
        chords.append((v, chord))
    for (v0, c0), (v1, c1) in zip(chords, chords[1:], strict=False):
        if float(c0 @ c1) <= 0:
            raise InputError(
                f"{where}: the distances on the marker lines y = {v0:g} m and y = {v1:g} m run in opposite "
                "directions in the image; expected both to increase down the slope"
            )


def read_markers(path: str | Path) -> Markers:
    """Read a marker CSV (see the module text).

    Raises
    ------
    InputError
        Unreadable file, missing columns, non-numeric values, too few markers, or distances that run
        backwards along a marker line (:func:`check_order`).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the marker file {p}: {exc.__class__.__name__}; expected a CSV file") from exc
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputError(f"marker file {p} is empty; expected a CSV with columns {','.join(COLUMNS)}")
    reader = csv.DictReader(io.StringIO("\n".join(lines)))
    fields = [f.strip() for f in (reader.fieldnames or [])]
    missing = [c for c in COLUMNS if c not in fields]
    if missing:
        raise InputError(f"marker file {p} lacks column(s) {', '.join(missing)}; expected a header {','.join(COLUMNS)}")
    vals: dict[str, list[float]] = {c: [] for c in COLUMNS}
    for k, rec in enumerate(reader, start=2):
        rec = {(key or "").strip(): v for key, v in rec.items()}
        for c in COLUMNS:
            try:
                vals[c].append(float((rec.get(c) or "").strip()))
            except ValueError as exc:
                raise InputError(f"marker file {p}, data line {k}: '{c}' is {rec.get(c)!r}; expected a number") from exc
    markers = make_markers(*(vals[c] for c in COLUMNS), where=f"marker file {p}")
    check_order(markers, f"marker file {p}")
    return markers


def write_markers(path: str | Path, markers: Markers, decimals: int = 2) -> None:
    """Write a marker CSV (see the module text), values rounded to ``decimals``."""
    out = [HEADER, ",".join(COLUMNS) + "\n"]
    for d, y, c, r in zip(markers.distance, markers.y, markers.col, markers.row, strict=True):
        out.append(f"{_num(d, 3)},{_num(y, 3)},{_num(c, decimals)},{_num(r, decimals)}\n")
    Path(path).write_text("".join(out), encoding="utf-8")


def _num(v: float, decimals: int) -> str:
    text = f"{float(v):.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def check_in_frame(markers: Markers, width: int, height: int, where: str = "markers") -> None:
    """Raise :class:`InputError` for the first marker whose pixel lies outside a ``width`` x ``height`` frame."""
    c, r = markers.col, markers.row
    bad = (c < -0.5) | (c > width - 0.5) | (r < -0.5) | (r > height - 0.5)
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{where}: the marker at {_num(markers.distance[i], 2)} m (y = {_num(markers.y[i], 2)} m) is at pixel "
            f"({_num(c[i], 1)}, {_num(r[i], 1)}), outside the {width}x{height} video frame; expected pixels inside it"
        )


def markers_path_for(video: str | Path) -> Path:
    """The default marker file beside a video: ``landing.mp4`` -> ``landing.markers.csv``."""
    p = Path(video)
    return p.with_name(p.stem + ".markers.csv")
