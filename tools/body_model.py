"""``body-model``: several IMUs on one athlete -> segment orientations, joint centres and the centre of mass."""

from __future__ import annotations

import io

import click

from sportfusion.body.anthropometry import CONTACT_M, EQUIPMENT_KG
from sportfusion.body.pipeline import BodyModelParams, body_model_table
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import parse_floats, parse_pairs


@tool(
    "body-model",
    cites=("gates",),
    example="""
  ingest imus/ | body-model --height 1.82 --mass 80 > body.parquet
  ingest imus/ | body-model --height 1.82 --mass 80 | detect-events --kind gates \\
    | gate-anchor --gates survey.parquet > run.parquet
  body-model session.parquet --height 1.70 --mass 62 --sex female --calibration 2.0,14.5 \\
    --opensense orientations.sto -o body.parquet""",
)
@click.option("--height", type=click.FloatRange(0, 5, min_open=True), required=True, help="Athlete's height [m].")
@click.option(
    "--mass", type=click.FloatRange(0, 500, min_open=True), required=True, help="Athlete's mass without equipment [kg]."
)
@click.option(
    "--sex",
    type=click.Choice(["male", "female"]),
    default="male",
    show_default=True,
    help="Which of de Leva's (1996) tables of segment parameters [choice].",
)
@click.option(
    "--equipment-mass",
    default=EQUIPMENT_KG,
    show_default=True,
    type=click.FloatRange(0, 60),
    help="Boots and skis with bindings, both legs together, half at each ankle [kg]; part of the CoM (default: "
    "2 x 2 kg boots + 2 x 4 kg skis; for a 1.80 m, 78 kg athlete standing upright it puts the CoM 0.13 m lower than "
    "the body's alone; 0: the body alone).",
)
@click.option(
    "--contact",
    default=CONTACT_M,
    show_default=True,
    type=click.FloatRange(0, 0.5),
    help="Ski-snow contact point below each ankle along the shank (gates paper) [m].",
)
@click.option(
    "--calibration",
    default=None,
    metavar="T0,T1",
    help="Time window [s] holding the static upright posture followed by the squats (default: found: the first "
    "still period of at least 1 s within 60 s of the start, then the movement until the next still period).",
)
@click.option(
    "--length",
    "lengths",
    multiple=True,
    metavar="NAME=M",
    help="Measured length replacing the scaled one: thigh (hip to knee joint centre), shank (knee to ankle), "
    "trunk (lumbar joint centre to suprasternale), head (suprasternale to vertex) [m]. Repeatable.",
)
@click.option(
    "--knee-window",
    default=4.0,
    show_default=True,
    type=click.FloatRange(0, 60),
    help="Window of the knee hinge drift correction (0: off) [s].",
)
@click.option(
    "--pelvis-lever",
    default="auto",
    show_default=True,
    metavar="auto|X,Y,Z",
    help="The lumbar joint centre relative to the pelvis (sacrum) sensor in the pelvis frame (x forward, y right, "
    "z down) [m]: auto estimates it from the hip joint centres (Seel et al. 2012: the hips move with the pelvis and "
    "the thighs); 0,0,0 takes the sensor at the LJC as the gates paper does; gate-anchor adds it to the sensor's "
    "track.",
)
@click.option(
    "--opensense",
    "opensense_path",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="Also write the segment orientations as an OpenSim OpenSense orientations file (.sto, quaternions).",
)
def main(
    tool: Tool,
    height: float,
    mass: float,
    sex: str,
    equipment_mass: float,
    contact: float,
    calibration: str | None,
    lengths: tuple[str, ...],
    knee_window: float,
    pelvis_lever: str,
    opensense_path: str | None,
) -> None:
    """Body model from several IMUs on one athlete (gates paper "Body model"; Fasel
    et al. 2017, Front. Physiol. 8:850): the sensors of the pelvis (plain acc_*,
    gyr_*), torso, head, femur_r, femur_l, tibia_r and tibia_l (<segment>__acc_*,
    <segment>__gyr_*, as ingest names a folder of exports with its mapping file).

    Protocol expected at the start: the athlete stands upright and still for at
    least 1 s (segments vertical, facing forward), then does a few squats (knees
    and hips flex, the trunk leans forward). The still posture gives each
    sensor's vertical axis, the squats the medio-lateral axis (functional
    calibration, Fasel et al. 2017d); the window is found, or given with
    --calibration T0,T1. Knees flexed in the still posture stay in the
    segments' orientations as a constant offset (11 deg there, on the
    simulator: thigh 3 deg, shank 8 deg, the ankles ~3 cm forward throughout);
    stand with straight knees. Orientations: strap-down integration with the gyro
    bias of every still period (start, finish, stops), the tilt reset in each
    still period, and the knee hinge drift correction (the knees' slow
    ab/adduction and axial rotation removed). Body: de Leva's (1996) segments
    scaled by --height and --mass (--length for measured ones), arms carried by
    the torso, boots and skis (--equipment-mass) at the ankles. The CoM is that
    of the athlete with the equipment (default 12 kg; --equipment-mass 0 for the
    body alone).

    The pelvis sensor's lever arm to the lumbar joint centre (LJC) is estimated
    from the hip joint centres (--pelvis-lever) and goes to the metadata.

    Writes, in the frame J (x forward, y right of the athlete in the calibration
    posture, z down) relative to the lumbar joint centre: <segment>__q0..q3,
    hip/knee/ankle_r/l, sternum, head and ski_r/l (contact points) as
    <point>_rel_x/y/z [m], com_rel_x/y/z [m] and hip/knee flexion [rad]."""
    table, meta = tool.read()
    window = None
    if calibration:
        t0, t1 = parse_floats(calibration, 2, "--calibration")
        if not t1 > t0:
            raise click.BadParameter(f"{calibration!r}: T1 must be after T0", param_hint="--calibration")
        window = (t0, t1)
    measured = {}
    for k, v in parse_pairs(lengths, "--length").items():
        try:
            measured[k] = float(v)
        except ValueError as exc:
            raise click.BadParameter(f"{k}={v}: not a length in metres", param_hint="--length") from exc
    lever = None
    if pelvis_lever.strip().lower() != "auto":
        lever = tuple(parse_floats(pelvis_lever, 3, "--pelvis-lever"))
        if max(abs(v) for v in lever) > 0.5:
            raise click.BadParameter(f"{pelvis_lever!r}: more than 0.5 m from the sensor", param_hint="--pelvis-lever")
    params = BodyModelParams(
        height=height,
        mass=mass,
        sex=sex,
        equipment=equipment_mass,
        contact=contact,
        calibration=window,
        lengths=measured,
        hinge_window=knee_window or None,
        pelvis_lever=lever,  # type: ignore[arg-type]
    )
    out, meta, msg, res, rows = body_model_table(table, meta, params)
    sto = None
    if opensense_path:
        from sportfusion.body.opensense import write_opensense
        from sportfusion.core import schema

        buf = io.BytesIO()
        write_opensense(buf, schema.floats(table, "t")[rows], res.rot)
        sto = buf.getvalue()
    if sto is not None:  # a side output, committed with the table: a failed run leaves neither
        tool.write_bytes(sto, opensense_path)
    tool.info(msg)
    tool.write(out, meta)
