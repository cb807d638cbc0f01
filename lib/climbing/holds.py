"""Hold maps: the ``holds`` table kind (route, hold, x, y, z) and its metadata.

A row is one hold of one route.  ``hold`` numbers a *physical* hold on the wall:
a hold shared by two routes appears once per route with the same number and the
same position.  Positions are hold centres [m] in the map frame.

The metadata key ``climbing`` declares what the rows cannot::

    {"up": "z",                                   # which map axis points up (x, y, z, -x, -y, -z)
     "start_holds": {"yellow": [3, 4]},           # the two start holds of each route
     "top_holds": {"yellow": 15},                 # optional: the top hold of each route
     "magnetic_field": [mx, my, mz],              # reference field in the map frame (normalised, |m| = 1)
     "gravity": 9.81}                             # optional, m/s^2

and ``frame.axes`` says the same in words (e.g. "x right along the wall, y into
the wall, z up").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import meta as sfmeta
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.stats import unique

AXES = {"x": 0, "y": 1, "z": 2}
DEFAULT_GRAVITY = 9.81  # m/s^2


@dataclass
class HoldMap:
    """A validated hold map.

    Attributes
    ----------
    route : numpy.ndarray of str
        Route of each row.
    hold : numpy.ndarray of int
        Physical hold number of each row.
    pos : numpy.ndarray, shape (n, 3)
        Hold centre of each row [m], map frame.
    start_holds : dict
        Route -> the two start hold numbers.
    top_holds : dict
        Route -> top hold number (may be empty).
    up : numpy.ndarray, shape (3,)
        Unit vector of the map's up axis.
    magnetic_field : numpy.ndarray or None
        Reference magnetic field in the map frame (normalised), if declared.
    gravity : float
        Gravity magnitude [m/s^2].
    meta : dict
        The table's metadata.
    """

    route: np.ndarray
    hold: np.ndarray
    pos: np.ndarray
    start_holds: dict[str, list[int]]
    top_holds: dict[str, int] = field(default_factory=dict)
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    magnetic_field: np.ndarray | None = None
    gravity: float = DEFAULT_GRAVITY
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def routes(self) -> list[str]:
        """Route names in first-seen order."""
        return list(dict.fromkeys(self.route.tolist()))

    def route_holds(self, route: str) -> tuple[np.ndarray, np.ndarray]:
        """Hold numbers (n,) and centres (n, 3) [m] of one route."""
        sel = self.route == route
        if not sel.any():
            raise InputError(f"route {route!r} is not in the hold map; expected one of {', '.join(self.routes)}")
        return self.hold[sel], self.pos[sel]

    def wall_holds(self) -> tuple[np.ndarray, np.ndarray]:
        """Every physical hold of the wall once: numbers (n,) and centres (n, 3) [m]."""
        ids, first = np.unique(self.hold, return_index=True)
        return ids, self.pos[first]

    def position(self, hold: int) -> np.ndarray:
        """Centre [m] of a hold number."""
        return self.pos[int(np.flatnonzero(self.hold == hold)[0])]

    def start_positions(self, route: str) -> tuple[np.ndarray, np.ndarray]:
        """The route's two start hold numbers (2,) and centres (2, 3) [m]."""
        if route not in self.start_holds:
            raise InputError(
                f"the hold map declares no start holds for route {route!r} (metadata climbing.start_holds); "
                "expected two hold numbers"
            )
        ids = np.asarray(self.start_holds[route], dtype=np.int64)
        return ids, np.array([self.position(int(h)) for h in ids])


def up_vector(axis: str) -> np.ndarray:
    """Unit vector of an axis name ``x y z -x -y -z``."""
    text = str(axis).strip().lower()
    sign = -1.0 if text.startswith("-") else 1.0
    name = text.lstrip("+-")
    if name not in AXES:
        raise InputError(f"hold map metadata climbing.up is {axis!r}; expected one of x, y, z, -x, -y, -z")
    v = np.zeros(3)
    v[AXES[name]] = sign
    return v


