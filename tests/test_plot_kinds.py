"""Every plot kind renders on the shipped fixtures as PNG, SVG and PDF; and the properties a reviewer checks by eye,
checked by numbers: yaw unwrapped, legends clear of the data, units on legend values, labels that do not collide
(hill points, gates, holds, events), route colours from route names, the flight zoom, stretched long thin tracks.

The inputs are the fixtures' truth tables dressed as tool outputs (small known errors added), so the figures are
drawn on realistic data in a second or so each, without running the smoothers.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from click.testing import CliRunner
from conftest import ROOT, run_cli

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta
from sportfusion.core import schema

pytest.importorskip("matplotlib")

FIX = ROOT / "fixtures"
MAGIC = {"png": b"\x89PNG\r\n\x1a\n", "pdf": b"%PDF-", "svg": b"<?xml"}


def _write(path: Path, table: pa.Table, meta: dict) -> Path:
    path.write_bytes(sfio.table_to_bytes(table, meta))
    return path


def _skijump(d: Path) -> Path:
    """rts-smooth-like output: the fixture's truth + 1 cm (m/s, rad) noise, sigmas, GNSS, mag and its prediction."""
    truth, _ = sfio.read_table(FIX / "skijump" / "truth.parquet", kind="truth")
    session, meta = sfio.read_table(FIX / "skijump" / "session.parquet")
    rng = np.random.default_rng(3)
    n = truth.num_rows
    cols: dict[str, object] = {"t": truth.column("t")}
    for name in ("x", "y", "z", "vx", "vy", "vz", "q0", "q1", "q2", "q3", "roll", "pitch", "yaw"):
        cols[name] = pa.array(schema.floats(truth, f"true_{name}") + rng.normal(0, 0.01, n))
    for name in ("x", "y", "z", "vx", "vy", "vz"):
        cols[f"std_{name}"] = pa.array(np.full(n, 0.05))
    for a in "xyz":
        cols[f"bias_gyr_{a}"] = pa.array(schema.floats(truth, f"true_bias_gyr_{a}"))
        cols[f"bias_acc_{a}"] = pa.array(schema.floats(truth, f"true_bias_acc_{a}"))
    has = ~np.isnan(schema.floats(session, "lat"))
    for a in "xyz":
        cols[f"gnss_{a}"] = pa.array(np.where(has, schema.floats(truth, f"true_{a}") + rng.normal(0, 1.0, n), np.nan))
        cols[f"mag_{a}"] = session.column(f"mag_{a}")
        cols[f"mag_pred_{a}"] = pa.array(schema.floats(truth, f"true_mag_{a}"))
    cols["event"] = truth.column("event")
    return _write(d / "skijump.parquet", pa.table(cols), meta)


def _skirace(d: Path) -> Path:
    """spline-smooth-like output: truth as the spline, GNSS every 6th row with 2 cm noise, one RTK-float span."""
    truth, _ = sfio.read_table(FIX / "skirace" / "truth.parquet", kind="truth")
    rng = np.random.default_rng(4)
    n = truth.num_rows
    t = schema.floats(truth, "t")
    cols: dict[str, object] = {"t": truth.column("t")}
    for name in ("x", "y", "z", "vx", "vy", "vz", "roll", "pitch", "yaw"):
        cols[name] = pa.array(schema.floats(truth, f"true_{name}"))
    rows = np.arange(n) % 6 == 0
    for a in "xyz":
        cols[f"gnss_{a}"] = pa.array(np.where(rows, schema.floats(truth, f"true_{a}") + rng.normal(0, 0.02, n), np.nan))
    fix = np.where((t > 15) & (t < 18), 5, 4)
    cols["gnss_fix"] = pa.array(np.where(rows, fix, None), pa.int32())
    return _write(d / "skirace.parquet", pa.table(cols), sfmeta.new_meta("session", 1.7e9))


