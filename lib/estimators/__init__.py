"""Generic estimators that know no sport (arrays in, arrays out; SI units).

* :mod:`~sportfusion.estimators.kalman` -- extended Kalman filter + Rauch-Tung-Striebel smoother with
  constraints as pseudo-measurements (the core of the skijump paper's smoother, model-agnostic);
* :mod:`~sportfusion.estimators.spline` -- weighted cubic smoothing splines by a banded Reinsch solve,
  GCV, epoch weights (skiracing-splines eqs 5-7);
* :mod:`~sportfusion.estimators.quest` -- Wahba's problem by batched QUEST and Davenport's q-method;
* :mod:`~sportfusion.estimators.particles` -- particle-filter machinery: log-weight normalisation,
  effective sample size, systematic resampling.

Nothing here imports a sport package.
"""
