"""The second simulator (fringe.tools.crosssim): its draws cover their ranges and its recordings are what the
encoder description says (the acceptance flow it drives is run by hand: python -m fringe.tools.crosssim)."""

import numpy as np

from fringe.tools import crosssim


def test_draws_cover_the_ranges():
    d = [crosssim.draw(s) for s in range(300)]
    assert {x["lines"] for x in d} == set(crosssim.LINES)
    assert {e for x in d for e in x["effects"]} == set(crosssim.EFFECTS) - {"none"}
    assert any(not x["effects"] for x in d) and any(len(x["effects"]) == 2 for x in d)
    assert all(10 <= x["adc_bits"] <= 16 for x in d) and {x["trajectory"] for x in d} == {"steady", "sweep", "reverse"}
    # below the overspeed limit (a quarter period per sample) with room for the sweeps' 1.5x
    assert all(abs(x["speed"]) * x["lines"] / x["fs"] <= 1 / 12 + 1e-12 for x in d)


def test_a_recording_is_what_its_encoder_says():
    d = next(x for x in map(crosssim.draw, range(100)) if x["coarse_bits"] and x["effects"])
    cols = crosssim.record(d, d["effects"], 1)
    half = 2 ** (d["adc_bits"] - 1)
    assert len(cols["sin"]) == crosssim.SAMPLES and cols["sin"].dtype.kind == "i"
    assert -half <= cols["sin"].min() and cols["cos"].max() <= half - 1
    assert 0 <= cols["coarse"].min() and cols["coarse"].max() < 2 ** d["coarse_bits"]
    assert np.all((0 <= cols["ref_deg"]) & (cols["ref_deg"] < 360))
