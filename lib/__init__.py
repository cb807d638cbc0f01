"""sportfusion: trajectories of athletes from wearable sensors and venue knowledge.

The library (import name ``sportfusion``) holds the numerics and the I/O; the
command-line tools in :mod:`sportfusion.tools` are thin wrappers around it.
"""

__version__ = "0.1.0"

from sportfusion.core.errors import InputError  # noqa: E402

__all__ = ["InputError", "__version__"]
