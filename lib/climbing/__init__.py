"""Climbing: grip events, the transition estimator and the hold-map particle filter.

Koller, Laue and Frese, *Event-Domain Knowledge in Inertial Sensor Based State
Estimation of Human Motion* (the climbing paper, §II-III and the Appendix):

* :mod:`.grips` -- the moving-window low-motion grip detector and sensor-range violations;
* :mod:`.transition` -- the whole trial as one sparse nonlinear least-squares problem (eq 12)
  on the boxplus manifold, giving transition velocities and their covariance (eq 13);
* :mod:`.particles` -- the particle filter over position and yaw error (eqs 16-22) and its
  forward-filtering backward-smoothing smoother;
* :mod:`.holds` -- hold maps (the ``holds`` table kind) and their validation.
"""
