"""Gate crossings from the magnetometer (gates paper, "Relative anchor point estimation"; Fasel et al. 2016c).

* The field intensity ``|B|`` is normalised by its background (a moving median
  over ``background`` seconds), so ``b = 1`` far from any magnet (the paper
  calibrates the magnetometer to ``||B|| = 1`` away from the magnets).
* A crossing is a peak of ``b - 1`` above ``threshold``, at least
  ``min_separation`` seconds from a higher one; its height is refined with a
  parabola through the logarithm of the excess (:func:`refine_peak`), which
  recovers most of what the 125 Hz sampling misses.
* The distance to the magnet comes from the cube law calibrated for the magnet
  (:class:`MagnetCalibration`; eq 1 of the paper is garbled and replaced by the
  physical model, see ``ref/papers-errata.md``).
* Turn side: "a turn was labelled as right turn if the sacrum's angular
  velocity along the trunk's longitudinal axis was negative at gate crossing".
  The sensor axes are x forward, y right, z down when standing, so the trunk's
  longitudinal (cranial) axis is ``-z``: right turn <=> mean ``gyr_z`` over
  ``turn_window`` around the crossing is positive.

Missed gates (a pass too far from the magnet) and noise peaks are expected;
the anchor matching (:mod:`sportfusion.gates.anchors`) handles them.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.gates.magnet import MagnetCalibration, default_calibration, fit_calibration, refine_peak

GATE_EVENTS = ("gate",)


@dataclass(frozen=True)
class GateParams:
    """Parameters of the gate-crossing detector.

    Attributes
    ----------
    threshold : float
        Smallest normalised excess intensity ``b - 1`` of a crossing [1].
    min_separation : float
        Two crossings are at least this far apart in time [s].
    background : float
        Window of the moving median giving the background intensity [s].
    turn_window : float
        Half-width of the window averaging ``gyr_z`` for the turn side [s].
    """

    threshold: float = 0.06
    min_separation: float = 0.5
    background: float = 2.0
    turn_window: float = 0.1


@dataclass
class Crossing:
    """One detected gate crossing."""

    t: float
    b_peak: float
    distance: float
    turn: str
    gyr_z: float


@dataclass
class GateDetection:
    """Result of :func:`detect_gates`."""

    crossings: list[Crossing] = field(default_factory=list)
    calibration: MagnetCalibration | None = None

    def summary(self, params: GateParams) -> dict[str, Any]:
        """JSON-ready summary for the metadata's ``events`` list."""
        cal = self.calibration
        return {
            "kind": "gates",
            "method": "peaks of the normalised |B| (gates paper; eq 1 replaced by the cube law r = (c/(b-1))^(1/3))",
            "params": asdict(params),
            "calibration": None if cal is None else {"c_m3": cal.c, "source": cal.source},
            "crossings": len(self.crossings),
        }

    def message(self) -> str:
        """One line saying what was found."""
        n = len(self.crossings)
        if not n:
            return "no gate crossing found (no |B| peak above the threshold)"
        nr = sum(c.turn == "R" for c in self.crossings)
        d = np.array([c.distance for c in self.crossings])
        return f"{n} gate crossings ({nr} R, {n - nr} L), distances {np.nanmin(d):.2f}-{np.nanmax(d):.2f} m"


def normalised_intensity(mag: np.ndarray, rate: float, background: float) -> np.ndarray:
    """``|B|`` divided by its moving median over ``background`` seconds (``rate`` [Hz])."""
    b = np.linalg.norm(mag, axis=1)
    size = max(3, int(round(background * rate)) | 1)
    from scipy.ndimage import median_filter  # here: scipy.signal/ndimage cost detect-events 0.3 s at start-up

    bg = median_filter(b, size=size, mode="nearest")
    return b / bg


def detect_gates(
    t_mag: np.ndarray,
    mag: np.ndarray,
    t_gyr: np.ndarray,
    gyr_z: np.ndarray,
    params: GateParams | None = None,
    calibration: MagnetCalibration | None = None,
) -> GateDetection:
    """Gate crossings from magnetometer peaks (see the module text).

    Parameters
    ----------
    t_mag : ndarray, shape (n,)
        Magnetometer sample times [s].
    mag : ndarray, shape (n, 3)
        Magnetic field, body frame [uT or normalised].
    t_gyr, gyr_z : ndarray, shape (k,)
        Angular-rate sample times [s] and the rate about the body z axis [rad/s].
    params : GateParams, optional
    calibration : MagnetCalibration, optional
        Distance model; default :func:`default_calibration` (the simulator's magnet).

    Returns
    -------
    GateDetection
    """
    p = params or GateParams()
    cal = calibration or default_calibration()
    det = GateDetection(calibration=cal)
    if t_mag.size < 5:
        return det
    rate = 1.0 / float(np.median(np.diff(t_mag)))
    b = normalised_intensity(mag, rate, p.background)
    from scipy.signal import find_peaks

    peaks, _ = find_peaks(b - 1.0, height=p.threshold, distance=max(1, int(p.min_separation * rate)))
    for k in peaks:
        bp = refine_peak(b, int(k))
        w = np.abs(t_gyr - t_mag[k]) <= p.turn_window
        wz = float(np.mean(gyr_z[w])) if w.any() else float(np.interp(t_mag[k], t_gyr, gyr_z))
        det.crossings.append(
            Crossing(
                t=float(t_mag[k]),
                b_peak=bp,
                distance=float(cal.distance(bp)),
                turn="R" if wz > 0 else "L",
                gyr_z=wz,
            )
        )
    return det


