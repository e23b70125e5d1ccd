"""Bit-exact model of ``fringe_trim``: the closed-loop angle trim (error map, speed and magnitude gains).

Mirrors ``rtl/verilog/fringe_trim.v`` and ``rtl/vhdl/fringe_trim.vhd`` (contract in ``docs/blocks/fringe_trim.md``).
With ``REV = LINES * 2^FINE_W`` fine counts per revolution, ``POS_W = FINE_W + clog2(LINES)`` (<= 31),
``N = 2^SPEED_LOG2`` samples of speed window, ``FB = FINE_W - MAP_PHI_W``::

    phase  = pos mod 2^FINE_W;  bin = phase >> FB;  frac = phase mod 2^FB
    sector = (pos * SECT_RECIP) >> SECT_SHIFT        (= floor(pos * 2^MAP_PSI_W / REV); 0 when MAP_PSI_W = 0)
    speed  = wrap(pos[n] - pos[n - N])   for n >= N   (n: samples accepted since the reset before this one)
           = sat(wrap(pos[n] - pos[n - 2^k]) * 2^(SPEED_LOG2 - k))   for 1 <= n < N, k = floor(log2(n)):
             the longest power-of-two window there is, scaled to N samples; sat: clipped to [-REV/2, REV/2 - 1]
           = START_SPEED   for n = 0 (no window yet: the generator's mean speed of the calibration recording);
             dir = speed < 0
             wrap: d in (-REV, REV); 2d >= REV: d - REV; 2d < -REV: d + REV  -> speed in [-REV/2, REV/2)
    avg    = mag   for n = 0, and K = MAG_SMOOTH_LOG2 = 0 (no average);  otherwise, with acc u(AMP_W + K):
             acc = mag << K for n = 0,  acc = acc + mag - (acc >> K) after;  avg = acc >> K
             (the magnitude's running average over about 2^K samples: the amplitude without the per-sample
             noise and the fine-phase ripple a waveform that changes with the amplitude puts on the radius)
    m      = value + ((slope * frac + 2^(FB-1)) >>> FB)   map word at {bank, dir, sector, bin}
    gs, ga = the same interpolation of the speed table and of the amp table at {bank, bin}
    total  = m + ((speed * gs + avg * ga + 2^(G_SHIFT-1)) >>> G_SHIFT)
    corr   = (total + 2^(TRIM_FRAC-1)) >>> TRIM_FRAC   (TRIM_FRAC = 0: corr = total)
    corr   clipped to [-2^(FINE_W-1), 2^(FINE_W-1) - 1]; sat = it was clipped
    pos_out = (pos - corr) mod REV

Table words are ``{slope, value}``, both s(TRIM_W), value in the low half. ``slope[k] = value[k+1] -
value[k]`` along the bin axis, periodic in the phase: the last bin of a row takes ``value[0]`` of the
same row (the same (dir, sector) for the map). Any word is legal in the RTL (the widths never
overflow): `trim_words` computes with raw words, `trim` with values (slopes derived).

Everything is vectorised numpy int64: the widest product is s(POS_W) x s(TRIM_W + 1) or
u(AMP_W) x s(TRIM_W + 1), below 2^57, and their sum with the rounding constant below 2^59.

The RTL has ``LATENCY = 13`` enabled clocks (stage list in ``docs/blocks/fringe_trim.md`` and the HDL headers).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .limits import check_int, check_integers, check_range
from .long_period import check_mapping, required_mapping
from .period_count import PositionWidths, check_lines_fine_w
from .table_ram import interpolate, periodic_slopes, split_words

__all__ = [
    "LATENCY",
    "NAME",
    "TrimParams",
    "check_sector_mapping",
    "error_budget",
    "error_terms",
    "make_gain_table",
    "make_map_table",
    "pack_words",
    "sector_mapping",
    "slopes",
    "speeds",
    "trim",
    "trim_detail",
    "trim_words",
    "unpack_words",
    "magnitudes",
]

#: Enabled clocks from ``in_valid`` to ``out_valid`` in the RTL.
LATENCY = 13
#: Largest SECT_SHIFT the HDL accepts (its elaboration check computes with 256-bit constants).
SECT_SHIFT_MAX = 127
NAME = "fringe_trim"
POS_W_MAX = 31
#: Longest magnitude average, 2^12 samples (the accumulator is AMP_W + MAG_SMOOTH_LOG2 <= 44 bits wide).
MAG_SMOOTH_LOG2_MAX = 12


# ---------------------------------------------------------------------------- sector mapping


def check_sector_mapping(lines: int, fine_w: int, map_psi_w: int, recip: int, shift: int) -> None:
    """Raise ValueError unless ``(pos * recip) >> shift == floor(pos * 2^MAP_PSI_W / REV)`` is proven
    for every pos in [0, REV) (nothing to check when MAP_PSI_W = 0: the sector is 0).

    With ``g = gcd(2^MAP_PSI_W, REV)``, ``e = recip * REV - 2^(MAP_PSI_W + shift) >= 0`` and
    ``(REV - 1) * e < 2^(log2(g) + shift)`` the product exceeds the exact quotient by less than
    ``g / REV``, which the floor cannot see (Granlund and Montgomery, 1994; the same bound as
    ``long_period.check_index_mapping``). The HDL checks the same bound with the same message.
    """
    if map_psi_w == 0:
        return
    check_mapping(NAME, "SECT", "MAP_PSI_W", "sector_mapping", int(lines) << int(fine_w), map_psi_w, recip, shift,
                  (0, SECT_SHIFT_MAX), f"0..{SECT_SHIFT_MAX}")


@lru_cache(maxsize=256)
def sector_mapping(lines: int, fine_w: int, map_psi_w: int) -> tuple[int, int]:
    """``(SECT_RECIP, SECT_SHIFT)``: the smallest shift whose reciprocal
    ``ceil(2^(MAP_PSI_W + shift) / REV)`` passes `check_sector_mapping`'s bound; ``(0, 0)`` when
    MAP_PSI_W = 0 (no sectors, the parameters are not used). A power-of-two REV gives a power-of-two
    SECT_RECIP (a shift)."""
    if map_psi_w == 0:
        return 0, 0
    return required_mapping(NAME, "sector", "SECT", int(lines) << int(fine_w), map_psi_w, 0, SECT_SHIFT_MAX)


# ---------------------------------------------------------------------------- parameters


@dataclass(frozen=True)
class TrimParams(PositionWidths):
    """Parameters of ``fringe_trim`` (same names, limits and messages as the HDL).

    ``sect_recip`` / ``sect_shift`` default to `sector_mapping`; given, they are checked.
    """

    lines: int          # LINES: signal periods per revolution, 1..2^20; POS_W = FINE_W + clog2(LINES) <= 31
    fine_w: int         # FINE_W: fine phase bits per period, 8..30
    amp_w: int          # AMP_W: magnitude width, 4..32
    speed_log2: int     # SPEED_LOG2: speed window 2^SPEED_LOG2 samples, 0..8
    map_psi_w: int      # MAP_PSI_W: 2^MAP_PSI_W map sectors per revolution, 0..8
    map_phi_w: int      # MAP_PHI_W: 2^MAP_PHI_W bins per signal period, 2..min(10, FINE_W-1)
    trim_w: int         # TRIM_W: width of table values and slopes, 8..24
    trim_frac: int      # TRIM_FRAC: fraction bits of map values and of the sum (fine counts), 0..16
    g_shift: int        # G_SHIFT: right shift of the gain products, 1..48
    sect_recip: int | None = None   # SECT_RECIP (default: sector_mapping)
    sect_shift: int | None = None   # SECT_SHIFT, 0..127 (default: sector_mapping)
    start_speed: int = 0    # START_SPEED: the first sample's speed (no window yet), in [-REV/2, REV/2 - 1]
    mag_smooth_log2: int = 0    # MAG_SMOOTH_LOG2: the magnitude's running average over ~2^K samples, 0 (off)..12

    def __post_init__(self) -> None:
        check_integers(NAME, self, ("fine_w", "lines", "amp_w", "speed_log2", "map_psi_w", "map_phi_w", "trim_w",
                                    "trim_frac", "g_shift"))
        check_lines_fine_w(self.lines, self.fine_w, NAME, POS_W_MAX)
        check_range(NAME, "AMP_W", self.amp_w, 4, 32)
        check_range(NAME, "SPEED_LOG2", self.speed_log2, 0, 8)
        check_range(NAME, "MAP_PSI_W", self.map_psi_w, 0, 8)
        phi_max = min(10, self.fine_w - 1)
        check_range(NAME, "MAP_PHI_W", self.map_phi_w, 2, phi_max, f"2..min(10, FINE_W-1) = {phi_max}")
        check_range(NAME, "TRIM_W", self.trim_w, 8, 24)
        check_range(NAME, "TRIM_FRAC", self.trim_frac, 0, 16)
        check_range(NAME, "G_SHIFT", self.g_shift, 1, 48)
        check_int(NAME, "START_SPEED", self.start_speed)
        check_int(NAME, "MAG_SMOOTH_LOG2", self.mag_smooth_log2)
        check_range(NAME, "MAG_SMOOTH_LOG2", self.mag_smooth_log2, 0, MAG_SMOOTH_LOG2_MAX)
        half = (self.lines << self.fine_w) >> 1
        check_range(NAME, "START_SPEED", self.start_speed, -half, half - 1, f"-REV/2..REV/2-1 = {-half}..{half - 1}")
        if (self.sect_recip is None) != (self.sect_shift is None):
            raise ValueError(f"{NAME}: give both SECT_RECIP and SECT_SHIFT, or neither")
        if self.sect_recip is not None:
            check_int(NAME, "SECT_RECIP", self.sect_recip)
            check_int(NAME, "SECT_SHIFT", self.sect_shift)
            check_sector_mapping(self.lines, self.fine_w, self.map_psi_w, self.sect_recip, self.sect_shift)

    # ---- derived constants (names as in the HDL)
    @property
    def fb(self) -> int:
        """FB: fraction bits of the phase within a bin, FINE_W - MAP_PHI_W (>= 1)."""
        return self.fine_w - self.map_phi_w

    @property
    def window(self) -> int:
        """N: the speed window in samples, 2^SPEED_LOG2."""
        return 1 << self.speed_log2

    @property
    def sectors(self) -> int:
        """Map sectors per revolution, 2^MAP_PSI_W."""
        return 1 << self.map_psi_w

    @property
    def bins(self) -> int:
        """Bins per signal period, 2^MAP_PHI_W (entries of the speed and amp tables per bank)."""
        return 1 << self.map_phi_w

    @property
    def map_words(self) -> int:
        """Map words per bank: 2 directions x 2^MAP_PSI_W sectors x 2^MAP_PHI_W bins."""
        return 2 * self.sectors * self.bins

    @property
    def gain_words(self) -> int:
        """Words per bank of the speed table and of the amp table, 2^MAP_PHI_W."""
        return self.bins

    @property
    def word_w(self) -> int:
        """Width of a table word {slope, value}: 2 * TRIM_W."""
        return 2 * self.trim_w

    @property
    def wr_addr_w(self) -> int:
        """Width of wr_addr: {bank, dir, sector, bin}, 2 + MAP_PSI_W + MAP_PHI_W."""
        return 2 + self.map_psi_w + self.map_phi_w

    @property
    def corr_max(self) -> int:
        """Largest |corr| before clipping: corr is clipped to [-2^(FINE_W-1), 2^(FINE_W-1) - 1]."""
        return 1 << (self.fine_w - 1)

    @property
    def recip(self) -> int:
        """SECT_RECIP."""
        if self.sect_recip is not None:
            return self.sect_recip
        return sector_mapping(self.lines, self.fine_w, self.map_psi_w)[0]

    @property
    def shift(self) -> int:
        """SECT_SHIFT."""
        if self.sect_shift is not None:
            return self.sect_shift
        return sector_mapping(self.lines, self.fine_w, self.map_psi_w)[1]

    @property
    def latency(self) -> int:
        """LATENCY: enabled clocks from in_valid to out_valid, 13."""
        return LATENCY

    def hdl_parameters(self) -> dict[str, int]:
        """The HDL parameter/generic map (SECT_RECIP as an integer: Verilog takes 64 bits, VHDL < 2^31)."""
        return {"LINES": self.lines, "FINE_W": self.fine_w, "AMP_W": self.amp_w, "SPEED_LOG2": self.speed_log2,
                "MAP_PSI_W": self.map_psi_w, "MAP_PHI_W": self.map_phi_w, "TRIM_W": self.trim_w,
                "TRIM_FRAC": self.trim_frac, "G_SHIFT": self.g_shift, "SECT_RECIP": self.recip,
                "SECT_SHIFT": self.shift, "START_SPEED": self.start_speed, "MAG_SMOOTH_LOG2": self.mag_smooth_log2}


# ---------------------------------------------------------------------------- tables


def _limits(w: int) -> tuple[int, int]:
    return -(1 << (w - 1)), (1 << (w - 1)) - 1


def slopes(values) -> np.ndarray:
    """``slope[k] = value[k+1] - value[k]`` along the last (bin) axis, periodic: the last bin takes value[0]."""
    return periodic_slopes(values)


def _round_check(raw: np.ndarray, scale: float, p: TrimParams, what: str) -> np.ndarray:
    if not np.all(np.isfinite(raw)):
        k = tuple(int(i) for i in np.argwhere(~np.isfinite(raw))[0])
        raise ValueError(f"{NAME}: {what} value at {k} is not finite")
    v = np.floor(raw * scale + 0.5)
    lo, hi = _limits(p.trim_w)
    bad = np.argwhere((v < lo) | (v > hi))
    if bad.size:
        k = tuple(int(i) for i in bad[0])
        raise ValueError(f"{NAME}: {what} value at {k}: {raw[k]:g} x {scale:g} = {v[k]:.0f} does not fit "
                         f"s({p.trim_w}) = {lo}..{hi}")
    values = v.astype(np.int64)
    _check_slopes(values, p, what)
    return values


def _check_slopes(values: np.ndarray, p: TrimParams, what: str) -> np.ndarray:
    sl = slopes(values)
    lo, hi = _limits(p.trim_w)
    bad = np.argwhere((sl < lo) | (sl > hi))
    if bad.size:
        k = tuple(int(i) for i in bad[0])
        raise ValueError(f"{NAME}: {what} slope at {k}: {int(sl[k])} does not fit s({p.trim_w})")
    return sl


def _call(fn, *args, n: int) -> np.ndarray:
    """``fn(*args)`` as a float array of n values; point by point when fn is not vectorised."""
    try:
        raw = np.asarray(fn(*args), dtype=np.float64)
    except TypeError:
        raw = None
    if raw is None or raw.shape != (n,):
        *head, ph = args
        raw = np.array([float(fn(*head, float(x))) for x in ph])
    return raw


def make_map_table(fn: Callable[[int, int, np.ndarray], np.ndarray], params: TrimParams) -> np.ndarray:
    """Map values of one bank, shape ``(2, 2^MAP_PSI_W, 2^MAP_PHI_W)`` = (dir, sector, bin), int64.

    ``fn(direction, sector, phase)`` is called once per row with ``direction`` 0 (forwards) or 1
    (backwards: the speed is negative), ``sector`` the sector index 0..2^MAP_PSI_W-1 (sector s covers
    the positions ``[s * REV / 2^MAP_PSI_W, (s + 1) * REV / 2^MAP_PSI_W)``; its centre is at the
    revolution fraction ``(s + 0.5) / 2^MAP_PSI_W``) and ``phase`` the float array of the bin starts
    as fractions of a signal period, ``k / 2^MAP_PHI_W``; it returns the correction in fine counts
    (subtracted from the position). Values are ``round(fn * 2^TRIM_FRAC)`` (half up); scalar
    functions are called point by point.

    Raises:
        ValueError: a value or a slope (periodic along the bins) outside s(TRIM_W), or not finite.
    """
    p = params
    ph = np.arange(p.bins) / p.bins
    raw = np.empty((2, p.sectors, p.bins))
    for d in (0, 1):
        for s in range(p.sectors):
            raw[d, s] = _call(fn, d, s, ph, n=p.bins)
    return _round_check(raw, float(1 << p.trim_frac), p, "map")


def make_gain_table(fn: Callable[[np.ndarray], np.ndarray], params: TrimParams, *, raw: bool = False) -> np.ndarray:
    """Speed or amp table values of one bank, shape ``(2^MAP_PHI_W,)``, int64.

    ``fn(phase)`` gets the bin starts as fractions of a signal period (``k / 2^MAP_PHI_W``). By default
    it returns the gain in fine counts of correction per unit of the input (per fine count per
    sample of speed, or per magnitude LSB), and the table holds ``round(fn * 2^(G_SHIFT + TRIM_FRAC))``
    (the product is shifted by G_SHIFT into the sum, which has TRIM_FRAC fraction bits). With
    ``raw=True`` ``fn`` returns table values in TRIM units (LSBs of the table) directly, rounded half up.

    Raises:
        ValueError: a value or a slope (periodic) outside s(TRIM_W), or not finite.
    """
    p = params
    ph = np.arange(p.bins) / p.bins
    vals = _call(fn, ph, n=p.bins)
    scale = 1.0 if raw else float(2 ** (p.g_shift + p.trim_frac))
    return _round_check(vals, scale, p, "gain")


def pack_words(values, params: TrimParams) -> np.ndarray:
    """RAM words ``{slope, value}`` of one bank's values, flattened in address order (the map:
    {dir, sector, bin}; a gain table: bin), int64 of 2*TRIM_W bits, value in the low half, both fields
    two's complement. Values shaped ``(2, 2^MAP_PSI_W, 2^MAP_PHI_W)`` (map) or ``(2^MAP_PHI_W,)`` (gain)."""
    p = params
    v = np.asarray(values)
    if v.size and not np.issubdtype(v.dtype, np.integer):
        raise ValueError(f"{NAME}: table values must be integers, got dtype {v.dtype}")
    v = v.astype(np.int64)
    if v.shape not in ((2, p.sectors, p.bins), (p.bins,)):
        raise ValueError(f"{NAME}: table values must have shape (2, {p.sectors}, {p.bins}) (map) or "
                         f"({p.bins},) (gain), got {v.shape}")
    lo, hi = _limits(p.trim_w)
    if v.size and (v.min() < lo or v.max() > hi):
        raise ValueError(f"{NAME}: a table value is outside s({p.trim_w})")
    sl = _check_slopes(v, p, "table")
    mask = (1 << p.trim_w) - 1
    return (((sl & mask) << p.trim_w) | (v & mask)).reshape(-1)


