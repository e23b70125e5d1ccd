"""``fringe.hardware.rtlsim.run_rtl`` (the RTL engines of ``fringe correct --engine verilog|vhdl``) on a real
recording: every output word of fringe_top equals the bit-exact model's.

Data: an RLS RM44 recording from ``../shared/data/rm44_hall_vs_tonic`` (skipped when absent),
calibrated on its even samples; all samples (even and odd) go through the RTL and ``run_core``.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parent.parent
RM44_DIR = REPO.parent / "shared" / "data" / "rm44_hall_vs_tonic"
RM44_FILE = RM44_DIR / "2017_10_02_xs_150u.csv"


@pytest.fixture(scope="module")
def rm44():
    if not RM44_FILE.is_file():
        pytest.skip(f"{RM44_FILE} not found (shared recordings absent)")
    from fringe.calib.calibrate import calibrate
    from fringe.fixed.config import CoreConfig
    from fringe.fixed.core import run_core, to_adc_codes
    from fringe.hardware.tables import build_tables
    from fringe.io.datasets import RM44_ENCODER, halves, read_rm44

    meas = read_rm44(str(RM44_FILE))
    cal = calibrate(halves(meas)[0], RM44_ENCODER)
    cfg = CoreConfig.for_encoder(RM44_ENCODER)
    tables = build_tables(cal, cfg)
    sin = to_adc_codes(meas.sin, cfg.adc_w, "sin")
    cos = to_adc_codes(meas.cos, cfg.adc_w, "cos")
    return cal, cfg, tables, meas, run_core(tables, cfg, sin, cos, None)


def test_run_rtl_matches_model(sim, rm44):
    from fringe.fixed.core import core_latency
    from fringe.hardware.rtlsim import run_rtl

    cal, cfg, tables, meas, expected = rm44
    t0 = time.monotonic()
    got = run_rtl(cal, cfg, meas.sin, meas.cos, None, sim=sim)
    print(f"run_rtl {sim}: {len(meas)} samples in {time.monotonic() - t0:.1f} s")
    assert len(got.pos) == len(meas)
    assert got.latency == core_latency(cfg)
    bad = np.flatnonzero((got.pos != expected.pos) | (got.status != expected.status))
    assert bad.size == 0, (f"{bad.size} of {len(meas)} words differ; first at {bad[0]}: RTL pos={got.pos[bad[0]]} "
                           f"status={got.status[bad[0]]:#04x}, model pos={expected.pos[bad[0]]} "
                           f"status={expected.status[bad[0]]:#04x}")


def test_run_rtl_result_is_the_model_angle(rm44):
    """The engine wrapper gives the model's angle and status (Verilator only: one run is enough)."""
    from cocotb_runner import available_simulators
    from fringe.hardware.rtlsim import run_rtl_result
    from fringe.hardware.tables import run_model

    if available_simulators()["verilator"]:
        pytest.skip(available_simulators()["verilator"])
    cal, cfg, tables, meas, _ = rm44
    r = run_rtl_result(cal, cfg, meas.sin, meas.cos, None, sim="verilog")
    m = run_model(cal, cfg, meas.sin, meas.cos, None, tables=tables)
    assert np.array_equal(r.angle_deg, m.angle_deg) and np.array_equal(r.status, m.status)


def test_cli_correct_verilog_rows_equal_model(tmp_path, capsys):
    """`fringe correct --engine verilog` writes the same rows as `--engine model` (a simulated
    seed-encoder file through the whole command line)."""
    from fringe.cli.cli import main

    d = tmp_path
    assert main(["simulate", "--preset", "seed-encoder", "--out", str(d / "a.csv"), "--encoder-out",
                 str(d / "e.json"), "--samples", "30000", "--seed", "5"]) == 0
    assert main(["simulate", "--preset", "seed-encoder", "--out", str(d / "b.csv"), "--samples", "3000",
                 "--seed", "6"]) == 0
    assert main(["calibrate", str(d / "a.csv"), "--encoder", str(d / "e.json"), "--out", str(d / "cal")]) == 0
    for engine in ("model", "verilog"):
        assert main(["correct", str(d / "b.csv"), "--cal", str(d / "cal"), "--out", str(d / f"{engine}.csv"),
                     "--engine", engine]) == 0
    rows = {e: [ln for ln in (d / f"{e}.csv").read_text().splitlines() if not ln.startswith("#")]
            for e in ("model", "verilog")}
    assert len(rows["model"]) == 3001 and rows["model"] == rows["verilog"]


