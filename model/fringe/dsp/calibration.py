"""What a calibration holds: the stages of the correction, as the float engine (`pipeline`) runs them and
the hardware compilers (`fringe.hardware`) quantise them for the core."""

from dataclasses import dataclass, field

import numpy as np

from ..encoder import Encoder
from .longperiod import FourierSeries
from .quadrature import QuadratureCorrection


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
    canceller: dict = field(default_factory=dict)   # interference canceller: tone_hz, sample_rate_hz, cancel_*
    # the speed the closed loop's speed terms assume for the first sample after reset, before the core has a
    # speed window (fringe_trim START_SPEED): the mean speed of the calibration recording, rev/s, encoder frame
    start_speed_rev_s: float = 0.0
    # the magnitude the closed loop's magnitude terms read: its running average over ~2^k samples (fringe_trim's
    # MAG_SMOOTH_LOG2; 0: the sample's own), chosen on held-out data where a magnitude term is added
    magnitude_smooth_log2: int = 0
    # the speed window of the closed loop's speed and direction terms, 2^k samples (fringe_trim's SPEED_LOG2): None
    # for the generator's default (fixed.trim.speed_window_log2), else chosen on held-out data (a shorter window
    # turns the direction sooner after a reversal, and passes more noise into the speed)
    speed_window_log2: int | None = None
    rev_norm: object | None = None               # offsets/gains over the revolution (effects.RevNormalisation)
    angle_terms: list = field(default_factory=list)   # closed-loop hardware terms (effects.FittedEffect)
    waves: dict = field(default_factory=dict)    # fitted channel models (for reports and plots)
    skipped: list = field(default_factory=list)
    provenance: dict = field(default_factory=dict)
    fit: dict = field(default_factory=dict)


def static_phase(cal: Calibration, sin: np.ndarray, cos: np.ndarray, canceller=None):
    """Fine phase (fraction of a period) and magnitude through the calibration's fixed stages: the
    waveform inverse per channel, the quadrature, the interference canceller (one from reset unless a
    stream's `canceller` is given), the arctan (without the closed loop's revolution normalisation and
    drift tracker, which `pipeline.fine_phase` adds)."""
    xs = cal.inv_sin(sin, cos) if cal.inv_sin is not None else sin
    xc = cal.inv_cos(cos, sin) if cal.inv_cos is not None else cos
    s, c = cal.quad.apply(xs, xc)
    if cal.canceller:
        c, s = (canceller or float_canceller(cal)).run(c, s)
    return (np.arctan2(s, c) / (2 * np.pi)) % 1.0, np.hypot(s, c)


# and cancel_gear_offset (`cancel_gear_offset`)
CANCELLER_KEYS = ("tone_hz", "sample_rate_hz", "cancel_block_log2", "cancel_mu_log2")


def cancel_gear_offset(canceller: dict) -> int:
    """closed_loop.canceller's gear offset (the core's CANCEL_GEAR_OFFSET): 0, the gear shift from 1/2, where a
    calibration written before it has none."""
    return canceller.get("cancel_gear_offset", 0)


def float_canceller(cal: Calibration):
    """The float twin of fringe_canceller for cal.canceller, from reset (dsp/canceller_float.py, CancelFloat)."""
    from ..fixed.canceller import freq_word
    from .canceller_float import CancelFloat
    k = cal.canceller
    return CancelFloat(freq_word(k["tone_hz"], k["sample_rate_hz"]), k["cancel_block_log2"], k["cancel_mu_log2"],
                       cancel_gear_offset(k))
