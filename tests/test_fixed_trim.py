"""Unit tests of the bit-exact fringe_trim model (model/fringe/fixed/trim.py)."""

from __future__ import annotations

import math
import re
import time

import numpy as np
import pytest
from hdl_text import block_texts, missing_checks
from param_cases import out_of_range

from fringe.fixed.trim import (
    LATENCY,
    TrimParams,
    check_sector_mapping,
    error_budget,
    error_terms,
    magnitudes,
    make_gain_table,
    make_map_table,
    pack_words,
    sector_mapping,
    sectors_of,
    slopes,
    speed_window_log2,
    speeds,
    trim,
    trim_detail,
    trim_words,
    unpack_words,
)

P1 = TrimParams(lines=256, fine_w=16, amp_w=12, speed_log2=5, map_psi_w=4, map_phi_w=6, trim_w=18, trim_frac=4,
                g_shift=20)
P2 = TrimParams(lines=1000, fine_w=12, amp_w=10, speed_log2=0, map_psi_w=3, map_phi_w=5, trim_w=16, trim_frac=0,
                g_shift=12)
P3 = TrimParams(lines=37, fine_w=10, amp_w=8, speed_log2=2, map_psi_w=0, map_phi_w=4, trim_w=12, trim_frac=2,
                g_shift=8)
P4 = TrimParams(lines=256, fine_w=16, amp_w=12, speed_log2=5, map_psi_w=4, map_phi_w=6, trim_w=18, trim_frac=4,
                g_shift=14, mag_smooth_log2=4)


def zeros_tables(p: TrimParams):
    return (np.zeros((2, p.sectors, p.bins), dtype=np.int64), np.zeros(p.bins, dtype=np.int64),
            np.zeros(p.bins, dtype=np.int64))


def motion(p: TrimParams, rng: np.random.Generator, n: int) -> np.ndarray:
    """Encoder-like positions: a random walk of speed (both signs, reversals), wrapped mod REV."""
    acc = rng.normal(0, p.rev * 1e-5, n)
    v = np.cumsum(acc)
    v = np.clip(v, -p.rev / 20, p.rev / 20)
    x = np.cumsum(v) + rng.integers(0, p.rev)
    return np.mod(np.round(x).astype(np.int64), p.rev)


# ---------------------------------------------------------------------------- parameters


def test_derived_constants():
    p = P1
    assert (p.rev, p.pos_w, p.fb, p.window, p.sectors, p.bins) == (1 << 24, 24, 10, 32, 16, 64)
    assert (p.map_words, p.gain_words, p.word_w, p.wr_addr_w, p.corr_max) == (2048, 64, 36, 12, 1 << 15)
    assert (p.recip, p.shift, p.latency, LATENCY) == (1, 20, 13, 13)
    assert p.hdl_parameters()["SECT_RECIP"] == 1 and p.hdl_parameters()["SECT_SHIFT"] == 20
    assert (P3.recip, P3.shift) == (0, 0)                       # no sectors: unused
    q = TrimParams(256, 16, 12, 5, 4, 6, 18, 4, 20, 2, 21)      # explicit, checked
    assert (q.recip, q.shift) == (2, 21)


BASE = dict(lines=256, fine_w=16, amp_w=12, speed_log2=5, map_psi_w=4, map_phi_w=6, trim_w=18, trim_frac=4,
            g_shift=20)


