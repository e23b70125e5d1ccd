"""fringe_canceller's bit-exact model (model/fringe/fixed/canceller.py): limits, stream pieces, the block and
gear-shift timing, saturation flags, convergence within its error budget, the float twin, and the core with
CANCEL = 1 (the RTL is compared word for word in tb/test_fringe_canceller.py)."""

import dataclasses
import math

import numpy as np
import pytest

from fringe.dsp.canceller_float import CancelFloat
from fringe.fixed import canceller as cm


def circle(p: cm.CancelParams, n: int, tone: tuple[float, float], cycles: float = 0.0917, speed: float = 0.013,
           noise: float = 0.0, seed: int = 0):
    """A point on the circle of radius R plus a tone of amplitudes tone (LSB) at `cycles` per sample on c and s."""
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    phi = 2 * np.pi * (speed * k + 0.002 * np.sin(2 * np.pi * k / 3000))
    w = 2 * np.pi * cycles * k
    c = p.radius * np.cos(phi) + tone[0] * np.cos(w + 0.4) + rng.normal(0, noise, n)
    s = p.radius * np.sin(phi) + tone[1] * np.sin(w + 1.9) + rng.normal(0, noise, n)
    lim = (1 << (p.wave_w - 1)) - 1
    return (np.clip(np.round(c), -lim - 1, lim).astype(np.int64), np.clip(np.round(s), -lim - 1, lim).astype(np.int64),
            phi, cm.freq_word(cycles, 1.0))


@pytest.mark.parametrize("kw, message", [
    (dict(block_log2=3), "BLOCK_LOG2 = 3 out of range 4..12"),
    (dict(mu_log2=0), "MU_LOG2 = 0 out of range 1..12"),
    (dict(wave_w=12, a_w=17), "A_W = 17 out of range 8..min(32, WAVE_W + A_FRAC) = 16"),
    (dict(block_log2=4, c_w=8, a_frac=12), "BLOCK_LOG2 + C_W - 2 - A_FRAC = -2 must be >= 0"),
    (dict(lut_w=True), "LUT_W must be an integer"),
    (dict(mu_log2=3, gear_offset=3), "GEAR_OFFSET = 3 out of range 0..MU_LOG2-1 = 2"),
    (dict(gear_offset=-1), "GEAR_OFFSET = -1 out of range 0..MU_LOG2-1 = 5"),
])
def test_limits(kw, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)").replace("+", r"\+")):
        cm.CancelParams(**kw)


def test_sine_table_and_freq_word():
    p = cm.CancelParams(lut_w=6, c_w=10)
    lut = cm.sine_table(p)
    assert lut.shape == (64,) and lut[16] == 511 and lut[48] == -511 and lut[0] == 0
    assert cm.freq_word(0.25, 1.0) == 1 << 30
    assert cm.freq_word(-0.25, 1.0) == 3 << 30          # an alias folds: -f is 1 - f
    assert cm.freq_word(1.25, 1.0) == 1 << 30
    with pytest.raises(ValueError, match="no NCO word"):
        cm.freq_word(10.0, 0.0)


def test_pieces_give_the_same_words():
    p = cm.CancelParams(wave_w=16, block_log2=4, mu_log2=3)
    c, s, _, word = circle(p, 3000, (900.0, 700.0), noise=2.0)
    whole = cm.cancel(c, s, word, p)
    st, rng, i, parts = cm.CancelStream(p), np.random.default_rng(3), 0, []
    while i < len(c):
        k = int(rng.integers(1, 50))
        parts.append(st.run(c[i:i + k], s[i:i + k], word))
        i += k
    for j, ref in enumerate((whole.c, whole.s, whole.sat, whole.track_sat)):
        assert np.array_equal(np.concatenate([q[j] for q in parts]), ref)


