"""Every paper a tool's help cites by short name is cited in full in that help, and in the README."""

from __future__ import annotations

import importlib
import re

import click
import pytest
from click.testing import CliRunner
from conftest import ROOT, console_scripts

from sportfusion.data.papers import PAPERS

#: inspect cites nothing.
SKIP = {"inspect"}
SHORTHAND = {
    "skijump": re.compile(r"ski-?jump(ing)? paper|skijump (§|App|eq|Table)", re.I),
    "skiracing-splines": re.compile(r"skiracing-splines|ski racing splines paper|racing splines paper", re.I),
    "gates": re.compile(r"gates paper", re.I),
    "climbing": re.compile(r"climbing paper", re.I),
}


def _commands() -> list[tuple[str, click.Command]]:
    out = []
    for name, target in console_scripts().items():
        if name in SKIP:
            continue
        mod, func = target.split(":")
        cmd = getattr(importlib.import_module(mod), func)
        out.append((name, cmd))
        if isinstance(cmd, click.Group):
            out += [(f"{name} {sub}", c) for sub, c in cmd.commands.items()]
    return out


@pytest.mark.parametrize(("name", "cmd"), _commands(), ids=[n for n, _ in _commands()])
def test_help_cites_its_papers_in_full(name, cmd):
    args = name.split()[1:] + ["--help"]
    root = cmd if len(name.split()) == 1 else None
    if root is None:
        top = name.split()[0]
        mod, func = console_scripts()[top].split(":")
        root = getattr(importlib.import_module(mod), func)
    res = CliRunner().invoke(root, args, terminal_width=200)
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())
    own = " ".join([cmd.help or ""] + [getattr(p, "help", None) or "" for p in cmd.params])  # not subcommands'
    for key, pattern in SHORTHAND.items():
        if pattern.search(own):
            doi_or_title = PAPERS[key].split(". ")[1][:40]
            assert f"[{key}]" in text and doi_or_title in text, (name, key)


def test_readme_cites_the_four_papers_in_full():
    readme = " ".join((ROOT / "README.md").read_text().split())
    for key, ref in PAPERS.items():
        assert ref in readme, key
    assert "10.3390/s20071995" in readme and "10.3389/fphys.2018.01203" in readme
