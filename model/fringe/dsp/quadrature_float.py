"""``fringe_quadrature``'s float twin: the correction of ``fixed/quadrature.py`` (``quadrature``, the bit-exact
model) without rounding or saturation, the reference of its ``error_budget``."""

import numpy as np

__all__ = ["quadrature_float"]


def quadrature_float(xs, xc, k_ss, k_sc, k_cc, ofs_s, ofs_c):
    """Float reference in any consistent units (no rounding, no saturation): (s, c)."""
    xs = np.asarray(xs, dtype=float)
    xc = np.asarray(xc, dtype=float)
    return k_ss * (xs - ofs_s) + k_sc * (xc - ofs_c), k_cc * (xc - ofs_c)