def test_block_timing_and_gear():
    """Blocks 0 and 1 run on the reset state; block j + 2 on the update of block j, by the step 2^-G_j."""
    p = cm.CancelParams(wave_w=16, block_log2=4, mu_log2=3)
    c, s, _, word = circle(p, 10 * p.b + 5, (900.0, 700.0))
    r = cm.cancel(c, s, word, p)
    assert np.array_equal(r.c[:2 * p.b], c[:2 * p.b]) and np.array_equal(r.s[:2 * p.b], s[:2 * p.b])
    assert np.any(r.c[2 * p.b:3 * p.b] != c[2 * p.b:3 * p.b])
    assert [p.gear(j) for j in range(9)] == [1, 2, 2, 3, 3, 3, 3, 3, 3]
    # GEAR_OFFSET starts the same sequence lower, down to the same last gear
    assert [dataclasses.replace(p, mu_log2=6, gear_offset=3).gear(j) for j in range(9)] == [4, 5, 5, 6, 6, 6, 6, 6, 6]
    assert [dataclasses.replace(p, gear_offset=2).gear(j) for j in range(4)] == [3, 3, 3, 3]
    assert np.array_equal(r.coefs[0], r.coefs[1]) and not np.any(r.coefs[1])
    # the partial last block changes nothing: the state after it is the one before
    assert np.array_equal(r.coefs[-1], r.coefs[-2])


def test_converges_within_budget():
    """Noise-free circle plus a tone: once converged, what is left of the tone is bounded by the NCO's phase
    truncation (a 2 pi / 2^LUT_W), the sine table's rounding (a 2^-(C_W-2)) and the integer steps (input and
    estimate rounding, coefficient resolution 2^-A_FRAC: 2 LSB). Without the canceller the error is the tone."""
    for kw in (dict(), dict(wave_w=12, lut_w=8, c_w=12, block_log2=5, mu_log2=2, a_w=16),
               dict(wave_w=24, lut_w=12, c_w=18, a_frac=8, a_w=32)):
        p = cm.CancelParams(**{"mu_log2": 3, **kw})
        a = p.radius / 20
        c, s, phi, word = circle(p, 400 * p.b, (a, 0.7 * a))
        r = cm.cancel(c, s, word, p)
        tail = slice(300 * p.b, None)
        err = np.maximum(np.abs(r.c - p.radius * np.cos(phi)), np.abs(r.s - p.radius * np.sin(phi)))[tail]
        budget = a * 2 * math.pi / (1 << p.lut_w) + a * 2.0 ** -(p.c_w - 2) + 2.0
        assert err.max() <= budget, (kw, err.max(), budget)
        before = np.abs(c - p.radius * np.cos(phi))[tail].max()
        assert before > 0.9 * a
        assert not r.sat.any() and not r.track_sat.any()


def test_float_twin_agrees():
    """The float twin (unit circle) against the bit-exact model: the same budget as above, relative to R."""
    for p in (cm.CancelParams(wave_w=20, mu_log2=4), cm.CancelParams(wave_w=20, mu_log2=4, gear_offset=2)):
        a = p.radius / 30
        c, s, phi, word = circle(p, 300 * p.b, (a, a), noise=3.0, seed=5)
        r = cm.cancel(c, s, word, p)
        fc, fs = CancelFloat(word, p.block_log2, p.mu_log2, p.gear_offset).run(c / p.radius, s / p.radius)
        tail = slice(200 * p.b, None)
        d = np.abs(r.c - fc * p.radius)[tail]
        budget = a * 2 * math.pi / (1 << p.lut_w) + a * 2.0 ** -(p.c_w - 2) + 2.0 + 4 * 3.0 * 2.0 ** -(p.mu_log2 / 2)
        assert d.max() <= budget, (d.max(), budget)


