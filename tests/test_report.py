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


@pytest.mark.slow
@pytest.mark.parametrize("sport", SPORTS)
def test_session_page_is_valid_self_contained_and_shows_the_tools_figures(pages: Path, sport: str) -> None:
    text = (pages / sport / "report.html").read_text(encoding="utf-8")
    c = check_page(text)
    assert c.imgs >= 2
    assert len(text.encode()) < 1_500_000, "a page to mail: under 1.5 MB"
    assert (
        "#0072b2"
        in "".join(__import__("base64").b64decode(m).decode() for m in re.findall(r"base64,([^\"]+)\"", text)).lower()
    ), "the figures use the Okabe-Ito palette"
    assert "<details>" in text and "Provenance" in text
    head = c.headline_text
    table, meta = sfio.read_table(pages / sport / f"{RESULT[sport]}.parquet")
    assert detect_sport(table, meta) == sport
    if sport == "skijump":
        jumps, _ = sfio.read_table(pages / sport / "jumps.parquet", kind="jumps")
        j = jumps.to_pylist()[0]
        assert f"{_fmt(j['jump_length'])} m" in head and f"{_fmt(j['takeoff_speed'])} m/s" in head
        assert f"{_fmt(j['flight_time'])} s" in head and f"{3.6 * j['takeoff_speed']:.1f} km/h" in head
    elif sport == "skirace":
        speed = table.column("speed").to_numpy(zero_copy_only=False)
        assert f"{_fmt(float(np.nanmax(speed)))} m/s" in head
        assert f"{float(np.nanmax(table.column('distance').to_numpy(zero_copy_only=False))):.0f} m" in head
    elif sport == "gates":
        n = sum(e == "gate" for e in table.column("event").to_pylist())
        assert re.search(rf"Gates passed\s+{n}\b", head)
        turn_len = [v for v in table.column("turn_length").to_pylist() if v is not None]
        assert turn_len and all(f"{_fmt(v)} m" in text for v in turn_len)
    else:
        ids = {h for h in table.column("hold_id").to_pylist() if h is not None and h >= 0}
        assert re.search(rf"Holds reached\s+{len(ids)}\b", head)
    # the evaluation table shows evaluate's numbers
    ev, _ = sfio.read_table(pages / sport / "evaluation.parquet", kind="summary")
    row = next(r for r in ev.to_pylist() if r["phase"] == "all" and r["stat"] == "rms")
    assert f"{row['x']:.3f} m" in text


def test_number_formatting_has_units_and_no_nan() -> None:
    assert H.number(float("nan"), "m") == "–" and H.number(None, "m") == "–"
    assert H.number(89.558, "m") == "89.56 m"
    assert H.speed(25.0) == "25.00 m/s (90.0 km/h)"
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
    links = re.findall(r'href="([^"]+)"', text)
    assert sorted(links) == sorted(f"{n}/report.html" for n in SPORTS)
    assert all((out / link).exists() for link in links)
    assert "4 of 5 sessions ok, 1 failed" in text and "standard input is not a Parquet file" in text


def _browser():  # noqa: ANN202
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    chromium, driver = shutil.which("chromium"), shutil.which("chromedriver")
    assert chromium and driver, "make test installs Debian's chromium and chromium-driver for this test"
    opts = webdriver.ChromeOptions()
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"):
        opts.add_argument(a)
    opts.binary_location = chromium
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver), options=opts)


@pytest.mark.slow
def test_pages_in_a_real_browser_at_phone_width(pages: Path, tmp_path: Path) -> None:
    d = _browser()
    try:
        d.set_window_size(390, 844)
        for sport in SPORTS:
            d.get((pages / sport / "report.html").as_uri())
            errors = [e for e in d.get_log("browser") if e.get("level") == "SEVERE"]
            assert errors == [], errors
            inner = d.execute_script("return window.innerWidth")
            assert d.execute_script("return document.body.scrollWidth") <= inner, "no sideways scrolling"
            box = d.find_element("css selector", ".headline")
            assert box.is_displayed() and box.rect["y"] < d.execute_script("return window.innerHeight")
            first = d.find_element("css selector", ".headline .value")
            assert re.search(r"\d", first.text) and first.rect["y"] + first.rect["height"] < 844
            shot = tmp_path / f"{sport}-phone.png"
            d.save_screenshot(str(shot))
            assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
            imgs = d.execute_script("return Array.from(document.images).map(i => i.naturalWidth > 0)")
            assert imgs and all(imgs), "every embedded figure decodes"
    finally:
        d.quit()
