"""Bit-exact model of ``fringe_wave_lut``: the waveform inverse of one channel (seed 001).

Mirrors ``rtl/verilog/fringe_wave_lut.v`` and ``rtl/vhdl/fringe_wave_lut.vhd`` (formats in
``docs/architecture.md``):

- index: ``u = adc + 2^(ADC_W-1)``, ``FB = ADC_W - WAVE_ADDR_W``, ``addr = u >> FB``,
  ``frac = u & (2^FB - 1)``;
- table: per branch ``2^WAVE_ADDR_W + 1`` values s(WAVE_W) with ``WAVE_FRAC = WAVE_W - 2``
  fractional bits (the last one lies one step beyond the largest code); the RAM word at
  ``{branch, addr}`` is ``{slope, value}`` with ``slope[k] = value[k+1] - value[k]``;
- ``x = value + ((slope * frac + 2^(FB-1)) >> FB)`` (arithmetic shift: floor), s(WAVE_W);
- ``clip``: ``adc`` is the most negative or the most positive code.

Everything is vectorised numpy int64 (the widest product, s(32) * u(22), fits).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .limits import check_integers, check_range

__all__ = [
    "LATENCY",
    "WaveLutParams",
    "check_table",
    "error_budget",
    "make_table",
    "pack_words",
    "unpack_words",
    "wave_lut",
]

#: Clock enables from ``in_valid`` to ``out_valid`` in the RTL (RAM read, its output register, the bare
#: multiply, ``({value, 2^(FB-1)} + product) >>> FB`` in one add).
LATENCY = 4


@dataclass(frozen=True)
class WaveLutParams:
    """Parameters of ``fringe_wave_lut`` (same names and limits as the HDL)."""

    adc_w: int        # ADC_W: ADC code width, 4..24
    wave_addr_w: int  # WAVE_ADDR_W: table address bits per branch, 2..ADC_W-1
    wave_w: int       # WAVE_W: table value and output width, 8..32

    def __post_init__(self) -> None:
        block = "fringe_wave_lut"
        check_integers(block, self, ("adc_w", "wave_addr_w", "wave_w"))
        check_range(block, "ADC_W", self.adc_w, 4, 24)
        check_range(block, "WAVE_ADDR_W", self.wave_addr_w, 2, self.adc_w - 1, f"2..ADC_W-1 = {self.adc_w - 1}")
        check_range(block, "WAVE_W", self.wave_w, 8, 32)

    # ---- derived constants (names as in the docs)
    @property
    def fb(self) -> int:
        """FB: fraction bits of the table index, ADC_W - WAVE_ADDR_W (>= 1)."""
        return self.adc_w - self.wave_addr_w

    @property
    def wave_frac(self) -> int:
        """WAVE_FRAC: fractional bits of table values and of x (+-1.0 is +-2^WAVE_FRAC)."""
        return self.wave_w - 2

    @property
    def entries(self) -> int:
        """Table segments per branch, 2^WAVE_ADDR_W (the table has one more point)."""
        return 1 << self.wave_addr_w

    @property
    def word_w(self) -> int:
        """Width of a packed {slope, value} RAM word, 2*WAVE_W."""
        return 2 * self.wave_w

    @property
    def bank_words(self) -> int:
        """RAM words per bank (both branches), 2 * 2^WAVE_ADDR_W."""
        return 2 * self.entries

    @property
    def value_min(self) -> int:
        return -(1 << (self.wave_w - 1))

    @property
    def value_max(self) -> int:
        return (1 << (self.wave_w - 1)) - 1

    def hdl_parameters(self) -> dict[str, int]:
        """The HDL parameters/generics of this configuration."""
        return {"ADC_W": self.adc_w, "WAVE_ADDR_W": self.wave_addr_w, "WAVE_W": self.wave_w}

    def entry_codes(self) -> np.ndarray:
        """ADC codes of the table points: k*2^FB - 2^(ADC_W-1), k = 0..2^WAVE_ADDR_W."""
        return (np.arange(self.entries + 1, dtype=np.int64) << self.fb) - (1 << (self.adc_w - 1))


def _as_table(table, params: WaveLutParams, what: str = "table") -> np.ndarray:
    t = np.asarray(table)
    if t.dtype.kind not in "iu":
        if t.dtype.kind == "f" and np.all(np.isfinite(t)) and np.all(t == np.round(t)):
            t = t.astype(np.int64)
        else:
            raise ValueError(f"{what}: values must be integers (s(WAVE_W) codes), got dtype {t.dtype}")
    t = t.astype(np.int64)
    shape = (2, params.entries + 1)
    if t.shape[-2:] != shape or t.ndim not in (2, 3):
        raise ValueError(f"{what}: shape must be (2, 2^WAVE_ADDR_W + 1) = {shape} "
                         f"or (banks, 2, {shape[1]}), got {t.shape}")
    return t


def check_table(table, params: WaveLutParams, what: str = "table") -> np.ndarray:
    """Range-check a table of shape (2, 2^WAVE_ADDR_W + 1); return it as int64.

    Every value must be an s(WAVE_W) code and every slope ``value[k+1] - value[k]`` must fit
    s(WAVE_W) too; a ValueError names the first bad entry.
    """
    t = _as_table(table, params, what)
    lo, hi = params.value_min, params.value_max
    scale = float(1 << params.wave_frac)
    for arr, name in ((t, "value"), (np.diff(t, axis=-1), "slope")):
        bad = np.argwhere((arr < lo) | (arr > hi))
        if bad.size:
            idx = tuple(int(i) for i in bad[0])
            v = int(arr[idx])
            where = ", ".join(f"{n} {i}" for n, i in zip(("bank", "branch", "entry")[-len(idx):], idx,
                                                          strict=True))
            raise ValueError(f"{what}[{where}]: {name} {v} ({v / scale:+.6f}) out of range "
                             f"s({params.wave_w}) = {lo}..{hi} ([-2, 2) with {params.wave_frac} "
                             "fractional bits)")
    return t


def pack_words(table, params: WaveLutParams) -> np.ndarray:
    """The RAM image of one bank: 2*2^WAVE_ADDR_W words ``{slope, value}``, branch 0 first.

    Words are unsigned integers of 2*WAVE_W bits (``slope`` in the upper half, both two's
    complement). Range errors (value or slope outside s(WAVE_W)) raise ValueError naming the
    entry.
    """
    t = check_table(table, params)
    if t.ndim != 2:
        raise ValueError(f"table: pack one bank at a time, shape (2, {params.entries + 1}), got {t.shape}")
    mask = (1 << params.wave_w) - 1
    value = t[:, :-1] & mask
    slope = np.diff(t, axis=1) & mask
    return ((slope << params.wave_w) | value).reshape(-1).astype(np.int64)


def unpack_words(words, params: WaveLutParams) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of ``pack_words`` for any array of words: (slope, value), signed int64."""
    w = np.asarray(words, dtype=np.int64)
    mask = (1 << params.wave_w) - 1
    sign = 1 << (params.wave_w - 1)
    value = ((w & mask) ^ sign) - sign
    slope = (((w >> params.wave_w) & mask) ^ sign) - sign
    return slope, value


