"""``simulate skijump``: a ski jump with known truth and the paper's sensor error models."""

from __future__ import annotations

import click

from sportfusion.core import meta as sfmeta
from sportfusion.core.describe import ms_to_kmh
from sportfusion.skijump.sim import DEFAULT_START, VARIANT_NAMES
from sportfusion.tools._cli import Tool, tool
from sportfusion.tools._options import SEED, hill_options, load_hill_option, parse_floats

DEFAULT_HILL = "oberstdorf_hs106"


@tool(
    "simulate skijump",
    cites=("skijump",),
    reads_table=False,
    example="""
  simulate skijump --seed 1 --truth truth.parquet > session.parquet
  simulate skijump --hill oberstdorf_hs106 --distance 92 --seed 4 --raw raw/ -o session.parquet
  simulate skijump --hill willingen_hs145 --origin 51.2905,8.6048,640 --azimuth 200 --seed 2 > s.parquet
  simulate skijump --seed 3 --height-error 4,30 --outage 14,16 --truth t.parquet | detect-events --kind jump > e.parquet
  simulate skijump --seed 5 --variant multipath --variant lever --truth t.parquet > s.parquet
  simulate skijump --physics paper --seed 1 > paper.parquet""",
)
@hill_options
@click.option(
    "--origin",
    default=None,
    metavar="LAT,LON,H",
    help="Take-off edge (frame origin): latitude [deg], longitude [deg], ellipsoidal height [m]; "
    "needed for hills without a site.",
)
@click.option("--azimuth", type=float, default=None, help="Hill azimuth psi_N, north -> hill x axis, clockwise [deg].")
@click.option("--seed", default=0, show_default=True, type=SEED, help="Random seed [integer >= 0].")
@click.option(
    "--distance",
    type=click.FloatRange(min=1.0),
    default=None,
    help="Jump length along the landing profile from F [m]; default: drawn around the K point.",
)
@click.option(
    "--gate",
    type=click.IntRange(min=1),
    default=None,
    help="Start gate [number, 1 = lowest]; default: the gate that suits the distance.",
)
@click.option(
    "--truth",
    "truth_path",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="Write the truth table (kind truth, Parquet: true_ columns, events, jump_length) to this file.",
)
@click.option(
    "--raw",
    "raw_dir",
    type=click.Path(file_okay=False, writable=True),
    default=None,
    help="Also write the raw files a user would ingest into this folder: phyphox.zip and gnss.nmea.",
)
@click.option(
    "--start",
    default=DEFAULT_START,
    show_default=True,
    help="UTC time of t = 0 [ISO-8601]; sets the World Magnetic Model date.",
)
@click.option(
    "--height-error",
    default=None,
    metavar="SIGMA,TAU",
    help="Slowly varying GNSS height error: Gauss-Markov 1-sigma [m] and correlation time [s].",
)
@click.option(
    "--outage",
    "outages",
    multiple=True,
    metavar="START,END",
    help="GNSS outage from START to END [s since t = 0]. Repeatable.",
)
@click.option(
    "--lever-arm",
    default="0,0,0",
    show_default=True,
    metavar="X,Y,Z",
    help="GNSS antenna position relative to the IMU in the sensor (body) frame [m].",
)
@click.option(
    "--gnss-latency",
    default=0.0,
    show_default=True,
    type=click.FloatRange(0, 1),
    help="GNSS time stamps late by this much: the fix stamped t describes t - latency [s].",
)
@click.option(
    "--wind",
    metavar="HEAD,GUST",
    default=None,
    help="Wind in flight: headwind along the hill axis (negative: tailwind) and the amplitude of its "
    "sinusoidal gusts [m/s, m/s]; the lift is planned with it, so the jump keeps its length.",
)
@click.option(
    "--physics",
    type=click.Choice(["full", "paper"]),
    default="full",
    show_default=True,
    help="full: the hardware as it is (1 kHz truth sensed through scale errors, misalignment, temperature drift, "
    "a 41 Hz anti-aliasing filter, quantisation, chatter; helmet antenna, multipath, wild fixes; steel in the "
    "take-off table), none of it in the smoother's model; paper: eqs 35-39 with the Table 3-5 noise.",
)
@click.option(
    "--variant",
    "variants",
    multiple=True,
    type=click.Choice(sorted(VARIANT_NAMES)),
    help="With --physics full: one effect made strong (model-mismatch benchmark variants). Repeatable.",
)
@click.option("--no-noise", is_flag=True, help="Sensors without biases or noise (the truth values), for tests.")
@click.option(
    "--video",
    "video_path",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="Also film the landing with a fixed camera beside the landing slope into this .mp4 (mp4v); the marker "
    "calibration goes beside it (landing.mp4 -> landing.markers.csv), the true touch-down frame into --truth.",
)
@click.option("--video-fps", type=click.FloatRange(25, 60), default=50.0, show_default=True, help="Frame rate [1/s].")
@click.option("--video-size", default="1280x720", show_default=True, metavar="WxH", help="Video size [px].")
@click.option(
    "--video-focal",
    type=float,
    default=None,
    help="35-mm equivalent focal length [mm]; default: a 26 m wide view at the touch-down point.",
)
@click.option(
    "--video-camera",
    default="nan,-38,8",
    show_default=True,
    metavar="S,Y,H",
    help="Camera station along the landing profile [m from F; nan: beside the touch-down], lateral position "
    "[m, negative: left looking downhill], lens height above the snow [m]; it aims at the touch-down point.",
)
@click.option("--video-noise", type=float, default=2.0, show_default=True, help="Sensor noise [grey levels, 1-sigma].")
@click.option("--video-extras", is_flag=True, help="A person walking and flags waving behind the far side.")
def main(
    tool: Tool,
    hill: str | None,
    hill_set: tuple[str, ...],
    origin: str | None,
    azimuth: float | None,
    seed: int,
    distance: float | None,
    gate: int | None,
    truth_path: str | None,
    raw_dir: str | None,
    start: str,
    height_error: str | None,
    outages: tuple[str, ...],
    lever_arm: str,
    gnss_latency: float,
    wind: str | None,
    physics: str,
    variants: tuple[str, ...],
    no_noise: bool,
    video_path: str | None,
    video_fps: float,
    video_size: str,
    video_focal: float | None,
    video_camera: str,
    video_noise: float,
    video_extras: bool,
) -> None:
    """Simulate one ski jump on a hill (default: the paper's Oberstdorf HS106):
    rest at a start gate, in-run along the profile with friction and air drag,
    take-off impulse at the edge, flight with lift and drag, touch-down with the
    landing impact, out-run, braking to a stop. Default (--physics full): the
    motion on a 1 kHz grid with ski chatter and the body's ringing at the
    landing, sensed by an arm-mounted phone as hardware does (scale errors,
    misalignment, temperature-driven biases, a 41 Hz anti-aliasing filter,
    16-bit quantisation; a magnetometer with soft iron and the take-off table's
    steel; IMU at 100 Hz on its own clock) and a helmet GNSS antenna fixed at
    10 Hz, 0.08 s late, with slow drift, multipath and wild fixes. --physics
    paper: the paper's error models (eqs 35-39, Tables 3-5) on a truth that
    obeys its INS kinematics (eqs 44-46). The session goes to stdout; --truth gets
    the true_ columns, the take-off/touch-down events and the jump length
    (curve length of the landing profile from F to the skis' touch-down point)."""
    from sportfusion.skijump.sim.simulate import SkiJumpConfig, simulate_skijump, write_raw

    extra = list(hill_set)
    if origin is not None:
        lat, lon, h = parse_floats(origin, 3, "--origin")
        extra += [f"lat={lat!r}", f"lon={lon!r}", f"height={h!r}"]
    if azimuth is not None:
        extra.append(f"azimuth_deg={azimuth!r}")
    the_hill = load_hill_option(DEFAULT_HILL if hill is None else hill, extra)
    cfg = SkiJumpConfig(
        seed=seed,
        distance=distance,
        gate=gate,
        start=sfmeta.format_epoch(start) or start,
        height_error=tuple(parse_floats(height_error, 2, "--height-error")) if height_error else None,  # type: ignore[arg-type]
        outages=[tuple(parse_floats(o, 2, "--outage")) for o in outages],  # type: ignore[misc]
        lever_arm=tuple(parse_floats(lever_arm, 3, "--lever-arm")),  # type: ignore[arg-type]
        gnss_latency=gnss_latency,
        wind=tuple(parse_floats(wind, 2, "--wind")) if wind else None,  # type: ignore[arg-type]
        noise=not no_noise,
        physics=physics,
        variants=tuple(variants),
    )
    if variants and physics != "full":
        raise click.BadParameter("variants modify the full physics; drop --physics paper", param_hint="--variant")
    sim = simulate_skijump(the_hill, cfg)
    sj = sim.truth_meta["skijump"]
    tool.info(
        f"{the_hill.name}: gate {sj['gate']:g}, take-off {sj['times']['takeoff']:.2f} s at "
        f"{sj['figures']['takeoff_speed']:.1f} m/s ({ms_to_kmh(sj['figures']['takeoff_speed']):.1f} km/h), touch-down {sj['times']['touchdown']:.2f} s, "
        f"jump length {sim.truth_meta['jump_length']:.2f} m; {sim.session.num_rows} rows"
    )
    if video_path:
        from sportfusion.skijump.video.markers import markers_path_for, write_markers
        from sportfusion.skijump.video.render import RenderOptions, render_landing, trajectory_from_truth

        size = video_size.lower().split("x")
        if len(size) != 2 or not all(v.strip().isdigit() for v in size):
            raise click.BadParameter(f"{video_size!r} is not WIDTHxHEIGHT in pixels", param_hint="--video-size")
        if not all(16 <= int(v) <= 7680 for v in size):
            raise click.BadParameter(f"{video_size!r}: each side must be 16 .. 7680 px", param_hint="--video-size")
        cam = parse_floats(video_camera, 3, "--video-camera")
        vopts = RenderOptions(
            width=int(size[0]),
            height=int(size[1]),
            fps=video_fps,
            focal_35mm=video_focal,
            camera=(cam[0], cam[1], cam[2]),
            noise=video_noise,
            person=video_extras,
            flags=video_extras,
            seed=seed,
        )
        trajectory = trajectory_from_truth(sim.truth, sim.truth_meta)
        res = tool.write_file(
            video_path, lambda tmp: render_landing(tmp, trajectory, the_hill.profile, vopts, tool.progress)
        )
        markers = markers_path_for(video_path)
        tool.write_file(markers, lambda tmp: write_markers(tmp, res.markers))
        video = {"file": str(video_path), "markers": str(markers), **res.summary()}
        sim.truth_meta["video"] = video
        sim.truth_meta["touchdown_frame"] = video["touchdown_frame"]
        tool.info(f"{video_path} and {markers}: touch-down in frame {video['touchdown_frame']}")
    if truth_path:
        tool.write_side(truth_path, sim.truth, sim.truth_meta)
    if raw_dir:
        written = tool.write_folder(raw_dir, lambda folder: write_raw(sim, folder))
        tool.info(f"{raw_dir}: {', '.join(p.name for p in written)}")
    tool.write(sim.session, sim.session_meta)
