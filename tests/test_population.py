"""The randomised population of the closed loop (fringe.tools.population): a small fixed subset of it, and
the generator's table formats on random fitted values."""

import dataclasses

import numpy as np
import pytest

from fringe.dsp.effects import AMPLITUDE_ORDERS, FittedEffect
from fringe.dsp.simulate import max_speed_ok
from fringe.tools.population import CLASSES, STRENGTH_RANGE, draw_case, population_case, summarise


def test_draws_cover_the_ranges_and_respect_the_overspeed_limit():
    seed = 4711
    print("seed", seed)
    cases = [draw_case(s) for s in range(seed, seed + 300)]
    lines = [c["lines"] for c in cases]
    assert min(lines) == 1 and max(lines) > 2000 and any(n & (n - 1) for n in lines)
    assert {c["adc_bits"] for c in cases} == set(range(10, 17))
    assert any(c["coarse_bits"] for c in cases) and any(not c["coarse_bits"] for c in cases)
    assert {c["trajectory"] for c in cases} == {"steady", "sweeps", "reversals", "slow", "fast"}
    assert set().union(*[c["classes"] for c in cases]) == set(CLASSES)
    assert any(len(c["classes"]) == 3 for c in cases) and any(not c["classes"] for c in cases)
    for c in cases:
        assert max_speed_ok(c["config"]), c["seed"]
        assert c["expected"] <= set(c["classes"]) - {"common_gain"}
        for s in c["strengths"].values():
            assert STRENGTH_RANGE[0] <= s <= STRENGTH_RANGE[1]


# a fixed subset: clean (9003, 9011), drift (9009, 9012), reference lag with hysteresis that cannot show (9013),
# reference lag beside a common gain change at reversals, where a hysteresis of more terms explains more of the fit
# data and the validation data must choose the lag (9024), hysteresis and skew at reversals, where the direction of
# the longest speed window turns 16 samples after each reversal (9017), offsets over the revolution under a phase term
# of high order, which fringe_trim's map must hold at the phase the offsets leave, as the float engine reads it (9022)
@pytest.mark.parametrize("seed", [9003, 9009, 9011, 9013, 9017, 9022, 9024])
def test_population_subset(seed):
    c = population_case(seed)
    assert c["abort"] is None, c
    assert c["named_right"], c
    assert c["model_ratio"] <= 1.25 and c["float_ratio"] <= 1.25, c
    if not c["expected"]:
        assert c["rise"] <= 0.02, c
    if not c["classes"]:
        # without effects the plain floor is the declared model's own validation error (the loop's "before")
        assert c["plain_floor_arcsec"] == pytest.approx(c["before_arcsec"], abs=1e-4), c


def test_summary_counts_names_and_aborts():
    rows = [dict(seed=1, classes=["drift"], strengths={}, trajectory="steady", lines=8, adc_bits=12, expected=["drift"],
                 found=["drift", "tone"], named_right=False, float_ratio=1.1, model_ratio=1.3, rise=-0.2, abort=None,
                 seconds=1.0, model_ratio_settled=1.1, model_over_plain=1.4),
            dict(seed=2, classes=[], strengths={}, trajectory="fast", lines=8, adc_bits=12, expected=[], found=[],
                 named_right=True, float_ratio=1.0, model_ratio=1.0, rise=0.01, abort=None, seconds=1.0,
                 model_ratio_settled=1.0, model_over_plain=1.0),
            dict(seed=3, classes=[], expected=[], found=[], named_right=False, abort="ValueError: x", seconds=1.0)]
    s = summarise(rows)
    assert s["naming"]["precision"] == 0.5 and s["naming"]["recall"] == 1.0
    assert s["aborts"] == [{"seed": 3, "abort": "ValueError: x"}]
    assert s["correctable_model_within_1.25"] == 0.5 and s["clean_rise_within_2pct"] == 1.0
    assert s["model_over_floor"]["max"] == 1.3 and s["model_over_floor_settled"]["max"] == 1.1
    assert s["model_over_plain_floor"]["max"] == 1.4 and s["model_within_1.25_of_plain_floor"] == 0.5


