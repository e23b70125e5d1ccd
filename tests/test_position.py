"""Coarse/fine combination and period counting, for any number of lines."""

import numpy as np
import pytest

from fringe.dsp.position import coarse_fine_combine, count_periods, fit_coarse_offset


@pytest.mark.parametrize("lines,coarse_bits", [(256, 9), (256, 8), (100, 8), (3, 4), (1, 3)])
def test_coarse_sync_recovers_absolute_position(lines, coarse_bits):
    rng = np.random.default_rng(lines + coarse_bits)
    pos = np.cumsum(rng.normal(0.01, 0.05, 20000)) % lines      # periods, wanders both ways
    frac = pos % 1.0
    misalign = 0.13                                                     # periods
    span = lines / (1 << coarse_bits)
    jitter = rng.normal(0, 0.02, pos.shape) if span < 1 else 0.0      # no margin when span = 1
    coarse = np.floor((pos + misalign + jitter) / span).astype(np.int64) % (1 << coarse_bits)
    offset = fit_coarse_offset(frac, coarse, lines, coarse_bits)
    # centre of code 0 is half a code after its start edge at -misalign
    assert np.angle(np.exp(2j * np.pi * (offset - (span / 2 - misalign)))) == pytest.approx(0, abs=0.01)
    got, flag = coarse_fine_combine(frac, coarse, lines, coarse_bits, offset)
    d = (got - pos + lines / 2) % lines - lines / 2
    if span < 1:
        assert np.all(np.abs(d) < 1e-9)
    else:
        # no overlap bit: nothing can settle a sample right at a code edge; the edge estimate is
        # good to ~1e-3 period, so only samples that close to an edge may be a period off
        near_edge = np.abs(((pos + misalign) % 1.0 + 0.5) % 1.0 - 0.5) < 2e-3
        assert np.all((np.abs(d) < 1e-9) | near_edge)
    assert not flag.any()


def test_wrong_coarse_code_is_flagged():
    """A code one step off moves the residual by half a period: beyond any edge jitter."""
    lines, bits = 256, 9
    pos = np.arange(5120) * 0.05 + np.random.default_rng(1).normal(0, 0.005, 5120)
    coarse = np.floor(pos * 2).astype(np.int64) % 512
    coarse[1005] = (coarse[1005] + 1) % 512          # pos 50.25: the middle of its code
    offset = fit_coarse_offset(pos % 1, coarse, lines, bits)
    _, flag = coarse_fine_combine(pos % 1, coarse, lines, bits, offset)
    assert flag[1005] and flag.sum() == 1


def test_counting_flags_a_quarter_period_jump():
    frac = np.array([0.0, 0.1, 0.2, 0.3, 0.55, 0.6]) % 1.0
    pos, flag = count_periods(frac, 4)
    assert list(flag) == [False, False, False, False, True, False]
    frac = np.mod(np.arange(40) * 0.2, 1.0)
    pos, flag = count_periods(frac, 4)
    np.testing.assert_allclose(pos, np.mod(np.arange(40) * 0.2, 4), atol=1e-12)
    assert not flag.any()


def test_the_track_restarts_at_gaps_in_the_rows():
    """Rows taken out of a recording (the loop's interleaved halves, cross-validation folds) leave gaps the motion
    crossed unseen: the coarse/fine track restarts at each (pipeline.run_starts), else a gap of a period and a
    fraction is tracked as the fraction alone and the position is a period off until the next trusted sample."""
    from fringe.engine.pipeline import run_starts

    lines, bits = 64, 6                                  # one code per period: tracking carries the edges
    n = 40_000
    t = np.arange(n) * 1e-4
    true = 0.371234 * np.arange(n) % lines               # periods a sample (no code edge exactly on a sample)
    frac = true % 1.0
    coarse = np.floor((true + 0.1) * (1 << bits) / lines).astype(np.int64) % (1 << bits)
    keep = (np.arange(n) // 7) % 2 == 0                  # blocks of 7 rows, every other one
    offset = fit_coarse_offset(frac, coarse, lines, bits)
    want = true[keep]
    got, _ = coarse_fine_combine(frac[keep], coarse[keep], lines, bits, offset, run_starts(t[keep], keep.sum()))
    np.testing.assert_allclose(np.mod(got - want + lines / 2, lines) - lines / 2, 0, atol=1e-9)
    bridged, _ = coarse_fine_combine(frac[keep], coarse[keep], lines, bits, offset)
    assert np.any(np.abs(np.mod(bridged - want + lines / 2, lines) - lines / 2) > 0.5)
