"""``ingest``: raw recordings -> one session table."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import click

from sportfusion.core.errors import InputError
from sportfusion.ingest import FORMATS, Options, combine, read_recording, time_order_totals
from sportfusion.ingest.xsensdir import segment_recording
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import check_number, parse_pairs


@tool(
    "ingest",
    cites=("climbing",),
    reads_table=False,
    example="""
  ingest phyphox_export.zip > session.parquet
  ingest phyphox_export.zip gps_logger.nmea -o session.parquet
  ingest track.gpx --geoid-offset 47.9 > gnss.parquet
  ingest dataset/P01/V01/trials/T1 --hand lefthand --holds-out holds.parquet > trial.parquet
  ingest --format csvmap log.csv --map t=Time,acc_x=AccX,acc_y=AccY,acc_z=AccZ --time-unit ms --units acc_x=g,acc_y=g,acc_z=g > s.parquet
  ingest logger.csv --map t=time,lat=lat,lon=lon,gnss_speed=speed --invalid gnss_speed=-1 > s.parquet
  ingest rover.pos imu.csv --map imu.csv:t=1,acc_x=2,acc_y=3,acc_z=4 --units imu.csv:t=ticks,acc=0.000244g --rate 400 > s.parquet
  ingest imus/ > body.parquet                          # Xsens exports + myIMUMappings.xml (OpenSense)
  ingest imus/ --mapping myIMUMappings.xml -o body.parquet
  ingest imus/ --segment 00B42279=pelvis --segment 00B4227C=femur_r ... > body.parquet
  ingest sacrum.csv thigh.csv --map t=Time,acc_x=AX,acc_y=AY,acc_z=AZ --segment sacrum.csv=pelvis --segment thigh.csv=femur_r > s.parquet""",
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
    help="GPX, NMEA, FIT, TCX: geoid separation N [m] added to heights above mean sea level (<ele>, GGA "
    "without its separation, FIT/TCX altitude) to give ellipsoidal h (gps2hill takes the same option for any format).",
)
@click.option(
    "--date",
    default=None,
    metavar="YYYY-MM-DD",
    help="NMEA: UTC date for a log without RMC/ZDA dates (times of day only).",
)
@click.option(
    "--base",
    default=None,
    metavar="LAT,LON,H",
    help="RTKLIB e/n/u-baseline solutions: the base station's WGS84 latitude, longitude [deg] and ellipsoidal "
    "height [m] (default: the solution header's 'ref pos' line).",
)
@click.option("--no-time", is_flag=True, help="GPX: accept points without times; t becomes the point index [s].")
@click.option(
    "--map",
    "mapping",
    multiple=True,
    metavar="[FILE:]COL=HEADER[,...]",
    help="Generic CSV: table column from CSV header or 1-based column number, e.g. t=Time,acc_x=AccX or t=1,acc_x=2. "
    "A FILE: prefix (an input's file name) applies it to that input only; repeatable.",
)
@click.option(
    "--time-unit",
    type=click.Choice(["s", "ms", "us", "ns", "ticks", "iso"]),
    default="s",
    show_default=True,
    help="Generic CSV: unit of the time column [s, ms, us, ns, ticks of 1/--rate s, or ISO-8601 UTC].",
)
@click.option(
    "--rate",
    type=click.FloatRange(min=0, min_open=True),
    default=None,
    metavar="HZ",
    help="Sampling rate [Hz] where the file states none: Xsens exports timed by PacketCounter, CSV time in ticks.",
)
@click.option(
    "--units",
    "units",
    multiple=True,
    metavar="[FILE:]COL=UNIT[,...]",
    help="Generic CSV: unit of the values per column or group (acc=g, gyr=deg/s, mag=mG, t=ms; a scale for counts: "
    "acc=0.000244g). A FILE: prefix applies it to that input only.",
)
@click.option(
    "--invalid",
    "invalid",
    multiple=True,
    metavar="[FILE:]COL=VALUE[/VALUE...][,...]",
    help="Generic CSV: the file's markers for 'no value' per column, group (acc) or * (every mapped column but t), "
    "as written (before --units), e.g. gnss_speed=-1 or acc=-999/9999: read as null, counted. None is assumed.",
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
@click.option(
    "--mapping",
    "mapping_file",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="A folder of Xsens exports (several IMUs on one athlete): OpenSim OpenSense's mapping file "
    "(myIMUMappings.xml: trial_prefix, ExperimentalSensor name -> name_in_model); default: the one in the folder.",
)
@click.option(
    "--segment",
    "segment_pairs",
    multiple=True,
    metavar="ID=NAME",
    help="Body segment of a sensor (OpenSim names: pelvis, torso, head, femur_r, femur_l, tibia_r, tibia_l, ...): "
    "ID is an Xsens sensor id in a folder (00B42279) or an input's file name (a CSV read with --map). The pelvis "
    "sensor keeps the plain column names, the others get <segment>__<column> (docs/table-contract.md). Repeatable.",
)
def main(
    tool: Tool,
    raw: tuple[Path, ...],
    fmt: str | None,
    offsets: tuple[str, ...],
    geoid_offset: float | None,
    date: str | None,
    base: str | None,
    no_time: bool,
    mapping: tuple[str, ...],
    time_unit: str,
    rate: float | None,
    units: tuple[str, ...],
    invalid: tuple[str, ...],
    hand: str | None,
    hold_map: str | None,
    map_up: str,
    holds_out: str | None,
    mapping_file: str | None,
    segment_pairs: tuple[str, ...],
) -> None:
    """Read raw recordings (phyphox CSV export as ZIP or folder, Sensor Logger ZIP or
    folder, NMEA 0183, GPX 1.1, Garmin FIT and TCX, RTKLIB .pos, Xsens MT Manager text
    export, a bouldering-dataset trial folder, a session Parquet, our own CSV from inspect --csv,
    or any CSV with a column map) and merge them into one session table on one
    clock: UTC where inputs have it, plus --offset. Rows are the union of all
    sample times, a sensor's columns null elsewhere. Times out of order are
    sorted; samples of one input at one time become one row (exact duplicates
    dropped, the first in file order wins a conflict); all counted on stderr
    and in the provenance (docs/recordings-gnss.md)."""
    if geoid_offset is not None and not (math.isfinite(geoid_offset) and abs(geoid_offset) <= 150.0):
        raise click.BadParameter(
            f"{geoid_offset} m is not a geoid separation (-150..150 m)", param_hint="--geoid-offset"
        )
    maps, map_all = _per_input(mapping, "--map", raw)
    unit_sets, units_all = _per_input(units, "--units", raw)
    invalid_sets, invalid_all = _per_input(invalid, "--invalid", raw)
    opts = Options(
        geoid_offset=geoid_offset,
        no_time=no_time,
        date=date,
        column_map=map_all,
        time_unit=time_unit,
        units=units_all,
        hand=hand,
        hold_map=hold_map,
        map_up=map_up,
        rate=rate,
        base=_base(base),
    )
    offs = {k: _seconds(v) for k, v in parse_pairs(offsets, "--offset").items()}
    segs = parse_pairs(segment_pairs, "--segment")
    file_segs = {k: v for k, v in segs.items() if any(k in (str(p), p.name) for p in raw)}
    opts.mapping = mapping_file
    opts.segments = {k: v for k, v in segs.items() if k not in file_segs}
    if (mapping_file or opts.segments) and not any(p.is_dir() for p in raw):
        raise click.UsageError("--mapping and --segment ID=NAME (a sensor id) need a folder of Xsens exports as input")
    recordings = []
    for i, p in enumerate(raw):
        own = dataclasses.replace(
            opts,
            column_map={**map_all, **maps.get(i, {})},
            units={**units_all, **unit_sets.get(i, {})},
            invalid={**invalid_all, **invalid_sets.get(i, {})},
        )
        # a column map only makes sense for the generic CSV reader
        rec = read_recording(p, fmt or ("csvmap" if own.column_map and not p.is_dir() else None), own)
        if own.invalid and rec.format != "csvmap":
            raise click.BadParameter(
                f"{p.name} is read as {rec.format}, which nulls its own documented markers; --invalid applies to "
                "a generic CSV read through --map only (give FILE: to name that input)",
                param_hint="--invalid",
            )
        seg = next((v for k, v in file_segs.items() if k in (str(p), p.name)), None)
        if seg is not None:
            rec = segment_recording(rec, seg)
        if rec.meta.get("summary"):
            tool.info(f"{p.name}: {rec.meta['summary']}")
        recordings.append(rec)
    table, meta, warnings = combine(recordings, offs)
    for w in warnings:
        tool.warn(w)
    holds = [r.tables["holds"] for r in recordings if "holds" in r.tables]
    if holds_out is not None:
        if not holds:
            raise InputError("--holds-out: no input came with a hold map; expected a bouldering trial (see --hold-map)")
        tool.write_side(holds_out, holds[0][0], holds[0][1])
    elif holds:
        tool.info("a hold map was found; write it for pf-holds with --holds-out FILE")
    order = time_order_totals(meta)
    done = ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in order.items() if v and k != "samples")
    tool.info(f"{table.num_rows} rows from {len(raw)} input(s); time order: {done or 'already in order'}")
    tool.write(table, meta, {**tool.params, "raw": [str(p) for p in raw], "time_order": order})


_PREFIX = re.compile(r"^([^=,]+):(?=[^:=,]+=)")


def _per_input(
    values: tuple[str, ...], option: str, raw: tuple[Path, ...]
) -> tuple[dict[int, dict[str, str]], dict[str, str]]:
    """Split ``FILE:COL=X,...`` values (for the input named FILE) from the ones for every input."""
    own: dict[int, dict[str, str]] = {}
    common: list[str] = []
    for value in values:
        m = _PREFIX.match(value)
        if m is None:
            common.append(value)
            continue
        name = m.group(1)
        hits = [i for i, p in enumerate(raw) if name in (str(p), p.name)]
        if not hits:
            raise click.BadParameter(
                f"{value!r}: {name!r} is not one of the inputs ({', '.join(p.name for p in raw)})", param_hint=option
            )
        for i in hits:
            own.setdefault(i, {}).update(parse_pairs([value[m.end() :]], option))
    return own, parse_pairs(common, option)


def _base(text: str | None) -> tuple[float, float, float] | None:
    if text is None:
        return None
    try:
        lat, lon, h = (float(v) for v in text.split(","))
    except ValueError as exc:
        raise click.BadParameter(f"{text!r} is not LAT,LON,H (degrees, degrees, metres)", param_hint="--base") from exc
    check_number(lat, -90, 90, "deg", "--base", text)
    check_number(lon, -180, 180, "deg", "--base", text)
    check_number(h, -1000, 10000, "m", "--base", text)
    return lat, lon, h


def _seconds(text: str) -> float:
    try:
        x = float(text)
    except ValueError as exc:
        raise click.BadParameter(f"{text!r} is not a number of seconds", param_hint="--offset") from exc
    return check_number(x, -1e10, 1e10, "s", "--offset", text)
