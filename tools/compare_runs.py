"""``compare-runs``: runs of one course compared gate by gate (skiracing-splines Figure 9)."""

from __future__ import annotations

from pathlib import Path

import click

from sportfusion.core import meta as sfmeta
from sportfusion.core.outputs import printable
from sportfusion.core.venue import read_venue
from sportfusion.skirace.compare import compare_tables, require_trajectory
from sportfusion.tools._cli import Tool, tool


def _labels(inputs: list[str | None], given: tuple[str, ...]) -> list[str]:
    if given and len(given) != len(inputs):
        raise click.BadParameter(
            f"{len(given)} label(s) for {len(inputs)} runs; give one --label per run (reference first)",
            param_hint="--label",
        )
    names = list(given) or [Path(p).stem if p not in (None, "-") else "reference" for p in inputs]
    out: list[str] = []
    for n in names:
        label, k = n, 2
        while label in out:
            label, k = f"{n}#{k}", k + 1
        out.append(label)
    return out


@tool(
    "compare-runs",
    cites=("skiracing-splines",),
    example="""
  compare-runs anna.parquet --run berta.parquet -o compare.parquet
  plot compare compare.parquet -o compare.png
  ingest anna.pos | gps2hill --origin 46.49,9.84,2200 --azimuth 160 | spline-smooth \\
      | compare-runs --run berta.parquet --run carla.parquet --gates gates.parquet --label Anna --label Berta \\
      --label Carla > compare.parquet""",
    input_help="Reference run (session table with a trajectory and gate crossings); default: standard input.",
)
@click.option(
    "--run",
    "runs",
    multiple=True,
    type=click.Path(dir_okay=False),
    help="Another run of the same course to compare with the reference (session table). Repeatable; at least one.",
)
@click.option(
    "--gates",
    "gates_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Gates table (kind gates: gate, x y z [m] in the runs' frame, or lat lon [deg] h [m]; a CSV or a plain "
    "Parquet with those columns too); runs without gate events cross each gate at their closest horizontal approach.",
)
@click.option(
    "--label",
    "labels",
    multiple=True,
    help="Name of each run in the summary [text], the reference first, then one per --run in order; "
    "default: the file names.",
)
@click.option(
    "--max-gate-distance",
    default=5.0,
    show_default=True,
    type=click.FloatRange(0, min_open=True),
    help="With --gates: a run passing a gate farther than this [m] (horizontally) does not cross it.",
)
@click.option(
    "--profile",
    "profile_path",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="Also write the speed difference as a function of distance to this summary table (run, "
    "path_distance [m] of the reference, speed, speed_diff [m/s]); `plot compare --profile` draws it.",
)
@click.option(
    "--profile-step",
    default=1.0,
    show_default=True,
    type=click.FloatRange(0, min_open=True),
    help="Spacing of the --profile samples along the reference's path [m].",
)
def main(
    tool: Tool,
    runs: tuple[str, ...],
    gates_path: str | None,
    labels: tuple[str, ...],
    max_gate_distance: float,
    profile_path: str | None,
    profile_step: float,
) -> None:
    """Compare runs of one course gate by gate, as in Figure 9 of the ski
    racing splines paper. The reference run comes on standard input (or INPUT)
    so that it can end a processing pipeline; the runs it is compared with are
    side inputs, --run FILE (repeatable), never a second stdin.

    Each run needs a trajectory in the same local frame (x y z [m], with
    vx vy vz [m/s] when present; else gnss_x gnss_y gnss_z) and gate
    crossings: rows with event 'gate' and a gate id (detect-events,
    gate-anchor), or, with --gates, the closest approach to each surveyed gate.

    Writes a summary table with one row per run and gate common to all runs:
    time since the first common gate and gate-to-gate time [s], distance along
    the path [m], speed at the gate [m/s], turn side (L/R), speed at the turn
    switches before and after the gate [m/s] and the turn's path length [m],
    each with its difference to the reference (run minus reference: positive
    time = slower). Draw it with `plot compare`. --profile FILE adds the
    speed difference as a function of the distance along the course, each
    section matched by its fraction between the gates."""
    ref_table, ref_meta = tool.read()
    names = _labels([tool.source, *runs], labels)
    require_trajectory(ref_table, names[0])
    if not runs:
        raise click.UsageError("give at least one --run FILE to compare with the reference")
    if "-" in runs:
        raise click.BadParameter(
            "standard input carries the reference run; give each --run as a file", param_hint="--run"
        )
    tables = [(names[0], ref_table, ref_meta)]
    for label, path in zip(names[1:], runs, strict=True):
        table, meta = tool.read_side(path, kind="session", what=f"run {printable(path)}")
        tables.append((label, table, meta))
    gates = None
    if gates_path is not None:
        gates = read_venue(gates_path, "gates", what=f"gates file {printable(gates_path)}")
    summary, info, warnings = compare_tables(
        tables, gates, max_gate_distance, profile_step if profile_path is not None else None
    )
    for w in warnings:
        tool.warn(w)
    meta = sfmeta.new_meta("summary", (ref_meta.get("time") or {}).get("epoch_utc"))
    if "frame" in ref_meta:
        meta["frame"] = ref_meta["frame"]
    meta["compare"] = {
        "reference": names[0],
        "runs": [
            {"label": lab, "source": src if src not in (None, "-") else "stdin", "crossings": info["crossings"][lab]}
            for lab, src in zip(names, [tool.source, *runs], strict=True)
        ],
        "gates": info["gates"],
    }
    meta["provenance"] = list(ref_meta.get("provenance", []))
    tool.info(f"{len(names)} runs compared over {len(info['gates'])} common gates (reference {names[0]})")
    if profile_path is not None:
        pmeta = {**meta, "compare": {**meta["compare"], "profile_step_m": profile_step}}
        tool.write_side(profile_path, info["profile"], pmeta)
    tool.write(summary, meta)
