"""Bit-exact model of ``fringe_long_period``: the seed 000 harmonic table, then direction and zero.

Mirrors ``rtl/verilog/fringe_long_period.v`` and ``rtl/vhdl/fringe_long_period.vhd`` (contract in
``docs/architecture.md``, section fringe_long_period). With ``REV = LINES * 2^FINE_W`` fine counts
per revolution, ``POS_W = FINE_W + clog2(LINES)`` and ``N = 2^LP_ADDR_W`` table entries per
revolution (entry k at position ``k * REV / N``)::

    t     = pos * LP_RECIP;  entry = t >> LP_SHIFT;  frac = (t >> (LP_SHIFT - LP_IF)) mod 2^LP_IF
    corr  = value[entry] + ((slope[entry] * frac + 2^(LP_IF-1)) >>> LP_IF)
    pos_c = (pos - ((corr + 2^(LP_FRAC-1)) >>> LP_FRAC)) mod REV      (LP_FRAC = 0: no rounding term)
    out   = DIR ? (ZERO - pos_c) mod REV : (pos_c + ZERO) mod REV

``value`` and ``slope`` are s(LP_W) in fine counts with LP_FRAC fraction bits, one word
``{slope, value}`` per entry of the two-bank ``fringe_table_ram``, ``slope[k] = value[k+1] -
value[k]`` with ``value[N] = value[0]`` (the revolution wraps).

`index_mapping` chooses ``LP_RECIP`` and ``LP_SHIFT``: the smallest shift for which the
Granlund-Montgomery bound proves ``entry == floor(pos * N / REV)`` for every pos in [0, REV)
(`check_index_mapping` tests the bound; a power-of-two REV gives a power-of-two LP_RECIP, a shift).

Ranges: ``2^(LP_W - LP_FRAC) <= REV``, so whatever the table holds, ``|step| <= REV`` and one add
or subtract of REV wraps each result into [0, REV) (with a table from `make_table` the step stays
below half that).

The RTL has ``LATENCY = 8`` enabled clocks, one carry chain per stage: (1) index product, (2) table read and
its output register, (3) slope x fraction (bare; split into two registered partial products when LP_W > 16) and
``value + 2^(LP_FRAC-1)``, (3b) the partial products summed, (4) the correction rounded to fine counts,
``({value + 2^(LP_FRAC-1), 2^(LP_IF-1)} + product) >>> (LP_IF + LP_FRAC)`` (one add), (5) ``pos - step`` and its
wrapped alternatives in parallel, chosen by sign bits, (6) zero and direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .limits import check_integers, check_range
from .period_count import PositionWidths, check_lines_fine_w, rev_and_pos_w

__all__ = [
    "LATENCY",
    "LongPeriodParams",
    "check_index_mapping",
    "error_budget",
    "error_terms",
    "index_mapping",
    "latency",
    "long_period",
    "long_period_words",
    "make_table",
    "pack_words",
    "slopes",
    "unpack_words",
]

#: Enabled clocks from ``in_valid`` to ``out_valid`` in the RTL.
LATENCY = 8
#: Largest LP_SHIFT the HDL accepts (its elaboration check computes with 256-bit constants).
LP_SHIFT_MAX = 127
NAME = "fringe_long_period"


def mapping_ok(rev: int, addr_w: int, recip: int, shift: int) -> bool:
    """The bound of `check_index_mapping` on Python integers (also what the HDL checks): whether
    ``(pos * recip) >> shift == floor(pos * 2^addr_w / rev)`` for every pos < rev. Shared with
    fringe_trim's sector index (`trim.check_sector_mapping`)."""
    v2 = (rev & -rev).bit_length() - 1               # 2-adic valuation of REV
    g_log = min(addr_w, v2)                          # gcd(2^addr_w, REV) = 2^g_log
    e = recip * rev - (1 << (addr_w + shift))        # g * (recip * b - a * 2^shift)
    return recip >= 1 and e >= 0 and (rev - 1) * e < (1 << (g_log + shift))


