"""Bit-exact model of ``fringe_period_count``: coarse/fine combination, or period counting.

Mirrors ``rtl/verilog/fringe_period_count.v`` and ``rtl/vhdl/fringe_period_count.vhd`` (contract in
``docs/blocks/fringe_period_count.md``). With ``REV = LINES * 2^FINE_W`` fine counts
per revolution and ``POS_W = clog2(REV) = FINE_W + clog2(LINES)`` (at most 48):

- ``delta = phase - phase_prev`` taken modulo ``2^FINE_W`` as a signed FINE_W-bit number, where
  ``phase_prev`` is the phase of the previous valid sample; ``overspeed = |delta| >= 2^(FINE_W-2)``
  (a quarter period); the first valid sample after reset never flags (its delta is 0);
- ``COARSE_W > 0`` (absolute): ``cpos = (coarse * LINES) << (FINE_W - COARSE_W)`` (the start of the
  code's span, ``REV / 2^COARSE_W`` fine counts per code), ``centre = cpos + coarse_ofs``,
  ``d = centre - phase``, ``n = (d + 2^(FINE_W-1)) >>> FINE_W`` (the period nearest to the centre),
  ``r = d - n * 2^FINE_W`` (the sample's distance from its code's centre), then ``n`` wrapped into
  [0, LINES) and ``pos_abs = n * 2^FINE_W + phase``. A code spans ``span = LINES / 2^COARSE_W <= 1``
  period; when it spans half a period or more, edge jitter that flips a code moves ``centre`` by as
  much, and ``pos_abs`` of such a sample is a whole period off (at span = 1 on every jittered edge).
  The fine phase says where in its code a sample lies: a sample in the TRUST band,
  ``trusted = -TRUST <= r < TRUST`` with ``TRUST = 2^(FINE_W-2)`` (the top two bits of ``r`` agree),
  is a quarter period or more from either edge of its code, so jitter under a quarter period cannot
  have flipped it. ``m = r XOR (r >>> (FINE_W-1))`` (``r`` for ``r >= 0``, ``-r-1`` for ``r < 0``, FINE_W-1
  bits, no carry) is the sample's carry-free distance from its code's centre; ``trusted`` is ``m < TRUST``.
  Output: ``pos = pos_abs`` (absolute) for a trusted sample; otherwise ``pos = pos_trk =
  (pos_prev + delta) mod REV`` (tracked, as the incremental mode; ``pos_prev`` the previous output),
  except before the first trusted sample since reset (start-up), where a sample is also absolute if it
  is the first valid sample since reset, an overspeed (its delta is ambiguous: the track restarts from
  the code), or nearer its code's centre than the start-up anchor, ``m < anchor_m``; ``anchor_m`` is
  the ``m`` of the last absolute sample. So the start-up track follows the best code seen so far and a
  sample at a jittered edge after a better one cannot put the output a period off (taking every
  code there made the output flicker by a period at span >= 1/2; a start nearer an edge than the
  jitter stays undecidable until a sample lies farther from its edge than that). ``pos_trk`` and ``pos_abs`` always
  share their low FINE_W bits (the phase), so they differ by whole periods only. A jump to a better
  anchor at start-up, or at the first trusted sample, is not flagged: a start-up anchor near an edge is
  a code edge jitter can flip, not a wrong code, and coarse_err keeps its meaning (below).
  ``coarse_err = |r| > COARSE_TOL`` with ``COARSE_TOL = (LINES << (FINE_W - COARSE_W - 2)) + 2^(FINE_W-2)``
  (the midpoint between half a coarse code and half a period; it cannot fire at span = 1), or a
  trusted sample after an earlier trusted one whose ``pos_abs`` differs from a valid ``pos_trk``:
  the code is really wrong, never edge jitter. That sample's output is ``pos_abs`` (the position
  resynchronises), and the jump is flagged, as are the samples tracked from it (``track_bad``, up to
  the next absolute output): either side of the jump may be the wrong one, none is silent (a wrong
  code repeated on the trusted samples after its resync agrees with the track it set: only its
  first sample and the samples tracked from it are flagged). The track is lost (``track_lost``) by
  an overspeed (this sample's or one since the last ``pos_abs`` output): then a disagreement is the
  track's fault, already flagged as overspeed, and is not a coarse_err (it would blame a good code).
  With span <= 1/2 and a calibrated offset ``|r|`` stays under a quarter period plus the jitter, and
  where it does not, ``pos_trk = pos_abs``: the output is that of the absolute combination;
- ``COARSE_W = 0`` (incremental): ``pos = (pos_prev + delta) mod REV`` with ``pos_prev`` the previous
  valid output; the first valid sample after reset gives ``pos = phase``; ``coarse_err = 0``.

``coarse_ofs`` is a calibrated register (the misalignment of the coarse code plus half a code);
calibration gives less than half a period, and the hardware supports ``|coarse_ofs| <= 2^FINE_W``:
then ``n`` lies in [-2, LINES+1] and one add or subtract of LINES wraps it (``period_count`` checks
the range and raises ``ValueError`` outside it).

`period_count` takes a stream of valid samples that starts right after a reset (the RTL's state
restarts there), or resumes one from `track_state`; it is vectorised (cumulative sums of delta from
the last absolute sample; start-up anchors are running minima of m, restarted at overspeeds).

The RTL has ``LATENCY = 4`` enabled clocks, one carry chain per stage: (1) delta and the coarse
centre; (2) the overspeed test, ``d + 2^(FINE_W-1)`` (period number and residual, and ``m``), and the track's
delta with its two wrapped alternatives (the counter's in both modes); (3) ``|r| > COARSE_TOL``, the wrap of the period
number and the tracked sum (three sums in parallel, chosen by sign bits) and ``m < anchor_m`` (``m``
registered in stage 2 from r's bits: a compare of FINE_W-1 bits against a register, shorter than
the sums beside it), then the choice between them (the state loop: ``pos``, anchor_m, trusted_seen,
track_lost); (4) the compare of the two period numbers, registered in stage 3, and the resync,
track_bad and coarse_err it decides. The compare was stage 3's until it made that stage the
slowest path of the design (a compare after the POS_W add in the ``pos`` loop); nothing in the loop
reads it, so it takes a clock of its own and the outputs one more clock.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .limits import check_int, check_range

__all__ = [
    "LATENCY",
    "POS_W_MAX",
    "PeriodCountParams",
    "PositionWidths",
    "clog2",
    "latency",
    "centre_distance",
    "coarse_absolute",
    "period_count",
    "track_state",
    "rev_and_pos_w",
]

#: Enabled clocks from ``in_valid`` to ``out_valid`` in the RTL.
LATENCY = 4
#: Widest position the blocks support: ``FINE_W + clog2(LINES) <= 48`` (REV < 2^48 fits int64 with room).
POS_W_MAX = 48
NAME = "fringe_period_count"


def clog2(v: int) -> int:
    """ceil(log2(v)) for v >= 1 (0 for 1), as Verilog's ``$clog2``."""
    return max(0, (int(v) - 1).bit_length())