def unpack_words(words, params: TrimParams) -> tuple[np.ndarray, np.ndarray]:
    """``(slope, value)`` as signed int64 from RAM words (any shape; any word is legal)."""
    return split_words(words, params.trim_w)


# ---------------------------------------------------------------------------- the datapath


def _as_pos(pos, p: TrimParams) -> np.ndarray:
    a = np.asarray(pos)
    if a.size and not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{NAME}: pos must be integers, got dtype {a.dtype}")
    a = a.astype(np.int64).reshape(-1)
    if a.size and (a.min() < 0 or a.max() >= p.rev):
        raise ValueError(f"{NAME}: pos outside [0, REV = {p.rev})")
    return a


def _wrap(d: np.ndarray, rev: int) -> np.ndarray:
    """d in (-REV, REV) into [-REV/2, REV/2): 2d >= REV: d - REV; 2d < -REV: d + REV."""
    return d - np.where(2 * d >= rev, rev, 0) + np.where(2 * d < -rev, rev, 0)


LONGEST_SPEED_LOG2 = 5    # the longest speed window the generator chooses (32 samples: a quiet speed, little lag)


def speed_window_log2(lines: int, longest: int = LONGEST_SPEED_LOG2) -> int:
    """The longest speed window, up to 2^longest samples, whose position change stays within half a revolution
    at the core's overspeed limit (a quarter period per sample): 2^SPEED_LOG2 < 2 LINES. A longer window
    would wrap the speed into [-REV/2, REV/2) and turn it, and the direction with it, into a wrong one without
    any fault, on encoders of few lines at speed."""
    return min(longest, (2 * int(lines) - 1).bit_length() - 1)


