"""The optional C extensions (``setup.py``): loaded when built, unless ``SPORTFUSION_NATIVE=0``.

Two implementations of every compiled kernel exist: the numpy reference (the readable statement of the
algorithm, and the tests' oracle) and the C extension (the fast path).  Each kernel module keeps its own
cache of the result (tests swap it for the reference); this is the one place that decides whether an
extension is used.

Where one is not built (no C compiler or no Python headers when the package was installed: ``setup.py``
builds them as optional, so the install goes on) or ``SPORTFUSION_NATIVE=0`` asks for the numpy path, the
first module that asks says so once per process, in one line on stderr: which path runs, about how much
slower it is (:data:`SLOWER`, measured in docs/speed.md) and how to build the extensions.
"""

from __future__ import annotations

import importlib
import os
import sys
from types import ModuleType

#: What runs slower without each extension, and about how much (CPU time of the whole command, the numpy path
#: against C: docs/speed.md, "Compiled paths").
SLOWER = {
    "sportfusion.skijump._ski_c": "rts-smooth 15-80x slower: about 1.5 ms per IMU step instead of 20 us",
    "sportfusion.estimators._banded_c": (
        "spline-smooth 1.5-10x slower, 10 s instead of 1 s at 1e6 epochs; dmc-attitude and pf-holds 1.1-1.5x"
    ),
    "sportfusion.climbing._climbing_c": "pf-holds about 1.5x slower",
}

#: how to build them (README.md, "Two commands")
BUILD = "install a C compiler and Python's headers (e.g. apt install gcc python3-dev) and run pip install -e . again"

_told = False


def notice(name: str, disabled: bool) -> str:
    """The one line said when the extension ``name`` is not used (``disabled``: SPORTFUSION_NATIVE=0)."""
    slower = SLOWER.get(name, "slower")
    if disabled:
        return (
            f"sportfusion: SPORTFUSION_NATIVE=0: the compiled kernels are not used; running the numpy path ({slower})"
        )
    return (
        f"sportfusion: the compiled kernels are not built ({name} is missing); running the numpy path ({slower}); "
        f"to build them, {BUILD}"
    )


def _tell(name: str, disabled: bool) -> None:
    global _told
    if not _told:
        _told = True
        try:
            sys.stderr.write(notice(name, disabled) + "\n")
        except (OSError, ValueError):  # stderr closed: nothing to say it on
            pass


def load_extension(name: str) -> ModuleType | None:
    """The C extension module ``name`` (e.g. ``"sportfusion.skijump._ski_c"``), or None when it is not built
    (no C compiler at install time) or ``SPORTFUSION_NATIVE=0`` asks for the numpy path; either is said once
    per process on stderr (:func:`notice`)."""
    if os.environ.get("SPORTFUSION_NATIVE", "1") == "0":
        _tell(name, disabled=True)
        return None
    try:
        return importlib.import_module(name)
    except ImportError:
        _tell(name, disabled=False)
        return None