def rev_and_pos_w(lines: int, fine_w: int) -> tuple[int, int]:
    """``(REV, POS_W)``: fine counts per revolution ``LINES * 2^FINE_W`` and ``FINE_W + clog2(LINES)``.

    ``POS_W`` is ``clog2(REV)``, the bits of a position in [0, REV).
    """
    return int(lines) << int(fine_w), int(fine_w) + clog2(lines)


class PositionWidths:
    """REV and POS_W (the HDL's names) of a parameter set with ``lines`` and ``fine_w``."""

    @property
    def rev(self) -> int:
        """REV: fine counts per revolution, LINES * 2^FINE_W."""
        return rev_and_pos_w(self.lines, self.fine_w)[0]

    @property
    def pos_w(self) -> int:
        """POS_W: bits of a position in [0, REV), FINE_W + clog2(LINES) = clog2(REV)."""
        return rev_and_pos_w(self.lines, self.fine_w)[1]


def check_lines_fine_w(lines, fine_w, block: str, pos_w_max: int = POS_W_MAX) -> None:
    """The FINE_W / LINES checks shared by fringe_period_count, fringe_long_period and fringe_trim (HDL messages)."""
    check_int(block, "FINE_W", fine_w)
    check_int(block, "LINES", lines)
    check_range(block, "FINE_W", fine_w, 8, 30)
    check_range(block, "LINES", lines, 1, 1 << 20, "1..2^20")
    pos_w = fine_w + clog2(lines)
    if pos_w > pos_w_max:
        raise ValueError(f"{block}: POS_W = FINE_W + clog2(LINES) = {pos_w} exceeds {pos_w_max}")


