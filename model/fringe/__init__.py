"""fringe: signal correction for sin/cos (moire-fringe) encoders.

The package is the golden model of the fringe core: an encoder simulator, the
calibration (waveform inversion, quadrature, long-period error), the float
reference of the correction pipeline and, later, its bit-exact twin.
"""

import os

# The fits are narrow (at most a few hundred columns): a multi-threaded BLAS gains little on them and, on a
# shared machine, spins its threads against the other processes (a 4096 x 72 Gram took 30x longer).
# Set before numpy is first imported; an explicit setting of the caller stands.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"
