"""Gate crossings from the magnetometer (gates paper, "Relative anchor point estimation"; Fasel et al. 2016c).

* The recording calibrates itself first: a magnetometer a few per cent off
  (scale, offset) shows a field norm that follows the sensor's orientation,
  and on a real trial without any magnet that alone passed the fixed
  threshold.  ``|B|`` is divided by the norm the sensor shows in the same
  direction, fitted robustly to the whole recording
  (:func:`~sportfusion.gates.magnet.self_calibrated_norm`), when that norm
  spreads by ``calibrate_spread`` (1 %) or more.
* The field intensity is then normalised by its background (a moving median
  over ``background`` seconds), so ``b = 1`` far from any magnet (the paper
  calibrates the magnetometer to ``||B|| = 1`` away from the magnets).
* A crossing is a peak of ``b - 1`` above the larger of ``threshold`` and
  ``noise_k`` times the recording's own noise (1.4826 MAD of ``b - 1``), no
  wider than ``max_width`` seconds at half its prominence (a buried magnet
  passed at 0.2-1.2 m and 5-30 m/s gives a bump of 0.01-0.4 s; slow swings of
  a disturbed field are wider), at least ``min_separation`` seconds from a
  higher one; its height is refined with a
  parabola through the logarithm of the excess (:func:`peak_vertex`), which
  recovers most of what the 125 Hz sampling misses.
* With the three gyro axes the field is also carried into a frame fixed to the ground (the gyro
  integrated; over the few seconds of the background window its drift is a fraction of a degree) and
  its anomaly ``|B - B_background| / |B_background|`` (the background a moving median per component) is
  searched the same way.  A magnet buried north pole up -- or tilted, or passed beside at a low
  elevation -- lowers ``|B|`` where it is strongest, a dip the intensity peaks miss; its anomaly is a
  peak whatever the polarity.  Crossings are the union of both searches (one per ``min_separation``).
* The distance to the magnet comes from the cube law calibrated for the magnet
  (:class:`MagnetCalibration`; eq 1 of the paper is garbled and replaced by the
  physical model).
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
from sportfusion.core.stats import median
from sportfusion.gates.magnet import (
    MagnetCalibration,
    default_calibration,
    fit_calibration,
    peak_vertex,
    self_calibrated_norm,
)

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
    noise_k : float
        A crossing's excess is at least this many robust noise sigmas [1].
    max_width : float
        Largest width of a crossing's bump at half its prominence [s].
    self_calibrate : bool
        Divide ``|B|`` by its orientation-dependent norm fitted to the recording first, when that norm
        spreads by at least ``calibrate_spread``.
    calibrate_spread : float
        Relative 1-sigma of the orientation-dependent norm from which the self-calibration is applied [1]
        (a calibrated sensor shows ~0.003; the correction is skipped there, where it would only add its
        own small errors to the peak heights).
    anomaly : bool
        Also search the field's vector anomaly in a ground-fixed frame (needs the three gyro axes).
    """

    threshold: float = 0.06
    min_separation: float = 0.5
    background: float = 2.0
    turn_window: float = 0.1
    noise_k: float = 6.0
    max_width: float = 0.5
    self_calibrate: bool = True
    calibrate_spread: float = 0.01
    anomaly: bool = True


@dataclass
class Crossing:
    """One detected gate crossing."""

    t: float
    b_peak: float
    distance: float
    turn: str
    gyr_z: float
    t_peak: float = float("nan")  # the |B| peak between samples [s] (:func:`sportfusion.gates.magnet.peak_vertex`)


