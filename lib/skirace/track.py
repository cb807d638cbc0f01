"""Smooth a session's GNSS track with weighted smoothing splines (what ``spline-smooth`` does).

Rows and values
---------------
A session's rows are the union of all sensors' times.  The spline is fitted
to the rows that carry a local GNSS position (``gnss_x gnss_y gnss_z``
finite) and then evaluated at **every** row inside the span of those epochs:
GNSS rows, IMU rows in between, and rows inside data gaps (loss of lock) up
to ``max_gap`` seconds long.  Rows before the first or after the last
position, or inside a longer gap, get nulls (no extrapolation).

Segments (gaps the data cannot bridge)
    A gap between two consecutive epochs longer than ``max_gap`` (10 s by
    default) **and** longer than ``BREAK_FACTOR`` (5) times the median epoch
    spacing -- a watch switched off overnight, a record clock that jumps by
    days, a phone that lost the sky for minutes -- splits the track: each
    segment gets its own spline (its own robust weights and, with
    ``--lambda gcv``, its own lambda), no spline is evaluated inside the gap
    (its rows are null), and nothing is counted for it.  ``distance``
    carries over: a segment's distance starts where the previous one ended
    (like a watch's total during a pause), so the gap adds no metres.
    ``spline_segment`` numbers the segments (0, 1, ...; null off the
    track) and a warning line names each gap with its time and length.  A
    segment of one fix alone is not smoothed (its row is null, counted in a
    warning).  The lambda reported is the longest segment's.

``spline_filled`` is True on rows that have no position of their own and lie
inside a data gap, i.e. between two consecutive position epochs more than 1.5
times the median epoch spacing apart: there the value bridges missing GNSS
data.  IMU rows between regular epochs are False.

1-sigma (``std_x std_y std_z``) is written when the input carries position
sigmas (``std_gnss_*``, else ``gnss_sigma_h``/``gnss_sigma_v``): the input
sigmas propagated through the smoother (noise only) at the position epochs,
interpolated linearly to rows between regular epochs; inside a gap (a GNSS
outage) the std also holds how far the track strays from the cubic bridge, as
measured on the session's own track
(:mod:`sportfusion.estimators.spline_gaps`), so it grows towards the middle of
the gap; null for per-segment smoothing.  A warning line says how many rows
were bridged.

Velocity and acceleration are the spline's first and second derivatives
(eq 7) in the local frame; ``speed`` is ``|v|``, ``distance`` the curvilinear
distance along the spline from the first epoch (carried over the track's
long gaps, see above), and ``course`` the azimuth of
the horizontal velocity, clockwise from north (frame azimuth added) [rad, in
(-pi, pi]].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.meta import epoch_unix
from sportfusion.core.rotations import ned_to_local
from sportfusion.core.stats import median
from sportfusion.estimators.spline import ambiguity_weights, epoch_weights, gcv_lambda, smoothing_spline
from sportfusion.estimators.spline_gaps import gap_std
from sportfusion.estimators.spline_robust import robust_fit

GAP_FACTOR = 1.5  # an interval longer than this times the median epoch spacing is a data gap
BREAK_FACTOR = 5.0  # a gap longer than --max-gap and this many median spacings splits the track
HDOP_SIGMA = 3.0  # [m] per-axis 1-sigma per unit of HDOP (a consumer receiver's range error) when no sigma is given
VDOP_RATIO = 1.5  # vertical / horizontal sigma from an HDOP (VDOP is typically 1.5 HDOP)


@dataclass
class TrackResult:
    """Columns to add (name -> array with NaN for null) plus what happened."""

    columns: dict[str, np.ndarray | pa.Array]
    lam: np.ndarray
    info: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def smooth_track(
    t: np.ndarray,
    pos: np.ndarray,
    fix: np.ndarray | None = None,
    sigma: np.ndarray | None = None,
    *,
    azimuth_deg: float = 0.0,
    lam: float | None = 0.5,
    segments: list[tuple[float, float, float]] | None = None,
    weighting: str = "eq6",
    w_float: float = 0.5,
    w_trans: float = 1e-4,
    no_trans: int = 5,
    edge_factor: float = 2.0,
    max_gap: float = 10.0,
    robust: bool = True,
    vel: np.ndarray | None = None,
    speed: np.ndarray | None = None,
    epoch_utc: float | None = None,
) -> TrackResult:
    """Fit the weighted smoothing splines to a track and evaluate them at every row.

    Parameters
    ----------
    t : (N,) row times [s].
    pos : (N, 3) local GNSS position [m], NaN where the row has none.
    fix : (N,) GGA fix quality (NaN/any value where unknown) or None (all fixed).
    sigma : (N, 3) position 1-sigma [m] per axis, or None.
    azimuth_deg : the local frame's x-axis azimuth [deg] (for ``course``).
    lam : the paper's smoothing factor in [0, 1]; None for GCV per axis.
    segments : per-segment lambda ``(t0 [s], t1 [s], lambda)``.
    weighting : ``"eq6"`` (ambiguity status and sigma, eq 6) or ``"uniform"`` (one weight for all
        epochs: 1 / the median sigma of the fixed epochs, so that ``lam`` smooths alike).
    w_float, w_trans, no_trans, edge_factor : eq 6 parameters (:func:`sportfusion.estimators.spline.ambiguity_weights`).
    max_gap : longest data gap [s] bridged; rows inside longer gaps are null.
    robust : down-weight fixes that disagree with their neighbours beyond their stated accuracy
        (:func:`sportfusion.estimators.spline_robust.robust_weights`); the weight is written as ``gnss_weight``.
    vel : (N, 3) receiver velocity in the local frame [m/s] (NaN where absent), or None: screens outliers.
    speed : (N,) receiver speed over ground [m/s], or None: screens spikes where there is no velocity.
    epoch_utc : the session's time origin [Unix s], only to name the track's long gaps in UTC.

    Returns
    -------
    TrackResult
        ``columns``: x y z vx vy vz ax ay az speed distance course
        spline_filled spline_segment (and std_x std_y std_z when sigmas were given).
    """
    t = np.asarray(t, float)
    pos = np.asarray(pos, float)
    warnings: list[str] = []
    every_epoch = bool(np.isfinite(pos).all())  # a GNSS-only table: every row is an epoch (no copies, no row search)
    has = np.ones(t.size, bool) if every_epoch else np.all(np.isfinite(pos), axis=1)
    k = None if every_epoch else np.flatnonzero(has)  # the epochs' rows (None: every row)
    ne = t.size if k is None else k.size  # epochs
    if ne < 4:
        raise InputError(f"only {ne} row(s) have a GNSS position (gnss_x gnss_y gnss_z); at least 4 are needed")
    sel = slice(None) if k is None else k  # (every row: views, not copies)
    tk, yk = t[sel], pos[sel]
    sk_in = None if sigma is None else np.asarray(sigma, float)[sel]  # (maybe the caller's: copied before filling)
    fk = None if fix is None else np.asarray(fix, float)[sel]
    if weighting == "uniform":
        # one weight for every epoch, on the scale of eq 6's fixed epochs so that lambda keeps its meaning
        sk0 = sk_in
        scale = np.nanmedian(sk0, axis=0) if sk0 is not None and np.isfinite(sk0).any() else np.ones(3)
        if fk is not None and sk0 is not None:
            fixed = fk == 4
            if fixed.any() and np.isfinite(sk0[fixed]).any():
                scale = np.nanmedian(sk0[fixed], axis=0)
        w = np.broadcast_to(1.0 / np.where(np.isfinite(scale) & (scale > 0), scale, 1.0), (ne, 3))
    elif weighting == "eq6":
        if fix is None:
            warnings.append("no gnss_fix column: every epoch is weighted as RTK fixed")
            w_amb = np.ones(ne)
        else:
            w_amb = ambiguity_weights(
                np.where(np.isfinite(fk), fk, -1).astype(int),
                w_float=w_float,
                w_trans=w_trans,
                no_trans=no_trans,
                edge_factor=edge_factor,
            )
        w = epoch_weights(w_amb, sk_in)  # (epoch_weights copies what it fills)
        del w_amb
    else:
        raise InputError(f"weighting {weighting!r} is not eq6 or uniform")
    sk = sk_in
    ok = None if sk is None else np.isfinite(sk) & (sk > 0)
    if sk is not None and not ok.all():  # (the median of 1e6 sigmas costs 10-30 ms: only where something is filled)
        sk = sk.copy()
        for c in range(3):
            if not ok[:, c].any():  # no sigma for an axis: no 1-sigma out
                sk = None
                break
            if not ok[:, c].all():
                sk[~ok[:, c], c] = median(sk[ok[:, c], c])
    w = np.broadcast_to(np.asarray(w, float).reshape(ne, -1), (ne, 3))
    vk = None
    spk = None
    if robust:
        vk = None if vel is None else np.asarray(vel, float)[sel]
        if vk is not None:
            vk = vk[:, : (3 if np.isfinite(vk[:, 2]).any() else 2)]
        spk = None if speed is None or vk is not None else np.asarray(speed, float)[sel]

    # the track's segments: split at the gaps the data cannot bridge (module text)
    n = t.size
    dtk = np.diff(tk)
    step = float(median(dtk))
    split_at = max(max_gap, BREAK_FACTOR * step)
    brk = np.flatnonzero(dtk > split_at)
    bounds = list(zip(np.r_[0, brk + 1], np.r_[brk + 1, ne], strict=True))
    fitted = [(a, b) for a, b in bounds if b - a >= 2]
    if not fitted:
        raise InputError(
            f"no stretch of the track has 2 GNSS epochs within {split_at:g} s of each other: nothing to smooth"
        )
    isolated = sum(1 for a, b in bounds if b - a < 2)

    rw = np.ones(ne)
    fits = []
    for a, b in fitted:
        ws = w[a:b]
        ss = None if sk is None else sk[a:b]
        knots = None  # the robust screen's last fit, when it is the final one
        if robust:
            rws, knots = robust_fit(
                tk[a:b],
                yk[a:b],
                ws,
                0.9 if lam is None else lam,
                ss,
                vel=None if vk is None else vk[a:b],
                speed=None if spk is None else spk[a:b],
            )
            rw[a:b] = rws
            if rws.min() < 1.0:  # (times 1: the same weights)
                ws = ws * rws[:, None]
        if lam is None and robust and (rw[a:b] < 0.1).any() and (rw[a:b] >= 0.1).sum() >= 4:
            # GCV chooses lambda on the fixes the robust screen kept: a weighted-down outlier still counts in
            # GCV's trace and pulls its choice towards interpolation, which then follows the outliers
            keep = rw[a:b] >= 0.1
            lam_axes = [gcv_lambda(tk[a:b][keep], yk[a:b][keep, c], ws[keep, c]) for c in range(3)]
            fits.append(_fit_axes(tk[a:b], yk[a:b], ws, lam_axes, segments, ss))
        else:
            reuse = knots if lam is not None and not segments else None
            fits.append(smoothing_spline(tk[a:b], yk[a:b], ws, lam, segments=segments, sigma=ss, knots=reuse))
    del w, ws  # (the weights, 24 MB at 1e6 epochs, are not held while the output columns are made)
    if robust:
        n_out = int(np.sum(rw < 0.1))
        if n_out:
            how = "receiver velocity and " if vk is not None else ("receiver speed and " if spk is not None else "")
            warnings.append(
                f"{n_out} of {ne} GNSS fix(es) disagree with their neighbours ({how}the spline through the others) "
                "beyond their stated accuracy: weighted down (see column gnss_weight)"
            )

    # rows that get a value: inside a fitted segment and not in a gap longer than max_gap (an epoch always
    # does; only the rows without a position are searched among the epochs)
    in_gap = np.zeros(n, bool)
    too_long = np.zeros(n, bool)
    cover = has.copy()
    lone = np.ones(ne, bool)  # epochs in no fitted segment: isolated fixes between long gaps
    for a, b in fitted:
        lone[a:b] = False
    if isolated:
        cover[np.flatnonzero(has)[lone]] = False
    nopos = np.flatnonzero(~has)
    if nopos.size:
        tn = t[nopos]
        inside = (tn >= tk[0]) & (tn <= tk[-1])
        j = np.clip(np.searchsorted(tk, tn, side="right") - 1, 0, tk.size - 2)
        span = dtk[j]
        in_gap[nopos] = inside & (span > GAP_FACTOR * step)
        too_long[nopos] = inside & (span > max_gap)
        cover[nopos] = inside & ~(span > max_gap)
    if too_long.any():
        what = f"{max_gap:g} s" if not brk.size else f"{max_gap:g} s (in the gaps that split the track, too)"
        warnings.append(f"{int(too_long.sum())} row(s) inside data gaps longer than {what} are left null")
    if brk.size:
        names = "; ".join(_describe_gap(tk[j], tk[j + 1], epoch_utc) for j in brk[:5])
        more = f"; and {brk.size - 5} more" if brk.size > 5 else ""
        warnings.append(
            f"track split into {len(fitted)} segment(s) at {brk.size} GNSS gap(s) longer than {split_at:g} s "
            f"({names}{more}): no spline across a gap, its rows are null, and distance carries over it "
            "(nothing is added for the gap; column spline_segment numbers the segments)"
        )
    if isolated:
        warnings.append(f"{isolated} isolated GNSS fix(es) between such gaps are not smoothed (their rows are null)")

    # a consumer track (no RTK fixed/float epoch, heights not stated to better than 0.2 m): its height wiggles
    # by metres from fix to fix, so speed and distance take the height smoothed over VERTICAL_WINDOW
    rtk = fk is not None and bool(np.isin(fk, (4, 5)).any())
    consumer = not rtk and (sk is None or float(median(sk[:, 2])) > 0.2)
    cols: dict[str, np.ndarray] = {}
    names = [f"{p}{a}" for p in ("", "v", "a") for a in "xyz"] + ["speed", "distance", "course"]
    with_std = fits[0].std is not None
    if with_std:
        names += ["std_x", "std_y", "std_z"]
    every = len(fitted) == 1 and bool(cover.all())  # every row gets a value: no scatter into NaN columns
    if not every:
        for name in names:
            cols[name] = np.full(n, np.nan)
    segment_no = np.full(n, -1, dtype=np.int32)
    ca, sa = np.cos(np.deg2rad(azimuth_deg)), np.sin(np.deg2rad(azimuth_deg))
    carried = 0.0
    filled = in_gap & cover
    for s_i, ((a, b), fit) in enumerate(zip(fitted, fits, strict=True)):
        r0 = int(np.searchsorted(t, tk[a], side="left"))
        r1 = int(np.searchsorted(t, tk[b - 1], side="right"))
        rows = slice(r0, r1) if cover[r0:r1].all() else r0 + np.flatnonzero(cover[r0:r1])  # (a slice: views)
        tr = t[rows]
        segment_no[rows] = s_i
        val, d1, d2 = fit.spline.evaluate(tr)
        if consumer:
            speed_s, dist = _consumer_speed_distance(fit.spline, tk[a], tk[b - 1], tr, d1)
            seg_end = float(dist[-1])
        else:
            speed_s = np.einsum("ij,ij->i", d1, d1)
            speed_s, dist = np.sqrt(speed_s, out=speed_s), fit.spline.arc_length(tr)
            # the segment's last row is its last epoch (an epoch always gets a value)
            seg_end = float(dist[-1] if tr[-1] == tk[b - 1] else fit.spline.arc_length(np.array([tk[b - 1]]))[0])
        dist += carried
        seg_cols = {"speed": speed_s, "distance": dist}
        for i, ax in enumerate("xyz"):
            seg_cols[ax], seg_cols[f"v{ax}"], seg_cols[f"a{ax}"] = val[:, i], d1[:, i], d2[:, i]
        # NED of the horizontal velocity (local_to_ned, written out: no (N, 3) matrix product; in place, as the
        # columns at 1e6 rows are 8 MB each)
        east, north = d1[:, 0] * sa, d1[:, 0] * ca
        east += d1[:, 1] * ca
        north -= d1[:, 1] * sa
        seg_cols["course"] = np.arctan2(east, north, out=east)
        carried += seg_end
        if with_std:
            seg_cols.update(_segment_std(fit, tk[a:b], yk[a:b], t, rows, has, in_gap, step))
        for name, values in seg_cols.items():
            if every:
                cols[name] = np.ascontiguousarray(values, dtype=float)
            else:
                cols[name][rows] = values
    if not with_std and sigma is not None and segments:
        warnings.append("1-sigma is not computed with per-segment lambda")
    cols["spline_filled"] = schema.numeric_array(filled, ~cover)  # null where no value is given
    cols["spline_segment"] = schema.numeric_array(segment_no, segment_no < 0)
    if filled.any():
        gaps_in = dtk[(dtk > GAP_FACTOR * step) & (dtk <= max_gap)]
        gap_len = float(gaps_in.max()) if gaps_in.size else max_gap
        warnings.append(
            f"{int(filled.sum())} row(s) bridge GNSS gaps (outages) of up to {gap_len:.1f} s "
            "(spline_filled; their std grows across the gap)"
        )
    if robust:
        gw = rw.copy() if isolated else rw
        if isolated:
            gw[lone] = np.nan
        if every_epoch:
            cols["gnss_weight"] = gw
        else:
            full = np.full(n, np.nan)
            full[k] = gw
            cols["gnss_weight"] = full
    main = max(range(len(fitted)), key=lambda i: fitted[i][1] - fitted[i][0])
    info = {
        "epochs": int(ne),
        "not_fixed": int(np.sum(fk != 4)) if fk is not None else 0,
        "filled_rows": int(filled.sum()),
        "downweighted": int(np.sum(rw < 0.1)),
        # outside the --segment spans when they are given; of the longest track segment when split
        "lambda": [float(v) for v in fits[main].lam],
        "penalty": [float(v) for v in fits[main].penalty],  # alpha = (1 - lambda) / lambda [s^3/m, weights in 1/m]
        "segments": len(fitted),
        "breaks": [[float(tk[j]), float(tk[j + 1])] for j in brk],
    }
    return TrackResult(cols, fits[main].lam, info, warnings)


VERTICAL_WINDOW = 10.0  # [s] the height's smoothing window for speed and distance on consumer tracks


def _consumer_speed_distance(
    spline, t0: float, t1: float, tr: np.ndarray, d1: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Speed [m/s] and distance from ``t0`` [m] at the rows ``tr`` of one segment of a consumer track.

    The horizontal part is the spline's own (``vx vy``, its horizontal arc length); the vertical part is the
    spline's height smoothed by a Gaussian of standard deviation ``VERTICAL_WINDOW / 4`` (a window of about
    ``VERTICAL_WINDOW`` seconds) on a 0.5 s grid: a phone's or watch's height wiggles by metres from fix to
    fix, and that wiggle is not distance travelled (it inflated the 3-D distance of a 1 Hz phone track by
    9 %, 22 % with GCV); a ski run's descent, over tens of seconds, is kept.  ``z`` and ``vz`` themselves stay
    the spline's.
    """
    from scipy.ndimage import gaussian_filter1d

    from sportfusion.estimators.spline import NaturalCubicSpline

    grid = np.arange(t0, t1, 0.5)
    grid = np.r_[grid, t1] if grid.size == 0 or grid[-1] < t1 else grid
    z = spline.evaluate(grid)[0][:, 2]
    zs = gaussian_filter1d(z, VERTICAL_WINDOW / 4 / 0.5, mode="nearest") if grid.size > 2 else z
    vzs = np.gradient(zs, grid) if grid.size > 1 else np.zeros(1)
    horiz = NaturalCubicSpline(spline.t, spline.g[:, :2], spline.gamma[:, :2])
    h_arc = horiz.arc_length(tr)
    z_at = np.interp(tr, grid, zs)
    step = np.sqrt(np.diff(h_arc) ** 2 + np.diff(z_at) ** 2)
    dist = np.r_[0.0, np.cumsum(step)] + (h_arc[0] if tr.size else 0.0)
    speed = np.sqrt(d1[:, 0] ** 2 + d1[:, 1] ** 2 + np.interp(tr, grid, vzs) ** 2)
    return speed, dist


