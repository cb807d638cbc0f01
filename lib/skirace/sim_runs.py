"""Two runs of one gated course with closed-form truth, for testing and benchmarking ``compare-runs``.

The course frame is x along the fall line, y right, z down [m].  Each run follows a sinusoidal line
``y = A sin(2 pi x / 50 m)`` down a 30 % slope (``z = 0.3 x``); the gates stand at the apexes
(``x = 12.5 m + 25 m k``, gates 1..12), the turn switches are the inflections (``x = 25 m k``).
Run ``"A"`` (the reference) takes ``A = 5 m``; run ``"B"`` a wider line (``A = 5.6 m``) and loses
:data:`SECTION_DT` [s] in each gate-to-gate section (a smootherstep in time within the section, so
speed and acceleration stay continuous).  Run A's time follows
``t = x / 15 + 0.3 sin(2 pi x / 130)`` [s]; B's clock starts 2.5 s later (only differences count).
Speeds reach ~20 m/s and lateral accelerations ~3 g at the apexes.

Truth (crossing times, arc lengths by ``scipy.integrate.quad``, speeds) comes from these closed forms,
independently of :mod:`sportfusion.skirace.compare`'s interpolation and quadrature.
"""

from __future__ import annotations

import numpy as np
import pyarrow as pa

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import schema

LAMBDA = 50.0  # turn wavelength along x [m]
SLOPE = 0.3  # dz/dx [1]
GATES_X = 12.5 + 25.0 * np.arange(12)  # apexes [m]
GATE_IDS = np.arange(1, 13)
SECTION_DT = np.array([0.05, -0.03, 0.12, 0.0, -0.08, 0.07, 0.02, -0.11, 0.04, 0.09, -0.02])  # B minus A [s]
AMP = {"A": 5.0, "B": 5.6}
FRAME = {"name": "course", "origin": [46.4975, 9.8365, 2200.0], "azimuth_deg": 160.0, "axes": "x forward"}