def read_calibration(path: str) -> MagnetCalibration:
    """A user's magnet calibration table: CSV (distance [m], peak intensity [1], optional header) or
    Parquet with columns ``distance`` and ``gate_b_peak``; fitted with :func:`fit_calibration`."""
    try:
        if path.endswith(".parquet"):
            from sportfusion.core import io as sfio

            table, _ = sfio.read_table(path, what=f"calibration table {path}")
            schema.require_columns(table, ("distance", "gate_b_peak"), "a magnet calibration table")
            d, b = schema.floats(table, "distance"), schema.floats(table, "gate_b_peak")
        else:
            data = np.genfromtxt(path, delimiter=",", comments="#")
            data = np.atleast_2d(data)
            data = data[np.isfinite(data).all(axis=1)] if data.shape[-1] >= 2 else data
            if data.ndim != 2 or data.shape[1] < 2:
                raise InputError(f"calibration table {path}: expected two columns, distance [m] and peak intensity [1]")
            d, b = data[:, 0], data[:, 1]
    except OSError as exc:
        raise InputError(f"calibration table {path}: {exc.strerror or exc}") from exc
    except (UnicodeDecodeError, ValueError) as exc:
        raise InputError(
            f"calibration table {path} is not readable text CSV ({type(exc).__name__}); "
            "expected two columns, distance [m] and peak intensity [1]"
        ) from exc
    return fit_calibration(d, b, source=f"user table {path}")


def detect_gate_table(
    table: pa.Table, params: GateParams | None = None, calibration: MagnetCalibration | None = None
) -> GateDetection:
    """:func:`detect_gates` on a session table (``mag_x mag_y mag_z`` and ``gyr_z`` needed)."""
    names = table.column_names
    if not all(c in names for c in ("mag_x", "mag_y", "mag_z")):
        raise InputError(
            "no magnetometer: gate crossings need columns mag_x, mag_y, mag_z; the table has " + ", ".join(names)
        )
    schema.require_columns(table, ("gyr_z",), "the turn side of gate crossings")
    t = schema.floats(table, "t")
    mag = np.stack([schema.floats(table, c) for c in ("mag_x", "mag_y", "mag_z")], axis=-1)
    ok = np.isfinite(mag).all(axis=1)
    if ok.sum() < 5:
        raise InputError("no magnetometer: columns mag_x, mag_y, mag_z hold fewer than 5 samples")
    gz = schema.floats(table, "gyr_z")
    okg = np.isfinite(gz)
    if not okg.any():
        raise InputError("column gyr_z holds no samples; expected the angular rate for the turn side")
    return detect_gates(t[ok], mag[ok], t[okg], gz[okg], params, calibration)


def gate_columns(table: pa.Table, det: GateDetection) -> dict[str, pa.Array]:
    """Columns ``event`` (``gate`` at each crossing's row, other events kept), ``gate_b_peak``,
    ``gate_distance``, ``turn`` (null except at crossing rows)."""
    from sportfusion.core.events import set_events

    out = set_events(table, [("gate", c.t) for c in det.crossings], replace=GATE_EVENTS)
    t = schema.floats(table, "t")
    n = t.size
    bp: list[float | None] = [None] * n
    dist: list[float | None] = [None] * n
    turn: list[str | None] = [None] * n
    for c in det.crossings:
        i = int(np.argmin(np.abs(t - c.t)))
        bp[i], turn[i] = c.b_peak, c.turn
        dist[i] = None if not np.isfinite(c.distance) else c.distance
    return {
        "event": out.column("event").combine_chunks(),
        "gate_b_peak": pa.array(bp, pa.float64()),
        "gate_distance": pa.array(dist, pa.float64()),
        "turn": pa.array(turn, pa.string()),
    }


def read_crossings(table: pa.Table) -> dict[str, np.ndarray]:
    """The crossings written by :func:`gate_columns`: ``t`` [s], ``distance`` [m], ``turn`` (+1 R, -1 L),
    ``row`` (row index)."""
    if "event" not in table.column_names:
        return {"t": np.zeros(0), "distance": np.zeros(0), "turn": np.zeros(0), "row": np.zeros(0, int)}
    ev = np.array(table.column("event").to_pylist(), dtype=object)
    rows = np.flatnonzero(ev == "gate")
    t = schema.floats(table, "t")[rows]
    dist = (
        schema.floats(table, "gate_distance")[rows]
        if "gate_distance" in table.column_names
        else np.full(rows.size, np.nan)
    )
    tv = table.column("turn").to_pylist() if "turn" in table.column_names else [None] * table.num_rows
    turn = np.array([1.0 if tv[i] == "R" else (-1.0 if tv[i] == "L" else 0.0) for i in rows])
    return {"t": t, "distance": dist, "turn": turn, "row": rows}
