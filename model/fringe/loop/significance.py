"""Whether a shape is in the residual: least-squares tests of a set of columns against the noise floor (chi-square
against P_VALUE; MIN_GAIN is what an effect must remove to matter), and whether a domain can be tested on a recording
at all (a speed that changes, both directions, a revolution covered and known)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..dsp.calibration import Calibration
from ..dsp.effects import LIBRARY, Context
from .evaluation import REVOLUTION_SECTORS, Evaluation
from .motion import motion_speed

P_VALUE = 1e-6
MIN_GAIN = 0.01          # an effect must remove at least this fraction of the residual RMS


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


def _fourier(x: np.ndarray, orders) -> np.ndarray:
    return np.column_stack([f(k * x) for k in orders for f in (np.cos, np.sin)])


def absolute(cal: Calibration | None) -> bool:
    """Whether the position in the revolution is known (a coarse code), so a correction tied to it repeats between
    recordings; an incremental encoder's count starts wherever the recording starts."""
    return cal is None or cal.encoder.lines_per_rev == 1 or \
        (bool(cal.encoder.coarse_bits) and cal.coarse_offset_periods is not None)


#: a speed effect is tested when the speed spreads by at least this fraction of its mean: below, the speed is as good
#: as a constant (a lag is an offset, a skew a quadrature phase error); above, significance and validation decide
SPEED_SPREAD = 0.01


# With fewer signal periods per revolution the revolution and the fine phase are nearly the same angle: a change over
# the revolution cannot be told from a waveform that differs between periods
REVOLUTION_MIN_LINES = 4


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
