"""rts-smooth: accuracy against the simulator's truth, output columns, windows, several jumps, bad input."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from conftest import run_cli

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.frames import gnss_local_columns
from sportfusion.evaluate import errors
from sportfusion.skijump.hillfile import load_hill
from sportfusion.skijump.smoother import rts_smooth_table
from sportfusion.skijump.smoother_inputs import SmootherConfig
from sportfusion.skijump.smoother_start import initial_state

FIX = "fixtures/skijump/"
HILL = "oberstdorf_hs106"


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.nanmean(np.asarray(a) ** 2)))


def _imu_span(table: pa.Table) -> np.ndarray:
    """Rows within the IMU's recording (the receiver's first fix may come before the IMU's first sample: the
    full physics has its own clock for each; rts-smooth estimates nothing outside the IMU data)."""
    t = schema.floats(table, "t")
    ti = t[np.isfinite(schema.floats(table, "acc_x"))]
    return (t >= ti[0]) & (t <= ti[-1])


def _first_seconds(table: pa.Table, seconds: float) -> pa.Table:
    """The rows of the first ``seconds`` [s] (IMU and GNSS rows; a row count would depend on their mix)."""
    return table.slice(0, int(np.searchsorted(schema.floats(table, "t"), seconds)))


@pytest.fixture(scope="module")
def fixture_run():
    tab, meta = sfio.read_table(FIX + "session.parquet")
    truth, tmeta = sfio.read_table(FIX + "truth.parquet", kind="truth")
    times = tmeta["skijump"]["times"]
    hill = load_hill(HILL)
    out, ometa, msg = rts_smooth_table(
        tab, meta, hill, takeoff=[times["takeoff"]], touchdown=[times["touchdown"]], filtered=True
    )
    return tab, meta, truth, tmeta, hill, out, ometa


def test_keeps_input_and_adds_registered_columns(fixture_run):
    tab, _, _, _, _, out, ometa = fixture_run
    assert out.num_rows == tab.num_rows
    for name in tab.column_names:
        assert out.column(name).equals(tab.column(name))
    want = ["x", "y", "z", "vx", "vy", "vz", "q0", "q1", "q2", "q3", "roll", "pitch", "yaw"]
    want += [f"{p}_{a}" for p in ("bias_gyr", "bias_acc", "bias_mag", "scale_mag") for a in "xyz"]
    want += [f"std_{n}" for n in want] + ["c_q", "c_v_ir", "c_h_ir", "c_v_la"]
    want += [f"filt_{n}" for n in ("x", "y", "z", "vx", "vy", "vz", "q0", "q1", "q2", "q3", "roll", "pitch", "yaw")]
    for name in want:
        assert name in out.column_names, name
        assert schema.lookup(name) is not None, name
    assert ometa["frame"]["azimuth_deg"] == 312.6
    assert set(ometa["rts"]["residual_rms"]) >= {"gnss_pos", "gnss_vel", "mag", "c_q", "c_v_ir", "c_h_ir", "c_v_la"}


def test_end_to_end_accuracy_far_better_than_gnss(fixture_run):
    """Tolerances: Table 6 of the paper gives 0.11-0.16 m, 0.02-0.03 m/s, 0.3-0.8 deg; GNSS alone has 3/3/5 m."""
    tab, meta, truth, tmeta, _, out, _ = fixture_run
    az = meta["frame"]["azimuth_deg"]
    _, _, err = errors(out, truth, az, velocity_frame="ned")  # the paper's Table 6 frames
    g = gnss_local_columns(tab, load_hill(HILL).frame())
    gout = tab.append_column("gnss_x", pa.array(g["gnss_x"])).append_column("gnss_y", pa.array(g["gnss_y"]))
    gout = gout.append_column("gnss_z", pa.array(g["gnss_z"]))
    _, _, gerr = errors(gout, truth, az, gnss=True, velocity_frame="ned")
    for a in "xyz":
        assert _rms(err[a]) < 0.3, (a, _rms(err[a]))
        assert _rms(err[a]) < _rms(gerr[a]) / 8, (a, _rms(err[a]), _rms(gerr[a]))
    for a in ("vel_n", "vel_e", "vel_d"):
        assert _rms(err[a]) < 0.05, (a, _rms(err[a]))
        assert _rms(err[a]) < _rms(gerr[a]) / 2
    assert np.degrees(_rms(err["rot_angle"])) < 1.0
    # the forward filter alone is worse than the smoother
    fout = out.select(["t"]).append_column("x", out.column("filt_x"))
    _, _, ferr = errors(fout, truth, az)
    assert _rms(ferr["x"]) > _rms(err["x"])


def test_std_columns_are_consistent_with_the_errors(fixture_run):
    _, meta, truth, _, _, out, _ = fixture_run
    _, i_est, err = errors(out, truth, meta["frame"]["azimuth_deg"])
    for a in "xyz":
        s = schema.floats(out, f"std_{a}")[i_est]
        assert np.all(s[_imu_span(out)[i_est]] > 0)
        z = _rms(err[a] / s)
        assert 0.2 < z < 3.0, (a, z)


def test_biases_are_estimated(fixture_run):
    _, _, truth, tmeta, _, out, _ = fixture_run
    true = tmeta["skijump"]["sensor_errors"]
    for k, a in enumerate("xyz"):
        est = schema.floats(out, f"bias_gyr_{a}")[-1]
        assert abs(est - true["bias_gyr"][k]) < 0.1 * 0.0873 + 0.003, (a, est, true["bias_gyr"][k])
        est = schema.floats(out, f"bias_mag_{a}")[-1]
        assert abs(est - true["bias_mag"][k]) < 2.5, (a, est, true["bias_mag"][k])


def test_constraint_residual_columns_and_windows(fixture_run):
    _, _, _, tmeta, _, out, _ = fixture_run
    t = schema.floats(out, "t")
    to, td = tmeta["skijump"]["times"]["takeoff"], tmeta["skijump"]["times"]["touchdown"]
    cv, ch, cl, cq = (schema.floats(out, c) for c in ("c_v_ir", "c_h_ir", "c_v_la", "c_q"))
    # the in-run window opens at the step after the rest's first GNSS epoch within the IMU data (0.1 s: the fix at
    # 0.0 s precedes the IMU's first sample in the full physics, its clock has another phase)
    imu = _imu_span(out) & (t > 0.11)
    assert np.isfinite(cv[imu & (t <= to)]).all() and np.isnan(cv[t > to + 1e-9]).all()
    assert np.isfinite(ch[imu & (t <= to)]).all() and np.isnan(ch[t > to + 1e-9]).all()
    assert np.isnan(cl[t <= td]).all() and np.isfinite(cl[t > td + 0.01]).all()
    # soft constraints of 0.1 m: residuals of that order; the unit-norm constraint much tighter
    assert _rms(cv) < 0.15 and _rms(ch) < 0.15 and _rms(cl) < 0.15
    assert np.nanmax(np.abs(cq)) < 5e-3 and np.isfinite(cq[_imu_span(out)]).all()


@pytest.mark.slow
def test_hill_constraints_improve_height(fixture_run):
    tab, meta, truth, tmeta, hill, out, _ = fixture_run
    times = tmeta["skijump"]["times"]
    free, _, _ = rts_smooth_table(
        tab,
        meta,
        hill,
        SmootherConfig(hill_constraints=False),
        takeoff=[times["takeoff"]],
        touchdown=[times["touchdown"]],
    )
    az = meta["frame"]["azimuth_deg"]
    e_c = errors(out, truth, az)[2]
    e_f = errors(free, truth, az)[2]
    assert _rms(e_c["z"]) < 0.5 * _rms(e_f["z"])
    assert np.isnan(schema.floats(free, "c_v_ir")).all()


def _slice_bytes(n: int = 300) -> bytes:
    tab, meta = sfio.read_table(FIX + "session.parquet")
    return sfio.table_to_bytes(tab.slice(0, n), meta)


def test_cli_short_session_with_filtered_output():
    res = run_cli(["rts-smooth", "--hill", HILL, "--filtered", "--no-hill-constraints", "-q"], stdin=_slice_bytes())
    assert res.returncode == 0, res.stderr.decode()
    # -q: nothing but warnings; the fixture's first 3 s hold one of its wild GNSS fixes (full physics)
    lines = res.stderr.decode().splitlines()
    assert all(ln.startswith("Warning: rts-smooth: ") and "GNSS fix" in ln for ln in lines), lines
    import io

    import pyarrow.parquet as pq

    table = pq.read_table(io.BytesIO(res.stdout))
    meta = sfmeta.decode(table.schema.metadata[b"sportfusion"])
    assert meta["provenance"][-1]["tool"] == "rts-smooth"
    assert "filt_x" in table.column_names and np.isfinite(schema.floats(table, "x")[_imu_span(table)]).all()


def test_no_events_is_refused_not_guessed():
    """Without take-off/touch-down the hill constraints would be placed from speed alone (roll errors ~10x):
    refused in one line naming the three ways out; each way out runs."""
    res = run_cli(["rts-smooth", "--hill", HILL], stdin=_slice_bytes())
    assert res.returncode == 1 and res.stdout == b""
    lines = res.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: rts-smooth: no take-off/touch-down events"), lines
    for way in ("detect-events --kind jump", "--takeoff/--touchdown", "--no-hill-constraints"):
        assert way in lines[0]
    tab, meta = sfio.read_table(FIX + "session.parquet")
    with pytest.raises(InputError, match="no take-off/touch-down"):
        rts_smooth_table(tab.slice(0, 300), meta, load_hill(HILL))
    # explicit events (inside the slice) are accepted by the same call
    out, m, _ = rts_smooth_table(tab.slice(0, 300), meta, load_hill(HILL), takeoff=[1.0], touchdown=[2.0])
    assert m["rts"]["jumps"] == [{"takeoff": 1.0, "touchdown": 2.0}]
    assert np.isfinite(schema.floats(out, "x")[_imu_span(out)]).all()


@pytest.mark.parametrize(
    ("args", "drop", "expect"),
    [
        ([], ("gyr_x",), "gyr_x"),
        ([], ("lat", "lon", "h"), "gnss"),
        (["--takeoff", "100", "--touchdown", "101"], (), "outside"),
        (["--takeoff", "1"], (), "touch-down"),
        (["--hill-set", "lat=47.6"], (), "km from the hill"),
    ],
    ids=["no-imu", "no-gnss", "events-outside", "unpaired-event", "hill-far-away"],
)
def test_cli_bad_input_one_line(args, drop, expect):
    tab, meta = sfio.read_table(FIX + "session.parquet")
    tab = tab.slice(0, 300)
    if drop:
        tab = tab.drop_columns(list(drop))
    res = run_cli(["rts-smooth", "--hill", HILL, *args], stdin=sfio.table_to_bytes(tab, meta))
    assert res.returncode == 1, res.stderr.decode()
    assert res.stdout == b""
    lines = res.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: rts-smooth: "), lines
    assert expect in lines[0].lower() or expect in lines[0], lines[0]


@pytest.mark.slow
def test_two_jumps_in_one_session():
    """Two simulated jumps 30 s apart (IMU gap between them): each smoothed, both metrics near truth."""
    from sportfusion.skijump.metrics import jump_metrics_table
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

    hill = load_hill(HILL)
    sims = [simulate_skijump(hill, SkiJumpConfig(seed=s)) for s in (3, 4)]
    t1 = schema.floats(sims[0].session, "t")
    shift = t1[-1] + 30.0
    second = sims[1].session
    second = second.set_column(0, "t", pa.array(schema.floats(second, "t") + shift))
    session = pa.concat_tables([sims[0].session, second])
    tt = [sims[0].truth_meta["skijump"]["times"], sims[1].truth_meta["skijump"]["times"]]
    to = [tt[0]["takeoff"], tt[1]["takeoff"] + shift]
    td = [tt[0]["touchdown"], tt[1]["touchdown"] + shift]
    out, ometa, _ = rts_smooth_table(session, sims[0].session_meta, hill, takeoff=to, touchdown=td)
    truth = pa.concat_tables(
        [sims[0].truth, sims[1].truth.set_column(0, "t", pa.array(schema.floats(sims[1].truth, "t") + shift))]
    )
    err = errors(out, truth, 312.6)[2]
    for a in "xyz":
        assert _rms(err[a]) < 0.3
    # no estimate in the gap between the recordings
    t = schema.floats(out, "t")
    recorded = np.concatenate([_imu_span(sims[0].session), _imu_span(second)])  # each recording's IMU span
    assert np.isfinite(schema.floats(out, "x")[recorded]).all()
    assert t.size == session.num_rows
    # jump metrics need the events in the table
    from sportfusion.core.events import set_events

    out = set_events(
        out,
        [("takeoff", to[0]), ("touchdown", td[0]), ("takeoff", to[1]), ("touchdown", td[1])],
        replace=("takeoff", "touchdown"),
    )
    jumps, jmeta, _ = jump_metrics_table(out, ometa, hill)
    assert jumps.num_rows == 2
    got = schema.floats(jumps, "jump_length")
    want = [s.truth_meta["jump_length"] for s in sims]
    assert np.abs(got - want).max() < 1.0, (got, want)


def _native_built() -> bool:
    from sportfusion.skijump import _ski_native

    return _ski_native.native() is not None


needs_c = pytest.mark.skipif(not _native_built(), reason="the C extension sportfusion.skijump._ski_c is not built")


def _inputs(tab, meta, hill, cfg, takeoff, touchdown):  # noqa: ANN001, ANN202
    from sportfusion.skijump import smoother_inputs as RI

    return RI.session_inputs(tab, meta, hill, cfg, takeoff, touchdown)[0]


@needs_c
def test_c_engine_equals_the_numpy_reference() -> None:
    """The C loop -- packed covariances, scalar updates (zero-velocity ones included), the std rows of its
    backward pass -- reproduces ekf_rts with the model callables on the same inputs."""
    from sportfusion.skijump.smoother_outputs import _std_from_cov
    from sportfusion.skijump.smoother_passes import smooth_inputs

    tab, meta = sfio.read_table(FIX + "session.parquet")
    tab = _first_seconds(tab, 9.0)  # rest, release, in-run
    hill = load_hill(HILL)
    cfg = SmootherConfig(passes=1)
    inp = _inputs(tab, meta, hill, cfg, [8.0], [8.5])
    assert inp.still is not None and inp.still.sum() > 100  # the rest at the gate: zero-velocity updates
    a = smooth_inputs(inp, cfg, engine="c")
    b = smooth_inputs(inp, cfg, engine="numpy")
    np.testing.assert_allclose(a.x_filt, b.x_filt, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.x_smooth, b.x_smooth, rtol=0, atol=1e-9)
    idx = np.arange(22)
    np.testing.assert_allclose(a.cov(idx), b.cov(idx), rtol=0, atol=1e-10)
    np.testing.assert_allclose(a.var(), b.var(), rtol=0, atol=1e-10)
    # standard deviations computed in the compiled backward pass = the numpy ones from the covariances
    assert b.std is None and a.std.shape == (inp.t.size, 28)
    want = np.hstack(_std_from_cov(b.x_smooth, b.cov, inp, b.var))
    np.testing.assert_allclose(a.std, want, rtol=1e-7, atol=1e-12)
    assert set(a.residuals) == set(b.residuals)
    for k in a.residuals:
        np.testing.assert_allclose(a.residuals[k], b.residuals[k], rtol=0, atol=1e-9)


def test_engine_choice() -> None:
    """auto runs C where it is built, numpy otherwise; c without the extension and unknown engines are refused."""
    from sportfusion.skijump import _ski_native
    from sportfusion.skijump import smoother_engine as E

    assert E.compiled("numpy") is False
    assert E.compiled("auto") is _native_built()
    with pytest.raises(InputError, match="expected one of auto, c, numpy"):
        E.compiled("fortran")
    saved = _ski_native._NATIVE
    try:
        _ski_native._NATIVE = None  # as where it is not built
        assert E.compiled("auto") is False
        with pytest.raises(InputError, match="not built.*pip install -e ."):
            E.compiled("c")
    finally:
        _ski_native._NATIVE = saved


@needs_c
def test_c_forward_run_without_filtered_covariances() -> None:
    """A forward run that keeps no covariances (the start window's) gives the same states and residuals."""
    from sportfusion.skijump import smoother_engine as E

    _, _, _, cfg, inp, x0, P0 = _first_900_rows()
    kept = E.run(inp, cfg, x0, P0, True, smooth=False)
    assert kept.cov.shape == (0, 253)  # no filtered covariances
    full = E.run(inp, cfg, x0, P0, True, smooth=True)
    np.testing.assert_array_equal(kept.x_filt, full.x_filt)
    for k in full.residuals:
        np.testing.assert_array_equal(kept.residuals[k], full.residuals[k])


@pytest.mark.parametrize("engine", [pytest.param("c", marks=needs_c), "numpy"])
def test_smoothing_without_keeping_the_covariances(engine: str) -> None:
    """keep_cov=False (what rts-smooth runs: only the std rows are written): the same states, std rows and
    residuals over two segments, no covariances kept by the C engine (cov/var refuse; its backward pass writes
    none); the numpy engine, which has no std rows, keeps them regardless."""
    from sportfusion.skijump import smoother_engine as E
    from sportfusion.skijump.smoother_passes import smooth_inputs

    # the numpy reference on the rest at the gate alone (4 s, no jump): it is slow
    secs, cut, takeoff, touchdown = (9.0, 4.0, [13.0], [13.5]) if engine == "c" else (4.0, 2.0, [], [])
    tab, meta = sfio.read_table(FIX + "session.parquet")
    tab = _first_seconds(tab, secs)
    t = schema.floats(tab, "t")
    tab = tab.set_column(0, "t", pa.array(np.where(t > cut, t + 5.0, t)))  # logging paused: two segments
    hill = load_hill(HILL)
    cfg = SmootherConfig(passes=1)
    inp = _inputs(tab, meta, hill, cfg, takeoff, touchdown)
    a = smooth_inputs(inp, cfg, engine=engine, keep_cov=False)
    b = smooth_inputs(inp, cfg, engine=engine)
    assert len(a.passes) == 2
    np.testing.assert_array_equal(a.x_smooth, b.x_smooth)
    for k in b.residuals:
        np.testing.assert_array_equal(a.residuals[k], b.residuals[k], err_msg=k)
    assert b.var().shape == (inp.t.size, 22)
    if engine == "numpy":
        assert a.std is None and b.std is None
        np.testing.assert_array_equal(a.var(), b.var())
        return
    np.testing.assert_array_equal(a.std, b.std)
    with pytest.raises(RuntimeError, match="not kept"):
        a.cov(np.arange(3))
    with pytest.raises(RuntimeError, match="not kept"):
        a.var()
    x0, P0 = initial_state(inp, cfg)
    assert E.run(inp, cfg, x0, P0, True, smooth=True, keep_cov=False).cov.shape == (0, 253)


def _first_900_rows():  # noqa: ANN202
    """The fixture session's first 9 s (rest and in-run, take-off placed at 8 s), one pass: its inputs and initial
    state."""
    tab, meta = sfio.read_table(FIX + "session.parquet")
    hill = load_hill(HILL)
    cfg = SmootherConfig(passes=1)
    inp = _inputs(_first_seconds(tab, 9.0), meta, hill, cfg, [8.0], [8.5])
    x0, P0 = initial_state(inp, cfg)
    return tab, meta, hill, cfg, inp, x0, P0


@needs_c
def test_c_backward_pass_from_the_stored_predictions(monkeypatch: pytest.MonkeyPatch) -> None:
    """The forward pass's predictions kept in ``work``'s third array give the backward pass the numbers it
    would form again, to the bit; smooth_inputs keeps them on a session of many short segments only."""
    from sportfusion.skijump import _ski_native
    from sportfusion.skijump import smoother_engine as E
    from sportfusion.skijump.smoother_passes import smooth_inputs

    tab, meta, hill, cfg, inp, x0, P0 = _first_900_rows()
    n = inp.t.size
    work = (np.empty((n, 22)), np.empty((n, 253)))
    pred = np.full((n, _ski_native.NPRED), np.nan)
    a = E.run(inp, cfg, x0, P0, True, smooth=True, keep_cov=False, work=work)
    b = E.run(inp, cfg, x0, P0, True, smooth=True, keep_cov=False, work=(*work, pred))
    assert np.isfinite(pred[: n - 1]).all() and np.isnan(pred[n - 1]).all()  # filled by the forward pass
    for i in (0, 1, 4):
        np.testing.assert_array_equal(a[i], b[i])
    for k in a.residuals:
        np.testing.assert_array_equal(a.residuals[k], b.residuals[k], err_msg=k)

    seen = []
    run = _ski_native.ski_ekf_rts

    def spy(*args, **kw):  # noqa: ANN002, ANN003, ANN202
        w = kw.get("work")
        seen.append(w is not None and len(w) > 2 and w[2] is not None)  # the predictions' scratch
        return run(*args, **kw)

    monkeypatch.setattr(_ski_native, "ski_ekf_rts", spy)
    t = schema.floats(_first_seconds(tab, 9.0), "t")
    paused = _first_seconds(tab, 9.0).set_column(0, "t", pa.array(t + 5.0 * np.searchsorted([2.25, 4.5, 6.75], t)))
    inp4 = _inputs(paused, meta, hill, cfg, [8.0 + 15.0], [8.5 + 15.0])  # four segments
    smooth_inputs(inp4, cfg, keep_cov=False)
    # four segments, each run with the predictions' scratch (a segment whose GNSS outliers are skipped runs twice)
    assert len(seen) >= 4 and set(seen) == {True}
    seen.clear()
    smooth_inputs(inp, cfg, keep_cov=False)  # one segment: fresh scratch would cost more than it saves
    assert set(seen) == {False}


@needs_c
@pytest.mark.parametrize("nb", [1, 97, 400])
def test_c_backward_pass_in_blocks_is_the_whole_history_to_the_bit(nb: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 38: ``work`` shorter than the run: the backward pass goes through blocks of ``nb`` steps, each
    block's forward pass run again from a checkpoint (the last block shorter than the others; blocks of one step
    too), with and without the stored predictions -- the states, std rows and residuals of the whole history,
    to the bit; smooth_inputs keeps blocks of ``BLOCK_STEPS`` on a longer session, the same numbers, with or
    without the filtered states kept."""
    from sportfusion.skijump import _ski_native
    from sportfusion.skijump import smoother_engine as E
    from sportfusion.skijump.smoother_passes import smooth_inputs

    _, _, _, cfg, inp, x0, P0 = _first_900_rows()
    n = inp.t.size
    assert n > 2 * nb
    whole = E.run(inp, cfg, x0, P0, True, smooth=True, keep_cov=False, work=(np.empty((n, 22)), np.empty((n, 253))))
    for pred in ((), (np.empty((nb, _ski_native.NPRED)),)):
        work = (np.full((nb + 1, 22), np.nan), np.full((nb, 253), np.nan), *pred)
        got = E.run(inp, cfg, x0, P0, True, smooth=True, keep_cov=False, work=work)
        for i in (0, 1, 4):
            np.testing.assert_array_equal(got[i], whole[i])
        for k in whole.residuals:
            np.testing.assert_array_equal(got.residuals[k], whole.residuals[k], err_msg=k)
    with pytest.raises(ValueError, match="x_pred and P_packed"):  # a block's priors need nb + 1 rows
        E.run(inp, cfg, x0, P0, True, smooth=True, keep_cov=False, work=(np.empty((nb, 22)), np.empty((nb, 253))))
    a = smooth_inputs(inp, cfg, keep_cov=False)
    c = smooth_inputs(inp, cfg, keep_cov=False, keep_filtered=False)  # one block: the whole run's scratch
    np.testing.assert_array_equal(a.x_smooth, c.x_smooth)
    np.testing.assert_array_equal(a.std, c.std)
    monkeypatch.setattr(_ski_native, "BLOCK_STEPS", nb)
    for keep_filtered in (True, False):  # without the filtered states: only one block of them, as scratch
        b = smooth_inputs(inp, cfg, keep_cov=False, keep_filtered=keep_filtered)
        np.testing.assert_array_equal(a.x_smooth, b.x_smooth)
        np.testing.assert_array_equal(a.std, b.std)
        for k in a.residuals:
            np.testing.assert_array_equal(a.residuals[k], b.residuals[k], err_msg=k)
        if keep_filtered:
            np.testing.assert_array_equal(a.x_filt, b.x_filt)
        else:
            assert b.x_filt.shape == (0, 22)


@needs_c
def test_c_loop_writes_states_and_std_column_by_column() -> None:
    """The C loop's smoothed states and std rows written into a session's column-major arrays (a segment at an
    offset) are its row-major results, to the bit; each column of them is contiguous; other layouts are refused."""
    from sportfusion.skijump import _ski_native
    from sportfusion.skijump import smoother_engine as E

    _, _, hill, cfg, inp, x0, P0 = _first_900_rows()
    n = inp.t.size
    rows = (np.empty((n, 22)), np.empty((n, 22)), np.empty((n, _ski_native.NRES)), np.empty((n, _ski_native.NSTD)))
    a = E.run(inp, cfg, x0, P0, True, smooth=True, keep_cov=False, out=rows)
    xs, std = _ski_native.column_outputs(n + 7)
    assert xs[:, 3].flags.c_contiguous and std[:, 3].flags.c_contiguous
    xs.T[:] = np.nan
    cols = (np.empty((n, 22)), xs[5 : 5 + n], np.empty((n, _ski_native.NRES)), std[5 : 5 + n])
    b = E.run(inp, cfg, x0, P0, True, smooth=True, keep_cov=False, out=cols)
    np.testing.assert_array_equal(a.x_smooth, b.x_smooth)
    np.testing.assert_array_equal(a.std, b.std)
    np.testing.assert_array_equal(b.x_smooth, xs[5 : 5 + n])
    assert np.isnan(xs[:5]).all() and np.isnan(xs[5 + n :]).all()  # nothing written outside the segment
    for k in a.residuals:
        np.testing.assert_array_equal(a.residuals[k], b.residuals[k], err_msg=k)
    strided = (np.empty((n, 22)), np.empty((n, 44))[:, ::2], np.empty((n, _ski_native.NRES)), std[5 : 5 + n])
    with pytest.raises(ValueError, match="x_smooth must be"):
        E.run(inp, cfg, x0, P0, True, smooth=True, keep_cov=False, out=strided)


@pytest.mark.slow
def test_relinearisation_passes_recover_a_bad_start():
    """Seed 0 draws a gyro bias of 0.11 rad/s: one EKF pass locks onto a wrong heading, the passes do not."""
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump

    hill = load_hill(HILL)
    sim = simulate_skijump(hill, SkiJumpConfig(seed=0, physics="paper"))  # the paper's Table 3 bias prior
    tt = sim.truth_meta["skijump"]["times"]
    kw = {"takeoff": [tt["takeoff"]], "touchdown": [tt["touchdown"]]}
    # the magnetometer's heading at the rest (no in-run alignment), one pass
    one_cfg = SmootherConfig(passes=1, inrun_align=False)
    one, _, _ = rts_smooth_table(sim.session, sim.session_meta, hill, one_cfg, **kw)
    many, m, _ = rts_smooth_table(sim.session, sim.session_meta, hill, SmootherConfig(), **kw)
    e1 = errors(one, sim.truth, 312.6)[2]
    e5 = errors(many, sim.truth, 312.6)[2]
    assert np.degrees(_rms(e1["yaw"])) > 1.0
    assert np.degrees(_rms(e5["yaw"])) < 0.759  # Table 6
    assert 2 <= m["rts"]["passes"][0] <= SmootherConfig().passes + 2  # + one where GNSS outliers were skipped


@pytest.mark.parametrize("engine", ["numpy", pytest.param("c", marks=needs_c)])
def test_degenerate_covariance_is_a_clear_error_not_nans(engine):
    """A hard c_q on a quaternion given zero prior variance: the innovation variance is zero at step 0."""
    from sportfusion.core.errors import InputError

    tab, meta = sfio.read_table(FIX + "session.parquet")
    hill = load_hill(HILL)
    cfg = SmootherConfig(p0_quat=0.0, r_c_q=0.0, passes=1, hill_constraints=False)
    with pytest.raises(InputError, match=r"step 0 \(t = 0\.\d{3} s\)"):  # the IMU's first sample
        rts_smooth_table(tab.slice(0, 200), meta, hill, cfg, engine=engine)


@pytest.mark.slow
@needs_c
@pytest.mark.parametrize("flag", ["-DSKI_PLAIN_C", "-DSKI_NO_CLONES"])
def test_c_other_builds_agree_with_this_one(flag: str, tmp_path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The loop built as other compilers and CPUs get it -- plain C without GCC's/Clang's vector types
    (-DSKI_PLAIN_C), the vector types on the baseline x86-64 alone (-DSKI_NO_CLONES: no AVX2/FMA clone) --
    gives this build's filtered and smoothed states, covariances and std rows to ~1e-11."""
    import importlib.util
    import shlex
    import shutil
    import subprocess
    import sysconfig
    from pathlib import Path

    from sportfusion.skijump import _ski_native
    from sportfusion.skijump import smoother_engine as E

    ld = shlex.split(sysconfig.get_config_var("LDSHARED") or "")
    if not ld or shutil.which(ld[0]) is None:
        pytest.skip("no C compiler here")
    src = Path(_ski_native.__file__).with_name("_ski_c.c")
    so = tmp_path / ("_ski_c" + sysconfig.get_config_var("EXT_SUFFIX"))
    flags = shlex.split(sysconfig.get_config_var("CCSHARED") or "")
    cmd = [*ld, *flags, "-O2", flag, "-I" + sysconfig.get_paths()["include"], str(src), "-o", str(so)]
    build = subprocess.run([*cmd, "-lm"], capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    spec = importlib.util.spec_from_file_location("sportfusion.skijump._ski_c", so)
    other = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(other)

    tab, meta, hill, cfg, inp, x0, P0 = _first_900_rows()
    a = E.run(inp, cfg, x0, P0, True, smooth=True)
    monkeypatch.setattr(_ski_native, "_NATIVE", other)
    b = E.run(inp, cfg, x0, P0, True, smooth=True)
    np.testing.assert_allclose(a[0], b[0], rtol=0, atol=1e-9)  # (other flags: the last bits differ)
    np.testing.assert_allclose(a[1], b[1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(a[2], b[2], rtol=0, atol=1e-10)
    np.testing.assert_allclose(a[4], b[4], rtol=1e-7, atol=1e-12)
    assert np.abs(a[1] - b[1]).max() > 0  # two builds, not one twice


def test_residual_rms_over_the_updates_made() -> None:
    """residual_rms: the RMS over the finite entries of each block (np.nanmean's), blocks never updated left out."""
    from sportfusion.skijump.smoother_outputs import residual_rms

    rng = np.random.default_rng(3)
    whole = rng.normal(size=(500, 5))
    whole[rng.random((500, 5)) < 0.7] = np.nan
    whole[:, 4] = np.nan
    res = {"a": whole[:, 0:1], "b": whole[:, 1:4], "never": whole[:, 4:5]}
    got = residual_rms(res)
    assert set(got) == {"a", "b"}
    for k in ("a", "b"):
        assert got[k] == pytest.approx(float(np.sqrt(np.nanmean(res[k] ** 2))), rel=1e-13)
