"""sportfusion command-line tools: one thin click command per file.

Importing the package (every console script does, before numpy) sets OpenBLAS, MKL and OpenMP to one
thread unless the user set them: the commands' linear algebra is on small matrices, where extra BLAS
threads only spin -- on a 2-core machine they added ~0.3 s of CPU to an rts-smooth run (issue 18).
Set ``OPENBLAS_NUM_THREADS`` (or ``OMP_NUM_THREADS``) yourself to override.
"""

import os as _os

for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")
