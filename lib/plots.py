"""Figures (PNG or SVG) for the ``plot`` command: hill profiles and tracks over them.

matplotlib is the optional ``plot`` extra (``pip install 'sportfusion[plot]'``)
and is imported only inside these functions, through its object-oriented API
on the Agg canvas (no pyplot, no global backend change).

All coordinates are in the hill frame (x forward, y right, z down) [m]; side
views show the height ``-z`` [m] so that the hill runs downhill on the page.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from sportfusion import schema
from sportfusion.errors import InputError
from sportfusion.hill import HillProfile

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["FORMATS", "figure_format", "render", "hill_figure", "track_figure", "profile_from_meta"]

#: Output formats by file suffix.
FORMATS = {".png": "png", ".svg": "svg"}
_POINTS = ("A", "B", "E1", "E2", "T", "F", "P", "K", "L", "U")


def _new_figure(width: float, height: float) -> Figure:
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise InputError("plotting needs matplotlib; install the extra: pip install 'sportfusion[plot]'") from exc
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def figure_format(path: str | Path) -> str:
    """``"png"`` or ``"svg"`` from an output file's suffix; :class:`InputError` otherwise."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise InputError(f"output {path} has suffix {suffix or '(none)'!r}; expected .png or .svg")
    return FORMATS[suffix]


def render(fig: Figure, fmt: str, dpi: float = 150.0) -> bytes:
    """The figure as PNG or SVG bytes (``dpi`` [dots per inch] sets a PNG's pixel size)."""
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, dpi=dpi, metadata={"Software": "sportfusion"} if fmt == "png" else None)
    return buf.getvalue()


def _draw_profile(ax: Axes, profile: HillProfile, points: bool = True) -> None:
    for part in ("inrun", "landing"):
        x, z = profile.sample(part)
        ax.plot(x, -z, color="0.25", lw=1.4, label="hill profile" if part == "landing" else None)
    x, z = profile.sample("landing")
    ax.fill_between(x, -z, np.nanmin(-z) - 5, color="0.9", zorder=0)
    if points:
        for name in _POINTS:
            px, pz = profile.points[name]
            ax.plot(px, -pz, "o", ms=4, color="tab:red" if name in ("K", "L") else "tab:blue", zorder=5)
            below = name in ("F", "B", "E2")
            ax.annotate(name, (px, -pz), textcoords="offset points", xytext=(4, -12 if below else 4), fontsize=8)


def hill_figure(profile: HillProfile, title: str = "", width: float = 10.0, height: float = 6.0) -> Figure:
    """Side view of a hill: in-run, landing hill and out-run with the key points A .. U.

    Parameters
    ----------
    profile : HillProfile
    title : str
        Figure title (the hill's name).
    width, height : float
        Figure size [inch].
    """
    fig = _new_figure(width, height)
    ax = fig.add_subplot()
    _draw_profile(ax, profile)
    c = profile.cert
    ax.set_title(
        f"{title}  ({c.type}, K {c.w:g} m, HS {c.hS:g} m; jump length at K "
        f"{profile.jump_length(profile.points['K'][0]):.1f} m, at L {profile.jump_length(profile.points['L'][0]):.1f} m)"
    )
    ax.set_xlabel("x: horizontal distance from the take-off edge [m]")
    ax.set_ylabel("height above the take-off edge, -z [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.6)
    return fig


def profile_from_meta(meta: dict[str, Any]) -> HillProfile | None:
    """The hill profile recorded in a table's ``hill`` metadata (by ``gps2hill --hill``), or None."""
    cert = (meta.get("hill") or {}).get("certificate")
    return None if not cert else HillProfile(cert)


def _col(table: pa.Table, name: str) -> np.ndarray | None:
    return schema.floats(table, name) if name in table.column_names else None


def track_figure(
    table: pa.Table,
    meta: dict[str, Any],
    profile: HillProfile | None = None,
    title: str = "",
    width: float = 10.0,
    height: float = 8.0,
) -> Figure:
    """Side and top view of a session in its local frame, over the hill profile when known.

    Draws the GNSS points ``gnss_x gnss_y gnss_z`` and, when present, the
    estimate ``x y z`` with a 1-sigma band from ``std_z`` (side) and
    ``std_y`` (top).

    Raises
    ------
    InputError
        Neither ``gnss_x/gnss_z`` nor ``x/z`` columns (run gps2hill first).
    """
    gx, gy, gz = (_col(table, f"gnss_{a}") for a in "xyz")
    ex, ey, ez = (_col(table, a) for a in "xyz")
    has_gnss = gx is not None and gz is not None
    has_est = ex is not None and ez is not None
    if not has_gnss and not has_est:
        raise InputError("no gnss_x/gnss_z or x/z columns to draw; expected a session after gps2hill")
    fig = _new_figure(width, height)
    side, top = fig.subplots(2, 1, sharex=True, height_ratios=[2, 1])
    if profile is not None:
        _draw_profile(side, profile, points=False)
        for name in ("T", "K", "L"):
            px, pz = profile.points[name]
            side.annotate(name, (px, -pz), textcoords="offset points", xytext=(4, 4), fontsize=8)
        for part in ("inrun", "landing"):
            x, _ = profile.sample(part)
            top.plot(x, np.zeros_like(x), color="0.25", lw=1.0)
    if has_gnss:
        ok = np.isfinite(gx) & np.isfinite(gz)
        side.plot(gx[ok], -gz[ok], ".", ms=3, color="tab:orange", label=f"GNSS ({ok.sum()} fixes)")
        if gy is not None:
            ok2 = ok & np.isfinite(gy)
            top.plot(gx[ok2], gy[ok2], ".", ms=3, color="tab:orange")
    if has_est:
        ok = np.isfinite(ex) & np.isfinite(ez)
        side.plot(ex[ok], -ez[ok], "-", lw=1.2, color="tab:blue", label="estimate")
        sz = _col(table, "std_z")
        if sz is not None:
            m = ok & np.isfinite(sz)
            side.fill_between(
                ex[m], -ez[m] - sz[m], -ez[m] + sz[m], color="tab:blue", alpha=0.25, lw=0, label="estimate ±1σ"
            )
        if ey is not None:
            m = ok & np.isfinite(ey)
            top.plot(ex[m], ey[m], "-", lw=1.2, color="tab:blue")
            sy = _col(table, "std_y")
            if sy is not None:
                m2 = m & np.isfinite(sy)
                top.fill_between(ex[m2], ey[m2] - sy[m2], ey[m2] + sy[m2], color="tab:blue", alpha=0.25, lw=0)
    frame = meta.get("frame") or {}
    where = f"frame '{frame.get('name', '?')}', azimuth {frame.get('azimuth_deg', 0):g} deg" if frame else "no frame"
    side.set_title(f"{title}  ({where})" if title else where)
    side.set_ylabel("height, -z [m]")
    side.legend(loc="upper right", fontsize=8)
    side.grid(True, lw=0.4, alpha=0.6)
    top.set_ylabel("y (right) [m]")
    top.invert_yaxis()
    top.set_xlabel("x: along the hill axis [m]")
    top.grid(True, lw=0.4, alpha=0.6)
    return fig
