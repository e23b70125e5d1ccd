"""The noise floor every test is judged against, estimated from the residual itself in several ways (spectral level,
successive differences, neighbours in fine phase, the Lissajous figure's radial scatter), and the time-axis helpers
the spectra need (a recording's uniform run, its sample rate)."""

from __future__ import annotations

import numpy as np
from scipy import signal

from ..encoder import ARCSEC_PER_REV
from .evaluation import Evaluation


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
