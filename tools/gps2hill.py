"""``gps2hill``: WGS84 lat/lon/h -> gnss_x gnss_y gnss_z in the hill (or any local) frame."""

from __future__ import annotations

import math

import click

from sportfusion.core.frames import GNSS_COLUMNS, METHODS, Frame, auto_origin, gnss_to_frame, track_heights
from sportfusion.core.schema import require_columns
from sportfusion.skijump.hillfile import hill_from_meta
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import hill_options, load_hill_option, parse_floats


@tool(
    "gps2hill",
    cites=("skijump",),
    example="""
  ingest run.zip track.nmea | gps2hill --hill oberstdorf_hs106 > session.parquet
  gps2hill session.parquet --hill my_hill.toml --hill-set height=951.2 -o hill.parquet
  gps2hill course.parquet --origin 47.2871,11.4044,2005 --azimuth 118 > local.parquet
  gps2hill session.parquet --hill oberstdorf_hs106 --method paper > paper.parquet
  ingest watch.gpx | gps2hill --origin auto > local.parquet
  ingest watch.gpx | gps2hill --hill oberstdorf_hs106 --geoid-offset 47.9 > hill.parquet""",
)
@hill_options
@click.option(
    "--origin",
    metavar="LAT,LON,H|auto",
    default=None,
    help="Frame origin: latitude [deg], longitude [deg], ellipsoidal height [m]; or 'auto': the track's first "
    "valid fix (for a venue without a surveyed origin); default: the hill's take-off edge.",
)
@click.option(
    "--geoid-offset",
    type=float,
    default=None,
    metavar="M",
    help="Geoid separation N at the site [m] for tracks with heights above mean sea level only (GPX <ele>, "
    "phone exports): h = h_msl + N.",
)
@click.option(
    "--azimuth",
    type=float,
    default=None,
    help="Azimuth of the frame's x axis, clockwise from north [deg]; default: the hill's psi_N, else 0 (NED).",
)
@click.option(
    "--method",
    type=click.Choice(METHODS),
    default="pyproj",
    show_default=True,
    help="pyproj: exact cart+topocentric pipeline; paper: the small-area eqs 27-29 (mm at 100 m, 13 cm at 1 km).",
)
def main(
    tool: Tool,
    hill: str | None,
    hill_set: tuple[str, ...],
    origin: str | None,
    geoid_offset: float | None,
    azimuth: float | None,
    method: str,
) -> None:
    """Convert GNSS positions (lat, lon [deg], ellipsoidal h [m]) into the hill
    frame of the ski-jumping paper (origin at the take-off edge, x along the
    hill azimuth, y right, z down) or any local frame, as gnss_x gnss_y gnss_z
    [m]; rows without a fix stay null.  Sigmas carry over as std_gnss_x/y/z
    [m] (north/east sigmas rotated by the azimuth; gnss_sigma_h per axis;
    gnss_sigma_v to z).  vel_n vel_e vel_d stay NED, untouched.  The frame
    (and the hill with --hill) is written into the metadata.  Without --hill
    and --origin the hill named in the session's metadata is used; a session
    that names none is refused.

    Heights: h (ellipsoidal) where the table has it; rows with only h_msl
    (height above mean sea level) use h_msl + --geoid-offset, else the
    receiver's own geoid separation where some rows give both.  A track with
    MSL heights only reaches a hill frame with --geoid-offset, or a local
    frame with --origin auto (heights then stay MSL, said in the frame); a
    track without heights gets gnss_x/gnss_y and a null gnss_z."""
    table, meta = tool.read()
    require_columns(table, GNSS_COLUMNS, "gps2hill (WGS84 latitude and longitude)")
    if geoid_offset is not None and not (math.isfinite(geoid_offset) and abs(geoid_offset) <= 150.0):
        raise click.BadParameter(
            f"{geoid_offset} m is not a geoid separation (-150..150 m)", param_hint="--geoid-offset"
        )
    the_hill = load_hill_option(hill, hill_set)
    if the_hill is None and origin is None and (meta.get("hill") or {}).get("spec"):
        the_hill = hill_from_meta(meta)  # the session already names its hill (simulate, an earlier gps2hill)
        tool.info(f"--hill {the_hill.spec}: the session's hill")
    if the_hill is None and origin is None:
        raise click.UsageError(
            "give --hill NAME|FILE.toml or --origin LAT,LON,H|auto (with --azimuth DEG); the session names no hill"
        )
    az = azimuth if azimuth is not None else (the_hill.site.get("azimuth_deg", 0.0) if the_hill else 0.0)
    name = "hill" if the_hill else "local"
    if origin is not None and origin.strip().lower() == "auto":
        lat, lon, h, ref = auto_origin(table, track_heights(table, geoid_offset))
        frame = Frame(lat, lon, h, az, name, ref)
    elif origin is not None:
        lat, lon, h = parse_floats(origin, 3, "--origin")
        frame = Frame(lat, lon, h, az, name)
    else:
        frame = the_hill.frame()
        if azimuth is not None:
            frame = Frame(frame.lat, frame.lon, frame.h, azimuth, "hill")
    out, meta = gnss_to_frame(table, meta, frame, method, the_hill.meta() if the_hill else None, geoid_offset)
    n_fix = out.num_rows - out.column("gnss_x").null_count
    import pyarrow.compute as pc

    n_pos = int(pc.sum(pc.and_(pc.is_valid(table.column("lat")), pc.is_valid(table.column("lon")))).as_py() or 0)
    if n_pos > n_fix:
        tool.warn(
            f"{n_pos - n_fix} row(s) with lat/lon have no usable height and stay null in the frame "
            "(heights above mean sea level only need --geoid-offset M)"
        )
    fr = meta["frame"]
    heights = {"ellipsoidal": "ellipsoidal heights", "msl": "heights above mean sea level", "none": "no heights"}
    how = heights[fr["gnss_z_ref"]] + (" (2-D: gnss_z null)" if fr["gnss_z_ref"] == "none" else "")
    if "geoid_offset_m" in fr:
        how += f", h = h_msl + {fr['geoid_offset_m']:.2f} m from {fr['geoid_source']}"
    tool.info(
        f"{n_fix} of {out.num_rows} rows into frame '{frame.name}' (origin {frame.lat:.6f}, {frame.lon:.6f}, "
        f"{frame.h:.2f} m {frame.height_ref}; azimuth {frame.azimuth_deg:g} deg; method {method}; {how})"
    )
    tool.write(out, meta)
