"""The effect library of the closed loop: effects outside the seeds' model.

Each effect has a signature (regressors of the angle error in the domains where it shows),
a model term (the same regressors, fitted by least squares: every term is linear in its
weights), and a place where its correction lives:
- "hardware": a correction stage the core can carry (it uses only what the core knows online:
  fine phase, position in the revolution, a filtered speed, the direction of motion);
- "adaptive": the effect does not repeat between recordings (drift), so its correction is an
  online tracker working from the signals themselves;
- "artefact": the effect is in the measurement, not in the encoder (the reference's lag, a
  vibration between encoder and reference); it is compensated in the evaluation only.

Angle-domain terms are the first-order image of the signal-domain cause: an offset that
changes over the revolution shows as a first-order fine-phase error whose size follows the
revolution, a gain as a second-order one, a channel sampling skew as a second-order error
proportional to speed, and so on.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from ..fixed.trim import speed_window_log2
from .fourierfit import harmonic_design
from .position import wrap

MAG_REF = 1.0                 # amplitude terms work on magnitude - MAG_REF (a fixed point, as in the hardware)
REV_ORDERS = 4                # revolution orders for modulated terms
TIME_ORDERS = 3               # Legendre degree for slow changes in time


@dataclass
class Context:
    """What every term may depend on, per sample."""

    phi: np.ndarray     # fine phase, rad
    psi: np.ndarray     # position in the revolution, rad
    t: np.ndarray       # time, s
    speed: np.ndarray   # filtered speed, rev/s (causal, as the core would estimate it)
    accel: np.ndarray   # rev/s^2
    direction: np.ndarray   # +1 / -1
    magnitude: np.ndarray   # corrected signal magnitude (1 nominal)
    lines: int = 1          # signal periods per revolution
    t_span: tuple | None = None   # (first, last) time of the whole recording when this is a slice of it
    # False where the recording a term is fitted on does not cover the revolution: columns that are harmonics of
    # the place in the revolution are then zero (their weights fit to 0: a series over part of the revolution would
    # be extrapolated to the rest). Predictions take the full columns, with those weights
    revolution_covered: bool = True

    def rows(self, sl: slice) -> Context:
        """The same context for a block of samples (designs are evaluated block by block to bound memory)."""
        return Context(self.phi[sl], self.psi[sl], self.t[sl], self.speed[sl], self.accel[sl], self.direction[sl],
                       self.magnitude[sl], self.lines, self.t_span or (float(self.t[0]), float(self.t[-1])),
                       self.revolution_covered)

    def revolution_harmonic(self, m: int, f) -> np.ndarray:
        """f(m psi), or zeros where the revolution is not covered (revolution_covered)."""
        return f(m * self.psi) if self.revolution_covered else np.zeros_like(self.psi)


def speed_estimate(rev_unwrapped: np.ndarray, t: np.ndarray, log2_window: int, start_speed: float = 0.0
                   ) -> np.ndarray:
    """Causal speed (rev/s): the position change over the last 2^log2_window samples; before that many samples
    came, over the longest power of two of samples there are (1, 2, 4, ...: a start-up has a speed from its
    second sample on), start_speed (rev/s) at the first (START_SPEED). What fringe_trim computes in fine counts
    (model/fringe/fixed/trim.py), with the window the generator gives it (fixed.trim.speed_window_log2), but for
    its saturation of a start-up window's scaled speed at half a revolution per window (beyond the overspeed limit
    only) and the rounding of START_SPEED."""
    n = len(rev_unwrapped)
    v = np.full(n, float(start_speed))
    for k in range(log2_window + 1):
        w = 1 << k                      # samples [w, 2w) take the window w; from the full window on, that one
        end = n if k == log2_window else min(2 * w, n)
        if end > w:
            dt = t[w:end] - t[:end - w]
            v[w:end] = (rev_unwrapped[w:end] - rev_unwrapped[:end - w]) / np.where(dt > 0, dt, 1.0)
    return v


def magnitude_average(magnitude: np.ndarray, log2_samples: int) -> np.ndarray:
    """The magnitude's running average over about 2^log2_samples samples, from the first sample of a stream
    (fringe_trim's MAG_SMOOTH_LOG2 = K, float): a[0] = m[0], a[n] = a[n-1] + (m[n] - a[n-1]) / 2^K; m itself
    for K = 0. What an amplitude that changes is read by: the sample's own magnitude also carries its noise
    and the fine-phase ripple that a waveform changing with the amplitude puts on the radius, which a term in
    the magnitude would otherwise take for the amplitude."""
    m = np.asarray(magnitude, dtype=float)
    if not log2_samples or m.size == 0:
        return m
    a = 2.0 ** -int(log2_samples)
    return lfilter([a], [1.0, a - 1.0], m, zi=[(1.0 - a) * m[0]])[0]


def make_context(frac: np.ndarray, position_periods: np.ndarray, lines: int, t: np.ndarray,
                 magnitude: np.ndarray, start_speed: float = 0.0, magnitude_smooth_log2: int = 0,
                 speed_log2: int | None = None) -> Context:
    """The context of a stream from reset; start_speed (rev/s): the speed taken for its first sample, which has
    no window yet (Calibration.start_speed_rev_s, fringe_trim's START_SPEED); the magnitude averaged over
    ~2^magnitude_smooth_log2 samples (Calibration.magnitude_smooth_log2, fringe_trim's MAG_SMOOTH_LOG2); the speed
    over 2^speed_log2 samples (Calibration.speed_window_log2, fringe_trim's SPEED_LOG2; None: the default)."""
    rev = position_periods / lines
    unwrapped = rev[0] + np.concatenate([[0.0], np.cumsum(wrap(np.diff(rev)))])
    log2_window = speed_window_log2(lines) if speed_log2 is None else speed_log2
    v = speed_estimate(unwrapped, t, log2_window, start_speed)
    acc = np.gradient(v, t) if len(t) > 2 else np.zeros_like(v)
    # no acceleration from the start-up's growing windows: their speeds jump from 0 at the first sample and
    # step between window lengths (a spike that would fit whatever error the first samples carry)
    acc[:(1 << log2_window) + 1] = 0.0
    d = np.where(v >= 0, 1, -1)     # standstill counts as forward (fringe_trim: dir = speed < 0)
    return Context(2 * np.pi * frac, 2 * np.pi * (rev % 1.0), t, v, acc, d,
                   magnitude_average(magnitude, magnitude_smooth_log2), lines)


def _rev_modulated(orders_phi, ctx: Context, m_orders=REV_ORDERS) -> list[np.ndarray]:
    cols = []
    for k in orders_phi:
        ck, sk = np.cos(k * ctx.phi), np.sin(k * ctx.phi)
        for m in range(1, m_orders + 1):
            cm, sm = ctx.revolution_harmonic(m, np.cos), ctx.revolution_harmonic(m, np.sin)
            cols += [ck * cm, ck * sm, sk * cm, sk * sm]
    return cols


def _legendre_time(ctx: Context, degree=TIME_ORDERS) -> list[np.ndarray]:
    t0, t1 = ctx.t_span or (ctx.t[0], ctx.t[-1])
    span = t1 - t0
    x = 2 * (ctx.t - t0) / span - 1 if span > 0 else np.zeros_like(ctx.t)
    return [np.polynomial.legendre.Legendre.basis(d)(x) for d in range(1, degree + 1)]


@dataclass
class Effect:
    name: str
    cause: str                 # the physical effect, in words
    signature: str             # where and how it shows
    correction: str            # "hardware", "adaptive" or "artefact"
    where: str                 # which stage carries it
    columns: object            # ctx -> list of regressors
    needs: tuple = ()          # context conditions: "speed", "direction", "time"
    static: int = 0            # trailing columns that are its static part: they fit, but are no evidence of it

    def design(self, ctx: Context) -> np.ndarray:
        return np.column_stack(self.columns(ctx))


def _speed_cols(ctx):
    return [ctx.speed]


def _skew_cols(ctx):
    # cos channel late by tau: c = cos(phi + delta), delta = 2 pi lines v tau, and
    # atan2(sin phi, c) - phi = delta sin^2 phi = (delta / 2)(1 - cos 2 phi). At a mean speed the conic takes
    # out the skew's mean phase delta0 (a quadrature phase error); a change D of delta around it then gives
    # (D / 2)(1 - cos 2 phi + tan(delta0) sin 2 phi): the second column carries the part that grows with delta0.
    # D follows the speed's change from its mean, so the shape is the speed columns less their static part: the
    # static order-2 columns let the fit take that part out (without them a skew at a large mean speed looks
    # like a lag, speed x 1, which is its only part that no static column holds)
    c2, s2 = np.cos(2 * ctx.phi), np.sin(2 * ctx.phi)
    return [ctx.speed * (1 - c2), ctx.speed * s2, c2, s2]


SKEW_COLUMNS = 4


def _hyst_cols(ctx):
    cols = [ctx.direction.astype(float)]
    for m in range(1, REV_ORDERS + 1):
        cols += [ctx.direction * ctx.revolution_harmonic(m, np.cos), ctx.direction * ctx.revolution_harmonic(m, np.sin)]
    return cols


def _drift_cols(ctx):
    cols = []
    for k in (1, 2):
        for f in (np.cos(k * ctx.phi), np.sin(k * ctx.phi)):
            cols += [f * p for p in _legendre_time(ctx)]
    return cols


def _accel_cols(ctx):
    return [ctx.accel]


# a channel harmonic n that grows or shrinks with the amplitude (or that a waveform table calibrated at one
# amplitude reads off its curve) moves the phase at fine-phase orders n - 1 and n + 1: harmonics 2 and 3 give 1..4
AMPLITUDE_ORDERS = 4


def amplitude_phase_columns(phi):
    """The fine-phase shape of the amplitude term per unit of magnitude change: 1, cos k phi, sin k phi."""
    cols = [np.ones_like(phi)]
    for k in range(1, AMPLITUDE_ORDERS + 1):
        cols += [np.cos(k * phi), np.sin(k * phi)]
    return cols


def amplitude_shape(weights, phi):
    """The amplitude term's fitted fine-phase shape (arcsec per unit of magnitude change) at phi."""
    return np.column_stack(amplitude_phase_columns(phi)) @ np.asarray(weights)


def _amplitude_cols(ctx):
    a = ctx.magnitude - MAG_REF
    return [a * c for c in amplitude_phase_columns(ctx.phi)]


LIBRARY = {
    "rev_offset_gain": Effect(
        "rev_offset_gain", "offsets and gains that vary over the revolution (disc or magnet eccentricity, air gap)",
        "fine-phase orders 1 and 2 whose size follows the revolution (sidebands of the signal period)",
        "hardware", "per-sector offset/gain correction indexed by the position in the revolution",
        lambda ctx: _rev_modulated((1, 2), ctx), ("periods",)),
    "sampling_skew": Effect(
        "sampling_skew", "the two channels are sampled at different instants",
        "speed x (1 - cos 2 phi) and, beside a large mean skew, speed x sin 2 phi, each less its part at the mean "
        "speed: a second-order fine-phase error and half as much lag, both in proportion to speed",
        "hardware", "speed-dependent phase correction (quadrature stage, filtered speed)", _skew_cols, ("speed",),
        static=2),
    "hysteresis": Effect(
        "hysteresis", "direction-dependent error (backlash, magnetic hysteresis, readhead tilt)",
        "an error that changes sign with the direction of motion, possibly varying over the revolution",
        "hardware", "direction-dependent long-period table", _hyst_cols, ("direction",)),
    "ref_lag": Effect(
        "ref_lag", "time lag between the reference and the ADC samples",
        "an error proportional to speed with no fine-phase structure",
        "artefact", "the measurement (shift the reference in time); nothing in the hardware", _speed_cols,
        ("speed",)),
    "drift": Effect(
        "drift", "offsets and gains drifting over time (temperature, supply)",
        "fine-phase orders 1 and 2 whose size changes slowly with time",
        "adaptive", "online offset/gain tracker after the quadrature stage (adapts from the signals)", _drift_cols,
        ("time",)),
    "acceleration": Effect(
        "acceleration", "error proportional to acceleration (shaft torsion between encoder and reference)",
        "an error following the acceleration", "artefact", "the mechanical set-up; nothing in the hardware",
        _accel_cols, ("speed",)),
    "amplitude": Effect(
        "amplitude", "error depending on the signal amplitude (the waveform's shape changes with the air gap, or "
        "the amplitude changes and the waveform tables, calibrated at one amplitude, read off their curve)",
        "fine-phase orders 0 to 4 whose size follows the corrected magnitude",
        "hardware", "magnitude-dependent phase correction (the CORDIC magnitude, known online)",
        _amplitude_cols),
}


PREDICT_ROWS = 1 << 14


@dataclass
class FittedEffect:
    name: str
    weights: np.ndarray
    tone_hz: float = 0.0       # for the "tone" artefact
    engine: str = "core"       # "float": the bit-exact core does not carry it (no legal width or no block)

    def to_dict(self) -> dict:
        e = LIBRARY.get(self.name)
        d = {"name": self.name, "weights": [float(w) for w in self.weights],
             "units": "arcsec per regressor (effects.LIBRARY[name].columns)"}
        if e is not None:
            d.update(correction=e.correction, where=e.where)
        if self.tone_hz:
            d["tone_hz"] = self.tone_hz
        if self.engine != "core":
            d["engine"] = self.engine
        return d

    @classmethod
    def from_dict(cls, d: dict) -> FittedEffect:
        w = np.asarray(d["weights"], float)
        if d["name"] == "sampling_skew" and len(w) < SKEW_COLUMNS:     # written before the skew had all its columns
            w = np.append(w, np.zeros(SKEW_COLUMNS - len(w)))
        return cls(d["name"], w, float(d.get("tone_hz", 0.0)), d.get("engine", "core"))

    def predict(self, ctx: Context) -> np.ndarray:
        """The term's error (arcsec) per sample, evaluated in blocks of rows (bounded memory)."""
        n = len(ctx.phi)
        if n <= PREDICT_ROWS:
            return self._predict(ctx)
        return np.concatenate([self._predict(ctx.rows(slice(s, s + PREDICT_ROWS))) for s in range(0, n, PREDICT_ROWS)])

    def _predict(self, ctx: Context) -> np.ndarray:
        if self.name == "tone":
            return tone_columns(ctx, self.tone_hz) @ self.weights
        if self.name == "interference":
            return interference_columns(ctx, self.tone_hz) @ self.weights
        if self.name.startswith("generic:"):
            return generic_design(self.name, ctx) @ self.weights
        return LIBRARY[self.name].design(ctx) @ self.weights


def tone_columns(ctx: Context, f: float) -> np.ndarray:
    return np.column_stack([np.cos(2 * np.pi * f * ctx.t), np.sin(2 * np.pi * f * ctx.t)])


INTERFERENCE_WAVE_ORDERS = 8     # what the magnitude repeats over the fine phase, removed before the tone fit

INTERFERENCE = dict(
    cause="additive interference on the signals at a fixed frequency (switching supply, motor drive, pick-up)",
    signature="a line at the frequency in each channel's error against the reference's phase; in the angle, "
              "sidebands at plus and minus the electrical frequency",
    correction="adaptive",
    where="fringe_canceller between the quadrature and the CORDIC: an adaptive canceller at the named frequency "
          "that estimates the tone on each corrected channel from the Lissajous radius (no reference needed) "
          "and subtracts it, converging anew after every reset (docs/blocks/fringe_canceller.md)")


def interference_columns(ctx: Context, f: float) -> np.ndarray:
    """The angle image (rad of fine phase) of an additive tone at f on the corrected channels, estimated
    from this recording alone: a tone n = (n_c, n_s) moves the point (cos phi, sin phi) radially by
    n_c cos phi + n_s sin phi (seen in the magnitude) and along the circle by n_s cos phi - n_c sin phi
    (the angle error). Its phase does not repeat between recordings, so it is fitted on each."""
    w = 2 * np.pi * f * ctx.t
    cw, sw = np.cos(w), np.sin(w)
    cp, sp = np.cos(ctx.phi), np.sin(ctx.phi)
    tone = np.column_stack([cw * cp, sw * cp, cw * sp, sw * sp])
    shape = [np.ones_like(cp)] + [g(k * ctx.phi) for k in range(1, INTERFERENCE_WAVE_ORDERS + 1)
                                  for g in (np.cos, np.sin)]
    x = np.column_stack([*shape, tone])
    coef, *_ = np.linalg.lstsq(x, ctx.magnitude, rcond=None)
    a_c, b_c, a_s, b_s = coef[-4:]
    n_c, n_s = a_c * cw + b_c * sw, a_s * cw + b_s * sw
    return ((n_s * cp - n_c * sp) / np.maximum(ctx.magnitude, 1e-9))[:, None]


@dataclass
class AngleCorrections:
    """Hardware-carried terms, subtracted from the output angle (arcsec)."""

    terms: list[FittedEffect] = field(default_factory=list)

    def arcsec(self, ctx: Context) -> np.ndarray:
        total = np.zeros_like(ctx.phi)
        for term in self.terms:
            total += term.predict(ctx)
        return total


# ---------------------------------------------------------------- offsets and gains over the revolution

@dataclass
class RevNormalisation:
    """Per channel: reading -> (reading - offset(psi)) / (1 + gain(psi)), Fourier in psi (orders 1..M).

    The hardware form is a small table over the revolution (per-sector offset and gain) in front of
    the waveform tables, indexed by the position of the previous sample.
    """

    weights: dict   # kind -> (offset cos/sin weights (2M,), gain cos/sin weights (2M,))

    @staticmethod
    def basis(psi: np.ndarray, orders: int = REV_ORDERS) -> np.ndarray:
        return np.column_stack([f(m * psi) for m in range(1, orders + 1) for f in (np.cos, np.sin)])

    def apply(self, sin: np.ndarray, cos: np.ndarray, psi: np.ndarray):
        b = self.basis(psi)
        out = []
        for kind, y in (("sin", sin), ("cos", cos)):
            off, gain = self.weights[kind]
            out.append((y - b @ off) / (1.0 + b @ gain))
        return out[0], out[1]

    def to_dict(self) -> dict:
        return {k: {"offset_counts": [float(x) for x in o], "gain_relative": [float(x) for x in g]}
                for k, (o, g) in self.weights.items()} | {"basis": "cos psi, sin psi, cos 2psi, ..."}

    @classmethod
    def from_dict(cls, d: dict) -> RevNormalisation:
        return cls({k: (np.asarray(d[k]["offset_counts"]), np.asarray(d[k]["gain_relative"])) for k in ("sin", "cos")})


def fit_rev_normalisation(waves: dict, sin: np.ndarray, cos: np.ndarray, phi: np.ndarray,
                          psi: np.ndarray) -> RevNormalisation:
    """Least squares, linearised: y - W(phi) = offset(psi) + gain(psi) * (W(phi) - w0)."""
    b = RevNormalisation.basis(psi)
    weights = {}
    for kind, y in (("sin", sin), ("cos", cos)):
        w = waves[kind](phi)
        ac = w - waves[kind].weights[0]
        x = np.column_stack([b, b * ac[:, None]])
        coef, *_ = np.linalg.lstsq(x, y - w, rcond=None)
        weights[kind] = (coef[:b.shape[1]], coef[b.shape[1]:])
    return RevNormalisation(weights)


# ---------------------------------------------------------------- the general dictionary under the names

#: factors that multiply the fine-phase harmonics, and whether fringe_trim's tables can carry the product
#: (map: any function of phase x sector x direction; gs: phase x speed; ga: phase x magnitude)
GENERIC_FACTORS = {"1": True, "speed": True, "speed2": False, "direction": True, "magnitude": True,
                   "magnitude2": False, "revolution": True, "time": False}
GENERIC_PHASE_ORDERS = (1, 2, 3, 4, 6, 8)     # fine-phase orders 0..K offered (K chosen by cross-validation)
GENERIC_REV_ORDERS = (1, 2, 4, 8)             # revolution orders 1..M of the "revolution" factor


FINE_MAP_PREFIX = "generic:1:"   # a term of the fine phase alone (factor 1): a fine-phase map in fringe_trim


def generic_name(factor: str, k: int, m: int = 0) -> str:
    return f"generic:{factor}:{k}:{m}"


def parse_generic(name: str) -> tuple[str, int, int]:
    _, factor, k, m = name.split(":")
    return factor, int(k), int(m)


def phase_columns(phi: np.ndarray, k: int, constant: bool) -> list[np.ndarray]:
    """[1,] cos(j phi), sin(j phi) for j = 1..k (fourierfit.harmonic_design's columns)."""
    return list(harmonic_design(phi, list(range(1, k + 1))).T[0 if constant else 1:])


def factor_columns(factor: str, ctx: Context, m: int) -> list[np.ndarray]:
    a = ctx.magnitude - MAG_REF
    if factor == "1":
        return [np.ones_like(ctx.phi)]
    if factor == "speed":
        return [ctx.speed]
    if factor == "speed2":
        return [ctx.speed ** 2]
    if factor == "direction":
        return [ctx.direction.astype(float)]
    if factor == "magnitude":
        return [a]
    if factor == "magnitude2":
        return [a * a]
    if factor == "revolution":
        return [ctx.revolution_harmonic(j, g) for j in range(1, m + 1) for g in (np.cos, np.sin)]
    if factor == "time":
        return _legendre_time(ctx)
    raise ValueError(f"unknown generic factor '{factor}'")


def generic_design(name: str, ctx: Context) -> np.ndarray:
    """Fine-phase harmonics 0..K (0 = the factor alone; not for the constant factor) times the factor."""
    factor, k, m = parse_generic(name)
    phase = phase_columns(ctx.phi, k, constant=factor != "1")
    return np.column_stack([p * f for f in factor_columns(factor, ctx, m) for p in phase])


GENERIC = dict(
    cause="structure the library's shapes do not describe (no physical name)",
    signature="fine-phase harmonics times a factor (speed, direction, magnitude, revolution, time), orders chosen "
              "on held-out data",
    correction="hardware",
    where="fringe_trim's tables when the factor is speed, direction, magnitude or revolution; the float engine "
          "for speed^2, magnitude^2 and time")


def known_term(name: str) -> bool:
    """Whether a stored closed-loop angle term names something this library can evaluate."""
    if name in LIBRARY or name == "interference":
        return True
    if name.startswith("generic:"):
        try:
            return parse_generic(name)[0] in GENERIC_FACTORS
        except ValueError:
            return False
    return False
