"""Build of the optional C extension; everything else is declared in pyproject.toml.

``sportfusion.estimators._banded_c`` (the smoothing spline's banded solve, selected inverse,
evaluation and arc length) imports in about a millisecond where numba's import and first kernel
load cost about a second of CPU (docs/speed.md).  It is optional: without a C compiler the install
goes on and spline-smooth uses scipy's banded solve and the numba kernels instead (same results).
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "sportfusion.estimators._banded_c",
            sources=["lib/estimators/_banded_c.c"],
            optional=True,
        )
    ]
)
