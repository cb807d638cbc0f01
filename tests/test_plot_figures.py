"""plot speed/series/errors/mag/spline/gates/holds: each figure is a labelled, non-trivial image."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from conftest import ROOT, run_cli
from test_plot import check_png, check_svg

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import schema

pytest.importorskip("matplotlib")

FIX = ROOT / "fixtures" / "skijump"


def _estimate_from_truth(tmp_path: Path) -> tuple[Path, Path]:
    """A constructed estimate: the fixture's truth plus known small errors, with the GNSS columns."""
    truth, _ = sfio.read_table(FIX / "truth.parquet", kind="truth")
    session, meta = sfio.read_table(FIX / "session.parquet")
    rng = np.random.default_rng(3)
    n = truth.num_rows
    cols = {"t": truth.column("t")}
    for name in ("x", "y", "z", "vx", "vy", "vz", "q0", "q1", "q2", "q3", "roll", "pitch", "yaw"):
        cols[name] = pa.array(schema.floats(truth, f"true_{name}") + rng.normal(0, 0.01, n))
    for name in ("x", "y", "z", "vx", "vy", "vz"):
        cols[f"std_{name}"] = pa.array(np.full(n, 0.02))
    for name in ("gnss_x", "gnss_y", "gnss_z"):
        src = schema.floats(truth, f"true_{name[-1]}")
        has = ~np.isnan(schema.floats(session, "lat"))
        cols[name] = pa.array(np.where(has, src + rng.normal(0, 1.0, n), np.nan))
    for a in "xyz":
        cols[f"mag_{a}"] = session.column(f"mag_{a}")
        cols[f"mag_pred_{a}"] = pa.array(schema.floats(truth, f"true_mag_{a}"))
    cols["event"] = truth.column("event")
    est = tmp_path / "est.parquet"
    est.write_bytes(sfio.table_to_bytes(pa.table(cols), meta))
    return est, FIX / "truth.parquet"


@pytest.mark.parametrize("fmt", ["png", "svg"])
def test_jump_figures(tmp_path, fmt):
    est, truth = _estimate_from_truth(tmp_path)
    for sub, extra in (
        ("speed", ["--hill", "oberstdorf_hs106"]),
        ("series", []),
        ("errors", ["--truth", str(truth)]),
        ("mag", []),
    ):
        out = tmp_path / f"{sub}.{fmt}"
        res = run_cli(["plot", sub, str(est), "-o", str(out), *extra])
        assert res.returncode == 0, (sub, res.stderr)
        (check_png if fmt == "png" else check_svg)(out)


def test_errors_figure_reports_the_constructed_rms(tmp_path):
    from sportfusion.core.plots import errors_figure

    est, truth = _estimate_from_truth(tmp_path)
    fig = errors_figure(sfio.read_table(est)[0], sfio.read_table(truth, kind="truth")[0])
    labels = [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()]
    rms = [float(lbl.split("RMS ")[1].split()[0]) for lbl in labels if lbl.startswith(("x:", "vx:"))]
    assert rms and all(abs(r - 0.01) < 0.002 for r in rms), labels  # the 1 cm / 1 cm/s noise we added


def test_mag_figure_needs_prediction(tmp_path):
    res = run_cli(["plot", "mag", str(FIX / "session.parquet"), "-o", str(tmp_path / "m.png")])
    assert res.returncode == 1 and "mag_pred" in res.stderr.decode()


def test_spline_figure(tmp_path):
    sess, truth, sm = tmp_path / "s.parquet", tmp_path / "t.parquet", tmp_path / "sm.parquet"
    assert (
        run_cli(
            ["simulate", "skirace", "--seed", "2", "--duration", "20", "--truth", str(truth), "-o", str(sess)],
            stdin=None,
        ).returncode
        == 0
    )
    assert run_cli(["spline-smooth", str(sess), "-o", str(sm)]).returncode == 0
    out = tmp_path / "spline.png"
    res = run_cli(["plot", "spline", str(sm), "--truth", str(truth), "-o", str(out)])
    assert res.returncode == 0, res.stderr
    check_png(out)


def test_float_spans():
    from sportfusion.skirace.plots import float_spans

    t = np.arange(10.0)
    fix = np.array([4, 5, 5, 4, 4, 5, 4, 4, 5, 5])
    assert float_spans(t, fix) == [(1.0, 2.0), (5.0, 5.0), (8.0, 9.0)]


def test_gates_figure(tmp_path):
    gx = np.arange(0, 250, 25.0)
    gy = 4.0 * (-1) ** np.arange(gx.size)
    gates = tmp_path / "gates.parquet"
    g = pa.table({"gate": pa.array(np.arange(1, gx.size + 1), pa.int32()), "x": gx, "y": gy, "z": gx * 0.3})
    gates.write_bytes(sfio.table_to_bytes(g, sfmeta.new_meta("gates")))
    t = np.arange(0, 25, 0.01)
    x = 10.0 * t
    y = 3.0 * np.sin(np.pi * x / 25.0 + np.pi / 2)
    ev = [None] * t.size
    gate = np.full(t.size, np.nan)
    for k, xv in enumerate(gx):
        i = int(np.argmin(np.abs(x - xv)))
        ev[i], gate[i] = "gate", k + 1
    run = pa.table(
        {
            "t": t,
            "x": x,
            "y": y,
            "z": x * 0.3,
            "event": pa.array(ev, pa.string()),
            "gate": pa.array(np.where(np.isnan(gate), None, gate), pa.int32()),
        }
    )
    sess = tmp_path / "run.parquet"
    sess.write_bytes(sfio.table_to_bytes(run, sfmeta.new_meta("session", 1.7e9)))
    out = tmp_path / "course.png"
    res = run_cli(["plot", "gates", str(sess), "--gates", str(gates), "-o", str(out)])
    assert res.returncode == 0, res.stderr
    check_png(out)


def test_holds_figure(tmp_path):
    holds, truth, sess = tmp_path / "h.parquet", tmp_path / "t.parquet", tmp_path / "s.parquet"
    res = run_cli(
        ["simulate", "boulder", "--seed", "1", "--truth", str(truth), "--holds", str(holds), "-o", str(sess)],
        stdin=None,
    )
    assert res.returncode == 0, res.stderr
    # the truth path stands in for pf-holds' estimate: the figure only needs x y z and grip
    tr, meta = sfio.read_table(truth, kind="truth")
    est = pa.table({"t": tr.column("t"), **{a: tr.column(f"true_{a}") for a in "xyz"}, "grip": tr.column("true_grip")})
    e = tmp_path / "e.parquet"
    e.write_bytes(sfio.table_to_bytes(est, sfmeta.new_meta("session", 1.7e9)))
    out = tmp_path / "holds.png"
    res = run_cli(["plot", "holds", str(e), "--holds", str(holds), "--truth", str(truth), "-o", str(out)])
    assert res.returncode == 0, res.stderr
    check_png(out)
