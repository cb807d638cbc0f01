"""Fixed-step ODE integration for simulated truth: the same numbers on every numpy/scipy release.

An adaptive integrator (scipy's ``solve_ivp``) chooses its steps from error estimates whose last bits
change between releases; a simulated trajectory then moves by far more than those bits wherever a
root (an event: the take-off edge, the touch-down) or a planning search (the lift area for a jump
length) sits on top of it -- 2.5e-4 m/s^2 of specific force at a landing was seen between scipy
1.16 and 1.17.  :func:`solve_fixed` integrates with the classical fourth-order Runge-Kutta method on
a fixed step in plain Python floats, locates events on the step's cubic Hermite interpolant by
bisection to ``1e-12`` s, and offers a dense output (the same Hermite interpolant between the
nodes), so a truth built on it depends only on IEEE arithmetic and the platform's ``math`` library.

The global error of RK4 is ``O(h^4)``; with ``h = 1 ms`` and accelerations of a few hundred m/s^2
changing over 20 ms (a landing impact) it is far below a micrometre, and the Hermite interpolant
between the nodes is within ``h^4 max|y''''| / 384`` (a few nanometres).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

Rhs = Callable[[float, tuple[float, ...]], Sequence[float]]
Event = Callable[[float, tuple[float, ...]], float]


@dataclass
class EventSpec:
    """An event function ``g(t, y)`` [any unit] with the ``solve_ivp`` conventions.

    ``direction`` > 0: only rising zero crossings count, < 0: only falling, 0: both; ``terminal``: stop
    the integration at the first crossing.
    """

    fun: Event
    terminal: bool = False
    direction: float = 0.0


@dataclass
class FixedSolution:
    """Result of :func:`solve_fixed` (names as scipy's ``OdeResult`` where they mean the same).

    ``t`` (m,) node times [s], ``y`` (n, m) states, ``f`` (n, m) their derivatives, ``status`` 1 when a
    terminal event stopped the run, 0 when it reached the end; ``t_events[i]`` / ``y_events[i]`` the
    crossings of event ``i``.
    """

    t: np.ndarray
    y: np.ndarray
    f: np.ndarray
    status: int
    t_events: list[np.ndarray] = field(default_factory=list)
    y_events: list[np.ndarray] = field(default_factory=list)

    def sol(self, t: float | np.ndarray) -> np.ndarray:
        """Dense output: the cubic Hermite interpolant of the nodes at ``t`` (scalar -> (n,), array -> (n, k))."""
        tt = np.asarray(t, dtype=float)
        scalar = tt.ndim == 0
        tt = np.atleast_1d(tt)
        i = np.clip(np.searchsorted(self.t, tt, side="right") - 1, 0, self.t.size - 2)
        h = self.t[i + 1] - self.t[i]
        s = (tt - self.t[i]) / h
        h00 = (1 + 2 * s) * (1 - s) ** 2
        h10 = s * (1 - s) ** 2
        h01 = s * s * (3 - 2 * s)
        h11 = s * s * (s - 1)
        out = h00 * self.y[:, i] + h10 * h * self.f[:, i] + h01 * self.y[:, i + 1] + h11 * h * self.f[:, i + 1]
        return out[:, 0] if scalar else out


def _hermite(t0: float, y0: tuple, f0: tuple, t1: float, y1: tuple, f1: tuple, t: float) -> tuple[float, ...]:
    h = t1 - t0
    s = (t - t0) / h
    a, b = (1 + 2 * s) * (1 - s) ** 2, s * (1 - s) ** 2 * h
    c, d = s * s * (3 - 2 * s), s * s * (s - 1) * h
    return tuple(a * p + b * q + c * r + d * w for p, q, r, w in zip(y0, f0, y1, f1, strict=True))


def _rk4(rhs: Rhs, t: float, y: tuple[float, ...], f0: tuple[float, ...], h: float) -> tuple[float, ...]:
    h2 = 0.5 * h
    k2 = tuple(rhs(t + h2, tuple(a + h2 * b for a, b in zip(y, f0, strict=True))))
    k3 = tuple(rhs(t + h2, tuple(a + h2 * b for a, b in zip(y, k2, strict=True))))
    k4 = tuple(rhs(t + h, tuple(a + h * b for a, b in zip(y, k3, strict=True))))
    h6 = h / 6.0
    return tuple(a + h6 * (p + 2.0 * (q + r) + s) for a, p, q, r, s in zip(y, f0, k2, k3, k4, strict=True))


def solve_fixed(
    rhs: Rhs,
    t_span: tuple[float, float],
    y0: Sequence[float],
    h: float,
    events: Sequence[EventSpec] = (),
    event_tol: float = 1e-12,
) -> FixedSolution:
    """Integrate ``y' = rhs(t, y)`` from ``t_span[0]`` with classical RK4 on the fixed step ``h`` [s].

    Parameters
    ----------
    rhs : callable(t, y) -> sequence of float
        Right-hand side; ``y`` arrives as a tuple of Python floats.
    t_span : (t0, t1)
        Start and end time [s]; the last step is shortened to end on ``t1``.
    y0 : sequence of float
        Initial state.
    h : float
        Step [s].
    events : sequence of EventSpec
        Event functions, evaluated at every node; a crossing is located on the step's Hermite
        interpolant by bisection to ``event_tol`` [s].  A terminal event ends the solution there (its
        last node is the event).
    event_tol : float
        Time tolerance of the event location [s].

    Returns
    -------
    FixedSolution
    """
    t0, t1 = float(t_span[0]), float(t_span[1])
    y = tuple(float(v) for v in y0)
    f = tuple(float(v) for v in rhs(t0, y))
    ts, ys, fs = [t0], [y], [f]
    g_prev = [float(e.fun(t0, y)) for e in events]
    t_ev: list[list[float]] = [[] for _ in events]
    y_ev: list[list[tuple[float, ...]]] = [[] for _ in events]
    status = 0
    k = 0
    t = t0
    while t < t1 - 1e-15:
        k += 1
        t_new = min(t0 + k * h, t1)
        y_new = _rk4(rhs, t, y, f, t_new - t)
        f_new = tuple(float(v) for v in rhs(t_new, y_new))
        stop_at = None
        for i, e in enumerate(events):
            g = float(e.fun(t_new, y_new))
            gp = g_prev[i]
            crossed = (gp < 0.0 <= g and e.direction >= 0) or (gp > 0.0 >= g and e.direction <= 0)
            if crossed and not (gp == 0.0):
                lo, hi, glo = t, t_new, gp
                while hi - lo > event_tol:
                    mid = 0.5 * (lo + hi)
                    gm = float(e.fun(mid, _hermite(t, y, f, t_new, y_new, f_new, mid)))
                    if (gm < 0.0) == (glo < 0.0) and gm != 0.0:
                        lo, glo = mid, gm
                    else:
                        hi = mid
                te = hi
                ye = _hermite(t, y, f, t_new, y_new, f_new, te)
                t_ev[i].append(te)
                y_ev[i].append(ye)
                if e.terminal and (stop_at is None or te < stop_at[0]):
                    stop_at = (te, ye)
            g_prev[i] = g
        if stop_at is not None:
            te, ye = stop_at
            # the run ends on the event: a last (short) RK4 step from the node before it, so that the
            # final node is on the integrator's own path, not only on the interpolant
            if te - t > 1e-15:
                ye = _rk4(rhs, t, y, f, te - t)
                ts.append(te)
                ys.append(ye)
                fs.append(tuple(float(v) for v in rhs(te, ye)))
            status = 1
            # crossings after the terminal one (other events in the same step) are not kept
            for i in range(len(events)):
                keep = [j for j, tv in enumerate(t_ev[i]) if tv <= te]
                t_ev[i] = [t_ev[i][j] for j in keep]
                y_ev[i] = [y_ev[i][j] for j in keep]
            break
        t, y, f = t_new, y_new, f_new
        ts.append(t)
        ys.append(y)
        fs.append(f)
    n = len(y)
    return FixedSolution(
        t=np.array(ts),
        y=np.array(ys, dtype=float).reshape(-1, n).T,
        f=np.array(fs, dtype=float).reshape(-1, n).T,
        status=status,
        t_events=[np.array(v) for v in t_ev],
        y_events=[np.array(v, dtype=float).reshape(-1, n) for v in y_ev],
    )


def bisect_root(fun: Callable[[float], float], lo: float, hi: float, xtol: float, max_iter: int = 200) -> float:
    """A root of ``fun`` in ``[lo, hi]`` (a sign change required) by the Illinois false-position method.

    Deterministic (no library's stopping rule involved): it stops when the bracket is narrower than
    ``xtol``, two successive estimates are within ``xtol / 4``, or ``fun`` is exactly zero.  Raises
    ValueError without a sign change.
    """
    flo, fhi = fun(lo), fun(hi)
    if flo == 0.0:
        return lo
    if fhi == 0.0:
        return hi
    if (flo < 0.0) == (fhi < 0.0):
        raise ValueError("no sign change in the bracket")
    side = 0
    x_old = math.inf
    for _ in range(max_iter):
        if hi - lo < xtol:
            break
        x = (lo * fhi - hi * flo) / (fhi - flo)
        if not (lo < x < hi) or not math.isfinite(x):
            x = 0.5 * (lo + hi)
        fx = fun(x)
        if fx == 0.0 or abs(x - x_old) < 0.25 * xtol:
            return x
        x_old = x
        if (fx < 0.0) == (flo < 0.0):
            lo, flo = x, fx
            if side == -1:
                fhi *= 0.5
            side = -1
        else:
            hi, fhi = x, fx
            if side == 1:
                flo *= 0.5
            side = 1
    return 0.5 * (lo + hi)
