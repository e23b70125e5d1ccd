"""Does the recording agree with the encoder description and with itself?

Run before calibration, so that a wrong `lines_per_rev`, swapped channels, a reference in radians
or with a jump is named as such, instead of surfacing later as a failed fit of sound signals.
The fine phase used here is the raw one (channels centred and scaled by their extremes): its
error of a few percent of a period is far below what these checks look for.
"""

import numpy as np

from ..encoder import Encoder
from ..errors import FringeInputError
from .dataio import Measurement

SCALE_OK = (0.8, 1.25)        # motion ratios accepted as "the same motion"
MIN_PERIODS = 0.9             # less motion than about a period: the raw phase itself is not sound
JUMP_PERIODS = 0.25           # a reference step this much larger than the signals' step is a jump
REVERSED_MAX = 0.05           # fraction of the motion in which the reference may run the other way


BLOCK = 1 << 18               # rows per block of the checks that visit every row: temporaries of one block
SAMPLE = 1 << 18              # statistical checks (median steps, noise scale) look at this many rows at most


def _blocks(n: int):
    for start in range(0, n, BLOCK):
        yield slice(start, min(start + BLOCK, n))


def _spread(n: int, m: int) -> np.ndarray:
    """All of range(n) when n <= m, else m evenly spread indices of it."""
    return np.arange(n) if n <= m else np.round(np.linspace(0, n - 1, m)).astype(np.int64)


def unwrap_in_blocks(values, n: int, period: float, scale: float = 1.0) -> np.ndarray:
    """np.unwrap(values(whole), period) * scale, block by block: each block continues from the last
    unwrapped value of the one before (`values(s)` gives the raw values of slice s as floats)."""
    out = np.empty(n)
    last_raw = last = None
    for s in _blocks(n):
        raw = values(s)
        if last_raw is None:
            u = np.unwrap(raw, period=period)
        else:
            u = np.unwrap(np.concatenate(([last_raw], raw)), period=period)[1:] + (last - last_raw)
        last_raw, last = raw[-1], u[-1]
        out[s] = u * scale
    return out


def raw_phase_periods(meas: Measurement) -> np.ndarray:
    """Unwrapped fine phase in signal periods from the raw channels."""
    def centring(v):
        lo, hi = np.percentile(v, [0.5, 99.5])
        return (hi + lo) / 2, max((hi - lo) / 2, 1e-12)

    (s0, sk), (c0, ck) = centring(meas.sin), centring(meas.cos)
    angle = lambda s: np.arctan2((meas.sin[s] - s0) / sk, (meas.cos[s] - c0) / ck)  # noqa: E731
    return unwrap_in_blocks(angle, len(meas), 2 * np.pi, 1 / (2 * np.pi))


def median_step(x: np.ndarray) -> float:
    """Median |x[i+1] - x[i]|, on at most SAMPLE evenly spread steps (a statistic: exact below that)."""
    i = _spread(len(x) - 1, SAMPLE)
    return float(np.median(np.abs(x[i + 1] - x[i])))


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
    step = median_step(phase)
    if step > 0.2:    # near the overspeed limit the raw phase cannot be unwrapped: calibration says so
        return
    codes_passed = np.ptp(phase) * (1 << enc.coarse_bits) / enc.lines_per_rev
    # a one-bit code steps by half its range either way: its direction, hence its scale, cannot be unwrapped
    if enc.coarse_bits >= 2 and meas.coarse is not None and np.ptp(phase) >= 2 and codes_passed >= 4:
        _check_coarse(meas, enc, phase)
    if meas.ref_deg is not None and purpose == "calibration":
        _check_reference(meas, enc, phase, step)


def _slope(x: np.ndarray, y: np.ndarray, x_scale: float = 1.0) -> tuple[float, float]:
    """Least-squares slope of y on x * x_scale, and the RMS of what it leaves (block by block)."""
    mx, my = x.mean() * x_scale, y.mean()
    sxy = sxx = 0.0
    for s in _blocks(len(x)):
        xc, yc = x[s] * x_scale - mx, y[s] - my
        sxy, sxx = sxy + float(np.dot(xc, yc)), sxx + float(np.dot(xc, xc))
    a = sxy / max(sxx, 1e-300)
    sq = sum(float(np.sum(((y[s] - my) - a * (x[s] * x_scale - mx)) ** 2)) for s in _blocks(len(x)))
    return a, float(np.sqrt(sq / len(x)))


def _check_coarse(meas: Measurement, enc: Encoder, phase: np.ndarray):
    codes = 1 << enc.coarse_bits
    span = enc.lines_per_rev / codes                       # periods per coarse code
    coarse = unwrap_in_blocks(lambda s: meas.coarse[s].astype(float), len(meas), codes, span)
    a, rest = _slope(phase, coarse)
    # a few codes off are hardware faults (a glitch, a bit flipped on the cable), which the core flags and rides
    # through: only codes that miss on a large share of the rows say that the code is not this encoder's
    off = _share_off(phase, coarse, a, 0.5 + span)
    del coarse
    if off > COARSE_OFF_SHARE:
        raise FringeInputError(f"the coarse code does not follow the fine phase ({100 * off:.3g} % of the rows "
                               f"miss it by more than half a code; RMS {rest:.3g} periods): random codes, another "
                               "encoder's, or the wrong coarse_bits?", meas.path, "column 'coarse'")
    if -SCALE_OK[1] <= a <= -SCALE_OK[0]:
        raise FringeInputError("the fine phase runs against the coarse code: sin and cos swapped, or one channel "
                               "inverted?", meas.path, "columns 'sin', 'cos'")
    if not SCALE_OK[0] <= a <= SCALE_OK[1]:
        raise FringeInputError(f"the coarse code moves {a:.3g} times as far as the fine phase with lines_per_rev = "
                               f"{enc.lines_per_rev} and coarse_bits = {enc.coarse_bits}: one of them is wrong",
                               meas.path, "column 'coarse'")


