"""Bit-exact model of ``fringe_drift``: online offset / gain tracker for drifting sin/cos signals.

Mirrors ``rtl/verilog/fringe_drift.v`` and ``rtl/vhdl/fringe_drift.vhd`` (contract in ``docs/blocks/fringe_drift.md``).
Two sides in one block, per channel k in {sin, cos}:

NORMALISER (front of the core, raw ADC codes s(ADC_W))::

    y_k = ((raw_k * 2^OFS_FRAC - OFF_k) * GINV_k + 2^(OFS_FRAC + GINV_W - 3)) >>> (OFS_FRAC + GINV_W - 2)
    saturated to s(ADC_W); norm_sat = either channel saturated

OBSERVER (each sample's fine phase from downstream with the same sample's y)::

    bin = phase >> FB, frac = phase mod 2^FB, FB = FINE_W - FWD_W
    a_k = value + ((slope * frac + 2^(FB-1)) >>> FB)        word {slope, value} at {bank, bin}
    e_k = y_k * 2^TABLE_FRAC - W0_k - a_k
    block j = observer samples [jB, (j+1)B), B = 2^BLOCK_LOG2; its window = the last W of them, those
    normalised with the latest state: W = B with HOLD = 1, W = B/2 with HOLD = 0; over the window
      SE_k = sum e_k;  SEA_k = sum e_k * a_k;  SWEEP = sum |wrap(phase[n] - phase[n-1])| (first sample after reset: 0)
    at the end of block j, if SWEEP >= 2^FINE_W, update number u (the whole-period updates before it, since
    reset) with the gear G_u = min(MU_LOG2, bit_length(u)) (steps 1, 1/2, 1/4, 1/4, 1/8 x 4, ... 2^-MU_LOG2);
    if 2^(FINE_W - SWEEP_MIN_LOG2) <= SWEEP < 2^FINE_W and MU_LOG2 >= PARTIAL_MU_MIN, the same update at
    G = MU_LOG2 (not counted in u):
      OFF_k  += (SE_k * 2^OFS_FRAC) >>> (log2(W) + TABLE_FRAC - 1 + G_u)             saturated to s(ADC_W + OFS_FRAC)
      GINV_k -= (SEA_k * KG_k * 2^(MU_LOG2 - G_u) + 2^(KG_SHIFT-1)) >>> KG_SHIFT     saturated to u(GINV_W)
      track_sat = either of the four saturated (held through skipped blocks, cleared by reset)
    the new state applies from normaliser input sample (j+1)B + D on: D = 0 with HOLD = 1 (the normaliser
    holds sample (j+1)B until the update is resolved: in_ready), D = B/2 with HOLD = 0.

The offset step is twice the mean error (the shift's -1) and KG carries a factor 4/3 (`kg_for`): inside
the core the phase comes from the same normalised codes, so the observer sees half of an offset error and
3/4 of a relative gain error (docs/blocks/fringe_drift.md, "Loop gain").
``KG_k`` is the value of the block's last sample's bank; ``W0_k`` and the tables those of each sample's
bank. Everything per sample is int64 (the widest product e * a is below 2^62); the block sums of e * a
are split into 32-bit halves and the update runs on Python integers (SEA * KG needs about 100 bits).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from .limits import check_range
from .table_ram import interpolate, periodic_slopes, split_words

__all__ = [
    "NAME",
    "NORM_LATENCY",
    "OBS_LATENCY",
    "SWEEP_MIN_LOG2",
    "PARTIAL_MU_MIN",
    "DriftParams",
    "DriftResult",
    "drift_float",
    "drift_run",
    "error_bound",
    "kg_for",
    "largest_kg_shift",
    "make_fwd_table",
    "normalise",
    "observe",
    "pack_words",
    "unpack_words",
]

NAME = "fringe_drift"
#: Enabled clocks from in_valid to norm_valid in the RTL.
NORM_LATENCY = 4
#: Enabled clocks from obs_valid of a block's last sample (its own clock enable counted) until the
#: block's update is pending (ready to be applied).
OBS_LATENCY = 16
# A block that swept less than a whole period but at least 2^-SWEEP_MIN_LOG2 of one still updates, at the final
# gear (a small step, which the next blocks' other directions complete): a slow or short-block tracker otherwise
# waits, with all of the drift in its readings, until some block sweeps a period ("Partial sweeps" in the docs)
SWEEP_MIN_LOG2 = 4
# ... and only where the final step is 2^-PARTIAL_MU_MIN or smaller: on an arc offset and gain are one direction, and
# with a final step of 1/2 an arc swept back and forth near a channel's peak drove GINV to 0 (absorbing) in the tests
PARTIAL_MU_MIN = 2


def _check_int(name: str, v) -> None:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise ValueError(f"{NAME}: {name} must be an integer")


@dataclass(frozen=True)
class DriftParams:
    """The HDL parameters (same names upper case, same limits and messages)."""

    adc_w: int = 14          # ADC code width, 4..24
    fine_w: int = 16         # fine phase bits per period, 8..30
    block_log2: int = 8      # B = 2^BLOCK_LOG2 samples per update block, 4..12
    mu_log2: int = 3         # update step 2^-MU_LOG2, 0..8
    ofs_frac: int = 4        # fraction bits of OFF, 0..8; ADC_W + OFS_FRAC <= 32
    ginv_w: int = 18         # width of GINV (GINV_W - 2 fraction bits), 8..24
    fwd_w: int = 6           # 2^FWD_W bins per period in the forward tables, 2..min(10, FINE_W-1)
    table_w: int = 18        # table value and slope width, 8..24
    table_frac: int = 2      # fraction bits of the table values and of W0 (ADC codes), 0..12
    kg_w: int = 18           # width of KG, 8..24
    kg_shift: int = 40       # right shift of SEA * KG, 1..60
    pipe_latency: int = 0    # clock enables from norm outputs to obs inputs in the core, >= 0
    hold: int = 1            # 1: updates apply at the block boundary (the input waits: in_ready); 0: D = B/2 later

    def __post_init__(self) -> None:
        for f in ("adc_w", "fine_w", "block_log2", "mu_log2", "ofs_frac", "ginv_w", "fwd_w", "table_w",
                  "table_frac", "kg_w", "kg_shift", "pipe_latency", "hold"):
            _check_int(f.upper(), getattr(self, f))
        check_range(NAME, "ADC_W", self.adc_w, 4, 24)
        check_range(NAME, "FINE_W", self.fine_w, 8, 30)
        check_range(NAME, "BLOCK_LOG2", self.block_log2, 4, 12)
        check_range(NAME, "MU_LOG2", self.mu_log2, 0, 8)
        check_range(NAME, "OFS_FRAC", self.ofs_frac, 0, 8)
        if self.adc_w + self.ofs_frac > 32:
            raise ValueError(f"{NAME}: ADC_W + OFS_FRAC = {self.adc_w + self.ofs_frac} exceeds 32")
        check_range(NAME, "GINV_W", self.ginv_w, 8, 24)
        fwd_max = min(10, self.fine_w - 1)
        check_range(NAME, "FWD_W", self.fwd_w, 2, fwd_max, f"2..min(10, FINE_W-1) = {fwd_max}")
        check_range(NAME, "TABLE_W", self.table_w, 8, 24)
        check_range(NAME, "TABLE_FRAC", self.table_frac, 0, 12)
        check_range(NAME, "KG_W", self.kg_w, 8, 24)
        check_range(NAME, "KG_SHIFT", self.kg_shift, 1, 60)
        if self.pipe_latency < 0:
            raise ValueError(f"{NAME}: PIPE_LATENCY = {self.pipe_latency} must be >= 0")
        check_range(NAME, "HOLD", self.hold, 0, 1)
        total = NORM_LATENCY + self.pipe_latency + OBS_LATENCY
        if not self.hold and total > self.d + 1:
            raise ValueError(f"{NAME}: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = {NORM_LATENCY} + "
                             f"{self.pipe_latency} + {OBS_LATENCY} = {total} exceeds D + 1 = "
                             f"2^(BLOCK_LOG2-1) + 1 = {self.d + 1}: the update would come too late")

    # ---- derived constants (names as in the HDL)
    @property
    def b(self) -> int:
        """B: samples per block, 2^BLOCK_LOG2."""
        return 1 << self.block_log2

    @property
    def d(self) -> int:
        """D: the application delay after a block's end: 0 with HOLD = 1, B/2 samples with HOLD = 0."""
        return 0 if self.hold else 1 << (self.block_log2 - 1)

    @property
    def w_log2(self) -> int:
        """log2(W): BLOCK_LOG2 with HOLD = 1, BLOCK_LOG2 - 1 with HOLD = 0."""
        return self.block_log2 - 1 + self.hold

    @property
    def w(self) -> int:
        """W: the samples accumulated per update, the last W of each block (those normalised with the
        latest state): B with HOLD = 1, B/2 with HOLD = 0."""
        return 1 << self.w_log2

    def gear(self, u: int) -> int:
        """G_u = min(MU_LOG2, bit_length(u)) of update number u (applied updates before it since reset)."""
        return min(self.mu_log2, int(u).bit_length())

    def whole_period(self, sweep: float) -> bool:
        """Whether a block swept a whole period (`sweep` in fine counts): only then does the gear advance."""
        return sweep >= 1 << self.fine_w

    def block_gear(self, sweep: float, u: int) -> int | None:
        """The gear of a block that swept `sweep` (fine counts; the float twin's may be fractional) after u
        whole-period updates: G_u for a whole period, MU_LOG2 for at least 2^-SWEEP_MIN_LOG2 of one (from
        MU_LOG2 = PARTIAL_MU_MIN on), None for a skipped block."""
        if self.whole_period(sweep):
            return self.gear(u)
        if sweep >= 1 << (self.fine_w - SWEEP_MIN_LOG2) and self.mu_log2 >= PARTIAL_MU_MIN:
            return self.mu_log2
        return None

    @property
    def fb(self) -> int:
        """FB: fraction bits of the phase within a bin, FINE_W - FWD_W (>= 1)."""
        return self.fine_w - self.fwd_w

    @property
    def bins(self) -> int:
        """Bins per period (words per bank of each forward table), 2^FWD_W."""
        return 1 << self.fwd_w

    @property
    def ofs_w(self) -> int:
        """Width of OFF: ADC_W + OFS_FRAC."""
        return self.adc_w + self.ofs_frac

    @property
    def unity(self) -> int:
        """GINV of gain 1: 2^(GINV_W-2)."""
        return 1 << (self.ginv_w - 2)

    @property
    def norm_shift(self) -> int:
        """OFS_FRAC + GINV_W - 2."""
        return self.ofs_frac + self.ginv_w - 2

    def off_shift(self, g: int) -> int:
        """log2(W) + TABLE_FRAC - 1 + G: the right shift of SE * 2^OFS_FRAC at gear G (twice the mean error:
        the observer sees half of an offset error)."""
        return self.w_log2 + self.table_frac - 1 + g

    @property
    def word_w(self) -> int:
        """Width of a table word {slope, value}: 2 * TABLE_W."""
        return 2 * self.table_w

    @property
    def e_w(self) -> int:
        """Width of e: s(max(ADC_W + TABLE_FRAC + 1, TABLE_W + 1) + 1)."""
        return max(self.adc_w + self.table_frac + 1, self.table_w + 1) + 1

    @property
    def se_w(self) -> int:
        """Width of SE: e_w + log2(W)."""
        return self.e_w + self.w_log2

    @property
    def sea_w(self) -> int:
        """Width of SEA: e_w + TABLE_W + 1 + log2(W) (a is s(TABLE_W + 1))."""
        return self.e_w + self.table_w + 1 + self.w_log2

    @property
    def sweep_w(self) -> int:
        """Width of SWEEP (unsigned): FINE_W + log2(W)."""
        return self.fine_w + self.w_log2

    @property
    def norm_latency(self) -> int:
        return NORM_LATENCY

    @property
    def obs_latency(self) -> int:
        return OBS_LATENCY

    def hdl_parameters(self) -> dict[str, int]:
        """The HDL parameter / generic map (without the init files and USER_W)."""
        return {"ADC_W": self.adc_w, "FINE_W": self.fine_w, "BLOCK_LOG2": self.block_log2, "MU_LOG2": self.mu_log2,
                "OFS_FRAC": self.ofs_frac, "GINV_W": self.ginv_w, "FWD_W": self.fwd_w, "TABLE_W": self.table_w,
                "TABLE_FRAC": self.table_frac, "KG_W": self.kg_w, "KG_SHIFT": self.kg_shift,
                "PIPE_LATENCY": self.pipe_latency, "HOLD": self.hold}


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


