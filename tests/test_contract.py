"""Command-line contract of DESIGN.md, parametrised over every console script."""

from __future__ import annotations

import importlib
import tempfile
from pathlib import Path

import click
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import console_scripts, run_cli, session_bytes

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta

SCRIPTS = console_scripts()
#: Tools that accept any table (no required columns beyond the table kind's).
ACCEPTS_ANY = {"inspect"}


def _commands() -> list[tuple[list[str], click.Command]]:
    """(argv prefix, click command) for every leaf command, group subcommands included."""
    out = []
    for name, target in sorted(SCRIPTS.items()):
        module, func = target.split(":")
        cmd = getattr(importlib.import_module(module), func)
        if isinstance(cmd, click.Group):
            out.append(([name], cmd))
            out += [([name, sub], c) for sub, c in sorted(cmd.commands.items())]
        else:
            out.append(([name], cmd))
    return out


COMMANDS = _commands()
IDS = [" ".join(a) for a, _ in COMMANDS]
READERS = [(a, c) for a, c in COMMANDS if any(p.name == "input" for p in c.params)]
READER_IDS = [" ".join(a) for a, _ in READERS]


@pytest.mark.parametrize(("argv", "cmd"), COMMANDS, ids=IDS)
def test_help_has_units_free_example(argv, cmd):
    res = run_cli([*argv, "--help"])
    assert res.returncode == 0, res.stderr
    text = res.stdout.decode()
    assert "Example" in text
    assert "Usage:" in text


@pytest.mark.parametrize("name", sorted(SCRIPTS))
def test_version(name):
    res = run_cli([name, "--version"])
    assert res.returncode == 0
    assert "sportfusion" in res.stdout.decode()


def _one_error_line(res, tool: str) -> str:
    assert res.returncode == 1, (res.returncode, res.stderr)
    assert res.stdout == b""
    lines = [ln for ln in res.stderr.decode().splitlines() if ln.strip()]
    errors = [ln for ln in lines if ln.startswith("Error:")]
    assert len(errors) == 1, lines
    assert errors[0].startswith(f"Error: {tool}: ")
    assert "internal error" not in errors[0], errors[0]
    assert "Traceback" not in res.stderr.decode()
    return errors[0]


@pytest.mark.parametrize(("argv", "cmd"), READERS, ids=READER_IDS)
def test_empty_input(argv, cmd):
    _one_error_line(run_cli([*argv, *_extra(argv)], stdin=b""), cmd.name)


@pytest.mark.parametrize(("argv", "cmd"), READERS, ids=READER_IDS)
def test_non_parquet_input(argv, cmd):
    _one_error_line(run_cli([*argv, *_extra(argv)], stdin=b"t,acc_x\n0,1\n"), cmd.name)


@pytest.mark.parametrize(("argv", "cmd"), READERS, ids=READER_IDS)
def test_table_without_metadata(argv, cmd):
    sink = pa.BufferOutputStream()
    pq.write_table(pa.table({"t": [0.0, 0.01]}), sink)
    line = _one_error_line(run_cli([*argv, *_extra(argv)], stdin=sink.getvalue().to_pybytes()), cmd.name)
    assert "metadata" in line


@pytest.mark.parametrize(
    ("argv", "cmd"),
    [r for r in READERS if r[1].name not in ACCEPTS_ANY],
    ids=[i for i, r in zip(READER_IDS, READERS, strict=True) if r[1].name not in ACCEPTS_ANY],
)
def test_missing_required_column(argv, cmd):
    line = _one_error_line(run_cli([*argv, *_extra(argv)], stdin=session_bytes()), cmd.name)
    assert "column" in line or "missing" in line


@pytest.mark.parametrize(("argv", "cmd"), READERS, ids=READER_IDS)
def test_terminal_refused_is_usage_error(argv, cmd):
    # stdin is not a terminal here, so emulate one with a pty on stdin
    import os
    import pty
    import subprocess

    from conftest import BIN

    master, slave = pty.openpty()
    try:
        res = subprocess.run(
            [str(BIN / argv[0]), *argv[1:], *_extra(argv)], stdin=slave, capture_output=True, timeout=120
        )
    finally:
        os.close(master)
        os.close(slave)
    assert res.returncode == 2
    assert res.stdout == b""
    assert "terminal" in res.stderr.decode()


def test_bad_time_column_names_column(tmp_path):
    table = pa.table({"t": [0.0, 0.02, 0.01]})
    data = sfio.table_to_bytes(table, sfmeta.new_meta("session"))
    res = run_cli(["inspect"], stdin=data)
    line = _one_error_line(res, "inspect")
    assert "'t'" in line and "strictly increasing" in line


_PNG = str(Path(tempfile.gettempdir()) / "sportfusion-contract.png")
_FIX = Path(__file__).resolve().parents[1] / "fixtures"
#: Extra arguments a tool needs before it reads its input (side inputs); filled as tools land.
EXTRA: dict[str, list[str]] = {
    # without --kind detect-events takes the kind from the metadata, and this bare session names none
    "detect-events": ["--kind", "grips"],
    # the athlete's height and mass are required
    "body-model": ["--height", "1.8", "--mass", "78"],
    # plot writes an image, so its output file is required
    "plot track": ["-o", _PNG],
    "plot speed": ["-o", _PNG],
    "plot series": ["-o", _PNG],
    "plot mag": ["-o", _PNG],
    "plot spline": ["-o", _PNG],
    "plot errors": ["-o", _PNG, "--truth", str(_FIX / "skijump" / "truth.parquet")],
    "plot gates": ["-o", _PNG, "--gates", str(_FIX / "skijump" / "truth.parquet")],
    "plot body": ["-o", _PNG],
    "plot holds": ["-o", _PNG, "--holds", str(_FIX / "skijump" / "truth.parquet")],
    "plot compare": ["-o", str(Path(tempfile.gettempdir()) / "sportfusion-contract-compare.png")],
    # report writes an HTML page
    "report": ["-o", str(Path(tempfile.gettempdir()) / "sportfusion-contract-report.html")],
}


def _extra(argv: list[str]) -> list[str]:
    return EXTRA.get(" ".join(argv), [])
