"""Bit-exact model of ``fringe_period_count``: coarse/fine combination and period counting.

Contract: docs/architecture.md, section fringe_period_count. With REV = LINES * 2^FINE_W:

- overspeed: ``delta = phase - phase_prev`` as a signed FINE_W-bit number; flagged when
  ``|delta| >= 2^(FINE_W-2)``; phase_prev is the previous valid sample's phase; the first
  sample after reset never flags;
- COARSE_W > 0: ``centre = (coarse*LINES << (FINE_W-COARSE_W)) + coarse_ofs``,
  ``d = centre - phase``, ``n = (d + 2^(FINE_W-1)) >>> FINE_W``, ``r = d - n*2^FINE_W``,
  ``coarse_err = |r| > COARSE_TOL``, n wrapped into [0, LINES), ``pos = n*2^FINE_W + phase``;
- COARSE_W = 0: ``pos = (pos_prev + delta) mod REV``, the first sample after reset gives
  ``pos = phase``.

The stream given to `period_count` starts right after a reset.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LATENCY = 2   # clock enables in the RTL: delta and coarse centre; period number and position
NAME = "fringe_period_count"


def rev_and_pos_w(lines: int, fine_w: int) -> tuple[int, int]:
    """Fine counts per revolution, and the bits of a position in [0, REV)."""
    rev = lines << fine_w
    return rev, max(1, (rev - 1).bit_length())


@dataclass(frozen=True)
class PeriodCountParams:
    fine_w: int     # FINE_W: fine phase bits per period, 8..30
    lines: int      # LINES: periods per revolution, 1..2^20, any integer
    coarse_w: int   # COARSE_W: coarse code bits, 0 = none; else FINE_W >= COARSE_W + 2, 2^COARSE_W >= LINES

    def __post_init__(self):
        if not 8 <= self.fine_w <= 30:
            raise ValueError(f"{NAME}: FINE_W = {self.fine_w} out of range 8..30")
        if not 1 <= self.lines <= (1 << 20):
            raise ValueError(f"{NAME}: LINES = {self.lines} out of range 1..2^20")
        if self.fine_w + max(0, (self.lines - 1).bit_length()) > 48:
            raise ValueError(f"{NAME}: FINE_W + clog2(LINES) = {self.fine_w + (self.lines - 1).bit_length()} "
                             "exceeds 48")
        if self.coarse_w:
            if not 1 <= self.coarse_w <= 24 or self.fine_w < self.coarse_w + 2:
                raise ValueError(f"{NAME}: COARSE_W = {self.coarse_w} must be 0 or 1..24 with "
                                 f"FINE_W >= COARSE_W + 2")
            if (1 << self.coarse_w) < self.lines:
                raise ValueError(f"{NAME}: 2^COARSE_W = {1 << self.coarse_w} < LINES = {self.lines}")

    @property
    def rev(self) -> int:
        return rev_and_pos_w(self.lines, self.fine_w)[0]

    @property
    def pos_w(self) -> int:
        return rev_and_pos_w(self.lines, self.fine_w)[1]

    @property
    def coarse_tol(self) -> int:
        """Midpoint between half a coarse code and half a period, fine counts."""
        return (self.lines << (self.fine_w - self.coarse_w - 2)) + (1 << (self.fine_w - 2)) if self.coarse_w else 0

    def hdl_parameters(self) -> dict[str, int]:
        return {"FINE_W": self.fine_w, "LINES": self.lines, "COARSE_W": self.coarse_w}


def _delta(phase: np.ndarray, fine_w: int) -> np.ndarray:
    """Signed FINE_W-bit difference to the previous sample (0 for the first)."""
    half = 1 << (fine_w - 1)
    d = np.diff(phase, prepend=phase[:1])
    return ((d + half) & ((1 << fine_w) - 1)) - half


def period_count(phase, coarse, coarse_ofs, params: PeriodCountParams):
    """(pos, overspeed, coarse_err) for a stream that starts right after reset."""
    p = params
    phase = np.asarray(phase, dtype=np.int64)
    delta = _delta(phase, p.fine_w)
    overspeed = np.abs(delta) >= (1 << (p.fine_w - 2))
    if p.coarse_w:
        coarse = np.asarray(coarse, dtype=np.int64)
        centre = ((coarse * p.lines) << (p.fine_w - p.coarse_w)) + int(coarse_ofs)
        d = centre - phase
        n = (d + (1 << (p.fine_w - 1))) >> p.fine_w
        r = d - (n << p.fine_w)
        coarse_err = np.abs(r) > p.coarse_tol
        n = np.mod(n, p.lines)
        return (n << p.fine_w) + phase, overspeed, coarse_err
    pos = np.mod(phase[0] + np.cumsum(delta), p.rev) if len(phase) else phase
    return pos, overspeed, np.zeros(len(phase), dtype=bool)