@dataclass(frozen=True)
class PeriodCountParams(PositionWidths):
    """Parameters of ``fringe_period_count`` (same names, limits and messages as the HDL)."""

    fine_w: int     # FINE_W: fine phase bits per signal period, 8..30
    lines: int      # LINES: signal periods per revolution, 1..2^20, any integer; FINE_W + clog2(LINES) <= 48
    coarse_w: int   # COARSE_W: coarse code bits, 0 = none (periods are counted); else 1..24,
                    #   COARSE_W <= FINE_W - 2 and 2^COARSE_W >= LINES

    def __post_init__(self) -> None:
        check_lines_fine_w(self.lines, self.fine_w, NAME)
        check_int(NAME, "COARSE_W", self.coarse_w)
        if self.coarse_w != 0 and not (1 <= self.coarse_w <= 24 and self.coarse_w <= self.fine_w - 2):
            raise ValueError(f"{NAME}: COARSE_W = {self.coarse_w} out of range: 0 (no coarse code) or "
                             "1..24 with COARSE_W <= FINE_W - 2")
        if self.coarse_w and (1 << self.coarse_w) < self.lines:
            raise ValueError(f"{NAME}: 2^COARSE_W = {1 << self.coarse_w} is less than LINES = {self.lines}")

    # ---- derived constants (names as in the HDL)
    @property
    def coarse_span(self) -> int:
        """Fine counts per coarse code, REV / 2^COARSE_W = LINES << (FINE_W - COARSE_W) (0 without)."""
        return self.lines << (self.fine_w - self.coarse_w) if self.coarse_w else 0

    @property
    def coarse_tol(self) -> int:
        """COARSE_TOL: largest accepted |r|, the midpoint between half a code and half a period (0 without)."""
        if not self.coarse_w:
            return 0
        return (self.lines << (self.fine_w - self.coarse_w - 2)) + (1 << (self.fine_w - 2))

    @property
    def trust(self) -> int:
        """TRUST: a sample with -TRUST <= r < TRUST, a quarter period from its code's edges, sets the position."""
        return 1 << (self.fine_w - 2)

    @property
    def ofs_max(self) -> int:
        """The supported |coarse_ofs|: 2^FINE_W (one period)."""
        return 1 << self.fine_w

    @property
    def latency(self) -> int:
        """LATENCY: enabled clocks from in_valid to out_valid, 4."""
        return LATENCY

    def hdl_parameters(self) -> dict[str, int]:
        """The HDL parameter/generic map (``FINE_W``, ``LINES``, ``COARSE_W``)."""
        return {"FINE_W": self.fine_w, "LINES": self.lines, "COARSE_W": self.coarse_w}


def latency(params: PeriodCountParams) -> int:
    """Clock enables from ``in_valid`` to ``out_valid`` in the RTL: 4."""
    return LATENCY


def _int_array(name: str, v, lo: int, hi: int) -> np.ndarray:
    """v as int64, checked to be integers in [lo, hi]."""
    a = np.asarray(v)
    if a.size and not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{NAME}: {name} must be integers, got dtype {a.dtype}")
    a = a.astype(np.int64, copy=False)
    if a.size and (a.min() < lo or a.max() > hi):
        bad = a.ravel()[np.flatnonzero((a.ravel() < lo) | (a.ravel() > hi))[0]]
        raise ValueError(f"{NAME}: {name} = {bad} outside {lo}..{hi}")
    return a


