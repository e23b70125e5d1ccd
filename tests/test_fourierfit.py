"""The fast paths of the Fourier fits (fringe.dsp.fourierfit, effects.phase_columns) against the plain products
they replace: the normal equations from the weights' spectrum, the held-out predictions of every candidate size from
one orthonormal basis, and harmonics as powers of exp(i phi)."""

import numpy as np
import pytest

from fringe.dsp.effects import phase_columns
from fringe.dsp.fourierfit import _gram_at_bin_centres, _orders, cv_folds, cv_harmonics, harmonic_design


@pytest.mark.parametrize("bins, top, skip", [(4096, 64, 0), (4096, 40, 7), (64, 40, 0), (16, 3, 0)])
def test_the_normal_equations_from_the_spectrum_equal_the_products(bins, top, skip):
    """Including harmonics above half the bins (their products alias; the spectrum's index wraps alike)."""
    rng = np.random.default_rng(bins + top)
    counts = rng.integers(0, 20, size=(3, bins)).astype(float)
    orders = _orders(top, skip)
    m = harmonic_design(2 * np.pi * (np.arange(bins) + 0.5) / bins, orders)
    direct = np.stack([m.T @ (m * c[:, None]) for c in counts])
    assert np.abs(_gram_at_bin_centres(counts, orders) - direct).max() <= 1e-12 * np.abs(direct).max()


def _held_out_rms_by_products(x, y, n_max, folds, bins=4096):
    """Each fold predicted by the least-squares series of the other folds, every size fitted on its own."""
    cell = np.minimum((np.mod(x / (2 * np.pi), 1.0) * bins).astype(int), bins - 1)
    centres = 2 * np.pi * (np.arange(bins) + 0.5) / bins
    press = np.zeros(n_max + 1)
    for n in range(n_max + 1):
        m = harmonic_design(centres, _orders(n, 0))[cell]
        for f in np.unique(folds):
            w = np.linalg.lstsq(m[folds != f], y[folds != f], rcond=None)[0]
            press[n] += np.sum((y[folds == f] - m[folds == f] @ w) ** 2)
    return np.sqrt(press / len(y))


def test_held_out_errors_of_every_size_equal_separate_fits():
    rng = np.random.default_rng(7)
    x = rng.uniform(0, 4 * np.pi, 3000)
    y = 0.5 * np.cos(3 * x + 1) + 0.2 * np.sin(5 * x) + rng.normal(0, 0.3, x.size)
    folds = cv_folds(x.size, 4)
    chosen, rms = cv_harmonics(x, y, 8, folds)
    expected = _held_out_rms_by_products(x, y, 8, folds)
    assert np.allclose(rms, expected, rtol=1e-9)
    assert chosen == int(np.argmin(expected)) >= 5       # the 5th harmonic is there; noise may add one more


def test_harmonic_columns_are_those_of_cos_and_sin():
    phi = np.random.default_rng(3).uniform(-60, 60, 20_000)
    cols = phase_columns(phi, 40, constant=True)
    plain = [np.ones_like(phi)] + [f(j * phi) for j in range(1, 41) for f in (np.cos, np.sin)]
    assert len(cols) == len(plain)
    assert max(np.abs(a - b).max() for a, b in zip(cols, plain, strict=True)) < 1e-12
