"""Hill files (TOML): a hill's certificate, its geodetic site and where the numbers come from.

Layout::

    name = "Oberstdorf HS106"
    venue = "Schattenbergschanze (normal hill), Oberstdorf, Germany"   # optional
    source = "..."                                                     # where the numbers come from
    notes = "..."                                                      # optional

    [site]              # optional; needed to convert GNSS into the hill frame
    lat = 47.4049       # take-off edge, WGS84 latitude [deg]
    lon = 10.2945       # take-off edge, WGS84 longitude [deg]
    height = 945.0      # take-off edge, ellipsoidal height [m]
    azimuth_deg = 312.6 # hill azimuth psi_N: north -> hill x axis, clockwise [deg]
    g0 = 9.8053         # optional local gravity [m/s^2] (else WGS84 normal gravity)
    mag_n = 21.46       # optional local magnetic field, north/east/down [uT]
    mag_e = 1.48
    mag_d = 43.44

    [certificate]       # see sportfusion.skijump.hill.PARAMETERS: lengths [m], angles [deg]
    type = "ICR2008"
    w = 95.0
    ...

``--hill NAME`` finds a shipped file (``sportfusion/data/hills/NAME.toml``;
case, spaces and hyphens ignored), ``--hill FILE.toml`` reads a user's.
``--hill-set KEY=VALUE`` overrides one value: a certificate parameter
(``e=95.5``, ``type=ICR1996``, ``gates=30``), a site value (``lat``,
``lon``, ``height``, ``azimuth_deg``, ``g0``, ``mag_n``, ``mag_e``,
``mag_d``) or ``name``; ``certificate.KEY`` / ``site.KEY`` spell it out.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sportfusion.core.errors import InputError
from sportfusion.core.frames import Frame
from sportfusion.core.gravity import normal_gravity
from sportfusion.skijump.hill import PARAMETERS, Certificate, HillProfile

__all__ = ["Hill", "load_hill", "shipped_hills", "SITE_KEYS"]

#: Site values: name -> unit.
SITE_KEYS = {
    "lat": "deg",
    "lon": "deg",
    "height": "m",
    "azimuth_deg": "deg",
    "g0": "m/s^2",
    "mag_n": "uT",
    "mag_e": "uT",
    "mag_d": "uT",
}
_TOP_KEYS = ("name", "venue", "source", "notes")
_CERT_EXTRA = ("type", "gates")


@dataclass
class Hill:
    """A loaded hill: profile, site and provenance of the numbers."""

    name: str
    profile: HillProfile
    site: dict[str, float] = field(default_factory=dict)
    venue: str = ""
    source: str = ""
    notes: str = ""
    spec: str = ""
    overrides: dict[str, str] = field(default_factory=dict)

    @property
    def has_origin(self) -> bool:
        """Whether the file gives the take-off edge's position and the azimuth."""
        return all(k in self.site for k in ("lat", "lon", "height", "azimuth_deg"))

    def frame(self) -> Frame:
        """The hill frame (origin at the take-off edge, x along ``azimuth_deg``)."""
        if not self.has_origin:
            missing = [k for k in ("lat", "lon", "height", "azimuth_deg") if k not in self.site]
            raise InputError(
                f"hill {self.name!r} has no site {', '.join(missing)}; give --origin LAT,LON,H and --azimuth DEG "
                "or add them with --hill-set"
            )
        s = self.site
        return Frame(s["lat"], s["lon"], s["height"], s["azimuth_deg"], "hill")

    def gravity(self) -> float:
        """Gravity at the take-off edge [m/s^2]: ``g0`` if given, else WGS84 normal gravity there."""
        if "g0" in self.site:
            return float(self.site["g0"])
        if "lat" not in self.site:
            raise InputError(f"hill {self.name!r} gives neither g0 nor a site latitude for normal gravity")
        return float(normal_gravity(self.site["lat"], self.site.get("height", 0.0)))

    def mag_field(self) -> tuple[float, float, float] | None:
        """Local magnetic field north/east/down [uT] if the file gives it."""
        if all(k in self.site for k in ("mag_n", "mag_e", "mag_d")):
            return (self.site["mag_n"], self.site["mag_e"], self.site["mag_d"])
        return None

    def venue_data(self, step: float = 0.05) -> dict[str, Any]:
        """The hill as plain numbers for a simulator (:class:`sportfusion.skijump.sim.venue.SimHill`): frame,
        gravity [m/s^2], field [uT], start gates, ``w`` [m], key points and the in-run and landing profiles
        as points ``(x, z)`` about ``step`` [m] apart (every segment end included)."""
        prof = self.profile
        xi, zi = prof.sample("inrun", step)
        xl, zl = prof.sample("landing", step)
        return {
            "name": self.name,
            "frame": self.frame(),
            "g": self.gravity(),
            "mag_field": self.mag_field(),
            "meta": self.meta(),
            "gates": int(prof.cert.gates or 2),
            "w": float(prof.cert.w),
            "points": {k: (float(v[0]), float(v[1])) for k, v in prof.points.items()},
            "inrun_x": xi,
            "inrun_z": zi,
            "landing_x": xl,
            "landing_z": zl,
        }

    def meta(self) -> dict[str, Any]:
        """The table's ``hill`` metadata: name, source, site, certificate, key points, overrides."""
        out: dict[str, Any] = {"name": self.name, "spec": self.spec}
        for k in ("venue", "source", "notes"):
            if getattr(self, k):
                out[k] = getattr(self, k)
        if self.site:
            out["site"] = dict(self.site)
        out.update(self.profile.summary())
        if self.overrides:
            out["overrides"] = dict(self.overrides)
        return out


