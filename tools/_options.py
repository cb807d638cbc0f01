"""Option parsers shared by the tools."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

import click

if TYPE_CHECKING:
    from sportfusion.skijump.hillfile import Hill


def parse_pairs(values: Iterable[str], option: str) -> dict[str, str]:
    """``("a=1,b=2", "c=3")`` -> ``{"a": "1", "b": "2", "c": "3"}``; a usage error otherwise."""
    out: dict[str, str] = {}
    for value in values:
        for item in value.split(","):
            item = item.strip()
            if not item:
                continue
            key, sep, val = item.partition("=")
            if not sep or not key.strip() or not val.strip():
                raise click.BadParameter(f"{item!r} is not KEY=VALUE", param_hint=option)
            out[key.strip()] = val.strip()
    return out


def parse_floats(text: str, n: int, option: str) -> list[float]:
    """``"47.4,10.3,900"`` -> ``[47.4, 10.3, 900.0]`` with exactly ``n`` numbers."""
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError as exc:
        raise click.BadParameter(f"{text!r} must be {n} comma-separated numbers", param_hint=option) from exc
    if len(vals) != n:
        raise click.BadParameter(f"{text!r} must be {n} comma-separated numbers", param_hint=option)
    return vals


def hill_options(func: Callable[..., Any] | None = None, *, required: bool = False) -> Any:
    """Add ``--hill NAME|FILE.toml`` and repeatable ``--hill-set KEY=VALUE`` to a command.

    Use as ``@hill_options`` or ``@hill_options(required=True)``; the command
    receives ``hill`` (str or None) and ``hill_set`` (tuple of str) and turns
    them into a :class:`sportfusion.skijump.hillfile.Hill` with :func:`load_hill_option`.
    """

    def decorate(f: Callable[..., Any]) -> Callable[..., Any]:
        f = click.option(
            "--hill-set",
            "hill_set",
            multiple=True,
            metavar="KEY=VALUE",
            help="Override one hill value: a certificate parameter (lengths [m], angles [deg], e.g. e=95.5), "
            "a site value (lat/lon [deg], height [m], azimuth_deg [deg], g0 [m/s^2]) or name. Repeatable.",
        )(f)
        return click.option(
            "--hill",
            "hill",
            metavar="NAME|FILE.toml",
            required=required,
            help="Hill: a shipped name (e.g. oberstdorf_hs106) or a TOML hill file (certificate [m, deg], "
            "take-off edge lat/lon [deg] and ellipsoidal height [m], azimuth [deg]).",
        )(f)

    return decorate if func is None else decorate(func)


def load_hill_option(hill: str | None, hill_set: Iterable[str]) -> Hill | None:
    """The :class:`sportfusion.skijump.hillfile.Hill` named by ``--hill`` with ``--hill-set`` applied, or None.

    ``--hill-set`` without ``--hill`` is a usage error; a bad hill raises
    :class:`sportfusion.core.errors.InputError` (exit 1).
    """
    overrides = parse_pairs(hill_set, "--hill-set")
    if hill is None:
        if overrides:
            raise click.UsageError("--hill-set needs --hill NAME|FILE.toml")
        return None
    from sportfusion.skijump.hillfile import load_hill

    return load_hill(hill, overrides)


def seed_truth_options(truth_help: str = "Write the truth table (kind truth, Parquet) to this file.") -> Any:
    """Add ``--seed N`` and ``--truth FILE`` (the command receives ``seed`` and ``truth_path``) to a simulator."""

    def decorate(f: Callable[..., Any]) -> Callable[..., Any]:
        f = click.option(
            "--truth", "truth_path", type=click.Path(dir_okay=False, writable=True), default=None, help=truth_help
        )(f)
        return click.option("--seed", default=0, show_default=True, type=int, help="Random seed [integer].")(f)

    return decorate


def course_site_options(site: str, azimuth: float, date: str) -> Any:
    """Add ``--site LAT,LON,H``, ``--azimuth DEG`` and ``--date ISO`` (a course's start, fall line and time)
    with the given defaults; the command receives ``site``, ``azimuth`` and ``date``."""

    def decorate(f: Callable[..., Any]) -> Callable[..., Any]:
        f = click.option("--date", default=date, show_default=True, help="Start time of the session [UTC ISO-8601].")(f)
        f = click.option(
            "--azimuth",
            default=azimuth,
            show_default=True,
            type=float,
            help="Fall-line azimuth = course-frame x axis, clockwise from north [deg].",
        )(f)
        return click.option(
            "--site",
            default=site,
            show_default=True,
            metavar="LAT,LON,H",
            help="Start of the course [deg, deg, m ellipsoidal].",
        )(f)

    return decorate


def _image_path(ctx: click.Context, param: click.Parameter, value: str) -> str:
    from sportfusion.core.errors import InputError
    from sportfusion.core.plots import figure_format

    try:
        figure_format(value)
    except InputError as exc:
        raise click.BadParameter(str(exc)) from exc
    return value


def image_options(f: Any) -> Any:
    """``-o FILE.png|svg|pdf``, ``--dpi`` and ``--title`` for a ``plot`` subcommand."""
    f = click.option(
        "--dpi",
        type=click.FloatRange(10, 1200),
        default=150,
        show_default=True,
        help="PNG resolution [dots per inch] (SVG and PDF are vector).",
    )(f)
    f = click.option(
        "--title", default=None, help="Figure title (default: what the figure shows, or the hill's name)."
    )(f)
    return click.option(
        "-o",
        "--output",
        required=True,
        type=click.Path(dir_okay=False, writable=True),
        callback=_image_path,
        help="Image file to write; the suffix picks the format: .png, .svg or .pdf.",
    )(f)
