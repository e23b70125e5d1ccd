"""Fast Fourier-series least squares on binned data, with the number of harmonics chosen by BIC
or by cross-validation (held-out data).

Calibration fits Fourier series to a million samples several times. Averaging the samples in
fine angle bins first (count, mean angle, mean value) leaves the least-squares problem the
same up to the tiny spread of the angle inside a bin, and makes every fit cost one pass over
the data plus a small dense solve.
"""

import numpy as np
from scipy.linalg import LinAlgError, cholesky, solve_triangular

from .longperiod import FourierSeries


def harmonic_design(x: np.ndarray, orders: list[int]) -> np.ndarray:
    """Columns [1, cos h1 x, sin h1 x, cos h2 x, ...]: a model with fewer harmonics is a prefix."""
    z = np.exp(1j * np.asarray(x, float))
    m = np.empty((len(z), 2 * len(orders) + 1))
    m[:, 0] = 1.0
    p, at = np.ones_like(z), 0
    for j, l in enumerate(orders):
        p = p * z ** (l - at)
        at = l
        m[:, 2 * j + 1], m[:, 2 * j + 2] = p.real, p.imag
    return m


def _gram_at_bin_centres(counts: np.ndarray, orders: list[int]) -> np.ndarray:
    """m.T @ diag(c) @ m for each row c of `counts` (weights of the bins), m = harmonic_design at the bin
    centres 2 pi (i + 1/2) / bins: from the weights' spectrum, without forming the products (a product of two
    harmonics is the sum of two others). Shape (rows, 2 len(orders) + 1, same)."""
    counts = np.atleast_2d(np.asarray(counts, float))
    bins = counts.shape[1]
    top = 2 * max(orders, default=0)
    h = np.arange(top + 1)
    # spec[:, h] = sum_i c_i exp(j h x_i), x_i the bin centres (the FFT's sign and phase origin turned to them)
    spec = np.conj(np.fft.fft(counts, axis=1)[:, h % bins]) * np.exp(1j * np.pi * h / bins)
    freq = np.array([0] + [o for o in orders for _ in (0, 1)])
    is_sin = np.array([False] + [t for _ in orders for t in (False, True)])
    diff, add = freq[:, None] - freq[None, :], freq[:, None] + freq[None, :]
    re_d, re_a = spec.real[:, np.abs(diff)], spec.real[:, add]
    im_d, im_a = np.sign(diff) * spec.imag[:, np.abs(diff)], spec.imag[:, add]
    sp, sq = is_sin[:, None], is_sin[None, :]
    return 0.5 * np.where(~sp & ~sq, re_d + re_a, np.where(sp & sq, re_d - re_a,
                                                           np.where(~sp & sq, im_a - im_d, im_a + im_d)))


def _to_paper_order(w: np.ndarray, orders: list[int]) -> np.ndarray:
    """Interleaved weights of `orders` -> seed 000 order [w0, a1..an, b1..bn], zeros where skipped."""
    n = max(orders, default=0)
    out = np.zeros(2 * n + 1)
    out[0] = w[0]
    for j, l in enumerate(orders):
        out[l], out[n + l] = w[2 * j + 1], w[2 * j + 2]
    return out


def bin_by_angle(x: np.ndarray, y: np.ndarray, bins: int):
    """Per bin of x (radians, any range): count, mean x, mean y; plus the within-bin sum of squares."""
    frac = np.mod(np.asarray(x, float) / (2 * np.pi), 1.0)
    idx = np.minimum((frac * bins).astype(np.int64), bins - 1)
    count = np.bincount(idx, minlength=bins).astype(float)
    sy = np.bincount(idx, y, minlength=bins)
    syy = np.bincount(idx, y * y, minlength=bins)
    # mean angle within the bin, measured from the bin start to stay continuous across 2*pi
    sx = np.bincount(idx, frac * bins - idx, minlength=bins)
    keep = count > 0
    c = count[keep]
    xm = 2 * np.pi * (np.flatnonzero(keep) + sx[keep] / c) / bins
    ym = sy[keep] / c
    within = float(np.sum(syy[keep] - c * ym * ym))
    return xm, ym, c, max(within, 0.0)


def _orders(top: int, skip_multiples_of: int) -> list[int]:
    return [l for l in range(1, top + 1) if not (skip_multiples_of and l % skip_multiples_of == 0)]


class CoverageError(ValueError):
    """The angles a series is fitted on do not determine its weights (too few distinct angles)."""


