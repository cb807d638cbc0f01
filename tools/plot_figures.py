"""``plot`` subcommands for the figures of the papers: speed, series, errors, mag, spline, gates, body, holds.

Each reads one table (stdin or INPUT), takes side inputs as options and writes one image (-o, PNG,
SVG or PDF by suffix). The drawing lives in :mod:`sportfusion.core.plots` and
:mod:`sportfusion.skirace.plots`.
"""

from __future__ import annotations

import click

from sportfusion.core import io as sfio
from sportfusion.core import schema
from sportfusion.core.venue import read_venue
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import hill_options, image_options, load_hill_option


def _write(tool: Tool, fig: object, output: str, dpi: float) -> None:
    from sportfusion.core.plots import figure_format, render

    tool.write_bytes(render(fig, figure_format(output), dpi), output)  # type: ignore[arg-type]
    tool.info(f"wrote {output}")


def _truth_option(required: bool = False):  # noqa: ANN202 - click decorator
    return click.option(
        "--truth",
        "truth_path",
        type=click.Path(exists=True, dir_okay=False),
        required=required,
        help="Truth table of the same session (simulate --truth): true_x.. [m], true_vx.. [m/s], true_q0..3.",
    )


@tool(
    "plot speed",
    writes_table=False,
    example="""
  rts-smooth jump.parquet --hill oberstdorf_hs106 | plot speed -o speed.png
  plot speed smoothed.parquet -o speed.pdf""",
)
@hill_options
@image_options
def speed_cmd(
    tool: Tool, hill: str | None, hill_set: tuple[str, ...], output: str, title: str | None, dpi: float
) -> None:
    """Side view of the estimated trajectory x, -z [m] as a line coloured by speed [m/s] over the hill profile
    (skijump Figure 7), and a zoom on the flight (take-off to touch-down events, own colour scale);
    events annotated with their speed. Hill: --hill, else the session's hill."""
    from sportfusion.skijump.plots import profile_from_meta, speed_figure

    table, meta = tool.read()
    the_hill = load_hill_option(hill, hill_set)
    profile = the_hill.profile if the_hill is not None else profile_from_meta(meta)
    _write(tool, speed_figure(table, meta, profile, title or ""), output, dpi)


@tool(
    "plot series",
    writes_table=False,
    example="""
  plot series smoothed.parquet -o series.png""",
)
@image_options
def series_cmd(tool: Tool, output: str, title: str | None, dpi: float) -> None:
    """Position [m] (with the GNSS points), velocity [m/s], attitude [deg, unwrapped: no jumps at
    +-180] and estimated sensor biases against time [s], 1-sigma bands, events as labelled dashed
    lines (skijump Figures 8-11)."""
    from sportfusion.core.plots import series_figure

    table, meta = tool.read()
    _write(tool, series_figure(table, meta, title or ""), output, dpi)


@tool(
    "plot errors",
    writes_table=False,
    example="""
  simulate skijump --hill oberstdorf_hs106 --seed 1 --truth truth.parquet > s.parquet
  ... | rts-smooth --hill oberstdorf_hs106 | plot errors --truth truth.parquet -o errors.png""",
)
@_truth_option(required=True)
@image_options
def errors_cmd(tool: Tool, truth_path: str, output: str, title: str | None, dpi: float) -> None:
    """Estimate minus truth against time [s]: position [m], velocity [m/s] and the attitude rotation
    angle [deg], with the estimated 1-sigma band (skijump Figure 6)."""
    from sportfusion.core.plots import errors_figure

    table, _ = tool.read()
    truth, _ = sfio.read_table(truth_path, kind="truth")
    _write(tool, errors_figure(table, truth, title or ""), output, dpi)


@tool(
    "plot mag",
    writes_table=False,
    example="""
  plot mag smoothed.parquet -o mag.png""",
)
@image_options
def mag_cmd(tool: Tool, output: str, title: str | None, dpi: float) -> None:
    """Measured magnetometer mag_x.. against the smoother's estimate mag_pred_x.. [uT or 1] against
    time [s] (skijump Figure 12)."""
    from sportfusion.skijump.plots import mag_figure

    table, _ = tool.read()
    _write(tool, mag_figure(table, title or ""), output, dpi)


@tool(
    "plot spline",
    writes_table=False,
    example="""
  spline-smooth run.parquet | plot spline -o spline.png
  plot spline smoothed.parquet --truth truth.parquet -o spline.svg""",
)
@_truth_option()
@image_options
def spline_cmd(tool: Tool, truth_path: str | None, output: str, title: str | None, dpi: float) -> None:
    """Raw GNSS gnss_x, gnss_y [m] against the smoothing spline x, y [m] in plan view (y stretched
    by a stated factor when the run is long and thin), and their horizontal difference [m] against
    time [s] with RTK-float epochs shaded (skiracing Figures 5-6)."""
    from sportfusion.skirace.plots import spline_figure

    table, _ = tool.read()
    truth = sfio.read_table(truth_path, kind="truth")[0] if truth_path else None
    _write(tool, spline_figure(table, truth, title or ""), output, dpi)


