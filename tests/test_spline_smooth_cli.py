"""``spline-smooth`` end to end on simulated ski runs: contract, columns, accuracy vs truth and the paper."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from conftest import run_cli, session_bytes

from sportfusion.core import io as sfio
from sportfusion.core.schema import floats
from sportfusion.skirace.sim import SkiRaceConfig, simulate_skirace

#: the paper's Table 1 (interpolating splines on decimated 10 Hz downhill data) [m]
TABLE1 = {2: (0.02, 0.02, 0.03, 0.03), 1: (0.09, 0.09, 0.12, 0.13), 0.5: (0.73, 0.65, 0.42, 0.38)}


def sim_bytes(seed: int = 1, **kw) -> tuple[bytes, pa.Table, object]:
    s = simulate_skirace(SkiRaceConfig(seed=seed, **kw))
    return sfio.table_to_bytes(s.session, s.meta), s.truth, s


def smooth(data: bytes, *args: str) -> pa.Table:
    res = run_cli(["spline-smooth", *args], stdin=data)
    assert res.returncode == 0, res.stderr.decode()
    return sfio.table_from_bytes(res.stdout)


def xyz(table, prefix="", suffix=""):
    return np.column_stack([floats(table, f"{prefix}{a}{suffix}") for a in "xyz"])


@pytest.fixture(scope="module")
def run1():
    data, truth, s = sim_bytes(1)
    return data, truth, s, smooth(data)


def test_missing_track_says_run_gps2hill():
    res = run_cli(["spline-smooth"], stdin=session_bytes({"lat": np.full(20, 46.0)}))
    assert res.returncode == 1 and res.stdout == b""
    line = res.stderr.decode().strip().splitlines()[-1]
    assert line.startswith("Error: spline-smooth: ") and "gps2hill" in line


def test_columns_rows_metadata(run1):
    data, truth, s, out = run1
    inp = sfio.table_from_bytes(data)
    assert out.num_rows == inp.num_rows
    for name in inp.column_names:  # passed through untouched
        assert out.column(name).equals(inp.column(name)), name
    for name in ("x", "vy", "az", "speed", "distance", "course", "std_x", "spline_filled"):
        assert name in out.column_names
    assert out.schema.field("course").metadata[b"unit"] == b"rad"
    meta = sfio.get_meta(out)
    assert meta["frame"] == s.meta["frame"]
    steps = meta["provenance"]
    assert len(steps) == len(s.meta["provenance"]) + 1 and steps[-1]["tool"] == "spline-smooth"
    assert steps[-1]["params"]["lambda_used"] == [0.9, 0.9, 0.9]
    # IMU rows between GNSS epochs got values too; rows outside the GNSS span stay null
    t = floats(out, "t")
    has = np.isfinite(floats(out, "gnss_x"))
    inside = (t >= t[has][0]) & (t <= t[has][-1])
    assert np.isfinite(floats(out, "x")[inside]).all()
    assert np.isnan(floats(out, "x")[~inside]).all()


def test_gaps_are_bridged_and_marked(run1):
    _, truth, s, out = run1
    t = floats(out, "t")
    filled = out.column("spline_filled").fill_null(False).to_numpy()
    gaps = np.flatnonzero(np.diff(s.gnss_t) > 0.5)
    assert gaps.size >= 1
    for g in gaps:
        inside = (t > s.gnss_t[g] + 0.01) & (t < s.gnss_t[g + 1] - 0.01)
        assert filled[inside].all()
        # the std inside a gap is given and exceeds the edges' (it holds the bridge's error)
        sx = floats(out, "std_x")
        edges = sx[np.isin(t, s.gnss_t[g : g + 2])]
        assert np.isfinite(sx[inside]).all() and sx[inside].max() > edges.max()
        err = np.linalg.norm(xyz(out)[inside] - xyz(truth, "true_")[inside], axis=1)
        assert err.max() < 3.0  # a cubic bridge over <= 2 s of turning
    assert filled.sum() < 0.2 * filled.size


def test_velocity_course_distance_sigma(run1):
    _, truth, s, out = run1
    t = floats(out, "t")
    ok = np.isfinite(floats(out, "x")) & ~out.column("spline_filled").fill_null(False).to_numpy() & (t > 6)
    v_err = np.linalg.norm(xyz(out, "v")[ok] - xyz(truth, "true_v")[ok], axis=1)
    assert np.median(v_err) < 0.15  # m/s
    tv = xyz(truth, "true_v")[ok]
    az = np.radians(160.0)
    true_course = np.arctan2(
        tv[:, 0] * np.sin(az) + tv[:, 1] * np.cos(az), tv[:, 0] * np.cos(az) - tv[:, 1] * np.sin(az)
    )
    d = np.angle(np.exp(1j * (floats(out, "course")[ok] - true_course)))
    assert np.degrees(np.median(np.abs(d))) < 0.5
    dist = floats(out, "distance")
    assert np.all(np.diff(dist[np.isfinite(dist)]) >= -1e-9)
    step = np.linalg.norm(np.diff(xyz(truth, "true_")[np.isfinite(dist)], axis=0), axis=1).sum()
    assert abs(np.nanmax(dist) - step) < 0.01 * step
    # formal 1-sigma at fixed epochs: below the 1.5 cm / 3 cm input sigma
    fixed = floats(out, "gnss_fix") == 4
    assert np.nanmedian(floats(out, "std_x")[fixed]) < 0.015
    assert np.nanmedian(floats(out, "std_z")[fixed]) < 0.03


@pytest.mark.slow
def test_weighted_beats_uniform_around_float_periods():
    """Eq 6 weighting vs one uniform weight (same lambda) on runs with float episodes (printed)."""
    rows = []
    for seed in (1, 2, 3):
        data, truth, _ = sim_bytes(seed)
        errs = {}
        for mode in ("eq6", "uniform"):
            out = smooth(data, "--weighting", mode)
            has = np.isfinite(floats(out, "gnss_x"))
            e = np.linalg.norm(xyz(out)[has] - xyz(truth, "true_")[has], axis=1)
            fix = floats(out, "gnss_fix")[has]
            tk = floats(out, "t")[has]
            near = np.zeros(tk.size, bool)
            for tf in tk[fix != 4]:
                near |= np.abs(tk - tf) <= 1.0
            around = near & (fix == 4)
            errs[mode] = (np.sqrt(np.mean(e[around] ** 2)), np.sqrt(np.mean(e[fix != 4] ** 2)))
        rows.append((errs["eq6"], errs["uniform"]))
        print(
            f"seed {seed}: RMS error at fixed epochs within 1 s of float: eq6 {errs['eq6'][0]:.3f} m, "
            f"uniform {errs['uniform'][0]:.3f} m; in float periods: eq6 {errs['eq6'][1]:.3f} m, uniform {errs['uniform'][1]:.3f} m"
        )
    around = np.array([[r[0][0], r[1][0]] for r in rows])
    inside = np.array([[r[0][1], r[1][1]] for r in rows])
    assert np.all(around[:, 0] <= 0.7 * around[:, 1])  # >= 30 % lower around the transitions
    assert np.mean(inside[:, 0]) <= 1.05 * np.mean(inside[:, 1])  # not worse inside float periods


@pytest.mark.slow
def test_table1_decimated_interpolation():
    """Interpolating splines through 2 / 1 / 0.5 Hz subsets of a clean 10 Hz track (paper Table 1)."""
    s = simulate_skirace(SkiRaceConfig(seed=3, float_episodes=0, lock_losses=0, jumps=0))
    table = s.session
    gx = floats(table, "gnss_x")
    has = np.flatnonzero(np.isfinite(gx))
    has = has[floats(table, "t")[has] > 7.0]  # the run, not the standing start
    ours = {}
    for rate, step in ((2, 5), (1, 10), (0.5, 20)):
        keep = has[::step]
        drop = np.setdiff1d(has, keep)
        cols = {}
        for c in ("gnss_x", "gnss_y", "gnss_z"):
            v = floats(table, c).copy()
            v[drop] = np.nan
            v[has[0] - 1 :: -1] = np.nan
            cols[c] = pa.array(v, mask=np.isnan(v))
        t2 = table
        for c, a in cols.items():
            t2 = t2.set_column(t2.column_names.index(c), c, a)
        t2 = t2.drop_columns(["std_gnss_x", "std_gnss_y", "std_gnss_z", "gnss_sigma_h", "gnss_sigma_v"])
        out = smooth(sfio.table_to_bytes(t2, s.meta), "--lambda", "1")
        inside = drop[(drop > keep[0]) & (drop < keep[-1])]
        d = xyz(out)[inside] - np.column_stack([floats(table, f"gnss_{a}") for a in "xyz"])[inside]
        dh, dv = np.hypot(d[:, 0], d[:, 1]), np.abs(d[:, 2])
        ours[rate] = (dh.mean(), dh.std(), dv.mean(), dv.std())
    print("Table 1 (mean/1-sigma horizontal, mean/1-sigma vertical) [m]: ours | paper")
    for rate in (2, 1, 0.5):
        print(
            f"  {rate:>3} Hz: "
            + " ".join(f"{v:.3f}" for v in ours[rate])
            + " | "
            + " ".join(f"{v:.2f}" for v in TABLE1[rate])
        )
    h1, v1 = ours[1][1], ours[1][3]
    assert 0.09 / 3 < h1 < 0.09 * 3 and 0.13 / 3 < v1 < 0.13 * 3  # comparable to the paper at 1 Hz
    assert ours[2][1] < ours[1][1] < ours[0.5][1]


def test_options_and_usage_errors(run1):
    data = run1[0]
    out = smooth(data, "--lambda", "gcv", "--segment", "20:30=0.99")
    assert np.isfinite(floats(out, "x")).sum() > 1000
    assert "std_x" not in out.column_names  # 1-sigma is not computed with per-segment lambda
    used = sfio.get_meta(out)["provenance"][-1]["params"]["lambda_used"]  # GCV's choice outside the segment
    assert len(used) == 3 and all(0.0 < v <= 1.0 for v in used)
    for bad in (["--lambda", "2"], ["--lambda", "abc"], ["--segment", "20-30"], ["--weighting", "x"]):
        res = run_cli(["spline-smooth", *bad], stdin=data)
        assert res.returncode == 2, bad
