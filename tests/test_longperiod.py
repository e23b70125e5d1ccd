"""Seed 000's long-period model: closed form, harmonic selection, and the DE / DE+SA training."""

import json

import numpy as np
import pytest

from fringe.dsp import longperiod
from fringe.dsp.longperiod import (
    FourierSeries,
    _crossover,
    _donors,
    _mutate,
    design_matrix,
    fit_de,
    fit_lsq,
    select_harmonics,
)
from fringe.dsp.seeds import SEED000_WEIGHTS, seed000_error_arcsec

X64 = np.arange(64) * 2 * np.pi / 64          # the paper's training angles: 5.625 degree steps
Q_SEED = 20 / np.sqrt(12)                     # quantisation noise of the seed's 20" encoder


def test_design_matrix_order_is_the_papers():
    x = np.array([0.3, -1.2, 7.0])
    want = np.column_stack([np.ones(3), np.cos(x), np.cos(2 * x), np.cos(3 * x),
                            np.sin(x), np.sin(2 * x), np.sin(3 * x)])
    np.testing.assert_allclose(design_matrix(x, 3), want, atol=1e-14)
    np.testing.assert_array_equal(design_matrix(x, 0), np.ones((3, 1)))


def test_series_evaluates_round_trips_and_reports_amplitudes():
    s = FourierSeries(SEED000_WEIGHTS)
    assert s.n == 9
    x = np.linspace(0, 2 * np.pi, 50)
    np.testing.assert_allclose(s(x), design_matrix(x, 9) @ SEED000_WEIGHTS, atol=1e-14)
    back = FourierSeries.from_dict(json.loads(json.dumps(s.to_dict())))
    np.testing.assert_array_equal(back.weights, s.weights)
    np.testing.assert_allclose(s.amplitudes(), np.hypot(SEED000_WEIGHTS[1:10], SEED000_WEIGHTS[10:]))


def test_slope_is_the_series_derivative():
    """Against a central difference of step h, whose error is the third derivative times h^2 / 6 (below 1e-6
    of the slope here)."""
    rng = np.random.default_rng(5)
    s = FourierSeries(rng.normal(0, 10, 2 * 16 + 1))
    x = rng.uniform(0, 2 * np.pi, 200)
    h = 1e-5
    np.testing.assert_allclose(s.slope(x), (s(x + h) - s(x - h)) / (2 * h), rtol=1e-6, atol=1e-6)
    assert np.all(FourierSeries(np.array([3.0])).slope(x) == 0.0)


@pytest.mark.parametrize("path", ["matrix", "moments"])
def test_lsq_recovers_weights_within_the_noise_bound(path, monkeypatch):
    """For uniformly spread angles the standard error is sigma/sqrt(N) for w1 = a0/2 and
    sigma*sqrt(2/N) for the a_l, b_l; 4.5 of them (p ~ 7e-6 per weight) bound the error."""
    if path == "moments":
        monkeypatch.setattr(longperiod, "_DIRECT_MAX", 0)
    rng = np.random.default_rng(1)
    n_samples, sigma = 20000, 0.05
    x = rng.uniform(0, 2 * np.pi, n_samples)
    y = FourierSeries(SEED000_WEIGHTS)(x) + rng.normal(0, sigma, n_samples)
    se = sigma * np.sqrt(np.r_[1, np.full(18, 2)] / n_samples)
    assert np.all(np.abs(fit_lsq(x, y, 9).weights - SEED000_WEIGHTS) < 4.5 * se)


@pytest.mark.parametrize("arc", [2 * np.pi, 0.3])
def test_moment_path_matches_the_matrix_path(arc, monkeypatch):
    """Normal equations from moments give the lstsq answer; on a short arc (ill-conditioned) the
    condition check sends the fit back to the matrix, so the answer stays the same."""
    rng = np.random.default_rng(2)
    x = rng.uniform(0, arc, 3000)
    y = np.cos(x) + 0.3 * np.sin(3 * x) + rng.normal(0, 0.01, len(x))
    direct = fit_lsq(x, y, 5).weights
    monkeypatch.setattr(longperiod, "_DIRECT_MAX", 0)
    np.testing.assert_allclose(fit_lsq(x, y, 5).weights, direct, rtol=1e-8, atol=1e-8)


def test_bic_picks_the_seeds_nine_harmonics_and_nothing_for_noise():
    rng = np.random.default_rng(3)
    x = rng.uniform(0, 2 * np.pi, 20000)
    assert select_harmonics(x, seed000_error_arcsec(x) + rng.normal(0, 1.3, len(x))) == 9
    assert select_harmonics(x, rng.normal(0, 1.3, len(x))) == 0


def test_bic_keeps_fewer_harmonics_from_64_points():
    """A harmonic of amplitude A lowers the RSS by about N A^2/2 and costs 2 ln N sigma^2 in BIC,
    so it is kept only if A > sigma*sqrt(4 ln N / N): 2.9" for the paper's 64 points at the
    quantisation noise of its 20" encoder. Harmonics 1-2 (26", 9.7") clear it twice over, 4-9
    (<= 2.3") do not."""
    amp = fit_lsq(X64, seed000_error_arcsec(X64), 9).amplitudes()
    threshold = Q_SEED * np.sqrt(4 * np.log(64) / 64)
    must = int(np.max(np.flatnonzero(amp > 2 * threshold))) + 1
    y = seed000_error_arcsec(X64) + np.random.default_rng(4).normal(0, Q_SEED, 64)
    assert must <= select_harmonics(X64, y) < 9