@tool(
    "plot gates",
    writes_table=False,
    cites=("gates",),
    example="""
  gate-anchor run.parquet --gates survey.parquet | plot gates --gates survey.parquet -o course.png""",
)
@click.option(
    "--gates",
    "gates_path",
    type=click.Path(exists=True, dir_okay=False),
    required=True,
    help="Gate survey (kind gates: gate, x, y, z [m] in the session's local frame; also a CSV or plain Parquet).",
)
@image_options
def gates_cmd(tool: Tool, gates_path: str, output: str, title: str | None, dpi: float) -> None:
    """Top view of an alpine course [m]: surveyed gates (numbered), the trajectory, and each detected
    crossing joined to the gate it was matched to (gates paper Figure 2); the across-slope axis is
    stretched by a stated factor when the course is long and thin."""
    from sportfusion.gates.plots import gates_figure

    table, _ = tool.read()
    schema.require_columns(table, ["x", "y"], "a session with a trajectory (gate-anchor output)")
    gates, _ = read_venue(gates_path, "gates", what=f"gate survey {gates_path}")
    _write(tool, gates_figure(table, gates, title or ""), output, dpi)


@tool(
    "plot body",
    writes_table=False,
    cites=("gates",),
    example="""
  ingest imus/ | body-model --height 1.8 --mass 78 | detect-events --kind gates \\
    | gate-anchor --gates survey.parquet | plot body --gates survey.parquet -o body.png
  plot body run.parquet --gate 12 -o turn12.pdf""",
)
@click.option(
    "--gates",
    "gates_path",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="Gate survey (gate, x, y, z [m]): the magnet beside every posture (default: the turn figures' gates).",
)
@click.option(
    "--gate", type=int, default=None, help="Gate of the turn drawn from above (default: the middle turn) [number]."
)
@click.option(
    "--max-postures",
    default=12,
    show_default=True,
    type=click.IntRange(1, 60),
    help="Postures drawn at most, evenly spread over the crossings [count].",
)
@image_options
def body_cmd(
    tool: Tool,
    gates_path: str | None,
    gate: int | None,
    max_postures: int,
    output: str,
    title: str | None,
    dpi: float,
) -> None:
    """The athlete's body at the gates (gates paper Figs 3 and 5), from gate-anchor's output of a session with
    body-model's columns: the posture at each matched gate crossing seen from behind (joint centres, ski
    contact points, centre of mass and the gate's magnet, right of travel and up from the lumbar joint centre
    [m]), and one turn seen from above: the CoM path beside the sacrum's and the ski line, the turn switches
    (equal left/right ankle distance to the CoM) and their distances to the gate."""
    from sportfusion.gates.plots import body_figure

    table, meta = tool.read()
    gates = sfio.read_table(gates_path, kind="gates")[0] if gates_path else None
    fig = body_figure(table, meta, gates, gate, title or "", max_postures=max_postures)
    _write(tool, fig, output, dpi)


@tool(
    "plot holds",
    writes_table=False,
    cites=("climbing",),
    example="""
  pf-holds trial.parquet --holds wall.parquet | plot holds --holds wall.parquet -o path.png""",
)
@click.option(
    "--holds",
    "holds_path",
    type=click.Path(exists=True, dir_okay=False),
    required=True,
    help="Hold map (kind holds: route, hold, x, y, z [m]; up axis and start holds in its metadata; also a CSV or "
    "plain Parquet).",
)
@_truth_option()
@image_options
def holds_cmd(tool: Tool, holds_path: str, truth_path: str | None, output: str, title: str | None, dpi: float) -> None:
    """Front view of the wall [m]: the routes' holds, numbered (S: start hold), in the colour the route
    is named after, the estimated hand path with its grips, and the true path when --truth is given
    (climbing paper Figure 6)."""
    from sportfusion.climbing.plots import holds_figure

    table, _ = tool.read()
    schema.require_columns(table, ["x", "y", "z"], "a session with a hand path (pf-holds output)")
    holds, hmeta = read_venue(holds_path, "holds", what=f"hold map {holds_path}")
    truth = sfio.read_table(truth_path, kind="truth")[0] if truth_path else None
    _write(tool, holds_figure(table, holds, hmeta, truth, title or ""), output, dpi)


COMMANDS = {
    "speed": speed_cmd,
    "series": series_cmd,
    "errors": errors_cmd,
    "mag": mag_cmd,
    "spline": spline_cmd,
    "gates": gates_cmd,
    "body": body_cmd,
    "holds": holds_cmd,
}
