"""Build of the optional C extensions; everything else is declared in pyproject.toml.

``sportfusion.skijump._ski_c`` (rts-smooth's EKF + RTS loop) imports in about a millisecond where
numba's import and first kernel load cost about 0.7 s of CPU (docs/speed.md).  It is optional: without
a C compiler the install goes on and rts-smooth uses the numba kernel instead (same results).
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension("sportfusion.skijump._ski_c", sources=["lib/skijump/_ski_c.c"], optional=True),
    ]
)
