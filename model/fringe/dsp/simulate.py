"""Physical encoder simulator: writes the measured-data CSV of the spec.

Every effect is a named parameter of `SimulationConfig` (units in the field comments), so a
test can switch one on and know the truth. The signal chain, per sample:

    true angle theta(t) (trajectory)                            [rev]
    disc angle   = theta + graduation_error(theta)              [rev]  (seed 000's long-period error)
    fine phase   = 2*pi * lines * disc angle                    [rad]
    channel k    = offset_k + gain_k * waveform_k(fine phase + phase_k) + noise
    ADC          = round(channel * 2^(adc_bits-1)), clipped to the ADC range
    coarse code  = floor((disc angle + misalignment/lines + jitter) * 2^coarse_bits) mod 2^coarse_bits
    ref_deg      = 360 * (ref_direction*theta + ref_zero + ref_error(theta)), 23-bit quantised
"""

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..encoder import ARCSEC_PER_REV, Encoder
from ..errors import FringeInputError
from . import seeds
from .position import shifted


@dataclass
class ChannelConfig:
    """One analog channel: offset + gain * sum_n (cos_h[n] cos(n psi) + sin_h[n] sin(n psi)).

    psi is the true fine phase plus `phase_rad`.
    """

    offset: float = 0.0                              # DC offset, fraction of ADC full scale
    gain: float = 0.8                                # scale of the normalised waveform, fraction of full scale
    phase_rad: float = 0.0                           # phase of this channel against the true fine phase
    sin_h: dict[int, float] = field(default_factory=dict)   # order -> amplitude of sin(n*psi)
    cos_h: dict[int, float] = field(default_factory=dict)   # order -> amplitude of cos(n*psi)

    def waveform(self, psi: np.ndarray) -> np.ndarray:
        y = np.zeros_like(psi)
        for n, a in self.sin_h.items():
            y += a * np.sin(n * psi)
        for n, a in self.cos_h.items():
            y += a * np.cos(n * psi)
        return y


