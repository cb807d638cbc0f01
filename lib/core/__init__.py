"""The core: everything that knows no sport.

* :mod:`~sportfusion.core.io` -- Parquet tables in and out, with the ``sportfusion`` metadata attached;
* :mod:`~sportfusion.core.schema` -- the column registry (names, types, units, meanings);
* :mod:`~sportfusion.core.meta` -- the versioned metadata: kind, time origin, frame, provenance;
* :mod:`~sportfusion.core.session` -- merging sensor streams onto one time axis, time validation;
* :mod:`~sportfusion.core.errors` -- :class:`~sportfusion.core.errors.InputError` (bad input, exit 1);
* :mod:`~sportfusion.core.frames` -- geodetic <-> local frames (pyproj), the frame metadata;
* :mod:`~sportfusion.core.rotations` -- quaternions, DCMs, Euler angles, NED <-> local;
* :mod:`~sportfusion.core.gravity`, :mod:`~sportfusion.core.magfield` -- normal gravity, the World Magnetic Model;
* :mod:`~sportfusion.core.events` -- the ``event`` column and boolean runs;
* :mod:`~sportfusion.core.describe` -- what ``inspect`` prints;
* :mod:`~sportfusion.core.plots` -- figure styling and the sport-agnostic figures.

The generic estimators (Kalman/RTS, smoothing spline, QUEST, particle-filter machinery) are in
:mod:`sportfusion.estimators`.  Nothing here imports a sport package.
"""
