"""The climbing C extension (``_climbing_c.c``: the particle filter's forward pass, the backward-simulation
paths, the complementary filter's loop), or None when it is not built or ``SPORTFUSION_NATIVE=0``.

The numpy code in :mod:`sportfusion.climbing.particles` and :mod:`sportfusion.climbing.orientation` is its
reference (``tests/test_climbing_native.py``); tests swap the cached module for None to run that path.
"""

from __future__ import annotations

from types import ModuleType

from sportfusion.core.native import load_extension

_UNSET = object()
_NATIVE: object = _UNSET


def native() -> ModuleType | None:
    """The extension module, loaded once; None without it."""
    global _NATIVE
    if _NATIVE is _UNSET:
        _NATIVE = load_extension("sportfusion.climbing._climbing_c")
    return _NATIVE  # type: ignore[return-value]
