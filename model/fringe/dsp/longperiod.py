"""Seed 000's long-period model: a truncated Fourier series ("Fourier neural network", eqs. 3-11).

The model is linear in its 2n+1 weights, so least squares gives the exact optimum in closed form
(`fit_lsq`), and BIC chooses n from the data (`select_harmonics`). The seed's own training,
differential evolution with and without its simulated-annealing mutation (eqs. 12-20), is kept
as `fit_de` to reproduce its Fig. 4 (`de_benchmark`), not to calibrate with.
"""

from dataclasses import dataclass

import numpy as np

from .seeds import fourier_network

# Above this many design-matrix elements fit_lsq works from trigonometric moments instead of
# materialising the matrix (32 MB of float64).
_DIRECT_MAX = 1 << 22
# Normal equations square the condition number: beyond this (cond(M) ~ 1e4, angles bunched on
# part of the revolution) fit_lsq goes back to the matrix itself.
_GRAM_COND_MAX = 1e8
_CHUNK = 1 << 16         # samples per pass when accumulating moments: keeps the pass in cache
_BINS = 1024             # angle bins for counting distinct angles (resolves up to 64 harmonics)
_N_CAP = 64


def _check(x_rad, y, n: int) -> tuple[np.ndarray, np.ndarray]:
    x = np.ravel(np.asarray(x_rad, float))
    y = np.ravel(np.asarray(y, float))
    if int(n) != n or n < 0:
        raise ValueError(f"number of harmonics n must be an integer >= 0, got {n}")
    if len(x) != len(y):
        raise ValueError(f"x and y differ in length ({len(x)} and {len(y)})")
    if len(x) < 2 * n + 1:
        raise ValueError(f"{len(x)} points cannot determine the 2n+1 = {2 * n + 1} weights of n = {n}")
    return x, y


def design_matrix(x_rad: np.ndarray, n: int) -> np.ndarray:
    """Columns in the paper's order (eq. 7): [1, cos x, ..., cos nx, sin x, ..., sin nx].

    Harmonics by the recurrence e^{ilx} = e^{ix} e^{i(l-1)x}; Fortran order so that each column
    is written contiguously.
    """
    if int(n) != n or n < 0:
        raise ValueError(f"number of harmonics n must be an integer >= 0, got {n}")
    x = np.ravel(np.asarray(x_rad, float))
    m = np.empty((len(x), 2 * n + 1), order="F")
    m[:, 0] = 1.0
    z = np.exp(1j * x)
    p = z.copy()
    for l in range(1, n + 1):
        m[:, l], m[:, n + l] = p.real, p.imag
        if l < n:
            p *= z
    return m


@dataclass
class FourierSeries:
    """Weights in the order of eqs. 7-8: w1 = a0/2, a1..an (cosine), b1..bn (sine)."""

    weights: np.ndarray

    def __post_init__(self):
        self.weights = np.asarray(self.weights, float)
        if self.weights.ndim != 1 or len(self.weights) % 2 == 0:
            raise ValueError(f"a series has 2n+1 weights, got shape {self.weights.shape}")

    @property
    def n(self) -> int:
        return (len(self.weights) - 1) // 2

    def __call__(self, x_rad: np.ndarray) -> np.ndarray:
        return fourier_network(self.weights, x_rad)

    def slope(self, x_rad: np.ndarray) -> np.ndarray:
        """The series' derivative in x (its units per radian): l b_l cos(l x) - l a_l sin(l x) summed."""
        n, w = self.n, self.weights
        l = np.arange(1, n + 1)
        return fourier_network(np.concatenate([[0.0], l * w[n + 1:], -l * w[1:n + 1]]), x_rad)

    def amplitudes(self) -> np.ndarray:
        """sqrt(a_l^2 + b_l^2) for l = 1..n."""
        return np.hypot(self.weights[1:self.n + 1], self.weights[self.n + 1:])

    def to_dict(self) -> dict:
        return {"weights": [float(w) for w in self.weights], "order": "w1=a0/2, a1..an, b1..bn"}

    @classmethod
    def from_dict(cls, d: dict) -> "FourierSeries":
        return cls(np.asarray(d["weights"], float))


