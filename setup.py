"""Build of the optional C extensions; everything else is declared in pyproject.toml.

* ``sportfusion.estimators._banded_c``: the smoothing spline's banded solve, selected inverse,
  evaluation and arc length (spline-smooth), and the block-tridiagonal solves (dmc-attitude, pf-holds);
* ``sportfusion.skijump._ski_c``: rts-smooth's EKF + RTS loop;
* ``sportfusion.climbing._climbing_c``: pf-holds' particle filter and backward-simulation paths.

They are the fast path; each kernel has a numpy reference (docs/speed.md).  All are optional: without a C
compiler and Python's headers the install goes on, and the commands run the numpy reference instead (the same
results, slower: rts-smooth by 100-200x), saying so once on stderr (``sportfusion.core.native``);
``SPORTFUSION_NATIVE=0`` forces that path.  Install gcc and the Python headers and run ``pip install -e .``
again to build them.
"""

from setuptools import Extension, setup

BUFFERS = "lib/core/_buffers.h"  # the buffer helpers both 8-byte-item extensions include
QUAT = "lib/core/_quat.h"  # the quaternion -> matrix formula both include

setup(
    ext_modules=[
        Extension("sportfusion.estimators._banded_c", sources=["lib/estimators/_banded_c.c"], optional=True),
        Extension(
            "sportfusion.skijump._ski_c", sources=["lib/skijump/_ski_c.c"], depends=[BUFFERS, QUAT], optional=True
        ),
        Extension(
            "sportfusion.climbing._climbing_c",
            sources=["lib/climbing/_climbing_c.c"],
            depends=[BUFFERS, QUAT],
            optional=True,
        ),
    ]
)