def _gates(d: Path) -> Path:
    """gate-anchor-like output: the truth's path and gate crossings, plus one crossing that matched no gate."""
    truth, _ = sfio.read_table(FIX / "gates" / "truth.parquet", kind="truth")
    ev = truth.column("true_event").to_pylist()
    gate = truth.column("true_gate").to_pylist()
    i = truth.num_rows // 2 + 7
    ev[i], gate[i] = "gate", -1
    cols = {"t": truth.column("t"), **{n: truth.column(f"true_{n}") for n in ("x", "y", "z", "vx", "vy", "vz")}}
    cols["event"] = pa.array(ev, pa.string())
    cols["gate"] = pa.array([g if e == "gate" else None for e, g in zip(ev, gate, strict=True)], pa.int32())
    return _write(d / "gates.parquet", pa.table(cols), sfmeta.new_meta("session", 1.7e9))


def _body(d: Path) -> Path:
    """gate-anchor-with-a-body-like output: the full-body fixture's truth as the estimate (CoM, body points
    relative to the LJC, crossings), the azimuth of body-model's frame and the turn figures in the metadata."""
    truth, _ = sfio.read_table(FIX / "gates_body" / "truth.parquet", kind="truth")
    survey, _ = sfio.read_table(FIX / "gates_body" / "raw" / "survey.parquet", kind="gates")
    cols: dict[str, object] = {"t": truth.column("t")}
    for n in ("x", "y", "z", "vx", "vy", "vz", "com_x", "com_y", "com_z", "com_vx", "com_vy", "com_vz"):
        cols[n] = truth.column(f"true_{n}")
    for c in truth.column_names:
        if c.endswith(("_rel_x", "_rel_y", "_rel_z")):
            cols[c[5:]] = truth.column(c)
    ev = truth.column("true_event").to_pylist()
    cols["event"] = pa.array(ev, pa.string())
    gate = truth.column("true_gate").to_pylist()
    cols["gate"] = pa.array([g if e == "gate" else None for e, g in zip(ev, gate, strict=True)], pa.int32())
    # the frame J's azimuth: the true CoM relative to the LJC in J against the same vector in the course frame
    rel = schema.float_columns(truth, ["true_com_rel_x", "true_com_rel_y"])
    d_xy = schema.float_columns(truth, ["true_com_x", "true_com_y"]) - schema.float_columns(
        truth, ["true_ljc_x", "true_ljc_y"]
    )
    alpha = np.arctan2(np.sum(rel[:, 0] * d_xy[:, 1] - rel[:, 1] * d_xy[:, 0]), np.sum(rel * d_xy))
    t = schema.floats(truth, "t")
    tc = [float(t[i]) for i, e in enumerate(ev) if e == "gate"]
    g_xyz = schema.float_columns(survey, ["x", "y", "z"])
    turns = [
        {"gate": k + 1, "gate_xyz": g_xyz[k].tolist(), "t_cross": tc[k], "t_in": 0.5 * (tc[k - 1] + tc[k]),
         "t_out": 0.5 * (tc[k] + tc[k + 1]), "v_in": 20.0, "v_out": 20.5, "d_in": 12.0, "d_out": 12.5,
         "d_cross": 0.6, "length": 24.0}
        for k in range(1, len(tc) - 1)
    ]  # fmt: skip
    meta = sfmeta.new_meta("session", 1.7e9)
    meta["gate_anchor"] = {"alpha_deg": float(np.degrees(alpha)), "turns": turns}
    return _write(d / "body.parquet", pa.table(cols), meta)


def _climbing(d: Path) -> Path:
    truth, _ = sfio.read_table(FIX / "climbing" / "truth.parquet", kind="truth")
    est = pa.table(
        {"t": truth.column("t"), **{a: truth.column(f"true_{a}") for a in "xyz"}, "grip": truth.column("true_grip")}
    )
    return _write(d / "climbing.parquet", est, sfmeta.new_meta("session", 1.7e9))


