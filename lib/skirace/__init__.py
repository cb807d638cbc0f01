"""Ski racing with GNSS (the skiracing-splines paper): smoothing splines, DMC attitude, runs compared.

Entry points (imported lazily); tables follow the session contract (SI units):

* :func:`smooth_session` -- weighted cubic smoothing splines of the local GNSS track (eqs 5-7; float
  epochs down-weighted by eq 6): position [m], velocity [m/s], acceleration [m/s^2], distance [m];
* :func:`dmc_table` -- attitude per sample from magnetometer + specific force by QUEST (eqs 8-9), the
  reference specific force from the spline's acceleration: ``q0..q3``, ``roll pitch yaw`` [rad];
* :func:`compare_tables` -- two or more runs of one course gate by gate: time [s], distance along the
  path [m], speed [m/s] (Figure 9);
* :func:`simulate_skirace` -- truth and noisy GNSS + IMU of a giant-slalom run.

Modules: ``track`` (the spline over a session), ``attitude`` (DMC per sample), ``dmc`` (over a session),
``compare``, ``plots``, ``sim`` and ``sim_runs`` (simulators).
"""

from sportfusion.core.exports import lazy_exports

_EXPORTS = {
    "smooth_session": "sportfusion.skirace.track",
    "dmc_table": "sportfusion.skirace.dmc",
    "compare_tables": "sportfusion.skirace.compare",
    "SkiRaceConfig": "sportfusion.skirace.sim",
    "simulate_skirace": "sportfusion.skirace.sim",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
