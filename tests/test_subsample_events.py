"""Event times between the samples: the parabolic peak of detect-events and the exact times in the metadata."""

from __future__ import annotations

import numpy as np
import pyarrow as pa

from sportfusion.skijump.events import peak_time
from sportfusion.skijump.smoother_inputs import session_events


def test_peak_time_is_exact_on_a_parabola_and_safe_elsewhere():
    t = np.arange(0.0, 1.0, 0.01)
    for tp in (0.503, 0.5049, 0.4951, 0.5):
        a = 50.0 - 3000.0 * (t - tp) ** 2
        k = int(np.argmax(a))
        assert abs(peak_time(t, a, k) - tp) < 1e-9
    a = np.abs(np.sin(7 * t))
    assert peak_time(t, a, 0) == t[0] and peak_time(t, a, t.size - 1) == t[-1]  # edges: the sample
    flat = np.ones(t.size)
    assert peak_time(t, flat, 50) == t[50]  # no bend: the sample
    gap = t.copy()
    gap[51:] += 1.0  # a gap after the peak sample: not interpolated across it
    assert peak_time(gap, 50.0 - (t - 0.503) ** 2, 50) == gap[50]


def _table(times, events):
    return pa.table({"t": times, "event": pa.array(events, pa.string())})


def test_exact_event_times_travel_in_the_metadata():
    t = np.arange(0.0, 20.0, 0.01)
    ev = [None] * t.size
    ev[1000], ev[1350] = "takeoff", "touchdown"
    table = _table(t, ev)
    meta = {"events": [{"kind": "jump", "jumps": [{"takeoff": 10.0031, "touchdown": 13.4988}]}]}
    assert session_events(table, None, None, meta) == [(10.0031, 13.4988)]
    # without the metadata, or with a time that is not this row's: the row times
    assert session_events(table, None, None) == [(t[1000], t[1350])]
    far = {"events": [{"kind": "jump", "jumps": [{"takeoff": 10.2, "touchdown": 13.4988}]}]}
    ((a, b),) = session_events(table, None, None, far)
    assert a == t[1000] and b == 13.4988
    # given times win over both
    assert session_events(table, [9.0], [12.0], meta) == [(9.0, 12.0)]
