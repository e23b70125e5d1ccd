"""Seed 000's long-period model: closed form, harmonic selection, and the DE / DE+SA training."""

import numpy as np
import pytest

from fringe.fourierfit import fit_select
from fringe.longperiod import FourierSeries, _mutate, design_matrix, fit_de, fit_lsq
from fringe.seeds import SEED000_WEIGHTS, seed000_error_arcsec


def test_design_matrix_order_is_the_papers():
    x = np.array([0.3])
    m = design_matrix(x, 2)
    np.testing.assert_allclose(m[0], [1, np.cos(0.3), np.cos(0.6), np.sin(0.3), np.sin(0.6)])


def test_lsq_recovers_weights_within_the_noise_bound():
    """Each weight's standard error is sigma*sqrt(2/N) for uniformly spread angles: 5 of them bound it."""
    rng = np.random.default_rng(1)
    n, sigma = 20000, 0.05
    x = rng.uniform(0, 2 * np.pi, n)
    y = FourierSeries(SEED000_WEIGHTS)(x) + rng.normal(0, sigma, n)
    got = fit_lsq(x, y, 9).weights
    assert np.all(np.abs(got - SEED000_WEIGHTS) < 5 * sigma * np.sqrt(2 / n))


def test_series_round_trips_through_json():
    s = FourierSeries(SEED000_WEIGHTS)
    np.testing.assert_array_equal(FourierSeries.from_dict(s.to_dict()).weights, s.weights)


def test_bic_picks_the_seeds_nine_harmonics_and_nothing_for_noise():
    rng = np.random.default_rng(2)
    x = rng.uniform(0, 2 * np.pi, 50000)
    _, n, _ = fit_select(x, seed000_error_arcsec(x) + rng.normal(0, 1.3, len(x)), 30)
    assert n == 9
    _, n, _ = fit_select(x, rng.normal(0, 1.3, len(x)), 30)
    assert n == 0


def test_mutation_is_eq14_at_eta_1_and_eq15_at_eta_0():
    pop = np.arange(40.0).reshape(10, 4)
    a = _mutate(pop, 3, 0.5, 1.0, np.random.default_rng(5))
    b = _mutate(pop, 3, 0.5, 0.0, np.random.default_rng(5))
    # same random r1, r2, r3: the difference is eta*(w_r3 - w_best)
    diff = a - b
    assert np.all([np.any(np.all(np.isclose(d, pop - pop[3]), axis=1)) for d in diff])


@pytest.mark.parametrize("variant", ["de", "desa"])
def test_de_converges_to_the_least_squares_optimum(variant):
    rng = np.random.default_rng(3)
    x = np.arange(64) * 2 * np.pi / 64
    y = 3 + 2 * np.cos(x) - np.sin(2 * x) + rng.normal(0, 0.1, 64)
    opt = fit_lsq(x, y, 2)
    e_opt = np.sqrt(np.mean((opt(x) - y) ** 2))
    r = fit_de(x, y, 2, variant=variant, rng=np.random.default_rng(4), g_max=1500, target_rms=1.01 * e_opt)
    assert r.reached and np.all(np.diff(r.history) <= 0)


@pytest.mark.parametrize("kwargs,msg", [(dict(n=-1), "n must be"), (dict(variant="pso"), "unknown variant"),
                                        (dict(n=40), "cannot determine")])
def test_bad_arguments(kwargs, msg):
    x = np.arange(64.0)
    args = dict(n=2, variant="de") | kwargs
    with pytest.raises(ValueError, match=msg):
        fit_de(x, np.sin(x), args["n"], variant=args["variant"])
