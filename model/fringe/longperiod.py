"""Seed 000's long-period model: a truncated Fourier series ("Fourier neural network").

(Interim version with the closed-form pieces; the DE / DE+SA training is added alongside.)
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