def _write_recording(cfg, seed: int, path) -> None:
    from fringe.dsp import simulate
    from fringe.io.dataio import write_csv

    rec = simulate.simulate(cfg, seed=seed)
    cols = {k: rec.columns[k] for k in ("t_s", "sin", "cos", "coarse", "ref_deg") if k in rec.columns}
    write_csv(str(path), cols, simulate.describe(cfg, seed), simulate.csv_formats())


# the loop's calibration is the same for both simulators: each case's tests share a worker (make test runs xdist with
# --dist loadgroup) and the calibration is made once there
LOOP_CASES = ["eccentricity+hysteresis", "ref_lag+skew", "drift"]
_LOOP_RUNS: dict[str, Path] = {}


def _loop_run(case: str, tmp_path_factory) -> Path:
    """`fringe loop` on the case's recording (its added effects carried by fringe_trim or the drift tracker), and a
    second recording to correct: the folder holding both."""
    import json

    from fringe.cli.cli import main
    from fringe.loop.scenarios import scenario

    if case not in _LOOP_RUNS:
        cfg, _ = scenario(case, samples=60_000)
        d = tmp_path_factory.mktemp("loop")
        _write_recording(cfg, 1, d / "a.csv")
        _write_recording(dataclasses.replace(cfg, samples=4000), 2, d / "b.csv")
        (d / "e.json").write_text(json.dumps(cfg.encoder().to_dict()))
        assert main(["loop", str(d / "a.csv"), "--encoder", str(d / "e.json"), "--out", str(d / "loop")]) == 0
        added = {e["name"] for e in json.loads((d / "loop" / "report.json").read_text())["effects_added"]}
        assert added & {"rev_offset_gain", "hysteresis", "sampling_skew", "drift"}, added
        core = json.loads((d / "loop" / "cal" / "core.json").read_text())["config"]
        assert core["trim"] == 1 or core["drift"] == 1, core
        assert main(["correct", str(d / "b.csv"), "--cal", str(d / "loop" / "cal"), "--out", str(d / "model.csv"),
                     "--engine", "model"]) == 0
        _LOOP_RUNS[case] = d
    return _LOOP_RUNS[case]


@pytest.mark.parametrize("case", [pytest.param(c, marks=pytest.mark.xdist_group(f"loop-rtl-{c}")) for c in LOOP_CASES])
def test_cli_loop_calibration_rtl_rows_equal_model(sim, tmp_path, tmp_path_factory, case):
    """A calibration from `fringe loop` (its added effects carried by fringe_trim and the drift tracker) through
    `fringe correct`: the RTL engine writes the same rows as the bit-exact model."""
    from fringe.cli.cli import main

    d = _loop_run(case, tmp_path_factory)
    engine = {"verilator": "verilog", "ghdl": "vhdl"}[sim]
    assert main(["correct", str(d / "b.csv"), "--cal", str(d / "loop" / "cal"), "--out", str(tmp_path / "rtl.csv"),
                 "--engine", engine]) == 0
    rows = {e: [ln for ln in p.read_text().splitlines() if not ln.startswith("#")]
            for e, p in (("model", d / "model.csv"), (engine, tmp_path / "rtl.csv"))}
    assert len(rows["model"]) == 4001 and rows["model"] == rows[engine]


