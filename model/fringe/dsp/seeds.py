"""Constants taken from the two seed papers (../shared/seeds/), with their provenance.

Seed 001: Feng et al., "Interpolation error correction of moire fringe photoelectric
signals in the approximate form of triangle wave", Acta Optica Sinica 33(8) 0812001, 2013.
Seed 000: Feng et al., "Correction of long-period error for small photoelectric encoders",
Optics and Precision Engineering 22(9) 2491, 2014.
"""

import numpy as np

# Seed 001, Table 1: Fourier coefficients of the two normalised channel waveforms, odd orders
# 1..23. The sine channel is sum f_n sin(n*theta), the cosine channel sum c_n cos(n*phi).
# The printed rows 19 and 21 of the sine column read -0.008 and -0.003, ten times larger than
# their neighbours and than the decay the text describes (n > 23 negligible): taken as the
# misprints of -0.0008 and -0.0003.
SEED001_ORDERS = np.arange(1, 24, 2)
SEED001_SIN_COEFFS = np.array([0.8933, -0.0923, -0.0006, -0.0088, -0.0032, -0.0021,
                               0.0012, -0.0016, -0.0010, -0.0008, -0.0003, 0.0001])
SEED001_COS_COEFFS = np.array([0.9070, 0.0565, 0.0126, 0.0039, 0.0040, 0.0019,
                               0.0014, 0.0008, 0.0007, 0.0006, 0.0001, 0.0001])
SEED001_F0 = {"sin": 0.0000, "cos": 0.0001}   # DC level
SEED001_F2 = {"sin": 0.0001, "cos": 0.0002}   # 2nd harmonic (sin 2theta / cos 2phi)
SEED001_PHASE_ERROR_RAD = -0.00013            # alpha of eq. 15: u_s = sin(theta - alpha)
SEED001_LINES = 256                           # 256 lines/rev, 8 coarse + 8 fine bits
SEED001_PP_BEFORE_ARCSEC = 162.5              # measured interpolation error, p-p, before
SEED001_PP_AFTER_ARCSEC = 47.5                # and after the seed's correction

# Seed 000, Table 1: the trained Fourier network weights, in the order of eqs. 7-8:
# w1 = a0/2, w2..w10 = a1..a9 (cosine), w11..w19 = b1..b9 (sine). They are normalised:
# the paper's measured curve runs from +45" to -17.5" (sigma 20.3").
SEED000_WEIGHTS = np.array([0.4748, -0.5335, -0.1654, -0.0187, 0.0450, -0.0124, -0.0127,
                            0.0050, -0.0012, 0.0075, -0.2343, -0.1413, 0.0138, -0.0258,
                            -0.0375, 0.0111, -0.0189, -0.0122, -0.0002])
SEED000_MAX_ARCSEC = 45.0
SEED000_MIN_ARCSEC = -17.5
SEED000_SIGMA_ARCSEC = 20.3


def fourier_network(weights: np.ndarray, x_rad: np.ndarray) -> np.ndarray:
    """Seed 000 eq. 11: w1 + sum_l (w_{l+1} cos(l x) + w_{n+l+1} sin(l x)), x in radians.

    Evaluated with the recurrence e^{i l x} = e^{i x} e^{i (l-1) x}: one exponential per sample.
    """
    weights = np.asarray(weights, dtype=float)
    n = (len(weights) - 1) // 2
    x = np.asarray(x_rad, dtype=float)
    y = np.full(x.shape, weights[0])
    if n == 0:
        return y
    z = np.exp(1j * x)
    p = z.copy()
    for l in range(1, n + 1):
        y += weights[l] * p.real + weights[n + l] * p.imag
        if l < n:
            p *= z
    return y


def seed000_error_arcsec(x_rad: np.ndarray) -> np.ndarray:
    """The seed encoder's long-period error (arcsec) at mechanical angle x (rad).

    The normalised Table 1 curve mapped linearly so that its extremes over the revolution
    are the paper's +45" and -17.5".
    """
    grid = np.linspace(0, 2 * np.pi, 1 << 16, endpoint=False)
    ref = fourier_network(SEED000_WEIGHTS, grid)
    lo, hi = ref.min(), ref.max()
    scale = (SEED000_MAX_ARCSEC - SEED000_MIN_ARCSEC) / (hi - lo)
    return SEED000_MIN_ARCSEC + (fourier_network(SEED000_WEIGHTS, x_rad) - lo) * scale