def normalise(raw_sin, raw_cos, state, params: DriftParams):
    """``(y_sin, y_cos, sat)`` of raw codes with one state ``(off_sin, off_cos, ginv_sin, ginv_cos)``."""
    p = params
    lo, hi = _limits(p.adc_w)
    rnd = 1 << (p.norm_shift - 1)
    out = []
    sat = None
    for raw, off, g in ((raw_sin, state[0], state[2]), (raw_cos, state[1], state[3])):
        y = ((np.asarray(raw, dtype=np.int64) << p.ofs_frac) - off) * g
        y += rnd
        y >>= p.norm_shift
        s = (y < lo) | (y > hi)
        out.append(np.clip(y, lo, hi))
        sat = s if sat is None else sat | s
    return out[0], out[1], sat


def _per_bank(x, banks: int, what: str) -> np.ndarray:
    a = np.asarray(x, dtype=np.int64)
    if a.shape == (2,):
        a = np.broadcast_to(a, (banks, 2))
    if a.shape != (banks, 2):
        raise ValueError(f"{NAME}: {what} must have shape (2,) or (banks, 2), got {a.shape}")
    return a


def observe(phase, y_sin, y_cos, bank, tables, w0, params: DriftParams):
    """Per-sample observer terms: ``(e_sin, e_cos, a_sin, a_cos)`` (int64). ``tables`` raw words of
    shape (banks, 2, 2^FWD_W) (channel 0 sin, 1 cos), ``w0`` (banks, 2), ``bank`` per sample."""
    p = params
    ph = np.asarray(phase, dtype=np.int64)
    b = ph >> p.fb
    frac = ph & ((1 << p.fb) - 1)
    res = []
    for k, y in ((0, y_sin), (1, y_cos)):
        a = interpolate(*unpack_words(tables[bank, k, b], p), frac, p.fb)
        e = (np.asarray(y, dtype=np.int64) << p.table_frac) - w0[bank, k] - a
        res.append((e, a))
    return res[0][0], res[1][0], res[0][1], res[1][1]