def speeds(pos, params: TrimParams) -> np.ndarray:
    """The speed of every sample of a stream that starts after a reset, int64 in [-REV/2, REV/2) (dir = speed < 0).

    Sample n >= N = 2^SPEED_LOG2: ``wrap(pos[n] - pos[n-N])``. Before the window is full (1 <= n < N) the
    longest power-of-two window there is, 2^k samples with ``k = floor(log2(n))``, scaled to N samples and
    saturated: ``clip(wrap(pos[n] - pos[n-2^k]) * 2^(SPEED_LOG2-k), -REV/2, REV/2 - 1)`` (a recording that
    starts in motion gets its speed-dependent trim from the second sample on). The first sample: START_SPEED."""
    p = params
    a = _as_pos(pos, p)
    sp = np.full(a.size, p.start_speed, dtype=np.int64)
    half = p.rev >> 1
    for k in range(p.speed_log2 + 1):
        w = 1 << k                       # samples n in [w, 2w) take the window w; from N on, N
        end = a.size if k == p.speed_log2 else min(2 * w, a.size)
        if end > w:
            d = _wrap(a[w:end] - a[:end - w], p.rev) << (p.speed_log2 - k)
            sp[w:end] = np.clip(d, -half, half - 1)
    return sp


def magnitudes(mag, params: TrimParams) -> np.ndarray:
    """The magnitude each sample of a stream that starts after a reset is trimmed with, int64 u(AMP_W): mag itself
    when MAG_SMOOTH_LOG2 = K = 0, else its running average ``acc >> K`` with ``acc = mag[0] << K`` at the first
    sample and ``acc = acc + mag - (acc >> K)`` at each one after. acc stays below 2^(AMP_W + K): its largest
    value, 2^(AMP_W + K) - 1, maps to 2^(AMP_W + K) - 2^AMP_W + mag at most."""
    p = params
    mg = np.asarray(mag).astype(np.int64).reshape(-1)
    k = p.mag_smooth_log2
    if k == 0 or mg.size == 0:
        return mg
    out = np.empty(mg.size, dtype=np.int64)
    acc = int(mg[0]) << k
    out[0] = mg[0]
    for n, x in enumerate(mg[1:].tolist(), 1):      # a recursion: sample by sample (Python integers)
        acc += x - (acc >> k)
        out[n] = acc >> k
    return out


