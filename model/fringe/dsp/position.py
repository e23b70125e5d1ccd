"""Coarse/fine combination and period counting (float reference of fringe_period_count)."""

import numpy as np


def wrap(x: np.ndarray, period: float = 1.0) -> np.ndarray:
    """Into [-period/2, period/2)."""
    return (np.asarray(x) + period / 2) % period - period / 2


def circular_mean(x: np.ndarray, period: float = 1.0) -> float:
    z = np.mean(np.exp(2j * np.pi * np.asarray(x) / period))
    return float(np.angle(z) / (2 * np.pi) * period)


def without_slips(x: np.ndarray, period: float, at: np.ndarray | None = None) -> np.ndarray:
    """x without the whole periods it jumped by between rows (only at the rows `at`, where given): an incremental
    encoder's count slips by whole periods where it cannot follow the motion, while its error moves far less than
    half a period from one row to the next."""
    jumps = np.round(np.diff(x, prepend=x[:1]) / period)
    if at is not None:
        jumps = np.where(at, jumps, 0.0)
    return x - period * np.cumsum(jumps)


def coarse_code_span(lines: int, coarse_bits: int) -> float:
    """Width of one coarse code, in signal periods."""
    return lines / float(1 << coarse_bits)


def fit_coarse_offset(frac: np.ndarray, coarse: np.ndarray, lines: int, coarse_bits: int) -> float:
    """Where the middle of coarse code 0 lies, in periods of the fine phase (COARSE_OFS).

    The code changes between k-1 and k at position k*span + delta; at each change the fine
    phase says where that is. delta is the circular mean over all changes (jitter averages
    out), and the code's middle is half a span further on.
    """
    span = coarse_code_span(lines, coarse_bits)
    codes = 1 << coarse_bits
    step = (coarse[1:] - coarse[:-1]) % codes
    up, down = step == 1, step == codes - 1
    edge = np.where(up, coarse[1:], np.where(down, coarse[:-1], -1))
    ok = edge >= 0
    if ok.sum() < 2:
        raise ValueError("the coarse code never changes: the recording does not move across a coarse code")
    f_edge = frac[:-1][ok] + 0.5 * wrap(frac[1:][ok] - frac[:-1][ok])
    delta = circular_mean(f_edge - edge[ok] * span)
    # the fine phase fixes the offset modulo a period: take the smallest misalignment
    return float(wrap(delta + span / 2))


