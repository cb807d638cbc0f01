"""compare-runs: two simulated runs of one course with known section time offsets; plot compare; bad input.

The runs come from :mod:`sportfusion.skirace.sim_runs`: sinusoidal lines down a slope, gates at the apexes,
run B on a wider line and delayed by a known amount per section.  Truth comes from the closed-form
timing law and scipy quad arc lengths, independent of the library's Hermite/Gauss-Legendre code.
"""

from __future__ import annotations

import io

import numpy as np
import pyarrow as pa
import pytest
from conftest import run_cli

from sportfusion.core import io as sfio
from sportfusion.core.errors import InputError
from sportfusion.skirace.sim_runs import GATE_IDS, GATES_X, SECTION_DT, arc, gates_table, run_table, speed, truth


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("runs")
    out = {}
    for name, data in {
        "A": run_table("A"),
        "B": run_table("B"),
        "A_plain": run_table("A", events=False),
        "B_plain": run_table("B", events=False),
        "B_10hz_novel": run_table("B", rate=10.0, velocity=False),
        "B_other_course": run_table("B", gate_ids=GATE_IDS + 100),
        "B_far": run_table("B", events=False, shift=(0.0, 400.0)),
        "gates": gates_table(),
    }.items():
        p = d / f"{name}.parquet"
        p.write_bytes(data)
        out[name] = p
    return out


def summary(path) -> dict[str, dict[str, np.ndarray]]:
    table, meta = sfio.read_table(path, kind="summary")
    runs = table.column("run").to_pylist()
    out = {}
    for r in dict.fromkeys(runs):
        m = np.array([v == r for v in runs])
        out[r] = {c: np.asarray(table.column(c).to_pylist(), dtype=object)[m] for c in table.column_names}
    return out, meta


def f(a):
    return np.array([np.nan if v is None else v for v in a], dtype=float)


def check_against_truth(b, a, *, dt_tol=0.01, dist_tol=0.05, speed_tol=0.05, turn=True):
    acc_dt, dist, spd, entry, exit_, length = truth()
    assert b["gate"].tolist() == GATE_IDS.tolist()
    # the paper's Figure 9 columns: accumulated and gate-to-gate time, distance along the path, speed
    np.testing.assert_allclose(f(b["acc_time_diff"]), acc_dt, atol=dt_tol)
    np.testing.assert_allclose(f(b["section_time_diff"])[1:], SECTION_DT, atol=dt_tol)
    assert np.isnan(f(b["section_time_diff"])[0])
    np.testing.assert_allclose(f(a["path_distance"]), dist["A"], atol=dist_tol)
    np.testing.assert_allclose(f(b["path_distance_diff"]), dist["B"] - dist["A"], atol=dist_tol)
    np.testing.assert_allclose(f(b["section_distance_diff"])[1:], np.diff(dist["B"] - dist["A"]), atol=dist_tol)
    np.testing.assert_allclose(f(b["gate_speed"]), spd["B"], atol=speed_tol)
    np.testing.assert_allclose(f(b["gate_speed_diff"]), spd["B"] - spd["A"], atol=speed_tol)
    # the reference's own differences are zero
    assert np.nanmax(np.abs(f(a["acc_time_diff"]))) == 0 and np.nanmax(np.abs(f(a["gate_speed_diff"]))) == 0
    if turn:
        # gate 1 is at a y > 0 apex: the heading swings back from +y (right) towards -y, a left turn; then alternating
        assert a["turn"].tolist() == ["R" if k % 2 else "L" for k in range(12)]
        inner = slice(1, -1)
        assert np.isnan(f(b["turn_length"])[0]) and np.isnan(f(b["turn_length"])[-1])
        np.testing.assert_allclose(f(b["turn_entry_speed"])[inner], entry["B"][inner], atol=speed_tol)
        np.testing.assert_allclose(f(b["turn_exit_speed"])[inner], exit_["B"][inner], atol=speed_tol)
        np.testing.assert_allclose(f(b["turn_length"])[inner], length["B"][inner], atol=dist_tol)
        np.testing.assert_allclose(f(b["turn_length_diff"])[inner], (length["B"] - length["A"])[inner], atol=dist_tol)


def test_event_crossings_recover_section_offsets(files, tmp_path):
    out = tmp_path / "cmp.parquet"
    res = run_cli(["compare-runs", str(files["A"]), "--run", str(files["B"]), "-o", str(out)])
    assert res.returncode == 0, res.stderr.decode()
    s, meta = summary(out)
    assert list(s) == ["A", "B"]
    check_against_truth(s["B"], s["A"])
    assert set(s["B"]["crossing_source"]) == {"event"}
    assert meta["compare"]["reference"] == "A" and meta["compare"]["gates"] == GATE_IDS.tolist()
    assert meta["provenance"][-1]["tool"] == "compare-runs"
    table, _ = sfio.read_table(out)
    assert table.schema.field("acc_time_diff").metadata[b"unit"] == b"s"
    assert table.schema.field("path_distance").metadata[b"unit"] == b"m"