def sectors_of(pos, params: TrimParams) -> np.ndarray:
    """``(pos * SECT_RECIP) >> SECT_SHIFT`` (0 when MAP_PSI_W = 0), exact in int64 (POS_W <= 31)."""
    p = params
    a = np.asarray(pos).astype(np.int64)
    if p.map_psi_w == 0:
        return np.zeros(a.shape, dtype=np.int64)
    if (p.rev - 1) * p.recip < 1 << 63:
        return (a * p.recip) >> p.shift
    q = (a.astype(object) * p.recip) >> p.shift            # wide reciprocals (Verilog only): exact, slow
    return q.astype(np.int64)


def _banked(words: np.ndarray, addr: np.ndarray, bank, size: int, what: str) -> np.ndarray:
    w = np.asarray(words)
    if w.ndim not in (1, 2) or w.shape[-1] != size:
        raise ValueError(f"{NAME}: {what} words must have shape ({size},) or (banks, {size}), got {w.shape}")
    w = w.astype(np.int64)
    if w.ndim == 1:
        return w[addr]
    if bank is None:
        raise ValueError(f"{NAME}: {what} words of {w.shape[0]} banks need a bank per sample")
    b = np.broadcast_to(np.asarray(bank).astype(np.int64), addr.shape)
    if b.size and (b.min() < 0 or b.max() >= w.shape[0]):
        raise ValueError(f"{NAME}: bank outside 0..{w.shape[0] - 1}")
    return w.reshape(-1)[b * size + addr]


