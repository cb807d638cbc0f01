"""The batch index page: one row per session of a batch summary, failed sessions with their error line,
links to each session's page.  The sports' headline figures come first (jump length, take-off speed, max
speed), the checks after (status, RMS against a truth); on a phone each session is a card of "name: value"
lines, so nothing is off-screen.  Sortable by a click on a column header (a few lines of inline script);
readable and complete without script.  "Reading the report" is folded at its end, as on every page."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pyarrow as pa

from sportfusion.report import html as H

#: summary column -> (header, unit, digits): the sports' headline figures first, then the checks
COLUMNS = (
    ("sport", "sport", "", None),
    ("jump_length", "jump length", "m", 2),
    ("takeoff_speed", "take-off speed", "m/s", 2),
    ("max_speed", "max speed", "m/s", 2),
    ("video_jump_length", "video jump length", "m", 2),
    ("duration", "recorded", "s", 1),
    ("status", "status", "", None),
    ("pos_rms", "position RMS vs truth", "m", 3),
    ("vel_rms", "velocity RMS vs truth", "m/s", 3),
)

_SORT = """<script>
document.querySelectorAll("th[data-sort]").forEach(function (th, i) {
  th.style.cursor = "pointer";
  th.addEventListener("click", function () {
    var body = th.closest("table").tBodies[0], rows = Array.from(body.rows), dir = th.dataset.dir === "1" ? -1 : 1;
    th.dataset.dir = dir === 1 ? "1" : "-1";
    rows.sort(function (a, b) {
      var x = a.cells[i].dataset.v, y = b.cells[i].dataset.v, nx = parseFloat(x), ny = parseFloat(y);
      if (!isNaN(nx) && !isNaN(ny)) return dir * (nx - ny);
      return dir * String(x).localeCompare(String(y));
    });
    rows.forEach(function (r) { body.appendChild(r); });
  });
});
</script>"""


def batch_index(summary: pa.Table, pages: dict[str, str], title: str = "Batch report") -> str:
    """The index page.

    Parameters
    ----------
    summary : pyarrow.Table
        A batch summary (``python -m sportfusion.batch``: one row per session).
    pages : dict
        Session name -> link to its page (relative to the index), for the sessions that have one.
    """
    from sportfusion.report.glossary import glossary_html

    rows: list[dict[str, Any]] = summary.to_pylist()
    head = '<th scope="col" data-sort="1">session</th>' + "".join(
        f'<th scope="col" data-sort="1">{H.esc(h)}</th>' for _, h, _, _ in COLUMNS
    )
    body = []
    for r in rows:
        name = str(r.get("session"))
        link = f'<a href="{H.esc(pages[name])}">{H.esc(name)}</a>' if name in pages else H.esc(name)
        cells = [f'<td data-label="session" data-v="{H.esc(name)}">{link}</td>']
        for col, label, unit, digits in COLUMNS:
            v = r.get(col)
            if digits is None:
                text = H.esc(v if v is not None else "–")
                cls = ' class="failed"' if col == "status" and v != "ok" else ""
                cells.append(f'<td data-label="{H.esc(label)}" data-v="{H.esc(v)}"{cls}>{text}</td>')
            else:
                shown = f'<span class="num">{H.esc(H.number(v, unit, digits))}</span>'
                if col in ("max_speed", "takeoff_speed") and v is not None:  # km/h beside, on its own line if need be
                    shown += f' <span class="num">({H.esc(H.kmh(v))})</span>'
                cls = ' class="empty"' if v is None else ' class="text"'
                cells.append(f'<td data-label="{H.esc(label)}" data-v="{"" if v is None else v}"{cls}>{shown}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    failed = [r for r in rows if r.get("status") != "ok"]
    n_ok = len(rows) - len(failed)
    html = (
        f"<h2>Sessions</h2><p>{n_ok} of {len(rows)} sessions ok, {len(failed)} failed. "
        "Click a column header to sort; a session's name opens its page. RMS vs truth: the 3-D error of a "
        "simulated session's estimate (position, velocity).</p>"
        f'<div class="scroll"><table class="cards"><thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody>'
        "</table></div>"
    )
    if failed:
        html += (
            "<h2>Failed sessions</h2><ul>"
            + "".join(
                f'<li><strong>{H.esc(r.get("session"))}</strong>: <span class="failed">{H.esc(r.get("error"))}</span></li>'
                for r in failed
            )
            + "</ul>"
        )
    html += H.folded("Reading the report: what each figure and word means", glossary_html(), "reading")
    page = H.page(title, f"{len(rows)} sessions", html, nav=(("Reading the report", "#reading"),))
    return page.replace("</main>", "</main>" + _SORT)


def session_pages(out: Path, names: list[str], page_name: str = "report.html") -> dict[str, str]:
    """Links to the sessions' pages that exist under a batch output folder."""
    return {n: f"{n}/{page_name}" for n in names if (Path(out) / n / page_name).exists()}