def validate(table: pa.Table, meta: dict[str, Any]) -> HoldMap:
    """Check a holds table and its metadata; raise :class:`InputError` naming the first problem.

    Checks: at least one row; finite x, y, z; each hold number has one position
    (within 1 mm) across routes; an up axis; for every route two start holds that
    belong to the route; a finite reference field when one is declared.
    """
    schema.require_columns(table, schema.REQUIRED["holds"], "a hold map")
    if table.num_rows == 0:
        raise InputError("the hold map has no rows; expected one row per hold (route, hold, x, y, z)")
    route = np.array([str(r) for r in table.column("route").to_pylist()], dtype=object)
    holds = table.column("hold")
    if holds.null_count:
        raise InputError("the hold map has a hold without a number; expected an integer in column 'hold'")
    hold = np.asarray(holds.to_numpy(), dtype=np.int64)
    if (hold < 0).any():
        raise InputError(f"hold number {int(hold.min())} is negative; expected hold numbers >= 0")
    pos = schema.float_columns(table, ("x", "y", "z"))
    bad = ~np.isfinite(pos).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(
            f"hold map row {i} (route {route[i]!r}, hold {hold[i]}) has a missing or NaN position; "
            "expected finite x, y, z [m]"
        )
    for h in unique(hold):
        p = pos[hold == h]
        if np.abs(p - p[0]).max() > 1e-3:
            raise InputError(f"hold {h} has two different positions in the hold map; expected one position per hold")
    cl = meta.get("climbing") or {}
    if "up" not in cl:
        raise InputError("the hold map does not declare its up axis (metadata climbing.up); expected e.g. 'z'")
    up = up_vector(cl["up"])
    starts_raw = cl.get("start_holds") or {}
    if not isinstance(starts_raw, dict):
        raise InputError("hold map metadata climbing.start_holds must map route names to two hold numbers")
    starts: dict[str, list[int]] = {}
    for r in dict.fromkeys(route.tolist()):
        val = starts_raw.get(r)
        if not isinstance(val, list) or len(val) != 2:
            raise InputError(
                f"the hold map declares no start holds for route {r!r} (metadata climbing.start_holds); "
                "expected two hold numbers"
            )
        mine = set(hold[route == r].tolist())
        for h in val:
            if not isinstance(h, int) or h not in mine:
                raise InputError(f"start hold {h!r} of route {r!r} is not a hold of that route in the hold map")
        starts[r] = [int(v) for v in val]
    tops = {str(k): int(v) for k, v in (cl.get("top_holds") or {}).items()}
    mag = cl.get("magnetic_field")
    field_w = None
    if mag is not None:
        field_w = np.asarray(mag, dtype=np.float64)
        if field_w.shape != (3,) or not np.isfinite(field_w).all() or np.linalg.norm(field_w) == 0:
            raise InputError("hold map metadata climbing.magnetic_field must be three finite numbers, not all zero")
    g = float(cl.get("gravity", DEFAULT_GRAVITY))
    if not np.isfinite(g) or g <= 0:
        raise InputError("hold map metadata climbing.gravity must be a positive number [m/s^2]")
    return HoldMap(route, hold, pos, starts, tops, up, field_w, g, meta)


def read_holds(path: str) -> HoldMap:
    """Read and validate a hold map file: a ``holds`` table, a plain Parquet file or a CSV with the columns
    route, hold, x, y, z [m] and start (:func:`sportfusion.core.venue.read_venue`)."""
    from sportfusion.core.venue import read_venue

    table, meta = read_venue(path, "holds", what=f"hold map {path}")
    return validate(table, meta)


def holds_table(
    route: list[str],
    hold: np.ndarray,
    pos: np.ndarray,
    start_holds: dict[str, list[int]],
    *,
    up: str = "z",
    axes: str = "x right along the wall, y into the wall, z up",
    top_holds: dict[str, int] | None = None,
    magnetic_field: np.ndarray | None = None,
    gravity: float = DEFAULT_GRAVITY,
    origin: tuple[float, float, float] = (53.1065, 8.8520, 10.0),
    azimuth_deg: float = 0.0,
) -> tuple[pa.Table, dict[str, Any]]:
    """Build a holds table and its metadata (validated).

    Parameters
    ----------
    route, hold, pos
        Route name, physical hold number and centre [m] of each row.
    start_holds, top_holds
        Route -> two start hold numbers / the top hold number.
    up, axes
        The up axis (``"z"``) and the axes in words.
    magnetic_field
        Reference field in the map frame (normalised).
    gravity
        [m/s^2].
    origin, azimuth_deg
        Where the map frame sits: lat [deg], lon [deg], ellipsoidal h [m], and
        the azimuth of its x axis clockwise from north [deg].
    """
    pos = np.asarray(pos, dtype=np.float64)
    table = pa.table(
        {
            "route": schema.to_arrow("route", np.asarray(route, dtype=object)),
            "hold": schema.to_arrow("hold", np.asarray(hold, dtype=np.int32)),
            "x": schema.to_arrow("x", pos[:, 0]),
            "y": schema.to_arrow("y", pos[:, 1]),
            "z": schema.to_arrow("z", pos[:, 2]),
        }
    )
    meta = sfmeta.new_meta("holds")
    meta["frame"] = {
        "name": "wall",
        "origin": [float(v) for v in origin],
        "azimuth_deg": float(azimuth_deg),
        "axes": axes,
    }
    cl: dict[str, Any] = {"up": up, "start_holds": {k: [int(v) for v in vs] for k, vs in start_holds.items()}}
    if top_holds:
        cl["top_holds"] = {k: int(v) for k, v in top_holds.items()}
    if magnetic_field is not None:
        cl["magnetic_field"] = [float(v) for v in magnetic_field]
    cl["gravity"] = float(gravity)
    meta["climbing"] = cl
    validate(table, meta)
    return table, meta
