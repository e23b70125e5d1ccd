"""Calibration: fit every stage of the pipeline from one recording.

1. Reference-free (seed 001): a conic fit gives a first phase. The seed fits its waveforms to
   samples at equal phase steps; here the phase reference comes from the motion being smooth
   in time (`smoothmotion`), so any trajectory will do. Each channel is fitted against it
   (all harmonics), inverted, the quadrature re-fitted and the phase recomputed, twice.
2. Coarse/fine synchronisation from the fine phase at the coarse code's edges.
3. With `ref_deg`: direction and zero, the long-period error (seed 000's Fourier network,
   solved in closed form by least squares, its size chosen on held-out data), and then the
   waveform refitted against the reference's phase with all harmonics (odd, even, both phases),
   alternating with the long-period fit until both settle.

With one signal period per revolution (lines_per_rev = 1) the long-period table after the
arctan is itself a table over the fine phase, and can carry the whole phase error instead of
the per-channel waveform inverse. The per-channel inverse assumes a fixed amplitude: a common
gain change leaves atan2 untouched but moves every table lookup, so where the amplitude
changes the phase-domain table holds and the inverse does not. With more lines the phase-table
structure puts the phase error in fringe_trim's fine-phase map (fit_phase_tables). Which structure
serves is decided on held-out data (cross-validation over interleaved blocks of the recording), for
every encoder with a reference.

Held-out choices (the structure, the long-period order) start from a default (the phase table for one
line, the per-channel inverse for more; LP_DEFAULT_HARMONICS) and leave it only where the held-out gain is
significant: near its minimum a held-out curve is flat, and on a short recording its argmin follows the
folds' noise.
"""

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.stats import f as f_dist

from ..dsp.calibration import Calibration
from ..dsp.effects import FINE_MAP_PREFIX, FittedEffect, generic_name, parse_generic, phase_columns
from ..dsp.fourierfit import CoverageError, cv_folds, cv_harmonics, fit_select, paired_gain_t, significant_choice
from ..dsp.metrics import error_arcsec
from ..dsp.position import circular_mean, fit_coarse_offset, without_slips, wrap
from ..dsp.quadrature import QuadratureCorrection, QuadratureFitError, fit_conic, fit_seed_ellipse, shape_phase_error
from ..dsp.smoothmotion import MotionTooSlow, interruptions, smooth_motion_phase
from ..dsp.waveform import ChannelWaveform, PaperChannel, WaveformInverse, build_inverse, is_invertible
from ..encoder import ARCSEC_PER_REV, Encoder
from ..engine.pipeline import encoder_position, fine_phase, run_float, run_starts
from ..errors import FringeInputError
from ..io.dataio import Measurement

MIN_SAMPLES = 64
# clipped samples are left out of every fit; a recording is refused only where they hide part of the
# waveform: some electrical phase (one of CLIP_PHASE_BINS) keeps under MIN_UNCLIPPED_SHARE of its samples
CLIP_PHASE_BINS = 64
MIN_UNCLIPPED_SHARE = 0.1
WAVEFORM, PHASE_TABLE = "waveform", "phase_table"   # structures of the reference calibration
# comparing structures on held-out data: 2..5 folds, as many as keep the calibrated samples per
# candidate within STRUCTURE_BUDGET (short recordings get more folds, hence steadier scores);
# longer recordings than STRUCTURE_SAMPLES are compared on every k-th sample (a structure's held-out
# gain shows on tens of thousands of samples; the choice is made for every encoder, so it is kept cheap)
STRUCTURE_BUDGET = 50_000
STRUCTURE_SAMPLES = 50_000
LP_ORDER_FOLDS = 10       # folds of the long-period order selection (cheap: binned data)
LP_SAMPLES_PER_HARMONIC = 16   # held-out order selection offers at most one harmonic per this many samples
# The long-period order the calibration keeps unless held-out data show a significant gain elsewhere: the
# order of the plain fit an engineer with a reference makes first (conic + 16 harmonics of the measured angle,
# bench_real.PLAIN_HARMONICS, issue 9). Held-out curves are flat near their minimum, and on short recordings
# their argmin follows the folds' noise and interference (up to 7 % worse than this order on the RM44 files).
LP_DEFAULT_HARMONICS = 16
# held-out folds are runs of at least this many samples: half the period of the highest harmonic offered at
# uniform motion (LP_SAMPLES_PER_HARMONIC), so every offered harmonic is still sampled within its period around
# each hole, while interference near the Nyquist frequency cancels over a run instead of leaking into the fit
# through single-sample holes (which made the RM44 files' held-out curves favour 8-9 harmonics against 16-25
# on the other half of the rows)
CV_MIN_RUN = LP_SAMPLES_PER_HARMONIC // 2
# significance of a held-out gain over the default (order or structure): one-sided, family-wise over the
# candidates (Bonferroni), from CV_BATCHES paired batch means of contiguous held-out errors
CV_ALPHA = 0.05
CV_BATCHES = 32


@dataclass
class CalibrationOptions:
    motion_iterations: int = 2
    shape_iterations: int = 3        # without motion: passes of the Lissajous-shape phase reference
    shape_correction: bool = True    # False: without motion, correct the conic only
    ref_iterations: int = 2
    wave_harmonics_max: int = 31     # general model: BIC chooses up to this many
    lp_harmonics_max: int = 64       # cross-validation chooses up to this many
    # "cv": held-out error; "bic": in-sample BIC; "default": LP_DEFAULT_HARMONICS (fewer where the samples are few)
    lp_order_selection: str = "cv"
    # WAVEFORM (per-channel inverse) or PHASE_TABLE (the waveform stage straight: a common gain change
    # then moves no angle; lines_per_rev = 1: the long-period table carries the phase error, else the
    # closed loop's fine-phase map in fringe_trim); None: chosen on held-out data where both apply
    structure: str | None = None
    # PHASE_TABLE: move the centre to where gain changes move no angle (centre_from_gain_changes);
    # None: chosen on held-out data together with the structure
    gain_centre: bool | None = None
    table_points: int | None = None  # None: one point per ADC code, at most 2^16 + 1
    # closed loop: error already explained by other terms (arcsec, encoder frame, per sample), kept
    # out of the long-period fit and added to the reference phase of the waveform fit
    known_error_arcsec: np.ndarray | None = None
    # PHASE_TABLE: the conic from the channels' offsets and fundamentals (conic_from_fundamentals); off in the
    # structure choice's folds, where it costs a second fit of the tables and changes no score within one recording
    # (it matters at amplitudes the recording does not have)
    conic_from_fundamentals: bool = True


def _fail(meas: Measurement, problem: str):
    raise FringeInputError(problem, meas.path)


def check_recording(meas: Measurement, enc: Encoder) -> np.ndarray:
    """Refuse what cannot be calibrated; return the mask of samples usable for fitting."""
    if len(meas) < MIN_SAMPLES:
        _fail(meas, f"too few samples: {len(meas)} (calibration needs at least {MIN_SAMPLES})")
    for name, v in (("sin", meas.sin), ("cos", meas.cos)):
        if np.ptp(v) == 0:
            _fail(meas, f"no signal: column '{name}' is {float(v[0]):g} on every row (sensor unplugged or no motion?)")
    lo, hi = -enc.adc_half_range, enc.adc_half_range - 1
    clipped = (meas.sin <= lo) | (meas.sin >= hi) | (meas.cos <= lo) | (meas.cos >= hi)
    if clipped.any():
        s, c = meas.sin.astype(float), meas.cos.astype(float)
        phase = np.arctan2(s - (s.max() + s.min()) / 2, c - (c.max() + c.min()) / 2)
        bins = ((phase / (2 * np.pi) + 0.5) * CLIP_PHASE_BINS).astype(int) % CLIP_PHASE_BINS
        total = np.bincount(bins, minlength=CLIP_PHASE_BINS)
        kept = np.bincount(bins[~clipped], minlength=CLIP_PHASE_BINS)
        hidden = (total > 0) & (kept < MIN_UNCLIPPED_SHARE * total)
        if hidden.any():
            first = int(np.argmax(clipped))
            _fail(meas, f"{int(clipped.sum())} of {len(meas)} samples are clipped at the ADC limits (first: "
                        f"{meas.row_line(first)}), all of them near some phases; reduce the gain: clipped samples "
                        "hide the waveform")
    return ~clipped