def _compare(d: Path) -> tuple[Path, Path]:
    from sportfusion.skirace.sim_runs import run_table

    a, b = d / "A.parquet", d / "B.parquet"
    a.write_bytes(run_table("A"))
    b.write_bytes(run_table("B"))
    out, prof = d / "cmp.parquet", d / "prof.parquet"
    res = run_cli(["compare-runs", str(a), "--run", str(b), "--profile", str(prof), "-o", str(out)])
    assert res.returncode == 0, res.stderr
    return out, prof


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("kinds")
    cmp, prof = _compare(d)
    return {
        "skijump": _skijump(d),
        "skirace": _skirace(d),
        "gates": _gates(d),
        "body": _body(d),
        "climbing": _climbing(d),
        "compare": cmp,
        "profile": prof,
    }


def kind_args(kind: str, inp: dict[str, Path]) -> list[str]:
    sj, truth = str(inp["skijump"]), str(FIX / "skijump" / "truth.parquet")
    return {
        "hill": ["hill", "--hill", "oberstdorf_hs106"],
        "track": ["track", sj, "--hill", "oberstdorf_hs106"],
        "speed": ["speed", sj, "--hill", "oberstdorf_hs106"],
        "series": ["series", sj],
        "errors": ["errors", sj, "--truth", truth],
        "mag": ["mag", sj],
        "spline": ["spline", str(inp["skirace"]), "--truth", str(FIX / "skirace" / "truth.parquet")],
        "gates": ["gates", str(inp["gates"]), "--gates", str(FIX / "gates" / "survey.parquet")],
        "body": ["body", str(inp["body"]), "--gates", str(FIX / "gates_body" / "raw" / "survey.parquet")],
        "holds": ["holds", str(inp["climbing"]), "--holds", str(FIX / "climbing" / "holds.parquet")]
        + ["--truth", str(FIX / "climbing" / "truth.parquet")],
        "compare": ["compare", str(inp["compare"]), "--profile", str(inp["profile"])],
    }[kind]


KINDS = ("hill", "track", "speed", "series", "errors", "mag", "spline", "gates", "body", "holds", "compare")


def test_every_kind_is_a_plot_subcommand():
    from sportfusion.tools.plot import main

    assert set(main.commands) == set(KINDS)


@pytest.mark.parametrize("fmt", ["png", "svg", "pdf"])
@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_renders(inputs, tmp_path, kind, fmt):
    from sportfusion.tools.plot import main

    out = tmp_path / f"{kind}.{fmt}"
    r = CliRunner().invoke(main, [*kind_args(kind, inputs), "-o", str(out), "--dpi", "60", "-q"])
    assert r.exit_code == 0, (r.stderr, r.exception)
    assert r.stderr == ""  # no warnings from matplotlib's layout on stderr
    data = out.read_bytes()
    assert data.startswith(MAGIC[fmt]), data[:16]
    assert len(data) > {"png": 15_000, "svg": 30_000, "pdf": 8_000}[fmt]
    if fmt == "pdf":
        assert data.rstrip().endswith(b"%%EOF") and b"/Creator (sportfusion)" in data
    if fmt == "svg":
        assert data.rstrip().endswith(b"</svg>")


def test_unknown_suffix_names_the_three_formats(tmp_path):
    from sportfusion.tools.plot import main

    r = CliRunner().invoke(main, ["hill", "--hill", "oberstdorf_hs106", "-o", str(tmp_path / "h.jpg")])
    assert r.exit_code == 2 and ".png, .svg or .pdf" in r.stderr
    assert not (tmp_path / "h.jpg").exists()


# ---------------------------------------------------------------------------------------------- the figures' properties


