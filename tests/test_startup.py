"""Start-up cost as a property: importing a command's module loads none of the heavy libraries.

``--help`` and a no-op stage should cost about ``import numpy, pyarrow``; scipy's signal/optimize/linalg/...,
OpenCV, matplotlib and pyproj are imported where a command body uses them.  This checks the property (which modules are loaded), never a time.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import sportfusion.tools

HEAVY = (
    "scipy.signal",
    "scipy.optimize",
    "scipy.linalg",
    "scipy.ndimage",
    "scipy.interpolate",
    "scipy.integrate",
    "scipy.sparse",
    "scipy.spatial",
    "cv2",
    "matplotlib",
    "pyproj",
)

TOOLS = sorted(p.stem for p in Path(sportfusion.tools.__file__).parent.glob("*.py") if not p.stem.startswith("_"))

PROBE = """
import importlib, json, sys
heavy = {heavy!r}
out = {{}}
for name in {tools!r}:
    importlib.import_module("sportfusion.tools." + name)
    out[name] = sorted(m for m in heavy if m in sys.modules)
print(json.dumps(out))
"""


def test_every_tool_is_listed() -> None:
    assert len(TOOLS) >= 15 and "rts_smooth" in TOOLS and "simulate" in TOOLS


def test_tool_modules_import_no_heavy_library() -> None:
    # one fresh interpreter, tools imported one after another: the first one that pulls a heavy
    # module in is named (later ones would inherit it, so the first non-empty entry is the culprit)
    res = subprocess.run(
        [sys.executable, "-c", PROBE.format(heavy=HEAVY, tools=TOOLS)], capture_output=True, text=True, check=True
    )
    loaded = json.loads(res.stdout)
    assert set(loaded) == set(TOOLS)
    culprits = {name: mods for name, mods in loaded.items() if mods}
    assert not culprits, f"importing these tool modules loads heavy modules: {culprits}"


def test_probe_detects_a_heavy_import() -> None:
    # the probe itself can fail: importing a module that needs scipy.linalg is seen
    res = subprocess.run(
        [sys.executable, "-c", "import sys, scipy.linalg; print('scipy.linalg' in sys.modules)"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert res.stdout.strip() == "True"


def test_commands_run_blas_on_one_thread_unless_the_user_says_otherwise() -> None:
    import os

    prog = "import os, sportfusion.tools; print(os.environ['OPENBLAS_NUM_THREADS'], os.environ['OMP_NUM_THREADS'])"
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", prog], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["1", "1"]
    env["OPENBLAS_NUM_THREADS"] = "4"
    out = subprocess.run([sys.executable, "-c", prog], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["4", "1"]


def test_the_collector_pause_names_every_console_script() -> None:
    from conftest import console_scripts

    assert sportfusion.tools.COMMANDS == set(console_scripts())


PAUSE = """
import gc, sys
sys.argv[0] = {argv0!r}
import sportfusion.tools as t
paused = not gc.isenabled()
t.resume_gc()
print(paused, t.GC_PAUSED, gc.isenabled(), gc.get_freeze_count() > 0)
"""


def test_a_console_script_imports_with_the_collector_paused_and_resumes_it() -> None:
    # the console script's path names the command: the package pauses the collector while modules import,
    # resume_gc freezes what they made and turns it back on
    out = subprocess.run(
        [sys.executable, "-c", PAUSE.format(argv0="/venv/bin/rts-smooth")], capture_output=True, text=True, check=True
    )
    assert out.stdout.split() == ["True", "False", "True", "True"]
    # any other process (python -c, a test run, a notebook) keeps its collector as it was
    out = subprocess.run([sys.executable, "-c", PAUSE.format(argv0="-c")], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False", "True", "False"]


def test_a_command_resumes_the_collector_however_it_is_run(monkeypatch) -> None:
    import gc

    from click.testing import CliRunner

    from sportfusion.tools.inspect_cmd import main

    gc.disable()
    monkeypatch.setattr(sportfusion.tools, "GC_PAUSED", True)
    try:
        CliRunner().invoke(main, ["--help"])
        assert gc.isenabled() and not sportfusion.tools.GC_PAUSED
    finally:
        gc.enable()
        gc.unfreeze()