def smallest_mapping(rev: int, addr_w: int, min_shift: int, max_shift: int) -> tuple[int, int] | None:
    """``(recip, shift)`` with the smallest shift in [min_shift, max_shift] whose reciprocal
    ``ceil(2^(addr_w + shift) / rev)`` passes `mapping_ok`, or None."""
    for shift in range(min_shift, max_shift + 1):
        recip = -(-(1 << (addr_w + shift)) // rev)
        if mapping_ok(rev, addr_w, recip, shift):
            return recip, shift
    return None


def check_mapping(unit: str, prefix: str, addr_name: str, helper: str, rev: int, addr_w: int, recip: int,
                  shift: int, shift_range: tuple[int, int], shift_range_text: str) -> None:
    """The checks of an index mapping ``(PREFIX_RECIP, PREFIX_SHIFT)`` onto ``2^addr_w`` entries per REV
    (fringe_long_period's LP_*, fringe_trim's SECT_*; the HDL's check_mapping, same messages): the shift
    in ``shift_range`` (named ``shift_range_text`` in the message), then the `mapping_ok` bound."""
    if not shift_range[0] <= shift <= shift_range[1]:
        raise ValueError(f"{unit}: {prefix}_SHIFT = {shift} out of range {shift_range_text}")
    if not mapping_ok(rev, addr_w, recip, shift):
        raise ValueError(f"{unit}: {prefix}_RECIP = {recip}, {prefix}_SHIFT = {shift} do not map every position to "
                         f"floor(pos * 2^{addr_name} / REV); take them from {helper}()")


def required_mapping(unit: str, kind: str, prefix: str, rev: int, addr_w: int, min_shift: int,
                     max_shift: int) -> tuple[int, int]:
    """`smallest_mapping`, or ValueError naming the ``kind`` of mapping that does not exist."""
    found = smallest_mapping(rev, addr_w, min_shift, max_shift)
    if found:
        return found
    raise ValueError(f"{unit}: no {kind} mapping with {prefix}_SHIFT <= {max_shift} for REV = {rev}")


def check_index_mapping(lines: int, fine_w: int, lp_addr_w: int, lp_if: int, recip: int, shift: int) -> None:
    """Raise ValueError unless ``(pos * recip) >> shift == floor(pos * 2^LP_ADDR_W / REV)`` is proven.

    With ``g = gcd(2^LP_ADDR_W, REV)``, ``a = 2^LP_ADDR_W / g`` and ``b = REV / g`` coprime, the exact
    quotient ``x = pos * a / b`` has a fractional part of at most ``1 - 1/b``. ``recip >= a 2^shift / b``
    makes ``t / 2^shift = x + pos * e / (b 2^shift)`` with ``e = recip * b - a 2^shift >= 0``, and
    ``(REV - 1) * e < 2^shift`` keeps that excess below ``1/b`` for every pos < REV: the floor
    cannot reach the next integer (Granlund and Montgomery, 1994). The same bound is checked by
    the HDL at elaboration (same message).
    """
    check_mapping(NAME, "LP", "LP_ADDR_W", "index_mapping", rev_and_pos_w(lines, fine_w)[0], lp_addr_w, recip, shift,
                  (lp_if, LP_SHIFT_MAX), f"LP_IF = {lp_if} .. {LP_SHIFT_MAX}")


@lru_cache(maxsize=256)
def index_mapping(lines: int, fine_w: int, lp_addr_w: int, lp_if: int) -> tuple[int, int]:
    """``(LP_RECIP, LP_SHIFT)``: the smallest shift >= LP_IF whose reciprocal passes the bound.

    ``LP_RECIP = ceil(2^(LP_ADDR_W + LP_SHIFT) / REV)``; see `check_index_mapping` for the proof.
    The bound always holds once ``2^LP_SHIFT >= REV * b``, so the search ends; in practice LP_RECIP
    is about REV or less (below 2^31, the VHDL limit, for REV up to about 2^30). A power-of-two REV
    gives ``e = 0`` at the first shift where the reciprocal is an integer: a power of two.
    """
    return required_mapping(NAME, "index", "LP", rev_and_pos_w(lines, fine_w)[0], lp_addr_w, lp_if, LP_SHIFT_MAX)


@dataclass(frozen=True)
class LongPeriodParams(PositionWidths):
    """Parameters of ``fringe_long_period`` (same names, limits and messages as the HDL).

    ``lp_recip`` / ``lp_shift`` default to `index_mapping`; given, they are checked.
    """

    lines: int       # LINES: signal periods per revolution, 1..2^20; FINE_W + clog2(LINES) <= 48
    fine_w: int      # FINE_W: fine phase bits per period, 8..30
    lp_addr_w: int   # LP_ADDR_W: 2^LP_ADDR_W table entries per revolution, 2..16, 2^LP_ADDR_W <= REV
    lp_w: int        # LP_W: width of value and slope, 8..32; 2^(LP_W - LP_FRAC) <= REV
    lp_frac: int     # LP_FRAC: fraction bits of the correction (fine counts), 0..16
    lp_if: int       # LP_IF: interpolation fraction bits, 1..16
    lp_recip: int | None = None   # LP_RECIP: index multiplier (default: index_mapping)
    lp_shift: int | None = None   # LP_SHIFT: index shift, LP_IF..127 (default: index_mapping)

    def __post_init__(self) -> None:
        check_lines_fine_w(self.lines, self.fine_w, NAME)
        check_integers(NAME, self, ("lp_addr_w", "lp_w", "lp_frac", "lp_if"))
        check_range(NAME, "LP_ADDR_W", self.lp_addr_w, 2, 16)
        if (1 << self.lp_addr_w) > self.rev:
            raise ValueError(f"{NAME}: 2^LP_ADDR_W = {1 << self.lp_addr_w} entries exceed REV = LINES * 2^FINE_W")
        check_range(NAME, "LP_W", self.lp_w, 8, 32)
        check_range(NAME, "LP_FRAC", self.lp_frac, 0, 16)
        check_range(NAME, "LP_IF", self.lp_if, 1, 16)
        if self.lp_w - self.lp_frac >= 0 and (1 << (self.lp_w - self.lp_frac)) > self.rev:
            raise ValueError(f"{NAME}: LP_W - LP_FRAC = {self.lp_w - self.lp_frac}: corrections up to "
                             f"2^{self.lp_w - self.lp_frac} fine counts exceed REV = LINES * 2^FINE_W")
        if (self.lp_recip is None) != (self.lp_shift is None):
            raise ValueError(f"{NAME}: give both LP_RECIP and LP_SHIFT, or neither")
        if self.lp_recip is not None:
            check_index_mapping(self.lines, self.fine_w, self.lp_addr_w, self.lp_if, self.lp_recip, self.lp_shift)

    # ---- derived constants (names as in the HDL)
    @property
    def entries(self) -> int:
        """Table entries per revolution (per bank), 2^LP_ADDR_W."""
        return 1 << self.lp_addr_w

    @property
    def word_w(self) -> int:
        """Width of a table word {slope, value}: 2 * LP_W."""
        return 2 * self.lp_w

    @property
    def recip(self) -> int:
        """LP_RECIP."""
        if self.lp_recip is not None:
            return self.lp_recip
        return index_mapping(self.lines, self.fine_w, self.lp_addr_w, self.lp_if)[0]

    @property
    def shift(self) -> int:
        """LP_SHIFT."""
        if self.lp_shift is not None:
            return self.lp_shift
        return index_mapping(self.lines, self.fine_w, self.lp_addr_w, self.lp_if)[1]

    @property
    def latency(self) -> int:
        """LATENCY: enabled clocks from in_valid to out_valid, 8."""
        return LATENCY

    def hdl_parameters(self) -> dict[str, int]:
        """The HDL parameter/generic map (LP_RECIP as an integer: Verilog takes it as 64'd..., VHDL < 2^31)."""
        return {"LINES": self.lines, "FINE_W": self.fine_w, "LP_ADDR_W": self.lp_addr_w, "LP_W": self.lp_w,
                "LP_FRAC": self.lp_frac, "LP_IF": self.lp_if, "LP_RECIP": self.recip, "LP_SHIFT": self.shift}


def latency(params: LongPeriodParams) -> int:
    """Clock enables from ``in_valid`` to ``out_valid`` in the RTL: 8."""
    return LATENCY


# ---------------------------------------------------------------------------- tables


def _limits(w: int) -> tuple[int, int]:
    return -(1 << (w - 1)), (1 << (w - 1)) - 1


def slopes(values) -> np.ndarray:
    """``slope[k] = value[k+1] - value[k]``, the revolution wrapping to value[0] (last axis)."""
    v = np.asarray(values, dtype=np.int64)
    return np.roll(v, -1, axis=-1) - v


def make_table(err_fn, params: LongPeriodParams) -> np.ndarray:
    """Table values: ``round(err_fn(pos) * 2^LP_FRAC)`` at the entry points ``pos = k * REV / 2^LP_ADDR_W``.

    ``err_fn`` maps positions in fine counts (a float array, or one float if it is a scalar
    function) to the correction in fine counts (the encoder's error, subtracted from the
    position). Every value and every slope must fit s(LP_W).

    Raises:
        ValueError: a value or a slope outside s(LP_W), or a non-finite value.
    """
    p = params
    pos = np.arange(p.entries) * (p.rev / p.entries)
    try:
        raw = np.asarray(err_fn(pos), dtype=np.float64)
    except TypeError:            # a scalar function
        raw = None
    if raw is None or raw.shape != pos.shape:
        raw = np.array([float(err_fn(float(x))) for x in pos])
    if not np.all(np.isfinite(raw)):
        raise ValueError(f"{NAME}: the correction is not finite at entry {int(np.flatnonzero(~np.isfinite(raw))[0])}")
    v = np.floor(raw * (1 << p.lp_frac) + 0.5)
    lo, hi = _limits(p.lp_w)
    bad = np.flatnonzero((v < lo) | (v > hi))
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"{NAME}: table entry {k}: {raw[k]:g} fine counts does not fit s({p.lp_w}) with "
                         f"{p.lp_frac} fraction bits")
    values = v.astype(np.int64)
    _check_slopes(values, p)
    return values