def figure(kind: str, inp: dict[str, Path]):
    """The figure object of a kind, drawn by the library on the same inputs as the command."""
    from sportfusion.climbing.plots import holds_figure
    from sportfusion.core.plots import errors_figure, series_figure
    from sportfusion.gates.plots import body_figure, gates_figure
    from sportfusion.skijump.hillfile import load_hill
    from sportfusion.skijump.plots import hill_figure, mag_figure, speed_figure, track_figure
    from sportfusion.skirace.plots import compare_figure, spline_figure

    hill = load_hill("oberstdorf_hs106")
    sj, meta = sfio.read_table(inp["skijump"])
    if kind == "hill":
        return hill_figure(hill.profile, hill.name)
    if kind == "track":
        return track_figure(sj, meta, hill.profile, hill.name)
    if kind == "speed":
        return speed_figure(sj, meta, hill.profile)
    if kind == "series":
        return series_figure(sj, meta)
    if kind == "errors":
        return errors_figure(sj, sfio.read_table(FIX / "skijump" / "truth.parquet", kind="truth")[0])
    if kind == "mag":
        return mag_figure(sj)
    if kind == "spline":
        return spline_figure(
            sfio.read_table(inp["skirace"])[0], sfio.read_table(FIX / "skirace" / "truth.parquet", kind="truth")[0]
        )
    if kind == "gates":
        return gates_figure(
            sfio.read_table(inp["gates"])[0], sfio.read_table(FIX / "gates" / "survey.parquet", kind="gates")[0]
        )
    if kind == "body":
        table, bmeta = sfio.read_table(inp["body"])
        return body_figure(table, bmeta, sfio.read_table(FIX / "gates_body" / "raw" / "survey.parquet")[0])
    if kind == "holds":
        holds, hmeta = sfio.read_table(FIX / "climbing" / "holds.parquet", kind="holds")
        return holds_figure(sfio.read_table(inp["climbing"])[0], holds, hmeta)
    table, cmeta = sfio.read_table(inp["compare"], kind="summary")
    return compare_figure(table, cmeta, profile=sfio.read_table(inp["profile"], kind="summary")[0])


def _drawn(fig):
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _points(ax) -> np.ndarray:
    """Display coordinates [px] of every plotted data point of an axes: line vertices and scatter offsets."""
    pts = [np.empty((0, 2))]
    for line in ax.get_lines():
        xy = np.column_stack([np.asarray(v, float) for v in line.get_data()]) if len(line.get_xdata()) else None
        if xy is not None:
            pts.append(line.get_transform().transform(xy))
    for coll in ax.collections:
        off = coll.get_offsets()
        if type(coll).__name__ == "PathCollection" and len(off):
            pts.append(coll.get_offset_transform().transform(off))
    p = np.vstack(pts)
    return p[np.all(np.isfinite(p), axis=1)]


def _annotations(ax):
    return [c for c in ax.texts if type(c).__name__ == "Annotation"]


def _text_box(text, renderer):
    from matplotlib.text import Text

    return Text.get_window_extent(text, renderer)  # the text itself, without an annotation's leader line


def _pairwise_disjoint(boxes) -> list[tuple[int, int]]:
    return [(i, j) for i in range(len(boxes)) for j in range(i + 1, len(boxes)) if boxes[i].overlaps(boxes[j])]


@pytest.mark.parametrize("kind", KINDS)
def test_legends_never_cover_data(inputs, kind):
    fig = figure(kind, inputs)
    renderer = _drawn(fig)
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    data = np.vstack([_points(ax) for ax in fig.axes])
    assert data.shape[0] > 100
    for leg in legends:
        bb = leg.get_window_extent(renderer)
        inside = (data[:, 0] > bb.x0) & (data[:, 0] < bb.x1) & (data[:, 1] > bb.y0) & (data[:, 1] < bb.y1)
        assert not inside.any(), (kind, int(inside.sum()), [t.get_text() for t in leg.get_texts()])


NUMBER = re.compile(r"[-+]?\d+\.\d+")
UNIT = re.compile(r"^\s*(m/s|m|s|deg|uT|km/h|m/s\^2|deg/s)\b")