def test_trim_format_follows_the_fitted_values():
    """Random closed-loop terms over nine decades on random encoders: fringe_trim's format is chosen so the
    tables build, and the tables then hold the float values to within their rounding."""
    from fringe.calib.calibrate import calibrate
    from fringe.calib.evaluate import measurement_of
    from fringe.dsp.simulate import SimulationConfig, simulate
    from fringe.hardware.closed_loop import build_trim_tables, grids_for
    from fringe.hardware.corefiles import core_config

    seed = 31
    print("seed", seed)
    rng = np.random.default_rng(seed)
    for _ in range(6):
        lines = int(rng.choice([1, 3, 64, 1000, 4096]))
        adc = int(rng.integers(10, 17))
        cfg = SimulationConfig(lines_per_rev=lines, adc_bits=adc, coarse_bits=0, samples=max(6000, 12 * lines),
                               speed_mean_rev_s=0.1371 * 10_000 / lines, speed_swing_rev_s=0.0)
        cal = calibrate(measurement_of(simulate(cfg, 1)), cfg.encoder())
        size = 10 ** rng.uniform(-3, 6)           # arcsec
        cal = dataclasses.replace(cal, angle_terms=[
            FittedEffect("hysteresis", rng.normal(0, size, 9)),
            FittedEffect("amplitude", amplitude_weights(rng.normal(0, size, 3))),
            FittedEffect("sampling_skew", np.concatenate([rng.normal(0, size * 1e-3, 2), rng.normal(0, size, 2)]))],
            adaptive=bool(rng.integers(2)))
        core = core_config(cal)
        tables = build_trim_tables(cal, core)
        grids = grids_for(cal, core)
        assert np.max(np.abs(tables.map / 2.0 ** core.trim_frac - grids.map)) <= 0.5 / 2 ** core.trim_frac + 1e-9


def amplitude_weights(order0_cos2_sin2):
    """The amplitude term's weights (orders 0..AMPLITUDE_ORDERS) with orders 0 and 2 (cos, sin) given, the rest 0."""
    w = np.zeros(1 + 2 * AMPLITUDE_ORDERS)
    w[[0, 3, 4]] = order0_cos2_sin2
    return w


def test_a_change_over_the_revolution_of_a_two_line_encoder_is_corrected_without_a_name():
    """9206 (held out): a 2-line encoder with a 1-bit coarse code, offsets over the revolution at 1.9x the floor.
    With so few periods they are not named rev_offset_gain, and until the general dictionary's revolution block was
    offered below 4 lines nothing corrected what the declared model left of them: 1.145x the floor, now 0.927x."""
    c = population_case(9206)
    assert c["abort"] is None and c["named_right"] and c["found"] == [], c
    assert any(g.startswith("generic:revolution:") for g in c["generic_terms"]), c
    assert c["model_ratio"] <= 1.0, c


# names that the population got wrong before: a large skew beside the magnitude changes it causes (9144: amplitude
# and sampling_skew, was amplitude and ref_lag), the drift tracker's phase-domain remedy (9124: drift and tone, was
# also amplitude), the canceller's (9248: interference alone, was also amplitude; a held-out seed, fixed after), a
# weak vibration at a changing speed whose angle line was taken for a sideband of a channel line that does not stand
# out (9211: ref_lag and tone, was ref_lag alone; held out), a canceller added after a skew, whose terms the
# re-calibration around the tone took in again (9230: drift, interference and sampling_skew, interference was
# rejected at 1606" against 530"; held out), a magnitude term on a 3-line encoder, whose amplitude change over the
# revolution is a waveform that differs between periods (9249: corrected and reported unexplained by name, was
# named amplitude; held out), a 2939" vibration beside interference on a 2-line encoder whose line went unnamed once
# a stronger line elsewhere was left after the interference's image came out (9246: interference and tone; held
# out), what the canceller leaves at its start-up on a 1-line encoder, at the interference's sidebands, named a tone
# (9229: interference alone; held out). 9246 and 9229 failed only once speed shapes of the general dictionary had to
# hold against the reference's motion (generic_candidates): before, a speed shape took the lines' power first
# 9248 named sampling_skew beside the interference for a while: a skew term of 3.4" (at a 6.5" noise floor) fitted to
# what the canceller leaves after reset lowered the validation error by a further 1 % (3.51x -> 3.35x the floor).
# Since the re-calibrations keep the structure choice (loop.refit.recalibrate) the skew term is not added, at 3.51x


@pytest.mark.parametrize("seed", [9124, 9144, 9211, 9229, 9230, 9246, 9248,
                                  9249])
def test_population_names(seed):
    c = population_case(seed)
    assert c["abort"] is None and c["named_right"], c