def _interp(word: np.ndarray, frac: np.ndarray, p: TrimParams) -> np.ndarray:
    """value + ((slope * frac + 2^(FB-1)) >>> FB) from raw words."""
    return interpolate(*unpack_words(word, p), frac, p.fb)


def trim_detail(pos, mag, map_words, speed_words, amp_words, params: TrimParams, bank=None,
                speed=None, avg=None) -> dict[str, np.ndarray]:
    """Every intermediate of `trim_words` (int64 arrays): speed, avg, dir, sector, bin, frac, m, gs, ga,
    total, corr (clipped), sat, pos_out."""
    p = params
    a = _as_pos(pos, p)
    mg = np.broadcast_to(np.asarray(mag), a.shape)
    if mg.size and not np.issubdtype(mg.dtype, np.integer):
        raise ValueError(f"{NAME}: mag must be integers, got dtype {mg.dtype}")
    mg = mg.astype(np.int64)
    if mg.size and (mg.min() < 0 or mg.max() >= 1 << p.amp_w):
        raise ValueError(f"{NAME}: mag outside u(AMP_W = {p.amp_w})")
    if speed is None:
        sp = speeds(a, p)
    else:
        sp = np.asarray(speed).astype(np.int64).reshape(-1)
        if sp.shape != a.shape:
            raise ValueError(f"{NAME}: speed must have one value per sample, got {sp.shape} for {a.shape}")
    if avg is None:
        mg = magnitudes(mg, p) if p.mag_smooth_log2 else mg
    else:
        mg = np.asarray(avg).astype(np.int64).reshape(-1)
        if mg.shape != a.shape:
            raise ValueError(f"{NAME}: avg must have one value per sample, got {mg.shape} for {a.shape}")
    d = (sp < 0).astype(np.int64)
    phase = a & ((1 << p.fine_w) - 1)
    b = phase >> p.fb
    frac = phase & ((1 << p.fb) - 1)
    sector = sectors_of(a, p)
    maddr = (d << (p.map_psi_w + p.map_phi_w)) | (sector << p.map_phi_w) | b
    m = _interp(_banked(map_words, maddr, bank, p.map_words, "map"), frac, p)
    gs = _interp(_banked(speed_words, b, bank, p.gain_words, "speed table"), frac, p)
    ga = _interp(_banked(amp_words, b, bank, p.gain_words, "amp table"), frac, p)
    s = sp * gs
    s += mg * ga
    s += 1 << (p.g_shift - 1)
    s >>= p.g_shift
    total = m + s
    corr = total
    if p.trim_frac:
        corr = (total + (1 << (p.trim_frac - 1))) >> p.trim_frac
    lo, hi = -p.corr_max, p.corr_max - 1
    sat = (corr < lo) | (corr > hi)
    corr = np.clip(corr, lo, hi)
    out = a - corr
    out += np.where(out < 0, p.rev, 0) - np.where(out >= p.rev, p.rev, 0)
    return {"speed": sp, "avg": mg, "dir": d, "sector": sector, "bin": b, "frac": frac, "m": m, "gs": gs, "ga": ga,
            "total": total, "corr": corr, "sat": sat.astype(np.int64), "pos_out": out}