@pytest.mark.parametrize("kind", KINDS)
def test_every_number_in_a_legend_or_label_has_its_unit(inputs, kind):
    fig = figure(kind, inputs)
    texts = [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()]
    texts += [a.get_text() for ax in fig.axes for a in _annotations(ax)]
    for text in texts:
        for m in NUMBER.finditer(text):
            assert UNIT.match(text[m.end() :]), (kind, text)


def test_series_yaw_is_unwrapped(inputs):
    from sportfusion.core.plots import series_figure

    table, meta = sfio.read_table(inputs["skirace"])
    raw = np.degrees(schema.floats(table, "yaw"))
    assert np.nanmax(np.abs(np.diff(raw))) > 300  # the input does wrap at +-180 deg
    fig = series_figure(table, meta)
    (yaw,) = [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_label().startswith("yaw")]
    y = np.asarray(yaw.get_ydata(), float)
    assert np.nanmax(np.abs(np.diff(y))) < 180.0
    # same angle modulo whole turns
    np.testing.assert_allclose(np.cos(np.radians(y)), np.cos(np.radians(raw[np.isfinite(raw)])), atol=1e-9)


def test_unwrap_deg_bridges_gaps_and_stays_near_zero():
    from sportfusion.core.plots import unwrap_deg

    a = np.array([170.0, 179.0, np.nan, -178.0, -170.0, 175.0, -179.0])
    u = unwrap_deg(a)
    assert np.isnan(u[2])
    np.testing.assert_allclose(u[[0, 1, 3, 4, 5, 6]] - u[0], [0, 9, 12, 20, 5, 11])
    assert -180 <= np.nanmedian(u) <= 180
    np.testing.assert_allclose(unwrap_deg(np.array([-10.0, 10.0])), [-10, 10])


def test_events_numbered_by_their_column_else_by_order():
    from sportfusion.core.plots import events_of

    t = pa.table(
        {
            "t": [0.0, 1.0, 2.0, 3.0],
            "event": ["gate", None, "gate", "gate"],
            "gate": pa.array([4, None, -1, 5], pa.int32()),
        }
    )
    assert events_of(t) == [(0.0, "gate 4"), (2.0, "gate ?"), (3.0, "gate 5")]
    u = pa.table({"t": [0.0, 1.0, 2.0], "event": ["grip", "takeoff", "grip"]})
    assert events_of(u) == [(0.0, "grip 1"), (1.0, "takeoff"), (2.0, "grip 2")]


@pytest.mark.parametrize("kind", ["series", "errors", "mag"])
def test_event_lines_labelled(inputs, kind):
    fig = figure(kind, inputs)
    _drawn(fig)
    labels = [a.get_text() for ax in fig.axes for a in _annotations(ax)]
    assert labels == ["takeoff", "touchdown"]


def test_gate_events_labelled_numbered_without_overlap(inputs):
    from sportfusion.core.plots import series_figure

    table, meta = sfio.read_table(inputs["gates"])
    fig = series_figure(table, meta)
    renderer = _drawn(fig)
    anns = [a for ax in fig.axes for a in _annotations(ax)]
    assert sorted(a.get_text() for a in anns) == sorted([f"gate {g}" for g in range(1, 11)] + ["gate ?"])
    assert _pairwise_disjoint([_text_box(a, renderer) for a in anns]) == []


def test_gate_labels_numbered_and_apart(inputs):
    fig = figure("gates", inputs)
    renderer = _drawn(fig)
    (ax,) = [a for a in fig.axes if a.get_legend() is not None]
    anns = _annotations(ax)
    survey, _ = sfio.read_table(FIX / "gates" / "survey.parquet", kind="gates")
    assert sorted(int(a.get_text()) for a in anns) == sorted(survey.column("gate").to_pylist())
    boxes = [_text_box(a, renderer) for a in anns]
    assert _pairwise_disjoint(boxes) == []
    # no label sits on a gate marker
    gates = ax.transData.transform(np.column_stack([schema.floats(survey, "y"), schema.floats(survey, "x")]))
    for bb in boxes:
        assert not ((gates[:, 0] > bb.x0) & (gates[:, 0] < bb.x1) & (gates[:, 1] > bb.y0) & (gates[:, 1] < bb.y1)).any()


