"""``rts-smooth``: the ski-jump trajectory by the extended RTS smoother with hill constraints (skijump §3-4).

:func:`rts_smooth_table` is the pipeline; each stage is a module, and the data flow one way through them:

1. **inputs** (:mod:`sportfusion.skijump.smoother_inputs`): the session on the IMU steps -- GNSS positions in
   the hill frame and NED velocities, magnetometer samples on the step they fall on (or the nearest IMU step
   within half a step), the constraint windows per jump, the still steps, the hill profile's tables;
2. **initial state** (:mod:`sportfusion.skijump.smoother_start`, paper §4.1): position and NED velocity of the
   first GNSS fix, the gyro bias the mean rate over the rest at the gate, the attitude from the in-run
   alignment (:mod:`sportfusion.skijump.alignment`) or QUEST over the rest, ``P0`` from Table 3;
3. **the filter/smoother engine** (:mod:`sportfusion.skijump.smoother_engine`, eqs 10-21 with the model of
   :mod:`sportfusion.skijump.model`, eqs 22, 35-51): the numpy reference and the C loop behind one function,
   run over each IMU segment by :mod:`sportfusion.skijump.smoother_passes` (the start window's re-linearising
   run, the whole segment, the GNSS latency and lever-arm corrections);
4. **outputs** (:mod:`sportfusion.skijump.smoother_outputs`): the estimate, standard-deviation and constraint
   columns, interpolated onto the table's rows where not every row is an IMU step.

Constraint windows (eqs 32-34, 51), per jump of the session:

* ``c_q`` at every step;
* ``c_V,IR`` and ``c_H,IR`` from the start of the in-run to the take-off
  (inclusive).  The in-run starts where the athlete last sat at the gate:
  the run of GNSS speeds below ``rest_speed`` that ends last before the
  take-off (at most ``max_rest`` seconds of it), or the session's (segment's)
  start when there is none;
* ``c_V,LA`` from the touch-down to the end of the first rest after it (or the
  next in-run / the session's end).  The errata's touch-down note: the sensor
  settles onto the slope over ~0.2 s after the detected touch-down, so the
  constraint starts ``la_delay`` seconds after it and its weight (inverse
  variance) ramps linearly from 0 to full over ``la_ramp`` seconds.

Beyond the paper, a zero-velocity update ``v_B = 0`` (1-sigma ``r_zupt`` per step) on the steps where the
athlete stands still (:func:`sportfusion.skijump.smoother_inputs.still_steps`: sitting at the gate,
standing after the stop), so that the rests do not drift between GNSS fixes; and magnetometer samples whose
innovations show a disturbance that keeps the field's strength are skipped and the session smoothed again.

``P0``, ``Q``, ``R`` are Tables 3-5 as 1-sigma values in :class:`SmootherConfig` (the GNSS position 5/5/8 m and the
hill constraints 0.05 m instead: issue 39's benchmark on independent physics), all overridable from a TOML
file (:func:`load_config`).  The reference field is the hill file's, else the World Magnetic Model at the
take-off edge and the session's date.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np
import pyarrow as pa

from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.gaps import describe_gaps
from sportfusion.core.magdisturb import describe as describe_mag
from sportfusion.core.session import with_columns
from sportfusion.skijump import model as mdl
from sportfusion.skijump.hillfile import Hill
from sportfusion.skijump.saturation import clipped_message, mag_innovation_outliers
from sportfusion.skijump.smoother_inputs import SkiJumpInputs, SmootherConfig, load_config, segments, session_inputs
from sportfusion.skijump.smoother_outputs import (
    constraint_residuals,
    estimate_columns,
    interp_columns,
    residual_rms,
)
from sportfusion.skijump.smoother_passes import Smoothed, smooth_inputs
from sportfusion.skijump.smoother_start import initial_state

__all__ = ["SmootherConfig", "Smoothed", "initial_state", "load_config", "rts_smooth_table", "smooth_inputs"]


def rts_smooth_table(
    table: pa.Table,
    meta: dict[str, Any],
    hill: Hill,
    cfg: SmootherConfig | None = None,
    *,
    takeoff: list[float] | None = None,
    touchdown: list[float] | None = None,
    filtered: bool = False,
    progress: Callable[[int], object] | None = None,
    on_start: Callable[[int], object] | None = None,
    engine: str = "auto",
) -> tuple[pa.Table, dict[str, Any], str]:
    """``rts-smooth`` on a session table: every input column plus the estimate columns.

    Parameters
    ----------
    table, meta : session and its metadata
    hill : the hill (profile for the constraints, take-off edge for the frame)
    cfg : SmootherConfig, optional
    takeoff, touchdown : lists of times [s], optional
        Events; default the ``event`` column's ``takeoff``/``touchdown`` rows.
    filtered : bool
        Also write the forward-only (EKF) estimates as ``filt_`` columns.
    progress : callable(k), optional
        Called once per forward and backward step.
    on_start : callable(total), optional
        Called with the number of progress calls to expect.
    engine : {"auto", "c", "numpy"}
        The engine (:func:`sportfusion.skijump.smoother_passes.smooth_inputs`).

    Returns
    -------
    table, meta, message
    """
    cfg = cfg or SmootherConfig()
    inp, frame = session_inputs(table, meta, hill, cfg, takeoff, touchdown)
    if cfg.hill_constraints and not inp.jumps:
        # without events the in-run/landing windows are guessed from speed alone: errors several times
        # larger (roll 1.8 deg instead of 0.15 on the fixture), so refuse rather than answer wrongly
        raise InputError(
            "no take-off/touch-down events in the session; expected detect-events --kind jump before "
            "rts-smooth, or --takeoff/--touchdown [s], or --no-hill-constraints"
        )
    if on_start is not None:
        on_start((2 * inp.t.size - 1) * max(cfg.passes, 1))
    res = _smooth_without_disturbed_mag(inp, cfg, progress, engine, filtered)
    new_meta = dict(meta)
    new_meta["frame"] = frame.to_meta()
    new_meta["hill"] = hill.meta()
    new_meta["rts"] = _rts_meta(inp, res, cfg)
    msg = (
        f"{inp.t.size} IMU steps, {int(np.isfinite(inp.pos[:, 0]).sum())} GNSS fixes, {len(inp.jumps)} jump(s); "
        f"hill constraints {'on' if cfg.hill_constraints else 'off'}"
    )
    # the sensors' arrays on the steps are not read again: freed before the columns are made (issue 38)
    inp.u, inp.pos, inp.vel, inp.mag = (np.empty((0, w)) for w in (6, 3, 3, 3))
    inp.clipped = inp.still = None
    # the metadata made, the output columns need only the states and std rows: the run is dropped so that its
    # innovations and (without `filtered`) filtered states are freed before the columns are made, and the
    # states and std rows as their columns are interpolated onto the table's rows (issue 38)
    cols = _step_columns(inp, res, cfg, filtered)
    del res
    cols = _on_rows(schema.floats(table, "t"), inp, cols, cfg, filtered)
    return with_columns(table, cols), new_meta, msg


def _smooth_without_disturbed_mag(
    inp: SkiJumpInputs, cfg: SmootherConfig, progress: Callable[[int], object] | None, engine: str, filtered: bool
) -> Smoothed:
    """:func:`smooth_inputs` (std rows, no covariances kept; the filtered states only with ``filtered``); with the magnetometer, the samples whose
    innovations show a disturbance that keeps the field's strength are skipped and the session smoothed again
    (``inp.mag`` and ``inp.mag_disturbed`` updated in place)."""
    res = smooth_inputs(inp, cfg, progress, engine, keep_cov=False, keep_filtered=filtered)
    if not cfg.use_mag:
        return res
    bad = mag_innovation_outliers(res.residuals.get("mag"), inp.t, cfg.r_mag)
    if not bad.any():
        return res
    raw = inp.mag.copy()
    inp.mag[bad] = np.nan
    del res  # its session-wide arrays (0.7 KB a step) freed before the next run makes its own (issue 38)
    res = smooth_inputs(inp, cfg, progress, engine, keep_cov=False, keep_filtered=filtered)
    # the flagged stretch may outlast the disturbance (the filter's heading was off for a while): give back the
    # samples that agree with the smoothed attitude, then run once more
    idx = np.flatnonzero(bad)
    pred = np.array([mdl.h_mag(res.x_smooth[k], inp.m_o) for k in idx])
    agree = np.linalg.norm(raw[idx] - pred, axis=1) < 2.0 * math.sqrt(3.0) * cfg.r_mag
    if agree.any():
        bad[idx[agree]] = False
        inp.mag[idx[agree]] = raw[idx[agree]]
        del res
        res = smooth_inputs(inp, cfg, progress, engine, keep_cov=False, keep_filtered=filtered)
    inp.mag_disturbed = bad if inp.mag_disturbed is None else inp.mag_disturbed | bad
    return res


def _step_columns(inp: SkiJumpInputs, res: Smoothed, cfg: SmootherConfig, filtered: bool) -> dict[str, np.ndarray]:
    """The estimate, std and constraint columns at the IMU steps (many of them views of ``res``' arrays)."""
    cols = estimate_columns(res.x_smooth, res.cov, inp, var=res.var, std=res.std)
    cols.update(constraint_residuals(res.x_smooth, inp, cfg.hill_constraints))
    if filtered:
        cols.update(estimate_columns(res.x_filt, None, inp, prefix="filt_"))
    return cols


def _on_rows(
    t_rows: np.ndarray, inp: SkiJumpInputs, cols: dict[str, np.ndarray], cfg: SmootherConfig, filtered: bool
) -> dict[str, np.ndarray]:
    """The columns at the steps (:func:`_step_columns`) on the table's rows ``t_rows`` [s]; ``cols`` is emptied
    as they are interpolated (each step column freed once no other column needs its array)."""
    if t_rows.size == inp.t.size and np.array_equal(t_rows, inp.t):
        return cols  # every row is an IMU step: nothing to interpolate (the quaternions are unit)
    out = interp_columns(t_rows, inp.t, cols, cfg.max_gap, consume=True)
    # quaternions interpolated linearly: renormalise
    for pre in ("", "filt_") if filtered else ("",):
        qs = [out[f"{pre}q{k}"] for k in range(4)]
        nq = np.sqrt(qs[0] * qs[0] + qs[1] * qs[1] + qs[2] * qs[2] + qs[3] * qs[3])
        for k in range(4):
            out[f"{pre}q{k}"] = qs[k] / nq
    return out


def _rts_meta(inp: SkiJumpInputs, res: Smoothed, cfg: SmootherConfig) -> dict[str, Any]:
    """The ``rts`` entry of the output's metadata: configuration, jumps, passes, latencies, residuals, warnings."""
    # the IMU's own stops (logging paused between jumps: independent segments) are not GNSS gaps
    pauses = [(inp.t[a - 1], inp.t[a]) for a, _ in segments(inp.t, cfg.max_gap)[1:]]
    warn = [clipped_message(inp), describe_gaps("GNSS", inp.t[np.isfinite(inp.pos[:, 0])], 2.0, pauses)]
    if inp.mag_disturbed is not None and inp.mag_disturbed.any():
        md = inp.mag_disturbed
        warn.append(describe_mag(int(md.sum()), inp.t, md) + ": those samples are skipped")
    n_wild = int(sum(res.gnss_outliers))
    if n_wild:
        warn.append(
            f"{n_wild} GNSS fix(es) more than {cfg.gnss_outlier_sigma:g} robust standard deviations from the smoothed "
            "track (multipath, wild fixes): skipped"
        )
    return {
        "config": {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(cfg).items()},
        "jumps": [{"takeoff": a, "touchdown": b} for a, b in inp.jumps],
        "gravity": inp.g0,
        "passes": res.passes,
        "gnss_latency_s": res.gnss_latency,
        "gnss_outliers": res.gnss_outliers,
        "mag_field_ned": inp.m_o.tolist(),
        "residual_rms": residual_rms(res.residuals),
        "warnings": [w for w in warn if w],
    }
