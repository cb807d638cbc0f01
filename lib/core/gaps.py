"""Irregular sampling: dropped samples and gaps in a sensor's time series.

Estimators use the real time step of every sample (never a nominal rate); this module only
describes what is missing, so that a tool can say it in one line.
"""

from __future__ import annotations

import numpy as np

from sportfusion.core.stats import median


def sampling_gaps(
    t: np.ndarray, factor: float = 1.5, pauses: list[tuple[float, float]] | None = None
) -> tuple[int, list[tuple[float, float]]]:
    """Missing samples and gaps of a sensor sampled at times ``t`` [s] (increasing).

    ``pauses``: intervals ``(t0, t1)`` [s] in which the whole recording stopped (logging paused between
    jumps): a step of ``t`` that spans one is not this sensor's gap and is not counted.

    Returns
    -------
    missing : int
        Estimated number of missing samples (each step longer than ``factor`` times the median step
        counts ``round(step / median) - 1``).
    gaps : list of (start [s], length [s])
        Every step longer than ``factor`` times the median step.
    """
    t = np.asarray(t, dtype=float)
    if t.size < 3:
        return 0, []
    d = np.diff(t)
    med = float(median(d))
    if med <= 0:
        return 0, []
    long = np.flatnonzero(d > factor * med)
    if pauses:
        p = np.asarray(pauses, dtype=float).reshape(-1, 2)
        spans = (t[long, None] <= p[None, :, 0]) & (t[long + 1, None] >= p[None, :, 1])
        long = long[~spans.any(axis=1)]
    missing = int(np.sum(np.rint(d[long] / med) - 1))
    return missing, [(float(t[i]), float(d[i])) for i in long]


def describe_gaps(
    sensor: str, t: np.ndarray, min_gap: float, pauses: list[tuple[float, float]] | None = None
) -> str | None:
    """One line about the gaps of at least ``min_gap`` [s] (None when there is none); steps across the
    recording's ``pauses`` (see :func:`sampling_gaps`) are not gaps."""
    missing, gaps = sampling_gaps(t, pauses=pauses)
    big = [(a, d) for a, d in gaps if d >= min_gap]
    if not big:
        return None
    a, d = max(big, key=lambda g: g[1])
    return (
        f"{sensor} gaps: {len(big)} stretch(es) of {min_gap:g} s or more without samples (longest {d:.2f} s "
        f"at {a:.2f} s; {missing} sample(s) missing in all): bridged by interpolation, "
        "the errors there grow"
    )