def _fit_axes(t, y, w, lams, segments, sigma):
    """:func:`smoothing_spline` of each column with its own lambda, assembled into one fit."""
    from sportfusion.estimators.spline import NaturalCubicSpline, SplineFit

    parts = [
        smoothing_spline(t, y[:, c], w[:, c], lams[c], segments=segments, sigma=None if sigma is None else sigma[:, c])
        for c in range(y.shape[1])
    ]
    std = None if any(p.std is None for p in parts) else np.column_stack([p.std[:, 0] for p in parts])
    return SplineFit(
        NaturalCubicSpline(t, np.column_stack([p.spline.g[:, 0] for p in parts]),
                           np.column_stack([p.spline.gamma[:, 0] for p in parts])),
        np.array([p.lam[0] for p in parts]),
        np.array([p.penalty[0] for p in parts]),
        std,
    )  # fmt: skip


def _describe_gap(t0: float, t1: float, epoch_utc: float | None) -> str:
    """``"t 120.0-3720.5 s (1.0 h, from 2026-01-02 10:00:00 UTC)"`` for a gap from t0 to t1 [s]."""
    d = t1 - t0
    size = (
        f"{d:.1f} s"
        if d < 120
        else (f"{d / 60:.1f} min" if d < 7200 else (f"{d / 3600:.1f} h" if d < 172800 else f"{d / 86400:.1f} d"))
    )
    text = f"t {t0:.1f}-{t1:.1f} s ({size}"
    if epoch_utc is not None and np.isfinite(epoch_utc):
        from datetime import UTC, datetime

        try:
            text += ", from " + datetime.fromtimestamp(epoch_utc + t0, UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
        except (OverflowError, OSError, ValueError):
            pass
    return text + ")"


def _segment_std(
    fit,
    tk: np.ndarray,
    yk: np.ndarray,
    t: np.ndarray,
    rows: np.ndarray | slice,
    has: np.ndarray,
    in_gap: np.ndarray,
    step: float,
) -> dict[str, np.ndarray]:
    """std_x/y/z at ``rows`` of one track segment: the propagated noise, and inside its gaps the bridge error."""
    edge = _at_rows(fit.std, tk, t, rows, has)
    g = in_gap[rows]
    inside_gap = None
    if g.any():
        big = np.flatnonzero(np.diff(tk) > GAP_FACTOR * step)
        gaps = [(float(tk[j]), float(tk[j + 1])) for j in big]
        # inside a gap the noise std is floored at the fit's residual RMS (the track's own error level)
        # (the spline's values at the knots are its knot values g: no evaluation needed)
        resid = np.sqrt(np.mean((fit.spline.g - yk) ** 2, axis=0))
        inside_gap = gap_std(fit.spline, tk, gaps, t[rows], np.maximum(edge, resid))
    out = {}
    for i, a in enumerate("xyz"):
        s = edge[:, i]
        if inside_gap is not None:
            s = s.copy()
            s[g] = inside_gap[g, i]
        out[f"std_{a}"] = s
    return out


def _at_rows(
    values: np.ndarray, tk: np.ndarray, t: np.ndarray, rows: np.ndarray | slice, has: np.ndarray
) -> np.ndarray:
    """``values`` (n_epochs, d) given at the epochs ``tk`` [s], linearly interpolated to the rows ``t[rows]``
    (``rows`` indices or a slice).

    Equal to :func:`numpy.interp` per column; rows that are epochs (``has``) take their epoch's value
    directly and only the others are interpolated (on a GNSS-only table nothing is).
    """
    ep = has[rows]
    if ep.all() and ep.size == tk.size:
        return values
    tr = t[rows]
    out = np.empty((ep.size, values.shape[1]))
    out[ep] = values[np.searchsorted(tk, tr[ep])]
    other = tr[~ep]
    for c in range(values.shape[1]):
        out[~ep, c] = np.interp(other, tk, values[:, c])
    return out


def smooth_session(table: pa.Table, meta: dict, **options: object) -> TrackResult:
    """:func:`smooth_track` on a session table: reads the columns, returns the columns to add.

    Needs ``gnss_x gnss_y gnss_z`` (from ``gps2hill``); uses ``gnss_fix`` and the
    sigmas ``std_gnss_*`` (else ``gnss_sigma_h``/``gnss_sigma_v``, a fix without
    either taking ``HDOP_SIGMA`` (3 m) x ``gnss_hdop`` horizontally and 1.5 times
    that vertically) when present,
    and the frame azimuth from the metadata.  ``options`` are those of
    :func:`smooth_track` except the arrays and ``azimuth_deg``.
    """
    from sportfusion.core.schema import float_columns, floats

    names = table.column_names
    need = ("gnss_x", "gnss_y", "gnss_z")
    missing = [c for c in need if c not in names]
    if missing:
        raise InputError(
            f"missing column(s) {', '.join(missing)}: spline-smooth needs the GNSS track in the local frame; "
            "run gps2hill first"
        )
    t = floats(table, "t")
    pos = float_columns(table, need)
    fix = floats(table, "gnss_fix") if "gnss_fix" in names else None
    sigma = None
    if all(f"std_gnss_{a}" in names for a in "xyz"):
        sigma = float_columns(table, [f"std_gnss_{a}" for a in "xyz"])
    elif "gnss_sigma_h" in names:
        sh = floats(table, "gnss_sigma_h")
        sv = floats(table, "gnss_sigma_v") if "gnss_sigma_v" in names else sh
        if "gnss_hdop" in names:  # fixes without a stated accuracy take it from their HDOP
            hd = floats(table, "gnss_hdop") * HDOP_SIGMA
            sh = np.where(np.isfinite(sh), sh, hd)
            sv = np.where(np.isfinite(sv), sv, hd * VDOP_RATIO)
        sigma = np.column_stack((sh, sh, sv))
    elif "gnss_hdop" in names and np.isfinite(floats(table, "gnss_hdop")).any():
        sh = floats(table, "gnss_hdop") * HDOP_SIGMA
        sigma = np.column_stack((sh, sh, sh * VDOP_RATIO))
    azimuth = float((meta.get("frame") or {}).get("azimuth_deg", 0.0))
    epoch = epoch_unix(meta)
    vel = speed = None
    if "vel_n" in names and "vel_e" in names:
        vd = floats(table, "vel_d") if "vel_d" in names else np.full(t.size, np.nan)
        ned = np.column_stack((floats(table, "vel_n"), floats(table, "vel_e"), np.nan_to_num(vd)))
        vel = ned_to_local(ned, azimuth)  # rotation about the vertical: vel_d stays the z component
        vel[~np.isfinite(vd), 2] = np.nan
    if "gnss_speed" in names:
        speed = floats(table, "gnss_speed")
    flat = not np.isfinite(pos[:, 2]).any() and (np.isfinite(pos[:, 0]) & np.isfinite(pos[:, 1])).any()
    if not flat:
        return smooth_track(t, pos, fix, sigma, azimuth_deg=azimuth, vel=vel, speed=speed, epoch_utc=epoch, **options)  # type: ignore[arg-type]
    # a 2-D track (gps2hill: no height, gnss_z null): smooth x and y on a flat z, leave every z output null
    pos = pos.copy()
    pos[:, 2] = np.where(np.isfinite(pos[:, 0]), 0.0, np.nan)
    if sigma is not None:
        sigma = sigma.copy()
        sigma[:, 2] = np.where(np.isfinite(sigma[:, 0]), sigma[:, 0], np.nan)
    if vel is not None:
        vel[:, 2] = np.nan  # no height: the velocity screen works in x/y
    res = smooth_track(t, pos, fix, sigma, azimuth_deg=azimuth, vel=vel, speed=speed, epoch_utc=epoch, **options)  # type: ignore[arg-type]
    for c in ("z", "vz", "az", "std_z"):
        if c in res.columns:
            res.columns[c] = np.full(len(t), np.nan)
    res.warnings.append("a 2-D track (gnss_z null): z, vz, az left null; speed and distance are horizontal")
    return res
