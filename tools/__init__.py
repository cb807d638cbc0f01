"""sportfusion command-line tools: one thin click command per file.

Importing the package (every console script does, before numpy) sets OpenBLAS, MKL and OpenMP to one
thread unless the user set them: the commands' linear algebra is on small matrices, where extra BLAS
threads only spin -- on a 2-core machine they added ~0.3 s of CPU to an rts-smooth run (issue 18).
Set ``OPENBLAS_NUM_THREADS`` (or ``OMP_NUM_THREADS``) yourself to override.

In a console script's process it installs the signal handlers of the output layer first (SIGINT,
SIGTERM, SIGHUP: temporaries removed, no traceback, exit 128 + signal number) and holds the number of a
closed standard stream with /dev/null.  It also pauses Python's cyclic garbage collector while the command's
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

#: Whether this process is a console script (the first import of every command's process).
CONSOLE = bool(getattr(_sys, "argv", None)) and _os.path.basename(_sys.argv[0]) in COMMANDS

if CONSOLE:
    # SIGINT, SIGTERM, SIGHUP from here on: no traceback (also while the command's modules import), the
    # temporaries of unfinished outputs removed, exit 128 + the signal number (sportfusion.core.outputs)
    from sportfusion.core.outputs import install_signal_handlers as _install

    _install()
    # a standard stream closed by the caller (>&-, <&-): its number is held by /dev/null, opened the wrong
    # way round (reads and writes fail), so no file the command opens later takes it (a table written "to
    # stdout" would land in an input file); Python already set sys.stdin/sys.stdout to None, which the
    # frame refuses in one line (tools._cli)
    for _fd, _flags in ((0, _os.O_WRONLY), (1, _os.O_RDONLY), (2, _os.O_WRONLY)):
        try:
            _os.fstat(_fd)
        except OSError:
            try:
                _held = _os.open(_os.devnull, _flags)
                if _held != _fd:
                    _os.dup2(_held, _fd, inheritable=False)
                    _os.close(_held)
            except OSError:
                pass

#: Whether this import paused the collector (a console script's process); CleanExit.main resumes it.
GC_PAUSED = CONSOLE and _gc.isenabled()
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