def _sum_exact(x: np.ndarray) -> int:
    """Exact sum of int64 values below 2^62 in magnitude (at most 2^20 of them)."""
    lo = x & 0xFFFFFFFF
    hi = x >> 32
    return (int(hi.sum()) << 32) + int(lo.sum())


@dataclass
class DriftResult:
    """What `drift_run` returns (int64 arrays unless noted).

    y_sin, y_cos, sat, phase: per sample. states: (blocks + 1, 4) = (off_sin, off_cos, ginv_sin, ginv_cos),
    row 0 the reset state, row j+1 the state after block j (applied from sample apply_at[j] =
    (j+1)B + D on; the same as row j when the block was skipped). updated, track_sat, sweep, se, sea: per
    complete block, over its window of the last W samples (track_sat: the flag once the block's state
    applies; se, sea as Python ints, lists).
    state_index: per sample, the row of ``states`` the normaliser used."""

    y_sin: np.ndarray
    y_cos: np.ndarray
    sat: np.ndarray
    phase: np.ndarray
    states: np.ndarray
    apply_at: np.ndarray
    updated: np.ndarray
    track_sat: np.ndarray
    sweep: np.ndarray
    state_index: np.ndarray
    se: list = field(default_factory=list)
    sea: list = field(default_factory=list)