def _hill_dir() -> Any:
    """The shipped hill files (``sportfusion/data/hills``): the folder beside this package where the package is
    installed as files (no import of importlib.resources and its zip reader, ~5 ms per command), else through
    importlib.resources."""
    here = Path(__file__).parent.parent / "data" / "hills"
    if here.is_dir():
        return here
    from importlib import resources

    return resources.files("sportfusion.data") / "hills"


def shipped_hills() -> list[str]:
    """Names of the hills shipped with sportfusion (``--hill NAME``), sorted."""
    return sorted(p.name[:-5] for p in _hill_dir().iterdir() if p.name.endswith(".toml"))


def _norm(name: str) -> str:
    return re.sub(r"[\s\-]+", "_", name.strip().lower())


def _read_toml(text: str, where: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"hill file {where} is not valid TOML ({exc})") from exc


def _locate(spec: str) -> tuple[str, str]:
    """``(toml text, where)`` for a shipped name or a file path."""
    looks_like_path = spec.endswith(".toml") or "/" in spec or "\\" in spec
    if looks_like_path or (Path(spec).is_file() and _norm(spec) not in shipped_hills()):
        path = Path(spec)
        try:
            return path.read_text(encoding="utf-8"), str(path)
        except FileNotFoundError as exc:
            raise InputError(f"hill file {spec} does not exist; expected a TOML hill file or a shipped name") from exc
        except (OSError, UnicodeDecodeError) as exc:
            raise InputError(f"cannot read hill file {spec}: {exc}") from exc
    names = shipped_hills()
    key = _norm(spec)
    if key not in names:
        few = ", ".join(names[:15]) + (f", ... ({len(names)} in all)" if len(names) > 15 else "")
        raise InputError(f"unknown hill {spec!r}; shipped hills: {few}; or give a FILE.toml")
    return (_hill_dir() / f"{key}.toml").read_text(encoding="utf-8"), f"{key} (shipped)"