# ---------------------------------------------------------------- closed form and harmonic selection

def _moments(x: np.ndarray, y: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """s_k = sum e^{ikx} (k = 0..2n) and t_l = sum y e^{ilx} (l = 0..n): all the Gram matrix needs.

    O(N n) instead of the O(N n^2) of M^T M.
    """
    s = np.zeros(2 * n + 1, complex)
    t = np.zeros(n + 1, complex)
    for a in range(0, len(x), _CHUNK):
        xc = x[a:a + _CHUNK]
        ones_y = np.vstack([np.ones_like(xc), y[a:a + _CHUNK]])
        z = np.exp(1j * xc)
        p = np.ones_like(z)
        for k in range(2 * n + 1):
            # one real matrix product gives both sums (complex and strided dots are slow paths)
            (sr, si), (tr, ti) = ones_y @ p.view(float).reshape(-1, 2)
            s[k] += complex(sr, si)
            if k <= n:
                t[k] += complex(tr, ti)
            p *= z
    return s, t


def _gram(s: np.ndarray, t: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """M^T M and M^T y (paper column order) from the moments, by the product-to-sum identities."""
    j, k = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    c, sn = s.real, s.imag
    d = j - k
    cc = (c[np.abs(d)] + c[j + k]) / 2                      # cos jx cos kx (j = 0: the constant)
    ss = (c[np.abs(d)] - c[j + k]) / 2                      # sin jx sin kx
    cs = (sn[j + k] + np.sign(k - j) * sn[np.abs(d)]) / 2   # cos jx sin kx
    g = np.block([[cc, cs[:, 1:]], [cs[:, 1:].T, ss[1:, 1:]]])
    b = np.concatenate([t.real, t.imag[1:]])
    return g, b


def fit_lsq(x_rad: np.ndarray, y: np.ndarray, n: int) -> FourierSeries:
    """Least-squares weights of an n-harmonic series: the exact optimum (the model is linear).

    Small problems: lstsq on the design matrix. Large ones: lstsq on the normal equations built
    from O(N n) moments (1e6 samples, n = 20 in a fraction of a second), unless the angles cover
    the revolution so unevenly that the normal equations would lose accuracy.
    """
    x, y = _check(x_rad, y, n)
    if len(x) * (2 * n + 1) > _DIRECT_MAX:
        g, b = _gram(*_moments(x, y, n), n)
        if np.linalg.cond(g) < _GRAM_COND_MAX:
            return FourierSeries(np.linalg.lstsq(g, b, rcond=None)[0])
    return FourierSeries(np.linalg.lstsq(design_matrix(x, n), y, rcond=None)[0])


def _covered_bins(x: np.ndarray) -> int:
    idx = (np.mod(x, 2 * np.pi) * (_BINS / (2 * np.pi))).astype(np.int64) % _BINS
    return int(np.count_nonzero(np.bincount(idx, minlength=_BINS)))


def select_harmonics(x_rad: np.ndarray, y: np.ndarray, n_max: int | None = None) -> int:
    """Number of harmonics n in 0..n_max minimising BIC = N ln(RSS/N) + (2n+1) ln N.

    Default n_max: min(64, covered/4 - 1), covered = number of the 1024 angle bins holding data,
    i.e. at least twice as many distinct angles as weights (64 equally spaced points: n <= 15).
    """
    x = np.ravel(np.asarray(x_rad, float))
    if n_max is None:
        n_max = max(0, min(_N_CAP, _covered_bins(x) // 4 - 1))
    x, y = _check(x, y, n_max)
    big_n = len(x)
    s, t = _moments(x, y, n_max)
    g, b = _gram(s, t, n_max)
    yy = float(y @ y)
    bic = []
    for n in range(n_max + 1):
        cols = np.r_[0:n + 1, n_max + 1:n_max + 1 + n]       # the n-harmonic model's sub-block
        w = np.linalg.lstsq(g[np.ix_(cols, cols)], b[cols], rcond=None)[0]
        # RSS at the optimum is y.y - w.b; floored at rounding level so that exact data do not
        # reward harmonics that only fit rounding noise
        rss = max(yy - float(w @ b[cols]), 1e-12 * yy, 1e-300)
        bic.append(big_n * np.log(rss / big_n) + (2 * n + 1) * np.log(big_n))
    return int(np.argmin(bic))


# ---------------------------------------------------------------- seed 000's training: DE and DE+SA

@dataclass
class DEResult:
    series: FourierSeries
    generations: int          # generations run until the stopping criterion held (or g_max)
    reached: bool             # best RMS <= target_rms
    history: np.ndarray       # best RMS of generations 0..generations


def _donors(npop: int, rng: np.random.Generator) -> np.ndarray:
    """(npop, 3) indices r1, r2, r3: distinct, and none equal to the row's own index i.

    Draw from the npop - m indices not yet taken, then step over the taken ones in ascending
    order: uniform without rejection, and a fixed use of the random stream.
    """
    taken = np.arange(npop)[:, None]
    for m in range(1, 4):
        u = rng.integers(0, npop - m, npop)
        for e in np.sort(taken, axis=1).T:
            u += u >= e
        taken = np.column_stack([taken, u])
    return taken[:, 1:]


def _mutate(pop: np.ndarray, best_idx: int, F: float, eta: float, rng: np.random.Generator) -> np.ndarray:
    """Eq. 16: V_i = eta*w_r3 + (1-eta)*w_gbest + F*(w_r1 - w_r2).

    eta = 1 is eq. 14 (DE/rand/1), eta = 0 is eq. 15 (DE/best/1).
    """
    r = _donors(len(pop), rng)
    return eta * pop[r[:, 2]] + (1 - eta) * pop[best_idx] + F * (pop[r[:, 0]] - pop[r[:, 1]])


def _crossover(pop: np.ndarray, v: np.ndarray, Cr: float, rng: np.random.Generator) -> np.ndarray:
    """Eq. 18, binomial: gene j from V if rand <= Cr or j = rnbr(D), so U differs from the parent."""
    npop, d = pop.shape
    take = rng.random((npop, d)) <= Cr
    take[np.arange(npop), rng.integers(0, d, npop)] = True
    return np.where(take, v, pop)


def fit_de(x_rad, y, n: int, *, variant: str = "desa", rng=None, pop_size: int | None = None, F: float = 0.5,
           Cr: float = 0.9, g_max: int = 1000, bounds=None, target_rms: float | None = None) -> DEResult:
    """Seed 000 eqs. 12-20: differential evolution of the D = 2n+1 weights, fitness RMS (eq. 20).

    variant "de": mutation eq. 14; "desa": eq. 16 with eta = (G_max - g)/G_max (eq. 17), g being
    the generation mutated (0..G_max-1), so the first step is exactly eq. 14.
    pop_size: NP, default 6*D (the paper asks for [5D, 10D]).
    bounds: (w_min, w_max) of the initial population (eq. 13), scalars or per weight. Default
    +-2*max|y|: each Fourier weight of data bounded by max|y| is at most 4/pi*max|y| (and the
    least-squares weights of equally spaced points at most 2*max|y|), so the box holds the answer.
    Mutants are not clipped to the box (the paper does not say so).
    rng: anything np.random.default_rng accepts; a seed or Generator makes the run reproducible.
    Stops at the first generation whose best RMS <= target_rms, or after g_max generations.
    """
    x, y = _check(x_rad, y, n)
    if variant not in ("de", "desa"):
        raise ValueError(f"unknown variant {variant!r}: 'de' (eq. 14) or 'desa' (eq. 16)")
    d = 2 * n + 1
    npop = 6 * d if pop_size is None else int(pop_size)
    if npop < 4:
        raise ValueError(f"pop_size must be >= 4 (r1, r2, r3 and i distinct), got {npop}")
    if int(g_max) != g_max or g_max < 1:
        raise ValueError(f"g_max must be an integer >= 1, got {g_max}")
    if not 0 <= Cr <= 1:
        raise ValueError(f"Cr must lie in [0, 1], got {Cr}")
    if bounds is None:
        span = 2 * float(np.max(np.abs(y)))
        bounds = (-span, span)
    lo, hi = (np.broadcast_to(np.asarray(b, float), (d,)) for b in bounds)
    if np.any(lo > hi):
        raise ValueError("bounds must be (w_min, w_max) with w_min <= w_max")
    rng = np.random.default_rng(rng)

    mt = design_matrix(x, n).T.copy()

    def rms(w):                                             # eq. 20, one value per individual
        return np.sqrt(np.mean((w @ mt - y) ** 2, axis=1))

    pop = lo + rng.random((npop, d)) * (hi - lo)            # eq. 13
    cost = rms(pop)
    best = int(np.argmin(cost))
    history = [cost[best]]
    g = 0
    while g < g_max and not (target_rms is not None and cost[best] <= target_rms):
        eta = (g_max - g) / g_max if variant == "desa" else 1.0
        u = _crossover(pop, _mutate(pop, best, F, eta, rng), Cr, rng)
        cu = rms(u)
        win = cu <= cost                                    # eq. 19, greedy one-to-one
        pop[win], cost[win] = u[win], cu[win]
        best = int(np.argmin(cost))
        history.append(cost[best])
        g += 1
    reached = target_rms is not None and bool(cost[best] <= target_rms)
    return DEResult(FourierSeries(pop[best].copy()), g, reached, np.array(history))


def de_benchmark(n_runs: int = 50, *, n_train: int = 64, noise_arcsec: float = 1.3, g_max: int = 2000,
                 tolerance: float = 0.05, seed: int = 0) -> dict:
    """Seed 000 Fig. 4 (DE ~600 generations, DE+SA ~400) over n_runs noise draws.

    Each run: n_train equally spaced angles, target seed000_error_arcsec plus fresh Gaussian noise,
    9 harmonics (19 weights, Table 1). Both variants get the same data and the same DE seed; each
    stops once its best RMS <= (1 + tolerance) x the least-squares RMS on that data. Generation
    statistics are over the successful runs. The default takes about 5 s on two cores.
    """
    from .seeds import seed000_error_arcsec

    n = 9
    x = np.arange(n_train) * 2 * np.pi / n_train
    clean = seed000_error_arcsec(x)
    rng = np.random.default_rng(seed)
    gens = {"de": [], "desa": []}
    lsq_rms = []
    for _ in range(n_runs):
        y = clean + rng.normal(0, noise_arcsec, n_train)
        e_opt = float(np.sqrt(np.mean((fit_lsq(x, y, n)(x) - y) ** 2)))
        lsq_rms.append(e_opt)
        run_seed = int(rng.integers(1 << 62))
        for variant, out in gens.items():
            r = fit_de(x, y, n, variant=variant, rng=run_seed, g_max=g_max, target_rms=(1 + tolerance) * e_opt)
            out.append(r.generations if r.reached else np.nan)
    res = {"paper": "Fig. 4: DE ~600 generations, DE+SA ~400",
           "params": {"n_runs": n_runs, "n_train": n_train, "harmonics": n, "weights": 2 * n + 1,
                      "pop_size": 6 * (2 * n + 1), "F": 0.5, "Cr": 0.9, "g_max": g_max,
                      "noise_arcsec": noise_arcsec, "tolerance": tolerance, "seed": seed},
           "criterion": f"best RMS <= (1 + {tolerance}) x least-squares RMS",
           "lsq_rms_arcsec": float(np.mean(lsq_rms))}
    for variant, g in gens.items():
        ok = np.array(g)[np.isfinite(g)]
        res[variant] = {"success_rate": len(ok) / n_runs, "median_generations": None, "mean_generations": None,
                        "p10": None, "p90": None}
        if len(ok):
            res[variant].update(median_generations=float(np.median(ok)), mean_generations=float(np.mean(ok)),
                                p10=float(np.percentile(ok, 10)), p90=float(np.percentile(ok, 90)))
    de, desa = np.array(gens["de"]), np.array(gens["desa"])
    both = np.isfinite(de) & np.isfinite(desa)
    # paired: same data and DE seed for both variants
    res["desa_fewer_generations_fraction"] = float(np.mean(desa[both] < de[both])) if both.any() else None
    return res
