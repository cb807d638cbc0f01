"""Self-contained HTML pieces for the reports: the page, number formatting with units, tables, figures.

A page needs no network and no JavaScript: styles are inline, figures are SVG embedded as ``data:`` URIs
with alt text, the provenance is a ``<details>`` block.  Colours follow the Okabe-Ito palette (safe for
the common colour-vision deficiencies); the layout reflows to a phone's width and prints on A4.
"""

from __future__ import annotations

import base64
import html
import json
import math
import re
from collections.abc import Iterable, Sequence
from typing import Any

#: Okabe & Ito (2008) colour-blind-safe palette, used for every line a report figure draws.
OKABE_ITO = ("#0072B2", "#E69F00", "#009E73", "#D55E00", "#CC79A7", "#56B4E9", "#F0E442", "#000000")

_CSS = """
:root { --fg: #1a1a1a; --muted: #555; --line: #ccc; --accent: #0072B2; }
* { box-sizing: border-box; }
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; color: var(--fg);
       margin: 0 auto; padding: 1rem; max-width: 60rem; line-height: 1.45; }
h1 { font-size: 1.5rem; margin: 0.2rem 0 0.5rem; }
h2 { font-size: 1.2rem; margin: 1.6rem 0 0.5rem; border-bottom: 1px solid var(--line); }
h3 { font-size: 1.05rem; margin: 1rem 0 0.3rem; }
.sub { color: var(--muted); margin: 0 0 0.4rem; }
nav.top { font-size: 0.9rem; margin: 0 0 1rem; }
nav.top a { margin-right: 1rem; white-space: nowrap; }
.headline { display: grid; grid-template-columns: repeat(auto-fit, minmax(9.5rem, 1fr)); gap: 0.6rem; }
.figure-box { border: 2px solid var(--accent); border-radius: 0.5rem; padding: 0.5rem 0.7rem; }
.figure-box .label { font-size: 0.85rem; color: var(--muted); }
.figure-box .value { font-size: 1.5rem; font-weight: 700; white-space: nowrap; }
.figure-box .alt { font-size: 0.85rem; color: var(--muted); }
.note { font-size: 0.9rem; color: var(--muted); }
table { border-collapse: collapse; width: 100%; font-variant-numeric: tabular-nums; font-size: 0.92rem; }
caption { text-align: left; color: var(--muted); font-size: 0.9rem; padding: 0.2rem 0; }
th, td { border-bottom: 1px solid var(--line); padding: 0.3rem 0.4rem; text-align: right; }
td { white-space: nowrap; }
td.text { white-space: normal; }
td.words { text-align: left; }
th:first-child, td:first-child { text-align: left; }
.num { white-space: nowrap; }
.scroll { overflow-x: auto; }
figure { margin: 1rem 0; }
figure img { display: block; width: 100%; max-width: 36rem; height: auto; }
figcaption { font-size: 0.9rem; color: var(--muted); max-width: 36rem; }
.failed { color: #D55E00; font-weight: 600; }
details { margin-top: 1.2rem; }
details.fold > summary { font-size: 1.2rem; font-weight: 600; cursor: pointer; border-bottom: 1px solid var(--line); }
dl.glossary dt { font-weight: 600; margin-top: 0.5rem; }
dl.glossary dd { margin: 0 0 0.3rem 0; }
pre { white-space: pre-wrap; word-break: break-word; font-size: 0.8rem; }
a { color: var(--accent); }
@media (max-width: 40rem) {
  table { font-size: 0.78rem; }
  th, td { padding: 0.25rem 0.15rem; }
  table.cards thead { position: absolute; width: 1px; height: 1px; overflow: hidden; clip: rect(0 0 0 0); }
  table.cards, table.cards caption, table.cards tbody, table.cards tr, table.cards td { display: block; width: 100%; }
  table.cards tr { border-bottom: 1px solid var(--line); padding: 0.3rem 0; }
  table.cards td { border: 0; text-align: left; padding: 0.05rem 0.2rem; white-space: normal; }
  table.cards td::before { content: attr(data-label) ": "; color: var(--muted); }
  table.cards td:first-child { font-weight: 600; }
  table.cards td:first-child::before { content: ""; }
  table.cards td.empty { display: none; }
}
@media (min-width: 62rem) {
  figure { display: grid; grid-template-columns: 36rem 1fr; gap: 1.2rem; align-items: start; }
  figcaption { padding-top: 2rem; }
}
@media print { body { max-width: none; } details { display: block; } .figure-box { break-inside: avoid; } }
"""


