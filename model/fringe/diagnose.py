"""Does the recording agree with the encoder description and with itself?

Run before calibration, so that a wrong `lines_per_rev`, swapped channels, a reference in radians
or with a jump is named as such, instead of surfacing later as a failed fit of sound signals.
The fine phase used here is the raw one (channels centred and scaled by their extremes): its
error of a few percent of a period is far below what these checks look for.
"""

import numpy as np

from .dataio import Measurement
from .encoder import Encoder
from .errors import FringeInputError

SCALE_OK = (0.8, 1.25)        # motion ratios accepted as "the same motion"
MIN_PERIODS = 0.9             # less motion than about a period: the raw phase itself is not sound
JUMP_PERIODS = 0.25           # a reference step this much larger than the signals' step is a jump
REVERSED_MAX = 0.05           # fraction of the motion in which the reference may run the other way


def raw_phase_periods(meas: Measurement) -> np.ndarray:
    """Unwrapped fine phase in signal periods from the raw channels."""
    def centred(v):
        lo, hi = np.percentile(v, [0.5, 99.5])
        return (v - (hi + lo) / 2) / max((hi - lo) / 2, 1e-12)

    return np.unwrap(np.arctan2(centred(meas.sin), centred(meas.cos))) / (2 * np.pi)


def _where(meas: Measurement, row: int) -> str:
    return meas.row_line(row)


def check_recording(meas: Measurement, enc: Encoder, purpose: str = "calibration"):
    """FringeInputError for a recording that cannot be what the encoder description says."""
    if enc.coarse_bits and meas.coarse is None:
        raise FringeInputError(f"the encoder declares coarse_bits = {enc.coarse_bits} but the recording has no "
                               "'coarse' column (add it, or set coarse_bits to 0 to count periods)", meas.path)
    if len(meas) < 16:
        return
    phase = raw_phase_periods(meas)
    if np.ptp(phase) < MIN_PERIODS:
        return
    step = np.abs(np.diff(phase))
    if np.median(step) > 0.2:    # near the overspeed limit the raw phase cannot be unwrapped: calibration says so
        return
    codes_passed = np.ptp(phase) * (1 << enc.coarse_bits) / enc.lines_per_rev
    if enc.coarse_bits and meas.coarse is not None and np.ptp(phase) >= 2 and codes_passed >= 4:
        _check_coarse(meas, enc, phase)
    if meas.ref_deg is not None and purpose == "calibration":
        _check_reference(meas, enc, phase)


def _slope(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Least-squares slope of y on x, and the RMS of what it leaves."""
    xc, yc = x - x.mean(), y - y.mean()
    a = float(np.dot(xc, yc) / max(np.dot(xc, xc), 1e-300))
    return a, float(np.sqrt(np.mean((yc - a * xc) ** 2)))


def _check_coarse(meas: Measurement, enc: Encoder, phase: np.ndarray):
    codes = 1 << enc.coarse_bits
    span = enc.lines_per_rev / codes                       # periods per coarse code
    coarse = np.unwrap(meas.coarse.astype(float), period=codes) * span
    a, rest = _slope(phase, coarse)
    if rest > 0.5 + span:
        raise FringeInputError(f"the coarse code does not follow the fine phase (it scatters {rest:.3g} periods "
                               "about it): random codes, another encoder's, or the wrong coarse_bits?",
                               meas.path, "column 'coarse'")
    if -SCALE_OK[1] <= a <= -SCALE_OK[0]:
        raise FringeInputError("the fine phase runs against the coarse code: sin and cos swapped, or one channel "
                               "inverted?", meas.path, "columns 'sin', 'cos'")
    if not SCALE_OK[0] <= a <= SCALE_OK[1]:
        raise FringeInputError(f"the coarse code moves {a:.3g} times as far as the fine phase with lines_per_rev = "
                               f"{enc.lines_per_rev} and coarse_bits = {enc.coarse_bits}: one of them is wrong",
                               meas.path, "column 'coarse'")


def _check_reference(meas: Measurement, enc: Encoder, phase: np.ndarray):
    ref, lines = meas.ref_deg, enc.lines_per_rev
    signal_deg = phase * 360.0 / lines
    if np.max(np.abs(ref)) <= 2 * np.pi + 1e-9 and np.ptp(signal_deg) > 20:
        a, _ = _slope(signal_deg, np.degrees(np.unwrap(ref)))
        if SCALE_OK[0] <= abs(a) <= SCALE_OK[1]:
            raise FringeInputError("ref_deg looks like radians (it moves 57.3 times less than the signals): "
                                   "convert it to degrees", meas.path, "column 'ref_deg'")
    ref_u = np.unwrap(ref, period=360.0)
    d_ref, d_sig = np.diff(ref_u), np.diff(signal_deg)
    sign = 1.0 if np.dot(d_ref, d_sig) >= 0 else -1.0
    miss = d_ref - sign * d_sig
    scale = 1.4826 * np.median(np.abs(miss - np.median(miss)))
    jumps = np.flatnonzero(np.abs(miss) > max(20 * scale, JUMP_PERIODS * 360.0 / lines))
    if jumps.size and jumps.size < 0.01 * len(miss):
        r = jumps[0] + 1
        raise FringeInputError(f"ref_deg jumps by {d_ref[r - 1]:.6g} deg while the signals move "
                               f"{sign * d_sig[r - 1]:.3g} deg", meas.path, _where(meas, r))
    window = max(1, int(np.ceil(0.1 / max(np.median(np.abs(np.diff(phase))), 1e-9))))  # about 0.1 period
    idx = np.arange(0, len(ref_u), window)
    w_ref, w_sig = np.diff(ref_u[idx]), np.diff(signal_deg[idx])
    moving = np.abs(w_sig) > 0.05 * 360.0 / lines
    if moving.sum() >= 10:
        against = (np.sign(w_ref[moving]) != np.sign(sign * w_sig[moving]))
        if REVERSED_MAX < against.mean() < 1 - REVERSED_MAX:
            first = idx[1:][moving][np.argmax(against)]
            raise FringeInputError(f"the reference runs against the signals in {100 * against.mean():.0f} % of the "
                                   "motion: a reversed part of ref_deg?", meas.path, _where(meas, int(first)))
    a, _ = _slope(signal_deg, ref_u)
    if not SCALE_OK[0] <= abs(a) <= SCALE_OK[1]:
        guess = lines / abs(a) if abs(a) > 1e-9 else float("inf")
        hint = (f"lines_per_rev is probably about {guess:.0f}, not {lines}" if 0.5 <= guess <= (1 << 24)
                else "is ref_deg in degrees?")
        raise FringeInputError(f"the reference moves {abs(a):.4g} times as far as the signals with lines_per_rev = "
                               f"{lines}: {hint} (or ref_deg is not in degrees)", meas.path, "column 'ref_deg'")
