"""``dmc-attitude``: attitude per sample from a digital magnetic compass and GNSS (skiracing-splines eqs 8-9),
gyro-stabilised when the session has a gyroscope."""

from __future__ import annotations

import click

from sportfusion.core.session import with_columns
from sportfusion.skirace.dmc import dmc_table, gyro_sampling
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import parse_floats


@tool(
    "dmc-attitude",
    cites=("skiracing-splines",),
    example="""
  simulate skirace --seed 1 | spline-smooth | dmc-attitude > attitude.parquet
  dmc-attitude session.parquet --site 46.49,9.84,2200 --lowpass 3 -o attitude.parquet
  dmc-attitude xsens.parquet --dip-from-data --mag-weight 0.5 > attitude.parquet
  dmc-attitude spline.parquet --no-gyro -o dmc-only.parquet""",
)
@click.option(
    "--site",
    default=None,
    metavar="LAT,LON,H",
    help="Site for gravity and the magnetic model [deg, deg, m ellipsoidal]; default: lat/lon/h columns or the frame origin.",
)
@click.option(
    "--date",
    default=None,
    metavar="YYYY-MM-DD",
    help="Date for the magnetic model [UTC ISO-8601]; default: the session's time.epoch_utc.",
)
@click.option(
    "--mag-ref",
    default=None,
    metavar="N,E,D",
    help="Reference magnetic field in NED [uT, or any unit: only its direction is used] instead of the model.",
)
@click.option(
    "--dip-from-data",
    is_flag=True,
    help="Estimate the magnetic inclination [deg] from quiet samples instead of the model.",
)
@click.option(
    "--g0",
    type=float,
    default=None,
    help="Gravity [m/s^2]; default: WGS84 normal gravity at the site (or the hill's g0).",
)
@click.option(
    "--acc-weight",
    default=1.0,
    show_default=True,
    type=click.FloatRange(0, min_open=True),
    help="Wahba weight of the specific-force vector [1].",
)
@click.option(
    "--mag-weight",
    default=1.0,
    show_default=True,
    type=click.FloatRange(0, min_open=True),
    help="Wahba weight of the magnetic vector [1].",
)
@click.option(
    "--lowpass",
    "lowpass_hz",
    default=None,
    type=click.FloatRange(0),
    help="Zero-phase low-pass cut-off for the raw DMC channels [Hz]; 0: none. Default 5 Hz, left out (with a note) "
    "on rows slower than 10 Hz.",
)
@click.option(
    "--coriolis", is_flag=True, help="Include the Coriolis and transport-rate terms of eq 9 (needs vx vy vz) [m/s^2]."
)
@click.option(
    "--free-fall",
    default=2.0,
    show_default=True,
    type=click.FloatRange(0),
    help="|specific force| below this flags dmc_singular [m/s^2].",
)
@click.option(
    "--no-gyro",
    is_flag=True,
    help="Ignore gyr_x gyr_y gyr_z: the attitude of the DMC alone, sample by sample.",
)
@click.option(
    "--acc-sigma",
    default=0.5,
    show_default=True,
    type=click.FloatRange(0, min_open=True),
    help="With a gyro: 1-sigma of the specific force against its reference [m/s^2], grown by the "
    "difference of their lengths.",
)
@click.option(
    "--mag-sigma",
    default=0.02,
    show_default=True,
    type=click.FloatRange(0, min_open=True),
    help="With a gyro: 1-sigma of the magnetic field direction [rad].",
)
@click.option(
    "--gyro-samples",
    type=click.Choice(["auto", "mean", "instant"]),
    default="auto",
    show_default=True,
    help="With a gyro: what a gyr_* sample is -- the mean rate over the interval ending at it (a delta-angle "
    "gyro; simulate skirace) or the rate at that instant (phones, most MEMS loggers; averaged over each "
    "interval by the trapezoid). auto: instant for a recording read by ingest, mean for a simulated session. "
    "Read as mean, an instantaneous gyro lags half a sample [choice].",
)
@click.option(
    "--gyro-noise",
    default=3e-4,
    show_default=True,
    type=click.FloatRange(0, min_open=True),
    help="With a gyro: its white-noise density [rad/s/sqrt(Hz)].",
)
@click.option(
    "--gyro-bias-walk",
    default=2e-4,
    show_default=True,
    type=click.FloatRange(0, min_open=True),
    help="With a gyro: random walk of its bias [rad/s/sqrt(s)].",
)
@click.option(
    "--mag-bias-sigma",
    default=0.5,
    show_default=True,
    type=click.FloatRange(0),
    help="With a gyro: prior 1-sigma per axis of the magnetometer's hard-iron bias [uT], estimated along "
    "(bias_mag_x..z, in the magnetometer's unit: a normalised one gets the prior scaled by its norm over the "
    "model's intensity); 0: not estimated.",
)
@click.option(
    "--acc-bias-sigma",
    default=0.05,
    show_default=True,
    type=click.FloatRange(0),
    help="With a gyro: prior 1-sigma per axis of the accelerometer's bias [m/s^2], estimated along "
    "(bias_acc_x..z); 0: not estimated.",
)
def main(
    tool: Tool,
    site: str | None,
    date: str | None,
    mag_ref: str | None,
    dip_from_data: bool,
    g0: float | None,
    acc_weight: float,
    mag_weight: float,
    lowpass_hz: float | None,
    coriolis: bool,
    free_fall: float,
    no_gyro: bool,
    gyro_samples: str,
    acc_sigma: float,
    mag_sigma: float,
    gyro_noise: float,
    gyro_bias_walk: float,
    mag_bias_sigma: float,
    acc_bias_sigma: float,
) -> None:
    """Attitude on every accelerometer row from the magnetometer and the specific
    force (a digital magnetic compass) by Wahba's problem solved with QUEST.
    References in NED: the field from the World Magnetic Model at the site and
    date (or --mag-ref, or --dip-from-data), and f = a - g (eq 9) with the GNSS
    acceleration ax ay az from spline-smooth; without it, low dynamics (f = -g).

    Adds q0..q3 (q_BO, NED to body, scalar first), roll pitch yaw [rad] (yaw =
    azimuth from north), quest_loss (Wahba loss, 0 = consistent), dmc_singular
    (near free fall or field parallel to f) and ax_dmc ay_dmc az_dmc, the
    kinematic acceleration re-estimated from the specific force through the
    attitude, in the local frame, and mag_implausible (the field norm is more
    than 20 % off the model's intensity, or, standing still, the
    field-to-gravity angle more than 5 deg off the model's: a disturbed or miscalibrated magnetometer;
    a warning line gives the numbers, as for a --dip-from-data inclination
    more than 5 deg from the model's).

    With a gyroscope (gyr_x gyr_y gyr_z [rad/s]; the paper's gyro-stabilised
    magnetometer) the attitude is smoothed over the whole record instead: the
    gyro carries it from sample to sample, the specific force and the field of
    every sample correct it, and the gyro bias is estimated along; this adds
    bias_gyr_x bias_gyr_y bias_gyr_z [rad/s] and std_roll std_pitch std_yaw
    [rad] (1-sigma). The magnetometer's hard-iron bias and the accelerometer's
    bias (constants in the body frame, observable through the run's rotations)
    are estimated along too: bias_mag_x..z [uT, or the magnetometer's unit] and
    bias_acc_x..z [m/s^2] with their std_ columns (--mag-bias-sigma,
    --acc-bias-sigma; 0 leaves one out). --no-gyro gives the DMC alone."""
    table, meta = tool.read()
    why = "--gyro-samples"
    if gyro_samples == "auto":
        gyro_samples, why = gyro_sampling(meta)
    result = dmc_table(
        table,
        meta,
        site=tuple(parse_floats(site, 3, "--site")) if site else None,  # type: ignore[arg-type]
        date=date,
        mag_ref=parse_floats(mag_ref, 3, "--mag-ref") if mag_ref else None,
        dip_from_data=dip_from_data,
        g0=g0,
        weight_acc=acc_weight,
        weight_mag=mag_weight,
        lowpass_hz=lowpass_hz,
        coriolis=coriolis,
        free_fall=free_fall,
        use_gyro=not no_gyro,
        gyro_samples=gyro_samples,
        sigma_acc=acc_sigma,
        sigma_mag=mag_sigma,
        gyro_noise=gyro_noise,
        bias_walk=gyro_bias_walk,
        sigma_mag_bias=mag_bias_sigma,
        sigma_acc_bias=acc_bias_sigma,
    )
    for w in result.warnings:
        tool.warn(w)
    i = result.info
    how = "gyro-stabilised DMC" if i["method"] == "gyro+dmc" else "DMC alone"
    tool.info(
        f"{i['rows']} attitude rows at {i['rate_hz']:.1f} Hz ({how}), {i['singular']} singular; magnetic reference "
        f"{i['mag_ref_source']} (inclination {i['inclination_deg']:.2f} deg, declination {i['declination_deg']:.2f} deg)"
    )
    if "bias_mag" in i or "bias_acc" in i:
        parts = []
        if "bias_mag" in i:
            parts.append(
                "magnetometer hard iron " + " ".join(f"{v:+.3g}" for v in i["bias_mag"]) + f" {i['bias_mag_unit']}"
            )
        if "bias_acc" in i:
            parts.append("accelerometer bias " + " ".join(f"{v:+.3g}" for v in i["bias_acc"]) + " m/s^2")
        tool.info("estimated " + ", ".join(parts) + " (body x y z)")
    if i["method"] == "gyro+dmc":
        tool.info(
            f"gyro samples read as {'instantaneous rates' if gyro_samples == 'instant' else 'interval means'} ({why})"
        )
    if i.get("bias_mag_unit", "uT") != "uT":  # a normalised magnetometer: its bias in its unit
        meta = dict(
            meta,
            units={
                **(meta.get("units") or {}),
                **{f"{p}bias_mag_{a}": i["bias_mag_unit"] for p in ("", "std_") for a in "xyz"},
            },
        )
    tool.write(
        with_columns(table, result.columns), meta, dict(tool.params, method=i["method"], gyro_samples=gyro_samples)
    )
