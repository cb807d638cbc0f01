"""How a figure is laid out for where it is read, and what it shows in words.

* :func:`narrow_layout` -- figures for a phone's width (the report pages): no text smaller than a minimum
  size [pt] and legends below their axes instead of beside them, so that a figure drawn about 5 inch wide and
  shown 358 px wide on a 390 px phone keeps its text at 11 px or more;
* :func:`fs` -- a font size [pt] as a figure asks for it, raised to that minimum;
* :func:`legend_outside` -- the legend outside the data: to the right, or below on a narrow page;
* :func:`describe_figure` -- a caption and an alt text read from the figure itself (its titles, axis labels
  and ranges, legend entries, colour scales), so that they describe the figure as drawn and cannot drift
  from it.

matplotlib is imported by the callers' plot functions only, never at library import.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from contextvars import ContextVar
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["Layout", "narrow_layout", "layout", "fs", "legend_outside", "describe_figure", "NARROW_WIDTH"]

#: Width [inch] of the report's figures: 360 pt, shown 358 px wide on a 390 px phone (1 pt -> 0.99 px).
NARROW_WIDTH = 5.0


@dataclass(frozen=True)
class Layout:
    """``min_font`` [pt]: no text smaller (0: the figure's own sizes); ``legend``: ``"right"`` of the axes or
    ``"below"`` them; ``width`` [inch]: the width figures are drawn at (None: each figure's own)."""

    min_font: float = 0.0
    legend: str = "right"
    width: float | None = None


_LAYOUT: ContextVar[Layout] = ContextVar("sportfusion_plot_layout", default=Layout())  # noqa: B039 (frozen)


def layout() -> Layout:
    """The layout figures are drawn in now."""
    return _LAYOUT.get()


def fs(pt: float) -> float:
    """A font size [pt] as a figure asks for it, raised to the layout's minimum."""
    return max(float(pt), _LAYOUT.get().min_font)


@contextlib.contextmanager
def narrow_layout(min_font: float = 11.5, width: float = NARROW_WIDTH) -> Iterator[Layout]:
    """Draw figures for a narrow page: every text at least ``min_font`` [pt] (tick labels, legends, titles,
    annotations), legends below their axes, figures ``width`` [inch] wide."""
    import matplotlib as mpl

    lay = Layout(min_font=min_font, legend="below", width=width)
    token = _LAYOUT.set(lay)
    rc = {k: min_font for k in ("font.size", "legend.fontsize", "axes.labelsize", "xtick.labelsize", "ytick.labelsize")}
    rc.update(
        {"axes.titlesize": 1.05 * min_font, "figure.titlesize": 1.1 * min_font, "legend.title_fontsize": min_font}
    )
    try:
        with mpl.rc_context(rc):
            yield lay
    finally:
        _LAYOUT.reset(token)


def _shows_x_labels(ax: Axes) -> bool:
    """True when the axes draws x tick labels (the bottom panel of a shared-x stack, or a lone axes)."""
    spec = ax.get_subplotspec() if hasattr(ax, "get_subplotspec") else None
    if spec is None:
        return True
    shared = len(ax.get_shared_x_axes().get_siblings(ax)) > 1
    return not shared or spec.is_last_row()


def legend_outside(ax: Axes, **kwargs: Any) -> Any:
    """The axes' legend outside the plotted area, so that it never covers data: to its right, or (in
    :func:`narrow_layout`) below it, in as many columns as its width holds, clear of the tick labels."""
    lay = _LAYOUT.get()
    size = fs(kwargs.pop("fontsize", 8))
    if lay.legend != "below":
        return ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=size, **kwargs)
    from matplotlib.transforms import offset_copy

    handles, labels = kwargs.pop("handles", None), None
    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    else:
        labels = [h.get_label() for h in handles]
    if not handles:
        return None
    width_pt = ax.figure.get_figwidth() * 72.0 * 0.9
    item = max(0.55 * size * max(len(lb) for lb in labels) + 3.2 * size, 1.0)
    ncol = max(1, min(len(labels), int(width_pt // item)))
    drop = (2.4 * size + 10.0) if _shows_x_labels(ax) else 2.0  # below the tick labels and the axis label
    where = offset_copy(ax.transAxes, fig=ax.figure, y=-drop, units="points")
    return ax.legend(
        handles,
        labels,
        loc="upper left",
        bbox_to_anchor=(0.0, 0.0),
        bbox_transform=where,
        borderaxespad=0.0,
        ncol=ncol,
        fontsize=size,
        columnspacing=1.0,
        handlelength=1.5,
        **kwargs,
    )


def fit_titles(fig: Figure) -> None:
    """Break the figure's titles (its own and each axes') into lines that fit the figure's width, so that no
    title is cut at the page's edge (long titles on a narrow figure)."""
    import textwrap

    width_pt = fig.get_figwidth() * 72.0
    texts = [fig._suptitle] if getattr(fig, "_suptitle", None) is not None else []
    for ax in fig.axes:
        texts += [ax.title, ax._left_title, ax._right_title]
    for t in texts:
        s = t.get_text()
        if not s or "\n" in s:
            continue
        chars = int(0.92 * width_pt / (0.56 * t.get_fontsize()))
        if len(s) > chars > 10:
            t.set_text("\n".join(textwrap.wrap(s, chars)))


# --------------------------------------------------------------------------- words for a figure
def _is_colourbar(ax: Axes) -> bool:
    return getattr(ax, "_colorbar", None) is not None


def _colourbar_parent(ax: Axes) -> Any:
    """The axes whose data a colour bar's axes explains (its mappable's axes), or None."""
    cb = getattr(ax, "_colorbar", None)
    return getattr(getattr(cb, "mappable", None), "axes", None)


def _span(lo: float, hi: float) -> str:
    lo, hi = min(lo, hi), max(lo, hi)
    digits = 0 if hi - lo >= 20 else 1 if hi - lo >= 2 else 2
    return f"{lo:.{digits}f} to {hi:.{digits}f}"


def _clean(text: str) -> str:
    return " ".join(str(text).replace("\n", " ").split()).strip()


def _sentence(text: str) -> str:
    text = _clean(text)
    return text[:1].upper() + text[1:] if text else text


def _panels(fig: Figure) -> list[dict[str, Any]]:
    panels: list[dict[str, Any]] = []
    by_axes: dict[int, dict[str, Any]] = {}
    bars = []
    for ax in fig.axes:
        if _is_colourbar(ax):
            bars.append(ax)
            continue
        if not ax.get_visible() or not ax.axison:
            continue
        leg = ax.get_legend()
        panels.append(
            {
                "title": _clean(ax.get_title() or ax.get_title("left")),
                "x": _clean(ax.get_xlabel()),
                "y": _clean(ax.get_ylabel()),
                "items": [_clean(t.get_text()) for t in leg.get_texts()] if leg else [],
                "colour": [],
                "xlim": ax.get_xlim(),
                "ylim": ax.get_ylim(),
                "lines": len(ax.get_lines()),
            }
        )
        by_axes[id(ax)] = panels[-1]
    for bar in bars:
        label = _clean(bar.get_ylabel() or bar.get_xlabel())
        owner = by_axes.get(id(_colourbar_parent(bar)), panels[-1] if panels else None)
        kind = type(getattr(bar._colorbar, "mappable", None)).__name__
        what = {"LineCollection": "line colour", "PathCollection": "dot colour"}.get(kind, "colour")
        if owner is not None and label:
            owner["colour"].append(f"{what}: {label}")
    # a stack sharing its time axis labels only the bottom panel: the others take its label
    xs = [p["x"] for p in panels if p["x"]]
    for p in panels:
        if not p["x"] and len(set(xs)) == 1:
            p["x"] = xs[0]
    return panels


def describe_figure(fig: Figure) -> tuple[str, str]:
    """A caption and an alt text for a figure, read from what it draws.

    The caption names the figure (its overall title, else each panel's title) and, per panel, what is drawn
    (the legend's entries, the colour scale's label); the alt text adds each panel's axes with their
    ranges. Both come from the figure's artists, so they say what the figure shows.

    Returns
    -------
    (caption, alt) : tuple of str
    """
    panels = _panels(fig)
    sup = _clean(fig._suptitle.get_text()) if getattr(fig, "_suptitle", None) is not None else ""
    sentences = [_sentence(sup)] if sup else []
    listed = []
    for k, p in enumerate(panels):
        details = "; ".join(x for x in (", ".join(p["items"]), *p["colour"]) if x)
        if sup:  # a stack of panels under one title: each named by its quantity
            listed.append(f"{p['y'] or p['title']}{' (' + details + ')' if details else ''}")
            continue
        head = p["title"] or p["y"]
        lead = ("Below: " if k else "") + head if head else ("Below" if k else "")
        if lead or details:
            sentences.append(_sentence(f"{lead}{': ' if lead and details else ''}{details}"))
    if listed:
        sentences.append(("Panels, top to bottom: " if len(listed) > 1 else "") + "; ".join(listed))
    caption = ". ".join(s.rstrip(".") for s in sentences if s)
    caption = caption + "." if caption else "Figure."
    axes = []
    for k, p in enumerate(panels):
        lead = f"Panel {k + 1} of {len(panels)}" if len(panels) > 1 else "The panel"
        xs, ys = (f" ({_span(*p[a])})" if all(math.isfinite(v) for v in p[a]) else "" for a in ("xlim", "ylim"))
        desc = f"{lead}{' (' + p['title'] + ')' if p['title'] and sup else ''} plots {p['y'] or 'values'}{ys}"
        desc += f" against {p['x'] or 'x'}{xs}"
        axes.append(desc)
    alt = caption + " " + ". ".join(axes) + ("." if axes else "")
    return caption, alt.strip()
