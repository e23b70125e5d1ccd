"""Bit-exact model of ``fringe_cordic``: phase (arctan) and magnitude by a vectoring CORDIC.

Mirrors ``rtl/verilog/fringe_cordic.v`` and ``rtl/vhdl/fringe_cordic.vhd`` (contract in
``docs/architecture.md``, section fringe_cordic). With ``N = FINE_W + GUARD``:

- pre-rotation: if ``x < 0``: ``x, y = -x, -y`` and ``z = 2^(N-1)`` (half a turn), else ``z = 0``;
  then ``x, y`` are scaled by ``2^GUARD`` into s(IN_W + 2 + GUARD);
- stage i = 0..STAGES-1: ``if y >= 0: x, y, z = x + (y >>> i), y - (x >>> i), z + ATAN[i]``,
  else ``x, y, z = x - (y >>> i), y + (x >>> i), z - ATAN[i]``;
- ``ATAN[i] = round(atan(2^-i) / (2 pi) * 2^N)``, computed as the 62-bit fraction of a turn
  ``ATAN62[i]`` (the one table shared by Verilog, VHDL and this model) rounded half up to N bits:
  ``(ATAN62[i] + 2^(61-N)) >> (62-N)``;
- out: ``phase = ((z + 2^(GUARD-1)) >>> GUARD) mod 2^FINE_W`` u(FINE_W) (fraction of a period),
  ``mag = (x + 2^(GUARD-1)) >>> GUARD`` u(IN_W+1) (magnitude times the CORDIC gain, ~1.6468);
  with ``GUARD = 0`` there is no rounding term.

The zero vector (x = y = 0) gives ``mag = 0`` and ``phase = round(sum(ATAN)) >>> GUARD``
(about 0.2775 of a turn for STAGES >= 8): every stage takes the ``y >= 0`` branch. It carries
no information; the top flags it through the magnitude threshold (AMP_LOW).

The RTL has ``LATENCY = STAGES + 2`` enabled clocks (pre-rotation register, STAGES stage registers,
output rounding register). ITERATIVE = 0 pipelines them (one sample per clock); ITERATIVE = 1 iterates one
micro-rotation stage on one register, the same stages in the same order (the same words, the same
latency), and takes one sample per ``STAGES + ITER_CLOCKS_BASE`` clock enables (``clocks_per_sample``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .limits import check_integers, check_range

__all__ = [
    "ATAN62",
    "ITER_CLOCKS_BASE",
    "CordicParams",
    "atan_table",
    "cordic",
    "cordic_gain",
    "error_budget",
    "latency",
    "mag_error_bound",
    "phase_error_bound",
]

#: atan(2^-i) / (2 pi) as a 62-bit fraction of a turn, round half up (i = 0..31). Generated once
#: with 120-digit decimal arithmetic (Machin's pi, Taylor series of atan); identical tables are
#: in the Verilog function ``atan62`` and the VHDL constant ``ATAN62``.
ATAN62 = (
    0x0800000000000000,  #  0: atan(2^-0) = 45.0000000000 deg
    0x04B90147677CC21A,  #  1: atan(2^-1) = 26.5650511771 deg
    0x027ECE16D7B8E7A3,  #  2: atan(2^-2) = 14.0362434679 deg
    0x0144447507776687,  #  3: atan(2^-3) = 7.1250163489 deg
    0x00A2C350C39626BB,  #  4: atan(2^-4) = 3.5763343750 deg
    0x005175F85641189E,  #  5: atan(2^-5) = 1.7899106082 deg
    0x0028BD87970A098A,  #  6: atan(2^-6) = 0.8951737102 deg
    0x00145F15447510AC,  #  7: atan(2^-7) = 0.4476141709 deg
    0x000A2F94D1B430CE,  #  8: atan(2^-8) = 0.2238105004 deg
    0x000517CBAECC2ACE,  #  9: atan(2^-9) = 0.1119056771 deg
    0x00028BE600246E9F,  # 10: atan(2^-10) = 0.0559528919 deg
    0x000145F3052A032E,  # 11: atan(2^-11) = 0.0279764526 deg
    0x0000A2F98337FB18,  # 12: atan(2^-12) = 0.0139882271 deg
    0x0000517CC1B05CBD,  # 13: atan(2^-13) = 0.0069941137 deg
    0x000028BE60DABA44,  # 14: atan(2^-14) = 0.0034970569 deg
    0x0000145F306DAE9F,  # 15: atan(2^-15) = 0.0017485284 deg
    0x00000A2F9836E17F,  # 16: atan(2^-16) = 0.0008742642 deg
    0x00000517CC1B7205,  # 17: atan(2^-17) = 0.0004371321 deg
    0x0000028BE60DB92B,  # 18: atan(2^-18) = 0.0002185661 deg
    0x00000145F306DC9B,  # 19: atan(2^-19) = 0.0001092830 deg
    0x000000A2F9836E4E,  # 20: atan(2^-20) = 0.0000546415 deg
    0x000000517CC1B727,  # 21: atan(2^-21) = 0.0000273208 deg
    0x00000028BE60DB94,  # 22: atan(2^-22) = 0.0000136604 deg
    0x000000145F306DCA,  # 23: atan(2^-23) = 0.0000068302 deg
    0x0000000A2F9836E5,  # 24: atan(2^-24) = 0.0000034151 deg
    0x0000000517CC1B72,  # 25: atan(2^-25) = 0.0000017075 deg
    0x000000028BE60DB9,  # 26: atan(2^-26) = 0.0000008538 deg
    0x0000000145F306DD,  # 27: atan(2^-27) = 0.0000004269 deg
    0x00000000A2F9836E,  # 28: atan(2^-28) = 0.0000002134 deg
    0x00000000517CC1B7,  # 29: atan(2^-29) = 0.0000001067 deg
    0x0000000028BE60DC,  # 30: atan(2^-30) = 0.0000000534 deg
    0x00000000145F306E,  # 31: atan(2^-31) = 0.0000000267 deg
)

#: Width of the shared table's fractions (bits of a turn).
ATAN62_BITS = 62

#: ITERATIVE = 1: clock enables per sample beyond STAGES: none (the clock enable of the last micro-rotation
#: writes its result to a register of its own and loads the next sample's pre-rotated vector).
ITER_CLOCKS_BASE = 0


@dataclass(frozen=True)
class CordicParams:
    """Parameters of ``fringe_cordic`` (same names, limits and messages as the HDL)."""

    in_w: int    # IN_W: width of the x and y inputs, s(IN_W), 8..30
    fine_w: int  # FINE_W: output phase bits per period, 8..30
    stages: int  # STAGES: CORDIC micro-rotations, 4..32 (>= FINE_W + 1 for full precision)
    guard: int   # GUARD: extra fractional bits of x, y and the angle accumulator, 0..8
    iterative: int = 0  # ITERATIVE: 1 = one micro-rotation stage iterated, one sample per clocks_per_sample

    def __post_init__(self) -> None:
        block = "fringe_cordic"
        check_integers(block, self, ("in_w", "fine_w", "stages", "guard", "iterative"))
        check_range(block, "IN_W", self.in_w, 8, 30)
        check_range(block, "FINE_W", self.fine_w, 8, 30)
        check_range(block, "STAGES", self.stages, 4, 32)
        check_range(block, "GUARD", self.guard, 0, 8)
        check_range(block, "ITERATIVE", self.iterative, 0, 1)

    # ---- derived constants (names as in the HDL)
    @property
    def acc_w(self) -> int:
        """ACC_W: bits of the angle accumulator z, FINE_W + GUARD (a full turn is 2^ACC_W)."""
        return self.fine_w + self.guard

    @property
    def dp_w(self) -> int:
        """DP_W: width of the x/y datapath, IN_W + 2 + GUARD (sign of -min, CORDIC gain)."""
        return self.in_w + 2 + self.guard

    @property
    def mag_w(self) -> int:
        """MAG_W: width of the magnitude output, IN_W + 1 (unsigned)."""
        return self.in_w + 1

    @property
    def latency(self) -> int:
        """LATENCY: enabled clocks from in_valid to out_valid, STAGES + 2."""
        return self.stages + 2

    @property
    def clocks_per_sample(self) -> int:
        """Clock enables from one accepted sample to the next at full speed: 1, or STAGES + ITER_CLOCKS_BASE
        with ITERATIVE = 1 (ready is 0 in between)."""
        return self.stages + ITER_CLOCKS_BASE if self.iterative else 1

    def hdl_parameters(self) -> dict[str, int]:
        """The HDL parameter/generic map (``IN_W``, ``FINE_W``, ``STAGES``, ``GUARD``, ``ITERATIVE``)."""
        return {"IN_W": self.in_w, "FINE_W": self.fine_w, "STAGES": self.stages, "GUARD": self.guard,
                "ITERATIVE": self.iterative}


def latency(params: CordicParams) -> int:
    """Clock enables from ``in_valid`` to ``out_valid`` in the RTL: STAGES + 2."""
    return params.latency


def atan_table(params: CordicParams) -> list[int]:
    """``ATAN[i] = round(atan(2^-i) / (2 pi) * 2^(FINE_W+GUARD))`` for i < STAGES (from ATAN62)."""
    sh = ATAN62_BITS - params.acc_w  # >= 24
    return [(ATAN62[i] + (1 << (sh - 1))) >> sh for i in range(params.stages)]


def cordic_gain(stages: int) -> float:
    """The CORDIC gain prod_{i<stages} sqrt(1 + 2^-2i) (about 1.6468 for many stages)."""
    return math.prod(math.sqrt(1.0 + 4.0 ** -i) for i in range(stages))


_CHUNK = 1 << 14  # samples per block: keeps the working arrays in the CPU cache


def cordic(x, y, params: CordicParams) -> tuple[np.ndarray, np.ndarray]:
    """Phase and magnitude of the vectors (x, y), bit-exact with the RTL.

    Args:
        x, y: integer arrays (or scalars) of the same shape, each in s(IN_W).
        params: the block parameters.

    Returns:
        ``(phase, mag)`` as int64 arrays of the input shape: ``phase`` u(FINE_W) is the angle of
        (x, y) as a fraction of a turn times 2^FINE_W; ``mag`` u(IN_W+1) is the magnitude times
        the CORDIC gain (see ``cordic_gain``).

    Raises:
        ValueError: an input is outside s(IN_W) or the shapes differ.
    """
    xa = np.asarray(x)
    ya = np.asarray(y)
    if xa.shape != ya.shape:
        raise ValueError(f"fringe_cordic: x and y shapes differ: {xa.shape} vs {ya.shape}")
    for name, a in (("x", xa), ("y", ya)):
        if a.size and not np.issubdtype(a.dtype, np.integer):
            raise ValueError(f"fringe_cordic: {name} must be integers, got dtype {a.dtype}")
    xa = xa.astype(np.int64, copy=False).ravel()
    ya = ya.astype(np.int64, copy=False).ravel()
    lo, hi = -(1 << (params.in_w - 1)), (1 << (params.in_w - 1)) - 1
    for name, a in (("x", xa), ("y", ya)):
        if a.size and (a.min() < lo or a.max() > hi):
            raise ValueError(f"fringe_cordic: {name} outside s(IN_W={params.in_w}) = {lo}..{hi}")

    g = params.guard
    half = 1 << (params.acc_w - 1)
    table = atan_table(params)
    phase = np.empty(xa.size, dtype=np.int64)
    mag = np.empty(xa.size, dtype=np.int64)
    rnd = (1 << (g - 1)) if g > 0 else 0
    fmask = (1 << params.fine_w) - 1

    for s in range(0, xa.size, _CHUNK):
        xc = xa[s:s + _CHUNK]
        yc = ya[s:s + _CHUNK]
        # Pre-rotation into the right half plane; m = -1 where x < 0, else 0.
        m = xc >> 63
        xr = ((xc ^ m) - m) << g       # |x| * 2^GUARD
        yr = ((yc ^ m) - m) << g       # y or -y, * 2^GUARD
        z = m & half                   # 2^(N-1) or 0
        for i, a in enumerate(table):
            m = yr >> 63               # -1 where y < 0 (the "else" branch), 0 where y >= 0
            # (v ^ m) - m is v where y >= 0 and -v where y < 0.
            dx = yr >> i
            dx ^= m
            dx -= m
            dy = xr >> i
            dy ^= m
            dy -= m
            xr += dx                   # x + (y >>> i)  |  x - (y >>> i)
            yr -= dy                   # y - (x >>> i)  |  y + (x >>> i)
            z += m ^ a                 # z + ATAN[i]  |  z + ~ATAN[i] ...
            z -= m                     # ... + 1 = z - ATAN[i]
        phase[s:s + _CHUNK] = ((z + rnd) >> g) & fmask
        mag[s:s + _CHUNK] = (xr + rnd) >> g
    shape = np.shape(x)
    return phase.reshape(shape), mag.reshape(shape)


def phase_error_bound(params: CordicParams, r) -> np.ndarray:
    """Bound on |phase - 2^FINE_W * atan2(y, x) / (2 pi)| (wrapped), in phase LSBs.

    ``r`` is the input magnitude hypot(x, y) in input LSBs (array or scalar). The bound is
    ``fixed + datapath_k / r``, see ``error_budget``; it is infinite where ``r`` is too small.
    """
    b = error_budget(params)
    r = np.asarray(r, dtype=np.float64)
    # The accumulated truncation error e_max must stay below the vector length for the
    # small-angle bound to hold; keep a factor-2 margin, otherwise report no bound.
    scaled = r * 2.0 ** params.guard
    with np.errstate(divide="ignore", invalid="ignore"):
        ok = scaled > 2.0 * b["datapath_e_max"]
        dp = np.where(ok, b["datapath_k"] / np.where(ok, r - b["datapath_e_max"] * 2.0 ** -params.guard, 1.0),
                      np.inf)
    return b["fixed"] + dp


def error_budget(params: CordicParams) -> dict:
    """The analysed phase and magnitude error of the model against float arithmetic.

    Phase (in LSBs of the u(FINE_W) output, one LSB = 2^-FINE_W turn), for a vector of input
    magnitude r (input LSBs):

    - ``table``: sum over the stages of |ATAN[i] - exact| (the angle table rounded to
      FINE_W + GUARD bits), converted to output LSBs;
    - ``residual``: atan(2^-(STAGES-1)), the angle a vectoring CORDIC leaves unresolved;
    - ``rounding``: 0.5 (output rounding of z to FINE_W bits; 0 when GUARD = 0);
    - datapath (input quantisation relative to the magnitude): each stage i >= 1 truncates
      ``x >>> i`` and ``y >>> i``, an error vector shorter than sqrt(2) units of 2^-GUARD input
      LSB; it turns the vector by at most sqrt(2) / |w_i| with |w_i| >= sqrt(2) * r * 2^GUARD
      after stage 0. That moves both the final vector and the decomposition of the angle, so
      the phase error gains 2 * (STAGES - 1) / (r * 2^GUARD) rad: ``datapath_k / r`` LSBs.
      ``datapath_e_max`` (2^-GUARD input LSB units) bounds the accumulated error vector, used
      to shrink r conservatively.

    ``fixed`` = table + residual + rounding; ``phase_error_bound(params, r)`` adds the datapath
    term. Magnitude: ``mag`` approximates ``gain * r`` (``gain = cordic_gain(STAGES)``) within
    ``mag_abs`` LSBs (accumulated truncation plus output rounding) plus ``gain * r`` times
    1 - cos(final angle), see ``mag_error_bound``.
    """
    n = params.acc_w
    to_lsb = 2.0 ** -params.guard                # accumulator LSB -> output LSB
    rad_to_lsb = 2.0 ** params.fine_w / (2.0 * math.pi)
    table = atan_table(params)
    exact = [math.atan(2.0 ** -i) / (2.0 * math.pi) * 2.0 ** n for i in range(params.stages)]
    table_err = sum(abs(a - e) for a, e in zip(table, exact, strict=True)) * to_lsb
    residual_rad = math.atan(2.0 ** -(params.stages - 1))
    residual = residual_rad * rad_to_lsb
    rounding = 0.5 if params.guard > 0 else 0.0
    # Accumulated truncation error vector, in units of 2^-GUARD input LSB: stage i contributes
    # < sqrt(2), amplified by the gain of the later stages.
    gains = [math.sqrt(1.0 + 4.0 ** -j) for j in range(params.stages)]
    e_max = sum(math.sqrt(2.0) * math.prod(gains[i + 1:]) for i in range(1, params.stages))
    # 1.01: asin(u) <= 1.01 u for the u <= 0.13 that phase_error_bound admits.
    datapath_k = 1.01 * 2.0 * (params.stages - 1) * 2.0 ** -params.guard * rad_to_lsb
    gain = cordic_gain(params.stages)
    return {
        "table": table_err,
        "residual": residual,
        "rounding": rounding,
        "fixed": table_err + residual + rounding,
        "datapath_k": datapath_k,
        "datapath_e_max": e_max,
        "gain": gain,
        "mag_abs": e_max * to_lsb + (0.5 if params.guard > 0 else 0.0),
    }


def mag_error_bound(params: CordicParams, r) -> np.ndarray:
    """Bound on |mag - cordic_gain(STAGES) * r| in LSBs, for input magnitude ``r`` (array)."""
    b = error_budget(params)
    r = np.asarray(r, dtype=np.float64)
    rad_per_lsb = 2.0 * math.pi / 2.0 ** params.fine_w
    # Angle of the final vector: residual plus the datapath turns (see error_budget).
    ang = np.minimum((b["residual"] + (phase_error_bound(params, r) - b["fixed"])) * rad_per_lsb, math.pi / 2)
    return b["mag_abs"] + b["gain"] * r * (1.0 - np.cos(ang))