def _smooth(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Smootherstep and its derivative: speed and acceleration stay continuous across the gates."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u * u), 30 * u * u * (1 - u) ** 2


def timing(run: str, x: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Time on the run's clock [s] and dt/dx [s/m] at course position x [m]."""
    x = np.asarray(x, float)
    t = x / 15.0 + 0.3 * np.sin(2 * np.pi * x / 130.0)
    dt = 1 / 15.0 + 0.3 * 2 * np.pi / 130.0 * np.cos(2 * np.pi * x / 130.0)
    if run == "B":
        t = t + 2.5  # B's clock started elsewhere: only differences count
        for k, d in enumerate(SECTION_DT):
            a, b = GATES_X[k], GATES_X[k + 1]
            s, ds = _smooth((x - a) / (b - a))
            t = t + d * s
            dt = dt + d * ds / (b - a)
    return t, dt


def path(run: str, x: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Position [m] and d(position)/dx [1] of the run's line."""
    x = np.asarray(x, float)
    k = 2 * np.pi / LAMBDA
    a = AMP[run]
    p = np.stack([x, a * np.sin(k * x), SLOPE * x], axis=-1)
    dp = np.stack([np.ones_like(x), a * k * np.cos(k * x), np.full_like(x, SLOPE)], axis=-1)
    return p, dp


def arc(run: str, x0: float, x1: float) -> float:
    """Arc length [m] of the run's line between course positions x0 and x1 [m] (quad)."""
    from scipy.integrate import quad

    return quad(lambda x: float(np.linalg.norm(path(run, x)[1])), x0, x1, epsabs=1e-10, limit=200)[0]


def speed(run: str, x: float) -> float:
    """True speed [m/s] of the run at course position x [m]."""
    return float(np.linalg.norm(path(run, x)[1]) / timing(run, x)[1])


def x_at(run: str, t: np.ndarray) -> np.ndarray:
    """Invert the timing law (Newton on a dense-grid start)."""
    grid = np.linspace(0.0, 300.0, 30001)
    x = np.interp(t, timing(run, grid)[0], grid)
    for _ in range(6):
        tt, dt = timing(run, x)
        x = x - (tt - t) / dt
    return x


def run_table(
    run: str,
    *,
    rate: float = 20.0,
    events: bool = True,
    velocity: bool = True,
    gate_ids: np.ndarray = GATE_IDS,
    shift: tuple[float, float] = (0.0, 0.0),
) -> bytes:
    """A session table (Parquet bytes) of the run: x y z [m] (+ vx vy vz [m/s]) at ``rate`` [Hz] from x = 2 m to
    298 m, gate event rows (``gate_ids``) at the true crossings when ``events``; ``shift`` moves it in x, y [m]."""
    t0, t1 = timing(run, 2.0)[0], timing(run, 298.0)[0]
    t = np.arange(np.ceil(t0 * rate), np.floor(t1 * rate)) / rate
    x = x_at(run, t)
    p, dp = path(run, x)
    v = dp / timing(run, x)[1][:, None]
    p = p + np.array([shift[0], shift[1], 0.0])
    cols = {"t": t, "x": p[:, 0], "y": p[:, 1], "z": p[:, 2]}
    if velocity:
        cols.update(vx=v[:, 0], vy=v[:, 1], vz=v[:, 2])
    n = t.size
    ev = [None] * n
    gate = [None] * n
    if events:
        tg = timing(run, GATES_X)[0]
        cols = {k: np.concatenate([c, tg if k == "t" else np.full(tg.size, np.nan)]) for k, c in cols.items()}
        ev += ["gate"] * tg.size
        gate += [int(g) for g in gate_ids]
    order = np.argsort(cols["t"], kind="stable")
    arrays = {k: schema.numeric_array(c[order], np.isnan(c[order])) for k, c in cols.items()}
    if events:
        arrays["event"] = pa.array([ev[i] for i in order], type=pa.string())
        arrays["gate"] = pa.array([gate[i] for i in order], type=pa.int32())
    meta = sfmeta.new_meta("session", 1.77e9 + (0.0 if run == "A" else 3600.0))
    meta["frame"] = FRAME
    return sfio.table_to_bytes(pa.table(arrays), meta)


def gates_table(ids: np.ndarray = GATE_IDS) -> bytes:
    """A ``gates`` table (Parquet bytes): gate, x y z [m], 1.5 m outside run B's apexes (2.1 m outside A's)."""
    side = np.sign(np.sin(2 * np.pi * GATES_X / LAMBDA))
    y = side * (max(AMP.values()) + 1.5)  # outside of each turn
    table = pa.table(
        {
            "gate": pa.array(ids, type=pa.int32()),
            "x": GATES_X,
            "y": y,
            "z": SLOPE * GATES_X,
        }
    )
    meta = sfmeta.new_meta("gates")
    meta["frame"] = FRAME
    return sfio.table_to_bytes(table, meta)


def truth() -> tuple[np.ndarray, dict, dict, dict, dict, dict]:
    """Per-gate truth: accumulated time difference B - A [s]; per run: distance from gate 1 [m], speed at
    the gates [m/s], speed at the turn switch before / after each gate [m/s], turn path length [m]."""
    xs = GATES_X
    acc_dt = np.concatenate(([0.0], np.cumsum(SECTION_DT)))
    dist = {r: np.array([arc(r, xs[0], x) for x in xs]) for r in AMP}
    spd = {r: np.array([speed(r, x) for x in xs]) for r in AMP}
    inflect = np.arange(len(xs) + 1) * 25.0  # turn switches
    entry = {r: np.array([speed(r, x) for x in inflect[:-1]]) for r in AMP}
    exit_ = {r: np.array([speed(r, x) for x in inflect[1:]]) for r in AMP}
    length = {r: np.array([arc(r, a, b) for a, b in zip(inflect[:-1], inflect[1:], strict=True)]) for r in AMP}
    return acc_dt, dist, spd, entry, exit_, length
