"""The README's library example runs as written (from the repository root) and gives a plausible jump."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_readme_library_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks, "the README has no python example"
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        scope: dict[str, object] = {}
        exec(compile(blocks[0], "README.md", "exec"), scope)  # noqa: S102 - our own README
    finally:
        os.chdir(cwd)
    lengths = scope["jumps"].column("jump_length").to_pylist()  # type: ignore[attr-defined]
    assert len(lengths) == 1 and 60.0 < lengths[0] < 120.0