def _sat(v: int, lo: int, hi: int) -> tuple[int, bool]:
    return (lo, True) if v < lo else (hi, True) if v > hi else (v, False)


def update(state, se, sea, kg, params: DriftParams, gear: int) -> tuple[tuple[int, int, int, int], bool]:
    """One block's update at gear G (Python ints): ``((off_s, off_c, ginv_s, ginv_c), saturated)``."""
    p = params
    olo, ohi = _limits(p.ofs_w)
    off, ginv, sat = [], [], False
    sh = p.off_shift(gear)
    up = p.mu_log2 - gear          # the gain step 2^(MU_LOG2 - G) times KG's design step
    for k in (0, 1):
        o, s1 = _sat(int(state[k]) + ((int(se[k]) << p.ofs_frac) >> sh), olo, ohi)
        g, s2 = _sat(int(state[2 + k]) - (((int(sea[k]) * int(kg[k])) << up) + (1 << (p.kg_shift - 1)) >> p.kg_shift),
                     0, (1 << p.ginv_w) - 1)
        off.append(o)
        ginv.append(g)
        sat = sat or s1 or s2
    return (off[0], off[1], ginv[0], ginv[1]), sat


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
    """Bit-exact ``fringe_drift`` over a whole stream of accepted samples starting after a reset.

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
    t = np.asarray(tables).astype(np.int64)
    if t.ndim == 2:
        t = t[None]
    if t.ndim != 3 or t.shape[1:] != (2, p.bins):
        raise ValueError(f"{NAME}: tables must have shape (2, {p.bins}) or (banks, 2, {p.bins}), got {t.shape}")
    nb = t.shape[0]
    w0a = _per_bank(w0, nb, "w0")
    kga = _per_bank(kg, nb, "kg")
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
    state = (0, 0, p.unity, p.unity)
    states = [state]
    updated, tsat, sweep, ses, seas = [], [], [], [], []
    applied = 0                 # updates applied since reset: the gear's count
    flag = False
    fmask = (1 << p.fine_w) - 1
    half = 1 << (p.fine_w - 1)
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
            sidx[c0:c1] = len(states) - 1
            ph = np.asarray(phase_of(y0, y1)).astype(np.int64)
            if ph.shape != (c1 - c0,) or (ph.size and (ph.min() < 0 or ph.max() > fmask)):
                raise ValueError(f"{NAME}: phase_of must return {c1 - c0} phases in u(FINE_W)")
            phase[c0:c1] = ph
            es, ec, as_, ac = observe(ph, y0, y1, bk[c0:c1], t, w0a, p)
            e[0, c0:c1], e[1, c0:c1] = es, ec
            ea[0, c0:c1], ea[1, c0:c1] = es * as_, ec * ac
            c0 = c1
        # |wrap(delta)| of the new samples (the first sample after reset: 0)
        lo_i = max(start, 1)
        if end > lo_i:
            d = (phase[lo_i:end] - phase[lo_i - 1:end - 1]) & fmask
            dabs[lo_i:end] = np.where(d >= half, (1 << p.fine_w) - d, d)
        start = end
        # block j is complete once (j+1)B samples are in; its update (over the block's last W samples)
        # applies from (j+1)B + D
        if j < nblocks:
            sl = slice((j + 1) * B - p.w, (j + 1) * B)
            sw = int(dabs[sl].sum())
            se = (int(e[0, sl].sum()), int(e[1, sl].sum()))
            sea = (_sum_exact(ea[0, sl]), _sum_exact(ea[1, sl]))
            g = p.block_gear(sw, applied)
            ok = g is not None
            if ok:
                state, flag = update(state, se, sea, kga[bk[(j + 1) * B - 1]], p, g)
                applied += p.whole_period(sw)      # only whole periods advance the gear
            states.append(state)
            updated.append(ok)
            tsat.append(flag)
            sweep.append(sw)
            ses.append(se)
            seas.append(sea)
            j += 1
        elif start < n:   # pragma: no cover - a segment always ends at an application point
            raise AssertionError("segment logic")
    apply_at = (np.arange(len(updated), dtype=np.int64) + 1) * B + D
    return DriftResult(ys, yc, sat.astype(np.int64), phase, np.array(states, dtype=np.int64).reshape(-1, 4),
                       apply_at, np.array(updated, dtype=bool), np.array(tsat, dtype=bool),
                       np.array(sweep, dtype=np.int64), sidx, ses, seas)


# ---------------------------------------------------------------------------- float twin


def drift_float(raw_sin, raw_cos, phase_of: Callable[[np.ndarray, np.ndarray], np.ndarray], params: DriftParams,
                tables, w0, kg, *, bank=None) -> dict[str, np.ndarray]:
    """The same tracker in float without rounding (the float engine's tracker).

    Units: codes. ``off`` in ADC codes (OFF / 2^OFS_FRAC), ``ginv`` the gain ratio (GINV / 2^(GINV_W-2)),
    ``y = (raw - off) * ginv`` clipped to the s(ADC_W) range, ``a = (value + slope * frac / 2^FB) /
    2^TABLE_FRAC`` (exact interpolation of the same table words), ``e = y - w0 - a`` (w0 = W0 /
    2^TABLE_FRAC), per update (the block's last W samples, gear G_u) ``off += 2 mean(e) 2^-G_u`` and ``ginv -=
    sum(e a) KG 2^(2 TABLE_FRAC - KG_SHIFT - GINV_W + 2 + MU_LOG2 - G_u)``, same sweep test (the phases from
    ``phase_of`` may be floats in fine counts), same application points. Returns y_sin, y_cos, phase (per
    sample) and states (blocks + 1, 4) in the fixed-point LSB units of OFF and GINV (floats) for a direct
    comparison, and updated."""
    p = params
    rs = np.asarray(raw_sin, dtype=np.float64)
    rc = np.asarray(raw_cos, dtype=np.float64)
    n = rs.size
    t = np.asarray(tables).astype(np.int64)
    if t.ndim == 2:
        t = t[None]
    nb = t.shape[0]
    w0a = _per_bank(w0, nb, "w0").astype(np.float64) / 2.0 ** p.table_frac
    kga = _per_bank(kg, nb, "kg").astype(np.float64)
    bk = np.zeros(n, dtype=np.int64) if bank is None else np.broadcast_to(np.asarray(bank, dtype=np.int64), (n,))
    B, D = p.b, p.d
    lo, hi = _limits(p.adc_w)
    per = float(1 << p.fine_w)
    tf = 2.0 ** p.table_frac
    gk = 2.0 ** (2 * p.table_frac - p.kg_shift - p.ginv_w + 2)
    off = np.zeros(2)
    ginv = np.ones(2)
    ys = np.empty(n)
    yc = np.empty(n)
    phase = np.empty(n)
    e = np.empty((2, n))
    a = np.empty((2, n))
    states = [(0.0, 0.0, float(p.unity), float(p.unity))]
    updated = []
    applied = 0                 # updates applied since reset: the gear's count
    start, j = 0, 0
    while start < n:
        end = min(n, (j + 1) * B + D)
        y0 = np.clip((rs[start:end] - off[0]) * ginv[0], lo, hi)
        y1 = np.clip((rc[start:end] - off[1]) * ginv[1], lo, hi)
        ys[start:end], yc[start:end] = y0, y1
        ph = np.asarray(phase_of(y0, y1), dtype=np.float64)
        phase[start:end] = ph
        u = np.mod(ph, per) / 2.0 ** p.fb
        b = np.floor(u).astype(np.int64) % p.bins
        fr = u - np.floor(u)
        for k, y in ((0, y0), (1, y1)):
            slope, value = unpack_words(t[bk[start:end], k, b], p)
            a[k, start:end] = (value + slope * fr) / tf
            e[k, start:end] = y - w0a[bk[start:end], k] - a[k, start:end]
        start = end
        if j < n // B:
            sl = slice((j + 1) * B - p.w, (j + 1) * B)
            ph_b = phase[max((j + 1) * B - p.w - 1, 0):(j + 1) * B]
            d = np.mod(np.diff(ph_b) + per / 2, per) - per / 2
            sw = float(np.abs(d).sum())
            g = p.block_gear(sw, applied)
            ok = g is not None
            if ok:
                kgb = kga[bk[(j + 1) * B - 1]]
                applied += p.whole_period(sw)
                off = off + e[:, sl].mean(axis=1) * 2.0 ** (1 - g)
                ginv = ginv - (e[:, sl] * a[:, sl]).sum(axis=1) * kgb * gk * 2.0 ** (p.mu_log2 - g)
            states.append((off[0] * 2.0 ** p.ofs_frac, off[1] * 2.0 ** p.ofs_frac,
                           ginv[0] * p.unity, ginv[1] * p.unity))
            updated.append(ok)
            j += 1
    return {"y_sin": ys, "y_cos": yc, "phase": phase, "states": np.array(states).reshape(-1, 4),
            "updated": np.array(updated, dtype=bool)}


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
