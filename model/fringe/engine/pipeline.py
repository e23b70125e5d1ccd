"""The float reference of the correction pipeline (`fringe correct --engine float`).

Stages, in hardware order: waveform inverse per channel -> quadrature -> arctan ->
coarse/fine combination or period counting -> long-period correction -> zero and direction.
Each stage is a swappable object of the `Calibration`; the bit-exact engine replaces them
one by one with fixed-point twins.
"""

import dataclasses

import numpy as np

from ..dsp.calibration import Calibration, float_canceller, static_phase
from ..dsp.drift_float import drift_float
from ..dsp.position import coarse_fine_combine, count_periods, overspeed
from ..encoder import ARCSEC_PER_REV
from ..fixed import drift as drift_mod
from ..hardware.closed_loop import build_drift_tables, rev_norm_image
from ..hardware.corefiles import tracker_config
from ..result import AMP_HIGH, AMP_LOW, CLIP_COS, CLIP_SIN, COARSE_ERR, OVERSPEED, Result


def fine_phase(cal: Calibration, sin: np.ndarray, cos: np.ndarray, psi: np.ndarray | None = None):
    if cal.adaptive or cal.canceller:
        # the core's order: the drift tracker and the interference canceller follow the raw readings, and
        # fringe_trim's map subtracts the angle image of the revolution's offsets and gains behind them. Normalising
        # the readings first instead would hide from the tracker what it follows of them in the core, and the map
        # would take that part out a second time; the canceller, which adapts on the Lissajous radius, would not
        # see the radius the offsets move (population 9018, offsets of 46x the floor beside a 65 Hz tone at
        # reversals: the float engine 0.80", the core 1.88", the core's constants chosen on the float's order)
        frac, mag = tracked_phase(cal, sin, cos) if cal.adaptive else static_phase(cal, sin, cos)
        if cal.rev_norm is not None and psi is not None:
            frac = (frac - rev_norm_image(cal, psi, 2 * np.pi * frac)) % 1.0
        return frac, mag
    if cal.rev_norm is not None and psi is not None:
        sin, cos = cal.rev_norm.apply(sin, cos, psi)
    return static_phase(cal, sin, cos)


def tracked_phase(cal: Calibration, sin: np.ndarray, cos: np.ndarray):
    """Fine phase with the online offset/gain tracker in front of the tables (the float twin of the core's drift
    tracker, docs/drift.md): per block of samples the normalised readings are compared with the calibrated
    waveform at the measured phase; the mean error steps the offset, its correlation with the waveform the gain;
    the new values apply from a fixed sample on, causal as in the hardware. The tracker's equations without
    rounding (dsp/drift_float.py), with the forward tables of the core configuration's defaults. Returns
    (fraction of a period, magnitude)."""
    r, mags, scale = _tracked(cal, sin, cos)
    return r["phase"] / scale, mags


def tracked_readings(cal: Calibration, sin: np.ndarray, cos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The readings as the tables see them behind the online tracker (its normalised sine and cosine, ADC codes):
    what a channel-domain test compares with the calibrated waveform when the calibration tracks drift."""
    r, _, _ = _tracked(cal, sin, cos)
    return r["y_sin"], r["y_cos"]


def tracker_activity(cal: Calibration, sin: np.ndarray, cos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per block of the online tracker on these readings: whether it updated, and how much of a signal period its
    window (the samples its sweep test measures) swept, in periods."""
    r, _, scale = _tracked(cal, sin, cos)
    p = tracker_config(cal).drift_params()
    steps = np.abs(np.mod(np.diff(r["phase"], prepend=r["phase"][:1]) / scale + 0.5, 1.0) - 0.5)
    ends = p.b * np.arange(1, len(r["updated"]) + 1)
    return r["updated"], np.array([steps[e - p.w:e].sum() for e in ends])


def _tracked(cal: Calibration, sin: np.ndarray, cos: np.ndarray):
    cfg = tracker_config(cal)
    p = cfg.drift_params()
    t = build_drift_tables(cal, cfg)
    plain = dataclasses.replace(cal, adaptive=False)
    scale = float(1 << cfg.fine_w)
    words = np.stack([drift_mod.pack_words(v, p) for v in t.fwd])

    mags = []       # drift_float feeds every sample once, in order
    stream = float_canceller(cal) if cal.canceller else None

    def phase_of(ys, yc):
        frac, mag = static_phase(plain, ys, yc, stream)
        mags.append(mag)
        return frac * scale

    r = drift_float(sin, cos, phase_of, p, words, t.w0, t.kg)
    return r, (np.concatenate(mags) if mags else np.zeros(0)), scale


def run_starts(t: np.ndarray | None, n: int) -> np.ndarray | None:
    """Samples that start a new run of consecutive samples: a step in time over 1.5 times the median (rows taken
    out of a recording, as the closed loop's interleaved halves and the cross-validation folds are). The
    combination's track must not bridge such a gap: the motion across it is unknown."""
    if t is None or n < 3:
        return None
    dt = np.diff(np.asarray(t, float))
    step = float(np.median(dt))
    if not step > 0:
        return None
    return np.concatenate([[False], (dt > 1.5 * step) | (dt <= 0)])


def encoder_position(cal: Calibration, frac: np.ndarray, coarse: np.ndarray | None, t: np.ndarray | None = None):
    """Position in periods [0, lines) and the flags of the combination (t: the time stamps, whose gaps restart
    the coarse/fine track)."""
    enc = cal.encoder
    if enc.coarse_bits and coarse is not None and cal.coarse_offset_periods is not None:
        pos, coarse_err = coarse_fine_combine(frac, coarse, enc.lines_per_rev, enc.coarse_bits,
                                              cal.coarse_offset_periods, run_starts(t, len(frac)))
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
    pos, coarse_err, fast = encoder_position(cal, frac, coarse, t)
    if cal.rev_norm is not None:     # the position in the revolution from a first pass selects the gains
        frac, mag = fine_phase(cal, sin, cos, 2 * np.pi * pos / enc.lines_per_rev)
        pos, coarse_err, fast = encoder_position(cal, frac, coarse, t)
    counted = pos     # the position the terms see (fringe_trim's input): the result's context, as the core's
    if cal.angle_terms:
        from ..dsp.effects import make_context
        ctx = make_context(frac, pos, enc.lines_per_rev, sample_times(len(frac), t), mag, cal.start_speed_rev_s,
                           cal.magnitude_smooth_log2, cal.speed_window_log2)
        correction = sum(term.predict(ctx) for term in cal.angle_terms)
        # the terms model the error of the output angle: map it back into the encoder's direction
        pos = (pos - cal.direction * correction / ARCSEC_PER_REV * enc.lines_per_rev) % enc.lines_per_rev
    lo, hi = -enc.adc_half_range, enc.adc_half_range - 1
    status = (np.where((sin <= lo) | (sin >= hi), CLIP_SIN, 0)
              | np.where((cos <= lo) | (cos >= hi), CLIP_COS, 0)
              | np.where(mag < cal.amp_low, AMP_LOW, 0) | np.where(mag > cal.amp_high, AMP_HIGH, 0)
              | np.where(fast, OVERSPEED, 0) | np.where(coarse_err, COARSE_ERR, 0))
    return Result(output_angle(cal, pos), status.astype(np.int64), frac, counted, mag)
