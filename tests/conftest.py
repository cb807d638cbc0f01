"""Shared test helpers: run console scripts, build small tables."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from sportfusion.core import io as sfio
from sportfusion.core import meta as sfmeta

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def console_scripts() -> dict[str, str]:
    """Console scripts declared in pyproject.toml: name -> 'module:function'."""
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    return dict(data["project"]["scripts"])


def run_cli(args: list[str], stdin: bytes | None = b"", cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run a console script from this venv with bytes on stdin; capture stdout/stderr as bytes."""
    exe = BIN / args[0]
    return subprocess.run([str(exe), *args[1:]], input=stdin, capture_output=True, cwd=cwd, timeout=300)


def session_bytes(columns: dict[str, object] | None = None, meta: dict | None = None, n: int = 20) -> bytes:
    """A small valid session table as Parquet bytes (t at 100 Hz plus the given columns)."""
    cols: dict[str, object] = {"t": np.arange(n) * 0.01}
    cols.update(columns or {})
    table = pa.table({k: (v if isinstance(v, pa.Array) else pa.array(v)) for k, v in cols.items()})
    return sfio.table_to_bytes(table, meta or sfmeta.new_meta("session", 1.7e9))


@pytest.fixture
def tiny_session() -> bytes:
    return session_bytes()
