"""``simulate boulder``: one hand's IMU + magnetometer on a bouldering wall, with truth and the hold map."""

from __future__ import annotations

import click

from sportfusion.climbing.sim import VARIANTS, BoulderConfig, simulate_boulder
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import seed_truth_options


@tool(
    "simulate boulder",
    cites=("climbing",),
    reads_table=False,
    example="""
  simulate boulder --seed 1 --truth truth.parquet --holds holds.parquet > trial.parquet
  simulate boulder --seed 2 --imu-rate 60 --route-holds 14 --holds holds.parquet -o trial.parquet
  simulate boulder --seed 3 --holds holds.parquet | detect-events --kind grips | pf-holds --holds holds.parquet > est.parquet
  simulate boulder --seed 4 --variant steel-wall --truth truth.parquet --holds holds.parquet > trial.parquet""",
)
@seed_truth_options(
    "Write the truth table (kind truth: true_x.. [m], true_vx.. [m/s], true_q0..3, true_grip, true_hold)."
)
@click.option(
    "--holds",
    "holds_path",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="Write the wall's hold map (kind holds: route, hold, x, y, z [m]; start holds, up axis, field in the metadata).",
)
@click.option(
    "--imu-rate",
    default=100.0,
    show_default=True,
    type=click.FloatRange(60, 100),
    help="IMU + magnetometer rate [Hz].",
)
@click.option(
    "--route-holds",
    default=None,
    type=click.IntRange(10, 20),
    help="Holds on the climbed route [count]; default: drawn from 10-20.",
)
@click.option(
    "--duration",
    default=None,
    type=click.FloatRange(5, 600),
    help="Stretch the grips so the trial lasts about this long [s]; default: natural grip times.",
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
def main(
    tool: Tool,
    seed: int,
    truth_path: str | None,
    holds_path: str | None,
    imu_rate: float,
    route_holds: int | None,
    duration: float | None,
    variant: str,
) -> None:
    """Simulate one bouldering trial of one hand: a 4-5 m wall with three routes
    (the first is climbed: two start holds, a top hold), grips at holds (sometimes
    off-centre, sometimes on the wall between holds, with grip adjustments) and
    transitions of 0.3-2 s, a down-climb on any holds of the wall. Sensors on the
    back of the hand: IMU and magnetometer (normalised, unit "1") with noise,
    biases, scale errors, magnetic disturbances behind the wall and occasional
    accelerometer range clipping, biases drifting with the unit's temperature, plus the unit's own
    orientation dev_q0..3 (sensor to world). Map frame: x right along the wall, y into the wall, z up.
    The simulator is written apart from the estimators (pf-holds); --variant picks a world they do not
    model."""
    cfg = BoulderConfig(seed=seed, imu_rate=imu_rate, route_holds=route_holds, duration=duration, variant=variant)
    sim = simulate_boulder(cfg)
    if truth_path:
        tool.write_side(truth_path, sim.truth, sim.truth_meta)
    if holds_path:
        tool.write_side(holds_path, sim.holds, sim.holds_meta)
    tool.info(
        f"{sim.session.num_rows} rows ({sim.session.column('t')[-1].as_py():.1f} s), route {sim.route}, "
        f"start hold {sim.start_hold}, descent at {sim.descent_time:.1f} s"
    )
    tool.write(sim.session, sim.meta)