def wave_lut(adc, branch, table, params: WaveLutParams, bank=None) -> tuple[np.ndarray, np.ndarray]:
    """Bit-exact output of ``fringe_wave_lut``: ``(x, clip)``.

    Args:
        adc: ADC codes, s(ADC_W) integers (any shape).
        branch: 0/1 per sample (broadcast against ``adc``).
        table: int array (2, 2^WAVE_ADDR_W + 1) of values (branch 0, branch 1); or
            (banks, 2, 2^WAVE_ADDR_W + 1) together with ``bank``.
        params: the configuration.
        bank: bank per sample (broadcast), required with a 3-D table.

    Returns:
        ``x`` int64 s(WAVE_W) codes (WAVE_FRAC fractional bits) and ``clip`` bool.
    """
    t = check_table(table, params)
    adc, branch = np.broadcast_arrays(np.asarray(adc), np.asarray(branch))
    if adc.dtype.kind not in "iu":
        raise ValueError(f"adc: integer codes expected, got dtype {adc.dtype}")
    if branch.dtype.kind not in "iub" or (branch.size and (branch.min() < 0 or branch.max() > 1)):
        raise ValueError("branch: must be 0 or 1")
    half = 1 << (params.adc_w - 1)
    u = adc.astype(np.int64) + half                    # offset binary, u(ADC_W) when in range
    if u.size and np.any(u >> params.adc_w):
        raise ValueError(f"adc: codes must lie in {-half}..{half - 1} (s({params.adc_w}))")
    clip = (u == 0) | (u == 2 * half - 1)
    # flat RAM-like index {bank, branch, addr}
    idx = u >> params.fb
    idx |= branch.astype(np.int64) << params.wave_addr_w
    value_tab = t[..., :-1].reshape(-1)
    slope_tab = np.diff(t, axis=-1).reshape(-1)
    if t.ndim == 3:
        if bank is None:
            raise ValueError("bank: required with a table of shape (banks, 2, entries + 1)")
        bk = np.asarray(bank, dtype=np.int64)
        if bk.size and (bk.min() < 0 or bk.max() >= t.shape[0]):
            raise ValueError(f"bank: must lie in 0..{t.shape[0] - 1}")
        idx = idx + (bk << (params.wave_addr_w + 1))
    elif bank is not None:
        raise ValueError("bank: given, but the table has one bank (shape (2, entries + 1))")
    u &= (1 << params.fb) - 1                          # frac
    slope = np.take(slope_tab, idx)
    slope *= u
    slope += 1 << (params.fb - 1)
    slope >>= params.fb
    x = np.take(value_tab, idx)
    x += slope
    return x, clip


