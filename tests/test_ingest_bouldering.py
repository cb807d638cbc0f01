"""Bouldering dataset layout: a simulated trial and wall written in the dataset's files, read back."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sportfusion.climbing.grips import grip_columns
from sportfusion.climbing.holds import read_holds
from sportfusion.climbing.sim import BoulderConfig, simulate_boulder
from sportfusion.climbing.track import TrackOptions, track_holds
from sportfusion.core import io as sfio
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.session import with_columns
from sportfusion.ingest import Options, bouldering, combine, phyphox, read_recording

BIN = Path(sys.executable).parent
IMU = ("t", *(f"{s}_{a}" for s in ("acc", "gyr", "mag") for a in "xyz"), "dev_q0", "dev_q1", "dev_q2", "dev_q3")


@pytest.fixture(scope="module")
def sim():
    return simulate_boulder(BoulderConfig(seed=11, route_holds=10, imu_rate=60))


def write_dataset(root: Path, sim, local_index: bool = False, hand: str = "lefthand") -> tuple[Path, Path]:
    """The simulated trial and wall in the dataset's layout; returns (trial folder, map folder)."""
    trial = root / "ds" / "P01" / "V02" / "trials" / "T3"
    trial.mkdir(parents=True)
    field = [3.0 * v for v in sim.holds_meta["climbing"]["magnetic_field"]]  # not normalised in the file
    (root / "ds" / "data_set.json").write_text(json.dumps({"magnet_in_art_V01": [1, 0, 0], "magnet_in_art_V02": field}))
    cl = sim.meta["climbing"]
    (trial / "trial_data.json").write_text(
        json.dumps(
            {
                "TrackID": cl["route"],
                "start_time": 0.5,
                "end_time": float(schema.floats(sim.session, "t")[-1]),
                "descent_time": cl["descent_time"],
                "data_mask": {"imu_lefthand": 1, "imu_righthand": 0},
                "has_outliers": {"imu_lefthand": 0, "imu_righthand": 0},
            }
        )
    )
    data = np.column_stack([schema.floats(sim.session, c) for c in IMU])
    lines = ["time,ax,ay,az,gx,gy,gz,mx,my,mz,qw,qx,qy,qz"] + [",".join(repr(float(v)) for v in row) for row in data]
    (trial / f"imu_{hand}.csv").write_text("\n".join(lines) + "\n")
    wall = root / "wall"
    (wall / "routes").mkdir(parents=True)
    route = np.array(sim.holds.column("route").to_pylist())
    hold = np.array(sim.holds.column("hold").to_pylist())
    pos = np.column_stack([schema.floats(sim.holds, a) for a in "xyz"])
    starts = {}
    for r in dict.fromkeys(route.tolist()):
        sel = route == r
        idx = np.arange(sel.sum()) if local_index else hold[sel]
        rows = ["index,x,y,z"] + [
            f"{i},{float(p[0])!r},{float(p[1])!r},{float(p[2])!r}" for i, p in zip(idx, pos[sel], strict=True)
        ]
        (wall / "routes" / f"{r}.csv").write_text("\n".join(rows) + "\n")
        start = sim.holds_meta["climbing"]["start_holds"][r]
        starts[r] = [int(idx[np.flatnonzero(hold[sel] == h)[0]]) for h in start]
    (wall / "start_handles.json").write_text(json.dumps(starts))
    return trial, wall