def coarse_fine_combine(frac: np.ndarray, coarse: np.ndarray, lines: int, coarse_bits: int,
                        offset: float, starts: np.ndarray | None = None,
                        quantum: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Absolute position (periods, [0, lines)) and the coarse/fine disagreement flag.

    centre = code*span + offset estimates the position to within half a code; the absolute count
    is the integer n that puts n + frac nearest to it, and resid = centre - frac - n is the
    sample's distance from its code's centre. A code of half a period or more can be flipped by
    edge jitter and then n is a period off, so n is trusted only within a quarter period of the
    centre (-1/4 <= resid < 1/4); elsewhere the count follows the fine-phase steps (as
    `count_periods`) from the last trusted sample: the offset from the incremental count to the
    absolute one is taken at trusted samples and carried forward. Before the first trusted sample
    of a run (start-up) the offset is taken at the run's first sample, at a quarter-period step
    (`overspeed`) and at each sample nearer its code's centre than every one since (the best code so
    far; taking every code made the position flicker by a period at a jittered edge). Flagged: a
    residual beyond the midpoint between half a code and half a period (span < 1), or a trusted
    sample whose absolute count differs from the
    tracked one (a code that is really wrong; the position resynchronises there, and the samples
    tracked from it carry the flag) unless a quarter-period step (`overspeed`) since the last
    absolute sample lost the track. `starts` marks samples that begin a new run (a gap in the rows
    before them): there the track restarts as after a reset (the hardware streams without gaps).
    `quantum`: the phase step when frac is quantised (2^-FINE_W): the start-up distance is then the
    hardware's m (r for r >= 0, -r-1 below, r = resid / quantum), which orders one-count ties as it
    does; None: |resid|.
    """
    frac = np.asarray(frac, float)
    span = coarse_code_span(lines, coarse_bits)
    centre = coarse * span + offset
    n = np.round(centre - frac)
    resid = centre - frac - n
    tolerance = 0.5 * (span / 2 + 0.5)
    flag = np.abs(resid) > tolerance if span < 1 else np.zeros(len(frac), bool)
    if len(frac) == 0:
        return (n % lines) + frac, flag
    trusted = (resid >= -0.25) & (resid < 0.25)
    # the incremental count in whole periods: frac[0] + the wrapped steps, less the phase
    unwrapped = frac[0] + np.concatenate([[0.0], np.cumsum(wrap(np.diff(frac)))])
    count = np.round(unwrapped - frac)
    to_abs = n - count                           # whole periods from the count to the absolute position
    idx = np.arange(len(frac))
    # whether a trusted sample came since the start of this sample's run (the recording's start, or a gap)
    run_start = np.maximum.accumulate(np.where(starts, idx, 0)) if starts is not None else np.zeros(len(frac), int)
    last_trusted = np.maximum.accumulate(np.where(trusted, idx, -1))
    seen = np.concatenate([[-1], last_trusted[:-1]]) >= run_start    # False at a run's first sample
    # start-up: a new minimum of the distance from the code's centre since the last restart (a run's
    # first sample, an overspeed); each restart's key sits below every earlier one
    fast_step = overspeed(frac)
    restart = fast_step | (idx == 0)
    if starts is not None:
        restart = restart | starts
    if quantum is None:
        dist = np.abs(resid)
    else:
        dist = (np.abs(np.round(resid / quantum) + 0.5) - 0.5) * quantum
    key = dist - np.cumsum(restart)             # dist <= 1/2
    record = np.concatenate([[True], key[1:] < np.minimum.accumulate(key)[:-1]])
    anchor = trusted | (~seen & record)
    last = np.maximum.accumulate(np.where(anchor, idx, 0))
    prev = np.concatenate([[0], last[:-1]])
    fast = np.cumsum(fast_step)
    lost = fast - fast[prev] > 0
    resync = trusted & seen & ~lost & ((to_abs - to_abs[prev]) % lines != 0)
    flag = flag | resync[last]                   # the samples tracked from a resync carry its flag
    return ((count + to_abs[last]) % lines) + frac, flag


def count_periods(frac: np.ndarray, lines: int) -> tuple[np.ndarray, np.ndarray]:
    """Incremental position (periods, [0, lines)) from the fine phase alone, and overspeed flags.

    The first sample sets the count to zero. A jump of a quarter period or more between samples
    is ambiguous (it could be either way round), so it is flagged, not trusted.
    """
    step = wrap(np.diff(frac))
    flag = np.concatenate([[False], np.abs(step) >= 0.25])
    pos = frac[0] + np.concatenate([[0.0], np.cumsum(step)])
    return pos % lines, flag


def overspeed(frac: np.ndarray) -> np.ndarray:
    return np.concatenate([[False], np.abs(wrap(np.diff(frac))) >= 0.25])


def shifted(t: np.ndarray, x: np.ndarray, dt: float, span: int = 1) -> np.ndarray:
    """x at the times t + dt: interpolated inside the recording, continued at the end slopes (over `span`
    samples, more for a noisy x) outside it: the motion goes on before the first and after the last sample,
    and holding the end values would freeze it."""
    y = np.interp(t + dt, t, x)
    k = min(span, len(t) - 1)
    if k < 1:
        return y
    before, after = t + dt < t[0], t + dt > t[-1]
    y[before] = x[0] + (t[before] + dt - t[0]) * (x[k] - x[0]) / (t[k] - t[0])
    y[after] = x[-1] + (t[after] + dt - t[-1]) * (x[-1] - x[-1 - k]) / (t[-1] - t[-1 - k])
    return y