def test_float_twin_saturates_where_the_core_does():
    """A step too large for the tone (16-sample blocks, final step 1/2, 0.3 radii at 0.003 cycles per sample) drives the
    canceller
    unstable. The core's words saturate (outputs and radial error at s(WAVE_W), +-2 radii; coefficients at
    s(A_W), half the radius with the A_W the core generator chooses); the float twin must stay bounded the same
    way (unbounded, it reached inf and NaN, and the loop's scoring of the candidate raised)."""
    from fringe.dsp.canceller_float import TONE_MAX_LOG2, WORD_MAX
    p = cm.CancelParams(wave_w=20, block_log2=4, mu_log2=1, a_w=20 + 4 - 1 + TONE_MAX_LOG2)
    c, s, _, word = circle(p, 2000 * p.b, (0.3 * p.radius, 0.3 * p.radius), cycles=0.003)
    twin = CancelFloat(word, p.block_log2, p.mu_log2)
    fc, fs = twin.run(c / p.radius, s / p.radius)
    rows = np.array(twin.rows)
    assert np.isfinite(fc).all() and np.isfinite(fs).all()
    assert np.abs(fc).max() <= WORD_MAX and np.abs(fs).max() <= WORD_MAX
    assert np.abs(rows).max() == pytest.approx(2.0 ** TONE_MAX_LOG2)      # it did reach the coefficients' limit
    r = cm.cancel(c, s, word, p)
    assert r.track_sat.any()            # and so did the core's


def test_saturation_flags():
    p = cm.CancelParams(wave_w=12, block_log2=4, mu_log2=1, a_w=8, a_frac=0)
    # a tone far larger than s(A_W) can hold: the coefficients saturate, track_sat from that block on
    c, s, _, word = circle(p, 40 * p.b, (900.0, 900.0))
    r = cm.cancel(c, s, word, p)
    first = int(np.argmax(r.track_sat))
    assert r.track_sat[first:].all() and not r.track_sat[:2 * p.b].any() and first % p.b == 0
    # inputs at full scale: the subtraction clips, sat on exactly those samples
    q = cm.CancelParams(wave_w=12, block_log2=4, mu_log2=1, a_w=14)
    lim = (1 << 11) - 1
    c = np.full(20 * q.b, lim, dtype=np.int64)
    s = np.zeros(20 * q.b, dtype=np.int64)
    r = cm.cancel(c, s, cm.freq_word(0.21, 1.0), q)
    assert r.sat.any() and not r.sat[:2 * q.b].any()
    assert np.all(r.c[r.sat] == lim)      # c - n_c above the top: clipped there


def test_core_with_canceller_removes_interference():
    """The core model with CANCEL = 1 on a simulated encoder with additive interference: the bit-exact angle error
    falls to the level of the same encoder without the tone (within 25 %: the canceller's start-up and
    estimation noise), and it rises by more than twice without the canceller."""
    import dataclasses

    from fringe.calib.calibrate import calibrate
    from fringe.calib.evaluate import measurement_of
    from fringe.dsp.metrics import error_arcsec
    from fringe.dsp.simulate import SimulationConfig, simulate
    from fringe.hardware.corefiles import core_config
    from fringe.hardware.tables import run_model

    base = SimulationConfig(samples=20_000)
    noisy = dataclasses.replace(base, interference_fs=0.01, interference_hz=0.137 * base.sample_rate_hz)
    cal = calibrate(measurement_of(simulate(base, 1)), base.encoder())
    rms = {}
    for name, c in (("clean", base), ("tone", noisy)):
        m = measurement_of(simulate(c, 2))
        for on in (False, True):
            k = dataclasses.replace(cal, canceller={"tone_hz": noisy.interference_hz, "sample_rate_hz":
                                                    base.sample_rate_hz, "cancel_block_log2": 4,
                                                    "cancel_mu_log2": 8} if on else {})
            res = run_model(k, core_config(k), m.sin, m.cos, m.coarse)
            rms[name, on] = float(np.sqrt(np.mean(error_arcsec(res.angle_deg, m.ref_deg) ** 2)))
    assert rms["tone", False] > 2 * rms["clean", False]
    assert rms["tone", True] <= 1.25 * rms["clean", False]
    assert rms["clean", True] <= 1.25 * rms["clean", False]
