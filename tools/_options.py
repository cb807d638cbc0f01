"""Option parsers shared by the tools."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

import click

if TYPE_CHECKING:
    from sportfusion.skijump.hillfile import Hill


class Finite(click.FloatRange):
    """A float option that is finite and inside a physically sensible range (a usage error otherwise).

    ``allow_inf`` lets ``inf`` through where the option documents it as "off"; ``zero_ok`` lets
    exactly 0 through below ``min`` where 0 means "none" (e.g. no low-pass).
    """

    name = "float"

    def __init__(
        self,
        min: float | None = None,
        max: float | None = None,
        unit: str = "",
        *,
        min_open: bool = False,
        max_open: bool = False,
        allow_inf: bool = False,
        zero_ok: bool = False,
    ) -> None:
        super().__init__(min, max, min_open=min_open, max_open=max_open)
        self.unit = unit
        self.allow_inf = allow_inf
        self.zero_ok = zero_ok

    def range_text(self) -> str:
        """The accepted range in words, e.g. ``a number in (0, 100] m/s``."""
        lo = "-inf" if self.min is None else f"{self.min:g}"
        hi = "inf" if self.max is None else f"{self.max:g}"
        text = f"a finite number in {'(' if self.min_open or self.min is None else '['}{lo}, {hi}"
        text += ")" if self.max_open or self.max is None else "]"
        text += f" {self.unit}" if self.unit else ""
        if self.zero_ok:
            text += " or 0"
        if self.allow_inf:
            text += " or inf (off)"
        return text

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        try:
            x = float(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a number; expected {self.range_text()}", param, ctx)
        if math.isinf(x) and x > 0 and self.allow_inf:
            return x
        if (x == 0 and self.zero_ok) or (math.isfinite(x) and _inside(x, self)):
            return x
        self.fail(f"{value!r} is out of range; expected {self.range_text()}", param, ctx)

    def __repr__(self) -> str:
        return f"Finite({self.range_text()})"


def _inside(x: float, r: click.FloatRange) -> bool:
    if r.min is not None and (x < r.min or (r.min_open and x == r.min)):
        return False
    return not (r.max is not None and (x > r.max or (r.max_open and x == r.max)))


#: Physically sensible ranges of the float options of every command, by parameter name:
#: (min, max, unit, extras).  A command's own FloatRange narrows these further; an option not
#: listed must be finite with magnitude at most 1e9.  Extras: "inf" (inf means off), "zero" (0: none).
LIMITS: dict[str, tuple[float | None, float | None, str, str]] = {
    "threshold": (0, 100, "rad/s", ""),
    "mean_threshold": (0, 100, "rad/s", "inf"),
    "acc_threshold": (0, 2000, "m/s^2", "inf"),
    "acc_limit": (1, 10000, "m/s^2", ""),
    "gyr_limit": (1, 100000, "deg/s", ""),
    "min_speed": (0, 100, "m/s", ""),
    "min_separation": (0, 60, "s", ""),
    "touchdown_offset": (-5, 5, "s", ""),
    "max_separation": (0, 60, "s", ""),
    "min_peak": (0, 2000, "m/s^2", ""),
    "max_flight_acc": (0, 2000, "m/s^2", "inf"),
    "max_gnss_gap": (0, 3600, "s", ""),
    "gate_threshold": (1e-4, 100, "1", ""),
    "gate_separation": (0, 60, "s", ""),
    "gate_background": (0.05, 60, "s", ""),
    "turn_window": (0, 10, "s", ""),
    "g0": (9.7, 9.9, "m/s^2", ""),
    "acc_weight": (1e-6, 1e6, "1", ""),
    "mag_weight": (1e-6, 1e6, "1", ""),
    "lowpass_hz": (0.01, 1000, "Hz", "zero"),
    "free_fall": (0, 20, "m/s^2", ""),
    "rate": (0.01, 100000, "Hz", ""),
    "sigma_first": (1e-4, 1000, "m", ""),
    "sigma_second": (1e-4, 1000, "m", ""),
    "q_jerk": (1e-6, 1e8, "(m/s^3)^2/Hz", ""),
    "sigma_acc": (1e-6, 1000, "m/s^2", ""),
    "geoid_offset": (-150, 150, "m", ""),
    "descent_after": (-1e6, 1e7, "s", ""),
    "yaw_psd": (1e-9, 100, "rad^2/s", ""),
    "hold_radius": (0, 10, "m", ""),
    "hold_sigma": (1e-4, 10, "m", ""),
    "elsewhere": (0, 100, "sigmas", ""),
    "reading_accuracy": (0, 100, "m", ""),
    "max_event_dt": (0, 3600, "s", ""),
    "max_gate_distance": (0.1, 1000, "m", ""),
    "profile_step": (0.01, 1000, "m", ""),
    "max_gap": (0, 3600, "s", ""),
    "edge_factor": (1, 100, "1", ""),
    "azimuth": (-360, 360, "deg", ""),
    "distance": (1, 300, "m", ""),
    "video_focal": (1, 5000, "mm", ""),
    "video_noise": (0, 255, "grey levels", ""),
}


def finite_type(name: str, current: click.ParamType) -> Finite:
    """The :class:`Finite` type of a float option ``name``: :data:`LIMITS` intersected with ``current``."""
    lo, hi, unit, extras = LIMITS.get(name, (-1e9, 1e9, "", ""))
    lo_open = hi_open = False
    if isinstance(current, click.FloatRange):
        if current.min is not None and (lo is None or current.min >= lo):
            lo, lo_open = current.min, bool(current.min_open)
        if current.max is not None and (hi is None or current.max <= hi):
            hi, hi_open = current.max, bool(current.max_open)
    zero = "zero" in extras and not (lo_open and lo == 0)
    return Finite(lo, hi, unit, min_open=lo_open, max_open=hi_open, allow_inf="inf" in extras, zero_ok=zero)


def check_float_options(cmd: click.Command) -> click.Command:
    """Give every float option of ``cmd`` a :class:`Finite` type (NaN, inf and absurd values: exit 2)."""
    for p in cmd.params:
        if isinstance(p.type, click.types.FloatParamType) and not isinstance(p.type, Finite) and p.name:
            p.type = finite_type(p.name, p.type)
    return cmd


#: Ranges of the numbers in comma-separated options (parse_floats), by option: one entry per number.
FLOAT_LISTS: dict[str, list[tuple[float, float, str]]] = {
    "--origin": [(-90, 90, "deg"), (-180, 360, "deg"), (-1000, 10000, "m")],
    "--site": [(-90, 90, "deg"), (-180, 360, "deg"), (-1000, 10000, "m")],
    "--mag-ref": [(-200, 200, "uT")] * 3,
    "--lever-arm": [(-10, 10, "m")] * 3,
    "--height-error": [(0, 100, "m"), (0, 1e5, "s")],
    "--wind": [(-10, 10, "m/s"), (0, 10, "m/s")],
    "--outage": [(-1e6, 1e7, "s")] * 2,
    "--video-camera": [(-100, 500, "m"), (-500, 500, "m"), (0, 200, "m")],
}
#: (option, index) of list numbers where ``nan`` is a documented value ("default").
NAN_OK = {("--video-camera", 0)}


def check_number(x: float, lo: float, hi: float, unit: str, option: str, text: str) -> float:
    """``x`` if finite and in [lo, hi], else a usage error naming the range."""
    if not (math.isfinite(x) and lo <= x <= hi):
        raise click.BadParameter(
            f"{text!r}: {x:g} is not a finite number in [{lo:g}, {hi:g}]{' ' + unit if unit else ''}", param_hint=option
        )
    return x


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
    ranges = FLOAT_LISTS.get(option, [(-1e9, 1e9, "")] * n)
    for i, (x, (lo, hi, unit)) in enumerate(zip(vals, ranges, strict=False)):
        if not (math.isnan(x) and (option, i) in NAN_OK):
            check_number(x, lo, hi, unit, option, text)
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

    check_hill_set(overrides)
    return load_hill(hill, overrides)


def check_hill_set(overrides: dict[str, str]) -> None:
    """Usage error for a ``--hill-set`` number that is not finite or not physically sensible."""
    from sportfusion.skijump.hill import PARAMETERS

    site = {"lat": (-90, 90), "lon": (-180, 360), "height": (-1000, 10000), "azimuth_deg": (-360, 360)}
    site |= {"g0": (9.7, 9.9), "mag_n": (-200, 200), "mag_e": (-200, 200), "mag_d": (-200, 200)}
    for raw_key, raw_val in overrides.items():
        key = raw_key.rpartition(".")[2]
        try:
            x = float(raw_val)
        except ValueError:
            continue  # a name or a hill type; the hill loader says what it expected
        if key in site:
            check_number(x, *site[key], "", "--hill-set", f"{raw_key}={raw_val}")
        elif key in PARAMETERS:
            bound = 90.0 if PARAMETERS[key][0] == "deg" else 1e5
            check_number(x, -bound, bound, PARAMETERS[key][0], "--hill-set", f"{raw_key}={raw_val}")
        elif key == "gates":
            check_number(x, 1, 1000, "", "--hill-set", f"{raw_key}={raw_val}")


def check_option_values(cmd: click.Command, values: dict[str, Any]) -> None:
    """Check the numbers inside string options (``--origin LAT,LON,H``, ``--hill-set K=V``...) before any
    input is read, so a bad option value is always a usage error (exit 2)."""
    for p in cmd.params:
        if not isinstance(p, click.Option) or values.get(p.name or "") in (None, ()):
            continue
        longest = max(p.opts, key=len)
        value = values[p.name or ""]
        items = value if isinstance(value, tuple) else (value,)
        if (
            isinstance(value, str)
            and not value.strip()
            and (isinstance(p.type, click.Path) or "FILE" in (p.metavar or ""))
        ):
            raise click.BadParameter("is empty; expected a name or a file", param_hint=longest)
        if longest in FLOAT_LISTS:
            for item in items:
                if longest == "--origin" and str(item).strip().lower() == "auto":
                    continue  # gps2hill --origin auto: the first fix (no numbers to check)
                vals = parse_floats(str(item), len(FLOAT_LISTS[longest]), longest)
                if longest == "--outage" and not vals[0] < vals[1]:
                    raise click.BadParameter(
                        f"{item!r}: the outage ends before it starts; expected START,END with START < END [s]",
                        param_hint=longest,
                    )
        elif longest in ("--takeoff", "--touchdown"):  # comma-separated instants [s]
            for item in items:
                for v in str(item).split(","):
                    try:
                        check_number(float(v), -1e6, 1e7, "s", longest, str(item))
                    except ValueError as exc:
                        raise click.BadParameter(
                            f"{item!r} is not comma-separated seconds", param_hint=longest
                        ) from exc
        elif longest == "--hill-set":
            check_hill_set(parse_pairs(items, longest))


#: A random seed: numpy's generators take a non-negative integer.
SEED = click.IntRange(min=0)


def seed_truth_options(truth_help: str = "Write the truth table (kind truth, Parquet) to this file.") -> Any:
    """Add ``--seed N`` and ``--truth FILE`` (the command receives ``seed`` and ``truth_path``) to a simulator."""

    def decorate(f: Callable[..., Any]) -> Callable[..., Any]:
        f = click.option(
            "--truth", "truth_path", type=click.Path(dir_okay=False, writable=True), default=None, help=truth_help
        )(f)
        return click.option("--seed", default=0, show_default=True, type=SEED, help="Random seed [integer >= 0].")(f)

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
