"""`report`: one self-contained HTML page per session (every fixture sport) and the batch index.

The pages come from the real pipeline (pipelines/session.mk, target ``report``). Checked: well-formed
HTML with headings in order and alt text on every figure; nothing loaded from outside the file; the
headline figures equal to the numbers of jump-metrics / the spline / gate-anchor / pf-holds / evaluate;
a colour-blind-safe palette; small enough to mail; and in a real headless Chromium at phone width: no
console errors, no horizontal overflow, the headline figures in the first screen (screenshot taken).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT

from sportfusion.core import io as sfio
from sportfusion.report import html as H
from sportfusion.report.session import detect_sport

BIN = f"{Path(sys.executable).parent}/"
SPORTS = ("skijump", "skirace", "gates", "climbing")
RESULT = {"skijump": "smoothed", "skirace": "attitude", "gates": "anchored", "climbing": "holds"}
VOID = {"meta", "img", "br", "hr", "link", "input", "source", "col", "area", "base", "wbr"}


class _Checker(HTMLParser):
    """Collects structure problems: unclosed/misnested tags, heading levels, imgs without alt, external URLs."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.problems: list[str] = []
        self.headings: list[int] = []
        self.imgs = 0
        self.headline_text = ""
        self._in_headline = 0

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        for key in ("src", "href"):
            v = a.get(key) or ""
            if re.match(r"(?i)(https?:)?//", v):
                self.problems.append(f"external URL in {tag} {key}: {v[:60]}")
        if tag == "script" and a.get("src"):
            self.problems.append("external script")
        if tag == "img":
            self.imgs += 1
            if not (a.get("alt") or "").strip():
                self.problems.append("img without alt text")
        if re.fullmatch(r"h[1-6]", tag):
            self.headings.append(int(tag[1]))
        if tag == "div" and a.get("class") == "headline":
            self._in_headline = 1
        elif self._in_headline and tag == "div":
            self._in_headline += 1
        if tag not in VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag: str) -> None:
        if tag in VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.problems.append(f"</{tag}> closes <{self.stack[-1] if self.stack else '-'}>")
            return
        self.stack.pop()
        if tag == "div" and self._in_headline:
            self._in_headline -= 1

    def handle_data(self, data: str) -> None:
        if self._in_headline:
            self.headline_text += data + " "


def check_page(text: str) -> _Checker:
    c = _Checker()
    c.feed(text)
    c.close()
    assert text.startswith("<!DOCTYPE html>")
    assert c.problems == [] and c.stack == [], (c.problems, c.stack)
    assert c.headings[0] == 1 and c.headings.count(1) == 1
    assert all(b - a <= 1 for a, b in zip(c.headings, c.headings[1:], strict=False)), c.headings
    return c


