"""The per-turn figures of the gates paper's Table 2 from a trajectory and its crossings (``gate-anchor``)."""

from __future__ import annotations

from typing import Any

import numpy as np


def _interp(tg: np.ndarray, x: np.ndarray, tq: np.ndarray) -> np.ndarray:
    return np.stack([np.interp(tq, tg, x[:, j]) for j in range(x.shape[1])], axis=-1)


def turn_figures(
    tg: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    acc: np.ndarray,
    cross_t: np.ndarray,
    ids: np.ndarray,
    survey: np.ndarray,
    gate_numbers: np.ndarray,
    signal: np.ndarray | None = None,
) -> list[dict[str, Any]]:
    """Per-turn figures (paper Table 2) for every matched crossing with a crossing before and after it.

    A turn runs from the switch before its gate to the switch after it; a switch is the sign change of
    ``signal`` (default: the course rate ``(vx ay - vy ax) / (vx^2 + vy^2)``; with a body the ankle criterion
    of :func:`sportfusion.gates.com.ankle_switch_signal`) between two consecutive crossings nearest the
    middle of the interval.  Returns dicts with ``gate``, ``t_in``, ``t_out`` [s], ``v_in``, ``v_out`` [m/s] (speed
    at the switches), ``d_in``, ``d_out`` (3-D distance from the sacrum at the switches to the gate's
    magnet), ``d_cross`` (at the crossing) and ``length`` (3-D path length from switch to switch) [m].
    """
    rate = (
        signal
        if signal is not None
        else (vel[:, 0] * acc[:, 1] - vel[:, 1] * acc[:, 0]) / np.maximum(vel[:, 0] ** 2 + vel[:, 1] ** 2, 1.0)
    )
    order = np.argsort(cross_t)
    ct = cross_t[order]

    def switch(a: float, b: float) -> float | None:
        w = np.flatnonzero((tg > a) & (tg < b))
        if w.size < 3:
            return None
        s = np.sign(rate[w])
        ch = np.flatnonzero(s[1:] != s[:-1])
        if ch.size == 0:
            return None
        mid = 0.5 * (a + b)
        j = ch[np.argmin(np.abs(tg[w[ch]] - mid))]
        i0, i1 = w[j], w[j + 1]
        r0, r1 = rate[i0], rate[i1]
        f = r0 / (r0 - r1) if r0 != r1 else 0.5
        return float(tg[i0] + f * (tg[i1] - tg[i0]))

    out = []
    for j in range(1, ct.size - 1):
        m = order[j]
        if ids[m] < 0:
            continue
        t_in, t_out = switch(ct[j - 1], ct[j]), switch(ct[j], ct[j + 1])
        if t_in is None or t_out is None:
            continue
        g = survey[ids[m]]
        pi, po, pc = (_interp(tg, pos, np.array([x]))[0] for x in (t_in, t_out, ct[j]))
        vi, vo = (np.linalg.norm(_interp(tg, vel, np.array([x]))[0]) for x in (t_in, t_out))
        seg = (tg > t_in) & (tg < t_out)
        path = np.vstack([pi, pos[seg], po])
        out.append(
            {
                "gate": int(gate_numbers[ids[m]]),
                "gate_xyz": [float(v) for v in g],
                "t_cross": float(ct[j]),
                "t_in": t_in,
                "t_out": t_out,
                "v_in": float(vi),
                "v_out": float(vo),
                "d_in": float(np.linalg.norm(pi - g)),
                "d_out": float(np.linalg.norm(po - g)),
                "d_cross": float(np.linalg.norm(pc - g)),
                "length": float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))),
            }
        )
    return out


__all__ = ["turn_figures"]
