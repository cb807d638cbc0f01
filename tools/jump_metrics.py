"""``jump-metrics``: per-jump figures (take-off, flight, touch-down, jump length) from a smoothed session."""

from __future__ import annotations

from sportfusion.core.schema import require_columns
from sportfusion.skijump.hillfile import hill_from_meta
from sportfusion.skijump.metrics import jump_metrics_table
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import hill_options, load_hill_option


@tool(
    "jump-metrics",
    cites=("skijump",),
    example="""
  rts-smooth jump.parquet --hill oberstdorf_hs106 | jump-metrics > jumps.parquet
  jump-metrics smooth.parquet --hill my_hill.toml -o jumps.parquet && inspect jumps.parquet""",
)
@hill_options
def main(tool: Tool, hill: str | None, hill_set: tuple[str, ...]) -> None:
    """One row per jump of a smoothed ski-jump session (rts-smooth output with
    take-off/touch-down events): t_takeoff [s], takeoff_speed [m/s],
    flight_time [s], touch-down position touchdown_x/y/z [m, hill frame],
    jump_length [m] along the landing profile to the foot of the normal from the
    touch-down position, and max_height [m], the largest vertical height above
    the landing profile in flight.  The hill defaults to the one in the
    table's metadata."""
    table, meta = tool.read()
    require_columns(table, ("x", "y", "z", "vx", "vy", "vz"), "jump-metrics (rts-smooth output)")
    the_hill = load_hill_option(hill, hill_set) or hill_from_meta(meta)
    out, meta, msg = jump_metrics_table(table, meta, the_hill)
    tool.info(msg)
    tool.write(out, meta)
