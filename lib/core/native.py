"""The optional C extensions (``setup.py``): loaded when built, unless ``SPORTFUSION_NATIVE=0``.

Each compiled kernel module keeps its own cache of the result (tests swap it for the fallback);
this is the one place that decides whether an extension is used.
"""

from __future__ import annotations

import importlib
import os
from types import ModuleType


def load_extension(name: str) -> ModuleType | None:
    """The C extension module ``name`` (e.g. ``"sportfusion.skijump._ski_c"``), or None when it is not built
    (no C compiler at install time) or ``SPORTFUSION_NATIVE=0`` asks for the numba/scipy fallbacks."""
    if os.environ.get("SPORTFUSION_NATIVE", "1") == "0":
        return None
    try:
        return importlib.import_module(name)
    except ImportError:
        return None