@dataclass
class GateDetection:
    """Result of :func:`detect_gates`."""

    crossings: list[Crossing] = field(default_factory=list)
    calibration: MagnetCalibration | None = None
    noise: float = float("nan")
    threshold: float = float("nan")
    spread: float = float("nan")

    def summary(self, params: GateParams) -> dict[str, Any]:
        """JSON-ready summary for the metadata's ``events`` list."""
        cal = self.calibration
        return {
            "kind": "gates",
            "method": "peaks of the normalised |B| (gates paper; eq 1 replaced by the cube law r = (c/(b-1))^(1/3))",
            "params": asdict(params),
            "calibration": None if cal is None else {"c_m3": cal.c, "source": cal.source},
            "crossings": len(self.crossings),
            "noise": _finite(self.noise),
            "threshold_used": _finite(self.threshold),
            "orientation_spread": _finite(self.spread),
        }

    def message(self) -> str:
        """One line saying what was found."""
        n = len(self.crossings)
        if not n:
            return (
                f"no gate crossing found (no narrow |B| peak above {self.threshold:.3f}; "
                f"noise {self.noise:.4f}, orientation-dependent norm spread {self.spread:.3f})"
            )
        nr = sum(c.turn == "R" for c in self.crossings)
        d = np.array([c.distance for c in self.crossings])
        return f"{n} gate crossings ({nr} R, {n - nr} L), distances {np.nanmin(d):.2f}-{np.nanmax(d):.2f} m"


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def normalised_intensity(mag: np.ndarray, rate: float, background: float, self_calibrate: bool = False) -> np.ndarray:
    """``|B|`` divided by its moving median over ``background`` seconds (``rate`` [Hz]).

    With ``self_calibrate`` ``|B|`` is first divided by its orientation-dependent
    norm (:func:`~sportfusion.gates.magnet.self_calibrated_norm`).
    """
    b = self_calibrated_norm(mag)[0] if self_calibrate else np.linalg.norm(mag, axis=1)
    return _over_background(b, rate, background)


def _over_background(b: np.ndarray, rate: float, background: float) -> np.ndarray:
    size = max(3, int(round(background * rate)) | 1)
    from scipy.ndimage import median_filter  # here: scipy.signal/ndimage cost detect-events 0.3 s at start-up

    bg = median_filter(b, size=size, mode="nearest")
    return b / bg


