"""Climbing: grip events, the transition estimator and the hold-map particle filter.

Koller, Laue and Frese, *Event-Domain Knowledge in Inertial Sensor Based State
Estimation of Human Motion* (the climbing paper, §II-III and the Appendix):

* :mod:`.grips` -- the moving-window low-motion grip detector and sensor-range violations;
* :mod:`.transition` -- the whole trial as one sparse nonlinear least-squares problem (eq 12)
  on the boxplus manifold, giving transition velocities and their covariance (eq 13);
* :mod:`.particles` -- the particle filter over position and yaw error (eqs 16-22) and its
  forward-filtering backward-smoothing smoother;
* :mod:`.holds` -- hold maps (the ``holds`` table kind) and their validation.
* :mod:`.plots` -- the hand path over the hold map; :mod:`.sim` -- the bouldering simulator.

Entry points (imported lazily); tables follow the session contract (SI units):

* :func:`read_holds` -- a hold map (``holds`` table: route, hold, x, y, z [m]) -> :class:`HoldMap`;
* :func:`grip_columns` -- grip intervals (low-motion windows) and sensor-range violations;
* :func:`track_holds` -- the transition estimator and the particle filter + smoother over the hold map:
  hand position [m], hold reached, its probability;
* :func:`simulate_boulder` -- truth and a hand IMU of a bouldering trial.
"""

from sportfusion.core.exports import lazy_exports

_EXPORTS = {
    "HoldMap": "sportfusion.climbing.holds",
    "read_holds": "sportfusion.climbing.holds",
    "grip_columns": "sportfusion.climbing.grips",
    "TrackOptions": "sportfusion.climbing.track",
    "track_holds": "sportfusion.climbing.track",
    "BoulderConfig": "sportfusion.climbing.sim",
    "simulate_boulder": "sportfusion.climbing.sim",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
