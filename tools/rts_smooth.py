"""``rts-smooth``: extended RTS smoother with hill constraints for ski jumping (skijump §3-4)."""

from __future__ import annotations

import sys

import click

from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import check_number, hill_options, load_hill_option, parse_floats


def _times(text: str | None, option: str) -> list[float] | None:
    if text is None:
        return None
    try:
        vals = [float(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise click.BadParameter(f"{text!r} is not comma-separated seconds", param_hint=option) from exc
    if not vals:
        raise click.BadParameter(f"{text!r} is not comma-separated seconds", param_hint=option)
    return [check_number(v, -1e6, 1e7, "s", option, text) for v in vals]


@tool(
    "rts-smooth",
    cites=("skijump",),
    example="""
  simulate skijump --seed 1 | detect-events --kind jump | rts-smooth --hill oberstdorf_hs106 > smooth.parquet
  rts-smooth jump.parquet --hill my_hill.toml --takeoff 12.34 --touchdown 15.61 -o smooth.parquet
  rts-smooth jump.parquet --config tuning.toml --filtered -o smooth.parquet""",
)
@hill_options
@click.option(
    "--takeoff",
    metavar="T[,T..]",
    default=None,
    help="Take-off time(s) [s on the session clock]; default: the event column's takeoff rows.",
)
@click.option(
    "--touchdown",
    metavar="T[,T..]",
    default=None,
    help="Touch-down time(s) [s on the session clock]; default: the event column's touchdown rows.",
)
@click.option(
    "--config",
    "config",
    type=click.Path(dir_okay=False),
    default=None,
    help="TOML file overriding the smoother settings (1-sigma P0, Q, R of Tables 3-5 -- GNSS position 5/5/8 m and "
    "hill constraints 0.05 m by default -- in m, m/s, rad/s, m/s^2, uT; "
    "windows in s); keys as in sportfusion.skijump.smoother_inputs.SmootherConfig.",
)
@click.option(
    "--no-hill-constraints",
    is_flag=True,
    help="Drop the in-run and landing constraints (eqs 32-34) [flag]; c_q stays.",
)
@click.option("--filtered", is_flag=True, help="Also write the forward-only EKF estimates as filt_ columns [flag].")
@click.option(
    "--no-zupt",
    is_flag=True,
    help="No zero-velocity updates where the athlete stands still (GNSS speed < 0.5 m/s and a quiet IMU "
    "for >= 1 s) [flag].",
)
@click.option(
    "--lever-arm",
    metavar="X,Y,Z",
    default=None,
    help="IMU -> GNSS antenna in the IMU's body frame [m] (a logger on the back, the phone on the arm); "
    "default 0,0,0 or the --config file's lever_arm.",
)
def main(
    tool: Tool,
    hill: str | None,
    hill_set: tuple[str, ...],
    takeoff: str | None,
    touchdown: str | None,
    config: str | None,
    no_hill_constraints: bool,
    filtered: bool,
    no_zupt: bool,
    lever_arm: str | None,
) -> None:
    """Reconstruct a ski jumper's trajectory with the extended Rauch-Tung-Striebel
    smoother of the ski-jumping paper: an INS model driven by the IMU (100 Hz),
    GNSS position (hill frame) and velocity (NED) and magnetometer updates
    (WMM reference field), sensor biases and magnetometer scale errors as
    augmented states, and the hill profile as soft constraints (in-run up to
    take-off, landing slope from touch-down, ramped in).  Input: a session with
    gyr/acc/mag columns, GNSS as gnss_x/y/z (gps2hill) or lat/lon/h, and
    take-off/touch-down events (detect-events --kind jump, or --takeoff and
    --touchdown).  A session without events is refused unless
    --no-hill-constraints is given: placed from speed alone the constraints
    make the attitude several times worse than no answer.  The initial attitude
    comes from the in-run (in-motion alignment); a GNSS time-stamp latency is
    estimated from the first pass and removed when it is at least 0.02 s; a
    known lever arm to the antenna (--lever-arm) is taken off the fixes; where
    the athlete stands still (sitting at the gate, standing after the stop) the
    velocity is held at zero.  Output: every input column plus x y z [m] and vx vy vz
    [m/s] in the hill frame, q0..q3, roll pitch yaw [rad], bias_/scale_
    columns, std_ columns, and the constraint residuals c_q c_v_ir c_h_ir c_v_la."""
    table, meta = tool.read()
    from sportfusion.core.schema import require_columns
    from sportfusion.skijump.hillfile import hill_from_meta
    from sportfusion.skijump.smoother import rts_smooth_table
    from sportfusion.skijump.smoother_inputs import IMU_COLUMNS, SmootherConfig, load_config

    require_columns(table, IMU_COLUMNS, "rts-smooth (gyroscope and accelerometer)")
    the_hill = load_hill_option(hill, hill_set) or hill_from_meta(meta)
    cfg = load_config(config, SmootherConfig())
    if no_hill_constraints:
        cfg.hill_constraints = False
    if no_zupt:
        cfg.zupt = False
    if lever_arm is not None:
        cfg.lever_arm = tuple(parse_floats(lever_arm, 3, "--lever-arm"))  # type: ignore[assignment]
    bar = None
    show = not tool.quiet and sys.stderr.isatty()  # no bar: no per-step callbacks either

    def on_start(total: int) -> None:
        nonlocal bar
        bar = click.progressbar(length=total, label="rts-smooth", file=sys.stderr)
        bar.__enter__()

    def progress(_k: int) -> None:
        if bar is not None:
            bar.update(1)

    try:
        out, meta, msg = rts_smooth_table(
            table,
            meta,
            the_hill,
            cfg,
            takeoff=_times(takeoff, "--takeoff"),
            touchdown=_times(touchdown, "--touchdown"),
            filtered=filtered,
            progress=progress if show else None,
            on_start=on_start if show else None,
        )
    finally:
        if bar is not None:
            bar.__exit__(None, None, None)
    for w in meta["rts"].get("warnings", []):
        tool.warn(w)
    tool.info(msg)
    tool.write(out, meta)
