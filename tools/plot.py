"""``plot``: PNG/SVG/PDF figures -- ``plot hill`` (a profile) and ``plot track`` (a session over its hill)."""

from __future__ import annotations

import click

from sportfusion import __version__
from sportfusion.core import io as sfio
from sportfusion.core.errors import InputError
from sportfusion.tools._cli import Group, Tool, tool
from sportfusion.tools._options import hill_options, image_options, load_hill_option
from sportfusion.tools.plot_figures import COMMANDS as FIGURE_COMMANDS


@tool(
    "plot hill",
    reads_table=False,
    writes_table=False,
    example="""
  plot hill --hill oberstdorf_hs106 -o oberstdorf.png
  plot hill --hill my_hill.toml --hill-set rL=230 -o my_hill.pdf""",
)
@hill_options(required=True)
@image_options
def hill_cmd(tool: Tool, hill: str, hill_set: tuple[str, ...], output: str, title: str | None, dpi: float) -> None:
    """Draw a hill's longitudinal profile (in-run, landing hill, out-run) with
    its key points A B E1 E2 T F P K L U, in the hill frame [m], to scale."""
    from sportfusion.core.plots import figure_format, render
    from sportfusion.skijump.plots import hill_figure

    the_hill = load_hill_option(hill, hill_set)
    fig = hill_figure(the_hill.profile, title or the_hill.name)
    tool.write_bytes(render(fig, figure_format(output), dpi), output)
    tool.info(f"wrote {output}")


@tool(
    "plot track",
    writes_table=False,
    example="""
  ingest run.zip track.nmea | gps2hill --hill oberstdorf_hs106 | plot track -o jump.png
  plot track smoothed.parquet -o jump.svg --hill oberstdorf_hs106""",
)
@hill_options
@image_options
def track_cmd(
    tool: Tool, hill: str | None, hill_set: tuple[str, ...], output: str, title: str | None, dpi: float
) -> None:
    """Draw a session's GNSS points (gnss_x gnss_y gnss_z [m]) and any
    estimated x y z [m] with a 1-sigma band (std_z, std_y) in side and top
    view, over the hill profile: --hill, else the hill recorded by gps2hill."""
    from sportfusion.core.plots import figure_format, render
    from sportfusion.skijump.plots import profile_from_meta, track_figure

    table, meta = tool.read(kind=("session", "truth"))
    the_hill = load_hill_option(hill, hill_set)
    if the_hill is not None:
        profile, name = the_hill.profile, the_hill.name
    else:
        profile, name = profile_from_meta(meta), (meta.get("hill") or {}).get("name", "")
    fig = track_figure(table, meta, profile, title or name)
    tool.write_bytes(render(fig, figure_format(output), dpi), output)
    tool.info(f"wrote {output}")


@tool(
    "plot compare",
    writes_table=False,
    cites=("skiracing-splines",),
    example="""
  compare-runs anna.parquet --run berta.parquet | plot compare -o compare.png
  compare-runs anna.parquet --run berta.parquet --profile speed.parquet -o compare.parquet
  plot compare compare.parquet --profile speed.parquet -o compare.svg --title "Downhill, St. Moritz" """,
    input_help="Summary table written by compare-runs; default: standard input.",
)
@image_options
@click.option(
    "--profile",
    "profile_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Speed profile written by compare-runs --profile: adds the speed difference [m/s] along the course.",
)
def compare_cmd(tool: Tool, output: str, title: str | None, dpi: float, profile_path: str | None) -> None:
    """Draw the run comparison of Figure 9 of the ski racing splines paper
    from a compare-runs summary: one row per gate, four columns: accumulated
    time difference [s], gate-to-gate time difference [s], difference of the
    distance along the path [m] and of the speed at the gate [m/s], each run
    minus the reference."""
    from sportfusion.core.plots import figure_format, render
    from sportfusion.skirace.plots import compare_figure

    table, meta = tool.read(kind=None)
    profile = None
    if profile_path is not None:
        profile, _ = sfio.read_table(profile_path, kind="summary", what=f"profile {profile_path}")
    fig = compare_figure(table, meta, title or "", profile=profile)
    if meta.get("kind") != "summary":
        raise InputError(f"the input is a '{meta.get('kind')}' table; expected the summary written by compare-runs")
    tool.write_bytes(render(fig, figure_format(output), dpi), output)
    tool.info(f"wrote {output}")


@click.group(
    cls=Group,
    name="plot",
    epilog="\b\nExample:\n  plot hill --hill oberstdorf_hs106 -o hill.png\n"
    "  ingest run.zip | gps2hill --hill oberstdorf_hs106 | plot track -o track.svg",
)
@click.version_option(__version__, "--version", prog_name="plot", message="%(prog)s (sportfusion) %(version)s")
def main() -> None:
    """PNG, SVG or PDF figures (format from the -o suffix: .png, .svg, .pdf):
    `hill` a hill profile, `track` a session over it, `speed` the trajectory
    as a line coloured by speed with a zoom on the flight,
    `series` estimates against time, `errors` estimate minus truth, `mag`
    measured vs estimated magnetometer, `spline` spline vs raw GNSS, `gates`
    an alpine course with its anchors, `body` the athlete's posture at the
    gates and the CoM path of a turn, `holds` a climbing hand path over the
    hold map, `compare` runs compared gate by gate.  Needs matplotlib (the
    `plot` extra). docs/plots.md shows each figure."""


main.add_command(hill_cmd, name="hill")
main.add_command(track_cmd, name="track")
for _name, _cmd in FIGURE_COMMANDS.items():
    main.add_command(_cmd, name=_name)
main.add_command(compare_cmd, name="compare")


if __name__ == "__main__":  # pragma: no cover
    main()
