"""compare-runs: two simulated runs of one course with known section time offsets; plot compare; bad input.

The runs follow sinusoidal lines y = A sin(2 pi x / 50 m) down a 30 % slope, with the gates at the
apexes (x = 12.5 m + 25 m k, on the outside of the turn) and the turn switches at the inflections
(x = 25 m k).  Run B takes a wider line (A = 5.6 m instead of 5 m) and is delayed by a known
amount in each section (smootherstep within the section).  Truth comes from the closed-form
timing law and scipy quad arc lengths, independent of the library's Hermite/Gauss-Legendre code.
"""

from __future__ import annotations

import io

import numpy as np
import pyarrow as pa
import pytest
from conftest import run_cli
from scipy.integrate import quad

from sportfusion import io as sfio
from sportfusion import meta as sfmeta

LAMBDA = 50.0  # turn wavelength along x [m]
SLOPE = 0.3  # dz/dx [1]
GATES_X = 12.5 + 25.0 * np.arange(12)  # apexes [m]
GATE_IDS = np.arange(1, 13)
SECTION_DT = np.array([0.05, -0.03, 0.12, 0.0, -0.08, 0.07, 0.02, -0.11, 0.04, 0.09, -0.02])  # B minus A [s]
AMP = {"A": 5.0, "B": 5.6}
FRAME = {"name": "course", "origin": [46.4975, 9.8365, 2200.0], "azimuth_deg": 160.0, "axes": "x forward"}


def _smooth(u):
    """Smootherstep and its derivative: speed and acceleration stay continuous across the gates."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u * u), 30 * u * u * (1 - u) ** 2


def timing(run: str, x):
    """Time on the run's clock [s] and dt/dx [s/m] at course position x [m]."""
    x = np.asarray(x, float)
    t = x / 15.0 + 0.3 * np.sin(2 * np.pi * x / 130.0)
    dt = 1 / 15.0 + 0.3 * 2 * np.pi / 130.0 * np.cos(2 * np.pi * x / 130.0)
    if run == "B":
        t = t + 2.5  # B's clock started elsewhere: only differences count
        for k, d in enumerate(SECTION_DT):
            a, b = GATES_X[k], GATES_X[k + 1]
            s, ds = _smooth((x - a) / (b - a))
            t = t + d * s
            dt = dt + d * ds / (b - a)
    return t, dt


def path(run: str, x):
    """Position [m] and d(position)/dx [1] of the run's line."""
    x = np.asarray(x, float)
    k = 2 * np.pi / LAMBDA
    a = AMP[run]
    p = np.stack([x, a * np.sin(k * x), SLOPE * x], axis=-1)
    dp = np.stack([np.ones_like(x), a * k * np.cos(k * x), np.full_like(x, SLOPE)], axis=-1)
    return p, dp


def arc(run: str, x0: float, x1: float) -> float:
    return quad(lambda x: float(np.linalg.norm(path(run, x)[1])), x0, x1, epsabs=1e-10, limit=200)[0]


def speed(run: str, x: float) -> float:
    return float(np.linalg.norm(path(run, x)[1]) / timing(run, x)[1])


def x_at(run: str, t):
    """Invert the timing law (Newton on a dense-grid start)."""
    grid = np.linspace(0.0, 300.0, 30001)
    x = np.interp(t, timing(run, grid)[0], grid)
    for _ in range(6):
        tt, dt = timing(run, x)
        x = x - (tt - t) / dt
    return x


def run_table(run: str, *, rate=20.0, events=True, velocity=True, gate_ids=GATE_IDS, shift=(0.0, 0.0)) -> bytes:
    """A session table of the run: x y z (+ vx vy vz) at ``rate`` [Hz], gate event rows at the true crossings."""
    t0, t1 = timing(run, 2.0)[0], timing(run, 298.0)[0]
    t = np.arange(np.ceil(t0 * rate), np.floor(t1 * rate)) / rate
    x = x_at(run, t)
    p, dp = path(run, x)
    v = dp / timing(run, x)[1][:, None]
    p = p + np.array([shift[0], shift[1], 0.0])
    cols = {"t": t, "x": p[:, 0], "y": p[:, 1], "z": p[:, 2]}
    if velocity:
        cols.update(vx=v[:, 0], vy=v[:, 1], vz=v[:, 2])
    n = t.size
    ev = [None] * n
    gate = [None] * n
    if events:
        tg = timing(run, GATES_X)[0]
        cols = {k: np.concatenate([c, tg if k == "t" else np.full(tg.size, np.nan)]) for k, c in cols.items()}
        ev += ["gate"] * tg.size
        gate += [int(g) for g in gate_ids]
    order = np.argsort(cols["t"], kind="stable")
    arrays = {k: pa.array(c[order], mask=np.isnan(c[order])) for k, c in cols.items()}
    if events:
        arrays["event"] = pa.array([ev[i] for i in order], type=pa.string())
        arrays["gate"] = pa.array([gate[i] for i in order], type=pa.int32())
    meta = sfmeta.new_meta("session", 1.77e9 + (0.0 if run == "A" else 3600.0))
    meta["frame"] = FRAME
    return sfio.table_to_bytes(pa.table(arrays), meta)


def gates_table(ids=GATE_IDS) -> bytes:
    side = np.sign(np.sin(2 * np.pi * GATES_X / LAMBDA))
    y = side * (max(AMP.values()) + 1.5)  # outside of each turn
    table = pa.table(
        {
            "gate": pa.array(ids, type=pa.int32()),
            "x": GATES_X,
            "y": y,
            "z": SLOPE * GATES_X,
        }
    )
    meta = sfmeta.new_meta("gates")
    meta["frame"] = FRAME
    return sfio.table_to_bytes(table, meta)


def truth():
    """Expected per-gate values for run B relative to run A."""
    xs = GATES_X
    acc_dt = np.concatenate(([0.0], np.cumsum(SECTION_DT)))
    dist = {r: np.array([arc(r, xs[0], x) for x in xs]) for r in AMP}
    spd = {r: np.array([speed(r, x) for x in xs]) for r in AMP}
    inflect = np.arange(len(xs) + 1) * 25.0  # turn switches
    entry = {r: np.array([speed(r, x) for x in inflect[:-1]]) for r in AMP}
    exit_ = {r: np.array([speed(r, x) for x in inflect[1:]]) for r in AMP}
    length = {r: np.array([arc(r, a, b) for a, b in zip(inflect[:-1], inflect[1:], strict=True)]) for r in AMP}
    return acc_dt, dist, spd, entry, exit_, length


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
    from sportfusion.compare import compare_tables
    from sportfusion.spline_track import smooth_track

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
    acc_dt, dist, spd, _, _, _ = truth()
    d = table.to_pydict()
    m = np.array(d["run"]) == "B"
    got = {c: f(np.asarray(d[c], dtype=object)[m]) for c in ("acc_time_diff", "path_distance_diff", "gate_speed")}
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
