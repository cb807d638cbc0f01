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
.sub { color: var(--muted); margin: 0 0 1rem; }
.headline { display: grid; grid-template-columns: repeat(auto-fit, minmax(9.5rem, 1fr)); gap: 0.6rem; }
.figure-box { border: 2px solid var(--accent); border-radius: 0.5rem; padding: 0.5rem 0.7rem; }
.figure-box .label { font-size: 0.85rem; color: var(--muted); }
.figure-box .value { font-size: 1.5rem; font-weight: 700; }
.figure-box .alt { font-size: 0.85rem; color: var(--muted); }
table { border-collapse: collapse; width: 100%; font-variant-numeric: tabular-nums; font-size: 0.92rem; }
th, td { border-bottom: 1px solid var(--line); padding: 0.3rem 0.4rem; text-align: right; }
th:first-child, td:first-child { text-align: left; }
.scroll { overflow-x: auto; }
figure { margin: 1rem 0; }
figure img { width: 100%; height: auto; }
figcaption { font-size: 0.9rem; color: var(--muted); }
.failed { color: #D55E00; font-weight: 600; }
details { margin-top: 2rem; }
pre { white-space: pre-wrap; word-break: break-word; font-size: 0.8rem; }
a { color: var(--accent); }
@media print { body { max-width: none; } details { display: block; } .figure-box { break-inside: avoid; } }
"""


def esc(text: Any) -> str:
    """HTML-escape any value's string form."""
    return html.escape(str(text), quote=True)


def number(value: float | None, unit: str, digits: int = 2) -> str:
    """``"25.83 m/s"``; a dash where there is no finite value (never "nan")."""
    if value is None or not math.isfinite(float(value)):
        return "–"
    return f"{float(value):.{digits}f} {unit}".strip()


def speed(value_ms: float | None) -> str:
    """A speed in m/s with km/h beside it (coaches think in km/h)."""
    if value_ms is None or not math.isfinite(float(value_ms)):
        return "–"
    return f"{value_ms:.2f} m/s ({3.6 * value_ms:.1f} km/h)"


def headline(items: Sequence[tuple[str, str, str]]) -> str:
    """The headline figures as boxes: (label, value with unit, secondary line)."""
    boxes = [
        f'<div class="figure-box"><div class="label">{esc(label)}</div>'
        f'<div class="value">{esc(value)}</div><div class="alt">{esc(alt)}</div></div>'
        for label, value, alt in items
    ]
    return '<div class="headline">' + "".join(boxes) + "</div>"


def table(headers: Sequence[str], rows: Iterable[Sequence[Any]], caption: str = "", raw_cells: bool = False) -> str:
    """A table (horizontally scrollable on a phone); cells are escaped unless ``raw_cells``."""
    cell = (lambda v: str(v)) if raw_cells else esc
    head = "".join(f'<th scope="col">{esc(h)}</th>' for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{cell(v)}</td>" for v in r) + "</tr>" for r in rows)
    cap = f"<caption>{esc(caption)}</caption>" if caption else ""
    return f'<div class="scroll"><table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></div>'


def svg_figure(fig: Any, alt: str, caption: str) -> str:
    """A matplotlib figure embedded as SVG (``data:`` URI, no external file) with alt text and caption."""
    import io as _io

    buf = _io.BytesIO()
    fig.savefig(buf, format="svg", metadata={"Date": None})
    data = base64.b64encode(compact_svg(buf.getvalue().decode("utf-8")).encode("utf-8")).decode("ascii")
    return (
        f'<figure><img src="data:image/svg+xml;base64,{data}" alt="{esc(alt)}">'
        f"<figcaption>{esc(caption)}</figcaption></figure>"
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


def page(title: str, subtitle: str, body: str) -> str:
    """The whole self-contained page."""
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{esc(title)}</title><style>{_CSS}</style></head>"
        f'<body><main><h1>{esc(title)}</h1><p class="sub">{esc(subtitle)}</p>{body}</main></body></html>\n'
    )