def esc(text: Any) -> str:
    """HTML-escape any value's string form."""
    return html.escape(str(text), quote=True)


#: a number with its unit (what must never break across lines)
_NUMBER_UNIT = re.compile(r"[-+−]?\d[\d.,:]*(?:\s?(?:km/h|m/s\^2|m/s|°/s|°|%|uT|s|m)(?![\w/]))?")


def nums(text: Any) -> str:
    """Escape ``text`` and keep each number with its unit on one line (``<span class="num">``)."""
    return _NUMBER_UNIT.sub(lambda m: f'<span class="num">{m.group(0)}</span>', esc(text))


#: the unit a reader sees for an angle, after the conversion from the tables' radians
DEG = "°"


def number(value: float | None, unit: str, digits: int = 2) -> str:
    """``"25.83 m/s"``; a dash where there is no finite value (never "nan"); ``°`` follows the number."""
    if value is None or not math.isfinite(float(value)):
        return "–"
    v = float(value) if round(float(value), digits) != 0 else 0.0  # no "-0.000"
    if unit == DEG:
        return f"{v:.{digits}f}{DEG}"
    return f"{v:.{digits}f} {unit}".strip()


def kmh(value_ms: float | None) -> str:
    """A speed [m/s] in km/h: ``"93.0 km/h"``."""
    return "–" if value_ms is None or not math.isfinite(float(value_ms)) else f"{3.6 * float(value_ms):.1f} km/h"


def speed(value_ms: float | None) -> str:
    """A speed in m/s with km/h beside it (coaches think in km/h)."""
    if value_ms is None or not math.isfinite(float(value_ms)):
        return "–"
    return f"{value_ms:.2f} m/s ({3.6 * value_ms:.1f} km/h)"


def value_in(value: float | None, unit: str, digits: int = 3) -> str:
    """A table value in its unit for a reader: radians become degrees (``0.194°``), rad/s degrees per second."""
    if value is not None and unit in ("rad", "rad/s") and math.isfinite(float(value)):
        return number(math.degrees(float(value)), DEG if unit == "rad" else "°/s", digits)
    return number(value, {"rad": DEG, "rad/s": "°/s"}.get(unit, unit), digits)


def headline(items: Sequence[tuple[str, str, str]]) -> str:
    """The headline figures as boxes: (label, value with unit, secondary line)."""
    boxes = [
        f'<div class="figure-box"><div class="label">{esc(label)}</div>'
        f'<div class="value">{nums(value)}</div><div class="alt">{nums(alt)}</div></div>'
        for label, value, alt in items
    ]
    return '<div class="headline">' + "".join(boxes) + "</div>"


def table(
    headers: Sequence[str],
    rows: Iterable[Sequence[Any]],
    caption: str = "",
    raw_cells: bool = False,
    cards: bool = False,
    ident: str = "",
    text_columns: Sequence[int] = (),
) -> str:
    """A table; cells are escaped unless ``raw_cells``.  Every cell carries its column's name
    (``data-label``); with ``cards`` each row becomes a card of "name: value" lines on a phone (no sideways
    scrolling, nothing off-screen).  Columns in ``text_columns`` may wrap (words); the others (numbers with
    their units) never do."""
    cell = (lambda v: str(v)) if raw_cells else nums
    head = "".join(f'<th scope="col">{esc(h)}</th>' for h in headers)

    def td(k: int, v: Any) -> str:
        cls = " ".join(c for c in ("text words" if k in text_columns else "", "empty" if v in ("", "–") else "") if c)
        return f'<td data-label="{esc(headers[k])}"{f" class={chr(34)}{cls}{chr(34)}" if cls else ""}>{cell(v)}</td>'

    body = "".join("<tr>" + "".join(td(k, v) for k, v in enumerate(r)) + "</tr>" for r in rows)
    cap = f"<caption>{esc(caption)}</caption>" if caption else ""
    attrs = (f' id="{esc(ident)}"' if ident else "") + (' class="cards"' if cards else "")
    return f'<div class="scroll"><table{attrs}>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></div>'


