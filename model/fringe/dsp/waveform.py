"""Per-channel waveform fit and inversion (seed 001, section 3.1), and its generalisation.

The seed writes each channel as a Fourier series in the fine phase, turns the odd sine
harmonics into a polynomial in x = sin(theta) with the multiple-angle matrix M (eqs. 7-10),
and inverts y = f0 + (FM)S(x) + 2 f2 x sqrt(1-x^2) by Newton's method (eqs. 12-13).

That polynomial only exists when the waveform is a function of sin(theta) alone. With even
or cosine-phase harmonics (or any asymmetry) the same reading y occurs at two phases whose
sines differ, and the inverse needs to know which half of the period the sample is in. The
other channel's sign tells exactly that, so the general inverse is a pair of tables per
channel, selected by `other >= threshold` (`WaveformInverse`).
"""

from dataclasses import dataclass
from math import factorial

import numpy as np

from .longperiod import design_matrix

# ---------------------------------------------------------------- the seed's polynomial form

def multiple_angle_matrix(max_order: int) -> np.ndarray:
    """Seed 001 eq. 10: [sin t, sin 3t, ..., sin nt]^T = M [x, x^3, ..., x^n]^T, x = sin t.

    Row for order n, column for power k (both odd): n (n^2-1^2)(n^2-3^2)...(n^2-(k-2)^2) / k!,
    with alternating sign; the product vanishes for k > n, so M is lower triangular.
    """
    orders = np.arange(1, max_order + 1, 2)
    m = np.zeros((len(orders), len(orders)))
    for i, n in enumerate(orders):
        for j, k in enumerate(orders):
            if k > n:
                break
            prod = float(n)
            for q in range(1, k - 1, 2):
                prod *= n * n - q * q
            m[i, j] = (-1) ** ((k - 1) // 2) * prod / factorial(k)
    return m


@dataclass
class PaperChannel:
    """The seed's single-channel model y = f0 + sum_odd f_n sin(n t) + f2 sin(2t), t the channel's phase."""

    f0: float
    odd: np.ndarray      # f_1, f_3, ..., f_n (eq. 6)
    f2: float

    def polynomial(self) -> np.ndarray:
        """Coefficients of x, x^3, ..., x^n: the row vector F M of eq. 11."""
        return self.odd @ multiple_angle_matrix(2 * len(self.odd) - 1)

    def invert(self, y: np.ndarray, iterations: int = 5) -> np.ndarray:
        """Eq. 12-13: Newton on f(x) = f0 + (FM)S(x) + 2 f2 x sqrt(1-x^2) - y, x0 = y normalised.

        As in the seed, sqrt(1-x^2) = cos t is taken positive: exact only on the half period
        where cos t >= 0 (the limitation `WaveformInverse` removes).
        """
        p = self.polynomial()
        powers = np.arange(1, 2 * len(p), 2)
        peak = abs(self.f0) + np.abs(self.odd).sum() + abs(self.f2)
        x = np.clip((np.asarray(y, float) - self.f0) / peak, -1.0, 1.0)
        for _ in range(iterations):
            xp = x[..., None] ** powers
            root = np.sqrt(np.maximum(1.0 - x * x, 1e-12))
            f = self.f0 + xp @ p + 2 * self.f2 * x * root - y
            df = (xp / np.where(x == 0, 1.0, x)[..., None] * powers) @ p \
                + 2 * self.f2 * (root - x * x / root)
            df = np.where(np.abs(df) < 1e-9, 1e-9, df)
            x = np.clip(x - f / df, -1.0, 1.0)
        return x


# ---------------------------------------------------------------- Fourier channel model

EVAL_ROWS = 1 << 14


@dataclass
class ChannelWaveform:
    """y(theta) = w0 + sum_n a_n cos(n theta) + b_n sin(n theta), theta the common fine phase.

    `kind` says what the channel ideally is: "sin" (y ~ sin(theta + psi)) or "cos"
    (y ~ cos(theta + psi)); psi is the phase of its fundamental, the channel's own phase
    error, which the quadrature stage corrects (seed 001 section 3.2).
    """

    kind: str
    weights: np.ndarray   # seed 000 order: [w0, a_1..a_H, b_1..b_H]

    @property
    def harmonics(self) -> int:
        return (len(self.weights) - 1) // 2

    def coefficients(self) -> tuple[float, np.ndarray, np.ndarray]:
        h = self.harmonics
        return self.weights[0], self.weights[1:h + 1], self.weights[h + 1:]

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        # in blocks of rows: the design matrix of a long recording would hold 2H+1 values a sample
        theta = np.ravel(theta)
        out = np.empty(len(theta))
        for start in range(0, len(theta), EVAL_ROWS):
            sl = slice(start, start + EVAL_ROWS)
            out[sl] = design_matrix(theta[sl], self.harmonics) @ self.weights
        return out

    def derivative(self, theta: np.ndarray) -> np.ndarray:
        _, a, b = self.coefficients()
        n = np.arange(1, self.harmonics + 1)
        t = np.asarray(theta, float)[..., None]
        return (-a * n * np.sin(n * t) + b * n * np.cos(n * t)).sum(-1)

    @property
    def amplitude(self) -> float:
        _, a, b = self.coefficients()
        return float(np.hypot(a[0], b[0]))

    @property
    def psi(self) -> float:
        """Phase of the fundamental: a1 cos + b1 sin = R sin(theta+psi) or R cos(theta+psi)."""
        _, a, b = self.coefficients()
        return float(np.arctan2(a[0], b[0]) if self.kind == "sin" else np.arctan2(-b[0], a[0]))

    def ideal(self, theta: np.ndarray) -> np.ndarray:
        """What the corrected channel should read at phase theta."""
        t = np.asarray(theta, float) + self.psi
        return np.sin(t) if self.kind == "sin" else np.cos(t)

    def to_dict(self) -> dict:
        return {"kind": self.kind, "weights": [float(w) for w in self.weights],
                "order": "w0, a_1..a_H (cos n*theta), b_1..b_H (sin n*theta)", "units": "ADC counts"}

    @classmethod
    def from_dict(cls, d: dict) -> "ChannelWaveform":
        return cls(d["kind"], np.asarray(d["weights"], float))


def paper_channel(wave: ChannelWaveform) -> PaperChannel:
    """Express a fitted channel in the seed's terms (its own phase), for the polynomial inverse."""
    w0, a, b = wave.coefficients()
    psi, h = wave.psi, wave.harmonics
    n = np.arange(1, h + 1)
    # components along cos(n t) and sin(n t), t = theta + psi
    along_cos = a * np.cos(n * psi) - b * np.sin(n * psi)
    along_sin = a * np.sin(n * psi) + b * np.cos(n * psi)
    f2 = float(along_sin[1]) if h >= 2 else 0.0
    if wave.kind == "sin":
        odd = along_sin[0::2]
    else:
        # with u = pi/2 - t, x = sin u = cos t: cos(n t) = (-1)^((n-1)/2) sin(n u) for odd n,
        # and sin(2u) = sin(2t), so the seed's eq. 12 applies unchanged in u.
        odd = along_cos[0::2] * (-1.0) ** np.arange(len(along_cos[0::2]))
    return PaperChannel(float(w0), odd, float(f2))


# ---------------------------------------------------------------- the general inverse

@dataclass
class WaveformInverse:
    """Reading -> ideal value (sin or cos of the channel's own phase), as two tables.

    Table `values[branch]` samples the inverse at readings `lo + k*step`. Branch 1 holds when
    the other channel's reading is at or above a threshold, branch 0 otherwise; the threshold
    is the other channel's reading at this channel's maximum (`threshold_hi`) for readings in
    the upper half (`reading >= mid`) and at its minimum (`threshold_lo`) below, so the branch
    flips exactly at the extremes. Between grid points the inverse is interpolated linearly,
    exactly as the hardware does.
    """

    kind: str
    lo: float
    step: float
    values: np.ndarray        # shape (2, n)
    threshold_hi: float
    threshold_lo: float
    mid: float

    def branch(self, y: np.ndarray, other: np.ndarray) -> np.ndarray:
        thr = np.where(np.asarray(y) >= self.mid, self.threshold_hi, self.threshold_lo)
        return (np.asarray(other) >= thr).astype(np.int64)

    def __call__(self, y: np.ndarray, other: np.ndarray) -> np.ndarray:
        pos = (np.asarray(y, float) - self.lo) / self.step
        n = self.values.shape[1]
        pos = np.clip(pos, 0, n - 1)
        i = np.minimum(pos.astype(np.int64), n - 2)
        frac = pos - i
        branch = self.branch(y, other)
        v0 = self.values[branch, i]
        return v0 + (self.values[branch, i + 1] - v0) * frac

    def value_at(self, y: np.ndarray, branch: int) -> np.ndarray:
        return np.interp(y, self.lo + self.step * np.arange(self.values.shape[1]), self.values[branch])

    def to_dict(self) -> dict:
        return {"kind": self.kind, "lo_counts": self.lo, "step_counts": self.step,
                "threshold_hi_counts": self.threshold_hi, "threshold_lo_counts": self.threshold_lo,
                "mid_counts": self.mid,
                "branch1_means": "other >= (reading >= mid ? threshold_hi : threshold_lo)"}


def build_inverse(wave: ChannelWaveform, other: ChannelWaveform, lo: float, hi: float,
                  points: int) -> WaveformInverse:
    """Invert `wave` on its two monotone half periods, one table per branch.

    The halves run between the waveform's minimum and maximum; the branch is told by the other
    channel, compared with its reading at this channel's nearer extreme (it is near its zero
    crossing there, so the compare is sharp). Only noise can put a sample on the wrong half,
    and only right at an extreme, where the two candidate values coincide.
    """
    grid = np.linspace(0, 2 * np.pi, 8192, endpoint=False)
    g = wave(grid)
    t_max, t_min = grid[np.argmax(g)], grid[np.argmin(g)]
    rising = _interval(t_min, t_max)
    falling = _interval(t_max, t_min)
    thr_hi, thr_lo = (float(v) for v in other(np.array([t_max, t_min])))
    mid = 0.5 * (float(g.max()) + float(g.min()))
    mid_rising = rising[len(rising) // 2]
    rising_is_branch1 = float(other(np.array([mid_rising]))[0]) >= 0.5 * (thr_hi + thr_lo)

    ys = np.linspace(lo, hi, points)
    tables = {}
    for name, interval in (("rising", rising), ("falling", falling)):
        gv = wave(interval)
        if name == "falling":   # make it increasing for np.interp
            interval, gv = interval[::-1], gv[::-1]
        gv = np.maximum.accumulate(gv)
        yc = np.clip(ys, gv[0], gv[-1])
        t = np.interp(yc, gv, interval)
        for _ in range(3):      # Newton polish (seed eq. 13), kept inside the half period
            d = wave.derivative(t)
            ok = np.abs(d) > 1e-6 * wave.amplitude
            t = np.where(ok, t - (wave(t) - yc) / np.where(ok, d, 1.0), t)
            t = np.clip(t, interval.min(), interval.max())
        v_min, v_max = wave.ideal(interval[[0, -1]])
        tables[name] = _beyond_extremes(ys, wave.ideal(t), (float(gv[0]), float(v_min)), (float(gv[-1]), float(v_max)))
    values = np.vstack([tables["falling"], tables["rising"]] if rising_is_branch1
                       else [tables["rising"], tables["falling"]])
    return WaveformInverse(wave.kind, lo, (hi - lo) / (points - 1), values, thr_hi, thr_lo, mid)


EDGE_SHARE = 0.1   # beyond an extreme the inverse keeps its secant slope over this share of the swing inside it
BEYOND_MAX = 1.5   # and stops at this ideal value (the tables hold [-2, 2))


def _beyond_extremes(ys: np.ndarray, values: np.ndarray, minimum: tuple[float, float],
                     maximum: tuple[float, float]) -> np.ndarray:
    """A branch's values with the readings beyond the waveform's extremes continued along the inverse's slope
    near each extreme, up to +-BEYOND_MAX, instead of held at the extreme's value.

    A reading beyond the swing is the signal plus something additive (noise, interference). Held flat, the
    table takes exactly the radial part of it out near the extremes and passes the tangential part: the
    radius no longer shows an additive tone whole, and the interference canceller, which adapts on the
    radius, cannot learn what it must remove (population 9000: a tone of 5 % of full scale on both channels;
    behind flat extremes the canceller left 250", four times the floor, behind continued ones 76").
    `minimum`, `maximum`: (reading, value) at each extreme, exact (the table's grid points straddle them)."""
    out = values.copy()
    (y_min, v_min), (y_max, v_max) = minimum, maximum
    span = y_max - y_min
    if span <= 0:
        return out
    for edge, v_edge, inner, beyond in ((y_max, v_max, y_max - EDGE_SHARE * span, ys > y_max),
                                        (y_min, v_min, y_min + EDGE_SHARE * span, ys < y_min)):
        if np.any(beyond):
            slope = (v_edge - np.interp(inner, ys, values)) / (edge - inner)
            out[beyond] = np.clip(v_edge + slope * (ys[beyond] - edge), -BEYOND_MAX, BEYOND_MAX)
    return out


def _interval(start: float, end: float, n: int = 8192) -> np.ndarray:
    span = (end - start) % (2 * np.pi)
    return start + np.linspace(0, span, n)


def is_invertible(wave: ChannelWaveform, points: int = 8192) -> bool:
    """One rising and one falling half per period: only then do the two tables of `build_inverse`
    invert the channel everywhere (a wiggle near an extreme folds a half onto itself)."""
    slope = wave.derivative(np.linspace(0, 2 * np.pi, points, endpoint=False))
    signs = np.sign(slope[slope != 0])
    return len(signs) > 0 and int(np.count_nonzero(signs != np.roll(signs, 1))) == 2
