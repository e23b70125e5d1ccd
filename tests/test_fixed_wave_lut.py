"""Bit-true model of fringe_wave_lut: against a scalar reference, against float, validation."""

import numpy as np
import pytest

from fringe.fixed.table_ram import format_hex, read_hex, write_hex
from fringe.fixed.wave_lut import (
    WaveLutParams,
    check_table,
    error_budget,
    make_table,
    pack_words,
    unpack_words,
    wave_lut,
)

CONFIGS = [
    WaveLutParams(12, 8, 18),
    WaveLutParams(16, 10, 20),
    WaveLutParams(4, 2, 8),
    WaveLutParams(4, 3, 8),      # FB = 1: the rounding term is 1
    WaveLutParams(24, 2, 32),
    WaveLutParams(24, 14, 32),
]
IDS = [f"adc{p.adc_w}_addr{p.wave_addr_w}_wave{p.wave_w}" for p in CONFIGS]


def smooth_inverse(params):
    """A smooth stand-in for a waveform inverse: two different curves, values within [-2, 2)."""
    half = float(1 << (params.adc_w - 1))

    def f(a, branch):
        r = np.asarray(a, dtype=float) / half
        if branch == 0:
            return 1.6 * np.sin(1.1 * r) + 0.05 * r * r
        return 1.2 * np.arcsin(r / 1.25) - 0.1 * np.cos(3 * r)

    return f


