"""1-sigma of a smoothing spline across a data gap, from the track's own behaviour.

Inside a gap (no epoch for many seconds: a GNSS outage) a smoothing spline is one
cubic: the Hermite cubic through the values and slopes at the gap's edges.  The
noise propagated from the epochs (:attr:`SplineFit.std`) says nothing about how
far the real track strays from that cubic -- over a 10 s gap of a ski race the
athlete makes several turns and the cubic misses them by metres.

Policy (issue 17): the std inside a gap of length ``L`` is estimated from the
same session.  Windows of length ``L`` are cut from the parts of the track that
have data (every ``L/4`` seconds); in each, the Hermite cubic through the
spline's values and slopes at the window's ends is compared with the spline
itself at fractions ``u`` of the window.  The RMS of that difference over the
windows, per axis and per ``u``, times ``safety`` (2: the edge slopes of a real
gap are less well determined than those of a window with data), combined with
the std at the edges (the propagated noise, at least the RMS residual of the
fit: the caller's floor), is the std inside the gap.  On simulated ski races
with an 8 s outage the truth lies within +-2 std on about 87 % of the bridged
rows (``bench/bench_faults.py``).  On a long session the windows are thinned
to :data:`MAX_WINDOWS` per gap length and profiles are computed for at most
:data:`MAX_LENGTHS` gap lengths, so the cost is linear in rows and gaps.  When
the session has no window of that length, a bound from the spline's RMS acceleration
``a_rms * s (L - s) / 2`` (``s`` the time into the gap) is used instead.
"""

from __future__ import annotations

import numpy as np

U = np.linspace(0.0, 1.0, 21)


#: at most this many validation windows per gap length (evenly spread over the session): the profile is an
#: RMS over windows, so a few thousand of them measure it as well as all; the cost no longer grows with the
#: session (issue 38: the whole session was scanned for every gap, quadratic on long sessions)
MAX_WINDOWS = 2000
#: at most this many distinct gap lengths get their own profile; beyond, profiles on a log-spaced grid of
#: lengths are interpolated (in log length) to each gap's length
MAX_LENGTHS = 24


def bridge_error_profile(
    spline,
    tk: np.ndarray,
    length: float,
    gaps: list[tuple[float, float]],
    safety: float = 2.0,
    max_windows: int = MAX_WINDOWS,
) -> np.ndarray:
    """RMS error (len(U), d) of a cubic bridge over ``length`` [s], at the fractions :data:`U` of the bridge.

    Parameters
    ----------
    spline : NaturalCubicSpline
        The fitted spline (``evaluate(t) -> (value, d1, d2)``).
    tk : ndarray
        The epoch times [s].
    length : float
        Gap length [s].
    gaps : list of (t0, t1)
        The session's gaps [s], in time order and not overlapping; validation windows never overlap them.
    safety : float
        Factor on the measured RMS.
    max_windows : int
        Most windows used (their stride grows beyond ``length / 4`` on long sessions): O(max_windows).
    """
    t0, t1 = float(tk[0]), float(tk[-1])
    span = t1 - length - t0
    stride = max(length / 4.0, 1e-3, span / max(max_windows, 1))
    starts = np.arange(t0, t1 - length, stride) if span > 0 else np.empty(0)
    if gaps and starts.size:
        ga = np.array([a for a, _ in gaps])
        gb = np.array([b for _, b in gaps])
        # window [s, s + L] overlaps gap (a, b) when s < b and s + L > a; the gaps are ordered and disjoint,
        # so only the last gap starting before the window's end can overlap it
        j = np.searchsorted(ga, starts + length, side="left") - 1
        hit = (j >= 0) & (gb[np.maximum(j, 0)] > starts)
        starts = starts[~hit]
    if starts.size == 0:
        _, _, acc = spline.evaluate(tk)
        a_rms = np.sqrt(np.mean(acc**2, axis=0))
        s = U * length
        return safety * np.outer(s * (length - s) / 2.0, a_rms)
    ends = starts + length
    p0, v0, _ = spline.evaluate(starts)
    p1, v1, _ = spline.evaluate(ends)
    tq = (starts[:, None] + U[None, :] * length).ravel()
    ref = spline.evaluate(tq)[0].reshape(starts.size, U.size, -1)
    u = U[None, :, None]
    h00 = 2 * u**3 - 3 * u**2 + 1
    h10 = u**3 - 2 * u**2 + u
    h01 = -2 * u**3 + 3 * u**2
    h11 = u**3 - u**2
    bridge = h00 * p0[:, None] + h10 * length * v0[:, None] + h01 * p1[:, None] + h11 * length * v1[:, None]
    return safety * np.sqrt(np.mean((bridge - ref) ** 2, axis=0))


