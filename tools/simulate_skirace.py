"""``simulate skirace``: an alpine ski run with truth, RTK GNSS with float episodes, a MEMS DMC and gyroscope."""

from __future__ import annotations

import click

from sportfusion.core import meta as sfmeta
from sportfusion.skirace.sim import SkiRaceConfig, simulate_skirace
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import course_site_options, parse_floats, seed_truth_options


@tool(
    "simulate skirace",
    cites=("skiracing-splines",),
    reads_table=False,
    example="""
  simulate skirace --seed 1 --truth truth.parquet > run.parquet
  simulate skirace --seed 2 --gnss-rate 20 --imu-rate 100 --floats 5 -o run.parquet
  simulate skirace --seed 3 --turn-period 2.8 --turn-acc 13 | spline-smooth | dmc-attitude > est.parquet""",
)
@seed_truth_options()
@click.option(
    "--duration",
    default=60.0,
    show_default=True,
    type=click.FloatRange(10, 600),
    help="Length of the run after the start [s].",
)
@click.option(
    "--static",
    default=5.0,
    show_default=True,
    type=click.FloatRange(0, 60),
    help="Standing in the start gate first (low dynamics) [s].",
)
@click.option(
    "--gnss-rate", default=10.0, show_default=True, type=click.FloatRange(10, 20), help="GNSS epoch rate [Hz]."
)
@click.option(
    "--imu-rate",
    default=50.0,
    show_default=True,
    type=click.FloatRange(30, 100),
    help="Accelerometer + magnetometer (+ gyroscope) rate [Hz].",
)
@click.option(
    "--no-gyro",
    is_flag=True,
    help="No gyroscope (gyr_x gyr_y gyr_z [rad/s]); the other sensors are the same samples either way.",
)
@course_site_options("46.4975,9.8365,2200", 160.0, "2026-02-10T10:00:00Z")
@click.option(
    "--turn-period",
    default=4.5,
    show_default=True,
    type=click.FloatRange(1, 20),
    help="Period of a left+right turn pair [s] (GS ~2.5-3, downhill ~4-6).",
)
@click.option(
    "--turn-acc",
    default=8.0,
    show_default=True,
    type=click.FloatRange(0, 30),
    help="Lateral acceleration amplitude in the turns [m/s^2].",
)
@click.option(
    "--jumps",
    default=2,
    show_default=True,
    type=click.IntRange(0, 10),
    help="Terrain jumps (free-fall flights) [count].",
)
@click.option(
    "--floats",
    "float_episodes",
    default=3,
    show_default=True,
    type=click.IntRange(0, 20),
    help="RTK float episodes [count].",
)
@click.option(
    "--losses",
    "lock_losses",
    default=2,
    show_default=True,
    type=click.IntRange(0, 20),
    help="Short losses of lock (no GNSS epochs) [count].",
)
def main(
    tool: Tool,
    seed: int,
    truth_path: str | None,
    duration: float,
    static: float,
    gnss_rate: float,
    imu_rate: float,
    site: str,
    azimuth: float,
    date: str,
    turn_period: float,
    turn_acc: float,
    jumps: int,
    float_episodes: int,
    lock_losses: int,
    no_gyro: bool,
) -> None:
    """Simulate an alpine ski run (downhill / giant-slalom like: turns, terrain
    rollers, jumps with free fall) in a course frame (x along the fall line,
    z down). Sensors: RTK GNSS with fixed/float ambiguity episodes (offsets that
    jump in and out at the transitions, optimistic sigmas) and short losses of
    lock, as lat/lon/h plus the local gnss_x/y/z with std_gnss_*; a MEMS DMC
    (accelerometer + magnetometer on the WMM field) with bias, scale, noise and
    ski vibration, and a MEMS gyroscope at the same instants (mean rate over each
    sample interval plus the Earth rate [rad/s]; turn-on bias, bias random walk,
    scale, noise, vibration; --no-gyro leaves it out). The truth (true_x.., true_vx.., true_ax.., true_q0..3,
    true_roll/pitch/yaw, true_speed at every session row) goes to --truth."""
    cfg = SkiRaceConfig(
        seed=seed,
        duration=duration,
        static=static,
        gnss_rate=gnss_rate,
        imu_rate=imu_rate,
        site=tuple(parse_floats(site, 3, "--site")),  # type: ignore[arg-type]
        azimuth_deg=azimuth,
        date=sfmeta.format_epoch(date) or date,
        turn_period=turn_period,
        turn_acc=turn_acc,
        jumps=jumps,
        float_episodes=float_episodes,
        lock_losses=lock_losses,
        gyro=not no_gyro,
    )
    sim = simulate_skirace(cfg)
    if truth_path:
        tool.write_side(truth_path, sim.truth, sim.truth_meta)
    tool.info(f"{sim.session.num_rows} rows, {sim.gnss_t.size} GNSS epochs ({int((sim.gnss_status != 4).sum())} float)")
    tool.write(sim.session, sim.meta)