def test_trial_and_hold_map_read_back_exactly(tmp_path, sim):
    trial, wall = write_dataset(tmp_path, sim)
    assert bouldering.sniff(trial, b"") and bouldering.sniff(trial / "imu_lefthand.csv", b"time,ax")
    assert not phyphox.sniff(trial, b"")
    out, holds_out = tmp_path / "trial.parquet", tmp_path / "holds.parquet"
    proc = subprocess.run(
        [str(BIN / "ingest"), str(trial), "--holds-out", str(holds_out), "-o", str(out)],
        capture_output=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr.decode()
    table, meta = sfio.read_table(out, kind="session")
    for c in IMU:
        np.testing.assert_array_equal(schema.floats(table, c), schema.floats(sim.session, c))
    cl = meta["climbing"]
    assert cl["route"] == sim.meta["climbing"]["route"]
    assert cl["descent_time"] == sim.meta["climbing"]["descent_time"]
    assert (cl["participant"], cl["visit"], cl["trial"], cl["hand"]) == ("P01", "V02", "T3", "lefthand")
    assert meta["units"] == {"mag_x": "1", "mag_y": "1", "mag_z": "1"}
    assert meta["time"]["epoch_utc"] is None
    holds = read_holds(str(holds_out))  # found beside the dataset without --hold-map
    ref = sim.holds_meta["climbing"]
    for r in holds.routes:
        ids, p = holds.start_positions(r)
        assert ids.tolist() == ref["start_holds"][r]
        np.testing.assert_array_equal(holds.route_holds(r)[0], np.sort(holds.route_holds(r)[0]))
    assert sorted(holds.routes) == sorted(ref["start_holds"])
    assert holds.hold.size == sim.holds.num_rows
    np.testing.assert_allclose(holds.magnetic_field, ref["magnetic_field"], atol=1e-15)  # the visit's, normalised
    assert holds.up.tolist() == [0.0, 0.0, 1.0]


def test_route_local_indices_are_renumbered_and_kept(tmp_path, sim):
    trial, wall = write_dataset(tmp_path, sim, local_index=True)
    table, meta, warnings = bouldering.read_hold_map(wall, None, "z")
    assert any("numbered by position" in w for w in warnings)
    route = np.array(table.column("route").to_pylist())
    hold = np.array(table.column("hold").to_pylist())
    local = np.array(table.column("route_hold").to_pylist())
    assert np.unique(hold).size == sim.holds.num_rows  # no two holds share a position in the simulation
    for r, pair in json.loads((wall / "start_handles.json").read_text()).items():
        sel = route == r
        start = meta["climbing"]["start_holds"][r]
        assert [int(local[sel][hold[sel] == h][0]) for h in start] == pair


@pytest.mark.slow
def test_pf_holds_gets_the_same_estimate_from_the_ingested_trial(tmp_path, sim):
    """The hold map and route metadata ingest writes are what pf-holds needs (same answer as the simulator's)."""
    trial, wall = write_dataset(tmp_path, sim)
    rec = read_recording(trial)
    table, meta, _ = combine([rec])
    holds_tab, holds_meta = rec.tables["holds"]
    path = tmp_path / "h.parquet"
    sfio.write_table(holds_tab, holds_meta, path)
    from sportfusion.climbing.holds import validate

    ref_holds = validate(sim.holds, sim.holds_meta)
    mine = read_holds(str(path))
    opts = TrackOptions(seed=5)
    a = track_holds(with_columns(table, grip_columns(table)[0]), meta, mine, opts)
    b = track_holds(with_columns(sim.session, grip_columns(sim.session)[0]), sim.meta, ref_holds, opts)
    assert a.route == b.route
    for c in ("x", "y", "z", "hold_id"):
        np.testing.assert_allclose(np.asarray(a.columns[c], float), np.asarray(b.columns[c], float), atol=1e-9)


def test_quirks_and_errors(tmp_path, sim):
    trial, wall = write_dataset(tmp_path, sim, hand="righthand")
    data = (trial / "imu_righthand.csv").read_text().splitlines()
    row = data[5].split(",")
    row[1], row[5], row[9] = "170.0", "40.0", "1.95"  # beyond 160 m/s^2, 2000 deg/s, 1.9 normalised
    data[5] = ",".join(row)
    (trial / "imu_righthand.csv").write_text("\n".join(data) + "\n")
    rec = read_recording(trial / "imu_righthand.csv", opts=Options(hold_map=str(wall)))
    assert rec.streams[0].name == "imu_righthand"
    assert any("data_mask marks imu_righthand as invalid" in w for w in rec.warnings)
    assert any("acc 1, gyr 1, mag 1" in w for w in rec.warnings)
    with pytest.raises(InputError, match="no imu_lefthand.csv \\(found imu_righthand.csv\\)"):
        bouldering.read(trial, Options(hand="lefthand"))
    (trial / "imu_righthand.csv").write_text("t,a,b\n0,1,2\n")
    with pytest.raises(InputError, match="3 columns; expected 14"):
        bouldering.read(trial, Options(hand="righthand"))
    (wall / "start_handles.json").write_text("{}")
    with pytest.raises(InputError, match="no two start holds for route"):
        bouldering.read_hold_map(wall)


def test_holds_out_without_a_hold_map_is_an_error(tmp_path):
    d = tmp_path / "x"
    d.mkdir()
    (d / "Accelerometer.csv").write_text('"Time (s)","Acceleration x (m/s^2)"\n0.0E0,1.0E0\n')
    proc = subprocess.run(
        [str(BIN / "ingest"), str(d), "--holds-out", str(tmp_path / "h.parquet"), "-o", str(tmp_path / "o.parquet")],
        capture_output=True,
        timeout=120,
    )
    assert proc.returncode == 1 and "no input came with a hold map" in proc.stderr.decode()
    assert not (tmp_path / "o.parquet").exists() and not (tmp_path / "h.parquet").exists()
