"""Bit-exact model of ``fringe_long_period``: the seed 000 harmonic table, direction and zero.

Contract: docs/architecture.md, section fringe_long_period. With REV = LINES * 2^FINE_W and
2^LP_ADDR_W entries per revolution:

    t = pos * LP_RECIP;  entry = t >> LP_SHIFT;  frac = (t >> (LP_SHIFT - LP_IF)) mod 2^LP_IF
    corr  = value[entry] + ((slope[entry] * frac + 2^(LP_IF-1)) >>> LP_IF)
    pos_c = (pos - ((corr + 2^(LP_FRAC-1)) >>> LP_FRAC)) mod REV        (no rounding term if LP_FRAC = 0)
    out   = DIR ? (ZERO - pos_c) mod REV : (pos_c + ZERO) mod REV

`index_mapping` chooses LP_RECIP and LP_SHIFT so that `entry = floor(pos * 2^LP_ADDR_W / REV)`
exactly for every pos < REV; a power-of-two REV gives a power-of-two LP_RECIP (no multiplier).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .period_count import rev_and_pos_w

LATENCY = 6   # clock enables in the RTL: index, table read, product, correction, wrap, zero and direction
NAME = "fringe_long_period"


@dataclass(frozen=True)
class LongPeriodParams:
    lines: int       # LINES: periods per revolution, >= 1
    fine_w: int      # FINE_W: fine phase bits per period
    lp_addr_w: int   # LP_ADDR_W: 2^LP_ADDR_W table entries per revolution, 2..16, <= clog2(REV)
    lp_w: int        # LP_W: value and slope width, 8..32
    lp_frac: int     # LP_FRAC: fraction bits of the correction (fine counts), 0..16
    lp_if: int       # LP_IF: interpolation fraction bits, 1..16

    def __post_init__(self):
        if not 2 <= self.lp_addr_w <= 16:
            raise ValueError(f"{NAME}: LP_ADDR_W = {self.lp_addr_w} out of range 2..16")
        if (1 << self.lp_addr_w) > self.rev:
            raise ValueError(f"{NAME}: 2^LP_ADDR_W = {1 << self.lp_addr_w} exceeds REV = {self.rev}")
        if not 8 <= self.lp_w <= 32:
            raise ValueError(f"{NAME}: LP_W = {self.lp_w} out of range 8..32")
        if not 0 <= self.lp_frac <= 16:
            raise ValueError(f"{NAME}: LP_FRAC = {self.lp_frac} out of range 0..16")
        if not 1 <= self.lp_if <= 16:
            raise ValueError(f"{NAME}: LP_IF = {self.lp_if} out of range 1..16")
        if (1 << (self.lp_w - 1 - self.lp_frac)) >= self.rev // 2:
            raise ValueError(f"{NAME}: LP_W - LP_FRAC = {self.lp_w - self.lp_frac} allows corrections of half a "
                             "revolution or more")

    @property
    def rev(self) -> int:
        """Fine counts per revolution."""
        return rev_and_pos_w(self.lines, self.fine_w)[0]

    @property
    def pos_w(self) -> int:
        return rev_and_pos_w(self.lines, self.fine_w)[1]

    @property
    def recip(self) -> int:
        return index_mapping(self.lines, self.fine_w, self.lp_addr_w, self.lp_if)[0]

    @property
    def shift(self) -> int:
        return index_mapping(self.lines, self.fine_w, self.lp_addr_w, self.lp_if)[1]

    def hdl_parameters(self) -> dict[str, int]:
        recip, shift = index_mapping(self.lines, self.fine_w, self.lp_addr_w, self.lp_if)
        return {"LINES": self.lines, "FINE_W": self.fine_w, "LP_ADDR_W": self.lp_addr_w, "LP_W": self.lp_w,
                "LP_FRAC": self.lp_frac, "LP_IF": self.lp_if, "LP_RECIP": recip, "LP_SHIFT": shift}


def index_mapping(lines: int, fine_w: int, lp_addr_w: int, lp_if: int) -> tuple[int, int]:
    """(LP_RECIP, LP_SHIFT) with (pos * LP_RECIP) >> LP_SHIFT == floor(pos * 2^LP_ADDR_W / REV), pos < REV.

    q = pos * den / num (num = REV, den = 2^LP_ADDR_W) is never closer than 1/num below the next
    integer, so with recip = ceil(2^s * den / num) the error pos * (recip * num - 2^s * den) / (num 2^s)
    stays below that gap when REV * (recip * num - 2^s * den) < 2^s (Granlund and Montgomery).
    Asking that 2^LP_IF times over keeps the interpolation fraction within one LSB too. The smallest
    such s >= LP_IF is taken; a power-of-two REV gives an exact power-of-two LP_RECIP.
    """
    num, den = lines << fine_w, 1 << lp_addr_w
    for s in range(lp_if, 63):
        recip = -((-(den << s)) // num)
        err = recip * num - (den << s)
        if err == 0 or (num * err) << lp_if < (1 << s):
            return recip, s
    raise ValueError(f"{NAME}: no index mapping for REV = {num}")


def make_table(err_fn, params: LongPeriodParams) -> np.ndarray:
    """Values s(LP_W), LP_FRAC fraction bits, of a correction (fine counts) at the entry points."""
    n = 1 << params.lp_addr_w
    pos = np.arange(n) * (params.rev / n)
    v = np.floor(np.asarray(err_fn(pos), dtype=float) * (1 << params.lp_frac) + 0.5)
    lo, hi = -(1 << (params.lp_w - 1)), (1 << (params.lp_w - 1)) - 1
    bad = np.flatnonzero((v < lo) | (v > hi))
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"long-period table entry {k}: {v[k] / (1 << params.lp_frac):g} fine counts does not fit "
                         f"s({params.lp_w}) with {params.lp_frac} fraction bits")
    return v.astype(np.int64)


def slopes(values: np.ndarray) -> np.ndarray:
    """slope[k] = value[k+1] - value[k], the revolution wrapping to value[0]."""
    return np.roll(values, -1, axis=-1) - values


def pack_words(values, params: LongPeriodParams) -> np.ndarray:
    v = np.asarray(values, dtype=np.int64)
    sl = slopes(v)
    lo, hi = -(1 << (params.lp_w - 1)), (1 << (params.lp_w - 1)) - 1
    bad = np.flatnonzero((sl < lo) | (sl > hi))
    if bad.size:
        raise ValueError(f"long-period table slope {int(bad[0])}: {int(sl[bad[0]])} does not fit s({params.lp_w})")
    mask = (1 << params.lp_w) - 1
    return ((sl & mask) << params.lp_w) | (v & mask)


def long_period(pos, values, zero: int, direction: int, params: LongPeriodParams, bank=None) -> np.ndarray:
    """Output position for each input position; `values` (entries,) or (banks, entries) with `bank`."""
    p = params
    recip, shift = index_mapping(p.lines, p.fine_w, p.lp_addr_w, p.lp_if)
    pos = np.asarray(pos, dtype=np.int64)
    v = np.asarray(values, dtype=np.int64)
    sl = slopes(v)
    t = pos * recip
    entry = t >> shift
    frac = (t >> (shift - p.lp_if)) & ((1 << p.lp_if) - 1)
    if v.ndim == 2:
        b = np.asarray(bank, dtype=np.int64)
        val, slope = v[b, entry], sl[b, entry]
    else:
        val, slope = v[entry], sl[entry]
    corr = val + ((slope * frac + (1 << (p.lp_if - 1))) >> p.lp_if)
    step = (corr + (1 << (p.lp_frac - 1))) >> p.lp_frac if p.lp_frac else corr
    pos_c = np.mod(pos - step, p.rev)
    zero = int(zero)
    return np.mod(zero - pos_c, p.rev) if direction else np.mod(pos_c + zero, p.rev)


def error_budget(params: LongPeriodParams, values) -> float:
    """Bound on |applied - ideal correction| in fine counts: linear interpolation between entries
    (1/8 of the largest second difference), quantisation of the values (1/2 LSB), rounding of the
    interpolated step (1/2 LSB), all in 2^-LP_FRAC units, plus the final rounding (1/2 count)."""
    v = np.asarray(values, dtype=float)
    second = np.abs(np.roll(v, -1) - 2 * v + np.roll(v, 1)).max() if len(v) > 2 else 0.0
    return float((second / 8 + 1.0) / (1 << params.lp_frac) + 0.5)