def _check_slopes(values: np.ndarray, p: LongPeriodParams) -> np.ndarray:
    sl = slopes(values)
    lo, hi = _limits(p.lp_w)
    bad = np.flatnonzero((sl.ravel() < lo) | (sl.ravel() > hi))
    if bad.size:
        k = int(bad[0]) % p.entries
        raise ValueError(f"{NAME}: table slope {k}: {int(sl.ravel()[bad[0]])} does not fit s({p.lp_w})")
    return sl


def _check_values(values, p: LongPeriodParams) -> np.ndarray:
    v = np.asarray(values)
    if v.size and not np.issubdtype(v.dtype, np.integer):
        raise ValueError(f"{NAME}: table values must be integers, got dtype {v.dtype}")
    v = v.astype(np.int64, copy=False)
    if v.ndim not in (1, 2) or v.shape[-1] != p.entries:
        raise ValueError(f"{NAME}: table values must have shape ({p.entries},) or (banks, {p.entries}), "
                         f"got {v.shape}")
    lo, hi = _limits(p.lp_w)
    if v.size and (v.min() < lo or v.max() > hi):
        raise ValueError(f"{NAME}: a table value is outside s({p.lp_w})")
    return v


def pack_words(values, params: LongPeriodParams) -> np.ndarray:
    """RAM words ``{slope, value}`` of one bank's values: 2*LP_W-bit unsigned integers, value in the
    low half, both fields two's complement. int64 when 2*LP_W <= 62, else uint64 (LP_W = 32)."""
    p = params
    v = _check_values(values, p)
    sl = _check_slopes(v, p)
    mask = (1 << p.lp_w) - 1
    words = ((sl & mask).astype(np.uint64) << np.uint64(p.lp_w)) | (v & mask).astype(np.uint64)
    return words.astype(np.int64) if 2 * p.lp_w <= 62 else words


