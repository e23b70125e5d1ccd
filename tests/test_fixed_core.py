"""The bit-exact core model: against the float engine within its own error budget; ROM images."""

import numpy as np
import pytest

from fringe.calib.calibrate import calibrate
from fringe.calib.evaluate import measurement_of
from fringe.dsp.simulate import SimulationConfig, seed_encoder, simulate
from fringe.engine.pipeline import run_float
from fringe.fixed.config import CoreConfig
from fringe.fixed.core import error_budget
from fringe.fixed.long_period import index_mapping
from fringe.fixed.period_count import PeriodCountParams, period_count
from fringe.hardware.rom import FORMATS, write_roms
from fringe.hardware.tables import build_tables, run_model


@pytest.fixture(scope="module")
def seed_setup(seed_recordings):
    train, val = (measurement_of(r) for r in seed_recordings)
    cal = calibrate(train, seed_recordings[0].encoder)
    cfg = CoreConfig.for_encoder(cal.encoder)
    return cal, cfg, build_tables(cal, cfg), val


def test_model_matches_float_within_its_budget(seed_setup):
    cal, cfg, tables, val = seed_setup
    q = cal.quad
    budget = error_budget(tables, cfg, (q.k_ss, q.k_sc, q.k_cc))["total_arcsec"]
    m = run_model(cal, cfg, val.sin, val.cos, val.coarse, tables=tables)
    f = run_float(cal, val.sin, val.cos, val.coarse)
    d = ((m.angle_deg - f.angle_deg + 180) % 360 - 180) * 3600
    assert np.max(np.abs(d)) <= budget
    np.testing.assert_array_equal(m.status, f.status)


def test_one_line_16_bit_configuration_runs_exactly_like_float():
    cfg_sim = SimulationConfig(lines_per_rev=1, adc_bits=16, coarse_bits=0, samples=20_000, sample_rate_hz=5000.0,
                               speed_mean_rev_s=3.0, speed_swing_rev_s=2.0)
    cfg_sim.sin_channel.sin_h = {1: 1.0, 3: -0.05}
    cfg_sim.cos_channel.cos_h = {1: 1.0, 3: 0.03}
    rec = simulate(cfg_sim, 3)
    cal = calibrate(measurement_of(rec), rec.encoder)
    cfg = CoreConfig.for_encoder(cal.encoder)
    tables = build_tables(cal, cfg)
    val = measurement_of(simulate(cfg_sim, 4))
    m = run_model(cal, cfg, val.sin, val.cos, None, tables=tables)
    f = run_float(cal, val.sin, val.cos, None)
    q = cal.quad
    d = ((m.angle_deg - f.angle_deg + 180) % 360 - 180) * 3600
    assert np.max(np.abs(d)) <= error_budget(tables, cfg, (q.k_ss, q.k_sc, q.k_cc))["total_arcsec"]


@pytest.mark.parametrize("lines,fine_w,addr,interp", [(256, 16, 8, 8), (100, 12, 6, 8), (1, 16, 10, 8), (3, 10, 11, 6)])
def test_long_period_index_is_exact(lines, fine_w, addr, interp):
    recip, shift = index_mapping(lines, fine_w, addr, interp)
    rev = lines << fine_w
    pos = np.arange(0, rev, max(1, rev // 100_000), dtype=np.int64)
    np.testing.assert_array_equal((pos * recip) >> shift, (pos << addr) // rev)


def test_period_count_incremental_and_overspeed():
    p = PeriodCountParams(fine_w=8, lines=3, coarse_w=0)
    phase = np.array([250, 10, 70, 130, 190, 250, 60])          # forward across wraps; last step 66 >= 64
    pos, over, err = period_count(phase, None, 0, p)
    np.testing.assert_array_equal(pos, [250, 266, 326, 386, 446, 506, (506 + 66) % 768])
    np.testing.assert_array_equal(over, [0, 0, 0, 0, 0, 0, 1])
    assert not err.any()


def test_period_count_coarse():
    p = PeriodCountParams(fine_w=10, lines=100, coarse_w=8)
    true = np.array([0, 1023, 1024, 50 * 1024 + 512, 99 * 1024 + 1000])
    span = 100 * 1024 / 256
    coarse = np.floor(true / span).astype(np.int64)
    for t, c in zip(true, coarse, strict=True):      # each from reset: the jumps are not motion
        pos, over, err = period_count(np.array([t % 1024]), np.array([c]), int(span / 2), p)
        assert pos[0] == t and not err[0]


def test_rom_images_are_deterministic_range_checked_and_labelled(seed_setup, tmp_path):
    cal, cfg, tables, _ = seed_setup
    a = write_roms(tables, cfg, str(tmp_path / "a"), FORMATS, "fringe rom cal --out a")
    write_roms(tables, cfg, str(tmp_path / "b"), FORMATS, "fringe rom cal --out a")
    for name in a:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    mem = (tmp_path / "a" / "wave_sin.mem").read_text().splitlines()
    assert mem[0].startswith("// fringe") and any("command: fringe rom" in ln for ln in mem[:4])
    words = [ln for ln in mem if not ln.startswith("//")]
    assert len(words) == 2 * 2 * (1 << cfg.wave_addr_w)
    mif = (tmp_path / "a" / "regs.mif").read_text()
    assert "DEPTH = 64;" in mif and "WIDTH = 32;" in mif   # 2 banks x 32 registers
    coe = (tmp_path / "a" / "long_period.coe").read_text()
    assert "memory_initialization_radix=16;" in coe and coe.rstrip().endswith(";")
    assert "package fringe_rom_pkg is" in (tmp_path / "a" / "fringe_rom_pkg.vhd").read_text()
    bad = tables.__class__(**{**tables.__dict__, "zero": cfg.rev + 5})
    with pytest.raises(ValueError, match="ZERO"):
        write_roms(bad, cfg, str(tmp_path / "c"), ("mem",), "x")
    assert not (tmp_path / "c").exists()


def test_seed_preset_config_defaults():
    cfg = CoreConfig.for_encoder(seed_encoder().encoder())
    assert (cfg.adc_w, cfg.lines, cfg.coarse_w, cfg.fine_w) == (12, 256, 9, 16) and cfg.pos_w == 24