def _coverage_cap(n_bins_with_data: int) -> int:
    """At least about twice as many distinct angles as weights."""
    return max(0, (n_bins_with_data - 1) // 2 - 1)


def fit_select(x: np.ndarray, y: np.ndarray, n_max: int, bins: int = 8192,
               n_fixed: int | None = None, skip_multiples_of: int = 0) -> tuple[FourierSeries, int, float]:
    """Least-squares Fourier series of y against angle x; n by BIC over 0..n_max unless n_fixed.

    `skip_multiples_of` = L leaves out the harmonics L, 2L, ... (they belong to another stage).
    Returns the series (seed 000 weight order), the chosen n and the residual RMS.
    """
    n_samples = len(y)
    xm, ym, c, within = bin_by_angle(x, y, bins)
    n_max = int(min(n_max, _coverage_cap(len(xm))))
    top = n_max if n_fixed is None else min(n_fixed, n_max)
    orders = _orders(top, skip_multiples_of)
    m = harmonic_design(xm, orders)
    sw = np.sqrt(c)
    mw, yw = m * sw[:, None], ym * sw
    g, b, yy = mw.T @ mw, mw.T @ yw, float(yw @ yw)
    # One Cholesky factor serves every candidate: the factor of a leading block is the leading
    # block of the factor, so u = L^-1 b gives RSS(k) = yy - sum(u[:k]^2) for all k at once.
    try:
        lower = cholesky(g, lower=True)
    except LinAlgError:
        raise CoverageError("the angles do not determine the Fourier series (too little coverage)") from None
    u = solve_triangular(lower, b, lower=True)
    ks = np.arange(1, m.shape[1] + 1, 2) if n_fixed is None else np.array([m.shape[1]])
    rss = np.maximum(yy - np.cumsum(u * u)[ks - 1], 0.0) + within
    bic = n_samples * np.log(np.maximum(rss, 1e-300) / n_samples) + ks * np.log(n_samples)
    best = int(np.argmin(bic))
    k = int(ks[best])
    w = solve_triangular(lower[:k, :k].T, u[:k], lower=False)
    used = orders[:(k - 1) // 2]
    return FourierSeries(_to_paper_order(w, used)), max(used, default=0), float(np.sqrt(rss[best] / n_samples))


def cv_folds(n: int, k: int = 5, blocks_per_fold: int = 64, min_run: int = 1) -> np.ndarray:
    """Fold label per sample: runs of consecutive samples, each group of k runs dealt to the k folds
    in a random order (fixed seed).

    Runs are as short as possible while each fold still gets `blocks_per_fold` of them (and at least
    `min_run` long), so every fold spreads over the whole recording (every k consecutive runs hold
    every fold), while noise correlated over a few samples stays within one fold. The order is
    shuffled within each group: a fixed round-robin can be commensurate with a steady motion and
    leave a sector of the revolution out of a fold.

    `min_run`: a held-out run is a hole in the training data, and a hole of one sample breaks the
    orthogonality of noise near the sampling's Nyquist frequency (interference whose sign alternates
    from sample to sample) to the low harmonics: that noise leaks into every candidate's fit and
    makes rich models look worse on held-out folds than on any regularly sampled validation. Over
    a run of r samples it mostly cancels, and there are r times fewer holes.
    """
    run = max(1, int(min_run), n // (k * blocks_per_fold))
    groups = -(-n // (run * k))
    rng = np.random.default_rng(n)
    labels = np.argsort(rng.random((groups, k)), axis=1).ravel()
    return labels[np.arange(n) // run]


def paired_gain_t(sse: np.ndarray, ref: int, blocks: int) -> tuple[np.ndarray, int]:
    """t statistic of each candidate's held-out gain over candidate `ref`, from paired batch means.

    `sse`: (candidates, cells) held-out squared errors, cells in the order of the recording (angle
    bins or samples). The cells are summed into `blocks` contiguous batches; the paired differences
    ref - candidate of the batch sums give the mean gain and its standard error. Batches, not single
    samples: noise correlated over neighbouring samples (interference) would otherwise shrink the
    standard error. Positive: the candidate predicts the held-out data better than `ref`. Fewer
    cells than `blocks`: one batch a cell. Returns the t statistics and the number of batches.
    """
    blocks = min(blocks, sse.shape[1])
    edges = np.linspace(0, sse.shape[1], blocks + 1).round().astype(int)
    batch = np.add.reduceat(sse, edges[:-1], axis=1)
    diff = batch[ref][None, :] - batch
    sd = diff.std(axis=1, ddof=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(sd > 0, diff.mean(axis=1) / (sd / np.sqrt(blocks)), 0.0)
    return t, blocks


def significant_choice(total: np.ndarray, t: np.ndarray, ref: int, alpha: float, blocks: int) -> int:
    """Index of the candidate to keep: `ref` unless some other candidate's held-out gain over it is
    significant (one-sided t test at family-wise level `alpha`, Bonferroni over the other candidates);
    then the significant one with the least held-out error `total`."""
    from scipy.stats import t as t_dist

    others = len(total) - 1
    if others < 1 or blocks < 2:
        return ref
    crit = float(t_dist.ppf(1 - alpha / others, blocks - 1))
    sig = np.flatnonzero(t > crit)
    return ref if len(sig) == 0 else int(sig[np.argmin(total[sig])])


def cv_harmonics(x: np.ndarray, y: np.ndarray, n_max: int, folds: np.ndarray, bins: int = 4096,
                 skip_multiples_of: int = 0, tolerance: float = 0.0, default: int | None = None,
                 alpha: float = 0.05, blocks: int = 32) -> tuple[int, np.ndarray]:
    """Number of harmonics (0..n_max) from the held-out squared error summed over the folds.

    Without a `default`: the least held-out error; with a tolerance, the largest number whose held-out
    RMS is within (1 + tolerance) of the least. With a `default` (a number of harmonics; the largest
    allowed one not above it): that number, unless another's held-out gain over it is significant
    (`significant_choice`: paired t test over `blocks` batches of contiguous angle bins, family-wise
    level `alpha`), then the significant one with the least held-out error. Held-out curves are
    flat and noisy near their minimum: a bare argmin there follows the noise of the folds.

    Each fold is predicted by the series fitted on the other folds, for every candidate size at
    once: per fold and angle bin, counts and sums in one pass; the training fold's normal
    equations share one Cholesky factor L among the prefix models (as in `fit_select`: the prefix
    model of k columns has the coefficients L_k^-T u_k, u = L^-1 b, and L_k^-T is the leading block
    of L^-T), so one product gives every candidate's prediction at the bins; the held-out error of
    each, per bin, is y.y - 2 p sum(y) + count p^2 with p the prediction at the bin. Angles are
    taken at the bin centres (2*pi/bins apart: 32 or more a period of the highest harmonic, 64).
    Returns the chosen n and the held-out RMS of each candidate size (index = number of harmonics,
    NaN where skipped).
    """
    x, y, folds = np.ravel(np.asarray(x, float)), np.ravel(np.asarray(y, float)), np.ravel(folds)
    labels, fold_of = np.unique(folds, return_inverse=True)
    k_folds = len(labels)
    frac = np.mod(x / (2 * np.pi), 1.0)
    cell = fold_of * bins + np.minimum((frac * bins).astype(np.int64), bins - 1)
    count, sy, syy = (np.bincount(cell, w, minlength=k_folds * bins).reshape(k_folds, bins)
                      for w in (None, y, y * y))
    train_count = count.sum(0) - count
    cap = min([int(n_max)] + [_coverage_cap(int(np.count_nonzero(c))) for c in train_count])
    orders = _orders(cap, skip_multiples_of)
    m = harmonic_design(2 * np.pi * (np.arange(bins) + 0.5) / bins, orders)
    ks = np.arange(1, 2 * len(orders) + 2, 2)
    sse = np.zeros((len(ks), bins))                       # held-out squared error per candidate and bin
    g_fold = _gram_at_bin_centres(count, orders)          # each fold's normal equations
    b_fold = sy @ m
    g_all, b_all = g_fold.sum(0), b_fold.sum(0)
    for f in range(k_folds):
        try:
            lower = cholesky(g_all - g_fold[f], lower=True)
        except LinAlgError:
            raise CoverageError("the angles do not determine the Fourier series (too little coverage)") from None
        u = solve_triangular(lower, b_all - b_fold[f], lower=True)
        inv_t = solve_triangular(lower, np.eye(len(u)), lower=True).T             # L^-T, upper triangular
        coef = inv_t @ np.where(np.arange(len(u))[:, None] < ks[None, :], u[:, None], 0.0)
        p = m @ coef                                       # predictions at the bin centres, one column a candidate
        sse += (syy[f][:, None] - 2 * p * sy[f][:, None] + count[f][:, None] * p * p).T
    press = sse.sum(axis=1)
    rms = np.full(cap + 1, np.nan)
    rms[[0] + orders] = np.sqrt(np.maximum(press, 0.0) / len(y))
    sizes = [0] + orders
    if default is not None:
        ref = max(j for j, s in enumerate(sizes) if s <= max(0, int(default)))
        t, batches = paired_gain_t(sse, ref, blocks)
        return sizes[significant_choice(press, t, ref, alpha, batches)], rms
    if tolerance <= 0:
        return sizes[int(np.argmin(press))], rms
    held = np.sqrt(np.maximum(press, 0.0))
    return sizes[int(np.flatnonzero(held <= (1 + tolerance) * held.min())[-1])], rms
