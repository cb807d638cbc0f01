"""Robust (outlier-resistant) weights for the smoothing spline of a GNSS track.

Phones and watches report single fixes, or a few in a row, tens of metres
off (multipath, a switch of satellite set), often at a standstill.  A
smoothing spline that nearly interpolates follows such a jump and turns it
into a speed of 30 m/s or more.  Two screens, both measured against each
fix's own 1-sigma, give every epoch a robust weight in [0, 1] that
multiplies its eq-6 weight:

1. **Leave-one-out residuals of the spline** (iteratively reweighted).  For a
   linear smoother ``g = H y`` the leave-one-out residual is
   ``e_i = (y_i - g_i) / (1 - H_ii)`` exactly; ``H_ii = w_i [(W + K)^-1]_ii``
   comes from the same O(n) banded recursion as the spline's 1-sigma.  A fix
   that disagrees with the curve through its neighbours gets a large ``e_i``
   even when the spline itself bends to meet it.
2. **The receiver's own velocity** (``vel_n vel_e [vel_d]``, Doppler: far
   better than differenced fixes).  The track integrated from the velocity,
   ``P(t_i) = sum (v_{k-1} + v_k)/2 dt_k``, is smooth and accurate over tens
   of seconds; ``D_i = y_i - P(t_i)`` is then a slow drift plus the fix noise,
   and a jump -- one fix or a plateau of several -- stands out of the running
   median of ``D`` over ``window`` seconds.  With only the receiver's speed
   (``gnss_speed``, no direction), a fix whose distance to *both* neighbours
   exceeds what that speed allows (plus 4 sigma) is a spike.

The standardised residual is ``z_i = |e_i| / s_i`` (3-D norm over
``sqrt(d)``) with ``s_i`` the largest of the fix's stated sigma, the
robust spread (1.4826 MAD) of the residuals and ``floor`` (1 m), so a
receiver with optimistic sigmas is not punished for its ordinary noise and
an RTK track's decimetre float offsets and gap edges are left to eq 6.  The weight is exactly 1
for ``z <= 2.5`` (a fix consistent with its neighbours: on clean data the fit is the plain
weighted smoothing spline, so ``--lambda gcv`` is Woltring's GCVSPL), then a biweight of the
excess, ``(1 - ((z - 2.5)/(c - 2.5))^2)^2`` for ``z < c`` (``c = 4.685``), else ``floor``
(never 0, the spline needs positive weights).
Velocity and speed screens only ever lower a weight.
"""

from __future__ import annotations

import numpy as np

from sportfusion.core.stats import median
from sportfusion.estimators import _banded
from sportfusion.estimators.spline import _minv_diag, _validated, penalty_from_lambda, smoothing_spline

TUKEY_C = 4.685
#: standardised residuals up to this are consistent with the neighbours: weight exactly 1
FLAT = 2.5


def tukey(z: np.ndarray, c: float = TUKEY_C, floor: float = 1e-6, flat: float = FLAT) -> np.ndarray:
    """Flat-topped biweight of standardised residuals ``z`` (>= ``floor``).

    Exactly 1 for ``|z| <= flat`` (a fix consistent with its neighbours keeps its weight: the spline of
    clean data is the plain weighted smoothing spline, to the last bit), then Tukey's biweight of the
    excess, ``(1 - ((|z| - flat) / (c - flat))^2)^2``, reaching ``floor`` at ``|z| >= c``.
    """
    e = np.maximum(np.abs(np.asarray(z, float)) - flat, 0.0) / (c - flat)
    return np.maximum(np.where(e < 1, (1 - e * e) ** 2, 0.0), floor)


def _scale(e: np.ndarray, sigma: np.ndarray | None, floor: float) -> np.ndarray:
    """Per-epoch, per-axis scale: max(stated sigma, 1.4826 MAD of the residuals, floor)."""
    mad = 1.4826 * median(np.abs(e - median(e, axis=0)), axis=0)
    mad = np.maximum(mad, max(floor, 1e-9))
    s = np.broadcast_to(mad, e.shape).copy()
    if sigma is not None:
        sg = np.asarray(sigma, float).reshape(e.shape[0], -1)
        sg = np.broadcast_to(sg, e.shape)
        s = np.where(np.isfinite(sg) & (sg > s), sg, s)
    return s


def _z(e: np.ndarray, sigma: np.ndarray | None, floor: float) -> np.ndarray:
    return np.sqrt(np.mean((e / _scale(e, sigma, floor)) ** 2, axis=1))


