"""``ingest``: raw recordings -> one session table."""

from __future__ import annotations

from pathlib import Path

import click

from sportfusion.core.errors import InputError
from sportfusion.core.io import write_table
from sportfusion.core.meta import add_provenance
from sportfusion.ingest import FORMATS, Options, combine, read_recording
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import parse_pairs


@tool(
    "ingest",
    cites=("climbing",),
    reads_table=False,
    example="""
  ingest phyphox_export.zip > session.parquet
  ingest phyphox_export.zip gps_logger.nmea -o session.parquet
  ingest track.gpx --geoid-offset 47.9 > gnss.parquet
  ingest dataset/P01/V01/trials/T1 --hand lefthand --holds-out holds.parquet > trial.parquet
  ingest --format csvmap log.csv --map t=Time,acc_x=AccX,acc_y=AccY,acc_z=AccZ --time-unit ms --units acc_x=g,acc_y=g,acc_z=g > s.parquet""",
)
@click.argument("raw", nargs=-1, required=True, type=click.Path(exists=True, path_type=Path))
@click.option(
    "--format",
    "fmt",
    type=click.Choice(FORMATS),
    default=None,
    help="Force the format of every RAW input (default: sniffed).",
)
@click.option(
    "--offset",
    "offsets",
    multiple=True,
    metavar="NAME=SECONDS",
    help="Shift one input's times by SECONDS [s] on the session clock (NAME: its file name). Repeatable.",
)
@click.option(
    "--geoid-offset",
    type=float,
    default=None,
    help="GPX: geoid separation N [m] added to <ele> (MSL) to give ellipsoidal h.",
)
@click.option(
    "--date",
    default=None,
    metavar="YYYY-MM-DD",
    help="NMEA: UTC date for a log without RMC/ZDA dates (times of day only).",
)
@click.option("--no-time", is_flag=True, help="GPX: accept points without times; t becomes the point index [s].")
@click.option(
    "--map",
    "mapping",
    multiple=True,
    metavar="COL=HEADER[,COL=HEADER...]",
    help="Generic CSV: table column from CSV header, e.g. t=Time,acc_x=AccX.",
)
@click.option(
    "--time-unit",
    type=click.Choice(["s", "ms", "us", "ns", "iso"]),
    default="s",
    show_default=True,
    help="Generic CSV: unit of the time column [s, ms, us, ns or ISO-8601 UTC].",
)
@click.option(
    "--units",
    "units",
    multiple=True,
    metavar="COL=UNIT[,...]",
    help="Generic CSV: unit of the CSV values per column (g, deg/s, mG, nT, km/h, ...).",
)
@click.option(
    "--hand",
    type=click.Choice(["lefthand", "righthand"]),
    default=None,
    help="Bouldering dataset trial: which hand's IMU file; default: the trial's only one (required when it has both).",
)
@click.option(
    "--hold-map",
    type=click.Path(exists=True, file_okay=False),
    default=None,
    help="Bouldering dataset: hold map folder (routes/, start_handles.json); default: searched near the trial.",
)
@click.option(
    "--map-up",
    type=click.Choice(["x", "y", "z", "-x", "-y", "-z"]),
    default="z",
    show_default=True,
    help="Bouldering dataset: the hold map's up axis (map coordinates in m).",
)
@click.option(
    "--holds-out",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="Bouldering dataset: write the hold map (kind holds, positions [m]) to this Parquet file for pf-holds.",
)
def main(
    tool: Tool,
    raw: tuple[Path, ...],
    fmt: str | None,
    offsets: tuple[str, ...],
    geoid_offset: float | None,
    date: str | None,
    no_time: bool,
    mapping: tuple[str, ...],
    time_unit: str,
    units: tuple[str, ...],
    hand: str | None,
    hold_map: str | None,
    map_up: str,
    holds_out: str | None,
) -> None:
    """Read raw recordings (phyphox CSV export as ZIP or folder, NMEA 0183, GPX 1.1,
    RTKLIB .pos, Xsens MT Manager text export, a bouldering-dataset trial folder,
    or any CSV with a column map) and merge them into one session table on one
    clock: UTC where inputs have it, plus --offset. Every sample is kept: rows
    are the union of all sample times, a sensor's columns null elsewhere."""
    opts = Options(
        geoid_offset=geoid_offset,
        no_time=no_time,
        date=date,
        column_map=parse_pairs(mapping, "--map"),
        time_unit=time_unit,
        units=parse_pairs(units, "--units"),
        hand=hand,
        hold_map=hold_map,
        map_up=map_up,
    )
    offs = {k: _seconds(v) for k, v in parse_pairs(offsets, "--offset").items()}
    if mapping and fmt is None:
        fmt = "csvmap"  # a column map only makes sense for the generic CSV reader
    recordings = [read_recording(p, fmt, opts) for p in raw]
    table, meta, warnings = combine(recordings, offs)
    for w in warnings:
        tool.warn(w)
    holds = [r.tables["holds"] for r in recordings if "holds" in r.tables]
    if holds_out is not None:
        if not holds:
            raise InputError("--holds-out: no input came with a hold map; expected a bouldering trial (see --hold-map)")
        write_table(holds[0][0], add_provenance(holds[0][1], tool.name, tool.params), holds_out)
    elif holds:
        tool.info("a hold map was found; write it for pf-holds with --holds-out FILE")
    tool.info(f"{table.num_rows} rows from {len(raw)} input(s)")
    tool.write(table, meta, {**tool.params, "raw": [str(p) for p in raw]})


def _seconds(text: str) -> float:
    try:
        return float(text)
    except ValueError as exc:
        raise click.BadParameter(f"{text!r} is not a number of seconds", param_hint="--offset") from exc
