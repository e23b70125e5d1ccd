"""The closed loop (`fringe loop`): calibrate the declared model, find what its residual still
holds, name the physical effect, add it, and report the error before and after.

Every test is against the noise floor estimated from the data itself (successive differences
of the residual: the systematic parts change slowly from one sample to the next, the noise
does not). An effect is added only when it is significant (chi-square of the explained sum of
squares against that noise, p < 1e-6), matters (it removes at least 1 % of the residual RMS),
and lowers the error on validation data (the --validate recording, or, without one, the
interleaved half of the recording that was not used to fit).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage, signal, stats

from ..calib.calibrate import PHASE_TABLE, calibrate
from ..dsp.calibration import Calibration
from ..dsp.effects import (
    AMPLITUDE_ORDERS,
    FINE_MAP_PREFIX,
    GENERIC,
    GENERIC_FACTORS,
    GENERIC_PHASE_ORDERS,
    GENERIC_REV_ORDERS,
    INTERFERENCE,
    LIBRARY,
    Context,
    FittedEffect,
    _legendre_time,
    amplitude_phase_columns,
    factor_columns,
    generic_design,
    generic_name,
    interference_columns,
    make_context,
    parse_generic,
    tone_columns,
)
from ..dsp.metrics import error_arcsec, error_figures
from ..dsp.position import shifted
from ..encoder import ARCSEC_PER_REV, Encoder
from ..engine.pipeline import run_float, sample_times, tracked_readings
from ..errors import FringeInputError
from ..fixed.trim import speed_window_log2
from ..io.dataio import Measurement

P_VALUE = 1e-6
MIN_GAIN = 0.01          # an effect must remove at least this fraction of the residual RMS
MAX_EFFECTS = 8          # effects kept at most
MAX_TRIALS = 20          # candidates tried at most: a rejected one must not use up a kept one's turn
VALIDATION_BLOCKS = 500  # interleaved blocks when there is no --validate recording
DECISION_ROWS = 1 << 17  # a longer recording is decided on this many of its rows (fit and validation each)
DECISION_RUNS = 8        # taken as evenly spaced runs of consecutive rows


def noise_sigma(r: np.ndarray) -> float:
    """Noise RMS from successive differences, robust to outliers (MAD). High-frequency structure (a tone,
    interference) inflates it: it is reported as a cross-check, not used for the tests."""
    return difference_sigma(np.diff(r))


def difference_sigma(d: np.ndarray) -> float:
    """Noise RMS from differences of two noisy samples, robust to outliers (MAD)."""
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2))


PHASE_NEIGHBOUR_RUNS = (16, 64, 256)    # samples per run of the replicate-state estimate


def phase_neighbour_sigma(r: np.ndarray, phi: np.ndarray) -> float:
    """Noise RMS from replicate states: within a short run of samples the speed, the magnitude, the position in
    the revolution and the time hardly change, so two samples next to each other in fine phase carry nearly the
    same error of any shape, and their difference is noise. Successive differences are the same estimate when
    the phase moves little between samples; at a fast electrical rate they see the fine-phase error change from
    one sample to the next, which this does not. The least inflated of a few run lengths (a longer run brings
    the phases closer, and the states further apart)."""
    best = np.inf
    for run in PHASE_NEIGHBOUR_RUNS:
        n = len(r) // run * run
        if n < 4 * run:
            continue
        order = np.argsort(np.mod(phi[:n], 2 * np.pi).reshape(-1, run), axis=1)
        d = np.diff(np.take_along_axis(r[:n].reshape(-1, run), order, axis=1), axis=1).ravel()
        best = min(best, difference_sigma(d))
    return best if np.isfinite(best) else noise_sigma(r)


def uniform_run(t: np.ndarray) -> slice:
    """The longest run of rows whose time steps equal the median step (to 0.1 %): the whole recording when its
    time axis is uniform; one of its runs when it is a set of evenly spaced runs of a longer one."""
    dt = np.diff(t)
    if len(dt) == 0:
        return slice(0, len(t))
    step = np.median(dt)
    ok = np.abs(dt - step) <= 1e-3 * abs(step) if step > 0 else np.zeros(len(dt), bool)
    if ok.all() or not ok.any():
        return slice(0, len(t))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(np.int8), [0]])))
    starts, stops = edges[0::2], edges[1::2]
    k = int(np.argmax(stops - starts))
    return slice(int(starts[k]), int(stops[k]) + 1)


def sample_rate(t: np.ndarray) -> float:
    """Samples per second on a uniform time axis, 1.0 (per sample) when the axis is not uniform."""
    dt = np.diff(t)
    if len(dt) == 0 or np.mean(dt) <= 0 or np.ptp(dt) > 1e-3 * np.mean(dt):
        return 1.0
    return float(1.0 / np.mean(dt))


def spectral_level(x: np.ndarray, fs: float = 1.0) -> float:
    """RMS of the white part of x: its spectrum's median level (lines and slow trends occupy few bins;
    a periodogram bin of white noise is exponential, its median ln 2 times the mean) over the whole band."""
    if len(x) < 64:
        return noise_sigma(x)
    f, p = signal.periodogram(x, fs, window="hann", detrend="linear")
    keep = f > 16 * f[1]           # the slowest trends belong to drift
    return float(np.sqrt(np.median(p[keep]) / np.log(2) * fs / 2))


def radial_floor(ev: Evaluation) -> float:
    """Angle noise from the corrected Lissajous figure's radial scatter (arcsec): channel noise over the
    amplitude is angle noise, and no error of the angle (a vibration, a reference error, a long-period
    error) moves the magnitude. What the magnitude repeats over the fine phase is removed first."""
    ctx = ev.ctx
    m = np.asarray(ctx.magnitude, float)
    bins = 256                 # the magnitude's shape over the fine phase: its mean per phase bin
    k = np.minimum((np.mod(ctx.phi, 2 * np.pi) / (2 * np.pi) * bins).astype(np.int64), bins - 1)
    counts = np.bincount(k, minlength=bins)
    shape = np.bincount(k, m, minlength=bins) / np.maximum(counts, 1)
    dof = np.sqrt(len(m) / max(len(m) - np.count_nonzero(counts), 1))     # the bin means took one each
    per_rad = ARCSEC_PER_REV / (2 * np.pi * ctx.lines)
    return spectral_level(m - shape[k], sample_rate(ctx.t)) * dof / float(np.mean(m)) * per_rad


FLOOR_ESTIMATES = ("spectral level of the residual away from lines", "successive differences of the residual",
                   "neighbours in fine phase within short runs")


def noise_floor(ev: Evaluation) -> tuple[float, dict]:
    """The floor the tests use (the least inflated of the residual's estimates) and every estimate."""
    est = {"spectral level of the residual away from lines": spectral_level(ev.r, sample_rate(ev.ctx.t)),
           "radial scatter of the corrected Lissajous figure": radial_floor(ev),
           "successive differences of the residual": noise_sigma(ev.r),
           "neighbours in fine phase within short runs": phase_neighbour_sigma(ev.r, ev.ctx.phi)}
    # structure inflates each, none deflates white noise: broadband (smeared by a changing speed) the spectral
    # level, high-frequency (a tone, interference, a fast electrical rate) the differences, a fast change of state
    # the replicate states; the lowest is the least inflated
    sigma = min(est[k] for k in FLOOR_ESTIMATES)
    ratios = {k: v / sigma for k, v in est.items()}
    # the radial scatter is a lower bound when the waveform inverse amplifies the noise along the circle
    # (harmonic-rich waveforms): it agrees if not above the floor by more than 40 % nor below half of it
    agree = all(ratios[k] <= 1.4 for k in FLOOR_ESTIMATES) and \
        0.5 <= ratios["radial scatter of the corrected Lissajous figure"] <= 1.4
    return sigma, {"used": "the lowest of the " + ", the ".join(FLOOR_ESTIMATES),
                   "estimates_arcsec": {k: round(v, 4) for k, v in est.items()},
                   "agree": agree,
                   "note": "the estimates agree" if agree else
                   "the estimates disagree: " + ("the radial scatter is lower, so part of the floor is not channel "
                                                 "noise (reference noise, mechanical jitter or unresolved structure)"
                                                 if ratios["radial scatter of the corrected Lissajous figure"] < 0.5
                                                 else "structure inflates the successive differences or the "
                                                 "magnitude (high-frequency content, interference)")}


@dataclass
class Evaluation:
    r: np.ndarray            # residual (arcsec), artefacts compensated
    ctx: Context
    figures: dict
    rms: float
    meas: Measurement | None = None     # the recording (its channels for the channel-domain tests)
    cal: Calibration | None = None
    ref_speed: np.ndarray | None = None  # the reference's speed over one electrical period (reference_motion)


@dataclass
class LoopState:
    cal: Calibration
    artefacts: list[FittedEffect] = field(default_factory=list)   # compensated in the evaluation only
    ref_lag_s: float = 0.0        # the reference's lag behind the ADC (a measurement artefact)


def shift_reference(meas: Measurement, lag_s: float) -> Measurement:
    """The reference as it would read if sampled with the ADC: ref(t + lag), on the unwrapped angle."""
    if not lag_s:
        return meas
    t = sample_times(len(meas), meas.t_s)
    unwrapped = np.rad2deg(np.unwrap(np.deg2rad(meas.ref_deg)))
    return dataclasses.replace(meas, ref_deg=np.mod(shifted(t, unwrapped, lag_s, span=16), 360.0))


REVOLUTION_SECTORS = 64     # a recording covers the revolution when it visits every one of these sectors
# With fewer signal periods per revolution the revolution and the fine phase are nearly the same angle: a change over
# the revolution cannot be told from a waveform that differs between periods
REVOLUTION_MIN_LINES = 4


def covered(ctx: Context) -> Context:
    """ctx marked with whether the recording covers the revolution (as the long-period fit requires): terms over
    the revolution are fitted only where it does."""
    sectors = np.unique(np.floor(np.mod(ctx.psi, 2 * np.pi) / (2 * np.pi) * REVOLUTION_SECTORS).astype(int))
    return dataclasses.replace(ctx, revolution_covered=len(sectors) >= REVOLUTION_SECTORS)


def evaluate(state: LoopState, meas: Measurement, res=None) -> Evaluation:
    """The residual of `meas` through state.cal (or `res`, another engine's result for `meas`), with
    the measurement artefacts compensated."""
    meas = shift_reference(meas, state.ref_lag_s)
    if res is None:
        res = run_float(state.cal, meas.sin, meas.cos, meas.coarse, meas.t_s)
    r = error_arcsec(res.angle_deg, meas.ref_deg)
    ctx = covered(make_context(res.frac, res.position, state.cal.encoder.lines_per_rev,
                               sample_times(len(r), meas.t_s), res.magnitude, state.cal.start_speed_rev_s))
    for art in state.artefacts:
        x = _design(art.name, ctx, art.tone_hz)
        x = x - x.mean(0)
        if art.name == "tone":
            # a tone's phase does not repeat between recordings, but a vibration's does within one: fitted on
            # each half and taken out of the other (a structure that only resembles a line, as a slowly
            # modulated fine-phase error at a steady speed, does not carry over, and is not credited)
            r = r - halves_cross_fit(x, r - r.mean())
            continue
        r = r - x @ art.weights          # everything else must repeat: the weights fitted on the fit data
    r = r - r.mean()
    fig = error_figures(r, res.frac, res.position / state.cal.encoder.lines_per_rev).to_dict()
    return Evaluation(r, ctx, fig, float(np.sqrt(np.mean(r * r))), meas, state.cal, reference_motion(meas, ctx))


def leans_on_vibrations(state: LoopState, trial: LoopState, meas: Measurement) -> bool:
    """Whether a correction the core makes (trial over state) fails to lower the error on `meas` once the vibration
    tones are left in the score. The tones are taken out of the score alone (a vibration between encoder and
    reference is the set-up's), so a term that only helps beside them models the tones, not the encoder: on a real
    Hall encoder a magnitude term took 1" off beside two tones near 249 Hz and added 7" to the core's output."""
    if not any(a.name == "tone" for a in trial.artefacts):
        return False
    def plain(s: LoopState) -> LoopState:
        return LoopState(s.cal, [a for a in s.artefacts if a.name != "tone"], s.ref_lag_s)
    return evaluate(plain(trial), meas).rms >= evaluate(plain(state), meas).rms


def cross_fit(x: np.ndarray, y: np.ndarray, blocks: int) -> np.ndarray:
    """x @ w for every row with w fitted on the other fold: the rows cut into `blocks` consecutive blocks, the
    folds every other block (2: two contiguous halves). No row's own value is in its fit."""
    fold = (np.arange(len(y)) * blocks // max(len(y), 1)) % 2
    out = np.empty(len(y))
    for f in (0, 1):
        w, *_ = np.linalg.lstsq(x[fold != f], y[fold != f], rcond=None)
        out[fold == f] = x[fold == f] @ w
    return out


def halves_cross_fit(x: np.ndarray, r: np.ndarray) -> np.ndarray:
    """x @ w with w fitted on the other half of the rows (two contiguous halves)."""
    return cross_fit(x, r, 2)


def _design(name: str, ctx: Context, tone_hz: float = 0.0) -> np.ndarray:
    if name == "tone":
        return tone_columns(ctx, tone_hz)
    if name == "interference":
        return interference_columns(ctx, tone_hz)
    if name.startswith("generic:"):
        return generic_design(name, ctx)
    return LIBRARY[name].design(ctx)


@dataclass
class Test:
    name: str
    weights: np.ndarray
    explained_rms: float
    rms_after: float
    p_value: float
    dof: int
    tone_hz: float = 0.0
    label: str = ""          # the library's name when the term is a general-dictionary shape for that effect
    ambiguous: bool = False  # a line at a steady revolution harmonic: as well a position error at that order


CHUNK = 1 << 12     # rows per block of a design matrix: memory stays bounded however long the recording


def test_terms(r: np.ndarray, x, sigma: float, name: str, tone_hz: float = 0.0) -> Test:
    """Least-squares fit of r on the columns x (plus a constant) and its chi-square against the noise.

    x: the design matrix, or a function of a block of rows (a slice) giving that block's columns; the
    fit is accumulated block by block as normal equations, so no full matrix of a wide domain is held."""
    design = x if callable(x) else (lambda sl: x[sl])
    n = len(r)
    gram = rhs = None
    for start in range(0, n, CHUNK):
        sl = slice(start, min(n, start + CHUNK))
        xa = np.column_stack([design(sl), np.ones(sl.stop - sl.start)])
        g, b = xa.T @ xa, xa.T @ r[sl]
        gram, rhs = (g, b) if gram is None else (gram + g, rhs + b)
    return _solve(gram, rhs, r, sigma, name, tone_hz)


def test_library_effect(ev: Evaluation, effect, sigma: float) -> Test:
    """test_terms for a library effect. Its static columns (a fine-phase shape that does not depend on the effect's
    factor) fit with it, but only what it explains beyond them is evidence of the effect: a static error the
    declared model left (an order-2 error of a few-line encoder) is not a skew."""
    t = test_terms(ev.r, lambda sl: effect.design(ev.ctx.rows(sl)), sigma, effect.name)
    if not effect.static:
        return t
    static = test_terms(ev.r, lambda sl: effect.design(ev.ctx.rows(sl))[:, -effect.static:], sigma, effect.name)
    beyond = max(t.explained_rms ** 2 - static.explained_rms ** 2, 0.0)
    n = len(ev.r)
    t.p_value = float(stats.chi2.sf(n * beyond / max(sigma, 1e-12) ** 2, t.dof - effect.static))
    t.rms_after = float(np.sqrt(t.rms_after ** 2 + static.explained_rms ** 2))
    t.explained_rms = float(np.sqrt(beyond))
    return t


def _solve(gram: np.ndarray, rhs: np.ndarray, r: np.ndarray, sigma: float, name: str, tone_hz: float = 0.0) -> Test:
    """The fit from its normal equations (the constant is the last column)."""
    n = len(r)
    scale = np.sqrt(np.maximum(np.diag(gram), 1e-300))       # equilibrate: columns of very different size
    w = np.linalg.lstsq(gram / np.outer(scale, scale), rhs / scale, rcond=1e-12)[0] / scale
    mean = float(np.mean(r))
    explained = max(float(w @ rhs) - n * mean * mean, 0.0)      # sum of (fit - mean)^2
    rest = max(float(r @ r) - float(w @ rhs), 0.0)
    k = gram.shape[0] - 1
    p = float(stats.chi2.sf(explained / max(sigma, 1e-12) ** 2, k))
    return Test(name, w[:-1], float(np.sqrt(explained / n)), float(np.sqrt(rest / n)), p, k, tone_hz)


ANGLE_BINS = 1 << 13     # angle bins of the Fourier-domain tests (orders up to 64: under 2.5 % phase error)


def test_fourier(r: np.ndarray, angle: np.ndarray, orders, sigma: float, name: str) -> Test:
    """test_terms for a Fourier series in one angle, in time linear in the samples: the residual is summed
    per angle bin and the series evaluated at the bins' centres."""
    k = np.minimum((np.mod(angle, 2 * np.pi) / (2 * np.pi) * ANGLE_BINS).astype(np.int64), ANGLE_BINS - 1)
    counts = np.bincount(k, minlength=ANGLE_BINS).astype(float)
    sums = np.bincount(k, r, minlength=ANGLE_BINS)
    centre = 2 * np.pi * (np.arange(ANGLE_BINS) + 0.5) / ANGLE_BINS
    xa = np.column_stack([_fourier(centre, orders), np.ones(ANGLE_BINS)])
    return _solve((xa * counts[:, None]).T @ xa, xa.T @ sums, r, sigma, name)


def settled_speed(ctx: Context) -> np.ndarray:
    """The speed estimate once its window is full (before, it comes from shorter windows, as in the hardware)."""
    n = 1 << speed_window_log2(ctx.lines)
    return ctx.speed[n:] if len(ctx.speed) > 2 * n else ctx.speed


def absolute(cal: Calibration | None) -> bool:
    """Whether the position in the revolution is known (a coarse code), so a correction tied to it repeats between
    recordings; an incremental encoder's count starts wherever the recording starts."""
    return cal is None or cal.encoder.lines_per_rev == 1 or \
        (bool(cal.encoder.coarse_bits) and cal.coarse_offset_periods is not None)


#: a speed effect is tested when the speed spreads by at least this fraction of its mean: below, the speed is as good
#: as a constant (a lag is an offset, a skew a quadrature phase error); above, significance and validation decide
SPEED_SPREAD = 0.01


def _period_mean(v: np.ndarray, ctx: Context) -> np.ndarray:
    """v averaged over one electrical period."""
    step = np.mean(np.abs(np.diff(np.unwrap(ctx.phi)))) if len(ctx.phi) > 1 else 0.0
    per_period = int(round(2 * np.pi / step)) if step > 0 else 1
    return ndimage.uniform_filter1d(v, max(1, min(per_period, len(v) // 4)))


def motion_speed(ctx: Context) -> np.ndarray:
    """The settled speed averaged over one electrical period: the motion's speed, not the estimator's ripple (a
    short window's speed carries the fine-phase error's change at the electrical rate, which a steady motion
    would pass off as a speed that changes)."""
    return _period_mean(settled_speed(ctx), ctx)


def reference_motion(meas: Measurement, ctx: Context) -> np.ndarray | None:
    """The reference's speed (rev/s) averaged over one electrical period: the motion as the reference saw it. The
    encoder's own speed also carries its angle error's changes, which on an encoder of few lines vary over the
    revolution even at a steady motion (a speed that seems to change, and a speed effect that seems present)."""
    if meas is None or meas.ref_deg is None or len(meas.ref_deg) < 3:
        return None
    rev = np.unwrap(np.deg2rad(meas.ref_deg)) / (2 * np.pi)
    t = sample_times(len(rev), meas.t_s)
    dt = np.gradient(t)
    return _period_mean(np.gradient(rev) / np.where(dt > 0, dt, 1.0), ctx)


def testable(name: str, ctx: Context, cal: Calibration | None = None, ref_speed: np.ndarray | None = None
             ) -> str | None:
    """Why a domain cannot be tested on this recording (None if it can). ref_speed: the reference's speed
    (reference_motion), which decides whether the motion's speed changes where there is one."""
    needs = LIBRARY[name].needs if name in LIBRARY else ("time",)
    v = motion_speed(ctx) if ref_speed is None else ref_speed
    if "speed" in needs and np.std(v) < SPEED_SPREAD * max(np.mean(np.abs(v)), 1e-12):
        return "the speed hardly changes in this recording, so speed effects cannot be told from a constant"
    if "direction" in needs and (np.all(ctx.direction > 0) or np.all(ctx.direction < 0)):
        return "the recording moves in one direction only"
    if "time" in needs and len(ctx.t) < 200:
        return "too few samples in time"
    if "periods" in needs and ctx.lines < REVOLUTION_MIN_LINES:
        return (f"with {ctx.lines} signal period(s) per revolution the revolution and the fine phase are nearly "
                "the same angle: a change over the revolution is a waveform that differs between periods, not "
                "named as offsets and gains")
    if "periods" in needs:
        return revolution_untestable(ctx, cal)
    return None


def revolution_untestable(ctx: Context, cal: Calibration | None) -> str | None:
    """Why no correction tied to the place in the revolution can be fitted (None if one can). With 2 or 3 periods
    per revolution a change over the revolution is not named (testable), but what the declared model leaves of it
    is still corrected, without a name, by the general dictionary's revolution block (fine-phase orders x
    revolution orders, chosen on held-out data). With one period the revolution is the fine phase: the waveform
    tables own its errors."""
    if ctx.lines < 2:
        return "with 1 signal period per revolution the revolution is the fine phase: the tables own its errors"
    if not ctx.revolution_covered:
        return (f"the recording does not visit every one of {REVOLUTION_SECTORS} sectors of the revolution: a "
                "correction tied to the place in the revolution would be extrapolated to the rest")
    if not absolute(cal):
        return ("the encoder has no coarse code, so the place in the revolution is not known and a correction tied "
                "to it would not repeat in another recording")
    return None


WAVE_HARMONICS = 32  # at a steady speed, channel lines at these multiples of the electrical frequency are waveform
LINE_WINDOW = 64      # bins either side for the local spectral level of the line detector


def find_line(x: np.ndarray, fs: float, exclude_hz=(), near_hz: float | None = None
              ) -> tuple[float, float, int] | None:
    """The strongest line of x's spectrum against the local spectral level, over the whole band up to
    Nyquist: (frequency in Hz, or cycles per sample at fs = 1; its level over the local one; bins
    searched). A periodogram bin of noise is exponential about the local mean, so a bin q times the
    local mean has the chance exp(-q), and the strongest of N bins N exp(-q). The slowest bins belong to
    the drift test; bins within 1.5 bins of `exclude_hz` are not offered; with `near_hz`, only the bins within
    2 bins of it (whether a line known beforehand is there: N is then those few bins)."""
    if len(x) < 256:
        return None
    f, p = signal.periodogram(x, fs, window="hann", detrend="linear")
    local = ndimage.median_filter(p, size=2 * LINE_WINDOW + 1, mode="reflect") / np.log(2)
    q = p / np.maximum(local, 1e-300)
    q[f <= 16 * f[1]] = 0.0
    for ex in exclude_hz:
        q[np.abs(f - ex) <= 1.5 * f[1]] = 0.0
    if near_hz is not None:
        q[np.abs(f - near_hz) > 2 * f[1]] = 0.0
    if not np.any(q > 0):
        return None
    k = int(np.argmax(q))
    return float(f[k]), float(q[k]), int(np.count_nonzero(q))


def refine_frequency(x: np.ndarray, t: np.ndarray, f0: float, bin_hz: float, points: int = 41) -> float:
    """The line's frequency between the periodogram's bins: the largest projection of x on a complex tone, on a
    grid within one bin of f0, then polished to a ten-thousandth of a bin (a frequency off by a twentieth of a bin
    drifts the phase by 0.3 rad over the recording, which leaves a sixth of the line uncorrected)."""
    from scipy.optimize import minimize_scalar

    xc = x - x.mean()

    def power(f):
        return abs(np.exp(-2j * np.pi * f * t) @ xc)

    grid = f0 + bin_hz * np.linspace(-1.0, 1.0, points)
    k = int(np.argmax([power(f) for f in grid]))
    step = grid[1] - grid[0]
    best = minimize_scalar(lambda f: -power(f), bounds=(grid[k] - step, grid[k] + step), method="bounded",
                           options={"xatol": 1e-4 * bin_hz})
    return float(best.x) if -best.fun >= power(grid[k]) else float(grid[k])


def line_p_value(found) -> float:
    if not found:
        return 1.0
    _, q, searched = found
    return float(min(1.0, searched * np.exp(-q)))


def steady_rate(ctx: Context) -> float | None:
    """The revolution rate (rev/s) when the speed is steady (it varies by less than 5 %), else None."""
    v = settled_speed(ctx)
    return float(np.mean(v)) if np.std(v) < 0.05 * np.mean(np.abs(v)) else None


def channel_errors(ev: Evaluation, with_phase: bool = False):
    """Each channel's reading minus the calibrated waveform at the reference's fine phase (ADC codes,
    shape (2, n)): an additive tone shows here as a line at its frequency; an angle error (a vibration)
    only through the waveform's slope, modulated by the fine phase. With `with_phase`, also that phase
    (periods) and the waveforms: (errors, phase, waves)."""
    from ..hardware.closed_loop import channel_waveforms

    if ev.meas is None or ev.cal is None or not ev.cal.waves:
        return None
    waves = channel_waveforms(ev.cal)
    sin, cos = ev.meas.sin, ev.meas.cos
    if ev.cal.adaptive:     # the readings behind the drift tracker, which takes the slow offsets and gains out
        sin, cos = tracked_readings(ev.cal, sin, cos)
    elif ev.cal.rev_norm is not None:     # as the waveform stage sees them (normalised per sector)
        sin, cos = ev.cal.rev_norm.apply(sin, cos, ev.ctx.psi)
    frac = ev.ctx.phi / (2 * np.pi)
    # the terms after the arctan (the phase-table structure's fine-phase map, a skew's or a hysteresis' phase
    # correction, any shape of the general dictionary) correct the measured phase to the disc's: the channels follow
    # the phase they correct to, as they follow the phase the residual corrects to (same frame: output-angle
    # error). Left out, a speed-dependent correction (a skew at a changing speed) spread an additive tone's line
    # in the channels over the sidebands of the electrical frequency, and the tone went unnamed
    terms = ev.cal.angle_terms
    error = ev.r + sum(t.predict(ev.ctx) for t in terms) if terms else ev.r
    dfrac = error * ev.ctx.lines / ARCSEC_PER_REV      # as a fraction of a period
    # the residual is in the output's frame, the fine phase in the encoder's: the calibration's direction turns one
    # into the other (choosing the sign that left the smaller channel errors took the wrong one where the residual
    # held an additive tone's angle image: the reference phase then carried the image, and the line went unseen)
    ref = frac - (ev.cal.direction or 1) * dfrac
    e = np.stack([sin - waves["sin"](ref), cos - waves["cos"](ref)])
    return (e, ref, waves) if with_phase else e


def explained(x: np.ndarray, y: np.ndarray) -> float:
    """The power (sum of squares) of y that least squares on the columns of x explains."""
    w, *_ = np.linalg.lstsq(x, y, rcond=None)
    fit = x @ w
    return float(fit @ fit)


def vibration_sideband(chan: np.ndarray, phase: np.ndarray, waves: dict, t: np.ndarray, f_chan: float,
                       candidates) -> float | None:
    """Whether a line at f_chan in the channels is a vibration's sideband rather than additive interference. A
    vibration v(t) at f_v moves the phase: each channel errs by its waveform's slope times it, W'(theta) v(t),
    lines at f_v +- the electrical frequency; an additive tone adds the same line to a channel at any phase.
    The two models are fitted to both channels' errors (the vibration with two weights shared by the channels,
    at each f_v of `candidates`: |f_chan -+ electrical| at a steady speed; at a changing one the sidebands wander,
    and the angle's own line is the vibration's frequency to try; the tone with two per channel): the
    vibration's frequency (Hz) when it explains more, else None."""
    def slope(kind):
        h = 1e-4
        return (waves[kind](phase + h) - waves[kind](phase - h)) / (2 * h)

    y = chan - chan.mean(axis=1, keepdims=True)
    tone = sum(explained(np.column_stack([np.cos(2 * np.pi * f_chan * t), np.sin(2 * np.pi * f_chan * t)]), e)
               for e in y)
    ds = np.concatenate([slope("sin"), slope("cos")])
    stacked = np.concatenate(list(y))
    best = None
    for f_v in candidates:
        tt = np.concatenate([t, t])
        p = explained(np.column_stack([ds * np.cos(2 * np.pi * f_v * tt), ds * np.sin(2 * np.pi * f_v * tt)]),
                      stacked)
        if p > tone and (best is None or p > best[0]):
            best = (p, f_v)
    return None if best is None else best[1]


def folded(f, fs: float):
    """Frequencies as the sampling at fs sees them, folded into 0..fs/2."""
    return np.abs((f + fs / 2) % fs - fs / 2)


def revolution_order(f: float, rate: float, fs: float, lines: int, tol: float) -> int:
    """The lowest revolution order n whose frequency n x rate, folded into 0..fs/2 by the sampling, lies within
    `tol` of f (0: none). Orders up to WAVE_HARMONICS times the lines: a position error at a high fine-phase order
    (sidebands of the electrical frequency's harmonics) is sampled as well as a low one."""
    n = np.arange(1, WAVE_HARMONICS * max(lines, 1) + 3)
    hits = np.flatnonzero(np.abs(folded(n * rate, fs) - f) <= tol)
    return int(n[hits[0]]) if len(hits) else 0


UPDATE_ORDERS = 4       # multiples of an online block's update rate, and the electrical harmonics, whose mixing
RIPPLE_HARMONICS = 8    # is that block's own ripple (9 x 8 lines: a few % of the band leave the tone search)


def update_ripple(f: float, cal: Calibration | None, fs: float, electrical: float, tol: float) -> str:
    """Whether a line at f (Hz) is an online block's ripple at a steady speed: the drift tracker and the canceller
    change their state once per block of 2^BLOCK_LOG2 samples, and the step mixes with the fine phase's harmonics
    into lines at |k fe + j fs / 2^BLOCK_LOG2| (folded by the sampling); the tracker's lag leaves the orders of
    what it tracks, offsets and gains (k = 1, 2 with j = 0; 9227: 340.66 Hz at 341.2 Hz electrical). A "tone"
    there would be an artefact of the set-up corrected away from the score, while the core itself makes it.
    Returns the explanation, or ""."""
    if cal is None:
        return ""
    k = np.arange(0, RIPPLE_HARMONICS + 1)[:, None]
    j = np.arange(-UPDATE_ORDERS, UPDATE_ORDERS + 1)[None, :]
    blocks = (("the drift tracker's", cal.tracker.get("drift_block_log2") if cal.adaptive else None, True),
              ("the canceller's", cal.canceller.get("cancel_block_log2") if cal.canceller else None, False))
    for who, log2, lag in blocks:
        if log2 is None:
            continue
        rate = fs / (1 << int(log2))
        own = (j != 0) | (lag & (k >= 1) & (k <= 2))
        hit = np.argwhere(own & (np.abs(folded(k * electrical + j * rate, fs) - f) <= tol))
        if len(hit):
            kk, jj = int(k[hit[0][0], 0]), int(j[0, hit[0][1]])
            if jj == 0:
                return f"{kk} x the electrical frequency, the order of the offsets and gains the drift tracker follows"
            return (f"{kk} x the electrical frequency {'+' if jj > 0 else '-'} {abs(jj)} x {who} update rate "
                    f"({rate:.4g} Hz)")
    return ""


def tone_candidates(ev: Evaluation, known_hz=()) -> tuple[list[tuple[str, float, float, bool]], list[str]]:
    """Lines in time: (name, Hz, p-value of the strongest of the searched lines, whether it lies on a steady
    revolution harmonic) and notes on what stays ambiguous. A line in the angle residual with none in the
    channels is a vibration ("tone"); a line in the channels is additive interference (the angle shows it as
    sidebands at +- the electrical frequency). Lines at `known_hz` (already corrected or rejected) are not
    offered again. The spectra are taken on the longest run of evenly spaced samples (a long recording is
    decided on runs of it), frequencies in the units of its time stamps."""
    run = uniform_run(ev.ctx.t)
    t, x = ev.ctx.t[run], ev.r[run]
    fs = sample_rate(t)
    bin_hz = fs / len(x)
    rate = steady_rate(ev.ctx)
    electrical = abs(rate) * ev.ctx.lines if rate else None
    out, notes = [], []
    got = channel_errors(ev, with_phase=True)
    chan = None if got is None else got[0][:, run]
    chan_found = None
    angle = find_line(x, fs, known_hz)
    angle = angle if angle and line_p_value(angle) < P_VALUE else None
    f_angle = refine_frequency(x, t, angle[0], bin_hz) if angle else None
    if chan is not None:
        # at a steady speed the waveform's own errors sit at the low multiples of the electrical frequency (a
        # waveform model's orders); a line at a high multiple is interference
        harmonics = [k * electrical for k in range(1, WAVE_HARMONICS + 1)] if electrical else []
        found = [find_line(e, fs, [*harmonics, *known_hz]) for e in chan]
        if any(found):
            which = int(np.argmax([f[1] if f else -1.0 for f in found]))
            chan_found = found[which]
            chan_found = (refine_frequency(chan[which], t, chan_found[0], bin_hz), *chan_found[1:])
            p = min(1.0, 2 * line_p_value(chan_found))
            f_c = chan_found[0]
            trial = (abs(f_c - electrical), f_c + electrical) if electrical else (f_angle,) if f_angle else ()
            f_v = vibration_sideband(chan, got[1][run], got[2], t, f_c, trial) if p < P_VALUE else None
            if f_v is not None:
                notes.append(f"the line at {chan_found[0]:.3f} Hz in the channels is a sideband of a vibration at "
                             f"{f_v:.3f} Hz (the waveform's slope times a tone in the angle explains it better than "
                             "an additive tone): not interference")
                chan_found = None
            elif p < P_VALUE:
                out.append(("interference", chan_found[0], p, False))
            else:       # no line stands out in the channels: nothing for the angle's line to be a sideband of
                chan_found = None
    if angle:
        f = f_angle
        # interference in the channels: the one found now, and the one the canceller already takes out (what it
        # leaves, its start-up above all, shows in the angle as the same sidebands: 9229)
        images = ([chan_found[0]] if chan_found is not None else []) + \
            ([float(ev.cal.canceller["tone_hz"])] if ev.cal is not None and ev.cal.canceller else [])
        if electrical:
            sideband = any(min(abs(f - f_i - electrical), abs(f - f_i + electrical)) <= 2 * bin_hz for f_i in images)
        else:
            # a changing speed spreads the interference's sidebands over +- the fastest electrical frequency: the
            # angle's line is one of them if most of its power goes once the interference's angle image is taken
            # out (the line at f itself: a stronger line elsewhere in the rest, as the vibration's own harmonic, is
            # no evidence that this one went, and 9246 lost a 2939" vibration that way; the image's fit leaves a
            # part of a sideband)
            sideband = False
            for f_i in images:
                img = interference_columns(ev.ctx, f_i)[run]
                rest = x - img @ np.linalg.lstsq(img, x, rcond=None)[0]
                left = find_line(rest, fs, known_hz, near_hz=f)
                sideband = sideband or not (left and line_p_value(left) < P_VALUE and left[1] >= 0.5 * angle[1])
        order = revolution_order(f, abs(rate), fs, ev.ctx.lines, 1.5 * bin_hz) if rate else 0
        harmonic = order >= 1
        ripple = update_ripple(f, ev.cal, fs, electrical, 1.5 * bin_hz) if electrical else ""
        if harmonic and not ripple:     # a steady revolution harmonic covers every few bins: say so, keep it
            notes.append(f"the line at {f:.3f} Hz is harmonic {order} of the steady revolution rate "
                         f"({abs(rate):.4g} rev/s): in the angle alone a vibration and a position error at that order "
                         "look the same within one recording; it is corrected as a tone in time (ambiguous)")
        if ripple:
            notes.append(f"the line at {f:.3f} Hz is {ripple}: the core makes it, so it is not a tone of the set-up")
        elif not sideband:
            out.append(("tone", f, line_p_value(angle), harmonic))
    if chan is None:
        notes.append("channel-domain test not run (the calibration has no per-channel waveform): a line in the "
                     "angle cannot be told from interference")
    return out, notes


GENERIC_ABOVE_FLOOR = 1.05
NAMED_SHARE = 0.1       # of the variance the best general shape explains, a named effect must explain this much
SEARCH_ROWS = 1 << 17    # the term tests run on at most this many rows (evenly strided): ample power, bounded time


def strided(ev: Evaluation) -> Evaluation:
    """Every k-th row of a long evaluation, for the term tests (the tone search keeps every sample)."""
    step = -(-len(ev.r) // SEARCH_ROWS)
    if step <= 1:
        return ev
    sl = slice(None, None, step)
    r = ev.r[sl]
    return Evaluation(r, ev.ctx.rows(sl), ev.figures, float(np.sqrt(np.mean(r * r))), None, ev.cal,
                      None if ev.ref_speed is None else ev.ref_speed[sl])


SMOOTH_BLOCKS = 64    # interleaved blocks: the magnitude's slow shape is fitted on every other one


def smooth_magnitude(ctx: Context) -> np.ndarray:
    """The magnitude's changes without its per-sample noise: its projection on fine-phase orders 0..AMPLITUDE_ORDERS
    crossed with slow functions of time and the first revolution harmonics (where a gain over the revolution, a
    drift or a skew at a changing speed moves it), fitted on every other block of samples and evaluated on the
    blocks between, so that no sample's own noise is in its value. The static shape of the radius over the fine
    phase is left out (a change of nothing: it leaves static fine-phase error)."""
    m = ctx.magnitude - ctx.magnitude.mean()
    slow = _slow_time(ctx) + (_slow_revolution(ctx) if ctx.lines > 1 else [])
    return ctx.magnitude.mean() + cross_fit(_magnitude_shapes(ctx, slow), m, SMOOTH_BLOCKS)


def _slow_time(ctx: Context) -> list[np.ndarray]:
    return list(_legendre_time(ctx, 3))


def _slow_revolution(ctx: Context) -> list[np.ndarray]:
    return [f(k * ctx.psi) for k in (1, 2) for f in (np.cos, np.sin)]


def _magnitude_shapes(ctx: Context, slow: list[np.ndarray]) -> np.ndarray:
    """Fine-phase orders 0..AMPLITUDE_ORDERS (the amplitude term's shape) times each slow function."""
    return np.column_stack([p * q for p in amplitude_phase_columns(ctx.phi) for q in slow])


def magnitude_follows_time(ctx: Context) -> bool:
    """Whether the magnitude's changes (fine-phase orders 0..AMPLITUDE_ORDERS times slow shapes, held out on
    interleaved blocks) follow time better than the place in the revolution: what a drift tracker leaves (it
    follows the gains late) against a gain tied to the revolution (air gap, eccentricity)."""
    if ctx.lines <= 1:
        return True
    m = ctx.magnitude - ctx.magnitude.mean()

    def held_out(slow) -> float:
        return float(np.sum((m - cross_fit(_magnitude_shapes(ctx, slow), m, SMOOTH_BLOCKS)) ** 2))

    return held_out(_slow_time(ctx)) < held_out(_slow_revolution(ctx))


NOISE_SHARE = 0.25    # of what the term explains, the noise-free magnitude must explain this much (variance)


def magnitude_noise_only(ev: Evaluation, t: Test, sigma: float) -> bool:
    """Whether an amplitude term explains the residual only through the magnitude's noise: the radial noise of a
    sample moves its reading along the waveform tables' curve (calibrated at the mean amplitude) and so its angle;
    the term then corrects noise sample by sample, a small real gain but not an amplitude effect. Judged by the same
    term on the noise-free magnitude (smooth_magnitude): it must be significant and explain NOISE_SHARE of what the
    term explains."""
    if t.explained_rms <= 0:
        return False
    quiet = dataclasses.replace(ev, ctx=dataclasses.replace(ev.ctx, magnitude=smooth_magnitude(ev.ctx)))
    slow = test_library_effect(quiet, LIBRARY["amplitude"], sigma)
    return slow.p_value >= P_VALUE or slow.explained_rms ** 2 < NOISE_SHARE * t.explained_rms ** 2


def reference_context(ev: Evaluation) -> Context | None:
    """The context with the motion (speed, acceleration, direction) of the reference instead of the encoder's own
    estimate. The encoder's speed is a difference of its own positions, so it carries the noise of the sample being
    corrected: on a noisy encoder a speed term fitted to it cancels part of that noise (it acts as a smoothing
    filter) and passes for a speed effect. The reference's motion is free of the encoder's noise, and a physical
    speed or direction effect shows against it as well."""
    if ev.ref_speed is None or ev.cal is None or len(ev.r) < 3:
        return None
    v = ev.cal.direction * ev.ref_speed           # the reference may count the other way
    return dataclasses.replace(ev.ctx, speed=v, accel=np.gradient(v, ev.ctx.t), direction=np.where(v >= 0, 1, -1))


def in_own_noise(ev: Evaluation, moving: Context | None, name: str, t: Test, sigma: float) -> bool:
    """Whether a significant motion effect shows only through the encoder's own motion estimate (its noise): against
    the reference's motion it is not testable (a direction that changes only in the encoder's estimate), not
    significant, or would not lower the residual by MIN_GAIN. The encoder's estimate carries the physical
    effect and the noise alike, so the share they explain is not compared, only whether the physical one is
    there at all."""
    effect = LIBRARY[name]
    if moving is None or t.p_value >= P_VALUE or not {"speed", "direction"} & set(effect.needs):
        return False
    if testable(name, moving, ev.cal, ev.ref_speed):
        return True
    ref = test_library_effect(dataclasses.replace(ev, ctx=moving), effect, sigma)
    return ref.p_value >= P_VALUE or ref.rms_after > (1 - MIN_GAIN) * ev.rms


def candidates(ev_full: Evaluation, sigma: float, exclude: set) -> tuple[list[Test], dict]:
    tests, skipped = [], {}
    ev = strided(ev_full)
    moving = reference_context(ev)
    for name in LIBRARY:
        if name in exclude:
            continue
        why = testable(name, ev.ctx, ev.cal, ev.ref_speed)
        if why:
            skipped[name] = why
            continue
        t = test_library_effect(ev, LIBRARY[name], sigma)
        # (not behind an online correction: what the tracker or the canceller leaves moves the magnitude in time,
        # outside the slow shapes the check knows, and magnitude_cause names it)
        online = ev.cal is not None and (ev.cal.adaptive or ev.cal.canceller)
        if name == "amplitude" and not online and magnitude_noise_only(ev, t, sigma):
            skipped[name] = ("it follows the magnitude's noise, not its changes: the radial noise of the sample being "
                             "corrected, read through the waveform tables' curvature, not a change of amplitude")
            continue
        if in_own_noise(ev, moving, name, t, sigma):
            skipped[name] = ("it shows against the encoder's own speed estimate but not against the reference's "
                             "motion: the noise of the sample being corrected, which a speed term would smooth, "
                             "not a physical effect")
            continue
        tests.append(t)
    known_hz = [float(e.split("@")[1]) for e in exclude if "@" in e]
    lines, notes = tone_candidates(ev_full, known_hz)
    for name, f, p_line, harmonic in lines:
        t = test_terms(ev_full.r, _design(name, ev_full.ctx, f), sigma, name, f)
        t.p_value = max(t.p_value, p_line)      # the line must stand out of its neighbours, and the term explain
        t.ambiguous = harmonic
        tests.append(t)
    if notes:
        skipped["tones"] = "; ".join(notes)
    if ev.rms > GENERIC_ABOVE_FLOOR * sigma:      # near the floor nothing is left for a shape without a name
        tests += generic_candidates(ev, sigma, exclude)
    return tests, skipped


GENERIC_NEEDS = {"speed": "speed", "speed2": "speed", "direction": "direction", "revolution": "periods",
                 "time": "time"}
# the library effect whose conditions gate a factor (the revolution factor has its own: revolution_untestable)
GENERIC_PROBE = {"speed": "ref_lag", "direction": "hysteresis", "time": "drift"}
CV_BLOCKS = 200     # interleaved blocks of the two-fold cross-validation


def _fold_grams(ev: Evaluation, design, width: int):
    """Normal equations of a design (plus a constant) on each half of the two-fold cross-validation."""
    r, n = ev.r, len(ev.r)
    fold = (np.arange(n) * CV_BLOCKS // n) % 2
    grams = [np.zeros((width + 1,) * 2) for _ in range(2)]
    rhs = [np.zeros(width + 1) for _ in range(2)]
    for start in range(0, n, CHUNK):
        sl = slice(start, min(n, start + CHUNK))
        xa = np.column_stack([design(sl), np.ones(sl.stop - sl.start)])
        for f in (0, 1):
            m = fold[sl] == f
            grams[f] += xa[m].T @ xa[m]
            rhs[f] += xa[m].T @ r[sl][m]
    rr = [float(r[fold == f] @ r[fold == f]) for f in (0, 1)]
    return grams, rhs, rr


def _held_out(grams, rhs, rr, idx) -> tuple[float, float]:
    """Held-out sum of squares of the columns idx (the constant last), and of the constant alone."""
    held = base = 0.0
    for a, b in ((0, 1), (1, 0)):
        g, y = grams[a][np.ix_(idx, idx)], rhs[a][idx]
        sc = np.sqrt(np.maximum(np.diag(g), 1e-300))
        w = np.linalg.lstsq(g / np.outer(sc, sc), y / sc, rcond=1e-12)[0] / sc
        gb, yb = grams[b][np.ix_(idx, idx)], rhs[b][idx]
        held += rr[b] - 2 * w @ yb + w @ gb @ w
        mean_a = rhs[a][-1] / grams[a][-1, -1]
        base += rr[b] - 2 * mean_a * rhs[b][-1] + mean_a ** 2 * grams[b][-1, -1]
    return float(held), float(base)


def cv_held_out(ev: Evaluation, design, width: int) -> float:
    grams, rhs, rr = _fold_grams(ev, design, width)
    return _held_out(grams, rhs, rr, list(range(width + 1)))[0]


def generic_cv(ev: Evaluation, factor: str) -> tuple[float, float, str]:
    """The factor's best orders by two-fold cross-validation: (held-out SSE, held-out SSE of a constant, name)."""
    ctx = ev.ctx
    kmax = max(GENERIC_PHASE_ORDERS) if factor != "revolution" else 4
    mmax = max(GENERIC_REV_ORDERS[:3]) if factor == "revolution" else 0
    nf = len(factor_columns(factor, ctx.rows(slice(0, 1)), mmax))
    npc = 2 * kmax + (factor != "1")
    grams, rhs, rr = _fold_grams(ev, lambda sl: generic_design(generic_name(factor, kmax, mmax), ctx.rows(sl)),
                                 nf * npc)
    best = None
    for k in [k for k in GENERIC_PHASE_ORDERS if k <= kmax]:
        for mm in ([m for m in GENERIC_REV_ORDERS if m <= mmax] or [0]):
            keep_f = 2 * mm if factor == "revolution" else nf
            keep_p = 2 * k + (factor != "1")
            idx = [fi * npc + pj for fi in range(keep_f) for pj in range(keep_p)] + [nf * npc]
            held, base = _held_out(grams, rhs, rr, idx)
            if best is None or held < best[0]:
                best = (held, base, generic_name(factor, k, mm))
    return best


def generic_candidates(ev: Evaluation, sigma: float, exclude: set) -> list[Test]:
    """The general dictionary: for each factor, fine-phase orders 0..K (and revolution orders 1..M) chosen by
    two-fold cross-validation on interleaved blocks of the fit data (fitted on one half, scored on the other,
    and the other way round); the best order of each factor is offered as a "generic" term when it lowers
    the held-out error by at least MIN_GAIN."""
    ctx, r = ev.ctx, ev.r
    if len(r) < 2000:
        return []
    out = []
    moving = reference_context(ev)
    for factor in GENERIC_FACTORS:
        need = GENERIC_NEEDS.get(factor)
        why = revolution_untestable(ctx, ev.cal) if need == "periods" else \
            need and testable(GENERIC_PROBE[need], ctx, ev.cal, ev.ref_speed)
        if why:
            continue
        if any(e.startswith(f"generic:{factor}:") for e in exclude):
            continue
        held, base, name = generic_cv(ev, factor)
        if held > (1 - MIN_GAIN) ** 2 * base:
            continue
        if need in ("speed", "direction") and moving is not None:
            # as in_own_noise for the library's motion effects: a motion shape must also predict held-out data
            # against the reference's motion, or it is the encoder's own noise (a speed estimate carries the
            # sample being corrected, and the angle error's own changes) that it smooths
            held_ref, base_ref, _ = generic_cv(dataclasses.replace(ev, ctx=moving), factor)
            if held_ref > (1 - MIN_GAIN) ** 2 * base_ref:
                continue
        out.append(test_terms(r, lambda sl, nm=name: generic_design(nm, ctx.rows(sl)), sigma, name))
    return out


#: library effects carried as angle terms, and the factor of the general dictionary their signature lies in
SHAPE_FACTOR = {"sampling_skew": "speed", "hysteresis": "direction", "amplitude": "magnitude"}


def widen(best: Test, ev: Evaluation, sigma: float) -> Test:
    """A named effect with the shape the data asks for: when the general dictionary's block of the same factor
    (orders chosen by cross-validation) predicts held-out data better than the library's fixed shape by at
    least MIN_GAIN, the name stays and the block is the correction (e.g. a large channel skew needs more than
    the one-term shape)."""
    factor = SHAPE_FACTOR.get(best.name)
    if factor is None or len(ev.r) < 2000:
        return best
    held, _, name = generic_cv(ev, factor)
    lib = LIBRARY[best.name]
    width = lib.design(ev.ctx.rows(slice(0, 1))).shape[1]
    lib_held = cv_held_out(ev, lambda sl: lib.design(ev.ctx.rows(sl)), width)
    if held > (1 - MIN_GAIN) ** 2 * lib_held:
        return best
    t = test_terms(ev.r, lambda sl: generic_design(name, ev.ctx.rows(sl)), sigma, name)
    t.label = best.name
    return t


#: the general dictionary's factors whose shapes belong to one library effect
FACTOR_EFFECT = {"magnitude": "amplitude", "magnitude2": "amplitude", "direction": "hysteresis",
                 "speed": "sampling_skew"}


def generic_effect(name: str) -> str | None:
    """The library effect whose wider form a shape of the general dictionary is (by its factor), if any."""
    return FACTOR_EFFECT.get(parse_generic(name)[0])


FAMILY_SHARE = 0.5      # of the variance a general shape explains, a library effect of its factor explaining this
                        # much is the better first step (the rest shows in the next iteration)


def family_holds(shape: Test, good: list[Test]) -> bool:
    """Whether a library effect whose shape lies in the same factor as a general-dictionary shape explains most of
    what the shape explains: then the name goes in by itself (a reference lag is speed x order 0, inside every
    speed shape), and the shape may not stand in for another effect of that factor."""
    need = GENERIC_NEEDS.get(parse_generic(shape.name)[0])
    return any(need in LIBRARY[t.name].needs and t.explained_rms ** 2 >= FAMILY_SHARE * shape.explained_rms ** 2
               for t in good if t.name in LIBRARY and not t.ambiguous)


def speed_holds(shape: Test, good: list[Test]) -> bool:
    """Whether a magnitude shape of the general dictionary may be a speed effect seen through the magnitude (a
    channel skew changes the corrected magnitude in proportion to speed): a speed shape, named or not, explains
    half of what it does."""
    if generic_effect(shape.name) != "amplitude":
        return False
    return any(t.explained_rms ** 2 >= FAMILY_SHARE * shape.explained_rms ** 2 for t in good
               if (t.name in LIBRARY and "speed" in LIBRARY[t.name].needs)
               or (t.name.startswith("generic:") and GENERIC_NEEDS.get(parse_generic(t.name)[0]) == "speed"))


def named_shape(best: Test, tests: list[Test], rms: float) -> Test:
    """A shape of the general dictionary is the wider form of the library effect of its factor when that effect
    is itself present (its fixed shape significant, and it matters): the name goes with it (as `widen` does the
    other way round)."""
    if not best.name.startswith("generic:") or best.label:
        return best
    effect = generic_effect(best.name)
    if any(t.name == effect and t.p_value < P_VALUE and t.rms_after < (1 - MIN_GAIN) * rms for t in tests):
        best.label = effect
    return best


TONE_EFFECT = dict(cause="a tone in time: vibration between encoder and reference, or interference",
                   correction="artefact", where="the measurement set-up; nothing in the hardware")


def describe(name: str) -> dict:
    if name.startswith("generic:"):
        factor, k, m = parse_generic(name)
        carried = GENERIC_FACTORS[factor]
        what = f"fine-phase orders 0..{k} times {factor}" + (f" (revolution orders 1..{m})" if m else "")
        return {**GENERIC, "signature": what + "; unexplained by name",
                "correction": "hardware" if carried else "float engine",
                "where": "fringe_trim's tables" if carried else "the float engine (no core block carries it)"}
    if name == "tone":
        return TONE_EFFECT
    if name == "interference":
        return INTERFERENCE
    e = LIBRARY[name]
    return {"cause": e.cause, "signature": e.signature, "correction": e.correction, "where": e.where}


def apply(state: LoopState, t: Test, fit_data: Measurement) -> LoopState:
    new = LoopState(dataclasses.replace(state.cal, angle_terms=list(state.cal.angle_terms)), list(state.artefacts),
                    state.ref_lag_s)
    kind = {"tone": "artefact", "interference": "canceller"}.get(t.name) or \
        (describe(t.name)["correction"] if t.name.startswith("generic:") else LIBRARY[t.name].correction)
    fitted = FittedEffect(t.name, t.weights, t.tone_hz, "float" if kind == "float engine" else "core")
    if t.name == "ref_lag":
        # r = direction * speed * lag: shift the reference, calibrate again without the lag in it, and
        # repeat (the first calibration absorbed part of the lag into its long-period table)
        w = float(t.weights[0])
        for _ in range(8):     # each round leaves a fraction of the lag: iterate until it is negligible
            new.ref_lag_s += w * state.cal.direction / ARCSEC_PER_REV
            fresh = recalibrate(shift_reference(fit_data, new.ref_lag_s), state.cal)
            new.cal = carry_loop(fresh, state.cal)
            ev = evaluate(LoopState(new.cal, [], new.ref_lag_s), fit_data)
            w = float(test_terms(ev.r, LIBRARY["ref_lag"].design(ev.ctx), 1.0, "ref_lag").weights[0])
            if abs(w) * np.std(ev.ctx.speed) < 0.01 * noise_sigma(ev.r):
                break
    elif t.name == "rev_offset_gain":
        new.cal = fit_rev_offset_gain(new.cal, shift_reference(fit_data, state.ref_lag_s))
    elif kind in ("hardware", "float engine"):
        new.cal.angle_terms.append(fitted)
        meas = shift_reference(fit_data, state.ref_lag_s)
        tones = [a for a in new.artefacts if a.name == "tone"]
        # with tones found before, the declared model is calibrated again without them (as when they were
        # found): calibrated on readings that hold them, its long-period table would take part of them back
        new.cal = refit_around_tone(new.cal, tones, meas) if tones else refit_angle_terms(new.cal, meas, as_is=True)
    elif kind == "adaptive":
        new.cal = choose_tracker(dataclasses.replace(new.cal, adaptive=True), new, fit_data)
    elif kind == "canceller":
        meas = shift_reference(fit_data, state.ref_lag_s)
        new.cal = choose_canceller(refit_around_interference(new.cal, new, meas, t.tone_hz), new, meas, t.tone_hz)
    else:
        new.artefacts.append(fitted)
        if t.name == "tone":     # the declared model was fitted with the tone in its residual: fit it without
            new.cal = refit_around_tone(new.cal, [a for a in new.artefacts if a.name == "tone"],
                                        shift_reference(fit_data, state.ref_lag_s))
    return new


def recalibrate(meas: Measurement, cal: Calibration, known_error_arcsec: np.ndarray | None = None) -> Calibration:
    """The declared model calibrated again, in the structure the loop chose for `cal` (the per-channel waveform
    inverse, or the phase-domain structure of `phase_domain`), with a known error held out of it."""
    from ..calib.calibrate import CANDIDATES, PHASE_TABLE, WAVEFORM, CalibrationOptions

    chosen = cal.fit.get("model_choice", {}).get("chosen")
    if cal.fit.get("phase_domain"):    # whether to centre the phase table is chosen once, then kept
        structure, centre = (CANDIDATES[chosen] if chosen and CANDIDATES[chosen][0] == PHASE_TABLE
                             else (PHASE_TABLE, None))
    else:   # the structure the declared model's calibration chose on held-out data, not chosen again
        # (none chosen: a structure given to calibrate, or the reference-free calibration)
        structure, centre = CANDIDATES[chosen] if chosen else (cal.fit.get("structure") or WAVEFORM, False)
    fresh = calibrate(meas, cal.encoder, CalibrationOptions(structure=structure, gain_centre=centre,
                                                            known_error_arcsec=known_error_arcsec))
    if cal.fit.get("phase_domain"):
        fresh.fit["phase_domain"] = True
    return fresh


def carry_loop(fresh: Calibration, cal: Calibration, **changes) -> Calibration:
    """A fresh calibration of the declared model with the closed loop's additions of `cal` carried over."""
    kept = dict(rev_norm=cal.rev_norm, adaptive=cal.adaptive, tracker=dict(cal.tracker),
                canceller=dict(cal.canceller), angle_terms=list(cal.angle_terms),
                start_speed_rev_s=cal.start_speed_rev_s)
    return dataclasses.replace(fresh, **{**kept, **changes})


# fringe_drift's update block and final step (its gear shift starts at 1): together the settled tracker's time
# constant, 2^(block + mu) samples. Short blocks start up soon after reset (with DRIFT_HOLD = 1 each update applies at
# the next block's first sample): until the first update the readings carry all of the drift at power-up, which can
# be most of a recording's excess error (9214: 12" in the first 32 samples against a 0.44" floor); long ones update
# with the gear's large first steps on a slower motion (a block of less than a period takes the final step only,
# and one of less than a sixteenth of a period none)
TRACKER_BLOCK_LOG2 = (4, 5, 6, 7, 8, 10, 12)
# The same true loop gains as (0, 1, 2, 4) before the offset step was doubled; MU_LOG2 = 0 keeps a step of 1, whose
# offset gain reaches 2 on a block that sweeps a short arc back and forth (docs/blocks/fringe_drift.md, "Loop gain");
# blocks of less than a period update only from MU_LOG2 = 2 on ("Partial sweeps": at 1 an arc swept back and forth
# near a channel's peak drove the gain to 0), which the choice on the fit recording took wherever most blocks were
# partial
TRACKER_MU_LOG2 = (1, 2, 3, 5)


def choose_tracker(cal: Calibration, state: LoopState, meas: Measurement) -> Calibration:
    """The drift tracker's constants that leave the least error on the fit data: a fast tracker follows a fast
    drift but passes more noise into the phase, a slow one the reverse; the best trade-off depends on the drift
    and the noise of this encoder, so it is measured, not fixed. (The tracker has no fitted weights: its
    in-sample error is a fair score.)"""
    best = None
    for block in TRACKER_BLOCK_LOG2:
        for mu in TRACKER_MU_LOG2:
            trial = dataclasses.replace(cal, tracker={"drift_block_log2": block, "drift_mu_log2": mu})
            rms = evaluate(LoopState(trial, state.artefacts, state.ref_lag_s), meas).rms
            if best is None or rms < best[0]:
                best = (rms, trial)
    return best[1]


CANCEL_BLOCK_LOG2 = (4, 5, 6)          # fringe_canceller's update block
CANCEL_MU_LOG2 = (4, 6, 8, 10)         # and its final step (the gear shift starts every run at 1/2)


def choose_canceller(cal: Calibration, state: LoopState, meas: Measurement, tone_hz: float) -> Calibration:
    """The interference canceller (fringe_canceller, ahead of the CORDIC) at the named tone, with the constants
    that leave the least error on the fit data: a fast canceller converges sooner after reset and follows a
    tone that wanders, a slow one passes less noise into the phase. Like the drift tracker it has no fitted
    weights (it estimates the tone from the signals on every run), so its in-sample error is a fair score.
    The tone's frequency is in the recording's time units (cycles per sample without time stamps)."""
    t = sample_times(len(meas), meas.t_s)
    fs = sample_rate(t[uniform_run(t)])
    best = None
    for block in CANCEL_BLOCK_LOG2:
        for mu in CANCEL_MU_LOG2:
            trial = dataclasses.replace(cal, canceller={"tone_hz": float(tone_hz), "sample_rate_hz": float(fs),
                                                        "cancel_block_log2": block, "cancel_mu_log2": mu})
            rms = evaluate(LoopState(trial, state.artefacts, state.ref_lag_s), meas).rms
            if best is None or rms < best[0]:
                best = (rms, trial)
    return best[1]


def refit_around_interference(cal: Calibration, state: LoopState, meas: Measurement, tone_hz: float) -> Calibration:
    """Re-calibrate the declared model on readings with the tone taken out: the first calibration fitted its
    waveforms and long-period table to readings that held it (a strong tone bends both), and the canceller only
    removes it from the signals the core sees. The tone (cos, sin at its frequency) is fitted to each channel's
    reading minus the calibrated waveform at the reference's phase, and the model calibrated again on the
    readings without it. (One round: the channel errors of a calibration made without the tone are taken in
    a frame that no longer shows it whole.)"""
    t = sample_times(len(meas), meas.t_s)
    x = np.column_stack([np.ones_like(t), np.cos(2 * np.pi * tone_hz * t), np.sin(2 * np.pi * tone_hz * t)])
    plain = dataclasses.replace(cal, canceller={})
    e = channel_errors(evaluate(LoopState(plain, state.artefacts, state.ref_lag_s), meas))
    if e is None:
        return plain
    w, *_ = np.linalg.lstsq(x, e.T, rcond=None)
    tone = x[:, 1:] @ w[1:]          # the offsets stay in the readings: the waveform fit has its own
    clean = dataclasses.replace(meas, sin=meas.sin - tone[:, 0], cos=meas.cos - tone[:, 1])
    fresh = carry_loop(recalibrate(clean, cal), plain)
    # vibrations already named stay out of the reference the declared model is fitted against; the angle terms
    # found before are refitted with it (a declared model calibrated again without their error held out takes
    # part of it, and they would correct it twice: held-out 9230, a skew found first, 1606" against 447")
    vibrations = [a for a in state.artefacts if a.name == "tone"]
    if vibrations:
        return refit_around_tone(fresh, vibrations, clean)
    return refit_angle_terms(fresh, clean) if fresh.angle_terms else fresh


def refit_around_tone(cal: Calibration, tones: list[FittedEffect], meas: Measurement, rounds: int = 3) -> Calibration:
    """Re-calibrate the declared model, and refit the closed loop's angle terms, with the tones (in time, fitted on
    this recording) taken out of the reference. The first calibration absorbed part of the tones (its long-period
    table): each round fits them on the residual of the previous round's calibration, which held the previous
    estimate out, until neither takes the other's error. The angle terms are refitted with it
    (refit_angle_terms): a declared model calibrated again without their error held out would take part of it,
    and the terms would then correct it twice."""
    t = sample_times(len(meas), meas.t_s)
    x = np.column_stack([np.cos(2 * np.pi * tone.tone_hz * t) for tone in tones]
                        + [np.sin(2 * np.pi * tone.tone_hz * t) for tone in tones])
    x = x - x.mean(0)
    current = cal
    for _ in range(rounds):
        r = error_arcsec(run_float(current, meas.sin, meas.cos, meas.coarse, meas.t_s).angle_deg, meas.ref_deg)
        w, *_ = np.linalg.lstsq(x, r - r.mean(), rcond=None)
        # r = angle - reference: the reference plus the tone leaves the residual without it
        quiet = dataclasses.replace(meas, ref_deg=np.mod(meas.ref_deg + (x @ w) / 3600.0, 360.0))
        if cal.angle_terms:
            current = refit_angle_terms(current, quiet, rounds=1)
        else:
            current = carry_loop(recalibrate(quiet, cal), cal)
    return current


def fit_rev_offset_gain(cal: Calibration, meas: Measurement, rounds: int = 2) -> Calibration:
    """Signal-domain fit: offsets and gains over the revolution against the reference's phase, then the
    declared model re-calibrated on the normalised signals (its waveform was biased by the effect)."""
    from ..calib.calibrate import reference_phase
    from ..dsp.effects import fit_rev_normalisation

    new = cal
    for _ in range(rounds):
        res = run_float(new, meas.sin, meas.cos, meas.coarse, meas.t_s)
        rev = res.position / cal.encoder.lines_per_rev
        raw_norm = new.rev_norm
        # without a long-period table (calibrate found none) the reference's phase needs no correction
        phi = reference_phase(new if new.long_period is not None else
                              dataclasses.replace(new, long_period=np.zeros_like), meas, rev)
        psi = 2 * np.pi * (rev % 1.0)
        if cal.adaptive:
            # the core's drift tracker sits in front and follows part of them: the map takes out what it leaves
            # (pipeline.fine_phase); the declared model stays, the tracker's forward tables are made from it
            ys, yc = tracked_readings(new, meas.sin, meas.cos)
            norm = fit_rev_normalisation(new.waves, ys, yc, phi, psi) if raw_norm is None else \
                _compose(raw_norm, fit_rev_normalisation(new.waves, *raw_norm.apply(ys, yc, psi), phi, psi))
            new = dataclasses.replace(new, rev_norm=norm)
            continue
        norm = fit_rev_normalisation(new.waves, meas.sin, meas.cos, phi, psi) if raw_norm is None else \
            _compose(raw_norm, fit_rev_normalisation(new.waves, *raw_norm.apply(meas.sin, meas.cos, psi), phi, psi))
        s, c = norm.apply(meas.sin, meas.cos, psi)
        fresh = recalibrate(dataclasses.replace(meas, sin=s, cos=c), cal)
        new = carry_loop(fresh, cal, rev_norm=norm)
    return new


def joint_fit(r: np.ndarray, ctx: Context, terms: list[FittedEffect], gain: np.ndarray | None = None
              ) -> np.ndarray:
    """Least squares of r on the terms' columns together (test_terms: blockwise normal equations, no design matrix
    of the whole recording held), each column times `gain` (per sample: how much of a correction reaches the
    output, terms_gain) where given."""
    def design(sl):
        x = np.column_stack([_design(t.name, ctx.rows(sl), t.tone_hz) for t in terms])
        return x if gain is None else x * gain[sl, None]
    return test_terms(r, design, 1.0, "joint").weights


def terms_gain(cal: Calibration, ctx: Context) -> np.ndarray | None:
    """How much of an angle term's correction reaches the output angle, per sample: fringe_trim corrects the
    position before the long-period table, which is then read where the corrected position lies, so a
    correction c comes out as c (1 - LP'(psi)) to first order (LP' its slope in arcsec per arcsec of the
    revolution). A long-period table fitted with many orders on a slow recording can be steep: 4 % there made
    the terms' joint refit on the fit data miss by 4.4" RMS on 9252 (held out), more than the term it added
    explains. None without a table."""
    if cal.long_period is None:
        return None
    return 1.0 - cal.long_period.slope(ctx.psi) * (2 * np.pi / ARCSEC_PER_REV)


def refit_angle_terms(cal: Calibration, meas: Measurement, rounds: int = 2, as_is: bool = False) -> Calibration:
    """Re-calibrate the declared model with the terms' error held out of it, then refit the terms
    jointly on what the declared model leaves: neither absorbs the other's error.

    The core's terms come first: the declared model holds out only their error, and they are fitted together;
    the terms only the float engine runs are then fitted on what is left. Fitted all together, a float-only
    term (speed^2 over a narrow speed range is nearly a constant plus a speed term) would trade weight with the
    core's terms, and the core, which runs without it, would be left with the other half of the trade.

    The rounds alternate between two fits that do not minimise the same error (the phase table's conic comes
    from the channels' fundamentals, its centre from the gain changes), so they need not converge: on a gain
    that changes over the revolution (held-out 9252) each round grew the fine-phase map and the error on the
    fit data with it. Of the terms refitted after each round, the one with the least error on the fit data is
    kept; with `as_is`, also the terms refitted on cal's declared model as it is, where that is the loop's state
    (itself calibrated on these readings with the earlier terms held out). Not a fresh calibration that held no
    terms out (it took part of their error, and they would correct it twice: on held-out 9248, a canceller's
    re-calibration, it fitted the data better and validated 3.78x -> 4.71x the floor)."""
    terms = list(cal.angle_terms)
    in_core = [t.engine != "float" for t in terms]

    def fitted_on(base: Calibration, ctx) -> Calibration:
        """base with the terms refitted on what it leaves (core terms first, then the float engine's)."""
        new = list(terms)
        r = error_arcsec(run_float(base, meas.sin, meas.cos, meas.coarse, meas.t_s).angle_deg, meas.ref_deg)
        gain = terms_gain(base, ctx)
        for group in (True, False):
            idx = [k for k, c in enumerate(in_core) if c == group]
            if not idx:
                continue
            w = joint_fit(r, ctx, [new[k] for k in idx], gain)
            widths = [len(new[k].weights) for k in idx]
            for k, ww in zip(idx, np.split(w, np.cumsum(widths)[:-1]), strict=True):
                new[k] = dataclasses.replace(new[k], weights=ww)
            r = r - sum(new[k].predict(ctx) for k in idx) * (1.0 if gain is None else gain)
        return dataclasses.replace(base, angle_terms=new)

    def core_context(c: Calibration):
        # the context as the core sees it: without the float engine's terms
        core = [t for t, k in zip(c.angle_terms, in_core, strict=True) if k]
        res = run_float(dataclasses.replace(c, angle_terms=core), meas.sin, meas.cos, meas.coarse, meas.t_s)
        ctx = covered(make_context(res.frac, res.position, c.encoder.lines_per_rev,
                                   sample_times(len(res.frac), meas.t_s), res.magnitude, c.start_speed_rev_s))
        return ctx, core

    def error_rms(c: Calibration) -> float:
        e = error_arcsec(run_float(c, meas.sin, meas.cos, meas.coarse, meas.t_s).angle_deg, meas.ref_deg)
        return float(np.std(e))

    candidates = [fitted_on(dataclasses.replace(cal, angle_terms=[]), core_context(cal)[0])] if as_is else []
    for _ in range(rounds):
        ctx, core = core_context(cal)
        # output frame -> encoder frame
        known = cal.direction * sum(t.predict(ctx) for t in core) if core else None
        base = carry_loop(recalibrate(meas, cal, known), cal, angle_terms=[])
        cal = fitted_on(base, ctx)
        terms = list(cal.angle_terms)
        candidates.append(cal)
    return candidates[0] if len(candidates) == 1 else min(candidates, key=error_rms)


PHASE_DOMAIN_ORDERS = (2, 4, 6, 8, 12, 16, 24, 32)   # fine-phase orders of the phase-domain map (chosen by CV)
AMPLITUDE_TERMS = ("amplitude", "generic:magnitude:", "generic:magnitude2:")


def unnamed_amplitude(entry: dict, lines: int) -> dict:
    """A magnitude-dependent correction on an encoder of fewer than REVOLUTION_MIN_LINES periods: kept, but reported
    as structure no name explains, not as "amplitude": with so few periods an amplitude change over the revolution
    is a waveform that differs from period to period, as testable() holds for the revolution's offsets and gains."""
    return {**entry, "name": generic_name("magnitude", AMPLITUDE_ORDERS), "cause": GENERIC["cause"],
            "signature": f"an error that follows the signal magnitude; unexplained by name (with {lines} signal "
                         "period(s) per revolution an amplitude change over the revolution cannot be told from a "
                         "waveform that differs between periods)"}


def amplitude_like(t: Test) -> bool:
    return any((t.label or t.name).startswith(a) for a in AMPLITUDE_TERMS)


def phase_orders(ev: Evaluation) -> str:
    """The fine-phase map's orders 1..K with the least two-fold held-out error."""
    kmax = max(PHASE_DOMAIN_ORDERS)
    grams, rhs, rr = _fold_grams(ev, lambda sl: generic_design(generic_name("1", kmax), ev.ctx.rows(sl)), 2 * kmax)
    held = {k: _held_out(grams, rhs, rr, list(range(2 * k)) + [2 * kmax])[0] for k in PHASE_DOMAIN_ORDERS}
    return generic_name("1", min(held, key=held.get))


def phase_domain(state: LoopState, meas: Measurement, keep_amplitude: bool) -> LoopState:
    """The remedy for an amplitude that changes, where the per-channel waveform inverse cannot serve: the waveform
    stage straight and the conic (a common gain then moves no angle: atan2 of two channels scaled alike is
    unchanged), and the phase error of the channels' shape corrected after the arctan, by the fine-phase map in
    fringe_trim (orders chosen on held-out data). With `keep_amplitude` the magnitude terms stay beside it (a
    waveform whose shape itself changes with the amplitude)."""
    meas = shift_reference(meas, state.ref_lag_s)
    terms = [t for t in state.cal.angle_terms if not t.name.startswith(FINE_MAP_PREFIX)
             and (keep_amplitude or not any(t.name.startswith(a) for a in AMPLITUDE_TERMS))]
    marked = dataclasses.replace(state.cal, fit={**state.cal.fit, "phase_domain": True}, angle_terms=terms)
    cal = carry_loop(recalibrate(meas, marked), marked)
    ev = strided(evaluate(LoopState(cal, state.artefacts), meas))
    name = phase_orders(ev)
    t = test_terms(ev.r, lambda sl: generic_design(name, ev.ctx.rows(sl)), 1.0, name)
    cal = dataclasses.replace(cal, angle_terms=terms + [FittedEffect(name, t.weights)])
    return LoopState(refit_angle_terms(cal, meas), list(state.artefacts), state.ref_lag_s)


def _compose(first, second):
    """Normalisations applied one after the other, to first order in the (small) weights."""
    from ..dsp.effects import RevNormalisation
    return RevNormalisation({k: (first.weights[k][0] + second.weights[k][0], first.weights[k][1] + second.weights[k][1])
                             for k in ("sin", "cos")})


def decision_rows(meas: Measurement) -> Measurement:
    """The rows a long recording is decided on: DECISION_RUNS evenly spaced runs, unless they see less of the
    revolution than the whole recording (a slow one), which is then used whole."""
    sub = meas.runs(DECISION_ROWS, DECISION_RUNS)
    if sub is meas or meas.ref_deg is None:
        return sub

    def sectors(m):
        return len(np.unique(np.floor(np.mod(m.ref_deg, 360.0) / 360.0 * 64)))
    return sub if sectors(sub) >= sectors(meas) else meas


def split(meas: Measurement, blocks: int = VALIDATION_BLOCKS) -> tuple[Measurement, Measurement]:
    """Interleaved blocks: both halves cover the revolution and the whole time span."""
    idx = (np.arange(len(meas)) * blocks // len(meas)) % 2
    return meas.subset(idx == 0), meas.subset(idx == 1)


def start_speed(ctx: Context) -> float:
    """The speed the speed terms take for the first sample after reset, which has no speed window yet (fringe_trim's
    START_SPEED): the mean speed of the calibration recording, rev/s. A recording that starts in motion would
    otherwise have its first sample corrected as at standstill: a skew term's whole speed image on one sample
    (held-out 9237: 3154" on the first of 16384 samples, 1.48x the floor over the recording, 1.00x without it)."""
    return float(np.mean(ctx.speed[1:])) if len(ctx.speed) > 1 else 0.0


def run_loop(train: Measurement, enc: Encoder, validate: Measurement | None = None, shown: list | None = None
             ) -> tuple[LoopState, LoopState, dict]:
    """The closed loop on `train` (validated on `validate`, else on the interleaved half of `train` left out of
    the fit). `shown`, a list, receives the validation rows the decision was made on (for the plots). A caller
    that keeps no reference to `train` lets it go once it is split (bounded memory)."""
    if train.ref_deg is None:
        raise FringeInputError("the closed loop needs a reference (a ref_deg column) to measure the residual; "
                               "without one, run 'fringe calibrate' (reference-free: conic and waveform "
                               "against the smooth-motion phase)", train.path)
    data_path = train.path
    if validate is None:
        fit_data, val_data, val_name = (*split(train), "interleaved half of the recording")
        del train
    else:
        if validate.ref_deg is None:
            raise FringeInputError("the validation recording has no ref_deg column", validate.path)
        fit_data, val_data, val_name = train, validate, validate.path
    # a long recording is decided on evenly spaced runs of it (ample power for every test, bounded time and
    # memory); the error before and after is then measured on every validation row
    full_val = val_data
    fit_data, val_data = decision_rows(fit_data), decision_rows(val_data)
    state = base = LoopState(calibrate(fit_data, enc))
    ev_fit = evaluate(state, fit_data)
    base.cal.start_speed_rev_s = start_speed(ev_fit.ctx)
    ev_val = evaluate(state, val_data)
    sigma, floor_info = noise_floor(ev_fit)
    if shown is not None:
        shown.append(val_data)
    report = {"data": data_path, "validation": val_name, "noise_floor_arcsec": round(sigma, 4),
              "noise_floor_method": floor_info["used"], "noise_floor_estimates": floor_info,
              "before": _figs(ev_val), "effects_added": [], "effects_rejected": [], "iterations": []}
    excluded: set = set()
    for _ in range(MAX_TRIALS):
        if len(report["effects_added"]) >= MAX_EFFECTS:
            break
        tests, skipped = candidates(ev_fit, sigma, excluded)
        good = [t for t in tests if t.p_value < P_VALUE and t.rms_after < (1 - MIN_GAIN) * ev_fit.rms]
        # what the core carries first: a correction only the float engine runs is left for when nothing else is
        good = [t for t in good if describe(t.name)["correction"] != "float engine"] or good
        # the library's names first, where one explains at least NAMED_SHARE of what the best shape of the general
        # dictionary explains (a named effect beside a far larger unnamed structure would be fitted on top of
        # it); a line on a steady revolution harmonic is as well a position error: it competes with the shapes.
        # A shape of the general dictionary in the factor of a library effect that is itself present is that
        # effect in its wider form (named_shape): it competes as the name (a large skew beside the magnitude
        # changes it causes is a speed effect, though its one-term shape explains less than the magnitude's), if
        # it explains more than the plain fine-phase shapes (a factor with a mean, as the speed of a steady
        # motion, also carries a static fine-phase error). The magnitude's shapes only where no speed shape
        # explains half as much: a skew changes the corrected magnitude in proportion to speed, so they stand in
        # for a speed effect as well
        top = max((t.explained_rms for t in good if t.name.startswith("generic:")), default=0.0)
        plain = max((t.explained_rms for t in good if t.name.startswith(FINE_MAP_PREFIX)), default=0.0)
        present = {t.name for t in good if not t.name.startswith("generic:") and not t.ambiguous}
        named = [t for t in good if not t.ambiguous and t.explained_rms ** 2 >= NAMED_SHARE * top ** 2
                 and (not t.name.startswith("generic:")
                      or (generic_effect(t.name) in present and t.explained_rms > plain
                          and not family_holds(t, good) and not speed_holds(t, good)))]
        good = named or good
        report["iterations"].append({"residual_rms_arcsec": round(ev_fit.rms, 4), "tests": [
            {"effect": t.name, "explained_rms_arcsec": round(t.explained_rms, 4), "p_value": t.p_value,
             "dof": t.dof} for t in sorted(tests, key=lambda t: t.rms_after)], "not_testable": skipped})
        if not good:
            break
        # BIC: between effects that explain nearly the same, the one with fewer terms
        n = len(ev_fit.r)
        best = min(good, key=lambda t: n * np.log(t.rms_after ** 2) + t.dof * np.log(n))
        best = widen(best, strided(ev_fit), sigma)
        best = named_shape(best, tests, ev_fit.rms)
        # a line is excluded by its frequency (a recording may hold several), every other term by its name
        excluded.update({f"{best.name}@{best.tone_hz!r}"} if best.tone_hz else {best.name, best.label} - {""})
        remedy = ""
        try:
            trial = apply(state, best, fit_data)
            val_after = evaluate(trial, val_data)
            if amplitude_like(best) and not state.cal.fit.get("phase_domain"):
                trial, val_after, remedy = best_amplitude_remedy(state, trial, val_after, fit_data, val_data)
        except (FringeInputError, ValueError, TypeError, KeyError, np.linalg.LinAlgError) as e:
            # never abort on the data: an effect whose fit fails is reported and left out
            report["effects_rejected"].append({"name": best.name, **describe(best.name), "evidence": "",
                                               "why_not_kept": f"re-calibration with it failed: {e}"})
            continue
        entry = {"name": best.label or best.name, **describe(best.label or best.name),
                 **({"shape": describe(best.name)["signature"], "correction": describe(best.name)["correction"],
                     "where": describe(best.name)["where"]} if best.label else {}),
                 "evidence": f"explains {best.explained_rms:.3f}\" RMS of the residual ({best.dof} terms, "
                             f"p = {best.p_value:.1e} against the {sigma:.3f}\" noise floor)"
                             + (f"; tone at {best.tone_hz:.3f} Hz" if best.tone_hz else ""),
                 "rms_before_arcsec": round(ev_val.rms, 4), "rms_after_arcsec": round(val_after.rms, 4)}
        cause, why = magnitude_cause(state, remedy, best, ev_fit)
        if cause:
            entry.update(name=cause, **{k: v for k, v in describe(cause).items() if k != "where"})
            if cause == "sampling_skew":
                entry["signature"] = describe(best.name)["signature"] + " (the magnitude changes a channel skew makes)"
            entry["evidence"] += why
        if remedy:
            entry.update(where=NORMALISER_WHERE if remedy == NORMALISER else PHASE_DOMAIN_WHERE, remedy=remedy,
                         correction="adaptive" if remedy == NORMALISER else "hardware")
        if entry["name"] == "amplitude" and state.cal.encoder.lines_per_rev < REVOLUTION_MIN_LINES:
            entry = unnamed_amplitude(entry, state.cal.encoder.lines_per_rev)
        why_not = "" if val_after.rms < (1 - 0.5 * MIN_GAIN) * ev_val.rms else \
            f"did not lower the error on the validation data ({val_name})"
        if not why_not and best.name != "tone" and leans_on_vibrations(state, trial, val_data):
            why_not = (f"lowered the error on the validation data ({val_name}) only with the vibration tones taken "
                       "out of the score, which the core does not do")
        if not why_not:
            report["effects_added"].append(entry)
            state, ev_val = trial, val_after
            ev_fit = evaluate(state, fit_data)
            sigma = min(sigma, noise_floor(ev_fit)[0])     # a cleaner residual inflates the floor less
        else:
            entry["why_not_kept"] = why_not
            report["effects_rejected"].append(entry)
    report["after"] = _figs(ev_val)
    if len(full_val) > len(val_data):
        report["decided_on_rows"] = {"fit": len(fit_data), "validation": len(val_data), "runs": DECISION_RUNS}
        report["before"], report["after"] = validation_figures(base, full_val), validation_figures(state, full_val)
    report["noise_floor_arcsec"] = round(sigma, 4)
    # the hardware tables' error budget (hardware.closed_loop.choose_map_psi_w) is set against this floor
    state = dataclasses.replace(state, cal=dataclasses.replace(
        state.cal, provenance={**state.cal.provenance, "noise_floor_arcsec": round(sigma, 6)}))
    report["unexplained"] = unexplained(ev_fit, sigma)
    report["artefacts"] = [a.to_dict() for a in state.artefacts]
    from ..hardware.closed_loop import float_only
    report["float_engine_only"] = float_only(state.cal)
    if state.ref_lag_s:
        report["artefacts"].append({"name": "ref_lag", "lag_s": state.ref_lag_s,
                                    "correction": "artefact", "where": LIBRARY["ref_lag"].where})
    return base, state, report


PHASE_DOMAIN = "phase-domain structure"
NORMALISER = "amplitude normaliser"
NORMALISER_WHERE = "fringe_drift ahead of the tables: the channels' offsets and gains tracked online from the signals"
PHASE_DOMAIN_WHERE = ("the waveform stage made straight (a common gain change then moves no angle), and the "
                      "phase error of the channels' shape in fringe_trim's fine-phase map after the arctan")


SKEW_MAGNITUDE_SHARE = 0.5   # of the magnitude's variance, the skew's signature must explain this much to own it


def skew_moves_magnitude(ev: Evaluation) -> bool:
    """Whether the corrected magnitude changes as a channel skew makes it change: sampling the cos channel tau
    late puts the Lissajous point off the circle by -(delta / 2) sin 2 phi (to first order), delta = 2 pi lines
    speed tau, so a magnitude term then corrects the skew per sample (the skew term works on the filtered speed)
    and is that effect's, not an amplitude's. Only where the speed varies (at a steady speed the conic owns it)."""
    ctx = ev.ctx
    v = ctx.speed - ctx.speed.mean()
    if np.std(v) < 0.05 * np.mean(np.abs(ctx.speed)):
        return False
    m = ctx.magnitude - ctx.magnitude.mean()
    x = np.column_stack([v * np.sin(2 * ctx.phi), v * np.cos(2 * ctx.phi)])
    w, *_ = np.linalg.lstsq(x, m, rcond=None)
    return float(np.sum((x @ w) ** 2)) >= SKEW_MAGNITUDE_SHARE * float(m @ m)


def magnitude_cause(state: LoopState, remedy: str, best: Test, ev: Evaluation) -> tuple[str, str]:
    """The name a magnitude-dependent correction is reported under ("" to keep the term's own), and why.

    An effect already corrected online changes the signals' magnitude by what its correction leaves: the drift
    tracker follows the gains late, the canceller converges from reset and leaves the tone's ripple on the
    Lissajous radius, and the revolution map corrects the angle after the arctan, not the signals, so the
    per-sector gains reach the waveform tables. The per-channel waveform inverse turns such magnitude changes
    into angle error, and the straight waveform stage of the phase-domain structure does not: then the remedy is
    that effect's correction, not a second cause. A skew moves the magnitude with the speed, and the drift
    tracker's leftovers follow time: a magnitude term (or a gain-invariant remedy) there corrects that effect.
    Gain invariance alone (the phase domain or the normaliser) is amplitude."""
    # the phase table, whether the loop's remedy or the structure calibrate chose, moves no angle with a common gain
    gain_invariant = remedy.startswith(PHASE_DOMAIN) or (not remedy and amplitude_like(best)
                                                         and state.cal.fit.get("structure") == PHASE_TABLE)
    if remedy.startswith(PHASE_DOMAIN) or (not remedy and amplitude_like(best)):
        # (the magnitude term itself, ahead of the per-channel inverse, corrects the same leftovers; the drift
        # tracker's only where they follow time, below)
        carried = ("drift" if state.cal.adaptive and gain_invariant else "interference" if state.cal.canceller
                   # the revolution map corrects the angle (fringe_trim), not the signals: the per-sector gains
                   # stay in what the waveform tables read
                   else "rev_offset_gain" if state.cal.rev_norm is not None else "")
        if carried:
            return carried, (f"; the magnitude changes that the {carried} correction leaves" + (
                ", made harmless by a gain-invariant waveform stage" if remedy else
                ", read through the phase table's fine-phase map" if gain_invariant else
                ", corrected by the magnitude term where the per-channel inverse reads them"))
    if amplitude_like(best) and state.cal.adaptive and magnitude_follows_time(ev.ctx):
        return "drift", ("; the magnitude changes it follows are the drift tracker's leftovers (slow functions of "
                         "time explain them better than the place in the revolution)")
    if amplitude_like(best) and skew_moves_magnitude(ev):
        # the correction stays (the magnitude term, or the gain-invariant remedy); the cause is the skew
        return "sampling_skew", ("; speed x (sin 2 phi, cos 2 phi) explains at least "
                                 f"{SKEW_MAGNITUDE_SHARE:.0%} of the magnitude's changes: the term corrects the "
                                 "skew per sample, through the magnitude it moves")
    return ("amplitude" if remedy in (PHASE_DOMAIN, NORMALISER) else ""), ""


def engine_rms(state: LoopState, meas: Measurement) -> float | None:
    """The validation RMS on the bit-exact engine (the core's own arithmetic, tables and block interplay), None
    where the core cannot run the calibration."""
    from ..hardware.closed_loop import unsupported
    from ..hardware.corefiles import core_config
    from ..hardware.tables import run_model

    if unsupported(state.cal):
        return None
    try:
        res = run_model(state.cal, core_config(state.cal), meas.sin, meas.cos, meas.coarse)
        return evaluate(state, meas, res).rms
    except (FringeInputError, ValueError, TypeError, KeyError, ArithmeticError, np.linalg.LinAlgError):
        return None     # a configuration the core cannot take: the candidates are compared on the float engine


def best_amplitude_remedy(state: LoopState, trial: LoopState, val_after: Evaluation, fit_data: Measurement,
                          val_data: Measurement) -> tuple[LoopState, Evaluation, str]:
    """Of the magnitude-dependent term (`trial`), the phase-domain structure (with and without that term) and the
    amplitude normaliser (the drift tracker), the one with the least error on the validation data: on the
    bit-exact engine where the core runs every candidate (the remedies live in different blocks, whose float
    twins do not show how they combine in the core), else on the float engine."""
    found = [("", trial, val_after)]
    for keep, label in ((False, PHASE_DOMAIN), (True, PHASE_DOMAIN + " and magnitude term"), (None, NORMALISER)):
        try:
            if keep is None:      # the channels' gains tracked online ahead of the tables (fringe_drift)
                if state.cal.adaptive:
                    continue
                alt = LoopState(choose_tracker(dataclasses.replace(state.cal, adaptive=True), state, fit_data),
                                list(state.artefacts), state.ref_lag_s)
            else:
                alt = phase_domain(trial if keep else state, fit_data, keep)
            found.append((label, alt, evaluate(alt, val_data)))
        except (FringeInputError, ValueError, TypeError, KeyError, np.linalg.LinAlgError):
            continue
    core = [engine_rms(alt, val_data) for _, alt, _ in found]
    scores = core if all(c is not None for c in core) else [ev.rms for _, _, ev in found]
    best = 0
    for k in range(1, len(found)):
        if scores[k] < (1 - 0.5 * MIN_GAIN) * scores[best]:
            best = k
    label, alt, ev = found[best]
    return alt, ev, label


EVAL_ROWS = 1 << 18      # the error before and after on a long validation recording: evaluated this many rows at
EVAL_LEAD = 1 << 14      # a time, each block run in from this many rows before it (speed window, drift tracker)


def _uses_time(state: LoopState) -> bool:
    return any(t.name.startswith("generic:time:") for t in state.cal.angle_terms + state.artefacts)


def validation_figures(state: LoopState, meas: Measurement) -> dict:
    """The error figures of `meas` through the state, in blocks of EVAL_ROWS rows (bounded memory however long
    the recording). Each block is run in from the EVAL_LEAD rows before it and joined to the previous block on
    the second half of that overlap, where both see the same samples with settled state: an incremental
    encoder's period count restarts with every block, and each block's mean is its own, so the offset is taken
    out there, and the figures are those of the whole recording as one."""
    n = len(meas)
    if n <= EVAL_ROWS + EVAL_LEAD or _uses_time(state):
        return _figs(evaluate(state, meas))
    r, frac, rev = np.empty(n), np.empty(n), np.empty(n)
    for start in range(0, n, EVAL_ROWS):
        a, b = max(0, start - EVAL_LEAD), min(n, start + EVAL_ROWS)
        sub = meas.subset(slice(a, b))
        if meas.t_s is None:     # the rows' own numbers as time, as for the whole recording
            sub = dataclasses.replace(sub, t_s=np.arange(a, b, dtype=float))
        ev = evaluate(state, sub)
        block = ev.r
        if start:
            join = slice(start - EVAL_LEAD // 2, start)
            block = block - float(np.median(block[join.start - a:join.stop - a] - r[join]))
        r[start:b], frac[start:b] = block[start - a:], ev.ctx.phi[start - a:] / (2 * np.pi)
        rev[start:b] = ev.ctx.psi[start - a:] / (2 * np.pi)
    r -= r.mean()
    return _report_figures(r, error_figures(r, frac, rev).to_dict())


def _report_figures(r: np.ndarray, figures: dict) -> dict:
    return {"rms_arcsec": round(float(np.sqrt(np.mean(r * r))), 4), "pp_arcsec": round(float(np.ptp(r)), 4),
            "interp_pp_arcsec": figures["interp_pp_arcsec"], "lp_pp_arcsec": figures["lp_pp_arcsec"]}


def _figs(ev: Evaluation) -> dict:
    return _report_figures(ev.r, ev.figures)


def _fourier(x: np.ndarray, orders) -> np.ndarray:
    return np.column_stack([f(k * x) for k in orders for f in (np.cos, np.sin)])


def unexplained(ev: Evaluation, sigma: float) -> list[dict]:
    """What is still significant, by domain (or why a domain could not be tested)."""
    ctx = ev.ctx
    from ..dsp.effects import _legendre_time

    domains = {     # name: (columns of a block of rows, why the domain cannot be tested, number of columns)
        "fine phase": ((ctx.phi, range(1, 33)), None, 64),
        "revolution": ((ctx.psi, range(1, 65)), None, 128),
        "fine phase x revolution": (lambda sl: LIBRARY["rev_offset_gain"].design(ctx.rows(sl)),
                                    revolution_untestable(ctx, None), 32),
        "time (trend)": (lambda sl: np.column_stack(_legendre_time(ctx.rows(sl))), None, 3),
        "speed": (lambda sl: np.column_stack([ctx.speed[sl], ctx.speed[sl] ** 2]),
                  testable("ref_lag", ctx, None, ev.ref_speed), 2),
        "acceleration": (lambda sl: ctx.accel[sl, None], testable("acceleration", ctx, None, ev.ref_speed), 1),
        "direction": (lambda sl: ctx.direction[sl, None].astype(float),
                      testable("hysteresis", ctx, None, ev.ref_speed), 1),
        "amplitude": (lambda sl: LIBRARY["amplitude"].design(ctx.rows(sl)), None, 1 + 2 * AMPLITUDE_ORDERS),
    }
    out = []
    for domain, (design, why, width) in domains.items():
        if why:
            out.append({"domain": domain, "description": f"not tested: {why}", "rms_arcsec": None})
            continue
        x = design
        if len(ev.r) < 4 * width:
            out.append({"domain": domain, "description": "not tested: too few samples for this domain",
                        "rms_arcsec": None})
            continue
        t = test_fourier(ev.r, *x, sigma, domain) if isinstance(x, tuple) else test_terms(ev.r, x, sigma, domain)
        if t.p_value < P_VALUE and t.explained_rms > 0.1 * sigma:
            tied = "revolution" in domain and not absolute(ev.cal)
            out.append({"domain": domain, "description": f"significant structure left ({t.dof} terms, "
                        f"p = {t.p_value:.1e}); " + ("the encoder has no coarse code, so it cannot be corrected (the "
                                                     "place in the revolution is not known in another recording)"
                                                     if tied else "no effect in the library explains it"),
                        "rms_arcsec": round(t.explained_rms, 4)})
    lines, notes = tone_candidates(ev)
    for name, f, p_line, _ in lines:
        t = test_terms(ev.r, _design(name, ctx, f), sigma, name, f)
        if max(t.p_value, p_line) < P_VALUE and t.explained_rms > 0.1 * sigma:
            what = "in the channels (additive interference)" if name == "interference" else "in the angle only"
            out.append({"domain": "time (tones)", "description": f"a line at {f:.3f} Hz {what}",
                        "rms_arcsec": round(t.explained_rms, 4)})
    for note in notes:
        out.append({"domain": "time (tones)", "description": note, "rms_arcsec": None})
    out.append({"domain": "noise", "description": "random part (the floor)", "rms_arcsec": round(sigma, 4)})
    return out
