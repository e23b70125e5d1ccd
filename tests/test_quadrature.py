"""Quadrature: the seed's ellipse (phase only) and the general conic (offsets, gains, phase)."""

import numpy as np
import pytest

from fringe.dsp.quadrature import QuadratureFitError, fit_conic, fit_seed_ellipse


def _lissajous(alpha, g_s=1.0, g_c=1.0, o_s=0.0, o_c=0.0, n=2000):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return t, o_s + g_s * np.sin(t - alpha), o_c + g_c * np.cos(t)


def test_seed_ellipse_recovers_phase_error():
    """Eq. 19 on noise-free data returns alpha exactly, and eq. 21 restores sin t."""
    t, s, c = _lissajous(alpha=-0.00013)
    q = fit_seed_ellipse(s, c)
    assert q.alpha_rad == pytest.approx(-0.00013, abs=1e-9)
    s2, c2 = q.apply(s, c)
    np.testing.assert_allclose(np.arctan2(s2, c2), np.angle(np.exp(1j * t)), atol=1e-9)


def test_conic_recovers_offsets_gains_and_phase():
    t, s, c = _lissajous(alpha=0.05, g_s=900.0, g_c=1000.0, o_s=12.0, o_c=-7.0)
    q = fit_conic(s, c)
    assert (q.ofs_s, q.ofs_c) == (pytest.approx(12.0, abs=1e-6), pytest.approx(-7.0, abs=1e-6))
    assert q.alpha_rad == pytest.approx(0.05, abs=1e-9)
    assert q.gain_ratio == pytest.approx(0.9, abs=1e-9)
    s2, c2 = q.apply(s, c)
    np.testing.assert_allclose(np.hypot(s2, c2), 1.0, atol=1e-9)
    np.testing.assert_allclose(np.angle(np.exp(1j * (np.arctan2(s2, c2) - t))), 0.0, atol=1e-9)


def test_partial_ellipse_is_refused():
    t = np.linspace(0, 1.0, 500)
    with pytest.raises(QuadratureFitError, match="full signal period"):
        fit_conic(np.sin(t), np.cos(t))


def test_a_speed_in_step_with_the_sampling_is_named_as_such():
    """0.2 periods a sample, steady: a long recording that visits five phases is not 'less than a period'."""
    t = 2 * np.pi * (0.2 * np.arange(4000) + 1e-4 * np.random.default_rng(1).standard_normal(4000))
    with pytest.raises(QuadratureFitError, match="moves 0.2 periods a sample.*same few phases"):
        fit_conic(np.sin(t), np.cos(t))