def test_closest_approach_to_surveyed_gates(files, tmp_path):
    out = tmp_path / "cmp.parquet"
    res = run_cli(
        ["compare-runs", "--run", str(files["B_plain"]), "--gates", str(files["gates"]), "-o", str(out)],
        stdin=files["A_plain"].read_bytes(),
    )
    assert res.returncode == 0, res.stderr.decode()
    s, meta = summary(out)
    assert list(s) == ["reference", "B_plain"]
    check_against_truth(s["B_plain"], s["reference"])
    # the gate lies 1.5 m (B) / 2.1 m (A) outside the apex
    np.testing.assert_allclose(f(s["B_plain"]["gate_distance"]), 1.5, atol=1e-3)
    np.testing.assert_allclose(f(s["reference"]["gate_distance"]), 2.1, atol=1e-3)
    assert set(s["B_plain"]["crossing_source"]) == {"closest"}


def test_positions_only_at_10hz(files, tmp_path):
    """Without velocity columns (not-a-knot spline through 10 Hz positions) the figures still hold
    (measured: speed 0.011 m/s, distance 0.7 mm, turn length 1.2 cm)."""
    out = tmp_path / "cmp.parquet"
    res = run_cli(
        ["compare-runs", str(files["A"]), "--run", str(files["B_10hz_novel"]), "--label", "Anna", "--label", "Berta"]
        + ["-o", str(out)]
    )
    assert res.returncode == 0, res.stderr.decode()
    s, _ = summary(out)
    assert list(s) == ["Anna", "Berta"]
    check_against_truth(s["Berta"], s["Anna"])


@pytest.mark.slow
def test_three_runs_and_missing_gate_left_out(files, tmp_path):
    out = tmp_path / "cmp.parquet"
    res = run_cli(
        ["compare-runs", str(files["A"]), "--run", str(files["B"]), "--run", str(files["A_plain"])]
        + ["--gates", str(files["gates"]), "--max-gate-distance", "2.0", "-o", str(out)]
    )
    # A_plain passes every gate 2.1 m away: beyond 2 m, it crosses none -> one clear line
    assert res.returncode == 1 and "passes no gate" in res.stderr.decode() and res.stdout == b""
    res = run_cli(
        ["compare-runs", str(files["A"]), "--run", str(files["B"]), "--run", str(files["A_plain"]), "-o", str(out)]
        + ["--gates", str(files["gates"])]
    )
    assert res.returncode == 0, res.stderr.decode()
    s, _ = summary(out)
    assert list(s) == ["A", "B", "A_plain"]
    # the same run found by closest approach instead of events: zero differences
    np.testing.assert_allclose(f(s["A_plain"]["acc_time_diff"]), 0.0, atol=1e-3)
    np.testing.assert_allclose(f(s["A_plain"]["path_distance_diff"]), 0.0, atol=1e-3)


