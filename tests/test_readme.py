"""What a new user reads: the README's commands write into out/, its Python snippet runs, its links and
the docs/ they point to exist, and docs/table-contract.md agrees with the column registry."""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

from sportfusion.core import schema

README = (ROOT / "README.md").read_text()
DOCS = ROOT / "docs"


def _block(section: str, lang: str) -> str:
    part = README[README.index(section) :]
    start = part.index(f"```{lang}\n") + len(lang) + 4
    return part[start : part.index("```", start)]


def _targets(script: str) -> list[str]:
    """Files a shell block writes: redirections and the -o / side-output options of each command."""
    code = "\n".join(line.split("#")[0] for line in script.splitlines())  # comments say "-> one session"
    joined = code.replace("\\\n", " ")
    out = re.findall(r"(?<![<>&\d])>\s*(\S+)", joined)
    for line in joined.splitlines():
        words = shlex.split(line.split("#")[0]) if line.strip() and not line.strip().startswith("#") else []
        for i, w in enumerate(words[:-1]):
            if w == "-o" or (words[0] == "simulate" and w in ("--gates", "--truth")):
                out.append(words[i + 1])
    return out


def test_the_by_hand_pipeline_writes_only_into_out():
    script = _block("## A pipeline by hand", "sh")
    targets = _targets(script)
    assert len(targets) >= 8, targets
    assert all(t.startswith("out/") for t in targets), [t for t in targets if not t.startswith("out/")]
    assert "mkdir -p out" in script
    race = _block("## Race analysis", "sh")
    assert all(t.startswith("out/") for t in _targets(race)), _targets(race)


@pytest.mark.slow
def test_the_by_hand_pipeline_runs(tmp_path):
    """Run the README's block as written, in an empty folder holding only fixtures/: every file lands in out/."""
    (tmp_path / "fixtures").symlink_to(ROOT / "fixtures")
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}", "MPLBACKEND": "Agg"}
    res = subprocess.run(
        ["bash", "-euo", "pipefail", "-c", _block("## A pipeline by hand", "sh")],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fixtures", "out"]
    for name in _targets(_block("## A pipeline by hand", "sh")):
        assert (tmp_path / name).stat().st_size > 0, name
    assert "take-off speed" in res.stdout and "km/h" in res.stdout


def test_the_python_snippet_reads_units_and_metadata(monkeypatch):
    pytest.importorskip("pandas")
    code = _block("## Reading a table from Python", "python")
    monkeypatch.chdir(ROOT)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        exec(compile(code, "README.md", "exec"), {})
    lines = buf.getvalue().splitlines()
    assert lines[0] == "session 312.6 m/s^2 deg"
    assert "lat" in lines[1] and "utc" in lines[1]
    assert "2026-01-05 13:00:00" in lines[2]  # the first GNSS fix, on the UTC clock
    assert lines[-1].startswith("['simulate")


def test_links_resolve_and_nothing_points_outside_the_project():
    texts = {"README.md": README} | {f"docs/{p.name}": p.read_text() for p in DOCS.glob("*.md")}
    for name in ("formats.md", "table-contract.md", "frames.md", "hills.md"):
        assert (DOCS / name).is_file(), name
    # other helpers' recording notes: linked by file name from formats.md (present once they land)
    for name in ("recordings-gnss.md", "recordings-imu.md", "recordings-watch.md"):
        assert f"({name})" in texts["docs/formats.md"]
    for where, text in texts.items():
        assert "shared folder" not in text and "ref/formats.md" not in text and "DESIGN.md" not in text, where
        for link in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
            if link.startswith("http") or link.startswith("recordings-"):
                continue
            assert ((ROOT / where).parent / link).resolve().exists(), (where, link)


def test_the_contract_doc_agrees_with_the_column_registry():
    text = (DOCS / "table-contract.md").read_text()
    table = text[text.index("| column | unit | meaning |") :].split("\n\n")[0].splitlines()[2:]
    checked = 0
    for row in table:
        cells = [c.strip() for c in row.strip("|").split("|")]
        names = re.findall(r"`([a-z0-9_]+)`", cells[0])
        for name in names:
            col = schema.lookup(name)
            assert col is not None, name
            assert col.unit == cells[1], (name, col.unit, cells[1])
            checked += 1
    assert checked > 40


def test_library_and_tool_docs_point_into_the_project():
    """Docstrings and help name docs/ files, never the development folder users do not have."""
    for path in [*(ROOT / "lib").rglob("*.py"), *(ROOT / "tools").glob("*.py")]:
        text = path.read_text()
        for bad in ("shared/ref", "ref/formats.md", "DESIGN.md", "papers-errata"):
            assert bad not in text, (str(path.relative_to(ROOT)), bad)


def test_every_doc_is_listed_in_the_documentation_section():
    section = README[README.index("## Documentation\n") : README.index("## Papers")]
    listed = set(re.findall(r"\(docs/([a-z0-9-]+\.md)\)", section))
    assert listed == {p.name for p in DOCS.glob("*.md")}, sorted({p.name for p in DOCS.glob("*.md")} ^ listed)
