"""Named recordings with an effect the declared model lacks: for the loop's tests and benchmarks.

Each scenario is the seed encoder plus the effects (`SimulationConfig` fields) and the names the
closed loop should give them (`effects.LIBRARY`, or "tone").
"""

import dataclasses

from .simulate import SimulationConfig, seed_encoder

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


def scenario(name: str, samples: int = 100_000) -> tuple[SimulationConfig, set]:
    effects, expected = SCENARIOS[name]
    return dataclasses.replace(seed_encoder(), samples=samples, **effects), expected
