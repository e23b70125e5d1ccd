"""A reference from the motion itself: the true phase moves smoothly in time.

The seed fits its waveforms to samples taken at equal phase steps, which a constant-speed
rotation gives for free. This is the same idea for any smooth trajectory: the measured,
unwrapped phase is a smooth function of time (a cubic spline with knots a couple of signal
periods apart) plus a periodic error of the phase (the interpolation error, a Fourier series
in the phase). The spline is too stiff to follow an error that repeats every period, so
alternating the two fits separates them. Samples too slow for that separation (near
reversals) are left out of the periodic fit.
"""

import numpy as np
from scipy.interpolate import LSQUnivariateSpline

from .fourierfit import fit_select

KNOT_PERIODS = 2.0      # knot spacing, in signal periods passed at the median speed


class MotionTooSlow(ValueError):
    pass


def smooth_motion_phase(theta_rad: np.ndarray, t: np.ndarray, harmonics: int = 31,
                        iterations: int = 3) -> tuple[np.ndarray, dict]:
    """Estimate the true (unwrapped) phase from a measured one with a periodic error."""
    total = np.unwrap(np.asarray(theta_rad, float)) / (2 * np.pi)     # periods
    t = np.asarray(t, float)
    if np.any(np.diff(t) <= 0):
        raise ValueError("time stamps must increase strictly")
    speed = np.abs(np.gradient(total, t))
    v_med = float(np.median(speed))
    if not v_med > 0 or (t[-1] - t[0]) * v_med < 8 * KNOT_PERIODS:
        raise MotionTooSlow("the recording passes too few signal periods to separate the motion from "
                            "the interpolation error")
    h = KNOT_PERIODS / v_med
    knots = np.arange(t[0] + h, t[-1] - h / 2, h)
    fast = speed >= 0.5 * v_med
    warp = np.zeros_like(total)
    info = {"knot_spacing_s": h, "median_speed_periods_s": v_med, "samples_used": int(fast.sum())}
    for _ in range(iterations):
        spline = LSQUnivariateSpline(t, total - warp, knots, k=3)
        resid = total - spline(t)
        series, n, rms = fit_select(2 * np.pi * total[fast], resid[fast], harmonics)
        series.weights[0] = 0.0          # a constant belongs to the motion, not to the phase error
        warp = series(2 * np.pi * total)
        info.update(harmonics=n, residual_rms_periods=rms)
    return 2 * np.pi * (total - warp), info
