"""``video-jumplength``: the video reference for the jump length (skijump paper, Appendix B).

``video-jumplength VIDEO... --markers FILE`` reads each landing video and
writes one ``jumps`` row per video; ``video-jumplength calibrate VIDEO``
writes a frame with a pixel grid for measuring the markers.  A first argument
that is not a subcommand means ``measure``.
"""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np
import pyarrow as pa

from sportfusion import __version__
from sportfusion.core import meta as sfmeta
from sportfusion.core import schema
from sportfusion.core.errors import InputError
from sportfusion.core.outputs import note_read, printable
from sportfusion.skijump.video.markers import markers_path_for, read_markers
from sportfusion.tools._cli import Group, Tool, papers_epilog, tool

COLUMNS = (
    "video",
    "touchdown_frame",
    "touchdown_time",
    "jump_length",
    "std_jump_length",
    "confidence",
    "touchdown_speed",
    "video_fps",
)


class _DefaultMeasure(Group):
    """A group whose first argument, when not a subcommand or option of the group, starts ``measure``."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] not in self.commands and args[0] not in ("--help", "-h", "--version"):
            args = ["measure", *args]
        return super().parse_args(ctx, args)


@click.group(
    name="video-jumplength",
    cls=_DefaultMeasure,
    epilog=papers_epilog(("skijump",))
    + "\b\nExample:\n  video-jumplength landing.mp4 --markers landing.markers.csv > jumps.parquet\n"
    "  video-jumplength calibrate landing.mp4 -o grid.png",
)
@click.version_option(
    __version__, "--version", prog_name="video-jumplength", message="%(prog)s (sportfusion) %(version)s"
)
def main() -> None:
    """Jump length from a video of the landing (skijump paper, Appendix B):
    the touch-down frame (both skis on the snow) and the distance of the skis'
    middle then, read against the distance markers. `video-jumplength VIDEO...`
    is `video-jumplength measure VIDEO...`."""


@tool(
    "video-jumplength",
    cites=("skijump",),
    reads_table=False,
    example="""
  video-jumplength landing.mp4 > jumps.parquet            (markers from landing.markers.csv)
  video-jumplength jump1.mp4 jump2.mp4 --markers cam1.markers.csv -o jumps.parquet
  video-jumplength landing.mp4 --debug check/ | inspect""",
)
@click.argument("videos", nargs=-1, required=True, metavar="VIDEO...", type=click.Path(dir_okay=False))
@click.option(
    "--markers",
    "markers_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Marker calibration CSV: distance [m], y [m], col [px], row [px] of each marker's foot "
    "(see `video-jumplength calibrate`); default: VIDEO's name with .markers.csv.",
)
@click.option(
    "--debug",
    "debug_dir",
    type=click.Path(file_okay=False, writable=True),
    default=None,
    help="Write annotated PNG frames around the touch-down and a plot of the skis' height per frame [px, m] here.",
)
def measure(tool: Tool, videos: tuple[str, ...], markers_path: str | None, debug_dir: str | None) -> None:
    """Read the touch-down frame and the jump length from landing videos
    filmed by a fixed camera beside the landing slope, one `jumps` row per
    video. Calibration: distance markers on both sides of the slope (at least
    two lines across it) give a homography of the slope plane with its
    curvature. The jumper is found by background subtraction; the touch-down is
    the first frame in which the skis' lowest points reach the snow and stay
    there (sub-frame from a hinge fit); the jump length is the distance along
    the landing profile from the knoll base F of the skis' middle at that
    instant. Columns: video, touchdown_frame (0-based), touchdown_time [s after
    the first frame], jump_length [m], std_jump_length [m], confidence (the
    probability of being within the paper's 0.5 m), touchdown_speed [m/s],
    video_fps [1/s]."""
    from sportfusion.skijump.video.annotate import write_debug
    from sportfusion.skijump.video.measure import measure_video

    rows: dict[str, list[object]] = {c: [] for c in COLUMNS}
    for video in videos:
        if not Path(video).is_file():
            raise InputError(f"video {video} does not exist; expected a video file (e.g. .mp4)")
        mpath = Path(markers_path) if markers_path else markers_path_for(video)
        if not mpath.exists():
            raise InputError(f"no marker file {mpath} for {video}; expected --markers FILE (a CSV distance,y,col,row)")
        note_read(mpath)  # the default marker file beside the video is an input too
        markers = read_markers(mpath)
        reading = measure_video(video, markers, progress=tool.progress)
        tool.info(
            f"{Path(video).name}: touch-down at frame {reading.touchdown_frame} ({reading.touchdown_time:.3f} s), "
            f"jump length {reading.jump_length:.2f} m +- {reading.std_jump_length:.2f} m"
        )
        if debug_dir:
            written = tool.write_folder(debug_dir, lambda folder: write_debug(video, reading, markers, folder))  # noqa: B023
            tool.info(f"{debug_dir}: {', '.join(p.name for p in written)}")
        values = (
            str(video),
            reading.touchdown_frame,
            reading.touchdown_time,
            reading.jump_length,
            reading.std_jump_length,
            reading.confidence,
            reading.speed,
            reading.fps,
        )
        for c, v in zip(COLUMNS, values, strict=True):
            rows[c].append(v)
    table = pa.table({c: schema.to_arrow(c, np.asarray(v) if c != "video" else pa.array(v)) for c, v in rows.items()})
    meta = sfmeta.new_meta("jumps")
    meta["reference"] = "video"
    tool.write(table, meta, {**tool.params, "videos": list(videos)})


@tool(
    "video-jumplength calibrate",
    cites=("skijump",),
    reads_table=False,
    writes_table=False,
    example="""
  video-jumplength calibrate landing.mp4                  (writes landing.grid.png)
  video-jumplength calibrate landing.mp4 --step 20 -o grid.png""",
)
@click.argument("video", type=click.Path(dir_okay=False))
@click.option(
    "-o",
    "--output",
    "output",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="PNG to write; default: VIDEO's name with .grid.png.",
)
@click.option("--step", type=click.IntRange(min=5), default=50, show_default=True, help="Grid spacing [px].")
def calibrate(tool: Tool, video: str, output: str | None, step: int) -> None:
    """Write a frame of VIDEO without the jumper (the median of frames) with a
    labelled pixel grid, to read the pixel (column, row) of each distance
    marker's foot on the snow for the marker CSV: distance [m] along the
    landing profile from F, y [m] the marker line's lateral position, col and
    row [px]. Measure markers on both sides of the landing slope."""
    import cv2

    from sportfusion.skijump.video.annotate import grid_image

    out = Path(output) if output else Path(video).with_name(Path(video).stem + ".grid.png")
    img = grid_image(video, step)

    def encode(path: str) -> None:
        try:
            ok = cv2.imwrite(path, img)
        except cv2.error:
            ok = False
        if not ok:
            raise InputError(f"cannot write {printable(str(out))}; expected a writable .png path")

    tool.write_file(out, encode)
    tool.info(f"wrote {out} ({img.shape[1]}x{img.shape[0]} px, grid every {step} px)")


main.add_command(measure, "measure")
main.add_command(calibrate, "calibrate")
