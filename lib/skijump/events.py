"""Ski-jump take-off and touch-down from the accelerometer (skijump Appendix A).

The method of the paper, with the errata applied:

1. Only instants where the GNSS speed ``V_GPS = |v_GPS|`` exceeds ``min_speed``
   (10 m/s) are analysed.  The speed is interpolated linearly from the GNSS
   epochs to the IMU samples, never across a GNSS gap longer than
   ``max_gnss_gap``.  Each contiguous stretch above the threshold is one
   window, analysed on its own, so a session of several jumps gives several
   jumps.
2. ``a_norm = |a_B,acc|`` per IMU sample.  ``t_peak1`` is its maximum in the
   window (eq A1); ``t_peak2`` the maximum among the samples *more* than
   ``min_separation`` (1.5 s) away from ``t_peak1`` (eq A2 as the text means it;
   the printed condition is the wrong way round).
3. ``t_TO = min(t_peak1, t_peak2)`` (eq A3) and
   ``t_TD = max(t_peak1, t_peak2) - touchdown_offset`` (0.05 s, eq A4), each peak time taken between
   the samples (:func:`peak_time`: the vertex of a parabola through the peak and its neighbours).
   The ``event`` rows are the nearest samples; the exact times are in the metadata's ``events`` list,
   where rts-smooth and jump-metrics read them (:func:`sportfusion.skijump.smoother_inputs.session_events`).

Touch-down (issue 19): by default (``touchdown_method="onset"``) the touch-down is not eq A4's fixed
offset but the onset of the landing impact, fitted between the samples to the rise of ``a_norm`` before
the landing peak (:func:`sportfusion.skijump.touchdown.impact_onset`: the flight's trend plus a smooth
step); where that fit is not credible, eq A4 is kept and a warning says so.  ``touchdown_method="peak"``
is Appendix A as printed.  Each jump records which one it used (``Jump.touchdown_method``).

GNSS outages (policy, issue 17): where the GNSS speed is unknown for longer
than ``max_gnss_gap`` (loss of lock, a receiver that stopped), the speed gate
cannot be applied.  Such a stretch is searched as if fast when the GNSS speed
just before or just after it exceeds ``min_speed`` (the athlete was moving
into or out of the outage): the jump is then found from the accelerometer
alone (the two peaks, the flight between them), and a warning names the
outage.  So is an outage of 3 s or more whose both sides are slow (the whole
in-run and jump may hide in it); a shorter one between slow stretches is not
searched.

Clipped accelerometer samples (policy, issue 17): a sensor that saturates
(impacts easily exceed 16 g) reports plateaus at its range
(:func:`sportfusion.core.saturation.clipped`, found from the data) and short
vibration bursts that clip too.  When the accelerometer of a session clips,
``a_norm`` within ``peak_filter`` seconds (0.1 s) of a clipped sample is bridged
by linear interpolation before the peak search (a burst is not a peak; a
landing peak lasts longer than the burst and its shoulders remain); if
Appendix A then finds no jump in a window, the pair of peaks with the longest
flight between them is taken (:func:`_pair_search`); a warning says so.  A session that
does not clip is analysed exactly as Appendix A says.

Appendix A always returns two peaks; to avoid inventing a jump where there is
none, a window is accepted only if, in addition, the second peak is a local
maximum no further than ``max_separation`` from the first, both peaks reach
``min_peak``, and the median ``a_norm`` between them (trimmed by ``flight_trim``
at each end) stays below ``max_flight_acc`` (9 m/s^2) -- in flight the
accelerometer measures only the aerodynamic force, below 1 g (about 0.5 g on a
normal hill, up to about 0.85 g in ski flying), while standing or skiing on
gentle terrain it measures about 1 g.  A rejected window is reported with the
reason.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.events import set_events, true_runs
from sportfusion.core.saturation import clipped_rows
from sportfusion.core.stats import median
from sportfusion.skijump.touchdown import first_impact_peak, impact_crossing, impact_onset

JUMP_EVENTS = ("takeoff", "touchdown")
#: How the touch-down is found: the landing impact's onset (default), or eq A4 (peak minus offset).
TOUCHDOWN_METHODS = ("onset", "peak")


@dataclass(frozen=True)
class JumpParams:
    """Parameters of the take-off/touch-down detector (defaults: Appendix A).

    Attributes
    ----------
    min_speed : float
        GNSS speed above which a jump is searched [m/s] (10, Appendix A).
    min_separation : float
        The two peaks are more than this apart [s] (1.5, eq A2).
    touchdown_offset : float
        Touch-down is this long before the landing peak [s] (0.05, eq A4).
    max_separation : float
        Longest plausible flight [s]; the second peak is searched within it.
    min_peak : float
        Both peaks must reach this specific force [m/s^2].
    max_flight_acc : float
        Largest median specific force between the peaks [m/s^2] (flight check, below 1 g).
    flight_trim : float
        Time trimmed at each end of the flight before the median [s].
    max_gnss_gap : float
        GNSS speed is not interpolated across gaps longer than this [s].
    peak_filter : float
        When the accelerometer clipped: samples within this time of a clipped sample are bridged
        (linear interpolation) before the peak search [s], so that impact bursts are not taken as peaks.
    touchdown_method : str
        ``"onset"`` (default): the landing impact's onset (:func:`sportfusion.skijump.touchdown.impact_onset`),
        eq A4 where it is not found; ``"peak"``: eq A4 (the landing peak minus ``touchdown_offset``).
    vibration_level : float
        A window whose ``|a|`` vibrates more than this from sample to sample (:func:`vibration_level`, a robust
        standard deviation [m/s^2]; the paper's white noise gives about 0.1) is searched on averaged forces.
    vibration_smoothing : float
        Width of that average [s] (0: never).
    """

    min_speed: float = 10.0
    min_separation: float = 1.5
    touchdown_offset: float = 0.05
    max_separation: float = 10.0
    min_peak: float = 15.0
    max_flight_acc: float = 9.0
    flight_trim: float = 0.3
    max_gnss_gap: float = 2.0
    peak_filter: float = 0.1
    touchdown_method: str = "onset"
    vibration_level: float = 0.5
    vibration_smoothing: float = 0.05

    def __post_init__(self) -> None:
        if self.touchdown_method not in TOUCHDOWN_METHODS:
            raise ValueError(f"touchdown_method {self.touchdown_method!r}; expected one of {TOUCHDOWN_METHODS}")


@dataclass
class Jump:
    """One detected jump (times in the session's seconds; ``touchdown_method``: how the touch-down was found,
    ``"onset"``, ``"rise"`` (the impact's rise through 5 % of its first peak, where no onset fits) or
    ``"peak"``)."""

    takeoff: float
    touchdown: float
    t_peak_takeoff: float
    t_peak_landing: float
    peak_takeoff: float
    peak_landing: float
    flight_acc: float
    window: tuple[float, float]
    touchdown_method: str = "peak"


@dataclass
class JumpDetection:
    """Result of :func:`detect_jumps`: the jumps, and why other windows were rejected."""

    jumps: list[Jump] = field(default_factory=list)
    rejected: list[dict[str, Any]] = field(default_factory=list)
    windows: int = 0
    warnings: list[str] = field(default_factory=list)

    def summary(self, params: JumpParams) -> dict[str, Any]:
        """JSON-ready summary for the metadata."""
        return {
            "kind": "jump",
            "method": "skijump Appendix A (errata: peaks more than min_separation apart); touch-down: "
            + ("the landing impact's onset" if params.touchdown_method == "onset" else "eq A4"),
            "params": asdict(params),
            "speed_windows": self.windows,
            "jumps": [asdict(j) for j in self.jumps],
            "rejected": self.rejected,
            "warnings": self.warnings,
        }

    def message(self) -> str:
        """One line saying what was found."""
        if self.jumps:
            parts = [
                f"take-off {j.takeoff:.2f} s, touch-down {j.touchdown:.2f} s (flight {j.touchdown - j.takeoff:.2f} s)"
                for j in self.jumps
            ]
            return f"{len(self.jumps)} jump(s): " + "; ".join(parts)
        if not self.windows:
            return "no jump found: the GNSS speed never exceeds the speed threshold"
        reasons = "; ".join(f"{r['window'][0]:.1f}-{r['window'][1]:.1f} s: {r['reason']}" for r in self.rejected)
        return f"no jump found in {self.windows} fast window(s) ({reasons})"


def speed_at(t: np.ndarray, t_gnss: np.ndarray, speed: np.ndarray, max_gap: float) -> np.ndarray:
    """GNSS speed linearly interpolated to times ``t`` [s]; NaN outside the GNSS span or across gaps > ``max_gap``."""
    ok = np.isfinite(speed) & np.isfinite(t_gnss)
    tg, vg = t_gnss[ok], speed[ok]
    out = np.full(t.shape, np.nan)
    if tg.size < 2:
        return out
    j = np.searchsorted(tg, t)
    inside = (j > 0) & (j < tg.size)
    jj = np.clip(j, 0, tg.size - 1)
    exact = tg[jj] == t
    lo, hi = np.clip(j - 1, 0, tg.size - 1), jj
    gap_ok = (tg[hi] - tg[lo]) <= max_gap
    use = inside & gap_ok
    out[use] = np.interp(t[use], tg, vg)
    out[exact] = vg[jj[exact]]
    return out


def detect_jumps(
    t: np.ndarray,
    acc_norm: np.ndarray,
    speed: np.ndarray,
    params: JumpParams | None = None,
    clipped: np.ndarray | None = None,
    acc: np.ndarray | None = None,
) -> JumpDetection:
    """Take-off and touch-down of every jump (Appendix A, see the module text).

    Parameters
    ----------
    t : ndarray, shape (n,)
        IMU sample times [s], increasing.
    acc_norm : ndarray, shape (n,)
        Norm of the measured specific force [m/s^2].
    speed : ndarray, shape (n,)
        GNSS speed at those times [m/s] (NaN where unknown), e.g. from :func:`speed_at`.
    params : JumpParams, optional
    clipped : ndarray of bool, shape (n,), optional
        Samples where the accelerometer clipped; when any, impact bursts are filtered
        (:func:`bridge_clipped`) before the peak search.
    acc : ndarray, shape (n, 3), optional
        The accelerometer axes [m/s^2]; needed when ``clipped`` has any True.

    Returns
    -------
    JumpDetection
    """
    p = params or JumpParams()
    det = JumpDetection()
    fast, bridged = _speed_gate(t, speed, p.min_speed)
    fast &= np.isfinite(acc_norm)
    for a, b in bridged:
        det.warnings.append(
            f"GNSS speed missing {a:.1f}-{b:.1f} s (outage) next to fast motion: "
            "that stretch is searched for a jump from the accelerometer alone"
        )
    acc_f = acc_norm
    if clipped is not None and np.any(clipped):
        if acc is None:
            raise ValueError("detect_jumps: clipped samples need the accelerometer axes (acc)")
        acc_f = bridge_clipped(t, acc, clipped, p.peak_filter)
        det.warnings.append(
            f"accelerometer clipped (saturated) in {int(np.sum(clipped))} sample(s): impact bursts "
            f"(within {p.peak_filter:g} s) are median-filtered before the peak search"
        )
    robust = acc_f is not acc_norm
    for i0, i1 in true_runs(fast):
        det.windows += 1
        tw, aw = t[i0:i1], acc_f[i0:i1]
        win = (float(tw[0]), float(tw[-1]))
        vib = vibration_level(aw)
        shaking = p.vibration_smoothing > 0 and vib > p.vibration_level
        # a vibrating sensor (ski chatter, impact ringing): the peaks are searched on the force averaged over
        # vibration_smoothing seconds (a zero-mean vibration averages out, the impulses of take-off and
        # landing, which last about 0.1 s, stay), then the landing peak is found on the samples near it
        src = aw if not shaking else _averaged(tw, aw if acc is None or robust else acc[i0:i1], p.vibration_smoothing)
        found = _window_jump(tw, src, p)
        if isinstance(found, str) and (robust or shaking):
            alt = _pair_search(tw, src, p)
            found = alt if alt is not None else found
        if isinstance(found, str):
            det.rejected.append({"window": win, "reason": found})
            continue
        ka, kb = found
        if shaking:
            half = int(np.searchsorted(tw, tw[kb] + 0.5 * p.vibration_smoothing)) - kb
            lo, hi = max(kb - half, 0), min(kb + half + 1, tw.size)
            kb = lo + int(np.argmax(aw[lo:hi]))
        mid = (tw > tw[ka] + p.flight_trim) & (tw < tw[kb] - p.flight_trim)
        flight = float(median(src[mid])) if mid.any() else float(src[ka + (kb - ka) // 2])
        t_a, t_b = peak_time(tw, src, ka), peak_time(tw, aw, kb)
        t_td, how = t_b - p.touchdown_offset, "peak"
        if p.touchdown_method == "onset":
            k1 = first_impact_peak(tw, aw, kb)
            onset = impact_onset(tw, aw, k1)
            cross = impact_crossing(tw, aw, k1) if onset is None else None
            if onset is not None:
                t_td, how = onset, "onset"
            elif cross is not None:
                t_td, how = cross, "rise"
                det.warnings.append(
                    f"landing at {t_b:.2f} s: no smooth impact onset found before the peak; the touch-down is where "
                    "the impact rises through 5 % of its first peak (a few ms late)"
                )
            else:
                det.warnings.append(
                    f"landing at {t_b:.2f} s: no smooth impact onset found before the peak; the touch-down is "
                    f"the peak minus {p.touchdown_offset:g} s (Appendix A)"
                )
        det.jumps.append(
            Jump(
                takeoff=t_a,
                touchdown=t_td,
                t_peak_takeoff=t_a,
                t_peak_landing=t_b,
                peak_takeoff=float(aw[ka]),
                peak_landing=float(aw[kb]),
                flight_acc=flight,
                window=win,
                touchdown_method=how,
            )
        )
    return det


def vibration_level(a: np.ndarray) -> float:
    """Robust standard deviation [m/s^2] of the sample-to-sample noise of ``a``: ``1.4826 MAD(d2 a) / sqrt(6)``
    with ``d2`` the second difference (a smooth signal has none; white noise of sigma gives sigma)."""
    d2 = np.diff(np.asarray(a, float), 2)
    d2 = d2[np.isfinite(d2)]
    if d2.size < 5:
        return 0.0
    return float(1.4826 * median(np.abs(d2 - median(d2))) / np.sqrt(6.0))


def _averaged(t: np.ndarray, a: np.ndarray, width: float) -> np.ndarray:
    """Norm of the centred running mean over ``width`` [s] of ``a`` (n,) or its axes (n, 3)."""
    dt = float(median(np.diff(t))) if t.size > 1 else 1.0
    k = max(int(round(width / dt)) | 1, 1)
    x = np.where(np.isfinite(a), a, 0.0)
    x = x[:, None] if x.ndim == 1 else x
    pad = k // 2
    xp = np.pad(x, ((pad, pad), (0, 0)), mode="edge")
    c = np.vstack([np.zeros((1, x.shape[1])), np.cumsum(xp, axis=0)])
    m = (c[k:] - c[:-k]) / k
    return np.linalg.norm(m, axis=1)


def _flight_median(tw: np.ndarray, aw: np.ndarray, ka: int, kb: int, p: JumpParams) -> float:
    mid = (tw > tw[ka] + p.flight_trim) & (tw < tw[kb] - p.flight_trim)
    return float(median(aw[mid])) if mid.any() else float(aw[ka + (kb - ka) // 2])


def peak_time(t: np.ndarray, a: np.ndarray, k: int) -> float:
    """The time [s] of the peak at sample ``k`` between the samples: vertex of the parabola through
    ``k - 1, k, k + 1`` (uniform steps assumed locally); ``t[k]`` at an edge, on a gap of more than
    twice the step, or where the three samples do not bend down.

    At 100 Hz the largest sample is up to 5 ms from the peak, which is 0.12 m along a landing slope
    at 25 m/s; the vertex is within about a millisecond on a smooth impact.
    """
    if k <= 0 or k >= a.size - 1:
        return float(t[k])
    h0, h1 = t[k] - t[k - 1], t[k + 1] - t[k]
    if not (0 < h0 <= 2 * h1 and 0 < h1 <= 2 * h0):
        return float(t[k])
    y0, y1, y2 = float(a[k - 1]), float(a[k]), float(a[k + 1])
    den = y0 - 2 * y1 + y2
    if not (den < 0) or not (y1 >= y0 and y1 >= y2):
        return float(t[k])
    d = 0.5 * (y0 - y2) / den  # in steps, within [-0.5, 0.5] for a local maximum
    return float(t[k] + d * (h1 if d > 0 else h0))


def _window_jump(tw: np.ndarray, aw: np.ndarray, p: JumpParams) -> tuple[int, int] | str:
    """Appendix A on one window: the indices (take-off peak, landing peak), or why there is no jump."""
    k1 = int(np.argmax(aw))
    dt = np.abs(tw - tw[k1])
    cand = (dt > p.min_separation) & (dt <= p.max_separation)
    if not cand.any():
        return f"no second acceleration peak more than {p.min_separation:g} s from the first"
    k2 = int(np.flatnonzero(cand)[np.argmax(aw[cand])])
    local = (k2 == 0 or aw[k2] >= aw[k2 - 1]) and (k2 == aw.size - 1 or aw[k2] >= aw[k2 + 1])
    if not local or (k2 > 0 and not cand[k2 - 1]) or (k2 < aw.size - 1 and not cand[k2 + 1]):
        return "the second largest acceleration is not a peak"
    ka, kb = sorted((k1, k2))
    if min(aw[ka], aw[kb]) < p.min_peak:
        return f"peaks {aw[ka]:.1f} and {aw[kb]:.1f} m/s^2, below min_peak {p.min_peak:g} m/s^2"
    flight = _flight_median(tw, aw, ka, kb, p)
    if flight > p.max_flight_acc:
        return f"no flight between the peaks (median |a| {flight:.1f} m/s^2 > {p.max_flight_acc:g})"
    return ka, kb


def _pair_search(tw: np.ndarray, aw: np.ndarray, p: JumpParams, top: int = 12) -> tuple[int, int] | None:
    """Robust fallback when the sensor clipped: of the ``top`` largest peaks above ``min_peak`` (0.3 s apart),
    the pair ``min_separation``-``max_separation`` apart with the purest flight between them (lowest
    median ``|a|``, below ``max_flight_acc``); None when none qualifies."""
    order = np.argsort(aw)[::-1]
    peaks: list[int] = []
    for k in order:
        if aw[k] < p.min_peak or len(peaks) >= top:
            break
        if all(abs(tw[k] - tw[j]) > 0.3 for j in peaks):
            peaks.append(int(k))
    pairs = []
    for i in peaks:
        for j in peaks:
            d = tw[j] - tw[i]
            if p.min_separation < d <= p.max_separation:
                f = _flight_median(tw, aw, i, j, p)
                if f <= p.max_flight_acc:
                    pairs.append((f, d, i, j))
    if not pairs:
        return None
    _, _, i, j = min(pairs)
    return i, j


def _speed_gate(
    t: np.ndarray, speed: np.ndarray, min_speed: float, min_outage: float = 3.0
) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """Samples to search (speed above ``min_speed``, or unknown next to a fast stretch or for at least
    ``min_outage`` [s]: a whole jump fits in it) and the bridged outages."""
    known = np.isfinite(speed)
    fast = known & (speed > min_speed)
    bridged = []
    for i0, i1 in true_runs(~known):
        before = speed[i0 - 1] if i0 > 0 else np.nan
        after = speed[i1] if i1 < speed.size else np.nan
        long_enough = t[i1 - 1] - t[i0] >= min_outage
        if before > min_speed or after > min_speed or long_enough:
            fast[i0:i1] = True
            bridged.append((float(t[i0]), float(t[i1 - 1])))
    return fast, bridged


def bridge_clipped(t: np.ndarray, acc: np.ndarray, clipped: np.ndarray, margin: float) -> np.ndarray:
    """``|a|`` with impact bursts removed: near a burst, the norm of the per-axis running median.

    A burst is a sample where the accelerometer clipped or any axis reads beyond half the
    clipping level (an impact-level vibration); within ``margin`` [s] of one, ``|a|`` is taken
    from the per-axis running median over 1.5 ``margin`` (a zero-mean vibration averages out,
    a landing's deceleration, which lasts longer, stays); elsewhere it is the raw norm.
    """
    norm = np.linalg.norm(acc, axis=1)
    c = np.asarray(clipped, bool)
    if not c.any():
        return norm
    level = float(np.nanmin(np.abs(acc[c]).max(axis=1)))
    burst = c | (np.nanmax(np.abs(acc), axis=1) >= 0.5 * level)
    tc = t[burst]
    j = np.clip(np.searchsorted(tc, t), 1, tc.size)
    near = (np.abs(t - tc[j - 1]) <= margin) | (np.abs(t - tc[np.minimum(j, tc.size - 1)]) <= margin)
    from scipy.ndimage import median_filter

    dt = float(median(np.diff(t))) if t.size > 1 else 1.0
    k = max(int(round(1.5 * margin / dt)) | 1, 3)
    med = np.linalg.norm(median_filter(np.nan_to_num(acc), size=(k, 1), mode="nearest"), axis=1)
    return np.where(near, med, norm)


def running_median(t: np.ndarray, x: np.ndarray, width: float) -> np.ndarray:
    """Running median of ``x`` over ``width`` seconds (odd number of samples, at least 3; ``x`` when too short).

    The sample spacing is the median of ``diff(t)``; edges use the shrinking window
    of :func:`scipy.ndimage.median_filter` (mode ``nearest``).
    """
    if width <= 0 or x.size < 3:
        return x
    from scipy.ndimage import median_filter

    dt = float(median(np.diff(t)))
    k = int(round(width / dt)) if dt > 0 else 1
    k = k + 1 if k % 2 == 0 else k
    if k < 3:
        return x
    out = median_filter(np.where(np.isfinite(x), x, 0.0), size=k, mode="nearest")
    return np.where(np.isfinite(x), out, np.nan)


def gnss_speed(table: pa.Table) -> tuple[np.ndarray, np.ndarray]:
    """GNSS epochs and speed [m/s] of a session.

    From ``vel_n vel_e`` (and ``vel_d`` where present: the 3-D speed of
    Appendix A), else from the differences of ``gnss_x gnss_y gnss_z``.

    Returns
    -------
    t : ndarray
        Times [s] of the rows with a GNSS speed.
    speed : ndarray
        Speed [m/s].
    """
    t = schema.floats(table, "t")
    names = table.column_names
    if "vel_n" in names and "vel_e" in names:
        vn, ve = schema.floats(table, "vel_n"), schema.floats(table, "vel_e")
        vd = schema.floats(table, "vel_d") if "vel_d" in names else np.zeros_like(vn)
        vd = np.where(np.isfinite(vd), vd, 0.0)
        ok = np.isfinite(vn) & np.isfinite(ve)
        return t[ok], np.sqrt(vn[ok] ** 2 + ve[ok] ** 2 + vd[ok] ** 2)
    if all(c in names for c in ("gnss_x", "gnss_y")):
        cols = [schema.floats(table, c) for c in ("gnss_x", "gnss_y", "gnss_z") if c in names]
        pos = np.stack(cols, axis=-1)
        ok = np.isfinite(pos).all(axis=1)
        tg, pg = t[ok], pos[ok]
        if tg.size < 3:
            return tg[:0], tg[:0]
        v = np.gradient(pg, tg, axis=0)
        return tg, np.linalg.norm(v, axis=1)
    raise InputError(
        "missing column(s) vel_n, vel_e (or gnss_x, gnss_y, gnss_z) for the GNSS speed of jump detection; "
        f"the table has {', '.join(names)}"
    )


def detect_jump_table(table: pa.Table, params: JumpParams | None = None) -> JumpDetection:
    """:func:`detect_jumps` on a session table (``acc_x acc_y acc_z`` and GNSS velocity or positions)."""
    p = params or JumpParams()
    schema.require_columns(table, ("acc_x", "acc_y", "acc_z"), "jump detection")
    t = schema.floats(table, "t")
    acc = schema.float_columns(table, ("acc_x", "acc_y", "acc_z"))
    imu = np.isfinite(acc).all(axis=1)
    if not imu.any():
        raise InputError("columns acc_x, acc_y, acc_z hold no samples; expected accelerometer data")
    t_g, v_g = gnss_speed(table)
    if t_g.size < 2:
        raise InputError("the session has fewer than 2 GNSS velocity samples; expected a GNSS track for the speed")
    ti = t[imu]
    clip = clipped_rows(acc[imu])
    a = acc[imu]
    return detect_jumps(ti, np.linalg.norm(a, axis=1), speed_at(ti, t_g, v_g, p.max_gnss_gap), p, clip, a)


def jump_events(det: JumpDetection) -> list[tuple[str, float]]:
    """(name, t) of the detected take-offs and touch-downs, in time order."""
    out = []
    for j in det.jumps:
        out += [("takeoff", j.takeoff), ("touchdown", j.touchdown)]
    return out


def detect_jump_events(table: pa.Table, params: JumpParams | None = None) -> tuple[pa.Table, dict[str, Any], str]:
    """Detect the jumps of a session and write their ``takeoff``/``touchdown`` rows into ``event``.

    Returns
    -------
    table : pyarrow.Table
        The input with the ``event`` column set (unchanged when no jump is found:
        no events are invented).
    summary : dict
        For the metadata's ``events`` list (:meth:`JumpDetection.summary`).
    message : str
        One line saying what was found or why nothing was.

    The numbers of each jump (take-off, touch-down, peak times and values) are
    in ``summary["jumps"]``; the metadata's ``events`` list is the place for it.
    """
    p = params or JumpParams()
    det = detect_jump_table(table, p)
    out = set_events(table, jump_events(det), replace=JUMP_EVENTS) if det.jumps else table
    return out, det.summary(p), det.message()
