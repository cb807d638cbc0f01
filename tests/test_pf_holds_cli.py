"""pf-holds command line: help, bad hold maps -> one clear line, determinism, output columns.

Run in-process with click's CliRunner (see the report: pyarrow's threaded Parquet reader can
abort the interpreter at exit, which would make subprocess runs flaky)."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from click.testing import CliRunner

from sportfusion.climbing.grips import grip_columns
from sportfusion.climbing.sim import BoulderConfig, simulate_boulder
from sportfusion.core import io as sfio
from sportfusion.core import schema
from sportfusion.core.session import with_columns
from sportfusion.tools.pf_holds import main


@pytest.fixture(scope="module")
def trial(tmp_path_factory):
    sim = simulate_boulder(BoulderConfig(seed=11, route_holds=10, imu_rate=60))
    cols, _ = grip_columns(sim.session)
    data = sfio.table_to_bytes(with_columns(sim.session, cols), sim.meta)
    folder = tmp_path_factory.mktemp("pf")
    holds = folder / "holds.parquet"
    sfio.write_table(sim.holds, sim.holds_meta, holds)
    return sim, data, folder, holds


def _invoke(args: list[str], data: bytes):
    res = CliRunner().invoke(main, args, input=data)
    return res.exit_code, res.stdout_bytes, res.stderr


def _one_line(code: int, out: bytes, err: str) -> str:
    assert code == 1 and out == b""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: pf-holds: "), lines
    assert "internal error" not in lines[0]
    return lines[0]


def test_help_has_units_and_example():
    res = CliRunner().invoke(main, ["--help"])
    assert res.exit_code == 0
    for text in ("Example", "--holds", "--descent-after", "[s]", "[count]", "[m]", "[rad^2/s]", "--seed"):
        assert text in res.output


def test_same_seed_identical_output_and_columns(trial):
    sim, data, folder, holds = trial
    a = _invoke(["--holds", str(holds), "--seed", "3", "-q"], data)
    b = _invoke(["--holds", str(holds), "--seed", "3", "-q"], data)
    assert a[0] == 0, a[2]
    assert a[1] == b[1]
    path = folder / "est.parquet"
    path.write_bytes(a[1])
    table, meta = sfio.read_table(str(path))
    for name in sim.session.column_names:
        assert table.column(name).equals(sim.session.column(name))
    assert table.column("hold_id").type == pa.int32()
    assert meta["provenance"][-1]["tool"] == "pf-holds" and meta["provenance"][-1]["params"]["seed"] == 3
    assert meta["frame"]["axes"].endswith("z up") and meta["climbing"]["up"] == "z"
    grip = table.column("grip").to_numpy(zero_copy_only=False)
    hold = table.column("hold_id")
    assert hold.null_count == int((~grip).sum())  # one hold (or -1) per grip sample, null elsewhere
    x = np.column_stack([schema.floats(table, a) for a in "xyz"])
    p = np.column_stack([schema.floats(sim.truth, f"true_{a}") for a in "xyz"])
    ok = np.isfinite(x[:, 0])
    assert ok.mean() > 0.95
    assert np.median(np.linalg.norm(x[ok] - p[ok], axis=1)) < 0.5  # a sane estimate, not an accuracy claim
    prob = schema.floats(table, "cluster_prob")[ok]
    assert ((prob > 0) & (prob <= 1 + 1e-12)).all()
    c = _invoke(["--holds", str(holds), "--seed", "4", "-q"], data)
    assert c[0] == 0 and c[1] != a[1]


def _bad_map(sim, folder, name: str, *, drop_starts: bool = False, nan: bool = False):
    table, meta = sim.holds, {**sim.holds_meta}
    meta["climbing"] = dict(meta["climbing"])
    if drop_starts:
        meta["climbing"].pop("start_holds")
    if nan:
        x = schema.floats(table, "x").copy()
        x[2] = np.nan
        table = table.set_column(table.column_names.index("x"), "x", schema.to_arrow("x", x))
    path = folder / name
    sfio.write_table(table, meta, path)
    return path


def test_hold_map_without_start_holds_is_one_line(trial):
    sim, data, folder, _ = trial
    line = _one_line(*_invoke(["--holds", str(_bad_map(sim, folder, "nostart.parquet", drop_starts=True))], data))
    assert "start holds" in line


def test_hold_map_with_nan_position_is_one_line(trial):
    sim, data, folder, _ = trial
    line = _one_line(*_invoke(["--holds", str(_bad_map(sim, folder, "nan.parquet", nan=True))], data))
    assert "NaN" in line and "row 2" in line


def test_missing_hold_map_and_missing_grips_are_one_line(trial, tmp_path):
    sim, data, folder, holds = trial
    assert "--holds" in _one_line(*_invoke([], data))
    assert "not-there" in _one_line(*_invoke(["--holds", str(tmp_path / "not-there.parquet")], data))
    raw = sfio.table_to_bytes(sim.session, sim.meta)
    assert "detect-events" in _one_line(*_invoke(["--holds", str(holds)], raw))
    session_as_map = tmp_path / "session.parquet"
    session_as_map.write_bytes(raw)
    assert "holds" in _one_line(*_invoke(["--holds", str(session_as_map)], data))
    assert "route" in _one_line(*_invoke(["--holds", str(holds), "--route", "nope"], data))


@pytest.mark.slow
def test_descent_after_opens_the_wall_holds(tmp_path):
    """Before the descent time grips match the route's holds only; after it, any hold of the wall.
    Seed 18 down-climbs on holds 15, 17 and 20 of other routes."""
    sim = simulate_boulder(BoulderConfig(seed=18, route_holds=10, imu_rate=60))
    data = sfio.table_to_bytes(with_columns(sim.session, grip_columns(sim.session)[0]), sim.meta)
    holds = tmp_path / "holds.parquet"
    sfio.write_table(sim.holds, sim.holds_meta, holds)
    route = set(np.asarray(sim.holds.column("hold"))[np.asarray(sim.holds.column("route")) == sim.route].tolist())
    t = schema.floats(sim.session, "t")
    true_hold = np.asarray(sim.truth.column("true_hold").fill_null(-2).to_numpy())
    off_route = set(true_hold[t > sim.descent_time].tolist()) - route - {-1, -2}
    assert off_route  # the scenario this test is about

    def hold_ids(*args: str) -> np.ndarray:
        code, out, err = _invoke(["--holds", str(holds), "-q", *args], data)
        assert code == 0, err
        return np.asarray(sfio.table_from_bytes(out).column("hold_id").fill_null(-2).to_numpy())

    default = hold_ids()  # the session's climbing.descent_time
    never = hold_ids("--descent-after", "1e6")
    given = hold_ids("--descent-after", str(sim.descent_time))
    assert np.array_equal(default, given)
    assert set(never.tolist()) <= route | {-1, -2}
    assert set(default[t < sim.descent_time].tolist()) <= route | {-1, -2}
    assert set(default[t > sim.descent_time].tolist()) & off_route  # found at least one of the wall's holds


def test_paper_noise_model_options_reach_the_library(trial):
    """--grip-count 0 --mag-disturbance 0 is the paper's model: the same output as the library with
    ``grip_count=None`` and ``mag_disturbance=0``; the defaults differ from it."""
    from sportfusion.climbing.holds import read_holds
    from sportfusion.climbing.particles import PFParams
    from sportfusion.climbing.track import TrackOptions, track_holds
    from sportfusion.climbing.transition import TransitionParams

    sim, data, folder, holds = trial
    code, out, err = _invoke(["--holds", str(holds), "--grip-count", "0", "--mag-disturbance", "0", "-q"], data)
    assert code == 0, err
    path = folder / "paper.parquet"
    path.write_bytes(out)
    table, _ = sfio.read_table(str(path))
    src, meta = sfio.read_table(pa.BufferReader(data))
    paper = TrackOptions(pf=PFParams(grip_count=None), transition=TransitionParams(mag_disturbance=0.0))
    ref = track_holds(src, meta, read_holds(str(holds)), paper)
    ours = track_holds(src, meta, read_holds(str(holds)))
    x = schema.floats(table, "x")
    assert np.allclose(x, ref.columns["x"].to_numpy(zero_copy_only=False), rtol=0, atol=1e-12, equal_nan=True)
    assert not np.allclose(x, ours.columns["x"].to_numpy(zero_copy_only=False), rtol=0, atol=1e-3, equal_nan=True)