def test_run_rtl_with_canceller_matches_model(sim):
    """A calibration that cancels interference online (CANCEL = 1, the core's config from it) on a recording
    with an additive tone: every word of the RTL engine (rtlsim, CANCEL_LUT_INIT, CANCEL_FREQ) equals
    ``run_core``'s, and the canceller's words are not those of the same core without it."""
    from fringe.calib.calibrate import calibrate
    from fringe.calib.evaluate import measurement_of
    from fringe.dsp.simulate import SimulationConfig, simulate
    from fringe.fixed.core import run_core, to_adc_codes
    from fringe.hardware.corefiles import core_config
    from fringe.hardware.rtlsim import run_rtl
    from fringe.hardware.tables import build_tables

    base = SimulationConfig(samples=6000)
    noisy = dataclasses.replace(base, interference_fs=0.01, interference_hz=0.137 * base.sample_rate_hz)
    cal = calibrate(measurement_of(simulate(dataclasses.replace(base, samples=20_000), 1)), base.encoder())
    cal = dataclasses.replace(cal, canceller={"tone_hz": noisy.interference_hz, "sample_rate_hz": base.sample_rate_hz,
                                              "cancel_block_log2": 4, "cancel_mu_log2": 8})
    cfg = core_config(cal)
    assert cfg.cancel == 1
    m = measurement_of(simulate(noisy, 2))
    tables = build_tables(cal, cfg)
    sin, cos = to_adc_codes(m.sin, cfg.adc_w, "sin"), to_adc_codes(m.cos, cfg.adc_w, "cos")
    expected = run_core(tables, cfg, sin, cos, m.coarse)
    without = run_core(tables, dataclasses.replace(cfg, cancel=0), sin, cos, m.coarse)
    assert (expected.pos != without.pos).mean() > 0.5
    got = run_rtl(cal, cfg, m.sin, m.cos, m.coarse, sim=sim, tables=tables)
    bad = np.flatnonzero((got.pos != expected.pos) | (got.status != expected.status))
    assert bad.size == 0, (f"{bad.size} of {len(m.sin)} words differ; first at {bad[0]}: RTL pos={got.pos[bad[0]]} "
                           f"status={got.status[bad[0]]:#04x}, model pos={expected.pos[bad[0]]} "
                           f"status={expected.status[bad[0]]:#04x}")


def test_run_rtl_with_drift_hold_matches_model(sim):
    """The drift tracker with its hold (DRIFT = 1, DRIFT_HOLD = 1, a short block): the RTL engine's harness waits
    for s_axis_tready at every block boundary and every word equals ``run_core``'s; the recording starts
    with an offset / gain error the tracker removes (its words are not those of the core without it)."""
    from fringe.calib.calibrate import calibrate
    from fringe.calib.evaluate import measurement_of
    from fringe.dsp.simulate import ChannelConfig, SimulationConfig, simulate
    from fringe.fixed.core import run_core, to_adc_codes
    from fringe.hardware.corefiles import core_config
    from fringe.hardware.rtlsim import drift_hold_clocks, run_rtl
    from fringe.hardware.tables import build_tables

    base = SimulationConfig(samples=3000)
    cal0 = calibrate(measurement_of(simulate(dataclasses.replace(base, samples=20_000), 1)), base.encoder())
    cal = dataclasses.replace(cal0, adaptive=True, tracker={"drift_block_log2": 5, "drift_mu_log2": 2})
    cfg = core_config(cal)
    assert cfg.drift == 1 and cfg.drift_hold == 1 and drift_hold_clocks(cfg, 3000) > 0
    s = base.sin_channel
    off = dataclasses.replace(base, sin_channel=ChannelConfig(offset=s.offset + 0.02, gain=s.gain * 1.03,
                                                              phase_rad=s.phase_rad, sin_h=dict(s.sin_h),
                                                              cos_h=dict(s.cos_h)))
    m = measurement_of(simulate(off, 2))
    tables = build_tables(cal, cfg)
    sin, cos = to_adc_codes(m.sin, cfg.adc_w, "sin"), to_adc_codes(m.cos, cfg.adc_w, "cos")
    expected = run_core(tables, cfg, sin, cos, m.coarse)
    cfg0 = dataclasses.replace(cfg, drift=0)
    without = run_core(build_tables(cal0, cfg0), cfg0, sin, cos, m.coarse)
    assert (expected.pos != without.pos).mean() > 0.3
    got = run_rtl(cal, cfg, m.sin, m.cos, m.coarse, sim=sim, tables=tables)
    bad = np.flatnonzero((got.pos != expected.pos) | (got.status != expected.status))
    assert bad.size == 0, f"{bad.size} of {len(m.sin)} words differ; first at {bad[0]}"
