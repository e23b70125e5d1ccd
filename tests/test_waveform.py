"""Seed 001 waveform model: multiple-angle matrix, polynomial inverse, and the generalised inverse."""

import numpy as np
import pytest

from fringe.dsp import seeds
from fringe.dsp.waveform import ChannelWaveform, PaperChannel, build_inverse, multiple_angle_matrix


def test_multiple_angle_matrix_is_exact():
    """Eq. 8: [sin t, sin 3t, ..., sin 23t] = M [x, x^3, ..., x^23], x = sin t."""
    t = np.linspace(-np.pi, np.pi, 1001)
    x = np.sin(t)
    m = multiple_angle_matrix(23)
    orders = np.arange(1, 24, 2)
    lhs = np.sin(np.outer(t, orders))
    rhs = (x[:, None] ** orders) @ m.T
    # rounding bound: the polynomial's terms cancel, so the error scales with sum |M[n, k]|
    bound = 8 * np.finfo(float).eps * np.abs(m).sum(axis=1)
    assert np.all(np.abs(lhs - rhs) <= bound)
    np.testing.assert_array_equal(m[0], np.eye(len(orders))[0])       # sin t = x
    np.testing.assert_allclose(m[1, :2], [3, -4])                      # sin 3t = 3x - 4x^3


def test_paper_inverse_recovers_sin_theta_on_its_half_period():
    ch = PaperChannel(0.0, seeds.SEED001_SIN_COEFFS, seeds.SEED001_F2["sin"])
    t = np.linspace(-np.pi / 2 + 0.05, np.pi / 2 - 0.05, 500)     # cos t >= 0: the seed's assumption
    orders = seeds.SEED001_ORDERS
    y = np.sin(np.outer(t, orders)) @ ch.odd + 2 * ch.f2 * np.sin(t) * np.cos(t)
    np.testing.assert_allclose(ch.invert(y), np.sin(t), atol=1e-9)


def _channel(kind, a, b, w0=0.0):
    return ChannelWaveform(kind, np.concatenate([[w0], a, b]))


def test_general_inverse_handles_even_and_cosine_phase_harmonics():
    """With a cos(2t) term and a cosine-phase 3rd harmonic the reading is not a function of sin t:
    the seed's polynomial inverse errs, the two-branch table (other channel's sign) does not."""
    sin_ch = _channel("sin", a=[0.0, 0.06, 0.03], b=[1.0, 0.0, -0.1], w0=0.01)
    cos_ch = _channel("cos", a=[1.0, 0.0, 0.05], b=[0.0, 0.0, 0.0])
    inv = build_inverse(sin_ch, cos_ch, -1.3, 1.3, 20001)
    t = np.linspace(0, 2 * np.pi, 5000, endpoint=False)
    y, other = sin_ch(t), cos_ch(t)
    ideal = sin_ch.ideal(t)
    got = inv(y, other)
    # angle error this value causes in the arctan is (error) * |cos(t + psi)|: weigh it so
    weight = np.abs(np.cos(t + sin_ch.psi))
    # away from the extremes only the table's linear interpolation is left: (step^2/8)*|x''| < 1e-8
    err = np.abs(got - ideal) * weight
    step = inv.step
    far = (y < y.max() - 100 * step) & (y > y.min() + 100 * step)
    assert np.max(err[far]) < 1e-6
    # at an extreme x(y) has a square-root shape: a table step spans dtheta ~ sqrt(2*step/|g''|),
    # so the weighted error is about |d(ideal)/dtheta| * dtheta * weight ~ 2e-5 here
    assert np.max(err) < 3e-5
    from fringe.dsp.waveform import paper_channel
    seed_err = np.abs(paper_channel(sin_ch).invert(y) - ideal) * weight
    assert np.max(seed_err) > 1e-2, "the seed's inverse should fail on this waveform"


def test_branch_threshold_follows_the_other_channel():
    sin_ch = _channel("sin", a=[0.0], b=[1.0])
    cos_ch = _channel("cos", a=[1.0], b=[0.0], w0=0.2)      # offset cos channel
    inv = build_inverse(sin_ch, cos_ch, -1.1, 1.1, 2001)
    # the cos channel at the sine's extremes (t = +-pi/2) reads its offset
    assert inv.threshold_hi == pytest.approx(0.2, abs=1e-3) and inv.threshold_lo == pytest.approx(0.2, abs=1e-3)
    assert inv.mid == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize("seed", [1, 2])
def test_readings_beyond_the_extremes_follow_the_inverses_slope(seed):
    """A sinusoidal channel plus an additive tone of 10 % of its amplitude: beyond the waveform's extremes the
    tables must go on reading (reading - offset) / amplitude, as inside, up to BEYOND_MAX. Held at the extreme's
    value they would err by up to the tone's 0.1, and take the tone's radial part out near the extremes
    (an interference canceller adapts on that radius). Tolerance: for a sinusoid the inverse is linear in the
    reading and the extremes' values are computed, not interpolated, so only rounding is left (measured 1e-15);
    reading the extreme's value off the table instead erred by 4e-5."""
    from fringe.dsp.waveform import BEYOND_MAX
    rng = np.random.default_rng(seed)
    amplitude, offset = rng.uniform(0.5, 0.9), rng.uniform(-0.05, 0.05)
    sin_ch = _channel("sin", a=[0.0], b=[amplitude], w0=offset)
    cos_ch = _channel("cos", a=[amplitude], b=[0.0])
    inv = build_inverse(sin_ch, cos_ch, -1.3, 1.3, 20001)
    t = rng.uniform(0, 2 * np.pi, 20_000)
    y = sin_ch(t) + 0.1 * amplitude * np.sin(rng.uniform(0, 2 * np.pi, t.size))
    beyond = (y > offset + amplitude) | (y < offset - amplitude)
    assert beyond.sum() > 100
    expected = np.clip((y - offset) / amplitude, -BEYOND_MAX, BEYOND_MAX)
    assert np.max(np.abs(inv(y, cos_ch(t)) - expected)[beyond]) < 1e-9
    assert np.max(np.abs(expected[beyond]) - 1) > 0.09      # the tone reaches beyond: a flat table would fail