@pytest.mark.parametrize(
    "over, msg",
    [
        *out_of_range("fringe_trim", "fine_w", 8, 30),
        ({"lines": 0}, "fringe_trim: LINES = 0 out of range 1..2^20"),
        ({"lines": (1 << 20) + 1}, "fringe_trim: LINES = 1048577 out of range 1..2^20"),
        ({"lines": 1 << 16}, "fringe_trim: POS_W = FINE_W + clog2(LINES) = 32 exceeds 31"),
        *out_of_range("fringe_trim", "amp_w", 4, 32),
        *out_of_range("fringe_trim", "speed_log2", 0, 8),
        *out_of_range("fringe_trim", "map_psi_w", 0, 8, values=(9,)),
        *out_of_range("fringe_trim", "map_phi_w", 2, 10, "min(10, FINE_W-1) = 10"),
        ({"fine_w": 9, "map_phi_w": 9}, "fringe_trim: MAP_PHI_W = 9 out of range 2..min(10, FINE_W-1) = 8"),
        *out_of_range("fringe_trim", "trim_w", 8, 24),
        *out_of_range("fringe_trim", "trim_frac", 0, 16, values=(17,)),
        *out_of_range("fringe_trim", "g_shift", 1, 48),
        *out_of_range("fringe_trim", "mag_smooth_log2", 0, 12),
        ({"sect_recip": 1, "sect_shift": 128}, "fringe_trim: SECT_SHIFT = 128 out of range 0..127"),
        ({"sect_recip": 1, "sect_shift": 19}, "fringe_trim: SECT_RECIP = 1, SECT_SHIFT = 19 do not map every "
                                              "position to floor(pos * 2^MAP_PSI_W / REV); take them from "
                                              "sector_mapping()"),
        ({"sect_recip": 1}, "fringe_trim: give both SECT_RECIP and SECT_SHIFT, or neither"),
        ({"trim_w": 18.0}, "fringe_trim: TRIM_W must be an integer"),
    ],
)
def test_parameter_validation(over, msg):
    with pytest.raises(ValueError, match=re.escape(msg)):
        TrimParams(**{**BASE, **over})


def test_hdl_messages_match_model():
    """The HDL checks carry the model's messages (plus the instance path in Verilog)."""
    v, h = block_texts("fringe_trim")
    ranges = (("FINE_W", "8..30"), ("LINES", "1..2^20"), ("AMP_W", "4..32"), ("SPEED_LOG2", "0..8"),
              ("MAP_PSI_W", "0..8"), ("TRIM_W", "8..24"), ("TRIM_FRAC", "0..16"), ("G_SHIFT", "1..48"),
              ("SECT_SHIFT", "0..127"), ("MAG_SMOOTH_LOG2", "0..12"))
    assert not missing_checks("fringe_trim", ranges, pos_w_max=31)
    for frag in ("out of range 2..min(10, FINE_W-1) = ", "take them from "):
        assert frag in v and frag in h, frag
    # written out in Verilog, built by fringe_pkg's check_mapping / check_min in VHDL
    assert "do not map every position to floor(pos * 2^MAP_PSI_W / REV);" in v
    assert "take them from sector_mapping()" in v
    assert 'check_mapping("fringe_trim", "SECT", "MAP_PSI_W", "sector_mapping"' in h
    assert '`FRINGE_CHECK_MIN(g_bad_user_w, "fringe_trim", "USER_W", USER_W, 1)' in v
    assert 'check_min("fringe_trim", "USER_W", USER_W, 1)' in h


# ---------------------------------------------------------------------------- sector mapping