def unpack_words(words, params: LongPeriodParams) -> tuple[np.ndarray, np.ndarray]:
    """``(slope, value)`` as signed int64 from RAM words (any shape; any word is legal)."""
    w = np.asarray(words, dtype=np.uint64)
    lw = params.lp_w
    mask = np.uint64((1 << lw) - 1)
    half = 1 << (lw - 1)
    value = (w & mask).astype(np.int64)
    slope = ((w >> np.uint64(lw)) & mask).astype(np.int64)
    return ((slope + half) & int(mask)) - half, ((value + half) & int(mask)) - half


# ---------------------------------------------------------------------------- the datapath


def _index(pos: np.ndarray, p: LongPeriodParams) -> tuple[np.ndarray, np.ndarray]:
    """(entry, frac) of ``t = pos * LP_RECIP`` exactly (Python integers when int64 could overflow)."""
    recip, shift = p.recip, p.shift
    if (p.rev - 1) * recip < 1 << 63:
        t = pos * recip
        return t >> shift, (t >> (shift - p.lp_if)) & ((1 << p.lp_if) - 1)
    # wide products (Verilog-only configurations): exact, slower
    q = (pos.astype(object) * recip) >> (shift - p.lp_if)
    q = q.astype(np.int64)
    return q >> p.lp_if, q & ((1 << p.lp_if) - 1)