@pytest.fixture(scope="module")
def pages(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("reports")
    for name in SPORTS:
        res = subprocess.run(
            ["make", "--no-print-directory", "-f", "pipelines/session.mk", f"SESSION=fixtures/{name}", f"OUT={out / name}",
             f"BIN={BIN}", "report"],
            capture_output=True, text=True, cwd=ROOT, timeout=900,
        )  # fmt: skip
        assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    return out


def _fmt(v: float, digits: int = 2) -> str:
    return f"{v:.{digits}f}"


class _Tables(HTMLParser):
    """Every table of a page as {id or caption: (headers, rows of cell texts)}; figures' (caption, alt)."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tables: dict[str, tuple[list[str], list[list[str]]]] = {}
        self.figures: list[tuple[str, str]] = []
        self._t: dict | None = None
        self._cell: list[str] | None = None
        self._alt = ""
        self._cap: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "table":
            self._t = {"id": a.get("id") or "", "head": [], "rows": [], "caption": []}
        elif tag in ("th", "td") and self._t is not None:
            self._cell = []
        elif tag == "tr" and self._t is not None:
            self._t["rows"].append([])
        elif tag == "caption" and self._t is not None:
            self._cell = []
        elif tag == "img":
            self._alt = a.get("alt") or ""
        elif tag == "figcaption":
            self._cap = []

    def handle_endtag(self, tag: str) -> None:
        if tag in ("th", "td") and self._t is not None and self._cell is not None:
            text = " ".join("".join(self._cell).split())
            (self._t["head"] if tag == "th" else self._t["rows"][-1]).append(text)
            self._cell = None
        elif tag == "caption" and self._t is not None and self._cell is not None:
            self._t["caption"] = " ".join("".join(self._cell).split())
            self._cell = None
        elif tag == "table" and self._t is not None:
            key = self._t["id"] or self._t["caption"] or f"table{len(self.tables)}"
            self.tables[key] = (self._t["head"], [r for r in self._t["rows"] if r])
            self._t = None
        elif tag == "figcaption" and self._cap is not None:
            self.figures.append((" ".join("".join(self._cap).split()), self._alt))
            self._cap = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)
        if self._cap is not None:
            self._cap.append(data)


def tables_of(text: str) -> _Tables:
    p = _Tables()
    p.feed(text)
    return p


def _row(table: tuple[list[str], list[list[str]]], first: str) -> dict[str, str]:
    head, rows = table
    row = next(r for r in rows if r[0] == first)
    return dict(zip(head, row, strict=True))


def _evaluate_text(pages: Path, sport: str) -> dict[str, dict[str, float]]:
    """evaluate --format text of the page's session: phase -> column label -> value (what the tool prints)."""
    res = subprocess.run(
        [f"{BIN}evaluate", str(pages / sport / f"{RESULT[sport]}.parquet"), "--truth",
         str(ROOT / "fixtures" / sport / "truth.parquet"), "--format", "text"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    lines = res.stdout.splitlines()
    head = next(ln for ln in lines if ln.startswith("phase"))
    labels = re.findall(r"\S+ \[[^\]]+\]", head)
    out = {}
    for ln in lines:
        parts = ln.split()
        if len(parts) == 3 + len(labels) and parts[1] == "rms":
            out[parts[0]] = dict(zip(labels, parts[3:], strict=True))
    return out


#: evaluate's text column -> (the report's row label, unit shown after the number)
EVAL_TEXT = {
    "dx [m]": ("x", " m"), "dy [m]": ("y", " m"), "dz [m]": ("z", " m"),
    "dvx [m/s]": ("vx", " m/s"), "dvy [m/s]": ("vy", " m/s"), "dvz [m/s]": ("vz", " m/s"),
    "droll [deg]": ("roll", "°"), "dpitch [deg]": ("pitch", "°"), "dyaw [deg]": ("yaw", "°"),
    "angle [deg]": ("attitude angle", "°"),
}  # fmt: skip


def _moving(t: np.ndarray, speed: np.ndarray, threshold: float = 1.0) -> tuple[float, float]:
    """The documented definition, written again: intervals whose mean speed is at least 1 m/s."""
    mean = (speed[1:] + speed[:-1]) / 2
    ok = np.isfinite(mean) & (mean >= threshold)
    return float(np.diff(t)[ok].sum()), float((mean * np.diff(t))[ok].sum())


@pytest.mark.slow
@pytest.mark.parametrize("sport", SPORTS)
def test_session_page_is_valid_self_contained_and_shows_the_tools_figures(pages: Path, sport: str) -> None:
    """The page's numbers are the tools' numbers in the same units: jump-metrics' table, gate-anchor's
    turns, pf-holds' holds, the spline's speeds, evaluate's RMS rows exactly as `evaluate --format text`
    prints them (angles in degrees), the estimator's 1-sigma."""
    text = (pages / sport / "report.html").read_text(encoding="utf-8")
    c = check_page(text)
    assert c.imgs >= 2
    assert len(text.encode()) < 1_500_000, "a page to mail: under 1.5 MB"
    assert (
        "#0072b2"
        in "".join(__import__("base64").b64decode(m).decode() for m in re.findall(r"base64,([^\"]+)\"", text)).lower()
    ), "the figures use the Okabe-Ito palette"
    assert "Provenance" in text and 'id="analyst"' in text and 'id="reading"' in text and 'href="#reading"' in text
    head = " ".join(c.headline_text.split())
    assert "Mean hold probability" not in text and ("Hold certainty" in head) == (sport == "climbing")
    page = tables_of(text)
    table, meta = sfio.read_table(pages / sport / f"{RESULT[sport]}.parquet")
    assert detect_sport(table, meta) == sport
    # against the truth: every RMS value as evaluate prints it, in its unit (angles in degrees, not radians)
    printed = _evaluate_text(pages, sport)
    truth_table = page.tables["against-truth"]
    from sportfusion.evaluate import frame_label

    assert f"position and velocity in the {H.esc(frame_label(meta))}" in text, "the table names its one frame"
    for label, (row, unit) in EVAL_TEXT.items():
        if label in printed["all"]:
            got = _row(truth_table, row)
            for phase, vals in printed.items():
                assert got[phase] == f"{float(vals[label]):.3f}{unit}", (row, phase, got[phase], vals[label])
    # how sure we are: the 1-sigma columns, angles in degrees
    for name in ("x", "vx", "roll", "yaw"):
        s = table.column(f"std_{name}").to_numpy(zero_copy_only=False) if f"std_{name}" in table.column_names else None
        if s is None or not np.isfinite(s).any():
            continue
        scale, unit = (180 / np.pi, "°") if name in ("roll", "yaw") else (1.0, " m" if name == "x" else " m/s")
        got = _row(page.tables["certainty"], name)
        assert got["median 1-sigma"] == f"{scale * np.nanmedian(s):.3f}{unit}"
        assert got["largest 1-sigma"] == f"{scale * np.nanmax(s):.3f}{unit}"
    t = table.column("t").to_numpy()
    if sport == "skijump":
        jumps, _ = sfio.read_table(pages / sport / "jumps.parquet", kind="jumps")
        j = jumps.to_pylist()[0]
        assert f"{_fmt(j['jump_length'])} m" in head and f"{_fmt(j['takeoff_speed'])} m/s" in head
        assert f"{_fmt(j['flight_time'])} s" in head and f"{3.6 * j['takeoff_speed']:.1f} km/h" in head
        assert f"{_fmt(j['max_height'])} m" in head
        row = _row(page.tables["jumps"], "jump 1")
        assert row["take-off at"] == f"{j['t_takeoff']:.2f} s" and row["jump length"] == f"{j['jump_length']:.2f} m"
        assert row["take-off speed"] == f"{j['takeoff_speed']:.2f} m/s"
        assert row["in km/h"] == f"{3.6 * j['takeoff_speed']:.1f} km/h"
        assert row["flight time"] == f"{j['flight_time']:.2f} s" and row["max height"] == f"{j['max_height']:.2f} m"
    elif sport in ("skirace", "gates"):
        speed = (
            table.column("speed").to_numpy(zero_copy_only=False)
            if sport == "skirace"
            else np.linalg.norm(np.column_stack([table.column(f"v{a}").to_numpy() for a in "xyz"]), axis=1)
        )
        t_move, d_move = _moving(t, speed)
        assert f"{_fmt(float(np.nanmax(speed)))} m/s" in head
        assert re.search(rf"Moving time\s+{t_move:.1f} s", head) and f"recording {t[-1] - t[0]:.1f} s" in head
        assert re.search(rf"Moving mean speed\s+{d_move / t_move:.2f} m/s", head)
        if sport == "skirace":
            assert f"{float(np.nanmax(table.column('distance').to_numpy(zero_copy_only=False))):.0f} m" in head
        else:
            ev = table.column("event").to_pylist()
            gate = table.column("gate").to_pylist()
            crossings = [g for e, g in zip(ev, gate, strict=True) if e == "gate"]
            survey, _ = sfio.read_table(ROOT / "fixtures" / "gates" / "survey.parquet", kind="gates")
            n_matched = len({g for g in crossings if g is not None and g >= 0})
            assert re.search(rf"Gates matched\s+{n_matched} of {survey.num_rows}\b", head)
            assert f"{len(crossings)} crossings detected, {n_matched} matched" in head
            turns = page.tables["turns"]
            assert sorted(r[0] for r in turns[1] if r[0].startswith("gate")) == sorted(
                f"gate {g}" for g in survey.column("gate").to_pylist()
            ), "every surveyed gate has a row"
            figs = {r["gate"]: r for r in table.to_pylist() if r.get("event") == "gate" and r.get("turn_length")}
            for r in turns[1]:
                row = dict(zip(turns[0], r, strict=True))
                g = int(row["gate"].split()[1]) if row["gate"].startswith("gate") else None
                if g in figs:
                    assert row["path length"] == f"{figs[g]['turn_length']:.2f} m"
                    assert row["speed in"].startswith(f"{figs[g]['turn_v_in']:.2f} m/s")
                    assert row["speed out"].startswith(f"{figs[g]['turn_v_out']:.2f} m/s")
                else:
                    assert row["why no turn"], f"a gate without a turn says why: {row}"
    else:
        ids = table.column("hold_id").to_pylist()
        reached = {h for h in ids if h is not None and h >= 0}
        assert re.search(rf"Holds reached\s+{len(reached)}\b", head)
        prob = table.column("cluster_prob").to_numpy(zero_copy_only=False)
        on = np.array([h is not None for h in ids])
        assert f"{100 * np.nanmean(prob[on]):.0f} %" in head
        order = [int(r[1]) for r in page.tables["holds"][1]]
        seq = [h for k, h in enumerate(ids) if h is not None and h >= 0 and (k == 0 or ids[k - 1] != h)]
        assert order == [h for k, h in enumerate(seq) if k == 0 or seq[k - 1] != h]
    # captions and alt texts: read from the figures, never the same text for two different figures
    caps = [cap for cap, _ in page.figures]
    assert len(set(caps)) == len(caps) and all(len(alt) > len(cap) for cap, alt in page.figures)
    if sport == "skijump":  # the page's first figure is the trajectory: its words are the figure's own
        from sportfusion.core.plots import describe_figure, narrow_layout
        from sportfusion.report.session import _thin
        from sportfusion.skijump.plots import profile_from_meta, speed_figure

        with narrow_layout():
            fig = speed_figure(_thin(table), meta, profile_from_meta(meta))
            from sportfusion.core.plots import fit_titles

            fit_titles(fig)
            assert page.figures[0] == describe_figure(fig)
        assert "line colour: speed |v| [m/s]" in caps[0] and "flight (zoom)" in caps[0]
        assert "speed" not in caps[1].lower().split("azimuth")[0], "the side view is not coloured by speed"


def test_number_formatting_has_units_and_no_nan() -> None:
    assert H.number(float("nan"), "m") == "–" and H.number(None, "m") == "–"
    assert H.number(89.558, "m") == "89.56 m"
    assert H.speed(25.0) == "25.00 m/s (90.0 km/h)"
    # the tables' radians are shown in degrees, with the unit
    assert H.value_in(0.0033859, "rad") == "0.194°" and H.value_in(0.01, "rad/s") == "0.573 °/s"
    assert H.value_in(0.107, "m") == "0.107 m" and H.value_in(None, "rad") == "–"
    # a number keeps its unit on its line
    assert H.nums("25.83 m/s (93.0 km/h)") == '<span class="num">25.83 m/s</span> (<span class="num">93.0 km/h</span>)'
    assert H.nums("gate 3 at 9.46 s") == 'gate <span class="num">3</span> at <span class="num">9.46 s</span>'

    svg = '<path style="x" d="M 84.99237 -326.924948 \n L 85.000001 -325.866113"/>'
    assert H.compact_svg(svg) == '<path style="x" d="M 85 -326.9 L 85 -325.9"/>'


@pytest.mark.slow
def test_batch_index_lists_every_session_links_pages_and_failures(pages: Path, tmp_path: Path) -> None:
    sessions = tmp_path / "sessions"
    for name in SPORTS:
        shutil.copytree(ROOT / "fixtures" / name, sessions / name)
    shutil.copytree(ROOT / "fixtures" / "climbing", sessions / "corrupt")
    out = tmp_path / "out"
    shutil.copytree(pages, out)
    (out / "corrupt").mkdir()
    (out / "corrupt" / "error").write_text("Error: detect-events: standard input is not a Parquet file\n")
    subprocess.run(
        [sys.executable, "-m", "sportfusion.batch", str(out), "--sessions", str(sessions)], capture_output=True
    )
    text = (out / "index.html").read_text(encoding="utf-8")
    check_page(text)
    links = [h for h in re.findall(r'href="([^"]+)"', text) if not h.startswith("#")]
    assert sorted(links) == sorted(f"{n}/report.html" for n in SPORTS)
    assert 'href="#reading"' in text and 'id="reading"' in text, "Reading the report, folded in the page"
    assert all((out / link).exists() for link in links)
    assert "4 of 5 sessions ok, 1 failed" in text and "standard input is not a Parquet file" in text


def _browser():  # noqa: ANN202
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    chromium, driver = shutil.which("chromium"), shutil.which("chromedriver")
    assert chromium and driver, "make test installs Debian's chromium and chromium-driver for this test"
    opts = webdriver.ChromeOptions()
    # --hide-scrollbars: a phone's scroll bars lie over the page, they take no width from it
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--hide-scrollbars"):
        opts.add_argument(a)
    opts.binary_location = chromium
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver), options=opts)


#: the same pattern as sportfusion.report.html.nums: a number with its unit
_JS_WRAPPED = r"""
const re = /[-+\u2212]?\d[\d.,:]*(?:\s?(?:km\/h|m\/s\^2|m\/s|\u00b0\/s|\u00b0|%|uT|s|m)(?![\w\/]))?/g;
const walker = document.createTreeWalker(document.querySelector("main"), NodeFilter.SHOW_TEXT);
const bad = []; let n = 0;
while (walker.nextNode()) {
  const node = walker.currentNode;
  if (node.parentElement.closest("pre, script, style")) continue;
  let m;
  while ((m = re.exec(node.data)) !== null) {
    const r = document.createRange(); r.setStart(node, m.index); r.setEnd(node, m.index + m[0].length);
    const rects = Array.from(r.getClientRects()).filter(q => q.width > 0);
    if (rects.length === 0) continue;  // folded away, not rendered
    n += 1;
    const tops = new Set(rects.map(q => Math.round(q.top)));
    if (tops.size > 1) bad.push(m[0] + " in " + node.parentElement.tagName);
  }
}
return [n, bad];
"""


def _figure_text_px(driver) -> list[tuple[float, float]]:  # noqa: ANN001
    """Per embedded SVG figure: (smallest text size rendered [px], rendered width [px]): the figure's font
    sizes [user units] times the image's rendered width over its viewBox width."""
    import base64

    out = []
    for src, width in driver.execute_script(
        "return Array.from(document.images).filter(i => i.offsetParent !== null)"
        ".map(i => [i.getAttribute('src'), i.getBoundingClientRect().width])"
    ):
        if not src.startswith("data:image/svg+xml;base64,"):
            continue
        svg = base64.b64decode(src.split(",", 1)[1]).decode()
        view_w = float(re.search(r'viewBox="[\d.]+ [\d.]+ ([\d.]+) ', svg).group(1))
        sizes = [float(v) for v in re.findall(r"font-size: ?([\d.]+)px", svg)]
        assert sizes, "the figure's text is text (svg.fonttype none), measurable"
        out.append((min(sizes) * width / view_w, width))
    return out


@pytest.mark.slow
def test_pages_in_a_real_browser_at_phone_width(pages: Path, tmp_path: Path) -> None:
    """At 390 px (a phone): no console error, no sideways scrolling, the headline in the first screen, every
    figure decodes and its smallest text renders at 11 px or more, no number is broken over two lines (the
    headline boxes, the tables, the captions); the same at 1280 px.  Screenshots of both widths are taken."""
    subprocess.run(
        [sys.executable, "-m", "sportfusion.batch", str(pages), "--sessions", str(ROOT / "fixtures")],
        capture_output=True,
    )
    d = _browser()
    try:
        for width in (390, 1280):
            d.set_window_size(width, 844)
            for name in (*SPORTS, "index"):
                page = pages / name / "report.html" if name != "index" else pages / "index.html"
                d.get(page.as_uri())
                errors = [e for e in d.get_log("browser") if e.get("level") == "SEVERE"]
                assert errors == [], errors
                inner = d.execute_script("return window.innerWidth")
                assert d.execute_script("return document.body.scrollWidth") <= inner, "no sideways scrolling"
                overflow = d.execute_script(
                    "return Array.from(document.querySelectorAll('.scroll')).filter(e => e.scrollWidth > e.clientWidth + 1).length"
                )
                assert overflow == 0, f"{name} at {width} px: a table wider than the page"
                n, wrapped = d.execute_script(_JS_WRAPPED)
                assert n > 10 and wrapped == [], (name, width, wrapped)
                if name != "index":
                    box = d.find_element("css selector", ".headline")
                    assert box.is_displayed() and box.rect["y"] < d.execute_script("return window.innerHeight")
                    first = d.find_element("css selector", ".headline .value")
                    assert re.search(r"\d", first.text) and first.rect["y"] + first.rect["height"] < 844
                    imgs = d.execute_script("return Array.from(document.images).map(i => i.naturalWidth > 0)")
                    assert imgs and all(imgs), "every embedded figure decodes"
                    sizes = _figure_text_px(d)
                    assert sizes and min(px for px, _ in sizes) >= 11.0, (name, width, sizes)
                else:
                    first = d.find_element("css selector", "tbody tr td:nth-child(1)")
                    assert first.is_displayed()
                    if width == 390:  # a card per session: the sport's headline figure before the checks
                        card = next(  # the skijump session's row (the fixtures hold more sessions than SPORTS)
                            r for r in d.find_elements("css selector", "tbody tr")
                            if r.find_elements("css selector", "td")[0].text.strip().startswith("skijump")
                        )  # fmt: skip
                        labels = [e.get_attribute("data-label") for e in card.find_elements("css selector", "td")]
                        shown = [lb for lb, e in zip(labels, card.find_elements("css selector", "td"), strict=True)
                                 if e.is_displayed()]  # fmt: skip
                        assert shown.index("jump length") < shown.index("status"), shown
                h = d.execute_script("return document.documentElement.scrollHeight")
                d.set_window_size(width, min(h + 150, 12000))
                shot = tmp_path / f"{name}-{width}.png"
                d.save_screenshot(str(shot))
                assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
                d.set_window_size(width, 844)
    finally:
        d.quit()


def _jump_table(events: bool) -> tuple:
    """A small smoothed-looking session: a parabola over 4 s at 20 m/s, with or without take-off/touch-down."""
    import pyarrow as pa

    from sportfusion.core import meta as sfmeta

    t = np.arange(0.0, 4.0, 0.01)
    x, z = 20.0 * t, 4.9 * (t - 1.0) ** 2 * (t > 1.0)
    ev = [None] * t.size
    if events:
        ev[100], ev[300] = "takeoff", "touchdown"
    table = pa.table(
        {"t": t, "x": x, "y": 0 * t, "z": z, "vx": 0 * t + 20.0, "vy": 0 * t, "vz": 9.8 * (t - 1.0) * (t > 1.0),
         "event": pa.array(ev, pa.string())}
    )  # fmt: skip
    meta = sfmeta.new_meta("session", 1.7e9)
    meta["frame"] = {"name": "hill", "origin": [47.0, 10.0, 900.0], "azimuth_deg": 0.0, "axes": "x forward"}
    return table, meta


def test_captions_and_alt_texts_are_read_from_the_figure() -> None:
    """What a caption says follows what the figure draws: the flight zoom only with its events, the colour
    scale named from the colour bar (a line, not dots), every panel's axes with their ranges in the alt."""
    from sportfusion.core.plots import describe_figure, narrow_layout, series_figure
    from sportfusion.skijump.plots import speed_figure, track_figure

    with_events, meta = _jump_table(True)
    without, _ = _jump_table(False)
    cap, alt = describe_figure(speed_figure(with_events, meta))
    assert "flight (zoom)" in cap and "line colour: speed |v| [m/s]" in cap and "speed in the zoom" in cap
    assert "Panel 1 of 2" in alt and "Panel 2 of 2" in alt and "against x [m]" in alt
    cap, alt = describe_figure(speed_figure(without, meta))
    assert "zoom" not in cap and "Panel" not in alt.split(".", 1)[1][:10] and "The panel plots height" in alt
    cap, _ = describe_figure(track_figure(with_events, meta))
    assert "coloured by speed" not in cap and "estimate" in cap and "top view" in cap
    with narrow_layout():
        cap, alt = describe_figure(series_figure(with_events, meta, panels=("position", "velocity")))
    assert "Panels, top to bottom: position [m] (x, y, z); velocity [m/s] (vx, vy, vz)" in cap
    assert "attitude" not in cap and "bias" not in cap and "against t [s]" in alt


def test_narrow_layout_keeps_every_text_at_its_minimum() -> None:
    """Figures drawn for a phone: no text under the minimum [pt], legends below the axes, 5 inch wide."""
    from sportfusion.core.plots import narrow_layout, series_figure
    from sportfusion.skijump.plots import speed_figure

    table, meta = _jump_table(True)
    with narrow_layout(min_font=11.5):
        for fig in (speed_figure(table, meta), series_figure(table, meta)):
            fig.canvas.draw()
            assert fig.get_figwidth() == pytest.approx(5.0)
            sizes = [t.get_fontsize() for t in fig.findobj(lambda a: hasattr(a, "get_fontsize")) if t.get_text()]
            assert sizes and min(sizes) >= 11.5, min(sizes)
    wide = series_figure(table, meta)
    assert wide.get_figwidth() == pytest.approx(12.0)


def test_reading_the_report_is_in_the_docs_as_on_the_pages() -> None:
    from sportfusion.report.glossary import GLOSSARY, glossary_html, glossary_markdown

    doc = (ROOT / "docs" / "reading-the-report.md").read_text(encoding="utf-8")
    assert glossary_markdown() in doc, "docs/reading-the-report.md holds the pages' glossary word for word"
    html = glossary_html()
    assert all(H.esc(term) in html for term, _ in GLOSSARY)
    for term in ("Moving time", "Max height", "Hold certainty", "Gates matched", "Jump length"):
        assert any(t.startswith(term) for t, _ in GLOSSARY)
    assert "docs/reading-the-report.md" in (ROOT / "README.md").read_text(encoding="utf-8")
