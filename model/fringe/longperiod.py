"""Seed 000's long-period model: a truncated Fourier series ("Fourier neural network").

The closed form (least squares: the model is linear in its weights) and the seed's own training,
differential evolution with and without the simulated-annealing mutation (eqs. 12-20).
"""

from dataclasses import dataclass

import numpy as np

from .seeds import fourier_network


def design_matrix(x_rad: np.ndarray, n: int) -> np.ndarray:
    """Columns in the paper's order (eq. 7): [1, cos x, ..., cos nx, sin x, ..., sin nx]."""
    x = np.asarray(x_rad, float)
    z = np.exp(1j * x)
    m = np.empty((len(x), 2 * n + 1))
    m[:, 0] = 1.0
    p = np.ones_like(z)
    for l in range(1, n + 1):
        p = p * z
        m[:, l], m[:, n + l] = p.real, p.imag
    return m


@dataclass
class FourierSeries:
    weights: np.ndarray

    def __post_init__(self):
        self.weights = np.asarray(self.weights, float)

    @property
    def n(self) -> int:
        return (len(self.weights) - 1) // 2

    def __call__(self, x_rad: np.ndarray) -> np.ndarray:
        return fourier_network(self.weights, x_rad)

    def amplitudes(self) -> np.ndarray:
        return np.hypot(self.weights[1:self.n + 1], self.weights[self.n + 1:])

    def to_dict(self) -> dict:
        return {"weights": [float(w) for w in self.weights], "order": "w1=a0/2, a1..an, b1..bn"}

    @classmethod
    def from_dict(cls, d: dict) -> "FourierSeries":
        return cls(np.asarray(d["weights"], float))


def fit_lsq(x_rad: np.ndarray, y: np.ndarray, n: int) -> FourierSeries:
    w, *_ = np.linalg.lstsq(design_matrix(x_rad, n), np.asarray(y, float), rcond=None)
    return FourierSeries(w)


# ---------------------------------------------------------------- seed 000's training: DE and DE+SA

@dataclass
class DEResult:
    series: FourierSeries
    generations: int          # generations run until the stopping criterion held (or g_max)
    reached: bool
    history: np.ndarray       # best RMS per generation


def _mutate(pop: np.ndarray, best: int, f: float, eta: float, rng: np.random.Generator) -> np.ndarray:
    """Eq. 16: V = eta*w_r3 + (1-eta)*w_best + F*(w_r1 - w_r2), r1, r2, r3 distinct and != i.

    eta = 1 is eq. 14 (DE/rand/1), eta = 0 is eq. 15 (DE/best/1).
    """
    npop = len(pop)
    idx = np.arange(npop)
    r = np.empty((npop, 3), dtype=np.int64)
    for k in range(3):        # draw r1, r2, r3 for all individuals, redrawing clashes
        r[:, k] = rng.integers(0, npop, npop)
        clash = (r[:, k] == idx) | np.any(r[:, :k] == r[:, k:k + 1], axis=1)
        while clash.any():
            r[clash, k] = rng.integers(0, npop, int(clash.sum()))
            clash = (r[:, k] == idx) | np.any(r[:, :k] == r[:, k:k + 1], axis=1)
    return eta * pop[r[:, 2]] + (1 - eta) * pop[best] + f * (pop[r[:, 0]] - pop[r[:, 1]])


