"""sportfusion command-line tools: one thin click command per file.

Importing the package (every console script does, before numpy) sets OpenBLAS, MKL and OpenMP to one
thread unless the user set them: the commands' linear algebra is on small matrices, where extra BLAS
threads only spin -- on a 2-core machine they added ~0.3 s of CPU to an rts-smooth run (issue 18).
Set ``OPENBLAS_NUM_THREADS`` (or ``OMP_NUM_THREADS``) yourself to override.

In a console script's process it also pauses Python's cyclic garbage collector while the command's
modules import: numpy, pyarrow, click and the library create objects that live as long as the process,
and the ~60 young-generation collections that sweep them cost ~20 ms of CPU on a 2-core machine (a
tenth of a ``--help``; issue 18).  :class:`sportfusion.tools._cli.CleanExit` freezes what the imports made and turns
the collector back on before the command parses its options.  Imported any other way (a test, a
notebook) the package leaves the collector alone.
"""

import gc as _gc
import os as _os
import sys as _sys

for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

#: The console scripts (pyproject.toml's ``[project.scripts]``; tests/test_startup.py checks that they agree).
COMMANDS = frozenset(
    (
        "ingest",
        "inspect",
        "video-jumplength",
        "gps2hill",
        "plot",
        "spline-smooth",
        "dmc-attitude",
        "evaluate",
        "simulate",
        "detect-events",
        "pf-holds",
        "rts-smooth",
        "jump-metrics",
        "gate-anchor",
        "body-model",
        "compare-runs",
        "report",
    )
)

#: Whether this import paused the collector (a console script's process); CleanExit.main resumes it.
GC_PAUSED = bool(getattr(_sys, "argv", None)) and _os.path.basename(_sys.argv[0]) in COMMANDS and _gc.isenabled()
if GC_PAUSED:
    _gc.disable()


def resume_gc() -> None:
    """Turn the collector back on after a console script's imports (a no-op where they did not pause it).

    What the imports made is frozen first (:func:`gc.freeze`): later collections never sweep it again.
    """
    global GC_PAUSED
    if GC_PAUSED:
        GC_PAUSED = False
        _gc.freeze()
        _gc.enable()