#: the share of rows whose coarse code may miss the fine phase before the code is refused as not the encoder's
COARSE_OFF_SHARE = 0.05


def _share_off(phase: np.ndarray, coarse: np.ndarray, a: float, limit: float) -> float:
    """The share of rows whose coarse code (unwrapped, in periods) lies more than `limit` from the line through
    the fine phase with slope `a` (its offset the median, which a few wild codes do not move)."""
    i = _spread(len(phase), SAMPLE)
    mid = float(np.median(coarse[i] - a * phase[i]))
    off = sum(int(np.count_nonzero(np.abs(coarse[s] - a * phase[s] - mid) > limit)) for s in _blocks(len(phase)))
    return off / len(phase)


def _steps(x: np.ndarray, s: slice) -> np.ndarray:
    """x[i + 1] - x[i] for i in s (s within range(len(x) - 1))."""
    return x[s.start + 1:s.stop + 1] - x[s]


def _check_reference(meas: Measurement, enc: Encoder, phase: np.ndarray, step: float):
    ref, lines = meas.ref_deg, enc.lines_per_rev
    deg = 360.0 / lines                                    # signal degrees per period of the phase
    n = len(ref)
    if np.ptp(ref) == 0:
        raise FringeInputError(f"ref_deg is {float(ref[0]):g} on every row while the signals move: no reference "
                               "was recorded? (remove the column to calibrate without one)", meas.path,
                               "column 'ref_deg'")
    if np.max(np.abs(ref)) <= 2 * np.pi + 1e-9 and np.ptp(phase) * deg > 20:
        a, _ = _slope(phase, unwrap_in_blocks(lambda s: ref[s], n, 2 * np.pi, 180 / np.pi), deg)
        if SCALE_OK[0] <= abs(a) <= SCALE_OK[1]:
            raise FringeInputError("ref_deg looks like radians (it moves 57.3 times less than the signals): "
                                   "convert it to degrees", meas.path, "column 'ref_deg'")
    ref_u = unwrap_in_blocks(lambda s: ref[s], n, 360.0)
    pairs = list(_blocks(n - 1))
    agree = sum(float(np.dot(_steps(ref_u, s), _steps(phase, s))) for s in pairs)
    sign = 1.0 if agree >= 0 else -1.0

    def miss(s):   # how much more the reference steps than the signals, degrees
        return _steps(ref_u, s) - sign * deg * _steps(phase, s)

    i = _spread(n - 1, SAMPLE)                             # the noise scale is a statistic
    sample = ref_u[i + 1] - ref_u[i] - sign * deg * (phase[i + 1] - phase[i])
    scale = 1.4826 * np.median(np.abs(sample - np.median(sample)))
    limit = max(20 * scale, JUMP_PERIODS * deg)
    jumps, first = 0, None                                 # every step is looked at: a jump is one row
    for s in pairs:
        hit = np.flatnonzero(np.abs(miss(s)) > limit)
        if hit.size and first is None:
            first = s.start + int(hit[0])
        jumps += hit.size
    if jumps and jumps < 0.01 * (n - 1):
        r = first + 1
        raise FringeInputError(f"ref_deg jumps by {ref_u[r] - ref_u[r - 1]:.6g} deg while the signals move "
                               f"{sign * deg * (phase[r] - phase[r - 1]):.3g} deg", meas.path, _where(meas, r))
    window = max(1, int(np.ceil(0.1 / max(step, 1e-9))))  # about 0.1 period
    idx = np.arange(0, n, window)
    w_ref, w_sig = np.diff(ref_u[idx]), np.diff(phase[idx]) * deg
    moving = np.abs(w_sig) > 0.05 * deg
    if moving.sum() >= 10:
        against = (np.sign(w_ref[moving]) != np.sign(sign * w_sig[moving]))
        if REVERSED_MAX < against.mean() < 1 - REVERSED_MAX:
            first = idx[1:][moving][np.argmax(against)]
            raise FringeInputError(f"the reference runs against the signals in {100 * against.mean():.0f} % of the "
                                   "motion: a reversed part of ref_deg?", meas.path, _where(meas, int(first)))
    a, _ = _slope(phase, ref_u, deg)
    if not SCALE_OK[0] <= abs(a) <= SCALE_OK[1]:
        guess = lines / abs(a) if abs(a) > 1e-9 else float("inf")
        hint = (f"lines_per_rev is probably about {guess:.0f}, not {lines} (or ref_deg is not in degrees)"
                if 0.5 <= guess <= (1 << 24) else "is ref_deg in degrees, and from the same shaft?")
        raise FringeInputError(f"the reference moves {abs(a):.4g} times as far as the signals with lines_per_rev = "
                               f"{lines}: {hint}", meas.path, "column 'ref_deg'")
