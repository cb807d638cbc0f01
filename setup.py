"""Build of the optional C extensions; everything else is declared in pyproject.toml.

* ``sportfusion.estimators._banded_c``: the smoothing spline's banded solve, selected inverse,
  evaluation and arc length (spline-smooth);
* ``sportfusion.skijump._ski_c``: rts-smooth's EKF + RTS loop;
* ``sportfusion.climbing._climbing_c``: pf-holds' particle filter and backward-simulation paths.

Each imports in about a millisecond where numba's import and first kernel load cost 0.7-1 s of CPU
(docs/speed.md).  Both are optional: without a C compiler and Python's headers the install goes on and
the commands use scipy and the numba kernels instead (same results; ``SPORTFUSION_NATIVE=0`` forces
that path).
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
