"""Alpine racing with magnet gates (the gates paper): magnet physics, gate crossings, anchor matching, gate-anchor.

Entry points (imported lazily); tables follow the session contract (SI units):

* :func:`detect_gate_table` -- gate crossings from magnetic-field peaks: time [s], peak field [uT],
  distance to the magnet [m], turn side;
* :func:`gate_anchor_table` -- crossings matched to the surveyed gates, then the two-pass extended Kalman
  smoother with the gates as anchors: position [m], velocity [m/s], attitude [rad] and per-turn figures;
* :func:`simulate_gates` -- truth, a sacrum IMU with magnetometer and the gates' survey.

Modules: ``magnet`` (dipole model, calibration), ``crossings``, ``anchors`` (the paper's relative anchors and
matching), ``passfit`` (a magnet placed by a fit of the whole pass), ``alignment`` (crossings aligned with the
survey as one sequence), ``inertial`` (strapdown, static windows), ``eks`` (the smoother), ``pipeline`` (over a
session), ``plots``; ``sim`` and ``sim_sensors`` (the simulator, written apart from all of these).
"""

from sportfusion.core.exports import lazy_exports

_EXPORTS = {
    "detect_gate_table": "sportfusion.gates.crossings",
    "GateAnchorParams": "sportfusion.gates.pipeline",
    "gate_anchor_table": "sportfusion.gates.pipeline",
    "GatesConfig": "sportfusion.gates.sim",
    "simulate_gates": "sportfusion.gates.sim",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
