"""Several recordings on one clock: UTC where they have it, --offset otherwise."""

from __future__ import annotations

import numpy as np
import pytest

from sportfusion.errors import InputError
from sportfusion.ingest import Recording, combine, detect_format
from sportfusion.meta import epoch_unix
from sportfusion.session import Stream


def _imu(epoch):
    return Recording("phone.zip", "phyphox", [Stream("acc", np.arange(5) * 0.01, {"acc_x": np.arange(5.0)})], epoch)


def _gps(epoch):
    return Recording("gps.nmea", "nmea", [Stream("gga", np.array([0.0, 0.1]), {"lat": [47.0, 47.1]})], epoch)


def test_aligned_by_utc_with_earliest_origin():
    table, meta, warnings = combine([_imu(1000.5), _gps(1000.0)])
    assert epoch_unix(meta) == pytest.approx(1000.0)
    t = table.column("t").to_numpy()
    lat = table.column("lat").to_pylist()
    acc = table.column("acc_x").to_pylist()
    assert [ti for ti, v in zip(t, lat, strict=True) if v is not None] == pytest.approx([0.0, 0.1])
    assert [ti for ti, v in zip(t, acc, strict=True) if v is not None] == pytest.approx(0.5 + np.arange(5) * 0.01)
    assert warnings == []
    assert [s["samples"] for s in meta["sources"]] == [{"acc": 5}, {"gga": 2}]


def test_offset_places_a_clockless_input_and_missing_offset_warns():
    table, meta, warnings = combine([_gps(2000.0), _imu(None)], {"phone.zip": 0.03})
    acc_t = [
        t for t, v in zip(table.column("t").to_numpy(), table.column("acc_x").to_pylist(), strict=True) if v is not None
    ]
    assert acc_t == pytest.approx(0.03 + np.arange(5) * 0.01)
    _, _, warnings = combine([_gps(2000.0), _imu(None)])
    assert len(warnings) == 1 and "--offset phone.zip=SECONDS" in warnings[0]


def test_offset_for_unknown_input_refused():
    with pytest.raises(InputError, match="--offset names nope.csv"):
        combine([_imu(1.0)], {"nope.csv": 1.0})


def test_detect_format_errors(tmp_path):
    empty = tmp_path / "empty.nmea"
    empty.write_bytes(b"")
    with pytest.raises(InputError, match="empty"):
        detect_format(empty)
    with pytest.raises(InputError, match="no such file"):
        detect_format(tmp_path / "missing.gpx")