def _phase(cal: Calibration, meas: Measurement) -> tuple[np.ndarray, np.ndarray]:
    frac, mag = fine_phase(cal, meas.sin, meas.cos)
    return 2 * np.pi * frac, mag


def _table_grid(enc: Encoder, points: int | None) -> tuple[float, float, int]:
    half = enc.adc_half_range
    n = points or min(2 * half + 1, (1 << 16) + 1)
    return -float(half), float(half), n


def _set_waveforms(cal: Calibration, ws, wc, enc: Encoder, opts: CalibrationOptions):
    lo, hi, n = _table_grid(enc, opts.table_points)
    cal.waves = {"sin": ws, "cos": wc}
    cal.inv_sin = build_inverse(ws, wc, lo, hi, n)
    cal.inv_cos = build_inverse(wc, ws, lo, hi, n)


def _within_swing(cal: Calibration, meas: Measurement) -> np.ndarray:
    """The samples whose two readings both lie within their fitted waveform's swing. Beyond it the tables
    continue the inverse's slope (waveform.build_inverse), right for an additive disturbance and wrong for a
    gain that drifted past the fitted one; inside it the tables read the waveform itself."""
    ok = np.ones(len(meas), bool)
    grid = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    for kind, reading in (("sin", meas.sin), ("cos", meas.cos)):
        wave = cal.waves[kind](grid)
        ok &= (reading >= wave.min()) & (reading <= wave.max())
    return ok


MIN_WITHIN_SWING = 0.5   # below this share within the swing, the quadrature fit keeps every sample


def _fit_quadrature(cal: Calibration, meas: Measurement, use: np.ndarray, seed_form: bool = False):
    """The quadrature conic on the samples `use` (a mask or indices), only those within the waveforms' swing
    where there are waveform tables: a drifting recording's samples beyond the swing pulled the conic
    (population 9053: drift and vibration, 4.45x -> 18x the plain floor with continued tables)."""
    if cal.waves and isinstance(cal.inv_sin, WaveformInverse) and isinstance(cal.inv_cos, WaveformInverse):
        use = np.asarray(use)
        mask = use if use.dtype == bool else np.isin(np.arange(len(meas)), use)
        kept = mask & _within_swing(cal, meas)
        if kept.sum() >= MIN_WITHIN_SWING * mask.sum():
            use = kept
    xs = cal.inv_sin(meas.sin[use], meas.cos[use]) if cal.inv_sin is not None else meas.sin[use]
    xc = cal.inv_cos(meas.cos[use], meas.sin[use]) if cal.inv_cos is not None else meas.cos[use]
    try:
        cal.quad = fit_seed_ellipse(xs, xc) if seed_form else fit_conic(xs, xc)
    except QuadratureFitError as e:
        _fail(meas, str(e))


