"""Bit-exact long-period model (fringe.fixed.long_period): index mapping, contract, error budget, limits."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hdl_text import block_texts, missing_checks

from fringe.fixed.long_period import (
    LATENCY,
    LongPeriodParams,
    check_index_mapping,
    error_budget,
    error_terms,
    index_mapping,
    long_period,
    long_period_words,
    make_table,
    pack_words,
    slopes,
    unpack_words,
)

PARAMS = [
    LongPeriodParams(256, 16, 8, 18, 4, 8),     # the core's default
    LongPeriodParams(256, 16, 8, 32, 8, 16),    # widest words; 2^(LP_W-LP_FRAC) = REV
    LongPeriodParams(100, 12, 6, 14, 0, 6),     # REV not a power of two, no rounding term
    LongPeriodParams(1, 16, 10, 18, 4, 8),
    LongPeriodParams(3, 10, 11, 13, 2, 6),      # more entries than periods, odd REV
    LongPeriodParams(2500, 16, 10, 20, 4, 8),
    LongPeriodParams(999_999, 20, 16, 24, 4, 16),   # LP_RECIP ~ 2^39: wide index product
]


def _pid(p: LongPeriodParams) -> str:
    return f"L{p.lines}-F{p.fine_w}-A{p.lp_addr_w}-W{p.lp_w}-FR{p.lp_frac}-IF{p.lp_if}"


# ---------------------------------------------------------------------------- index mapping


def _entry_ends(rev: int, n: int) -> list[int]:
    """First and last position of every entry (exact integers)."""
    out = []
    for k in range(n):
        a = -(-(k * rev) // n)                 # ceil(k REV / N)
        b = -(-((k + 1) * rev) // n) - 1
        out += [a, b]
    return out


@pytest.mark.parametrize("fine_w", [8, 9])
def test_index_mapping_exhaustive_small(fine_w):
    """Every position of every small REV: the entry is exactly floor(pos 2^LP_ADDR_W / REV), and the
    fraction is the exact one or above it by less than 2^LP_IF / b + 1 LSB."""
    for lines in range(1, 41):
        rev = lines << fine_w
        pos = np.arange(rev, dtype=np.int64)
        for addr in range(2, min(16, rev.bit_length() - 1) + 1):
            for lp_if in (1, 4, 8):
                recip, shift = index_mapping(lines, fine_w, addr, lp_if)
                t = pos * recip
                np.testing.assert_array_equal(t >> shift, (pos << addr) // rev,
                                              err_msg=f"LINES={lines} A={addr} IF={lp_if}")
                frac = (t >> (shift - lp_if)) & ((1 << lp_if) - 1)
                exact = ((pos << (addr + lp_if)) // rev) & ((1 << lp_if) - 1)
                b = rev // math.gcd(rev, 1 << addr)
                dev = frac - exact
                assert dev.min() >= 0 and dev.max() <= math.ceil((1 << lp_if) / b)


@pytest.mark.parametrize("lines,fine_w,addr,lp_if", [
    (256, 16, 8, 8), (100, 12, 6, 6), (2500, 16, 10, 8), (3600, 16, 12, 8), (1000, 20, 16, 16),
    (999_999, 20, 16, 16), ((1 << 20) - 1, 28, 16, 16), ((1 << 20) - 3, 16, 2, 1), (3, 30, 16, 16)])
def test_index_mapping_large_by_bound_and_entry_ends(lines, fine_w, addr, lp_if):
    """Large REV: the bound holds, and (the index being monotonic in pos) the first and the last
    position of every entry map to it, which makes every position in between map to it too."""
    recip, shift = index_mapping(lines, fine_w, addr, lp_if)
    check_index_mapping(lines, fine_w, addr, lp_if, recip, shift)
    rev = lines << fine_w
    n = 1 << addr
    ends = _entry_ends(rev, n)
    got = [(q * recip) >> shift for q in ends]
    assert got == [k for k in range(n) for _ in (0, 1)]
    # the smallest shift: one less fails the bound (unless it is LP_IF)
    if shift > lp_if:
        r1 = -(-(1 << (addr + shift - 1)) // rev)
        with pytest.raises(ValueError, match="do not map every position"):
            check_index_mapping(lines, fine_w, addr, lp_if, r1, shift - 1)
    # LP_RECIP stays about REV or below (the VHDL limit 2^31 holds for REV < 2^30)
    assert recip <= 2 * rev
    if rev < 1 << 30:
        assert recip < 1 << 31


def test_power_of_two_rev_gives_a_power_of_two_recip():
    for lines in (1, 2, 4, 256, 1 << 20):
        for fine_w in (8, 16, 28):
            for addr in (2, 8, 16):
                if (lines << fine_w) < (1 << addr) or fine_w + lines.bit_length() - 1 > 48:
                    continue
                for lp_if in (1, 8, 16):
                    recip, shift = index_mapping(lines, fine_w, addr, lp_if)
                    assert recip & (recip - 1) == 0, (lines, fine_w, addr, lp_if, recip)
                    assert shift == max(lp_if, fine_w + lines.bit_length() - 1 - addr)


def test_check_index_mapping_rejects_wrong_pairs():
    check_index_mapping(256, 16, 8, 8, 1, 16)
    check_index_mapping(256, 16, 8, 8, 2, 17)                 # not the smallest, but correct
    for recip, shift in ((2, 16), (1, 15), (0, 16), (3, 17)):
        with pytest.raises(ValueError, match=re.escape(f"LP_RECIP = {recip}, LP_SHIFT = {shift} do not map")):
            check_index_mapping(256, 16, 8, 8, recip, shift)
    recip, shift = index_mapping(100, 12, 6, 6)
    assert (recip, shift) == (335545, 31)
    with pytest.raises(ValueError, match="do not map"):
        check_index_mapping(100, 12, 6, 6, recip - 1, shift)
    with pytest.raises(ValueError, match=r"LP_SHIFT = 5 out of range LP_IF = 6 \.\. 127"):
        check_index_mapping(100, 12, 6, 6, recip, 5)


# ---------------------------------------------------------------------------- the contract, literally


def contract(pos: int, slope: list[int], value: list[int], zero: int, direction: int, p: LongPeriodParams) -> int:
    """docs/architecture.md on Python integers, one sample."""
    t = pos * p.recip
    e = t >> p.shift
    f = (t >> (p.shift - p.lp_if)) % (1 << p.lp_if)
    corr = value[e] + ((slope[e] * f + (1 << (p.lp_if - 1))) >> p.lp_if)
    step = (corr + (1 << (p.lp_frac - 1))) >> p.lp_frac if p.lp_frac else corr
    pos_c = (pos - step) % p.rev
    return (zero - pos_c) % p.rev if direction else (pos_c + zero) % p.rev


def harmonic_fn(p: LongPeriodParams, rng, amp: float, orders: int):
    a = rng.uniform(-1, 1, (orders, 2)) * amp / orders

    def f(pos):
        x = 2 * np.pi * np.asarray(pos, dtype=float) / p.rev
        return sum(a[m, 0] * np.cos((m + 1) * x) + a[m, 1] * np.sin((m + 1) * x) for m in range(orders))

    return f


def positions(p: LongPeriodParams, rng, n: int) -> np.ndarray:
    ends = np.array(_entry_ends(p.rev, p.entries)[:64] + [0, 1, p.rev - 2, p.rev - 1], dtype=np.int64)
    return np.concatenate([rng.integers(0, p.rev, n), ends, np.mod(ends + 1, p.rev)])


@pytest.mark.parametrize("p", PARAMS, ids=_pid)
def test_vectorised_model_matches_the_contract(p):
    rng = np.random.default_rng(9)
    amp = 0.9 * 2.0 ** (p.lp_w - 1 - p.lp_frac)
    smooth = make_table(harmonic_fn(p, rng, amp, 4), p)
    w = p.lp_w
    raw = [int(s) << w | int(v) for s, v in rng.integers(0, 1 << w, (p.entries, 2))]
    raw[:4] = [(1 << (w - 1)) << w | (1 << (w - 1)), ((1 << (w - 1)) - 1) << w | ((1 << (w - 1)) - 1),
               (1 << (w - 1)) << w | ((1 << (w - 1)) - 1), 0]
    words = np.array([pack_words(smooth, p).astype(np.uint64), np.array(raw, dtype=np.uint64)])
    pos = positions(p, rng, 2000)
    zero = np.where(rng.random(pos.size) < 0.5, rng.integers(0, p.rev, pos.size), rng.choice([0, p.rev - 1], pos.size))
    d = rng.integers(0, 2, pos.size)
    bank = rng.integers(0, 2, pos.size)
    out = long_period_words(pos, words, zero, d, p, bank=bank)
    sl, val = unpack_words(words, p)
    sl, val = [x.tolist() for x in sl], [x.tolist() for x in val]
    want = [contract(int(q), sl[b], val[b], int(z), int(dd), p)
            for q, z, dd, b in zip(pos, zero, d, bank, strict=True)]
    np.testing.assert_array_equal(out, want)
    assert out.min() >= 0 and out.max() < p.rev
    # from values (slopes derived) = from the packed words
    np.testing.assert_array_equal(long_period(pos, smooth, zero, d, p),
                                  long_period_words(pos, pack_words(smooth, p), zero, d, p))


def test_direction_zero_and_wrap():
    p = LongPeriodParams(lines=4, fine_w=10, lp_addr_w=4, lp_w=12, lp_frac=2, lp_if=4)
    zeros = np.zeros(16, dtype=np.int64)
    pos = np.array([0, 1, 4095, 2000])
    np.testing.assert_array_equal(long_period(pos, zeros, 10, 0, p), (pos + 10) % 4096)
    np.testing.assert_array_equal(long_period(pos, zeros, 10, 1, p), (10 - pos) % 4096)
    np.testing.assert_array_equal(long_period(pos, zeros, 4095, 0, p), (pos + 4095) % 4096)
    threes = np.full(16, 3 * 4, dtype=np.int64)                 # 3 fine counts everywhere
    np.testing.assert_array_equal(long_period(pos, threes, 0, 0, p), (pos - 3) % 4096)
    np.testing.assert_array_equal(long_period(pos, -threes, 0, 1, p), (-(pos + 3)) % 4096)
    # rounding half up: 2.5 counts -> 3, -2.5 -> -2
    np.testing.assert_array_equal(long_period(pos, np.full(16, 10), 0, 0, p), (pos - 3) % 4096)
    np.testing.assert_array_equal(long_period(pos, np.full(16, -10), 0, 0, p), (pos + 2) % 4096)


def test_interpolation_between_entries():
    """A ramp over one entry is followed count by count (LP_IF bits of the position in the entry)."""
    p = LongPeriodParams(lines=1, fine_w=12, lp_addr_w=4, lp_w=12, lp_frac=0, lp_if=8)   # 256 counts per entry
    values = np.zeros(16, dtype=np.int64)
    values[3] = 256
    pos = np.arange(2 * 256, 5 * 256)
    pc = long_period(pos, values, 0, 0, p)
    corr = pos - pc
    k = pos // 256
    f = pos % 256
    want = np.where(k == 2, f, np.where(k == 3, 256 - f, 0))
    np.testing.assert_array_equal(corr, want)


# ---------------------------------------------------------------------------- against float


@pytest.mark.parametrize("p", [q for q in PARAMS if q.lines != 999_999], ids=_pid)
@pytest.mark.parametrize("orders", [1, 4, 8])
def test_model_within_error_budget(p, orders):
    """|output - ideal| <= error_budget for smooth corrections (harmonics up to N/8), the ideal
    being pos - c(pos), then zero and direction, in real numbers."""
    if orders > p.entries // 8:
        pytest.skip("harmonic above N/8")
    rng = np.random.default_rng(orders)
    amp = 0.4 * 2.0 ** (p.lp_w - 1 - p.lp_frac) / (1 + orders * 2 * math.pi / p.entries * 4)
    fn = harmonic_fn(p, rng, amp, orders)
    values = make_table(fn, p)
    budget = error_budget(p, values)
    pos = positions(p, rng, 200_000)
    zero = int(rng.integers(0, p.rev))
    for d in (0, 1):
        out = long_period(pos, values, zero, d, p)
        ideal = pos - fn(pos)
        ideal = (zero - ideal) if d else (ideal + zero)
        err = np.mod(out - ideal + p.rev / 2, p.rev) - p.rev / 2
        assert np.abs(err).max() <= budget, (np.abs(err).max(), budget, error_terms(p, values))
    # the budget is not vacuous: its dominant parts are reached within a factor of 4
    assert np.abs(err).max() >= 0.25 * (budget - error_terms(p, values)["fraction"])


def test_error_terms():
    p = LongPeriodParams(256, 16, 8, 18, 4, 8)
    flat = np.full(256, 40)
    t = error_terms(p, flat)
    assert t["interpolation"] == 0 and t["fraction"] == 0
    assert t["quantisation"] == t["interp_rounding"] == 1 / 32 and t["output_rounding"] == 0.5
    assert error_budget(p, flat) == pytest.approx(0.5 + 1 / 16)
    para = np.zeros(256)
    para[10] = 160                                  # second difference 320 LSB = 20 counts
    t = error_terms(p, para)
    assert t["interpolation"] == pytest.approx(1.25 * 320 / 8 / 16)
    assert t["fraction"] == pytest.approx(160 * (2 ** -8 + 2 ** -16) / 16)
    assert error_terms(LongPeriodParams(100, 12, 6, 14, 0, 6), np.zeros(64))["output_rounding"] == 0


# ---------------------------------------------------------------------------- tables


def test_make_table_samples_the_entry_points_and_rounds():
    p = LongPeriodParams(100, 12, 6, 14, 2, 6)
    seen = []

    def fn(pos):
        seen.append(np.array(pos))
        return np.full(len(pos), 1.125)             # 4.5 LSB -> 5 (half up)

    v = make_table(fn, p)
    np.testing.assert_allclose(seen[0], np.arange(64) * p.rev / 64)
    assert v.dtype == np.int64 and np.all(v == 5)
    assert np.all(make_table(lambda x: -1.125 + 0 * x, p) == -4)
    scalar = make_table(lambda x: math.sin(2 * math.pi * x / p.rev), p)
    np.testing.assert_array_equal(scalar, make_table(lambda x: np.sin(2 * np.pi * x / p.rev), p))


def test_make_table_range_checks():
    p = LongPeriodParams(256, 16, 8, 12, 2, 8)      # values s(12): +-512 counts
    with pytest.raises(ValueError, match="table entry 0: 512 fine counts does not fit s.12. with 2 fraction bits"):
        make_table(lambda x: 512.0 + 0 * x, p)
    make_table(lambda x: 511.0 + 0 * x, p)
    with pytest.raises(ValueError, match="table slope"):       # a step of 1000 counts: slope 4000 > 2047
        make_table(lambda x: np.where(x < p.rev / 2, -500.0, 500.0), p)
    with pytest.raises(ValueError, match="not finite"):
        make_table(lambda x: np.full(len(x), np.nan), p)


def test_pack_and_unpack():
    for p in (LongPeriodParams(256, 16, 8, 18, 4, 8), LongPeriodParams(256, 16, 8, 32, 8, 16)):
        rng = np.random.default_rng(1)
        lo, hi = -(1 << (p.lp_w - 1)), (1 << (p.lp_w - 1)) - 1
        v = np.cumsum(rng.integers(lo // 600, hi // 600, 256))
        v -= v[-1] * np.arange(256) // 255                      # closes the revolution
        v = np.clip(v, lo, hi)
        words = pack_words(v, p)
        assert words.dtype == (np.uint64 if p.lp_w == 32 else np.int64)
        assert int(words.min()) >= 0 and int(words.max()) < 1 << (2 * p.lp_w)
        sl, val = unpack_words(words, p)
        np.testing.assert_array_equal(val, v)
        np.testing.assert_array_equal(sl, slopes(v))
        assert slopes(v)[-1] == v[0] - v[-1]
    p = LongPeriodParams(256, 16, 8, 12, 2, 8)
    bad = np.zeros(256, dtype=np.int64)
    bad[5] = 2047
    bad[6] = -2048                                              # slope -4095
    with pytest.raises(ValueError, match="table slope 5"):
        pack_words(bad, p)
    with pytest.raises(ValueError, match="outside s.12."):
        pack_words(np.full(256, 2048), p)
    with pytest.raises(ValueError, match="shape"):
        pack_words(np.zeros(255, dtype=np.int64), p)


# ---------------------------------------------------------------------------- parameters


def test_derived_constants():
    p = LongPeriodParams(256, 16, 8, 18, 4, 8)
    assert (p.rev, p.pos_w, p.entries, p.word_w, p.latency, p.recip, p.shift) == (1 << 24, 24, 256, 36, 8, 1, 16)
    assert p.hdl_parameters() == {"LINES": 256, "FINE_W": 16, "LP_ADDR_W": 8, "LP_W": 18, "LP_FRAC": 4, "LP_IF": 8,
                                  "LP_RECIP": 1, "LP_SHIFT": 16}
    q = LongPeriodParams(256, 16, 8, 18, 4, 8, 2, 17)            # explicit (checked) mapping
    assert (q.recip, q.shift) == (2, 17)
    assert LATENCY == 8


@pytest.mark.parametrize(
    "args, msg",
    [
        ((256, 7, 8, 18, 4, 8), "fringe_long_period: FINE_W = 7 out of range 8..30"),
        ((0, 16, 8, 18, 4, 8), "fringe_long_period: LINES = 0 out of range 1..2^20"),
        (((1 << 18) + 1, 30, 8, 18, 4, 8), "fringe_long_period: POS_W = FINE_W + clog2(LINES) = 49 exceeds 48"),
        ((256, 16, 1, 18, 4, 8), "fringe_long_period: LP_ADDR_W = 1 out of range 2..16"),
        ((256, 16, 17, 18, 4, 8), "fringe_long_period: LP_ADDR_W = 17 out of range 2..16"),
        ((1, 8, 9, 16, 4, 8), "fringe_long_period: 2^LP_ADDR_W = 512 entries exceed REV = LINES * 2^FINE_W"),
        ((256, 16, 8, 7, 0, 8), "fringe_long_period: LP_W = 7 out of range 8..32"),
        ((256, 16, 8, 33, 12, 8), "fringe_long_period: LP_W = 33 out of range 8..32"),
        ((256, 16, 8, 18, 17, 8), "fringe_long_period: LP_FRAC = 17 out of range 0..16"),
        ((256, 16, 8, 18, -1, 8), "fringe_long_period: LP_FRAC = -1 out of range 0..16"),
        ((256, 16, 8, 18, 4, 0), "fringe_long_period: LP_IF = 0 out of range 1..16"),
        ((256, 16, 8, 18, 4, 17), "fringe_long_period: LP_IF = 17 out of range 1..16"),
        ((1, 16, 10, 21, 4, 8), "fringe_long_period: LP_W - LP_FRAC = 17: corrections up to 2^17 fine counts "
                                "exceed REV = LINES * 2^FINE_W"),
        ((256, 16, 8, 18, 4, 8, 1, 4), "fringe_long_period: LP_SHIFT = 4 out of range LP_IF = 8 .. 127"),
        ((256, 16, 8, 18, 4, 8, 2, 16), "fringe_long_period: LP_RECIP = 2, LP_SHIFT = 16 do not map every "
                                        "position to floor(pos * 2^LP_ADDR_W / REV); take them from index_mapping()"),
        ((256, 16, 8, 18, 4, 8, 1, None), "give both LP_RECIP and LP_SHIFT"),
        ((256, 16, 8.0, 18, 4, 8), "fringe_long_period: LP_ADDR_W must be an integer"),
    ],
)
def test_parameter_validation(args, msg):
    with pytest.raises(ValueError, match=re.escape(msg)):
        LongPeriodParams(*args)


def test_corrections_up_to_rev_are_allowed():
    LongPeriodParams(1, 16, 10, 20, 4, 8)           # 2^16 = REV: one add or subtract still suffices
    LongPeriodParams(256, 16, 8, 32, 8, 16)


def test_hdl_messages_match_model():
    """The HDL checks carry the model's messages (plus the instance path in Verilog)."""
    v, h = block_texts("fringe_long_period")
    ranges = (("FINE_W", "8..30"), ("LINES", "1..2^20"), ("LP_ADDR_W", "2..16"), ("LP_W", "8..32"),
              ("LP_FRAC", "0..16"), ("LP_IF", "1..16"))
    assert not missing_checks("fringe_long_period", ranges, pos_w_max=48)
    for frag in ("entries exceed REV = LINES * 2^FINE_W", "fine counts exceed REV = LINES * 2^FINE_W",
                 " .. 127"):
        assert frag in v and frag in h, frag
    # the mapping message: written out in Verilog, built by fringe_pkg's check_mapping in VHDL
    assert "do not map every position to floor(pos * 2^LP_ADDR_W / REV);" in v and "take them from index_mapping()" in v
    assert 'check_mapping("fringe_long_period", "LP", "LP_ADDR_W", "index_mapping"' in h


def test_input_validation():
    p = LongPeriodParams(100, 12, 6, 14, 0, 6)
    t = np.zeros(64, dtype=np.int64)
    with pytest.raises(ValueError, match="pos outside"):
        long_period(np.array([p.rev]), t, 0, 0, p)
    with pytest.raises(ValueError, match="zero outside"):
        long_period(np.array([0]), t, p.rev, 0, p)
    with pytest.raises(ValueError, match="direction must be 0 or 1"):
        long_period(np.array([0]), t, 0, 2, p)
    with pytest.raises(ValueError, match="need a bank per sample"):
        long_period(np.array([0]), np.stack([t, t]), 0, 0, p)
    with pytest.raises(ValueError, match="bank outside 0..1"):
        long_period(np.array([0]), np.stack([t, t]), 0, 0, p, bank=np.array([2]))
    with pytest.raises(ValueError, match="shape"):
        long_period(np.array([0]), np.zeros(63, dtype=np.int64), 0, 0, p)
    with pytest.raises(ValueError, match="must be integers"):
        long_period(np.array([0.5]), t, 0, 0, p)


# ---------------------------------------------------------------------------- speed


