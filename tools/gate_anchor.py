"""``gate-anchor``: sacrum trajectory from the IMU with the surveyed magnet gates as anchor points (gates paper)."""

from __future__ import annotations

import click

from sportfusion.core.venue import read_venue
from sportfusion.gates.eks import EKSParams
from sportfusion.gates.pipeline import GateAnchorParams, gate_anchor_table
from sportfusion.tools._cli import Tool, tool


@tool(
    "gate-anchor",
    cites=("gates",),
    example="""
  simulate gates --seed 1 --gates survey.parquet --truth truth.parquet \\
    | detect-events --kind gates | gate-anchor --gates survey.parquet > run.parquet
  evaluate --truth truth.parquet run.parquet > errors.parquet
  gate-anchor --gates survey.parquet --anchors-every 3 crossings.parquet -o downhill_like.parquet
  ingest imus/ | body-model --height 1.80 --mass 78 | detect-events --kind gates | gate-anchor --gates survey.parquet""",
)
@click.option(
    "--gates",
    "gates_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Survey of the gate magnets (kind gates: gate, x y z [m] in the session's frame or lat [deg] lon [deg] "
    "h [m], optional turn L/R; a sportfusion table, or a CSV / plain Parquet with those columns, "
    "docs/table-contract.md). Needed.",
)
@click.option(
    "--anchors-every",
    default=1,
    show_default=True,
    type=click.IntRange(1, 100),
    help="Use only every K-th gate as an anchor (the paper's simulated downhill: 3) [count].",
)
@click.option(
    "--rate",
    default=50.0,
    show_default=True,
    type=click.FloatRange(5, 1000),
    help="Rate of the smoother grid; the IMU acceleration is averaged down to it [Hz].",
)
@click.option(
    "--sigma-first",
    default=1.0,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="Anchor 1-sigma in the first EKS-2 iteration [m].",
)
@click.option(
    "--sigma-second",
    default=0.1,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="Anchor 1-sigma in the second EKS-2 iteration [m].",
)
@click.option(
    "--sacrum-height",
    default=0.95,
    show_default=True,
    type=click.FloatRange(0, 3),
    help="Sacrum height above the snow at zero lean; at a crossing h = H0 cos(roll) [m].",
)
@click.option(
    "--burial",
    default=0.05,
    show_default=True,
    type=click.FloatRange(0, 1),
    help="Peak model: depth of the magnets below the snow surface [m].",
)
@click.option(
    "--survey-depth",
    default=GateAnchorParams.survey_depth,
    show_default=True,
    type=click.FloatRange(0, 1),
    help="Depth of each magnet's centre below its surveyed point: 0 if the survey gives the magnets themselves, "
    "about 0.1 if it gives the snow above a buried 15 cm stick [m].",
)
@click.option(
    "--peak-model",
    is_flag=True,
    help="Place each anchor from the peak intensity and the body model alone (the paper's eqs 1-6) instead "
    "of a fit of the whole pass's field with a bar magnet [flag].",
)
@click.option(
    "--projection",
    type=click.Choice(["vertical", "normal"]),
    default="vertical",
    show_default=True,
    help="Sacrum -> magnet plane direction: vertical (the |B| peak of a vertical dipole is above the magnet) "
    "or normal (the paper's eq 6, along the snow-plane normal) [choice].",
)
@click.option(
    "--static-height",
    default=GateAnchorParams.static_height,
    show_default=True,
    type=click.FloatRange(0, 3),
    help="Sacrum height above the snow in the static upright posture, vertically above a surveyed start or "
    "finish spot (gates table rows with point = start / finish) [m].",
)
@click.option(
    "--sigma-spot",
    default=GateAnchorParams.sigma_spot,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="1-sigma of a surveyed static spot as an anchor of the standing sacrum [m].",
)
@click.option(
    "--q-jerk",
    default=EKSParams.q_jerk,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="PSD of the white jerk of the constant-acceleration model [(m/s^3)^2/Hz].",
)
@click.option(
    "--sigma-acc",
    default=EKSParams.sigma_acc,
    show_default=True,
    type=click.FloatRange(0, None, min_open=True),
    help="1-sigma of one averaged acceleration measurement [m/s^2].",
)
def main(
    tool: Tool,
    gates_path: str | None,
    anchors_every: int,
    rate: float,
    sigma_first: float,
    sigma_second: float,
    sacrum_height: float,
    burial: float,
    survey_depth: float,
    peak_model: bool,
    projection: str,
    static_height: float,
    sigma_spot: float,
    q_jerk: float,
    sigma_acc: float,
) -> None:
    """Refine the sacrum trajectory of an alpine run with magnet gates as anchor
    points (gates paper, Figure 2): gravity-removed acceleration in a global frame
    (strap-down with drift correction, or the session's q0..q3), a 15-state
    extended Kalman smoother (position, velocity, acceleration, position offset,
    residual orientation drift; sportfusion.estimators.kalman) with zero-velocity updates at
    the static start and finish; relative anchor points at the crossings found by
    detect-events --kind gates: the magnet's position relative to the sensor from a
    fit of the whole pass's field (the magnetometer rotated into the global frame,
    the background removed, a bar magnet of free moment fitted), or from the peak
    intensity and the body model (--peak-model, the paper's eqs 1-6); matching to
    the survey (PCA azimuth, then a sequence alignment of crossings and gates by
    their inertial displacements, robust to runs of missed gates and to a drifting
    speed); the smoother
    again with the anchors (1 m, then each pass fit's covariance, or 0.1 m with
    --peak-model). Writes x y z, vx vy vz and
    std_ columns on every row, and at each crossing the matched gate, whether it
    was an anchor and the turn's figures (speeds at the turn switches, distances
    to the gate, path length). Where the gates table also surveys the spots the
    athlete stands on for the static postures (rows with point = start / finish),
    each anchors the standing sacrum (--static-height above the mark): without
    them the track drifts where no gate anchors it, at the start and the finish.
    After body-model (several IMUs): the pelvis orientation of the body model, the
    relative anchors from the snow plane fitted to the ski contact points over
    +-0.4 s (eqs 2-6), turn switches where the ankles are equidistant from the
    CoM, and the paper's output: com_x com_y com_z, com_vx com_vy com_vz with
    std_ columns (the sensor's track + its lever arm to the lumbar joint centre
    (body-model's pelvis_lever_m) + the relative CoM, three-point speed,
    2nd-order Butterworth 5 Hz zero phase), the turn figures from the CoM.
    Crossings are taken at the field peak's time between samples
    (detect-events' gate_t_peak). Never silently wrong: when few of the detected
    crossings are matched, many lie off every gate on the anchored track, or the
    anchors contradict it, a warning names it and the std_ columns are widened to
    the difference between the anchored and the inertial track; fewer than half
    matched (or few matched and many off every gate) is refused (exit 1)."""
    table, meta = tool.read()
    survey, smeta = (None, None)
    if gates_path:
        survey, smeta = read_venue(gates_path, "gates", what=f"gate survey {gates_path}")
    params = GateAnchorParams(
        rate=rate,
        sigma_first=sigma_first,
        sigma_second=sigma_second,
        anchors_every=anchors_every,
        sacrum_height=sacrum_height,
        burial=burial,
        survey_depth=survey_depth,
        pass_fit=not peak_model,
        projection=projection,
        static_height=static_height,
        sigma_spot=sigma_spot,
        eks=EKSParams(q_jerk=q_jerk, sigma_acc=sigma_acc),
    )
    out, meta, msg = gate_anchor_table(table, meta, survey, smeta, params)
    for w in meta["gate_anchor"].get("warnings", []):
        tool.warn(w)
    tool.info(msg)
    tool.write(out, meta)
