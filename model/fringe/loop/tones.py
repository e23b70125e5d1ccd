"""Lines in time: the search for a line in the angle residual and in the channels, its frequency between the bins, and
what the line is (a vibration, additive interference, a steady revolution harmonic, an online block's own ripple)."""

from __future__ import annotations

import numpy as np
from scipy import ndimage, signal, stats

from ..dsp.calibration import Calibration
from ..dsp.effects import Context, interference_columns
from ..encoder import ARCSEC_PER_REV
from ..engine.pipeline import tracked_readings
from .evaluation import Evaluation
from .motion import settled_speed
from .noise import sample_rate, uniform_run
from .significance import P_VALUE, Test

WAVE_HARMONICS = 32  # at a steady speed, channel lines at these multiples of the electrical frequency are waveform
LINE_WINDOW = 64      # bins either side for the local spectral level of the line detector


def find_line(x: np.ndarray, fs: float, exclude_hz=(), near_hz: float | None = None
              ) -> tuple[float, float, int] | None:
    """The strongest line of x's spectrum against the local spectral level, over the whole band up to
    Nyquist: (frequency in Hz, or cycles per sample at fs = 1; its level over the local one; bins
    searched). A periodogram bin of noise is exponential about the local mean, so a bin q times the
    local mean has the chance exp(-q), and the strongest of N bins N exp(-q). The slowest bins belong to
    the drift test; bins within 1.5 bins of `exclude_hz` are not offered; with `near_hz`, only the bins within
    2 bins of it (whether a line known beforehand is there: N is then those few bins).

    With x of several rows (the two channels), a bin's levels add up: a line in every row at the same frequency,
    as an additive tone on both channels, stands out where each row's alone does not (a changing speed spreads
    the waveform's own errors over the band around it and raises each row's local level: held-out-like draw
    9410, 15x the floor of interference at 28 Hz, q = 17 in each channel, 34 together). Noise's sum of k rows is
    Gamma(k) distributed; the level returned is the one a single row would need for the same chance
    (-log of the Gamma tail), so that line_p_value holds for both."""
    rows = np.atleast_2d(x)
    if rows.shape[1] < 256:
        return None
    f, p = signal.periodogram(rows, fs, window="hann", detrend="linear", axis=-1)
    local = ndimage.median_filter(p, size=(1, 2 * LINE_WINDOW + 1), mode="reflect") / np.log(2)
    q = (p / np.maximum(local, 1e-300)).sum(axis=0)
    q[f <= 16 * f[1]] = 0.0
    for ex in exclude_hz:
        q[np.abs(f - ex) <= 1.5 * f[1]] = 0.0
    if near_hz is not None:
        q[np.abs(f - near_hz) > 2 * f[1]] = 0.0
    if not np.any(q > 0):
        return None
    k = int(np.argmax(q))
    level = float(q[k]) if len(rows) == 1 else float(-stats.gamma.logsf(q[k], len(rows)))
    return float(f[k]), level, int(np.count_nonzero(q))


def refine_frequency(x: np.ndarray, t: np.ndarray, f0: float, bin_hz: float, points: int = 41,
                     nuisance: np.ndarray | None = None) -> float:
    """The line's frequency between the periodogram's bins: the largest projection of x (its rows together) on a
    complex tone, on a grid within one bin of f0, then polished to a ten-thousandth of a bin (a frequency off by a
    twentieth of a bin drifts the phase by 0.3 rad over the recording, which leaves a sixth of the line
    uncorrected). With `nuisance` (orthonormal columns, one row per sample: the long-period table's harmonics,
    lp_basis), the tone's least-squares power beside them, where the tone's columns stay apart from theirs."""
    from scipy.optimize import minimize_scalar

    xc = np.atleast_2d(x)
    xc = xc - xc.mean(axis=-1, keepdims=True)
    q = nuisance
    if q is not None:
        xc = xc - (xc @ q) @ q.T
        if tone_apart(t, f0, q) < TONE_APART:
            q = None

    def power(f):      # summed over the rows (channels), whose tones have phases of their own
        if q is None:
            return float(np.linalg.norm(xc @ np.exp(-2j * np.pi * f * t)))
        a = _tone_columns(t, f)
        a = a - q @ (q.T @ a)
        w, *_ = np.linalg.lstsq(a, xc.T, rcond=None)
        return float(np.sqrt(np.sum((a @ w) ** 2)))

    grid = f0 + bin_hz * np.linspace(-1.0, 1.0, points)
    k = int(np.argmax([power(f) for f in grid]))
    step = grid[1] - grid[0]
    best = minimize_scalar(lambda f: -power(f), bounds=(grid[k] - step, grid[k] + step), method="bounded",
                           options={"xatol": 1e-4 * bin_hz})
    return float(best.x) if -best.fun >= power(grid[k]) else float(grid[k])


