"""``inspect``: the terminal view of any sportfusion table."""

from __future__ import annotations

import json

import click
import pyarrow.csv as pacsv

from sportfusion.core.describe import describe_json, render
from sportfusion.tools._cli import Tool, tool


@tool(
    "inspect",
    writes_table=False,
    stdout=True,
    example="""
  ingest fixtures/raw/phyphox_jump.zip | inspect
  inspect session.parquet --rows 10
  inspect session.parquet --csv > session.csv
  inspect session.parquet --json | python -m json.tool""",
)
@click.option(
    "--rows", default=5, show_default=True, type=click.IntRange(0), help="Rows shown at the head and the tail [rows]."
)
@click.option(
    "--csv", "as_csv", is_flag=True, help="Write the whole table as CSV to stdout (units: see the plain view)."
)
@click.option(
    "--json",
    "as_json",
    is_flag=True,
    help="Write JSON to stdout: metadata, rows, columns (name, type, unit, nulls, meaning), sensor rates [Hz].",
)
def main(tool: Tool, rows: int, as_csv: bool, as_json: bool) -> None:
    """Print a table's columns (unit, type, nulls), per-sensor rates and time
    span, metadata (kind, frame, hill, events), provenance, and head/tail rows.
    Reads any table kind; writes text, never Parquet.  Head/tail values: degrees
    (lat, lon) with 8 decimals (~1 mm), metres and seconds with 3, others with
    6 significant digits; --csv writes full precision."""
    if as_csv and as_json:
        raise click.UsageError("--csv and --json exclude each other")
    table, meta = tool.read(kind=None)
    if as_json:
        tool.write_bytes((json.dumps(describe_json(table, meta), indent=2) + "\n").encode())
    elif as_csv:
        tool.outputs.add_stream(None, lambda fh: pacsv.write_csv(table, fh))
    else:
        tool.write_bytes(render(table, meta, rows).encode())