def _weights(e: np.ndarray, sigma: np.ndarray | None, floor: float, c: float) -> np.ndarray:
    """``tukey(_z(e, sigma, floor), c)``, the same weights.

    Every scale is at least ``max(floor, 1e-9)``: residuals all below ``FLAT`` times that (by a margin far
    beyond rounding) give ``z < FLAT`` and a weight of exactly 1 everywhere, known without the medians (an RTK
    track: centimetre residuals against a 1 m floor).
    """
    big = max(float(e.max()), -float(e.min())) if e.size else 0.0  # NaN: the comparison fails
    if big < FLAT * max(floor, 1e-9) * (1.0 - 1e-9):
        return np.ones(e.shape[0])
    return tukey(_z(e, sigma, floor), c)


def loo_residuals(t: np.ndarray, y: np.ndarray, w: np.ndarray, lam: float, power: float = 1.0) -> np.ndarray:
    """Leave-one-out residuals ``(y - S(t)) / (1 - H_ii)^power`` of the smoothing spline, per column.

    Parameters
    ----------
    t : (n,) epoch times [s]; y : (n, d) observations [m]; w : (n, d) weights [1/m]; lam : smoothing factor.
    power : 1 gives the leave-one-out residual, 0.5 the studentised one.
    """
    return _loo_fit(t, y, w, lam, power)[0]


def _loo_fit(
    t: np.ndarray, y: np.ndarray, w: np.ndarray, lam: float, power: float = 1.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`loo_residuals` and the spline's knot values and second derivatives ``(e, g, gamma)``, each (n, d).

    In C the fit and the hat diagonal ``w_i [(W + K)^-1]_ii`` come from one factorization per weight vector;
    else (or where that factorization fails) :func:`smoothing_spline` and ``_minv_diag``: the same numbers.
    """
    alpha = penalty_from_lambda(float(lam))
    t, y2, h, W = _validated(t, y, w)
    n, d = y2.shape
    if n >= 4 and np.isfinite(alpha) and _banded.native() is not None:
        same = bool(np.all(W == W[:, :1]))
        parts = []
        for c in range(1 if same else d):
            res = _banded.reinsch(h, 1.0 / W[:, c], alpha, y2 if same else y2[:, c : c + 1], diag=True)
            if res is None:  # lost positive definiteness: the KKT solve below
                break
            parts.append((res[0], res[1], W[:, c : c + 1] * res[2][:, None]))
        else:
            g, gam, den = parts[0] if same else (np.hstack(q) for q in zip(*parts, strict=True))
            np.maximum(np.subtract(1.0, den, out=den), 1e-9, out=den)  # 1 - H_ii, in place (as below)
            e = np.subtract(y2, g)
            e /= den if power == 1.0 else den**power
            return e, g, gam
    fit = smoothing_spline(t, y2, W, lam)
    g, gam = fit.spline.g, fit.spline.gamma
    r = y2 - g
    if not np.isfinite(alpha) or n < 4:
        return r, g, gam
    e = np.empty_like(r)
    hii = np.zeros(n)
    for c in range(d):
        if not (c and np.array_equal(W[:, c], W[:, c - 1])):  # same weights: same hat diagonal
            hii = np.real(W[:, c] * _minv_diag(h, W[:, c], alpha))
        e[:, c] = r[:, c] / np.maximum(1.0 - hii, 1e-9) ** power
    return e, g, gam


def velocity_residuals(t: np.ndarray, y: np.ndarray, vel: np.ndarray, window: float = 20.0) -> np.ndarray:
    """Fix minus the velocity-integrated track, minus the running median of that difference [m].

    ``vel`` is (n, k) in the axes of the first k columns of ``y`` (NaN where
    unknown: those epochs get residual 0).  ``window`` [s] is the running
    median's width: plateaus of bad fixes shorter than half of it are found.
    """
    n, k = t.size, vel.shape[1]
    out = np.zeros((n, y.shape[1]))
    ok = np.isfinite(vel).all(axis=1)
    if ok.sum() < 4:
        return out
    idx = np.flatnonzero(ok)
    tv, v = t[idx], vel[idx]
    steps = 0.5 * (v[1:] + v[:-1]) * np.diff(tv)[:, None]
    p = np.vstack([np.zeros((1, k)), np.cumsum(steps, axis=0)])
    d = y[idx, :k] - p
    half = 0.5 * window
    lo = np.searchsorted(tv, tv - half, side="left")
    hi = np.searchsorted(tv, tv + half, side="right")
    med = np.array([median(d[a:b], axis=0) for a, b in zip(lo, hi, strict=True)])
    out[idx, :k] = d - med
    return out


def _steps(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal step lengths [m] (``|y_{i+1} - y_i|`` of the first two columns) and durations [s], (n-1,) each."""
    dx, dy = np.diff(y[:, 0]), np.diff(y[:, 1])
    return np.sqrt(dx * dx + dy * dy), np.diff(t)


def _jumps(
    dist: np.ndarray, dt: np.ndarray, speed: np.ndarray | None, sigma: np.ndarray | None
) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray]:
    """The steps longer than the speed allows (:func:`speed_spikes`), with the valid speeds and ``vmax``.

    ``speed`` None: the fixes' own running-median speed (:func:`step_speed`).  A step no longer than
    ``dt + 4 sqrt(2) sigma`` (what a standstill allows; a speed only allows more) is no jump whatever the
    speed, so where the other steps are few the speed is first taken at their ends only, and computed for
    every epoch only when one of them is a jump (the stall screen then walks along it).  Returns
    ``(sp, vmax, jumps)``: the speed [m/s] per epoch (NaN where wrapped or invalid), the larger of the two
    speeds per step [m/s] (both None when there is no jump and they were not computed), and the indices of
    the jump steps.
    """
    n = dist.size + 1
    sg = np.full(n, np.nan) if sigma is None else np.asarray(sigma, float).reshape(n, -1)[:, 0]
    bad = ~(np.isfinite(sg) & (sg > 0))
    if bad.any():  # (the median only where something is filled)
        sg = np.where(bad, np.nanmedian(sg) if np.isfinite(sg).any() else 3.0, sg)
    slack = 4.0 * np.sqrt(2.0) * np.fmax(sg[1:], sg[:-1])

    def valid(s: np.ndarray) -> np.ndarray:  # a wrapped or invalid value is no speed
        return np.where((s >= 0) & (s < 150.0), s, np.nan)

    def jump(vmax: np.ndarray, i: np.ndarray | slice) -> np.ndarray:
        return np.isfinite(vmax) & (dist[i] > vmax * dt[i] * 1.2 + 1.0 * dt[i] + slack[i])

    if speed is None:
        cand = np.flatnonzero(dist > dt + slack)  # (the speed term of `jump` is >= 0)
        if not cand.size:
            return None, None, cand
        v = _step_speeds(dist, dt)
        if 128 * cand.size < n:
            ends = np.union1d(cand, cand + 1)
            sp = valid(_running_median_at(v, ends, 15))
            if not jump(np.fmax(sp[np.searchsorted(ends, cand + 1)], sp[np.searchsorted(ends, cand)]), cand).any():
                return None, None, np.empty(0, np.intp)
        speed = _running_median(v, 15)
    sp = valid(np.asarray(speed, float))
    vmax = np.fmax(sp[1:], sp[:-1])
    return sp, vmax, np.flatnonzero(jump(vmax, slice(None)))


