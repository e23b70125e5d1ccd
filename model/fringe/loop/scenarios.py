"""Named recordings with an effect the declared model lacks: for the loop's tests and benchmarks.

Each scenario is the seed encoder plus the effects (`SimulationConfig` fields) and the names the
closed loop should give them (`effects.LIBRARY`, or "tone").
"""

import dataclasses

from ..dsp.simulate import SimulationConfig, seed_encoder

SCENARIOS = {
    "none": ({}, set()),
    "rev_offset_gain": (dict(rev_offset_mod_sin={1: (0.004, 0.0)}, rev_gain_mod={1: (0.003, 0.002)}),
                        {"rev_offset_gain"}),
    "sampling_skew": (dict(sampling_skew_s=2e-6), {"sampling_skew"}),
    "drift": (dict(drift_offset_rms=0.003, drift_gain_rms=0.003), {"drift"}),
    "hysteresis": (dict(hysteresis_arcsec=3.0), {"hysteresis"}),
    "ref_lag": (dict(ref_lag_s=2e-5), {"ref_lag"}),
    "tone": (dict(vibration_arcsec=2.0, vibration_hz=37.0), {"tone"}),
    "eccentricity+hysteresis": (dict(rev_offset_mod_sin={1: (0.004, 0.0)}, rev_gain_mod={1: (0.003, 0.002)},
                                     hysteresis_arcsec=3.0), {"rev_offset_gain", "hysteresis"}),
    "ref_lag+skew": (dict(ref_lag_s=2e-5, sampling_skew_s=2e-6), {"ref_lag", "sampling_skew"}),
}


def _waveform_asymmetry() -> dict:
    """Even and cosine-phase harmonics on both channels: outside the seed 001 model (odd sine
    harmonics only) but inside fringe's declared model (the full Fourier waveform, two-branch
    inverse), so the loop must add nothing and still reach the floor."""
    base = seed_encoder()
    s, c = base.sin_channel, base.cos_channel
    return dict(sin_channel=dataclasses.replace(s, sin_h={**s.sin_h, 2: 0.02}, cos_h={**s.cos_h, 3: 0.012}),
                cos_channel=dataclasses.replace(c, cos_h={**c.cos_h, 2: -0.015}, sin_h={**c.sin_h, 4: 0.006}))


SCENARIOS["waveform_asymmetry"] = (_waveform_asymmetry, set())


def scenario(name: str, samples: int = 100_000) -> tuple[SimulationConfig, set]:
    effects, expected = SCENARIOS[name]
    if callable(effects):
        effects = effects()
    return dataclasses.replace(seed_encoder(), samples=samples, **effects), expected
