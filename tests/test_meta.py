"""The versioned metadata: validation names the bad key; round trips are exact."""

from __future__ import annotations

import io
import json

import pyarrow as pa
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core.errors import InputError

json_leaf = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**53), 2**53),
    st.floats(allow_nan=False, allow_infinity=False),
    st.text(max_size=8),
)
json_value = st.recursive(
    json_leaf,
    lambda kids: st.lists(kids, max_size=3) | st.dictionaries(st.text(max_size=6), kids, max_size=3),
    max_leaves=10,
)


@settings(max_examples=60, deadline=None)
@given(
    epoch=st.one_of(st.none(), st.floats(0, 4e9)),
    extra=st.dictionaries(
        st.text(min_size=1, max_size=8).filter(lambda k: k not in sfmeta.new_meta()), json_value, max_size=3
    ),
    params=st.dictionaries(st.text(max_size=8), json_value, max_size=4),
    azimuth=st.floats(0, 360),
)
def test_metadata_round_trip(epoch, extra, params, azimuth):
    meta = sfmeta.new_meta("session", epoch)
    meta.update(extra)
    meta["frame"] = {
        "name": "hill",
        "origin": [47.4, 10.3, 900.0],
        "azimuth_deg": azimuth,
        "axes": "x forward, y right, z down",
    }
    meta = sfmeta.add_provenance(meta, "tool", params)
    data = sfio.table_to_bytes(pa.table({"t": [0.0, 1.0]}), meta)
    _, back = sfio.read_table(io.BytesIO(data))
    assert back == json.loads(json.dumps(meta))


def test_epoch_string_round_trip():
    meta = sfmeta.new_meta("session", 1_767_225_600.123456)
    assert meta["time"]["epoch_utc"] == "2026-01-01T00:00:00.123456Z"
    assert sfmeta.epoch_unix(meta) == pytest.approx(1_767_225_600.123456, abs=1e-6)


@pytest.mark.parametrize(
    ("mutate", "key"),
    [
        (lambda m: m.pop("version"), "'version' is missing"),
        (lambda m: m.update(version=7), "'version' is 7"),
        (lambda m: m.pop("kind"), "'kind' is missing"),
        (lambda m: m.update(kind="nonsense"), "'kind' is 'nonsense'"),
        (lambda m: m.pop("provenance"), "'provenance'"),
        (lambda m: m.update(provenance=[{"tool": "x"}]), "'provenance\\[0\\]'"),
        (lambda m: m.update(time={"epoch_utc": "yesterday"}), "'time.epoch_utc'"),
        (lambda m: m.update(frame={"name": "hill", "origin": [1, 2], "azimuth_deg": 0}), "'frame.origin'"),
        (lambda m: m.update(frame={"name": "hill", "origin": [1, 2, 3]}), "'frame.azimuth_deg' is missing"),
    ],
)
def test_validation_names_the_key(mutate, key):
    meta = sfmeta.new_meta()
    mutate(meta)
    with pytest.raises(InputError, match=key):
        sfmeta.decode(json.dumps(meta).encode())


def test_not_json():
    with pytest.raises(InputError, match="not valid JSON"):
        sfmeta.decode(b"{nope")


def test_provenance_appends_exactly_one_step_and_copies():
    meta = sfmeta.new_meta()
    one = sfmeta.add_provenance(meta, "a", {"x": float("nan"), "y": (1, 2)})
    two = sfmeta.add_provenance(one, "b", {})
    assert meta["provenance"] == []
    assert [s["tool"] for s in two["provenance"]] == ["a", "b"]
    assert one["provenance"][0]["params"] == {"x": None, "y": [1, 2]}