@dataclass
class SimulationConfig:
    lines_per_rev: int = 256
    adc_bits: int = 12
    coarse_bits: int = 9                              # 0 = no coarse code column
    sample_rate_hz: float = 10_000.0
    samples: int = 200_000
    # graduation (long-period) error of the disc: Fourier series over the revolution, arcsec.
    # {order: (cos amplitude, sin amplitude)}; "seed000" selects seed 000's measured curve.
    graduation_error: dict[int, tuple[float, float]] | str = field(default_factory=dict)
    sin_channel: ChannelConfig = field(default_factory=lambda: ChannelConfig(sin_h={1: 1.0}))
    cos_channel: ChannelConfig = field(default_factory=lambda: ChannelConfig(cos_h={1: 1.0}))
    noise_rms: float = 1.3e-3                         # additive Gaussian noise per channel, fraction of FS
    coarse_misalignment_periods: float = 0.1         # coarse code edges lag the fine phase zero by this
    coarse_jitter_periods: float = 0.02              # RMS edge jitter of the coarse code, periods
    ref_zero_deg: float = 123.456                     # reference zero against the encoder's
    ref_direction: int = 1                            # +1 same direction as the encoder, -1 opposite
    ref_error_arcsec: dict[int, tuple[float, float]] = field(default_factory=lambda: {1: (0.3, 0.2)})
    ref_bits: int = 23                                # reference resolution, bits per revolution
    # trajectory: speed = mean + sum of two sinusoids; reversals when the swing exceeds the mean
    speed_mean_rev_s: float = 0.6
    speed_swing_rev_s: float = 1.2
    start_rev: float = 0.0
    # ---- effects outside the seeds' model (all off by default); the closed loop must find them
    # offsets and gains that vary over the revolution (disc or magnet eccentricity, air gap):
    # relative gain 1 + sum_m (a cos m psi + b sin m psi) on both channels, psi the mechanical angle,
    # and per-channel offset modulations (fraction of FS), {order: (cos amplitude, sin amplitude)}
    rev_gain_mod: dict[int, tuple[float, float]] = field(default_factory=dict)
    rev_offset_mod_sin: dict[int, tuple[float, float]] = field(default_factory=dict)
    rev_offset_mod_cos: dict[int, tuple[float, float]] = field(default_factory=dict)
    sampling_skew_s: float = 0.0          # the cos channel is sampled this much later than the sin channel
    drift_offset_rms: float = 0.0         # slow random drift of each channel's offset (fraction of FS, RMS)
    drift_gain_rms: float = 0.0           # slow random drift of each channel's gain (relative, RMS)
    drift_timescale_s: float = 5.0        # typical period of the drift
    hysteresis_arcsec: float = 0.0        # the readhead lags by half of this in the direction of motion
    ref_lag_s: float = 0.0                # the reference is sampled this much earlier than the ADC
    vibration_arcsec: float = 0.0         # amplitude of a vibration between encoder and reference
    vibration_hz: float = 0.0
    # ---- amplitude that changes (field strength, air gap, temperature): both channels together
    common_gain_rms: float = 0.0          # slow random wander of the common gain (relative, RMS), drift timescale
    # harmonics 2, 3, ... of both waveforms scale with (common gain)^this (rev_gain_mod and common_gain_rms):
    # a sensor whose distortion grows with the field (0: the waveform's shape does not change)
    harmonics_gain_exponent: float = 0.0
    # additive interference on both channels (a switching supply, motor PWM): a sinusoid of this amplitude
    # (fraction of FS) and frequency, with a random phase per channel and recording
    interference_fs: float = 0.0
    interference_hz: float = 0.0
    # a waveform that changes with the amplitude (the air gap): a 2nd harmonic on the sin channel in
    # proportion to the relative gain change over the revolution (rev_gain_mod), this much per unit of it
    harmonic2_per_gain: float = 0.0

    def encoder(self) -> Encoder:
        full_scale = None
        return Encoder(self.lines_per_rev, self.adc_bits, self.coarse_bits, full_scale).validate("simulation")

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def seed_encoder() -> SimulationConfig:
    """The seeds' 16-bit encoder: 256 lines, seed 001 Table 1 waveforms, seed 000 long-period error.

    Noise: 12-bit ADC, gain 0.9 of full scale (the normalised waveforms peak near 1.0, so the
    peaks sit at about 0.9 FS), noise 1.3e-3 FS RMS (2.7 counts) per channel, which makes one
    sample's angle noise about 1.3" RMS (the seed's 1.3"-ish scatter at 20" resolution); ADC
    quantisation adds about 0.1".
    """
    sin_h = {int(n): float(c) for n, c in zip(seeds.SEED001_ORDERS, seeds.SEED001_SIN_COEFFS, strict=True)}
    cos_h = {int(n): float(c) for n, c in zip(seeds.SEED001_ORDERS, seeds.SEED001_COS_COEFFS, strict=True)}
    sin_h[2] = seeds.SEED001_F2["sin"]
    cos_h[2] = seeds.SEED001_F2["cos"]
    gain = 0.9
    return SimulationConfig(
        lines_per_rev=seeds.SEED001_LINES, adc_bits=12, coarse_bits=9,
        graduation_error="seed000",
        # seed 001 eq. 15: u_s = sin(theta - alpha), alpha = -0.00013 rad
        sin_channel=ChannelConfig(offset=gain * seeds.SEED001_F0["sin"], gain=gain,
                                  phase_rad=-seeds.SEED001_PHASE_ERROR_RAD, sin_h=sin_h),
        cos_channel=ChannelConfig(offset=gain * seeds.SEED001_F0["cos"], gain=gain, cos_h=cos_h),
        noise_rms=1.3e-3,
    )


PRESETS = {"seed-encoder": seed_encoder}


def preset(name: str) -> SimulationConfig:
    if name not in PRESETS:
        raise FringeInputError(f"unknown preset '{name}' (known: {', '.join(sorted(PRESETS))})", "--preset")
    return PRESETS[name]()


def fourier_arcsec(terms: dict[int, tuple[float, float]], x_rad: np.ndarray) -> np.ndarray:
    y = np.zeros_like(x_rad)
    for n, (a, b) in terms.items():
        y += a * np.cos(n * x_rad) + b * np.sin(n * x_rad)
    return y


