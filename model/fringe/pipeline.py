"""The float reference of the correction pipeline (`fringe correct --engine float`).

Stages, in hardware order: waveform inverse per channel -> quadrature -> arctan ->
coarse/fine combination or period counting -> long-period correction -> zero and direction.
Each stage is a swappable object of the `Calibration`; the bit-exact engine replaces them
one by one with fixed-point twins.
"""

from dataclasses import dataclass, field

import numpy as np

from .encoder import ARCSEC_PER_REV, Encoder
from .longperiod import FourierSeries
from .position import coarse_fine_combine, count_periods, overspeed
from .quadrature import QuadratureCorrection

# status bits (docs/architecture.md)
CLIP_SIN, CLIP_COS, AMP_LOW, AMP_HIGH, OVERSPEED, COARSE_ERR, SATURATED, BANK = (1 << i for i in range(8))
STATUS_NAMES = ["CLIP_SIN", "CLIP_COS", "AMP_LOW", "AMP_HIGH", "OVERSPEED", "COARSE_ERR", "SATURATED", "BANK"]


@dataclass
class Calibration:
    """Everything the pipeline needs; stages left as None are skipped (identity)."""

    encoder: Encoder
    inv_sin: object | None = None        # callable (reading, other reading) -> ideal sine value
    inv_cos: object | None = None
    quad: QuadratureCorrection = field(default_factory=QuadratureCorrection)
    coarse_offset_periods: float | None = None
    long_period: FourierSeries | None = None    # encoder error (arcsec) against its own angle (rad)
    direction: int = 1                           # -1: the output runs the other way (the reference's)
    zero_deg: float = 0.0                        # added last, in the output direction
    amp_low: float = 0.5                         # loss-of-signal thresholds on the corrected magnitude
    amp_high: float = 1.5
    adaptive: bool = False                       # online offset/gain tracker (closed loop: drift)
    tracker: dict = field(default_factory=dict)  # its constants chosen on the data: drift_block_log2, drift_mu_log2
    rev_norm: object | None = None               # offsets/gains over the revolution (effects.RevNormalisation)
    angle_terms: list = field(default_factory=list)   # closed-loop hardware terms (effects.FittedEffect)
    waves: dict = field(default_factory=dict)    # fitted channel models (for reports and plots)
    skipped: list = field(default_factory=list)
    provenance: dict = field(default_factory=dict)
    fit: dict = field(default_factory=dict)


@dataclass
class Result:
    angle_deg: np.ndarray       # corrected output angle, [0, 360)
    status: np.ndarray          # int status word per sample
    frac: np.ndarray            # fine phase, fraction of a period
    position: np.ndarray        # encoder position before long-period correction, periods [0, lines)
    magnitude: np.ndarray       # corrected vector magnitude (1 nominal)


def fine_phase(cal: Calibration, sin: np.ndarray, cos: np.ndarray, psi: np.ndarray | None = None):
    if cal.rev_norm is not None and psi is not None:
        sin, cos = cal.rev_norm.apply(sin, cos, psi)
    if cal.adaptive:
        from .effects import tracked_phase
        return tracked_phase(cal, sin, cos)
    xs = cal.inv_sin(sin, cos) if cal.inv_sin is not None else sin
    xc = cal.inv_cos(cos, sin) if cal.inv_cos is not None else cos
    s, c = cal.quad.apply(xs, xc)
    return (np.arctan2(s, c) / (2 * np.pi)) % 1.0, np.hypot(s, c)


def encoder_position(cal: Calibration, frac: np.ndarray, coarse: np.ndarray | None):
    """Position in periods [0, lines) and the flags of the combination."""
    enc = cal.encoder
    if enc.coarse_bits and coarse is not None and cal.coarse_offset_periods is not None:
        pos, coarse_err = coarse_fine_combine(frac, coarse, enc.lines_per_rev, enc.coarse_bits,
                                              cal.coarse_offset_periods)
        return pos, coarse_err, overspeed(frac)
    pos, fast = count_periods(frac, enc.lines_per_rev)
    return pos, np.zeros(len(frac), bool), fast


def output_angle(cal: Calibration, position: np.ndarray) -> np.ndarray:
    """Long-period correction, then direction and zero: degrees in [0, 360)."""
    rev = position / cal.encoder.lines_per_rev
    if cal.long_period is not None:
        rev = rev - cal.long_period(2 * np.pi * rev) / ARCSEC_PER_REV
    return (cal.direction * rev * 360.0 + cal.zero_deg) % 360.0


def sample_times(n: int, t: np.ndarray | None) -> np.ndarray:
    """The recording's time stamps, or the sample index when it has none."""
    return np.arange(n, dtype=float) if t is None else np.asarray(t, float)


def run_float(cal: Calibration, sin: np.ndarray, cos: np.ndarray, coarse: np.ndarray | None = None,
              t: np.ndarray | None = None) -> Result:
    enc = cal.encoder
    frac, mag = fine_phase(cal, sin, cos)
    pos, coarse_err, fast = encoder_position(cal, frac, coarse)
    if cal.rev_norm is not None:     # the position in the revolution from a first pass selects the gains
        frac, mag = fine_phase(cal, sin, cos, 2 * np.pi * pos / enc.lines_per_rev)
        pos, coarse_err, fast = encoder_position(cal, frac, coarse)
    if cal.angle_terms:
        from .effects import make_context
        ctx = make_context(frac, pos, enc.lines_per_rev, sample_times(len(frac), t), mag)
        correction = sum(term.predict(ctx) for term in cal.angle_terms)
        # the terms model the error of the output angle: map it back into the encoder's direction
        pos = (pos - cal.direction * correction / ARCSEC_PER_REV * enc.lines_per_rev) % enc.lines_per_rev
    lo, hi = -enc.adc_half_range, enc.adc_half_range - 1
    status = (np.where((sin <= lo) | (sin >= hi), CLIP_SIN, 0)
              | np.where((cos <= lo) | (cos >= hi), CLIP_COS, 0)
              | np.where(mag < cal.amp_low, AMP_LOW, 0) | np.where(mag > cal.amp_high, AMP_HIGH, 0)
              | np.where(fast, OVERSPEED, 0) | np.where(coarse_err, COARSE_ERR, 0))
    return Result(output_angle(cal, pos), status.astype(np.int64), frac, pos, mag)
