"""``simulate gates``: a giant-slalom (or downhill) run over magnet gates, with truth and the gate survey."""

from __future__ import annotations

import click

from sportfusion.core import io as sfio
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
  simulate gates --seed 3 --gates survey.parquet | detect-events --kind gates | gate-anchor --gates survey.parquet
  simulate gates --seed 4 --body --truth truth.parquet --gates survey.parquet \
    | body-model --height 1.80 --mass 78 | detect-events --kind gates | gate-anchor --gates survey.parquet
  simulate gates --seed 5 --body --raw run5/ --truth truth.parquet > /dev/null
  ingest run5/ | body-model --height 1.80 --mass 78 | detect-events --kind gates | gate-anchor --gates run5/survey.parquet""",
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
@click.option(
    "--body",
    is_flag=True,
    help="A full-body skier with seven IMUs (pelvis, torso, head, thighs, shanks; sensors strapped at unknown "
    "rotations up to 30 deg and lever arms), the calibration (still upright, three squats) before the start [flag].",
)
@click.option(
    "--height", default=1.80, show_default=True, type=click.FloatRange(1.0, 2.5), help="--body: athlete's height [m]."
)
@click.option(
    "--mass", default=78.0, show_default=True, type=click.FloatRange(25, 200), help="--body: athlete's mass [kg]."
)
@click.option(
    "--body-rate",
    default=100.0,
    show_default=True,
    type=click.FloatRange(20, 1000),
    help="--body: sampling rate of every sensor, magnetometer included [Hz].",
)
@click.option(
    "--raw",
    "raw_dir",
    type=click.Path(file_okay=False, writable=True),
    default=None,
    help="--body: also write the recording as raw files into this folder: one Xsens MT Manager export per sensor, "
    "OpenSense's myIMUMappings.xml, athlete.txt (height, mass) and the survey (survey.parquet).",
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
    body: bool,
    height: float,
    mass: float,
    body_rate: float,
    raw_dir: str | None,
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
    spots the athlete stands on at the start and the finish. With --body: a skier
    whose posture follows the turns (sportfusion.gates.sim_skier: Dempster's
    segment table, independent of body-model's de Leva), seven IMUs at
    --body-rate (the pelvis one with the magnetometer; the others'
    columns <segment>__acc_*), and the truth of the CoM (true_com_*, true_com_v*),
    of the LJC and of the joint centres relative to it in body-model's frame
    (true_<point>_rel_*)."""
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
    if raw_dir and not body:
        raise click.UsageError("--raw writes the seven sensors' exports: give --body")
    if body:
        cfg.body, cfg.height, cfg.body_mass = True, height, mass
        cfg.imu_rate = cfg.mag_rate = body_rate
    sim = simulate_gates(cfg, survey_wgs84=wgs84)
    if truth_path:
        sfio.write_table(sim.truth, sfmeta.add_provenance(sim.truth_meta, tool.name, tool.params), truth_path)
    if gates_path:
        sfio.write_table(sim.survey, sfmeta.add_provenance(sim.survey_meta, tool.name, tool.params), gates_path)
    if raw_dir:  # side outputs: the one place to switch to the Tool's side-output API
        write_body_raw(sim, raw_dir, body_rate, seed, tool, height, mass)
    tool.info(
        f"{sim.session.num_rows} rows, {sim.magnets.shape[0]} gates, "
        f"closest passes {sim.crossings['distance'].min():.2f}-{sim.crossings['distance'].max():.2f} m"
    )
    tool.write(sim.session, sim.meta)


def write_body_raw(sim, raw_dir: str, rate: float, seed: int, tool: Tool, height: float, mass: float) -> None:
    """The simulated recording as an Xsens export folder (sportfusion.sim.xsens_raw) with the survey."""
    from pathlib import Path

    from sportfusion.core.magfield import reference_field
    from sportfusion.sim.xsens_raw import write_xsens_folder

    lat, lon, h = sim.meta["frame"]["origin"]
    norm = float((reference_field(lat, lon, h, sim.meta["time"]["epoch_utc"]) ** 2).sum() ** 0.5)
    segs = ["pelvis", "torso", "head", "femur_r", "femur_l", "tibia_r", "tibia_l"]
    write_xsens_folder(sim.session, raw_dir, segs, rate, mag_norm=norm, seed=seed)
    Path(raw_dir, "athlete.txt").write_text(f"height_m = {height:g}\nmass_kg = {mass:g}\n")
    sfio.write_table(
        sim.survey, sfmeta.add_provenance(sim.survey_meta, tool.name, tool.params), str(Path(raw_dir, "survey.parquet"))
    )