def speed_spikes(
    t: np.ndarray, y: np.ndarray, speed: np.ndarray, sigma: np.ndarray | None, max_run: int = 10
) -> np.ndarray:
    """Boolean (n,): fixes that jumped away and back faster than the receiver's speed allows.

    An interval is a jump when the horizontal distance between its fixes
    exceeds ``max(speed_a, speed_b) dt 1.2 + 1 m/s dt + 4 sqrt(2) sigma``.  A
    jump out and a jump back at most ``max_run`` epochs later whose excess
    displacements (the displacement minus the median of the neighbouring
    intervals' displacements) cancel to within half of the larger one enclose
    a run of bad fixes (one fix: a spike; several: a plateau).
    """
    if t.size < 3:
        return np.zeros(t.size, bool)
    dist, dt = _steps(t, y)
    return _spikes(y, _jumps(dist, dt, speed, sigma)[2], max_run)


def _spikes(y: np.ndarray, jumps: np.ndarray, max_run: int) -> np.ndarray:
    """:func:`speed_spikes` from the jump steps (:func:`_jumps`)."""
    n = y.shape[0]
    bad = np.zeros(n, bool)
    if jumps.size < 2:
        return bad

    def step(i: np.ndarray | int) -> np.ndarray:
        return y[np.add(i, 1), :2] - y[i, :2]

    ok = np.ones(n - 1, bool)
    ok[jumps] = False
    used = np.zeros(n - 1, bool)
    for ia, a in enumerate(jumps):
        if used[a]:
            continue
        for b in jumps[ia + 1 :]:
            if b - a > max_run:
                break
            if used[b]:
                continue
            near = np.r_[max(a - 3, 0) : a, b + 1 : min(b + 4, n - 1)]
            near = near[ok[near]]
            expect = median(step(near), axis=0) if near.size else np.zeros(2)
            ja, jb = step(a) - expect, step(b) - expect
            if np.linalg.norm(ja + jb) < 0.5 * max(np.linalg.norm(ja), np.linalg.norm(jb)):
                bad[a + 1 : b + 1] = True
                used[a] = used[b] = True
                break
    return bad


