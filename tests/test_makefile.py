"""The Makefile a newcomer meets: one line before the long install, one line for a missing SESSIONS folder."""

from __future__ import annotations

import shutil
import subprocess

import pytest
from conftest import ROOT

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")


def _make(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["make", "--no-print-directory", *args], cwd=ROOT, capture_output=True, text=True, timeout=60)


def test_batch_without_a_sessions_folder_says_what_to_pass(tmp_path):
    res = _make("batch", f"SESSIONS={tmp_path / 'nowhere'}", f"BATCH={tmp_path / 'out'}")
    assert res.returncode != 0 and res.stdout == ""
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, res.stderr
    assert "SESSIONS=dir" in lines[0] and str(tmp_path / "nowhere") in lines[0]
    assert not (tmp_path / "out").exists()


def test_batch_with_a_folder_goes_ahead():
    res = _make("-n", "batch", "SESSIONS=fixtures")
    assert res.returncode == 0, res.stderr
    assert "pipelines/batch.mk SESSIONS=fixtures" in res.stdout


def test_install_announces_itself_before_the_silent_pip(tmp_path):
    venv = tmp_path / "venv"
    res = _make("-n", f"VENV={venv}", f"{venv}/.installed")
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    first_pip = next(i for i, ln in enumerate(lines) if "pip install" in ln)
    assert any("installing dependencies into" in ln and "minutes" in ln for ln in lines[:first_pip])
