"""Bit-exact model of the drift tracker: online offset / gain tracking of drifting sin/cos signals in ``fringe_core``.

No HDL block of its own: with DRIFT = 1 ``fringe_core`` (``rtl/verilog/fringe_core.v``, ``rtl/vhdl/fringe_core.vhd``)
instantiates its two halves, each with its own model: ``drift_normaliser`` (``fringe_drift_normaliser``,
at the front of the core: ``y_k = ((raw_k * 2^OFS_FRAC - OFF_k) * GINV_k + half) >>> shift``, saturated) and
``drift_observer`` (``fringe_drift_observer``: from each sample's fine phase, computed downstream from the same
sample's y, the block sums of the error against the calibrated waveform and each block's update at the gear).
The observer's update of block j becomes the normaliser's state from input sample (j+1)B + D on: D = 0 with
HOLD = 1 (the normaliser holds sample (j+1)B until the update is resolved: in_ready), D = B/2 with HOLD = 0;
``drift_run`` closes that loop through the rest of the core (``phase_of``). The tracker as a whole (loop gain,
partial sweeps, the core's timing): ``docs/drift.md``.

The offset step is twice the mean error (the shift's -1) and KG carries a factor 4/3 (`kg_for`): inside
the core the phase comes from the same normalised codes, so the observer sees half of an offset error and
3/4 of a relative gain error (docs/drift.md, "Loop gain").
``KG_k`` is the value of the block's last sample's bank; ``W0_k`` and the tables those of each sample's
bank. Everything per sample is int64 (the widest product e * a is below 2^62); the block sums of e * a
are split into 32-bit halves and the update runs on Python integers (SEA * KG needs about 100 bits).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from .drift_normaliser import LATENCY as NORM_LATENCY
from .drift_normaliser import NormaliserParams, apply_points, normalise
from .drift_observer import LATENCY as OBS_LATENCY
from .drift_observer import (
    PARTIAL_MU_MIN,
    SWEEP_MIN_LOG2,
    ObserverParams,
    ObserverResult,
    abs_deltas,
    bank_tables,
    collect,
    end_block,
    observe,
    per_bank,
)
from .limits import check_integers
from .table_ram import periodic_slopes, split_words

__all__ = [
    "NAME",
    "NORM_LATENCY",
    "OBS_LATENCY",
    "SWEEP_MIN_LOG2",
    "PARTIAL_MU_MIN",
    "DriftParams",
    "DriftResult",
    "drift_run",
    "error_bound",
    "kg_for",
    "largest_kg_shift",
    "make_fwd_table",
    "pack_words",
    "unpack_words",
]

NAME = "drift tracker"   # this model's messages (tables, streams): the tracker is no HDL block of its own
CORE = "fringe_core"    # the HDL unit that checks the normaliser-to-observer timing (PIPE_LATENCY is its pipeline)
# NORM_LATENCY (fringe_drift_normaliser's LATENCY): enabled clocks from in_valid to norm_valid in the RTL.
# OBS_LATENCY (fringe_drift_observer's LATENCY): enabled clocks from obs_valid of a block's last sample (its own
# clock enable counted) until the block's update is pending (ready to be applied).


@dataclass(frozen=True)
class DriftParams(ObserverParams):
    """The HDL parameters (same names upper case, same limits and messages): those of fringe_drift_observer
    (fringe_drift_normaliser's are among them), refused in its name as the core's observer instance does, and
    PIPE_LATENCY, the core's clock enables between the halves, whose timing check is fringe_core's."""

    pipe_latency: int = 0    # clock enables from norm outputs to obs inputs in the core, >= 0

    def __post_init__(self) -> None:
        super().__post_init__()     # fringe_drift_observer's checks
        check_integers(CORE, self, ("pipe_latency",))
        if self.pipe_latency < 0:
            raise ValueError(f"{CORE}: PIPE_LATENCY = {self.pipe_latency} must be >= 0")
        total = NORM_LATENCY + self.pipe_latency + OBS_LATENCY
        if not self.hold and total > self.d + 1:
            raise ValueError(f"{CORE}: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = {NORM_LATENCY} + "
                             f"{self.pipe_latency} + {OBS_LATENCY} = {total} exceeds D + 1 = "
                             f"2^(BLOCK_LOG2-1) + 1 = {self.d + 1}: the update would come too late")

    @property
    def norm_latency(self) -> int:
        return NORM_LATENCY

    @property
    def obs_latency(self) -> int:
        return OBS_LATENCY

    def normaliser(self) -> NormaliserParams:
        """fringe_drift_normaliser's parameters."""
        return NormaliserParams(self.adc_w, self.block_log2, self.ofs_frac, self.ginv_w, self.hold)

    def observer(self) -> ObserverParams:
        """fringe_drift_observer's parameters."""
        return ObserverParams(**{f: getattr(self, f) for f in ObserverParams.__dataclass_fields__})


# ---------------------------------------------------------------------------- tables


def _limits(w: int) -> tuple[int, int]:
    return -(1 << (w - 1)), (1 << (w - 1)) - 1


def make_fwd_table(fn: Callable[[np.ndarray], np.ndarray], params: DriftParams) -> tuple[np.ndarray, int]:
    """``(values, w0)`` of one forward table from ``fn(phase_fraction) -> ADC codes`` (the calibrated
    waveform, vectorised over the bin starts ``k / 2^FWD_W``).

    ``w0 = round(mean * 2^TABLE_FRAC)`` (the mean over the bin starts: the W0 register, s(ADC_W +
    TABLE_FRAC)) and ``values = round(fn * 2^TABLE_FRAC) - w0`` (the table holds the waveform minus its
    mean), int64 of shape (2^FWD_W,). Raises ValueError when a value or a periodic slope does not fit
    s(TABLE_W) or W0 does not fit s(ADC_W + TABLE_FRAC)."""
    p = params
    ph = np.arange(p.bins) / p.bins
    raw = np.asarray(fn(ph), dtype=np.float64) * 2.0 ** p.table_frac
    if raw.shape != (p.bins,) or not np.all(np.isfinite(raw)):
        raise ValueError(f"{NAME}: the waveform function must give {p.bins} finite values")
    w0 = int(np.floor(raw.mean() + 0.5))
    lo, hi = _limits(p.adc_w + p.table_frac)
    if not lo <= w0 <= hi:
        raise ValueError(f"{NAME}: W0 = {w0} does not fit s({p.adc_w + p.table_frac})")
    v = np.floor(raw - w0 + 0.5).astype(np.int64)
    pack_words(v, p)    # range checks
    return v, w0


def pack_words(values, params: DriftParams) -> np.ndarray:
    """RAM words ``{slope, value}`` (value in the low TABLE_W bits) of one table's values, shape
    (2^FWD_W,); ``slope[k] = value[k+1] - value[k]``, periodic (the last bin takes value[0])."""
    p = params
    v = np.asarray(values)
    if v.shape != (p.bins,) or (v.size and not np.issubdtype(v.dtype, np.integer)):
        raise ValueError(f"{NAME}: table values must be {p.bins} integers, got {v.shape} {v.dtype}")
    v = v.astype(np.int64)
    sl = periodic_slopes(v)
    lo, hi = _limits(p.table_w)
    for what, x in (("value", v), ("slope", sl)):
        bad = np.flatnonzero((x < lo) | (x > hi))
        if bad.size:
            k = int(bad[0])
            raise ValueError(f"{NAME}: table {what} at {k}: {int(x[k])} does not fit s({p.table_w})")
    m = (1 << p.table_w) - 1
    return ((sl & m) << p.table_w) | (v & m)


def unpack_words(words, params: DriftParams) -> tuple[np.ndarray, np.ndarray]:
    """``(slope, value)`` as signed int64 from RAM words (any word is legal)."""
    return split_words(words, params.table_w)


def kg_for(values, params: DriftParams) -> int:
    """KG = round(4/3 * 2^(KG_SHIFT + GINV_W - 2 - MU_LOG2) / (W * mean(a^2))), mean(a^2) over the bin values
    (table LSBs), W the samples accumulated per update: at the design step 2^-MU_LOG2 (the gear's last) the
    gain loop corrects that fraction of a relative gain error of its channel per update (the gear multiplies
    KG's step by 2^(MU_LOG2 - G)). The 4/3: with the phase from the same codes the observer sees 3/4 of a
    channel's gain error (and 1/4 of it on the other channel) on any ellipse that the core's quadrature
    correction makes a circle: a constant, not a property of the table. ValueError
    when it does not fit u(KG_W) (choose KG_SHIFT) or the table is zero."""
    p = params
    m2 = float(np.mean(np.asarray(values, dtype=np.float64) ** 2))
    if m2 <= 0:
        raise ValueError(f"{NAME}: KG of an all-zero table")
    kg = int(np.floor(2.0 ** (p.kg_shift + p.ginv_w - 2 - p.mu_log2) * 4 / (3 * p.w * m2) + 0.5))
    if not 0 <= kg < 1 << p.kg_w:
        raise ValueError(f"{NAME}: KG = {kg} does not fit u({p.kg_w}); change KG_SHIFT")
    return kg


def largest_kg_shift(params: DriftParams, tables) -> DriftParams:
    """The parameters with the largest KG_SHIFT (60..1) at which kg_for fits every table's bin values (the finest
    gain step); ValueError when none does."""
    for shift in range(60, 0, -1):
        q = replace(params, kg_shift=shift)
        try:
            for values in tables:
                kg_for(values, q)
            return q
        except ValueError:
            continue
    raise ValueError(f"{NAME}: no KG_SHIFT in 1..60 fits KG in u({params.kg_w})")


# ---------------------------------------------------------------------------- the datapath


@dataclass(kw_only=True)
class DriftResult(ObserverResult):
    """What `drift_run` returns: the observer's `ObserverResult` per complete block (``states`` (blocks + 1, 4)
    = (off_sin, off_cos, ginv_sin, ginv_cos), row 0 the reset state, row j+1 the state after block j, applied
    from sample apply_at[j] = (j+1)B + D on, the same as row j when the block was skipped; ``updated``,
    ``track_sat`` (the flag once the block's state applies), ``sweep``, ``se``, ``sea`` over its window of the
    last W samples) and per sample (int64): y_sin, y_cos, sat, phase and state_index (the row of ``states``
    the normaliser used)."""

    y_sin: np.ndarray
    y_cos: np.ndarray
    sat: np.ndarray
    phase: np.ndarray
    apply_at: np.ndarray
    state_index: np.ndarray


def _check_stream(raw_sin, raw_cos, p: DriftParams):
    rs = np.asarray(raw_sin)
    rc = np.asarray(raw_cos)
    if rs.shape != rc.shape or rs.ndim != 1:
        raise ValueError(f"{NAME}: raw_sin and raw_cos must be one-dimensional and of equal length")
    if rs.size and not (np.issubdtype(rs.dtype, np.integer) and np.issubdtype(rc.dtype, np.integer)):
        raise ValueError(f"{NAME}: raw codes must be integers")
    lo, hi = _limits(p.adc_w)
    rs = rs.astype(np.int64)
    rc = rc.astype(np.int64)
    if rs.size and (min(rs.min(), rc.min()) < lo or max(rs.max(), rc.max()) > hi):
        raise ValueError(f"{NAME}: raw codes outside s(ADC_W = {p.adc_w})")
    return rs, rc


def drift_run(raw_sin, raw_cos, phase_of: Callable[[np.ndarray, np.ndarray], np.ndarray], params: DriftParams,
              tables, w0, kg, *, bank=None, chunk: int | None = None) -> DriftResult:
    """The bit-exact drift tracker (the core's fringe_drift_normaliser and fringe_drift_observer) over a whole
    stream of accepted samples starting after a reset.

    Args:
        raw_sin, raw_cos: s(ADC_W) codes, one per sample accepted by the normaliser.
        phase_of: ``phase_of(y_sin, y_cos) -> u(FINE_W) phases``, the stateless rest of the core up to
            the CORDIC, called on consecutive segments of normalised codes (in order, each sample once).
        params: the block parameters.
        tables: raw words of the forward tables, (2, 2^FWD_W) (sin, cos) or (banks, 2, 2^FWD_W).
        w0, kg: W0_k and KG_k, (2,) or (banks, 2).
        bank: the bank of every observer sample (default 0). Any number of "banks" works (a test can
            number table versions as banks).
        chunk: split the segments further (at most ``chunk`` samples per phase_of call): the result
            does not depend on it.

    Returns:
        `DriftResult`.
    """
    p = params
    rs, rc = _check_stream(raw_sin, raw_cos, p)
    n = rs.size
    t = bank_tables(tables, p, NAME)
    nb = t.shape[0]
    w0a = per_bank(w0, nb, "w0", NAME)
    kga = per_bank(kg, nb, "kg", NAME)
    if bank is None:
        bk = np.zeros(n, dtype=np.int64)
    else:
        bk = np.broadcast_to(np.asarray(bank, dtype=np.int64), (n,))
        if n and (bk.min() < 0 or bk.max() >= nb):
            raise ValueError(f"{NAME}: bank outside 0..{nb - 1}")
    B, D = p.b, p.d
    nblocks = n // B
    ys = np.empty(n, dtype=np.int64)
    yc = np.empty(n, dtype=np.int64)
    sat = np.empty(n, dtype=bool)
    phase = np.empty(n, dtype=np.int64)
    ea = np.empty((2, n), dtype=np.int64)
    e = np.empty((2, n), dtype=np.int64)
    sidx = np.empty(n, dtype=np.int64)
    state = p.reset_state()
    ends = []                   # the blocks' ends
    applied = 0                 # updates applied since reset: the gear's count
    flag = False
    fmask = (1 << p.fine_w) - 1
    dabs = np.zeros(n, dtype=np.int64)
    start = 0
    j = 0
    while start < n:
        end = min(n, (j + 1) * B + D)                   # the next application point (or the end)
        c0 = start
        while c0 < end:
            c1 = end if chunk is None else min(end, c0 + chunk)
            y0, y1, s = normalise(rs[c0:c1], rc[c0:c1], state, p)
            ys[c0:c1], yc[c0:c1], sat[c0:c1] = y0, y1, s
            sidx[c0:c1] = len(ends)
            ph = np.asarray(phase_of(y0, y1)).astype(np.int64)
            if ph.shape != (c1 - c0,) or (ph.size and (ph.min() < 0 or ph.max() > fmask)):
                raise ValueError(f"{NAME}: phase_of must return {c1 - c0} phases in u(FINE_W)")
            phase[c0:c1] = ph
            es, ec, as_, ac = observe(ph, y0, y1, bk[c0:c1], t, w0a, p)
            e[0, c0:c1], e[1, c0:c1] = es, ec
            ea[0, c0:c1], ea[1, c0:c1] = es * as_, ec * ac
            c0 = c1
        # |wrap(delta)| of the new samples (the first sample after reset: 0)
        dabs[start:end] = abs_deltas(phase[start:end], int(phase[start - 1]) if start else None, p)
        start = end
        # block j is complete once (j+1)B samples are in; its update (over the block's last W samples)
        # applies from (j+1)B + D
        if j < nblocks:
            sl = slice((j + 1) * B - p.w, (j + 1) * B)
            ends.append(end_block(state, flag, applied, e[:, sl], ea[:, sl], dabs[sl], kga[bk[(j + 1) * B - 1]], p))
            state, flag, applied = ends[-1].state, ends[-1].track_sat, ends[-1].applied   # whole periods: the gear
            j += 1
        elif start < n:   # pragma: no cover - a segment always ends at an application point
            raise AssertionError("segment logic")
    r = collect(p.reset_state(), ends)
    return DriftResult(**vars(r), y_sin=ys, y_cos=yc, sat=sat.astype(np.int64), phase=phase,
                       apply_at=apply_points(len(ends), p), state_index=sidx)


def error_bound(params: DriftParams, *, ginv_min: float = 0.5) -> dict[str, float]:
    """Steady-state bound on |fixed - float| of the tracked state, per channel, after both trackers
    have settled on the same signal (OFF LSBs and GINV LSBs), inside the core (the phase from the
    normalised codes).

    Per update the fixed tracker's mean error differs from the float one's by the rounding of y (1/2 code
    each sample, a mean of at most 1/2; scaled back to the input by 1/ginv) and the interpolation rounding
    (2^-TABLE_FRAC / 2). Both settle where their mean error is zero; the observer sees half of an offset
    error, so a bias b of the mean error moves the settled offset by 2 b. The floor of the offset step
    (twice the mean error, floored to OFF LSBs) leaves a dead band of 2^(MU_LOG2 - OFS_FRAC - 1) codes in the
    mean error at the final step, 2^(MU_LOG2 - OFS_FRAC) codes of offset. The gain loop: its step is rounded
    to 1/2 GINV LSB (with KG's 4/3 the channel's own error moves GINV by 2^-MU_LOG2 of it per update: a
    dead band of 2^(MU_LOG2 - 1) LSB), plus the relative effect of the mean code rounding against the signal
    (estimated with a quarter of the code range as amplitude), doubled: the observer's gain matrix
    [[3/4, 1/4], [1/4, 3/4]] has the inverse [[3/2, -1/2], [-1/2, 3/2]] (a row sum of magnitudes 2). Bounds,
    not estimates: the rounding means are taken at their worst (1/2), which a moving signal never reaches."""
    p = params
    off_codes = (2 * (0.5 + 0.5 * 2.0 ** -p.table_frac) + 2.0 ** (p.mu_log2 - p.ofs_frac)) / ginv_min
    amp = 2.0 ** (p.adc_w - 3)
    ginv_rel = 2 * (0.5 + 0.5 * 2.0 ** -p.table_frac) / amp / ginv_min
    return {"off_lsb": off_codes * 2.0 ** p.ofs_frac + 1.0,
            "ginv_lsb": ginv_rel * p.unity + 2.0 ** (p.mu_log2 - 1) + 1.0}
