"""Quadrature correction (seed 001 section 3.2) and its general (Heydemann) form.

Both produce the same correction, the one the hardware applies:
    s' = k_ss*(s - ofs_s) + k_sc*(c - ofs_c),   c' = k_cc*(c - ofs_c)
The seed fits A*uc^2 + B*us^2 + C*us*uc = 1 (eq. 18) and keeps only the phase
alpha = arcsin(C/2A) (eq. 19): k_ss = 1/cos(alpha), k_sc = tan(alpha), k_cc = 1 (eq. 21).
The general conic a*s^2 + b*s*c + c*c^2 + d*s + e*c = 1 also finds offsets and the gain
ratio, as Heydemann (1981) does.
"""

from dataclasses import asdict, dataclass

import numpy as np


class QuadratureFitError(ValueError):
    """The samples do not determine an ellipse (too little of it is covered, or no signal)."""


@dataclass
class QuadratureCorrection:
    ofs_s: float = 0.0
    ofs_c: float = 0.0
    k_ss: float = 1.0
    k_sc: float = 0.0
    k_cc: float = 1.0
    alpha_rad: float = 0.0        # the phase error it removes (for reports)
    gain_ratio: float = 1.0       # g_s / g_c (for reports)

    def apply(self, s: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        cs = c - self.ofs_c
        return self.k_ss * (s - self.ofs_s) + self.k_sc * cs, self.k_cc * cs

    def to_dict(self) -> dict:
        d = asdict(self)
        d["form"] = "s' = k_ss*(s-ofs_s) + k_sc*(c-ofs_c); c' = k_cc*(c-ofs_c)"
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "QuadratureCorrection":
        """Every field is required (KeyError names a missing one): a dropped key would silently mean no correction."""
        return cls(**{k: float(d[k]) for k in cls.__dataclass_fields__})


NOT_ROUND = "the recording must span at least one full signal period"


def not_round(ang: np.ndarray) -> str:
    """Why samples at the angles ``ang`` (rad, in time order) miss part of the figure: too little motion, or a
    steady speed in step with the sampling (0.2 periods a sample visits five phases over a long recording)."""
    step = float(np.median(np.abs(np.angle(np.exp(1j * np.diff(ang)))))) / (2 * np.pi) if len(ang) > 1 else 0.0
    if step > 1 / 16:
        return (f"the phase moves {step:.3g} periods a sample, and at a steady speed in step with the sampling "
                "the samples fall on the same few phases: record at another speed or sample rate")
    return NOT_ROUND


def _check_coverage(s: np.ndarray, c: np.ndarray, min_octants: int = 8):
    """An ellipse is only determined when the samples go round it."""
    if len(s) < 6:
        raise QuadratureFitError(f"only {len(s)} samples; an ellipse needs at least 6")
    ang = np.arctan2(s - np.median(s), c - np.median(c))
    octants = np.unique(np.floor((ang + np.pi) / (np.pi / 4)).astype(int) % 8)
    if len(octants) < min_octants:
        raise QuadratureFitError(f"the samples cover only {len(octants)} of 8 octants of the "
                                 f"Lissajous figure: {not_round(ang)}")


def _check_fit(q: "QuadratureCorrection", s: np.ndarray, c: np.ndarray, min_octants: int = 8):
    """After the fit: the corrected samples must go round a circle, not scatter around a point."""
    s2, c2 = q.apply(s, c)
    r = np.hypot(s2, c2)
    scatter = np.std(r) / max(np.mean(r), 1e-300)
    if scatter > 0.25:
        raise QuadratureFitError(f"the samples scatter by {100 * scatter:.0f}% around the fitted ellipse "
                                 f"(noise or no motion): {NOT_ROUND}")
    ang = np.arctan2(s2, c2)
    octants = np.unique(np.floor((ang + np.pi) / (np.pi / 4)).astype(int) % 8)
    if len(octants) < min_octants:
        raise QuadratureFitError(f"the samples cover only {len(octants)} of 8 octants of the "
                                 f"Lissajous figure: {not_round(ang)}")
    return q


def fit_seed_ellipse(us: np.ndarray, uc: np.ndarray) -> QuadratureCorrection:
    """Seed 001 eqs. 18-21: least squares on A*uc^2 + B*us^2 + C*us*uc = 1, alpha = arcsin(C/2A)."""
    _check_coverage(us, uc)
    m = np.column_stack([uc * uc, us * us, us * uc])
    (a, b, c), *_ = np.linalg.lstsq(m, np.ones_like(us), rcond=None)
    ratio = c / (2 * a)
    if not -1 < ratio < 1:
        raise QuadratureFitError(f"ellipse fit gives C/2A = {ratio:.3g}, outside (-1, 1)")
    alpha = float(np.arcsin(ratio))
    return _check_fit(QuadratureCorrection(k_ss=1 / np.cos(alpha), k_sc=np.tan(alpha), alpha_rad=alpha,
                                           gain_ratio=float(np.sqrt(a / b))), us, uc)


def fit_conic(s: np.ndarray, c: np.ndarray) -> QuadratureCorrection:
    """General conic through the Lissajous figure: offsets, gains and phase (Heydemann).

    Model: s = ofs_s + g_s sin(theta - alpha), c = ofs_c + g_c cos(theta). Output is scaled so
    that c' has unit amplitude; s' then has unit amplitude too and leads c' by 90 degrees.
    """
    _check_coverage(s, c)
    # centre and scale first: the fit is then well conditioned for any ADC units
    s0, c0 = np.mean(s), np.mean(c)
    scale = np.sqrt(np.mean((s - s0) ** 2 + (c - c0) ** 2))
    if not scale > 0:
        raise QuadratureFitError("no signal: both channels are constant")
    x, y = (s - s0) / scale, (c - c0) / scale
    m = np.empty((len(x), 5))       # the design matrix filled in place: no temporaries of its columns
    np.multiply(x, x, out=m[:, 0])
    np.multiply(x, y, out=m[:, 1])
    np.multiply(y, y, out=m[:, 2])
    m[:, 3], m[:, 4] = x, y
    del x, y
    p, *_ = np.linalg.lstsq(m, np.ones(len(m)), rcond=None)
    del m
    q = np.array([[p[0], p[1] / 2], [p[1] / 2, p[2]]])
    if np.linalg.det(q) <= 0 or p[0] <= 0:
        raise QuadratureFitError(f"the samples do not lie on an ellipse: {NOT_ROUND}")
    centre = -0.5 * np.linalg.solve(q, p[3:])
    k = 1 + centre @ q @ centre
    qa, qb, qc = q[0, 0] / k, 2 * q[0, 1] / k, q[1, 1] / k
    sin_alpha = qb / (2 * np.sqrt(qa * qc))
    alpha = float(np.arcsin(np.clip(sin_alpha, -0.999999, 0.999999)))
    cos_a = np.cos(alpha)
    g_s = 1 / (np.sqrt(qa) * cos_a) * scale
    g_c = 1 / (np.sqrt(qc) * cos_a) * scale
    return _check_fit(QuadratureCorrection(ofs_s=float(s0 + centre[0] * scale), ofs_c=float(c0 + centre[1] * scale),
                                           k_ss=float(1 / (g_s * cos_a)), k_sc=float(np.tan(alpha) / g_c),
                                           k_cc=float(1 / g_c), alpha_rad=alpha, gain_ratio=float(g_s / g_c)), s, c)


# ---------------------------------------------------------------- the figure's shape alone

SHAPE_HARMONICS_MAX = 16
SHAPE_PASSES = 4          # fixed-point passes from the measured to the true phase
CONIC_ORDERS = 2          # radius harmonics 1 and 2 are the conic's (offsets, gains, phase)


def shape_phase_error(theta: np.ndarray, radius: np.ndarray, harmonics_max: int = SHAPE_HARMONICS_MAX):
    """The phase error that the shape of a corrected Lissajous figure implies, without any time.

    Write the corrected figure as z = exp(i*theta) * (1 + eps_m * exp(-i*m*theta)): the term bends the
    radius, ln r = Re(eps_m exp(-i m theta)), and moves the angle by Im(eps_m exp(-i m theta)), the
    same size a quarter of a harmonic later. That is the channels' harmonic of order m-1 (for
    m = 4: the 3rd harmonic two quadrature channels of the same shape have; interferometer software
    corrects it this way). The other cause of the same radius harmonic, order m+1, moves the angle
    the opposite way and cannot be told apart without a time or angle reference: the lower order is
    taken. Radius harmonics 1 and 2 belong to the conic. Returns the phase error (rad, per sample,
    measured minus true) and the radius's harmonics (relative amplitude per order, for reports).
    """
    from .fourierfit import fit_select

    theta = np.asarray(theta, float)
    log_r = np.log(radius / np.median(radius))
    true = theta
    for _ in range(SHAPE_PASSES):    # ln r and the angle error are series in the true phase: fixed point
        series, _, _ = fit_select(true, log_r, harmonics_max)
        h = (len(series.weights) - 1) // 2
        orders = np.arange(1, h + 1)
        keep = orders > CONIC_ORDERS
        a, b, orders = series.weights[1:h + 1][keep], series.weights[h + 1:][keep], orders[keep]
        arg = true[:, None] * orders
        true = theta - (b * np.cos(arg) - a * np.sin(arg)).sum(axis=1)
    return theta - true, {int(m): float(np.hypot(x, y)) for m, x, y in zip(orders, a, b, strict=True)}