def test_long_thin_tracks_are_stretched_by_a_stated_factor(inputs):
    from sportfusion.core.plots import stretch_factor

    assert stretch_factor(800.0, 30.0) == 10 and stretch_factor(100.0, 60.0) == 1 and stretch_factor(300.0, 0.0) == 1
    for kind, axis in (("spline", "y"), ("gates", "x")):
        fig = figure(kind, inputs)
        _drawn(fig)
        ax = fig.axes[0]
        label = ax.get_ylabel() if axis == "y" else ax.get_xlabel()
        f = int(label.rsplit("×", 1)[1])
        assert f >= 5
        # the stated factor is the one drawn, and the track's short side takes a quarter of its long side
        x0, y0 = ax.transData.transform((ax.get_xlim()[0], ax.get_ylim()[0]))
        x1, y1 = ax.transData.transform((ax.get_xlim()[1], ax.get_ylim()[1]))
        sx, sy = abs(x1 - x0) / np.ptp(ax.get_xlim()), abs(y1 - y0) / np.ptp(ax.get_ylim())  # px per m
        assert (sy / sx if axis == "y" else sx / sy) == pytest.approx(
            f, rel=0.01
        )  # matplotlib leaves < 0.5 % aspect misfits
        (line,) = [ln for ln in ax.get_lines() if ln.get_label() in ("spline", "trajectory")]
        px = line.get_transform().transform(np.column_stack(line.get_data()))
        span = np.ptp(px[np.all(np.isfinite(px), axis=1)], axis=0)
        assert span.min() >= 0.25 * span.max(), span


@pytest.mark.parametrize("name", ["oberstdorf_hs106", "hakuba_hs131", "harrachov_hs210"])
def test_hill_point_labels_do_not_collide(name):
    from sportfusion.skijump.hillfile import load_hill
    from sportfusion.skijump.plots import _POINTS, hill_figure

    hill = load_hill(name)
    fig = hill_figure(hill.profile, hill.name)
    renderer = _drawn(fig)
    anns = _annotations(fig.axes[0])
    assert [a.get_text() for a in anns] == list(_POINTS)
    boxes = [_text_box(a, renderer) for a in anns]
    assert _pairwise_disjoint(boxes) == []
    # nor does a label cover a key point's marker (4 pt either side of the point)
    pts = fig.axes[0].transData.transform([(hill.profile.points[n][0], -hill.profile.points[n][1]) for n in _POINTS])
    r = 4.0 * fig.dpi / 72.0
    for name, bb in zip(_POINTS, boxes, strict=True):
        hit = (pts[:, 0] + r > bb.x0) & (pts[:, 0] - r < bb.x1) & (pts[:, 1] + r > bb.y0) & (pts[:, 1] - r < bb.y1)
        assert not hit.any(), (name, [p for p, h in zip(_POINTS, hit, strict=True) if h])
        # and each label is nearer its own point than any other key point (no "T" read as F's label)
        centre = np.array([(bb.x0 + bb.x1) / 2, (bb.y0 + bb.y1) / 2])
        assert _POINTS[int(np.argmin(np.hypot(*(pts - centre).T)))] == name
    axbox = fig.axes[0].get_window_extent(renderer)
    assert all(axbox.x0 <= b.x0 and b.x1 <= axbox.x1 and axbox.y0 <= b.y0 and b.y1 <= axbox.y1 for b in boxes)