def _half_height_width(e: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """Samples around each peak where the excess stays above half the peak's excess (over the baseline 0).

    Measured against the baseline, not scipy's prominence: a pass beside the
    magnet puts a negative lobe next to the peak, which would inflate the
    prominence and the width at half of it.
    """
    width = np.zeros(peaks.size)
    for i, k in enumerate(peaks):
        half = 0.5 * e[k]
        lo = k
        while lo > 0 and e[lo - 1] > half:
            lo -= 1
        hi = k
        while hi < e.size - 1 and e[hi + 1] > half:
            hi += 1
        width[i] = hi - lo + 1
    return width


def gyro_bias_guess(t: np.ndarray, gyr: np.ndarray, window: float = 1.0) -> np.ndarray:
    """Gyro bias [rad/s]: the mean rate over the quietest ``window`` seconds (lowest spread of ``|gyr|``),
    zero when nothing is quiet (spread above 0.2 rad/s)."""
    fs = 1.0 / float(median(np.diff(t)))
    w = max(3, int(window * fs))
    if gyr.shape[0] <= w:
        return np.zeros(3)
    n = np.linalg.norm(gyr, axis=1)
    c1 = np.convolve(n, np.ones(w) / w, mode="valid")
    c2 = np.convolve(n * n, np.ones(w) / w, mode="valid")
    sd = np.sqrt(np.maximum(c2 - c1 * c1, 0.0))
    k = int(np.argmin(sd))
    return gyr[k : k + w].mean(axis=0) if sd[k] < 0.2 else np.zeros(3)


def field_anomaly(
    t_mag: np.ndarray, mag: np.ndarray, t_gyr: np.ndarray, gyr: np.ndarray, rate: float, background: float
) -> np.ndarray:
    """``|B - B_bg| / |B_bg|`` [1]: the field carried into a ground-fixed frame by the integrated gyro, its
    background a moving median per component over ``background`` seconds (``rate`` [Hz] the magnetometer's)."""
    from scipy.ndimage import median_filter

    from sportfusion.core.rotations import dcm_from_quat, integrate_body_rates, interval_mean_rates

    w = interval_mean_rates(gyr - gyro_bias_guess(t_gyr, gyr))
    q = integrate_body_rates(np.array([1.0, 0.0, 0.0, 0.0]), t_gyr, w)
    k = np.clip(np.searchsorted(t_gyr, t_mag), 0, t_gyr.size - 1)
    b = np.einsum("kji,kj->ki", dcm_from_quat(q[k]), mag)
    size = max(3, int(round(background * rate)) | 1)
    bg = np.stack([median_filter(b[:, j], size=size, mode="nearest") for j in range(3)], axis=-1)
    return np.linalg.norm(b - bg, axis=1) / np.maximum(np.linalg.norm(bg, axis=1), 1e-12)


def _peaks(e: np.ndarray, p: GateParams, rate: float) -> tuple[np.ndarray, float, float]:
    """Narrow peaks of ``e`` above the larger of ``threshold`` and ``noise_k`` robust sigmas: indices, noise,
    threshold."""
    from scipy.signal import find_peaks

    noise = 1.4826 * float(median(np.abs(e - median(e))))
    thr = max(p.threshold, p.noise_k * noise)
    peaks, _ = find_peaks(e, height=thr, distance=max(1, int(p.min_separation * rate)))
    return peaks[_half_height_width(e, peaks) <= max(1.0, p.max_width * rate)], noise, thr


def detect_gates(
    t_mag: np.ndarray,
    mag: np.ndarray,
    t_gyr: np.ndarray,
    gyr_z: np.ndarray,
    params: GateParams | None = None,
    calibration: MagnetCalibration | None = None,
    gyr: np.ndarray | None = None,
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
    gyr : ndarray, shape (k, 3), optional
        All three angular rates at ``t_gyr`` [rad/s]: the field's vector anomaly is searched too.

    Returns
    -------
    GateDetection
    """
    p = params or GateParams()
    cal = calibration or default_calibration()
    det = GateDetection(calibration=cal)
    if t_mag.size < 5:
        return det
    rate = 1.0 / float(median(np.diff(t_mag)))
    bn = np.linalg.norm(mag, axis=1)
    if p.self_calibrate:
        cal_norm, det.spread = self_calibrated_norm(mag)
        if det.spread >= p.calibrate_spread:
            bn = cal_norm
    b = _over_background(bn, rate, p.background)
    e = b - 1.0
    peaks, det.noise, det.threshold = _peaks(e, p, rate)
    anom = None
    if p.anomaly and gyr is not None and t_gyr.size > 10:
        anom = field_anomaly(t_mag, mag, t_gyr, gyr, rate, p.background)
        extra, _, _ = _peaks(anom, p, rate)
        sep = max(1, int(p.min_separation * rate))
        # an anomaly peak is a crossing of its own where no intensity peak is near (a dip of |B|)
        extra = [int(k) for k in extra if peaks.size == 0 or np.min(np.abs(peaks - k)) >= sep]
        peaks = np.sort(np.concatenate([peaks, np.asarray(extra, dtype=peaks.dtype)]))
    dt = 1.0 / rate
    for k in peaks:
        dk, bp = peak_vertex(b, int(k))
        if anom is not None and bp - 1.0 < 0.5 * anom[k]:  # a dip or a weak bump: the anomaly's size instead
            bp = 1.0 + float(anom[k])
        # the gyro samples within turn_window of the peak: found by bisection in the sorted times (a scan
        # of the whole record per peak made a day's recording quadratic), then the same test on that slice
        lo = int(np.searchsorted(t_gyr, t_mag[k] - 2.0 * p.turn_window, side="left"))
        hi = int(np.searchsorted(t_gyr, t_mag[k] + 2.0 * p.turn_window, side="right"))
        w = np.abs(t_gyr[lo:hi] - t_mag[k]) <= p.turn_window
        wz = float(np.mean(gyr_z[lo:hi][w])) if w.any() else float(np.interp(t_mag[k], t_gyr, gyr_z))
        det.crossings.append(
            Crossing(
                t=float(t_mag[k]),
                b_peak=bp,
                distance=float(cal.distance(bp)),
                turn="R" if wz > 0 else "L",
                gyr_z=wz,
                t_peak=float(t_mag[k] + dk * dt),
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
    gyr3 = None
    if all(c in names for c in ("gyr_x", "gyr_y")):
        g3 = schema.float_columns(table, ("gyr_x", "gyr_y", "gyr_z"))
        ok3 = np.isfinite(g3).all(axis=1)
        if ok3.sum() > 10:
            gyr3 = (t[ok3], g3[ok3])
    mag = schema.float_columns(table, ("mag_x", "mag_y", "mag_z"))
    ok = np.isfinite(mag).all(axis=1)
    if ok.sum() < 5:
        raise InputError("no magnetometer: columns mag_x, mag_y, mag_z hold fewer than 5 samples")
    gz = schema.floats(table, "gyr_z")
    okg = np.isfinite(gz)
    if not okg.any():
        raise InputError("column gyr_z holds no samples; expected the angular rate for the turn side")
    if gyr3 is not None:
        return detect_gates(t[ok], mag[ok], gyr3[0], gyr3[1][:, 2], params, calibration, gyr3[1])
    return detect_gates(t[ok], mag[ok], t[okg], gz[okg], params, calibration)


def gate_columns(table: pa.Table, det: GateDetection) -> dict[str, pa.Array]:
    """Columns ``event`` (``gate`` at each crossing's row, other events kept), ``gate_b_peak``,
    ``gate_distance``, ``gate_t_peak`` (the peak's time between samples), ``turn`` (null except at crossing
    rows)."""
    from sportfusion.core.events import set_events

    out = set_events(table, [("gate", c.t) for c in det.crossings], replace=GATE_EVENTS)
    t = schema.floats(table, "t")
    n = t.size
    bp = np.full(n, np.nan)
    dist = np.full(n, np.nan)
    tp = np.full(n, np.nan)
    turn = np.full(n, None, dtype=object)
    at = np.zeros(n, dtype=bool)
    for c in det.crossings:
        # the row nearest the crossing (the first of two equally near), by bisection: t is increasing
        i = int(np.clip(np.searchsorted(t, c.t), 0, n - 1))
        if i > 0 and abs(t[i - 1] - c.t) <= abs(t[i] - c.t):
            i -= 1
        at[i] = True
        bp[i], dist[i], turn[i], tp[i] = c.b_peak, c.distance, c.turn, c.t_peak
    return {
        "event": out.column("event").combine_chunks(),
        "gate_b_peak": pa.array(bp, pa.float64(), mask=~at),
        "gate_distance": pa.array(dist, pa.float64(), mask=~(at & np.isfinite(dist))),
        "gate_t_peak": pa.array(tp, pa.float64(), mask=~(at & np.isfinite(tp))),
        "turn": turn,
    }


def read_crossings(table: pa.Table) -> dict[str, np.ndarray]:
    """The crossings written by :func:`gate_columns`: ``t`` [s] (the peak's time between samples where the
    session has it, else the row's), ``distance`` [m], ``turn`` (+1 R, -1 L), ``row`` (row index)."""
    if "event" not in table.column_names:
        return {"t": np.zeros(0), "distance": np.zeros(0), "turn": np.zeros(0), "row": np.zeros(0, int)}
    ev = np.array(table.column("event").to_pylist(), dtype=object)
    rows = np.flatnonzero(ev == "gate")
    t = schema.floats(table, "t")[rows]
    if "gate_t_peak" in table.column_names:
        tp = schema.floats(table, "gate_t_peak")[rows]
        t = np.where(np.isfinite(tp) & (np.abs(tp - t) < 0.1), tp, t)
    dist = (
        schema.floats(table, "gate_distance")[rows]
        if "gate_distance" in table.column_names
        else np.full(rows.size, np.nan)
    )
    tv = table.column("turn").to_pylist() if "turn" in table.column_names else [None] * table.num_rows
    turn = np.array([1.0 if tv[i] == "R" else (-1.0 if tv[i] == "L" else 0.0) for i in rows])
    return {"t": t, "distance": dist, "turn": turn, "row": rows}
