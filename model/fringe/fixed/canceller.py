"""Bit-exact model of ``fringe_canceller``: an adaptive canceller of additive interference at one frequency.

Mirrors ``rtl/verilog/fringe_canceller.v`` and ``rtl/vhdl/fringe_canceller.vhd`` (contract in
``docs/blocks/fringe_canceller.md``). It sits between the quadrature stage and the CORDIC: its inputs are
the corrected channels (c, s) s(WAVE_W) on the circle of radius R = 2^(WAVE_W-2). An additive tone on the
ADC channels (a switching supply, motor PWM) reaches them as n_c, n_s at the tone's frequency with
phases nobody knows in advance and that change at every power-up, so no table can hold it: the block
estimates it from the signals (the radius of the Lissajous figure, no reference needed) and subtracts it.

With ``i`` the top LUT_W bits of the NCO phase, ``cw = LUT[(i + 2^(LUT_W-2)) mod 2^LUT_W]``,
``sw = LUT[i]`` (``LUT[k] = round((2^(C_W-1) - 1) sin(2 pi k / 2^LUT_W))``), per sample n::

    acc[0] = 0;  acc[n+1] = (acc[n] + FREQ) mod 2^32        FREQ: the CANCEL_FREQ register of sample n's bank
    n_c = (A_C * cw + B_C * sw + 2^(C_W + A_FRAC - 2)) >>> (C_W - 1 + A_FRAC)       n_s likewise (A_S, B_S)
    c_out = sat(c - n_c), s_out = sat(s - n_s)             saturated to s(WAVE_W); sat = either was clipped
    e   = clip(((c_out^2 + s_out^2) >> (WAVE_W - 2)) - R)  clipped to s(WAVE_W): 2 x the radial error
    u_c = (e * c_out) >>> (WAVE_W - 2),  u_s = (e * s_out) >>> (WAVE_W - 2)
    per block j of B = 2^BLOCK_LOG2 samples:  S_AC = sum u_c * cw, S_BC = sum u_c * sw, S_AS, S_BS likewise
    at its end: X += (S_X + 2^(SH_j-1)) >>> SH_j  for X in (A_C, B_C, A_S, B_S), saturated to s(A_W)
                (track_sat, held until reset); the new values apply from the first sample of block j + 2 on
                (block j + 1 still runs on the old ones);
                SH_j = BLOCK_LOG2 + C_W - 2 - A_FRAC + G_j,
                G_j = min(MU_LOG2, GEAR_OFFSET + bit_length(j + 1))
                (gear shift: steps 1/2, 1/4, 1/4, 1/8 x 4, ... down to 2^-MU_LOG2, so the first blocks average
                the estimate instead of creeping towards it; j counts blocks since reset; GEAR_OFFSET starts
                it lower, for a start-up that a few blocks cannot tell from a slow change of the radius).

Why it converges: with a residual d = n - n_est, e ~ 2 (d_c cos phi + d_s sin phi) and the mean of u_c * cw
over a block is (A_C,true - A_C) 2^(C_W - 2 - A_FRAC) when the tone is not a multiple of the electrical
frequency; the update then removes 2^-G_j of the error per block (the sums of block j apply two blocks
later: with steps up to 1/2 that delayed loop is stable). A tone at the electrical frequency is
an offset, one at its multiples a waveform error: those are the tables' job, and the canceller sees them
as a steady bias it averages out. At standstill only the radial part of the tone is observable: the
tangential part (the angle error) is then not corrected. Reset clears NCO, coefficients and sums.

Everything per sample is int64 (the widest product, c_out^2 + s_out^2, is below 2^61); the block sums are
taken exactly (int64 halves) and the update runs on Python integers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .limits import check_integers, check_range

__all__ = ["ADAPT_LATENCY", "LATENCY", "NAME", "CancelParams", "CancelResult", "CancelStream", "cancel",
           "freq_word", "sine_table"]

NAME = "fringe_canceller"
#: Enabled clocks from in_valid to out_valid (LUT read, products, sum and rounding, subtraction and saturation).
LATENCY = 4
#: Enabled clocks from a block's last sample at the input (its own clock enable counted) until the
#: block's update is in place (the adaptation path beside the output: squares, e, u, the products with
#: cw / sw, the sums, the step); at most B, so block j's update is there before block j + 2 begins.
ADAPT_LATENCY = 15
NCO_W = 32


@dataclass(frozen=True)
class CancelParams:
    """The HDL parameters (same names upper case, same limits and messages)."""

    wave_w: int = 18        # data width of c, s (quadrature output, radius 2^(WAVE_W-2)), 8..31
    lut_w: int = 10         # 2^LUT_W entries of the sine table per turn, 4..12
    c_w: int = 16           # sine table value width, 8..18
    block_log2: int = 4     # B = 2^BLOCK_LOG2 samples per update, 4..12
    mu_log2: int = 6        # final update step 2^-MU_LOG2 per block, 1..12
    a_frac: int = 4         # fraction bits of the coefficients (data LSBs), 0..12
    a_w: int = 20           # coefficient width, 8..32; A_W <= WAVE_W + A_FRAC
    gear_offset: int = 0    # the gear shift starts this many gears lower (first step 2^-(1+it)), 0..MU_LOG2-1

    def __post_init__(self) -> None:
        check_integers(NAME, self, ("wave_w", "lut_w", "c_w", "block_log2", "mu_log2", "a_frac", "a_w", "gear_offset"))
        check_range(NAME, "WAVE_W", self.wave_w, 8, 31)
        check_range(NAME, "LUT_W", self.lut_w, 4, 12)
        check_range(NAME, "C_W", self.c_w, 8, 18)
        check_range(NAME, "BLOCK_LOG2", self.block_log2, 4, 12)
        check_range(NAME, "MU_LOG2", self.mu_log2, 1, 12)
        check_range(NAME, "A_FRAC", self.a_frac, 0, 12)
        check_range(NAME, "GEAR_OFFSET", self.gear_offset, 0, self.mu_log2 - 1, f"0..MU_LOG2-1 = {self.mu_log2 - 1}")
        check_range(NAME, "A_W", self.a_w, 8, min(32, self.wave_w + self.a_frac),
                    f"8..min(32, WAVE_W + A_FRAC) = {min(32, self.wave_w + self.a_frac)}")
        if self.sh0 < 0:
            raise ValueError(f"{NAME}: BLOCK_LOG2 + C_W - 2 - A_FRAC = {self.sh0} must be >= 0")

    @property
    def b(self) -> int:
        """B: samples per block."""
        return 1 << self.block_log2

    @property
    def sh0(self) -> int:
        """SH0 = BLOCK_LOG2 + C_W - 2 - A_FRAC: the shift of the block sums is SH0 + G_j."""
        return self.block_log2 + self.c_w - 2 - self.a_frac

    def gear(self, j: int) -> int:
        """G_j = min(MU_LOG2, GEAR_OFFSET + bit_length(j + 1)) of block j."""
        return min(self.mu_log2, self.gear_offset + (j + 1).bit_length())

    @property
    def radius(self) -> int:
        """R = 2^(WAVE_W-2): the calibrated radius of (c, s)."""
        return 1 << (self.wave_w - 2)

    def hdl_parameters(self) -> dict[str, int]:
        """The HDL parameter / generic map (without LUT_INIT and USER_W)."""
        return {"WAVE_W": self.wave_w, "LUT_W": self.lut_w, "C_W": self.c_w, "BLOCK_LOG2": self.block_log2,
                "MU_LOG2": self.mu_log2, "A_FRAC": self.a_frac, "A_W": self.a_w, "GEAR_OFFSET": self.gear_offset}


def sine_table(params: CancelParams) -> np.ndarray:
    """LUT[k] = round((2^(C_W-1) - 1) sin(2 pi k / 2^LUT_W)), k < 2^LUT_W (the LUT_INIT image)."""
    n = 1 << params.lut_w
    amp = (1 << (params.c_w - 1)) - 1
    return np.floor(amp * np.sin(2 * np.pi * np.arange(n) / n) + 0.5).astype(np.int64)


def freq_word(tone_hz: float, sample_rate_hz: float) -> int:
    """The CANCEL_FREQ register of a tone: round(f / fs * 2^32) mod 2^32 (an alias folds by itself)."""
    if not (math.isfinite(tone_hz) and math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise ValueError(f"{NAME}: tone {tone_hz!r} Hz at {sample_rate_hz!r} samples/s has no NCO word")
    return int(math.floor(tone_hz / sample_rate_hz * 2.0 ** NCO_W + 0.5)) % (1 << NCO_W)


def _limits(w: int) -> tuple[int, int]:
    return -(1 << (w - 1)), (1 << (w - 1)) - 1


def _sum_exact(x: np.ndarray) -> int:
    """Exact sum of int64 values below 2^62 in magnitude (at most 2^20 of them)."""
    return (int((x >> 32).sum()) << 32) + int((x & 0xFFFFFFFF).sum())


@dataclass
class CancelResult:
    """What `cancel` returns: per sample c, s (int64), sat and track_sat (bool); coefs (blocks + 2, 4): row k
    the (A_C, B_C, A_S, B_S) block k ran on (rows past the last block: the state that would come next)."""

    c: np.ndarray
    s: np.ndarray
    sat: np.ndarray
    track_sat: np.ndarray
    coefs: np.ndarray


class CancelStream:
    """The canceller over a stream given in pieces of any length (the core's model feeds it as the drift tracker
    asks for phases): the same words as one `cancel` over the whole stream."""

    def __init__(self, params: CancelParams):
        self.p = params
        self.lut = sine_table(params)
        self.n = 0                            # samples since reset
        self.acc = 0                          # NCO phase of the next sample
        self.rows = [[0, 0, 0, 0], [0, 0, 0, 0]]   # row k: the coefficients of block k
        self.row_sat = [False, False]
        self.sums = [0, 0, 0, 0]              # of the block in progress

    def run(self, c, s, freq):
        """(c_out, s_out, sat, track_sat) of the next piece; freq: int or one NCO word per sample."""
        p = self.p
        c, s = np.asarray(c, dtype=np.int64), np.asarray(s, dtype=np.int64)
        n = len(c)
        if s.shape != c.shape:
            raise ValueError(f"{NAME}: c and s must have the same length")
        f = np.broadcast_to(np.asarray(freq, dtype=np.int64), c.shape)
        if f.size and (f.min() < 0 or f.max() >= 1 << NCO_W):
            raise ValueError(f"{NAME}: FREQ must be a u({NCO_W}) word")
        mask = (1 << NCO_W) - 1
        acc = np.empty(n, dtype=np.uint64)
        if n:
            acc[0] = self.acc
            acc[1:] = np.uint64(self.acc) + np.cumsum(f[:-1].astype(np.uint64))   # wraps mod 2^64: mod 2^32 exact
            self.acc = int((int(acc[-1]) + int(f[-1])) & mask)
        i = ((acc & np.uint64(mask)) >> np.uint64(NCO_W - p.lut_w)).astype(np.int64)
        sw = self.lut[i]
        cw = self.lut[(i + (1 << (p.lut_w - 2))) & ((1 << p.lut_w) - 1)]
        lo, hi = _limits(p.wave_w)
        alo, ahi = _limits(p.a_w)
        est_shift = p.c_w - 1 + p.a_frac
        est_rnd = 1 << (est_shift - 1)
        out_c, out_s = np.empty(n, np.int64), np.empty(n, np.int64)
        sat, tsat = np.zeros(n, bool), np.zeros(n, bool)
        start = 0
        while start < n:
            k, pos = divmod(self.n, p.b)
            r = slice(start, min(n, start + p.b - pos))
            cwk, swk = cw[r], sw[r]
            a_c, b_c, a_s, b_s = self.rows[k]
            yc = c[r] - ((a_c * cwk + b_c * swk + est_rnd) >> est_shift)
            ys = s[r] - ((a_s * cwk + b_s * swk + est_rnd) >> est_shift)
            sat[r] = (yc < lo) | (yc > hi) | (ys < lo) | (ys > hi)
            yc, ys = np.clip(yc, lo, hi), np.clip(ys, lo, hi)
            out_c[r], out_s[r] = yc, ys
            tsat[r] = self.row_sat[k]
            e = np.clip(((yc * yc + ys * ys) >> (p.wave_w - 2)) - p.radius, lo, hi)
            uc, us = (e * yc) >> (p.wave_w - 2), (e * ys) >> (p.wave_w - 2)
            for m, x in enumerate((uc * cwk, uc * swk, us * cwk, us * swk)):
                self.sums[m] += _sum_exact(x)
            taken = r.stop - r.start
            self.n += taken
            start = r.stop
            if pos + taken == p.b:          # block k complete: its update is the state of block k + 2
                sh = p.sh0 + p.gear(k)
                new = [x + ((sx + (1 << (sh - 1))) >> sh) for x, sx in zip(self.rows[k + 1], self.sums, strict=True)]
                self.rows.append([min(max(v, alo), ahi) for v in new])
                self.row_sat.append(self.row_sat[k + 1] or any(v < alo or v > ahi for v in new))
                self.sums = [0, 0, 0, 0]
        return out_c, out_s, sat, tsat


def cancel(c, s, freq, params: CancelParams) -> CancelResult:
    """One stream from reset. ``freq``: the NCO word (int, or one per sample: the register of its bank)."""
    st = CancelStream(params)
    oc, os_, sat, tsat = st.run(c, s, freq)
    blocks = -(-len(oc) // params.b)
    rows = st.rows + [st.rows[-1]] * max(0, blocks + 2 - len(st.rows))
    return CancelResult(oc, os_, sat, tsat, np.array(rows[:blocks + 2], dtype=np.int64).reshape(-1, 4))