def _apply(pos, val_of, zero, direction, p: LongPeriodParams) -> np.ndarray:
    pos_a = np.asarray(pos)
    if pos_a.size and not np.issubdtype(pos_a.dtype, np.integer):
        raise ValueError(f"{NAME}: pos must be integers, got dtype {pos_a.dtype}")
    pos_a = pos_a.astype(np.int64, copy=False)
    if pos_a.size and (pos_a.min() < 0 or pos_a.max() >= p.rev):
        raise ValueError(f"{NAME}: pos outside [0, REV = {p.rev})")
    z = np.asarray(zero).astype(np.int64)
    if z.size and (z.min() < 0 or z.max() >= p.rev):
        raise ValueError(f"{NAME}: zero outside [0, REV = {p.rev})")
    d = np.asarray(direction).astype(np.int64)
    if d.size and (d.min() < 0 or d.max() > 1):
        raise ValueError(f"{NAME}: direction must be 0 or 1")
    entry, frac = _index(pos_a, p)
    slope, value = val_of(entry)
    corr = slope * frac
    corr += 1 << (p.lp_if - 1)
    corr >>= p.lp_if
    corr += value
    if p.lp_frac:
        corr += 1 << (p.lp_frac - 1)
        corr >>= p.lp_frac
    pos_c = pos_a - corr
    pos_c += np.where(pos_c < 0, p.rev, np.where(pos_c >= p.rev, -p.rev, 0))   # |step| <= REV
    out = np.where(d == 1, z - pos_c, pos_c + z)
    out += np.where(out < 0, p.rev, np.where(out >= p.rev, -p.rev, 0))
    return out


def _banked(table: np.ndarray, entry: np.ndarray, bank, what: str) -> np.ndarray:
    if table.ndim == 1:
        return table[entry]
    if bank is None:
        raise ValueError(f"{NAME}: {what} of {table.shape[0]} banks need a bank per sample")
    b = np.asarray(bank).astype(np.int64)
    if b.size and (b.min() < 0 or b.max() >= table.shape[0]):
        raise ValueError(f"{NAME}: bank outside 0..{table.shape[0] - 1}")
    return table[b, entry]