def _one_error(res) -> str:
    assert res.returncode == 1, res.stderr.decode()
    assert res.stdout == b""
    lines = [ln for ln in res.stderr.decode().splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: compare-runs: "), lines
    return lines[0]


def test_different_courses_refused(files):
    line = _one_error(run_cli(["compare-runs", str(files["A"]), "--run", str(files["B_other_course"])]))
    assert "no gate in common" in line and "same course" in line


def test_run_without_crossings_refused(files):
    line = _one_error(run_cli(["compare-runs", str(files["A"]), "--run", str(files["B_plain"])]))
    assert "B_plain has no gate crossings" in line and "--gates" in line


def test_run_far_from_the_gates_refused(files):
    line = _one_error(
        run_cli(["compare-runs", str(files["A"]), "--run", str(files["B_far"]), "--gates", str(files["gates"])])
    )
    assert "B_far passes no gate" in line and "nearest" in line


def test_no_run_is_a_usage_error(files):
    res = run_cli(["compare-runs", str(files["A"])])
    assert res.returncode == 2 and "--run" in res.stderr.decode()


@pytest.mark.slow
def test_plot_compare_png_and_svg(files, tmp_path):
    pytest.importorskip("matplotlib")
    from test_plot import check_png, check_svg

    out = tmp_path / "cmp.parquet"
    res = run_cli(["compare-runs", str(files["A"]), "--run", str(files["B"]), "--run", str(files["B_10hz_novel"])])
    assert res.returncode == 0, res.stderr.decode()
    out.write_bytes(res.stdout)
    png, svg = tmp_path / "cmp.png", tmp_path / "cmp.svg"
    for img in (png, svg):
        r = run_cli(["plot", "compare", str(out), "-o", str(img)])
        assert r.returncode == 0, r.stderr.decode()
    check_png(png)
    check_svg(svg)
    # a session table is not a comparison
    r = run_cli(["plot", "compare", str(files["A"]), "-o", str(tmp_path / "x.png")])
    assert r.returncode == 1 and "compare-runs" in r.stderr.decode()


def test_noisy_rtk_tracks_smoothed_then_compared(files):
    """10 Hz RTK positions with 2 cm / 3 cm noise -> spline-smooth's library call (GCV) -> closest approach.

    Times still hold to 0.01 s (measured 2.5-4.5 ms over seeds 7, 8).  The noise the spline leaves
    adds path length, differently per run: the distance differences over the 300 m course err
    3-5 cm (0.05 m is the noise-free target, checked above), so 0.1 m here; speeds 0.13-0.17 m/s."""
    from sportfusion.skirace.compare import compare_tables
    from sportfusion.skirace.track import smooth_track

    rng = np.random.default_rng(7)
    gates = sfio.read_table(files["gates"], kind="gates")
    runs = []
    for r in ("A", "B"):
        table, meta = sfio.read_table(io.BytesIO(run_table(r, rate=10.0, events=False, velocity=False)), kind="session")
        t = table.column("t").to_numpy()
        pos = np.column_stack([table.column(c).to_numpy() for c in "xyz"])
        noisy = pos + rng.normal(size=pos.shape) * [0.02, 0.02, 0.03]
        sig = np.tile([0.02, 0.02, 0.03], (t.size, 1))
        res = smooth_track(t, noisy, np.full(t.size, 4), sig, lam=None)
        cols = {"t": t, **{c: res.columns[c] for c in ("x", "y", "z", "vx", "vy", "vz")}}
        runs.append((r, pa.table(cols), meta))
    table, info, _ = compare_tables(runs, gates)
    acc_dt, dist, spd, _, _, length = truth()
    d = table.to_pydict()
    m = np.array(d["run"]) == "B"
    got = {
        c: f(np.asarray(d[c], dtype=object)[m])
        for c in ("acc_time_diff", "path_distance_diff", "gate_speed", "turn_length")
    }
    np.testing.assert_allclose(got["acc_time_diff"], acc_dt, atol=0.01)
    np.testing.assert_allclose(got["path_distance_diff"], dist["B"] - dist["A"], atol=0.1)
    np.testing.assert_allclose(got["gate_speed"], spd["B"], atol=0.3)


@pytest.mark.slow
def test_speed_profile_along_the_course(files, tmp_path):
    """--profile: each run's speed at the same fraction of each section, against closed-form truth."""
    from scipy.optimize import brentq

    out, prof = tmp_path / "cmp.parquet", tmp_path / "prof.parquet"
    res = run_cli(
        ["compare-runs", str(files["A"]), "--run", str(files["B"]), "--profile", str(prof)]
        + ["--profile-step", "2.5", "-o", str(out)]
    )
    assert res.returncode == 0, res.stderr.decode()
    table, meta = sfio.read_table(prof, kind="summary")
    assert meta["compare"]["profile_step_m"] == 2.5
    run = np.array(table.column("run").to_pylist())
    s = table.column("path_distance").to_numpy()[run == "B"]
    sd = table.column("speed_diff").to_numpy()[run == "B"]
    assert np.all(table.column("speed_diff").to_numpy()[run == "A"] == 0)
    np.testing.assert_allclose(np.diff(s), 2.5)
    _, dist, _, _, _, _ = truth()

    def x_at_distance(r, d):
        return brentq(lambda x: arc(r, GATES_X[0], x) - d, GATES_X[0] - 1e-9, GATES_X[-1] + 1e-9, xtol=1e-10)

    for i in range(0, s.size, 7):  # every 17.5 m
        k = min(np.searchsorted(dist["A"], s[i], side="right") - 1, len(GATES_X) - 2)
        frac = (s[i] - dist["A"][k]) / (dist["A"][k + 1] - dist["A"][k])
        xb = x_at_distance("B", dist["B"][k] + frac * (dist["B"][k + 1] - dist["B"][k]))
        xa = x_at_distance("A", s[i])
        assert sd[i] == pytest.approx(speed("B", xb) - speed("A", xa), abs=0.05), (i, s[i])
    png = tmp_path / "p.png"
    r = run_cli(["plot", "compare", str(out), "--profile", str(prof), "-o", str(png)])
    assert r.returncode == 0, r.stderr.decode()
    assert png.stat().st_size > 20_000


def test_gates_given_as_lat_lon_h(files):
    """A gates table in WGS84 is converted into the runs' frame: the same crossings as with x y."""
    from sportfusion.core.frames import Frame
    from sportfusion.skirace.compare import compare_tables
    from sportfusion.skirace.sim_runs import FRAME

    gates, gmeta = sfio.read_table(files["gates"], kind="gates")
    lat, lon, h = Frame.from_meta(FRAME).to_geodetic(*(gates.column(c).to_numpy() for c in "xyz"))
    geo = pa.table({"gate": gates.column("gate"), "lat": lat, "lon": lon, "h": h})
    runs = [(r, *sfio.read_table(files[f"{r}_plain"], kind="session")) for r in ("A", "B")]
    by_xy, _, _ = compare_tables(runs, (gates, gmeta))
    by_geo, _, _ = compare_tables(runs, (geo, {k: v for k, v in gmeta.items() if k != "frame"}))
    np.testing.assert_allclose(by_geo.column("crossing_t").to_numpy(), by_xy.column("crossing_t").to_numpy(), atol=1e-6)
    # a gates table in x y of another frame is refused
    other = {**gmeta, "frame": {**FRAME, "azimuth_deg": 10.0}}
    with pytest.raises(InputError, match="different local frames"):
        compare_tables(runs, (gates, other))