def _number(key: str, value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{where}: '{key}' is {value!r}, expected a finite number [{SITE_KEYS.get(key, '')}]")
    return float(value)


def _apply_overrides(doc: dict[str, Any], overrides: Mapping[str, str]) -> None:
    """Write ``--hill-set`` values into the parsed document (strings parsed to numbers)."""
    cert = doc.setdefault("certificate", {})
    site = doc.setdefault("site", {})
    for raw_key, raw_val in overrides.items():
        section, _, key = raw_key.rpartition(".")
        if section not in ("", "certificate", "site"):
            raise InputError(f"--hill-set {raw_key}: unknown section {section!r}, expected certificate or site")
        if key in _TOP_KEYS and not section:
            doc[key] = raw_val
            continue
        if section == "certificate" or (not section and (key in PARAMETERS or key in _CERT_EXTRA)):
            target = cert
            if key not in PARAMETERS and key not in _CERT_EXTRA:
                raise InputError(
                    f"--hill-set {raw_key}: unknown certificate value; expected one of {', '.join(PARAMETERS)}"
                )
        elif section == "site" or (not section and key in SITE_KEYS):
            target = site
            if key not in SITE_KEYS:
                raise InputError(f"--hill-set {raw_key}: unknown site value; expected one of {', '.join(SITE_KEYS)}")
        else:
            known = ", ".join([*PARAMETERS, *_CERT_EXTRA, *SITE_KEYS, "name"])
            raise InputError(f"--hill-set {raw_key}: unknown key; expected one of {known}")
        if key == "type":
            target[key] = raw_val
            continue
        try:
            target[key] = int(raw_val) if key == "gates" else float(raw_val)
        except ValueError as exc:
            what = "a whole number" if key == "gates" else "a number"
            raise InputError(f"--hill-set {raw_key}={raw_val}: expected {what}") from exc


def load_hill(spec: str, overrides: Mapping[str, str] | None = None) -> Hill:
    """Load a hill by shipped name or TOML path, apply ``--hill-set`` overrides, build its profile.

    Parameters
    ----------
    spec : str
        Shipped hill name (see :func:`shipped_hills`) or path to a ``.toml`` file.
    overrides : mapping of str -> str, optional
        ``KEY -> VALUE`` from ``--hill-set`` (values as typed on the command line).

    Raises
    ------
    InputError
        Unknown name, unreadable or malformed TOML, missing or inconsistent
        certificate values, bad site values.
    """
    text, where = _locate(spec)
    doc = _read_toml(text, where)
    overrides = dict(overrides or {})
    if overrides:
        _apply_overrides(doc, overrides)
    cert = doc.get("certificate")
    if not isinstance(cert, dict) or not cert:
        raise InputError(f"hill file {where} has no [certificate] table; expected the certificate values")
    site_raw = doc.get("site") or {}
    if not isinstance(site_raw, dict):
        raise InputError(f"hill file {where}: 'site' must be a table ([site])")
    unknown = sorted(set(site_raw) - set(SITE_KEYS))
    if unknown:
        raise InputError(
            f"hill file {where}: unknown [site] key(s) {', '.join(unknown)}; expected {', '.join(SITE_KEYS)}"
        )
    site = {k: _number(k, v, f"hill file {where} [site]") for k, v in site_raw.items()}
    if "lat" in site and not -90 <= site["lat"] <= 90:
        raise InputError(f"hill file {where}: site lat = {site['lat']} deg, expected -90 .. 90")
    for key, lo, hi in (("lon", -180, 360), ("height", -1000, 10000), ("azimuth_deg", -360, 360)):
        if key in site and not lo <= site[key] <= hi:
            raise InputError(f"hill file {where}: site {key} = {site[key]} {SITE_KEYS[key]}, expected {lo} .. {hi}")
    for key in ("mag_n", "mag_e", "mag_d"):
        if key in site and abs(site[key]) > 200:
            raise InputError(f"hill file {where}: site {key} = {site[key]} uT, expected -200 .. 200")
    if "g0" in site and not 9.7 < site["g0"] < 9.9:
        raise InputError(f"hill file {where}: site g0 = {site['g0']} m/s^2, expected a value near 9.81")
    try:
        profile = HillProfile(Certificate.from_mapping(cert, where=f"hill file {where} [certificate]"))
    except InputError as exc:
        msg = str(exc)
        if not msg.startswith("hill file"):
            msg = f"hill file {where} {msg}"
        raise InputError(msg) from None
    strs = {}
    for k in _TOP_KEYS:
        v = doc.get(k, "")
        if not isinstance(v, str):
            raise InputError(f"hill file {where}: '{k}' must be a string")
        strs[k] = v
    name = strs["name"] or Path(spec).stem
    return Hill(
        name=name,
        profile=profile,
        site=site,
        venue=strs["venue"],
        source=strs["source"],
        notes=strs["notes"],
        spec=spec,
        overrides=overrides,
    )


def hill_from_meta(meta: Mapping[str, Any]) -> Hill:
    """The hill a table's metadata names (``meta["hill"]["spec"]`` with its overrides), as :func:`load_hill` loads it.

    Raises :class:`InputError` when the metadata names no hill (the caller should then ask for ``--hill``).
    """
    h = meta.get("hill") or {}
    spec = h.get("spec")
    if not spec:
        raise InputError("no --hill given and the table's metadata names no hill; expected --hill NAME|FILE.toml")
    return load_hill(spec, h.get("overrides") or None)
