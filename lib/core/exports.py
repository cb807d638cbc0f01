"""Lazy re-exports for the packages' entry modules (PEP 562), so ``import sportfusion.skijump`` stays cheap.

A sport's ``__init__`` names its public functions and where they live; the defining module (and scipy,
OpenCV behind it) is imported on first use of the name, not when any submodule of the package is.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, exports: Mapping[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for a package that re-exports names lazily.

    Parameters
    ----------
    package : str
        The package's ``__name__`` (for the error message).
    exports : mapping
        Public name -> ``"module"`` or ``"module:attribute"`` (the attribute's name in its module
        when it differs from the public one).
    """

    def __getattr__(name: str) -> Any:
        where = exports.get(name)
        if where is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, _, attr = where.partition(":")
        return getattr(importlib.import_module(module), attr or name)

    def __dir__() -> list[str]:
        return sorted(exports)

    return __getattr__, __dir__