def reference(adc, branch, table, p):
    """Scalar, plain-int transcription of docs/architecture.md (independent of the model)."""
    u = adc + (1 << (p.adc_w - 1))
    fb = p.adc_w - p.wave_addr_w
    addr, frac = u >> fb, u & ((1 << fb) - 1)
    value = int(table[branch][addr])
    slope = int(table[branch][addr + 1]) - value
    x = value + ((slope * frac + (1 << (fb - 1))) >> fb)
    clip = adc in (-(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1)
    return x, clip


@pytest.mark.parametrize("p", CONFIGS, ids=IDS)
def test_model_matches_scalar_reference(p):
    seed = 1000 + p.adc_w
    rng = np.random.default_rng(seed)
    lo, hi = p.value_min, p.value_max
    # a random table (any values whose slopes fit) exercises negative slopes and wrap-free sums
    table = np.clip(np.cumsum(rng.integers(-(1 << (p.wave_w - 3)), 1 << (p.wave_w - 3),
                                           size=(2, p.entries + 1)), axis=1), lo, hi)
    half = 1 << (p.adc_w - 1)
    adc = np.concatenate([rng.integers(-half, half, 3000), [-half, half - 1, -half + 1, half - 2, 0, -1]])
    branch = rng.integers(0, 2, adc.size)
    x, clip = wave_lut(adc, branch, table, p)
    for i in range(adc.size):
        rx, rc = reference(int(adc[i]), int(branch[i]), table, p)
        assert (int(x[i]), bool(clip[i])) == (rx, rc), \
            f"seed {seed}, sample {i}: adc {adc[i]} branch {branch[i]}"
    assert np.all((x >= lo) & (x <= hi))


@pytest.mark.parametrize("p", CONFIGS, ids=IDS)
def test_model_vs_float_within_budget(p):
    f = smooth_inverse(p)
    table = make_table(f, p)
    budget = error_budget(p, table)
    assert budget.shape == (2, p.entries)
    half = 1 << (p.adc_w - 1)
    if p.adc_w <= 16:
        adc = np.arange(-half, half)  # every code
    else:
        adc = np.random.default_rng(7).integers(-half, half, 400_000)
        adc = np.concatenate([adc, [-half, half - 1]])
    scale = float(1 << p.wave_frac)
    for b in (0, 1):
        x, _ = wave_lut(adc, b, table, p)
        err = np.abs(x - f(adc.astype(float), b) * scale)
        seg = (adc + half) >> p.fb
        assert np.all(err <= budget[b, seg]), (
            f"branch {b}: worst error {err.max():.3f} LSB at adc {adc[np.argmax(err - budget[b, seg])]}, "
            f"budget there {budget[b, seg][np.argmax(err - budget[b, seg])]:.3f}")
        # the budget is not vacuous: a small multiple of the worst error seen (tables of 4
        # segments are too coarse for a sharp curvature estimate)
        if p.entries >= 256:
            assert budget[b].max() < 2 * err.max() + 1


def test_table_points_are_exact():
    p = CONFIGS[0]
    table = make_table(smooth_inverse(p), p)
    codes = p.entry_codes()
    assert codes[0] == -(1 << (p.adc_w - 1)) and codes[-1] == 1 << (p.adc_w - 1)
    for b in (0, 1):
        x, _ = wave_lut(codes[:-1], b, table, p)
        assert np.array_equal(x, table[b, :-1])


def test_clip_flags_only_the_end_codes():
    p = CONFIGS[1]
    table = make_table(smooth_inverse(p), p)
    half = 1 << (p.adc_w - 1)
    adc = np.arange(-half, half)
    _, clip = wave_lut(adc, 0, table, p)
    assert np.flatnonzero(clip).tolist() == [0, 2 * half - 1]


def test_banks_select_tables():
    p = CONFIGS[0]
    t0 = make_table(smooth_inverse(p), p)
    t1 = -t0[::-1] // 2
    both = np.stack([t0, t1])
    rng = np.random.default_rng(3)
    adc = rng.integers(-2048, 2048, 1000)
    br = rng.integers(0, 2, 1000)
    bank = rng.integers(0, 2, 1000)
    x, _ = wave_lut(adc, br, both, p, bank=bank)
    x0, _ = wave_lut(adc, br, t0, p)
    x1, _ = wave_lut(adc, br, t1, p)
    assert np.array_equal(x, np.where(bank == 1, x1, x0))
    with pytest.raises(ValueError, match="bank: required"):
        wave_lut(adc, br, both, p)


def test_pack_unpack_roundtrip():
    for p in CONFIGS[:3]:
        t = make_table(smooth_inverse(p), p)
        words = pack_words(t, p)
        assert words.shape == (p.bank_words,)
        assert np.all((words >= 0) & (words < (1 << p.word_w)))
        slope, value = unpack_words(words, p)
        assert np.array_equal(value, t[:, :-1].reshape(-1))
        assert np.array_equal(slope, np.diff(t, axis=1).reshape(-1))


def test_pack_range_checks_name_the_entry():
    p = CONFIGS[0]
    t = np.zeros((2, p.entries + 1), dtype=np.int64)
    t[1, 37] = p.value_max + 1
    with pytest.raises(ValueError, match=r"table\[branch 1, entry 37\]: value 131072"):
        pack_words(t, p)
    t[1, 37] = 0
    t[0, 5], t[0, 6] = p.value_min, p.value_max  # slope 2^WAVE_W - 1 does not fit
    with pytest.raises(ValueError, match=r"table\[branch 0, entry 5\]: slope"):
        pack_words(t, p)
    with pytest.raises(ValueError, match="shape"):
        pack_words(np.zeros((2, p.entries)), p)
    with pytest.raises(ValueError, match="integers"):
        check_table(np.full((2, p.entries + 1), 0.5), p)


def test_make_table_range_check_and_scalar_functions():
    p = CONFIGS[0]
    with pytest.raises(ValueError, match=r"table\[branch 1, entry \d+\]: .* out of range \[-2, 2\)"):
        make_table(lambda a, b: 2.5 * a / 2048 * b, p)
    # a scalar-only function is evaluated point by point and gives the same table
    f = smooth_inverse(p)
    scalar = make_table(lambda a, b: float(f(np.array([a]), b)[0]), p)
    assert np.array_equal(scalar, make_table(f, p))


@pytest.mark.parametrize("kw, msg", [
    (dict(adc_w=3, wave_addr_w=2, wave_w=18), "fringe_wave_lut: ADC_W = 3 out of range 4..24"),
    (dict(adc_w=25, wave_addr_w=2, wave_w=18), "fringe_wave_lut: ADC_W = 25 out of range 4..24"),
    (dict(adc_w=12, wave_addr_w=12, wave_w=18),
     "fringe_wave_lut: WAVE_ADDR_W = 12 out of range 2..ADC_W-1 = 11"),
    (dict(adc_w=12, wave_addr_w=1, wave_w=18),
     "fringe_wave_lut: WAVE_ADDR_W = 1 out of range 2..ADC_W-1 = 11"),
    (dict(adc_w=12, wave_addr_w=8, wave_w=7), "fringe_wave_lut: WAVE_W = 7 out of range 8..32"),
    (dict(adc_w=12, wave_addr_w=8, wave_w=33), "fringe_wave_lut: WAVE_W = 33 out of range 8..32"),
])
def test_parameter_validation(kw, msg):
    with pytest.raises(ValueError) as e:
        WaveLutParams(**kw)
    assert str(e.value) == msg


def test_adc_range_checked():
    p = CONFIGS[0]
    t = np.zeros((2, p.entries + 1), dtype=np.int64)
    with pytest.raises(ValueError, match="adc: codes must lie in -2048..2047"):
        wave_lut(np.array([2048]), 0, t, p)
    with pytest.raises(ValueError, match="adc: codes must lie"):
        wave_lut(np.array([-2049]), 0, t, p)


def test_speed():
    import time
    p = CONFIGS[1]
    t = make_table(smooth_inverse(p), p)
    rng = np.random.default_rng(0)
    n = 2_000_000
    adc = rng.integers(-32768, 32768, n)
    br = rng.integers(0, 2, n)
    wave_lut(adc[:1000], br[:1000], t, p)
    best = min(_timed(lambda: wave_lut(adc, br, t, p), time) for _ in range(3))
    assert n / best > 1e6, f"{n / best / 1e6:.1f} M samples/s"  # a floor that holds under load


def _timed(fn, time):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def test_hex_image_roundtrip(tmp_path):
    p = CONFIGS[0]
    t = make_table(smooth_inverse(p), p)
    words = np.concatenate([pack_words(t, p), pack_words(-t // 2, p)])
    path = write_hex(tmp_path / "w.hex", words, p.word_w, ["fringe wave table", "ADC_W=12"])
    text = path.read_text()
    assert text.startswith("// fringe wave table\n// ADC_W=12\n")
    assert all(len(line) == 9 for line in text.splitlines()[2:])  # 36 bits = 9 hex digits
    assert np.array_equal(read_hex(path, p.word_w), words)
    assert format_hex(words, p.word_w, ["x"]) == text.replace("// fringe wave table\n// ADC_W=12\n", "// x\n")
    with pytest.raises(ValueError, match=r"words\[1\] = -1 out of range"):
        format_hex(np.array([0, -1]), 8)
