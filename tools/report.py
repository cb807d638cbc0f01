"""``report``: one self-contained HTML page per processed session, or the index page of a batch."""

from __future__ import annotations

from pathlib import Path

import click

from sportfusion.core import io as sfio
from sportfusion.core.errors import InputError
from sportfusion.tools._cli import Tool, tool


def _side(path: str | None, kind: str) -> tuple | None:
    if not path:
        return None
    if kind in ("gates", "holds"):  # a venue: also a CSV or a plain Parquet file (docs/table-contract.md)
        from sportfusion.core.venue import read_venue

        return read_venue(path, kind)
    return sfio.read_table(path, kind=kind)


@tool(
    "report",
    writes_table=False,
    input_help="A processed session (Parquet), or a batch summary (OUT/summary.parquet); default: standard input.",
    example="""
  rts-smooth events.parquet --hill oberstdorf_hs106 | report --jumps jumps.parquet -o jump.html
  report batch-out/summary.parquet -o batch-out/index.html     # the batch index, links to <name>/report.html""",
)
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False, writable=True),
    help="HTML file to write (self-contained: figures embedded as SVG, no network needed).",
)
@click.option(
    "--sport",
    type=click.Choice(["skijump", "skirace", "gates", "climbing"]),
    default=None,
    help="The session's sport (default: read from the table: hill -> skijump, spline -> skirace, "
    "gate anchors -> gates, hold labels -> climbing).",
)
@click.option("--title", default=None, help="Page title (default: the sport and the recording's start time).")
@click.option(
    "--jumps",
    "jumps_path",
    type=click.Path(exists=True, dir_okay=False),
    help="jump-metrics output (ski jump): take-off speed [m/s], flight time [s], jump length [m] per jump; "
    "computed from the session when not given.",
)
@click.option(
    "--evaluation",
    "evaluation_path",
    type=click.Path(exists=True, dir_okay=False),
    help="evaluate output against a truth or reference: adds the RMS table (position [m], velocity [m/s], "
    "attitude [deg]).",
)
@click.option(
    "--gates",
    "gates_path",
    type=click.Path(exists=True, dir_okay=False),
    help="Gate survey (gates table: gate, x, y, z [m]; also a CSV or plain Parquet) for the course figure (gates).",
)
@click.option(
    "--holds",
    "holds_path",
    type=click.Path(exists=True, dir_okay=False),
    help="Hold map (holds table: route, hold, x, y, z [m]; also a CSV or plain Parquet) for the wall figure "
    "(climbing).",
)
def main(
    tool: Tool,
    output: str,
    sport: str | None,
    title: str | None,
    jumps_path: str | None,
    evaluation_path: str | None,
    gates_path: str | None,
    holds_path: str | None,
) -> None:
    """Write one HTML page a coach can open on a phone or print: the headline figures with their units
    (jump length [m], take-off speed [m/s, km/h], flight time [s], max height [m]; moving time [s] and
    moving mean speed [m/s] (speed >= 1 m/s), distance [m], max speed, gates matched of the survey and
    per-turn speeds with the reason a turn is missing; holds reached, hold certainty [%]), the trajectory
    over the venue, the time series with their 1-sigma bands, the accuracy against a truth when
    --evaluation is given (angles in degrees), folded: the analyst's part (sensor biases, full errors,
    provenance) and "Reading the report" (docs/reading-the-report.md).  Given a batch summary
    (python -m sportfusion.batch, make batch), it writes the batch's index page instead: one row per
    session, failed sessions with their error line, links to OUT/<name>/report.html where they exist."""
    table, meta = tool.read(kind=("session", "summary"))
    if meta.get("kind") == "summary":
        from sportfusion.report.batch import batch_index, session_pages

        if "session" not in table.column_names:
            raise InputError("a summary table without a 'session' column; expected python -m sportfusion.batch output")
        names = [str(n) for n in table.column("session").to_pylist()]
        page = batch_index(table, session_pages(Path(output).parent, names), title or "Batch report")
        tool.info(f"{len(names)} sessions -> {output}")
    else:
        from sportfusion.report.session import session_report

        jumps = _side(jumps_path, "jumps")
        evaluation = _side(evaluation_path, "summary")
        gates = _side(gates_path, "gates")
        holds = _side(holds_path, "holds")
        page, figures = session_report(
            table,
            meta,
            sport=sport,
            title=title,
            jumps=jumps[0] if jumps else None,
            evaluation=evaluation,
            gates=gates[0] if gates else None,
            holds=holds,
        )
        tool.info("; ".join(f"{k} {v}" for k, v in figures.items()) + f" -> {output}")
    tool.write_bytes(page.encode("utf-8"), output)