def trim_words(pos, mag, map_words, speed_words, amp_words, params: TrimParams, bank=None,
               speed=None, avg=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bit-exact ``(pos_out, dir, sat)`` of ``fringe_trim`` for a stream of samples taken after a reset.

    Args:
        pos: u(POS_W) positions in [0, REV), one per accepted sample, in order.
        mag: u(AMP_W) magnitudes (scalar or per sample).
        map_words, speed_words, amp_words: raw RAM words ``{slope, value}`` (any contents), shape
            (words per bank,) or (banks, words per bank) with ``bank``.
        params: the block parameters.
        bank: the table bank of each sample (with banked words).
        speed: the speeds, when the stream does not start at a reset (from `speeds` over the whole
            stream since the reset); default `speeds(pos)`.
        avg: the magnitudes trimmed with, likewise (`magnitudes` over the stream since the reset); default
            `magnitudes(mag)`.

    Returns:
        int64 arrays: pos_out in [0, REV), dir (0/1), sat (0/1).
    """
    r = trim_detail(pos, mag, map_words, speed_words, amp_words, params, bank, speed, avg)
    return r["pos_out"], r["dir"], r["sat"]


def trim(pos, mag, map_values, speed_values, amp_values, params: TrimParams, bank=None,
         speed=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """As `trim_words`, from table values (slopes derived, periodic): the map ``(2, 2^MAP_PSI_W,
    2^MAP_PHI_W)`` or with a leading bank axis, the gain tables ``(2^MAP_PHI_W,)`` or ``(banks, ...)``."""
    p = params

    def words(v, shape):
        v = np.asarray(v)
        if v.shape == shape:
            return pack_words(v, p)
        if v.ndim == len(shape) + 1 and v.shape[1:] == shape:
            return np.stack([pack_words(x, p) for x in v])
        raise ValueError(f"{NAME}: table values must have shape {shape} or (banks, *{shape}), got {v.shape}")

    return trim_words(pos, mag, words(map_values, (2, p.sectors, p.bins)), words(speed_values, (p.bins,)),
                      words(amp_values, (p.bins,)), p, bank, speed)


# ---------------------------------------------------------------------------- error budget


def _second(values) -> float:
    v = np.asarray(values, dtype=np.float64)
    if v.size == 0:
        return 0.0
    return float(np.abs(np.roll(v, -1, axis=-1) - 2 * v + np.roll(v, 1, axis=-1)).max())


def error_terms(params: TrimParams, *, speed_max: float | None = None, mag_max: float | None = None,
                map_values=None, speed_values=None, amp_values=None) -> dict[str, float]:
    """The terms of `error_budget`, in fine counts.

    Analytic worst cases (any table, any sample; ``speed_max`` defaults to REV/2, ``mag_max`` to
    2^AMP_W - 1; ``k = 2^-TRIM_FRAC`` is the LSB of the sum in fine counts):

    - ``map_interp_rounding``: ``(slope * frac + 2^(FB-1)) >>> FB`` is within 1/2 LSB: ``k/2``;
    - ``gain_interp_rounding``: the same in gs and ga, amplified by the inputs:
      ``(speed_max + mag_max) / 2 * k / 2^G_SHIFT``;
    - ``gain_rounding``: the sum of the products rounded by G_SHIFT bits: ``k/2``;
    - ``output_rounding``: corr rounded to whole fine counts: 1/2 (0 when TRIM_FRAC = 0).

    For tables made by `make_map_table` / `make_gain_table` from smooth functions (a bound only if
    the functions are smooth: the second differences sample their curvature):

    - ``map_quantisation`` / ``gain_quantisation``: values rounded to the table LSB: ``k/2`` and
      ``(speed_max + mag_max) / 2 * k / 2^G_SHIFT``;
    - ``map_interpolation`` / ``gain_interpolation`` (only with the values given): linear
      interpolation misses by at most h^2 max|f''| / 8, estimated by the largest periodic second
      difference along the bins with a margin of 5/4 (the gains weighted by speed_max and mag_max).
    """
    p = params
    k = 2.0 ** -p.trim_frac
    sm = p.rev / 2 if speed_max is None else float(speed_max)
    mm = (1 << p.amp_w) - 1 if mag_max is None else float(mag_max)
    gk = k / 2.0 ** p.g_shift
    terms = {
        "map_interp_rounding": 0.5 * k,
        "gain_interp_rounding": 0.5 * (sm + mm) * gk,
        "gain_rounding": 0.5 * k,
        "output_rounding": 0.5 if p.trim_frac else 0.0,
        "map_quantisation": 0.5 * k,
        "gain_quantisation": 0.5 * (sm + mm) * gk,
        "map_interpolation": 0.0,
        "gain_interpolation": 0.0,
    }
    if map_values is not None:
        terms["map_interpolation"] = 1.25 * _second(map_values) / 8 * k
    gi = 0.0
    if speed_values is not None:
        gi += sm * 1.25 * _second(speed_values) / 8 * gk
    if amp_values is not None:
        gi += mm * 1.25 * _second(amp_values) / 8 * gk
    terms["gain_interpolation"] = gi
    return terms


def error_budget(params: TrimParams, **kw) -> float:
    """Bound on ``|(pos - pos_out) - c|`` (modulo REV, fine counts) where ``c = f_map(dir, sector, phase)
    + speed * f_speed(phase) + mag * f_amp(phase)`` is the ideal correction of the float functions the
    tables were made from (no clipping); the sum of `error_terms` (same keyword arguments)."""
    return float(sum(error_terms(params, **kw).values()))