def _profiles(spline, tk: np.ndarray, lengths: np.ndarray, gaps: list[tuple[float, float]], safety: float):
    """Bridge profile (len(U), d) for each of ``lengths`` [s]: exact for a few distinct lengths, else
    interpolated in log length between :data:`MAX_LENGTHS` profiles on a log-spaced grid."""
    distinct = np.unique(lengths)
    if distinct.size <= MAX_LENGTHS:
        prof = {float(L): bridge_error_profile(spline, tk, float(L), gaps, safety) for L in distinct}
        return [prof[float(L)] for L in lengths]
    grid = np.geomspace(distinct[0], distinct[-1], MAX_LENGTHS)
    table = np.stack([bridge_error_profile(spline, tk, float(L), gaps, safety) for L in grid])
    lg = np.log(grid)
    out = []
    for L in lengths:
        i = int(np.clip(np.searchsorted(lg, np.log(L)) - 1, 0, grid.size - 2))
        f = (np.log(L) - lg[i]) / (lg[i + 1] - lg[i])
        out.append((1 - f) * table[i] + f * table[i + 1])
    return out


def gap_std(
    spline,
    tk: np.ndarray,
    gaps: list[tuple[float, float]],
    tq: np.ndarray,
    edge_std: np.ndarray,
    safety: float = 2.0,
) -> np.ndarray:
    """1-sigma (len(tq), d) at times ``tq`` inside the ``gaps``; NaN for times outside every gap.

    ``edge_std`` (len(tq), d) is the noise std interpolated from the gap's edges; the result is
    ``sqrt(edge_std^2 + bridge^2)`` with the bridge profile of :func:`bridge_error_profile`.  The cost is
    linear in rows and gaps: the rows strictly inside a gap are one slice of the sorted ``tq``, and the
    profiles are computed for at most :data:`MAX_LENGTHS` gap lengths, on at most :data:`MAX_WINDOWS`
    windows each.
    """
    out = np.full(edge_std.shape, np.nan)
    gaps = sorted(gaps)
    ordered = tq.size < 2 or bool(np.all(tq[1:] >= tq[:-1]))
    order = None if ordered else np.argsort(tq, kind="stable")
    ts = tq if ordered else tq[order]
    lo = np.searchsorted(ts, [a for a, _ in gaps], side="right")
    hi = np.searchsorted(ts, [b for _, b in gaps], side="left")
    used = [i for i in range(len(gaps)) if lo[i] < hi[i]]
    if not used:
        return out
    profs = _profiles(spline, tk, np.array([gaps[i][1] - gaps[i][0] for i in used]), gaps, safety)
    for i, prof in zip(used, profs, strict=True):
        a, b = gaps[i]
        m = slice(int(lo[i]), int(hi[i])) if ordered else order[lo[i] : hi[i]]
        u = (tq[m] - a) / (b - a)
        br = np.stack([np.interp(u, U, prof[:, c]) for c in range(prof.shape[1])], axis=1)
        out[m] = np.sqrt(edge_std[m] ** 2 + br**2)
    return out
