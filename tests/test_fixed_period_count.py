"""Bit-exact period-count model (fringe.fixed.period_count): the contract, the float reference, limits."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hdl_text import block_texts, missing_checks

from fringe.dsp.position import coarse_fine_combine, count_periods
from fringe.fixed.period_count import (
    LATENCY,
    PeriodCountParams,
    clog2,
    coarse_absolute,
    period_count,
    rev_and_pos_w,
    track_state,
)

PARAMS = [
    PeriodCountParams(16, 256, 9),
    PeriodCountParams(12, 100, 8),       # LINES not a power of two, span < a period
    PeriodCountParams(16, 1, 0),
    PeriodCountParams(14, 3, 0),
    PeriodCountParams(10, 1, 1),         # one line with a coarse code: n mod 1 = 0
    PeriodCountParams(10, 4, 2),         # LINES = 2^COARSE_W: span = one period
    PeriodCountParams(8, 5, 6),          # COARSE_W = FINE_W - 2
    PeriodCountParams(30, 200_000, 18),  # widest: POS_W = 48
    PeriodCountParams(20, 3600, 0),
]


def _pid(p: PeriodCountParams) -> str:
    return f"F{p.fine_w}-L{p.lines}-C{p.coarse_w}"


# ---------------------------------------------------------------------------- the contract, literally


class Contract:
    """docs/architecture.md on Python integers, one valid sample at a time (as the RTL's state)."""

    def __init__(self, p: PeriodCountParams):
        self.p = p
        self.prev: int | None = None
        self.pos: int | None = None
        self.seen = False                 # a trusted sample since reset
        self.lost = False                 # an overspeed since the last absolute output
        self.bad = False                  # the last absolute output resynchronised a valid track
        self.anchor_m = 0                 # m of the last absolute output (read before the first trusted one)

    def step(self, phase: int, coarse: int, ofs: int) -> tuple[int, bool, bool]:
        p = self.p
        m = 1 << p.fine_w
        delta = 0 if self.prev is None else (phase - self.prev) % m
        if delta >= m // 2:
            delta -= m                                             # signed FINE_W bits
        over = self.prev is not None and abs(delta) >= m // 4
        if p.coarse_w:
            centre = ((coarse * p.lines) << (p.fine_w - p.coarse_w)) + ofs
            d = centre - phase
            n = (d + m // 2) >> p.fine_w                          # floor
            r = d - n * m
            err = abs(r) > p.coarse_tol
            pos_abs = (n % p.lines) * m + phase
            trusted = -m // 4 <= r < m // 4
            dist = r if r >= 0 else -r - 1                         # m: the distance from the code's centre
            pos_trk = None if self.pos is None else (self.pos + delta) % p.rev
            lost = self.lost or over
            start_up = not self.seen and (self.prev is None or over or dist < self.anchor_m)
            if trusted or start_up:
                self.bad = trusted and self.seen and not lost and pos_abs != pos_trk
                pos, self.lost, self.anchor_m = pos_abs, False, dist
            else:
                pos, self.lost = pos_trk, lost
            err = err or self.bad
            self.seen = self.seen or trusted
        else:
            pos = phase if self.pos is None else (self.pos + delta) % p.rev
            err = False
        self.prev, self.pos = phase, pos
        return pos, over, err


def stream(p: PeriodCountParams, rng: np.random.Generator, n: int, ofs: int | None = None):
    """A wandering position (reversals, jumps up to half a period), its phases and coarse codes
    (a few wrong), and a calibrated-like or given offset."""
    period = 1 << p.fine_w
    steps = np.round((np.clip(np.cumsum(rng.normal(0, 0.02, n)), -0.3, 0.3) + rng.normal(0, 0.05, n))
                     * period).astype(np.int64)
    jumps = rng.random(n) < 0.05
    steps[jumps] = rng.integers(-period // 2, period // 2, jumps.sum())
    true = np.mod(int(rng.integers(0, p.rev)) + np.cumsum(steps), p.rev)
    phase = true & (period - 1)
    if not p.coarse_w:
        return phase, None, 0
    span = p.coarse_span
    if ofs is None:
        ofs = span // 2 - int(rng.integers(-period // 2 + 1, period // 2))
    m = span // 2 - ofs
    coarse = (np.mod(true + m, p.rev) // span) % (1 << p.coarse_w)
    bad = rng.random(n) < 0.03
    coarse[bad] = rng.integers(0, 1 << p.coarse_w, bad.sum())
    return phase, coarse, ofs


@pytest.mark.parametrize("p", PARAMS, ids=_pid)
def test_vectorised_model_matches_the_contract(p):
    rng = np.random.default_rng(5)
    ofs_cases = [None, 1 << p.fine_w, -(1 << p.fine_w), 0] if p.coarse_w else [None]
    for ofs in ofs_cases:
        phase, coarse, ofs_v = stream(p, rng, 3000, ofs)
        pos, over, err = period_count(phase, coarse, ofs_v, p)
        ref = Contract(p)
        want = [ref.step(int(a), int(coarse[i]) if p.coarse_w else 0, ofs_v) for i, a in enumerate(phase)]
        assert pos.dtype == np.int64 and over.dtype == bool and err.dtype == bool
        np.testing.assert_array_equal(pos, [w[0] for w in want])
        np.testing.assert_array_equal(over, [w[1] for w in want])
        np.testing.assert_array_equal(err, [w[2] for w in want])
        assert pos.min() >= 0 and pos.max() < p.rev


@pytest.mark.parametrize("lines,fine_w,coarse_w", [(1, 8, 1), (2, 8, 1), (3, 8, 2), (5, 8, 3), (64, 8, 6),
                                                   (7, 9, 3)])
def test_period_number_range_and_wrap_exhaustive(lines, fine_w, coarse_w):
    """Every phase and code, offsets over the whole supported range: n in [-2, LINES+1] before the
    wrap (so one add or subtract of LINES suffices, as in the RTL), and pos_abs = (n mod LINES) 2^F + phase,
    the output of every trusted sample."""
    p = PeriodCountParams(fine_w, lines, coarse_w)
    m = 1 << fine_w
    ph, co = np.meshgrid(np.arange(m), np.arange(1 << coarse_w))
    ph, co = ph.ravel(), co.ravel()
    n_min, n_max = 0, 0
    for ofs in range(-m, m + 1, 7 if m > 256 else 3):
        for o in (ofs, -m, m):
            d = ((co * lines) << (fine_w - coarse_w)) + o - ph
            n = (d + m // 2) >> fine_w
            n_min, n_max = min(n_min, int(n.min())), max(n_max, int(n.max()))
            pos_abs, r = coarse_absolute(ph, co, o, p)
            np.testing.assert_array_equal(pos_abs, np.mod(n, lines) * m + ph)
            np.testing.assert_array_equal(r, d - n * m)
            pos, _, err = period_count(ph, co, o, p)
            trusted = np.abs(2 * r + 1) <= m // 2           # -m/4 <= r < m/4
            np.testing.assert_array_equal(pos[trusted], pos_abs[trusted])
            assert np.all(err[np.abs(r) > p.coarse_tol])         # the rest: the contract test
    assert -2 <= n_min and n_max <= lines + 1
    assert n_min == -2                                       # the range is reached
    with pytest.raises(ValueError, match="coarse_ofs"):
        period_count(ph, co, m + 1, p)


# ---------------------------------------------------------------------------- against the float engine


@pytest.mark.parametrize("p", [q for q in PARAMS if q.coarse_w and q.pos_w <= 40], ids=_pid)
def test_coarse_combination_equals_float_reference(p):
    """The float engine (fringe.dsp.position) gives the same position and flag: the budget is 0
    (only exact half-period ties differ: float rounds them to even, the hardware up)."""
    rng = np.random.default_rng(11)
    phase, coarse, ofs = stream(p, rng, 50_000)
    m = 1 << p.fine_w
    pos, _, err = period_count(phase, coarse, ofs, p)
    fpos, fflag = coarse_fine_combine(phase / m, coarse, p.lines, p.coarse_w, ofs / m, quantum=1 / m)
    d = ((coarse * p.lines) << (p.fine_w - p.coarse_w)) + ofs - phase
    tie = (d % m) == m // 2
    assert not np.all(tie)
    np.testing.assert_array_equal(pos[~tie] / m, fpos[~tie])
    np.testing.assert_array_equal(err[~tie], fflag[~tie])


@pytest.mark.parametrize("p", [q for q in PARAMS if not q.coarse_w], ids=_pid)
def test_counting_equals_float_reference(p):
    rng = np.random.default_rng(12)
    phase, _, _ = stream(p, rng, 50_000)
    m = 1 << p.fine_w
    pos, over, err = period_count(phase, None, 0, p)
    fpos, fover = count_periods(phase / m, p.lines)
    np.testing.assert_array_equal(pos / m, fpos)
    np.testing.assert_array_equal(over, fover)
    assert not err.any()


# ---------------------------------------------------------------------------- edge cases


@pytest.mark.parametrize("p", [PeriodCountParams(16, 256, 9), PeriodCountParams(14, 3, 0)], ids=_pid)
def test_overspeed_at_the_quarter_period(p):
    m = 1 << p.fine_w
    q = m // 4
    jumps = [q - 1, q, -(q - 1), -q, q + 1, m // 2 - 1, -(m // 2), m // 2, 0, 1, -1]
    want = [False, True, False, True, True, True, True, True, False, False, False]
    phase = [12345 % m]
    for j in jumps:
        phase.append((phase[-1] + j) % m)
    coarse = np.zeros(len(phase), dtype=np.int64)
    _, over, _ = period_count(np.array(phase), coarse, 0, p)
    assert not over[0]                                   # the first sample after reset never flags
    np.testing.assert_array_equal(over[1:], want)


def test_counting_starts_at_the_phase_and_wraps_both_ways():
    p = PeriodCountParams(8, 3, 0)
    phase = np.array([250, 10, 70, 130, 190, 250, 60, 0, 200, 150, 100, 50, 0, 255])
    pos, over, err = period_count(phase, None, 0, p)
    np.testing.assert_array_equal(pos, [250, 266, 326, 386, 446, 506, 572, 512, 456, 406, 356, 306, 256, 255])
    np.testing.assert_array_equal(over, [0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0])
    assert not err.any()
    # across the revolution: 767 -> 0 and back
    pos, _, _ = period_count(np.array([250, 255, 0, 5, 0, 255]), None, 0, p)
    np.testing.assert_array_equal(pos, [250, 255, 256, 261, 256, 255])
    pos, _, _ = period_count(np.array([0, 255, 0]), None, 0, PeriodCountParams(8, 1, 0))
    np.testing.assert_array_equal(pos, [0, 255, 0])


def test_coarse_code_wrap_and_period_edges():
    p = PeriodCountParams(12, 100, 8)
    span, m = p.coarse_span, 1 << p.fine_w
    true = np.array([0, 1, m - 1, m, p.rev - 1, p.rev - m, p.rev - m - 1, 50 * m + 7, span - 1, span])
    coarse = (true + span // 2 - span // 2) // span        # ofs = span/2: no misalignment
    pos, r = coarse_absolute(true % m, coarse, span // 2, p)
    np.testing.assert_array_equal(pos, true)
    assert not (np.abs(r) > p.coarse_tol).any()
    # misaligned by half a code: code 2^COARSE_W-1 spans the revolution wrap, then code 0
    ofs = span
    true = np.array([p.rev - 3, p.rev - 1, 0, 5, span // 2 - 1, span // 2, span // 2 + 1])
    coarse = (np.mod(true + span // 2 - ofs, p.rev) // span) % 256
    np.testing.assert_array_equal(coarse, [255, 255, 255, 255, 255, 0, 0])
    pos, r = coarse_absolute(true % m, coarse, ofs, p)
    np.testing.assert_array_equal(pos, true)
    assert not (np.abs(r) > p.coarse_tol).any()


def test_wrong_codes_are_flagged_beyond_the_tolerance():
    p = PeriodCountParams(16, 256, 9)
    m, tol, span = 1 << p.fine_w, p.coarse_tol, p.coarse_span
    assert tol == (256 << 5) + (1 << 14) == span // 2 + (m // 2 - span // 2) // 2
    codes = np.array([3, 3, 3, 3, 511, 511])
    r = np.array([tol, tol + 1, -tol, -tol - 1, tol + 1, -tol])
    phase = np.mod(codes * span + span // 2 - r, m)
    _, _, err = period_count(phase, codes, span // 2, p)
    np.testing.assert_array_equal(err, [0, 1, 0, 1, 1, 0])


def test_scalar_and_per_sample_offsets_agree():
    p = PeriodCountParams(12, 100, 8)
    phase, coarse, ofs = stream(p, np.random.default_rng(3), 1000)
    a = period_count(phase, coarse, ofs, p)
    b = period_count(phase, coarse, np.full(phase.size, ofs), p)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    ofs2 = np.where(np.arange(phase.size) < 500, ofs, -ofs)
    pos, _, _ = period_count(phase, coarse, ofs2, p)
    pos_abs, r = coarse_absolute(phase, coarse, -ofs, p)
    trusted = np.abs(2 * r + 1) <= p.trust * 2           # -TRUST <= r < TRUST
    assert trusted[500:].sum() >= 10
    np.testing.assert_array_equal(pos[500:][trusted[500:]], pos_abs[500:][trusted[500:]])


def test_empty_stream():
    for p in (PeriodCountParams(12, 100, 8), PeriodCountParams(12, 100, 0)):
        pos, over, err = period_count(np.array([], dtype=np.int64), np.array([], dtype=np.int64), 0, p)
        assert pos.size == over.size == err.size == 0


# ---------------------------------------------------------------------------- parameters


def test_derived_constants():
    p = PeriodCountParams(16, 256, 9)
    assert (p.rev, p.pos_w, p.coarse_span, p.coarse_tol, p.latency) == (1 << 24, 24, 1 << 15, (1 << 13) + (1 << 14), 4)
    p = PeriodCountParams(12, 100, 8)
    assert (p.rev, p.pos_w, p.coarse_span, p.coarse_tol) == (409600, 19, 1600, 400 + 1024)
    p = PeriodCountParams(16, 1, 0)
    assert (p.rev, p.pos_w, p.coarse_span, p.coarse_tol) == (1 << 16, 16, 0, 0)
    assert PeriodCountParams(30, 200_000, 18).pos_w == 48
    assert rev_and_pos_w(3, 14) == (3 << 14, 16) and rev_and_pos_w(1, 8) == (256, 8)
    assert [clog2(v) for v in (1, 2, 3, 4, 5, 1 << 20)] == [0, 1, 2, 2, 3, 20]
    for lines in list(range(1, 70)) + [1000, 3600, (1 << 20) - 1, 1 << 20]:
        assert rev_and_pos_w(lines, 8)[1] == math.ceil(math.log2(lines << 8) - 1e-12)
    assert PeriodCountParams(16, 256, 9).hdl_parameters() == {"FINE_W": 16, "LINES": 256, "COARSE_W": 9}
    assert LATENCY == 4


@pytest.mark.parametrize(
    "args, msg",
    [
        ((7, 256, 0), "fringe_period_count: FINE_W = 7 out of range 8..30"),
        ((31, 256, 0), "fringe_period_count: FINE_W = 31 out of range 8..30"),
        ((16, 0, 0), "fringe_period_count: LINES = 0 out of range 1..2^20"),
        ((16, (1 << 20) + 1, 0), "fringe_period_count: LINES = 1048577 out of range 1..2^20"),
        ((30, (1 << 18) + 1, 0), "fringe_period_count: POS_W = FINE_W + clog2(LINES) = 49 exceeds 48"),
        ((16, 256, 15), "fringe_period_count: COARSE_W = 15 out of range: 0 (no coarse code) or 1..24 with "
                        "COARSE_W <= FINE_W - 2"),
        ((16, 256, -1), "fringe_period_count: COARSE_W = -1 out of range"),
        ((30, 256, 25), "fringe_period_count: COARSE_W = 25 out of range"),
        ((16, 257, 8), "fringe_period_count: 2^COARSE_W = 256 is less than LINES = 257"),
        ((16.0, 256, 9), "fringe_period_count: FINE_W must be an integer"),
        ((16, 256, True), "fringe_period_count: COARSE_W must be an integer"),
    ],
)
def test_parameter_validation(args, msg):
    with pytest.raises(ValueError, match=re.escape(msg)):
        PeriodCountParams(*args)


def test_hdl_messages_match_model():
    """The HDL checks carry the model's messages (plus the instance path in Verilog)."""
    v, h = block_texts("fringe_period_count")
    ranges = (("FINE_W", "8..30"), ("LINES", "1..2^20"))
    assert not missing_checks("fringe_period_count", ranges, pos_w_max=48)
    tail = "out of range: 0 (no coarse code) or 1..24 with COARSE_W <= FINE_W - 2"
    assert f"COARSE_W = %0d {tail} (instance %m)" in v and f'" {tail}"' in h
    assert "2^COARSE_W = %0d is less than LINES = %0d (instance %m)" in v and '" is less than LINES = "' in h


def test_input_validation():
    p = PeriodCountParams(12, 100, 8)
    ok = np.array([0, 1])
    with pytest.raises(ValueError, match="phase = 4096 outside 0..4095"):
        period_count(np.array([0, 4096]), ok, 0, p)
    with pytest.raises(ValueError, match="coarse = 256 outside 0..255"):
        period_count(ok, np.array([0, 256]), 0, p)
    with pytest.raises(ValueError, match="coarse_ofs = 4097 outside -4096..4096"):
        period_count(ok, ok, 4097, p)
    with pytest.raises(ValueError, match="coarse codes are required"):
        period_count(ok, None, 0, p)
    with pytest.raises(ValueError, match="differs from phase shape"):
        period_count(ok, np.array([1]), 0, p)
    with pytest.raises(ValueError, match="must be integers"):
        period_count(np.array([0.5]), np.array([0]), 0, p)
    with pytest.raises(ValueError, match="one-dimensional"):
        period_count(np.zeros((2, 2), dtype=np.int64), np.zeros((2, 2), dtype=np.int64), 0, p)
    with pytest.raises(ValueError, match="one value per sample"):
        period_count(ok, ok, np.array([0, 0, 0]), p)
    # without a coarse code the coarse inputs are ignored
    pos, _, _ = period_count(ok, None, 10**9, PeriodCountParams(12, 100, 0))
    np.testing.assert_array_equal(pos, [0, 1])


# ---------------------------------------------------------------------------- speed




# ---------------------------------------------------------------------------- edge jitter


SPANS = [PeriodCountParams(12, 64, 6),     # span 1 period: every jittered edge flips n by one
         PeriodCountParams(10, 96, 7),     # span 3/4
         PeriodCountParams(12, 64, 7),     # span 1/2
         PeriodCountParams(12, 64, 8)]     # span 1/4


def jittered(p: PeriodCountParams, rng: np.random.Generator, n: int, jitter: float, misalign: float):
    """A wandering position under a quarter period a sample (no overspeed) and the code a reader whose
    edges jitter uniformly by +-jitter period gives, with the offset misaligned by misalign period."""
    period = 1 << p.fine_w
    speed = np.clip(np.cumsum(rng.normal(0, 0.01, n)), -0.2, 0.2) + rng.normal(0, 0.01, n)
    steps = np.round(np.clip(speed, -0.24, 0.24) * period).astype(np.int64)
    true = np.mod(int(rng.integers(0, p.rev)) + np.cumsum(steps), p.rev)
    ofs = p.coarse_span // 2 + int(round(misalign * period))
    jit = np.round(rng.uniform(-jitter, jitter, n) * period).astype(np.int64)
    coarse = (np.mod(true + jit, p.rev) // p.coarse_span) % (1 << p.coarse_w)
    return true, true & (period - 1), coarse, ofs


@pytest.mark.parametrize("p", SPANS, ids=_pid)
def test_edge_jitter_under_a_quarter_period_never_slips(p):
    """Jitter plus misalignment under a quarter period: every output from the first trusted sample on
    is the true position (at span <= 1/2 every output), and no coarse_err beyond today's |r| > COARSE_TOL;
    the absolute combination alone slips at span >= 3/4."""
    rng = np.random.default_rng(p.coarse_w * 1000 + p.lines)
    slips_abs = 0
    for _ in range(20):
        misalign = rng.uniform(-0.04, 0.04)
        true, phase, coarse, ofs = jittered(p, rng, 3000, 0.24 - abs(misalign), misalign)
        pos, over, err = period_count(phase, coarse, ofs, p)
        pos_abs, r = coarse_absolute(phase, coarse, ofs, p)
        trusted = (r >= -p.trust) & (r < p.trust)
        first = int(np.argmax(trusted))
        assert trusted.any() and not over.any()
        np.testing.assert_array_equal(pos[first:], true[first:])
        if p.coarse_span * 2 <= 1 << p.fine_w:
            np.testing.assert_array_equal(pos, true)
            np.testing.assert_array_equal(pos, pos_abs)          # unchanged from the absolute combination
        np.testing.assert_array_equal(err, np.abs(r) > p.coarse_tol)
        slips_abs += int(np.sum(pos_abs != true))
        # the float twin: the same positions and flags (no exact half-period ties here)
        m = 1 << p.fine_w
        fpos, fflag = coarse_fine_combine(phase / m, coarse, p.lines, p.coarse_w, ofs / m, quantum=1 / m)
        np.testing.assert_array_equal(np.round(fpos * m).astype(np.int64), pos)
        np.testing.assert_array_equal(fflag, err)
    if p.coarse_span * 4 >= 3 << p.fine_w:
        assert slips_abs > 100


@pytest.mark.parametrize("p", SPANS, ids=_pid)
def test_a_really_wrong_code_is_never_silent(p):
    """Isolated codes off by 1..3 (a broken reader, not jitter): every output that is not the true
    position carries coarse_err, and wrong codes on trusted samples are flagged. (A wrong code repeated
    on the trusted samples after a resync agrees with the track it set: see the model's docstring.)"""
    rng = np.random.default_rng(7 + p.coarse_w)
    flagged_wrong = 0
    for _ in range(20):
        true, phase, coarse, ofs = jittered(p, rng, 3000, 0.1, 0.02)
        bad = np.arange(100, 2900, 200) + rng.integers(-50, 50, 14)
        coarse[bad] = (coarse[bad] + rng.choice([1, -1, 2, -2, 3, -3], bad.size)) % (1 << p.coarse_w)
        pos, over, err = period_count(phase, coarse, ofs, p)
        _, r = coarse_absolute(phase, coarse, ofs, p)
        trusted = (r >= -p.trust) & (r < p.trust)
        first = int(np.argmax(trusted))
        assert first < 50
        wrong = pos != true
        assert np.all(err[first:][wrong[first:]])
        flagged_wrong += int(np.sum(err[bad] & trusted[bad]))
    assert flagged_wrong > 20


# ---------------------------------------------------------------------------- start-up near a code edge


START = [PeriodCountParams(16, 64, 6),     # span 1 period, the validation recording's configuration
         PeriodCountParams(12, 64, 6),
         PeriodCountParams(14, 256, 8)]    # span 1 period, more lines (at span < 1 a flip moves r, not n)


def slow_start(p: PeriodCountParams, rng: np.random.Generator, n: int, gap: int, jitter: int, speed: float,
               noise: int = 3):
    """A slow motion from reset that starts ``gap`` fine counts inside a code, moves towards its edge and on
    across it (a quarter period past it, into the trusted band of the next code), and the code a reader
    whose edge moves by a uniform jitter in [-jitter, jitter] counts per sample gives (the true code
    index of the jittered position). Returns (true, phase, coarse, ofs)."""
    period, span = 1 << p.fine_w, p.coarse_span
    sign = 1 if rng.random() < 0.5 else -1                   # towards the upper or the lower edge
    edge = int(rng.integers(1, 1 << p.coarse_w)) * span      # calibrated offset: edges at k * span
    x0 = edge - sign * gap
    true = x0 + sign * np.round(np.arange(n) * speed).astype(np.int64) + rng.integers(-noise, noise + 1, n)
    true = np.mod(true, p.rev)
    jit = rng.integers(-jitter, jitter + 1, n)
    coarse = (np.mod(true + jit, p.rev) // span) % (1 << p.coarse_w)
    return true, true & (period - 1), coarse, span // 2


def old_rule_startup(p: PeriodCountParams, phase, coarse, ofs) -> tuple[list[int], int]:
    """The rule before the start-up anchor, written out: every sample before the first trusted one since
    reset outputs the code's position. Returns those outputs and the first trusted index."""
    period = 1 << p.fine_w
    out = []
    for ph, co in zip(phase.tolist(), coarse.tolist(), strict=True):
        d = ((co * p.lines) << (p.fine_w - p.coarse_w)) + ofs - ph
        n = (d + period // 2) // period
        r = d - n * period
        if -period // 4 <= r < period // 4:
            return out, len(out)
        out.append((n % p.lines) * period + ph)
    return out, len(out)


@pytest.mark.parametrize("p", START, ids=_pid)
def test_a_slow_start_at_a_jittered_edge_is_never_a_period_off(p):
    """The validation recording's failure: a slow start a few hundred counts (scaled to FINE_W) from a code
    edge whose jitter flips the code. Taking every code before the first trusted sample put samples a
    period off; anchoring on the sample nearest its code's centre does not, as long as the first sample
    lies beyond the jitter (a sample nearer the edge has a larger m and is tracked)."""
    rng = np.random.default_rng(100 + p.fine_w)
    period = 1 << p.fine_w
    scale = period / 65536
    old_off = 0
    for _ in range(20):
        gap = int(rng.integers(200, 400) * scale) + 6
        jitter = gap - 5                                     # a sample at the start is never flipped
        speed = rng.uniform(2, 12) * scale
        n = int((gap + period // 4 + 200 * scale) / speed) + 50
        true, phase, coarse, ofs = slow_start(p, rng, n, gap, jitter, speed, noise=max(1, int(3 * scale)))
        pos, over, err = period_count(phase, coarse, ofs, p)
        old, first = old_rule_startup(p, phase, coarse, ofs)
        assert 100 < first < n and not over.any()
        np.testing.assert_array_equal(pos, true)             # no sample a period off, before and after trust
        assert not err.any()                                 # edge jitter is not a wrong code
        old_off += int(np.sum(np.array(old) != true[:first]))
    assert old_off > 100                                     # the old rule fails on these very streams


@pytest.mark.parametrize("p", START, ids=_pid)
def test_a_start_inside_the_jitter_flickers_less_than_taking_every_code(p):
    """Starting within the jitter of an edge, the first code may be a period off and nothing can tell
    until a sample beyond the jitter: from there every output is right. Until then a new anchor is
    taken only on a sample nearer its code's centre than every one before, so the output jumps between
    right and a period off far less often than with every code taken (about as many samples are off)."""
    rng = np.random.default_rng(200 + p.fine_w)
    period = 1 << p.fine_w
    scale = period / 65536
    new_jumps = old_jumps = 0
    for _ in range(20):
        jitter = int(300 * scale) + 4
        gap = int(rng.integers(0, jitter))
        speed = rng.uniform(2, 12) * scale
        n = int((gap + period // 4 + 200 * scale) / speed) + 50
        true, phase, coarse, ofs = slow_start(p, rng, n, gap, jitter, speed, noise=max(1, int(3 * scale)))
        pos, _, _ = period_count(phase, coarse, ofs, p)
        old, first = old_rule_startup(p, phase, coarse, ofs)
        np.testing.assert_array_equal(pos[first:], true[first:])
        _, r = coarse_absolute(phase, coarse, ofs, p)
        beyond = int(np.argmax(np.abs(np.abs(r) - period // 2) > jitter + 1))   # first sample past the jitter
        np.testing.assert_array_equal(pos[beyond:], true[beyond:])
        new_jumps += int(np.sum(np.diff((pos[:first] != true[:first]).astype(int)) != 0))
        old_jumps += int(np.sum(np.diff((np.array(old) != true[:first]).astype(int)) != 0))
    assert old_jumps > 200 and new_jumps < old_jumps / 4


def _in_pieces(p, phase, coarse, ofs, cuts):
    """period_count over pieces, each resumed from the last sample of the one before (as CoreStream)."""
    out, start, state, k = [], None, (False, False, None), 0
    for a, b in zip([0, *cuts], [*cuts, len(phase)], strict=True):
        lo = a - k
        sl = slice(lo, b)
        pos, over, err = period_count(phase[sl], coarse[sl], ofs, p, start, *state)
        seen, lost, bad, am = track_state(phase[sl], coarse[sl], ofs, p, start, *state)
        out.append(np.stack([pos, over, err])[:, k:])
        start, state, k = int(pos[-1]), (bool(lost[-1]), bool(bad[-1]), None if seen[-1] else int(am[-1])), 1
    return np.concatenate(out, axis=1)


@pytest.mark.parametrize("p", START + [PeriodCountParams(12, 100, 8)], ids=_pid)
def test_a_stream_in_pieces_gives_the_words_of_one_run(p):
    """Resumed with track_state (anchor_m included), pieces cut before, at and after the first trusted
    sample give every word of the whole run; without anchor_m (a restart before trust) they would not."""
    rng = np.random.default_rng(300 + p.fine_w)
    period = 1 << p.fine_w
    scale = period / 65536
    restarted_differs = False
    for i in range(12):
        jitter = int(300 * scale) + 4
        gap = int(rng.integers(0, 2 * jitter))
        speed = rng.uniform(2, 12) * scale
        n = int((gap + period // 4 + 200 * scale) / speed) + 50
        true, phase, coarse, ofs = slow_start(p, rng, n, gap, jitter, speed, noise=max(1, int(3 * scale)))
        if i % 3 == 2:                                       # overspeed restarts before trust
            jumps = rng.choice(n // 2, 3, replace=False)
            phase = phase.copy()
            for j in jumps:
                phase[j:] = (phase[j:] + period // 4 + 3) & (period - 1)
        whole = np.stack(period_count(phase, coarse, ofs, p))
        _, first = old_rule_startup(p, phase, coarse, ofs)
        cuts = np.unique(np.r_[np.sort(rng.choice(np.arange(1, n), 8, replace=False)), first, first + 1,
                               rng.integers(1, max(2, first), 3)])
        cuts = cuts[(cuts > 0) & (cuts < n)]
        np.testing.assert_array_equal(_in_pieces(p, phase, coarse, ofs, cuts), whole)
        # restarting before trust (the old CoreStream) at a sample whose code is a period off loses the anchor
        pos_abs, _ = coarse_absolute(phase, coarse, ofs, p)
        off = np.flatnonzero(pos_abs[:first] != whole[0, :first])
        if off.size:
            c = int(off[-1])
            again = np.stack(period_count(phase[c:], coarse[c:], ofs, p))
            restarted_differs |= bool(np.any(again != whole[:, c:]))
            np.testing.assert_array_equal(_in_pieces(p, phase, coarse, ofs, [c, c + 1]), whole)
    assert restarted_differs == (p.coarse_span == 1 << p.fine_w)     # at span 1/4 no code is a period off