def graduation_error_arcsec(cfg: SimulationConfig, theta_rev: np.ndarray) -> np.ndarray:
    x = 2 * np.pi * theta_rev
    if cfg.graduation_error == "seed000":
        return seeds.seed000_error_arcsec(x)
    return fourier_arcsec(cfg.graduation_error, x)


@dataclass
class Recording:
    """A simulated recording and the truth behind it."""

    columns: dict[str, np.ndarray]     # what goes into the CSV
    theta_rev: np.ndarray              # true mechanical angle, unwrapped, rev
    fine_phase_rad: np.ndarray         # true electrical phase (after graduation error)
    clean_sin: np.ndarray              # noise-free channel values, ADC counts (not quantised)
    clean_cos: np.ndarray
    encoder: Encoder


def trajectory(cfg: SimulationConfig, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Smooth speed changes and reversals: two sinusoidal speed swings on a mean speed."""
    t = np.arange(cfg.samples) / cfg.sample_rate_hz
    duration = max(t[-1], 1e-9)
    periods = duration / rng.uniform([2.5, 6.0], [4.0, 11.0])
    phases = rng.uniform(0, 2 * np.pi, 2)
    split = rng.uniform(0.55, 0.75)
    speed = (cfg.speed_mean_rev_s
             + cfg.speed_swing_rev_s * split * np.sin(2 * np.pi * t / periods[0] + phases[0])
             + cfg.speed_swing_rev_s * (1 - split) * np.sin(2 * np.pi * t / periods[1] + phases[1]))
    theta = cfg.start_rev + rng.uniform(0, 1) + np.concatenate([[0.0], np.cumsum(speed[:-1])]) / cfg.sample_rate_hz
    return t, theta


def simulate(cfg: SimulationConfig, seed: int = 1) -> Recording:
    enc = cfg.encoder()
    if cfg.samples < 2:
        raise FringeInputError(f"needs at least 2 samples, got {cfg.samples}", "--samples")
    rng = np.random.default_rng(seed)
    effects_rng = np.random.default_rng([seed, 1])    # effects never disturb the noise draws
    tone_rng = np.random.default_rng([seed, 2])       # nor the drift draws
    t, theta = trajectory(cfg, rng)
    disc = theta + graduation_error_arcsec(cfg, theta) / ARCSEC_PER_REV
    disc += (cfg.vibration_arcsec * np.sin(2 * np.pi * cfg.vibration_hz * t)
             - 0.5 * cfg.hysteresis_arcsec * _direction(theta)) / ARCSEC_PER_REV
    phase = 2 * np.pi * cfg.lines_per_rev * disc
    psi = 2 * np.pi * theta
    gain_mod = 1.0 + fourier_arcsec(cfg.rev_gain_mod, psi)
    half = enc.adc_half_range

    common = gain_mod * (1.0 + _drift(t, cfg.common_gain_rms, cfg, effects_rng))

    def channel(ch: ChannelConfig, ph: np.ndarray, offset_mod: dict):
        offset = ch.offset + fourier_arcsec(offset_mod, psi) + _drift(t, cfg.drift_offset_rms, cfg, effects_rng)
        gain = ch.gain * common * (1.0 + _drift(t, cfg.drift_gain_rms, cfg, effects_rng))
        wave = _shape(ch, ph + ch.phase_rad, common, cfg.harmonics_gain_exponent)
        if cfg.harmonic2_per_gain and ch is cfg.sin_channel:
            wave = wave + cfg.harmonic2_per_gain * (gain_mod - 1.0) * np.sin(2 * (ph + ch.phase_rad))
        clean = (offset + gain * wave) * half
        if cfg.interference_fs:
            clean = clean + cfg.interference_fs * half * np.cos(2 * np.pi * cfg.interference_hz * t
                                                               + tone_rng.uniform(0, 2 * np.pi))
        noisy = clean + rng.normal(0.0, cfg.noise_rms * half, clean.shape)
        return clean, np.clip(np.round(noisy), -half, half - 1).astype(np.int64)

    clean_s, adc_s = channel(cfg.sin_channel, phase, cfg.rev_offset_mod_sin)
    phase_c = shifted(t, phase, cfg.sampling_skew_s) if cfg.sampling_skew_s else phase
    clean_c, adc_c = channel(cfg.cos_channel, phase_c, cfg.rev_offset_mod_cos)
    cols = {"t_s": t, "sin": adc_s, "cos": adc_c}
    if cfg.coarse_bits:
        cpos = (disc + (cfg.coarse_misalignment_periods
                        + rng.normal(0.0, cfg.coarse_jitter_periods, disc.shape)) / cfg.lines_per_rev)
        cols["coarse"] = np.floor(cpos * (1 << cfg.coarse_bits)).astype(np.int64) % (1 << cfg.coarse_bits)
    ref_theta = shifted(t, theta, -cfg.ref_lag_s) if cfg.ref_lag_s else theta
    ref_rev = (cfg.ref_direction * ref_theta + cfg.ref_zero_deg / 360.0
               + fourier_arcsec(cfg.ref_error_arcsec, 2 * np.pi * ref_theta) / ARCSEC_PER_REV)
    counts = 1 << cfg.ref_bits
    ref_rev = np.floor(np.mod(ref_rev, 1.0) * counts) / counts
    cols["ref_deg"] = ref_rev * 360.0
    return Recording(cols, theta, phase, clean_s, clean_c, enc)


def _shape(ch: ChannelConfig, psi: np.ndarray, common_gain: np.ndarray, exponent: float) -> np.ndarray:
    """The channel's normalised waveform, its harmonics above the fundamental scaled by common_gain^exponent."""
    if not exponent:
        return ch.waveform(psi)
    fundamental = ch.sin_h.get(1, 0.0) * np.sin(psi) + ch.cos_h.get(1, 0.0) * np.cos(psi)
    return fundamental + (ch.waveform(psi) - fundamental) * np.power(common_gain, exponent)


def _direction(theta: np.ndarray) -> np.ndarray:
    """+1 / -1 by the direction of motion; a standstill keeps the last direction."""
    d = np.sign(np.gradient(theta))
    idx = np.where(d != 0, np.arange(len(d)), 0)
    np.maximum.accumulate(idx, out=idx)
    d = d[idx]
    d[d == 0] = 1
    return d


def _drift(t: np.ndarray, rms: float, cfg: SimulationConfig, rng: np.random.Generator) -> np.ndarray:
    """A smooth random wander of RMS `rms`: three sinusoids near the drift timescale, new each recording."""
    if not rms:
        return np.zeros_like(t)
    periods = cfg.drift_timescale_s * rng.uniform(0.5, 2.0, 3)
    phases = rng.uniform(0, 2 * np.pi, 3)
    weights = rng.normal(0, 1, 3)
    y = sum(w * np.sin(2 * np.pi * t / p + ph) for w, p, ph in zip(weights, periods, phases, strict=True))
    return rms * y / np.sqrt(np.mean(y * y))


def csv_formats() -> dict:
    return {"t_s": "%.7f", "sin": "%d", "cos": "%d", "coarse": "%d", "ref_deg": "%.9f"}


def describe(cfg: SimulationConfig, seed: int) -> tuple[str, ...]:
    return (f"fringe simulate: seed {seed}, {cfg.samples} samples at {cfg.sample_rate_hz:g} Hz",
            f"lines_per_rev: {cfg.lines_per_rev}", f"adc_bits: {cfg.adc_bits}",
            f"coarse_bits: {cfg.coarse_bits}")


def max_speed_ok(cfg: SimulationConfig) -> bool:
    """A quarter period per sample is the overspeed limit of the core."""
    vmax = abs(cfg.speed_mean_rev_s) + abs(cfg.speed_swing_rev_s)
    return vmax / cfg.sample_rate_hz * cfg.lines_per_rev < 0.25


__all__ = ["ChannelConfig", "SimulationConfig", "Recording", "simulate", "preset", "PRESETS",
           "seed_encoder", "graduation_error_arcsec"]
