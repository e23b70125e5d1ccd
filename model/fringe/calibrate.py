"""Calibration: fit every stage of the pipeline from one recording.

1. Reference-free (seed 001): a conic fit gives a first phase. The seed fits its waveforms to
   samples at equal phase steps; here the phase reference comes from the motion being smooth
   in time (`smoothmotion`), so any trajectory will do. Each channel is fitted against it
   (all harmonics), inverted, the quadrature re-fitted and the phase recomputed, twice.
2. Coarse/fine synchronisation from the fine phase at the coarse code's edges.
3. With `ref_deg`: direction and zero, the long-period error (seed 000's Fourier network,
   solved in closed form by least squares, its size chosen by BIC), and then the waveform
   refitted against the reference's phase with all harmonics (odd, even, both phases),
   alternating with the long-period fit until both settle.
"""

from dataclasses import dataclass

import numpy as np

from .dataio import Measurement
from .encoder import ARCSEC_PER_REV, Encoder
from .errors import FringeInputError
from .fourierfit import fit_select
from .pipeline import Calibration, encoder_position, fine_phase
from .position import circular_mean, fit_coarse_offset, wrap
from .quadrature import QuadratureFitError, fit_conic, fit_seed_ellipse, shape_phase_error
from .smoothmotion import MAX_STEP_PERIODS, MotionTooSlow, smooth_motion_phase, times
from .waveform import ChannelWaveform, PaperChannel, build_inverse, is_invertible

MIN_SAMPLES = 64
MAX_CLIPPED_FRACTION = 0.005


@dataclass
class CalibrationOptions:
    motion_iterations: int = 2
    shape_iterations: int = 3        # without motion: passes of the Lissajous-shape phase reference
    shape_correction: bool = True    # False: without motion, correct the conic only
    ref_iterations: int = 2
    wave_harmonics_max: int = 31     # general model: BIC chooses up to this many
    lp_harmonics_max: int = 64       # BIC chooses up to this many
    table_points: int | None = None  # None: one point per ADC code, at most 2^16 + 1
    # closed loop: error already explained by other terms (arcsec, encoder frame, per sample), kept
    # out of the long-period fit and added to the reference phase of the waveform fit
    known_error_arcsec: np.ndarray | None = None


def _fail(meas: Measurement, problem: str):
    raise FringeInputError(problem, meas.path)


def check_recording(meas: Measurement, enc: Encoder) -> np.ndarray:
    """Refuse what cannot be calibrated; return the mask of samples usable for fitting."""
    if len(meas) < MIN_SAMPLES:
        _fail(meas, f"too few samples: {len(meas)} (calibration needs at least {MIN_SAMPLES})")
    if np.ptp(meas.sin) == 0 or np.ptp(meas.cos) == 0:
        _fail(meas, "no signal: a channel never changes (sensor unplugged or no motion?)")
    lo, hi = -enc.adc_half_range, enc.adc_half_range - 1
    clipped = (meas.sin <= lo) | (meas.sin >= hi) | (meas.cos <= lo) | (meas.cos >= hi)
    if clipped.mean() > MAX_CLIPPED_FRACTION:
        first = int(np.argmax(clipped))
        _fail(meas, f"{int(clipped.sum())} of {len(meas)} samples are clipped at the ADC limits "
                    f"(first: data row {first + 1}); reduce the gain: clipped samples hide the waveform")
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


def _fit_quadrature(cal: Calibration, meas: Measurement, use: np.ndarray, seed_form: bool = False):
    xs = cal.inv_sin(meas.sin[use], meas.cos[use]) if cal.inv_sin is not None else meas.sin[use]
    xc = cal.inv_cos(meas.cos[use], meas.sin[use]) if cal.inv_cos is not None else meas.cos[use]
    try:
        cal.quad = fit_seed_ellipse(xs, xc) if seed_form else fit_conic(xs, xc)
    except QuadratureFitError as e:
        _fail(meas, str(e))