def make_table(inverse_fn: Callable[[np.ndarray, int], np.ndarray], params: WaveLutParams) -> np.ndarray:
    """Sample a float inverse function into a table of shape (2, 2^WAVE_ADDR_W + 1).

    ``inverse_fn(adc_code_float, branch)`` is called with the float ADC codes of the table points
    (``k*2^FB - 2^(ADC_W-1)``, k = 0..2^WAVE_ADDR_W; the last lies one code beyond the largest
    ADC code) and ``branch`` 0 or 1, and returns values in [-2, 2); non-vectorised functions
    (returning a scalar) are evaluated point by point. Values are rounded to WAVE_FRAC
    fractional bits (half up) and range-checked with ``check_table``.
    """
    codes = params.entry_codes().astype(float)
    scale = float(1 << params.wave_frac)
    rows = []
    for b in (0, 1):
        try:
            v = np.asarray(inverse_fn(codes, b), dtype=float)
        except (TypeError, ValueError):
            v = None  # not vectorised: evaluate point by point below
        if v is None or v.shape != codes.shape:
            v = np.array([float(inverse_fn(float(c), b)) for c in codes])
        if not np.all(np.isfinite(v)):
            k = int(np.argmin(np.isfinite(v)))
            raise ValueError(f"table[branch {b}, entry {k}]: inverse_fn({codes[k]:g}, {b}) = {v[k]} "
                             "is not finite")
        rows.append(np.floor(v * scale + 0.5))
    t = np.array(rows)
    lo, hi = params.value_min, params.value_max
    bad = np.argwhere((t < lo) | (t > hi))
    if bad.size:
        b, k = (int(i) for i in bad[0])
        raise ValueError(f"table[branch {b}, entry {k}]: inverse_fn({codes[k]:g}, {b}) = "
                         f"{t[b, k] / scale:+.6f} out of range [-2, 2)")
    return check_table(t.astype(np.int64), params)


def error_budget(params: WaveLutParams, table) -> np.ndarray:
    """Bound on |x - f(adc)| in output LSBs (2^-WAVE_FRAC) per segment, shape (2, 2^WAVE_ADDR_W).

    ``table`` was made by ``make_table`` from a smooth ``f``. For segment k of a branch:

    - rounding of the table values: 1/2 LSB (linear interpolation of values each within 1/2);
    - rounding of the interpolated step: 1/2 LSB;
    - linear interpolation of f: ``h^2/8 * max|f''|``, estimated by the largest second
      difference ``|v[j+1] - 2 v[j] + v[j-1]|`` at the points j = k-1..k+2 around the segment
      (linearly extrapolated beyond the ends of the table, where f'' tends to grow), plus
      2 LSB for the rounding of the three values in it, divided by 8, times a safety factor
      of 1.5 for f'' that grows faster than linearly (coarse tables of steep inverses).

    Not a proof for an arbitrary f (the second difference samples f''), but sharp for smooth
    waveform inverses; the tests fail only beyond it.
    """
    t = check_table(table, params)
    if t.ndim != 2:
        raise ValueError("table: one bank, shape (2, entries + 1)")
    n = params.entries
    d2 = (t[:, 2:] - 2 * t[:, 1:-1] + t[:, :-2]).astype(float)  # at points 1..n-1
    lo1, lo2 = d2[:, :1], d2[:, 1:2]
    hi1, hi2 = d2[:, -1:], d2[:, -2:-1]
    # points -1..n+1: extrapolate the second difference linearly at both ends
    ext = np.concatenate([3 * lo1 - 2 * lo2, 2 * lo1 - lo2, d2, 2 * hi1 - hi2, 3 * hi1 - 2 * hi2], axis=1)
    ext = np.abs(ext)
    # segment k spans points k, k+1: look at points k-1..k+2 (ext index = point + 1)
    win = np.maximum.reduce([ext[:, j:j + n] for j in range(4)])
    return 0.5 + 0.5 + 1.5 * (win + 2.0) / 8.0
