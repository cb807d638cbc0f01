"""``jump-metrics``: per-jump figures from a smoothed ski-jump session (skijump §4.4).

For every (take-off, touch-down) pair of the session:

* ``t_takeoff`` [s] and ``takeoff_speed`` [m/s]: the estimated speed at take-off;
* ``flight_time`` [s]: touch-down minus take-off;
* ``touchdown_x touchdown_y touchdown_z`` [m]: the estimated sensor position at
  the touch-down (hill frame);
* ``jump_length`` [m]: the curve length of the landing profile from its start
  (:meth:`sportfusion.skijump.hill.HillProfile.jump_length`) to the foot of the normal
  from the touch-down position onto the profile (the sensor is still a few
  decimetres above the slope at the touch-down; the simulator measures its
  true jump length the same way);
* ``max_height`` [m]: the largest vertical height of the sensor above the
  landing profile during the flight, ``max(z_LA(x) - z)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.describe import ms_to_kmh
from sportfusion.core.errors import InputError
from sportfusion.skijump.hillfile import Hill

__all__ = ["profile_foot", "jump_metrics", "jump_metrics_table"]


def profile_foot(hill: Hill, x: float, z: float, iterations: int = 20) -> float:
    """x [m] of the foot of the normal from the point ``(x, z)`` [m] onto the landing profile.

    Newton's method on ``(x - xp) + (z - z_LA(xp)) z_LA'(xp) = 0``, from ``xp = x``.
    """
    prof = hill.profile
    xp = float(x)
    for _ in range(iterations):
        zp = float(prof.z(xp, "landing", extend=True))
        d1 = float(prof.dzdx(xp, "landing", extend=True))
        k = float(prof.curvature(xp, "landing", extend=True)) * (1 + d1 * d1) ** 1.5  # z''
        g = (x - xp) + (z - zp) * d1
        dg = -1.0 - d1 * d1 + (z - zp) * k
        step = g / dg
        xp -= step
        if abs(step) < 1e-10:
            break
    return xp


def _col(table: pa.Table, name: str) -> np.ndarray:
    return schema.floats(table, name)


def session_jumps(table: pa.Table, meta: dict[str, Any]) -> list[tuple[float, float]]:
    """(take-off, touch-down) times [s] from the ``event`` column, else the rts-smooth metadata."""
    from sportfusion.skijump.smoother_inputs import session_events

    jumps = session_events(table, None, None, meta)
    if not jumps and meta.get("rts", {}).get("jumps"):
        jumps = [(float(j["takeoff"]), float(j["touchdown"])) for j in meta["rts"]["jumps"]]
    return jumps


def jump_metrics(
    t: np.ndarray, pos: np.ndarray, vel: np.ndarray, jumps: list[tuple[float, float]], hill: Hill
) -> list[dict[str, float]]:
    """Figures of every jump (see the module text).

    Parameters
    ----------
    t : (n,) times [s]; pos : (n, 3) hill-frame position [m]; vel : (n, 3) hill-frame velocity [m/s]
    jumps : (take-off, touch-down) times [s]
    hill : the hill (landing profile)

    Returns
    -------
    list of dict, one per jump
    """
    ok = np.isfinite(pos).all(axis=1) & np.isfinite(vel).all(axis=1)
    t, pos, vel = t[ok], pos[ok], vel[ok]
    if t.size < 2:
        raise InputError("no row has a complete estimate x y z vx vy vz; expected rts-smooth output")
    out = []
    for k, (a, b) in enumerate(jumps):
        if not (t[0] <= a < b <= t[-1]):
            raise InputError(
                f"jump {k + 1}: take-off {a:.3f} s / touch-down {b:.3f} s outside the estimate "
                f"({t[0]:.3f}-{t[-1]:.3f} s); expected events within the smoothed session"
            )
        v_to = np.array([np.interp(a, t, vel[:, j]) for j in range(3)])
        r_td = np.array([np.interp(b, t, pos[:, j]) for j in range(3)])
        fl = (t >= a) & (t <= b)
        zf = hill.profile.z(pos[fl, 0], "landing", extend=True)
        xp = profile_foot(hill, r_td[0], r_td[2])
        out.append(
            {
                "jump": k + 1,  # numbered from 1, as evaluate and the batch summary print them
                "t_takeoff": a,
                "t_touchdown": b,
                "takeoff_speed": float(np.linalg.norm(v_to)),
                "flight_time": b - a,
                "touchdown_x": float(r_td[0]),
                "touchdown_y": float(r_td[1]),
                "touchdown_z": float(r_td[2]),
                "jump_length": float(hill.profile.jump_length(xp, extend=True)),
                "max_height": float(np.max(zf - pos[fl, 2])) if fl.any() else float("nan"),
            }
        )
    return out


def jump_metrics_table(table: pa.Table, meta: dict[str, Any], hill: Hill) -> tuple[pa.Table, dict[str, Any], str]:
    """``jump-metrics``: a ``jumps`` table (one row per jump) from a smoothed session."""
    schema.require_columns(table, ("x", "y", "z", "vx", "vy", "vz"), "jump-metrics (rts-smooth output)")
    jumps = session_jumps(table, meta)
    if not jumps:
        raise InputError(
            "the session has no take-off/touch-down events; expected detect-events --kind jump before rts-smooth"
        )
    t = _col(table, "t")
    pos = np.stack([_col(table, c) for c in ("x", "y", "z")], axis=-1)
    vel = np.stack([_col(table, c) for c in ("vx", "vy", "vz")], axis=-1)
    rows = jump_metrics(t, pos, vel, jumps, hill)
    names = list(rows[0])
    cols = {n: schema.to_arrow(n, np.array([r[n] for r in rows])) for n in names}
    out = pa.table(cols)
    new_meta = dict(meta)
    new_meta["kind"] = "jumps"
    new_meta["hill"] = hill.meta()
    new_meta["jump_length"] = [r["jump_length"] for r in rows]
    msg = "; ".join(
        f"jump {r['jump']}: {r['jump_length']:.1f} m, {r['takeoff_speed']:.1f} m/s "
        f"({ms_to_kmh(r['takeoff_speed']):.1f} km/h)"
        for r in rows
    )
    return out, new_meta, msg