@pytest.mark.parametrize("lines, fine_w", [(1, 8), (3, 8), (5, 9), (100, 8), (7, 10), (256, 8)])
@pytest.mark.parametrize("psi", [1, 3, 8])
def test_sector_mapping_exact_for_all_positions(lines, fine_w, psi):
    p = TrimParams(lines, fine_w, 8, 0, psi, 2, 8, 0, 1)
    pos = np.arange(p.rev, dtype=np.int64)
    np.testing.assert_array_equal(sectors_of(pos, p), (pos << psi) // p.rev)


@pytest.mark.parametrize("lines, fine_w", [(1000, 12), (999_999, 11), ((1 << 20) - 3, 11), (1 << 20, 11),
                                           (12_345, 16), (3, 29), (1, 30)])
@pytest.mark.parametrize("psi", [1, 4, 8])
def test_sector_mapping_at_the_boundaries(lines, fine_w, psi):
    p = TrimParams(lines, fine_w, 8, 0, psi, 2, 8, 0, 1)
    ks = np.arange(1 << psi, dtype=object)
    firsts = np.array([-(-(int(k) * p.rev) >> psi) for k in ks], dtype=object)   # ceil(k REV / 2^psi)
    pos = np.concatenate([firsts, firsts - 1, firsts + 1, [p.rev - 1, p.rev - 2]])
    pos = np.array([q for q in pos if 0 <= q < p.rev], dtype=np.int64)
    want = np.array([(int(q) << psi) // p.rev for q in pos], dtype=np.int64)
    np.testing.assert_array_equal(sectors_of(pos, p), want)
    check_sector_mapping(lines, fine_w, psi, p.recip, p.shift)
    # one less is not a proof any more (or is wrong)
    with pytest.raises(ValueError):
        check_sector_mapping(lines, fine_w, psi, p.recip - 1, p.shift)


def test_sector_mapping_small():
    assert sector_mapping(256, 16, 4) == (1, 20)
    assert sector_mapping(1, 8, 8) == (1, 0)
    assert sector_mapping(1000, 12, 0) == (0, 0)
    r, s = sector_mapping(1000, 12, 3)
    assert r < 1 << 31


# ---------------------------------------------------------------------------- speed and direction


def test_speed_and_dir_on_synthetic_motion():
    p = P1
    n = 5000
    rng = np.random.default_rng(3)
    pos = motion(p, rng, n)
    sp = speeds(pos, p)
    assert sp[0] == 0 and np.all(sp[1:p.window] != 0)         # moving from the start: a start-up speed
    # reference: unwrapped trajectory differences (|true speed| < REV/2 here)
    un = np.concatenate([[0], np.cumsum(_wrap_ref(np.diff(pos), p.rev))])
    want = un[p.window:] - un[:-p.window]
    np.testing.assert_array_equal(sp[p.window:], want)
    r = trim_detail(pos, 0, *[pack_words(t, p) for t in zeros_tables(p)], p)
    np.testing.assert_array_equal(r["dir"], (sp < 0).astype(int))
    assert r["dir"].min() == 0 and r["dir"].max() == 1           # both directions, reversals
    np.testing.assert_array_equal(r["pos_out"], pos)             # zero tables: no correction
    assert not r["sat"].any()


@pytest.mark.parametrize("lines", [1, 2, 3, 4, 5, 7, 8, 9, 15, 16, 17, 33, 1000, 4095])
def test_generated_speed_window_never_wraps_below_overspeed(lines):
    """The generator's window (CoreConfig.for_encoder) keeps the speed exact up to the overspeed limit, a quarter
    period per sample, both ways: longer windows would alias the speed, and the direction with it, silently."""
    from fringe.encoder import Encoder
    from fringe.fixed.config import CoreConfig

    cfg = CoreConfig.for_encoder(Encoder(lines_per_rev=lines, adc_bits=12))
    w = cfg.trim_speed_log2
    p = TrimParams(lines=lines, fine_w=12, amp_w=12, speed_log2=w, map_psi_w=0, map_phi_w=4,
                   trim_w=16, trim_frac=0, g_shift=8)
    assert w == speed_window_log2(lines) and (w == 5 or 2 << w >= 2 * lines)
    step = (1 << p.fine_w) // 4 - 1                     # just under a quarter period per sample
    for sign in (1, -1):
        un = sign * step * np.arange(4 * p.window + 8, dtype=np.int64)
        sp = speeds(un % p.rev, p)
        # the start-up windows, scaled to N samples, give the same speed from the second sample on
        assert sp[0] == 0
        np.testing.assert_array_equal(sp[1:], sign * step * p.window)


def _wrap_ref(d, rev):
    d = np.asarray(d, dtype=np.int64)
    return np.array([x - rev if 2 * x >= rev else (x + rev if 2 * x < -rev else x) for x in d], dtype=np.int64)


def test_speed_wrap_limits():
    p = P2                                                       # window 1: the previous sample
    rev = p.rev
    pos = np.array([0, rev // 2, 0, rev - 1, 0, rev // 2 + 1, 1, 5, 2])
    sp = speeds(pos, p)
    # d = REV/2 -> -REV/2; d = -REV/2 -> stays; 2d < -REV wraps up
    assert list(sp) == [0, -rev // 2, -rev // 2, -1, 1, -rev // 2 + 1, -rev // 2, 4, -3]
    assert sp.min() >= -rev // 2 and sp.max() < rev // 2


P8 = TrimParams(lines=4, fine_w=8, amp_w=8, speed_log2=3, map_psi_w=0, map_phi_w=4, trim_w=12, trim_frac=0,
                g_shift=8)   # N = 8, REV = 1024


def test_start_up_speed_by_hand():
    """Before N samples: the longest power-of-two window there is, scaled to N samples (N = 8)."""
    p = P8
    pos = np.array([1000, 10, 30, 70, 100, 101, 105, 120, 140, 150])
    # n: window, change  -> x 8 / window
    # 1: 1, 10 - 1000 + 1024 = 34 -> 272;  2: 2, 30 - 1000 + 1024 = 54 -> 216;  3: 2, 70 - 10 = 60 -> 240
    # 4: 4, 100 - 1000 + 1024 = 124 -> 248;  5: 4, 91 -> 182;  6: 4, 75 -> 150;  7: 4, 50 -> 100
    # 8: 8, 140 - 1000 + 1024 = 164;  9: 8, 140 (the full window, as before)
    assert speeds(pos, p).tolist() == [0, 272, 216, 240, 248, 182, 150, 100, 164, 140]
    # a constant speed: the same from n = 1 on as after N samples, both ways, through 0/REV
    for v in (3, -5, 63):
        sp = speeds((900 + v * np.arange(40)) % p.rev, p)
        assert sp[0] == 0 and np.all(sp[1:] == 8 * v)
    # a stream shorter than a window, and one sample
    assert speeds(pos[:3], p).tolist() == [0, 272, 216] and speeds(pos[:1], p).tolist() == [0]


def test_start_up_speed_saturates():
    """The scaled start-up speed is clipped to [-REV/2, REV/2 - 1] (never wraps silently); the sign, and dir
    with it, is the window's."""
    p = P8
    half = p.rev // 2
    pos = np.array([0, 64, 128, 200, 256, 300, 400, 500, 600])      # 64 per sample: 512 per 8 samples
    sp = speeds(pos, p)
    # n = 5: (300 - 64) * 2 = 472 fits; n = 8: the full window wraps 600 to -424, as before
    assert sp.tolist() == [0, half - 1, half - 1, half - 1, half - 1, 472, half - 1, half - 1, -424]
    sp = speeds((-pos) % p.rev, p)
    assert sp.tolist() == [0, -half, -half, -half, -half, -472, -half, -half, 424]
    # the wrap first (d = REV/2 -> -REV/2), then the scaling: -REV/2 * 8 clipped to -REV/2
    assert speeds(np.array([0, half, 0]), p).tolist() == [0, -half, 0]
    # a small start-up speed is exact; dir = speed < 0 throughout
    r = trim_detail(np.array([5, 4, 4, 1000, 1010]), 0, *[pack_words(t, p) for t in zeros_tables(p)], p)
    assert r["speed"].tolist() == [0, -8, -4, -112, -38] and r["dir"].tolist() == [0, 1, 1, 1, 1]


# ---------------------------------------------------------------------------- datapath against a reference


def reference(pos, mag, mw, sw, aw, bank, p: TrimParams):
    """Sample by sample on Python integers, straight from the contract."""
    out = []
    hist: list[int] = []
    k, acc = p.mag_smooth_log2, None
    for q, mg, b in zip(pos.tolist(), mag.tolist(), bank.tolist(), strict=True):
        acc = mg << k if acc is None else acc + mg - (acc >> k)     # the magnitude's running average
        mg = acc >> k
        d = 0
        if hist:    # the longest power-of-two window there is, up to N, scaled to N samples and clipped
            w = min(1 << (len(hist).bit_length() - 1), p.window)
            d = q - hist[-w]
            d = d - p.rev if 2 * d >= p.rev else (d + p.rev if 2 * d < -p.rev else d)
            d = min(max(d * (p.window // w), -(p.rev // 2)), p.rev // 2 - 1)
        hist.append(q)
        dr = int(d < 0)
        phase = q % (1 << p.fine_w)
        bn, fr = phase >> p.fb, phase % (1 << p.fb)
        sec = (q << p.map_psi_w) // p.rev

        def ip(word, fr=fr):
            word, tw = int(word), p.trim_w
            v, s = word & ((1 << tw) - 1), (word >> tw) & ((1 << tw) - 1)
            v, s = v - ((v >> (tw - 1)) << tw), s - ((s >> (tw - 1)) << tw)
            return v + ((s * fr + (1 << (p.fb - 1))) >> p.fb)

        m = ip(mw[b][(dr << (p.map_psi_w + p.map_phi_w)) | (sec << p.map_phi_w) | bn])
        gs, ga = ip(sw[b][bn]), ip(aw[b][bn])
        total = m + ((d * gs + mg * ga + (1 << (p.g_shift - 1))) >> p.g_shift)
        corr = (total + (1 << (p.trim_frac - 1))) >> p.trim_frac if p.trim_frac else total
        lim = 1 << (p.fine_w - 1)
        sat = int(not -lim <= corr < lim)
        corr = min(max(corr, -lim), lim - 1)
        out.append(((q - corr) % p.rev, dr, sat))
    return out


@pytest.mark.parametrize("p", [P1, P2, P3, P4], ids=["P1", "P2", "P3", "P4"])
def test_against_reference_with_arbitrary_words(p):
    rng = np.random.default_rng(p.lines)
    n = 3000
    pos = motion(p, rng, n)
    jumps = rng.random(n) < 0.02
    pos[jumps] = rng.integers(0, p.rev, jumps.sum())
    mag = rng.integers(0, 1 << p.amp_w, n)
    bank = rng.integers(0, 2, n)
    ww = 1 << p.word_w
    mw = rng.integers(0, ww, (2, p.map_words))
    sw = rng.integers(0, ww, (2, p.gain_words))
    aw = rng.integers(0, ww, (2, p.gain_words))
    # extremes
    ext = [(1 << (2 * p.trim_w - 1)) | (1 << (p.trim_w - 1)), ((1 << (p.trim_w - 1)) - 1) * ((1 << p.trim_w) + 1)]
    sw[:, :2] = ext
    aw[:, :2] = ext[::-1]
    out, d, sat = trim_words(pos, mag, mw, sw, aw, p, bank=bank)
    want = reference(pos, mag, mw, sw, aw, bank, p)
    np.testing.assert_array_equal(np.stack([out, d, sat], axis=1), np.array(want))
    assert sat.any() and not sat.all()
    assert out.min() >= 0 and out.max() < p.rev


@pytest.mark.parametrize("k", [1, 4, 12])
def test_magnitude_average_stays_in_range_and_within_a_step_of_the_float_average(k):
    """The running average (MAG_SMOOTH_LOG2 = k) stays in u(AMP_W) for any input, the extremes included, equals
    a steady input exactly, and is within 1 LSB of the float average of the same integers: with e = acc -
    2^k y (y the float average), e' = e (1 - 2^-k) + frac(acc / 2^k) stays in [0, 2^k) from e = 0, so acc / 2^k
    - y is in [0, 1) and its floor within (-1, 1) of y."""
    from fringe.dsp.effects import magnitude_average

    p = TrimParams(**{**BASE, "mag_smooth_log2": k})
    top = (1 << p.amp_w) - 1
    rng = np.random.default_rng(k)
    mag = np.concatenate([np.full(200, top), np.zeros(300, np.int64), rng.integers(0, top + 1, 3000),
                          np.full(60 << k, 1234)])
    avg = magnitudes(mag, p)
    assert avg.min() >= 0 and avg.max() <= top and avg[0] == mag[0]
    assert avg[-1] == 1234
    np.testing.assert_array_less(np.abs(avg - magnitude_average(mag, k)), 1.0)
    np.testing.assert_array_equal(magnitudes(mag, TrimParams(**BASE)), mag)


def test_speed_can_be_given_for_a_continued_stream():
    p = P1
    rng = np.random.default_rng(9)
    pos = motion(p, rng, 1000)
    tabs = [pack_words(t, p) for t in zeros_tables(p)]
    tabs[1] = pack_words(np.full(p.bins, 1000), p)
    full = trim_words(pos, 7, *tabs, p)
    sp = speeds(pos, p)
    tail = trim_words(pos[600:], 7, *tabs, p, speed=sp[600:])
    for a, b in zip(full, tail, strict=True):
        np.testing.assert_array_equal(a[600:], b)


# ---------------------------------------------------------------------------- saturation and rounding


def test_saturation_both_ways_and_wrap():
    p = P2                                                      # TRIM_FRAC 0, FINE_W 12: corr in [-2048, 2047]
    m, s, a = zeros_tables(p)
    pos = np.array([0, 5, p.rev - 1, 100])
    for val, corr, sat in ((2047, 2047, 0), (2048, 2047, 1), (-2048, -2048, 0), (-2049, -2048, 1),
                           (-32768, -2048, 1), (32767, 2047, 1)):
        mm = m.copy()
        mm[:] = val
        out, d, st = trim(pos, 0, mm, s, a, p)
        np.testing.assert_array_equal(out, np.mod(pos - corr, p.rev))
        assert list(st) == [sat] * 4


def test_rounding_half_up():
    p = P1                                                      # TRIM_FRAC 4
    m, s, a = zeros_tables(p)
    pos = np.array([0, 1000, p.rev - 1])
    for val, corr in ((8, 1), (7, 0), (-8, 0), (-9, -1), (24, 2)):
        out, _, _ = trim(pos, 0, np.full_like(m, val), s, a, p)
        np.testing.assert_array_equal(out, np.mod(pos - corr, p.rev))


def test_interpolation_is_periodic_in_phase():
    """A ramp over the last bin of a row interpolates towards value[0] of the same row."""
    p = P3                                                      # FB = 6, TRIM_FRAC 2
    m, s, a = zeros_tables(p)
    m[0, 0, -1] = 64 * 4                                        # 64 counts at the last bin, 0 at bin 0
    phase = np.arange((p.bins - 1) << p.fb, p.bins << p.fb)
    pos = phase + 3 * (1 << p.fine_w)                          # some period, fine phase in the last bin
    r = trim_detail(pos, 0, pack_words(m, p), pack_words(s, p), pack_words(a, p), p)
    np.testing.assert_array_equal(r["m"], 256 - 4 * (phase & 63))
    assert slopes(m)[0, 0, -1] == -256


# ---------------------------------------------------------------------------- tables and the error budget


def test_make_tables_and_pack():
    p = P1
    calls = []

    def fn(d, sec, ph):
        calls.append((d, sec))
        return (1 - 2 * d) * 3.0 + sec * 0.5 + 2.0 * np.sin(2 * np.pi * ph)

    m = make_map_table(fn, p)
    assert m.shape == (2, p.sectors, p.bins) and len(calls) == 2 * p.sectors
    assert m[0, 0, 0] == 48 and m[1, 3, 0] == -48 + 24
    words = pack_words(m, p)
    assert words.shape == (p.map_words,) and words.min() >= 0 and words.max() < 1 << p.word_w
    sl, v = unpack_words(words, p)
    np.testing.assert_array_equal(v.reshape(m.shape), m)
    np.testing.assert_array_equal(sl.reshape(m.shape), slopes(m))
    g = make_gain_table(lambda ph: 1e-3 * np.cos(2 * np.pi * ph), p)
    assert g[0] == round(1e-3 * 2 ** (p.g_shift + p.trim_frac))
    np.testing.assert_array_equal(make_gain_table(lambda ph: 5.0 + 0 * ph, p, raw=True), np.full(p.bins, 5))
    scalar = make_gain_table(lambda ph: math.sin(ph * 6), p, raw=True)
    np.testing.assert_array_equal(scalar, make_gain_table(lambda ph: np.sin(ph * 6), p, raw=True))


def test_table_range_checks():
    p = P2                                                      # s(16), TRIM_FRAC 0
    with pytest.raises(ValueError, match=r"fringe_trim: map value at \(0, 0, 0\): 32768 x 1 = 32768 does not fit "
                                         r"s\(16\) = -32768..32767"):
        make_map_table(lambda d, s, ph: 32768.0 + 0 * ph, p)
    make_map_table(lambda d, s, ph: 32767.0 + 0 * ph, p)
    with pytest.raises(ValueError, match="map slope"):
        make_map_table(lambda d, s, ph: np.where(ph < 0.5, -20000.0, 20000.0), p)
    with pytest.raises(ValueError, match="gain value"):
        make_gain_table(lambda ph: 8.0 + 0 * ph, p)             # 8 x 2^12 = 32768 > 32767
    make_gain_table(lambda ph: 7.0 + 0 * ph, p)
    with pytest.raises(ValueError, match="not finite"):
        make_gain_table(lambda ph: np.full(len(ph), np.nan), p)
    with pytest.raises(ValueError, match="shape"):
        pack_words(np.zeros(7, dtype=np.int64), p)
    with pytest.raises(ValueError, match="outside s"):
        pack_words(np.full(p.bins, 1 << 15), p)


def test_model_within_error_budget():
    """|(pos - pos_out) - ideal| <= error_budget for smooth float trims (no clipping)."""
    p = TrimParams(lines=64, fine_w=14, amp_w=12, speed_log2=3, map_psi_w=3, map_phi_w=6, trim_w=20, trim_frac=6,
                   g_shift=20)
    rng = np.random.default_rng(5)
    a = rng.uniform(-1, 1, (2, p.sectors, 3))

    def fmap(d, s, ph):
        return 40 * a[d, s, 0] + 30 * a[d, s, 1] * np.sin(2 * np.pi * ph) + 20 * a[d, s, 2] * np.cos(4 * np.pi * ph)

    def fspeed(ph):
        return 2e-3 * np.sin(2 * np.pi * ph + 0.3)

    def famp(ph):
        return 5e-3 * np.cos(2 * np.pi * ph)

    m, s_, a_ = make_map_table(fmap, p), make_gain_table(fspeed, p), make_gain_table(famp, p)
    pos = motion(p, rng, 200_000)
    mag = rng.integers(0, 1 << p.amp_w, pos.size)
    r = trim_detail(pos, mag, pack_words(m, p), pack_words(s_, p), pack_words(a_, p), p)
    assert not r["sat"].any()
    sp = r["speed"]
    ph = (pos & ((1 << p.fine_w) - 1)) / (1 << p.fine_w)
    sec = (pos * p.sectors) // p.rev
    ideal = np.empty(pos.size)
    for d in (0, 1):
        for s in range(p.sectors):
            k = (r["dir"] == d) & (sec == s)
            ideal[k] = fmap(d, s, ph[k])
    ideal += sp * fspeed(ph) + mag * famp(ph)
    applied = np.mod(pos - r["pos_out"] + p.rev // 2, p.rev) - p.rev // 2
    err = np.abs(applied - ideal).max()
    budget = error_budget(p, speed_max=np.abs(sp).max(), mag_max=mag.max(), map_values=m, speed_values=s_,
                          amp_values=a_)
    assert err <= budget, (err, budget)
    assert err >= 0.4, err                                       # the output rounding is reached
    t = error_terms(p)
    assert t["output_rounding"] == 0.5 and t["map_interp_rounding"] == 2 ** -7
    assert t["gain_interp_rounding"] == pytest.approx(0.5 * (p.rev / 2 + 4095) * 2 ** -26)
    assert error_terms(P2)["output_rounding"] == 0


# ---------------------------------------------------------------------------- inputs


def test_input_validation():
    p = P2
    tabs = [pack_words(t, p) for t in zeros_tables(p)]
    with pytest.raises(ValueError, match="pos outside"):
        trim_words(np.array([p.rev]), 0, *tabs, p)
    with pytest.raises(ValueError, match="mag outside"):
        trim_words(np.array([0]), 1 << p.amp_w, *tabs, p)
    with pytest.raises(ValueError, match="need a bank per sample"):
        trim_words(np.array([0]), 0, np.stack([tabs[0]] * 2), tabs[1], tabs[2], p)
    with pytest.raises(ValueError, match="bank outside"):
        trim_words(np.array([0]), 0, np.stack([tabs[0]] * 2), tabs[1], tabs[2], p, bank=np.array([2]))
    with pytest.raises(ValueError, match="must be integers"):
        trim_words(np.array([0.5]), 0, *tabs, p)
    with pytest.raises(ValueError, match="shape"):
        trim_words(np.array([0]), 0, tabs[0][:-1], tabs[1], tabs[2], p)


# ---------------------------------------------------------------------------- speed


def test_model_speed():
    rng = np.random.default_rng(0)
    n = 1_000_000
    for p in (P1, P2):
        pos = motion(p, rng, n)
        mag = rng.integers(0, 1 << p.amp_w, n)
        bank = rng.integers(0, 2, n)
        ww = 1 << p.word_w
        tabs = [rng.integers(0, ww, (2, k)) for k in (p.map_words, p.gain_words, p.gain_words)]
        best = math.inf
        for _ in range(2):
            t0 = time.perf_counter()
            trim_words(pos, mag, *tabs, p, bank=bank)
            best = min(best, time.perf_counter() - t0)
        print(f"fringe.fixed.trim: {n / best / 1e6:.1f} M samples/s")
        assert n / best > 2e5
