"""Error figures: the angle against the reference, split into interpolation and long-period parts."""

from dataclasses import dataclass

import numpy as np

from .encoder import ARCSEC_PER_REV
from .position import circular_mean, wrap


def error_arcsec(angle_deg: np.ndarray, ref_deg: np.ndarray, direction: int = 1) -> np.ndarray:
    """Angle minus reference (arcsec), the constant zero offset removed (spec section 3).

    `direction` = -1 compares against a reference that runs the other way.
    """
    d = wrap(np.asarray(angle_deg) / 360.0 - direction * np.asarray(ref_deg) / 360.0)
    return wrap(d - circular_mean(d)) * ARCSEC_PER_REV


def binned_mean(values: np.ndarray, where: np.ndarray, bins: int) -> np.ndarray:
    """Mean of `values` in `bins` equal bins of `where` (a fraction in [0, 1)); NaN for empty bins."""
    idx = np.minimum((np.mod(where, 1.0) * bins).astype(np.int64), bins - 1)
    count = np.bincount(idx, minlength=bins)
    total = np.bincount(idx, values, minlength=bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


@dataclass
class ErrorFigures:
    rms_arcsec: float
    pp_arcsec: float
    interp_pp_arcsec: float      # systematic, binned over the fine phase (64 bins a period)
    lp_pp_arcsec: float          # systematic, binned over the revolution (64 bins, as seed 000)
    lp_sigma_arcsec: float       # sample sigma of the 64 long-period points (seed 000 eq. 21)

    def to_dict(self) -> dict:
        return {k: round(float(v), 4) for k, v in self.__dict__.items()}


def error_figures(err: np.ndarray, fine_frac: np.ndarray, rev_frac: np.ndarray, bins: int = 64) -> ErrorFigures:
    """Systematic parts are bin means: noise averages out, a repeatable error does not.

    The interpolation part is taken after removing the long-period part (and vice versa), so
    each figure sees only its own error.
    """
    lp = binned_mean(err, rev_frac, bins)
    lp_each = np.interp(np.mod(rev_frac, 1.0), (np.arange(bins) + 0.5) / bins, lp, period=1.0)
    interp = binned_mean(err - lp_each, fine_frac, bins)
    lp_clean = binned_mean(err - np.interp(np.mod(fine_frac, 1.0), (np.arange(bins) + 0.5) / bins, interp,
                                           period=1.0), rev_frac, bins)
    return ErrorFigures(rms_arcsec=float(np.sqrt(np.mean(err ** 2))), pp_arcsec=float(np.ptp(err)),
                        interp_pp_arcsec=float(np.nanmax(interp) - np.nanmin(interp)),
                        lp_pp_arcsec=float(np.nanmax(lp_clean) - np.nanmin(lp_clean)),
                        lp_sigma_arcsec=float(np.nanstd(lp_clean, ddof=1)))