def _refit_waveforms(cal: Calibration, meas: Measurement, use: np.ndarray, phi: np.ndarray,
                     opts: CalibrationOptions, invertible: bool = False):
    """Fit both channels against a phase reference `phi` (rad, per sample), invert, re-fit quadrature.

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
    _set_waveforms(cal, fits["sin"], fits["cos"], cal.encoder, opts)
    _fit_quadrature(cal, meas, use)
    cal.fit["wave_harmonics"] = {k: w.harmonics for k, w in fits.items()}


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
    why = []
    if info["pauses"]:
        why.append(f"the recording pauses {times(info['pauses'])}")
    if info["time_not_advancing"]:
        why.append(f"its time stamps stand still or go back {times(info['time_not_advancing'])}")
    if info["phase_jumps"]:
        why.append(f"the phase jumps by more than {MAX_STEP_PERIODS} of a period between samples "
                   f"{times(info['phase_jumps'])}")
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
    pos, _, _ = encoder_position(cal, frac, meas.coarse)
    return pos / cal.encoder.lines_per_rev


def find_direction_and_zero(cal: Calibration, meas: Measurement, rev: np.ndarray):
    ref = meas.ref_deg / 360.0
    d_enc, d_ref = wrap(np.diff(rev)), wrap(np.diff(ref))
    moving = np.abs(d_ref) > 0
    if not moving.any():
        _fail(meas, "no motion: the reference angle never changes")
    corr = float(np.sum(d_enc[moving] * d_ref[moving]))
    cal.direction = 1 if corr >= 0 else -1
    cal.zero_deg = 360.0 * (circular_mean(ref - cal.direction * rev) % 1.0)


def lp_error_arcsec(cal: Calibration, meas: Measurement, rev: np.ndarray) -> np.ndarray:
    """Encoder error against the reference, in the encoder's own direction (arcsec)."""
    truth = cal.direction * (meas.ref_deg / 360.0 - cal.zero_deg / 360.0)
    return wrap(rev - truth) * ARCSEC_PER_REV


def check_revolution_coverage(meas: Measurement, rev: np.ndarray, bins: int = 64):
    covered = np.unique(np.floor((rev % 1.0) * bins).astype(int))
    if len(covered) < bins:
        _fail(meas, f"the recording covers only {len(covered)} of {bins} sectors of the revolution; the "
                    "long-period error needs at least one full revolution (or calibrate without ref_deg)")


def fit_long_period(cal: Calibration, meas: Measurement, use: np.ndarray, opts: CalibrationOptions):
    rev = encoder_rev(cal, meas)
    find_direction_and_zero(cal, meas, rev)
    err = lp_error_arcsec(cal, meas, rev)
    if opts.known_error_arcsec is not None:
        err = err - opts.known_error_arcsec
    x = 2 * np.pi * (rev[use] % 1.0)
    # harmonics L, 2L, ... of the revolution are functions of the fine phase: the waveform tables own them
    cal.long_period, n, rms = fit_select(x, err[use], opts.lp_harmonics_max,
                                         skip_multiples_of=cal.encoder.lines_per_rev)
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


def refine_with_reference(cal: Calibration, meas: Measurement, use: np.ndarray, opts: CalibrationOptions):
    """Fit each channel against the reference's phase (all harmonics), then the long period again.

    The disc's phase is the reference angle plus the encoder's long-period error (the
    graduation error moves the fringes): 2*pi*lines*(truth + e(rev)).
    """
    for _ in range(opts.ref_iterations):
        _refit_waveforms(cal, meas, use, reference_phase(cal, meas, encoder_rev(cal, meas), opts.known_error_arcsec),
                         opts)
        sync_coarse(cal, meas)
        fit_long_period(cal, meas, use, opts)


def calibrate(meas: Measurement, enc: Encoder, opts: CalibrationOptions | None = None) -> Calibration:
    opts = opts or CalibrationOptions()
    use = check_recording(meas, enc)
    has_lp = meas.ref_deg is not None and (enc.coarse_bits > 0 or enc.lines_per_rev == 1)
    if has_lp:   # the reference gives the phase: only the conic is needed to start
        cal = Calibration(encoder=enc)
        _fit_quadrature(cal, meas, use)
    else:
        cal = reference_free(meas, enc, use, opts)
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
    else:
        check_revolution_coverage(meas, encoder_rev(cal, meas))
        fit_long_period(cal, meas, use, opts)
        refine_with_reference(cal, meas, use, opts)
    cal.amp_low, cal.amp_high = amplitude_thresholds(cal, meas, use)
    dt = np.diff(meas.t_s) if meas.t_s is not None and len(meas) > 1 else np.ones(1)   # no t_s: time = index
    cal.provenance = {"data": meas.path, "samples": len(meas), "samples_used": int(use.sum()),
                      "sample_interval_s": float(np.median(dt)),
                      "encoder": enc.to_dict(), "method": "fringe calibrate"}
    if "phase_reference" in cal.fit:   # reference-free: which phase reference the waveforms rest on, on how much
        cal.provenance["phase_reference"] = cal.fit["phase_reference"]
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