def test_default_n_max_from_64_points_is_15():
    """64 distinct angles allow 2n+1 <= 64/2 - 1, n <= 15, however many harmonics the data hold."""
    y = design_matrix(X64, 20)[:, 1:21] @ np.r_[np.ones(15), np.full(5, 0.3)]
    assert select_harmonics(X64, y, 25) == 20       # the data do hold 20 harmonics
    assert select_harmonics(X64, y) == 15


def test_donors_are_distinct_and_not_the_target():
    r = _donors(7, np.random.default_rng(5))
    own = np.arange(7)[:, None]
    assert np.all(r != own)
    assert np.all((r[:, 0] != r[:, 1]) & (r[:, 0] != r[:, 2]) & (r[:, 1] != r[:, 2]))
    counts = np.bincount(np.concatenate([_donors(7, np.random.default_rng(s)).ravel() for s in range(300)]))
    # every index is a donor equally often: 300 * 7 * 3 / 7 = 900 each, sd ~ 26
    assert np.all(np.abs(counts - 900) < 5 * 26)


def test_mutation_is_eq14_at_eta_1_and_eq15_at_eta_0():
    pop = np.random.default_rng(6).normal(size=(10, 5))
    best, f = 3, 0.5
    r = _donors(10, np.random.default_rng(7))
    eq14 = pop[r[:, 2]] + f * (pop[r[:, 0]] - pop[r[:, 1]])
    eq15 = pop[best] + f * (pop[r[:, 0]] - pop[r[:, 1]])
    np.testing.assert_allclose(_mutate(pop, best, f, 1.0, np.random.default_rng(7)), eq14, rtol=0, atol=1e-15)
    np.testing.assert_allclose(_mutate(pop, best, f, 0.0, np.random.default_rng(7)), eq15, rtol=0, atol=1e-15)


def test_crossover_takes_at_least_one_gene_from_the_mutant():
    pop, v = np.zeros((50, 6)), np.ones((50, 6))
    assert np.all(_crossover(pop, v, 0.0, np.random.default_rng(8)).sum(axis=1) == 1)
    assert np.all(_crossover(pop, v, 1.0, np.random.default_rng(8)) == 1)


def test_desa_first_generation_is_plain_de():
    """eta = (G_max - 0)/G_max = 1 at the first mutation: with one generation both variants agree."""
    y = np.cos(X64)
    a = fit_de(X64, y, 1, variant="de", rng=9, g_max=1)
    b = fit_de(X64, y, 1, variant="desa", rng=9, g_max=1)
    np.testing.assert_array_equal(a.series.weights, b.series.weights)
    assert a.generations == 1 and len(a.history) == 2 and not a.reached


@pytest.mark.parametrize("variant", ["de", "desa"])
def test_de_converges_to_the_least_squares_optimum(variant):
    """RMS within (1+t) of the optimum bounds the weights: (w-w*)' G (w-w*) = RSS - RSS* <=
    ((1+t)^2 - 1) RSS*, and G = M'M = diag(64, 32, ...) for the 64 equally spaced points."""
    rng = np.random.default_rng(10)
    y = 3 + 2 * np.cos(X64) - np.sin(2 * X64) + rng.normal(0, 0.1, 64)
    opt = fit_lsq(X64, y, 2)
    rss = float(np.sum((opt(X64) - y) ** 2))
    t = 0.01
    r = fit_de(X64, y, 2, variant=variant, rng=11, g_max=1500, target_rms=(1 + t) * np.sqrt(rss / 64))
    assert r.reached and r.generations == len(r.history) - 1 < 1500
    assert np.all(np.diff(r.history) <= 0)            # greedy selection never loses the best
    bound = np.sqrt(((1 + t) ** 2 - 1) * rss / 32)
    assert np.all(np.abs(r.series.weights - opt.weights) <= bound)
    again = fit_de(X64, y, 2, variant=variant, rng=11, g_max=1500, target_rms=(1 + t) * np.sqrt(rss / 64))
    np.testing.assert_array_equal(again.history, r.history)


@pytest.mark.parametrize("call,msg", [
    (lambda: fit_lsq(X64, np.sin(X64), -1), "n must be"),
    (lambda: fit_lsq(X64, np.sin(X64), 1.5), "n must be"),
    (lambda: fit_lsq(X64, np.sin(X64[:10]), 1), "differ in length"),
    (lambda: fit_lsq(X64[:10], np.sin(X64[:10]), 5), "cannot determine"),
    (lambda: select_harmonics(X64[:10], np.sin(X64), 2), "differ in length"),
    (lambda: select_harmonics(X64, np.sin(X64), 40), "cannot determine"),
    (lambda: fit_de(X64, np.sin(X64), 2, variant="pso"), "unknown variant"),
    (lambda: fit_de(X64, np.sin(X64), -1), "n must be"),
    (lambda: fit_de(X64, np.sin(X64), 40), "cannot determine"),
    (lambda: fit_de(X64, np.sin(X64), 1, pop_size=3), "pop_size"),
    (lambda: design_matrix(X64, -2), "n must be"),
    (lambda: FourierSeries(np.zeros(4)), "2n\\+1 weights"),
])
def test_bad_arguments(call, msg):
    with pytest.raises(ValueError, match=msg):
        call()
