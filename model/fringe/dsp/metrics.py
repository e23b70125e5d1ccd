"""Error figures: the angle against the reference, split into interpolation and long-period parts."""

from dataclasses import dataclass

import numpy as np

from ..encoder import ARCSEC_PER_REV
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


def split_error(err: np.ndarray, fine_frac: np.ndarray, rev_frac: np.ndarray, fine_bins: int = 64,
                rev_bins: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Interpolation curve (bin means over the fine phase) and long-period curve (over the revolution).

    Each is taken after removing the other, so that uneven phase coverage in a revolution bin
    (a reversal dwells at one phase) does not leak the interpolation error into it, and back.
    """
    centres = lambda bins: (np.arange(bins) + 0.5) / bins  # noqa: E731
    lp = binned_mean(err, rev_frac, rev_bins)
    lp_each = np.interp(np.mod(rev_frac, 1.0), centres(rev_bins), np.nan_to_num(lp), period=1.0)
    interp = binned_mean(err - lp_each, fine_frac, fine_bins)
    interp_each = np.interp(np.mod(fine_frac, 1.0), centres(fine_bins), np.nan_to_num(interp), period=1.0)
    return interp, binned_mean(err - interp_each, rev_frac, rev_bins)


def error_figures(err: np.ndarray, fine_frac: np.ndarray, rev_frac: np.ndarray, bins: int = 64) -> ErrorFigures:
    """Systematic parts are bin means: noise averages out, a repeatable error does not."""
    interp, lp = split_error(err, fine_frac, rev_frac, bins, bins)
    return ErrorFigures(rms_arcsec=float(np.sqrt(np.mean(err ** 2))), pp_arcsec=float(np.ptp(err)),
                        interp_pp_arcsec=float(np.nanmax(interp) - np.nanmin(interp)),
                        lp_pp_arcsec=float(np.nanmax(lp) - np.nanmin(lp)),
                        lp_sigma_arcsec=float(np.nanstd(lp, ddof=1)))
