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
  simulate gates --seed 4 --variant stray-iron --truth truth.parquet --gates survey.parquet > run.parquet
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
    variant: str,
    spurious: int | None,
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
    world the estimator does not model. With --body: a
    skier whose posture follows the turns (sportfusion.gates.sim_skier: Dempster's
    segment table, independent of body-model's de Leva), seven units at
    --body-rate (the pelvis one with the magnetometer; the others' columns
    <segment>__acc_*), and the truth of the CoM (true_com_*, true_com_v*), of
    the LJC and of the joint centres relative to it in body-model's frame
    (true_<point>_rel_*)."""
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
    if raw_dir and not body:
        raise click.UsageError("--raw writes the seven sensors' exports: give --body")
    if body:
        cfg.body, cfg.height, cfg.body_mass = True, height, mass
        cfg.imu_rate = cfg.mag_rate = body_rate
    sim = simulate_gates(cfg, survey_wgs84=wgs84)
    if truth_path:
        tool.write_side(truth_path, sim.truth, sim.truth_meta)
    if gates_path:
        tool.write_side(gates_path, sim.survey, sim.survey_meta)
    if raw_dir:  # the seven units' exports, the mapping file, the athlete and the survey, as one folder
        tool.write_folder(raw_dir, lambda folder: write_body_raw(sim, folder, body_rate, seed, tool, height, mass))
    tool.info(
        f"{sim.session.num_rows} rows, {sim.magnets.shape[0]} gates, "
        f"closest passes {sim.crossings['distance'].min():.2f}-{sim.crossings['distance'].max():.2f} m"
    )
    tool.write(sim.session, sim.meta)


def write_body_raw(sim, raw_dir, rate: float, seed: int, tool: Tool, height: float, mass: float) -> None:  # noqa: ANN001
    """The simulated recording as an Xsens export folder (sportfusion.sim.xsens_raw) with the survey, into
    ``raw_dir`` (the output layer's temporary folder, renamed to --raw when every output is ready)."""
    from pathlib import Path

    from sportfusion.core import io as sfio
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