def folded(summary: str, body: str, ident: str = "", open_: bool = False) -> str:
    """A section folded under its summary line (``<details>``), with an id to link to."""
    attrs = (f' id="{esc(ident)}"' if ident else "") + (" open" if open_ else "")
    return f'<details class="fold"{attrs}><summary>{esc(summary)}</summary>{body}</details>'


def svg_figure(fig: Any, alt: str | None = None, caption: str | None = None) -> str:
    """A matplotlib figure embedded as SVG (``data:`` URI, no external file) with alt text and caption;
    both are read from the figure itself (:func:`sportfusion.core.plotlayout.describe_figure`) unless given."""
    import io as _io

    from sportfusion.core.plotlayout import describe_figure, fit_titles

    fit_titles(fig)
    auto_caption, auto_alt = describe_figure(fig)
    alt, caption = alt or auto_alt, caption or auto_caption
    buf = _io.BytesIO()
    fig.savefig(buf, format="svg", metadata={"Date": None})
    data = base64.b64encode(compact_svg(buf.getvalue().decode("utf-8")).encode("utf-8")).decode("ascii")
    return (
        f'<figure><img src="data:image/svg+xml;base64,{data}" alt="{esc(alt)}">'
        f"<figcaption>{nums(caption)}</figcaption></figure>"
    )


_PATH = re.compile(r'(<path[^>]*? d=")([^"]*)(")')
_NUM = re.compile(r"-?\d+\.\d+")


#: matplotlib's default (tab10) colours -> their Okabe-Ito counterparts, so every figure of a report is
#: colour-blind safe whichever colours the plotting function chose
TAB10_TO_OKABE_ITO = {
    "#1f77b4": "#0072b2",
    "#ff7f0e": "#e69f00",
    "#2ca02c": "#009e73",
    "#d62728": "#d55e00",
    "#9467bd": "#cc79a7",
    "#8c564b": "#000000",
    "#e377c2": "#cc79a7",
    "#7f7f7f": "#7f7f7f",
    "#bcbd22": "#f0e442",
    "#17becf": "#56b4e9",
}
_HEX = re.compile(r"#[0-9a-fA-F]{6}\b")


def compact_svg(svg: str) -> str:
    """Path coordinates rounded to 0.1 pt (a tenth of a screen pixel at the figure's size) and their
    whitespace collapsed (the same picture in about half the bytes); tab10 colours -> Okabe-Ito."""

    def one(m: re.Match[str]) -> str:
        d = _NUM.sub(lambda n: f"{float(n.group(0)):.1f}".rstrip("0").rstrip("."), m.group(2))
        return m.group(1) + " ".join(d.split()) + m.group(3)

    svg = _HEX.sub(lambda m: TAB10_TO_OKABE_ITO.get(m.group(0).lower(), m.group(0)), svg)
    return _PATH.sub(one, svg)


def provenance(meta: dict[str, Any]) -> str:
    """The tools, versions and parameters that made the table, folded."""
    steps = meta.get("provenance") or []
    items = "".join(
        f"<li><strong>{esc(s.get('tool'))}</strong> {esc(s.get('version', ''))}"
        f"<pre>{esc(json.dumps(s.get('params', {}), indent=1, sort_keys=True, default=str))}</pre></li>"
        for s in steps
    )
    return f"<details><summary>Provenance: {len(steps)} processing steps</summary><ol>{items}</ol></details>"


#: a link to a folded section opens it (a few lines of script; without script the section is a click away)
_OPEN_TARGET = """<script>
function sfOpen() { var d = document.getElementById(location.hash.slice(1)); if (d && d.tagName === "DETAILS") d.open = true; }
window.addEventListener("hashchange", sfOpen); sfOpen();
</script>"""


def page(title: str, subtitle: str, body: str, nav: Sequence[tuple[str, str]] = ()) -> str:
    """The whole self-contained page; ``nav``: (text, ``#id``) links under the title."""
    links = "".join(f'<a href="{esc(href)}">{esc(text)}</a>' for text, href in nav)
    top = f'<nav class="top">{links}</nav>' if links else ""
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{esc(title)}</title><style>{_CSS}</style></head>"
        f'<body><main><h1>{esc(title)}</h1><p class="sub">{esc(subtitle)}</p>{top}{body}</main>'
        f"{_OPEN_TARGET if links else ''}</body></html>\n"
    )
