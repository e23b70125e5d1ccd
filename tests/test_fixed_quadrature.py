"""Bit-true model of fringe_quadrature: against a scalar reference, against float, validation."""

import math

import numpy as np
import pytest

from fringe.dsp.quadrature_float import quadrature_float
from fringe.fixed.quadrature import (
    QuadratureCoefs,
    QuadratureParams,
    error_budget,
    quadrature,
    quantise_coefs,
)

CONFIGS = [QuadratureParams(18, 18), QuadratureParams(20, 16), QuadratureParams(8, 8),
           QuadratureParams(32, 27)]
IDS = [f"wave{p.wave_w}_coef{p.coef_w}" for p in CONFIGS]


def reference(xs, xc, k_ss, k_sc, k_cc, ofs_s, ofs_c, p):
    """Scalar, plain-int transcription of docs/architecture.md (independent of the model)."""
    f = p.coef_w - 2
    lo, hi = -(1 << (p.wave_w - 1)), (1 << (p.wave_w - 1)) - 1
    s = (k_ss * (xs - ofs_s) + k_sc * (xc - ofs_c) + (1 << (f - 1))) >> f
    c = (k_cc * (xc - ofs_c) + (1 << (f - 1))) >> f
    ss, cc = min(max(s, lo), hi), min(max(c, lo), hi)
    return ss, cc, ss != s or cc != c


def random_codes(rng, w, n):
    return rng.integers(-(1 << (w - 1)), 1 << (w - 1), n)