def _running_median_py(v: np.ndarray, half: int) -> np.ndarray:
    """The median of the non-NaN ``v[j]``, ``|j - i| <= half``, for each ``i`` (the window shrinks at the ends):
    the reference for the C kernel ``_banded_c.running_median``, which runs where it is built."""
    if not np.isfinite(v).all():  # a missing fix: the median of the finite steps in each window
        from numpy.lib.stride_tricks import sliding_window_view

        pad = np.r_[np.full(half, np.nan), v, np.full(half, np.nan)]
        return np.nanmedian(sliding_window_view(pad, 2 * half + 1), axis=1)
    from scipy.ndimage import median_filter

    # the same medians as the padded nanmedian above (tested) at 2 % of its cost: scipy's running median
    # inside, the shrinking windows at the ends by hand
    n = v.size
    out = median_filter(v, size=2 * half + 1, mode="nearest")
    for i in (*range(min(half, n)), *range(max(n - half, half), n)):
        out[i] = np.median(v[max(i - half, 0) : i + half + 1])
    return out


def _running_median(v: np.ndarray, half: int) -> np.ndarray:
    out = _banded.running_median(v, half)
    return out if out is not None else _running_median_py(v, half)


def _running_median_at(v: np.ndarray, idx: np.ndarray, half: int) -> np.ndarray:
    """``_running_median(v, half)[idx]``, each value from its own window only (for a few epochs)."""
    out = np.empty(idx.size)
    for j, i in enumerate(idx):
        lo = max(i - half, 0)
        out[j] = _running_median(v[lo : i + half + 1], half)[i - lo]
    return out