def _fit_waveforms(meas: Measurement, use: np.ndarray, phi: np.ndarray, opts: CalibrationOptions,
                   invertible: bool = False) -> dict:
    """Both channels' models against a phase reference `phi` (rad, per sample).

    `invertible`: fewer harmonics than BIC chose where needed, so that each channel keeps one rising
    and one falling half per period, which its two tables can invert."""
    hmax = max(1, min(opts.wave_harmonics_max, int(use.sum()) // 16))
    fits = {}
    for kind, y in (("sin", meas.sin), ("cos", meas.cos)):
        series, n, _ = fit_select(phi[use], y[use], hmax)
        if n < 1:
            _fail(meas, f"the {kind} channel does not follow the phase: no signal?")
        while invertible and n > 1 and not is_invertible(ChannelWaveform(kind, series.weights)):
            n -= 1
            series, _, _ = fit_select(phi[use], y[use], hmax, n_fixed=n)
        fits[kind] = ChannelWaveform(kind, series.weights)
    return fits


def _refit_waveforms(cal: Calibration, meas: Measurement, use: np.ndarray, phi: np.ndarray,
                     opts: CalibrationOptions, invertible: bool = False):
    """Fit both channels against a phase reference `phi` (rad, per sample), invert, re-fit quadrature."""
    fits = _fit_waveforms(meas, use, phi, opts, invertible)
    _set_waveforms(cal, fits["sin"], fits["cos"], cal.encoder, opts)
    _fit_quadrature(cal, meas, use)
    cal.fit["wave_harmonics"] = {k: w.harmonics for k, w in fits.items()}


LINEAR_LIMIT = 1.99    # the core's table values lie in [-2, 2)


def linear_inverse(kind: str, peak: float, enc: Encoder, opts: CalibrationOptions) -> WaveformInverse:
    """The waveform stage as a straight line, reading / peak (both branches, clipped to the table
    format beyond twice the largest reading seen): the core keeps its tables, and the conic and
    the long-period table do the correcting."""
    lo, hi, n = _table_grid(enc, opts.table_points)
    line = np.clip(np.linspace(lo, hi, n) / peak, -LINEAR_LIMIT, LINEAR_LIMIT)
    return WaveformInverse(kind, lo, (hi - lo) / (n - 1), np.vstack([line, line]), 0.0, 0.0, 0.0)


def straight_inverses(cal: Calibration, meas: Measurement, use: np.ndarray, opts: CalibrationOptions):
    cal.inv_sin, cal.inv_cos = (linear_inverse(k, max(float(np.max(np.abs(y[use]))), 1.0), cal.encoder, opts)
                                for k, y in (("sin", meas.sin), ("cos", meas.cos)))


def conic_from_fundamentals(cal: Calibration, meas: Measurement, use: np.ndarray, opts: CalibrationOptions):
    """The quadrature stage of the straight waveform stage (PHASE_TABLE) from the channels' offsets and
    fundamentals against the reference's phase (the graduation error averages out), in place of the conic fitted
    through the figure; then the coarse code, direction and zero again for it. Nothing if
    opts.conic_from_fundamentals is off.

    A conic fitted through a figure that the channels' harmonics bend puts its centre off the channels' offsets
    (a 10-bit, 50-line encoder with 1 % harmonics: 2.3 codes of 400). The tables after the arctan take the
    phase error that leaves at the recording's amplitude, but it scales as 1 / amplitude: another amplitude
    (a gain that follows the revolution, the air gap, temperature) moves the angle. Around the channels' own
    offsets a common gain change moves no angle, and the harmonics' phase error, which scales with the signal,
    stays the tables'. The model is the conic's (dsp.quadrature.fit_conic): s = ofs_s + g_s sin(theta - alpha),
    c = ofs_c + g_c cos(theta), here in the straight stage's units."""
    if not opts.conic_from_fundamentals:
        return
    find_direction_and_zero(cal, meas, encoder_rev(cal, meas))
    waves = _fit_waveforms(meas, use, true_phase(cal, meas, opts.known_error_arcsec), opts)
    unit = {k: float(inv(np.array([1.0]), np.array([0.0]))[0]) for k, inv in (("sin", cal.inv_sin),
                                                                                 ("cos", cal.inv_cos))}
    (o_s, a_s, b_s), (o_c, a_c, b_c) = ((w.weights[0], w.coefficients()[1][0], w.coefficients()[2][0])
                                        for w in (waves["sin"], waves["cos"]))
    g_s, g_c = np.hypot(a_s, b_s) * unit["sin"], np.hypot(a_c, b_c) * unit["cos"]
    # sin: g_s sin(theta_ref + gamma), cos: g_c cos(theta_ref + beta); theta = theta_ref + beta, alpha = beta - gamma
    alpha = float(np.angle(np.exp(1j * (np.arctan2(-b_c, a_c) - np.arctan2(a_s, b_s)))))
    if not (g_s > 0 and g_c > 0 and abs(alpha) < 1.0):
        return
    cal.quad = QuadratureCorrection(ofs_s=float(o_s * unit["sin"]), ofs_c=float(o_c * unit["cos"]),
                                    k_ss=float(1 / (g_s * np.cos(alpha))), k_sc=float(np.tan(alpha) / g_c),
                                    k_cc=float(1 / g_c), alpha_rad=alpha, gain_ratio=float(g_s / g_c))
    cal.fit["conic"] = "the channels' offsets and fundamentals against the reference"
    sync_coarse(cal, meas)
    find_direction_and_zero(cal, meas, encoder_rev(cal, meas))


def straight_conic(meas: Measurement, enc: Encoder, use: np.ndarray, opts: CalibrationOptions) -> Calibration:
    """PHASE_TABLE without a long-period fit (an incremental encoder): the waveform stage straight and the
    conic; what the channels' shape does to the phase is left to the closed loop's fine-phase map."""
    cal = Calibration(encoder=enc)
    cal.fit["structure"] = PHASE_TABLE
    straight_inverses(cal, meas, use, opts)
    _fit_quadrature(cal, meas, use)
    theta, _ = _phase(cal, meas)     # the channels against the phase the core measures (reports, drift tables)
    cal.waves = _fit_waveforms(meas, use, theta, opts)
    cal.fit["wave_harmonics"] = {k: w.harmonics for k, w in cal.waves.items()}
    return cal


def reference_free(meas: Measurement, enc: Encoder, use: np.ndarray, opts: CalibrationOptions) -> Calibration:
    """Conic, then waveforms against a phase reference that needs no instrument: the motion being
    smooth in time where it is, else the shape of the Lissajous figure (`shape_reference`)."""
    cal = Calibration(encoder=enc)
    _fit_quadrature(cal, meas, use)
    t = meas.t_s if meas.t_s is not None else np.arange(len(meas), dtype=float)   # no t_s: rows equally spaced
    for i in range(max(1, opts.motion_iterations)):
        theta, _ = _phase(cal, meas)
        try:
            phi, valid, info = smooth_motion_phase(theta, t)
        except MotionTooSlow as e:
            if i == 0:
                timing = "" if meas.t_s is not None else "no t_s column, so rows are taken as equally spaced in time: "
                shape_reference(cal, meas, use, opts, timing + str(e))
                return cal
            break          # the first pass had a reference: keep its waveforms
        _refit_waveforms(cal, meas, use & valid, phi, opts, invertible=True)
        info["time"] = "t_s" if meas.t_s is not None else "row index (no t_s column)"
        cal.fit["smooth_motion"] = info
    info = cal.fit["smooth_motion"]
    cal.fit["phase_reference"] = {"method": "smooth motion in time", "samples_used": info["samples_used"],
                                  "fraction_used": info["fraction_used"], "runs_used": info["runs_used"],
                                  "runs": info["runs"]}
    if info["fraction_used"] < 0.99:
        cal.skipped.append(motion_usage_text(info, len(meas)))
    return cal


def motion_usage_text(info: dict, n: int) -> str:
    """What the smooth-motion reference left out of the waveform fit, and why."""
    why = interruptions(info)
    rough = info["runs_not_smooth"]
    short = info["runs"] - info["runs_used"] - rough
    if short:
        why.append(f"{short} of its {info['runs']} gap-free runs are too short")
    if rough:
        why.append(f"{rough} of its {info['runs']} gap-free runs do not move smoothly")
    why.append("samples near stops and reversals move too slowly")
    return (f"waveform fit: {n - info['samples_used']} of {n} samples ({100 * (1 - info['fraction_used']):.0f} %) "
            f"left out of the smooth-motion phase reference ({'; '.join(why)}); it used "
            f"{info['runs_used']} run(s), {info['periods_used']:.0f} signal periods")


def shape_reference(cal: Calibration, meas: Measurement, use: np.ndarray, opts: CalibrationOptions, why: str):
    """Without a phase reference from the motion: the conic, and from the figure's shape alone the
    radius's harmonics (`quadrature.shape_phase_error`). Both go into waveform tables the core runs:
    the channels are fitted against the phase the shape implies, so with a round figure the tables
    are those of the conic-corrected channels."""
    harmonics = None      # the radius's harmonics after the conic alone: what the shape corrects
    for _ in range(opts.shape_iterations):
        theta, mag = _phase(cal, meas)
        delta, found = shape_phase_error(theta[use], mag[use]) if opts.shape_correction else (0.0, {})
        phi = np.full(len(meas), np.nan)
        phi[use] = theta[use] - delta
        _refit_waveforms(cal, meas, use, phi, opts, invertible=True)
        harmonics = found if harmonics is None else harmonics
    largest = sorted((m for m, v in harmonics.items() if v > 0), key=lambda m: -harmonics[m])
    named = ", ".join(f"{m}: {100 * harmonics[m]:.2g} %" for m in largest[:4])
    shape = (f"the radius's harmonics ({len(largest)} orders; largest {named}) are corrected as the channel "
             "harmonics one order below (the order above, which bends the radius alike but moves the angle the "
             "other way, cannot be told apart without a reference)"
             if largest else "the figure's shape shows no radius harmonic above the conic's")
    cal.skipped.append(f"waveform fit against the motion: {why}. The phase reference comes from the Lissajous "
                       f"figure's shape instead: offsets, gains and phase (conic) are corrected, and {shape}; a "
                       "waveform error that keeps the figure round needs t_s with smooth motion or ref_deg")
    cal.fit["phase_reference"] = {"method": "shape of the Lissajous figure", "samples_used": int(use.sum()),
                                  "fraction_used": float(use.mean()),
                                  "radius_harmonics_after_conic": {str(m): harmonics[m] for m in largest}}


def sync_coarse(cal: Calibration, meas: Measurement):
    enc = cal.encoder
    if not enc.coarse_bits or meas.coarse is None:
        cal.coarse_offset_periods = None
        return
    frac, _ = fine_phase(cal, meas.sin, meas.cos)
    try:
        cal.coarse_offset_periods = fit_coarse_offset(frac, meas.coarse, enc.lines_per_rev, enc.coarse_bits)
    except ValueError as e:
        _fail(meas, str(e))


def encoder_rev(cal: Calibration, meas: Measurement) -> np.ndarray:
    frac, _ = fine_phase(cal, meas.sin, meas.cos)
    pos, _, _ = encoder_position(cal, frac, meas.coarse, meas.t_s)
    return pos / cal.encoder.lines_per_rev


def find_direction_and_zero(cal: Calibration, meas: Measurement, rev: np.ndarray):
    ref = meas.ref_deg / 360.0
    d_enc, d_ref = wrap(np.diff(rev)), wrap(np.diff(ref))
    moving = np.abs(d_ref) > 0
    starts = run_starts(meas.t_s, len(rev))
    if starts is not None and not starts[1:].all():
        # not across the holes of rows taken out (the loop's interleaved halves): there the reference moved by a
        # whole hole and the encoder's count by what it could follow, of either sign at a fast motion
        moving &= ~starts[1:]
    if not moving.any():
        _fail(meas, "no motion: the reference angle never changes")
    corr = float(np.sum(d_enc[moving] * d_ref[moving]))
    cal.direction = 1 if corr >= 0 else -1
    offset = wrap(ref - cal.direction * rev)
    if cal.encoder.lines_per_rev > 1 and len(offset) > 1:
        # the count of an incremental encoder slips by whole periods where the rows skip a fast motion (the closed
        # loop's interleaved halves: 32-sample holes at 0.02 periods a sample); the zero is the offset between
        # the slips, as lp_error_arcsec takes the error
        offset = without_slips(offset, 1.0 / cal.encoder.lines_per_rev)
    cal.zero_deg = 360.0 * (circular_mean(offset) % 1.0)


def lp_error_arcsec(cal: Calibration, meas: Measurement, rev: np.ndarray) -> np.ndarray:
    """Encoder error against the reference, in the encoder's own direction (arcsec), without the whole periods
    its period count slipped by (more than one line)."""
    truth = cal.direction * (meas.ref_deg / 360.0 - cal.zero_deg / 360.0)
    err = wrap(rev - truth) * ARCSEC_PER_REV
    if cal.encoder.lines_per_rev > 1 and len(err) > 1:
        # an incremental encoder counts periods from the fine phase, which cannot follow a fast motion across the
        # holes of a fold (a hole of two samples at 0.17 periods a sample: half a period a step), nor a coarse code
        # that misses a period where its edges sit at the wrap: the count then slips by whole periods, which the
        # tables over the phase must not fit (a 26-line phase table scored 14375" on such folds against 138"). The
        # error itself moves far less than half a period between rows
        period = ARCSEC_PER_REV / cal.encoder.lines_per_rev
        err = without_slips(err, period)
        err = err - period * np.round(np.median(err) / period)
    return err


class PartialRevolution(FringeInputError):
    """The recording does not cover the whole revolution: no long-period table can be fitted from it."""

    def __init__(self, problem: str, path: str | None = None):
        super().__init__(problem, path)
        self.problem = problem


def check_revolution_coverage(meas: Measurement, rev: np.ndarray, bins: int = 64):
    covered = np.unique(np.floor((rev % 1.0) * bins).astype(int))
    if len(covered) < bins:
        raise PartialRevolution(f"the recording covers only {len(covered)} of {bins} sectors of the revolution; "
                                "the long-period error needs at least one full revolution", meas.path)


def fit_long_period(cal: Calibration, meas: Measurement, use: np.ndarray, opts: CalibrationOptions):
    rev = encoder_rev(cal, meas)
    find_direction_and_zero(cal, meas, rev)
    err = lp_error_arcsec(cal, meas, rev)
    if opts.known_error_arcsec is not None:
        err = err - opts.known_error_arcsec
    x = 2 * np.pi * (rev[use] % 1.0)
    # harmonics L, 2L, ... of the revolution are functions of the fine phase: the waveform tables own
    # them, unless the long-period table is itself a table over the fine phase (lines_per_rev = 1)
    skip = 0 if cal.encoder.lines_per_rev == 1 else cal.encoder.lines_per_rev
    n_fixed, n_max = None, opts.lp_harmonics_max
    if opts.lp_order_selection == "default":
        n_max = max(1, min(n_max, int(use.sum()) // LP_SAMPLES_PER_HARMONIC))
        n_fixed = min(LP_DEFAULT_HARMONICS, n_max)
    if opts.lp_order_selection == "cv":
        # at least 16 samples a harmonic, as for the waveforms: held-out folds of a short recording
        # cannot expose a fit to structured noise (a tone at a fixed sample pattern) otherwise
        n_max = max(1, min(n_max, int(use.sum()) // LP_SAMPLES_PER_HARMONIC))
        folds = cv_folds(len(meas), LP_ORDER_FOLDS, min_run=CV_MIN_RUN)[use]
        n_fixed, held_out = cv_harmonics(x, err[use], n_max, folds, skip_multiples_of=skip,
                                         default=LP_DEFAULT_HARMONICS, alpha=CV_ALPHA, blocks=CV_BATCHES)
        cal.fit["lp_held_out_rms_arcsec"] = float(held_out[n_fixed])
    cal.long_period, n, rms = fit_select(x, err[use], n_max, n_fixed=n_fixed, skip_multiples_of=skip)
    cal.fit["lp_harmonics"] = n
    cal.fit["lp_residual_rms_arcsec"] = rms


def reference_phase(cal: Calibration, meas: Measurement, rev: np.ndarray,
                    known_error_arcsec: np.ndarray | None = None) -> np.ndarray:
    """The disc's fine phase per sample (rad): the reference angle plus the encoder's long-period
    error (the graduation error moves the fringes): 2*pi*lines*(truth + e(rev))."""
    truth = cal.direction * (meas.ref_deg / 360.0 - cal.zero_deg / 360.0)
    disc = truth + cal.long_period(2 * np.pi * (rev % 1.0)) / ARCSEC_PER_REV
    if known_error_arcsec is not None:
        disc = disc + known_error_arcsec / ARCSEC_PER_REV
    return 2 * np.pi * cal.encoder.lines_per_rev * disc


def true_phase(cal: Calibration, meas: Measurement, known_error_arcsec: np.ndarray | None = None) -> np.ndarray:
    """The fine phase of the reference angle alone (rad)."""
    truth = cal.direction * (meas.ref_deg / 360.0 - cal.zero_deg / 360.0)
    if known_error_arcsec is not None:
        truth = truth + known_error_arcsec / ARCSEC_PER_REV
    return 2 * np.pi * cal.encoder.lines_per_rev * truth


def refine_with_reference(cal: Calibration, meas: Measurement, use: np.ndarray, opts: CalibrationOptions):
    """Fit each channel against the reference's phase (all harmonics), then the long period again.

    The disc's phase is the reference angle plus the encoder's long-period error (the
    graduation error moves the fringes): 2*pi*lines*(truth + e(rev)).
    """
    for _ in range(opts.ref_iterations):
        # one period a revolution: the disc's phase error is a function of the phase, the channel models
        # take it against the reference angle alone and the long-period table what the inverse leaves
        phi = (true_phase(cal, meas, opts.known_error_arcsec) if cal.encoder.lines_per_rev == 1 else
               reference_phase(cal, meas, encoder_rev(cal, meas), opts.known_error_arcsec))
        _refit_waveforms(cal, meas, use, phi, opts)
        sync_coarse(cal, meas)
        fit_long_period(cal, meas, use, opts)


def reference_calibration(meas: Measurement, enc: Encoder, use: np.ndarray, opts: CalibrationOptions,
                          structure: str) -> Calibration:
    """Conic, long period and (WAVEFORM) the per-channel inverse, all against the reference.

    PHASE_TABLE keeps the waveform stage a straight line and lets the tables after the arctan carry
    the phase error (fit_phase_tables); the channel models are still fitted (against the reference's
    phase) for the reports and the closed loop, but not inverted.
    """
    cal = Calibration(encoder=enc)   # the reference gives the phase: only the conic is needed to start
    cal.fit["structure"] = structure
    if structure == PHASE_TABLE:
        straight_inverses(cal, meas, use, opts)
    _fit_quadrature(cal, meas, use)
    sync_coarse(cal, meas)
    check_revolution_coverage(meas, encoder_rev(cal, meas))
    if structure == PHASE_TABLE:
        conic_from_fundamentals(cal, meas, use, opts)
        fit_phase_tables(cal, meas, use, opts)
        if opts.gain_centre:
            centre_from_gain_changes(cal, meas, use, opts)
        report_amplitude_dependence(cal, meas, use, opts)
        cal.waves = _fit_waveforms(meas, use, reference_phase(cal, meas, encoder_rev(cal, meas),
                                                              opts.known_error_arcsec), opts)
        cal.fit["wave_harmonics"] = {k: w.harmonics for k, w in cal.waves.items()}
    else:
        fit_long_period(cal, meas, use, opts)
        refine_with_reference(cal, meas, use, opts)
    return cal


FINE_MAP_MAX = 32         # fine-phase orders offered to the phase-table structure's fine-phase map
FINE_MAP_DEFAULT = 16     # its default order (left only for a significant held-out gain, as the LP order)


def fine_map_error(cal: Calibration, meas: Measurement) -> np.ndarray:
    """The declared fine-phase map's error per sample (arcsec, encoder frame; 0 without one)."""
    terms = [t for t in cal.angle_terms if t.name.startswith(FINE_MAP_PREFIX)]
    if not terms:
        return np.zeros(len(meas))
    frac, _ = fine_phase(cal, meas.sin, meas.cos)
    k = parse_generic(terms[0].name)[1]
    return cal.direction * (np.column_stack(phase_columns(2 * np.pi * frac, k, constant=False)) @ terms[0].weights)


def fit_fine_map(cal: Calibration, meas: Measurement, use: np.ndarray, known: np.ndarray):
    """fringe_trim's fine-phase map against the reference (PHASE_TABLE with more than one line, or on part of a
    revolution): an angle term of the fine phase alone, every harmonic of it the same in every period, its orders
    chosen on held-out data; fitted on what the long-period table (if any) and the `known` error leave."""
    frac, _ = fine_phase(cal, meas.sin, meas.cos)
    rev = encoder_rev(cal, meas)
    err = lp_error_arcsec(cal, meas, rev) - known
    if cal.long_period is not None:
        err = err - cal.long_period(2 * np.pi * (rev % 1.0))
    phi = 2 * np.pi * frac[use]
    folds = cv_folds(len(meas), LP_ORDER_FOLDS, min_run=CV_MIN_RUN)[use]
    cal.angle_terms = [t for t in cal.angle_terms if not t.name.startswith(FINE_MAP_PREFIX)]
    try:
        k, held_out = cv_harmonics(phi, err[use], FINE_MAP_MAX, folds, default=FINE_MAP_DEFAULT, alpha=CV_ALPHA,
                                   blocks=CV_BATCHES)
    except ValueError:
        held_out = []
    if len(held_out) < 2:     # the phases seen hold no harmonic on every fold (too little of the period): no map
        cal.fit["fine_map_orders"] = 0
        return
    k = max(k, 1)
    name = generic_name("1", k)
    x = np.column_stack(phase_columns(phi, k, constant=False))
    w, *_ = np.linalg.lstsq(np.column_stack([x, np.ones(len(phi))]), err[use], rcond=None)
    # encoder frame -> output frame (the terms model the output angle's error)
    cal.angle_terms = cal.angle_terms + [FittedEffect(name, cal.direction * w[:-1])]
    cal.fit["fine_map_orders"] = k
    cal.fit["fine_map_held_out_rms_arcsec"] = float(held_out[k])


def fit_phase_tables(cal: Calibration, meas: Measurement, use: np.ndarray, opts: CalibrationOptions):
    """PHASE_TABLE's tables after the arctan, against the reference. With one line a revolution the long-period
    table is a table over the fine phase and carries the whole phase error. With more, it holds the revolution's
    harmonics other than multiples of the lines, and the phase error of the channels' shape goes to the fine-phase
    map (fit_fine_map). The two are fitted in turn, each with the other's error held out."""
    fit_long_period(cal, meas, use, opts)
    if cal.encoder.lines_per_rev == 1:
        return
    known = np.zeros(len(meas)) if opts.known_error_arcsec is None else opts.known_error_arcsec
    for _ in range(2):
        fit_fine_map(cal, meas, use, known)
        fit_long_period(cal, meas, use, dataclasses.replace(opts, known_error_arcsec=known + fine_map_error(cal, meas)))


def incremental_reference(meas: Measurement, enc: Encoder, use: np.ndarray, opts: CalibrationOptions
                          ) -> Calibration:
    """An incremental encoder (no coarse code) against a reference. Within one recording the fine phase is the
    reference angle times the lines plus a constant, so the conic and the channels are fitted against it as for
    an absolute encoder: a reference sees every waveform error, the figure's shape only those that bend the
    radius. The long-period table is fitted too, so that the graduation error does not bend the channel fits,
    and then left out: the place in the revolution is not known after power-up, so it would not repeat in
    another recording. Where the recording does not cover a revolution, reference_phase_only."""
    try:
        cal = reference_calibration(meas, enc, use, opts, opts.structure or WAVEFORM)
    except PartialRevolution:
        return reference_phase_only(meas, enc, use, opts)
    cal.long_period = None
    cal.fit["phase_reference"] = {"method": "reference angle times the lines (the fine phase only: an incremental "
                                            "encoder's long-period table would not repeat after power-up)",
                                  "samples_used": int(use.sum()), "fraction_used": float(use.mean())}
    return cal


def reference_phase_only(meas: Measurement, enc: Encoder, use: np.ndarray, opts: CalibrationOptions
                         ) -> Calibration:
    """The conic and the channels against the reference angle times the lines, without a long-period table: a
    recording of part of a revolution cannot give one (nor take the graduation error out of the reference's
    phase, which then stays in it as a slow phase error the channel fits average over), but the reference
    still sees every waveform error within the periods it covers."""
    cal = Calibration(encoder=enc)
    if opts.structure == PHASE_TABLE:     # the waveform stage straight, the phase error in the fine-phase map
        cal.fit["structure"] = PHASE_TABLE
        straight_inverses(cal, meas, use, opts)
        _fit_quadrature(cal, meas, use)
        sync_coarse(cal, meas)
        find_direction_and_zero(cal, meas, encoder_rev(cal, meas))
        known = np.zeros(len(meas)) if opts.known_error_arcsec is None else opts.known_error_arcsec
        conic_from_fundamentals(cal, meas, use, opts)
        fit_fine_map(cal, meas, use, known)
        if opts.gain_centre:
            centre_from_gain_changes(cal, meas, use, opts, refit=lambda: fit_fine_map(cal, meas, use, known))
        cal.waves = _fit_waveforms(meas, use, true_phase(cal, meas, opts.known_error_arcsec), opts)
        cal.fit["wave_harmonics"] = {k: w.harmonics for k, w in cal.waves.items()}
        return _part_of_a_revolution(cal, use)
    _fit_quadrature(cal, meas, use)
    sync_coarse(cal, meas)
    for _ in range(max(1, opts.ref_iterations)):
        find_direction_and_zero(cal, meas, encoder_rev(cal, meas))
        _refit_waveforms(cal, meas, use, true_phase(cal, meas, opts.known_error_arcsec), opts)
        sync_coarse(cal, meas)
    find_direction_and_zero(cal, meas, encoder_rev(cal, meas))
    cal.fit["structure"] = WAVEFORM
    return _part_of_a_revolution(cal, use)


def _part_of_a_revolution(cal: Calibration, use: np.ndarray) -> Calibration:
    cal.fit["phase_reference"] = {"method": "reference angle times the lines (part of a revolution: no long-period "
                                            "table)", "samples_used": int(use.sum()),
                                  "fraction_used": float(use.mean())}
    return cal


CENTRE_ITERATIONS = 3
CENTRE_T_MIN = 3.0        # a centre shift must be this many standard errors from zero
GAIN_WINDOW_MIN = 16      # samples averaged at least for the slow gain (1/256 of the recording if longer)


def centre_from_gain_changes(cal: Calibration, meas: Measurement, use: np.ndarray, opts: CalibrationOptions,
                             refit=None):
    """Move the quadrature centre to where a common gain change moves no angle (PHASE_TABLE).

    atan2 ignores a common gain only around the true centre. A conic fitted to a family of scaled
    ellipses (field strength, air gap or temperature changing during the recording) misplaces it,
    and an error (dx, dy) of the corrected components moves the angle by (dx cos phi - dy sin phi)/g,
    g the relative gain: the phase table takes the part at g = 1, the rest follows the gain. The
    residual after the table is regressed on a cos(phi), a sin(phi), the centre moved by the fitted
    (dx, dy) and the table refitted. a = g - 1 is the slow part of the magnitude that its mean shape
    along the phase does not explain: the magnitude over that shape, averaged over GAIN_WINDOW
    samples, so that noise and interference (which move magnitude and angle together, sample by
    sample) do not pass for a gain change. Without a gain change the regressors are noise and
    nothing significant is found (nor needed: the table absorbs a fixed centre error). `refit` fits the
    tables again after a move (default fit_phase_tables; on part of a revolution the fine-phase map alone).
    """
    q = cal.quad
    shifts = 0
    for _ in range(CENTRE_ITERATIONS):
        phi, a, err = _slow_gain_and_residual(cal, meas, use, opts)
        m = np.column_stack([a * np.cos(phi), a * np.sin(phi)])
        w, rss, rank, _ = np.linalg.lstsq(m, err, rcond=None)
        if rank < 2 or len(phi) <= 2:
            break
        sigma2 = float(np.sum((err - m @ w) ** 2)) / (len(phi) - 2)
        se = np.sqrt(np.diag(np.linalg.inv(m.T @ m)) * sigma2)
        if not np.any(np.abs(w) > CENTRE_T_MIN * se):
            break
        dx, dy = -w[0], w[1]       # the a-part of the error is -a (dx cos phi - dy sin phi)
        q.ofs_c += dy / q.k_cc
        q.ofs_s += (dx - q.k_sc * dy / q.k_cc) / q.k_ss
        shifts += 1
        if refit is None:
            fit_phase_tables(cal, meas, use, opts)
        else:
            refit()
    cal.fit["centre_shifts"] = shifts


AMPLITUDE_ORDERS = 4     # fine-phase harmonics of the amplitude-dependence test
AMPLITUDE_P_MAX = 1e-3   # significance of that test


def _slow_gain_and_residual(cal: Calibration, meas: Measurement, use: np.ndarray, opts: CalibrationOptions):
    """Fine phase (rad), slow relative gain - 1 and the residual angle error (rad, encoder frame) of
    the used samples: see centre_from_gain_changes."""
    frac, mag = fine_phase(cal, meas.sin, meas.cos)
    rev = encoder_rev(cal, meas)
    table = cal.long_period(2 * np.pi * (rev % 1.0)) if cal.long_period is not None else 0.0
    err = (lp_error_arcsec(cal, meas, rev) - table - fine_map_error(cal, meas)) / ARCSEC_PER_REV * 2 * np.pi
    if opts.known_error_arcsec is not None:
        err = err - opts.known_error_arcsec / ARCSEC_PER_REV * 2 * np.pi
    phi = 2 * np.pi * frac[use]
    shape, _, _ = fit_select(phi, mag[use], max(8, min(64, len(phi) // 16)))
    a = uniform_filter1d(mag[use] / shape(phi), max(GAIN_WINDOW_MIN, len(phi) // 256), mode="nearest") - 1.0
    return phi, a, err[use]


def report_amplitude_dependence(cal: Calibration, meas: Measurement, use: np.ndarray, opts: CalibrationOptions):
    """Say so when the error left still follows the amplitude (PHASE_TABLE).

    A waveform whose shape changes with the field leaves an error of (g - 1) x f(phase), which no
    table of the open-loop core can hold. F test of the slow gain x harmonics 0..AMPLITUDE_ORDERS
    of the phase against the residual; significant and at least 1 % of the residual RMS: skipped.
    """
    phi, a, err = _slow_gain_and_residual(cal, meas, use, opts)
    cols = [a] + [a * f(k * phi) for k in range(1, AMPLITUDE_ORDERS + 1) for f in (np.cos, np.sin)]
    m = np.column_stack(cols)
    dof = len(err) - m.shape[1]
    if dof <= 0:
        return
    w, *_ = np.linalg.lstsq(m, err, rcond=None)
    fitted = m @ w
    rss1 = float(np.sum((err - fitted) ** 2))
    explained = float(np.sum(err ** 2)) - rss1
    if rss1 <= 0 or explained <= 0:
        return
    p = float(f_dist.sf(explained / m.shape[1] / (rss1 / dof), m.shape[1], dof))
    rms = float(np.sqrt(np.mean(fitted ** 2))) * ARCSEC_PER_REV / (2 * np.pi)
    cal.fit["amplitude_dependent_rms_arcsec"] = round(rms, 4)
    if p < AMPLITUDE_P_MAX and rms >= 0.01 * float(np.sqrt(np.mean(err ** 2))) * ARCSEC_PER_REV / (2 * np.pi):
        cal.skipped.append(f"amplitude-dependent error: {rms:.3g}\" RMS of the calibration residual follows the "
                           f"signal magnitude (p = {p:.1e}; a waveform whose shape changes with the field or air "
                           "gap); the core's open-loop tables do not carry it")


def held_out_error_arcsec(cal: Calibration, meas: Measurement, known_error_arcsec: np.ndarray | None = None):
    """Output error of `cal` on `meas` against its reference (float engine), less the known error."""
    res = run_float(cal, meas.sin, meas.cos, meas.coarse, meas.t_s)
    err = error_arcsec(res.angle_deg, meas.ref_deg)
    if known_error_arcsec is not None:    # encoder frame -> output frame
        err = err - cal.direction * known_error_arcsec
    if cal.encoder.lines_per_rev > 1:
        # the error within the period: an incremental encoder counts periods from wherever a run of held-out rows
        # starts, and an absolute one's coarse code can miss by a period at a run's start where its edges sit at
        # the fine phase's wrap (a 2-line encoder with a 1-bit code: one such sample of 5440 scored the phase
        # table 8800" against 95"). Whole periods are the combination's, the same under every structure
        period = ARCSEC_PER_REV / cal.encoder.lines_per_rev
        err = wrap(err / period) * period
    return err - np.mean(err)


CANDIDATES = {WAVEFORM: (WAVEFORM, False), PHASE_TABLE: (PHASE_TABLE, False),
              PHASE_TABLE + "+gain_centre": (PHASE_TABLE, True)}


def choose_structure(meas: Measurement, enc: Encoder, use: np.ndarray,
                     opts: CalibrationOptions) -> tuple[str, bool, dict]:
    """The structure (and, for the phase table, whether to centre it on the gain changes), chosen on
    held-out data: each candidate is calibrated on all folds but one and scored on that one (the
    folds interleave runs of the recording, as an even/odd split does). The phase table without the
    centre move is the default: the simplest (the waveform stage a straight line, one table over
    the phase) and the one a common gain change cannot upset; another candidate is taken only where
    its held-out gain over the default is significant (`fourierfit.significant_choice`: paired batch
    means of the per-sample held-out errors in recording order), then the best of those."""
    step = -(-len(meas) // STRUCTURE_SAMPLES)      # ceil: a structure shows at any sampling of the recording
    known = opts.known_error_arcsec
    if step > 1:
        pick = np.arange(0, len(meas), step)
        meas, use, known = meas.subset(pick), use[pick], None if known is None else known[pick]
    k = int(np.clip(STRUCTURE_BUDGET // len(meas), 2, 5))
    # runs of len / (64 k) samples: each candidate is calibrated on the other folds, and that calibration refuses
    # a training part that leaves a 64th of the revolution empty (check_revolution_coverage); an incremental
    # encoder counts its periods from the fine phase alone, which cannot bridge a hole of many
    # samples: its folds are dealt sample by sample (holes of a few samples)
    incremental = not enc.coarse_bits and enc.lines_per_rev > 1
    folds = cv_folds(len(meas), k, blocks_per_fold=max(1, len(meas) // k) if incremental else 64)
    found = {}
    unmoved = set()     # the centred phase table's structures whose centre never moved: the plain one's results
    # the centred phase table first: where its centre moves on no fold, it is the plain phase table, not fitted again
    for name in sorted(CANDIDATES, key=lambda n: not CANDIDATES[n][1]):
        structure, centre = CANDIDATES[name]
        if opts.structure not in (None, structure) or opts.gain_centre not in (None, centre):
            continue
        twin = next((m for m in unmoved if CANDIDATES[m][0] == structure), None)
        if twin is not None:
            found[name] = found[twin]
            continue
        e2 = np.zeros(len(meas))      # held-out squared error per sample, in recording order (0: not used)
        shifts = 0
        for f in range(k):
            train, test = folds != f, folds == f
            # an absolute encoder of more than one line: its long-period table holds none of the fine phase's
            # harmonics, and the same under either structure; the folds take its default order (its choice is most
            # of their cost). An incremental encoder's table only keeps the channel fits straight: chosen as ever
            sub = dataclasses.replace(opts, structure=structure, gain_centre=centre, conic_from_fundamentals=False,
                                      known_error_arcsec=None if known is None else known[train],
                                      lp_order_selection="default" if enc.lines_per_rev > 1 and enc.coarse_bits
                                      else opts.lp_order_selection)
            try:
                cal = calibrate(meas.subset(train), enc, sub)
            except (FringeInputError, ValueError, np.linalg.LinAlgError):
                # a candidate that cannot be calibrated on a fold (a training part that leaves too little of the
                # revolution or of the phase for its tables) is not compared
                e2 = None
                break
            err = held_out_error_arcsec(cal, meas.subset(test), None if known is None else known[test])
            e2[np.flatnonzero(test)] = np.where(use[test], err, 0.0) ** 2
            shifts += cal.fit.get("centre_shifts", 0)
        if e2 is not None:
            found[name] = e2
            if centre and not shifts:
                unmoved.add(name)
    sq = {name: found[name] for name in CANDIDATES if name in found}
    count = max(int(use.sum()), 1)
    scores = {name: float(np.sqrt(e2.sum() / count)) for name, e2 in sq.items()}
    # with more than one line the per-channel inverse stays where it could not be scored (a fold it cannot be
    # fitted on): there is nothing to compare the phase table against; a structure given (the loop's phase-domain
    # remedy) stays, only its gain centre is chosen
    kept = PHASE_TABLE if opts.structure == PHASE_TABLE else WAVEFORM
    default = PHASE_TABLE if enc.lines_per_rev == 1 else kept
    if not sq or (enc.lines_per_rev > 1 and default not in sq):
        best, tstat = kept, {}
    else:
        names = list(sq)
        ref = names.index(default) if default in sq else int(np.argmin([scores[n] for n in names]))
        e2 = np.vstack([sq[n] for n in names])
        t, batches = paired_gain_t(e2, ref, CV_BATCHES)
        # no minimum size beyond significance: the phase table also holds where the amplitude moves to values the
        # recording never had (a gain over the revolution seen on part of it: 0.5 % better on the folds, 3.8x better
        # at the validation's amplitude). A 2 % rule stood here while fringe_drift_observer read the phase table's
        # channels at the wrong phase (tracker_waveforms): the tracked drift recordings then lost 15-30x with it
        best = names[significant_choice(e2.sum(axis=1), t, ref, CV_ALPHA, batches)]
        tstat = {n: round(float(v), 2) for n, v in zip(names, t, strict=True) if n != names[ref]}
    return (*CANDIDATES[best], {"chosen": best, "held_out_rms_arcsec": {n: round(v, 4) for n, v in scores.items()},
                                "gain_t_over_default": tstat, "folds": k, "every_nth_sample": step})


def calibrate(meas: Measurement, enc: Encoder, opts: CalibrationOptions | None = None) -> Calibration:
    opts = opts or CalibrationOptions()
    use = check_recording(meas, enc)
    try:
        return _calibrate(meas, enc, opts, use)
    except CoverageError:
        # a recording whose phases repeat (a steady speed locked to the sample rate: 400 Hz electrical at 10 kHz
        # visits 25 phases) cannot determine the waveform's harmonics between them: say so, not a fit between them
        try:
            fill = f"they fill {distinct_phases(meas, use)} of its {PHASE_PARTS} parts: "
        except QuadratureFitError:
            fill = ""
        _fail(meas, f"the samples fall on too few distinct places in the signal period to fit the correction ({fill}"
                    "a steady speed that is a simple fraction of the sample rate?); record with the speed changing, "
                    "or at a speed the sample rate does not divide")


PHASE_PARTS = 256


def distinct_phases(meas: Measurement, use: np.ndarray, bins: int = PHASE_PARTS) -> int:
    """How many of `bins` equal parts of the signal period the ellipse-corrected phase visits."""
    s, c = meas.sin[use].astype(float), meas.cos[use].astype(float)
    ys, yc = fit_conic(s, c).apply(s, c)
    phase = np.arctan2(ys, yc)
    return int(np.unique(np.floor(np.mod(phase / (2 * np.pi), 1.0) * bins)).size)


def _calibrate(meas: Measurement, enc: Encoder, opts: CalibrationOptions, use: np.ndarray) -> Calibration:
    has_lp = meas.ref_deg is not None and (enc.coarse_bits > 0 or enc.lines_per_rev == 1)
    choice = {}
    if meas.ref_deg is not None and (opts.structure is None or (opts.structure == PHASE_TABLE
                                                                and opts.gain_centre is None)):
        structure, centre, choice = choose_structure(meas, enc, use, opts)
        opts = dataclasses.replace(opts, structure=structure, gain_centre=centre)
    if has_lp:   # the reference gives the phase
        try:
            cal = reference_calibration(meas, enc, use, opts, opts.structure)
        except PartialRevolution as e:
            cal = reference_phase_only(meas, enc, use, opts)
            cal.skipped.append(f"long-period correction: {e.problem}")
    elif meas.ref_deg is not None:
        cal = incremental_reference(meas, enc, use, opts)
    elif opts.structure == PHASE_TABLE:
        cal = straight_conic(meas, enc, use, opts)
    else:
        cal = reference_free(meas, enc, use, opts)
    if choice:
        cal.fit["model_choice"] = choice
    if not use.all():
        cal.skipped.append(f"{int(np.count_nonzero(~use))} samples clipped at the ADC limits: left out of the fits "
                           "(the core flags them CLIP_SIN / CLIP_COS)")
    sync_coarse(cal, meas)
    if not enc.coarse_bits:
        cal.skipped.append("coarse/fine synchronisation: no coarse code (coarse_bits = 0); periods are counted "
                           "from the fine phase")
    if meas.ref_deg is None:
        cal.skipped += ["direction and zero: no ref_deg column (output keeps the encoder's own zero)",
                        "long-period (seed 000) correction: needs ref_deg"]
    elif not has_lp:
        cal.skipped.append("long-period correction: an incremental encoder (lines_per_rev > 1, no coarse code) "
                           "does not know where it is in the revolution after power-up")
        find_direction_and_zero(cal, meas, encoder_rev(cal, meas))
    cal.amp_low, cal.amp_high = amplitude_thresholds(cal, meas, use)
    dt = np.diff(meas.t_s) if meas.t_s is not None and len(meas) > 1 else np.ones(1)   # no t_s: time = index
    cal.provenance = {"data": meas.path, "samples": len(meas), "samples_used": int(use.sum()),
                      "sample_interval_s": float(np.median(dt)),
                      "encoder": enc.to_dict(), "method": "fringe calibrate"}
    if "phase_reference" in cal.fit:   # reference-free: which phase reference the waveforms rest on, on how much
        cal.provenance["phase_reference"] = cal.fit["phase_reference"]
    if "fine_map_held_out_rms_arcsec" in cal.fit:
        # the fine-phase map's bins are sized against what the calibration leaves (hardware.closed_loop's error
        # budget, a tenth of it), as the closed loop's terms are against its noise floor
        cal.provenance["noise_floor_arcsec"] = round(cal.fit["fine_map_held_out_rms_arcsec"], 6)
    return cal


def amplitude_thresholds(cal: Calibration, meas: Measurement, use: np.ndarray) -> tuple[float, float]:
    """Loss of signal below half the calibrated magnitude, overdrive above 1.5 times it."""
    _, mag = _phase(cal, meas)
    nominal = float(np.median(mag[use]))
    return 0.5 * nominal, 1.5 * nominal


# ---------------------------------------------------------------- comparison methods (bench)

class _PaperInverse:
    def __init__(self, ch: PaperChannel):
        self.ch = ch

    def __call__(self, y, other):
        return self.ch.invert(y)


SEED001_POINTS = 75       # seed 001 section 4.1: 75 samples over one signal period
SEED000_POINTS = 64       # seed 000 section 4.1: 64 points, one every 5.625 degrees
SEED000_HARMONICS = 9     # Table 1: 19 weights


def fit_paper_channel(kind: str, y: np.ndarray, phi: np.ndarray, odd_max: int = 23) -> PaperChannel:
    """Seed 001 eq. 5 by least squares in the channel's own phase (the seed's DFT on equal steps).

    sin channel, t = phi + psi: f0 + sum_odd f_n sin(n t) + f2 sin(2t). The cos channel is the
    same in u = pi/2 - t (x = sin u = cos t), so eq. 12 inverts both.
    """
    m1 = np.column_stack([np.ones_like(phi), np.cos(phi), np.sin(phi)])
    (_, a1, b1), *_ = np.linalg.lstsq(m1, y, rcond=None)
    u = phi + np.arctan2(a1, b1) if kind == "sin" else np.pi / 2 - (phi + np.arctan2(-b1, a1))
    orders = list(range(1, odd_max + 1, 2))
    m = np.column_stack([np.ones_like(u)] + [np.sin(n * u) for n in orders] + [np.sin(2 * u)])
    coef, *_ = np.linalg.lstsq(m, y, rcond=None)
    return PaperChannel(float(coef[0]), coef[1:-1], float(coef[-1]))


def _nearest(values: np.ndarray, targets: np.ndarray, period: float) -> np.ndarray:
    """Index of the sample nearest (circularly) to each target."""
    order = np.argsort(np.mod(values, period))
    v = np.mod(values, period)[order]
    i = np.clip(np.searchsorted(v, np.mod(targets, period)), 1, len(v) - 1)
    left_better = np.abs(wrap(v[i - 1] - targets, period)) <= np.abs(wrap(v[i] - targets, period))
    return order[np.where(left_better, i - 1, i)]


def seed_method(cal: Calibration, meas: Measurement) -> Calibration:
    """The seeds' own procedure with their data budget, on the same recording.

    Seed 001: 75 samples at equal phase steps in one signal period (phases from the reference, as
    the seed's 23-bit reference gave them), its waveform model and eq. 12 polynomial inverted by
    Newton (sqrt taken positive), its ellipse (phase only). Seed 000: 64 points at 5.625 degree
    steps, a 9-harmonic Fourier network at its optimum (least squares; see the DE benchmark).
    """
    enc = cal.encoder
    check_recording(meas, enc)
    if meas.ref_deg is None or cal.long_period is None:
        _fail(meas, "the seeds' method needs ref_deg and a long-period calibration")
    rev = encoder_rev(cal, meas)
    truth = cal.direction * (meas.ref_deg / 360.0 - cal.zero_deg / 360.0)
    phi = np.unwrap(2 * np.pi * enc.lines_per_rev * (truth + cal.long_period(2 * np.pi * rev) / ARCSEC_PER_REV))
    one_period = np.flatnonzero(np.abs(phi - phi[0]) <= 2 * np.pi)
    pick = one_period[_nearest(phi[one_period], phi[0] + 2 * np.pi * np.arange(SEED001_POINTS) / SEED001_POINTS,
                               2 * np.pi)]
    seed = Calibration(encoder=enc,
                       inv_sin=_PaperInverse(fit_paper_channel("sin", meas.sin[pick], phi[pick])),
                       inv_cos=_PaperInverse(fit_paper_channel("cos", meas.cos[pick], phi[pick])))
    _fit_quadrature(seed, meas.subset(pick), np.ones(len(pick), bool), seed_form=True)
    sync_coarse(seed, meas)
    rev = encoder_rev(seed, meas)
    find_direction_and_zero(seed, meas, rev)
    err = lp_error_arcsec(seed, meas, rev)
    pts = _nearest(rev, np.arange(SEED000_POINTS) / SEED000_POINTS, 1.0)
    seed.long_period, _, _ = fit_select(2 * np.pi * rev[pts], err[pts], SEED000_HARMONICS,
                                        bins=1 << 16, n_fixed=SEED000_HARMONICS)
    return seed


def ellipse_only(cal: Calibration, meas: Measurement) -> Calibration:
    """Only the general conic (Heydemann), plus the same long-period network: no waveform inversion."""
    use = check_recording(meas, cal.encoder)
    e = Calibration(encoder=cal.encoder)
    _fit_quadrature(e, meas, use)
    sync_coarse(e, meas)
    if meas.ref_deg is not None and cal.long_period is not None:
        fit_long_period(e, meas, use, CalibrationOptions())
    return e


def uncorrected(cal: Calibration, meas: Measurement) -> Calibration:
    """The encoder as it comes: plain arctan of the readings, with only what is needed to compare
    it with the reference (coarse synchronisation, direction and zero)."""
    raw = Calibration(encoder=cal.encoder)
    sync_coarse(raw, meas)
    if meas.ref_deg is not None:
        find_direction_and_zero(raw, meas, encoder_rev(raw, meas))
    return raw
