"""``simulate gates``: a giant-slalom (or downhill) run over magnet gates, with truth and the gate survey."""

from __future__ import annotations

import click

from sportfusion.core import meta as sfmeta
from sportfusion.gates.sim import VARIANTS, GatesConfig, simulate_gates
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import course_site_options, parse_floats, seed_truth_options


@tool(
    "simulate gates",
    cites=("gates",),
    reads_table=False,
    example="""
  simulate gates --seed 1 --truth truth.parquet --gates survey.parquet > run.parquet
  simulate gates --seed 2 --downhill --wgs84 --gates survey.parquet -o run.parquet
  simulate gates --seed 3 --gates survey.parquet | detect-events --kind gates | gate-anchor --gates survey.parquet
  simulate gates --seed 4 --variant stray-iron --truth truth.parquet --gates survey.parquet > run.parquet""",
)
@seed_truth_options()
@click.option(
    "--gates",
    "gates_path",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="Write the survey of the buried magnets (kind gates: gate, x y z [m] or lat [deg] lon [deg] h [m], turn) here.",
)
@click.option("--downhill", is_flag=True, help="A downhill course: gates three times further apart, faster [flag].")
@click.option("--wgs84", is_flag=True, help="Write the survey in WGS84 lat/lon/h instead of the course frame [flag].")
@click.option(
    "--n-gates",
    default=None,
    type=click.IntRange(3, 200),
    help="Number of gates [count]; default 30 (GS), 12 (downhill).",
)
@click.option(
    "--variant",
    default="nominal",
    show_default=True,
    type=click.Choice(list(VARIANTS)),
    help="A world the estimator does not model: "
    + "; ".join(f"{k}: {v[0]}" for k, v in VARIANTS.items() if k != "nominal")
    + ".",
)
@click.option(
    "--spurious",
    default=None,
    type=click.IntRange(0, 20),
    help="Small metal objects beside the track that give noise peaks [count]; default: the variant's (1).",
)
@click.option(
    "--static",
    default=5.0,
    show_default=True,
    type=click.FloatRange(1, 60),
    help="Static posture at start and finish [s].",
)
@click.option(
    "--survey-spots",
    is_flag=True,
    help="Also survey the snow spots of the static postures: rows point = start / finish in --gates [flag].",
)
@course_site_options("46.8345,9.2103,1600", 20.0, "2026-01-20T10:00:00Z")
def main(
    tool: Tool,
    seed: int,
    truth_path: str | None,
    gates_path: str | None,
    downhill: bool,
    wgs84: bool,
    n_gates: int | None,
    variant: str,
    spurious: int | None,
    static: float,
    survey_spots: bool,
    site: str,
    azimuth: float,
    date: str,
) -> None:
    """Simulate an alpine run over a course of magnet gates (gates paper setup),
    with physics written apart from the estimators: about 30 GS gates 22-28 m
    apart over 700 m and 150 m drop (--downhill: gates three times further
    apart); at each gate the paper's magnet, a 15 cm stack of ten disc magnets
    buried a few cm under the snow, a little tilted, its moment spread between
    magnets; stray iron (a pylon, debris, the start hut) and a geological
    anomaly; the athlete balancing along the specific force (legs inclined
    into the turn, the pelvis less: angulation), poling out of the start,
    hockey-stopping after the finish, swaying in the static postures; the
    sacrum unit passing 0.2-1.5 m from the magnets at 15-25 m/s. The session
    has the unit's IMU at 500 Hz (acc_*, gyr_*) and magnetometer at 125 Hz
    (mag_* [uT]) with scale, misalignment, bias, temperature drift,
    quantisation, noise and ski chatter. The truth (true_x.., true_vx..,
    true_q0..3 of the unit, and true_event/true_gate/true_gate_distance/true_turn
    at the gate crossings) goes to --truth; the survey of the snow above each
    magnet (with survey noise) to --gates, with --survey-spots also the spots
    the athlete stands on at the start and the finish. --variant picks a
    world the estimator does not model."""
    cfg = GatesConfig(
        seed=seed,
        variant=variant,
        downhill=downhill,
        spurious=spurious,
        static=static,
        survey_spots=survey_spots,
        site=tuple(parse_floats(site, 3, "--site")),  # type: ignore[arg-type]
        azimuth_deg=azimuth,
        date=sfmeta.format_epoch(date) or date,
    )
    if n_gates is not None:
        cfg.n_gates = n_gates
    sim = simulate_gates(cfg, survey_wgs84=wgs84)
    if truth_path:
        tool.write_side(truth_path, sim.truth, sim.truth_meta)
    if gates_path:
        tool.write_side(gates_path, sim.survey, sim.survey_meta)
    tool.info(
        f"{sim.session.num_rows} rows, {sim.magnets.shape[0]} gates, "
        f"closest passes {sim.crossings['distance'].min():.2f}-{sim.crossings['distance'].max():.2f} m"
    )
    tool.write(sim.session, sim.meta)