@pytest.mark.parametrize("p", CONFIGS, ids=IDS)
def test_model_matches_scalar_reference(p):
    seed = 2000 + p.wave_w
    rng = np.random.default_rng(seed)
    n = 3000
    xs, xc = random_codes(rng, p.wave_w, n), random_codes(rng, p.wave_w, n)
    k = [random_codes(rng, p.coef_w, n) for _ in range(3)]
    o = [random_codes(rng, p.wave_w, n) // 8 for _ in range(2)]
    # corners: extreme codes everywhere
    lo_w, hi_w = -(1 << (p.wave_w - 1)), (1 << (p.wave_w - 1)) - 1
    lo_k, hi_k = -(1 << (p.coef_w - 1)), (1 << (p.coef_w - 1)) - 1
    corners = [(a, b, c, d, e, f, g) for a in (lo_w, hi_w) for b in (lo_w, hi_w) for c in (lo_k, hi_k)
               for d in (lo_k, hi_k) for e in (lo_k, hi_k) for f in (lo_w, hi_w) for g in (lo_w, hi_w)]
    cols = list(zip(*corners, strict=True))
    xs, xc = np.concatenate([xs, cols[0]]), np.concatenate([xc, cols[1]])
    k = [np.concatenate([k[i], cols[2 + i]]) for i in range(3)]
    o = [np.concatenate([o[i], cols[5 + i]]) for i in range(2)]
    coefs = QuadratureCoefs(k_ss=k[0], k_sc=k[1], k_cc=k[2], ofs_s=o[0], ofs_c=o[1])
    s, c, sat = quadrature(xs, xc, coefs, p)
    for i in range(xs.size):
        ref = reference(int(xs[i]), int(xc[i]), int(k[0][i]), int(k[1][i]), int(k[2][i]), int(o[0][i]),
                        int(o[1][i]), p)
        assert (int(s[i]), int(c[i]), bool(sat[i])) == ref, f"seed {seed}, sample {i}"
    assert sat.any() and not sat.all()


@pytest.mark.parametrize("p", CONFIGS, ids=IDS)
def test_model_vs_float_within_budget(p):
    """Seed 001 eq. 21 form (k_ss = 1/cos a, k_sc = tan a) plus offsets and a cosine gain."""
    rng = np.random.default_rng(3000 + p.wave_w)
    a = math.radians(3.0)
    kf = dict(k_ss=1.02 / math.cos(a), k_sc=math.tan(a), k_cc=0.97)
    of = dict(ofs_s=0.0123, ofs_c=-0.0071)
    coefs = quantise_coefs(**kf, **of, params=p)
    scale = float(1 << p.wave_frac)
    # unit circle with some amplitude spread: no saturation
    th = rng.uniform(0, 2 * np.pi, 20000)
    r = rng.uniform(0.5, 1.2, th.size)
    xs = np.floor(r * np.sin(th) * scale + 0.5).astype(np.int64)
    xc = np.floor(r * np.cos(th) * scale + 0.5).astype(np.int64)
    s, c, sat = quadrature(xs, xc, coefs, p)
    assert not sat.any()
    # 1) against the float result with the quantised coefficients: rounding only (1/2 LSB)
    k_ss, k_sc, k_cc, o_s, o_c = coefs.as_float(p)
    fs, fc = quadrature_float(xs / scale, xc / scale, k_ss, k_sc, k_cc, o_s, o_c)
    assert np.abs(s - fs * scale).max() <= 0.5 + 1e-6
    assert np.abs(c - fc * scale).max() <= 0.5 + 1e-6
    # 2) against the float coefficients: within the budget
    fs, fc = quadrature_float(xs / scale, xc / scale, **kf, **of)
    d_max = 1.3
    bs, bc = error_budget(p, **kf, d_max=d_max)
    es, ec = np.abs(s - fs * scale).max(), np.abs(c - fc * scale).max()
    assert es <= bs and ec <= bc, f"errors {es:.3f}/{ec:.3f} LSB, budget {bs:.3f}/{bc:.3f}"


@pytest.mark.parametrize("p", CONFIGS[:2], ids=IDS[:2])
def test_saturation(p):
    lo, hi = -(1 << (p.wave_w - 1)), (1 << (p.wave_w - 1)) - 1
    coefs = quantise_coefs(1.9, 0.0, 1.9, -1.0, 1.0, p)
    s, c, sat = quadrature(np.array([hi, lo, lo, 0]), np.array([lo, hi, lo, 0]), coefs, p)
    # xs - ofs_s = 3.0 -> s saturates high; xc - ofs_c = -3.0 -> c saturates low
    assert (s[0], c[0], sat[0]) == (hi, lo, True)
    assert not sat[1] and abs(s[1] + c[1]) <= 3
    assert (c[2], sat[2]) == (lo, True) and s[2] > lo
    assert not sat[3]


def test_quantise_coefs_rounding_and_checks():
    p = CONFIGS[0]
    q = quantise_coefs(1.0, -0.5, 1.9999, 0.25, -2.0, p)
    assert (q.k_ss, q.k_sc, q.k_cc) == (1 << 16, -(1 << 15), round(1.9999 * (1 << 16)))
    assert (q.ofs_s, q.ofs_c) == (1 << 14, -(1 << 17))
    # half up
    assert quantise_coefs(0.5 / (1 << 16), -0.5 / (1 << 16), 0, 0, 0, p).k_ss == 1
    assert quantise_coefs(0.5 / (1 << 16), -0.5 / (1 << 16), 0, 0, 0, p).k_sc == 0
    with pytest.raises(ValueError, match=r"k_sc = 2.0 out of range \[-2, 2\)"):
        quantise_coefs(1.0, 2.0, 1.0, 0, 0, p)
    with pytest.raises(ValueError, match=r"k_cc = -2.1 out of range"):
        quantise_coefs(1.0, 0.0, -2.1, 0, 0, p)
    with pytest.raises(ValueError, match=r"ofs_c = 1.999999 out of range"):
        quantise_coefs(1.0, 0.0, 1.0, 0, 1.999999, p)
    assert quantise_coefs(1.0, 0.0, 1.0, 0, 1.99999, p).ofs_c == (1 << 17) - 1
    with pytest.raises(ValueError, match="ofs_s = nan is not finite"):
        quantise_coefs(1.0, 0.0, 1.0, float("nan"), 0, p)
    # arrays (one coefficient set per sample) work too
    qa = quantise_coefs(np.array([1.0, 0.5]), 0.0, 1.0, 0.0, 0.0, p)
    assert qa.k_ss.tolist() == [1 << 16, 1 << 15]


def test_input_codes_checked():
    p = CONFIGS[0]
    coefs = quantise_coefs(1.0, 0.0, 1.0, 0.0, 0.0, p)
    with pytest.raises(ValueError, match=r"xs: code 131072 out of range s\(18\)"):
        quadrature(np.array([1 << 17]), np.array([0]), coefs, p)
    bad = QuadratureCoefs(k_ss=1 << 17, k_sc=0, k_cc=0, ofs_s=0, ofs_c=0)
    with pytest.raises(ValueError, match=r"k_ss: code 131072 out of range s\(18\)"):
        quadrature(np.array([0]), np.array([0]), bad, p)
    with pytest.raises(ValueError, match="integer codes"):
        quadrature(np.array([0.5]), np.array([0]), coefs, p)


@pytest.mark.parametrize("kw, msg", [
    (dict(wave_w=7, coef_w=18), "fringe_quadrature: WAVE_W = 7 out of range 8..32"),
    (dict(wave_w=33, coef_w=18), "fringe_quadrature: WAVE_W = 33 out of range 8..32"),
    (dict(wave_w=18, coef_w=7), "fringe_quadrature: COEF_W = 7 out of range 8..27"),
    (dict(wave_w=18, coef_w=28), "fringe_quadrature: COEF_W = 28 out of range 8..27"),
])
def test_parameter_validation(kw, msg):
    with pytest.raises(ValueError) as e:
        QuadratureParams(**kw)
    assert str(e.value) == msg


