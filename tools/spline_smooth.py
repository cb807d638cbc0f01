"""``spline-smooth``: weighted smoothing cubic splines of a GNSS track (skiracing-splines eqs 5-7)."""

from __future__ import annotations

import click

from sportfusion.core.session import with_columns
from sportfusion.skirace.track import smooth_session
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import check_number


def _lambda(value: str) -> float | None:
    if value.strip().lower() == "gcv":
        return None
    try:
        lam = float(value)
    except ValueError as exc:
        raise click.BadParameter(f"{value!r} is not a number in [0, 1] or 'gcv'", param_hint="--lambda") from exc
    if not 0.0 <= lam <= 1.0:  # NaN fails this too
        raise click.BadParameter(f"{value!r} is outside [0, 1]", param_hint="--lambda")
    return lam


def _segment(text: str) -> tuple[float, float, float]:
    try:
        span, value = text.split("=")
        t0, t1 = span.split(":")
        vals = float(t0), float(t1), float(value)
    except ValueError as exc:
        raise click.BadParameter(f"{text!r} is not T0:T1=LAMBDA", param_hint="--segment") from exc
    check_number(vals[0], -1e6, 1e7, "s", "--segment", text)
    check_number(vals[1], vals[0], 1e7, "s", "--segment", text)
    check_number(vals[2], 0, 1, "", "--segment", text)
    return vals


@tool(
    "spline-smooth",
    cites=("skiracing-splines",),
    example="""
  ingest rover.pos | gps2hill --origin 46.49,9.84,2200 --azimuth 160 | spline-smooth > smooth.parquet
  simulate skirace --seed 1 | spline-smooth --lambda 0.9 --no-trans 8 > smooth.parquet
  spline-smooth run.parquet --lambda gcv --segment 30:42=0.99 -o smooth.parquet""",
)
@click.option(
    "--lambda",
    "lam",
    default="0.9",
    show_default=True,
    help="Smoothing factor [1, dimensionless] in [0, 1] as in the paper (1 interpolates, 0 is a straight line; "
    "penalty = (1 - lambda)/lambda with t in s and weights in 1/m), or 'gcv' to choose it per axis.",
)
@click.option(
    "--segment",
    "segments",
    multiple=True,
    metavar="T0:T1=LAMBDA",
    help="Per-segment smoothing factor [1] for knot intervals between T0 and T1 [s on the session clock]. Repeatable.",
)
@click.option(
    "--weighting",
    type=click.Choice(["eq6", "uniform"]),
    default="eq6",
    show_default=True,
    help="Epoch weights: eq 6 (ambiguity status / position sigma [1/m]) or uniform (one weight, 1/median fixed sigma [1/m]).",
)
@click.option(
    "--w-float",
    default=0.5,
    show_default=True,
    type=click.FloatRange(0, 1, min_open=True),
    help="Weight of float epochs [1] (fixed = 1).",
)
@click.option(
    "--w-trans",
    default=1e-4,
    show_default=True,
    type=click.FloatRange(0, 1, min_open=True),
    help="Weight of a float epoch next to a fixed one [1].",
)
@click.option(
    "--no-trans",
    default=5,
    show_default=True,
    type=click.IntRange(0),
    help="Float epochs ramping from --w-trans to --w-float [epochs].",
)
@click.option(
    "--edge-factor",
    default=2.0,
    show_default=True,
    type=click.FloatRange(1),
    help="Weight multiplier [1] on the fixed epochs bordering a float period (paper: 2-3).",
)
@click.option(
    "--max-gap",
    default=10.0,
    show_default=True,
    type=click.FloatRange(0, min_open=True),
    help="Longest GNSS data gap bridged [s]; rows in longer gaps stay null, and a gap longer than this and 5 "
    "median fix intervals splits the track (a spline per segment, distance carried over the gap).",
)
@click.option(
    "--robust/--no-robust",
    default=True,
    show_default=True,
    help="Weight down fixes that disagree with their neighbours beyond their stated accuracy (phone/watch "
    "position jumps of tens of m): Tukey weights on leave-one-out residuals [m / sigma], screened also by the "
    "receiver's own velocity (vel_n/vel_e) or speed (gnss_speed) where the table has them; writes gnss_weight [1].",
)
def main(
    tool: Tool,
    lam: str,
    segments: tuple[str, ...],
    weighting: str,
    w_float: float,
    w_trans: float,
    no_trans: int,
    edge_factor: float,
    max_gap: float,
    robust: bool,
) -> None:
    """Smooth a GNSS track in the local frame (gnss_x gnss_y gnss_z, from
    gps2hill) with weighted smoothing cubic splines, one per coordinate, solved
    by a direct banded (Reinsch) system in O(N). Weights follow eq 6: fixed
    epochs 1, float epochs (gnss_fix != 4) ramping from --w-trans to --w-float,
    divided by the position sigma (std_gnss_*, else gnss_sigma_h/v).

    Adds x y z, vx vy vz, ax ay az (the spline and its derivatives, eq 7),
    speed, distance (along the spline from the first epoch), course (azimuth of
    the tangent from north [rad]), std_x std_y std_z when sigmas are given
    (input noise propagated through the smoother), spline_filled (True
    where the value bridges a GNSS data gap) and spline_segment. Every row inside the GNSS span
    gets values, IMU rows included; rows outside it stay null. A gap longer than
    --max-gap and 5 fix intervals splits the track: no spline across it, its rows
    null, distance carried over (one line names each gap). With --robust
    (default) phone/watch position jumps and stalls are weighted down (gnss_weight);
    on consumer tracks speed and distance take the height smoothed over 10 s."""
    table, meta = tool.read()
    result = smooth_session(
        table,
        meta,
        lam=_lambda(lam),
        segments=[_segment(s) for s in segments] or None,
        weighting=weighting,
        w_float=w_float,
        w_trans=w_trans,
        no_trans=no_trans,
        edge_factor=edge_factor,
        max_gap=max_gap,
        robust=robust,
    )
    for w in result.warnings:
        tool.warn(w)
    info = result.info
    lams = ", ".join(f"{v:.8g}" for v in info["lambda"])
    lams += " (penalty " + ", ".join(f"{v:.3g}" for v in info["penalty"]) + ")"
    lams += " outside the --segment spans" if segments else ""
    tool.info(
        f"{info['epochs']} GNSS epochs ({info['not_fixed']} not fixed), lambda x/y/z {lams}, "
        f"{info['filled_rows']} row(s) bridged across gaps, {info['downweighted']} outlying fix(es) weighted down"
    )
    tool.write(with_columns(table, result.columns), meta, {**tool.params, "lambda_used": info["lambda"]})