def coarse_absolute(ph: np.ndarray, co: np.ndarray, ofs, p: PeriodCountParams) -> tuple[np.ndarray, np.ndarray]:
    """``(pos_abs, r)`` of checked int64 inputs: the absolute position from the code and the sample's
    distance from its code's centre (stateless; `period_count` chooses between it and the track)."""
    half = 1 << (p.fine_w - 1)
    mask = (1 << p.fine_w) - 1
    d = co * p.lines
    d <<= p.fine_w - p.coarse_w      # cpos
    d += ofs                         # centre
    d -= ph
    t = d + half
    nper = t >> p.fine_w             # floor((d + 2^(FINE_W-1)) / 2^FINE_W)
    r = (t & mask) - half            # d - n * 2^FINE_W
    # |coarse_ofs| <= 2^FINE_W keeps n in [-2, LINES+1]: one add or subtract of LINES, as the RTL
    if p.lines == 1:
        nper[:] = 0
    else:
        nper += np.where(nper < 0, p.lines, np.where(nper >= p.lines, -p.lines, 0))
    pos_abs = (nper << p.fine_w) | ph
    return pos_abs, r


def period_count(phase, coarse, coarse_ofs, params: PeriodCountParams, start_pos: int | None = None,
                 start_lost: bool = False, start_bad: bool = False,
                 start_anchor: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position and flags for a stream of valid samples that starts right after reset.

    Args:
        phase: u(FINE_W) fine phases, one-dimensional (the stream, in order).
        coarse: u(COARSE_W) coarse codes of the same length; ignored (may be None) when COARSE_W = 0.
        coarse_ofs: s(POS_W+1) middle of coarse code 0 in fine counts, a scalar or one value per
            sample (the register value each sample saw); |coarse_ofs| <= 2^FINE_W. Ignored when
            COARSE_W = 0.
        params: the block parameters.
        start_pos: the output at the first sample, for a stream resumed in the middle (its low FINE_W
            bits must equal the first phase); default: as after reset. With COARSE_W > 0 and no
            start_anchor it also says that a trusted sample had been seen.
        start_lost, start_bad: with start_pos and COARSE_W > 0: track_lost and track_bad after the
            first sample (`track_state`).
        start_anchor: with start_pos and COARSE_W > 0: no trusted sample had been seen up to the first
            sample, and this is anchor_m after it (`track_state`); None: a trusted sample had been seen.

    Returns:
        ``(pos, overspeed, coarse_err)``: int64 positions in [0, REV) and two bool arrays.

    Raises:
        ValueError: an input outside its format or range, or mismatched lengths.
    """
    return _run(phase, coarse, coarse_ofs, params, start_pos, start_lost, start_bad, start_anchor)[:3]


def track_state(phase, coarse, coarse_ofs, params: PeriodCountParams, start_pos: int | None = None,
                start_lost: bool = False, start_bad: bool = False, start_anchor: int | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(trusted_seen, track_lost, track_bad, anchor_m)`` after each sample of `period_count` (the RTL's
    state; all False / 0 with COARSE_W = 0), to resume a stream exactly: pass track_lost, track_bad and,
    while trusted_seen is False, anchor_m (the only time it is read) as start_lost, start_bad, start_anchor."""
    return _run(phase, coarse, coarse_ofs, params, start_pos, start_lost, start_bad, start_anchor)[3:]


def centre_distance(r: np.ndarray, fine_w: int) -> np.ndarray:
    """``m = r XOR (r >>> (FINE_W-1))``: r for r >= 0, -r-1 for r < 0, in [0, 2^(FINE_W-1)): a sample's
    distance from its code's centre without a carry (the RTL's XOR of r's low bits with its sign)."""
    return r ^ (r >> (fine_w - 1))


def _run(phase, coarse, coarse_ofs, p: PeriodCountParams, start_pos, start_lost, start_bad, start_anchor=None):
    ph = _int_array("phase", phase, 0, (1 << p.fine_w) - 1)
    if ph.ndim != 1:
        raise ValueError(f"{NAME}: phase must be one-dimensional (a stream), got shape {ph.shape}")
    n = ph.size
    half = 1 << (p.fine_w - 1)
    mask = (1 << p.fine_w) - 1
    # delta as s(FINE_W); 0 for the first sample (it has no predecessor)
    delta = np.empty(n, dtype=np.int64)
    if n:
        delta[0] = 0
        np.subtract(ph[1:], ph[:-1], out=delta[1:])
        delta[1:] += half
        delta[1:] &= mask
        delta[1:] -= half
    overspeed = np.abs(delta) >= (1 << (p.fine_w - 2))
    no_state = np.zeros(n, dtype=bool)
    if start_pos is not None and n and ((start_pos & mask) != ph[0] or not 0 <= start_pos < p.rev):
        raise ValueError(f"{NAME}: start_pos {start_pos} does not hold the first phase {ph[0]}")

    if p.coarse_w == 0:
        if n == 0:
            return ph.copy(), overspeed, no_state, no_state, no_state, no_state, np.zeros(0, np.int64)
        # |running sum| < n * 2^(FINE_W-1): int64 holds 2^34 samples of the widest phase
        pos = np.cumsum(delta)
        pos += ph[0] if start_pos is None else start_pos
        pos %= p.rev
        return pos, overspeed, no_state, no_state, no_state.copy(), no_state.copy(), np.zeros(n, np.int64)

    if coarse is None:
        raise ValueError(f"{NAME}: coarse codes are required when COARSE_W = {p.coarse_w}")
    co = _int_array("coarse", coarse, 0, (1 << p.coarse_w) - 1)
    if co.shape != ph.shape:
        raise ValueError(f"{NAME}: coarse shape {co.shape} differs from phase shape {ph.shape}")
    ofs = _int_array("coarse_ofs", coarse_ofs, -p.ofs_max, p.ofs_max)
    if ofs.ndim and ofs.shape != ph.shape:
        raise ValueError(f"{NAME}: coarse_ofs must be a scalar or one value per sample, got shape {ofs.shape}")
    resumed = start_pos is not None
    early = resumed and start_anchor is not None      # resumed before the first trusted sample
    mtop = 1 << (p.fine_w - 1)                        # m < mtop
    if early and not 0 <= start_anchor < mtop:
        raise ValueError(f"{NAME}: start_anchor = {start_anchor} outside 0..{mtop - 1}")
    pos_abs, r = coarse_absolute(ph, co, ofs, p)
    coarse_err = np.abs(r) > p.coarse_tol
    if n == 0:
        return pos_abs, overspeed, coarse_err, no_state, no_state, no_state, np.zeros(0, np.int64)
    trusted = (r >= -p.trust) & (r < p.trust)
    m = centre_distance(r, p.fine_w)
    # sets: trusted for the state after each sample (a resumed first sample: as the state says)
    sets = trusted.copy()
    if resumed:
        sets[0] = not early
    # seen: a trusted sample before this one since reset
    seen = np.zeros(n, dtype=bool)
    seen[1:] = np.logical_or.accumulate(sets[:-1])
    # start-up anchors: a new minimum of m since the last restart (the first sample, an overspeed);
    # key = m - restarts * 2^(FINE_W-1) puts every restart below all earlier keys
    restart = overspeed.copy()
    restart[0] = not resumed
    mval = m.copy()
    if early:
        mval[0] = start_anchor
    key = mval - np.cumsum(restart) * mtop
    record = np.ones(n, dtype=bool)
    record[1:] = key[1:] < np.minimum.accumulate(key)[:-1]
    anchor_val = pos_abs.copy()
    if resumed:
        anchor_val[0] = start_pos
    anchor = trusted | (~seen & record)              # samples whose output is pos_abs
    anchor[0] = True
    idx = np.arange(n)
    last = np.maximum.accumulate(np.where(anchor, idx, 0))          # the last anchor up to each sample
    cum = np.cumsum(delta)                       # |sum| < n * 2^(FINE_W-1)
    pos = (anchor_val[last] + (cum - cum[last])) % p.rev
    # each sample's track: from the last anchor before it; lost by an overspeed since that anchor
    prev = np.empty(n, dtype=np.int64)
    prev[0] = 0
    prev[1:] = last[:-1]
    pos_trk = (anchor_val[prev] + (cum - cum[prev])) % p.rev
    cum_over = np.cumsum(overspeed)
    lost = (cum_over - cum_over[prev]) > 0
    if resumed and start_lost:
        lost |= prev == 0
    lost[0] = False
    # a resync against a valid track; the samples tracked from it carry its flag (track_bad)
    resync = trusted & seen & ~lost & (pos_abs != pos_trk)
    if resumed:
        resync[0] = start_bad
    coarse_err |= resync[last]
    seen_after = seen | sets
    lost_after = lost & ~anchor
    if resumed:
        lost_after[0] = bool(start_lost)
    return pos, overspeed, coarse_err, seen_after, lost_after, resync[last], mval[last]
