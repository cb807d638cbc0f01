"""``simulate gates``: a giant-slalom (or downhill) run over magnet gates, with truth and the gate survey."""

from __future__ import annotations

import click

from sportfusion.core import meta as sfmeta
from sportfusion.gates.sim import GatesConfig, simulate_gates
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import course_site_options, parse_floats, seed_truth_options


@tool(
    "simulate gates",
    cites=("gates",),
    reads_table=False,
    example="""
  simulate gates --seed 1 --truth truth.parquet --gates survey.parquet > run.parquet
  simulate gates --seed 2 --downhill --wgs84 --gates survey.parquet -o run.parquet
  simulate gates --seed 3 --gates survey.parquet | detect-events --kind gates | gate-anchor --gates survey.parquet""",
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
    "--spurious",
    default=1,
    show_default=True,
    type=click.IntRange(0, 20),
    help="Magnetic disturbances beside the track that give noise peaks [count].",
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
    spurious: int,
    static: float,
    survey_spots: bool,
    site: str,
    azimuth: float,
    date: str,
) -> None:
    """Simulate an alpine run over a course of magnet gates (gates paper setup):
    about 30 GS gates 22-28 m apart over 700 m and 150 m drop (--downhill: gates
    three times further apart), a magnet buried at each gate, the athlete's
    sacrum swinging around the gates and passing 0.2-1.2 m from the magnets at
    15-25 m/s, static postures at start and finish. The session has a sacrum
    IMU at 500 Hz (acc_*, gyr_*) and a magnetometer at 125 Hz (mag_* [uT]: the
    Earth field plus each magnet's dipole field, decaying with the cube of the
    distance), with bias, noise and ski vibration. The truth (true_x.., true_vx..,
    true_q0..3, and true_event/true_gate/true_gate_distance/true_turn at the
    gate crossings) goes to --truth; the magnet survey (with survey noise) to --gates, with --survey-spots also the
    spots the athlete stands on at the start and the finish."""
    cfg = GatesConfig(
        seed=seed,
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