def fit_de(x_rad, y, n: int, *, variant: str = "desa", rng=None, pop_size: int | None = None, F: float = 0.5,
           Cr: float = 0.9, g_max: int = 1000, bounds: tuple[float, float] | None = None,
           target_rms: float | None = None) -> DEResult:
    """Seed 000 eqs. 12-20: differential evolution of the 2n+1 weights, fitness = RMS (eq. 20).

    variant "de": mutation eq. 14; "desa": eq. 16 with the annealing factor eta = (G_max - g)/G_max
    (eq. 17). Population NP = 6*D (the paper's [5D, 10D]), initialised uniformly in the bounds
    (eq. 13; default +-2*max|y| for every weight), binomial crossover with one forced gene (eq. 18),
    greedy selection (eq. 19). Stops when the best RMS <= target_rms, or at g_max.
    """
    x = np.asarray(x_rad, float)
    y = np.asarray(y, float)
    if variant not in ("de", "desa"):
        raise ValueError(f"unknown variant '{variant}' (de or desa)")
    if n < 0:
        raise ValueError(f"n must be >= 0, got {n}")
    if len(x) != len(y):
        raise ValueError(f"x and y differ in length ({len(x)} and {len(y)})")
    d = 2 * n + 1
    if len(x) < d:
        raise ValueError(f"{len(x)} points cannot determine {d} weights")
    rng = rng if rng is not None else np.random.default_rng(0)
    npop = pop_size or 6 * d
    lo, hi = bounds if bounds is not None else (-2 * np.max(np.abs(y)), 2 * np.max(np.abs(y)))
    m = design_matrix(x, n)
    pop = lo + rng.random((npop, d)) * (hi - lo)
    cost = np.sqrt(np.mean((pop @ m.T - y) ** 2, axis=1))
    history = []
    g = 0
    for g in range(1, g_max + 1):
        best = int(np.argmin(cost))
        history.append(cost[best])
        if target_rms is not None and cost[best] <= target_rms:
            return DEResult(FourierSeries(pop[best].copy()), g - 1, True, np.array(history))
        eta = (g_max - g) / g_max if variant == "desa" else 1.0
        v = _mutate(pop, best, F, eta, rng)
        cross = rng.random((npop, d)) <= Cr
        cross[np.arange(npop), rng.integers(0, d, npop)] = True
        u = np.where(cross, v, pop)
        cu = np.sqrt(np.mean((u @ m.T - y) ** 2, axis=1))
        better = cu <= cost
        pop[better], cost[better] = u[better], cu[better]
    best = int(np.argmin(cost))
    history.append(cost[best])
    reached = target_rms is not None and cost[best] <= target_rms
    return DEResult(FourierSeries(pop[best].copy()), g_max, reached, np.array(history))


def de_benchmark(n_runs: int = 30, *, n_train: int = 64, noise_arcsec: float = 1.3, g_max: int = 2000,
                 tolerance: float = 0.05, seed: int = 0) -> dict:
    """Seed 000 Fig. 4 over many seeds: generations until the best RMS is within `tolerance` of the
    least-squares optimum on the same 64 points (9 harmonics, 19 weights), DE against DE+SA."""
    from .seeds import seed000_error_arcsec

    x = np.arange(n_train) * 2 * np.pi / n_train
    rng = np.random.default_rng(seed)
    gens = {"de": [], "desa": []}
    lsq_rms = []
    for _ in range(n_runs):
        y = seed000_error_arcsec(x) + rng.normal(0, noise_arcsec, n_train)
        opt = fit_lsq(x, y, 9)
        e_opt = float(np.sqrt(np.mean((opt(x) - y) ** 2)))
        lsq_rms.append(e_opt)
        run_seed = int(rng.integers(1 << 31))
        for variant in gens:
            r = fit_de(x, y, 9, variant=variant, rng=np.random.default_rng(run_seed), g_max=g_max,
                       target_rms=(1 + tolerance) * e_opt)
            gens[variant].append(r.generations if r.reached else np.inf)
    out = {"runs": n_runs, "points": n_train, "harmonics": 9, "g_max": g_max, "noise_arcsec": noise_arcsec,
           "criterion": f"best RMS <= (1 + {tolerance}) x least-squares RMS", "lsq_rms_arcsec": float(np.mean(lsq_rms)),
           "paper": "DE ~600 generations, DE+SA ~400 (Fig. 4)"}
    for variant, g in gens.items():
        g = np.array(g, float)
        ok = np.isfinite(g)
        out[variant] = {"success_rate": float(ok.mean()),
                        "median_generations": float(np.median(g[ok])) if ok.any() else None,
                        "p10": float(np.percentile(g[ok], 10)) if ok.any() else None,
                        "p90": float(np.percentile(g[ok], 90)) if ok.any() else None}
    return out