def test_hold_labels_apart_and_route_colours_match_names(inputs):
    from matplotlib.colors import to_rgb

    from sportfusion.climbing.plots import route_colours

    fig = figure("holds", inputs)
    renderer = _drawn(fig)
    ax = fig.axes[0]
    for line in ax.get_lines():
        label = line.get_label()
        if label.startswith("holds: "):
            route = label.removeprefix("holds: ")
            assert to_rgb(line.get_markerfacecolor()) == to_rgb(route), label
    boxes = [_text_box(a, renderer) for a in _annotations(ax)]
    assert len(boxes) == sfio.read_table(FIX / "climbing" / "holds.parquet", kind="holds")[0].num_rows
    assert _pairwise_disjoint(boxes) == []
    c = route_colours(["red", "Light Blue", "route A", "route B"])
    assert to_rgb(c["red"]) == to_rgb("red") and to_rgb(c["Light Blue"]) == to_rgb("lightblue")
    assert c["route A"] != c["route B"] and to_rgb(c["route A"]) != to_rgb("red")


def test_speed_plot_zooms_on_the_flight(inputs):
    fig = figure("speed", inputs)
    _drawn(fig)
    table, _ = sfio.read_table(inputs["skijump"])
    t, x = schema.floats(table, "t"), schema.floats(table, "x")
    ev = np.array([e or "" for e in table.column("event").to_pylist()])
    x_to, x_td = x[ev == "takeoff"][0], x[ev == "touchdown"][0]
    overview, zoom = [ax for ax in fig.axes if ax.get_xlabel() == "x [m]"]
    lo, hi = zoom.get_xlim()
    assert lo < x_to < x_td < hi
    assert hi - lo < 0.6 * np.ptp(overview.get_xlim())
    assert "s in the air" in zoom.get_title()
    # the zoom is to scale: one metre is as long across as up
    (x0, y0), (x1, y1) = zoom.transData.transform([(lo, zoom.get_ylim()[0]), (hi, zoom.get_ylim()[1])])
    assert abs(x1 - x0) / (hi - lo) == pytest.approx(abs(y1 - y0) / np.ptp(zoom.get_ylim()), rel=1e-3)
    assert t.size == x.size


def test_plot_speed_without_events_draws_no_zoom(inputs, tmp_path):
    from sportfusion.skijump.plots import speed_figure

    table, meta = sfio.read_table(inputs["skijump"])
    fig = speed_figure(table.drop_columns(["event"]), meta)
    assert len([ax for ax in fig.axes if ax.get_xlabel() == "x [m]"]) == 1


def test_body_postures_are_in_the_survey_frame(inputs):
    """The stick figures hang from the CoM through body-model's frame J turned by the matching's azimuth: the
    LJC they put at each crossing is the true LJC, the magnets are beside the skier, the ankles below the hips."""
    from sportfusion.gates.plots import _behind, body_crossings

    table, meta = sfio.read_table(inputs["body"])
    truth, _ = sfio.read_table(FIX / "gates_body" / "truth.parquet", kind="truth")
    survey, _ = sfio.read_table(FIX / "gates_body" / "raw" / "survey.parquet")
    cr = body_crossings(table, meta, survey)
    assert len(cr) == int(np.sum([e == "gate" for e in truth.column("true_event").to_pylist()]))
    tt = schema.floats(truth, "t")
    for c in cr:
        i = int(np.argmin(np.abs(tt - c["t"])))
        ljc = np.array([schema.floats(truth, f"true_ljc_{a}")[i] for a in "xyz"])
        assert np.linalg.norm(c["points"]["ljc"] - ljc) < 0.002
        assert 0.2 < np.linalg.norm(c["magnet"] - c["points"]["ljc"]) < 2.0  # 0.2-1.2 m beside, 0.5-1 m above
        for side in "rl":
            assert _behind(c, c["points"][f"ankle_{side}"])[1] < _behind(c, c["points"][f"hip_{side}"])[1] - 0.2
