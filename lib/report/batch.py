"""The batch index page: one row per session of a batch summary, failed sessions with their error line,
links to each session's page.  Sortable by a click on a column header (a few lines of inline script);
readable and complete without script."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pyarrow as pa

from sportfusion.report import html as H

#: summary column -> (header, unit, digits)
COLUMNS = (
    ("sport", "sport", "", None),
    ("status", "status", "", None),
    ("duration", "duration", "s", 1),
    ("max_speed", "max speed", "m/s", 2),
    ("jump_length", "jump length", "m", 2),
    ("video_jump_length", "video jump length", "m", 2),
    ("takeoff_speed", "take-off speed", "m/s", 2),
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
    rows: list[dict[str, Any]] = summary.to_pylist()
    head = '<th scope="col" data-sort="1">session</th>' + "".join(
        f'<th scope="col" data-sort="1">{H.esc(h)}{f" [{u}]" if u else ""}</th>' for _, h, u, _ in COLUMNS
    )
    body = []
    for r in rows:
        name = str(r.get("session"))
        link = f'<a href="{H.esc(pages[name])}">{H.esc(name)}</a>' if name in pages else H.esc(name)
        cells = [f'<td data-v="{H.esc(name)}">{link}</td>']
        for col, _, _unit, digits in COLUMNS:
            v = r.get(col)
            if digits is None:
                text = H.esc(v if v is not None else "–")
                cls = ' class="failed"' if col == "status" and v != "ok" else ""
                cells.append(f'<td data-v="{H.esc(v)}"{cls}>{text}</td>')
            else:
                cells.append(f'<td data-v="{"" if v is None else v}">{H.esc(H.number(v, "", digits))}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    failed = [r for r in rows if r.get("status") != "ok"]
    n_ok = len(rows) - len(failed)
    html = (
        f"<h2>Sessions</h2><p>{n_ok} of {len(rows)} sessions ok, {len(failed)} failed. "
        "Click a column header to sort.</p>"
        f'<div class="scroll"><table><thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody></table></div>'
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
    return H.page(title, f"{len(rows)} sessions", html).replace("</main>", "</main>" + _SORT)


def session_pages(out: Path, names: list[str], page_name: str = "report.html") -> dict[str, str]:
    """Links to the sessions' pages that exist under a batch output folder."""
    return {n: f"{n}/{page_name}" for n in names if (Path(out) / n / page_name).exists()}
