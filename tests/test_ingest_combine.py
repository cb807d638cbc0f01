"""Several recordings on one clock: UTC where they have it, --offset otherwise."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sportfusion.core.errors import InputError
from sportfusion.core.meta import epoch_unix
from sportfusion.core.session import Stream
from sportfusion.ingest import Recording, combine, detect_format


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


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.integers(1, 40),  # samples
            st.sampled_from([0.01, 0.02, 0.1, 1 / 3, 0.0125]),  # step [s]
            st.one_of(st.none(), st.floats(1.7e9, 1.7e9 + 100.0)),  # epoch [Unix s] or no clock
            st.floats(-2.0, 2.0),  # --offset [s]
        ),
        min_size=1,
        max_size=4,
    )
)
def test_combine_of_random_recordings_loses_nothing(spec):
    """Every sample of every recording lands on its own row at epoch shift + offset + its time."""
    cols = ["acc_x", "gyr_x", "mag_x", "lat"]
    recs, offsets = [], {}
    for i, (n, dt, epoch, off) in enumerate(spec):
        t = dt * np.arange(n)
        recs.append(Recording(f"in{i}.csv", "csvmap", [Stream("s", t, {cols[i]: np.arange(n) + 100.0 * i})], epoch))
        offsets[f"in{i}.csv"] = off
    table, meta, _ = combine(recs, offsets)  # each input has its own column, so instants may coincide
    t = table.column("t").to_numpy()
    assert np.all(np.diff(t) > 0)
    epochs = [e for _, _, e, _ in spec if e is not None]
    origin = min(epochs) if epochs else None
    assert (epoch_unix(meta) is None) == (origin is None)
    for i, (n, dt, epoch, off) in enumerate(spec):
        col = table.column(cols[i])
        assert len(col) - col.null_count == n
        present = col.is_valid().to_numpy(zero_copy_only=False)
        shift = off + (epoch - origin if epoch is not None else 0.0)
        np.testing.assert_allclose(t[present], shift + dt * np.arange(n), atol=1e-6)
        np.testing.assert_array_equal(np.asarray(col.drop_null().to_numpy()), np.arange(n) + 100.0 * i)
    assert [sum(s["samples"].values()) for s in meta["sources"]] == [n for n, *_ in spec]


def test_every_format_is_claimed_by_its_own_sniffer_only(tmp_path):
    """One small input per format; each sniffer claims exactly its own (csvmap claims none: it needs --map)."""
    import importlib
    import json

    from sportfusion.ingest import FORMATS
    from sportfusion.sim.rawfiles import nmea_sentence, write_phyphox_zip

    write_phyphox_zip(tmp_path / "phone.zip", 1.7e9, {"Accelerometer": (np.arange(3) * 0.01, np.ones((3, 3)))})
    (tmp_path / "gps.txt").write_text(
        nmea_sentence("GPGGA,120000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,") + "\r\n"
    )
    (tmp_path / "track.xml").write_text('<?xml version="1.0"?>\n<gpx version="1.1" creator="x"><trk/></gpx>\n')
    (tmp_path / "rtk.txt").write_text(
        "% program   : RTKPOST ver.2.4.3\n% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix)\n"
        "%  GPST                  latitude(deg) longitude(deg)  height(m)   Q  ns\n"
        "2025/03/15 10:00:00.000   47.400000000   10.300000000   900.0000   1   9\n"
    )
    (tmp_path / "mt.txt").write_text("// Update Rate: 100.0Hz\nPacketCounter\tAcc_X\n1\t9.8\n")
    trial = tmp_path / "T1"
    trial.mkdir()
    (trial / "trial_data.json").write_text(json.dumps({"TrackID": "1"}))
    (trial / "imu_lefthand.csv").write_text("t,a\n0,1\n")
    (tmp_path / "plain.csv").write_text("Time,AccX\n0,1\n")
    expect = {
        "phone.zip": "phyphox",
        "gps.txt": "nmea",
        "track.xml": "gpx",
        "rtk.txt": "rtklib",
        "mt.txt": "xsens",
        "T1": "bouldering",
        "plain.csv": None,
    }
    mods = {f: importlib.import_module(f"sportfusion.ingest.{f}") for f in FORMATS}
    for name, fmt in expect.items():
        p = tmp_path / name
        head = p.read_bytes()[:4096] if p.is_file() else b""
        claims = {f for f, m in mods.items() if m.sniff(p, head)}
        assert claims == ({fmt} if fmt else set()), (name, claims)
        if fmt:
            assert detect_format(p) == fmt
    with pytest.raises(InputError, match="format not recognised.*--map"):
        detect_format(tmp_path / "plain.csv")
