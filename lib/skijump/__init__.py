"""Ski jumping (the skijump paper: an extended RTS smoother with hill-profile constraints).

Entry points (imported lazily, so ``import sportfusion.skijump`` is cheap); tables are pyarrow
tables in the session contract (SI units: m, s, m/s, rad) with their metadata dict:

* :func:`load_hill` (``NAME`` or ``FILE.toml``) -> :class:`Hill`, the certified profile (ICR 2008) in the
  hill frame (x along the hill axis, z down, origin at the take-off edge) [m];
* :func:`detect_jump_events` -- take-off / touch-down from accelerometer peaks (Appendix A);
* :func:`smooth_session` -- the 22-state extended RTS smoother (eqs 1-51): position [m], velocity [m/s],
  attitude (``q0..q3``, ``roll pitch yaw`` [rad]) and sensor biases with 1-sigma columns;
* :func:`jump_metrics_table` -- per jump: take-off speed [m/s], flight time [s], jump length along the
  profile [m] (§4.4);
* :func:`measure_video` -- jump length from a landing video (Appendix B);
* :func:`simulate_skijump` -- truth and noisy sensors of a jump on a hill (§4.2).

Modules: ``hill``/``hillfile`` (profile geometry, hill files), ``events``, ``kinematics``/``model``
(eqs 22, 35-51), the smoother in its stages -- ``smoother`` (the pipeline: ``rts_smooth_table``),
``smoother_inputs`` (configuration, constraint windows, the session on the IMU steps), ``smoother_start``
(the initial state), ``smoother_engine`` (one EKF + RTS run: the numpy reference and the C loop of
``_ski_c.c``), ``smoother_passes`` (the runs over each segment), ``smoother_outputs`` (the output columns) --
``metrics``, ``plots``, ``sim/`` (the jump simulator), ``video/`` (the video reference).
"""

from sportfusion.core.exports import lazy_exports

_EXPORTS = {
    "Hill": "sportfusion.skijump.hillfile",
    "load_hill": "sportfusion.skijump.hillfile",
    "detect_jump_events": "sportfusion.skijump.events",
    "SmootherConfig": "sportfusion.skijump.smoother_inputs",
    "smooth_session": "sportfusion.skijump.smoother:rts_smooth_table",
    "jump_metrics_table": "sportfusion.skijump.metrics",
    "measure_video": "sportfusion.skijump.video.measure",
    "SkiJumpConfig": "sportfusion.skijump.sim.simulate",
    "simulate_skijump": "sportfusion.skijump.sim.simulate",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