def long_period(pos, values, zero, direction, params: LongPeriodParams, bank=None) -> np.ndarray:
    """Output positions, bit-exact with the RTL, from table values (slopes derived, wrapping).

    Args:
        pos: u(POS_W) positions in [0, REV) (any shape).
        values: the table, shape (2^LP_ADDR_W,), or (banks, 2^LP_ADDR_W) with ``bank``.
        zero: u(POS_W) output zero in [0, REV), scalar or per sample.
        direction: 0 or 1 (1: the output runs the other way), scalar or per sample.
        params: the block parameters.
        bank: the table bank of each sample (when ``values`` has banks).

    Returns:
        int64 positions in [0, REV), the shape of ``pos`` (broadcast with zero/direction/bank).
    """
    p = params
    v = _check_values(values, p)
    sl = _check_slopes(v, p)
    return _apply(pos, lambda e: (_banked(sl, e, bank, "values"), _banked(v, e, bank, "values")),
                  zero, direction, p)


def long_period_words(pos, words, zero, direction, params: LongPeriodParams, bank=None) -> np.ndarray:
    """As `long_period`, from raw RAM words ``{slope, value}`` (any contents, as written to the RAM)."""
    p = params
    w = np.asarray(words)
    if w.ndim not in (1, 2) or w.shape[-1] != p.entries:
        raise ValueError(f"{NAME}: words must have shape ({p.entries},) or (banks, {p.entries}), got {w.shape}")
    sl, v = unpack_words(w, p)
    return _apply(pos, lambda e: (_banked(sl, e, bank, "words"), _banked(v, e, bank, "words")),
                  zero, direction, p)


# ---------------------------------------------------------------------------- error budget


def error_terms(params: LongPeriodParams, values) -> dict[str, float]:
    """The terms of `error_budget`, in fine counts (values: one bank, from `make_table`).

    - ``interpolation``: linear interpolation between entries h apart misses a smooth c(x) by at
      most h^2 max|c''| / 8; the table's largest second difference estimates h^2 max|c''| (exact
      for a parabola, within a few percent for harmonics well below N/8), taken with a margin of
      5/4;
    - ``quantisation``: each value is c(k h) rounded to LP_FRAC bits, 1/2 LSB (interpolation is a
      convex combination of two values);
    - ``interp_rounding``: the product slope * frac rounded to LP_FRAC bits, 1/2 LSB;
    - ``fraction``: frac is the position within the entry truncated to LP_IF bits, and the index
      product exceeds the exact quotient by less than 1/b (``b = REV / gcd(2^LP_ADDR_W, REV)``):
      max|slope| * (2^-LP_IF + 1/b) LSB;
    - ``output_rounding``: the correction rounded to whole fine counts, 1/2 count (0 when LP_FRAC = 0:
      it is then already whole, the terms above are whole LSBs).
    """
    p = params
    v = np.asarray(values, dtype=np.float64)
    if v.ndim != 1 or v.size != p.entries:
        raise ValueError(f"{NAME}: error_terms takes one bank of {p.entries} values, got shape {v.shape}")
    lsb = 2.0 ** -p.lp_frac
    second = float(np.abs(np.roll(v, -1) - 2 * v + np.roll(v, 1)).max())
    max_slope = float(np.abs(slopes(v.astype(np.int64))).max())
    b = p.rev // math.gcd(p.entries, p.rev)
    return {
        "interpolation": 1.25 * second / 8 * lsb,
        "quantisation": 0.5 * lsb,
        "interp_rounding": 0.5 * lsb,
        "fraction": max_slope * (2.0 ** -p.lp_if + 1.0 / b) * lsb,
        "output_rounding": 0.5 if p.lp_frac else 0.0,
    }


def error_budget(params: LongPeriodParams, values) -> float:
    """Bound on |applied - ideal correction| in fine counts for a table made by `make_table` from a
    smooth correction (sum of `error_terms`): the output position differs from
    ``(pos - c(pos))`` (then zero and direction) by at most this, modulo REV."""
    return float(sum(error_terms(params, values).values()))
