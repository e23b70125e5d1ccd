"""fringe: signal correction for sin/cos (moire-fringe) encoders.

The package is the golden model of the fringe core: an encoder simulator, the
calibration (waveform inversion, quadrature, long-period error), the float
reference of the correction pipeline and, later, its bit-exact twin.
"""

__version__ = "0.1.0"