def _step_speeds(dist: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """Per epoch, the horizontal step speed [m/s] of the step ending at it (the first epoch: its following one)."""
    v = dist / dt
    return np.r_[v[0], v]


def step_speed(t: np.ndarray, y: np.ndarray, window: int = 31) -> np.ndarray:
    """Speed over ground [m/s] estimated from the fixes alone: the running median (over ``window`` epochs)
    of the horizontal step speeds ``|y_{i+1} - y_i| / dt``, one value per epoch.

    A run of bad fixes shorter than half the window (a plateau of jumped fixes, a stall) moves the median
    little, so the out-and-back and catch-up screens get a speed where the receiver reports none.
    """
    if t.size < 3:
        return np.full(t.size, np.nan)
    return _running_median(_step_speeds(*_steps(t, y)), max(window // 2, 1))


def stall_fixes(t: np.ndarray, y: np.ndarray, speed: np.ndarray, sigma: np.ndarray | None) -> np.ndarray:
    """Boolean (n,): fixes frozen during a stall that a catch-up step then ends.

    A watch or phone that loses its fix keeps reporting the last position for some seconds while the
    athlete moves on, then jumps to the true position (60 m in one second after a 13 s stall).  A
    *catch-up* is a step longer than the speed allows (as in :func:`speed_spikes`); the fixes before it
    whose own steps repeated the position (under 5 cm) or moved less than a third of what the speed says
    (``speed dt > 1 m``) are the frozen ones, flagged when the speed integrated over them and the step is
    at least half the step (the step catches up what the stall missed; a stall that ends in a stop is
    caught too).  A real stop, or a stop without a catch-up step, is left alone.
    """
    if t.size < 3:
        return np.zeros(t.size, bool)
    dist, dt = _steps(t, y)
    return _stalls(dist, dt, *_jumps(dist, dt, speed, sigma))


def _stalls(
    dist: np.ndarray, dt: np.ndarray, sp: np.ndarray | None, vmax: np.ndarray | None, jumps: np.ndarray
) -> np.ndarray:
    """:func:`stall_fixes` from the steps (:func:`_steps`) and the jumps (:func:`_jumps`)."""
    bad = np.zeros(dist.size + 1, bool)
    if not jumps.size or sp is None or vmax is None:
        return bad
    expect = vmax * dt
    # a frozen step: the position repeated (a stall repeats the last fix), or far less than the speed says
    frozen = (dist < 0.05) | (np.isfinite(expect) & (expect > 1.0) & (dist < expect / 3.0))
    travel = np.nan_to_num(0.5 * (sp[1:] + sp[:-1])) * dt
    for a in jumps:
        i = a
        while i > 0 and frozen[i - 1]:
            i -= 1
        # the catch-up step must be what the speed says the frozen stretch travelled (a stall that ends in a
        # stop is caught too; a jump with no frozen stretch before it is left to the other screens)
        if i < a and travel[i : a + 1].sum() > 0.5 * dist[a]:
            bad[i + 1 : a + 1] = True
    return bad


def robust_weights(
    t: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    lam: float,
    sigma: np.ndarray | None = None,
    *,
    vel: np.ndarray | None = None,
    speed: np.ndarray | None = None,
    iterations: int = 4,
    c: float = TUKEY_C,
    window: float = 20.0,
    floor: float = 1.0,
) -> np.ndarray:
    """Robust weight in (0, 1] per epoch (see the module text); multiply the spline weights by it.

    Parameters
    ----------
    t : (n,) epoch times [s].
    y : (n, d) positions in a local frame [m] (x, y horizontal first when ``vel``/``speed`` are given).
    w : (n, d) spline weights [1/m].
    lam : the smoothing factor used for the spline.
    sigma : (n,) or (n, d) stated 1-sigma of the fixes [m], or None.
    vel : (n, k) receiver velocity in the axes of ``y[:, :k]`` [m/s] (NaN where absent), or None.
    speed : (n,) receiver speed over ground [m/s] (NaN where absent), or None.
    iterations : reweighting passes of the leave-one-out screen.
    c : Tukey constant [robust sigmas].
    window : running-median width of the velocity screen [s].
    floor : smallest scale [m]: a fix within ``c * floor`` of its neighbours' curve is never weighted
        down, so an RTK track (cm sigmas) keeps its float epochs (eq 6 weighs those) and its gap edges.
    """
    return robust_fit(
        t, y, w, lam, sigma, vel=vel, speed=speed, iterations=iterations, c=c, window=window, floor=floor
    )[0]


def robust_fit(
    t: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    lam: float,
    sigma: np.ndarray | None = None,
    *,
    vel: np.ndarray | None = None,
    speed: np.ndarray | None = None,
    iterations: int = 4,
    c: float = TUKEY_C,
    window: float = 20.0,
    floor: float = 1.0,
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """:func:`robust_weights` (same parameters), and the spline that the final weights give when it is known.

    Returns
    -------
    weights : (n,) robust weight in (0, 1] per epoch.
    knots : ``(g, gamma)``, each (n, d), or None
        Knot values and second derivatives of the smoothing spline with weights ``w * weights[:, None]``
        and ``lam`` when the last reweighting pass fitted it with exactly those weights (on a track whose
        fixes all agree with their neighbours, the first pass): pass it to :func:`smoothing_spline` as
        ``knots`` instead of solving it again.
    """
    n = t.size
    base = np.ones(n)
    if n < 5:
        return base, None
    if vel is not None and np.isfinite(vel).all(axis=1).sum() >= 4:
        base = np.minimum(base, _weights(velocity_residuals(t, y, vel, window), sigma, floor, c))
    sp = None if speed is None or not np.isfinite(speed).any() else np.asarray(speed, float)
    if sp is None and vel is not None and np.isfinite(vel[:, :2]).all(axis=1).sum() >= 4:
        sp = np.linalg.norm(vel[:, :2], axis=1)
    # without a receiver speed (sp None) the fixes' own running-median speed (plateaus, catch-up steps)
    dist, dt = _steps(t, y)  # (shared by the three screens)
    spv, vmax, jumps = _jumps(dist, dt, sp, sigma)
    base[_spikes(y, jumps, 10)] = 1e-6
    base[_stalls(dist, dt, spv, vmax, jumps)] = 1e-6
    del dist, dt, spv, vmax  # (8 MB each at 1e6 epochs)
    loo = np.ones(n)
    for _ in range(iterations):
        used = base * loo
        e, g, gam = _loo_fit(t, y, w if used.min() == 1.0 else w * used[:, None], lam)  # (w times 1: w)
        new = _weights(e, sigma, floor, c)
        done = (new.min() == 1.0 and loo.min() == 1.0) or np.allclose(new, loo, atol=1e-3)  # (all 1: the same)
        loo = new
        if done:
            break
    out = np.maximum(base * loo, 1e-6)
    return out, ((g, gam) if np.array_equal(used, out) else None)
