"""``pf-holds``: climbing hand positions from IMU grips and a hold map (transition estimator + particle filter)."""

from __future__ import annotations

import click

from sportfusion.climbing.holds import read_holds
from sportfusion.climbing.particles import HoldModel, PFParams
from sportfusion.climbing.track import TrackOptions, track_holds
from sportfusion.climbing.transition import TransitionParams
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.session import with_columns
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import SEED


@tool(
    "pf-holds",
    cites=("climbing",),
    example="""
  simulate boulder --seed 1 --holds holds.parquet --truth truth.parquet \\
    | detect-events --kind grips | pf-holds --holds holds.parquet > est.parquet
  pf-holds --holds wall.parquet --route yellow --descent-after 41.5 --seed 3 trial.parquet -o est.parquet""",
)
@click.option(
    "--holds",
    "holds_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Hold map (kind holds: route, hold, x, y, z [m]; start holds, up axis and field in its metadata), or a "
    "CSV / plain Parquet with those columns and start (docs/table-contract.md). Needed.",
)
@click.option("--route", default=None, help="Route climbed [name]; default: the session's climbing.route.")
@click.option(
    "--descent-after",
    type=float,
    default=None,
    help="Time from which grips may be at any hold of the wall [s]; default: the session's climbing.descent_time.",
)
@click.option("--particles", default=200, show_default=True, type=click.IntRange(2, 100000), help="Particles [count].")
@click.option(
    "--seed", default=0, show_default=True, type=SEED, help="Random seed of the particle filter [integer >= 0]."
)
@click.option(
    "--smooth/--no-smooth",
    default=True,
    show_default=True,
    help="Output the particle smoother (backward simulation) or the forward filter [flag].",
)
@click.option(
    "--yaw-psd",
    default=PFParams.yaw_psd,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="Random walk of the yaw error [rad^2/s].",
)
@click.option(
    "--hold-radius",
    default=HoldModel.radius,
    show_default=True,
    type=click.FloatRange(0, None),
    help="Radius of the uniform ball around a hold centre [m].",
)
@click.option(
    "--hold-sigma",
    default=HoldModel.sigma,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="Standard deviation of the Gaussian tails around the ball [m].",
)
@click.option(
    "--elsewhere",
    default=HoldModel.elsewhere_sigmas,
    show_default=True,
    type=click.FloatRange(0, None),
    help="Grip-elsewhere likelihood: the tail's value this far outside the ball [sigmas].",
)
@click.option(
    "--grip-count",
    default=PFParams.grip_count,
    show_default=True,
    type=click.FloatRange(0, None),
    help="How many times one grip's likelihood counts, whatever its length [count]; 0: every sample "
    "once (the paper's eq 18).",
)
@click.option(
    "--mag-disturbance",
    default=TransitionParams.mag_disturbance,
    show_default=True,
    type=click.FloatRange(0, None),
    help="1-sigma of the wall's slowly varying magnetic disturbance [normalised field, 1], counted once per "
    "second of samples; 0: the paper's white magnetometer noise only.",
)
def main(
    tool: Tool,
    holds_path: str | None,
    route: str | None,
    descent_after: float | None,
    particles: int,
    seed: int,
    smooth: bool,
    yaw_psd: float,
    hold_radius: float,
    hold_sigma: float,
    elsewhere: float,
    grip_count: float,
    mag_disturbance: float,
) -> None:
    """Estimate one hand's position on a climbing wall (climbing paper §III):
    the whole trial as one least-squares problem with zero-velocity updates at the
    detected grips gives transition velocities and their covariance; a particle
    filter over position and yaw error, started at the route's two start holds
    (one stratum of particles each, kept until their tracks meet on a hold; the one
    with the larger evidence goes on), matches every grip against the route's holds (all holds of the wall after the
    descent time) and a particle smoother refines it. Adds x y z [m] and vx vy vz
    [m/s] in the hold map's frame, hold_id at grips (-1: elsewhere) and
    cluster_prob. Needs the columns grip (detect-events --kind grips) and
    acc_*, gyr_*, mag_*. Two defaults go beyond the paper (fewer wrong start holds
    on simulated walls): the magnetometer's slowly varying disturbance counts once
    per second of samples (--mag-disturbance) and each grip counts twice whatever
    its length (--grip-count); --mag-disturbance 0 --grip-count 0 is the paper's model."""
    if route is not None and not route.strip():
        raise click.BadParameter("is empty; expected a route name of the hold map", param_hint="--route")
    table, meta = tool.read()
    schema.require_columns(
        table,
        tuple(f"{s}_{a}" for s in ("acc", "gyr", "mag") for a in "xyz") + ("grip",),
        "pf-holds (run `detect-events --kind grips` first)",
    )
    if holds_path is None:
        raise InputError("no hold map given; expected --holds FILE (a holds table)")
    holds = read_holds(holds_path)
    opts = TrackOptions(
        route=route,
        descent_after=descent_after,
        seed=seed,
        smooth=smooth,
        pf=PFParams(
            particles=particles,
            yaw_psd=yaw_psd,
            hold=HoldModel(hold_radius, hold_sigma, elsewhere),
            grip_count=grip_count or None,
        ),
        transition=TransitionParams(mag_disturbance=mag_disturbance),
    )
    res = track_holds(table, meta, holds, opts)
    for w in res.warnings:
        tool.warn(w)
    meta = dict(meta)
    if "frame" in holds.meta:
        meta["frame"] = holds.meta["frame"]
    meta["climbing"] = {**(meta.get("climbing") or {}), "up": holds.meta["climbing"]["up"], "route": res.route}
    tool.info(f"route {res.route}, {res.transition.iterations} solver iterations, {res.pf.resamples} resamplings")
    tool.write(with_columns(table, res.columns), meta)
