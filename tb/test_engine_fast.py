"""The fast Verilator engine (C++ harness, sim/verilator_engine) against the bit-exact model on a
randomised population of encoders: every output word equal, the latency as documented.

The population (seed printed) draws ADC width, lines per revolution and the coarse code; one
member is forced to a 24-bit ADC with a 9-bit coarse code: s_axis_tdata is then 64 bits, the widest
word the parameter rules allow (COARSE_W <= FINE_W - 2 and POS_W <= 31 keep the coarse lane at 16
bits). Each member is one Verilator build (~30 s).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

SEED = 20261201
MEMBERS = 2


def population():
    rng = np.random.default_rng(SEED)
    out = []
    for _ in range(MEMBERS):
        adc = int(rng.integers(8, 24, endpoint=True))
        lines = int(rng.integers(1, 512, endpoint=True))
        coarse = int(math.ceil(math.log2(lines))) if lines > 1 and rng.random() < 0.5 else 0
        out.append((adc, lines, coarse, 0))
    out.append((24, int(rng.integers(257, 512)), 9, 0))   # s_axis_tdata 2*24 + 16 = 64 bits
    out.append((12, 256, 9, 1))   # the compact core: the harness waits for s_axis_tready
    return out


@pytest.mark.parametrize("adc_bits,lines,coarse_bits,compact", population())
def test_fast_engine_words_equal_model(adc_bits, lines, coarse_bits, compact):
    from cocotb_runner import available_simulators
    from fringe.calib.calibrate import calibrate
    from fringe.calib.evaluate import measurement_of
    from fringe.dsp.simulate import seed_encoder, simulate
    from fringe.fixed.config import CoreConfig
    from fringe.fixed.core import core_latency, run_core, to_adc_codes
    from fringe.hardware.rtlsim import run_rtl, top_widths
    from fringe.hardware.tables import build_tables

    if available_simulators()["verilator"]:
        pytest.skip(available_simulators()["verilator"])
    print(f"population seed {SEED}: adc_bits={adc_bits} lines={lines} coarse_bits={coarse_bits} COMPACT={compact}")
    sc = dataclasses.replace(seed_encoder(), lines_per_rev=lines, adc_bits=adc_bits, coarse_bits=coarse_bits,
                             samples=20000)
    rec = simulate(sc, seed=3)
    meas = measurement_of(rec)
    cal = calibrate(meas, rec.encoder)
    cfg = CoreConfig.for_encoder(cal.encoder, compact=compact)
    t = build_tables(cal, cfg)
    sin, cos = to_adc_codes(meas.sin, cfg.adc_w, "sin"), to_adc_codes(meas.cos, cfg.adc_w, "cos")
    expected = run_core(t, cfg, sin, cos, meas.coarse if cfg.coarse_w else None)
    got = run_rtl(cal, cfg, meas.sin, meas.cos, meas.coarse if cfg.coarse_w else None, tables=t)
    print(f"s_axis_tdata {top_widths(cfg)['S_DATA_W']} bits")
    assert got.latency == core_latency(cfg)
    bad = np.flatnonzero((got.pos != expected.pos) | (got.status != expected.status))
    assert bad.size == 0, f"{bad.size} of {len(sin)} words differ; first at {bad[0]}"
