"""Bit-exact model of ``fringe_drift_observer``: the back half of the core's drift tracker (``drift.py``).

Mirrors ``rtl/verilog/fringe_drift_observer.v`` and ``rtl/vhdl/fringe_drift_observer.vhd`` (contract in
``docs/blocks/fringe_drift_observer.md``). Per observer sample (its fine phase, the same sample's normalised
codes y and its bank) and channel k in {sin, cos}::

    bin = phase >> FB, frac = phase mod 2^FB, FB = FINE_W - FWD_W
    a_k = value + ((slope * frac + 2^(FB-1)) >>> FB)        word {slope, value} at {bank, bin}
    e_k = y_k * 2^TABLE_FRAC - W0_k - a_k
    block j = observer samples [jB, (j+1)B), B = 2^BLOCK_LOG2; its window = the last W of them: W = B with
    HOLD = 1, W = B/2 with HOLD = 0; over the window
      SE_k = sum e_k;  SEA_k = sum e_k * a_k;  SWEEP = sum |wrap(phase[n] - phase[n-1])| (first sample after reset: 0)
    at the end of block j, if SWEEP >= 2^FINE_W, update number u (the whole-period updates before it, since
    reset) with the gear G_u = min(MU_LOG2, bit_length(u)); if 2^(FINE_W - SWEEP_MIN_LOG2) <= SWEEP < 2^FINE_W
    and MU_LOG2 >= PARTIAL_MU_MIN, the same update at G = MU_LOG2 (not counted in u); otherwise a skip:
      OFF_k  + (SE_k * 2^OFS_FRAC) >>> (log2(W) + TABLE_FRAC - 1 + G_u)             saturated to s(ADC_W + OFS_FRAC)
      GINV_k - (SEA_k * KG_k * 2^(MU_LOG2 - G_u) + 2^(KG_SHIFT-1)) >>> KG_SHIFT     saturated to u(GINV_W)
      sat = either of the four saturated
    OFF_k, GINV_k: the state on the block's state inputs (the normaliser's: the update taken last). The update
    is held (pending) until the normaliser takes it.

``KG_k`` is the value of the block's last sample's bank; ``W0_k`` and the tables those of each sample's bank.
Everything per sample is int64 (the widest product e * a is below 2^62); the block sums of e * a are split into
32-bit halves and the update runs on Python integers (SEA * KG needs about 100 bits).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .drift_normaliser import StateParams, check_state_params
from .limits import check_integers, check_range
from .table_ram import interpolate, split_words

__all__ = ["NAME", "LATENCY", "SWEEP_MIN_LOG2", "PARTIAL_MU_MIN", "ObserverParams", "ObserverResult",
           "abs_deltas", "check_observer_params", "collect", "end_block", "observe", "observer_run", "update"]

NAME = "fringe_drift_observer"
#: Enabled clocks from obs_valid of a block's last sample (its own clock enable counted) until the
#: block's update is resolved (pending, ready to be taken, or a skip).
LATENCY = 16
# A block that swept less than a whole period but at least 2^-SWEEP_MIN_LOG2 of one still updates, at the final
# gear (a small step, which the next blocks' other directions complete): a slow or short-block tracker otherwise
# waits, with all of the drift in its readings, until some block sweeps a period ("Partial sweeps" in the docs)
SWEEP_MIN_LOG2 = 4
# ... and only where the final step is 2^-PARTIAL_MU_MIN or smaller: on an arc offset and gain are one direction, and
# with a final step of 1/2 an arc swept back and forth near a channel's peak drove GINV to 0 (absorbing) in the tests
PARTIAL_MU_MIN = 2


def check_observer_params(block: str, p) -> None:
    """The limits of the observer's own parameters (after check_state_params), with ``block``'s name."""
    check_range(block, "FINE_W", p.fine_w, 8, 30)
    check_range(block, "MU_LOG2", p.mu_log2, 0, 8)
    fwd_max = min(10, p.fine_w - 1)
    check_range(block, "FWD_W", p.fwd_w, 2, fwd_max, f"2..min(10, FINE_W-1) = {fwd_max}")
    check_range(block, "TABLE_W", p.table_w, 8, 24)
    check_range(block, "TABLE_FRAC", p.table_frac, 0, 12)
    check_range(block, "KG_W", p.kg_w, 8, 24)
    check_range(block, "KG_SHIFT", p.kg_shift, 1, 60)


@dataclass(frozen=True)
class ObserverParams(StateParams):
    """The HDL parameters (same names upper case, same limits and messages; the init files are the HDL's)."""

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
    hold: int = 1            # 1: the window is the whole block; 0: its second half (W = B/2)

    def __post_init__(self) -> None:
        check_integers(NAME, self, ("adc_w", "fine_w", "block_log2", "mu_log2", "ofs_frac", "ginv_w", "fwd_w",
                                    "table_w", "table_frac", "kg_w", "kg_shift", "hold"))
        check_state_params(NAME, self)
        check_observer_params(NAME, self)

    # ---- derived constants (names as in the HDL)
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

    def hdl_parameters(self) -> dict[str, int]:
        """The HDL parameter / generic map (without the init files)."""
        return {"ADC_W": self.adc_w, "FINE_W": self.fine_w, "BLOCK_LOG2": self.block_log2, "MU_LOG2": self.mu_log2,
                "OFS_FRAC": self.ofs_frac, "GINV_W": self.ginv_w, "FWD_W": self.fwd_w, "TABLE_W": self.table_w,
                "TABLE_FRAC": self.table_frac, "KG_W": self.kg_w, "KG_SHIFT": self.kg_shift, "HOLD": self.hold}


# ---------------------------------------------------------------------------- per sample


def observe(phase, y_sin, y_cos, bank, tables, w0, params: ObserverParams):
    """Per-sample observer terms: ``(e_sin, e_cos, a_sin, a_cos)`` (int64). ``tables`` raw words of
    shape (banks, 2, 2^FWD_W) (channel 0 sin, 1 cos), ``w0`` (banks, 2), ``bank`` per sample."""
    p = params
    ph = np.asarray(phase, dtype=np.int64)
    b = ph >> p.fb
    frac = ph & ((1 << p.fb) - 1)
    res = []
    for k, y in ((0, y_sin), (1, y_cos)):
        a = interpolate(*split_words(tables[bank, k, b], p.table_w), frac, p.fb)
        e = (np.asarray(y, dtype=np.int64) << p.table_frac) - w0[bank, k] - a
        res.append((e, a))
    return res[0][0], res[1][0], res[0][1], res[1][1]


def abs_deltas(phase, prev: int | None, params: ObserverParams) -> np.ndarray:
    """|wrap(phase[n] - phase[n-1])| per sample (wrap into [-2^(FINE_W-1), 2^(FINE_W-1))); ``prev`` the phase of
    the sample before the first, None after a reset (the first sample's delta is 0)."""
    p = params
    ph = np.asarray(phase, dtype=np.int64)
    before = np.concatenate([[ph[0] if prev is None else prev], ph[:-1]]) if ph.size else ph
    d = (ph - before) & ((1 << p.fine_w) - 1)
    return np.where(d >= 1 << (p.fine_w - 1), (1 << p.fine_w) - d, d)


def _sum_exact(x: np.ndarray) -> int:
    """Exact sum of int64 values below 2^62 in magnitude (at most 2^20 of them)."""
    lo = x & 0xFFFFFFFF
    hi = x >> 32
    return (int(hi.sum()) << 32) + int(lo.sum())


# ---------------------------------------------------------------------------- per block


def _sat(v: int, lo: int, hi: int) -> tuple[int, bool]:
    return (lo, True) if v < lo else (hi, True) if v > hi else (v, False)


def update(state, se, sea, kg, params: ObserverParams, gear: int) -> tuple[tuple[int, int, int, int], bool]:
    """One block's update at gear G (Python ints): ``((off_s, off_c, ginv_s, ginv_c), saturated)``."""
    p = params
    olo, ohi = -(1 << (p.ofs_w - 1)), (1 << (p.ofs_w - 1)) - 1
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


@dataclass
class BlockEnd:
    """One block's end (`end_block`): the state after it (the pending update, or the state it was given when
    skipped), whether it updated, its saturation flag (the one of the update taken last), SWEEP and the sums,
    and the whole-period updates counted so far (the gear's count)."""

    state: tuple[int, int, int, int]
    updated: bool
    track_sat: bool
    sweep: int
    se: tuple[int, int]
    sea: tuple[int, int]
    applied: int


def end_block(state, track_sat: bool, applied: int, e, ea, dabs, kg, params: ObserverParams) -> BlockEnd:
    """The end of a block: ``e`` (2, W) and ``ea`` (2, W) the window's e_k and e_k * a_k, ``dabs`` (W,) its
    |delta|, ``kg`` the KG pair of the block's last sample; ``state`` the state the update steps from,
    ``track_sat`` the flag before, ``applied`` the whole-period updates before it."""
    p = params
    sw = int(np.asarray(dabs).sum())
    se = (int(e[0].sum()), int(e[1].sum()))
    sea = (_sum_exact(ea[0]), _sum_exact(ea[1]))
    g = p.block_gear(sw, applied)
    if g is None:
        return BlockEnd(tuple(state), False, track_sat, sw, se, sea, applied)
    new, sat = update(state, se, sea, kg, p, g)
    return BlockEnd(new, True, sat, sw, se, sea, applied + p.whole_period(sw))


def per_bank(x, banks: int, what: str, name: str = NAME) -> np.ndarray:
    """A W0 or KG pair per bank: ``x`` of shape (2,) (every bank) or (banks, 2)."""
    a = np.asarray(x, dtype=np.int64)
    if a.shape == (2,):
        a = np.broadcast_to(a, (banks, 2))
    if a.shape != (banks, 2):
        raise ValueError(f"{name}: {what} must have shape (2,) or (banks, 2), got {a.shape}")
    return a


def bank_tables(tables, params: ObserverParams, name: str = NAME) -> np.ndarray:
    """The forward tables' raw words as (banks, 2, 2^FWD_W) from (2, 2^FWD_W) or (banks, 2, 2^FWD_W)."""
    t = np.asarray(tables).astype(np.int64)
    if t.ndim == 2:
        t = t[None]
    if t.ndim != 3 or t.shape[1:] != (2, params.bins):
        raise ValueError(f"{name}: tables must have shape (2, {params.bins}) or (banks, 2, {params.bins}), "
                         f"got {t.shape}")
    return t


@dataclass
class ObserverResult:
    """What `observer_run` returns, per complete block: ``states`` (blocks + 1, 4) with row 0 the state given
    and row j+1 the state after block j (the pending update, or row j when skipped); ``updated``,
    ``track_sat`` (the flag after block j), ``sweep`` (int64), ``se``, ``sea`` (Python ints, lists)."""

    states: np.ndarray
    updated: np.ndarray
    track_sat: np.ndarray
    sweep: np.ndarray
    se: list = field(default_factory=list)
    sea: list = field(default_factory=list)


def observer_run(phase, y_sin, y_cos, tables, w0, kg, params: ObserverParams, *, bank=None,
                 state=None) -> ObserverResult:
    """Bit-exact ``fringe_drift_observer`` over a stream of observer samples from a reset, each block's update
    taken by the normaliser before the next block's update steps from the state (as in ``fringe_core``, where
    the application sample comes before the next block's end).

    Args:
        phase: u(FINE_W) per sample; y_sin, y_cos: the same samples' normalised codes, s(ADC_W).
        tables: raw words of the forward tables, (2, 2^FWD_W) (sin, cos) or (banks, 2, 2^FWD_W).
        w0, kg: W0_k and KG_k, (2,) or (banks, 2).
        params: the block parameters.
        bank: per sample (default 0).
        state: the normaliser's state until the first update is taken (default the reset state).
    """
    p = params
    t = bank_tables(tables, p)
    nb = t.shape[0]
    w0a = per_bank(w0, nb, "w0")
    kga = per_bank(kg, nb, "kg")
    ph = np.asarray(phase, dtype=np.int64)
    n = ph.size
    bk = np.zeros(n, dtype=np.int64) if bank is None else np.broadcast_to(np.asarray(bank, dtype=np.int64), (n,))
    es, ec, as_, ac = observe(ph, y_sin, y_cos, bk, t, w0a, p)
    e = np.stack([es, ec])
    ea = np.stack([es * as_, ec * ac])
    dabs = abs_deltas(ph, None, p)
    st0 = p.reset_state() if state is None else tuple(int(x) for x in state)
    ends = [BlockEnd(st0, False, False, 0, (0, 0), (0, 0), 0)]     # (the state before the first block)
    for j in range(n // p.b):
        sl = slice((j + 1) * p.b - p.w, (j + 1) * p.b)
        last = ends[-1]
        ends.append(end_block(last.state, last.track_sat, last.applied, e[:, sl], ea[:, sl], dabs[sl],
                              kga[bk[(j + 1) * p.b - 1]], p))
    return collect(st0, ends[1:])


def collect(state, ends: list[BlockEnd]) -> ObserverResult:
    """The `ObserverResult` of the blocks ``ends`` after the state ``state``."""
    return ObserverResult(np.array([state] + [r.state for r in ends], dtype=np.int64).reshape(-1, 4),
                          np.array([r.updated for r in ends], dtype=bool),
                          np.array([r.track_sat for r in ends], dtype=bool),
                          np.array([r.sweep for r in ends], dtype=np.int64), [r.se for r in ends],
                          [r.sea for r in ends])