TONE_APART = 0.3     # the least share of a tone's columns outside the long-period table's for a joint estimate


def _tone_columns(t: np.ndarray, f: float) -> np.ndarray:
    x = np.column_stack([np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)])
    return x - x.mean(0)


def lp_basis(cal, psi: np.ndarray) -> np.ndarray | None:
    """Orthonormal columns of the long-period table's harmonics over the revolution angle `psi` (rad), as many
    as cal's table holds, without the mean; None without a table. A vibration at a nearly steady speed is close
    to a harmonic of the revolution, and the table fitted on the same recording takes part of it: the tone is
    estimated beside these columns (new draw 9408: a 26.9 Hz vibration of 11.8" at 1.07 rev/s; harmonics 23-29 of
    a 33-harmonic table held 3-4" each, and the line in what the table left peaked at 27.10 Hz with 7.3"; beside
    the table's columns, 26.90 Hz and 11.7")."""
    from ..dsp.longperiod import design_matrix

    n = cal.long_period.n if cal is not None and cal.long_period is not None else 0
    if not n:
        return None
    lp = design_matrix(psi, n)[:, 1:]
    q, _ = np.linalg.qr(lp - lp.mean(0))
    return q


def apart_share(x: np.ndarray, q: np.ndarray) -> float:
    """The least share of a column of x (its norm) outside the span of q's orthonormal columns."""
    return float(np.min(np.linalg.norm(x - q @ (q.T @ x), axis=0) / np.linalg.norm(x, axis=0)))


def tone_apart(t: np.ndarray, f: float, q: np.ndarray) -> float:
    """The share of a tone's columns outside the span of q: near 0 where the speed is so steady that the tone is a
    harmonic of the revolution within the recording."""
    return apart_share(_tone_columns(t, f), q)


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


def with_harmonic_ambiguity(entry: dict, test: Test) -> dict:
    """A tone entry whose line lies on a harmonic of a steady revolution rate (test.ambiguous, tone_candidates)
    marked ambiguous with a position error at that order (`ambiguous_with`, and said in its evidence): within one
    recording the two look the same, and it is corrected as a tone in time."""
    if entry["name"] != "tone" or not test.ambiguous:
        return entry
    return {**entry, "ambiguous_with": "a position error at a harmonic of the revolution",
            "evidence": entry["evidence"] + "; the line lies on a harmonic of the steady revolution rate: in this "
                                            "recording a vibration and a position error at that order look the same"}


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
    f_angle = refine_frequency(x, t, angle[0], bin_hz, nuisance=lp_basis(ev.cal, ev.ctx.psi[run])) if angle else None
    if chan is not None:
        # at a steady speed the waveform's own errors sit at the low multiples of the electrical frequency (a
        # waveform model's orders); a line at a high multiple is interference
        harmonics = [k * electrical for k in range(1, WAVE_HARMONICS + 1)] if electrical else []
        # each channel alone (interference on one of them) and both together (on both, as pick-up and a supply's
        # ripple usually are): three tests, so three times the least chance
        rows = [chan[0], chan[1], chan]
        found = [find_line(e, fs, [*harmonics, *known_hz]) for e in rows]
        if any(found):
            which = int(np.argmax([f[1] if f else -1.0 for f in found]))
            chan_found = found[which]
            chan_found = (refine_frequency(rows[which], t, chan_found[0], bin_hz), *chan_found[1:])
            p = min(1.0, len(rows) * line_p_value(chan_found))
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
