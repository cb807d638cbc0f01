"""What the compiled kernels' modules run before they import numba.

The first time a process loads a cached kernel, numba checks that a BLAS is available for ``np.dot``
and ``np.linalg`` in compiled code by importing ``scipy.linalg.cython_blas``; Python imports the whole
``scipy.linalg`` package first, which costs 0.13-0.35 s of CPU: a tenth of ``rts-smooth``'s start-up
(issue 18).  The check only needs the extension module itself, so :func:`preload_cython_blas` loads that
one file without its package.  Where it cannot (another scipy layout, an import error) it does nothing and
numba imports ``scipy.linalg`` as before; a later ``import scipy.linalg`` works as usual either way.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import sys
from pathlib import Path

_NAME = "scipy.linalg.cython_blas"


def preload_cython_blas() -> bool:
    """Load ``scipy.linalg.cython_blas`` alone into ``sys.modules``; True when it is there afterwards."""
    if _NAME in sys.modules or "scipy.linalg" in sys.modules:
        return _NAME in sys.modules
    try:
        spec = importlib.util.find_spec("scipy")
        if spec is None or not spec.submodule_search_locations:
            return False
        folder = Path(next(iter(spec.submodule_search_locations))) / "linalg"
        path = next(
            (
                folder / f"cython_blas{s}"
                for s in importlib.machinery.EXTENSION_SUFFIXES
                if (folder / f"cython_blas{s}").is_file()
            ),
            None,
        )
        if path is None:
            return False
        own = importlib.util.spec_from_file_location(_NAME, path)
        if own is None or own.loader is None:
            return False
        module = importlib.util.module_from_spec(own)
        own.loader.exec_module(module)
    except Exception:  # noqa: BLE001  (any failure: numba imports scipy.linalg itself, as without this)
        return False
    sys.modules[_NAME] = module
    return True
